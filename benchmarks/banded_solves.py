"""Time ACMP's banded Cholesky factorisation and solve against the generic loops and LAPACK.

    python benchmarks/banded_solves.py [--repeat 200]   # after pip install -e . (or PYTHONPATH=src)

Per band width (4 super-diagonals: the demodulation's 2N unknowns; 2: the smoothing's N), on a
random symmetric positive definite band matrix of the size one ACMP iteration solves on the
bundled example's windowed records (N = 12 000 samples at the working rate): the library's
``cholesky_banded`` (the band width a constant of the compiled loop, its inner loops unrolled)
against the same loop with the band width a run-time number (the code before, compiled here),
then with ``solve_factored`` (the triangular solves, unchanged) beside
``scipy.linalg.solveh_banded`` (LAPACK ``pbsv``). Prints a Markdown table of the median wall
time per call (a row's functions called in turn, so the host's drift touches each alike) and
whether the library's result equals the generic loops' to the last bit. A last row times
ACMP's whole mode update (``demodulate_into``: the band assembled, factored and solved in one
pass) against the same three steps one after another with the generic loops (the code
before). One thread (BLAS limited before NumPy is imported).
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402

import numba  # noqa: E402
import numpy as np  # noqa: E402
from scipy.linalg import solveh_banded  # noqa: E402

from freeplayid.signal.banded import (  # noqa: E402
    cholesky_banded,
    demodulate_into,
    second_difference_gram,
    solve_factored,
)


@numba.njit(nogil=True)
def generic_factor(ab):  # the loops before: kd read at run time, bounds by max/min
    kd, n = ab.shape[0] - 1, ab.shape[1]
    for j in range(n):
        s = ab[kd, j]
        for k in range(max(0, j - kd), j):
            u = ab[kd + k - j, j]
            s -= u * u
        if not s > 0.0:
            return j + 1
        d = math.sqrt(s)
        ab[kd, j] = d
        for i in range(j + 1, min(n, j + kd + 1)):
            s = ab[kd + j - i, i]
            for k in range(max(0, i - kd), j):
                s -= ab[kd + k - j, j] * ab[kd + k - i, i]
            ab[kd + j - i, i] = s / d
    return 0


@numba.njit(nogil=True)
def assemble(x, phase, alpha, p0, p1, p2, ab):  # the band and right-hand side, as before
    n = x.shape[0]
    inv = 1.0 / alpha
    rhs = np.empty(2 * n)
    for k in range(n):
        ck, sk = math.cos(phase[k]), math.sin(phase[k])
        j = 2 * k
        ab[4, j], ab[4, j + 1] = ck * ck + inv * p0[k], sk * sk + inv * p0[k]
        ab[3, j], ab[3, j + 1] = 0.0, ck * sk
        ab[1, j], ab[1, j + 1] = 0.0, 0.0
        q1 = inv * p1[k - 1] if k >= 1 else 0.0
        ab[2, j], ab[2, j + 1] = q1, q1
        q2 = inv * p2[k - 2] if k >= 2 else 0.0
        ab[0, j], ab[0, j + 1] = q2, q2
        rhs[j], rhs[j + 1] = ck * x[k], sk * x[k]
    return rhs


def generic_demodulate(x, phase, alpha, p0, p1, p2, ab, u, v):  # assemble, factor, solve
    rhs = assemble(x, phase, alpha, p0, p1, p2, ab)
    generic_factor(ab)
    y = solve_factored(ab, rhs)  # the triangular solves: the library's, unchanged
    u[:], v[:] = y[0::2], y[1::2]


def demodulate_row(n: int, repeat: int) -> str:
    """The mode update of ``n`` samples (2n unknowns): the library's one pass against the
    generic three steps."""
    rng = np.random.default_rng(2)
    x, phase = rng.normal(size=n), np.cumsum(np.full(n, 0.3))
    p = second_difference_gram(n)
    lib = [np.empty((5, 2 * n)), np.empty(n), np.empty(n), np.empty(n), np.empty(n)]
    gen = [np.empty((5, 2 * n)), np.empty(n), np.empty(n)]
    demodulate_into(x, phase, 1e-6, *p, *lib)
    generic_demodulate(x, phase, 1e-6, *p, *gen)
    same = np.array_equal(lib[3], gen[1]) and np.array_equal(lib[4], gen[2])
    t_lib, t_gen = median_ms([lambda: demodulate_into(x, phase, 1e-6, *p, *lib),
                              lambda: generic_demodulate(x, phase, 1e-6, *p, *gen)], repeat)
    return (f"| 4 | {2 * n} | mode update (assemble, factor, solve) | {t_lib:.3f} | "
            f"{t_gen:.3f} | – | {same} |")


def band_matrix(kd: int, n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    ab = 0.3 * rng.normal(size=(kd + 1, n))
    ab[kd] = 2 * kd + 1 + rng.random(n)
    for i in range(kd):
        ab[i, : kd - i] = 0.0
    return ab


def median_ms(fns, repeat: int) -> list[float]:
    """Median wall time [ms] of each of ``fns``, called in turn ``repeat`` times (so a host's
    drift touches each alike)."""
    times = [[] for _ in fns]
    for _ in range(repeat):
        for fn, t in zip(fns, times, strict=True):
            t0 = time.perf_counter()
            fn()
            t.append(time.perf_counter() - t0)
    return [1e3 * float(np.median(t)) for t in times]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=200)
    args = ap.parse_args()
    print("| super-diagonals | unknowns | step | library [ms] | generic loops [ms] | "
          "scipy solveh_banded [ms] | library = generic (bits) |")
    print("|---|---|---|---|---|---|---|")
    for kd, n in ((4, 24_000), (2, 12_000)):
        for row in band_rows(kd, n, args.repeat):
            print(row)
    print(demodulate_row(12_000, args.repeat))


def band_rows(kd: int, n: int, repeat: int) -> list[str]:
    """The table's rows of one band width and size."""
    ab = band_matrix(kd, n)
    b = np.random.default_rng(1).normal(size=n)
    lib_u, gen_u = cholesky_banded(ab.copy()), _factored(ab)
    same_u = np.array_equal(lib_u, gen_u)
    same_x = np.array_equal(solve_factored(lib_u, b), solve_factored(gen_u, b))
    rows = {
        "factor": (lambda: cholesky_banded(ab.copy()), lambda: generic_factor(ab.copy()), None,
                   same_u),
        "factor + solve": (lambda: solve_factored(cholesky_banded(ab.copy()), b),
                           lambda: solve_factored(_factored(ab), b),
                           lambda: solveh_banded(ab, b), same_x),
    }
    out = []
    for step, (lib, gen, ref, same) in rows.items():
        ms = median_ms([lib, gen] + ([] if ref is None else [ref]), repeat)
        scipy_ms = "–" if ref is None else f"{ms[2]:.3f}"
        out.append(f"| {kd} | {n} | {step} | {ms[0]:.3f} | {ms[1]:.3f} | {scipy_ms} | {same} |")
    return out


def _factored(ab):
    u = ab.copy()
    generic_factor(u)
    return u


if __name__ == "__main__":
    main()

"""Banded operators of ACMP: the second-difference Gram matrix and the two banded solves.

D is the unscaled second difference, shape (N-2, N): (D y)_n = y_n - 2 y_{n+1} + y_{n+2}.
Its Gram matrix P = D^T D is symmetric pentadiagonal with

    diag 0: [1, 5, 6, ..., 6, 5, 1],  diag 1: [-2, -4, ..., -4, -2],  diag 2: [1, ..., 1]

(N >= 4; the short cases are built from the definition). Both ACMP solves are therefore banded
and cost O(N): a banded Cholesky factorisation ``A = U^T U`` and two triangular solves
(:func:`cholesky_banded`, :func:`solve_factored`), compiled with numba. They do what LAPACK's
``pbtrf`` / ``pbtrs`` do (the same upper band storage), row by row; for these narrow bands
(4 and 2 super-diagonals) that is 2-2.5x faster than ``scipy.linalg.solveh_banded`` (84 000
unknowns: 5.3 against 11.9 ms), and they release the GIL. Tested against scipy's solves to
1e-12. The smoothing's matrix ``P / beta + I`` depends only on (N, beta), which every iteration
of an ACMP call, and every call on a record of the same length, share: its factor is kept.
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np

__all__ = ["second_difference_gram", "demodulate", "demodulate_into", "smoothing_factor",
           "smooth_second_difference", "smooth_pair_into", "cholesky_banded", "solve_factored"]


def second_difference_gram(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Diagonals (0, 1, 2) of P = D^T D, lengths (n, n-1, n-2)."""
    assert n >= 3
    p0 = np.zeros(n)
    p1 = np.zeros(n - 1)
    p2 = np.ones(n - 2)
    # each row (1, -2, 1) at columns (k, k+1, k+2) adds its outer product
    w = (1.0, -2.0, 1.0)
    for a in range(3):
        p0[a : n - 2 + a] += w[a] ** 2
    for a in range(2):
        p1[a : n - 2 + a] += w[a] * w[a + 1]
    return p0, p1, p2


def demodulate(x: np.ndarray, phase: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Regularised quadrature demodulation: the ACMP mode update.

    Minimises ``||D u||^2 + ||D v||^2 + alpha ||x - u cos(phase) - v sin(phase)||^2``, i.e. solves

        (Phi^T Phi / alpha + K^T K) y = K^T x,   K = [diag cos, diag sin],  Phi = blkdiag(D, D).

    With u and v interleaved (y = [u_0, v_0, u_1, v_1, ...]) the matrix is symmetric with 4
    super-diagonals: K^T K couples (u_n, v_n) (offset 1), P couples u_n with u_{n+1}, u_{n+2}
    (offsets 2 and 4). One banded Cholesky solve of 2N unknowns, O(N) time and memory, assembled,
    factored and solved in one compiled pass (:func:`demodulate_into`).

    Parameters
    ----------
    x, phase : ndarray, shape (N,) [signal units], [rad]
    alpha : float [-], > 0

    Returns
    -------
    u, v : ndarray, shape (N,) [signal units]
    """
    x = np.ascontiguousarray(x, dtype=float)
    phase = np.ascontiguousarray(phase, dtype=float)
    if x.ndim != 1 or phase.shape != x.shape:
        raise ValueError(f"`x` and `phase` must be 1-D of one length, got {x.shape}, {phase.shape}")
    n = x.shape[0]
    p0, p1, p2 = second_difference_gram(n)
    u, v = np.empty(n), np.empty(n)
    bad = demodulate_into(x, phase, float(alpha), p0, p1, p2,
                          np.empty((5, 2 * n)), np.empty(n), np.empty(n), u, v)
    if bad:
        raise not_positive_definite(bad)
    return u, v


@numba.njit(nogil=True, cache=True)
def demodulate_into(x, phase, alpha, p0, p1, p2, ab, c, s, u, v):  # pragma: no cover (compiled)
    """:func:`demodulate` into ``u``, ``v`` (and the phase's cosine and sine into ``c``, ``s``),
    with ``ab`` (5, 2N) as work space; the Gram's diagonals ``p0, p1, p2`` of
    :func:`second_difference_gram`. Returns 0, or the failing leading minor (not positive
    definite).

    One pass assembles the matrix a few columns ahead of the factorisation, factors it row by
    row and solves ``U^T y = b`` behind it, while each column is in cache; a second pass solves
    ``U x = y``. The operations and their order are those of assembling, then
    :func:`cholesky_banded`, then :func:`solve_factored`: the same bits (tests/test_signal.py),
    in about half the passes over memory."""
    n = x.shape[0]
    m = 2 * n
    inv = 1.0 / alpha
    y = np.empty(m)
    filled = 0  # samples whose two columns (and right-hand sides) are assembled
    for j in range(m):
        last = min(m - 1, j + 4) // 2  # row j reads columns up to j + 4
        while filled <= last:  # upper form: ab[4 + i - j, j] = A[i, j]
            k = filled
            ck, sk = math.cos(phase[k]), math.sin(phase[k])
            c[k], s[k] = ck, sk
            i = 2 * k
            ab[4, i], ab[4, i + 1] = ck * ck + inv * p0[k], sk * sk + inv * p0[k]
            ab[3, i], ab[3, i + 1] = 0.0, ck * sk  # A[2k, 2k+1]
            ab[1, i], ab[1, i + 1] = 0.0, 0.0
            q1 = inv * p1[k - 1] if k >= 1 else 0.0  # A[2k-2, 2k] and A[2k-1, 2k+1]
            ab[2, i], ab[2, i + 1] = q1, q1
            q2 = inv * p2[k - 2] if k >= 2 else 0.0  # A[2k-4, 2k] and A[2k-3, 2k+1]
            ab[0, i], ab[0, i + 1] = q2, q2
            y[i], y[i + 1] = ck * x[k], sk * x[k]
            filled += 1
        bad = _factor_row(ab, j, 4, m)
        if bad:
            return bad
        t = y[j]  # U^T y = b, row j (U's column j is final now)
        for k in range(max(0, j - 4), j):
            t -= ab[4 + k - j, j] * y[k]
        y[j] = t / ab[4, j]
    for j in range(m - 1, -1, -1):  # U x = y
        t = y[j]
        for i in range(j + 1, min(m, j + 5)):
            t -= ab[4 + j - i, i] * y[i]
        y[j] = t / ab[4, j]
    for k in range(n):
        u[k], v[k] = y[2 * k], y[2 * k + 1]
    return 0


def not_positive_definite(minor: int) -> np.linalg.LinAlgError:
    return np.linalg.LinAlgError(f"banded matrix not positive definite (leading minor {minor})")


def smooth_second_difference(z: np.ndarray, beta: float) -> np.ndarray:
    """Tikhonov low-pass ``(P / beta + I)^{-1} z`` (passes linear trends exactly).

    Parameters
    ----------
    z : ndarray, shape (N,) [any]
    beta : float [-], > 0
    """
    factor = smoothing_factor(z.shape[0], beta)
    return solve_factored(factor, np.asarray(z, dtype=float))


def smoothing_factor(n: int, beta: float) -> np.ndarray:
    """Upper banded Cholesky factor of ``P / beta + I`` for records of ``n`` samples (kept per
    ``(n, beta)``; read-only): :func:`smooth_second_difference` is ``solve_factored`` with it."""
    return _smoothing_factor(int(n), float(beta))


@functools.lru_cache(maxsize=16)
def _smoothing_factor(n: int, beta: float) -> np.ndarray:
    """Upper banded Cholesky factor of ``P / beta + I`` (read-only; 3 x n floats)."""
    p0, p1, p2 = second_difference_gram(n)
    inv = 1.0 / beta
    ab = np.zeros((3, n))
    ab[2] = 1.0 + inv * p0
    ab[1, 1:] = inv * p1
    ab[0, 2:] = inv * p2
    factor = cholesky_banded(ab)
    factor.setflags(write=False)
    return factor


@numba.njit(nogil=True, cache=True)
def _factor(ab):  # pragma: no cover (compiled)
    kd = ab.shape[0] - 1
    if kd == 4:  # the demodulation's band, its width then a constant of the compiled loop
        return _factor_kd(ab, 4)
    if kd == 2:  # the smoothing's
        return _factor_kd(ab, 2)
    return _factor_kd(ab, kd)


# Row by row, for ``kd`` super-diagonals. Inlined where ``kd`` is a literal (above), so the
# compiler unrolls the inner loops of the interior rows (their bounds are then constants); the
# operations and their order are those of the generic loop, so the factor is the same to the
# last bit: 1.3-1.85x faster for kd = 4 on 24 000 unknowns (benchmarks/banded_solves.py). It
# gains nothing for kd = 2, nor did the triangular solves written so, which stay generic.
@numba.njit(inline="always")
def _factor_kd(ab, kd):  # pragma: no cover (compiled)
    n = ab.shape[1]
    for j in range(n):
        bad = _factor_row(ab, j, kd, n)
        if bad:
            return bad
    return 0


@numba.njit(inline="always")
def _factor_row(ab, j, kd, n):  # pragma: no cover (compiled)
    """Row j of U: U[j, j], then U[j, i] for i = j+1 .. j+kd (band storage ab[kd+j-i, i]),
    from column j's entries (rows j - kd .. j - 1 already done) and the original A[j, i]
    (columns up to j + kd filled). 0, or j + 1 where the leading minor is not positive."""
    s = ab[kd, j]
    for k in range(max(0, j - kd), j):
        u = ab[kd + k - j, j]
        s -= u * u
    if not s > 0.0:
        return j + 1
    d = math.sqrt(s)
    ab[kd, j] = d
    if j >= kd and j + kd < n:  # interior: kd rows, row j + m with kd - m earlier terms
        for m in range(1, kd + 1):
            i = j + m
            s = ab[kd - m, i]
            for k in range(i - kd, j):
                s -= ab[kd + k - j, j] * ab[kd + k - i, i]
            ab[kd - m, i] = s / d
    else:
        for i in range(j + 1, min(n, j + kd + 1)):
            s = ab[kd + j - i, i]
            for k in range(max(0, i - kd), j):
                s -= ab[kd + k - j, j] * ab[kd + k - i, i]
            ab[kd + j - i, i] = s / d
    return 0


@numba.njit(nogil=True, cache=True)
def _solve(u, b):  # pragma: no cover (compiled)
    kd, n = u.shape[0] - 1, u.shape[1]
    x = b.copy()
    for j in range(n):  # U^T y = b
        s = x[j]
        for k in range(max(0, j - kd), j):
            s -= u[kd + k - j, j] * x[k]
        x[j] = s / u[kd, j]
    for j in range(n - 1, -1, -1):  # U x = y
        s = x[j]
        for i in range(j + 1, min(n, j + kd + 1)):
            s -= u[kd + j - i, i] * x[i]
        x[j] = s / u[kd, j]
    return x


@numba.njit(nogil=True, cache=True)
def smooth_pair_into(factor, zr, zi):  # pragma: no cover (compiled)
    """:func:`solve_factored` of two records at once, in place (``zr``, ``zi`` <- ``A^{-1}`` of
    each), for a factor of two super-diagonals (:func:`smoothing_factor`: ``factor[2 - m, j] =
    U[j - m, j]``): one pass, the diagonal's inverse off the recurrence (4.6x faster than two
    :func:`solve_factored` on 66 k samples; the lock-in's two parts)."""
    n = factor.shape[1]
    inv = np.empty(n)
    for j in range(n):
        inv[j] = 1.0 / factor[2, j]
    r1 = i1 = r2 = i2 = 0.0  # y[j-1], y[j-2]
    for j in range(n):  # U^T y = b
        u1 = factor[1, j] if j >= 1 else 0.0
        u2 = factor[0, j] if j >= 2 else 0.0
        r = (zr[j] - u1 * r1 - u2 * r2) * inv[j]
        im = (zi[j] - u1 * i1 - u2 * i2) * inv[j]
        zr[j], zi[j] = r, im
        r1, r2, i1, i2 = r, r1, im, i1
    r1 = i1 = r2 = i2 = 0.0  # z[j+1], z[j+2]
    for j in range(n - 1, -1, -1):  # U z = y
        u1 = factor[1, j + 1] if j + 1 < n else 0.0
        u2 = factor[0, j + 2] if j + 2 < n else 0.0
        r = (zr[j] - u1 * r1 - u2 * r2) * inv[j]
        im = (zi[j] - u1 * i1 - u2 * i2) * inv[j]
        zr[j], zi[j] = r, im
        r1, r2, i1, i2 = r, r1, im, i1


def cholesky_banded(ab: np.ndarray) -> np.ndarray:
    """Upper banded Cholesky factor U (``A = U^T U``) of a symmetric positive definite matrix in
    upper band storage (``ab[kd + i - j, j] = A[i, j]``, i <= j), in that storage; ``ab`` is
    overwritten. ``numpy.linalg.LinAlgError`` if A is not positive definite."""
    ab = np.ascontiguousarray(ab, dtype=float)
    bad = _factor(ab)
    if bad:
        raise not_positive_definite(bad)
    return ab


def solve_factored(factor: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``A^{-1} b`` from the factor of :func:`cholesky_banded`; ``b`` shape (n,)."""
    return _solve(factor, np.ascontiguousarray(b, dtype=float))

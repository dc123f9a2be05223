"""Time first-harmonic extraction of one 250 s channel at 2048 Hz (512 000 samples).

    python benchmarks/extract.py [--repeat 5]     # after pip install -e . (or PYTHONPATH=src)

The channel is the acceleration of a linear 45 Hz resonance (zeta = 0.04) under a 25 -> 50 Hz,
0.1 Hz/s base sweep at 0.6 g (the paper's experiment), plus 0.1 g white noise; two rows use the
SDOF freeplay reference record instead (a jump: more ACMP iterations); the lock-in's compiled
rows stand beside the numpy composition they replace, at the full rate and on a record of the
studies' bank (256 Hz, 260 s; a phase lag of pi through 150 s, 0.01 g noise). BLAS/OpenMP are
limited to one thread before NumPy is imported (the target is one CPU core). Prints a Markdown
table: best and median wall time over ``--repeat`` runs, ACMP iterations, and the peak found
(frequency, amplitude) so the decimated default can be compared with the full-rate solve.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import importlib  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy.signal  # noqa: E402

from freeplayid.signal import acmp, extract_backbone_points, lockin, white_noise  # noqa: E402
from freeplayid.sweep import Sweep  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from lockin_reference import numpy_lockin  # noqa: E402  (the numpy composition, before)

# the modules (the package's names are the functions): what they keep between calls
_acmp = importlib.import_module("freeplayid.signal.acmp")
_lockin = importlib.import_module("freeplayid.signal.lockin")

FS = 2048.0  # [Hz]
SWEEP = Sweep(25.0, 50.0, 0.1)  # 250 s
FS_STUDY, SWEEP_STUDY = 256.0, Sweep(30.0, 56.0, 0.1)  # the studies' bank (docs/inverse.md)


def make_channel(seed: int = 0) -> np.ndarray:
    """Absolute acceleration [m/s^2] of a linear 45 Hz resonance, plus 0.1 g noise; (512000,)."""
    t = np.arange(int(SWEEP.duration * FS)) / FS
    wn, zeta = 2 * np.pi * 45.0, 0.04
    # relative displacement y: y'' + 2 zeta wn y' + wn^2 y = -a_g; relative acceleration from it
    sys = scipy.signal.lti([-1.0, 0.0, 0.0], [1.0, 2 * zeta * wn, wn * wn])
    a_g = SWEEP.acceleration(t, 0.6)
    _, a_rel, _ = scipy.signal.lsim(sys, a_g, t)
    return a_rel + a_g + white_noise(t.shape, std_g=0.1, seed=seed)


def make_freeplay_channel(seed: int = 0) -> np.ndarray:
    """Relative acceleration [m/s^2] of the SDOF freeplay oscillator (tests/sdof_reference.py,
    f_n = 50 Hz, zeta = 0.04, delta = 1.2e-4 m) at 0.6 g over the same sweep, plus 0.1 g noise."""
    from sdof_reference import simulate_sdof_sweep

    _, _, a, _ = simulate_sdof_sweep(0.6, SWEEP)
    return a[: int(SWEEP.duration * FS)] + white_noise(a.size - 1, std_g=0.1, seed=seed)


def timed(fn, repeat: int, fresh: bool = True):
    """(best, median, last result) of ``repeat`` calls; ``fresh``: every call without what an
    earlier one kept (ACMP's pursuits, the lock-in's carrier), so each row times the work."""
    times, out = [], None
    for _ in range(repeat):
        if fresh:
            _acmp._PURSUITS.entries.clear()
            _lockin._kept_carrier.cache_clear()
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), float(np.median(times)), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    x = make_channel()
    t_study = np.arange(int(SWEEP_STUDY.duration * FS_STUDY)) / FS_STUDY
    xs = np.cos(SWEEP_STUDY.phase(t_study) - 0.5 * np.pi * (1 + np.tanh(t_study - 150.0))) \
        + white_noise(t_study.shape, std_g=0.01, seed=1)
    t0 = time.perf_counter()
    xf = make_freeplay_channel()
    print(f"(freeplay reference record simulated in {time.perf_counter() - t0:.1f} s)")
    fs_acc = "acceleration"
    cases = [
        ("ACMP, sweep hint (default: decimated)", lambda: acmp(x, FS, sweep=SWEEP)),
        ("ACMP, no hint (STFT ridge init)", lambda: acmp(x, FS)),
        ("ACMP, sweep hint, full rate", lambda: acmp(x, FS, sweep=SWEEP, decimate_to=None)),
        # a freeplay jump needs 15-50 iterations: bound the cost with a forced 100
        ("ACMP, 100 iterations forced", lambda: acmp(x, FS, sweep=SWEEP, tol=1e-300)),
        ("ACMP, 20 iterations forced, full rate",
         lambda: acmp(x, FS, sweep=SWEEP, tol=1e-300, max_iter=20, decimate_to=None)),
        ("ACMP, freeplay record (jump), sweep hint", lambda: acmp(xf, FS, sweep=SWEEP)),
        ("ACMP, freeplay record (jump), no hint", lambda: acmp(xf, FS)),
        ("lock-in (default: decimated)", lambda: lockin(x, FS, sweep=SWEEP)),
        ("lock-in, full rate", lambda: lockin(x, FS, sweep=SWEEP, decimate_to=None)),
        ("lock-in, full rate, numpy composition", lambda: numpy_lockin(x, FS, SWEEP)),
        # the studies' cases: 256 Hz records of 260 s (30 -> 56 Hz at 0.1 Hz/s), undecimated
        ("lock-in, a study's record (256 Hz)",
         lambda: lockin(xs, FS_STUDY, sweep=SWEEP_STUDY, bandwidth_hz=1.0)),
        ("lock-in, a study's record, numpy composition",
         lambda: numpy_lockin(xs, FS_STUDY, SWEEP_STUDY, 1.0)),
    ]
    kept = {  # a data set's later runs: the carrier of their common sweep kept
        "lock-in, a study's record, its sweep's carrier kept":
            lambda: lockin(xs, FS_STUDY, sweep=SWEEP_STUDY, bandwidth_hz=1.0),
    }
    print(f"one channel: {x.size} samples ({x.size / FS:.0f} s at {FS:.0f} Hz), 1 thread\n")
    print("| method | best [s] | median [s] | iterations | peak f [Hz] | peak A [m/s^2] |")
    print("|---|---|---|---|---|---|")
    for name, fn in [*cases, *kept.items()]:
        best, med, m = timed(fn, args.repeat, fresh=name not in kept)
        k = int(np.argmax(m.amplitude[int(FS) : -int(FS)])) + int(FS)
        print(f"| {name} | {best:.3f} | {med:.3f} | {m.iterations} | {m.frequency[k]:.3f} "
              f"| {m.amplitude[k]:.3f} |")
    best, med, res = timed(
        lambda: extract_backbone_points(x[None, None, :], FS, quantity=fs_acc, sweep=SWEEP,
                                        require_jump=False),
        args.repeat,
    )
    p = res.points[0]
    print(f"| extract_backbone_points (ACMP + Eq. 9 + peak) | {best:.3f} | {med:.3f} | - "
          f"| {p.f_hz:.3f} | X = {p.amplitude_m:.4e} m |")


if __name__ == "__main__":
    main()

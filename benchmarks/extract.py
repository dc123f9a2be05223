"""Time first-harmonic extraction of one 250 s channel at 2048 Hz (512 000 samples).

    python benchmarks/extract.py [--repeat 5]     # after pip install -e . (or PYTHONPATH=src)

The channel is the acceleration of a linear 45 Hz resonance (zeta = 0.04) under a 25 -> 50 Hz,
0.1 Hz/s base sweep at 0.6 g (the paper's experiment), plus 0.1 g white noise; two rows use the
SDOF freeplay reference record instead (a jump: more ACMP iterations). BLAS/OpenMP are
limited to one thread before NumPy is imported (the target is one CPU core). Prints a Markdown
table: best and median wall time over ``--repeat`` runs, ACMP iterations, and the peak found
(frequency, amplitude) so the decimated default can be compared with the full-rate solve.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy.signal  # noqa: E402

from freeplayid.signal import acmp, extract_backbone_points, lockin, white_noise  # noqa: E402
from freeplayid.sweep import Sweep  # noqa: E402

FS = 2048.0  # [Hz]
SWEEP = Sweep(25.0, 50.0, 0.1)  # 250 s


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
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from sdof_reference import simulate_sdof_sweep

    _, _, a, _ = simulate_sdof_sweep(0.6, SWEEP)
    return a[: int(SWEEP.duration * FS)] + white_noise(a.size - 1, std_g=0.1, seed=seed)


def timed(fn, repeat: int):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), float(np.median(times)), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    x = make_channel()
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
    ]
    print(f"one channel: {x.size} samples ({x.size / FS:.0f} s at {FS:.0f} Hz), 1 thread\n")
    print("| method | best [s] | median [s] | iterations | peak f [Hz] | peak A [m/s^2] |")
    print("|---|---|---|---|---|---|")
    for name, fn in cases:
        best, med, m = timed(fn, args.repeat)
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

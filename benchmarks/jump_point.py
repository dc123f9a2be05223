"""The jump point against a clean reference: the smoothed maximum vs the windowed point.

    python benchmarks/jump_point.py [--seeds 3] [--skip-fin]     # PYTHONPATH=src; ~10 min

For every condition the TRUE jump point comes from the clean, densely sampled displacement: the
largest first-harmonic cycle amplitude (one Fourier integral per response cycle between zero
up-crossings, no filter; tests/sdof_reference.py ``jump_reference``), at the excitation
frequency of that time. The MEASURED record is the same run, sampled as a test would be, with
white noise of 0, 1 or 5 % of the peak (the reference amplitude in the measured quantity) on
every channel, seeds 0 .. seeds-1. Each record goes through ``extract_backbone_points`` with
``jump_point="smoothed"`` (the rule before) and ``"windowed"`` (the default), for ACMP with
the sweep hint, ACMP without it, and the lock-in. Errors: f - f_true [Hz], X / X_true - 1 [%]
(mean over seeds, and the largest |error| over seeds).

Systems:
- SDOF freeplay oscillator (tests/sdof_reference.py: f_n = 50 Hz, zeta = 0.04, delta = 1.2e-4 m),
  RK4 at 8192 Hz x 2 substeps, 15 <-> 47 Hz up and down; measured: relative acceleration at
  2048 Hz (every 4th sample). 0.17 g and 0.37 g give X*/delta = 2.5 and 4.5 on the up-sweep.
- the default fin (freeplayid.simulate, kn 480 N m/rad, delta 3e-3 rad, 30 -> 46.5 Hz up);
  reference: relative displacement of uz_top_left at 2048 Hz; measured: absolute accelerations
  of uz_top_left and of the base at 256 Hz (the example's rate), the base subtracted.
  0.6 g and 1.25 g give Theta/delta = 2.6 and 4.5 at the hinge.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from freeplayid.signal import extract_backbone_points  # noqa: E402
from freeplayid.sweep import Sweep  # noqa: E402
from sdof_reference import DELTA, jump_reference, simulate_sdof_sweep  # noqa: E402

RATES = (0.1, 0.5, 1.0)  # [Hz/s]
NOISE = (0.0, 0.01, 0.05)  # [-] white-noise std / the peak amplitude of the measured quantity
SDOF_LEVELS = (0.17, 0.37)  # [g]
SDOF_BAND = (15.0, 47.0)  # [Hz]
SDOF_FS, SDOF_Q = 8192.0, 4  # [Hz] simulation rate, decimation to the measured 2048 Hz
FIN_LEVELS = (0.6, 1.25)  # [g]
FIN_BAND = (30.0, 46.5)  # [Hz]
FIN_KN, FIN_DELTA = 480.0, 3e-3  # [N m/rad], [rad]
FIN_FS_REF, FIN_FS = 2048.0, 256.0  # [Hz]
FIN_CHANNEL = "uz_top_left"
METHODS = (("ACMP", "acmp", True), ("ACMP, no hint", "acmp", False), ("lock-in", "lockin", True))


def errors(x, fs, sweep, truth, noise, seeds, base=None):
    """{(method label, jump_point): [(df, dX%), ...] over seeds} for one measured record."""
    _, f_true, x_true = truth
    scale = x_true * (2 * np.pi * f_true) ** 2  # the peak in the measured quantity (m/s^2)
    out = {}
    for seed in range(seeds if noise else 1):
        rng = np.random.default_rng(seed)
        xn = x + noise * scale * rng.standard_normal(x.shape)
        bn = None if base is None else [base + noise * scale * rng.standard_normal(base.shape)]
        for label, method, hint in METHODS:
            for jp in ("smoothed", "windowed"):
                p = extract_backbone_points(
                    xn[None, None], fs, quantity="acceleration", sweep=sweep if hint else None,
                    base=bn, method=method, jump_point=jp,
                ).points[0]
                err = (p.f_hz - f_true, 100 * (p.amplitude_m / x_true - 1), p.used)
                out.setdefault((label, jp), []).append(err)
    return out


def row(case, ratio, truth, res):
    cells = [case, f"{ratio:.2f}", f"{truth[1]:.3f}"]
    for label, _, _ in METHODS:
        for jp in ("smoothed", "windowed"):
            e = np.array([r[:2] for r in res[(label, jp)]])
            used = all(r[2] for r in res[(label, jp)])
            mark = "" if used else " (rejected)"
            spread = f" ({np.abs(e[:, 1]).max():.2f})" if len(e) > 1 else ""
            cells.append(f"{e[:, 0].mean():+.3f} / {e[:, 1].mean():+.2f}{spread}{mark}")
    return "| " + " | ".join(cells) + " |"


def header():
    cols = ["case", "X*/δ or Θ*/δ", "f* [Hz]"]
    for label, _, _ in METHODS:
        cols += [f"{label}: smoothed", f"{label}: windowed"]
    return "| " + " | ".join(cols) + " |\n|" + "---|" * len(cols)


def sdof_cases(seeds):
    for rate in RATES:
        for level in SDOF_LEVELS:
            for up in (True, False):
                lo, hi = SDOF_BAND
                sweep = Sweep(lo, hi, rate) if up else Sweep(hi, lo, rate)
                y, _, a, _ = simulate_sdof_sweep(level, sweep, fs=SDOF_FS, jit=True)
                truth = jump_reference(y, SDOF_FS, sweep)
                for noise in NOISE:
                    res = errors(a[::SDOF_Q], SDOF_FS / SDOF_Q, sweep, truth, noise, seeds)
                    case = (f"SDOF {rate:g} Hz/s {'up' if up else 'down'} {level:g} g, "
                            f"noise {100 * noise:g} %")
                    yield row(case, truth[2] / DELTA, truth, res)


def fin_cases(seeds, rates):
    import torch

    from freeplayid.model import default_fin
    from freeplayid.simulate import simulate_sweeps

    fin = default_fin()
    out_dof, in_dof = fin.hinge_pairs[0]
    for rate in rates:
        sweep = Sweep(*FIN_BAND, rate)
        common = dict(kn=FIN_KN, delta=FIN_DELTA, level_g=list(FIN_LEVELS), sweep=sweep,
                      dtype=torch.float64)
        ref = simulate_sweeps(fin, channels=[FIN_CHANNEL, out_dof, in_dof],
                              quantity="displacement", frame="relative",
                              sample_rate=FIN_FS_REF, **common)
        meas = simulate_sweeps(fin, channels=[FIN_CHANNEL], quantity="acceleration",
                               frame="absolute", sample_rate=FIN_FS, **common)
        for i, level in enumerate(FIN_LEVELS):
            truth = jump_reference(ref.signals[i, 0], FIN_FS_REF, sweep)
            theta = ref.signals[i, 1] - ref.signals[i, 2]
            th_ratio = jump_reference(theta, FIN_FS_REF, sweep)[2] / FIN_DELTA
            base = sweep.acceleration(meas.time, level)
            for noise in NOISE:
                res = errors(meas.signals[i, 0], FIN_FS, sweep, truth, noise, seeds, base=base)
                case = f"fin {rate:g} Hz/s up {level:g} g, noise {100 * noise:g} %"
                yield row(case, th_ratio, truth, res)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3, help="noise seeds per noisy condition")
    ap.add_argument("--skip-fin", action="store_true", help="only the SDOF oscillator")
    ap.add_argument("--fin-rates", type=float, nargs="+", default=RATES, help="[Hz/s]")
    args = ap.parse_args()
    t0 = time.perf_counter()
    print("errors f - f_true [Hz] / X / X_true - 1 [%], with noise the mean over "
          f"{args.seeds} seeds (the largest |X error| over them)\n")
    print(header(), flush=True)
    for line in sdof_cases(args.seeds):
        print(line, flush=True)
    if not args.skip_fin:
        for line in fin_cases(args.seeds, args.fin_rates):
            print(line, flush=True)
    print(f"\n({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()

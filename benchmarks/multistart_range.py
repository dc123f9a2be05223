"""The multi-start grid's kn range: the old default [1e3, 1e8] against [1e2, 1e7] N·m/rad.

    PYTHONPATH=src python benchmarks/multistart_range.py          # ~2 min on 2 cores

The plain fit (``fit_backbone`` with the 5 x 5 multi-start grid, DFA backbone) of the same points
from both grids: the bundled example (``examples/fin_sweeps``, kn 480 N·m/rad, below the old
grid's lowest start) and default fins simulated here at the ends of the studies' prior (kn 300
and 800 N·m/rad, delta 1.5 and 5 mrad; relative accelerations of both measure points, 20 -> 75 Hz
at 0.5 Hz/s, four levels for Theta/delta of about 2.5-5, no noise). Prints, per case and grid,
the fitted kn and delta against the truth, the objective evaluations and the fit's time.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from freeplayid.estimate import extract_points
from freeplayid.fit import fit_backbone, multistart_grid
from freeplayid.fit.fitting_points import FittingPoints
from freeplayid.io import read_dataset
from freeplayid.model import default_fin, load_system
from freeplayid.signal import Extraction, extract_backbone_points
from freeplayid.simulate import simulate_sweeps
from freeplayid.sweep import Sweep

ROOT = Path(__file__).resolve().parents[1]
GRIDS = {"[1e3, 1e8] (old)": (1e3, 1e8), "[1e2, 1e7] (default)": (1e2, 1e7)}
SIMULATED = ((300.0, 1.5e-3), (800.0, 5e-3))  # (kn [N m/rad], delta [rad])


def example():
    ds = read_dataset(ROOT / "examples" / "fin_sweeps")
    pts, _ = extract_points(ds, extraction=Extraction())
    return "bundled example", load_system(ds.model), \
        FittingPoints.from_extraction(pts, dofs=ds.channels), (480.0, 3e-3)


def simulated(kn: float, delta: float):
    fin = default_fin()
    sweep = Sweep(20.0, 75.0, 0.5)
    levels = [g * delta / 3e-3 for g in (0.6, 0.8, 1.0, 1.2)]
    res = simulate_sweeps(fin, kn=kn, delta=delta, level_g=levels, sweep=sweep,
                          channels=["uz_top_left", "uz_lower_right"], frame="relative")
    pts = extract_backbone_points(res.signals, res.sample_rate, quantity="acceleration",
                                  channel_names=res.channels, sweep=sweep)
    return f"fin kn {kn:g}, delta {1e3 * delta:g} mrad", fin, pts, (kn, delta)


def main() -> int:
    cases = [example()] + [simulated(*p) for p in SIMULATED]
    print("| case | kn grid [N·m/rad] | kn (err %) | δ mrad (err %) | evaluations | fit s |")
    print("|---|---|---|---|---|---|")
    for name, system, pts, (kn0, d0) in cases:
        for label, rng in GRIDS.items():
            t0 = time.perf_counter()
            starts = multistart_grid(5, kn_range=rng, delta_range=(1e-4, 1e-2))
            fit = fit_backbone(pts, system, init=starts, init_label="multistart")
            dt = time.perf_counter() - t0
            print(f"| {name} | {label} | {fit.kn:.2f} ({100 * (fit.kn / kn0 - 1):+.2f}) | "
                  f"{1e3 * fit.delta:.4f} ({100 * (fit.delta / d0 - 1):+.2f}) | "
                  f"{fit.n_evaluations} | {dt:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Whether ACMP's pursuit converges on sweep records with a jump, and what its stopping point
does to the backbone points: the plain pursuit (``if_weighting="none"``, the default before
2026-12-04) beside the locally weighted one (``"local"``, the default) in the same run.

    python benchmarks/pursuit_convergence.py                          # the bundled example
    python benchmarks/pursuit_convergence.py --data DIR [DIR ...] --jump-point drop

For each data set, run and channel: the pursuit's iterations (``*`` = stopped at ``max_iter``
without converging) and the largest relative change of the first harmonic's amplitude between
100 and 400 allowed iterations, anywhere in the record (the default stop is 100). For each
point the extraction reads (``--jump-point``: the drop point the replay matches without a base
channel, or the quadrature point with one): how far its amplitude and frequency move between
100 and 400 iterations. A reading that converged does not move; one that did not depends on
where the iterations stopped, which the noise changes from record to record. Last, the time
to extract the whole data set with each weighting (best of ``--repeat``; the pursuit's memo
is cleared before each).
"""

from __future__ import annotations

import argparse
import importlib
import time

import numpy as np

from freeplayid.estimate import extract_points
from freeplayid.io import read_dataset
from freeplayid.signal import Extraction
from freeplayid.sweep import Sweep

_acmp = importlib.import_module("freeplayid.signal.acmp")
WEIGHTINGS = ("none", "local")
STOPS = (100, 400)


def channel_rows(ds, weighting: str) -> list[tuple]:
    """(run, channel, iterations at 100, converged, max |amp400 / amp100 - 1|) per channel."""
    fs, rows = float(ds.sample_rate), []
    for run in ds.runs:
        if run.reason:
            continue
        sweep = Sweep(**run.sweep) if run.sweep else None
        for c, name in enumerate(ds.channels):
            modes = [_acmp.acmp(run.data[c], fs, sweep=sweep, bandwidth_hz=1.0, max_iter=m,
                                if_weighting=weighting) for m in STOPS]
            moved = np.abs(modes[1].amplitude / modes[0].amplitude - 1)
            rows.append((run.file, name, modes[0].iterations, modes[0].converged,
                         float(np.nanmax(moved))))
    return rows


def points(ds, weighting: str, max_iter: int, jump_point: str) -> dict:
    """{(run, DOF): (f [Hz], amplitude [m])} of the used points."""
    ext = Extraction(jump_point=jump_point,
                     options={"if_weighting": weighting, "max_iter": max_iter})
    pts, _ = extract_points(ds, extraction=ext)
    return {(p.run, p.channel): (p.f_hz, p.amplitude_m) for p in pts.used()}


def extraction_time(ds, weighting: str, jump_point: str, repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        _acmp._PURSUITS.entries.clear()
        t0 = time.perf_counter()
        points(ds, weighting, 100, jump_point)
        best = min(best, time.perf_counter() - t0)
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", nargs="+", default=["examples/fin_sweeps"])
    ap.add_argument("--jump-point", default="drop", help="the points' rule (default drop)")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args(argv)
    for folder in args.data:
        ds = read_dataset(folder)
        print(f"\n## {folder}\n")
        print("| run | channel | " + " | ".join(
            f"{w}: iterations | {w}: max amplitude move 100->400" for w in WEIGHTINGS) + " |")
        print("|---|---|" + "---|---|" * len(WEIGHTINGS))
        tables = [channel_rows(ds, w) for w in WEIGHTINGS]
        for rows in zip(*tables):
            cells = [f"{it}{'' if ok else '*'} | {100 * mv:.3g} %" for _, _, it, ok, mv in rows]
            print(f"| {rows[0][0]} | {rows[0][1]} | " + " | ".join(cells) + " |")
        for w, rows in zip(WEIGHTINGS, tables):
            print(f"\n{w}: {sum(not r[3] for r in rows)} of {len(rows)} channels stopped at "
                  f"max_iter {STOPS[0]} without converging")
        print(f"\n| point ({args.jump_point}) | " + " | ".join(
            f"{w}: amplitude 100->400 | {w}: frequency 100->400" for w in WEIGHTINGS) + " |")
        print("|---|" + "---|---|" * len(WEIGHTINGS))
        read = {w: [points(ds, w, m, args.jump_point) for m in STOPS] for w in WEIGHTINGS}
        worst = dict.fromkeys(WEIGHTINGS, 0.0)
        for key in sorted(read["none"][0]):
            cells = []
            for w in WEIGHTINGS:
                a, b = read[w][0].get(key), read[w][1].get(key)
                if a is None or b is None:
                    cells.append("not read | not read")
                    continue
                worst[w] = max(worst[w], abs(b[1] / a[1] - 1))
                cells.append(f"{100 * (b[1] / a[1] - 1):+.3f} % | {1e3 * (b[0] - a[0]):+.2f} mHz")
            print(f"| {key[0]} {key[1]} | " + " | ".join(cells) + " |")
        times = {w: extraction_time(ds, w, args.jump_point, args.repeat) for w in WEIGHTINGS}
        print("\n" + "; ".join(f"{w}: largest point amplitude move {100 * worst[w]:.3f} %, "
                               f"extraction {times[w]:.2f} s" for w in WEIGHTINGS))


if __name__ == "__main__":
    main()

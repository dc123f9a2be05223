"""What replaying flat costs: a test's replay at one (kn, delta) with the simulator's default
decimating filter (flat to 0.3 of the sample rate) beside one flat to 0.45 (4 x the taps), the
filter ``identify`` replays with where the points lie above 0.3 fs (``replay.antialias``).

    python benchmarks/antialias_cost.py                      # the bundled example
    python benchmarks/antialias_cost.py DATA_FOLDER --repeat 3

One process, warm (a first replay of each, not timed, compiles the kernel); per row the best of
``--repeat`` wall times of ``freeplayid.replay.replay_dataset`` (the runs on freeplayid's
threads, the exponential engine) at the data set's truth (``truth`` in its manifest; else its
plain fit), and each run's largest sample against the default's (the flat filter passes the
jumps' harmonics between 0.3 and 0.45 fs as well as the points). Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from freeplayid import identify
from freeplayid.io import read_dataset
from freeplayid.model import load_system
from freeplayid.replay import replay_dataset
from freeplayid.simulate.resample import MAX_PASSBAND, PASSBAND, design_decimator

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "fin_sweeps"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="?", default=str(EXAMPLE))
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    ds = read_dataset(Path(args.data))
    system = load_system(ds.model)
    truth = ds.truth or {}
    if "kn" in truth and "delta" in truth:
        kn, delta = float(truth["kn"]), float(truth["delta"])
    else:
        plain = identify(ds, system=system, progress=False, replay=None)
        kn, delta = plain.kn, plain.delta
    rows, peaks = [], {}
    for passband in (PASSBAND, MAX_PASSBAND):
        replay_dataset(ds, system, kn, delta, passband=passband)  # warm
        best, rep = np.inf, None
        for _ in range(max(1, args.repeat)):
            t0 = time.perf_counter()
            rep = replay_dataset(ds, system, kn, delta, passband=passband)
            best = min(best, time.perf_counter() - t0)
        peaks[passband] = np.array([np.max(np.abs(r.data)) for r in rep.runs])
        rows.append((passband, len(design_decimator(8, passband=passband)), best))
    print(f"{ds.name}: {len(ds.runs)} runs, {ds.sample_rate:g} Hz, kn {kn:.4g}, "
          f"delta {delta:.4g}\n")
    print("| filter flat to [fs] | taps at factor 8 | replay wall [s] (best of "
          f"{args.repeat}) | largest sample against the default's |")
    print("|---|---|---|---|")
    for passband, taps, wall in rows:
        ratio = peaks[passband] / peaks[PASSBAND]
        print(f"| {passband:g} | {taps} | {wall:.2f} | {ratio.min():.4f}-{ratio.max():.4f} |")


if __name__ == "__main__":
    main()

"""How far the test's noise moves the statistic's points on copies of the answer's replay,
against copies of the true noise-free records (a realtests case made by ``redraw.py --noise
none``): the precision check measures the first; the test's own answer scatters as the second.

    python benchmarks/realtests/copies_scatter.py CASE --data R --draw d4 --copies 10

Identifies the draw with the library's defaults, keeps the replay its precision copies are made
of, then fits ``--copies`` noisy copies of that replay and of the noise-free records (``d_none``)
with the test's statistic (its extraction options), the noise the copies get (each channel's
measured level, the base's too) on both. Prints each run's and channel's point scatter and the
fits' scatter in log kn and log delta.
"""

from __future__ import annotations

import argparse
import collections
import sys
from pathlib import Path

import numpy as np

import freeplayid.replay.bootstrap as bootstrap
import freeplayid.replay.corrected as corrected
from freeplayid import identify
from freeplayid.io import read_dataset


def _scatter(dataset, system, noise, extraction, copies: int, rng):
    """The points' (run, channel) -> frequencies [Hz] and the fits' log (kn, delta) over
    ``copies`` noisy copies of ``dataset``."""
    points, fits = collections.defaultdict(list), []
    for _ in range(copies):
        copy = bootstrap.noisy_copy(dataset, noise, rng)
        r = identify(copy, system=system, replay=None, records=None, extraction=extraction,
                     progress=False)
        fits.append(np.log([r.kn, r.delta]))
        for p in r.points.used():
            points[(p.run, p.channel)].append(p.f_hz)
    return points, np.asarray(fits)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case")
    ap.add_argument("--data", required=True, help="redraw.py's --out (with d_none)")
    ap.add_argument("--draw", default="d0")
    ap.add_argument("--copies", type=int, default=10)
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args(argv)
    folder = Path(args.data) / args.case
    if not (folder / "d_none").is_dir() or not (folder / args.draw).is_dir():
        ap.error(f"{folder}: needs {args.draw}/ and d_none/ (redraw.py --noise none)")
    kept = {}
    original = corrected.precision_by_replay

    def keep(replayed, system, noise, **kw):  # the replay the precision copies are made of
        kept.update(replay=replayed, system=system, noise=noise, extraction=kw["extraction"])
        return original(replayed, system, noise, **kw)

    corrected.precision_by_replay = keep
    try:
        answer = identify(folder / args.draw, progress=False)
    finally:
        corrected.precision_by_replay = original
    if not kept:
        print("the answer's precision was not measured (no copies)", file=sys.stderr)
        return 1
    truth = answer.truth or {}
    print(f"{args.case} {args.draw}: kn {answer.kn:.5g} (truth {truth.get('kn')}), "
          f"delta {answer.delta:.6g} (truth {truth.get('delta')}), "
          f"statistic {kept['extraction'].jump_point!r}")
    rng = np.random.default_rng(args.seed)
    for label, ds in (("copies of the answer's replay", kept["replay"]),
                      ("copies of the noise-free records", read_dataset(folder / "d_none"))):
        points, fits = _scatter(ds, kept["system"], kept["noise"], kept["extraction"],
                                args.copies, rng)
        sd = fits.std(axis=0, ddof=1)
        print(f"{label}: {len(fits)} fits, sd log kn {sd[0]:.4f}, log delta {sd[1]:.4f}")
        print("  | run | channel | mean [Hz] | sd [Hz] |")
        print("  |---|---|---|---|")
        for (run, channel), f in sorted(points.items()):
            print(f"  | {run} | {channel} | {np.mean(f):.3f} | {np.std(f, ddof=1):.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

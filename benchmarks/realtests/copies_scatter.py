"""How far the test's noise moves the statistic's points on copies of the answer's replay,
against copies of the true noise-free records (a realtests case made by ``redraw.py --noise
none``): the precision check measures the first; the test's own answer scatters as the second.

    python benchmarks/realtests/copies_scatter.py CASE --data R --draw d4 --copies 12

Identifies the draw with the library's defaults and keeps what its precision copies are made
of: the answer's replay, the noise they get (each channel's measured level, the base's too),
the statistic's extraction and fit options, the points' weights, the runs' points. Then fits
``--copies`` noisy copies of that replay and of the noise-free records (``d_none``) as the
precision does (``plain_estimate`` from the replayed answer), on whole records and cut to
``PRECISION_MARGIN_HZ`` about the points, with and without the weights, each from the same
noise seed. Prints the fits' scatter in log kn and log delta per variant.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import freeplayid.replay.bootstrap as bootstrap
import freeplayid.replay.corrected as corrected
from freeplayid import identify
from freeplayid.io import read_dataset


def _scatter(dataset, kept: dict, copies: int, seed: int, weights: bool) -> np.ndarray:
    """The fits' log (kn, delta) over ``copies`` noisy copies of ``dataset``, made and fitted
    by the precision's own loop (``bootstrap._copy_estimates``, ``kept``: what the precision
    was called with); a copy whose noise hides a jump, or whose fit fails, is left out."""
    estimates = bootstrap._copy_estimates(
        dataset, kept["system"], kept["noise"], np.random.default_rng(seed), n=copies,
        theta_rep=kept["theta_rep"], extraction=kept["extraction"], fit=kept["fit"],
        point_weights=kept["point_weights"] if weights else None, desc="", progress=False)
    return np.asarray([np.log([e.kn, e.delta]) for e in estimates
                       if e is not None and e.fit.success])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case")
    ap.add_argument("--data", required=True, help="redraw.py's --out (with d_none)")
    ap.add_argument("--draw", default="d0")
    ap.add_argument("--copies", type=int, default=12)
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args(argv)
    folder = Path(args.data) / args.case
    if not (folder / "d_none").is_dir() or not (folder / args.draw).is_dir():
        ap.error(f"{folder}: needs {args.draw}/ and d_none/ (redraw.py --noise none)")
    kept = {}
    original = corrected.precision_by_replay

    def keep(replayed, system, noise, **kw):  # the replay the precision copies are made of
        kept.update(replay=replayed, system=system, noise=noise, **kw)
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
    precision = getattr(answer.replay, "precision", None)
    if precision is not None and precision.delta_halfwidth is not None:
        print(f"the precision's own {precision.n_fitted} copies: sd log delta about "
              f"{np.log1p(precision.delta_halfwidth) / 1.96:.4f} (its half-width / 1.96)")
    centres = bootstrap.point_centres(kept["points"])
    print("| records | cut to the points | weights | fits | sd log kn | sd log delta |")
    print("|---|---|---|---|---|---|")
    for label, ds in (("the answer's replay", kept["replay"]),
                      ("the true noise-free records", read_dataset(folder / "d_none"))):
        for cut in (False, True):
            src = bootstrap.windowed(ds, centres, bootstrap.PRECISION_MARGIN_HZ) if cut else ds
            for weights in (False, True):
                fits = _scatter(src, kept, args.copies, args.seed, weights)
                sd = fits.std(axis=0, ddof=1) if len(fits) > 1 else (np.nan, np.nan)
                print(f"| {label} | {'yes' if cut else 'no'} | {'yes' if weights else 'no'} | "
                      f"{len(fits)} | {sd[0]:.4f} | {sd[1]:.4f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

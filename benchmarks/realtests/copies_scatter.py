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
noise seed. Prints the fits' scatter in log kn and log delta per variant, and the copies' scatter
carried through the answer's binding slope as the precision carries it (``answer_sd``).

    python benchmarks/realtests/copies_scatter.py CASE --data R --draw d4 --copies 32 \
        --stream precision --only-precision

``--stream precision`` draws the noise from the precision's own seed stream (the answer's
``Replay.seed``, stream 2), so its first ``precision_copies`` copies are the precision's to the
digit; ``--only-precision`` fits only what the precision reads (cut, weighted).
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


def _scatter(dataset, kept: dict, copies: int, seed, weights: bool) -> np.ndarray:
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
    ap.add_argument("--stream", choices=("own", "precision"), default="own",
                    help="precision: the precision's seed stream ([Replay.seed, 2])")
    ap.add_argument("--only-precision", action="store_true",
                    help="only the copies the precision reads (cut, weighted)")
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
    seed = [kept["seed"], 2] if args.stream == "precision" else args.seed
    slope = kept.get("binding_slope")
    print(f"noise seed {seed}; the answer's binding slope "
          f"{'none' if slope is None else np.round(np.asarray(slope), 3).tolist()}")
    print("| records | cut to the points | weights | fits | sd log kn | sd log delta "
          "| through the slope: sd log kn | sd log delta |")
    print("|---|---|---|---|---|---|---|---|")
    for label, ds in (("the answer's replay", kept["replay"]),
                      ("the true noise-free records", read_dataset(folder / "d_none"))):
        for cut in (False, True):
            src = bootstrap.windowed(ds, centres, bootstrap.PRECISION_MARGIN_HZ) if cut else ds
            for weights in (False, True):
                if args.only_precision and not (cut and weights):
                    continue
                fits = _scatter(src, kept, args.copies, seed, weights)
                sd = carried = (np.nan, np.nan)
                if len(fits) > 1:
                    sd = fits.std(axis=0, ddof=1)
                    carried = bootstrap.answer_sd(fits, slope)
                print(f"| {label} | {'yes' if cut else 'no'} | {'yes' if weights else 'no'} | "
                      f"{len(fits)} | {sd[0]:.4f} | {sd[1]:.4f} | {carried[0]:.4f} "
                      f"| {carried[1]:.4f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

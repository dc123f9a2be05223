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
        --stream precision --seed 7 --seed 11 --only-precision

``--stream precision`` adds the precision's own seed stream (the answer's ``Replay.seed``, stream
2), whose first ``precision_copies`` copies are the precision's to the digit; ``--seed`` (repeat
it) adds others; ``--only-precision`` fits only what the precision reads (cut, weighted). Last,
per seed, the copies the precision reads paired: the same noise on the replay and on the true
records, each one's sd of log delta, their ratio and correlation (a ratio below 1: the replay is
moved less by the noise than the structure, so the precision reads the noise narrow).
``--measured`` adds copies of the draw's own records (already noisy: noise on noise), paired the
same way: how far the noise moves the fit at the tested structure rather than at its replay.
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
    """The fits' log (kn, delta), (copies, 2), over ``copies`` noisy copies of ``dataset``,
    made and fitted by the precision's own loop (``bootstrap._copy_estimates``, ``kept``: what
    the precision was called with); NaN for a copy whose noise hides a jump or whose fit fails
    (so two data sets' copies from one seed stay paired)."""
    estimates = bootstrap._copy_estimates(
        dataset, kept["system"], kept["noise"], np.random.default_rng(seed), n=copies,
        theta_rep=kept["theta_rep"], extraction=kept["extraction"], fit=kept["fit"],
        point_weights=kept["point_weights"] if weights else None, desc="", progress=False)
    return np.asarray([np.log([e.kn, e.delta]) if e is not None and e.fit.success
                       else [np.nan, np.nan] for e in estimates])


def _sd(fits: np.ndarray, slope=None) -> np.ndarray:
    """sd of log (kn, delta) over the fitted copies (rows without NaN), carried through
    ``slope`` as the precision carries it (``answer_sd``; None: the identity)."""
    fits = fits[~np.isnan(fits).any(axis=1)]
    if len(fits) < 2:
        return np.array([np.nan, np.nan])
    return bootstrap.answer_sd(fits, slope)


def paired(copies: np.ndarray, truth: np.ndarray) -> dict:
    """Copies (of the replay, or of the measured records) against the true records' copies
    made with the same noise (the same seed): the fitted pairs, each side's sd of log delta,
    their ratio, the correlation of the pairs' log delta and the slope of the copies' on the
    truth's (1 where the copies are moved by the noise as the structure is)."""
    ok = ~(np.isnan(copies).any(axis=1) | np.isnan(truth).any(axis=1))
    c, t = copies[ok, 1] - copies[ok, 1].mean(), truth[ok, 1] - truth[ok, 1].mean()
    sd_c, sd_t = np.std(c, ddof=1), np.std(t, ddof=1)
    return {"pairs": int(ok.sum()), "sd_copies": sd_c, "sd_truth": sd_t, "ratio": sd_c / sd_t,
            "corr": float(np.corrcoef(c, t)[0, 1]), "slope": float(c @ t / (t @ t))}


def _paired_table(label: str, rows: list) -> None:
    """Print :func:`paired` per seed (``rows``: (seed, its dict)) and over all seeds."""
    print(f"\nThe precision's copies (cut, weighted): {label} against the true records, the "
          "same noise on each:\n")
    print("| noise seed | pairs | sd log delta: these | truth | ratio | correlation "
          "| slope on truth's |")
    print("|---|---|---|---|---|---|---|")
    for seed, r in rows:
        print(f"| {seed} | {r['pairs']} | {r['sd_copies']:.4f} | {r['sd_truth']:.4f} "
              f"| {r['ratio']:.2f} | {r['corr']:.2f} | {r['slope']:.2f} |")
    if len(rows) > 1:  # root mean square over the seeds
        sd_r = np.sqrt(np.mean([r["sd_copies"] ** 2 for _, r in rows]))
        sd_t = np.sqrt(np.mean([r["sd_truth"] ** 2 for _, r in rows]))
        print(f"| all | {sum(r['pairs'] for _, r in rows)} | {sd_r:.4f} | {sd_t:.4f} "
              f"| {sd_r / sd_t:.2f} | | |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case")
    ap.add_argument("--data", required=True, help="redraw.py's --out (with d_none)")
    ap.add_argument("--draw", default="d0")
    ap.add_argument("--copies", type=int, default=12)
    ap.add_argument("--seed", type=int, action="append",
                    help="a noise seed (repeat for more; default 7)")
    ap.add_argument("--stream", choices=("own", "precision"), default="own",
                    help="precision: the precision's own seed stream ([Replay.seed, 2]) first")
    ap.add_argument("--only-precision", action="store_true",
                    help="only the copies the precision reads (cut, weighted)")
    ap.add_argument("--measured", action="store_true",
                    help="also copies of the draw's own (noisy) records: noise on noise")
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
    seeds = ([[kept["seed"], 2]] if args.stream == "precision" else []) + (
        args.seed or ([] if args.stream == "precision" else [7]))
    slope = kept.get("binding_slope")
    print(f"the answer's binding slope "
          f"{'none' if slope is None else np.round(np.asarray(slope), 3).tolist()}")
    print("| records | cut to the points | weights | noise seed | fits | sd log kn | sd log delta "
          "| through the slope: sd log kn | sd log delta |")
    print("|---|---|---|---|---|---|---|---|---|")
    truth_label = "the true noise-free records"
    records = {"the answer's replay": kept["replay"], truth_label: read_dataset(folder / "d_none")}
    if args.measured:  # the draw's own records, already noisy: noise on noise
        records["the measured records"] = read_dataset(folder / args.draw)
    read = {}  # (records, the seed's place) -> fits, of the variant the precision reads
    for label, ds in records.items():
        for cut in (False, True):
            src = bootstrap.windowed(ds, centres, bootstrap.PRECISION_MARGIN_HZ) if cut else ds
            for weights in (False, True):
                if args.only_precision and not (cut and weights):
                    continue
                for k, seed in enumerate(seeds):
                    fits = _scatter(src, kept, args.copies, seed, weights)
                    if cut and weights:
                        read[label, k] = fits
                    sd, carried = _sd(fits), _sd(fits, slope)
                    print(f"| {label} | {'yes' if cut else 'no'} | {'yes' if weights else 'no'} "
                          f"| {seed} | {int((~np.isnan(fits).any(axis=1)).sum())} "
                          f"| {sd[0]:.4f} | {sd[1]:.4f} | {carried[0]:.4f} | {carried[1]:.4f} |",
                          flush=True)
    for label in records:
        if label != truth_label:
            _paired_table(label, [(seed, paired(read[label, k], read[truth_label, k]))
                                  for k, seed in enumerate(seeds)])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

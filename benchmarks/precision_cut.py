"""Whether the precision copies' cut reads the noise's mean move as the whole records do, with
ACMP's plain pursuit ("none") and with the locally weighted one that converges (the default).

    python benchmarks/precision_cut.py DATA [--copies 30] [--margins 2.5,10]

``identify`` measures how far the test's noise moves the answer on average (``noise_bias``) on
noisy copies of the answer's replay, each run cut to ``PRECISION_MARGIN_HZ`` (2.5 Hz) either side
of its point (``replay.bootstrap.windowed``), against the same cut replay read without noise. This
script asks whether the cut changes that move. It identifies DATA with the defaults, replays the
test at the answer (``replay.runs.replay_dataset``), and adds the same white noise (each
channel's level as ``identify`` measures it, ``record_noise``) to it once per copy. Each noisy
copy is read whole and cut at each margin, as the precision copies are: the statistic's rule and
point weights, the fit started at the noise-free reading's. Each reading's move is taken from
its own noise-free reading. The copies are paired (the same noise in every reading), so the
difference of two readings' moves is measured far more finely than either move. Prints one row
per reading: the mean move of log kn and log delta [%] with its standard error. The moves are the
statistic's, before the binding's slope carries them to the answer. First, per pursuit, the
noise-free readings themselves (delta's error against the answer replayed, whole and cut): with
a pursuit that stops before it converges they differ with the record's extent, and each move
is taken from one of them.
"""

from __future__ import annotations

import argparse
import contextlib
import io

import numpy as np

import freeplayid
from freeplayid.estimate import plain_estimate
from freeplayid.fit import FitOptions
from freeplayid.io import read_dataset
from freeplayid.replay.bootstrap import noisy_copy, point_centres, windowed
from freeplayid.replay.runs import replay_dataset
from freeplayid.replay.weights import record_noise
from freeplayid.signal import Extraction


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data", help="a data set (manifest.yaml's folder)")
    ap.add_argument("--copies", type=int, default=30)
    ap.add_argument("--margins", default="2.5,10", help="cuts [Hz] either side, comma-separated")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    margins = [float(m) for m in args.margins.split(",")]

    with contextlib.redirect_stderr(io.StringIO()):
        res = freeplayid.identify(args.data)
    rep = res.replay
    if rep is None or not rep.weights:
        raise SystemExit(f"{args.data}: no replay with point weights to compare")
    test = read_dataset(args.data)
    weights = {(p.run, p.channel): p.weight for p in rep.weights}
    replay = replay_dataset(test, res.system, rep.kn, rep.delta)
    noise = record_noise(test, replay)

    print(f"{args.data}: answer kn {rep.kn:.5g}, delta {rep.delta:.5g}; rule {rep.jump_point}; "
          f"{args.copies} paired copies")
    for weighting in ("none", "local"):
        compare(replay, res.system, rep, weights, noise, margins, weighting, args)


def compare(replay, system, rep, weights, noise, margins, weighting, args):
    """One pursuit's table (module docstring)."""
    ext = Extraction(jump_point=rep.jump_point, options={"if_weighting": weighting})
    fit = FitOptions()

    def read(ds, init):
        e = plain_estimate(ds, system, init=init, extraction=ext, fit=fit, point_weights=weights)
        return np.log([e.kn, e.delta]), e

    clean, est = read(replay, (rep.kn, rep.delta))
    start = (est.kn, est.delta)
    centres = point_centres(est.points.used())
    cut_clean = [read(windowed(replay, centres, m), start)[0] for m in margins]
    readings = [("whole", clean)] + [(f"+-{m:g} Hz", c) for m, c in zip(margins, cut_clean)]
    print(f"\n### if_weighting={weighting!r}\n\nnoise-free readings, delta's fit less the answer: "
          + ", ".join(f"{n} {100 * (np.exp(c[1]) / rep.delta - 1):+.3f} %" for n, c in readings))
    rng = np.random.default_rng(args.seed)  # the same copies for both pursuits
    whole, cut = [], [[] for _ in margins]
    for _ in range(args.copies):
        copy = noisy_copy(replay, noise, rng)
        whole.append(read(copy, start)[0] - clean)
        for j, m in enumerate(margins):
            cut[j].append(read(windowed(copy, centres, m), start)[0] - cut_clean[j])
    whole = 100 * np.asarray(whole)
    rows = [("whole records", whole)]
    rows += [(f"cut +-{m:g} Hz", 100 * np.asarray(c)) for m, c in zip(margins, cut)]
    rows += [(f"cut +-{m:g} Hz less whole", 100 * np.asarray(c) - whole)
             for m, c in zip(margins, cut)]
    print("\n| reading | move of log kn [%] | move of log delta [%] |\n|---|---|---|")
    for name, a in rows:
        se = a.std(axis=0, ddof=1) / np.sqrt(len(a))
        print(f"| {name} | {a[:, 0].mean():+.3f} ± {se[0]:.3f} | "
              f"{a[:, 1].mean():+.3f} ± {se[1]:.3f} |")


if __name__ == "__main__":
    main()

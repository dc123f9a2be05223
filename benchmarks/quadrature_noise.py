"""How far the test's noise moves the quadrature point: today's reading against the first one.

    python benchmarks/quadrature_noise.py --data outputs/realtests/data
    python benchmarks/quadrature_noise.py --data D --cases var5_finB_nominal,fin_nominal \\
        --noise 0.05,0.2 --draws 8

The replay's statistic on a data set with a base channel is the quadrature point of each run
(docs/signal.md section 6): where the response's first harmonic lags the base's by a quarter
period before the drop. Its frequency carries the answer, so its scatter under noise is the
answer's. Each case's noise-free records (``clean.npz`` of ``benchmarks/realtests/cases.py``,
an integrator that is not the package's) get ``--draws`` fresh draws of white noise on every
channel, base included, at each ``--noise`` level [g]; each draw's points are extracted with
``jump_point="quadrature"`` by two readings, in the same run:

- ``today``: the base's phase over the band the replay's excitation is read over (a quarter of
  the responses' where the base is noisy, ``freeplayid.signal.level.quiet_base``), the crossing
  the zero of a line fitted about the lag's first sign change;
- ``first``: the base's phase over the responses' band and the first sign change (the rule
  before 2026-11-30, rebuilt here by replacing those two functions in this process only).

Per level and reading, over every point (run x channel) the noise-free record gives: the
median and largest |mean shift| of its frequency from the noise-free point [Hz] (a bias the
replays, read without that noise, do not share), the median and largest standard deviation [Hz]
over the draws, and the median of the amplitude's relative standard deviation.
"""

from __future__ import annotations

import argparse
import dataclasses
import warnings
from pathlib import Path

import numpy as np

G0 = 9.80665


def _draw(ds0, clean, noise_g, rng):
    runs = []
    for k, run in enumerate(ds0.runs):
        acc = clean[f"accel_{k}"] / G0
        data = acc + rng.normal(0.0, noise_g, acc.shape)
        if run.data.shape != data.shape:
            data = data.T
        base = None if run.base is None else (
            clean[f"base_{k}"] / G0 + rng.normal(0.0, noise_g, run.base.shape))
        runs.append(dataclasses.replace(run, data=data, base=base))
    return dataclasses.replace(ds0, runs=tuple(runs))


def _points(ds):
    from freeplayid.estimate import extract_points
    from freeplayid.signal import Extraction

    pts, _ = extract_points(ds, extraction=Extraction(jump_point="quadrature"))
    return {(p.run, p.channel): (p.f_hz, p.amplitude_m) for p in pts.points if p.used}


def _first_reading():
    """Context: the quadrature point as first written (the responses' band for the base, the
    first sign change), in this process only."""
    import contextlib

    import freeplayid.signal.extract as extract
    import freeplayid.signal.peak as peak

    @contextlib.contextmanager
    def ctx():
        saved = extract.quiet_base, peak._fitted_crossing
        extract.quiet_base = lambda wide, narrow: wide
        peak._fitted_crossing = lambda c, first, **_: first
        try:
            yield
        finally:
            extract.quiet_base, peak._fitted_crossing = saved

    return ctx()


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="outputs/realtests/data",
                    help="benchmarks/realtests/cases.py --out")
    ap.add_argument("--cases", default="var5_finB_nominal,fin_nominal,var6_finC_nominal")
    ap.add_argument("--noise", default="0.05,0.2", help="white noise levels [g], comma-separated")
    ap.add_argument("--draws", type=int, default=8)
    ap.add_argument("--seed", type=int, default=1000)
    args = ap.parse_args(argv)
    warnings.filterwarnings("ignore")

    import contextlib

    from tqdm import tqdm

    from freeplayid.io import read_dataset

    cases = [c for c in args.cases.split(",") if c]
    levels = [float(v) for v in args.noise.split(",")]
    readings = {"today": contextlib.nullcontext, "first": _first_reading}
    rows = []
    bar = tqdm(total=len(cases) * len(levels) * (args.draws + 1) * len(readings),
               desc="extractions", unit="set")
    for case in cases:
        root = Path(args.data) / case
        if not (root / "clean.npz").is_file():
            raise SystemExit(f"{root / 'clean.npz'}: not found (run benchmarks/realtests/cases.py"
                             f" --out {args.data} first)")
        ds0 = read_dataset(root / "d0" / "manifest.yaml")
        if ds0.base_channel is None:
            raise SystemExit(f"{case}: no base channel, so no quadrature point")
        clean = dict(np.load(root / "clean.npz"))
        for noise in levels:
            for name, reading in readings.items():
                with reading():
                    ref = _points(_draw(ds0, clean, 0.0, np.random.default_rng(0)))
                    bar.update()
                    got = {}
                    for d in range(args.draws):
                        pts = _points(_draw(ds0, clean, noise,
                                            np.random.default_rng(args.seed + d)))
                        for key, v in pts.items():
                            got.setdefault(key, []).append(v)
                        bar.update()
                shift, sd, asd = [], [], []
                for key, (f0, a0) in ref.items():
                    v = np.array(got.get(key, []))
                    if v.shape[0] < max(3, args.draws // 2):  # lost in most draws: not a point
                        continue
                    shift.append(abs(v[:, 0].mean() - f0))
                    sd.append(v[:, 0].std(ddof=1))
                    asd.append(v[:, 1].std(ddof=1) / a0)
                rows.append((case, noise, name, len(shift), shift, sd, asd))
    bar.close()
    print(f"\n{args.draws} draws per level; per point (run x channel) of the noise-free records\n")
    print("| case | noise [g] | reading | points | \\|mean shift\\| median / max [Hz] | "
          "sd median / max [Hz] | amplitude sd median [%] |")
    print("|---|---|---|---|---|---|---|")
    for case, noise, name, n, shift, sd, asd in rows:
        if not n:
            print(f"| {case} | {noise:g} | {name} | 0 | – | – | – |")
            continue
        print(f"| {case} | {noise:g} | {name} | {n} | {np.median(shift):.4f} / "
              f"{np.max(shift):.4f} | {np.median(sd):.4f} / {np.max(sd):.4f} | "
              f"{100 * np.median(asd):.2f} |")


if __name__ == "__main__":
    main()

"""The drop point's amplitude window (``Extraction.drop_window``): its noise against its
sensitivity to the damping's form.

    python benchmarks/drop_window.py                          # beam and fin, windows 1 2 4
    python benchmarks/drop_window.py --structures fin --windows 1 3 --noise-g 0.2 --draws 16
    python benchmarks/drop_window.py --jump-point quadrature --draws 24   # the quadrature point's

The drop point (``jump_point="drop"``, the replays' statistic without a base channel) takes
its frequency where the curve drops, all but exact under white noise, and its amplitude from a
Gaussian window one filter time ahead of the drop; its noise is that amplitude's. A window
``w`` times as long, ``w`` filter times ahead, averages about ``w`` times as many samples, but
reads the upper branch further from the drop, where the forced response depends more on how
the structure is damped. The replay removes the point's bias only under its own damping, so
what a longer window gains in noise it may lose to a damping of another form.

Both are measured on the structures of ``benchmarks/binding_damping.py`` (one hinge's beam,
the default fin; four levels swept at 0.25 Hz/s, absolute acceleration at 256 Hz, sweep hints,
no base channel), with each window:

- the form shift: the plain fit of the drop points under modal, Rayleigh and hinge-dashpot
  damping of the same first-mode ratio; the largest difference between forms is the error a
  modal-damped replay could leave (binding slope 1);
- the noise: the modal-damped records with white noise of ``--noise-g`` on each channel,
  ``--draws`` draws; the standard deviation of the fit's log delta and log kn over the draws,
  and their mean's move from the noise-free fit (a bias the noise-free replays cannot see).

``--jump-point quadrature`` does the same for the quadrature point (the replays' statistic with a
base channel), whose amplitude ``drop_window`` reads over that many times the window about the
phase resonance; the base channel then gets the same noise (it gives the phase).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from binding_damping import FORMS, STRUCTURES, records  # noqa: E402
from freeplayid.estimate import plain_estimate  # noqa: E402
from freeplayid.fit import FitOptions  # noqa: E402
from freeplayid.quantity import G  # noqa: E402
from freeplayid.signal import Extraction  # noqa: E402
from freeplayid.simulate import sweep_dataset  # noqa: E402

SAMPLE_RATE = 256.0  # [Hz] as binding_damping.py and the compare studies' bank


def _fit(system, res, columns, window: float, kn: float, delta: float, noise=None,
         jump_point: str = "drop", base_noise=None) -> np.ndarray:
    """log (kn, delta) of the plain fit of the ``jump_point`` points, relative to the truth;
    ``base_noise`` (one row per run, in g) is added to the base channel."""
    ds = sweep_dataset(res, columns=columns, noise=noise)
    if base_noise is not None:
        ds = dataclasses.replace(ds, runs=tuple(
            dataclasses.replace(r, base=r.base + n[: r.base.shape[0]])
            for r, n in zip(ds.runs, base_noise, strict=True)))
    est = plain_estimate(ds, system, extraction=Extraction(jump_point=jump_point,
                                                           drop_window=window),
                         fit=FitOptions(), init=(kn, delta))
    return np.log([est.kn / kn, est.delta / delta])


def run(structure: str, windows, noise_g: float, draws: int, seed: int,
        jump_point: str = "drop") -> list[dict]:
    _, kn, delta, *_ = STRUCTURES[structure]
    rows = {w: {"structure": structure, "window": w, "forms": {}} for w in windows}
    for form in FORMS:
        t0 = time.perf_counter()
        system, res, columns = records(structure, form, SAMPLE_RATE)
        for w in windows:
            rows[w]["forms"][form] = _fit(system, res, columns, w, kn, delta,
                                          jump_point=jump_point)
        if form != "modal":
            continue
        shape = np.asarray(res.signals).shape
        rng = np.random.default_rng(seed)
        noises = [rng.normal(0.0, noise_g * G, shape) for _ in range(draws)]
        # the quadrature point reads the base's phase: a shaker test's base channel is as noisy
        # (in g; the data set's base is in g) as the responses
        bases = [rng.normal(0.0, noise_g, (shape[0], shape[-1])) if jump_point == "quadrature"
                 else None for _ in range(draws)]
        for w in windows:
            logs = np.array([_fit(system, res, columns, w, kn, delta, noise=n,
                                  jump_point=jump_point, base_noise=b)
                             for n, b in zip(noises, bases, strict=True)])
            rows[w]["sd"] = np.std(logs, axis=0, ddof=1)
            rows[w]["bias"] = logs.mean(axis=0) - rows[w]["forms"]["modal"]
        print(f"{structure}: {form} and {draws} noise draws, windows {list(windows)}: "
              f"{time.perf_counter() - t0:.0f} s", flush=True)
    return list(rows.values())


def table(rows: list[dict], noise_g: float, draws: int) -> str:
    lines = [f"| structure | window | {' | '.join(f'{f}: δ / kn [%]' for f in FORMS)} | "
             "shift between forms: δ / kn [points] | noise sd: δ / kn [%] | noise's mean move: "
             "δ / kn [%] |",
             "|---|---|" + "---|" * (len(FORMS) + 3)]
    for r in rows:
        f = {k: 100 * np.expm1(v) for k, v in r["forms"].items()}
        d = [v[1] for v in f.values()]
        k = [v[0] for v in f.values()]
        cells = " | ".join(f"{f[n][1]:+.2f} / {f[n][0]:+.2f}" for n in FORMS)
        lines.append(f"| {r['structure']} | {r['window']:g} | {cells} | {max(d) - min(d):.2f} / "
                     f"{max(k) - min(k):.2f} | {100 * r['sd'][1]:.2f} / {100 * r['sd'][0]:.2f} "
                     f"| {100 * r['bias'][1]:+.2f} / {100 * r['bias'][0]:+.2f} |")
    lines.append(f"\nNoise: {noise_g:g} g white on each channel at {SAMPLE_RATE:g} Hz, {draws} "
                 "draws, modal damping; standard deviations of log delta and log kn.")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--structures", nargs="+", default=list(STRUCTURES), choices=STRUCTURES)
    ap.add_argument("--windows", nargs="+", type=float, default=[1.0, 2.0, 4.0])
    ap.add_argument("--noise-g", type=float, default=0.3)
    ap.add_argument("--draws", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jump-point", choices=("drop", "quadrature"), default="drop",
                    help="the statistic: the drop point (no base channel) or the quadrature "
                    "point (with one; its noise then on the base channel too)")
    args = ap.parse_args()
    rows = []
    for s in args.structures:
        rows += run(s, args.windows, args.noise_g, args.draws, args.seed, args.jump_point)
    print()
    print(table(rows, args.noise_g, args.draws))


if __name__ == "__main__":
    main()

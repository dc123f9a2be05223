"""The network alone, side by side, where its training did not go: other noise levels, and
records another simulator made.

    PYTHONPATH=src python benchmarks/inverse_checks.py CKPT [CKPT ...] \
        [--values 0.05,0.15,0.25] [--realtests DIR] [--cache DIR]        # ~2 min + 10 s a record

CKPT: checkpoints of ``scripts/train.py`` for the default fin (e.g. one with the noise input and
one with ``network.noise_input=false``; a checkpoint from before the input works too).

1. **Noise levels never trained on**: from the first checkpoint's stored data-set configuration,
   its bank and a case set drawn for ``--values`` [g] (the same seed and split; cached under
   ``--cache``, where ``train.py``'s bank is found when it is the same folder); per checkpoint on
   the test split (kn never trained on): within 10 % δ / 25 % kn, median |errors|, the largest
   coverage gap, the SBC p-values, and per noise level the share of truths inside the central
   50 % interval of δ (0.50 when calibrated).
2. **Independent records** (``--realtests DIR``: the output of ``benchmarks/realtests/cases.py
   --out DIR``, the exact piecewise-linear integrator): every ``*/d*/manifest.yaml`` whose points
   are on the checkpoint's channels goes through ``identify``'s extraction (ACMP, its defaults)
   and the network; per record its errors and standardised errors z = ln(truth / estimate) /
   spread, then per checkpoint the share with |z| < 2 (0.95 when calibrated) and the median
   |errors|.
"""

from __future__ import annotations

import argparse
import glob
import sys
import warnings
from pathlib import Path

import numpy as np

from freeplayid.inverse import load_inverse_model
from freeplayid.inverse.calibration import calibration_metrics
from freeplayid.model import default_fin
from freeplayid.progress import progress_bar
from freeplayid.simulate import Sweep
from freeplayid.studies import BankSpec, CaseSpec, build_cases, simulate_bank, split_by_kn


def other_noise(models: dict, values: list[float], cache: str) -> None:
    first = next(iter(models.values()))
    d = first.extra["dataset"]
    bank_cfg = dict(d["bank"])
    bank_cfg["sweep"] = Sweep(**bank_cfg["sweep"])
    fin = default_fin()
    bank = simulate_bank(fin, BankSpec(channels=tuple(first.channels), **bank_cfg),
                         cache_dir=cache)
    cases_cfg = dict(d["cases"], values=tuple(values), axis="noise_g")
    ps = build_cases(bank, CaseSpec(**cases_cfg), cache_dir=cache)
    test = split_by_kn(ps, bank.spec.n_kn, tuple(d["split"]))[2]
    print(f"\n### Noise levels {values} g: {test.n_cases} test cases (kn never trained on)\n")
    print("| checkpoint | within 10 % / 25 % | median abs err δ / kn | largest gap kn / δ "
          "[points] | SBC p kn / δ (clustered) | central-50 % share of δ by noise |")
    print("|---|---|---|---|---|---|")
    for name, m in models.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            raw = m.predict(test, calibrated=False)
            cal = m.predict(test)
        ed, ek = np.abs(cal.delta / test.delta - 1), np.abs(cal.kn / test.kn - 1)
        met = m.calibration.metrics(test, raw) if m.calibration else \
            calibration_metrics(test, raw)
        z = np.log(test.delta / cal.delta) / cal.log_delta_std
        shares = " / ".join(
            f"{np.mean(np.abs(z[test.meta['noise_g'] == v]) < 0.6745):.2f}" for v in values)
        sbc = {p: met[p]["sbc"] for p in ("kn", "delta")}
        print(f"| {name} | {100 * np.mean((ed < 0.10) & (ek < 0.25)):.1f} % | "
              f"{100 * np.median(ed):.2f} / {100 * np.median(ek):.2f} % | "
              f"{100 * met['kn']['max_gap']:.1f} / {100 * met['delta']['max_gap']:.1f} | "
              + " / ".join(f"{sbc[p]['p_value']:.2g} ({sbc[p]['p_value_clustered']:.2g})"
                           for p in ("kn", "delta"))
              + f" | {shares} |")


def independent(models: dict, folder: str) -> None:
    from freeplayid.estimate import extract_points, point_rates, run_sweeps
    from freeplayid.fit import FittingPoints
    from freeplayid.inverse import point_sets_from_records
    from freeplayid.io.dataset_files import read_dataset
    from freeplayid.signal.options import Extraction

    manifests = sorted(glob.glob(str(Path(folder) / "*" / "d*" / "manifest.yaml")))
    if not manifests:
        sys.exit(f"--realtests {folder}: no */d*/manifest.yaml there (make them with "
                 "benchmarks/realtests/cases.py --out DIR)")
    chans = set(next(iter(models.values())).channels)
    rows, per = [], {n: [] for n in models}
    for man in progress_bar(manifests, desc="records", unit="record"):
        ds = read_dataset(man, check_model=False)
        pts, _ = extract_points(ds, extraction=Extraction())
        try:
            fp = FittingPoints.from_extraction(pts, dofs=ds.channels)
        except ValueError:  # fewer than 2 points
            continue
        if set(fp.channel) - chans:
            continue
        rate = point_rates(fp, run_sweeps(ds, pts, Extraction()))  # for a rate-input network
        kn, delta = ds.truth["kn"], ds.truth["delta"]
        cells = []
        for name, m in models.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                p = m.predict(point_sets_from_records(fp, m.channels,
                                                      rate=rate if m.uses_rate else None))
            e = (p.delta[0] / delta - 1, p.kn[0] / kn - 1)
            z = (np.log(delta / p.delta[0]) / p.log_delta_std[0],
                 np.log(kn / p.kn[0]) / p.log_kn_std[0])
            per[name].append((*e, *z))
            cells.append(f"{100 * e[0]:+.2f} / {100 * e[1]:+.2f} % (z {z[0]:+.1f} / {z[1]:+.1f})"
                         + (" outside" if p.outside[0] else ""))
        rel = Path(man).parent
        rows.append(f"| {rel.parent.name} {rel.name} | " + " | ".join(cells) + " |")
    print(f"\n### Independent records ({folder}): the network alone on identify's points\n")
    print("| record | " + " | ".join(f"{n}: δ / kn error (z)" for n in models) + " |")
    print("|---|" + "---|" * len(models))
    print("\n".join(rows))
    print("\n| checkpoint | records | abs z < 2: δ / kn | median abs error δ / kn |")
    print("|---|---|---|---|")
    for name, v in per.items():
        a = np.array(v)
        print(f"| {name} | {len(a)} | {np.mean(np.abs(a[:, 2]) < 2):.2f} / "
              f"{np.mean(np.abs(a[:, 3]) < 2):.2f} | {100 * np.median(np.abs(a[:, 0])):.2f} / "
              f"{100 * np.median(np.abs(a[:, 1])):.2f} % |")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("checkpoints", nargs="+")
    ap.add_argument("--values", default="0.05,0.15,0.25",
                    help="noise levels [g] of the other case set, comma-separated ('' skips)")
    ap.add_argument("--realtests", default=None, help="folder of benchmarks/realtests/cases.py")
    ap.add_argument("--cache", default="outputs/datasets")
    args = ap.parse_args()
    fin = default_fin()
    models = {}
    for path in args.checkpoints:
        name = Path(path).parent.name or path
        models[name if name not in models else path] = load_inverse_model(path, system=fin)
    for name, m in models.items():
        print(f"{name}: noise input {'yes' if m.norm.uses_noise else 'no'}")
    if args.values:
        other_noise(models, [float(v) for v in args.values.split(",")], args.cache)
    if args.realtests:
        independent(models, args.realtests)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""The network's out-of-domain warning on cases inside and outside its training prior.

    PYTHONPATH=src python benchmarks/inverse_domain.py CHECKPOINT [--cache DIR]   # ~2 min

CHECKPOINT: a calibrated checkpoint of ``scripts/train.py`` for the default fin. From the data-set
configuration stored in it, three small banks are simulated (cached under ``--cache``) with the
training bank's sweep, levels and extraction but other kn: inside the prior (the middle tenth of
its log range), just inside its ends, and outside it (kn 2000 N·m/rad, and 150). Their cases
(4 kn x the study's axis values, one draw each) go through ``predict``; the table gives, per bank,
how many cases were warned of (``InverseDomainWarning``) and the network's median |kn| error.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

from freeplayid.errors import InverseDomainWarning
from freeplayid.inverse import load_inverse_model
from freeplayid.model import default_fin
from freeplayid.simulate import Sweep
from freeplayid.studies import BankSpec, CaseSpec, build_cases, simulate_bank


def banks(prior: tuple[float, float]) -> dict[str, tuple[float, float]]:
    lo, hi = np.log(prior)
    mid = 0.5 * (lo + hi)
    span = hi - lo
    return {
        "inside: the prior's middle": (float(np.exp(mid - 0.05 * span)),
                                       float(np.exp(mid + 0.05 * span))),
        "inside: near its ends": (float(np.exp(lo + 0.02 * span)),
                                  float(np.exp(hi - 0.02 * span))),
        "outside: kn 2000": (1900.0, 2100.0),
        "outside: kn 150": (140.0, 160.0),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("checkpoint")
    ap.add_argument("--cache", default="outputs/datasets")
    args = ap.parse_args()
    fin = default_fin()
    model = load_inverse_model(args.checkpoint, system=fin)
    if model.calibration is None:
        sys.exit(f"{args.checkpoint}: no calibration record (train it with scripts/train.py)")
    d = model.extra["dataset"]
    bank = dict(d["bank"])
    bank["sweep"] = Sweep(**bank["sweep"])
    prior = tuple(bank["kn_range"])
    cases = dict(d["cases"], cases_per_value=1)
    print(f"training prior kn {prior[0]:g}-{prior[1]:g} N·m/rad\n")
    print("| bank | kn [N·m/rad] | cases | warned | network median abs kn err |")
    print("|---|---|---|---|---|")
    for name, rng in banks(prior).items():
        spec = BankSpec(channels=model.channels, **{**bank, "kn_range": rng, "n_kn": 4})
        b = simulate_bank(fin, spec, cache_dir=Path(args.cache), progress=False)
        ps = build_cases(b, CaseSpec(**cases), cache_dir=Path(args.cache), progress=False)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InverseDomainWarning)
            pred = model.predict(ps)
        warned = sum(bool(w) for w in pred.outside)
        err = np.median(np.abs(pred.kn / ps.kn - 1))
        print(f"| {name} | {rng[0]:.0f}–{rng[1]:.0f} | {ps.n_cases} | {warned} | "
              f"{100 * err:.1f} % |")
        reasons = [w for w in pred.outside if w]
        if reasons:
            print(f"|  | e.g. | | | {reasons[0][:140]} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

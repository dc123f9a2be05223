"""Is the verdict's precision calibrated? The answers' errors on a compare study's cases against
the half-width that the precision's noisy copies give, with and without the binding's slope.

    python benchmarks/noise_precision.py                       # the noise study, 0.1-0.3 g
    python benchmarks/noise_precision.py --experiment clearance --cases 0,1,2

Each case of the study (the same seeded plan and picked cases as ``scripts/compare.py
+experiment=... compare.corrected_cases_per_value=12``; the bank is simulated, or read from
``outputs/datasets`` where a compare study ran in this folder) is rebuilt with its own noise draw
(:func:`freeplayid.studies.cases.rebuild_case`) and identified as ``multi-start+corrected``
does (the replays started from the statistic's fit). Per case: the errors, the precision's δ
half-width as reported (carried through the binding's slope where the loop measured one) and the
copies' own, their ratio, the chance that ``noise_precision`` reads and the verdict. Last line:
the RMS of z = log(1 + error) / (half-width / 1.96) over the noisy cases, for both half-widths (1
for a calibrated precision). Two processes (``--jobs``); about 30 s per case on 2 cores.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--experiment", default="noise", choices=["noise", "clearance"])
    ap.add_argument("--cases", default="", help="comma-separated case indices (default: all "
                    "the study's corrected cases whose noise is not 0)")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)

    from hydra import compose, initialize_config_dir
    from joblib import Parallel, delayed

    import freeplayid
    from freeplayid.studies import pick_cases, simulate_bank
    from freeplayid.studies.cases import plan_cases, rebuild_case
    from freeplayid.tasks.common import study_data, study_specs
    from freeplayid.tasks.options import options_from_config

    conf = Path(freeplayid.__file__).parent / "conf"
    with initialize_config_dir(str(conf), version_base="1.3"):
        cfg = compose("compare", overrides=[f"+experiment={args.experiment}",
                                            "compare.corrected_cases_per_value=12"])
    fit = options_from_config(cfg, "fit")
    data = study_data(cfg, progress=False)
    bank_spec, case_spec, _, cache_dir = study_specs(cfg, data.system)
    test = data.test.subset(pick_cases(data.test, int(cfg.compare.cases_per_value)))
    bank = simulate_bank(data.system, bank_spec, cache_dir=cache_dir, progress=True)
    plan = plan_cases(bank, case_spec)
    if args.cases:
        cases = [int(c) for c in args.cases.split(",")]
    else:
        cases = [int(i) for i in pick_cases(test, int(cfg.compare.corrected_cases_per_value))
                 if float(test.meta["noise_g"][i]) > 0]
    from freeplayid.replay import Replay
    from freeplayid.signal import Extraction

    ext = Extraction(**{**case_spec.extraction, "use_sweep_hint": True})

    def one(i):
        ds = rebuild_case(bank, case_spec, test, i, plan=plan)
        res = freeplayid.identify(ds, system=data.system, extraction=ext, fit=fit,
                                  replay=Replay(start="statistic"),
                                  progress=False)
        p = res.replay.precision
        check = {c.name: c for c in res.verdict.checks}.get("noise_precision")
        return dict(case=i, noise=float(test.meta["noise_g"][i]),
                    de=res.delta / float(test.delta[i]) - 1, ke=res.kn / float(test.kn[i]) - 1,
                    hw=None if p is None else p.delta_halfwidth,
                    own=None if p is None else (p.statistic_halfwidths or
                                                (p.kn_halfwidth, p.delta_halfwidth))[1],
                    chance=None if check is None else check.value, verdict=res.verdict.status,
                    replays=len(res.replay.iterations))

    rows = Parallel(n_jobs=args.jobs, batch_size=1)(delayed(one)(i) for i in cases)
    print("| case | noise [g] | δ err [%] | kn err [%] | δ half-width [%] | copies' own [%] | "
          "factor | chance [%] | verdict | replays |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    z = {"hw": [], "own": []}
    for r in rows:
        if r["hw"] is None:
            print(f"| {r['case']} | {r['noise']:g} | {100 * r['de']:+.2f} | {100 * r['ke']:+.2f} "
                  f"| – | – | – | – | {r['verdict']} | {r['replays']} |")
            continue
        factor = math.log1p(r["hw"]) / math.log1p(r["own"]) if r["own"] > 0 else float("nan")
        print(f"| {r['case']} | {r['noise']:g} | {100 * r['de']:+.2f} | {100 * r['ke']:+.2f} | "
              f"{100 * r['hw']:.2f} | {100 * r['own']:.2f} | {factor:.2f} | "
              f"{100 * (r['chance'] or 0):.1f} | {r['verdict']} | {r['replays']} |")
        if r["noise"] > 0:
            for key in z:
                z[key].append(math.log1p(r["de"]) / (math.log1p(r[key]) / 1.96))
    if z["hw"]:
        rms = {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in z.items()}
        print(f"\nRMS of δ's error over its precision (noisy cases, {len(z['hw'])}): "
              f"{rms['hw']:.2f} as reported (through the binding's slope), {rms['own']:.2f} "
              "from the copies' own spread (1: calibrated)")


if __name__ == "__main__":
    main()

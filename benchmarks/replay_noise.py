"""The corrected fit on noisy tests like the compare studies': which statistic the replays match.

    python benchmarks/replay_noise.py                     # 16 cases (about 40 min on 2 cores)
    python benchmarks/replay_noise.py --variants weighted weighted_before   # drop point windows
    python benchmarks/replay_noise.py --variants smoothed drop weighted   # statistics
    python benchmarks/replay_noise.py --cases 3 --jobs 1  # smoke run
    python benchmarks/replay_noise.py --from runs/noise/cases.jsonl   # the table again, no rerun

Every case is drawn like a case of the compare studies (``freeplayid/conf/dataset/sim.yaml``): the
default fin with its own damping, kn log-uniform in [300, 800] N m/rad, delta log-uniform in [1, 5]
mrad, 3-6 up-sweeps 30 -> 56 Hz at 0.1 Hz/s with level / delta log-uniform in [150, 700] g/rad,
relative accelerations of the two measure points at 256 Hz, simulated by the RK4 engine in float32
(as the study banks), with white noise of 0.1, 0.2 or 0.3 g (cycling) on every channel.
The identification gets each run's ``level_g`` and sweep hint and the lock-in extraction (as
the compare task's corrected rows) and starts its fit 5 % off the truth (as from the network).

Each case runs the plain fit and corrected fits (the default replay) that differ only in the
statistic the replays match: "smoothed" (the plain fit's points: the maximum of the smoothed
curve, every point the same weight), "drop" (the frequency where the curve drops, the amplitude
just ahead of it; every point the same weight) and "weighted" (the drop points, each weighted by
its amplitude noise: the default of ``identify``); "weighted_before" is "weighted" with the drop
points read off the smoothed curve alone (``jump_point="drop_smoothed"``, the statistic before
the drop point's windows stopped at the drop). A drawn case whose usable points lie at one
resonance is left out (counted under the table). A case succeeds when |delta error| < 1 % and
|kn error| < 2 %; an interval (Jacobian, moved with the estimate) covers when it holds the truth.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

SWEEP = (30.0, 56.0, 0.1)  # start [Hz], stop [Hz], rate [Hz/s] (freeplayid/conf/dataset/sim.yaml)
SAMPLE_RATE = 256.0  # [Hz]
NOISE_G = (0.1, 0.2, 0.3)  # [g] white noise std (the noise study's nonzero levels)
# variant -> (replay_jump_point, replay_weighted); "weighted_before": the weighted drop points
# read off the smoothed curve alone (jump_point="drop_smoothed", the statistic before the drop
# point's windows stopped at the drop)
VARIANTS = {"smoothed": ("smoothed", False), "drop": ("drop", False), "weighted": ("drop", True),
            "weighted_before": ("drop_smoothed", True)}
RULES = ("drop", "weighted")  # the variants run by default (--variants)


def draw_cases(n: int, seed: int) -> list[dict]:
    rng = np.random.default_rng(seed)
    cases = []
    for i in range(n):
        kn = float(np.exp(rng.uniform(np.log(300.0), np.log(800.0))))
        delta = float(np.exp(rng.uniform(np.log(1e-3), np.log(5e-3))))
        runs = int(rng.integers(3, 7))
        ratios = np.sort(np.exp(rng.uniform(np.log(150.0), np.log(700.0), runs)))
        cases.append({"case": i, "kn": kn, "delta": delta, "noise_g": NOISE_G[i % len(NOISE_G)],
                      "levels": [float(r * delta) for r in ratios],
                      "noise_seed": int(rng.integers(2**31))})
    return cases


def make_dataset(case: dict):
    import torch

    from freeplayid.io import Dataset, Run
    from freeplayid.model import default_fin
    from freeplayid.quantity import G
    from freeplayid.simulate import Sweep, simulate_sweeps

    fin = default_fin()
    channels = [d for d in fin.dof_names if d.startswith("uz_")]
    n = len(case["levels"])
    sweep = Sweep(*SWEEP)
    res = simulate_sweeps(fin, kn=[case["kn"]] * n, delta=[case["delta"]] * n,
                          level_g=case["levels"], sweep=sweep, channels=channels,
                          quantity="acceleration", frame="relative", sample_rate=SAMPLE_RATE,
                          dtype=torch.float32, engine="numba", progress=False)
    sig = np.asarray(res.signals, dtype=float)
    sig = sig + np.random.default_rng(case["noise_seed"]).normal(0.0, case["noise_g"] * G,
                                                                 sig.shape)
    t = np.arange(sig.shape[-1]) / SAMPLE_RATE
    runs = tuple(Run(file=f"run{m}", time=t, data=sig[m], level_g=lv, sweep=sweep.to_dict())
                 for m, lv in enumerate(case["levels"]))
    return fin, Dataset(name=f"case {case['case']}", model=None, quantity="acceleration",
                        units="m/s^2", sample_rate=SAMPLE_RATE,
                        channels={c: c for c in channels}, runs=runs,
                        truth={"kn": case["kn"], "delta": case["delta"]}, frame="relative")


def run_case(case: dict, rules=RULES) -> dict:
    from freeplayid import identify

    row = {k: case[k] for k in ("case", "kn", "delta", "noise_g")}
    row["runs"] = len(case["levels"])
    fin, ds = make_dataset(case)
    init = (1.05 * case["kn"], 0.95 * case["delta"])
    for rule in rules:
        jump_point, weighted = VARIANTS[rule]
        try:
            res = identify(ds, system=fin, fit={"init": init}, progress=False,
                           extraction={"method": "lockin", "use_sweep_hint": True},
                           replay={"jump_point": jump_point, "weighted": weighted})
        except ValueError as err:  # no usable points: a failed case for both rules
            row[f"{rule}_failure"] = str(err)[:200]
            continue
        r = res.replay
        covers = lambda v, ci: bool(ci[0] <= v <= ci[1])  # noqa: E731
        row.update({"kn_err_plain": res.plain_fit.kn / case["kn"] - 1,
                    "delta_err_plain": res.plain_fit.delta / case["delta"] - 1,
                    f"{rule}_kn_err": res.kn / case["kn"] - 1,
                    f"{rule}_delta_err": res.delta / case["delta"] - 1,
                    f"{rule}_kn_cover": covers(case["kn"], res.kn_ci95),
                    f"{rule}_delta_cover": covers(case["delta"], res.delta_ci95),
                    f"{rule}_verdict": res.verdict.status,
                    f"{rule}_replays": len(r.iterations),
                    f"{rule}_points": len(res.points.used())})
    return row


def summarise(rows: list[dict], rules=RULES) -> str:
    """The table over the cases the plain fit could identify (the compare studies drop a case
    whose points lie at fewer than two resonances too)."""
    failed = [r for r in rows if "delta_err_plain" not in r]
    rows = [r for r in rows if "delta_err_plain" in r]
    lines = ["| estimate | cases | success (δ < 1 %, kn < 2 %) | median abs δ err | "
             "95th pct abs δ err | median abs kn err | δ CI covers | kn CI covers | verdict ok |",
             "|---|---|---|---|---|---|---|---|---|"]
    n = len(rows)

    def line(label, dk, kk, prefix=None):
        d = np.array([r.get(dk, math.nan) for r in rows], float)
        k = np.array([r.get(kk, math.nan) for r in rows], float)
        ok = np.isfinite(d) & np.isfinite(k)
        succ = np.sum(ok & (np.abs(d) < 0.01) & (np.abs(k) < 0.02)) / n
        cov = lambda key: (f"{100 * np.mean([bool(r.get(key)) for r in rows]):.0f} %"  # noqa: E731
                           if prefix else "–")
        verdict = (f"{sum(r.get(prefix + 'verdict') == 'ok' for r in rows)} / {n}"
                   if prefix else "–")
        lines.append(
            f"| {label} | {n} | {100 * succ:.0f} % | {100 * np.nanmedian(np.abs(d)):.2f} % | "
            f"{100 * np.nanpercentile(np.abs(d), 95):.2f} % | "
            f"{100 * np.nanmedian(np.abs(k)):.2f} % | "
            f"{cov((prefix or '') + 'delta_cover')} | {cov((prefix or '') + 'kn_cover')} | "
            f"{verdict} |")

    line("plain fit", "delta_err_plain", "kn_err_plain")
    labels = {"smoothed": "`smoothed` points", "drop": "`drop` points",
              "weighted": "`drop` points, weighted"}
    for rule in rules:
        line(f"corrected, replays match {labels[rule]}", f"{rule}_delta_err",
             f"{rule}_kn_err", prefix=f"{rule}_")
    by_noise = []
    for g in NOISE_G:
        sel = [r for r in rows if r["noise_g"] == g]
        if sel:
            med = {rule: np.nanmedian([abs(r.get(rule + "_delta_err", math.nan)) for r in sel])
                   for rule in rules}
            by_noise.append(f"{g:g} g: " + ", ".join(
                f"{rule} median abs δ {100 * m:.2f} %" for rule, m in med.items())
                + f" ({len(sel)} cases)")
    dropped = (f"{len(failed)} drawn case(s) without two usable resonances left out"
               if failed else "")
    return "\n".join(lines + [""] + by_noise + ([dropped] if dropped else []))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=16)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--variants", nargs="+", choices=sorted(VARIANTS), default=list(RULES),
                    help="statistics of the corrected fits (default: drop weighted)")
    ap.add_argument("--out", default=None, help="folder for cases.jsonl and table.md")
    ap.add_argument("--from", dest="source", default=None, metavar="JSONL",
                    help="summarise an earlier run's cases.jsonl instead of running")
    args = ap.parse_args()
    if args.source:
        rows = [json.loads(x) for x in Path(args.source).read_text().splitlines() if x.strip()]
        print(summarise(rows, [v for v in VARIANTS if any(v + "_delta_err" in r
                                                          for r in rows)]))
        return
    out = Path(args.out) if args.out else None
    if out:
        out.mkdir(parents=True, exist_ok=True)
        (out / "cases.jsonl").write_text("")
    rows = []
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        cases = draw_cases(args.cases, args.seed)
        for row in pool.map(run_case, cases, [tuple(args.variants)] * len(cases)):
            rows.append(row)
            if out:  # one line per finished case: an interrupted run keeps what it did
                with open(out / "cases.jsonl", "a") as fh:
                    fh.write(json.dumps(row) + "\n")
            print(f"case {row['case']}: noise {row['noise_g']:g} g, {row['runs']} runs; delta err "
                  + ", ".join(f"{rule} {100 * row.get(rule + '_delta_err', math.nan):+.2f} %"
                              for rule in args.variants)
                  + f" (plain {100 * row.get('delta_err_plain', math.nan):+.2f} %)",
                  file=sys.stderr, flush=True)
    table = summarise(rows, tuple(args.variants))
    print(table)
    if out:
        (out / "table.md").write_text(table + "\n")


if __name__ == "__main__":
    main()

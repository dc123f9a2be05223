"""How smoothly the replayed fit follows (kn, delta): the binding function's jitter.

    python benchmarks/binding_jitter.py                  # held-out cases 2 (2 %) and 3 (5 %)
    python benchmarks/binding_jitter.py --cases 0 1 2 3 --engines expo numba
    python benchmarks/binding_jitter.py --rules drop     # the replay's statistic only

The corrected fit solves theta_rep(theta) = theta_hat (:mod:`freeplayid.replay`) and stops when
(kn, delta) move by less than 0.05 % between replays. That needs theta_rep, the fit of the
replayed test, to move smoothly with theta on that scale. This benchmark measures whether it
does, and where it does not, which step of replay -> extraction -> fit makes it jump.

For each case of the held-out study (``benchmarks/replay_study.py``: the default fin, modal
damping of 2 % or 5 % and no C in the model file, four 0.5 Hz/s up-sweeps, no base channel, no
sweep hints, relative accelerations with 0.5 % noise), the test is replayed at the true
(kn, delta, zeta) with the sweep laws and levels the corrected fit would use, and the replay is
extracted with the statistic's rule (``jump_point="drop"``, the laws as hints) and fitted from
the truth. Then, each against that reference:

* "record + noise e": the reference replay's records plus white noise of e times each record's
  peak, extracted and fitted again (the extraction and fit alone: a smooth chain moves by
  about e);
* "kn x (1 + e)", "delta x (1 + e)": the test replayed again at the perturbed parameter, for
  each simulator engine (the whole chain: a smooth binding moves by about e).

Each replay is extracted with each jump-point rule of ``--rules``: ``drop`` (the replay's
statistic: windows that stop at the drop) and ``drop_smoothed`` (the rule before it: the
smoothed curve's crossing and its value ahead, whose filter reaches the grazing transient after
the drop), side by side on the same records.

Columns: the change of the replayed fit's log kn and log delta, and the largest change of any
point's frequency and amplitude (log, %). Under the table: the binding's jitter, the RMS of
the perturbed replays' log-parameter changes (perturbations of <= 0.05 %: a smooth binding
would stay below ~0.05 %).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import replay_study  # noqa: E402  (the held-out study's cases, same seed)

RECORD_NOISE = (1e-6, 1e-5, 1e-4)  # white noise std / record peak added to the replay
PERTURBATIONS = (1e-4, 2e-4, 5e-4)  # relative parameter changes


def fitted(dataset, system, theta, rule: str) -> np.ndarray:
    """log(kn, delta, point frequencies, point amplitudes) of the statistic's fit."""
    from freeplayid import identify

    res = identify(dataset, system=system, fit={"init": tuple(theta)}, progress=False,
                   extraction={"jump_point": rule, "use_sweep_hint": True}, replay=None)
    pts = res.points.used()
    return np.log(np.array([res.kn, res.delta] + [p.f_hz for p in pts]
                           + [p.amplitude_m for p in pts]))


def run_case(index: int, seed: int, engines: list[str], rules: list[str]) -> list[tuple]:
    from freeplayid import replay as rp
    from freeplayid.model import default_fin
    from freeplayid.replay.runs import with_sweep_hints

    case = replay_study.draw_cases(max(index + 1, 50), seed)[index]
    records = replay_study.simulate_case(case)
    measured = replay_study.make_dataset(case, records, seed)
    system = default_fin().replace(C=None)
    laws = rp.replay_sweeps(measured)
    levels = rp.replay_levels(measured, laws)
    stat_ds = with_sweep_hints(measured, laws)
    damped = rp.damped_system(system, case["zeta"], case["kn"])
    theta = np.array([case["kn"], case["delta"]])
    label = f"case {index} (zeta {case['zeta']:.0%})"
    rows = []

    def row(name, engine, rule, eps, values, ref, t):
        d = 100 * (values - ref)
        n = (d.size - 2) // 2
        rows.append((label, name, engine, rule, eps, d[0], d[1], np.max(np.abs(d[2:2 + n])),
                     np.max(np.abs(d[2 + n:])), t))
        print(f"| {label} | {name} | {engine} | {rule} | {d[0]:+.4f} | {d[1]:+.4f} | "
              f"{rows[-1][7]:.5f} | {rows[-1][8]:.4f} | {t:.0f} s |", flush=True)

    rng = np.random.default_rng(seed)
    for engine in engines:
        t0 = time.perf_counter()
        ref_ds = rp.replay_dataset(stat_ds, damped, *theta, levels=levels, sweeps=laws,
                                   engine=engine)
        t_sim = time.perf_counter() - t0
        refs = {}
        for rule in rules:
            t0 = time.perf_counter()
            refs[rule] = fitted(ref_ds, system, theta, rule)
            row("reference", engine, rule, 0.0, refs[rule], refs[rule],
                t_sim + time.perf_counter() - t0)
        if engine == engines[0]:
            for e in RECORD_NOISE:
                runs = tuple(dataclasses.replace(
                    r, data=r.data + e * np.abs(r.data).max(axis=-1, keepdims=True)
                    * rng.standard_normal(r.data.shape)) for r in ref_ds.runs)
                noisy_ds = dataclasses.replace(ref_ds, runs=runs)
                for rule in rules:
                    t0 = time.perf_counter()
                    row(f"record + noise {e:.0e}", engine, rule, e,
                        fitted(noisy_ds, system, theta, rule), refs[rule],
                        time.perf_counter() - t0)
        for k, name in ((0, "kn"), (1, "delta")):
            for e in PERTURBATIONS:
                t0 = time.perf_counter()
                th = theta.copy()
                th[k] *= 1 + e
                rep = rp.replay_dataset(stat_ds, damped, *th, levels=levels, sweeps=laws,
                                        engine=engine)
                t_sim = time.perf_counter() - t0
                for rule in rules:
                    t0 = time.perf_counter()
                    row(f"{name} x (1 + {e:.0e})", engine, rule, e,
                        fitted(rep, system, th, rule), refs[rule],
                        t_sim + time.perf_counter() - t0)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, nargs="+", default=[2, 3],
                    help="held-out study case numbers (even: 2 %% damping, odd: 5 %%)")
    ap.add_argument("--seed", type=int, default=7, help="the held-out study's seed")
    ap.add_argument("--engines", nargs="+", default=["expo"],
                    help="simulator engines of the replays (expo: the replay's default; numba: "
                         "RK4, about 220 s per replay)")
    ap.add_argument("--rules", nargs="+", default=["drop", "drop_smoothed"],
                    help="jump-point rules of the statistic, each on the same replays")
    args = ap.parse_args()
    print("| case | change | engine | rule | d log kn_rep [%] | d log delta_rep [%] | "
          "max d log f point [%] | max d log A point [%] | time |")
    print("|---|---|---|---|---|---|---|---|---|")
    rows = []
    for index in args.cases:
        rows += run_case(index, args.seed, args.engines, args.rules)
    print()
    for label in dict.fromkeys(r[0] for r in rows):
        for engine in args.engines:
            for rule in args.rules:
                mine = [r for r in rows if r[0] == label and r[2] == engine and r[3] == rule]
                sel = [r for r in mine if " x " in r[1]]
                noise = [r for r in mine if "noise" in r[1]]
                if not sel:
                    continue
                jit = np.sqrt(np.mean([[r[5] ** 2, r[6] ** 2] for r in sel], axis=0))
                line = (f"{label}, {engine}, {rule}: binding jitter (RMS over parameter changes "
                        f"of {min(PERTURBATIONS):.0e}-{max(PERTURBATIONS):.0e}) kn_rep "
                        f"{jit[0]:.4f} %, delta_rep {jit[1]:.4f} %")
                if noise:
                    worst = max(max(abs(r[5]), abs(r[6])) for r in noise)
                    line += (f"; extraction + fit under record noise <= {max(RECORD_NOISE):.0e}:"
                             f" <= {worst:.4f} %")
                print(line)


if __name__ == "__main__":
    main()

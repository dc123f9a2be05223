"""`compare` task: inverse-initialised fitting against pure fitting on held-out simulated cases.

Per value of the ablation axis (noise level or clearance): the network alone, the fit started
from the network's estimate, a single-start fit from the centre of the priors and the
multi-start baseline, on the same test cases (kn values never seen in training); on
``compare.corrected_cases_per_value`` of them per value also the bias-corrected fit (replay)
started from the network and from the multi-start grid, their records rebuilt from the bank.
Writes ``compare.csv`` (one row per case and method), ``compare.md`` (the summary table, and
every method on the corrected cases alone), ``compare_errors.png``, ``compare_cost.png`` and
``metrics.json``, all or none (``staged_folder``), after checking the whole configuration.
"""

from __future__ import annotations

import csv
import time
from pathlib import Path

import numpy as np
from omegaconf import DictConfig, OmegaConf

from ..atomic import staged_folder
from ..errors import InputError
from .checks import COMPARE, check_config
from .common import run_dir, study_data, study_specs, train_network, write_metrics, writing_to

__all__ = ["compare"]


def _pick(test, per_value: int) -> np.ndarray:
    """Up to ``per_value`` test cases per axis value, spread over the kn values."""
    axis = test.meta["axis_value"]
    keep = []
    for v in np.unique(axis):
        idx = np.flatnonzero(axis == v)
        take = np.unique(np.linspace(0, idx.size - 1, min(per_value, idx.size)).round().astype(int))
        keep.extend(idx[take].tolist())
    return np.array(sorted(keep), dtype=int)


def _markdown(summary: list[dict], axis: str, bounds: dict, *, lead: bool = True) -> str:
    unit = "g" if axis == "noise_g" else "mrad"
    scale = 1.0 if axis == "noise_g" else 1e3
    head = (f"| {axis.replace('_g', '')} [{unit}] | method | cases | δ err median / p95 [%] | "
            f"kn err median / p95 [%] | success [%] | evaluations | wall [s] |")
    lines = [
        f"Success: |δ error| < {100 * bounds['delta']:g} % and |kn error| < "
        f"{100 * bounds['kn']:g} %. Errors are absolute relative errors on held-out kn values; "
        "evaluations count objective (residual vector) calls, Jacobians included (a corrected "
        "fit: its plain fit's and every replay's refit).", "",
    ] if lead else []
    lines += [head, "|---|---|---|---|---|---|---|---|"]
    for r in summary:
        lines.append(
            f"| {scale * r['axis_value']:g} | {r['method']} | {r['n']} | "
            f"{100 * r['delta_err_median']:.3g} / {100 * r['delta_err_p95']:.3g} | "
            f"{100 * r['kn_err_median']:.3g} / {100 * r['kn_err_p95']:.3g} | "
            f"{100 * r['success_rate']:.0f} | {r['evaluations_mean']:.0f} | "
            f"{r['wall_s_mean']:.3f} |"
        )
    return "\n".join(lines) + "\n"


def _figures(out: Path, rows: list[dict], summary: list[dict], axis: str) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..plots import plot_compare_cost, plot_compare_errors

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, q in zip(axes, ("delta", "kn"), strict=True):
        plot_compare_errors(ax, rows, quantity=q, axis_name=axis)
    fig.tight_layout()
    fig.savefig(out / "compare_errors.png", dpi=110)
    plt.close(fig)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.0))
    plot_compare_cost(axes[0], summary, key="success_rate", axis_name=axis)
    plot_compare_cost(axes[1], summary, key="evaluations_mean", axis_name=axis)
    fig.tight_layout()
    fig.savefig(out / "compare_cost.png", dpi=110)
    plt.close(fig)
    return ["compare_errors.png", "compare_cost.png"]


def compare(cfg: DictConfig) -> dict:
    """Run the comparison study; write the tables, figures and ``metrics.json``.

    Returns
    -------
    dict
        The metrics: the summary per axis value and method, and the acceptance figures
        (network-alone share within bounds, success rates, evaluation ratio).
    """
    from hydra.utils import to_absolute_path

    from ..inverse import load_inverse_model

    t0 = time.perf_counter()
    check_config(cfg, COMPARE)  # every field, before any work
    out = run_dir()
    ckpt = None
    if cfg.inverse.checkpoint:
        ckpt = Path(to_absolute_path(str(cfg.inverse.checkpoint)))
        load_inverse_model(ckpt)  # a missing or foreign file fails before the data set is built
    with staged_folder(out) as stage:
        return _compare(cfg, stage, out, ckpt, t0)


def _compare(cfg: DictConfig, stage: Path, out: Path, ckpt: Path | None, t0: float) -> dict:
    from ..fit import multistart_grid
    from ..inverse import load_inverse_model
    from ..studies import (
        CORRECTED,
        METHODS,
        corrected_cases,
        fit_cases,
        network_rows,
        simulate_bank,
        summarise,
    )

    data = study_data(cfg)
    n_corrected = int(cfg.compare.corrected_cases_per_value)
    bank_spec, case_spec, _, cache_dir = study_specs(cfg, data.system)
    if n_corrected and "plan_index" not in data.test.meta:  # before any long work
        raise InputError(
            f"the cached cases {str(cache_dir / f'cases-{data.cases_key}')!r} predate "
            "meta['plan_index'], which the corrected fits need to rebuild their records; delete "
            "that folder to rebuild it, or set compare.corrected_cases_per_value=0")
    if ckpt is None:
        print("no inverse.checkpoint given: training one on the cached data set")
        model = load_inverse_model(train_network(cfg, data, stage), system=data.system)
        ckpt = out / "checkpoint.ckpt"  # where it will be once the run completes
    else:
        model = load_inverse_model(ckpt, system=data.system)
    test = data.test.subset(_pick(data.test, int(cfg.compare.cases_per_value)))
    t1 = time.perf_counter()
    pred = model.predict(test)
    t_net = time.perf_counter() - t1
    axis = str(cfg.dataset.cases.axis)
    cases = cfg.dataset.cases
    if cfg.compare.single_start:
        single = tuple(float(v) for v in cfg.compare.single_start)
    else:  # the centre of the priors, on log scale
        d_rng = cases["values"] if axis == "delta" else cases["delta_range"]
        single = (float(np.sqrt(np.prod(cfg.dataset.bank.kn_range))),
                  float(np.sqrt(min(d_rng) * max(d_rng))))
    ms = cfg.multistart
    starts = multistart_grid(int(ms.n), kn_range=tuple(ms.kn_range),
                             delta_range=tuple(ms.delta_range))
    rows = network_rows(test, pred.kn, pred.delta, wall_s=t_net)
    rows += fit_cases(test, data.system, network_estimate=(pred.kn, pred.delta),
                      single_start=single, multistart=starts, backbone=str(cfg.compare.backbone),
                      n_jobs=int(cfg.compare.n_jobs))
    picked = _pick(test, n_corrected) if n_corrected else np.zeros(0, int)
    if picked.size:
        _print_corrected(test, picked, axis)
        bank = simulate_bank(data.system, bank_spec, cache_dir=cache_dir, progress=False)
        rows += corrected_cases(test, picked, data.system, bank=bank, spec=case_spec,
                                network_estimate=(pred.kn, pred.delta),
                                multistart=OmegaConf.to_container(ms, resolve=True),
                                backbone=str(cfg.compare.backbone),
                                n_jobs=int(cfg.compare.n_jobs))
        del bank
        for r in rows:
            if r.get("verdict") == "failed":
                print(f"case {r['case']}, {r['method']}: failed: {r['failure']}")
    bounds = OmegaConf.to_container(cfg.success)
    summary = summarise(rows, success_delta=bounds["delta"], success_kn=bounds["kn"])
    on_picked = set(picked.tolist())
    sub_summary = summarise([r for r in rows if r["case"] in on_picked],
                            success_delta=bounds["delta"], success_kn=bounds["kn"])

    table = _markdown(summary, axis, bounds)
    if sub_summary:
        table += (f"\n## The {picked.size} cases with corrected fits, every method\n\n"
                  "The corrected fits run on these cases only; the plain methods on the same "
                  "cases, for a like-for-like comparison.\n\n"
                  + _markdown(sub_summary, axis, bounds, lead=False))
    print(table)  # before anything is written
    with writing_to(out):
        with open(stage / "compare.csv", "w", newline="") as fh:
            fields = list(dict.fromkeys(k for r in rows for k in r))  # corrected rows add keys
            w = csv.DictWriter(fh, fieldnames=fields, restval="")
            w.writeheader()
            w.writerows(rows)
        with open(stage / "compare_summary.csv", "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(summary[0]))
            w.writeheader()
            w.writerows(summary)
        (stage / "compare.md").write_text(f"# Comparison over {axis}\n\n" + table)
        figures = _figures(stage, rows, summary, axis) if cfg.plot else []

    def total(method, key, table=summary):
        return float(np.mean([r[key] for r in table if r["method"] == method]))

    nb = OmegaConf.to_container(cfg.network_bounds)
    de = np.abs(pred.delta / test.delta - 1)
    ke = np.abs(pred.kn / test.kn - 1)
    metrics = {
        "axis": axis, "checkpoint": str(ckpt), "n_cases": test.n_cases,
        "single_start": list(single), "n_multistart": len(starts),
        "summary": summary,
        "network_within_bounds": float(np.mean((de < nb["delta"]) & (ke < nb["kn"]))),
        "success_network_fit": total("network+fit", "success_rate"),
        "success_multistart": total("multi-start", "success_rate"),
        "success_single_start": total("single-start", "success_rate"),
        "evaluation_ratio_multistart_to_network_fit":
            total("multi-start", "evaluations_mean") / total("network+fit", "evaluations_mean"),
        "figures": figures,
        "runtime_s": time.perf_counter() - t0,
    }
    if sub_summary:
        corr = [r for r in rows if r["method"] in CORRECTED]
        ran = [r for r in corr if r["verdict"] != "failed"]
        metrics["corrected"] = {
            "cases": picked.tolist(),  # indices into the compared test cases (compare.csv)
            "plan_index": [int(test.meta["plan_index"][i]) for i in picked],
            "summary": sub_summary,  # every method on these cases
            **{f"success_{m}": total(m, "success_rate", sub_summary) for m in METHODS},
            **{f"evaluations_{m}": total(m, "evaluations_mean", sub_summary)
               for m in METHODS},
            # over the cases that could be identified (a failed one has no replay)
            "replays_mean": {m: _mean(r["n_replays"] for r in ran if r["method"] == m)
                             for m in CORRECTED},
            "converged": {m: _mean(r["converged"] for r in ran if r["method"] == m)
                          for m in CORRECTED},
            "suspect": {m: int(sum(r["verdict"] == "suspect" for r in ran if r["method"] == m))
                        for m in CORRECTED},
            "failed": {m: int(sum(r["verdict"] == "failed" for r in corr if r["method"] == m))
                       for m in CORRECTED},
        }
    with writing_to(out):
        write_metrics(stage, metrics)
    print(f"network alone within bounds: {100 * metrics['network_within_bounds']:.1f} %; "
          f"success network+fit {100 * metrics['success_network_fit']:.1f} % vs multi-start "
          f"{100 * metrics['success_multistart']:.1f} % with "
          f"{metrics['evaluation_ratio_multistart_to_network_fit']:.1f}x fewer evaluations")
    if sub_summary:
        c = metrics["corrected"]
        print(f"on the {picked.size} corrected cases: success network+corrected "
              f"{100 * c['success_network+corrected']:.1f} % "
              f"({c['evaluations_network+corrected']:.0f} evaluations) vs multi-start+corrected "
              f"{100 * c['success_multi-start+corrected']:.1f} % "
              f"({c['evaluations_multi-start+corrected']:.0f}); plain network+fit "
              f"{100 * c['success_network+fit']:.1f} %, multi-start "
              f"{100 * c['success_multi-start']:.1f} %")
    print(f"{metrics['runtime_s']:.1f} s -> {out}")
    return metrics


def _mean(values) -> float:
    """Mean of ``values``; NaN (no warning) when there are none."""
    v = [float(x) for x in values]
    return float(np.mean(v)) if v else float("nan")


def _print_corrected(test, picked: np.ndarray, axis: str) -> None:
    """Which cases get the corrected fits (their index in compare.csv and their truth)."""
    unit, scale = ("g", 1.0) if axis == "noise_g" else ("mrad", 1e3)
    print(f"corrected fits (replay) on {picked.size} cases: "
          + "; ".join(f"case {i} ({axis.replace('_g', '')} "
                      f"{scale * test.meta['axis_value'][i]:g} {unit}, kn "
                      f"{test.kn[i]:.4g} N·m/rad, δ {1e3 * test.delta[i]:.4g} mrad)"
                      for i in picked))

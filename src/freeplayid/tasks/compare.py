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
import logging
import time
from pathlib import Path

import numpy as np
from omegaconf import DictConfig, OmegaConf

from ..atomic import staged_folder
from ..errors import InputError
from .checks import COMPARE, check_config
from .common import (
    debug_choice,
    run_dir,
    study_data,
    study_specs,
    train_network,
    write_metrics,
    writing_to,
)
from .options import options_from_config

__all__ = ["compare"]

log = logging.getLogger(__name__)


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

    # PyTorch Lightning (the network) loads with the command that needs it: importing
    # freeplayid.tasks, as every command does, stays light
    from ..inverse import load_inverse_model

    t0 = time.perf_counter()
    check_config(cfg, COMPARE)  # every field, before any work
    fit = options_from_config(cfg, "fit")
    out = run_dir()
    ckpt = None
    if cfg.inverse.checkpoint:
        ckpt = Path(to_absolute_path(str(cfg.inverse.checkpoint)))
        load_inverse_model(ckpt)  # a missing or foreign file fails before the data set is built
    with staged_folder(out) as stage:
        return _compare(cfg, fit, stage, out, ckpt, t0)


def _compare(cfg: DictConfig, fit, stage: Path, out: Path, ckpt: Path | None,
             t0: float) -> dict:
    from ..inverse import load_inverse_model
    from ..studies import compare_methods, pick_cases, simulate_bank

    data = study_data(cfg)
    n_corrected = int(cfg.compare.corrected_cases_per_value)
    bank_spec, case_spec, _, cache_dir = study_specs(cfg, data.system)
    if n_corrected and "plan_index" not in data.test.meta:  # before any long work
        raise InputError(
            f"the cached cases {str(cache_dir / f'cases-{data.cases_key}')!r} predate "
            "meta['plan_index'], which the corrected fits need to rebuild their records; delete "
            "that folder to rebuild it, or set compare.corrected_cases_per_value=0")
    if ckpt is None:
        log.info("no inverse.checkpoint given: training one on the cached data set")
        model = load_inverse_model(train_network(cfg, data, stage)[0], system=data.system)
        ckpt = out / "checkpoint.ckpt"  # where it will be once the run completes
    else:
        model = load_inverse_model(ckpt, system=data.system)
    test = data.test.subset(pick_cases(data.test, int(cfg.compare.cases_per_value)))
    axis = str(cfg.dataset.cases.axis)
    bank = None
    if n_corrected:
        _log_corrected(test, pick_cases(test, n_corrected), axis)
        bank = simulate_bank(data.system, bank_spec, cache_dir=cache_dir, progress=False)
    result = compare_methods(
        test, data.system, network=model, axis=axis, single_start=_single_start(cfg), fit=fit,
        bounds=OmegaConf.to_container(cfg.success),
        network_bounds=OmegaConf.to_container(cfg.network_bounds),
        corrected_per_value=n_corrected, bank=bank, case_spec=case_spec,
        n_jobs=int(cfg.compare.n_jobs), base_channel=bool(cfg.compare.base_channel))
    del bank
    for r in result.rows:
        if r.get("verdict") == "failed":
            log.info(f"case {r['case']}, {r['method']}: failed: {r['failure']}")
    table = result.markdown()
    log.info(table)  # before anything is written
    with writing_to(out):
        _write_tables(stage, result)
        figures = _figures(stage, result.rows, result.summary, axis) if cfg.plot else []
    metrics = {**result.metrics(), "checkpoint": str(ckpt), "figures": figures,
               "runtime_s": time.perf_counter() - t0}
    with writing_to(out):
        write_metrics(stage, metrics)
    debug = debug_choice()
    if debug:
        log.info(f"debug={debug}: a few short debug cases"
                 + (", a barely trained debug network" if cfg.inverse.checkpoint is None
                    else "") + "; the rates below say nothing of the method")
    _log_metrics(metrics, result.corrected.size)
    log.info(f"{metrics['runtime_s']:.1f} s -> {out}")
    return metrics


def _single_start(cfg: DictConfig) -> tuple[float, float]:
    """``compare.single_start``, else the centre of the priors (log scale)."""
    if cfg.compare.single_start:
        return tuple(float(v) for v in cfg.compare.single_start)
    cases = cfg.dataset.cases
    d_rng = cases["values"] if cases.axis == "delta" else cases["delta_range"]
    return (float(np.sqrt(np.prod(cfg.dataset.bank.kn_range))),
            float(np.sqrt(min(d_rng) * max(d_rng))))


def _write_tables(stage: Path, result) -> None:
    """``compare.csv`` (one row per case and method), ``compare_summary.csv``, ``compare.md``."""
    with open(stage / "compare.csv", "w", newline="") as fh:
        fields = list(dict.fromkeys(k for r in result.rows for k in r))  # corrected rows add keys
        w = csv.DictWriter(fh, fieldnames=fields, restval="")
        w.writeheader()
        w.writerows(result.rows)
    with open(stage / "compare_summary.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(result.summary[0]))
        w.writeheader()
        w.writerows(result.summary)
    (stage / "compare.md").write_text(f"# Comparison over {result.axis}\n\n" + result.markdown())


def _log_metrics(metrics: dict, n_corrected: int) -> None:
    log.info(f"network alone within bounds: {100 * metrics['network_within_bounds']:.1f} %; "
             f"success network+fit {100 * metrics['success_network_fit']:.1f} % vs multi-start "
             f"{100 * metrics['success_multistart']:.1f} % with "
             f"{metrics['evaluation_ratio_multistart_to_network_fit']:.1f}x fewer evaluations")
    if "corrected" in metrics:
        c = metrics["corrected"]
        log.info(f"on the {n_corrected} corrected cases: success network+corrected "
                 f"{100 * c['success_network+corrected']:.1f} % "
                 f"({c['evaluations_network+corrected']:.0f} evaluations) vs multi-start+corrected "
                 f"{100 * c['success_multi-start+corrected']:.1f} % "
                 f"({c['evaluations_multi-start+corrected']:.0f}); plain network+fit "
                 f"{100 * c['success_network+fit']:.1f} %, multi-start "
                 f"{100 * c['success_multi-start']:.1f} %")
        for m in ("network+corrected", "multi-start+corrected"):
            log.info(f"{m}: `ok` outside the bounds {c['ok_outside'][m]} (intervals holding the "
                     f"truth in {c['ok_outside_ci_holds'][m]} of them); both intervals hold the "
                     f"truth in {100 * c['ci_holds'][m]:.0f} % of the cases; `suspect` inside "
                     f"the bounds, by failed check: {c['suspect_inside_checks'][m] or 'none'}")


def _log_corrected(test, picked: np.ndarray, axis: str) -> None:
    """Which cases get the corrected fits (their index in compare.csv and their truth)."""
    unit, scale = ("g", 1.0) if axis == "noise_g" else ("mrad", 1e3)
    log.info(f"corrected fits (replay) on {picked.size} cases: "
             + "; ".join(f"case {i} ({axis.replace('_g', '')} "
                         f"{scale * test.meta['axis_value'][i]:g} {unit}, kn "
                         f"{test.kn[i]:.4g} N·m/rad, δ {1e3 * test.delta[i]:.4g} mrad)"
                         for i in picked))

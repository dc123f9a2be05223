"""`train` task: the neural inverse model on simulated cases, evaluated on held-out kn values.

Steps: build the model, simulate (or load) the sweep bank and the cases (cached under
``dataset.cache_dir``), split them by kn into train / validation / test, train the set network
(Lightning, the best validation epoch kept), evaluate the network alone on the test cases per
value of the ablation axis, with its calibration (coverage at every credibility level, SBC ranks:
:func:`freeplayid.inverse.calibration_metrics`), and write ``checkpoint.ckpt`` (calibrated on
the validation cases), ``metrics.json``, ``learning_curves.png``, ``predictions.png`` and
``calibration.png``, all or none (``staged_folder``), after checking the whole configuration.
"""

from __future__ import annotations

import logging
import time
import warnings
from pathlib import Path

import numpy as np
from omegaconf import DictConfig, OmegaConf

from ..atomic import staged_folder
from ..errors import InverseDomainWarning
from .checks import TRAIN, check_config
from .common import (
    debug_choice,
    run_dir,
    study_data,
    train_network,
    write_metrics,
    writing_to,
)

__all__ = ["train"]

log = logging.getLogger(__name__)


def _figures(out: Path, history: dict, test, pred, axis_name: str,
             calibration: dict) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..plots import (
        plot_coverage,
        plot_inverse_predictions,
        plot_learning_curves,
        plot_sbc_ranks,
    )

    fig, ax = plt.subplots(figsize=(6, 4))
    plot_learning_curves(ax, history)
    fig.tight_layout()
    fig.savefig(out / "learning_curves.png", dpi=110)
    plt.close(fig)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    for ax, name in zip(axes, ("kn", "delta"), strict=True):
        plot_inverse_predictions(ax, getattr(test, name), getattr(pred, name),
                                 getattr(pred, f"log_{name}_std"),
                                 groups=test.meta["axis_value"], group_name=axis_name,
                                 quantity=name)
    fig.tight_layout()
    fig.savefig(out / "predictions.png", dpi=110)
    plt.close(fig)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    plot_coverage(axes[0], calibration)
    plot_sbc_ranks(axes[1], calibration, "kn")
    plot_sbc_ranks(axes[2], calibration, "delta")
    fig.tight_layout()
    fig.savefig(out / "calibration.png", dpi=110)
    plt.close(fig)
    return ["learning_curves.png", "predictions.png", "calibration.png"]


def train(cfg: DictConfig) -> dict:
    """Train and evaluate the inverse model; write the checkpoint, metrics and figures.

    Returns
    -------
    dict
        The metrics (also in ``metrics.json``): case counts, the data-set cache keys, and the
        network-alone errors on the held-out cases per axis value.
    """
    t0 = time.perf_counter()
    check_config(cfg, TRAIN)  # every field, before any work
    with staged_folder(run_dir()) as stage:
        return _train(cfg, stage, t0)


def _train(cfg: DictConfig, stage: Path, t0: float) -> dict:
    from ..inverse import calibration_metrics, load_inverse_model
    from ..studies import network_metrics

    out = run_dir()
    data = study_data(cfg)
    ckpt, history = train_network(cfg, data, stage)
    model = load_inverse_model(ckpt, system=data.system)
    with warnings.catch_warnings():  # metrics.json counts the test cases outside the domain
        warnings.simplefilter("ignore", InverseDomainWarning)
        pred = model.predict(data.test)
    raw = model.predict(data.test, calibrated=False)
    calibration = model.calibration.metrics(data.test, raw)
    before = calibration_metrics(data.test, raw)
    calibration.update(
        std_scale=dict(zip(("kn", "delta"), model.calibration.std_scale, strict=True)),
        uncalibrated_max_gap={p: before[p]["max_gap"] for p in ("kn", "delta")},
        recalibrated={p: model.calibration.z[p] is not None for p in ("kn", "delta")},
        validation_sbc_p=model.calibration.val_p_value,
        outside_domain=sum(bool(w) for w in pred.outside))
    axis = str(cfg.dataset.cases.axis)
    metrics = {
        "checkpoint": str(out / ckpt.name),  # where it is once the run completes
        "axis": axis,
        "n_train": data.train.n_cases, "n_val": data.val.n_cases, "n_test": data.test.n_cases,
        "n_dropped": data.n_dropped, "bank": data.bank_key, "cases": data.cases_key,
        "data_s": data.build_s,
        "epochs": len(history.get("val_loss", [])),
        "best_val_loss": float(np.nanmin(history["val_loss"])) if history.get("val_loss")
        else None,
        "network": network_metrics(data.test, pred,
                                   bounds=OmegaConf.to_container(cfg.network_bounds)),
        "calibration": calibration,
    }
    if cfg.plot:
        with writing_to(out):
            metrics["figures"] = _figures(stage, history, data.test, pred, axis, calibration)
    metrics["runtime_s"] = time.perf_counter() - t0
    with writing_to(out):
        write_metrics(stage, metrics)
    net = metrics["network"]
    debug = debug_choice()
    if debug:
        log.info(f"debug={debug}: a debug network, barely trained ({metrics['epochs']} epochs on "
                 f"{data.train.n_cases} cases of a short sweep); its errors below say nothing "
                 f"of the method (train without debug={debug} for a real one)")
    log.info(f"test cases: {data.test.n_cases}; network alone within "
             f"{100 * cfg.network_bounds.delta:g} % in delta and {100 * cfg.network_bounds.kn:g} % "
             f"in kn: {100 * net['overall']['within_bounds']:.1f} % of cases")
    sbc = {p: calibration[p]["sbc"] for p in ("kn", "delta")}
    log.info(f"calibration on the test cases ({model.calibration.describe()}; spreads x " +
             ", ".join(f"{p} {calibration['std_scale'][p]:.3g}" for p in ("kn", "delta")) +
             "): largest coverage gap " + ", ".join(
                 f"{p} {100 * calibration[p]['max_gap']:.1f} points (uncalibrated "
                 f"{100 * calibration['uncalibrated_max_gap'][p]:.1f})" for p in ("kn", "delta")) +
        "; SBC ranks' chi-square p " + ", ".join(
        f"{p} {sbc[p]['p_value']:.2g} ({sbc[p]['p_value_clustered']:.2g} clustered by kn, "
        f"design effect {sbc[p]['deff']:.2f})" for p in ("kn", "delta")) +
        f"; {calibration['outside_domain']} cases outside the training domain")
    for v, b in net["per_value"].items():
        log.info(f"  {axis} = {v}: median |err| delta {100 * b['delta_err_median']:.2f} %, "
                 f"kn {100 * b['kn_err_median']:.2f} %, "
                 f"within bounds {100 * b['within_bounds']:.0f} %")
    log.info(f"{metrics['runtime_s']:.1f} s -> {out}")
    return metrics

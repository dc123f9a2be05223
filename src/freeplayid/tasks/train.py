"""`train` task: the neural inverse model on simulated cases, evaluated on held-out kn values.

Steps: build the model, simulate (or load) the sweep bank and the cases (cached under
``dataset.cache_dir``), split them by kn into train / validation / test, train the set network
(Lightning, the best validation epoch kept), evaluate the network alone on the test cases per
value of the ablation axis, and write ``checkpoint.ckpt``, ``metrics.json``,
``learning_curves.png`` and ``predictions.png``, all or none (``staged_folder``), after checking
the whole configuration.
"""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import numpy as np
from omegaconf import DictConfig, OmegaConf

from ..atomic import staged_folder
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


def _figures(out: Path, history: dict, test, pred, axis_name: str) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..plots import plot_inverse_predictions, plot_learning_curves

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
    return ["learning_curves.png", "predictions.png"]


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
    from ..inverse import load_inverse_model
    from ..studies import network_metrics

    out = run_dir()
    data = study_data(cfg)
    ckpt = train_network(cfg, data, stage)
    model = load_inverse_model(ckpt, system=data.system)
    pred = model.predict(data.test)
    history = json.loads((stage / "history.json").read_text())
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
    }
    if cfg.plot:
        with writing_to(out):
            metrics["figures"] = _figures(stage, history, data.test, pred, axis)
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
    for v, b in net["per_value"].items():
        log.info(f"  {axis} = {v}: median |err| delta {100 * b['delta_err_median']:.2f} %, "
                 f"kn {100 * b['kn_err_median']:.2f} %, "
                 f"within bounds {100 * b['within_bounds']:.0f} %")
    log.info(f"{metrics['runtime_s']:.1f} s -> {out}")
    return metrics

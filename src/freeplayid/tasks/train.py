"""`train` task: the neural inverse model on simulated cases, evaluated on held-out kn values.

Steps: build the model, simulate (or load) the sweep bank and the cases (cached under
``dataset.cache_dir``), split them by kn into train / validation / test, train the set network
(Lightning, the best validation epoch kept), evaluate the network alone on the test cases per
value of the ablation axis, and write ``checkpoint.ckpt``, ``metrics.json``,
``learning_curves.png`` and ``predictions.png``.
"""

from __future__ import annotations

import json
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from omegaconf import DictConfig, OmegaConf

from .common import build_system, run_dir, write_metrics

__all__ = ["train", "prepare_cases", "train_network", "network_metrics", "StudyData"]


@dataclass(frozen=True)
class StudyData:
    """The simulated cases of a study, split by kn (no kn shared between the parts)."""

    system: object
    channels: tuple
    train: object
    val: object
    test: object
    bank_key: str
    cases_key: str
    n_dropped: int
    build_s: float


def _channels(cfg: DictConfig, system) -> tuple:
    chosen = cfg.dataset.get("channels") or cfg.model.get("channels")
    if chosen:
        c = OmegaConf.to_container(chosen, resolve=True)
        return tuple(c.values()) if isinstance(c, dict) else tuple(c)
    return tuple(d for d in system.dof_names if d.startswith("uz_")) or tuple(system.dof_names)


def prepare_cases(cfg: DictConfig, *, progress: bool = True) -> StudyData:
    """Build (or load from the cache) the bank and cases of ``cfg.dataset`` and split them."""
    from hydra.utils import to_absolute_path

    from ..inverse.dataset import BankSpec, CaseSpec, build_cases, simulate_bank, split_by_kn
    from ..simulate import Sweep

    t0 = time.perf_counter()
    system = build_system(cfg.model)
    channels = _channels(cfg, system)
    d = OmegaConf.to_container(cfg.dataset, resolve=True)
    b = dict(d["bank"])
    b["sweep"] = Sweep(**b["sweep"])
    bank_spec = BankSpec(channels=channels, **b)
    case_spec = CaseSpec(**d["cases"])
    cache = Path(to_absolute_path(str(d["cache_dir"])))
    bank = simulate_bank(system, bank_spec, cache_dir=cache, progress=progress)
    cases = build_cases(bank, case_spec, cache_dir=cache, progress=progress)
    parts = split_by_kn(cases, bank_spec.n_kn, tuple(d["split"]))
    if len(parts) != 3:
        raise ValueError(f"`dataset.split` must give 3 fractions (train, val, test), "
                         f"got {d['split']!r}")
    for name, p in zip(("train", "validation", "test"), parts, strict=True):
        if p.n_cases == 0:
            raise ValueError(f"the {name} split has no case with 2 or more points; raise "
                             f"`dataset.bank.n_kn` or `dataset.split`, or widen the level ratios")
    n_planned = bank_spec.n_kn * len(case_spec.values) * case_spec.cases_per_value
    return StudyData(system=system, channels=channels, train=parts[0], val=parts[1],
                     test=parts[2], bank_key=bank.key, cases_key=case_spec.key(bank),
                     n_dropped=n_planned - cases.n_cases, build_s=time.perf_counter() - t0)


def train_network(cfg: DictConfig, data: StudyData, out: Path) -> Path:
    """Train the set network; the best checkpoint is copied to ``out/checkpoint.ckpt``."""
    from ..inverse import train_inverse_model

    t = cfg.training
    extra = {
        "dataset": OmegaConf.to_container(cfg.dataset, resolve=True),
        "bank": data.bank_key, "cases": data.cases_key,
    }
    _, trainer, history = train_inverse_model(
        data.train, data.val, channels=data.channels, fingerprint=data.system.fingerprint(),
        hidden=int(cfg.network.hidden), depth=int(cfg.network.depth), lr=float(t.lr),
        weight_decay=float(t.weight_decay), batch_size=int(t.batch_size),
        max_epochs=int(t.max_epochs), seed=int(cfg.seed), out_dir=out / "lightning",
        extra=extra, accelerator=str(t.accelerator),
    )
    best = Path(trainer.checkpoint_callback.best_model_path or "")
    if not best.is_file():
        raise RuntimeError(f"training wrote no checkpoint under {out / 'lightning'}")
    target = out / "checkpoint.ckpt"
    shutil.copyfile(best, target)
    (out / "history.json").write_text(json.dumps(history, indent=1))
    return target


def network_metrics(test, pred, *, bounds: dict) -> dict:
    """Network-alone errors on ``test`` per axis value and overall (absolute relative errors)."""
    de = np.abs(pred.delta / test.delta - 1)
    ke = np.abs(pred.kn / test.kn - 1)
    inside = (de < bounds["delta"]) & (ke < bounds["kn"])
    # calibration: share of cases whose truth lies within the predicted +-2 sigma (ln scale);
    # 95 % for a calibrated Gaussian
    z_d = np.abs(np.log(pred.delta / test.delta)) / pred.log_delta_std
    z_k = np.abs(np.log(pred.kn / test.kn)) / pred.log_kn_std

    def block(sel):
        return {
            "n": int(sel.sum()),
            "delta_err_median": float(np.median(de[sel])),
            "delta_err_p90": float(np.percentile(de[sel], 90)),
            "kn_err_median": float(np.median(ke[sel])),
            "kn_err_p90": float(np.percentile(ke[sel], 90)),
            "within_bounds": float(inside[sel].mean()),
            "delta_within_2sigma": float(np.mean(z_d[sel] < 2)),
            "kn_within_2sigma": float(np.mean(z_k[sel] < 2)),
        }

    axis = test.meta["axis_value"]
    return {
        "overall": block(np.ones(test.n_cases, bool)),
        "per_value": {f"{v:g}": block(axis == v) for v in np.unique(axis)},
        "bounds": dict(bounds),
    }


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
    from ..inverse import load_inverse_model

    t0 = time.perf_counter()
    out = run_dir()
    data = prepare_cases(cfg)
    ckpt = train_network(cfg, data, out)
    model = load_inverse_model(ckpt, system=data.system)
    pred = model.predict(data.test)
    history = json.loads((out / "history.json").read_text())
    axis = str(cfg.dataset.cases.axis)
    metrics = {
        "checkpoint": str(ckpt),
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
        metrics["figures"] = _figures(out, history, data.test, pred, axis)
    metrics["runtime_s"] = time.perf_counter() - t0
    write_metrics(out, metrics)
    net = metrics["network"]
    print(f"test cases: {data.test.n_cases}; network alone within "
          f"{100 * cfg.network_bounds.delta:g} % in delta and {100 * cfg.network_bounds.kn:g} % "
          f"in kn: {100 * net['overall']['within_bounds']:.1f} % of cases")
    for v, b in net["per_value"].items():
        print(f"  {axis} = {v}: median |err| delta {100 * b['delta_err_median']:.2f} %, "
              f"kn {100 * b['kn_err_median']:.2f} %, "
              f"within bounds {100 * b['within_bounds']:.0f} %")
    print(f"{metrics['runtime_s']:.1f} s -> {out}")
    return metrics

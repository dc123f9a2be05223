"""Helpers shared by the tasks: the model from its config group, the run folder, metrics."""

from __future__ import annotations

import json
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from ..io.atomic import atomic_write_text
from ..model.system import FreeplaySystem

__all__ = ["build_system", "register_configs", "run_dir", "write_metrics", "MODEL_KINDS"]

MODEL_KINDS = ("fin", "npz", "sdof")


def register_configs() -> None:
    """Store the package's default fin in Hydra's ConfigStore as the option ``model=fin``.

    The fin's numbers live once, in the package data ``freeplayid/model/fin.yaml``
    (:func:`freeplayid.model.fin_config_path`, read by ``default_fin()`` in any install); the
    ``model`` group of ``conf/`` holds the other options (``sdof``, ``npz``). The ConfigStore is on
    every Hydra search path, so ``model=fin`` composes from every primary config, also from one
    included by another (``compare`` includes ``train``, where a ``hydra.searchpath`` entry is
    refused), with the file's keys and values (OmegaConf's YAML loader), so overrides such as
    ``model.geometry.root_chord=0.25`` apply. Runs when :mod:`freeplayid.tasks` is imported (the
    scripts import it before ``@hydra.main`` composes; a compose elsewhere imports it first).
    """
    from hydra.core.config_store import ConfigStore

    from ..model.fin_config import fin_config_path

    node = OmegaConf.create(fin_config_path().read_text(encoding="utf-8"))
    ConfigStore.instance().store(group="model", name="fin", node=node, provider="freeplayid")


def build_system(model_cfg: DictConfig | dict) -> FreeplaySystem:
    """The linear structure selected by the ``model`` config group.

    ``kind: fin`` -> :func:`freeplayid.model.fin_from_config` (the default plate-FE fin),
    ``kind: npz`` -> :func:`freeplayid.model.load_system` of ``path`` (relative to the directory
    the command was started from), ``kind: sdof`` -> :func:`freeplayid.model.sdof_system`.
    """
    cfg = OmegaConf.to_container(model_cfg, resolve=True) if isinstance(model_cfg, DictConfig) \
        else dict(model_cfg)
    kind = cfg.get("kind")
    if kind == "fin":
        try:
            from ..model import fin_from_config
        except ImportError as exc:  # the fin model lands in a separate change
            raise ValueError(
                "model `kind`='fin' needs freeplayid.model.fin_from_config, which this checkout "
                f"does not have ({exc}); use model=npz or model=sdof"
            ) from None
        return fin_from_config({k: v for k, v in cfg.items() if k != "channels"})
    if kind == "npz":
        from hydra.utils import to_absolute_path

        from ..model import load_system

        path = cfg.get("path")
        if not path:
            raise ValueError("model `kind`='npz' needs `path` (model.path=FILE.npz)")
        return load_system(to_absolute_path(str(path)))
    if kind == "sdof":
        from ..model import sdof_system

        return sdof_system(
            mass=float(cfg["mass"]), stiffness=float(cfg.get("stiffness", 0.0)),
            damping=float(cfg.get("damping", 0.0)),
        )
    raise ValueError(f"model `kind` must be one of {MODEL_KINDS}, got {kind!r}")


def run_dir() -> Path:
    """Hydra's output folder of this run (the working directory outside a Hydra run)."""
    from hydra.core.hydra_config import HydraConfig

    if HydraConfig.initialized():
        return Path(HydraConfig.get().runtime.output_dir)
    return Path.cwd()


def write_metrics(folder: Path, metrics: dict) -> Path:
    """Write ``metrics.json`` (atomically) and return its path."""
    return atomic_write_text(Path(folder) / "metrics.json",
                             json.dumps(metrics, indent=2, sort_keys=True))

"""The `model` task (freeplayid-model or scripts/model.py, freeplayid/conf/model.yaml): config ->
:func:`freeplayid.model.model_from_modal_test` arguments, then write ``model.npz``, ``report.md``,
``modes.png`` and ``metrics.json``."""

from __future__ import annotations

import logging
import warnings
from pathlib import Path

from hydra.utils import to_absolute_path
from omegaconf import DictConfig, OmegaConf

from ..atomic import atomic_path, atomic_write_text
from ..errors import ModalTestError
from ..io import read_modal_test
from ..model import FinConfig, model_from_modal_test, save_system
from ..model.from_test import TEST_TITLES
from ..plots import plot_mode_pairs
from .common import run_dir, write_metrics

__all__ = ["model"]

log = logging.getLogger(__name__)


def _figure(out: Path, build) -> list[str]:
    if not build.comparisons:
        return []
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(build.comparisons)
    fig, axes = plt.subplots(1, n, figsize=(4.6 * n, 3.8), squeeze=False)
    for ax, (name, c) in zip(axes[0], build.comparisons.items(), strict=True):
        kind = "mode shapes" if c.measured_shapes is not None else "frequencies"
        plot_mode_pairs(ax, c, title=f"{TEST_TITLES.get(name, name)}: {kind}")
    fig.tight_layout()
    with atomic_path(out / "modes.png") as tmp:  # the name ends in .png: savefig's format
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return ["modes.png"]


def model(cfg: DictConfig) -> dict:
    """The linear fin of ``cfg.model``, updated against ``cfg.modal_test`` when given.

    Returns
    -------
    dict
        The metrics (also in ``metrics.json``): parameters, condition number, frequency errors.

    Raises
    ------
    freeplayid.InputError
        A modal-test file or configuration problem; the message names the file and the field.
    """
    mapping = OmegaConf.to_container(cfg.model, resolve=True)
    if mapping.get("kind") != "fin":
        raise ValueError(f"model.py builds a plate fin (model=fin), got model `kind`="
                         f"{mapping.get('kind')!r}")
    try:
        fin = FinConfig.from_mapping({k: v for k, v in mapping.items() if k != "channels"})
    except ValueError as exc:
        raise ModalTestError(f"model: {exc}") from None
    test = None if cfg.get("modal_test") in (None, "") else \
        read_modal_test(to_absolute_path(str(cfg.modal_test)))
    u = cfg.updating
    parameters = list(u.parameters) if test is not None else []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the report carries the warnings
        build = model_from_modal_test(
            fin, test, parameters=parameters,
            clamp_stiffness=None if u.clamp_stiffness is None else float(u.clamp_stiffness),
            min_mac=float(u.min_mac), max_evaluations=int(u.max_evaluations))
    out = run_dir()
    save_system(out / "model.npz", build.system)
    figures = _figure(out, build) if cfg.plot else []
    atomic_write_text(out / "report.md", build.report(figures))
    for w in build.warnings():
        log.warning(w)
    for k, (a, b, s) in build.parameters.items():
        log.info(f"{k}: {a:.6g} -> {b:.6g} (x {s:.5f})")
    log.info(f"model.npz ({len(build.system.dof_names)} DOFs), report.md -> {out}")
    metrics = build.metrics()
    metrics["modal_test"] = None if test is None else test.source
    write_metrics(out, metrics)
    return metrics

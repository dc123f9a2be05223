"""`identify` task: config -> :func:`freeplayid.identify` arguments, then write and draw.

Writes ``identification.json``, ``report.md``, ``backbone_fit.png`` (the paper's Fig. 12),
``residuals.png`` and ``metrics.json`` in the run folder, all or none (``staged_folder``); the
configuration is checked before any work and the result printed before anything is written.
"""

from __future__ import annotations

import dataclasses
import logging
import time
import warnings
from pathlib import Path

import numpy as np
from omegaconf import DictConfig

from ..atomic import atomic_write_text, staged_folder
from ..errors import ConfigError, InverseDomainWarning
from ..identification import Identification, SuspectResultError
from ..identification import identify as identify_dataset
from ..io import DatasetError, bundled_example, read_dataset
from ..io.result_file import write_identification
from .checks import IDENTIFY, check_config
from .common import run_dir, write_metrics, writing_to
from .options import identify_options

__all__ = ["identify", "bundled_example"]

log = logging.getLogger(__name__)


def _data_path(cfg: DictConfig) -> Path:
    if cfg.get("data") in (None, ""):
        path = bundled_example()
        if not path.is_file():
            raise DatasetError(
                f"no `data=` given and the bundled example {path} is not there; "
                "run `freeplayid-identify data=PATH/manifest.yaml`"
            )
        return path
    from hydra.utils import to_absolute_path

    return Path(to_absolute_path(str(cfg.data)))


def _load_inverse(cfg: DictConfig, system):
    """The inverse model of ``inverse.checkpoint``, checked against ``system``, or None."""
    if not (cfg.get("inverse") and cfg.inverse.get("checkpoint")):
        return None
    from hydra.utils import to_absolute_path

    from ..inverse import load_inverse_model

    return load_inverse_model(Path(to_absolute_path(str(cfg.inverse.checkpoint))), system=system)


def _figures(out: Path, result: Identification) -> list[str]:
    """Save the figures the result can draw (``Identification.plot``) in ``out``; their names."""
    from ..identification.figures import FIGURES, figure_kinds

    names = []
    for kind in figure_kinds(result):
        result.plot(kind).savefig(out / FIGURES[kind], dpi=110)
        names.append(FIGURES[kind])
    return names


def identify(cfg: DictConfig) -> dict:
    """Identify (kn, delta) from the configured data set; write the result, report and figures.

    Returns
    -------
    dict
        The metrics (also in ``metrics.json``): kn, delta, CIs, residual RMS, point counts,
        runtime, and the errors against the manifest's ``truth`` when it has one.

    Raises
    ------
    freeplayid.InputError
        A configuration value outside its allowed set (``ConfigError``), an output folder that
        cannot take the results (``OutputError``), a data set, model file or checkpoint problem,
        or data that cannot support an identification; the message names the field, file or run.
    """
    t0 = time.perf_counter()
    check_config(cfg, IDENTIFY)  # every field, before any work
    options = identify_options(cfg)
    with staged_folder(run_dir()) as stage:
        metrics = _identify(cfg, options, stage, t0)
    # a suspect result is written whole (its report says why), then refused
    reasons = metrics.pop("suspect_reasons", None)
    if reasons:
        raise SuspectResultError(f"the result is suspect: {'; '.join(reasons)} (results in "
                                 f"{run_dir()}; allow_suspect=true accepts it)")
    return metrics


def _identify(cfg: DictConfig, options: dict, stage: Path, t0: float) -> dict:
    from ..model import load_system

    ds = read_dataset(_data_path(cfg))
    log.debug("data set %s: %d runs, model %s", ds.path, len(ds.runs), ds.model)
    if ds.model is None:
        raise DatasetError(f"{ds.path}: missing field `model` (the linear model file, .npz)")
    system = load_system(ds.model)
    if options["fit"].mode >= system.n_dof:
        raise ConfigError(f"`fit.mode` must be an integer in [0, {system.n_dof - 1}] (the model "
                          f"{ds.model.name} has {system.n_dof} modes), got {cfg.fit.mode!r}")
    inverse_model = _load_inverse(cfg, system)  # a wrong checkpoint fails before the extraction
    if inverse_model is not None:
        options["fit"] = dataclasses.replace(options["fit"], init=inverse_model)
    with warnings.catch_warnings():  # the log line below says it
        warnings.simplefilter("ignore", InverseDomainWarning)
        result = identify_dataset(ds, system=system, **options)
    est = result.inverse_estimate
    if est:
        log.info(f"inverse model: kn = {est['kn']:.4g} N·m/rad "
                 f"(x/÷ {np.exp(est['log_kn_std']):.3f}), delta = {est['delta']:.4g} rad "
                 f"(x/÷ {np.exp(est['log_delta_std']):.3f})")
        if est.get("outside"):
            log.warning(f"inverse model: {est['outside']}")
    log.info(result.summary())  # before anything is written: a failed write does not lose it
    out = run_dir()
    with writing_to(out):
        figures = _figures(stage, result) if cfg.plot else []
        write_identification(stage, result)
        atomic_write_text(stage / "report.md", result.report(figures))
    used = result.used_points
    fit = result.plain_fit
    metrics = {
        "kn": result.kn, "delta": result.delta, "kn_ci95": list(result.kn_ci95),
        "delta_ci95": list(result.delta_ci95), "residual_rms": result.residual_rms,
        "n_points_used": len(used), "n_points": len(result.points.points),
        "n_rejected_runs": len(result.rejected_runs), "n_evaluations": fit.n_evaluations,
        "fit_runtime_s": fit.runtime_s, "runtime_s": time.perf_counter() - t0,
        "dataset": str(ds.path),
    }
    if result.truth_error:
        metrics.update({f"{k}_rel_error": v for k, v in result.truth_error.items()})
    metrics["verdict"] = result.verdict.status
    with writing_to(out):
        write_metrics(stage, metrics)
    log.info(f"{len(used)} points, {len(result.rejected_runs)} rejected runs, "
             f"{result.runtime_s:.1f} s -> {out}")
    if not result.verdict.ok and not cfg.allow_suspect:
        metrics["suspect_reasons"] = list(result.verdict.reasons)
    return metrics

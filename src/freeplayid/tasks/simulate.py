"""`simulate` task: sine sweeps of a model written as a measured-data set (docs/identify.md).

Checks the whole configuration, the channels against the model and the RK4 cost of the sweep
(refused above ``max_steps`` steps per sweep unless ``force=true``) before simulating; writes the
data set, ``responses.png`` and ``metrics.json`` all or none (``staged_folder``).
"""

from __future__ import annotations

import logging
import time

import numpy as np
from omegaconf import DictConfig, OmegaConf

from ..atomic import staged_folder
from ..errors import ConfigError
from ..io import write_dataset
from ..quantity import G
from ..sweep import Sweep
from .checks import SIMULATE, check_config
from .common import build_system, run_dir, write_metrics, writing_to

__all__ = ["simulate"]

log = logging.getLogger(__name__)

def _channels(cfg: DictConfig, system) -> dict:
    """CSV column -> DOF name: ``channels``, else the model's ``channels``, else every uz_* DOF."""
    chosen = cfg.get("channels") or cfg.model.get("channels")
    if chosen:
        columns = dict(OmegaConf.to_container(chosen, resolve=True))
        unknown = sorted(set(columns.values()) - set(system.dof_names))
        if unknown:
            raise ConfigError(f"`channels` name DOF(s) {unknown} the model does not have; its "
                              f"DOFs are {list(system.dof_names)}")
        return columns
    from ..simulate import default_columns

    dofs = [d for d in system.dof_names if d.startswith("uz_")] or list(system.dof_names)
    return default_columns(cfg.quantity, dofs)


def _check_cost(cfg: DictConfig, system, sweep: Sweep, channels: dict) -> int:
    """RK4 steps per sweep, from the model's fastest closed-hinge mode at ``kn``; refused above
    ``max_steps`` unless ``force``."""
    from ..simulate import rk4_step_count

    steps, dt = rk4_step_count(
        system, kn=float(cfg.kn), sweep=sweep, sample_rate=float(cfg.sample_rate),
        channels=tuple(channels.values()), quantity=cfg.quantity, frame=cfg.frame,
        method=cfg.method, cutoff_hz=cfg.cutoff_hz, quasi_static_hz=cfg.get("quasi_static_hz"),
    )
    cost = (f"kn = {cfg.kn:g} needs {steps:.3g} RK4 steps per sweep (dt = {dt:.3g} s over "
            f"{sweep.duration:g} s, x {len(cfg.levels)} sweeps)")
    if steps > cfg.max_steps and not cfg.force:
        raise ConfigError(f"{cost}, above `max_steps` = {cfg.max_steps:g}: check `kn` "
                          "(a stiff hinge shrinks the step as sqrt(kn)), or set cutoff_hz / "
                          "quasi_static_hz, or force=true to run anyway")
    log.info(cost)
    return steps


def simulate(cfg: DictConfig) -> dict:
    """Simulate the configured sweeps, write the data set, a figure and ``metrics.json``.

    Returns
    -------
    dict
        The metrics (also in ``metrics.json``): runtime, step, per-run peak amplitudes, ...
    """
    t0 = time.perf_counter()
    check_config(cfg, SIMULATE)  # every field, before the model is built
    with staged_folder(run_dir()) as stage:
        return _simulate(cfg, stage, t0)


def _simulate(cfg: DictConfig, stage, t0: float) -> dict:
    import torch

    from ..simulate import simulate_sweeps, sweep_dataset

    try:
        system = build_system(cfg.model)
    except (ValueError, TypeError) as e:
        if isinstance(e, ConfigError):
            raise
        raise ConfigError(f"`model`: {e}") from None
    channels = _channels(cfg, system)
    sweep = Sweep(**OmegaConf.to_container(cfg.sweep, resolve=True))
    levels = [float(v) for v in cfg.levels]
    dtype = {"float32": torch.float32, "float64": torch.float64}[cfg.dtype]
    steps = _check_cost(cfg, system, sweep, channels)
    res = simulate_sweeps(
        system, kn=float(cfg.kn), delta=float(cfg.delta), level_g=levels, sweep=sweep,
        channels=tuple(channels.values()), quantity=cfg.quantity, frame=cfg.frame,
        sample_rate=float(cfg.sample_rate), method=cfg.method, device=cfg.device, dtype=dtype,
        cutoff_hz=cfg.cutoff_hz, quasi_static_hz=cfg.get("quasi_static_hz"),
        static_g=float(cfg.get("gravity_g", 0.0)),
    )
    noise = None
    if cfg.noise_std_g:
        rng = np.random.default_rng(int(cfg.seed))
        noise = rng.normal(0.0, float(cfg.noise_std_g) * G, size=res.signals.shape)
    # what a test records: the responses, the sweep hint, the level and, for absolute
    # accelerations, the base (control) accelerometer
    ds = sweep_dataset(res, columns=channels, units=cfg.units, noise=noise, name=cfg.name)
    runs, data = ds.runs, np.stack([run.data for run in ds.runs])
    out = run_dir()
    with writing_to(out):
        _write(cfg, stage, ds, system, res, sweep, channels, levels, data)
    metrics = {
        "runtime_s": time.perf_counter() - t0,
        "n_sweeps": len(levels),
        "n_diverged": int(res.diverged.sum()),
        "dt_s": res.dt,
        "rk4_steps": steps,
        "steps_per_sample": res.steps_per_sample,
        "omega_max_dt": res.omega_max * res.dt,
        "engine": res.engine,
        "dataset": str(out / cfg.output_dir / "manifest.yaml"),
        "peak_abs": {
            run.file: {col: float(np.nanmax(np.abs(data[i, c]))) for c, col in enumerate(channels)}
            for i, run in enumerate(runs)
        },
    }
    if res.truncation is not None:
        metrics["truncation"] = {
            "cutoff_hz": res.truncation.cutoff_hz, "kept": res.truncation.kept,
            "total": res.truncation.total, "static_error": res.truncation.static_error,
        }
    if res.quasi_static is not None:
        q = res.quasi_static
        metrics["quasi_static"] = {
            "threshold_hz": q.threshold_hz, "integrated": q.slow, "total": q.total,
            "condensed_hz": list(q.fast_hz), "damping_coupling": q.damping_coupling,
        }
    with writing_to(out):
        write_metrics(stage, metrics)
    log.info(f"{len(levels)} sweeps, {metrics['n_diverged']} diverged, "
             f"{metrics['runtime_s']:.1f} s -> {out}")
    return metrics


def _write(cfg, stage, ds, system, res, sweep, channels, levels, data) -> None:
    """The data set and the figure, into the staging folder."""
    write_dataset(
        stage / cfg.output_dir, name=ds.name, quantity=ds.quantity, units=ds.units,
        sample_rate=ds.sample_rate, channels=ds.channels, runs=ds.runs, system=system,
        base_channel=ds.base_channel, truth=ds.truth, frame=ds.frame, gravity_g=ds.gravity_g,
    )
    if cfg.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from ..plots import plot_sweep_response

        fig, axes = plt.subplots(len(channels), 1, figsize=(8, 2.5 * len(channels)),
                                 sharex=True, squeeze=False)
        for c, (col, dof) in enumerate(channels.items()):
            for i, lv in enumerate(levels):
                plot_sweep_response(axes[c, 0], res.time, data[i, c], sweep=sweep,
                                    label=f"{lv:g} g", units=cfg.units, title=f"{col} ({dof})")
        fig.tight_layout()
        fig.savefig(stage / "responses.png", dpi=110)
        plt.close(fig)

"""`simulate` task: sine sweeps of a model written as a measured-data set (docs/identify.md)."""

from __future__ import annotations

import time

import numpy as np
from omegaconf import DictConfig, OmegaConf

from ..io import write_dataset
from ..quantity import G
from ..simulate import Sweep, default_columns, simulate_sweeps, sweep_dataset
from .common import build_system, run_dir, write_metrics

__all__ = ["simulate"]

def _channels(cfg: DictConfig, system) -> dict:
    """CSV column -> DOF name: ``channels``, else the model's ``channels``, else every uz_* DOF."""
    chosen = cfg.get("channels") or cfg.model.get("channels")
    if chosen:
        return dict(OmegaConf.to_container(chosen, resolve=True))
    dofs = [d for d in system.dof_names if d.startswith("uz_")] or list(system.dof_names)
    return default_columns(cfg.quantity, dofs)


def simulate(cfg: DictConfig) -> dict:
    """Simulate the configured sweeps, write the data set, a figure and ``metrics.json``.

    Returns
    -------
    dict
        The metrics (also in ``metrics.json``): runtime, step, per-run peak amplitudes, ...
    """
    import torch

    t0 = time.perf_counter()
    system = build_system(cfg.model)
    channels = _channels(cfg, system)
    sweep = Sweep(**OmegaConf.to_container(cfg.sweep, resolve=True))
    levels = [float(v) for v in cfg.levels]
    dtype = {"float32": torch.float32, "float64": torch.float64}.get(cfg.dtype)
    if dtype is None:
        raise ValueError(f"`dtype` must be float32 or float64, got {cfg.dtype!r}")
    units = cfg.units
    if cfg.noise_std_g and cfg.quantity != "acceleration":
        raise ValueError(
            f"`noise_std_g` applies to acceleration data, got quantity={cfg.quantity!r}"
        )
    res = simulate_sweeps(
        system, kn=float(cfg.kn), delta=float(cfg.delta), level_g=levels, sweep=sweep,
        channels=tuple(channels.values()), quantity=cfg.quantity, frame=cfg.frame,
        sample_rate=float(cfg.sample_rate), method=cfg.method, device=cfg.device, dtype=dtype,
        cutoff_hz=cfg.cutoff_hz, quasi_static_hz=cfg.get("quasi_static_hz"),
    )
    noise = None
    if cfg.noise_std_g:
        rng = np.random.default_rng(int(cfg.seed))
        noise = rng.normal(0.0, float(cfg.noise_std_g) * G, size=res.signals.shape)
    # what a test records: the responses, the sweep hint, the level and, for absolute
    # accelerations, the base (control) accelerometer
    ds = sweep_dataset(res, columns=channels, units=units, noise=noise, name=cfg.name)
    runs, data = ds.runs, np.stack([run.data for run in ds.runs])
    out = run_dir()
    manifest = write_dataset(
        out / cfg.output_dir, name=ds.name, quantity=ds.quantity, units=ds.units,
        sample_rate=ds.sample_rate, channels=ds.channels, runs=runs, system=system,
        base_channel=ds.base_channel, truth=ds.truth,
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
                                    label=f"{lv:g} g", units=units, title=f"{col} ({dof})")
        fig.tight_layout()
        fig.savefig(out / "responses.png", dpi=110)
        plt.close(fig)
    metrics = {
        "runtime_s": time.perf_counter() - t0,
        "n_sweeps": len(levels),
        "n_diverged": int(res.diverged.sum()),
        "dt_s": res.dt,
        "steps_per_sample": res.steps_per_sample,
        "omega_max_dt": res.omega_max * res.dt,
        "engine": res.engine,
        "dataset": str(manifest),
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
    write_metrics(out, metrics)
    return metrics

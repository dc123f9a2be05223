"""`identify` task: kn and delta from a measured data set (DESIGN.md §3), with report and figures.

Steps: read and validate the data set, load its model, extract the resonance (jump) points of
every channel of every run (ACMP, the sweep hint when given, the base channel subtracted when
given), fit the backbone (multi-start baseline), write ``identification.json``, ``report.md``,
``backbone_fit.png`` (the paper's Fig. 12), ``residuals.png`` and ``metrics.json``.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np
from omegaconf import DictConfig, OmegaConf

from ..io import DatasetError, read_dataset
from .common import run_dir, write_metrics

__all__ = ["identify", "IdentificationError", "bundled_example"]


class IdentificationError(ValueError):
    """The data set is valid but does not support an identification (e.g. too few points)."""


def bundled_example() -> Path:
    """Manifest of the example data set shipped with the source tree (examples/fin_sweeps)."""
    return Path(__file__).resolve().parents[3] / "examples" / "fin_sweeps" / "manifest.yaml"


def _data_path(cfg: DictConfig) -> Path:
    if cfg.get("data") in (None, ""):
        path = bundled_example()
        if not path.is_file():
            raise DatasetError(
                f"no `data=` given and the bundled example {path} is not there; "
                "run `python scripts/identify.py data=PATH/manifest.yaml`"
            )
        return path
    from hydra.utils import to_absolute_path

    return Path(to_absolute_path(str(cfg.data)))


def _finite(x):
    """JSON-safe number: NaN/inf -> None."""
    x = float(x)
    return x if math.isfinite(x) else None


def _extract(ds, cfg: DictConfig):
    """Points of every usable run (one run at a time, with a progress bar)."""
    from tqdm import tqdm

    from ..signal import BackbonePoints, extract_backbone_points
    from ..simulate.sweep import Sweep

    ex = OmegaConf.to_container(cfg.extraction, resolve=True)
    points, curves, rejected = [], [], {}
    for run in tqdm(ds.runs, desc="extracting points", unit="run", disable=len(ds.runs) < 2):
        if run.reason:
            rejected[run.file] = run.reason
            continue
        sweep = Sweep(**run.sweep) if (run.sweep and cfg.use_sweep_hint) else None
        base = None if run.base is None else [ds.to_si(run.base)]
        res = extract_backbone_points(
            [ds.to_si(run.data)], ds.sample_rate, quantity=ds.quantity,
            channel_names=list(ds.channels), run_names=[run.file], sweep=sweep, base=base, **ex,
        )
        points += res.points
        curves += res.curves
        if res.rejected_runs:
            rejected[run.file] = "; ".join(dict.fromkeys(p.reason for p in res.points))
    pts = BackbonePoints(tuple(points), tuple(rejected), tuple(curves), ds.quantity,
                         ex.get("method", "acmp"))
    return pts, rejected


def _load_inverse(cfg: DictConfig, system):
    """The inverse model of ``inverse.checkpoint``, checked against ``system``, or None."""
    if not (cfg.get("inverse") and cfg.inverse.get("checkpoint")):
        return None
    from hydra.utils import to_absolute_path

    from ..inverse import load_inverse_model

    return load_inverse_model(Path(to_absolute_path(str(cfg.inverse.checkpoint))), system=system)


def _inverse_estimate(model, points) -> dict:
    """The inverse model's estimate of (kn, delta) from the points (the fit's start)."""
    from ..inverse import InverseModelError

    try:
        kn, delta, s_kn, s_delta = model.predict_points(points)
    except ValueError as exc:  # e.g. a channel the network was not trained on
        raise InverseModelError(f"{model.path}: {exc}") from None
    est = {"kn": float(kn), "delta": float(delta), "log_kn_std": float(s_kn),
           "log_delta_std": float(s_delta), "checkpoint": str(model.path)}
    print(f"inverse model: kn = {kn:.4g} N·m/rad (x/÷ {np.exp(s_kn):.3f}), "
          f"delta = {delta:.4g} rad (x/÷ {np.exp(s_delta):.3f})")
    return est


def _backbone_overlay(system, fit, dofs: dict, backbone: str, mode: int):
    """Identified backbone: frequency [Hz] (m,) and amplitude [m] (m,) per CSV column."""
    from ..backbone import backbone_curve

    bc = backbone_curve(system, method=backbone, kn=fit.kn, delta=fit.delta, mode=mode)
    f = bc.frequency_hz[0]
    return {col: (f, bc.amplitude[0][:, system.dof_names.index(d)]) for col, d in dofs.items()}


def _figures(out: Path, pts, fit, overlay: dict, used_cols: list) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..plots import plot_backbone_points, plot_fit_residuals

    cols = list(overlay)
    fig, axes = plt.subplots(1, len(cols), figsize=(5.5 * len(cols), 4.2), squeeze=False)
    for ax, col in zip(axes[0], cols, strict=True):
        f, x = overlay[col]
        mine = [c for c in pts.curves if c.channel == col and c.amplitude_m.size]
        top = max((np.nanmax(c.amplitude_m) for c in mine), default=np.nanmax(x))
        f_lo = min((np.nanmin(c.frequency) for c in mine), default=np.nanmin(f))
        keep = (x <= 1.3 * top) & (f >= f_lo - 3.0)  # the measured band, 3 Hz below it
        plot_backbone_points(ax, pts, channel=col, backbone=(f[keep], x[keep]))
        ax.set_title(f"{col}: kn = {fit.kn:.4g} N m/rad, delta = {fit.delta:.4g} rad", fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "backbone_fit.png", dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    used = pts.used()
    plot_fit_residuals(ax, [p.f_hz for p in used], fit.residuals, labels=used_cols)
    fig.tight_layout()
    fig.savefig(out / "residuals.png", dpi=110)
    plt.close(fig)
    return ["backbone_fit.png", "residuals.png"]


def _ci(v) -> str:
    return f"[{v[0]:.5g}, {v[1]:.5g}]"


def _report(ds, data_path, result: dict, fit, truth_err: dict | None, figures) -> str:
    lines = [
        "# Freeplay identification", "",
        f"- data set: {ds.name or '(unnamed)'} (`{data_path}`)",
        f"- model: `{ds.model}`",
        f"- quantity: {ds.quantity} [{ds.units}], {ds.sample_rate:g} Hz, "
        f"{len(ds.runs)} runs, channels {ds.channels}"
        + (f", base channel `{ds.base_channel}` subtracted" if ds.base_channel else ""),
        f"- backbone: {result['backbone']}, start: {result['init']}, "
        f"runtime {result['runtime_s']:.2f} s", "",
        "## Result", "",
        "| parameter | identified | 95 % CI (Jacobian) |"
        + (" 95 % CI (bootstrap) |" if fit.kn_ci95_bootstrap else ""),
        "|---|---|---|" + ("---|" if fit.kn_ci95_bootstrap else ""),
    ]
    for name, unit, boot in (("kn", "N·m/rad", fit.kn_ci95_bootstrap),
                             ("delta", "rad", fit.delta_ci95_bootstrap)):
        row = f"| {name} [{unit}] | {result[name]:.5g} | {_ci(result[name + '_ci95'])} |"
        lines.append(row + (f" {_ci(boot)} |" if boot else ""))
    lines += ["", f"Residual RMS (relative frequency): {result['residual_rms']:.3e}"]
    est = result.get("inverse_estimate")
    if est:
        lines += ["", f"Start from the inverse model (`{est['checkpoint']}`): kn = "
                  f"{est['kn']:.5g} N·m/rad (×/÷ {math.exp(est['log_kn_std']):.3f}), delta = "
                  f"{est['delta']:.5g} rad (×/÷ {math.exp(est['log_delta_std']):.3f}); the fit "
                  f"took {fit.n_evaluations} objective evaluations."]
    if truth_err:
        lines += ["", "## Against the data set's truth", "",
                  "| parameter | truth | identified | error |", "|---|---|---|---|"]
        for k in ("kn", "delta"):
            lines.append(f"| {k} | {ds.truth[k]:.5g} | {result[k]:.5g} | "
                         f"{100 * truth_err[k]:+.2f} % |")
    lines += ["", "## Fitting points", "",
              "| run | channel | f [Hz] | amplitude [mm] | used | residual [%] | reason |",
              "|---|---|---|---|---|---|---|"]
    res = iter(fit.residuals)
    for p in result["points"]:
        r = f"{100 * next(res):+.3f}" if p["used"] else ""
        f = "–" if p["f_hz"] is None else f"{p['f_hz']:.3f}"
        a = "–" if p["amplitude_m"] is None else f"{1e3 * p['amplitude_m']:.4f}"
        lines.append(f"| {p['run']} | {p['channel']} | {f} | {a} | "
                     f"{'yes' if p['used'] else 'no'} | {r} | {p['reason']} |")
    lines += ["", "## Rejected runs", ""]
    lines += [f"- `{r['run']}`: {r['reason']}" for r in result["rejected_runs"]] or ["none"]
    lines += ["", "## Figures", ""] + [f"![{f}]({f})" for f in figures]
    return "\n".join(lines) + "\n"


def identify(cfg: DictConfig) -> dict:
    """Identify (kn, delta) from the configured data set; write the result, report and figures.

    Returns
    -------
    dict
        The metrics (also in ``metrics.json``): kn, delta, CIs, residual RMS, point counts,
        runtime, and the errors against the manifest's ``truth`` when it has one.

    Raises
    ------
    DatasetError
        The data set breaks the contract (the message names the file, run, field or column).
    IdentificationError
        Fewer than two usable fitting points (the message lists the rejected runs).
    """
    from ..backbone import backbone_method
    from ..fit import FittingPoints, fit_backbone, multistart_grid
    from ..model import load_system

    t0 = time.perf_counter()
    backbone_method(cfg.backbone, argument="backbone")
    data_path = _data_path(cfg)
    ds = read_dataset(data_path)
    if ds.model is None:
        raise DatasetError(f"{ds.path}: missing field `model` (the linear model file, .npz)")
    system = load_system(ds.model)
    inverse_model = _load_inverse(cfg, system)  # a wrong checkpoint fails before the extraction
    pts, rejected = _extract(ds, cfg)
    used = pts.used()
    if len(used) < 2:
        why = "; ".join(f"{r}: {w}" for r, w in rejected.items()) or "none rejected"
        raise IdentificationError(
            f"{ds.path}: {len(used)} usable fitting point(s), at least 2 are needed "
            f"(rejected runs: {why}); add runs at higher levels that resonate in the band"
        )
    from ..fit import count_resonances

    if count_resonances([p.f_hz for p in used]) < 2:
        raise IdentificationError(
            f"{ds.path}: the {len(used)} usable points lie at one resonance (within 0.5 %: "
            f"{used[0].f_hz:.3f} Hz, run {used[0].run}): kn and delta need resonances at two "
            "or more levels; add runs at other levels that resonate in the band"
        )
    records = FittingPoints.from_extraction(pts, dofs=ds.channels)
    inverse = None
    if inverse_model is not None:
        inverse = _inverse_estimate(inverse_model, records)
        starts, label = (inverse["kn"], inverse["delta"]), "inverse"
    else:
        ms = cfg.multistart
        starts = multistart_grid(int(ms.n), kn_range=tuple(ms.kn_range),
                                 delta_range=tuple(ms.delta_range))
        label = "multistart"
    fit = fit_backbone(records, system, init=starts, init_label=label,
                       backbone=cfg.backbone, mode=int(cfg.mode),
                       n_bootstrap=int(cfg.n_bootstrap), seed=int(cfg.seed))
    runtime = time.perf_counter() - t0
    result = {
        "kn": fit.kn,
        "delta": fit.delta,
        "kn_ci95": list(fit.kn_ci95),
        "delta_ci95": list(fit.delta_ci95),
        "points": [
            {"channel": p.channel, "dof": ds.channels[p.channel], "run": p.run,
             "f_hz": _finite(p.f_hz), "amplitude_m": _finite(p.amplitude_m),
             "used": bool(p.used), "reason": p.reason}
            for p in pts.points
        ],
        "rejected_runs": [{"run": r, "reason": w} for r, w in rejected.items()],
        "residual_rms": fit.residual_rms,
        "backbone": fit.backbone,
        "init": fit.init,
        "runtime_s": runtime,
    }
    if inverse is not None:
        result["inverse_estimate"] = inverse
    if fit.kn_ci95_bootstrap is not None:
        result["kn_ci95_bootstrap"] = list(fit.kn_ci95_bootstrap)
        result["delta_ci95_bootstrap"] = list(fit.delta_ci95_bootstrap)
    truth_err = None
    if ds.truth:
        truth_err = {k: result[k] / ds.truth[k] - 1 for k in ("kn", "delta") if k in ds.truth}
    out = run_dir()
    figures = []
    if cfg.plot:
        overlay = _backbone_overlay(system, fit, ds.channels, cfg.backbone, int(cfg.mode))
        figures = _figures(out, pts, fit, overlay, [p.channel for p in used])
    for name, text in (("identification.json", json.dumps(result, indent=2)),
                       ("report.md", _report(ds, data_path, result, fit, truth_err, figures))):
        tmp = out / (name + ".tmp")
        tmp.write_text(text)
        tmp.replace(out / name)
    print(f"kn    = {fit.kn:.5g} N·m/rad  (95 % CI {_ci(fit.kn_ci95)})")
    print(f"delta = {fit.delta:.5g} rad  (95 % CI {_ci(fit.delta_ci95)})")
    if truth_err:
        print("truth: " + ", ".join(f"{k} = {ds.truth[k]:.5g} ({100 * e:+.2f} %)"
                                    for k, e in truth_err.items()))
    for r in result["rejected_runs"]:
        print(f"rejected run {r['run']}: {r['reason']}")
    print(f"{len(used)} points, {len(rejected)} rejected runs, {runtime:.1f} s -> {out}")
    metrics = {
        "kn": fit.kn, "delta": fit.delta, "kn_ci95": result["kn_ci95"],
        "delta_ci95": result["delta_ci95"], "residual_rms": fit.residual_rms,
        "n_points_used": len(used), "n_points": len(pts.points),
        "n_rejected_runs": len(rejected), "n_evaluations": fit.n_evaluations,
        "fit_runtime_s": fit.runtime_s, "runtime_s": time.perf_counter() - t0,
        "dataset": str(ds.path),
    }
    if truth_err:
        metrics.update({f"{k}_rel_error": v for k, v in truth_err.items()})
    write_metrics(out, metrics)
    return metrics

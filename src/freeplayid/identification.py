"""The measured-data pipeline as one library function: :func:`identify` -> :class:`Identification`.

    from freeplayid import identify
    from freeplayid.io import read_dataset

    result = identify(read_dataset("examples/fin_sweeps"))
    print(result.kn, result.delta, result.kn_ci95)

Steps: the data set's linear model (or ``system``), the resonance (jump) point of every channel of
every usable run (ACMP or lock-in, the base channel subtracted when the data set has one, the
run's sweep hint when given), the start (the neural inverse model's estimate or the multi-start
grid), the backbone least squares with its intervals. No Hydra, no files: ``scripts/identify.py``
maps its config to these arguments and writes what the returned object holds.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from .errors import InputError

__all__ = ["Identification", "IdentificationError", "SuspectResultError", "identify"]


class IdentificationError(InputError):
    """The data set is valid but does not support an identification (e.g. too few points).

    ``points`` holds what the extraction found (a ``BackbonePoints``), when it got that far.
    """

    def __init__(self, message: str, *, points=None) -> None:
        super().__init__(message)
        self.points = points


class SuspectResultError(InputError):
    """An identification whose verdict is ``suspect``, refused by a command (its reasons say why;
    ``allow_suspect=true`` accepts it)."""


@dataclass(frozen=True)
class Identification:
    """Result of :func:`identify`: (kn, delta), their intervals and everything behind them.

    Attributes
    ----------
    kn : float [N m/rad]
    delta : float [rad]
    kn_ci95, delta_ci95 : (float, float)
        95 % intervals from the fit's Jacobian.
    kn_ci95_bootstrap, delta_ci95_bootstrap : (float, float) or None
        95 % percentile intervals of a bootstrap over the points, if requested.
    residual_rms : float [-]
        RMS relative frequency residual of the used points.
    backbone : str
        Backbone method of the fit ("dfa", "hb").
    init : str
        What started the fit: "inverse", "multistart" or "given".
    runtime_s : float [s]
        Wall time of :func:`identify`.
    points : freeplayid.signal.BackbonePoints
        Every run's and channel's candidate point, used or not, with its amplitude curve.
    dofs : dict of str -> str
        Channel (data-set column) -> model DOF name.
    rejected_runs : tuple of (str, str)
        (run, reason) of every run without a usable point.
    fit : freeplayid.fit.FitResult
    system : freeplayid.model.FreeplaySystem
        The linear model identified against.
    mode : int
        Backbone mode (0: the lowest).
    inverse_estimate : dict or None
        The inverse model's estimate (kn, delta, log_kn_std, log_delta_std, checkpoint).
    truth : dict or None
        ``{"kn", "delta"}`` of a simulated data set (informational).
    dataset : dict
        What the report says of the data set: name, path, model, quantity, units, sample_rate,
        n_runs, channels, base_channel.
    verdict : freeplayid.verdict.Verdict
        ``ok`` or ``suspect`` with the reasons: the plausibility checks of the result and the
        data (:mod:`freeplayid.verdict`).
    validation : freeplayid.model.ModeValidation or None
        The zero-clearance check (paper's Table 11): the model closed at the identified kn
        against the data set's ``reference_modes``, if it has them.
    """

    kn: float
    delta: float
    kn_ci95: tuple
    delta_ci95: tuple
    residual_rms: float
    backbone: str
    init: str
    runtime_s: float
    points: object
    dofs: dict
    rejected_runs: tuple
    fit: object
    system: object
    mode: int = 0
    kn_ci95_bootstrap: tuple | None = None
    delta_ci95_bootstrap: tuple | None = None
    inverse_estimate: dict | None = None
    truth: dict | None = None
    dataset: dict = field(default_factory=dict)
    verdict: object = None
    validation: object | None = None

    @property
    def used_points(self) -> tuple:
        """The points the fit used (``BackbonePoint``), in the order of ``fit.residuals``."""
        return self.points.used()

    @property
    def truth_error(self) -> dict | None:
        """Relative errors ``{"kn": ..., "delta": ...}`` against ``truth``, if known."""
        if not self.truth:
            return None
        return {k: getattr(self, k) / self.truth[k] - 1 for k in ("kn", "delta") if k in self.truth}

    def point_records(self) -> list[dict]:
        """Every candidate point as a JSON-ready record (run, channel, dof, f_hz, amplitude_m,
        used, reason), NaN as None."""
        out = []
        for rec in self.points.to_records():
            rec = {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                   for k, v in rec.items()}
            rec["dof"] = self.dofs.get(rec["channel"])
            out.append(rec)
        return out

    def to_dict(self) -> dict:
        """The ``identification.json`` record (see :mod:`freeplayid.io.result`)."""
        out = {
            "kn": self.kn,
            "delta": self.delta,
            "kn_ci95": list(self.kn_ci95),
            "delta_ci95": list(self.delta_ci95),
            "points": self.point_records(),
            "rejected_runs": [{"run": r, "reason": w} for r, w in self.rejected_runs],
            "residual_rms": self.residual_rms,
            "backbone": self.backbone,
            "init": self.init,
            "runtime_s": self.runtime_s,
        }
        if self.inverse_estimate is not None:
            out["inverse_estimate"] = dict(self.inverse_estimate)
        if self.kn_ci95_bootstrap is not None:
            out["kn_ci95_bootstrap"] = list(self.kn_ci95_bootstrap)
            out["delta_ci95_bootstrap"] = list(self.delta_ci95_bootstrap)
        if self.truth:
            out["truth"] = dict(self.truth)
        if self.verdict is not None:
            out["verdict"] = self.verdict.status
            out["verdict_reasons"] = list(self.verdict.reasons)
            out["checks"] = [c.to_dict() for c in self.verdict.checks]
        if self.validation is not None:
            out["validation"] = _validation_record(self.validation)
        return out

    def backbone_overlay(self) -> dict:
        """The identified backbone per channel: ``{column: (f [Hz] (m,), amplitude [m] (m,))}``."""
        from .backbone import backbone_curve

        bc = backbone_curve(self.system, method=self.backbone, kn=self.kn, delta=self.delta,
                            mode=self.mode)
        f = bc.frequency_hz[0]
        names = self.system.dof_names
        return {col: (f, bc.amplitude[0][:, names.index(d)]) for col, d in self.dofs.items()}

    def summary(self) -> str:
        """The lines a command prints: the estimates, the truth if known, the rejected runs."""
        lines = [f"kn    = {self.kn:.5g} N·m/rad  (95 % CI {_ci(self.kn_ci95)})",
                 f"delta = {self.delta:.5g} rad  (95 % CI {_ci(self.delta_ci95)})"]
        err = self.truth_error
        if err:
            lines.append("truth: " + ", ".join(f"{k} = {self.truth[k]:.5g} ({100 * e:+.2f} %)"
                                               for k, e in err.items()))
        lines += [f"rejected run {r}: {w}" for r, w in self.rejected_runs]
        if self.verdict is not None:
            lines.append(f"verdict: {self.verdict.status}" + "".join(
                f"\n  - {why}" for why in self.verdict.reasons))
        return "\n".join(lines)

    def report(self, figures: Sequence[str] = ()) -> str:
        """``report.md``: the data set, the result, the fitting points, the rejected runs."""
        ds, fit = self.dataset, self.fit
        boot = self.kn_ci95_bootstrap is not None
        lines = [
            "# Freeplay identification", "",
            f"- data set: {ds.get('name') or '(unnamed)'} (`{ds.get('path')}`)",
            f"- model: `{ds.get('model')}`",
            f"- quantity: {ds.get('quantity')} [{ds.get('units')}], "
            f"{ds.get('sample_rate', float('nan')):g} Hz, {ds.get('n_runs')} runs, "
            f"channels {self.dofs}"
            + (f", base channel `{ds['base_channel']}` subtracted"
               if ds.get("base_channel") else ""),
            f"- backbone: {self.backbone}, start: {self.init}, runtime {self.runtime_s:.2f} s", "",
            "## Result", "",
            "| parameter | identified | 95 % CI (Jacobian) |" + (" 95 % CI (bootstrap) |" if boot
                                                               else ""),
            "|---|---|---|" + ("---|" if boot else ""),
        ]
        for name, unit, b in (("kn", "N·m/rad", self.kn_ci95_bootstrap),
                              ("delta", "rad", self.delta_ci95_bootstrap)):
            row = f"| {name} [{unit}] | {getattr(self, name):.5g} | " \
                  f"{_ci(getattr(self, name + '_ci95'))} |"
            lines.append(row + (f" {_ci(b)} |" if b else ""))
        lines += ["", f"Residual RMS (relative frequency): {self.residual_rms:.3e}"]
        if self.verdict is not None:
            lines += ["", f"## Verdict: {self.verdict.status}", "", "| check | passed | finding |",
                      "|---|---|---|"]
            lines += [f"| {c.name} | {'yes' if c.passed else '**no**'} | {c.message} |"
                      for c in self.verdict.checks]
        est = self.inverse_estimate
        if est:
            lines += ["", f"Start from the inverse model (`{est['checkpoint']}`): kn = "
                      f"{est['kn']:.5g} N·m/rad (×/÷ {math.exp(est['log_kn_std']):.3f}), delta = "
                      f"{est['delta']:.5g} rad (×/÷ {math.exp(est['log_delta_std']):.3f}); the fit "
                      f"took {fit.n_evaluations} objective evaluations."]
        err = self.truth_error
        if err:
            lines += ["", "## Against the data set's truth", "",
                      "| parameter | truth | identified | error |", "|---|---|---|---|"]
            for k, e in err.items():
                lines.append(f"| {k} | {self.truth[k]:.5g} | {getattr(self, k):.5g} | "
                             f"{100 * e:+.2f} % |")
        lines += ["", "## Fitting points", "",
                  "| run | channel | f [Hz] | amplitude [mm] | used | residual [%] | reason |",
                  "|---|---|---|---|---|---|---|"]
        res = iter(fit.residuals)
        for p in self.point_records():
            r = f"{100 * next(res):+.3f}" if p["used"] else ""
            f = "–" if p["f_hz"] is None else f"{p['f_hz']:.3f}"
            a = "–" if p["amplitude_m"] is None else f"{1e3 * p['amplitude_m']:.4f}"
            lines.append(f"| {p['run']} | {p['channel']} | {f} | {a} | "
                         f"{'yes' if p['used'] else 'no'} | {r} | {p['reason']} |")
        lines += ["", "## Rejected runs", ""]
        lines += [f"- `{r}`: {w}" for r, w in self.rejected_runs] or ["none"]
        lines += _validation_lines(self.validation)
        lines += ["", "## Figures", ""] + [f"![{f}]({f})" for f in figures]
        return "\n".join(lines) + "\n"


# ---- the zero-clearance check (paper's Table 11), self-contained
def _zero_clearance_check(dataset, system, kn: float):
    """:func:`freeplayid.model.validate_modes` of the closed model against the data set's
    ``reference_modes`` (None without them)."""
    ref = getattr(dataset, "reference_modes", None)
    if not ref:
        return None
    from .model import validate_modes

    return validate_modes(system, kn, ref["frequencies_hz"], ref["shapes"], ref["dofs"])


def _validation_record(v) -> dict:
    return {"reference_hz": v.reference_hz.tolist(), "model_hz": v.model_hz.tolist(),
            "error_hz": v.error_hz.tolist(), "mac": v.mac.tolist(), "passed": v.passed,
            "max_error_hz": 1.0, "min_mac": 0.98}


def _validation_lines(v) -> list[str]:
    if v is None:
        return []
    rows = ["", "## Zero-clearance check (Table 11 analogue)", "",
            "The model with the hinges closed at the identified kn against the reference modes "
            "of the fin with its clearance sealed; pass: |error| < 1 Hz and MAC > 0.98.", "",
            "| mode | reference [Hz] | model [Hz] | error [Hz] | MAC | pass |",
            "|---|---|---|---|---|---|"]
    for i in range(v.reference_hz.size):
        ok = abs(v.error_hz[i]) < 1.0 and v.mac[i] > 0.98
        rows.append(f"| {i + 1} | {v.reference_hz[i]:.2f} | {v.model_hz[i]:.2f} | "
                    f"{v.error_hz[i]:+.2f} | {v.mac[i]:.4f} | {'yes' if ok else 'NO'} |")
    rows += ["", f"Zero-clearance check: {'passed' if v.passed else 'FAILED'}."]
    return rows


def _ci(v) -> str:
    return f"[{v[0]:.5g}, {v[1]:.5g}]"


def _extract(ds, *, extraction: Mapping, use_sweep_hint: bool, progress: bool):
    """Points of every usable run (one run at a time) and the rejected runs {run: reason}."""
    from tqdm import tqdm

    from .signal import BackbonePoints, extract_backbone_points
    from .sweep import Sweep

    points, curves, rejected = [], [], {}
    bar = tqdm(ds.runs, desc="extracting points", unit="run",
               disable=not progress or len(ds.runs) < 2)
    for run in bar:
        if run.reason:
            rejected[run.file] = run.reason
            continue
        sweep = Sweep(**run.sweep) if (run.sweep and use_sweep_hint) else None
        base = None if run.base is None else [ds.to_si(run.base)]
        res = extract_backbone_points(
            [ds.to_si(run.data)], ds.sample_rate, quantity=ds.quantity,
            channel_names=list(ds.channels), run_names=[run.file], sweep=sweep, base=base,
            base_name=ds.base_channel or "base", **extraction,
        )
        points += res.points
        curves += res.curves
        if res.rejected_runs:
            rejected[run.file] = "; ".join(dict.fromkeys(p.reason for p in res.points))
    pts = BackbonePoints(tuple(points), tuple(rejected), tuple(curves), ds.quantity,
                         extraction.get("method", "acmp"))
    return pts, rejected


def _check_enough(pts, rejected: dict, where) -> None:
    """IdentificationError unless the used points span two resonances or more."""
    from .fit import count_resonances

    used = pts.used()
    if len(used) < 2:
        why = "; ".join(f"{r}: {w}" for r, w in rejected.items()) or "none rejected"
        raise IdentificationError(
            f"{where}: {len(used)} usable fitting point(s), at least 2 are needed "
            f"(rejected runs: {why}); add runs at higher levels that resonate in the band",
            points=pts,
        )
    if count_resonances([p.f_hz for p in used]) < 2:
        raise IdentificationError(
            f"{where}: the {len(used)} usable points lie at one resonance (within 0.5 %: "
            f"{used[0].f_hz:.3f} Hz, run {used[0].run}): kn and delta need resonances at two "
            "or more levels; add runs at other levels that resonate in the band",
            points=pts,
        )


def _inverse_start(model, points) -> dict:
    """The inverse model's estimate of (kn, delta) from the fitting points (the fit's start)."""
    try:
        kn, delta, s_kn, s_delta = model.predict_points(points)
    except ValueError as exc:  # e.g. a channel the network was not trained on
        from .inverse import InverseModelError

        raise InverseModelError(f"{model.path}: {exc}") from None
    return {"kn": float(kn), "delta": float(delta), "log_kn_std": float(s_kn),
            "log_delta_std": float(s_delta), "checkpoint": str(model.path)}


def identify(
    dataset,
    *,
    system=None,
    backbone: str = "dfa",
    init=None,
    extraction: Mapping | None = None,
    use_sweep_hint: bool = True,
    multistart: Mapping | None = None,
    mode: int = 0,
    n_bootstrap: int = 0,
    seed: int = 0,
    progress: bool = True,
) -> Identification:
    """Identify (kn, delta) from a measured (or simulated) sine-sweep data set.

    Parameters
    ----------
    dataset : freeplayid.io.Dataset or path
        A data set (:func:`freeplayid.io.read_dataset`, or built in memory) or the path of its
        folder or ``manifest.yaml``.
    system : FreeplaySystem, optional
        The linear model; default the data set's ``model`` file.
    backbone : str
        Backbone method of the fit (``freeplayid.backbone`` registry: "dfa", "hb").
    init : InverseModel, (kn, delta), sequence of them, or None
        The fit's start: a trained inverse model (:func:`freeplayid.inverse.load_inverse_model`;
        its estimate from the points), given start(s), or None for the multi-start grid.
    extraction : mapping, optional
        Options of :func:`freeplayid.signal.extract_backbone_points` (``method``,
        ``bandwidth_hz``, ``trim_s``, the jump rule, ``min_snr_db``).
    use_sweep_hint : bool
        Use the runs' ``sweep`` hints (ACMP's start, the band, the rate).
    multistart : mapping, optional
        ``n``, ``kn_range`` [N m/rad], ``delta_range`` [rad] of the multi-start grid (default:
        those of :func:`freeplayid.fit.multistart_grid`).
    mode : int
        Backbone mode (0: the lowest, first bending).
    n_bootstrap : int
        Bootstrap resamples over the points for percentile intervals (0: none).
    seed : int
        Bootstrap seed.
    progress : bool
        Show a progress bar over the runs.

    Returns
    -------
    Identification

    Raises
    ------
    DatasetError
        The data set breaks its contract (the message names the file, run, field or column).
    SystemFileError
        The model file is broken.
    IdentificationError
        Fewer than two usable points, or all of them at one resonance.
    InverseModelError
        The inverse model cannot take these points (e.g. a channel it was not trained on).
    """
    from .backbone import backbone_method
    from .fit import FittingPoints, fit_backbone, multistart_grid
    from .io import DatasetError, read_dataset
    from .model import FreeplaySystem, load_system
    from .verdict import base_level_checks, fit_checks, make_verdict

    t0 = time.perf_counter()
    backbone_method(backbone, argument="backbone")  # an unknown name fails before any work
    if isinstance(dataset, (str, os.PathLike)):
        dataset = read_dataset(dataset)
    if system is None:
        if dataset.model is None:
            raise DatasetError(f"{dataset.path}: missing field `model` (the linear model file, "
                               ".npz); or pass `system`")
        system = load_system(dataset.model)
    elif not isinstance(system, FreeplaySystem):
        raise TypeError(f"`system` must be a FreeplaySystem, got {type(system).__name__}")
    where = dataset.path or dataset.name or "data set"
    pts, rejected = _extract(dataset, extraction=dict(extraction or {}),
                             use_sweep_hint=use_sweep_hint, progress=progress)
    _check_enough(pts, rejected, where)
    points = FittingPoints.from_extraction(pts, dofs=dataset.channels)
    inverse = None
    if hasattr(init, "predict_points"):
        inverse = _inverse_start(init, points)
        starts, label = (inverse["kn"], inverse["delta"]), "inverse"
    elif init is None and multistart:
        starts, label = multistart_grid(**{k: v if k == "n" else tuple(v)
                                           for k, v in multistart.items()}), "multistart"
    else:
        starts, label = init, None
    fit = fit_backbone(points, system, init=starts, init_label=label, backbone=backbone,
                       mode=int(mode), n_bootstrap=int(n_bootstrap), seed=int(seed))
    verdict = make_verdict(base_level_checks(dataset)
                           + fit_checks(points, fit, system, pts, mode=int(mode)))
    return Identification(
        kn=fit.kn,
        delta=fit.delta,
        kn_ci95=tuple(fit.kn_ci95),
        delta_ci95=tuple(fit.delta_ci95),
        residual_rms=fit.residual_rms,
        backbone=fit.backbone,
        init=fit.init,
        runtime_s=time.perf_counter() - t0,
        points=pts,
        dofs=dict(dataset.channels),
        rejected_runs=tuple(rejected.items()),
        fit=fit,
        system=system,
        mode=int(mode),
        kn_ci95_bootstrap=fit.kn_ci95_bootstrap,
        delta_ci95_bootstrap=fit.delta_ci95_bootstrap,
        inverse_estimate=inverse,
        truth=dict(dataset.truth) if dataset.truth else None,
        dataset={
            "name": dataset.name, "path": str(dataset.path) if dataset.path else None,
            "model": str(dataset.model) if dataset.model else None,
            "quantity": dataset.quantity, "units": dataset.units,
            "sample_rate": float(dataset.sample_rate), "n_runs": len(dataset.runs),
            "channels": dict(dataset.channels), "base_channel": dataset.base_channel,
        },
        verdict=verdict,
        validation=_zero_clearance_check(dataset, system, fit.kn),
    )

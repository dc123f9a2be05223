"""The result of an identification: :class:`Identification`, its JSON record and its report."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from ..errors import IdentificationError, SuspectResultError

__all__ = ["Identification", "IdentificationError", "SuspectResultError"]


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
    replay: object = None
    interval_source: str = "Jacobian"
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
        if self.replay is not None:
            r = self.replay
            out["replay"] = {
                "kn_fit": r.kn_fit, "delta_fit": r.delta_fit, "converged": r.converged,
                "closest_misfit_se": r.closest_misfit_se,
                "jump_point": r.jump_point, "kn_statistic": r.kn_statistic,
                "delta_statistic": r.delta_statistic, "weights": r.weights,
                "iterations": r.iterations, "offsets": r.offsets,
                "levels": {k: {"level_g": v[0], "source": v[1]} for k, v in r.levels.items()},
                "misfit": r.misfit,
                "damping": None if r.damping is None else r.damping.to_dict(),
                "failure": r.failure or None,
                "kn_ci95_bootstrap": None if r.kn_ci95_replay is None else list(r.kn_ci95_replay),
                "delta_ci95_bootstrap": (None if r.delta_ci95_replay is None
                                         else list(r.delta_ci95_replay)),
                "n_bootstrap": r.n_bootstrap, "noise": r.noise, "sweeps": r.sweeps,
            }
            out["interval_source"] = self.interval_source
        return out

    def backbone_overlay(self) -> dict:
        """The identified backbone per channel: ``{column: (f [Hz] (m,), amplitude [m] (m,))}``."""
        from ..backbone import backbone_curve

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
        if self.replay is not None:
            r = self.replay
            lines += ["", "## Replay (bias correction by indirect inference)", "",
                      f"Plain fit: kn = {r.kn_fit:.5g} N·m/rad, delta = {r.delta_fit:.5g} rad; "
                      f"corrected: kn = {self.kn:.5g}, delta = {self.delta:.5g} "
                      f"({'converged' if r.converged else '**not converged**'} after "
                      f"{len(r.iterations)} replays"
                      + ("" if r.converged or r.closest_misfit_se is None else
                         f"; the closest replay misses the test's statistics by "
                         f"{r.closest_misfit_se:.2g} of their standard error")
                      + "). The replays match the fit of the points "
                      f"taken with jump point `{r.jump_point}`: kn = {r.kn_statistic:.5g}, "
                      f"delta = {r.delta_statistic:.5g}"
                      + ("" if not r.weights else
                         ", each point weighted by its amplitude noise (weights "
                         f"{min(w['weight'] for w in r.weights):.2g} to "
                         f"{max(w['weight'] for w in r.weights):.2g}, median point 1)")
                      + ".", "",
                      "| replay | kn [N·m/rad] | delta [rad] | fit of the replay: kn | delta |",
                      "|---|---|---|---|---|"]
            lines += [f"| {k + 1} | {it['kn']:.5g} | {it['delta']:.5g} | {it['kn_rep']:.5g} | "
                      f"{it['delta_rep']:.5g} |" for k, it in enumerate(r.iterations)]
            lines += ["", "Levels: " + ", ".join(f"{run} {lv:.4g} g ({src})"
                                                  for run, (lv, src) in r.levels.items())]
            if r.sweeps:
                lines += ["", "Sweep laws: " + ", ".join(
                    f"{run} {_sweep_text(sw)} ({sw['source']}"
                    + (f", fit residual {sw['residual_hz']:.2g} Hz" if "residual_hz" in sw else "")
                    + ")" for run, sw in r.sweeps.items())]
            if r.damping is not None:
                lines += ["", f"Damping of the replay: {r.damping.describe()}."]
            if r.failure:
                lines += ["", f"**Replay failed:** {r.failure}; the estimate above is the plain "
                          "fit's."]
            lines += ["", f"95 % intervals: {self.interval_source}."]
            if r.kn_ci95_replay is not None:
                lines += [f"Bootstrap by replay alone: kn {_ci(r.kn_ci95_replay)}, delta "
                          f"{_ci(r.delta_ci95_replay)}."]
            if r.misfit:
                lines += ["", "Measured vs replayed curves (median difference / measured peak): "
                          + ", ".join(f"{run} {100 * m:.2g} %" for run, m in r.misfit.items())]
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
def _ci(v) -> str:
    return f"[{v[0]:.5g}, {v[1]:.5g}]"



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


def _sweep_text(sw: dict) -> str:
    """A replay's sweep-law record in words: "30 -> 50 Hz at 0.1 Hz/s"."""
    rate = (f"{sw['rate_hz_per_s']:.4g} Hz/s" if sw.get("rate_hz_per_s") is not None else
            f"{sw['octaves_per_min']:.4g} octaves/min")
    return f"{sw['start_hz']:.5g} -> {sw['stop_hz']:.5g} Hz at {rate}"

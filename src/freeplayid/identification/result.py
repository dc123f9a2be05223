"""The result of an identification: :class:`Identification` and its JSON record."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from ..errors import IdentificationError, SuspectResultError
from .figures import plot_identification
from .records import findings_text
from .report import (
    PLAIN_FIT_NOTE,
    fit_kind,
    format_ci,
    format_sig,
    play_deg,
    render_report,
    render_summary,
    validation_record,
)

__all__ = ["Identification", "IdentificationError", "SuspectResultError"]


@dataclass(frozen=True, repr=False)
class Identification:
    """Result of :func:`identify`: (kn, delta), their intervals and everything behind them.

    Its ``repr`` is a few lines (kn, delta in mrad, the total play 2·delta in degrees, the
    verdict); Jupyter shows :meth:`_repr_markdown_`'s table. :meth:`plot` draws the command's
    figures, :meth:`points_table` / :meth:`to_dataframe` give the points, and
    :func:`~freeplayid.identification.read_identification` reads one back from its file.

    Attributes
    ----------
    kn : float [N·m/rad]
    delta : float [rad]
        The reported estimate: the corrected fit's with the replay, else the plain fit's.
    kn_ci95, delta_ci95 : (float, float)
        Their 95 % intervals (``interval_source`` says how they were made).
    plain_fit : freeplayid.fit.FitResult
        The plain backbone fit of the measured points (before any correction): its estimate,
        Jacobian (and bootstrap) intervals, residuals, backbone, start.
    runtime_s : float [s]
        Wall time of :func:`identify`.
    points : freeplayid.signal.BackbonePoints
        Every run's and channel's candidate point, used or not, with its amplitude curve.
    dofs : dict of str -> str
        Channel (data-set column) -> model DOF name.
    rejected_runs : tuple of (str, str)
        (run, reason) of every run without a usable point.
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
        n_runs, channels, base_channel, frame.
    verdict : freeplayid.identification.verdict.Verdict
        ``ok`` or ``suspect`` with the reasons: the plausibility checks of the result and the
        data (:mod:`freeplayid.identification.verdict`).
    replay : freeplayid.replay.ReplayResult or None
        The corrected fit (None for the plain fit alone).
    interval_source : str
        How ``kn_ci95`` and ``delta_ci95`` were made.
    validation : freeplayid.model.ModeValidation or None
        The zero-clearance check (paper's Table 11): the model closed at the identified kn
        against the data set's ``reference_modes``, if it has them.
    model_error : freeplayid.identification.model_error.ModelError or None
        What kn owes to the linear model: its update to the sealed modes, the frequency
        uncertainty taken into kn's interval.
    records : freeplayid.quality.RecordReport or None
        What the record checks found before the extraction (rejected runs, ``suspect``
        findings, warnings, repairs, checks skipped); None when they were off.
    """

    kn: float
    delta: float
    kn_ci95: tuple
    delta_ci95: tuple
    plain_fit: object
    runtime_s: float
    points: object
    dofs: dict
    rejected_runs: tuple
    system: object
    mode: int = 0
    inverse_estimate: dict | None = None
    truth: dict | None = None
    dataset: dict = field(default_factory=dict)
    verdict: object = None
    replay: object = None
    interval_source: str = "Jacobian"
    validation: object | None = None
    model_error: object | None = None
    records: object | None = None

    def __repr__(self) -> str:
        """A few lines: how the estimate was made, kn and delta with their 95 % intervals
        (delta in mrad and as the total play in degrees), the verdict (the failed checks'
        names when ``suspect``). The fields are the dataclass's; ``to_dict()`` lists them all."""
        used, n = len(self.used_points), len(self.points.points)
        lines = [f"<Identification: {fit_kind(self)}, {self.backbone} backbone, {used} of {n} "
                 "points used>",
                 f"  kn    = {format_sig(self.kn)} N·m/rad  (95 % CI {format_ci(self.kn_ci95)})",
                 f"  delta = {format_sig(1e3 * self.delta)} mrad  "
                 f"(95 % CI {format_ci(self.delta_ci95, 1e3)}), total play 2·delta = "
                 f"{format_sig(play_deg(self.delta))}°"]
        v = self.verdict
        if v is not None:
            failed = [c.name for c in v.checks if not c.passed]
            lines.append(f"  verdict: {v.status}" + (
                f" (failed: {', '.join(dict.fromkeys(failed))}; .verdict.reasons says why)"
                if failed else ""))
        return "\n".join(lines)

    def _repr_markdown_(self) -> str:
        """What Jupyter shows: the estimates in N·m/rad, rad, mrad and degrees of total play
        with their intervals, the truth if known, and the verdict table."""
        return render_summary(self)

    @property
    def residual_rms(self) -> float:
        """RMS relative frequency residual of the plain fit's points [-]."""
        return self.plain_fit.residual_rms

    @property
    def backbone(self) -> str:
        """Backbone method of the fit ("dfa", "hb")."""
        return self.plain_fit.backbone

    @property
    def init(self) -> str:
        """What started the plain fit: "inverse", "multistart" or "given"."""
        return self.plain_fit.init

    @property
    def kn_ci95_bootstrap(self) -> tuple | None:
        """The plain fit's percentile interval of a bootstrap over the points, if asked for."""
        return self.plain_fit.kn_ci95_bootstrap

    @property
    def delta_ci95_bootstrap(self) -> tuple | None:
        return self.plain_fit.delta_ci95_bootstrap

    @property
    def used_points(self) -> tuple:
        """The points the plain fit used (``BackbonePoint``), in the order of
        ``plain_fit.residuals``."""
        return self.points.used()

    @property
    def truth_error(self) -> dict | None:
        """Relative errors ``{"kn": ..., "delta": ...}`` against ``truth``, if known."""
        if not self.truth:
            return None
        return {k: getattr(self, k) / self.truth[k] - 1 for k in ("kn", "delta") if k in self.truth}

    @property
    def levels(self) -> dict:
        """Each run's base level [g]: the data set's ``level_g``, else the level the replay
        drove it at; None where neither is known. ``{run: level_g}``."""
        known = dict(self.dataset.get("levels") or {})
        replayed = {} if self.replay is None else self.replay.levels
        runs = dict.fromkeys(p.run for p in self.points.points)
        return {run: known.get(run) if known.get(run) is not None
                else (replayed[run][0] if run in replayed else None) for run in runs}

    def points_table(self) -> list[dict]:
        """Every candidate point, used or not, one dict a row (no pandas needed).

        Returns
        -------
        list of dict
            Keys: ``run``, ``level_g`` [g] (None if unknown), ``channel``, ``dof``, ``f_hz``
            [Hz], ``amplitude_m`` [m] (first-harmonic displacement), ``used``, ``reason``
            (empty when used), ``residual`` [-] (the plain fit's (f_BC - f) / f of a used point,
            NaN otherwise), ``snr_db`` [dB], ``noise_db`` [dB] (the record's noise floor
            relative to the point) and ``time_s`` [s] (NaN where not measured or not in the
            result file).
        """
        residuals = iter(self.plain_fit.residuals)  # in the order of the used points
        levels = self.levels
        return [{"run": p.run, "level_g": levels.get(p.run), "channel": p.channel,
                 "dof": self.dofs.get(p.channel), "f_hz": float(p.f_hz),
                 "amplitude_m": float(p.amplitude_m), "used": bool(p.used), "reason": p.reason,
                 "residual": float(next(residuals)) if p.used else math.nan,
                 "snr_db": float(p.snr_db), "noise_db": float(p.noise_db),
                 "time_s": float(p.time_s)}
                for p in self.points.points]

    def to_dataframe(self):
        """:meth:`points_table` as a pandas DataFrame, one row per point (needs pandas).

        Raises
        ------
        ImportError
            pandas is not installed.
        """
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("Identification.to_dataframe() needs pandas (pip install pandas); "
                              "points_table() gives the same rows as dicts") from None
        return pd.DataFrame(self.points_table())

    def point_records(self) -> list[dict]:
        """Every candidate point as a JSON-ready record (run, channel, dof, f_hz, amplitude_m,
        used, reason, residual: the plain fit's (f_BC - f) / f, None for a point not used;
        noise_db: the record's noise floor re the point, which an inverse model reads), NaN as
        None."""
        keys = ("run", "channel", "dof", "f_hz", "amplitude_m", "used", "reason", "residual",
                "noise_db")
        return [{k: (None if isinstance(row[k], float) and not math.isfinite(row[k]) else row[k])
                 for k in keys} for row in self.points_table()]

    def to_dict(self) -> dict:
        """The ``identification.json`` record (see :mod:`freeplayid.io.result_file`)."""
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
            "mode": self.mode,
            "n_evaluations": self.plain_fit.n_evaluations,
            "dataset": dict(self.dataset),
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
            out["validation"] = validation_record(self.validation)
        if self.model_error is not None:
            out["model_error"] = self.model_error.to_dict()
            gaps = self.hinge_gap_records()
            if gaps:
                out["hinge_gaps"] = gaps
        if self.replay is not None:
            out["replay"] = self._replay_record()
            out["interval_source"] = self.interval_source
        out["records"] = None if self.records is None else {
            "findings": self.records.to_records(), "skipped": dict(self.records.skipped)}
        return out

    def hinge_gap_records(self) -> list[dict]:
        """Each hinge's half-gap [rad] and 95 % interval (``linear_model.hinge_gaps``, or where
        the answer's replay had unequal gaps): read against the answer's replay where there is one
        (:class:`~freeplayid.identification.model_error.ReplayedSplit`), else the per-hinge
        fit moved by the replay's correction of delta
        (:meth:`~freeplayid.identification.model_error.HingeGaps.half_gaps`); [] without
        them."""
        err = self.model_error
        replayed = err is not None and err.split is not None and bool(err.split.shares)
        per = None if err is None or not (err.per_hinge or replayed) else err.hinge_gaps
        if per is None:
            return []
        if err.split is not None and err.split.n_copies >= 2:
            sp = err.split
            pairs = zip(sp.half_gaps, sp.intervals(self.delta_ci95), strict=True)
        else:
            pairs = per.half_gaps(self.delta, self.delta_ci95)
        return [{"hinge": n, "delta": v, "delta_ci95": list(ci)} for n, (v, ci) in
                zip(per.hinges, pairs, strict=True)]

    def _replay_record(self) -> dict:
        """The ``replay`` entry of the JSON record."""
        r, boot = self.replay, self.replay.bootstrap
        ok = boot is not None and boot.kn_ci95 is not None
        return {
            "kn_fit": self.plain_fit.kn, "delta_fit": self.plain_fit.delta,
            "converged": r.converged, "closest_misfit_se": r.closest_misfit_se,
            "unconverged_offset": None if getattr(r, "unconverged_offset", None) is None
            else list(r.unconverged_offset),
            "jump_point": r.jump_point, "kn_statistic": r.kn_statistic,
            "gap_shares": None if getattr(r, "gap_shares", None) is None
            else list(r.gap_shares),
            "wide_base": list(getattr(r, "wide_base", ())),
            "delta_statistic": r.delta_statistic,
            "statistic_ci95": _pairs(r.statistic_ci95),
            "replayed_ci95": _pairs(getattr(r, "replayed_ci95", None)),
            "weights": None if not r.weights else [vars(w) for w in r.weights],
            "iterations": [it.to_dict() for it in r.iterations],
            "offsets": [vars(o) for o in r.offsets],
            "levels": {k: {"level_g": v[0], "source": v[1]} for k, v in r.levels.items()},
            "misfit": r.misfit,
            "damping": None if r.damping is None else r.damping.to_dict(),
            "failure": r.failure or None,
            "stopped": getattr(r, "stopped", "") or None,
            "kn_ci95_bootstrap": list(boot.kn_ci95) if ok else None,
            "delta_ci95_bootstrap": list(boot.delta_ci95) if ok else None,
            "n_bootstrap": boot.n if ok else 0,
            "noise": None if boot is None else boot.noise, "sweeps": r.sweeps,
            "excitation": getattr(r, "excitation", None),
            "start": getattr(r, "start", None),
            "resonance": {k: m.to_dict() for k, m in (getattr(r, "resonance", None) or {}).items()},
            "cross_check": None if getattr(r, "cross", None) is None else r.cross.to_dict(),
            "level": None if getattr(r, "level", None) is None else r.level.to_dict(),
            "damping_sensitivity": None if getattr(r, "damping_sensitivity", None) is None
            else r.damping_sensitivity.to_dict(),
            "form_sensitivity": None if getattr(r, "form_sensitivity", None) is None
            else r.form_sensitivity.to_dict(),
            "precision": None if getattr(r, "precision", None) is None
            else r.precision.to_dict(),
            "excitation_noise": None if getattr(r, "excitation_noise", None) is None
            else r.excitation_noise.to_dict(),
            "base_reading": None if getattr(r, "base_reading", None) is None
            else r.base_reading.to_dict(),
            "antialias": None if getattr(r, "antialias", None) is None
            else r.antialias.to_dict(),
            "records_filter": getattr(r, "records_filter", "unknown"),
            "base_timing": None if getattr(r, "base_timing", None) is None
            else r.base_timing.to_dict(),
            "binding_jump": None if getattr(r, "binding_jump", None) is None
            else r.binding_jump.to_dict(),
        }

    def backbone_overlay(self) -> dict:
        """The identified backbone per channel: ``{column: (f [Hz] (m,), amplitude [m] (m,))}``."""
        from ..backbone import backbone_curve

        if self.system is None:
            raise ValueError("the backbone needs the linear model (`system`), which a result "
                             "read from identification.json does not hold")

        bc = backbone_curve(self.system, method=self.backbone, kn=self.kn, delta=self.delta,
                            mode=self.mode)
        f = bc.frequency_hz[0]
        names = self.system.dof_names
        return {col: (f, bc.amplitude[0][:, names.index(d)]) for col, d in self.dofs.items()}

    def plot(self, kind: str = "backbone", ax=None, *, channel: str | None = None):
        """A figure of the result, as ``scripts/identify.py`` writes it.

        Parameters
        ----------
        kind : {"backbone", "residuals", "replay"}
            ``backbone``: the runs' first-harmonic displacement curves, their points and the
            identified backbone, one panel per channel (``backbone_fit.png``); ``residuals``:
            the plain fit's residual of each used point (``residuals.png``); ``replay``:
            measured against replayed curves, one panel per channel (``replay_check.png``).
        ax : matplotlib.axes.Axes, optional
            Draw one channel on it instead of on a new figure.
        channel : str, optional
            That channel (a data-set column); needed with ``ax`` when there are several.

        Returns
        -------
        matplotlib.figure.Figure or matplotlib.axes.Axes
            A new figure (not saved, not shown; ``fig.savefig(...)``), or ``ax``.

        Raises
        ------
        ValueError
            An unknown kind or channel, or a kind this result cannot draw (no replay; a result
            read from ``identification.json`` holds no curves and no model: residuals only).
        """
        return plot_identification(self, kind, ax, channel=channel)

    def summary(self) -> str:
        """The lines a command prints: the estimates (delta also in mrad and as the total play
        2·delta in degrees), the truth if known, what the record checks
        found (one line, when they found something), the rejected runs, the verdict."""
        lines = [f"kn    = {self.kn:.5g} N·m/rad  (95 % CI {format_ci(self.kn_ci95)})",
                 f"delta = {self.delta:.5g} rad = {1e3 * self.delta:.5g} mrad  "
                 f"(95 % CI {format_ci(self.delta_ci95, 1e3)} mrad)",
                 f"total play 2·delta = {play_deg(self.delta):.5g}°  "
                 f"(95 % CI {format_ci(self.delta_ci95, play_deg(1.0))}°)"]
        err = self.truth_error
        if err:
            lines.append("truth: " + ", ".join(f"{k} = {self.truth[k]:.5g} ({100 * e:+.2f} %)"
                                               for k, e in err.items()))
        if self.records is not None and self.records.findings:
            lines.append(f"record checks: {findings_text(self.records)} (report.md lists them)")
        lines += [f"rejected run {r}: {w}" for r, w in self.rejected_runs]
        if self.verdict is not None:
            lines.append(f"verdict: {self.verdict.status}" + "".join(
                f"\n  - {why}" for why in self.verdict.reasons))
            if fit_kind(self) == "plain fit":
                lines.append(PLAIN_FIT_NOTE)
        return "\n".join(lines)

    def report(self, figures: Sequence[str] = ()) -> str:
        """``report.md``: the data set, the result, the verdict, the replay, the fitting points,
        the rejected runs, the zero-clearance check and the figures."""
        return render_report(self, figures)


def _pairs(intervals) -> list | None:
    """(kn, delta) intervals as JSON lists ([[lo, hi], [lo, hi]]), None where absent."""
    return None if intervals is None else [list(ci) for ci in intervals]

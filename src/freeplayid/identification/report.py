"""``report.md`` of an :class:`~freeplayid.identification.Identification`, section by section."""

from __future__ import annotations

import math
from collections.abc import Sequence

from .replay_checks import solution_move
from .verdict import within_binding_noise

__all__ = ["render_report", "render_summary", "validation_record", "format_ci", "format_sig",
           "delta_text", "fit_kind", "play_deg"]


def render_report(result, figures: Sequence[str] = ()) -> str:
    """The whole report: the data set, the result, the verdict, the record checks, the inverse
    model's start, the truth, the replay, the fitting points, the rejected runs, the
    zero-clearance check and the figures."""
    lines = (_header(result) + _verdict(result.verdict) + _plain_note(result) + _records(result)
             + _inverse(result) + _truth(result)
             + _model(result) + _replay(result) + _points(result)
             + _rejected(result.rejected_runs)
             + _validation_lines(result.validation)
             + ["", "## Figures", ""] + [f"![{f}]({f})" for f in figures])
    return "\n".join(lines) + "\n"


def format_ci(v, scale: float = 1.0) -> str:
    """An interval as text: [lo, hi] with 5 significant digits (each end times ``scale``)."""
    return f"[{scale * v[0]:.5g}, {scale * v[1]:.5g}]"


def format_sig(v: float, digits: int = 5) -> str:
    """``v`` with ``digits`` significant digits, trailing zeros kept: 0.0029996 -> "0.0029996",
    0.003 -> "0.0030000", 480.0 -> "480.00" (a figure title never shows 0.0029996 as 0.003)."""
    return f"{v:#.{digits}g}".rstrip(".")


def play_deg(delta: float) -> float:
    """The total play 2·delta of a half-gap ``delta`` [rad], in degrees [°]."""
    return math.degrees(2.0 * delta)


def delta_text(delta: float) -> str:
    """A half-gap in the units an engineer reads: "0.0029996 rad = 2.9996 mrad, total play
    2·delta = 0.34373°" (5 significant digits, trailing zeros kept)."""
    return (f"{format_sig(delta)} rad = {format_sig(1e3 * delta)} mrad, total play "
            f"2·delta = {format_sig(play_deg(delta))}°")


def _header(r) -> list[str]:
    ds = r.dataset
    boot = r.kn_ci95_bootstrap is not None
    lines = [
        "# Freeplay identification", "",
        f"- data set: {ds.get('name') or '(unnamed)'} (`{ds.get('path')}`)",
        f"- model: `{ds.get('model')}`",
        f"- quantity: {ds.get('quantity')} [{ds.get('units')}], "
        f"{ds.get('sample_rate', float('nan')):g} Hz, {ds.get('n_runs')} runs, "
        f"channels {r.dofs}"
        + (f", base channel `{ds['base_channel']}` subtracted" if ds.get("base_channel") else
           ", motion relative to the base" if ds.get("frame") == "relative" else
           ", absolute motion without a base channel"),
        *([f"- anti-alias filter of the records: {ds['antialias_said']} (the data set's "
             "`antialias`)"] if ds.get("antialias", "unknown") != "unknown" else []),
        *([f"- base channel's timing: {ds['base_delay_said']}"
           + ("" if ds.get("base_delay_source") == "estimated" else
              " (the data set's `base_delay_s`)")] if ds.get("base_delay_s") else []),
        *([f"- gravity along the shaking axis: {ds['gravity_g']:+g} g (the data set's "
           "`gravity_g`): the fin's weight rests its panel on a stop, and the replays carry it"]
          if ds.get("gravity_g") else []),
        f"- backbone: {r.backbone}, start: {r.init}, runtime {r.runtime_s:.2f} s", "",
        "## Result", "",
        "| parameter | identified | 95 % CI (Jacobian) |" + (" 95 % CI (bootstrap) |" if boot
                                                           else ""),
        "|---|---|---|" + ("---|" if boot else ""),
    ]
    lines += _result_rows(r, boot)
    return lines + ["", f"Residual RMS (relative frequency): {r.residual_rms:.3e}"]


def _result_rows(r, boot: bool) -> list[str]:
    """The result table's rows: kn [N·m/rad], delta [rad] and [mrad], the total play 2·delta
    [°], each with its intervals (the bootstrap's too when ``boot``)."""
    deg = play_deg(1.0)  # 2·delta [°] per rad of delta
    rows = []
    for label, name, scale in (("kn [N·m/rad]", "kn", 1.0), ("delta [rad]", "delta", 1.0),
                               ("delta [mrad]", "delta", 1e3),
                               ("total play 2·delta [°]", "delta", deg)):
        row = (f"| {label} | {scale * getattr(r, name):.5g} | "
               f"{format_ci(getattr(r, name + '_ci95'), scale)} |")
        b = getattr(r, name + "_ci95_bootstrap")
        rows.append(row + (f" {format_ci(b, scale)} |" if boot and b else ""))
    return rows


def render_summary(result) -> str:
    """The result as Jupyter shows it (``Identification._repr_markdown_``): the estimates with
    their intervals in N·m/rad, rad, mrad and degrees of total play, and the verdict table."""
    r = result
    boot = r.kn_ci95_bootstrap is not None
    lines = ["**Freeplay identification** "
             f"({fit_kind(r)}, {len(r.used_points)} of {len(r.points.points)} points used, "
             f"backbone {r.backbone})", "",
             "| parameter | identified | 95 % CI |" + (" 95 % CI (bootstrap) |" if boot else ""),
             "|---|---|---|" + ("---|" if boot else "")]
    lines += _result_rows(r, boot)
    err = r.truth_error
    if err:
        lines += ["", "Truth: " + ", ".join(f"{k} = {r.truth[k]:.5g} ({100 * e:+.2f} %)"
                                           for k, e in err.items())]
    if r.verdict is not None:
        lines += ["", f"**Verdict: {r.verdict.status}**", ""] + _verdict_table(r.verdict)
    return "\n".join(lines + _plain_note(r))


# what a plain fit's verdict did not judge (the command's summary and report.md say it)
PLAIN_FIT_NOTE = ("plain fit (replay off): judged on its own checks; its bias from the sweep is "
                  "not measured (2-7 % in delta on held-out swept, damped tests); the default "
                  "replay measures and removes it")


def _plain_note(r) -> list[str]:
    """Under a plain fit's verdict: what that verdict did not judge (Markdown lines)."""
    if r.verdict is None or fit_kind(r) != "plain fit":
        return []
    return ["", PLAIN_FIT_NOTE[0].upper() + PLAIN_FIT_NOTE[1:] + "."]


def fit_kind(r) -> str:
    """"plain fit", "corrected fit (replay)" or "plain fit (the replay failed)"."""
    rep = r.replay
    if rep is not None and rep.failure:
        return "plain fit (the replay failed)"
    if rep is not None or r.interval_source != "Jacobian":
        return "corrected fit (replay)"
    return "plain fit"


def _verdict(verdict) -> list[str]:
    if verdict is None:
        return []
    return ["", f"## Verdict: {verdict.status}", ""] + _verdict_table(verdict)


def _verdict_table(verdict) -> list[str]:
    """Every check of the verdict: its name, passed or not, what it found."""
    return (["| check | passed | finding |", "|---|---|---|"]
            + [f"| {c.name} | {'yes' if c.passed else '**no**'} | {c.message} |"
               for c in verdict.checks])


def _records(r) -> list[str]:
    """What the record checks found (docs/record_checks.md), or that they were off."""
    report = getattr(r, "records", None)
    if report is None:
        return ["", "## Record checks", "", "Off: the records were taken as they are."]
    return ["", "## Record checks", "", report.to_markdown()]


def _inverse(r) -> list[str]:
    est = r.inverse_estimate
    if not est:
        return []
    return ["", f"Start from the inverse model (`{est['checkpoint']}`): kn = "
            f"{est['kn']:.5g} N·m/rad (×/÷ {math.exp(est['log_kn_std']):.3f}), delta = "
            f"{est['delta']:.5g} rad (×/÷ {math.exp(est['log_delta_std']):.3f}); the fit "
            f"took {r.plain_fit.n_evaluations} objective evaluations."] + (
        [f"**Outside the network's training domain:** {est['outside']}."]
        if est.get("outside") else [])


def _truth(r) -> list[str]:
    err = r.truth_error
    if not err:
        return []
    return (["", "## Against the data set's truth", "",
             "| parameter | truth | identified | error |", "|---|---|---|---|"]
            + [f"| {k} | {r.truth[k]:.5g} | {getattr(r, k):.5g} | {100 * e:+.2f} % |"
               for k, e in err.items()])


def _model(r) -> list[str]:
    err = getattr(r, "model_error", None)
    if err is None:
        return []
    lines = ["", "## Linear model", "", err.describe()[0].upper() + err.describe()[1:] + "."]
    upd = err.update
    if upd is not None:
        lines += ["", "| sealed mode | reference [Hz] | model before [Hz] | updated [Hz] |",
                  "|---|---|---|---|"]
        lines += [f"| {i + 1} | {f:.3f} | {b:.3f} | {a:.3f} |" for i, (f, b, a) in
                  enumerate(zip(upd.reference_hz, upd.before_hz, upd.after_hz, strict=True))]
    gaps = r.hinge_gap_records()
    if gaps:
        sp = err.split
        how = (("the test was replayed with the hinges' gaps split as it showed against one "
                "common gap; " + ("delta is their mean" if sp.mean_reported else
                                  "delta is the one-gap answer, these gaps as read"))
               if sp is not None and sp.shares else
               "`linear_model.hinge_gaps`: the points fitted with each hinge's gap free, moved "
               "by the replay's correction of delta")
        lines += ["", f"One half-gap per hinge ({how}):", "",
                  "| hinge (outboard/inboard DOF) | half-gap [mrad] | 95 % CI [mrad] |",
                  "|---|---|---|"]
        lines += [f"| {g['hinge']} | {1e3 * g['delta']:.4g} | "
                  + ("not determined by the points" if g["delta_ci95"][1] == float("inf") else
                     format_ci(g["delta_ci95"], 1e3)) + " |" for g in gaps]
    return lines


def _offset_text(rep) -> str:
    """Where the binding's slope puts the solution of an unconverged loop, or ""."""
    off = getattr(rep, "unconverged_offset", None)
    if rep.converged or off is None:
        return ""
    return (f"; the binding's slope puts the solution at {solution_move(off)} from it, which "
            "the intervals reach")


def _replay_lead(r) -> str:
    """The replay section's first paragraph: plain and corrected estimates, convergence, the
    statistic and its weights."""
    rep = r.replay
    return (f"Plain fit: kn = {r.plain_fit.kn:.5g} N·m/rad, delta = {r.plain_fit.delta:.5g} rad; "
            f"corrected: kn = {r.kn:.5g}, delta = {r.delta:.5g} "
            f"({'converged' if rep.converged else '**not converged**'} after "
            f"{len(rep.iterations)} replays"
            + ("" if rep.converged or rep.closest_misfit_se is None else
               f"; the closest replay misses the test's statistics by "
               f"{rep.closest_misfit_se:.2g} of their standard error")
            + _offset_text(rep)
            + "). The replays match the fit of the points "
            f"taken with jump point `{rep.jump_point}`: kn = {rep.kn_statistic:.5g}, "
            f"delta = {rep.delta_statistic:.5g}"
            + ("" if not rep.weights else
               ", each point weighted by its amplitude noise (weights "
               f"{min(w.weight for w in rep.weights):.2g} to "
               f"{max(w.weight for w in rep.weights):.2g}, median point 1)")
            + ".")


def _replay(r) -> list[str]:
    rep = r.replay
    if rep is None:
        return []
    lines = ["", "## Replay (bias correction by indirect inference)", "", _replay_lead(r), "",
             "| replay | kn [N·m/rad] | delta [rad] | fit of the replay: kn | delta |",
             "|---|---|---|---|---|"]
    lines += [f"| {k + 1} | {it.kn:.5g} | {it.delta:.5g} | {it.kn_rep:.5g} | "
              f"{it.delta_rep:.5g} |" for k, it in enumerate(rep.iterations)]
    start = getattr(rep, "start", "statistic")
    if start == "network":
        lines += ["", "The first replay is at the network's estimate (`replay.start=network`)."]
    elif start.startswith("statistic, delta x"):
        lines += ["", f"The replay at the statistic's fit could not be identified (it stays in "
                      f"the gap or loses a jump the test has); the loop started at that fit with "
                      f"{start.split(', ', 1)[1]} instead."]
    lines += ["", "Levels: " + ", ".join(f"{run} {lv:.4g} g ({src})"
                                          for run, (lv, src) in rep.levels.items())]
    if rep.sweeps:
        lines += ["", "Sweep laws: " + ", ".join(
            f"{run} {_sweep_text(sw)} ({sw['source']}"
            + (f", fit residual {sw['residual_hz']:.2g} Hz" if "residual_hz" in sw else "")
            + ")" for run, sw in rep.sweeps.items())]
    if rep.damping is not None:
        lines += ["", f"Damping of the replay: {rep.damping.describe()}."]
    lines += ["", "Excitation of the replays: " + (
        "each run's base channel as measured (its level profile, sweep law and direction)"
        if getattr(rep, "excitation", "law") == "measured" else "each run's sweep law at one "
        "level") + (f"; the base of {', '.join(rep.wide_base)} read over the wide band, which "
                    "follows the level around their points where the narrowed reading did not"
                    if getattr(rep, "wide_base", ()) else "") + "."]
    excited = getattr(rep, "excitation_noise", None)
    if excited is not None:
        said = excited.describe()
        lines += [said[0].upper() + said[1:]
                  + (", in the intervals and the noise check." if excited.delta_halfwidth
                     is not None else ".")]
    reading = getattr(rep, "base_reading", None)
    if reading is not None:
        said = reading.describe()
        lines += [said[0].upper() + said[1:]
                  + (" (in the intervals)." if reading.delta_shift is not None else ".")]
    level = getattr(rep, "level", None)
    if level is not None:
        lines += [f"Levels from `level_g` ({', '.join(level.runs)}): {level.describe()}."]
        implied = getattr(level, "implied", None) or {}
        if implied:
            lines += ["Levels the upper branches imply at the answer, against `level_g`: "
                      + ", ".join(f"{run} {100 * v.error:+.2g} %" for run, v in implied.items())
                      + ("" if getattr(level, "ratio_kn", None) is None else
                         f"; the channels' amplitude ratios put kn {100 * level.ratio_kn:+.2g} % "
                         "from the answer") + "."]
    declared = getattr(rep, "records_filter", "unknown")
    if declared != "unknown":
        lines += ["Anti-alias filter of the records: declared " + (
            "flat to 0.45 of the sample rate (`replay.antialias=flat` or the data set's "
            "`antialias`); the replays are decimated so." if declared == "flat" else
            "as the replay's own, flat to 0.3 of the sample rate (`replay.antialias=replay` or "
            "the data set's `antialias`).")]
    acquisition = getattr(rep, "antialias", None)
    if acquisition is not None:
        said = acquisition.describe()
        lines += [f"Anti-alias filter: {said} (`replay.antialias=replay` where the records were "
                  "decimated as the replay's are)."]
    damped = getattr(rep, "damping_sensitivity", None)
    if damped is not None:
        lines += [f"Damping of the down-sweeps ({', '.join(damped.runs)}), which they do not "
                  f"measure: {100 * damped.uncertainty:g} % more of it moves kn by "
                  f"{100 * damped.kn_shift:.2g} % and delta by {100 * damped.delta_shift:.2g} % "
                  "(in the intervals)" + _settled(damped)]
    formed = getattr(rep, "form_sensitivity", None)
    if formed is not None:
        chose = formed.chose()
        lines += ["Damping form, which no base channel lets the replay read"
                  + (f"; {chose}" if chose else "") + ": the answer replayed with "
                  + formed.describe() + " (the larger move of those the curves do not rule "
                  "out in the intervals)."]
    if rep.failure:
        lines += ["", f"**Replay failed:** {rep.failure}; the estimate above is the plain fit's."]
    elif getattr(rep, "stopped", ""):
        lines += ["", f"**The loop stopped** after {len(rep.iterations)} replays: "
                  f"{rep.stopped}; the estimate above is its closest replay's."]
    lines += ["", f"95 % intervals: {r.interval_source}."]
    precision = getattr(rep, "precision", None)
    if precision is not None:
        lines += [f"Precision: {precision.describe()}."]
    boot = rep.bootstrap
    if boot is not None and boot.kn_ci95 is not None:
        lines += [f"Bootstrap by replay alone: kn {format_ci(boot.kn_ci95)}, delta "
                  f"{format_ci(boot.delta_ci95)}."]
    if rep.misfit:
        lines += ["", "Measured vs replayed curves (median difference / measured peak): "
                  + ", ".join(f"{run} {100 * m:.2g} %" for run, m in rep.misfit.items())]
    return lines


def _points(r) -> list[str]:
    lines = ["", "## Fitting points", "",
             "| run | channel | f [Hz] | amplitude [mm] | used | residual [%] | reason |",
             "|---|---|---|---|---|---|---|"]
    for p in r.point_records():
        e = f"{100 * p['residual']:+.3f}" if p["residual"] is not None else ""
        f = "–" if p["f_hz"] is None else f"{p['f_hz']:.3f}"
        a = "–" if p["amplitude_m"] is None else f"{1e3 * p['amplitude_m']:.4f}"
        lines.append(f"| {p['run']} | {p['channel']} | {f} | {a} | "
                     f"{'yes' if p['used'] else 'no'} | {e} | {p['reason']} |")
    return lines


def _rejected(rejected_runs) -> list[str]:
    return ["", "## Rejected runs", ""] + ([f"- `{r}`: {w}" for r, w in rejected_runs]
                                            or ["none"])


def validation_record(v) -> dict:
    """The zero-clearance check as the JSON record's ``validation`` entry."""
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


def _settled(damped) -> str:
    """How the damping's move was measured, for the report: its solve converged, or its closest
    replay within the statistics' noise (as the verdict takes it), or neither."""
    if damped.converged:
        return "."
    close = getattr(damped, "closest_misfit_se", None)
    if within_binding_noise(close):
        return (f"; its replays did not converge, their closest within {close:.2g} of the "
                "statistics' standard error.")
    return "; its replays did not converge: their closest's move, not a measured one."

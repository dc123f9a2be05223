"""Figures. Every function draws on a matplotlib ``Axes`` it is given; none computes or saves."""

from __future__ import annotations

import numpy as np

__all__ = [
    "backbone_in_band",
    "plot_backbone_comparison",
    "plot_compare_cost",
    "plot_compare_errors",
    "plot_inverse_predictions",
    "plot_learning_curves",
    "plot_backbone_points",
    "plot_fit_residuals",
    "plot_identification_errors",
    "plot_sweep_response",
]


# ------------------------------------------------------------------------------------------------
# signal: amplitude-frequency curves of all runs with their backbone points (paper Fig. 7 / 11)
# ------------------------------------------------------------------------------------------------

_AMPLITUDE_SCALE = {"m": 1.0, "mm": 1e3, "um": 1e6}


def plot_backbone_points(
    ax,
    points,
    *,
    channel: str | None = None,
    backbone=None,
    amplitude_unit: str = "mm",
    legend: bool = True,
    labels=None,
):
    """First-harmonic displacement curves of all runs, with their peaks (fitting points) marked.

    Used points are filled circles; rejected maxima are crosses, labelled with the reason.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    points : freeplayid.signal.BackbonePoints
        Result of :func:`freeplayid.signal.extract_backbone_points` (its ``curves`` are drawn).
    channel : str, optional
        Draw this channel only (default: all; the channel is then added to each label).
    backbone : (array_like, array_like), optional
        A backbone curve to overlay: frequency [Hz], shape (K,), and amplitude [m], shape (K,).
    amplitude_unit : {"m", "mm", "um"}
    legend : bool
    labels : mapping of str to str, optional
        Run -> its legend entry (e.g. its level, "0.8 g"); default the run's name.

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``.
    """
    if amplitude_unit not in _AMPLITUDE_SCALE:
        raise ValueError(
            f"`amplitude_unit` must be one of {sorted(_AMPLITUDE_SCALE)}, got {amplitude_unit!r}"
        )
    labels = labels or {}
    channels = sorted({c.channel for c in points.curves})
    if channel is not None and channel not in channels:
        raise ValueError(f"`channel` must be one of {channels}, got {channel!r}")
    scale = _AMPLITUDE_SCALE[amplitude_unit]
    multi = channel is None and len(channels) > 1
    reasons_shown = set()
    for curve, p in zip(points.curves, points.points, strict=True):
        if channel is not None and curve.channel != channel:
            continue
        run = labels.get(curve.run, curve.run)
        label = f"{run}, {curve.channel}" if multi else run
        (line,) = ax.plot(curve.frequency, scale * curve.amplitude_m, lw=1.0, label=label)
        if p.used:
            ax.plot(
                p.f_hz, scale * p.amplitude_m, "o", color=line.get_color(), ms=6, mec="k", zorder=3
            )
        else:
            ax.plot(
                p.f_hz,
                scale * p.amplitude_m,
                "x",
                color=line.get_color(),
                ms=8,
                mew=2,
                zorder=3,
                label=None if p.reason in reasons_shown else f"rejected: {p.reason}",
            )
            reasons_shown.add(p.reason)
    if backbone is not None:
        f_bb, x_bb = backbone
        ax.plot(f_bb, [scale * v for v in x_bb], "k--", lw=1.2, label="backbone")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel(f"first-harmonic displacement [{amplitude_unit}]")
    if legend:
        ax.legend(fontsize="small")
    return ax


def backbone_in_band(backbone, curves, *, amplitude_factor: float = 1.3, below_hz: float = 3.0):
    """The part of a backbone curve a figure of measured curves shows: amplitudes up to
    ``amplitude_factor`` x the curves' highest, frequencies from ``below_hz`` under their lowest.

    Parameters
    ----------
    backbone : (array_like, array_like)
        Frequency [Hz], shape (K,), and amplitude [m], shape (K,).
    curves : sequence of freeplayid.signal.AmplitudeCurve
        The measured curves drawn with it (empty ones are passed over; none: the whole
        backbone).
    amplitude_factor : float [-]
    below_hz : float [Hz]

    Returns
    -------
    (ndarray, ndarray)
        The backbone's frequency [Hz] and amplitude [m] inside that band, shape (k,).
    """
    f, x = (np.asarray(a, dtype=float) for a in backbone)
    if f.shape != x.shape:
        raise ValueError(f"`backbone` must be two arrays of one shape, got {f.shape} and {x.shape}")
    drawn = [c for c in curves if np.asarray(c.amplitude_m).size]
    top = max((np.nanmax(c.amplitude_m) for c in drawn), default=np.nanmax(x))
    f_lo = min((np.nanmin(c.frequency) for c in drawn), default=np.nanmin(f))
    keep = (x <= amplitude_factor * top) & (f >= f_lo - below_hz)
    return f[keep], x[keep]


def plot_fit_residuals(ax, f_hz, residuals, *, labels=None):
    """Relative frequency residuals of a backbone fit, one marker per fitting point.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    f_hz : array_like, shape (p,) [Hz]
        Measured frequency of each point.
    residuals : array_like, shape (p,) [-]
        (f_BC - f) / f of each point (``FitResult.residuals``); drawn in percent.
    labels : sequence of str, shape (p,), optional
        Group of each point (e.g. its channel); one marker colour and legend entry per group.

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``.
    """
    f = np.asarray(f_hz, dtype=float)
    r = 100 * np.asarray(residuals, dtype=float)
    if f.shape != r.shape:
        raise ValueError(
            f"`f_hz` and `residuals` must have the same shape, got {f.shape} and {r.shape}"
        )
    groups = [None] * f.size if labels is None else list(labels)
    if len(groups) != f.size:
        raise ValueError(f"`labels` must have {f.size} entries, got {len(groups)}")
    for g in dict.fromkeys(groups):
        sel = np.array([x == g for x in groups])
        ax.plot(f[sel], r[sel], "o", ms=6, mec="k", label=g)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel("fitting-point frequency [Hz]")
    ax.set_ylabel("residual (f_BC - f) / f [%]")
    if labels is not None:
        ax.legend(fontsize="small")
    return ax


# ------------------------------------------------------------------------------------------------
# simulate: response time histories of a sweep
# ------------------------------------------------------------------------------------------------


def plot_sweep_response(ax, time, signal, *, sweep=None, label=None, units="", title=None):
    """Draw one response time history of a sine sweep.

    Parameters
    ----------
    ax : matplotlib Axes
    time : array_like, shape (T,) [s]
    signal : array_like, shape (T,) [units]
    sweep : Sweep, optional
        If given, a top axis shows the sweep frequency [Hz].
    label, units, title : str, optional
    """
    time = np.asarray(time)
    ax.plot(time, np.asarray(signal), lw=0.5, label=label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"response [{units}]" if units else "response")
    if title:
        ax.set_title(title, fontsize=9)
    if label is not None:
        ax.legend(loc="upper left", fontsize=8)
    if sweep is not None and not getattr(ax, "_freq_axis", False):
        sec = ax.secondary_xaxis(
            "top", functions=(sweep.frequency, lambda f: np.asarray(sweep.time_at(f)))
        )
        sec.set_xlabel("sweep frequency [Hz]", fontsize=8)
        ax._freq_axis = True
    return ax


# ------------------------------------------------------------------------------------------------
# backbone: DFA and harmonic balance against the exact SDOF backbone (paper Fig. 3)
# ------------------------------------------------------------------------------------------------


def plot_backbone_comparison(ax, curves, *, exact=None, delta=1.0, omega_n=1.0):
    """Backbone curves as frequency ratio w / w_n against peak amplitude / delta.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    curves : sequence of (label, amplitude, frequency_hz)
        amplitude [m] (peak or first harmonic, as labelled), shape (m,); frequency [Hz], (m,).
    exact : (amplitude, omega), optional
        Exact backbone: peak amplitude [m] and angular frequency [rad/s].
    delta : float [m]
        Gap used to normalise the amplitude axis.
    omega_n : float [rad/s]
        Contact (closed-gap) natural frequency used to normalise the frequency axis.
    """
    if exact is not None:
        a, w = exact
        ax.plot(
            np.asarray(a) / delta, np.asarray(w) / omega_n, "k-", lw=2.5, alpha=0.35, label="exact"
        )
    for label, a, f in curves:
        ax.plot(np.asarray(a) / delta, 2 * np.pi * np.asarray(f) / omega_n, lw=1.2, label=label)
    ax.set_xlabel("amplitude / delta")
    ax.set_ylabel("frequency / closed-gap frequency")
    ax.legend(fontsize="small")
    return ax


# ------------------------------------------------------------------------------------------------
# studies: identification errors over an ablation axis (docs/results.md)
# ------------------------------------------------------------------------------------------------


def plot_identification_errors(ax, x, errors, *, bounds=None, xlabel="", title=None):
    """Identification errors [%] of repeated trials (e.g. noise seeds) at each value of an axis.

    Every trial is a dot, the mean a line; bounds are drawn as symmetric dashed lines.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    x : array_like, shape (n,)
        Axis values (e.g. noise std [g]).
    errors : sequence of n array_like, each shape (trials_i,) [%]
        Signed relative errors of the trials at each x.
    bounds : mapping of str to float [%], optional
        Label -> bound; drawn at +-bound.
    xlabel, title : str

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``.
    """
    x = np.asarray(x, dtype=float)
    if len(errors) != x.size:
        raise ValueError(f"`errors` must have one entry per x value ({x.size}), got {len(errors)}")
    for xi, e in zip(x, errors, strict=True):
        e = np.asarray(e, dtype=float)
        ax.plot(np.full(e.size, xi), e, "o", color="C0", ms=4, alpha=0.7)
    ax.plot(x, [np.mean(e) for e in errors], "-", color="C0", label="mean")
    for i, (label, b) in enumerate((bounds or {}).items()):
        ax.axhline(b, ls="--", color=f"C{i + 1}", lw=1, label=label)
        ax.axhline(-b, ls="--", color=f"C{i + 1}", lw=1)
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("error [%]")
    if title:
        ax.set_title(title, fontsize=9)
    ax.legend(fontsize="small")
    return ax


# ------------------------------------------------------------------------------------------------
# inverse model: learning curves, predictions against truth, and the comparison study
# ------------------------------------------------------------------------------------------------

_METHOD_STYLE = {
    "network": ("tab:purple", "network alone"),
    "network+fit": ("tab:green", "network-initialised fit"),
    "single-start": ("tab:orange", "single-start fit"),
    "multi-start": ("tab:blue", "multi-start fit"),
    "network+corrected": ("tab:olive", "network + corrected fit (replay)"),
    "multi-start+corrected": ("tab:cyan", "multi-start + corrected fit (replay)"),
}


def _axis_label(axis_name: str, value: float) -> str:
    if axis_name == "delta":
        return f"{1e3 * value:g} mrad"
    if axis_name == "noise_g":
        return f"{value:g} g"
    return f"{value:g}"


def plot_learning_curves(ax, history: dict):
    """Training and validation loss per epoch (Gaussian NLL of the normalised log-parameters).

    ``history``: lists ``train_loss`` and ``val_loss`` (one value per epoch).
    """
    for key, style in (("train_loss", "-"), ("val_loss", "--")):
        v = np.asarray(history.get(key, []), dtype=float)
        if v.size:
            ax.plot(np.arange(1, v.size + 1), v, style, label=key.replace("_", " "))
    val = np.asarray(history.get("val_loss", []), dtype=float)
    if val.size and np.isfinite(val).any():
        i = int(np.nanargmin(val))
        ax.plot(i + 1, val[i], "o", color="k", label=f"best (epoch {i + 1})")
    ax.set_xlabel("epoch")
    ax.set_ylabel("Gaussian NLL [-]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)


def _sparse_log_ticks(ax) -> None:
    """Log axes labelled at 1, 2 and 5 per decade in plain numbers, minor ticks unlabelled: a
    range under a decade otherwise labels every minor tick, one over the other."""
    from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter

    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
        fmt = ScalarFormatter()
        fmt.set_scientific(False)
        axis.set_major_formatter(fmt)
        axis.set_minor_formatter(NullFormatter())


def plot_inverse_predictions(ax, truth, estimate, log_std, *, groups=None, group_name="",
                             quantity="kn"):
    """Network estimate against truth (log-log) with +-2 sigma bars, one colour per group.

    Parameters
    ----------
    truth, estimate : array_like, shape (N,)
        [N m/rad] for kn, [rad] for delta.
    log_std : array_like, shape (N,) [-]
        Predicted standard deviation of the natural log.
    groups : array_like, shape (N,), optional
        Ablation-axis value of each case.
    """
    truth, estimate, log_std = (np.asarray(a, dtype=float) for a in (truth, estimate, log_std))
    groups = np.zeros(truth.size) if groups is None else np.asarray(groups, dtype=float)
    scale, unit = (1e3, "mrad") if quantity == "delta" else (1.0, "N·m/rad")
    for g in np.unique(groups):
        m = groups == g
        lo = estimate[m] * (1 - np.exp(-2 * log_std[m]))
        hi = estimate[m] * (np.exp(2 * log_std[m]) - 1)
        ax.errorbar(scale * truth[m], scale * estimate[m], yerr=scale * np.vstack([lo, hi]),
                    fmt="o", ms=3, lw=0.6, alpha=0.7,
                    label=_axis_label(group_name, g) if groups.size else None)
    lim = scale * np.array([truth.min(), truth.max()])
    ax.plot(lim, lim, "k-", lw=0.8, label="exact")
    ax.set_xscale("log")
    ax.set_yscale("log")
    _sparse_log_ticks(ax)
    name = "δ" if quantity == "delta" else "kn"
    ax.set_xlabel(f"true {name} [{unit}]")
    ax.set_ylabel(f"network {name} [{unit}]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, title=group_name or None, title_fontsize=7)


def plot_coverage(ax, calibration: dict):
    """Coverage of the network's central intervals against their credibility level, kn and
    delta, on held-out cases (``calibration``: :func:`freeplayid.inverse.calibration_metrics`);
    the diagonal is a calibrated posterior, the band +-5 points."""
    lv = np.asarray(calibration["levels"])
    ax.fill_between([0, 1], [-0.05, 0.95], [0.05, 1.05], color="0.85", label="±5 points")
    ax.plot([0, 1], [0, 1], "k-", lw=0.8)
    for p, name in (("kn", "kn"), ("delta", "δ")):
        c = calibration[p]
        ax.plot(lv, c["coverage"], "o-", ms=3, label=f"{name} (largest gap "
                f"{100 * c['max_gap']:.1f} points)")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.set_xlabel("credibility level of the central interval")
    ax.set_ylabel("share of test cases inside")
    ax.set_title(f"coverage, {calibration['n_cases']} held-out cases", fontsize=9)
    ax.legend(fontsize=7, loc="upper left")
    ax.grid(True, alpha=0.3)


def plot_sbc_ranks(ax, calibration: dict, quantity: str = "kn"):
    """Histogram of the SBC ranks of ``quantity``'s truth among its posterior draws, with the
    uniform expectation and its 99 % band (binomial), and the chi-square test's p-value."""
    from scipy import stats

    sbc = calibration[quantity]["sbc"]
    counts = np.asarray(sbc["counts"])
    n, bins = counts.sum(), counts.size
    lo, hi = stats.binom.ppf([0.005, 0.995], n, 1 / bins)
    ax.axhspan(lo, hi, color="0.85", label="uniform, 99 % band")
    ax.bar(np.arange(bins), counts, width=0.9, color="C0")
    ax.axhline(n / bins, color="k", lw=0.8)
    name = "δ" if quantity == "delta" else "kn"
    ax.set_xticks(np.arange(bins))
    ax.set_xticklabels([f"{round(i * (sbc['n_draws'] + 1) / bins)}–"
                        f"{round((i + 1) * (sbc['n_draws'] + 1) / bins) - 1}"
                        for i in range(bins)], fontsize=7)
    ax.set_xlabel(f"rank of the true {name} among {sbc['n_draws']} posterior draws")
    ax.set_ylabel("test cases")
    clustered = (f" ({sbc['p_value_clustered']:.2g} clustered by kn)"
                 if sbc.get("deff", 1.0) > 1.0 else "")
    ax.set_title(f"SBC ranks of {name}: chi-square p = {sbc['p_value']:.2g}{clustered}",
                 fontsize=9)
    ax.legend(fontsize=7)


def plot_compare_errors(ax, rows, *, quantity="delta", axis_name=""):
    """Absolute relative error of each method per axis value (box plots, log scale).

    ``rows``: the per-case rows of :func:`freeplayid.studies.fit_cases`,
    :func:`~freeplayid.studies.corrected_cases` and :func:`~freeplayid.studies.network_rows`
    (``method``, ``axis_value``, ``delta_error``, ``kn_error``); the corrected methods' boxes
    hold only the cases they ran on.
    """
    methods = [m for m in _METHOD_STYLE if any(r["method"] == m for r in rows)]
    values = sorted({r["axis_value"] for r in rows})
    width = 0.8 / max(len(methods), 1)
    for j, m in enumerate(methods):
        data = []
        for v in values:
            e = np.abs([r[f"{quantity}_error"] for r in rows
                        if r["method"] == m and r["axis_value"] == v])
            data.append(np.clip(np.where(np.isfinite(e), e, 10.0), 1e-6, 10.0))
        pos = np.arange(len(values)) + (j - (len(methods) - 1) / 2) * width
        bp = ax.boxplot(data, positions=pos, widths=0.9 * width, patch_artist=True,
                        showfliers=True, flierprops={"markersize": 2})
        for patch in bp["boxes"]:
            patch.set_facecolor(_METHOD_STYLE[m][0])
            patch.set_alpha(0.6)
        ax.plot([], [], "s", color=_METHOD_STYLE[m][0], label=_METHOD_STYLE[m][1])
    ax.set_xticks(np.arange(len(values)), [_axis_label(axis_name, v) for v in values])
    ax.set_yscale("log")
    name = "δ" if quantity == "delta" else "kn"
    ax.set_ylabel(f"|{name} error| [-]")
    ax.set_xlabel(axis_name)
    ax.grid(True, axis="y", which="both", alpha=0.3)
    ax.legend(fontsize=7)


def plot_compare_cost(ax, summary, *, key="success_rate", axis_name=""):
    """Grouped bars of a summary column (``success_rate`` or ``evaluations_mean``) per method."""
    methods = [m for m in _METHOD_STYLE if any(r["method"] == m for r in summary)]
    values = sorted({r["axis_value"] for r in summary})
    width = 0.8 / max(len(methods), 1)
    for j, m in enumerate(methods):
        y = [next((r[key] for r in summary if r["method"] == m and r["axis_value"] == v), np.nan)
             for v in values]
        y = 100 * np.asarray(y) if key == "success_rate" else np.asarray(y)
        pos = np.arange(len(values)) + (j - (len(methods) - 1) / 2) * width
        ax.bar(pos, y, width=width, color=_METHOD_STYLE[m][0], label=_METHOD_STYLE[m][1])
    ax.set_xticks(np.arange(len(values)), [_axis_label(axis_name, v) for v in values])
    ax.set_xlabel(axis_name)
    ax.set_ylabel({"success_rate": "success rate [%]",
                   "evaluations_mean": "objective evaluations per case"}.get(key, key))
    if key == "evaluations_mean":
        ax.set_yscale("log")
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=7)


def plot_mode_pairs(ax, comparison, *, title=None):
    """Paired modes of one modal test (:class:`freeplayid.model.TestComparison`) on ``ax``.

    With mode shapes: measured (markers) and updated model (lines) w at the test's points, one
    colour per mode, the model scaled onto the measured shape. Without: the frequency error of
    each mode before and after updating [%].
    """
    c = comparison
    if c.measured_shapes is not None:
        x = np.arange(len(c.points))
        for i in range(c.measured_hz.size):
            line, = ax.plot(x, c.model_shapes[:, i], "-", lw=1.2,
                            label=f"{c.measured_hz[i]:.1f} Hz, MAC {c.mac_after[i]:.3f}")
            ax.plot(x, c.measured_shapes[:, i], "o", color=line.get_color())
        ax.set_xticks(x, c.points, rotation=30, fontsize=7)
        ax.set_ylabel("w (o measured, - model)")
        ax.axhline(0.0, color="0.7", lw=0.6)
    else:
        x = np.arange(1, c.measured_hz.size + 1)
        ax.bar(x - 0.2, 100 * (c.before_hz / c.measured_hz - 1), 0.4, label="before")
        ax.bar(x + 0.2, 100 * c.error, 0.4, label="after")
        ax.set_xticks(x)
        ax.set_xlabel("mode")
        ax.set_ylabel("frequency error [%]")
    ax.legend(fontsize=7)
    ax.set_title(title or c.test, fontsize=9)


def plot_replay_check(ax, measured, replayed, *, channel: str, misfit=None,
                      amplitude_unit: str = "mm", labels=None):
    """Measured (solid) and replayed (dashed) first-harmonic displacement curves of one channel,
    run by run: the self-check of a replay (the paper's Fig. 7/11 with the model on top).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    measured, replayed : sequence of freeplayid.signal.AmplitudeCurve
    channel : str
    misfit : dict of run -> float, optional
        Per-run misfit [-]: the median of |replayed - measured| over the measured band relative
        to the measured peak (:func:`freeplayid.replay.curve_misfit`), shown in percent in the
        labels; the legend's title says what the number is.
    amplitude_unit : {"m", "mm", "um"}
    labels : mapping of str to str, optional
        Run -> its legend entry (e.g. its level, "0.8 g"); default the run's name.

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``.
    """
    if amplitude_unit not in _AMPLITUDE_SCALE:
        raise ValueError(
            f"`amplitude_unit` must be one of {sorted(_AMPLITUDE_SCALE)}, got {amplitude_unit!r}"
        )
    scale = _AMPLITUDE_SCALE[amplitude_unit]
    rep = {(c.run, c.channel): c for c in replayed}
    for k, c in enumerate(cc for cc in measured if cc.channel == channel):
        r = rep.get((c.run, c.channel))
        if r is None or not c.amplitude_m.size:
            continue
        color = f"C{k % 10}"
        label = (labels or {}).get(c.run, c.run) + (
            f": {100 * misfit[c.run]:.2g} %" if misfit and c.run in misfit else "")
        ax.plot(c.frequency, c.amplitude_m * scale, color=color, lw=1.0, label=label)
        ax.plot(r.frequency, r.amplitude_m * scale, color=color, lw=1.0, ls="--")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel(f"first-harmonic displacement [{amplitude_unit}]")
    ax.set_title(f"{channel}: measured (solid) and replayed (dashed)", fontsize=9)
    ax.legend(fontsize=7, title_fontsize=7, alignment="left", title=(
        "misfit: median |replayed − measured|\n/ measured peak, in %" if misfit else None))
    return ax

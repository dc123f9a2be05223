"""The figures of an :class:`~freeplayid.identification.Identification`, made by the library.

:func:`plot_identification` draws one kind of figure (:data:`FIGURES`) on a new matplotlib
``Figure`` (one panel per channel where the kind has them) or on one ``Axes`` it is given; it
never saves. ``Identification.plot`` calls it; the identify task saves what it returns under
the names of :data:`FIGURES`. The drawing itself is :mod:`freeplayid.plots`'.
"""

from __future__ import annotations

import numpy as np

from ..plots import backbone_in_band, plot_backbone_points, plot_fit_residuals, plot_replay_check
from .report import delta_text, fit_kind, format_sig

__all__ = ["FIGURES", "figure_kinds", "plot_identification", "run_labels"]

# kind -> the file the identify command writes it to
FIGURES = {"backbone": "backbone_fit.png", "residuals": "residuals.png",
           "replay": "replay_check.png"}
_PANEL = (5.5, 4.2)  # [in] one channel's panel
_DPI = 110


def figure_kinds(result) -> tuple[str, ...]:
    """The kinds of :data:`FIGURES` ``result`` can draw: the backbone figure needs the
    amplitude curves and the linear model, the residuals the plain fit's residuals, the replay
    check the replay's curves (a result read from ``identification.json`` has the residuals
    only)."""
    kinds = []
    if result.points.curves and result.system is not None:
        kinds.append("backbone")
    if np.isfinite(np.asarray(result.plain_fit.residuals, dtype=float)).any():
        kinds.append("residuals")
    if result.replay is not None and result.replay.curves:
        kinds.append("replay")
    return tuple(kinds)


def run_labels(result) -> dict:
    """Each run's legend entry: its level ("0.8 g") where known, else its name; runs at one
    level are told apart by their names ("0.8 g (sweep_a.csv)")."""
    levels = result.levels
    text = {run: f"{_level(lv)} g" for run, lv in levels.items() if lv is not None}
    seen = list(text.values())
    return {run: (text[run] if seen.count(text[run]) == 1 else f"{text[run]} ({run})")
            if run in text else run for run in levels}


def _level(level_g: float) -> str:
    """A level in 3 significant digits, a decimal point always: 0.8 -> "0.8", 1 -> "1.0"."""
    text = f"{level_g:.3g}"
    return text if "." in text or "e" in text else text + ".0"


def plot_identification(result, kind: str = "backbone", ax=None, *, channel: str | None = None):
    """Draw one figure of ``result`` (see :data:`FIGURES`).

    Parameters
    ----------
    result : Identification
    kind : {"backbone", "residuals", "replay"}
        ``backbone``: every run's first-harmonic displacement curves with their points and the
        identified backbone, one panel per channel (``backbone_fit.png``, the paper's Fig. 12);
        ``residuals``: the plain fit's relative frequency residual of each used point
        (``residuals.png``); ``replay``: measured and replayed curves, one panel per channel
        (``replay_check.png``).
    ax : matplotlib.axes.Axes, optional
        Draw on it (one channel) instead of on a new figure.
    channel : str, optional
        The channel (data-set column) to draw on ``ax``; needed when ``ax`` is given, the kind
        has one panel per channel and there are several. Without ``ax``: only this channel.

    Returns
    -------
    matplotlib.figure.Figure or matplotlib.axes.Axes
        A new figure (``ax`` None), else ``ax``.

    Raises
    ------
    ValueError
        An unknown ``kind`` or ``channel``, a kind the result cannot draw (a plain fit has no
        replay; a result read from its file has no curves and no model), or ``ax`` with several
        channels and no ``channel``.
    """
    if kind not in FIGURES:
        raise ValueError(f"`kind` must be one of {list(FIGURES)}, got {kind!r}")
    if kind not in figure_kinds(result):
        raise ValueError(f"`kind`={kind!r} cannot be drawn for this result: "
                         f"{_missing(result, kind)}; it can draw "
                         f"{list(figure_kinds(result)) or 'nothing'}")
    if kind == "residuals":
        fig, axes = _canvas(ax, 1, (6.0, 3.5))
        _residuals(result, axes[0])
        return _done(fig, ax)
    channels = _channels(result, channel, ax)
    fig, axes = _canvas(ax, len(channels), (_PANEL[0] * len(channels), _PANEL[1]))
    draw = _backbone if kind == "backbone" else _replay
    for a, col in zip(axes, channels, strict=True):
        draw(result, a, col)
    if fig is not None and kind == "replay":
        fig.suptitle(f"{fit_kind(result)}: kn = {format_sig(result.kn)} N·m/rad, delta = "
                     f"{delta_text(result.delta)}", fontsize=9)
    return _done(fig, ax)


def _missing(result, kind: str) -> str:
    if kind == "replay":
        return ("it has no replay (a plain fit: identify(..., replay=None)"
                + (", or a result read from its file)" if result.system is None else ")"))
    if kind == "backbone":
        return ("the amplitude curves and the linear model are not in a result read from "
                "identification.json")
    return "it has no residuals (a result file written before they were recorded)"


def _channels(result, channel: str | None, ax) -> list[str]:
    cols = list(result.dofs)
    if channel is not None:
        if channel not in cols:
            raise ValueError(f"`channel` must be one of {cols}, got {channel!r}")
        return [channel]
    if ax is not None and len(cols) > 1:
        raise ValueError(f"`channel` must be one of {cols} when `ax` is given (one Axes draws "
                         "one channel), got None")
    return cols


def _canvas(ax, n: int, size: tuple[float, float]):
    """``(None, [ax])`` for a given Axes, else a new Figure (no pyplot: nothing global, shown
    once in Jupyter) and its ``n`` panels in a row."""
    if ax is not None:
        return None, [ax]
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=_DPI)
    return fig, list(fig.subplots(1, n, squeeze=False)[0])


def _done(fig, ax):
    if fig is None:
        return ax
    fig.tight_layout()
    return fig


def _backbone(result, ax, col: str) -> None:
    """One channel's curves, points and the identified backbone in the measured band."""
    pts = result.points
    mine = [c for c in pts.curves if c.channel == col]
    band = backbone_in_band(result.backbone_overlay()[col], mine)
    plot_backbone_points(ax, pts, channel=col, backbone=band, labels=run_labels(result))
    ax.set_title(f"{col}: kn = {format_sig(result.kn)} N·m/rad\n"
                 f"delta = {delta_text(result.delta)}", fontsize=9)


def _residuals(result, ax) -> None:
    used = result.used_points
    plot_fit_residuals(ax, [p.f_hz for p in used], result.plain_fit.residuals,
                       labels=[p.channel for p in used])
    fit = result.plain_fit
    ax.set_title(f"plain fit: kn = {format_sig(fit.kn)} N·m/rad, delta = "
                 f"{format_sig(1e3 * fit.delta)} mrad", fontsize=9)


def _replay(result, ax, col: str) -> None:
    rep = result.replay
    plot_replay_check(ax, result.points.curves, rep.curves, channel=col, misfit=rep.misfit,
                      labels=run_labels(result))

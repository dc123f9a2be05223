"""Figures. Every function draws on an ``Axes`` it is given; none computes results or saves."""

from __future__ import annotations

import numpy as np

__all__ = ["plot_sweep_response"]


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

"""The self-check: measured against replayed amplitude-frequency curves."""

from __future__ import annotations

import numpy as np

__all__ = ["curve_misfit"]


def curve_misfit(measured, replayed) -> float:
    """Median of |X_replayed(f) - X_measured(f)| over the measured curve's band, relative to the
    measured peak: 0 for identical amplitude-frequency curves, 0.1 for a 10 % offset.

    The median, not the RMS: at the jump the amplitude falls by half within a fraction of a Hz,
    so a jump 0.01 Hz apart (a start transient, the sweep's phase) puts a few samples far apart
    that say nothing about the model; a model that does not fit the test differs over the band.

    Both curves are ``AmplitudeCurve`` (frequency [Hz], displacement amplitude [m]) of one run
    and channel; the replayed one is interpolated at the measured frequencies (an up- or
    down-sweep's frequency track is monotonic in time; it is sorted for the interpolation).
    """
    f, x = np.asarray(measured.frequency), np.asarray(measured.amplitude_m)
    fr, xr = np.asarray(replayed.frequency), np.asarray(replayed.amplitude_m)
    ok, okr = np.isfinite(f) & np.isfinite(x), np.isfinite(fr) & np.isfinite(xr)
    if np.count_nonzero(ok) < 2 or np.count_nonzero(okr) < 2:
        return float("nan")
    order = np.argsort(fr[okr])
    inside = ok & (f >= fr[okr].min()) & (f <= fr[okr].max())
    if np.count_nonzero(inside) < 2:
        return float("nan")
    xi = np.interp(f[inside], fr[okr][order], xr[okr][order])
    return float(np.median(np.abs(xi - x[inside])) / np.max(x[ok]))

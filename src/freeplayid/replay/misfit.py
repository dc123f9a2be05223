"""The self-check: measured against replayed amplitude-frequency curves."""

from __future__ import annotations

import numpy as np

__all__ = ["curve_misfit", "run_misfits"]


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


def run_misfits(measured_curves, replayed_curves, runs) -> dict:
    """Per run of ``runs``: the largest :func:`curve_misfit` over its channels' measured and
    replayed curves (matched by run and channel)."""
    replayed = {(c.run, c.channel): c for c in replayed_curves}
    out: dict[str, float] = {}
    for c in measured_curves:
        r = replayed.get((c.run, c.channel))
        if r is not None and c.run in runs:
            out[c.run] = max(out.get(c.run, 0.0), curve_misfit(c, r))
    return out

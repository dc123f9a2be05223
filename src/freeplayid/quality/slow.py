"""DC offset and drift: a channel's slow trend, below the swept band.

The trend is the record low-passed at a fifth of the lowest swept frequency (zero-phase
4th-order Butterworth, even padding): at the band's bottom the filter passes 2.6e-6 of the
power, so the sweep's first harmonic does not leak into it, and subtracting it leaves the band
untouched. Bumps shorter than five filter times (what the edges of a dropout, a clipped
stretch or a missed spike leak into a low-pass) are taken out by a running median.

For white noise of standard deviation s the trend's standard deviation is
``s_t = s sqrt(2 f_c / fs)`` (equivalent noise bandwidth f_c), over ``n = 2 f_c T`` independent
values; so

- the offset (the trend's mean) is significant above ``offset_sigma x s_t / sqrt(n)``;
- the drift (the trend's peak-to-peak, leaving out one filter time at each end) above
  ``2 x offset_sigma x s_t`` (the peak-to-peak of noise stays below ~2 sqrt(2 ln n) s_t,
  7.8 s_t for n = 2000);

and both must exceed ``offset_fraction`` (1 %) of the channel's vibration RMS to be worth
reporting. A first-harmonic extraction ignores both, so they are removed (the trend
subtracted) and reported as repaired, never a reason to reject.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy import signal as sps

from .report import Finding

__all__ = ["check_offset", "slow_trend"]

MEDIAN_TIMES = 5.0  # [filter times] bumps shorter than this are no drift


def _lowpass(x, fs: float, cutoff_hz: float) -> np.ndarray:
    sos = sps.butter(4, cutoff_hz, fs=fs, output="sos")
    pad = min(x.size - 1, int(3 * fs / cutoff_hz))
    return sps.sosfiltfilt(sos, x, padtype="even", padlen=pad)


def slow_trend(x, fs: float, cutoff_hz: float) -> np.ndarray:
    """The slow trend of ``x``, shape (T,) [x's units] (module docstring).

    ``x`` : ndarray, shape (T,); ``fs``, ``cutoff_hz`` : float [Hz].

    The zero-phase low-pass, its bumps shorter than ``MEDIAN_TIMES`` filter times removed by a
    running median, low-passed again: an abrupt change of a large vibration (a dropout's
    edges, a missed spike, a clipped stretch) leaks a bump of about one filter time
    (1 / cutoff) into a low-pass, a drift lasts far longer.
    """
    lp = _lowpass(x, fs, cutoff_hz)
    size = int(MEDIAN_TIMES * fs / cutoff_hz) | 1
    if size >= x.size:
        return lp
    return _lowpass(ndimage.median_filter(lp, size=size, mode="nearest"), fs, cutoff_hz)


def _channel(records, rec, name, x, row, unit) -> Finding | None:
    opts = records.options
    fs = records.fs
    band = records.band(rec)
    f_c = (band[0] if band else 5.0) / 5.0
    if x.size < 4 * fs / f_c:
        return None
    trend = slow_trend(x, fs, f_c)
    vib = x - trend
    rms = float(np.sqrt(np.mean(vib * vib)))
    s_t = records.noise(rec, row) * np.sqrt(2 * f_c / fs)
    n_ind = max(1.0, 2 * f_c * x.size / fs)
    offset = float(np.mean(trend))
    edge = int(fs / f_c)
    inner = trend[edge:-edge] if trend.size > 2 * edge + 1 else trend
    drift = float(np.ptp(inner))
    relevant = opts.offset_fraction * rms
    has_offset = abs(offset) > max(opts.offset_sigma * s_t / np.sqrt(n_ind), relevant)
    has_drift = drift > max(2 * opts.offset_sigma * s_t, relevant)
    if not (has_offset or has_drift):
        return None
    records.replace_signal(rec, row, vib)
    parts = []
    if has_offset:
        parts.append(f"a DC offset of {offset:+.3g} {unit}")
    if has_drift:
        parts.append(f"a drift of {drift:.3g} {unit} peak to peak")
    size = max(abs(offset), drift)
    msg = (f"run {rec.file}, channel {name}: {' and '.join(parts)} ({100 * size / rms:.3g} % of "
           f"the vibration RMS), removed below {f_c:.3g} Hz")
    return Finding("offset", rec.file, name, size, unit, "repaired", msg)


def check_offset(records) -> list[Finding]:
    """DC offset and drift of every channel (module docstring); removed where found."""
    return records.each_signal(_channel)

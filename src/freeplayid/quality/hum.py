"""Mains hum: a stationary line at 50 or 60 Hz (or a harmonic) standing above the noise floor.

The record is cut into segments (16, each at least 4 s; Hann window, zero-padded 4x). In each,
a candidate line ``h x f_mains`` (within +-0.1 Hz x h, the mains' own wander) is compared with
the median power of the neighbouring band (0.5-3 Hz away, leaving out the line's main lobe).
The line is hum when it stands ``hum_snr`` (10 dB) above that floor in at least three quarters
of the segments: a sweep passes any frequency in one or two segments, a line from the mains is
in all of them. Its frequency is the median of the segments' peaks, its amplitude the median of
the segments' Hann-corrected peak amplitudes.

Repair (a notch that does not touch the sweep): the line's complex envelope
``z = 2 LP_0.2Hz[x exp(-i w_h t)]`` is measured where it is steady (within 30 % of its median
magnitude; a jump's broadband drop or the sweep's harmonics passing within 1 Hz of the line
disturb it, and so do the filter's first and last 5 s), a stationary line is fitted to it there
(amplitude linear, phase cubic in time, robustly: the mains drifts slowly) and subtracted over
the whole record: the sweep's first harmonic is never notched.

The line is not removed from a response channel whose resonance lies within
``resonance_margin_hz`` (plus the notch's width) of it: the hum's envelope under the resonance
would be a guess. There the hum stays; it makes the answer ``suspect`` when it exceeds
``amplitude_tolerance`` of the channel's peak (delta scales with the amplitudes), a warning
otherwise.
"""

from __future__ import annotations

import numpy as np

from .context import demodulate
from .report import Finding

__all__ = ["check_hum", "find_lines", "remove_line"]

N_SEGMENTS = 16
MIN_SEGMENT_S = 4.0  # [s]
WANDER_HZ = 0.1  # [Hz] mains frequency tolerance per harmonic
FLOOR_BAND_HZ = (0.5, 3.0)  # [Hz] distance of the noise floor's band from the line
NOTCH_HZ = 0.2  # [Hz] low-pass of the line's complex envelope
PASSAGE_HZ = 1.0  # [Hz] the sweep's harmonics closer than this to the line: left out of the fit
STEADY = 0.3  # [-] the line's envelope fitted where it lies within this of its median


def _segment_spectra(x, fs: float):
    """(frequencies [Hz], power (seg, bins), amplitude scale) of Hann-windowed segments."""
    n_seg = min(N_SEGMENTS, int(x.size / (MIN_SEGMENT_S * fs)))
    if n_seg < 4:
        return None
    L = x.size // n_seg
    segs = x[: n_seg * L].reshape(n_seg, L)
    segs = segs - segs.mean(axis=1, keepdims=True)
    w = np.hanning(L)
    nfft = 4 * L
    X = np.fft.rfft(segs * w, n=nfft, axis=1)
    return np.fft.rfftfreq(nfft, 1 / fs), np.abs(X) ** 2, 2.0 / w.sum(), np.abs(X)


def find_lines(x, fs: float, *, lines_hz, harmonics: int, snr: float):
    """Stationary lines near ``h x f`` for f in ``lines_hz``, h = 1..``harmonics``.

    Parameters
    ----------
    x : ndarray, shape (T,)
    fs : float [Hz]
    lines_hz : sequence of float [Hz]
    harmonics : int
    snr : float [-]
        Power ratio over the neighbouring floor a line needs in three quarters of the segments.

    Returns
    -------
    list of (frequency [Hz], amplitude [x's units], median power ratio [-])
    """
    spec = _segment_spectra(np.asarray(x, dtype=float), fs)
    if spec is None:
        return []
    freq, power, scale, mag = spec
    found = []
    for f0 in lines_hz:
        for h in range(1, harmonics + 1):
            fl = h * f0
            if fl + FLOOR_BAND_HZ[1] >= 0.45 * fs:
                break
            near = np.abs(freq - fl) <= WANDER_HZ * h + (freq[1] - freq[0])
            dist = np.abs(freq - fl)
            ring = (dist >= FLOOR_BAND_HZ[0] + WANDER_HZ * h) & (dist <= FLOOR_BAND_HZ[1])
            k = np.nonzero(near)[0][np.argmax(power[:, near], axis=1)]
            peak = power[np.arange(power.shape[0]), k]
            floor = np.median(power[:, ring], axis=1)
            ratio = peak / np.maximum(floor, np.finfo(float).tiny)
            if np.quantile(ratio, 0.25) < snr:
                continue
            good = ratio >= snr
            amp = float(np.median(mag[np.arange(power.shape[0]), k][good])) * scale
            found.append((float(np.median(freq[k[good]])), amp, float(np.median(ratio))))
    return found


def remove_line(x, fs: float, f_line: float, law=None) -> np.ndarray:
    """``x`` without its stationary line at ``f_line`` (module docstring).

    Parameters
    ----------
    x : ndarray, shape (T,)
    fs, f_line : float [Hz]
    law : Sweep, optional
        The record's sweep, whose harmonics' passages near the line are left out of its fit.

    Returns
    -------
    ndarray, shape (T,)
    """
    t = np.arange(x.size) / fs
    z = demodulate(x, fs, 2 * np.pi * f_line * t, NOTCH_HZ, order=2)
    good = np.ones(x.size, dtype=bool)
    memory = int(fs / NOTCH_HZ)  # the low-pass's memory [samples]
    good[:memory], good[x.size - memory:] = False, False
    if law is not None:
        f = law.frequency(t)
        near = np.zeros(x.size, dtype=bool)
        for k in (1, 2, 3):
            near |= np.abs(k * f - f_line) < PASSAGE_HZ
        for a, b in _runs(np.nonzero(near)[0]) if near.any() else ():
            good[max(0, a - memory):min(x.size, b + memory)] = False
    mag = np.abs(z)
    if good.sum() > 16:
        good &= np.abs(mag / np.median(mag[good]) - 1) < STEADY
    if good.sum() < 16:  # nothing steady to fit: the plain narrow-band envelope
        return x - np.real(z * np.exp(1j * 2 * np.pi * f_line * t))
    # a stationary line: slowly varying amplitude (degree 1) and phase (degree 3) in time
    tc = (t - t.mean()) / max(t[-1] - t[0], 1e-9)
    amp = np.polyval(_robust_polyfit(tc[good], mag[good], 1), tc)
    phase = np.polyval(_robust_polyfit(tc[good], np.unwrap(np.angle(z[good])), 3), tc)
    return x - amp * np.cos(2 * np.pi * f_line * t + phase)


def _robust_polyfit(t, y, degree: int) -> np.ndarray:
    """Polynomial fit, refitted twice without the points beyond 3 scaled MADs (the few
    seconds a jump's drop disturbs)."""
    keep = np.ones(t.size, dtype=bool)
    for _ in range(3):
        coef = np.polyfit(t[keep], y[keep], degree)
        r = y - np.polyval(coef, t)
        scale = 1.4826 * np.median(np.abs(r[keep])) + 1e-15
        new = np.abs(r) <= 3 * scale
        if new.sum() <= degree + 1 or np.array_equal(new, keep):
            break
        keep = new
    return coef


def _runs(idx: np.ndarray):
    """(first, last + 1) of each run of consecutive integers in sorted ``idx``."""
    breaks = np.nonzero(np.diff(idx) > 1)[0]
    starts = np.concatenate([[idx[0]], idx[breaks + 1]])
    stops = np.concatenate([idx[breaks], [idx[-1]]]) + 1
    return zip(starts, stops, strict=True)


def _channel(records, rec, name, x, row, unit) -> list[Finding]:
    opts = records.options
    lines = find_lines(x, records.fs, lines_hz=opts.hum_lines_hz, harmonics=opts.hum_harmonics,
                       snr=opts.hum_snr)
    if not lines:
        return []
    res = records.resonance(rec) if row >= 0 else None
    peak = float(np.max(np.abs(x - np.median(x))))
    out = []
    for f_line, amp, ratio in lines:
        what = (f"run {rec.file}, channel {name}: hum at {f_line:.2f} Hz, {amp:.3g} {unit} "
                f"({10 * np.log10(ratio):.0f} dB above the noise floor)")
        margin = opts.resonance_margin_hz + 3 * NOTCH_HZ
        if res is not None and res.interior and abs(res.f_hz - f_line) <= margin:
            share = amp / peak
            action = "suspect" if share > opts.amplitude_tolerance else "warning"
            out.append(Finding("hum", rec.file, name, amp, unit, action,
                               f"{what}, {100 * share:.2g} % of the peak, at the resonance "
                               f"({res.f_hz:.2f} Hz): not notched, it would bend the resonance"))
            continue
        x = remove_line(x, records.fs, f_line, rec.law)
        records.replace_signal(rec, row, x)
        out.append(Finding("hum", rec.file, name, amp, unit, "repaired",
                           f"{what}, notched (the sweep's passages bridged)"))
    return out


def check_hum(records) -> list[Finding]:
    """Mains lines in every channel (module docstring); notched where they miss the resonance."""
    out = []
    unit = records.dataset.units
    for rec in records.runs:
        for name, x, row in records.signals(rec):
            out += _channel(records, rec, name, x, row, unit)
    return out

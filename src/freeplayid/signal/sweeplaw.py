"""The sweep law of a record without a hint: :func:`estimate_sweep` (start, stop, rate, law).

A sine-sweep record (the base channel, or a response that follows the excitation) carries its
sweep law in its instantaneous frequency (IF). Two passes:

1. the short-time Fourier ridge (per-frame peak, parabolic refinement; 1 s frames or shorter for
   short records) gives a coarse IF track f_j at frame centres t_j with the peak power w_j;
2. the record demodulated with that coarse law, ``z = x e^{-i phi_1(t)}``, low-passed (zero
   phase) and differentiated, gives a fine IF ``f_1(t) + (d arg z / dt) / 2 pi`` on a decimated
   grid, weighted by ``|z|^2`` (the first harmonic's power).

In each pass both laws are fitted by weighted least squares that are linear in their
parameters, with two robust re-weightings (a frame far from the fit -- noise, the free decay
after a jump, the in-gap part of a response -- loses its weight)::

    linear:  f(t) = a + b t               (fit f)
    log:     ln f(t) = c + kappa t        (fit ln f, weights w f^2 so residuals count in Hz)

and the law with the smaller power-weighted median |residual| [Hz] is taken; the log law must
beat the linear one by 10 % (two laws that fit equally well are the same sweep within the
track's noise, and the linear one is the common test). The record's sample 0 is the sweep's
start and its last sample the stop: start = f(0), stop = f(T), T = (N - 1) / fs; the rate is
|b| [Hz/s] or |kappa| 60 / ln 2 [octaves/min].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal as sps

from ..quantity import check_quantity
from ..sweep import Sweep
from .acmp import ridge_track
from .validate import as_signal, check_positive

__all__ = ["SweepEstimate", "estimate_sweep"]

LOG_MARGIN = 0.9  # [-] the log law is taken when its residual is below this x the linear one's


@dataclass(frozen=True)
class SweepEstimate:
    """A sweep law estimated from a record.

    Attributes
    ----------
    sweep : Sweep
        The law (start = f(0), stop = f(T) of the record).
    residual_hz : float [Hz]
        Power-weighted median |IF - f(t)| of the chosen law (fine pass).
    residuals_hz : dict of str -> float [Hz]
        The same for both laws ("linear", "log").
    channel : int
        The row of a 2-D input the law comes from (the one with the smallest residual).
    """

    sweep: Sweep
    residual_hz: float
    residuals_hz: dict
    channel: int = 0

    def to_dict(self) -> dict:
        return {"law": self.sweep.law, **self.sweep.to_dict(),
                "residual_hz": float(self.residual_hz),
                "residuals_hz": {k: float(v) for k, v in self.residuals_hz.items()}}


def _weighted_median(x: np.ndarray, w: np.ndarray) -> float:
    order = np.argsort(x)
    cw = np.cumsum(w[order])
    return float(x[order][np.searchsorted(cw, 0.5 * cw[-1])])


def _fit_law(law: str, t, f, w, floor: float):
    """Robust weighted fit of one law to an IF track; (coefficients, residual [Hz])."""
    ok = np.isfinite(f) & (w > 0) & ((f > 0) if law == "log" else True)
    t, f, w = t[ok], f[ok], w[ok]
    if t.size < 3:
        return None, math.inf
    y = f if law == "linear" else np.log(f)
    scale_y = np.ones_like(f) if law == "linear" else f  # d f = f d ln f: residuals in Hz

    def model(c):
        v = c[1] + c[0] * t
        return v if law == "linear" else np.exp(v)

    ww = w.copy()
    for i in range(3):  # the fit, then two robust re-weightings
        coef = np.polyfit(t, y, 1, w=np.sqrt(ww) * scale_y)
        r = f - model(coef)
        if i < 2:
            scale = 1.4826 * np.median(np.abs(r)) + floor
            ww = w / (1.0 + (r / (2 * scale)) ** 2)
    return coef, _weighted_median(np.abs(r), w)


def _law_sweep(law: str, coef, T: float) -> Sweep:
    """The Sweep of fitted coefficients over [0, T] (ValueError when it is no sweep)."""
    slope, icpt = float(coef[0]), float(coef[1])
    change = abs(slope) * T * (1.0 if law == "linear" else math.exp(icpt))
    if change < 1.0 / T:  # below the record's frequency resolution: a tone, not a sweep
        raise ValueError(f"the frequency changes by {change:.3g} Hz over the record: no sweep")
    if law == "linear":
        f0, f1 = icpt, icpt + slope * T
        if not (f0 > 0 and f1 > 0):
            raise ValueError(f"the fitted linear law runs through 0 Hz ({f0:.4g} -> {f1:.4g} Hz)")
        return Sweep(f0, f1, rate_hz_per_s=abs(slope))
    f0, f1 = math.exp(icpt), math.exp(icpt + slope * T)
    return Sweep(f0, f1, octaves_per_min=abs(slope) * 60.0 / math.log(2.0))


def _best(fits: dict):
    law = "log" if fits["log"][1] < LOG_MARGIN * fits["linear"][1] else "linear"
    return law, fits[law][0]


def _estimate_one(x: np.ndarray, fs: float, *, window_s, fmin: float, bandwidth_hz, order):
    n = x.shape[0]
    T = (n - 1) / fs
    x = x - np.mean(x)
    # pass 1: the STFT ridge (1 s frames; at least ~16 frames in a short record)
    win = min(1.0, T / 8.0) if window_s is None else float(window_s)
    t, fr, pw, df = ridge_track(x, fs, window_s=win, fmin=fmin, order=order)
    coarse = {law: _fit_law(law, t, fr, pw, df) for law in ("linear", "log")}
    if all(c[0] is None for c in coarse.values()):
        raise ValueError(f"the record is too short for a frequency track ({n} samples)")
    law, coef = _best(coarse)
    sw1 = _law_sweep(law, coef, T)
    # pass 2: demodulate with the coarse law, low-pass, differentiate the phase
    bw = max(2.0 / win, 2.0) if bandwidth_hz is None else float(bandwidth_hz)
    bw = min(bw, 0.2 * fs)
    tt = np.arange(n) / fs
    z = x * np.exp(-1j * sw1.phase(tt))
    sos = sps.butter(4, bw, fs=fs, output="sos")
    z = sps.sosfiltfilt(sos, z.real) + 1j * sps.sosfiltfilt(sos, z.imag)
    step = max(1, int(fs / (8.0 * bw)))
    keep = slice(0, n, step)
    zt, tk = z[keep], tt[keep]
    dtheta = np.gradient(np.unwrap(np.angle(zt)), tk) / (2 * np.pi)
    fi = sw1.frequency(tk) + dtheta
    w = np.abs(zt) ** 2
    w[(tk < 1.0 / bw) | (tk > T - 1.0 / bw)] = 0.0  # the filter's edge transients
    # capped at the median power: the resonance (largest, where the response's phase moves
    # against the excitation's) counts as much as the rest of the sweep, not more
    w = np.minimum(w, np.median(w[w > 0])) if np.any(w > 0) else w
    fine = {law: _fit_law(law, tk, fi, w, 0.01 * bw) for law in ("linear", "log")}
    if any(c[0] is None for c in fine.values()):
        fine = coarse
    law, coef = _best(fine)
    return SweepEstimate(_law_sweep(law, coef, T), fine[law][1],
                         {k: v[1] for k, v in fine.items()})


def estimate_sweep(signal, sample_rate: float, *, window_s: float | None = None,
                   fmin: float = 2.0, bandwidth_hz: float | None = None,
                   quantity: str = "displacement") -> SweepEstimate:
    """Sweep law (start, stop, rate, direction; linear or log) of a record without a hint.

    Parameters
    ----------
    signal : array_like, shape (T,) or (channel, T) [any]
        A record that follows the sweep: the base channel, or response channels (the law of
        the row whose track fits best is returned). Sample 0 is the sweep's start, the last
        sample its stop.
    sample_rate : float [Hz]
    window_s : float [s], optional
        STFT frame of the coarse pass; default min(1 s, record / 8).
    fmin : float [Hz]
        Spectral lines below this are ignored (offsets, drifts).
    bandwidth_hz : float [Hz], optional
        Low-pass of the fine pass; default max(2 Hz, 2 / window_s).
    quantity : {"displacement", "velocity", "acceleration"}
        What the record measures: the coarse ridge follows the fundamental of the displacement,
        not a harmonic that a velocity or acceleration record raises above it
        (:func:`freeplayid.signal.acmp.ridge_track`'s ``order``).

    Returns
    -------
    SweepEstimate

    Raises
    ------
    ValueError
        A record without a sweep in it (a constant frequency, a law that runs through 0 Hz),
        or too short for a frequency track.
    """
    fs = check_positive(sample_rate, "sample_rate")
    order = check_quantity(quantity).order
    x = np.asarray(signal, dtype=float)
    if x.ndim == 1:
        x = x[None, :]
    if x.ndim != 2:
        raise ValueError(f"`signal` must be 1-D or (channel, T), got shape {x.shape}")
    best, errors = None, []
    for c in range(x.shape[0]):
        row = as_signal(x[c], "signal")
        try:
            est = _estimate_one(row, fs, window_s=window_s, fmin=fmin, bandwidth_hz=bandwidth_hz,
                                order=order)
        except ValueError as exc:
            errors.append(f"row {c}: {exc}")
            continue
        if best is None or est.residual_hz < best.residual_hz:
            best = SweepEstimate(est.sweep, est.residual_hz, est.residuals_hz, c)
    if best is None:
        raise ValueError("no sweep law found in `signal`: " + "; ".join(errors))
    return best

"""The jump point: where the first-harmonic displacement peaks before the drop, without overshoot.

Why not the maximum of the extracted curve. ACMP and the lock-in low-pass their base band with
the second-difference Tikhonov filter ``(I + 2 P / alpha)^{-1}`` (gain 1/2 at 0.84 f_c, 4th-order
roll-off). That filter passes straight lines exactly, so its kernel has negative side lobes: ahead
of the sharp drop after a freeplay jump (the cycle amplitude falls by half within a few cycles)
the smoothed curve rises above the true one. The true curve peaks on a flat top 0.6-1.3 Hz of
sweep before the drop; the smoothed one has its maximum on the overshoot, between them. On the
SDOF freeplay oscillator and the fin (benchmarks/jump_point.py) this put the point up to
0.2 Hz late and 0.4-2.7 % high at 0.1-1 Hz/s, for ACMP and the lock-in alike.

The windowed point (``jump_point="windowed"``). Around the jump, the first harmonic is
re-estimated on the raw record by a Gaussian-weighted least-squares fit at every sample t0,

    min_{a, b} sum_t g(t - t0) (x(t) - a cos phi(t) - b sin phi(t))^2,   A(t0) = hypot(a, b),

with ``phi`` the extracted mode's phase (it follows the response, so the weighted average does
not cancel a drifting phase lag) and ``g`` a Gaussian of the same half-gain frequency as the
extractor's filter (``exp(-(2 pi f sigma)^2 / 2) = 1/2`` at ``0.84 f_c``, i.e.
``sigma = sqrt(2 ln 2) / (2 pi 0.84 f_c)``): it averages about as much noise, but a non-negative
kernel cannot overshoot, so the drop only pulls the estimate down near itself. The normal
equations are five Gaussian convolutions (FFT, O(N log N)) and a 2x2 solve per sample; solving
them rather than low-passing ``2 x e^{-i phi}`` removes the 2 f term exactly.

The point is the maximum of ``X = A / w^p`` (Eq. 9, ``w`` the response's instantaneous frequency,
as for the curve) over the lobe of the smoothed curve around its maximum (where it stays above
``jump_ratio`` times the maximum), and its frequency is the excitation frequency there: the
sweep law: the hint's, else the record's own (:func:`.sweeplaw.estimate_sweep`), else (a given
``init_freq``) a robust straight line through the extracted instantaneous frequency. The
response's own frequency lags the excitation near the fold (by 0.07-0.09 Hz at 1 Hz/s).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import fftconvolve

__all__ = ["JUMP_POINTS", "windowed_amplitude", "gaussian_sigma"]

# half-gain frequency of the extractors' base-band filter, as a fraction of its bandwidth f_c
# (acmp.py, lockin.py: (I + 2 P / alpha)^{-1} has gain 1/2 at 2^(-1/4) f_c)
HALF_GAIN = 2.0**-0.25
# the Gaussian kernel is cut at this many standard deviations (weight 4e-6 there)
TRUNCATE = 5.0


def gaussian_sigma(bandwidth_hz: float) -> float:
    """Standard deviation [s] of the Gaussian with the extractor's half-gain frequency.

    ``exp(-(2 pi f sigma)^2 / 2) = 1/2`` at ``f = 2^(-1/4) bandwidth_hz``.
    """
    return math.sqrt(2.0 * math.log(2.0)) / (2.0 * math.pi * HALF_GAIN * bandwidth_hz)


def windowed_amplitude(x, phase, sample_rate: float, *, sigma_s: float, start: int, stop: int):
    """Gaussian-weighted least-squares first-harmonic amplitude at samples ``start:stop``.

    Parameters
    ----------
    x, phase : ndarray, shape (N,) [signal units], [rad]
        The raw record and the phase of its first harmonic.
    sample_rate : float [Hz]
    sigma_s : float [s]
        Standard deviation of the Gaussian weight.
    start, stop : int
        The samples at which the amplitude is wanted; the weights reach ``TRUNCATE`` sigma
        beyond them (cut at the record's ends, where the fit uses the samples there are).

    Returns
    -------
    ndarray, shape (stop - start,) [signal units]
    """
    half = int(math.ceil(TRUNCATE * sigma_s * sample_rate))
    lo, hi = max(0, start - half), min(x.shape[0], stop + half)
    c, s = np.cos(phase[lo:hi]), np.sin(phase[lo:hi])
    xs = x[lo:hi]
    u = np.arange(-half, half + 1) / (sigma_s * sample_rate)
    g = np.exp(-0.5 * u * u)
    # the weighted normal equations [[cc, cs], [cs, ss]] (a, b) = (xc, xs) at every sample
    cc, ss, cs, xc, xsn = (fftconvolve(z, g, mode="same") for z in (c * c, s * s, c * s, xs * c,
                                                                     xs * s))
    det = cc * ss - cs * cs
    a = (ss * xc - cs * xsn) / det
    b = (cc * xsn - cs * xc) / det
    return np.hypot(a, b)[start - lo : stop - lo]


def _lobe(xi: np.ndarray, k: int, ratio: float) -> tuple[int, int]:
    """The samples around ``k`` where ``xi`` stays at or above ``ratio * xi[k]`` (start, stop)."""
    low = np.nonzero(xi < ratio * xi[k])[0]
    before, after = low[low < k], low[low > k]
    return (int(before[-1]) + 1 if before.size else 0,
            int(after[0]) if after.size else xi.shape[0])


def _drop_point(k, *, xi, ratio, steep_after, fs, bandwidth_hz, **_):
    """Fractional index of the drop (where the smoothed curve falls through ``ratio`` times its
    maximum on the jump's steep side, linearly interpolated) and the smoothed amplitude one
    filter time ``1 / bandwidth_hz`` ahead of it (on the flat top; not its maximum, which noise
    biases upwards)."""
    level = ratio * xi[k]
    start, stop = _lobe(xi, k, ratio)
    if steep_after and stop < xi.shape[0]:  # stop: the first sample below the level
        crossing = stop - 1 + float((xi[stop - 1] - level) / (xi[stop - 1] - xi[stop]))
        ahead = max(float(k), crossing - fs / bandwidth_hz)
    elif not steep_after and start > 0:  # start - 1: the last sample below the level
        crossing = start - 1 + float((level - xi[start - 1]) / (xi[start] - xi[start - 1]))
        ahead = min(float(k), crossing + fs / bandwidth_hz)
    else:  # no drop in the record (a rejected point): the maximum itself
        return k, float(xi[k])
    return crossing, float(np.interp(ahead, np.arange(xi.shape[0]), xi))


def _smoothed_point(k, **_):
    """The maximum of the extractor's smoothed curve (the behaviour before the windowed point)."""
    return k, None


def _windowed_point(k, *, x, fs, mode, trim, xi, ratio, bandwidth_hz, to_disp, clip, **_):
    """Index (in the analysed part) and displacement amplitude of the windowed jump point."""
    start, stop = _lobe(xi, k, ratio)
    amp = windowed_amplitude(x, mode.phase, fs, sigma_s=gaussian_sigma(bandwidth_hz),
                             start=trim + start, stop=trim + stop)
    xw = to_disp(amp, clip(mode.frequency[trim + start : trim + stop]))
    j = int(np.argmax(xw))
    return start + j, float(xw[j])


# name -> jump point rule (extract_backbone_points' `jump_point`); a new rule is one function
# here and one line
JUMP_POINTS = {"windowed": _windowed_point, "smoothed": _smoothed_point, "drop": _drop_point}

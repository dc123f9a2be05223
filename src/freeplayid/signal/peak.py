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

__all__ = ["JUMP_POINTS", "NEEDS_BASE", "windowed_amplitude", "one_sided_amplitude",
           "gaussian_sigma"]

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


def _smoothed_crossing(xi, k, ratio, steep_after):
    """Fractional index where the smoothed curve ``xi`` falls through ``ratio * xi[k]`` on the
    jump's steep side (linearly interpolated), or None when it never does (no drop)."""
    level = ratio * xi[k]
    start, stop = _lobe(xi, k, ratio)
    if steep_after and stop < xi.shape[0]:  # stop: the first sample below the level
        return stop - 1 + float((xi[stop - 1] - level) / (xi[stop - 1] - xi[stop]))
    if not steep_after and start > 0:  # start - 1: the last sample below the level
        return start - 1 + float((level - xi[start - 1]) / (xi[start] - xi[start - 1]))
    return None


def _drop_smoothed_point(k, *, xi, ratio, steep_after, fs, bandwidth_hz, **_):
    """The drop read off the smoothed curve alone: where it falls through ``ratio`` times its
    maximum, and its value one filter time ahead (the rule before ``"drop"``; its filter reaches
    the grazing transient after the drop, see :func:`_drop_point`)."""
    crossing = _smoothed_crossing(xi, k, ratio, steep_after)
    if crossing is None:  # no drop in the record (a rejected point): the maximum itself
        return k, float(xi[k])
    ahead = (max(float(k), crossing - fs / bandwidth_hz) if steep_after
             else min(float(k), crossing + fs / bandwidth_hz))
    return crossing, float(np.interp(ahead, np.arange(xi.shape[0]), xi))


def one_sided_amplitude(x, phase, sample_rate: float, *, sigma_s: float, center: float,
                        edge: float) -> float:
    """Gaussian-weighted least-squares first-harmonic amplitude at the fractional sample
    ``center``, using only the samples on ``center``'s side of the fractional sample ``edge``.

    As :func:`windowed_amplitude` at one sample, with the weights cut at ``edge``: nothing
    beyond it (after a drop, the transient) enters the estimate.

    Parameters
    ----------
    x, phase : ndarray, shape (N,) [signal units], [rad]
    sample_rate : float [Hz]
    sigma_s : float [s]
        Standard deviation of the Gaussian weight (cut at ``TRUNCATE`` sigma).
    center, edge : float
        Fractional sample indices.

    Returns
    -------
    float [signal units]
    """
    half = TRUNCATE * sigma_s * sample_rate
    if edge >= center:
        lo, hi = max(0, math.ceil(center - half)), min(x.shape[0], math.floor(edge) + 1)
    else:
        lo, hi = max(0, math.ceil(edge)), min(x.shape[0], math.floor(center + half) + 1)
    idx = np.arange(lo, hi)
    if idx.size < 3:
        return float("nan")
    sw = np.exp(-0.25 * ((idx - center) / (sigma_s * sample_rate)) ** 2)  # sqrt of the weight
    basis = np.stack([np.cos(phase[idx]), np.sin(phase[idx])], axis=1) * sw[:, None]
    ab = np.linalg.lstsq(basis, x[idx] * sw, rcond=None)[0]
    return float(np.hypot(ab[0], ab[1]))


def _drop_point(k, *, x, fs, mode, trim, xi, ratio, steep_after, bandwidth_hz, to_disp, clip,
                window: float = 1.0, **_):
    """Fractional index of the drop and the displacement amplitude ``window`` filter times
    ahead of it, read over ``window`` times the extractor's width, from windows that stop at the
    drop (the block comment above :data:`JUMP_POINTS`)."""
    c0 = _smoothed_crossing(xi, k, ratio, steep_after)
    if c0 is None:  # no drop in the record (a rejected point): the maximum itself
        return k, float(xi[k])
    n = xi.shape[0]
    side = 1.0 if steep_after else -1.0  # where the drop lies from the top, in time
    filter_time = fs / bandwidth_hz  # [samples]
    sigma = gaussian_sigma(bandwidth_hz)

    def ahead_of(c, times=1.0):  # filter times towards the top (not clamped to the maximum, a
        # sample index that jumps along a flat top), within the analysed record
        return min(max(c - side * times * filter_time, 0.0), n - 1.0)

    # the top's level, in signal units, from a window that stops at the smoothed crossing
    top = one_sided_amplitude(x, mode.phase, fs, sigma_s=sigma, center=trim + ahead_of(c0),
                              edge=trim + c0)
    if not np.isfinite(top):
        return _drop_smoothed_point(k, xi=xi, ratio=ratio, steep_after=steep_after, fs=fs,
                                    bandwidth_hz=bandwidth_hz)
    # the drop on a sharp amplitude (a Gaussian of DROP_CYCLES response cycles): its first
    # crossing of ratio x top, searched from a quarter filter time on the top's side of c0
    f_top = float(clip(mode.frequency[trim + int(round(ahead_of(c0)))]))
    a = int(max(0, math.floor(c0 - 0.25 * filter_time)))
    b = int(min(n, math.ceil(c0 + 0.25 * filter_time) + 1))
    sharp = windowed_amplitude(x, mode.phase, fs, sigma_s=DROP_CYCLES / f_top, start=trim + a,
                               stop=trim + b)
    level = ratio * top
    below = sharp < level
    # consecutive samples (i, i + 1) in time order from the top's side: the first that go from
    # at or above the level to below it
    order = np.arange(sharp.shape[0]) if steep_after else np.arange(sharp.shape[0])[::-1]
    crossing = c0
    for i, j in zip(order[:-1], order[1:], strict=True):
        if not below[i] and below[j]:
            crossing = a + i + side * float((sharp[i] - level) / (sharp[i] - sharp[j]))
            break
    center = ahead_of(crossing, window)
    amp = one_sided_amplitude(x, mode.phase, fs, sigma_s=window * sigma, center=trim + center,
                              edge=trim + crossing)
    freq = clip(np.interp(trim + center, np.arange(mode.frequency.shape[0]), mode.frequency))
    return crossing, float(to_disp(np.asarray(amp), np.asarray(freq)))


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


# The drop point (``jump_point="drop"``, the replay's statistic). The maximum of a swept jump lies
# on a flat top, where noise decides its place; the drop after it is sharp. After the drop the
# response falls to the in-gap branch through a few cycles of grazing contacts (0.3-0.5 s on
# the fin at 5 % damping) that are sensitive to everything: a relative change of 1e-9 in kn
# moves them by 2 % of the record's peak (RK4 and the exponential engine alike). Read through
# the extractor's smoother (a filter time of about 1 s), that transient moved the smoothed
# crossing by 0.001-0.002 Hz and the amplitude by 0.02 % at random between replays 1e-7
# apart, a 0.02-0.05 % jitter of the replayed fit, more than the replay loop's 0.05 % steps
# (benchmarks/binding_jitter.py). So the drop point uses windows that stop at the drop:
#
#   1. c0: the smoothed curve's crossing of ``jump_ratio`` x its maximum (a first guess);
#   2. top: the Gaussian-weighted least-squares amplitude (the extractor's half-gain width)
#      one filter time (1 / bandwidth) towards the top from c0, its weights cut at c0;
#   3. the crossing: where a sharp amplitude (a Gaussian of DROP_CYCLES response cycles) first
#      falls through ``jump_ratio`` x top, searched from a quarter filter time before c0,
#      interpolated between samples; its frequency is the excitation's there (the sweep law);
#   4. the amplitude: as in 2, one filter time towards the top from that crossing, cut there,
#      converted with Eq. 9 at the response's frequency there (``window`` = ``drop_window``
#      filter times, over that many times the width: below).
#
# Nothing after the crossing enters the point. DROP_CYCLES = 1 keeps the sharp amplitude's
# noise at a few percent of the top for the compare studies' noisiest channel while the fall
# (the amplitude halves within 2-4 cycles) stays resolved.
#
# Under white noise the crossing's time is all but exact (its frequency scattered by 1e-5
# relative on the noise study's 0.3 g cases) and the point's noise is its amplitude's: a
# Gaussian window of width sigma at the sample rate fs averages about 2 sqrt(pi) sigma fs
# samples. ``Extraction.drop_window`` reads it over a longer window, further ahead: less
# noise, but a point further down the upper branch, which the damping's form moves more
# (``benchmarks/drop_window.py`` measures both).
DROP_CYCLES = 1.0

def _quadrature_point(k, *, x, fs, mode, trim, xi, ratio, steep_after, bandwidth_hz, to_disp,
                      clip, base_phase=None, window: float = 1.0, **_):
    """Fractional index and displacement amplitude of the phase resonance: where the response's
    first harmonic comes into quadrature with the base's on the way up to the drop (the block
    comment above :data:`JUMP_POINTS`); the drop point where it does not (no quadrature before
    the drop, e.g. a down-sweep's jump-up)."""
    if base_phase is None:
        raise ValueError("`jump_point='quadrature'` needs the base channel (the phase reference)")

    def drop():
        return _drop_point(k, x=x, fs=fs, mode=mode, trim=trim, xi=xi, ratio=ratio,
                           steep_after=steep_after, bandwidth_hz=bandwidth_hz, to_disp=to_disp,
                           clip=clip, window=window)

    c0 = _smoothed_crossing(xi, k, ratio, steep_after)
    if c0 is None or not steep_after:  # no drop, or a jump-up: the upper branch after it
        return drop()  # never passes through the phase resonance
    start, _ = _lobe(xi, k, ratio)
    n = xi.shape[0]
    delta = mode.phase[trim : trim + n] - np.asarray(base_phase)[trim : trim + n]
    cos_lag = np.cos(delta)
    c = cos_lag[start : int(math.floor(c0)) + 1]
    flip = np.nonzero(np.sign(c[1:]) != np.sign(c[0]))[0] if c.size >= 2 else np.zeros(0)
    if not flip.size:
        return drop()
    i = int(flip[0])
    crossing = _fitted_crossing(cos_lag, start + i + float(c[i] / (c[i] - c[i + 1])),
                                lo=start, hi=c0, half=fs / bandwidth_hz)
    amp = one_sided_amplitude(x, mode.phase, fs, sigma_s=window * gaussian_sigma(bandwidth_hz),
                              center=trim + crossing, edge=trim + c0)
    if not np.isfinite(amp):
        return drop()
    freq = clip(np.interp(trim + crossing, np.arange(mode.frequency.shape[0]), mode.frequency))
    return crossing, float(to_disp(np.asarray(amp), np.asarray(freq)))


def _fitted_crossing(c, first: float, *, lo: float, hi: float, half: float) -> float:
    """Where ``c`` (the cosine of the response's phase lag behind the base) crosses zero: the
    zero of a straight line fitted to it over a window symmetric about the crossing (at most
    ``half`` samples either side, within ``lo .. hi``), moved to that zero until it settles,
    from ``first`` (its first sign change). Noise makes early sign changes, and a first sign
    change reads them (on fin B at 0.2 g of noise the point fell up to 0.8 Hz early); the line
    averages over the window. The window stays symmetric so that the curve's bend towards the
    drop does not tilt the line. A zero outside the window (a line too flat to extrapolate) is
    not followed; ``first`` where the window is too short for a line."""
    j = first
    for _ in range(MAX_REFITS):
        h = min(half, j - lo, hi - j)
        a, b = int(math.ceil(j - h)), int(math.floor(j + h)) + 1
        if h < CROSSING_MIN_FIT * half or b - a < 8:
            break
        slope, at_j = np.polyfit(np.arange(a, b) - j, c[a:b], 1)
        if not (np.isfinite(slope) and slope != 0.0):
            break
        moved = j - at_j / slope
        if abs(moved - j) > h:  # the line's zero outside its window: an extrapolation
            break
        j, step = moved, abs(moved - j)
        if step < 0.5:  # within a sample
            break
    return float(j)


# the quadrature crossing's line (:func:`_fitted_crossing`): refits at most, and the shortest
# half-window it is fitted over, a fraction of the extractor's filter time (shorter: the first
# sign change is kept)
MAX_REFITS = 5
CROSSING_MIN_FIT = 0.25


# The quadrature point (``jump_point="quadrature"``, with a base channel). At the phase
# resonance the response of a lightly damped mode lags its forcing by a quarter period, and
# there it lies on the backbone whatever the damping's form or level (the damping force alone
# balances the excitation; for the describing-function oscillator exactly at the curve's
# maximum). On an up-sweep's upper branch the response-to-base phase goes from in (or anti)
# phase through quadrature at the phase resonance to the fold and the drop beyond it, so the
# point is where cos(phase_response - phase_base) changes sign within the lobe before the drop
# (the zero of a line fitted about its first sign change, :func:`_fitted_crossing`); the phase
# moves by about 1 / (zeta f) rad per Hz there, while the drop's place on the backbone depends on
# how the damping acts (a Rayleigh-damped beam: the replays of a modal damping matched the drop
# points only at delta -11 %). The base's phase is read over the band the replay's excitation is
# (a quarter of the responses' where the base is noisy: signal.level.quiet_base), so the replays
# are read against the phase they were driven with. The amplitude is read as the drop point's,
# from a window that stops at the drop. A run that never passes through quadrature before its
# drop (a down-sweep's jump-up onto the upper branch) gives its drop point.

# name -> jump point rule (extract_backbone_points' `jump_point`); a new rule is one function
# here and one line
JUMP_POINTS = {"windowed": _windowed_point, "smoothed": _smoothed_point, "drop": _drop_point,
               "drop_smoothed": _drop_smoothed_point, "quadrature": _quadrature_point}
# the rules that need the base channel's first-harmonic phase (``base_phase``)
NEEDS_BASE = ("quadrature",)

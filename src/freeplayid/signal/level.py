"""The base channel's first harmonic: its level in windows, and the band it is read over.

The base (control) accelerometer of a sine-sweep test moves as ``A sin(phase)``; its amplitude
in windows along the sweep gives the run's level (the replay) and, against the manifest's
``level_g``, a units or quantity error (the verdict). Its first harmonic along the sweep, over
the band :func:`quiet_base` picks, is both the excitation the replay is driven with
(:func:`freeplayid.replay.excitation.measured_sweep`) and the phase reference of the quadrature
jump point (:mod:`freeplayid.signal.peak`): one reading of the base for both, so that the
replay's statistic is taken against the excitation it was driven with.
"""

from __future__ import annotations

import functools
import math

import numpy as np

__all__ = ["window_amplitudes", "quiet_base", "envelope_noise", "reading_sd", "sharpened",
           "sharpened_gain", "rounds", "NARROW_BASE", "ENVELOPE_NOISE", "SHARPEN_STEPS",
           "SHARPEN_FROM", "reading_gap", "GAP_Z", "GAP_AROUND",
           "GAP_Z_AROUND", "GAP_Z_STRONG", "quiet_phase", "law_phase", "phase_sd",
           "PHASE_DEGREE", "PHASE_TIMES_PER_TERM", "PHASE_Z"]

# The base level is what the controller holds. A replay driven by the measured envelope feels
# its noise as a level error: at the response extraction's bandwidth the envelope of a base
# record with 0.05 g of noise at 256 Hz scatters by 0.4-1.2 % (0.4-1.2 g; measured against the
# known profile of benchmarks/realtests data), and replays driven by it put delta 1-1.4 % off
# on a level ramp and a level dip (0.4-0.5 % over a quarter of the bandwidth). The phase
# scatters as much (radians for relative amplitude): on fin B (levels 0.13-0.39 g, 0.2 g of
# noise) the quadrature point, read against the wide band's phase, fell 0.1-0.8 Hz early with a
# scatter of 0.05-0.3 Hz. Over a quarter of the bandwidth a notch whose flanks last under a
# second (0.5 Hz of sweep at 0.5 Hz/s) is filled in, so the narrow band is taken only where the
# wide one is noisy.
NARROW_BASE = 0.25  # [-] the narrow band, a fraction of the response extraction's bandwidth
ENVELOPE_NOISE = 2e-3  # [-] relative scatter of the wide band's envelope that takes the narrow
# Van Cittert steps that undo most of the narrow band's rounding of a level profile
# (:func:`sharpened`): the reading a_0 = S x of the level x, a_{k+1} = a_k + (a_0 - S a_k), has
# the response 1 - (1 - H)^(k + 1) to x. Averaged over the 3 s before each jump of the realtests
# level dips (benchmarks/realtests, clean base records), the narrow reading was 0.6-1.3 % low;
# one step left 0.25-0.47 %, two 0.12-0.23 %, at 1.22 times the narrow reading's noise (sd).
# More steps widen the band towards the wide one's noise (its response tends to 1 wherever
# (k + 1) H >> 1); on 28 realtests answers with level profiles or noise, two steps put delta's
# RMS error at 0.37 % against 0.47 % unsharpened, 0.78 % read over half the band.
SHARPEN_STEPS = 2
# A run's reading is sharpened only where it shows a profile the band rounds (:func:`rounds`):
# the first step's correction a_0 - S a_0 beyond this many of its noise-alone standard deviations
# somewhere in the record. Its noise-alone maximum over a record was 2.1-4.0 on 30 realtests runs
# without a level profile (constant levels, ramps; fins B and C at 0.05-0.2 g), the dips' runs
# 7.6-22; fin B's dips (3.5-4.0) are hidden by its noise, where sharpening would add noise only.
SHARPEN_FROM = 6.0
# A run jumps where the level has fallen (or risen) far enough, so the level that decides its
# jump is the one in the time before it. The narrow band rounds a profile over its own time
# (1 / band); :func:`reading_gap` compares the chosen reading with the wide band's over the half
# of that time before the jump, and a gap beyond this many of its noise-alone standard
# deviations says the chosen reading misses a profile there (the three standard errors that the
# replay's other checks take as significant).
GAP_Z = 3.0
# [windows] how far either side of a run's point the window's end is moved to find its largest
# gap (:func:`reading_gap`'s ``around``): the level that decides a run's point is read on its
# approach, and the narrow band's rounding of a flank crosses the level there, so a single
# window ending at the point can average a gap of each sign to none (realtests' fin C at
# 0.4 Hz/s, d1: -1.4 standard deviations ending at the points, 8-19 one second later, and
# delta -3.7 %, `ok`). Half a window (1 s at the quarter band) either side covers the flank
# a run crosses on its way to the point and the jump that follows it.
GAP_AROUND = 0.5


def _scanned_z(z: float, around: float) -> float:
    """The threshold on the largest of the gaps that :func:`reading_gap` scans ``around`` window
    lengths either side of a point whose false alarm on white noise is that of one window at
    ``z``: the scan spans 1 + 2 ``around`` independent windows (Sidak's correction)."""
    import scipy.stats

    one = 2.0 * float(scipy.stats.norm.sf(z))
    return float(scipy.stats.norm.isf(0.5 * (1.0 - (1.0 - one) ** (1.0 / (1.0 + 2.0 * around)))))


# the gate on the gap scanned around a point: 3.32 standard deviations for GAP_Z 3 scanned half
# a window either side (three windows' worth), as often crossed by noise as one window at GAP_Z
GAP_Z_AROUND = _scanned_z(GAP_Z, GAP_AROUND)
# a gap that says the narrowed reading plainly misses a profile: twice the gate. On 206
# realtests answers at constant levels (no dip or ramp), the largest gap read around their
# jumps was 3.9 standard deviations; fast dips' runs reach 8-31
GAP_Z_STRONG = 2.0 * GAP_Z_AROUND
# The phase of a noisy base read over the narrow band still scatters: on fin B (0.05 g of noise
# on 0.13-0.39 g) by 0.011-0.036 rad, which moves the quadrature point, where the response's
# phase crosses the base's on the way to its jump, and put delta's answer 0.9-1.7 % off (sd
# over draws). A shaker holds the base at the controller's sweep, so the base's phase is the
# sweep law's plus an offset that moves slowly with frequency (the shaker's and fixture's phase,
# and the law's own error): read as the law's phase plus a polynomial in time of this degree
# fitted to the narrow reading's offset (:func:`law_phase`), its noise falls to 0.0015-0.009
# rad on those records (degree 4 on the whole record). Degree 4 follows a constant, a law's
# error in its start and rate (quadratic) and a smooth drift over the band; what it cannot
# follow, the gate below catches.
PHASE_DEGREE = 4
# [-] narrow-band times (1 / band) per term of that polynomial: a reading's noise is
# correlated over about one such time, so a stretch of 2 k of them carries k terms' worth (at
# 0.25 Hz: a 65-s stretch the full degree, 30 s a parabola, 10-16 s a constant; a window cut
# around a jump for the answer's noisy copies, 15-22 s with 5 s at each end, a constant or none)
PHASE_TIMES_PER_TERM = 2.0
# Where the base's phase moves within the record (a shaker table that lags its drive as the load
# resonates, a controller's step), the polynomial misses it: the narrow reading's offset about
# it, away from the record's ends, beyond this many of the reading's phase noise
# (:func:`phase_sd`) keeps the narrow reading (:func:`law_phase` returns None). On 1320
# realtests base records read over the narrow band (d0 and d1), none with a phase move, the
# largest excursion was 3.7 of that noise in the median, 5.5 at the 99th percentile and 7.0 at
# most (3.4 % beyond 5; level dips raise it, and keep their narrow readings); a lag of
# 0.1-0.15 rad around each jump (the fifteenth set: fin B, the default fin) reached 5.4-20 in
# the runs that jump.
PHASE_Z = 5.0
# [-] a reading noise below this counts as none (a noiseless record reads 1e-8 to 1e-6 from the
# extraction's own error): a level error a hundred times below the 1 % that moves delta by 1 %
EXACT_READING = 1e-4


def window_amplitudes(x, fs, sweep=None, *, n_windows: int = 16):
    """Frequency and first-harmonic amplitude of ``x`` in ``n_windows`` equal windows.

    With the sweep law the amplitude is the least-squares sine at the sweep's phase (noise
    averages out); without it, sqrt(2) x RMS and the zero-crossing rate.

    Parameters
    ----------
    x : ndarray, shape (T,) [any]
    fs : float [Hz]
    sweep : Sweep, optional
        The record's sweep law (sample 0 at its t = 0).
    n_windows : int

    Returns
    -------
    frequency : ndarray, shape (n_windows,) [Hz]
    amplitude : ndarray, shape (n_windows,) [units of x]
    """
    n = x.size // n_windows
    t = np.arange(x.size) / fs
    f_out, a_out = [], []
    for k in range(n_windows):
        sl = slice(k * n, (k + 1) * n)
        xw = x[sl] - np.mean(x[sl])
        if sweep is not None:
            ph = sweep.phase(t[sl])
            basis = np.column_stack([np.sin(ph), np.cos(ph)])
            coef, *_ = np.linalg.lstsq(basis, xw, rcond=None)
            a_out.append(math.hypot(*coef))
            f_out.append(float(np.mean(sweep.frequency(t[sl]))))
        else:
            crossings = np.count_nonzero(np.diff(np.signbit(xw)))
            a_out.append(math.sqrt(2.0) * float(np.std(xw)))
            f_out.append(crossings / (2.0 * n / fs))
    return np.array(f_out), np.array(a_out)


def quiet_base(wide, narrow):
    """Of the base record's first harmonic over the response extraction's band (``wide``) and
    over :data:`NARROW_BASE` of it (``narrow``), the one to read the base by: ``narrow`` where
    ``wide``'s envelope is noisier than :data:`ENVELOPE_NOISE` (:func:`envelope_noise`), else
    ``wide`` (ChirpMode each)."""
    return narrow if envelope_noise(wide.amplitude, narrow.amplitude) > ENVELOPE_NOISE else wide


def quiet_phase(wide, narrow, law, sample_rate: float) -> np.ndarray:
    """The base record's first-harmonic phase [rad] at every sample, of the ChirpMode
    :func:`quiet_base` picks: the wide band's as read; the narrow band's, where the base is
    noisy, read against the sweep law (:func:`law_phase`, its noise :func:`phase_sd`) unless
    its phase moves within the record, where it is kept as read."""
    chosen = quiet_base(wide, narrow)
    if chosen is wide or law is None:
        return np.asarray(chosen.phase, dtype=float)
    smooth = law_phase(chosen, law, sample_rate, phase_sd(wide, narrow))
    return np.asarray(chosen.phase, dtype=float) if smooth is None else smooth


def phase_sd(wide, narrow) -> float:
    """The standard deviation [rad] of the phase of ``narrow`` from white noise, from its
    difference to ``wide``'s (two readings of one record, ChirpModes) as :func:`reading_sd`
    takes the envelope's: the robust scatter (1.4826 x MAD) of the wrapped difference, less
    the noise the two bands share, over the narrow band. A phase move both bands follow
    cancels; one the narrow band rounds, where it lasts a few seconds, touches too few samples
    to move the median."""
    d = np.angle(np.exp(1j * (np.asarray(wide.phase, float) - np.asarray(narrow.phase, float))))
    d = d[np.isfinite(d)]
    if d.size == 0:
        return 0.0
    sd_wide, r = _wide_sd(1.4826 * float(np.median(np.abs(d - np.median(d)))), wide, narrow)
    return sd_wide * math.sqrt(r)


def law_phase(mode, law, sample_rate: float, noise_sd: float, *, degree: int = PHASE_DEGREE,
              z: float = PHASE_Z) -> np.ndarray | None:
    """``mode``'s phase (a ChirpMode of a base record, sample 0 at ``law``'s t = 0) read as
    the sweep law's phase plus a Legendre polynomial in time least-squares fitted to the
    unwrapped offset ``mode.phase - law.phase(t)`` away from the record's ends (1.25 / band
    seconds, where the extraction's own edges are) and continued along its tangent over them.
    Its degree is ``degree`` (:data:`PHASE_DEGREE`) on a long record and less on a short one:
    one term per two of the narrow band's times (1 / band) in the fitted stretch
    (:data:`PHASE_TIMES_PER_TERM`), so that a window cut around a jump (the answer's noisy
    copies, 15-20 s at 0.25 Hz) is read with a constant or a line, not a polynomial that
    follows its noise and swings at its ends. None where the offset's residual exceeds ``z``
    (:data:`PHASE_Z`) times ``noise_sd`` (the reading's phase noise, :func:`phase_sd`)
    anywhere away from the ends: a phase that moves faster than the polynomial follows, which
    the reading keeps. None too where no stretch is left to fit."""
    phase = np.asarray(mode.phase, dtype=float)
    n = phase.size
    t = np.arange(n) / float(sample_rate)
    swept = np.asarray(law.phase(t), dtype=float)
    offset = np.unwrap(phase - swept)
    band = float(mode.bandwidth_hz)
    trim = int(1.25 / band * sample_rate)
    lo, hi = trim, n - trim
    terms = int((hi - lo) / sample_rate * band / PHASE_TIMES_PER_TERM)
    if terms < 1 or hi - lo < 16 or not np.all(np.isfinite(offset[lo:hi])):
        return None
    deg = min(int(degree), terms - 1)
    x = (t - t[lo]) / (t[hi - 1] - t[lo]) * 2.0 - 1.0
    coef = np.polynomial.legendre.legfit(x[lo:hi], offset[lo:hi], deg)
    # over the ends, the tangent at the fitted stretch's ends (a polynomial there would swing)
    leg = np.polynomial.legendre
    inner = np.clip(x, -1.0, 1.0)
    fitted = leg.legval(inner, coef) + (x - inner) * leg.legval(inner, leg.legder(coef))
    if float(np.max(np.abs(offset - fitted)[lo:hi])) > z * noise_sd:
        return None
    return swept + fitted


def envelope_noise(wide, narrow) -> float:
    """The relative noise of the envelope ``wide`` (one extraction of a record) against
    ``narrow`` (the same over a narrower band): the robust scatter (1.4826 x the median absolute
    deviation) of their difference over the median level. A level profile both bands follow
    cancels, a notch narrower than the narrow band touches few samples and barely moves the
    median, white noise does not cancel."""
    d = np.asarray(wide, float) - np.asarray(narrow, float)
    d = d[np.isfinite(d)]
    level = float(np.median(np.abs(narrow)))
    if d.size == 0 or level <= 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / level)


def _read_again(a, narrow, sample_rate: float, law) -> np.ndarray:
    """The amplitude ``a`` (at ``narrow``'s phase) read again over ``narrow``'s band as it was
    adapted (:func:`freeplayid.signal.acmp`, ``law`` its hint)."""
    from .acmp import acmp

    return acmp(a * np.cos(narrow.phase), sample_rate, sweep=law,
                bandwidth_hz=float(narrow.bandwidth_hz), adapt=False).amplitude


def sharpened(narrow, sample_rate: float, law, steps: int = SHARPEN_STEPS) -> np.ndarray:
    """The amplitude of ``narrow`` (a ChirpMode of a record read over a narrow band) with the
    band's rounding of the level profile undone by ``steps`` Van Cittert steps
    (:data:`SHARPEN_STEPS`): each reads the amplitude again over the band (``law`` its hint)
    and adds what that reading lost. A level that varies slower than the band passes unchanged;
    the noise grows by :func:`sharpened_gain`."""
    a0 = np.asarray(narrow.amplitude, dtype=float)
    a = a0
    for _ in range(steps):
        a = a + (a0 - _read_again(a, narrow, sample_rate, law))
    return a


def rounds(narrow, sample_rate: float, law, noise_sd: float) -> bool:
    """Whether the reading ``narrow`` (a ChirpMode) shows a level profile its band rounds: the
    first sharpening step's correction, relative to the median level, exceeds
    :data:`SHARPEN_FROM` times its noise-alone standard deviation (``noise_sd``, the reading's
    relative noise, times the step's gain, :func:`_noise_gain`) somewhere away from the
    record's ends (1.25 / band seconds, where the extraction's own edges are)."""
    if noise_sd <= 0:
        return True
    a0 = np.asarray(narrow.amplitude, dtype=float)
    trim = int(1.25 / float(narrow.bandwidth_hz) * sample_rate)
    step = (a0 - _read_again(a0, narrow, sample_rate, law))[trim:a0.size - trim]
    if step.size == 0:
        return False
    gain = _noise_gain(lambda h: h * (1.0 - h))
    return float(np.max(np.abs(step))) / float(np.median(a0)) > SHARPEN_FROM * noise_sd * gain


@functools.lru_cache(maxsize=8)
def sharpened_gain(steps: int = SHARPEN_STEPS) -> float:
    """How much :func:`sharpened` multiplies a reading's white-noise standard deviation: the
    gain of ``F = 1 - (1 - H)^(steps + 1)`` (:func:`_noise_gain`; 1.22 for two steps)."""
    return _noise_gain(lambda h: 1.0 - (1.0 - h) ** (steps + 1))


def _low_pass(f, corner: float = 1.0):
    """The extraction's low-pass ``H(f) = 1 / (1 + (f / corner)^4)``."""
    return 1.0 / (1.0 + (f / corner) ** 4)


def _integral(g) -> float:
    """``int_0^inf g(f) df``."""
    import scipy.integrate

    return float(scipy.integrate.quad(g, 0.0, np.inf)[0])


def _noise_gain(response) -> float:
    """``sqrt(int F(H)^2 / int H^2)``: how much the response ``F`` of the reading ``H``
    (:func:`_low_pass`) multiplies its white-noise standard deviation."""
    return math.sqrt(_integral(lambda f: response(_low_pass(f)) ** 2)
                     / _integral(lambda f: _low_pass(f) ** 2))


def reading_sd(wide, narrow, chosen) -> float:
    """The relative noise of the envelope ``chosen`` (``wide`` or ``narrow``, the ChirpModes
    :func:`quiet_base` chose between), from their difference's (:func:`envelope_noise`).

    Each reading is the record's demodulated noise through the extraction's low-pass, ``H(f) =
    1 / (1 + (f / f_c)^4)`` at its band ``f_c`` (their ``bandwidth_hz`` as adapted; ratio ``r``
    = narrow / wide), so ``var(narrow) = r var(wide)`` and ``var(wide - narrow) = var(wide) (1
    + r - 2 k r)``, ``k = int H_w H_n / int H_n^2`` (1.33 at r = 1/4): the two readings share
    the narrow band's noise. Checked on a constant-level sweep with white noise (0.05-0.2 g
    against 0.2-1 g, tests/test_real_tests.py). A level profile both bands follow does not
    count; one the narrow band rounds (a dip shorter than its time) counts in part, as noise."""
    sd_wide, r = _wide_sd(envelope_noise(wide.amplitude, narrow.amplitude), wide, narrow)
    sd = sd_wide * math.sqrt(r) if chosen is narrow else sd_wide
    return sd if sd >= EXACT_READING else 0.0


def _wide_sd(difference_sd: float, wide, narrow) -> tuple[float, float]:
    """(the wide reading's white-noise standard deviation, the bands' ratio r = narrow / wide)
    from ``difference_sd``, that of the difference of the two readings (:func:`reading_sd`:
    ``var(wide - narrow) = var(wide) (1 + r - 2 k r)``); the narrow one's is ``sqrt(r)`` times
    it."""
    r = min(max(float(narrow.bandwidth_hz) / float(wide.bandwidth_hz), 1e-3), 0.9)
    share = 1.0 + r - 2.0 * _shared(r) * r
    return difference_sd / math.sqrt(max(share, 1e-3)), r


@functools.lru_cache(maxsize=64)
def _shared(r: float) -> float:
    """``int H_1 H_r / int H_r^2`` of the low-passes :func:`_low_pass` at corners 1 and r."""
    return (_integral(lambda f: _low_pass(f) * _low_pass(f, r))
            / _integral(lambda f: _low_pass(f, r) ** 2))


def reading_gap(chosen, wide, sample_rate: float, at: int, band_hz: float, *,
                around: float = 0.0) -> tuple[float, float]:
    """How far the wide band's reading of a base record lies from the ``chosen`` one where a run
    jumps: the mean of ``wide - chosen`` (relative envelopes of one level) over the half of the
    chosen band's time (0.5 / ``band_hz`` s) that ends at sample ``at``, and that mean in units
    of its noise: the robust scatter (1.4826 x MAD) of the same running mean along the whole
    record, away from its ends (1.25 / ``band_hz`` s, where the extraction's own edges are). A
    profile both readings follow cancels; a short feature the chosen band rounds shows where it
    is; white noise scatters the running mean alike everywhere.

    With ``around`` > 0 the window's end may lie anywhere within ``around`` window lengths
    either side of ``at`` (a step of an eighth of a window), and the one whose gap stands
    furthest from its noise is returned: a reading that rounds a flank lies on both sides of the
    level, above on one side of the flank and below on the other, so one window can straddle
    the crossing and show no gap where the reading misses the profile on either side.
    (nan, nan) where the window or the record is too short."""
    d = np.asarray(wide, dtype=float) - np.asarray(chosen, dtype=float)
    n = max(int(round(0.5 / band_hz * sample_rate)), 1)
    trim = int(1.25 / band_hz * sample_rate)
    at = int(at)
    if not n <= at <= d.size or d.size - n + 1 - 2 * trim < 8:
        return math.nan, math.nan
    c = np.concatenate(([0.0], np.cumsum(d)))
    running = (c[n:] - c[:-n]) / n  # running[k]: the mean of d[k:k + n]
    reach = int(round(float(around) * n))
    ends = np.arange(max(at - reach, n), min(at + reach, d.size) + 1,
                     max(n // 8, 1) if reach else 1)
    gaps = running[ends - n]
    core = running[trim:running.size - trim]
    sd = 1.4826 * float(np.median(np.abs(core - np.median(core))))
    gap = float(gaps[int(np.argmax(np.abs(gaps)))])
    if not sd > 0:
        return gap, (0.0 if gap == 0 else math.copysign(math.inf, gap))
    return gap, gap / sd

"""ACMP: adaptive chirp mode pursuit (Chen et al., MSSP 116, 2019), one chirp mode.

Signal model ``x(t) ~ u(t) cos phi(t) + v(t) sin phi(t)``, ``phi = 2 pi int f~ dt``, with u, v
narrow-band (slowly varying). Iteration n (Chen et al., MSSP 116 (2019) 566-584):

1. mode update, a banded O(N) solve (see :func:`.banded.demodulate`)::

       y = (Phi^T Phi / alpha + K^T K)^{-1} K^T x,    x_m = K y

2. instantaneous-frequency increment by arctangent demodulation::

       df^ = (v u' - u v') / (2 pi (u^2 + v^2))

3. its Tikhonov smoothing and the update ``f~ <- f~ + (P / beta + I)^{-1} df^`` (P = D^T D),
4. bandwidth adaptation ``alpha <- alpha (x_m^T x_m) / (x_m^T x)`` (residual orthogonal to mode),
5. stop when ``||x_m^n - x_m^{n-1}||^2 / ||x_m^{n-1}||^2 < tol``.

With ``if_weighting="local"`` (the default) step 3 weights each sample's increment by the
mode's local strength,
``w = a^2 / max(a^2 within +-IF_WEIGHT_SPAN filter times of the IF smoothing)``, and solves
``(P / beta + W) s = W df^`` (a weighted Whittaker smoother): where the mode collapses next to
where it was strong (the drop after a freeplay jump, where the record is the free
transient at another frequency) the frequency follows from the strong side instead of from
the transient, which otherwise pulls it by up to 17 Hz and back, so that the plain pursuit
never settles (module block comment at :data:`IF_WEIGHT_SPAN`).

Bandwidths in Hz. D is the unscaled second difference, so the low-pass ``(I + P/alpha)^{-1}`` has
its corner where ``(2 sin(w/2))^4 = alpha``, i.e. at ``f_c ~ fs alpha^(1/4) / (2 pi)``. We take
``alpha = (2 pi f_c / fs)^4`` (and the same for beta), so a bandwidth means the same thing at
every sample rate.

Speed: the signal is first decimated (zero-phase anti-alias filter) to a rate of about
``decimate_to`` times the highest frequency of the mode; the demodulated u, v, f~ are smooth and
are interpolated back to the original samples. Each iteration's cost is the demodulation's
banded factorisation and solves (:mod:`.banded`; the factor's loop unrolled for its band).
"""

from __future__ import annotations

import hashlib
import math
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numba
import numpy as np
from scipy import signal as sps

from .banded import (
    _factor_kd,
    _solve,  # the compiled triangular solves, called from the pursuit
    demodulate,
    demodulate_into,
    not_positive_definite,
    second_difference_gram,
    smoothing_factor,
)
from .decimate import decimate, decimation_factor
from .validate import as_signal, check_positive

__all__ = ["ChirpMode", "acmp", "ridge_frequency", "bandwidth_weight", "narrowest_bandwidth"]


@dataclass(frozen=True)
class ChirpMode:
    """One extracted chirp mode, at the samples of the input signal.

    Attributes
    ----------
    amplitude : ndarray, shape (N,) [signal units]
        Instantaneous amplitude ``sqrt(u^2 + v^2)``.
    frequency : ndarray, shape (N,) [Hz]
        Instantaneous frequency.
    phase : ndarray, shape (N,) [rad]
        Unwrapped instantaneous phase of the mode, ``mode = amplitude * cos(phase)``.
    mode : ndarray, shape (N,) [signal units]
        The reconstructed mode ``x_m``.
    snr_db : float [dB]
        ``10 log10(||x_m||^2 / ||x - x_m||^2)`` over the record.
    iterations : int
    converged : bool
        Whether the relative mode change fell below ``tol`` within ``max_iter``.
    bandwidth_hz : float [Hz]
        Final demodulation bandwidth (after adaptation).
    sample_rate : float [Hz]
    """

    amplitude: np.ndarray
    frequency: np.ndarray
    phase: np.ndarray
    mode: np.ndarray
    snr_db: float
    iterations: int
    converged: bool
    bandwidth_hz: float
    sample_rate: float


# The banded Cholesky of P / alpha + (O(1) terms) loses accuracy as 1/alpha grows (P is singular
# on lines): measured amplitude errors vs a decimated solve of 2e-4 at 1/alpha = 7e12, 1e-3 at
# 2e13, 3e-3 at 1e14, breakdown near 1e16. We keep 1/alpha <= 1e12, i.e. f_c >= fs / (2 pi 1e3).
MAX_INVERSE_WEIGHT = 1e12
# ``if_weighting="local"``: the span [in IF-smoothing filter times, 1 / if_bandwidth_hz] either
# side of a sample over which its mode's strongest squared amplitude is taken as the reference of
# its weight. The plain pursuit (weights 1) does not converge on records whose first harmonic
# collapses at a jump: 3 of the bundled example's 10 channels and 4 of 10 on a realtests fin
# stop at ``max_iter`` = 100, their amplitude around the drop moved by 7-11 % (the example) and
# 14-1060 % (the fin) between 100 and 400 iterations and the fin's drop points' amplitude by up
# to 0.09 % (0.3 % by 1600), so a point's reading depends on where the iterations stopped and on
# the noise's path through them. With the weights all of
# them converge (16-65 iterations) and the points are the same at 100 and 400 iterations
# (benchmarks/pursuit_convergence.py). Two filter times reach across the drop's transient
# (a few cycles) to the upper branch before it.
IF_WEIGHT_SPAN = 2.0
IF_WEIGHTINGS = ("none", "local")
# ridge_track with `order`: the highest harmonic whose fundamental is looked for below a line
MAX_HARMONIC = 7
# ... and how far above its frame's median power a candidate must stand to be a line [-]
LINE_FACTOR = 20.0


def bandwidth_weight(bandwidth_hz: float, sample_rate: float) -> float:
    """Regularisation weight ``(2 pi f_c / fs)^4`` of a second-difference filter with corner f_c."""
    return (2.0 * math.pi * bandwidth_hz / sample_rate) ** 4


def narrowest_bandwidth(sample_rate: float) -> float:
    """Narrowest bandwidth [Hz] solved accurately at ``sample_rate`` (1/alpha <= 1e12)."""
    return sample_rate * MAX_INVERSE_WEIGHT**-0.25 / (2.0 * math.pi)


def check_bandwidth(bandwidth_hz: float, working_rate: float, name: str) -> None:
    """ValueError if the bandwidth is too narrow for the (decimated) working sample rate."""
    lowest = narrowest_bandwidth(working_rate)
    if bandwidth_hz < lowest:
        raise ValueError(
            f"`{name}` = {bandwidth_hz} Hz is too narrow for the working sample rate "
            f"{working_rate:g} Hz (banded solve ill-conditioned below {lowest:.3g} Hz): decimate "
            "(`decimate_to`) or widen it"
        )


def ridge_track(x, fs: float, *, window_s: float = 1.0, fmin: float = 0.0, order: int = 0):
    """The short-time Fourier ridge: per-frame spectral peak, refined by parabolic interpolation.

    Parameters
    ----------
    x : ndarray, shape (N,) [any]
    fs : float [Hz]
    window_s : float [s]
        STFT window (half overlap); frequency resolution ~ 1/window_s.
    fmin : float [Hz]
        Ignore spectral lines below this (offsets, drifts).
    order : int
        Time derivatives of displacement in ``x`` (0 displacement, 1 velocity, 2 acceleration).
        A nonlinear response has harmonics, and a derivative raises the n-th one's power by
        n^(2 order) against the fundamental: in an acceleration record of a freeplay fin the
        3rd-7th harmonics can outgrow the fundamental for seconds. So the frame's largest line
        f_k is compared with the lines at f_k / n (n = 2 ... ``MAX_HARMONIC``, the local maximum
        within one bin) by their displacement power (the power over f^(2 order)), and the
        largest of those is the ridge: the fundamental of the displacement. Only subharmonics of
        the largest line itself are looked at (not of one found there), and only lines: a
        candidate's power must reach ``LINE_FACTOR`` times the frame's median power (the noise
        floor; a noise bin passes with probability 2^-LINE_FACTOR). Without that test the
        f^-4 weight of an acceleration promoted noise near ``fmin`` over a clean sweep (a
        shaker record at 0.15 g of noise on 0.4 g read 2.5 Hz in 326 of 329 frames).

    Returns
    -------
    t : ndarray, shape (F,) [s]
        Frame centres.
    f : ndarray, shape (F,) [Hz]
        Ridge frequency of each frame.
    power : ndarray, shape (F,)
        The peak's spectral power (a weight).
    df : float [Hz]
        The STFT's bin width.
    """
    n = x.shape[0]
    nper = int(min(n, max(16, round(window_s * fs))))
    f, t, z = sps.stft(x, fs=fs, nperseg=nper, noverlap=nper // 2, boundary=None, padded=False)
    p = np.abs(z) ** 2
    p[f < fmin, :] = 0.0
    k = np.argmax(p, axis=0)
    cols = np.arange(p.shape[1])
    if order:
        # the fundamental of the displacement among the subharmonics of the largest line
        fsafe = np.maximum(f, f[1])
        floor = np.median(p[f >= fmin], axis=0)  # the frame's noise floor
        top, best = k.copy(), p[k, cols] / fsafe[k] ** (2 * order)
        for n in range(2, MAX_HARMONIC + 1):
            j = np.rint(top / n).astype(int)
            j = np.clip(j, 1, len(f) - 2)
            j = j - 1 + np.argmax(np.stack([p[j - 1, cols], p[j, cols], p[j + 1, cols]]), axis=0)
            pd = p[j, cols] / fsafe[j] ** (2 * order)
            line = p[j, cols] >= LINE_FACTOR * floor
            take = (pd > best) & line & (f[j] >= fmin) & (j > 0)
            k, best = np.where(take, j, k), np.where(take, pd, best)
    k = np.clip(k, 1, len(f) - 2)
    lm, l0, lp = (np.log(p[k + d, cols] + 1e-300) for d in (-1, 0, 1))
    den = lm - 2 * l0 + lp
    off = np.where(np.abs(den) > 0, 0.5 * (lm - lp) / np.where(den == 0, 1, den), 0.0)
    fr = f[k] + np.clip(off, -1, 1) * (f[1] - f[0])
    return t, fr, p[k, cols], float(f[1] - f[0])


def ridge_frequency(
    signal, sample_rate: float, *, window_s: float = 1.0, fmin: float = 0.0, degree: int = 1
) -> np.ndarray:
    """Initial instantaneous frequency from the short-time Fourier ridge.

    The ridge (per-frame spectral peak, refined by parabolic interpolation) is fitted by a
    power-weighted polynomial of ``degree`` in time with two robust re-weightings, so weak frames
    (noise, the in-gap part of a sweep) do not pull it. A linear sweep needs ``degree = 1``.

    Parameters
    ----------
    signal : array_like, shape (N,) [any]
    sample_rate : float [Hz]
    window_s : float [s]
        STFT window length (frequency resolution ~ 1/window_s).
    fmin : float [Hz]
        Ignore spectral lines below this (offsets, drifts).
    degree : int
        Degree of the fitted ridge polynomial.

    Returns
    -------
    ndarray, shape (N,) [Hz]
    """
    x = as_signal(signal, "signal")
    fs = check_positive(sample_rate, "sample_rate")
    n = x.shape[0]
    t, fr, w, df = ridge_track(x, fs, window_s=window_s, fmin=fmin)
    deg = min(degree, max(0, len(t) - 1))
    coef = np.polyfit(t, fr, deg, w=np.sqrt(w))
    for _ in range(2):  # robust re-weighting: down-weight frames far from the fit
        r = fr - np.polyval(coef, t)
        scale = 1.4826 * np.median(np.abs(r)) + df
        ww = w / (1.0 + (r / (2 * scale)) ** 2)
        coef = np.polyfit(t, fr, deg, w=np.sqrt(ww))
    return np.polyval(coef, np.arange(n) / fs)


def acmp(
    signal,
    sample_rate: float,
    *,
    init_freq=None,
    sweep=None,
    bandwidth_hz: float = 2.0,
    if_bandwidth_hz: float = 1.0,
    adapt: bool = True,
    min_bandwidth_hz: float | None = None,
    tol: float = 1e-8,
    max_iter: int = 100,
    decimate_to: float | None = 4.0,
    if_weighting: str = "local",
) -> ChirpMode:
    """Extract one chirp mode (first harmonic) with adaptive chirp mode pursuit.

    Parameters
    ----------
    signal : array_like, shape (N,) [any]
        One channel, uniformly sampled, N >= 16.
    sample_rate : float [Hz]
    init_freq : float or array_like, shape (N,) [Hz], optional
        Initial instantaneous frequency. Default: the sweep law if ``sweep`` is given, else the
        short-time Fourier ridge (:func:`ridge_frequency`).
    sweep : freeplayid.simulate.Sweep, optional
        Sweep hint; sample 0 is taken at the sweep's t = 0.
    bandwidth_hz : float [Hz]
        Initial demodulation bandwidth f_c (alpha = (2 pi f_c / fs)^4): how fast the amplitude may
        change. 2 Hz follows the drop after a freeplay jump at sweep rates up to ~1 Hz/s and
        rejects harmonics; narrower averages more noise (:func:`extract_backbone_points` picks
        it from the sweep rate).
    if_bandwidth_hz : float [Hz]
        Bandwidth of the frequency-increment smoothing (beta); linear trends pass exactly.
    adapt : bool
        Adapt alpha (the pursuit step); ``False`` keeps ``bandwidth_hz`` (ACMD).
    min_bandwidth_hz : float [Hz], optional
        Floor of the adapted bandwidth (default ``bandwidth_hz / 4``): the adaptation only ever
        narrows the band, and too narrow a band would smear a jump. Never below
        :func:`narrowest_bandwidth` of the working rate.
    tol : float
        Stop when the relative squared change of the mode is below it.
    max_iter : int
    decimate_to : float, optional
        Decimate to about this many samples per period of the highest initial frequency before
        iterating (``None``: never). Results are interpolated back to the N input samples.
        Besides speed, this keeps narrow bands well conditioned: bandwidths below
        ``fs_work / 6283`` (0.33 Hz at 2048 Hz, 0.04 Hz at 256 Hz) raise ValueError.
    if_weighting : {"none", "local"}
        How the frequency increment is smoothed: "local" (default), each sample weighted by
        its mode's squared amplitude relative to the strongest within :data:`IF_WEIGHT_SPAN`
        IF-filter times (module docstring), so that the pursuit converges through a jump's
        drop; "none", every sample alike (Chen et al.), which there stops at ``max_iter``
        with a mode that depends on where it stopped.

    Returns
    -------
    ChirpMode
    """
    x_full = as_signal(signal, "signal")
    fs = check_positive(sample_rate, "sample_rate")
    bw = check_positive(bandwidth_hz, "bandwidth_hz")
    ifbw = check_positive(if_bandwidth_hz, "if_bandwidth_hz")
    bw_min = (
        bw / 4.0
        if min_bandwidth_hz is None
        else check_positive(min_bandwidth_hz, "min_bandwidth_hz")
    )
    tol = check_positive(tol, "tol")
    if if_weighting not in IF_WEIGHTINGS:
        raise ValueError(f"`if_weighting` must be one of {IF_WEIGHTINGS}, got {if_weighting!r}")
    if not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise ValueError(f"`max_iter` must be an integer >= 1, got {max_iter!r}")
    if decimate_to is not None and check_positive(decimate_to, "decimate_to") < 2.5:
        raise ValueError(
            f"`decimate_to` must be >= 2.5 samples per period or None, got {decimate_to!r}"
        )
    n_full = x_full.shape[0]
    t_full = np.arange(n_full) / fs
    f0 = _initial_frequency(x_full, fs, t_full, init_freq, sweep, bw)
    f_pass = float(np.max(f0)) + 2 * bw
    q = decimation_factor(f_pass, fs, decimate_to)
    if q > 1:
        x = decimate(x_full, q, f_pass, fs)
        fsd = fs / q
        f = f0[::q][: x.shape[0]].copy()
    else:
        x, fsd, f = x_full, fs, f0.copy()
    n = x.shape[0]
    check_bandwidth(bw, fsd, "bandwidth_hz")
    check_bandwidth(ifbw, fsd, "if_bandwidth_hz")
    u, v, f, alpha, it, converged = _PURSUITS.get_or_run(
        x, f, fsd, alpha=bandwidth_weight(bw, fsd),
        alpha_min=bandwidth_weight(max(bw_min, narrowest_bandwidth(fsd)), fsd),
        beta=bandwidth_weight(ifbw, fsd), adapt=adapt, tol=tol, max_iter=max_iter,
        span=int(round(IF_WEIGHT_SPAN * fsd / ifbw)) if if_weighting == "local" else 0)
    if q > 1:
        td = np.arange(n) / fsd
        u = np.interp(t_full, td, u)
        v = np.interp(t_full, td, v)
        f = np.interp(t_full, td, f)
    else:  # the kept arrays are shared and read-only
        u, v, f = u.copy(), v.copy(), f.copy()
    phi = _phase(f, fs)
    xm = u * np.cos(phi) + v * np.sin(phi)
    res = float(np.sum((x_full - xm) ** 2))
    snr = 10 * np.log10(max(float(xm @ xm), 1e-300) / max(res, 1e-300))
    return ChirpMode(
        amplitude=np.hypot(u, v),
        frequency=f,
        phase=phi - np.unwrap(np.arctan2(v, u)),
        mode=xm,
        snr_db=float(snr),
        iterations=it,
        converged=converged,
        bandwidth_hz=float(fsd * alpha**0.25 / (2 * np.pi)),
        sample_rate=fs,
    )


def _phase(f, fs: float) -> np.ndarray:
    """The phase [rad] of the instantaneous frequency ``f`` [Hz] (trapezoidal rule, 0 first)."""
    return 2 * np.pi * np.concatenate(([0.0], np.cumsum(0.5 * (f[1:] + f[:-1])) / fs))


def _initial_frequency(x, fs, t, init_freq, sweep, bandwidth_hz) -> np.ndarray:
    """The pursuit's initial frequency [Hz] per sample: ``init_freq``, else the sweep law, else
    the short-time Fourier ridge; below Nyquist everywhere."""
    if init_freq is not None:
        f0 = np.broadcast_to(np.asarray(init_freq, dtype=float), (x.shape[0],)).copy()
        if not np.all(np.isfinite(f0)) or np.any(f0 <= 0):
            raise ValueError("`init_freq` must be finite and > 0 everywhere")
    elif sweep is not None:
        if not hasattr(sweep, "frequency"):
            raise TypeError(
                f"`sweep` must be a freeplayid.simulate.Sweep, got {type(sweep).__name__}"
            )
        f0 = np.asarray(sweep.frequency(t), dtype=float)
    else:
        f0 = ridge_frequency(x, fs, fmin=2.0 * bandwidth_hz)
    if np.any(f0 >= fs / 2):
        raise ValueError(f"initial frequency reaches the Nyquist frequency {fs / 2} Hz")
    return f0


class _Pursuits:
    """The pursuit's results at the working rate, kept for the last records it ran on (about
    ``max_bytes`` of them): identify extracts some records more than once with the same inputs
    (the test's responses for the plain fit and again for the replay's statistic, a replayed
    base channel that no (kn, delta) changes), and the pursuit is a pure function of its inputs
    (the working-rate record, the initial frequency, the rate and the weights). Entries are
    read-only; a hit returns what the same call computed."""

    def __init__(self, max_bytes: int = 64 << 20):
        self.max_bytes, self.entries, self.lock = max_bytes, OrderedDict(), threading.Lock()

    def get_or_run(self, x, f, fsd, **options):
        """(u, v, f, alpha, iterations, converged): the final demodulation at the pursuit's
        final frequency (amplitude, phase and IF consistent) and the pursuit's outcome."""
        h = hashlib.blake2b(digest_size=20)
        for a in (x, f):
            h.update(np.ascontiguousarray(a, dtype=float).view(np.uint8))
        key = (h.hexdigest(), x.shape[0], float(fsd), tuple(sorted(options.items())))
        with self.lock:
            if key in self.entries:
                self.entries.move_to_end(key)
                return self.entries[key]
        f, alpha, it, converged = _pursue(x, f, fsd, **options)
        u, v = demodulate(x, _phase(f, fsd), alpha)
        value = (u, v, f, alpha, it, converged)
        for a in value[:3]:
            a.setflags(write=False)
        with self.lock:
            self.entries[key] = value
            while sum(e[0].nbytes * 3 for e in self.entries.values()) > self.max_bytes \
                    and len(self.entries) > 1:
                self.entries.popitem(last=False)
        return value


_PURSUITS = _Pursuits()


def _pursue(x, f, fsd, *, alpha, alpha_min, beta, adapt, tol, max_iter, span=0):
    """The pursuit's iterations at the working rate ``fsd``: (frequency, final alpha,
    iterations, converged). Each demodulates at the current frequency, moves the frequency by
    the smoothed phase drift of the demodulated pair (``span`` > 0: weighted by the mode's
    squared amplitude relative to its largest within ``span`` samples either side,
    ``if_weighting="local"``) and, with ``adapt``, narrows alpha; all of it in one compiled
    call (:func:`_pursuit`), which releases the GIL."""
    x = np.ascontiguousarray(x, dtype=float)
    p0, p1, p2 = second_difference_gram(x.shape[0])
    f, alpha, it, converged, bad = _pursuit(
        x, np.array(f, dtype=float), float(fsd), float(alpha), float(alpha_min),
        smoothing_factor(x.shape[0], beta), p0, p1, p2, bool(adapt), float(tol), int(max_iter),
        1.0 / float(beta), int(span))
    if bad:
        raise not_positive_definite(bad)
    return f, alpha, it, converged


@numba.njit(nogil=True, cache=True)
def _pursuit(x, f, fsd, alpha, alpha_min, smoothing, p0, p1, p2, adapt, tol,
             max_iter, inv_beta, span):  # pragma: no cover (compiled)
    """:func:`_pursue`'s loop on ``f`` (updated in place): (f, alpha, iterations, converged,
    0 or the leading minor of a demodulation that was not positive definite). Step by step the
    numpy composition it replaced (``demodulate``, ``np.gradient``, ``smooth_second_difference``,
    or with ``span`` > 0 its weighted form; tests/test_signal.py checks the two agree)."""
    n = x.shape[0]
    a2 = np.empty(n)
    if span > 0:  # the weighted smoothing's matrix and the running maximum's arrays
        sab, peak, left, right = np.empty((3, n)), np.empty(n), np.empty(n), np.empty(n)
    phi, u, v = np.empty(n), np.empty(n), np.empty(n)
    c, s, xm, prev, df = np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    ab = np.empty((5, 2 * n))
    two_pi = 2 * math.pi
    converged, it = False, 0
    for it in range(1, max_iter + 1):
        total = 0.0  # the phase of f (trapezoidal rule, 0 first), as _phase
        phi[0] = 0.0
        for k in range(1, n):
            total += 0.5 * (f[k] + f[k - 1])
            phi[k] = two_pi * (total / fsd)
        bad = demodulate_into(x, phi, alpha, p0, p1, p2, ab, c, s, u, v)
        if bad:
            return f, alpha, it, converged, bad
        for k in range(n):
            xm[k] = u[k] * c[k] + v[k] * s[k]
        for k in range(n):  # np.gradient (one-sided at the ends) times fsd
            if k == 0:
                du, dv = u[1] - u[0], v[1] - v[0]
            elif k == n - 1:
                du, dv = u[k] - u[k - 1], v[k] - v[k - 1]
            else:
                du, dv = 0.5 * (u[k + 1] - u[k - 1]), 0.5 * (v[k + 1] - v[k - 1])
            a2[k] = u[k] * u[k] + v[k] * v[k]
            df[k] = (v[k] * (du * fsd) - u[k] * (dv * fsd)) / (two_pi * max(a2[k], 1e-300))
        if span > 0:
            _running_max(a2, span, peak, left, right)
            for k in range(n):
                wk = max(a2[k] / max(peak[k], 1e-300), MIN_IF_WEIGHT)
                sab[2, k] = wk + inv_beta * p0[k]
                sab[1, k] = inv_beta * p1[k - 1] if k >= 1 else 0.0
                sab[0, k] = inv_beta * p2[k - 2] if k >= 2 else 0.0
                df[k] *= wk
            bad = _factor_kd(sab, 2)
            if bad:
                return f, alpha, it, converged, bad
            step = _solve(sab, df)
        else:
            step = _solve(smoothing, df)
        for k in range(n):
            f[k] = min(max(f[k] + step[k], 1e-6 * fsd), 0.5 * fsd)
        mm, mx = 0.0, 0.0
        for k in range(n):
            mm += xm[k] * xm[k]
            mx += xm[k] * x[k]
        if adapt and mx > 0:
            alpha = max(alpha_min, min(alpha * mm / mx, alpha))
        if it > 1:
            change, norm = 0.0, 0.0
            for k in range(n):
                change += (xm[k] - prev[k]) ** 2
                norm += prev[k] * prev[k]
            if change / max(norm, 1e-300) < tol:
                converged = True
                break
        prev[:] = xm
    return f, alpha, it, converged, 0


# the smallest weight of a sample's frequency increment (``if_weighting="local"``): keeps the
# weighted smoothing's matrix positive definite where a mode vanishes
MIN_IF_WEIGHT = 1e-9


@numba.njit(nogil=True, cache=True)
def _running_max(a, h, out, left, right):  # pragma: no cover (compiled)
    """``out[k]`` <- max of ``a[k - h .. k + h]`` (within the record), in O(n): van Herk /
    Gil-Werman, blocks of 2h + 1 with their running maxima from the left (``left``) and from the
    right (``right``); a window spans two blocks, or lies in one from its start (the record's
    start) or to its end (the record's end)."""
    n = a.shape[0]
    m = 2 * h + 1
    for b0 in range(0, n, m):
        b1 = min(n, b0 + m)
        left[b0] = a[b0]
        for k in range(b0 + 1, b1):
            left[k] = max(left[k - 1], a[k])
        right[b1 - 1] = a[b1 - 1]
        for k in range(b1 - 2, b0 - 1, -1):
            right[k] = max(right[k + 1], a[k])
    for k in range(n):
        lo, hi = max(0, k - h), min(n - 1, k + h)
        if lo // m != hi // m:
            out[k] = max(right[lo], left[hi])
        elif lo % m == 0:
            out[k] = left[hi]
        else:
            out[k] = right[lo]
    return out

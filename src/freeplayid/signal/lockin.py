"""Known-sweep demodulation (lock-in with the sweep phase): the reference method and baseline.

With the sweep phase phi(t) known, ``z = 2 x e^{-i phi}`` holds the first harmonic at base band,
``a e^{i theta}``, plus a term at twice the sweep frequency. A zero-phase low-pass removes the
latter; ``|z|`` is the amplitude, ``phi + theta`` the phase, and ``f + theta'/(2 pi)`` the
instantaneous frequency (the response need not be in phase with, or exactly at, the sweep).
The low-pass is the base-band filter ACMP applies for the same ``bandwidth_hz`` f_c: with
``K^T K ~ I / 2`` the ACMP mode update reduces to ``(I + 2 D^T D / alpha)^{-1}``,
``alpha = (2 pi f_c / fs)^4``: gain 1/2 at ``2^(-1/4) f_c ~ 0.84 f_c``, 4th-order roll-off, O(N)
banded solves. So both methods average the same amount of noise for the same bandwidth.

The two low-pass solves share one compiled pass with the kept factor of the smoothing matrix
(:func:`~.banded.smooth_pair_into`);
the sweep's carrier (its phase, cosine and sine) is kept for the last few sweeps and lengths, so
the runs of a data set share it; the unwrapping and the outputs are compiled loops (checked
against the numpy composition: ``smooth_second_difference``, ``np.unwrap``, ``np.gradient``).
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np

from .acmp import ChirpMode, bandwidth_weight, check_bandwidth
from .banded import smooth_pair_into, smoothing_factor
from .decimate import decimate, decimation_factor
from .validate import as_signal, check_positive

__all__ = ["lockin"]


def lockin(
    signal,
    sample_rate: float,
    *,
    sweep,
    bandwidth_hz: float = 2.0,
    decimate_to: float | None = 4.0,
) -> ChirpMode:
    """First harmonic of a sweep response by demodulation with the known sweep phase.

    Parameters
    ----------
    signal : array_like, shape (N,) [any]
    sample_rate : float [Hz]
    sweep : freeplayid.simulate.Sweep
        The excitation's sweep law; sample 0 is at the sweep's t = 0.
    bandwidth_hz : float [Hz]
        Base-band bandwidth f_c, the same meaning as in :func:`acmp` (gain 1/2 at 0.84 f_c).
    decimate_to : float, optional
        As in :func:`acmp`: decimate to about this many samples per period of the top sweep
        frequency first (``None``: never).

    Returns
    -------
    ChirpMode
        ``iterations = 0``, ``converged = True``.
    """
    x_full = as_signal(signal, "signal")
    fs = check_positive(sample_rate, "sample_rate")
    bw = check_positive(bandwidth_hz, "bandwidth_hz")
    if sweep is None or not hasattr(sweep, "phase"):
        raise TypeError(f"`sweep` must be a freeplayid.simulate.Sweep, got {type(sweep).__name__}")
    n_full = x_full.shape[0]
    t_full = np.arange(n_full) / fs
    fmax = max(sweep.start_hz, sweep.stop_hz) + 2 * bw
    if fmax >= fs / 2:
        raise ValueError(f"the sweep reaches {fmax} Hz, above the Nyquist frequency {fs / 2} Hz")
    if decimate_to is not None and check_positive(decimate_to, "decimate_to") < 2.5:
        raise ValueError(
            f"`decimate_to` must be >= 2.5 samples per period or None, got {decimate_to!r}"
        )
    q = decimation_factor(fmax, fs, decimate_to)
    if q > 1:
        x = decimate(x_full, q, fmax, fs)
        fsd = fs / q
    else:
        x, fsd = x_full, fs
    check_bandwidth(bw, fsd, "bandwidth_hz")
    factor = smoothing_factor(x.shape[0], 0.5 * bandwidth_weight(bw, fsd))
    phi, c, s = _carrier(sweep, x.shape[0], fsd)
    x = np.asarray(x, dtype=float)
    zr, zi = 2.0 * x * c, -2.0 * x * s
    smooth_pair_into(factor, zr, zi)
    theta = np.arctan2(zi, zr)
    _unwrap(theta)
    if q > 1:
        t = np.arange(x.shape[0]) / fsd
        zr = np.interp(t_full, t, zr)
        zi = np.interp(t_full, t, zi)
        theta = np.interp(t_full, t, theta)
        phi = sweep.phase(t_full)
        c = s = None
    amp, phase, freq = np.empty(n_full), np.empty(n_full), np.empty(n_full)
    _assemble(np.asarray(phi, dtype=float), zr, zi, theta,
              np.asarray(sweep.frequency(t_full), dtype=float), fs / (2 * np.pi), amp, phase, freq)
    # Re(z e^{i phi}) = amp cos(phase); at the full rate without decimation the carrier's
    # sines are at hand
    mode = zr * c - zi * s if c is not None else amp * np.cos(phase)
    r = x_full - mode
    snr = 10 * np.log10(max(float(mode @ mode), 1e-300) / max(float(r @ r), 1e-300))
    return ChirpMode(
        amplitude=amp,
        frequency=freq,
        phase=phase,
        mode=mode,
        snr_db=float(snr),
        iterations=0,
        converged=True,
        bandwidth_hz=bw,
        sample_rate=fs,
    )


def _carrier(sweep, n: int, fs: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The sweep's phase at ``n`` samples of rate ``fs``, its cosine and sine (read-only), kept
    for the last few (sweep, n, fs): a data set's runs share one sweep."""
    try:
        return _kept_carrier(sweep, int(n), float(fs))
    except TypeError:  # an unhashable sweep law
        return _make_carrier(sweep, int(n), float(fs))


def _make_carrier(sweep, n, fs):
    phi = np.ascontiguousarray(sweep.phase(np.arange(n) / fs), dtype=float)
    out = (phi, np.cos(phi), np.sin(phi))
    for a in out:
        a.setflags(write=False)
    return out


_kept_carrier = functools.lru_cache(maxsize=4)(_make_carrier)


@numba.njit(nogil=True, cache=True)
def _unwrap(theta):  # pragma: no cover (compiled)
    """``np.unwrap(theta)`` in place: each step of 2 pi or more brought into [-pi, pi)."""
    pi, two_pi = math.pi, 2.0 * math.pi
    shift = 0.0
    prev = theta[0]
    for k in range(1, theta.shape[0]):
        a = theta[k]
        dd = a - prev
        if abs(dd) >= pi:
            m = (dd + pi) % two_pi - pi
            if m == -pi and dd > 0:
                m = pi
            shift += m - dd
        prev = a
        theta[k] = a + shift


@numba.njit(nogil=True, cache=True)
def _assemble(phi, zr, zi, theta, f_sweep, scale, amp, phase, freq):  # pragma: no cover
    """Amplitude ``|z|``, phase ``phi + theta`` and frequency ``f_sweep + scale * dtheta`` (the
    derivative as ``np.gradient`` takes it) at every sample."""
    n = phi.shape[0]
    for k in range(n):
        amp[k] = math.sqrt(zr[k] * zr[k] + zi[k] * zi[k])
        phase[k] = phi[k] + theta[k]
        if k == 0:  # n >= 3: the smoothing's factor needs three samples
            g = theta[1] - theta[0]
        elif k == n - 1:
            g = theta[n - 1] - theta[n - 2]
        else:
            g = 0.5 * (theta[k + 1] - theta[k - 1])
        freq[k] = f_sweep[k] + scale * g

"""Known-sweep demodulation (lock-in with the sweep phase): the reference method and baseline.

With the sweep phase phi(t) known, ``z = 2 x e^{-i phi}`` holds the first harmonic at base band,
``a e^{i theta}``, plus a term at twice the sweep frequency. A zero-phase low-pass removes the
latter; ``|z|`` is the amplitude, ``phi + theta`` the phase, and ``f + theta'/(2 pi)`` the
instantaneous frequency (the response need not be in phase with, or exactly at, the sweep).
The low-pass is the base-band filter ACMP applies for the same ``bandwidth_hz`` f_c: with
``K^T K ~ I / 2`` the ACMP mode update reduces to ``(I + 2 D^T D / alpha)^{-1}``,
``alpha = (2 pi f_c / fs)^4``: gain 1/2 at ``2^(-1/4) f_c ~ 0.84 f_c``, 4th-order roll-off, O(N)
banded solves. So both methods average the same amount of noise for the same bandwidth.
"""

from __future__ import annotations

import numpy as np

from .acmp import ChirpMode, bandwidth_weight, check_bandwidth
from .banded import smooth_second_difference
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
    t = np.arange(x.shape[0]) / fsd
    phi = sweep.phase(t)
    check_bandwidth(bw, fsd, "bandwidth_hz")
    a = 0.5 * bandwidth_weight(bw, fsd)
    zr = smooth_second_difference(2 * x * np.cos(phi), a)
    zi = smooth_second_difference(-2 * x * np.sin(phi), a)
    theta = np.unwrap(np.arctan2(zi, zr))
    if q > 1:
        zr = np.interp(t_full, t, zr)
        zi = np.interp(t_full, t, zi)
        theta = np.interp(t_full, t, theta)
    amp = np.hypot(zr, zi)
    phase = sweep.phase(t_full) + theta
    freq = sweep.frequency(t_full) + np.gradient(theta) * fs / (2 * np.pi)
    mode = amp * np.cos(phase)
    res = float(np.sum((x_full - mode) ** 2))
    snr = 10 * np.log10(max(float(mode @ mode), 1e-300) / max(res, 1e-300))
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

"""Zero-phase decimation before demodulation (the speed-up for long records)."""

from __future__ import annotations

import numpy as np
from scipy import signal as sps

__all__ = ["decimate", "decimation_factor"]


def decimation_factor(f_pass: float, fs: float, samples_per_period: float | None) -> int:
    """Largest integer q keeping at least ``samples_per_period`` samples per period of ``f_pass``.

    ``None`` means no decimation (q = 1).
    """
    if samples_per_period is None:
        return 1
    return max(1, int(fs // (samples_per_period * f_pass)))


def decimate(x: np.ndarray, q: int, f_pass: float, fs: float) -> np.ndarray:
    """Keep every q-th sample after a zero-phase (centred) Kaiser FIR anti-alias filter.

    Pass band up to ``f_pass``, stop band from ``fs/q - f_pass`` (only that part can alias back
    into the pass band), 100 dB: its pass-band ripple (~1e-5) is far below the 0.1 % level, unlike
    the default Hamming design of :func:`scipy.signal.decimate` (~0.2 %).
    """
    f_stop = fs / q - f_pass
    assert f_stop > f_pass
    numtaps, kbeta = sps.kaiserord(100.0, (f_stop - f_pass) / (0.5 * fs))
    numtaps |= 1  # odd: integer group delay, so the centred filter has zero phase
    taps = sps.firwin(numtaps, 0.5 * (f_pass + f_stop), window=("kaiser", kbeta), fs=fs)
    return sps.resample_poly(x, 1, q, window=taps, padtype="line")

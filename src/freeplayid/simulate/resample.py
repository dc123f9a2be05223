"""Streaming anti-aliasing decimation from the RK4 step rate to the output sample rate.

The integrator runs at ``m * sample_rate``; the outputs are low-pass filtered by a linear-phase
Kaiser FIR (pass band up to 0.3 fs_out with ripple ~1e-6, stop band from the output Nyquist
frequency 0.5 fs_out at 120 dB, so nothing aliases at all) and kept every m-th step.
The filter is centred (zero phase): output sample k is ``sum_j h[j] x[k m + j - K m]`` with
``2 K m + 1`` taps, so it needs
``K m`` steps past the last output sample, which the simulator integrates (a tail of K output
samples), and before t = 0 the signal is continued by its first value (the state at rest).
The filter runs chunk by chunk with its history carried over, so the memory is one chunk.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.signal
import torch

from ..arguments import is_number

__all__ = ["design_decimator", "decimator_gain", "derivative_taps", "StreamingDecimator"]


# the flat band of the decimating filter, as a fraction of the output rate: the simulator's
# default, and the most it takes (a transition of 0.05 fs to the Nyquist frequency: 4 x the taps)
PASSBAND, MAX_PASSBAND = 0.3, 0.45


def design_decimator(factor: int, *, attenuation_db: float = 120.0,
                     passband: float = PASSBAND) -> np.ndarray:
    """Zero-phase anti-aliasing FIR for decimation by ``factor``.

    Parameters
    ----------
    factor : int, >= 1
        Step rate over output rate.
    attenuation_db : float [dB]
        Stop-band attenuation above the output Nyquist frequency.
    passband : float [-], in [0.1, 0.45]
        Where the filter stays flat, as a fraction of the output rate (0.3: the transition
        0.3 -> 0.5, -0.8 % at 0.336, -6 dB at 0.4; 0.45: flat to 0.45 like a sigma-delta
        acquisition, with 4 x the taps).

    Returns
    -------
    ndarray, shape (2 K factor + 1,) [-]
        Taps with unit DC gain (``[1.0]`` for ``factor == 1``).
    """
    if not (isinstance(factor, (int, np.integer)) and factor >= 1):
        raise ValueError(f"`factor` must be an integer >= 1, got {factor!r}")
    if not (is_number(passband) and 0.1 <= passband <= MAX_PASSBAND):
        raise ValueError(f"`passband` must be a number in [0.1, {MAX_PASSBAND}] (of the output "
                         f"rate), got {passband!r}")
    if factor == 1:
        return np.ones(1)
    # transition passband -> 0.5 of the output rate, in units of the step-rate Nyquist frequency
    width = 2 * (0.5 - passband) / factor
    numtaps, beta = scipy.signal.kaiserord(attenuation_db, width)
    half = math.ceil((numtaps - 1) / (2 * factor))  # K output samples of delay
    numtaps = 2 * half * factor + 1
    h = scipy.signal.firwin(numtaps, (passband + 0.5) / factor, window=("kaiser", beta))
    return h / h.sum()


# the factor the gain is read at: the design's response in units of the output rate does not
# depend on it (factors 4-64 agree to 1e-6)
_GAIN_FACTOR = 8


def decimator_gain(f_hz, sample_rate: float, passband: float = PASSBAND) -> np.ndarray:
    """The gain of :func:`design_decimator`'s filter at ``f_hz`` for output rate
    ``sample_rate``: what the simulator's records keep of a sinusoid there (1 to ~1e-6 below
    ``passband`` x ``sample_rate``, falling through its transition band to the output Nyquist
    frequency; with the default 0.3: 0.99 at 0.336, 0.5 at 0.4).

    Parameters
    ----------
    f_hz : array_like [Hz], >= 0
    sample_rate : float [Hz], > 0
    passband : float [-]
        That of :func:`design_decimator`.

    Returns
    -------
    ndarray, the shape of ``f_hz`` [-]
    """
    f = np.asarray(f_hz, dtype=float)
    if not (sample_rate > 0 and np.all(np.isfinite(f)) and np.all(f >= 0)):
        raise ValueError(f"`decimator_gain` needs finite frequencies >= 0 and a sample rate "
                         f"> 0, got {f_hz!r} at {sample_rate!r}")
    taps = _gain_taps(float(passband))
    w = 2 * np.pi * f.reshape(-1) / (sample_rate * _GAIN_FACTOR)
    # zero phase: the centred filter's response is real, sum_j h[j] cos(w (j - centre))
    k = np.arange(taps.size) - (taps.size - 1) / 2
    return np.abs(np.cos(np.outer(w, k)) @ taps).reshape(f.shape)


_TAPS: dict = {}


def _gain_taps(passband: float) -> np.ndarray:
    if passband not in _TAPS:
        _TAPS[passband] = design_decimator(_GAIN_FACTOR, passband=passband)
    return _TAPS[passband]


# 5-point central stencils of the first and second derivative, sample spacing 1, as correlation
# weights of x[n - 2] .. x[n + 2]: error (omega h)^4 / 30 and (omega h)^4 / 90 relative
_STENCILS = {1: np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / 12.0,
             2: np.array([-1.0, 16.0, -30.0, 16.0, -1.0]) / 12.0}


def derivative_taps(taps: np.ndarray, factor: int, h: float, order: int
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Decimating taps of a signal and of its derivative, to share one fused FIR.

    The derivative filter is ``taps`` applied to the 5-point central difference of the
    step-rate samples, i.e. ``taps`` convolved with the stencil, two samples longer on each
    side. Both are returned padded with zeros to ``len(taps) + 2 P`` (P = ``factor`` *
    ceil(2 / ``factor``), which keeps the form 2 K factor + 1), so the signal's outputs are
    those of ``taps`` unchanged (the zeros add nothing) and K grows by ceil(2 / factor).

    Parameters
    ----------
    taps : ndarray, shape (2 K factor + 1,)
        From :func:`design_decimator`.
    factor : int
        Step rate over output rate.
    h : float [s]
        Step (the spacing of the filtered samples).
    order : {1, 2}
        First (velocity from displacement) or second derivative.

    Returns
    -------
    taps_padded, taps_derivative : ndarray, shape (len(taps) + 2 P,)
        ``taps_derivative`` in units of 1 / s**order.
    """
    if order not in _STENCILS:
        raise ValueError(f"`order` must be 1 or 2, got {order!r}")
    if not (isinstance(factor, (int, np.integer)) and factor >= 1):
        raise ValueError(f"`factor` must be an integer >= 1, got {factor!r}")
    if not (np.isfinite(h) and h > 0):
        raise ValueError(f"`h` must be a positive step in s, got {h!r}")
    taps = np.asarray(taps, dtype=float)
    pad = factor * math.ceil(2 / factor)
    padded = np.concatenate([np.zeros(pad), taps, np.zeros(pad)])
    d = np.convolve(taps, _STENCILS[order]) / h**order  # taps[i - l] s[l]: length len + 4
    d = np.concatenate([np.zeros(pad - 2), d, np.zeros(pad - 2)])
    return padded, d


class StreamingDecimator:
    """Chunked zero-phase FIR decimation of many rows, on any torch device.

    Parameters
    ----------
    taps : ndarray, shape (2 K m + 1,)
        From :func:`design_decimator`.
    factor : int
        m, the decimation factor.
    dtype, device : torch dtype and device of the rows.
    """

    def __init__(self, taps: np.ndarray, factor: int, *, dtype, device) -> None:
        m = self.factor = int(factor)
        self.half = (len(taps) - 1) // 2  # K m
        # polyphase matrix: taps zero-padded to Q m and folded to (Q, m)
        Q = self.n_phase = -(-len(taps) // m)
        padded = np.zeros(Q * m)
        padded[: len(taps)] = taps
        self.H = torch.as_tensor(padded.reshape(Q, m).T.copy(), dtype=dtype, device=device)
        self.buffer: torch.Tensor | None = None

    def push(self, x: torch.Tensor) -> torch.Tensor:
        """Feed the next samples and return every output now complete.

        Output k is ``sum_{q,p} h[q m + p] buf[(k + q) m + p]``: with the buffer folded into blocks
        X (rows, blocks, m) this is one matrix product Z = X H (rows, blocks, Q) and a sum of Q
        shifted columns, ``y[k] = sum_q Z[k + q, q]`` (GEMM speed in float32 and float64).

        Parameters
        ----------
        x : Tensor, shape (rows, L)
            Next L step-rate samples of each row (the first call starts at t = 0).

        Returns
        -------
        Tensor, shape (rows, L_out)
            Decimated samples; over all calls they are outputs 0, 1, 2, ... in order.
        """
        if self.buffer is None:
            pad = x[:, :1].expand(-1, self.half)
            buf = torch.cat([pad, x], dim=1)
        else:
            buf = torch.cat([self.buffer, x], dim=1)
        m, Q = self.factor, self.n_phase
        n_out = (buf.shape[1] - Q * m) // m + 1
        if n_out <= 0:
            self.buffer = buf
            return buf.new_zeros((buf.shape[0], 0))
        X = buf[:, : (n_out + Q - 1) * m].reshape(buf.shape[0], n_out + Q - 1, m)
        Z = X @ self.H  # (rows, n_out + Q - 1, Q)
        y = Z[:, :n_out, 0].clone()
        for q in range(1, Q):
            y += Z[:, q : q + n_out, q]
        self.buffer = buf[:, n_out * m :]
        return y

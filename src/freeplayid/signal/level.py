"""First-harmonic amplitude of a sine-swept record in windows: the base channel's level.

The base (control) accelerometer of a sine-sweep test moves as ``A sin(phase)``; its amplitude
in windows along the sweep gives the run's level (the replay) and, against the manifest's
``level_g``, a units or quantity error (the verdict).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["window_amplitudes"]


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

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

import math

import numpy as np

__all__ = ["window_amplitudes", "quiet_base", "envelope_noise", "NARROW_BASE", "ENVELOPE_NOISE"]

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

"""Measurement noise for simulated records."""

from __future__ import annotations

import numpy as np

from ..quantity import G

__all__ = ["white_noise", "add_noise_for_snr"]


def white_noise(shape, *, std_g: float, seed: int | None = None) -> np.ndarray:
    """Gaussian white noise in acceleration, given its standard deviation in g.

    Parameters
    ----------
    shape : int or tuple of int
        E.g. (runs, channels, T).
    std_g : float [g], >= 0
        The paper's noise cases are 0.1, 0.2 and 0.3 g.
    seed : int, optional

    Returns
    -------
    ndarray, shape ``shape`` [m/s^2]
    """
    if not np.isfinite(std_g) or std_g < 0:
        raise ValueError(f"`std_g` must be a finite number >= 0, got {std_g!r}")
    return np.random.default_rng(seed).normal(0.0, std_g * G, size=shape)


def add_noise_for_snr(signal, snr_db: float, *, seed: int | None = None) -> np.ndarray:
    """The signal plus white Gaussian noise of power ``mean(signal^2) / 10^(snr_db/10)``.

    The power is taken along the last axis (per record), so every record gets the same SNR.

    Parameters
    ----------
    signal : array_like, shape (..., T) [any]
    snr_db : float [dB]
    seed : int, optional

    Returns
    -------
    ndarray, shape (..., T) [same units]
    """
    x = np.asarray(signal, dtype=float)
    if x.ndim < 1 or x.shape[-1] < 1:
        raise ValueError(f"`signal` must have a non-empty last (time) axis, got shape {x.shape}")
    if not np.isfinite(snr_db):
        raise ValueError(f"`snr_db` must be finite, got {snr_db!r}")
    p = np.mean(x * x, axis=-1, keepdims=True)
    std = np.sqrt(p / 10.0 ** (snr_db / 10.0))
    return x + std * np.random.default_rng(seed).standard_normal(x.shape)

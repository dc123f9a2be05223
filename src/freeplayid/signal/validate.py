"""Input checks shared by the signal functions (ValueError/TypeError naming the argument)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["as_signal", "check_positive"]


def as_signal(x, name: str, *, min_len: int = 16) -> np.ndarray:
    """A finite 1-D float64 array of at least ``min_len`` samples."""
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as e:
        raise TypeError(f"`{name}` must be a 1-D array of numbers, got {type(x).__name__}") from e
    if a.ndim != 1:
        raise ValueError(f"`{name}` must be 1-D (samples,), got shape {a.shape}")
    if a.shape[0] < min_len:
        raise ValueError(f"`{name}` must have at least {min_len} samples, got {a.shape[0]}")
    if not np.all(np.isfinite(a)):
        bad = int(np.sum(~np.isfinite(a)))
        raise ValueError(f"`{name}` must be finite, got {bad} NaN/inf samples")
    return a


def check_positive(value, name: str) -> float:
    """A finite real number > 0."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"`{name}` must be a real number, got {type(value).__name__}")
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"`{name}` must be a finite number > 0, got {value!r}")
    return v

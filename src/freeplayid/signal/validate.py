"""Input checks shared by the signal functions (ValueError/TypeError naming the argument)."""

from __future__ import annotations

import math

import numpy as np

from ..quantity import si_unit

__all__ = ["as_signal", "check_positive", "dead_channel", "DEAD_FLOOR_SI", "DEAD_RATIO"]


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


# A channel is dead (a disconnected or broken sensor, a channel recorded as zeros) when it is
# constant, or when its standard deviation is below DEAD_RATIO of the median standard deviation of
# the run's other channels (live sensors on one structure under one excitation differ by a few
# orders of magnitude at most, never by six), or below DEAD_FLOOR_SI of its quantity: far below
# the noise floor of any accelerometer (~1e-5 m/s^2 rms), velocimeter or displacement sensor, so
# only a numerically dead record lies under it. Subtracting a dead base channel, or extracting a
# dead one, would turn a sensor fault into "no resonance" or into the base's own motion.
DEAD_RATIO = 1e-6  # [-]
DEAD_FLOOR_SI = {"displacement": 1e-12, "velocity": 1e-10, "acceleration": 1e-8}  # [m, m/s, m/s^2]


def dead_channel(x, peers=(), *, quantity: str | None = None) -> str:
    """Why a channel is dead, or "" when it is alive.

    Parameters
    ----------
    x : array_like, shape (T,) [SI units of ``quantity``]
        The raw channel (before any base subtraction); non-finite samples are ignored.
    peers : sequence of array_like, shape (T_k,) [same units]
        The run's other channels (and its base channel), the scale a live channel is compared with.
    quantity : {"displacement", "velocity", "acceleration"}, optional
        Enables the absolute floor ``DEAD_FLOOR_SI[quantity]``.

    Returns
    -------
    str
        ``"constant 0"``, ``"constant 2.45 m/s^2"``, ``"std 3e-12 m/s^2, below 1e-06 of the
        run's other channels (median std 0.5 m/s^2)"``, ``"std 1e-09 m/s^2, below the floor
        1e-08 m/s^2 of any acceleration sensor"`` or "" (values in SI units).
    """
    a = np.asarray(x, dtype=float)
    a = a[np.isfinite(a)]
    if a.size == 0:
        return "no finite sample"
    unit = f" {si_unit(quantity)}" if quantity else ""
    if np.ptp(a) == 0:
        return "constant 0" if a[0] == 0 else f"constant {a[0]:.6g}{unit}"
    std = float(np.std(a))
    stds = [float(np.std(p[np.isfinite(p)])) for p in map(np.asarray, peers) if p.size]
    stds = [s for s in stds if s > 0]
    if stds:
        ref = float(np.median(stds))
        if std < DEAD_RATIO * ref:
            return (f"std {std:.3g}{unit}, below {DEAD_RATIO:g} of the run's other channels "
                    f"(median std {ref:.3g}{unit})")
    floor = DEAD_FLOOR_SI.get(quantity) if quantity else None
    if floor is not None and std < floor:
        return f"std {std:.3g}{unit}, below the floor {floor:g}{unit} of any {quantity} sensor"
    return ""

"""The sine-sweep law of the base excitation (simulation, extraction and the data sets' hints)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .quantity import G

__all__ = ["Sweep"]


@dataclass(frozen=True)
class Sweep:
    """Linear sine sweep ``a_g(t) = A sin(2 pi (f0 t + s t^2 / 2))``, s = +-rate.

    Parameters
    ----------
    start_hz, stop_hz : float [Hz], > 0 and different
        Up-sweep if stop > start, down-sweep otherwise.
    rate_hz_per_s : float [Hz/s], > 0
        Magnitude of the sweep rate.
    """

    start_hz: float
    stop_hz: float
    rate_hz_per_s: float

    def __post_init__(self) -> None:
        for name in ("start_hz", "stop_hz", "rate_hz_per_s"):
            v = getattr(self, name)
            number = isinstance(v, (int, float, np.floating, np.integer))
            if not (number and math.isfinite(v) and v > 0):
                raise ValueError(f"Sweep `{name}` must be a finite number > 0, got {v!r}")
        if self.start_hz == self.stop_hz:
            raise ValueError(
                f"Sweep `start_hz` and `stop_hz` must differ, both are {self.start_hz!r}"
            )

    @property
    def signed_rate(self) -> float:
        """Sweep rate with its sign [Hz/s] (negative for a down-sweep)."""
        return math.copysign(self.rate_hz_per_s, self.stop_hz - self.start_hz)

    @property
    def duration(self) -> float:
        """Length of the sweep [s]."""
        return abs(self.stop_hz - self.start_hz) / self.rate_hz_per_s

    def frequency(self, t):
        """Instantaneous frequency f0 + s t [Hz] at times ``t`` [s]."""
        return self.start_hz + self.signed_rate * np.asarray(t, dtype=float)

    def phase(self, t):
        """Phase 2 pi (f0 t + s t^2 / 2) [rad] at times ``t`` [s]."""
        t = np.asarray(t, dtype=float)
        return 2 * np.pi * (self.start_hz * t + 0.5 * self.signed_rate * t * t)

    def time_at(self, freq_hz):
        """Time [s] at which the sweep passes ``freq_hz``."""
        return (np.asarray(freq_hz, dtype=float) - self.start_hz) / self.signed_rate

    def acceleration(self, t, level_g: float = 1.0):
        """Base acceleration [m/s^2] at times ``t`` [s] for an amplitude of ``level_g`` [g]."""
        return level_g * G * np.sin(self.phase(t))

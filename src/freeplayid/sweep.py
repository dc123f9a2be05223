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

    def record_mismatch(self, n_samples: int, sample_rate: float) -> str:
        """Why a record of ``n_samples`` at ``sample_rate`` [Hz] cannot be this sweep, or "".

        A hint is checked against the record it describes (sample 0 = the sweep's start):

        - its top frequency must lie below the Nyquist frequency ``fs / 2``, and the sample rate
          must be at least 2.5 x the top frequency (the first-harmonic extraction and the jump
          rule need several samples per period and a margin for the drop's harmonics);
        - the record must last between half the sweep and 1.1 x the sweep + 1 s: a longer record
          would run the sweep law past its stop (frequencies that were never swept; a hint at ten
          times the true rate), a much shorter one means the rate or the band is wrong (or the
          record holds too little of the sweep to find its resonance).

        Returns
        -------
        str
            The reason, naming the numbers, or "" when the record fits the hint.
        """
        fs = float(sample_rate)
        top = max(self.start_hz, self.stop_hz)
        law = f"{self.start_hz:g} -> {self.stop_hz:g} Hz at {self.rate_hz_per_s:g} Hz/s"
        if top >= fs / 2:
            return (f"sweep hint ({law}) reaches {top:g} Hz, at or above the Nyquist frequency "
                    f"{fs / 2:g} Hz of the {fs:g} Hz record")
        if fs < 2.5 * top:
            return (f"sample rate {fs:g} Hz is below 2.5 x the sweep hint's top frequency "
                    f"{top:g} Hz ({2.5 * top:g} Hz needed)")
        span, dur = (int(n_samples) - 1) / fs, self.duration
        if span > 1.1 * dur + 1.0 or span < 0.5 * dur:
            return (f"the record lasts {span:.4g} s but the sweep hint ({law}) lasts {dur:.4g} s; "
                    "the hint does not describe this record (check its rate and band)")
        return ""

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

"""The sine-sweep law of the base excitation (simulation, extraction and the data sets' hints)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .quantity import G

__all__ = ["Sweep", "MeasuredSweep", "SWEEP_LAWS", "rate_at"]

SWEEP_LAWS = ("linear", "log")


def _positive(name: str, v) -> None:
    number = isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool)
    if not (number and math.isfinite(v) and v > 0):
        raise ValueError(f"Sweep `{name}` must be a finite number > 0, got {v!r}")


@dataclass(frozen=True)
class Sweep:
    """Sine sweep ``a_g(t) = A sin(phase(t))``, linear in Hz/s or logarithmic in octaves/min.

    Give exactly one of ``rate_hz_per_s`` (linear law) and ``octaves_per_min`` (log law)::

        Sweep(30, 50, 0.1)                       # linear, 0.1 Hz/s, 200 s
        Sweep(20, 80, octaves_per_min=2)         # logarithmic, 2 octaves/min, 60 s

    The same keys make a data set's ``sweep:`` hint (``{start_hz: 20, stop_hz: 80,
    octaves_per_min: 2}``) and a config's ``sweep`` group; :meth:`to_dict` writes them.

    Laws, with s = +-rate [Hz/s] and k = +-octaves_per_min / 60 [octaves/s], the sign of
    ``stop - start``, and ``kappa = k ln 2`` [1/s]::

        linear: f(t) = f0 + s t        phase(t) = 2 pi (f0 t + s t^2 / 2)
        log:    f(t) = f0 2^(k t)      phase(t) = 2 pi f0 (2^(k t) - 1) / (k ln 2)

    (the phase is the integral of 2 pi f from 0: both start at phase 0). A log sweep spends
    equal time per octave, so its rate ``df/dt = kappa f(t)`` grows with the frequency.

    Parameters
    ----------
    start_hz, stop_hz : float [Hz], > 0 and different
        Up-sweep if stop > start, down-sweep otherwise.
    rate_hz_per_s : float [Hz/s], > 0, optional
        Magnitude of a linear sweep's rate.
    octaves_per_min : float [octaves/min], > 0, optional
        Magnitude of a logarithmic sweep's rate.
    """

    start_hz: float
    stop_hz: float
    rate_hz_per_s: float | None = None
    octaves_per_min: float | None = None

    def __post_init__(self) -> None:
        given = [n for n in ("rate_hz_per_s", "octaves_per_min") if getattr(self, n) is not None]
        if len(given) != 1:
            raise ValueError(
                "Sweep needs exactly one of `rate_hz_per_s` (linear sweep [Hz/s]) and "
                f"`octaves_per_min` (logarithmic sweep [octaves/min]), got "
                f"{'both' if given else 'neither'} (rate_hz_per_s={self.rate_hz_per_s!r}, "
                f"octaves_per_min={self.octaves_per_min!r})"
            )
        for name in ("start_hz", "stop_hz", *given):
            _positive(name, getattr(self, name))
        if self.start_hz == self.stop_hz:
            raise ValueError(
                f"Sweep `start_hz` and `stop_hz` must differ, both are {self.start_hz!r}"
            )

    @property
    def law(self) -> str:
        """"linear" or "log"."""
        return "linear" if self.rate_hz_per_s is not None else "log"

    @property
    def _kappa(self) -> float:
        """Log law: d ln f / dt = +-octaves_per_min ln 2 / 60 [1/s]."""
        return math.copysign(self.octaves_per_min * math.log(2.0) / 60.0,
                             self.stop_hz - self.start_hz)

    @property
    def signed_rate(self) -> float:
        """A linear sweep's rate with its sign [Hz/s] (negative for a down-sweep).

        Raises ``ValueError`` for a log sweep, whose rate varies: use :meth:`rate` (at times) or
        :attr:`mean_rate`.
        """
        if self.law != "linear":
            raise ValueError("a logarithmic sweep has no constant rate: use `Sweep.rate(t)` "
                             "or `Sweep.mean_rate`")
        return math.copysign(self.rate_hz_per_s, self.stop_hz - self.start_hz)

    @property
    def mean_rate(self) -> float:
        """(stop - start) / duration [Hz/s], signed; a linear sweep's :attr:`signed_rate`."""
        if self.law == "linear":
            return self.signed_rate
        return (self.stop_hz - self.start_hz) / self.duration

    @property
    def duration(self) -> float:
        """Length of the sweep [s]."""
        if self.law == "linear":
            return abs(self.stop_hz - self.start_hz) / self.rate_hz_per_s
        return abs(math.log2(self.stop_hz / self.start_hz)) * 60.0 / self.octaves_per_min

    def describe(self) -> str:
        """The law in words: "30 -> 50 Hz at 0.1 Hz/s" or "20 -> 80 Hz at 2 octaves/min"."""
        rate = (f"{self.rate_hz_per_s:g} Hz/s" if self.law == "linear" else
                f"{self.octaves_per_min:g} octaves/min")
        return f"{self.start_hz:g} -> {self.stop_hz:g} Hz at {rate}"

    def to_dict(self) -> dict:
        """The hint's keys: ``start_hz``, ``stop_hz`` and ``rate_hz_per_s`` or
        ``octaves_per_min`` (``Sweep(**d)`` rebuilds it)."""
        key = "rate_hz_per_s" if self.law == "linear" else "octaves_per_min"
        return {"start_hz": float(self.start_hz), "stop_hz": float(self.stop_hz),
                key: float(getattr(self, key))}

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
        law = self.describe()
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
        """Instantaneous frequency f(t) [Hz] at times ``t`` [s] (class docstring)."""
        t = np.asarray(t, dtype=float)
        if self.law == "linear":
            return self.start_hz + self.signed_rate * t
        return self.start_hz * np.exp(self._kappa * t)

    def rate(self, t):
        """The frequency's time derivative df/dt [Hz/s] at times ``t`` [s], signed."""
        t = np.asarray(t, dtype=float)
        if self.law == "linear":
            return np.full(t.shape, self.signed_rate)
        return self._kappa * self.frequency(t)

    def phase(self, t):
        """Phase, the integral of 2 pi f from 0 to ``t`` [rad] at times ``t`` [s]."""
        t = np.asarray(t, dtype=float)
        if self.law == "linear":
            return 2 * np.pi * (self.start_hz * t + 0.5 * self.signed_rate * t * t)
        k = self._kappa
        return 2 * np.pi * self.start_hz * np.expm1(k * t) / k

    def time_at(self, freq_hz):
        """Time [s] at which the sweep passes ``freq_hz``."""
        f = np.asarray(freq_hz, dtype=float)
        if self.law == "linear":
            return (f - self.start_hz) / self.signed_rate
        return np.log(f / self.start_hz) / self._kappa

    def acceleration(self, t, level_g: float = 1.0):
        """Base acceleration [m/s^2] at times ``t`` [s] for an amplitude of ``level_g`` [g]."""
        return level_g * G * np.sin(self.phase(t))

    def unit(self, t):
        """The excitation per unit level at times ``t`` [s]: ``sin(phase(t))``."""
        return np.sin(self.phase(t))

    def unit_derivatives(self, t) -> tuple:
        """``unit`` and its first two time derivatives at times ``t`` [s]."""
        phase = self.phase(t)
        w = 2 * np.pi * self.frequency(t)
        c, s = np.cos(phase), np.sin(phase)
        return s, w * c, 2 * np.pi * self.rate(t) * c - w * w * s

    def unit_start(self) -> tuple[float, float]:
        """The base displacement and velocity at t = 0 per unit level whose oscillation has no
        mean (``-sin(phase) / w^2``, ``-cos(phase) / w``): (0, -1 / (2 pi f0))."""
        return 0.0, -1.0 / (2 * np.pi * self.start_hz)


@dataclass(frozen=True, eq=False)
class MeasuredSweep:
    """The base excitation as it was measured: ``a_g(t) = A envelope(t) sin(phase(t))``.

    A controller's sweep departs from the ideal law: the level dips where the structure
    resonates (force limiting, notching), drifts or ramps, and the phase follows its own clock.
    This holds what the base channel recorded, its first harmonic at every sample (an extraction
    of the base record: :func:`freeplayid.replay.measured_sweep`), as smooth functions of time,
    so a simulation can be driven by the test's own excitation. It answers what :class:`Sweep`
    answers (``frequency``, ``rate``, ``phase``, ``duration``, ``start_hz``, ``stop_hz``) and
    ``envelope(t)`` (1 for a :class:`Sweep`); the level ``A`` stays the simulation's
    ``level_g`` (the envelope's median is 1).

    Parameters
    ----------
    sample_rate : float [Hz]
    phase : ndarray, shape (N,) [rad]
        The phase of ``sin`` at the samples ``n / sample_rate`` (unwrapped).
    envelope : ndarray, shape (N,) [-], > 0
        The first harmonic's amplitude relative to its median.
    reading_sd : float [-], >= 0
        The envelope's reading noise: the standard deviation of its relative error that the
        record's noise makes (0: taken as exact).
    reading_band_hz : float [Hz], >= 0
        The band it was read over, which sets how fast that error changes
        (:func:`freeplayid.replay.excitation.read_again`).
    reading_steps : int
        The sharpening steps of that reading (:func:`freeplayid.signal.level.sharpened`).
    wide : MeasuredSweep or None
        Where the envelope was read over a narrower band than the response extraction's: the
        same record's envelope read over that wide band, unsharpened, relative to the same
        median and at the same phase, with its own reading noise and band (what the replay's
        :class:`~freeplayid.replay.BaseReading` check drives a replay with). None where the
        wide band was read.
    """

    sample_rate: float
    phase_samples: np.ndarray
    envelope_samples: np.ndarray
    reading_sd: float = 0.0
    reading_band_hz: float = 0.0
    reading_steps: int = 0
    wide: MeasuredSweep | None = None

    def __post_init__(self) -> None:
        import scipy.interpolate

        _positive("sample_rate", self.sample_rate)
        ph = np.asarray(self.phase_samples, dtype=float).reshape(-1)
        env = np.asarray(self.envelope_samples, dtype=float).reshape(-1)
        if ph.size < 4 or env.shape != ph.shape:
            raise ValueError(f"MeasuredSweep needs `phase_samples` and `envelope_samples` of one "
                             f"length >= 4, got {ph.size} and {env.size}")
        if not (np.all(np.isfinite(ph)) and np.all(np.isfinite(env)) and np.all(env > 0)):
            raise ValueError("MeasuredSweep `phase_samples` must be finite and "
                             "`envelope_samples` finite and > 0")
        if self.wide is not None and (np.asarray(self.wide.envelope_samples).shape != env.shape
                                      or self.wide.sample_rate != self.sample_rate):
            raise ValueError(f"MeasuredSweep `wide` must be read from the same record: "
                             f"{env.size} samples at {self.sample_rate:g} Hz, got "
                             f"{np.asarray(self.wide.envelope_samples).size} at "
                             f"{self.wide.sample_rate:g} Hz")
        for name in ("reading_sd", "reading_band_hz"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"MeasuredSweep `{name}` must be a finite number >= 0, got {v!r}")
        t = np.arange(ph.size) / float(self.sample_rate)
        object.__setattr__(self, "_phase", scipy.interpolate.CubicSpline(t, ph))
        object.__setattr__(self, "_env", scipy.interpolate.CubicSpline(t, env))

    law = "measured"
    rate_hz_per_s = None
    octaves_per_min = None

    @property
    def duration(self) -> float:
        """Length of the record [s] (its last sample's time)."""
        return (np.asarray(self.phase_samples).size - 1) / float(self.sample_rate)

    @property
    def start_hz(self) -> float:
        return float(self.frequency(0.0))

    @property
    def stop_hz(self) -> float:
        return float(self.frequency(self.duration))

    @property
    def mean_rate(self) -> float:
        """The mean |df/dt| [Hz/s] over the record."""
        return abs(self.stop_hz - self.start_hz) / self.duration

    def phase(self, t):
        return self._phase(np.clip(np.asarray(t, dtype=float), 0.0, self.duration))

    def frequency(self, t):
        return self._phase(np.clip(np.asarray(t, dtype=float), 0.0, self.duration), 1) / (2 * np.pi)

    def rate(self, t):
        return self._phase(np.clip(np.asarray(t, dtype=float), 0.0, self.duration), 2) / (2 * np.pi)

    def envelope(self, t, order: int = 0):
        """The relative amplitude (or its ``order``-th time derivative) at times ``t`` [s]."""
        return self._env(np.clip(np.asarray(t, dtype=float), 0.0, self.duration), order)

    def time_at(self, freq_hz):
        """The time [s] the measured frequency passes ``freq_hz`` (its running maximum, or
        minimum for a down-sweep, so a track that wavers still maps one to one)."""
        t = np.arange(np.asarray(self.phase_samples).size) / float(self.sample_rate)
        f = self.frequency(t)
        if f[-1] < f[0]:
            f, t = f[::-1], t[::-1]
        return np.interp(freq_hz, np.maximum.accumulate(f), t)

    def acceleration(self, t, level_g: float = 1.0):
        """Base acceleration [m/s^2] at times ``t`` [s] for a level of ``level_g`` [g]."""
        return level_g * G * self.unit(t)

    def unit(self, t):
        """The excitation per unit level at times ``t`` [s]: ``envelope(t) sin(phase(t))``."""
        return self.envelope(t) * np.sin(self.phase(t))

    def unit_derivatives(self, t) -> tuple:
        """``unit`` and its first two time derivatives at times ``t`` [s]."""
        a, a1, a2 = (self.envelope(t, k) for k in (0, 1, 2))
        phase = self.phase(t)
        w = 2 * np.pi * self.frequency(t)
        c, s = np.cos(phase), np.sin(phase)
        return (a * s, a1 * s + a * w * c,
                a2 * s + 2 * a1 * w * c + a * (2 * np.pi * self.rate(t) * c - w * w * s))

    def unit_start(self) -> tuple[float, float]:
        """The base displacement and velocity at t = 0 per unit level whose oscillation has no
        mean: ``-A sin(phase) / w^2``, ``-A cos(phase) / w``."""
        a, ph = float(self.envelope(0.0)), float(self.phase(0.0))
        w = 2 * np.pi * float(self.frequency(0.0))
        return -a * np.sin(ph) / w**2, -a * np.cos(ph) / w

    def describe(self) -> str:
        return (f"{self.start_hz:.5g} -> {self.stop_hz:.5g} Hz as measured (mean "
                f"{self.mean_rate:.3g} Hz/s, level {np.min(self.envelope_samples):.2f}-"
                f"{np.max(self.envelope_samples):.2f} x its median)")

    def to_dict(self) -> dict:
        """What a report says of it (not a hint: a record's own excitation has no keys)."""
        return {"start_hz": self.start_hz, "stop_hz": self.stop_hz, "rate_hz_per_s": None,
                "octaves_per_min": None, "mean_rate_hz_per_s": self.mean_rate,
                "envelope_range": [float(np.min(self.envelope_samples)),
                                   float(np.max(self.envelope_samples))]}

    def record_mismatch(self, n_samples: int, sample_rate: float) -> str:
        """The record it was measured on fits it by construction ("" unless the length or rate
        differ)."""
        if n_samples != np.asarray(self.phase_samples).size or sample_rate != self.sample_rate:
            return (f"the measured excitation has {np.asarray(self.phase_samples).size} samples at "
                    f"{self.sample_rate:g} Hz, the record {n_samples} at {sample_rate:g} Hz")
        return ""


def rate_at(sweep, freq_hz) -> np.ndarray:
    """The magnitude of the sweep's rate |df/dt| [Hz/s] where ``sweep`` (a :class:`Sweep` or
    :class:`MeasuredSweep`) passes ``freq_hz``: a linear sweep's rate, a log sweep's at that
    frequency."""
    return np.abs(np.asarray(sweep.rate(sweep.time_at(np.asarray(freq_hz, dtype=float))),
                             dtype=float))

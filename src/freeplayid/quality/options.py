"""The thresholds of the record checks, one frozen object validated on construction."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

__all__ = ["RecordCheckOptions", "CHECK_NAMES"]

# the checks in the order they run: the ones that read exact sample values (flat tops, held
# values) before any repair changes them; spikes before the slow trend and the hum, which they
# would bias; the frequency track, the mode shapes and the levels last, on the repaired records,
# then the even harmonics (on the resonance the checks before it have found)
CHECK_NAMES = ("saturation", "dropout", "spike", "offset", "hum", "sample_rate", "sweep_hint",
               "foreign_record", "cabling", "units", "even_harmonics")


@dataclass(frozen=True)
class RecordCheckOptions:
    """Which record checks run, and their thresholds (docs/record_checks.md says why each).

    Every threshold is a physical or statistical bound, none is fitted to a data set.

    Attributes
    ----------
    checks : tuple of str
        Checks to run, a subset of :data:`CHECK_NAMES` (default all).
    clip_min_samples : int [samples]
        A flat top needs at least this many samples at the channel's extreme value ...
    clip_pileup : float [-]
        ... and this many times more samples there than per quantisation step just below it.
        An unclipped oscillation reaches its extreme once: the samples thin out towards the top
        (arcsine density times a falling envelope), so the top step never holds more than the
        next ones. A clipped one piles every sample above the clip level onto one value.
    dropout_periods : float [periods]
        A held value (zeros or any repeated value) is a dropout when it lasts this many periods
        of the lowest swept frequency: a resolvable vibration crosses zero twice per period.
    spike_envelope : float [-]
        A spike is a sample (or up to ``spike_width`` of them) beyond this many times the largest
        excursion within two periods on either side (the local envelope; a response envelope
        changes by a few per cent per period; the grazing contacts after a jump make single
        cycles up to 1.4 x their neighbours on the bundled example, never 2 x) ...
    spike_sigma : float [-]
        ... and beyond that envelope by this many noise standard deviations (white noise
        exceeds 7 sigma once in 4e11 samples).
    spike_width : int [samples]
        Widest spike (consecutive samples) that is repaired; wider bursts are not spikes.
    spike_max_rate : float [1/s]
        Spikes are repaired (interpolated by a local autoregressive model) when there are at
        most this many per second of record; denser ones make a warning, unrepaired.
    offset_sigma : float [-]
        A DC offset or a slow drift is reported and removed when it exceeds this many standard
        errors of the slow trend (noise never triggers it) ...
    offset_fraction : float [-]
        ... and this fraction of the channel's vibration RMS (below, it moves neither the
        first harmonic nor the extremes by more than this fraction).
    hum_lines_hz : tuple of float [Hz]
        Mains frequencies whose lines (and harmonics) are looked for.
    hum_harmonics : int
        Harmonics of each mains frequency looked at (below 0.45 x the sample rate).
    hum_snr : float [-]
        A line is hum when its power stands this many times above the neighbouring noise floor
        (10 dB) in at least three quarters of the record's segments: stationary, unlike the
        sweep, which passes a frequency in one segment.
    resonance_margin_hz : float [Hz]
        A hum line within this distance (plus the notch's width) of a run's resonance frequency
        is not notched: the notch would bend the resonance's first harmonic (2 Hz, the jump
        rule's fall width, docs/signal.md).
    amplitude_tolerance : float [-]
        Hum left at the resonance (not notched) makes the answer ``suspect`` above this
        fraction of the channel's peak (1 %: delta scales with the amplitudes, and 1 % is the
        accuracy bound on delta), a warning below.
    rate_tolerance : float [-]
        The declared sample rate is wrong when the base channel's frequency track is the sweep
        hint's scaled by more than this (0.1 %): every frequency, hence every jump frequency,
        moves by that fraction, more than the drop point's standard error (docs/identify.md:
        <= 0.0008 Hz at 40 Hz) and enough to move delta by about 0.5 % (2.3 % moved it 11 %).
        A hint's start offset is judged by the same fraction of the band.
    shape_tolerance : float [-]
        A channel's amplitude ratio to the reference channel at resonance may differ from the
        model's mode shape by the factor ``1 + shape_tolerance`` (1.5) before the cabling is
        suspect: the first-harmonic shape of a freeplay resonance is the describing function's
        mode only approximately (within 0.1 % on the bundled fin, but 27 % at a 2-DOF fin's
        inboard DOF, which moves 1/15 of the outboard one), and sensor sensitivities add a few
        per cent. Swapped channels invert a ratio (4.2 for 0.24 on the default fin).
    units_factor : float [-]
        Levels are inconsistent when a measured amplitude lies below the model's lowest
        possible transmissibility (or the base level) by more than this factor (2; units errors
        are factors of 9.81 or 1000).
    mode : int
        The model's mode of the resonance (0: the lowest, first bending), as in the fit.
    even_noise : float [-]
        A response's second harmonic around the resonance is reported (``even_harmonics``,
        above ``amplitude_tolerance`` of the first) where its share of the first exceeds this
        many times the noise's share read the same way at 2.5 times the sweep's phase (4: two
        noise readings over the same samples differ by 0.5-1.7 times).
    """

    checks: tuple = CHECK_NAMES
    clip_min_samples: int = 5
    clip_pileup: float = 4.0
    dropout_periods: float = 1.0
    spike_envelope: float = 2.0
    spike_sigma: float = 7.0
    spike_width: int = 3
    spike_max_rate: float = 1.0
    offset_sigma: float = 6.0
    offset_fraction: float = 0.01
    hum_lines_hz: tuple = (50.0, 60.0)
    hum_harmonics: int = 5
    hum_snr: float = 10.0
    resonance_margin_hz: float = 2.0
    amplitude_tolerance: float = 0.01
    rate_tolerance: float = 1e-3
    shape_tolerance: float = 0.5
    units_factor: float = 2.0
    mode: int = 0
    even_noise: float = 4.0

    def __post_init__(self) -> None:
        checks = tuple(self.checks) if not isinstance(self.checks, str) else (self.checks,)
        unknown = [c for c in checks if c not in CHECK_NAMES]
        if unknown:
            raise ValueError(f"`checks` must name checks of {CHECK_NAMES}, got {unknown!r}")
        object.__setattr__(self, "checks", tuple(c for c in CHECK_NAMES if c in checks))
        lines = tuple(self.hum_lines_hz)
        if not lines or not all(_is_positive(v) for v in lines):
            raise ValueError(f"`hum_lines_hz` must be frequencies > 0 [Hz], got {lines!r}")
        object.__setattr__(self, "hum_lines_hz", tuple(float(v) for v in lines))
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name in ("checks", "hum_lines_hz"):
                continue
            if f.name == "mode":
                if not isinstance(v, int) or isinstance(v, bool) or v < 0:
                    raise ValueError(f"`mode` must be an integer >= 0, got {v!r}")
            elif f.name in ("clip_min_samples", "spike_width", "hum_harmonics"):
                if not isinstance(v, int) or isinstance(v, bool) or v < 1:
                    raise ValueError(f"`{f.name}` must be an integer >= 1, got {v!r}")
            elif not _is_positive(v):
                raise ValueError(f"`{f.name}` must be a finite number > 0, got {v!r}")
        for name in ("clip_pileup", "units_factor", "spike_envelope", "even_noise"):
            if getattr(self, name) <= 1:
                raise ValueError(f"`{name}` must be > 1, got {getattr(self, name)!r}")


def _is_positive(v) -> bool:
    return (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            and v > 0)

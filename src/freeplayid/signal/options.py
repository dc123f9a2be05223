"""The extraction's options as one record: :class:`Extraction`."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field

from ..arguments import check_bool, check_choice, check_int, check_number
from .acmp import acmp
from .lockin import lockin
from .peak import JUMP_POINTS

__all__ = ["Extraction", "EXTRACTION_METHODS", "with_options"]

# name -> first-harmonic extractor (x, fs, *, sweep, bandwidth_hz, ...) -> ChirpMode; a new method
# is one module and one line here
EXTRACTION_METHODS = {"acmp": acmp, "lockin": lockin}


@dataclass(frozen=True)
class Extraction:
    """How the fitting points are taken from the records (:func:`extract_backbone_points`).

    Validated on construction; a bad value raises ``ValueError`` naming the field.

    Attributes
    ----------
    method : {"acmp", "lockin"}
        First-harmonic extractor (:data:`EXTRACTION_METHODS`); the lock-in needs the sweep law.
    bandwidth_hz : float or None [Hz]
        Demodulation bandwidth; None: ``max(1 Hz, 2 s x |sweep rate|)``.
    trim_s : float [s]
        Ignored at each end of a record (filter end effects).
    jump_ratio : float [-]
        Level of the drop after a jump, relative to the peak (0 < ratio < 1).
    jump_width_hz : float [Hz]
        The drop must happen within this much sweep.
    jump_asymmetry : float [-]
        Rise before / fall after the peak (>= 1).
    edge_hz : float [Hz]
        A peak this close to the band's end is rejected.
    min_snr_db : float [dB]
        Below this mode-to-residual SNR a channel is rejected.
    jump_point : str
        Where the point is taken (:data:`freeplayid.signal.JUMP_POINTS`, docs/signal.md
        section 6): "smoothed" the smoothed curve's maximum; "windowed" a windowed maximum
        without overshoot; "drop" where the curve drops (the replay's statistic, from windows
        that stop at the drop); "drop_smoothed" the drop read off the smoothed curve alone (the
        first drop rule, kept to compare with).
    drop_window : float [-]
        The drop point's amplitude (``jump_point="drop"``, and the drop that the quadrature
        rule falls back to) is read over this many times the extractor's window, centred as
        many filter times ahead of the drop (1: one, the default); the quadrature point's
        (``jump_point="quadrature"``) over this many times the window about the phase
        resonance, still cut at the drop. The frequencies stay the drop's and the lag's
        crossing. Longer windows average more noise but read more of the upper branch, where
        the form of the damping moves it more and where, on records of another integrator, the
        replays of drop points missed it (docs/signal.md section 6, docs/inverse.md section 4,
        ``benchmarks/drop_window.py``): for studies of the statistic. ``identify`` reads the drop
        points wider itself where the noise needs it and the data agree
        (``Replay.noisy_window``), not the quadrature points (tried and not kept:
        docs/identify.md section 3c).
    use_sweep_hint : bool
        Use the runs' ``sweep`` hints (ACMP's start, the band, the rate); False, or a run without
        one: each run's law is estimated from its base channel, else its best-tracked response.
    require_jump : bool
        Reject a run whose maximum is not followed by a jump (False: take the maximum anyway).
    curve_points : int
        Samples kept per amplitude curve for figures.
    options : mapping
        Further keyword options of the method (e.g. ``{"if_bandwidth_hz": 0.5}``).
    """

    method: str = "acmp"
    bandwidth_hz: float | None = None
    trim_s: float = 1.0
    jump_ratio: float = 0.5
    jump_width_hz: float = 2.0
    jump_asymmetry: float = 3.0
    edge_hz: float = 0.5
    min_snr_db: float = 0.0
    jump_point: str = "smoothed"
    drop_window: float = 1.0
    use_sweep_hint: bool = True
    require_jump: bool = True
    curve_points: int = 2000
    options: Mapping = field(default_factory=dict)

    def __post_init__(self):
        check_choice("method", self.method, EXTRACTION_METHODS)
        check_choice("jump_point", self.jump_point, JUMP_POINTS)
        if self.bandwidth_hz is not None:
            check_number("bandwidth_hz", self.bandwidth_hz, 0.0, open_lo=True)
        check_number("trim_s", self.trim_s, 0.0)
        check_number("jump_ratio", self.jump_ratio, 0.0, 1.0, open_lo=True, open_hi=True)
        check_number("jump_width_hz", self.jump_width_hz, 0.0, open_lo=True)
        check_number("jump_asymmetry", self.jump_asymmetry, 1.0)
        check_number("edge_hz", self.edge_hz, 0.0, open_lo=True)
        check_number("min_snr_db", self.min_snr_db)
        check_number("drop_window", self.drop_window, 1.0)
        check_bool("use_sweep_hint", self.use_sweep_hint)
        check_bool("require_jump", self.require_jump)
        check_int("curve_points", self.curve_points, 2)
        if not isinstance(self.options, Mapping):
            raise ValueError(f"`options` must be a mapping of the method's options, "
                             f"got {self.options!r}")
        if "bandwidth_hz" in self.options or "sweep" in self.options:
            raise ValueError("pass `bandwidth_hz` and `sweep` as arguments, not in `options`")
        object.__setattr__(self, "options", dict(self.options))


def with_options(extraction: Extraction | None, overrides: Mapping) -> Extraction:
    """``extraction`` (default :class:`Extraction`) with some fields replaced; an unknown
    field is a TypeError that lists the valid ones."""
    base = Extraction() if extraction is None else extraction
    if not isinstance(base, Extraction):
        raise TypeError(f"`extraction` must be a freeplayid.signal.Extraction, "
                        f"got {type(base).__name__}")
    names = {f.name for f in dataclasses.fields(Extraction)}
    unknown = sorted(set(overrides) - names)
    if unknown:
        raise TypeError(f"unknown extraction option(s) {unknown}; valid: {sorted(names)}")
    return dataclasses.replace(base, **overrides) if overrides else base

"""Fitting points: the one point-record type of the backbone fit and of the neural inverse model.

A fitting point is the resonance (jump) point of one channel in one sweep run: the model DOF it
was measured at, its first-harmonic displacement amplitude relative to the base and its frequency
(docs/backbone.md). :class:`FittingPoints` holds p of them as validated arrays; it is built
from plain records (:meth:`FittingPoints.from_records`) or from an extraction
(:meth:`FittingPoints.from_extraction`) and written back as records (:meth:`to_records`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

__all__ = ["FittingPoints"]


def _vector(name: str, value) -> np.ndarray:
    """Read-only float copy of a 1-D field; ValueError naming the field otherwise."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be numbers, got {value!r}") from None
    if arr.ndim != 1:
        raise ValueError(f"`{name}` must be 1-D, shape (p,), got shape {arr.shape}")
    arr.flags.writeable = False
    return arr


def _names(name: str, value) -> tuple[str, ...]:
    if isinstance(value, str):
        raise ValueError(f"`{name}` must be a sequence of str, one per point, got str {value!r}")
    arr = np.asarray(value)
    if arr.ndim != 1:
        raise ValueError(f"`{name}` must be 1-D, shape (p,), got shape {arr.shape}")
    return tuple(str(v) for v in arr.tolist())


@dataclass(frozen=True, eq=False)
class FittingPoints:
    """Backbone fitting points: p resonance points (DOF name, amplitude, frequency).

    Validated on construction: equal lengths, at least 2 points (two unknowns, kn and delta),
    finite amplitudes and frequencies > 0. Sequences are stored as tuples and read-only arrays.

    Attributes
    ----------
    channel : tuple of str, shape (p,)
        Model DOF name of each point.
    amplitude_m : ndarray, shape (p,) [m]
        First-harmonic displacement amplitude relative to the base.
    f_hz : ndarray, shape (p,) [Hz]
        Resonance (jump) frequency.
    run : tuple of str, shape (p,), or None
        Sweep run of each point (informational).
    noise_db : ndarray, shape (p,) [dB], or None
        Each point's record's noise floor relative to the point (``noise_db`` of
        :class:`freeplayid.signal.BackbonePoint`; NaN where not measured): the neural inverse
        model's word of the noise (docs/inverse.md). The fit does not use it.

    Raises
    ------
    ValueError
        A field has the wrong length, fewer than 2 points, or a non-finite or non-positive
        amplitude or frequency (the message names the field and the bad indices).
    """

    channel: tuple
    amplitude_m: np.ndarray
    f_hz: np.ndarray
    run: tuple | None = None
    noise_db: np.ndarray | None = None

    def __post_init__(self):
        channel = _names("channel", self.channel)
        amp = _vector("amplitude_m", self.amplitude_m)
        f = _vector("f_hz", self.f_hz)
        run = None if self.run is None else _names("run", self.run)
        noise = None if self.noise_db is None else _vector("noise_db", self.noise_db)
        p = len(channel)
        sizes = {"amplitude_m": amp.size, "f_hz": f.size}
        if run is not None:
            sizes["run"] = len(run)
        if noise is not None:
            sizes["noise_db"] = noise.size
        wrong = {k: v for k, v in sizes.items() if v != p}
        if wrong:
            raise ValueError(
                f"every field must have one entry per point ({p} channels), got "
                + ", ".join(f"`{k}` with {v}" for k, v in wrong.items())
            )
        if p < 2:
            raise ValueError(f"at least 2 fitting points are needed for (kn, delta), got {p}")
        for name, arr in (("amplitude_m", amp), ("f_hz", f)):
            bad = ~np.isfinite(arr) | (arr <= 0)
            if np.any(bad):
                raise ValueError(
                    f"fitting points must have finite `{name}` > 0; bad points at indices "
                    f"{np.flatnonzero(bad).tolist()}"
                )
        object.__setattr__(self, "channel", channel)
        object.__setattr__(self, "amplitude_m", amp)
        object.__setattr__(self, "f_hz", f)
        object.__setattr__(self, "run", run)
        object.__setattr__(self, "noise_db", noise)

    def __len__(self) -> int:
        return len(self.channel)

    def __eq__(self, other) -> bool:
        if not isinstance(other, FittingPoints):
            return NotImplemented
        return (
            self.channel == other.channel
            and self.run == other.run
            and np.array_equal(self.amplitude_m, other.amplitude_m)
            and np.array_equal(self.f_hz, other.f_hz)
            and (self.noise_db is None) == (other.noise_db is None)
            and (self.noise_db is None
                 or np.array_equal(self.noise_db, other.noise_db, equal_nan=True))
        )

    __hash__ = None  # mutable-looking arrays inside: not hashable, like ndarray

    @classmethod
    def from_records(cls, records: Iterable[Mapping]) -> FittingPoints:
        """Points from records: ``channel`` (DOF name), ``amplitude_m`` [m], ``f_hz`` [Hz],
        optional ``run``, ``noise_db`` [dB] and ``used`` (records with ``used`` False are skipped).

        ``run`` and ``noise_db`` are kept when every used record has one, else dropped.

        Raises
        ------
        ValueError
            A record lacks a required key (named), or the points fail validation.
        """
        rows = [r for r in records if r.get("used", True)]
        for i, r in enumerate(rows):
            missing = [k for k in ("channel", "amplitude_m", "f_hz") if k not in r]
            if missing:
                raise ValueError(f"point record {i} lacks {missing} (has {sorted(r)})")
        runs = [r.get("run") for r in rows]
        noise = [r.get("noise_db") for r in rows]
        return cls(
            channel=tuple(r["channel"] for r in rows),
            amplitude_m=[r["amplitude_m"] for r in rows],
            f_hz=[r["f_hz"] for r in rows],
            run=None if any(v is None for v in runs) else tuple(runs),
            noise_db=None if any(v is None for v in noise) else noise,
        )

    @classmethod
    def from_extraction(cls, points, dofs: Mapping[str, str] | None = None) -> FittingPoints:
        """The used points of an extraction (:class:`freeplayid.signal.BackbonePoints`).

        Parameters
        ----------
        points : freeplayid.signal.BackbonePoints
        dofs : mapping of str -> str, optional
            Extraction channel name (a CSV column) -> model DOF name, as a data set's
            ``channels``; default: the channel names are the DOF names.

        Raises
        ------
        TypeError
            ``points`` is not a BackbonePoints.
        ValueError
            A used channel is missing from ``dofs`` (named), or the points fail validation.
        """
        from ..signal import BackbonePoints

        if not isinstance(points, BackbonePoints):
            raise TypeError(
                f"`points` must be a freeplayid.signal.BackbonePoints, got {type(points).__name__}"
            )
        used = points.used()
        if dofs is not None:
            unknown = sorted({p.channel for p in used} - set(dofs))
            if unknown:
                raise ValueError(
                    f"channels {unknown} of the points are not in `dofs` (known: {sorted(dofs)})"
                )
        return cls(
            channel=tuple(p.channel if dofs is None else dofs[p.channel] for p in used),
            amplitude_m=[p.amplitude_m for p in used],
            f_hz=[p.f_hz for p in used],
            run=tuple(p.run for p in used),
            noise_db=[p.noise_db for p in used],
        )

    def to_records(self) -> list[dict]:
        """One dict per point: ``channel``, ``amplitude_m`` [m], ``f_hz`` [Hz] (plain floats),
        and ``run`` and ``noise_db`` [dB] when known; :meth:`from_records` reads them back."""
        out = [
            {"channel": c, "amplitude_m": float(a), "f_hz": float(q)}
            for c, a, q in zip(self.channel, self.amplitude_m, self.f_hz, strict=True)
        ]
        if self.run is not None:
            for rec, r in zip(out, self.run, strict=True):
                rec["run"] = r
        if self.noise_db is not None:
            for rec, v in zip(out, self.noise_db, strict=True):
                rec["noise_db"] = float(v)
        return out

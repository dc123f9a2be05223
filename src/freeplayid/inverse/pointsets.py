"""Sets of backbone fitting points, one set per identification case, as flat arrays.

A *case* is what one identification sees: the used resonance points (channel, displacement
amplitude, frequency) of all runs of one test, and, for simulated cases, the truth (kn, delta).
The sets have different sizes (runs rejected, channels without a jump), so they are stored flat
with a ``case`` index, sorted by case, the layout a set network pads per batch.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..atomic import atomic_path
from ..fit import FittingPoints

__all__ = ["PointSets", "point_sets_from_records"]


@dataclass(frozen=True)
class PointSets:
    """Fitting-point sets of N cases (P points in all).

    Attributes
    ----------
    channels : tuple of str
        DOF names the ``channel`` indices refer to (the model's measured DOFs).
    case : ndarray, shape (P,) int64
        Case of each point, non-decreasing, in [0, N).
    channel : ndarray, shape (P,) int64
        Index into ``channels``.
    amplitude : ndarray, shape (P,) [m]
        First-harmonic displacement amplitude relative to the base (> 0).
    frequency : ndarray, shape (P,) [Hz]
        Resonance (jump) frequency (> 0).
    kn : ndarray, shape (N,) [N m/rad]
        Truth, NaN when unknown (measured data).
    delta : ndarray, shape (N,) [rad]
        Truth, NaN when unknown.
    meta : dict of str -> ndarray, shape (N,)
        Per-case labels of the studies (e.g. ``noise_g``, ``sim``), any dtype.
    noise_db : ndarray, shape (P,) [dB], or None
        Each point's record's noise floor relative to the point (``noise_db`` of
        :class:`freeplayid.signal.BackbonePoint`), NaN where not measured; None: none recorded.
    rate : ndarray, shape (P,) [Hz/s], or None
        The sweep's rate at each point (its magnitude, > 0; a log sweep's grows with the
        frequency); None: none recorded.
    """

    channels: tuple
    case: np.ndarray
    channel: np.ndarray
    amplitude: np.ndarray
    frequency: np.ndarray
    kn: np.ndarray
    delta: np.ndarray
    meta: dict = field(default_factory=dict)
    noise_db: np.ndarray | None = None
    rate: np.ndarray | None = None

    def __post_init__(self):
        n = self.kn.shape[0]
        p = self.case.shape[0]
        if self.delta.shape != (n,):
            raise ValueError(f"`delta` must have shape ({n},), got {self.delta.shape}")
        for name in ("channel", "amplitude", "frequency") + tuple(
                k for k in ("noise_db", "rate") if getattr(self, k) is not None):
            if getattr(self, name).shape != (p,):
                got = getattr(self, name).shape
                raise ValueError(f"`{name}` must have shape ({p},), got {got}")
        if p and (np.any(np.diff(self.case) < 0) or self.case[0] < 0 or self.case[-1] >= n):
            raise ValueError("`case` must be non-decreasing and index the N cases")
        if p and (self.channel.min() < 0 or self.channel.max() >= len(self.channels)):
            raise ValueError(f"`channel` indices must lie in [0, {len(self.channels)})")
        if np.any(~(self.amplitude > 0)) or np.any(~(self.frequency > 0)):
            raise ValueError("point amplitudes and frequencies must be finite and > 0")
        if self.rate is not None and np.any(~(self.rate > 0)):
            raise ValueError("point sweep rates must be finite and > 0")
        for k, v in self.meta.items():
            if np.shape(v)[:1] != (n,):
                raise ValueError(f"meta[{k!r}] must have {n} entries, got shape {np.shape(v)}")

    @property
    def noise_known(self) -> bool:
        """Whether every point has a measured (finite) ``noise_db``."""
        return self.noise_db is not None and bool(np.all(np.isfinite(self.noise_db)))

    @property
    def n_cases(self) -> int:
        return int(self.kn.shape[0])

    @property
    def n_points(self) -> np.ndarray:
        """Points per case, shape (N,) int64."""
        return np.bincount(self.case, minlength=self.n_cases).astype(np.int64)

    def subset(self, cases) -> PointSets:
        """The cases ``cases`` (indices or boolean mask, shape (N,)), renumbered in that order."""
        idx = np.arange(self.n_cases)[np.asarray(cases)]
        starts = np.concatenate([[0], np.cumsum(self.n_points)])
        take = [np.arange(starts[i], starts[i + 1]) for i in idx]
        rows = np.concatenate(take) if take else np.zeros(0, np.int64)
        new_case = np.repeat(np.arange(idx.size), [t.size for t in take]) if take else rows
        return PointSets(
            channels=self.channels, case=new_case.astype(np.int64),
            channel=self.channel[rows], amplitude=self.amplitude[rows],
            frequency=self.frequency[rows], kn=self.kn[idx], delta=self.delta[idx],
            meta={k: np.asarray(v)[idx] for k, v in self.meta.items()},
            noise_db=None if self.noise_db is None else self.noise_db[rows],
            rate=None if self.rate is None else self.rate[rows],
        )

    def with_rate(self, rate) -> PointSets:
        """These point sets with each point's sweep rate ``rate`` (P,) [Hz/s]."""
        return dataclasses.replace(self, rate=np.asarray(rate, dtype=float).reshape(-1))

    def fitting_points(self, i: int) -> FittingPoints:
        """Case ``i`` as :class:`~freeplayid.fit.FittingPoints` (for ``fit_backbone``).

        Raises
        ------
        ValueError
            The case has fewer than 2 points (a fit needs 2).
        """
        rows = np.flatnonzero(self.case == i)
        return FittingPoints(channel=tuple(self.channels[c] for c in self.channel[rows]),
                             amplitude_m=self.amplitude[rows], f_hz=self.frequency[rows],
                             noise_db=None if self.noise_db is None else self.noise_db[rows])

    def records(self, i: int) -> list[dict]:
        """Case ``i`` as point records (channel name, amplitude_m, f_hz)."""
        return self.fitting_points(i).to_records()

    @staticmethod
    def concatenate(parts: Sequence[PointSets]) -> PointSets:
        """One PointSets of all cases of ``parts`` (same channels), in order; ``noise_db`` where
        every part has it."""
        if not parts:
            raise ValueError("`parts` must not be empty")
        chans = parts[0].channels
        if any(p.channels != chans for p in parts):
            raise ValueError("all parts must have the same `channels`")
        offs = np.cumsum([0] + [p.n_cases for p in parts[:-1]])
        keys = set(parts[0].meta)
        if any(set(p.meta) != keys for p in parts):
            raise ValueError("all parts must have the same `meta` keys")
        return PointSets(
            channels=chans,
            case=np.concatenate([p.case + o for p, o in zip(parts, offs, strict=True)]),
            channel=np.concatenate([p.channel for p in parts]),
            amplitude=np.concatenate([p.amplitude for p in parts]),
            frequency=np.concatenate([p.frequency for p in parts]),
            kn=np.concatenate([p.kn for p in parts]),
            delta=np.concatenate([p.delta for p in parts]),
            meta={k: np.concatenate([np.asarray(p.meta[k]) for p in parts]) for k in keys},
            noise_db=None if any(p.noise_db is None for p in parts) else
            np.concatenate([p.noise_db for p in parts]),
            rate=None if any(p.rate is None for p in parts) else
            np.concatenate([p.rate for p in parts]),
        )

    def save(self, path) -> None:
        """Write an ``.npz`` at ``path`` as named, atomically (:func:`~..atomic.atomic_path`)."""
        # through an open file: np.savez adds no ``.npz`` to a name that lacks it
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez(fh, channels=np.array(self.channels, dtype=str), case=self.case,
                     channel=self.channel, amplitude=self.amplitude, frequency=self.frequency,
                     kn=self.kn, delta=self.delta,
                     meta_keys=np.array(sorted(self.meta), dtype=str),
                     **({} if self.noise_db is None else {"noise_db": self.noise_db}),
                     **({} if self.rate is None else {"rate": self.rate}),
                     **{f"meta_{k}": np.asarray(v) for k, v in self.meta.items()})

    @staticmethod
    def load(path) -> PointSets:
        with np.load(path) as z:
            return PointSets(
                channels=tuple(str(c) for c in z["channels"]), case=z["case"],
                channel=z["channel"], amplitude=z["amplitude"], frequency=z["frequency"],
                kn=z["kn"], delta=z["delta"],
                meta={str(k): z[f"meta_{k}"] for k in z["meta_keys"]},
                noise_db=z["noise_db"] if "noise_db" in z.files else None,
                rate=z["rate"] if "rate" in z.files else None,
            )


def point_sets_from_records(records: FittingPoints | Sequence[dict],
                            channels: Sequence[str], *, rate=None) -> PointSets:
    """One case from fitting points: a :class:`~freeplayid.fit.FittingPoints`, or point records
    (``channel`` DOF name, ``amplitude_m``, ``f_hz``; ``used``, ``noise_db``; one point suffices
    here). ``noise_db`` is kept where every point has it; ``rate``: each (used) point's sweep
    rate [Hz/s], optional.

    Raises
    ------
    ValueError
        A point's channel is not one of ``channels`` (the message lists them).
    """
    channels = tuple(channels)
    if isinstance(records, FittingPoints):
        names = records.channel
        amplitude = np.array(records.amplitude_m, dtype=float)
        frequency = np.array(records.f_hz, dtype=float)
        noise = records.noise_db
    else:
        rows = [r for r in records if r.get("used", True)]
        names = [r["channel"] for r in rows]
        amplitude = np.array([float(r.get("amplitude_m", r.get("amplitude"))) for r in rows])
        frequency = np.array([float(r["f_hz"]) for r in rows])
        noise = None if any(r.get("noise_db") is None for r in rows) else \
            [float(r["noise_db"]) for r in rows]
    idx = []
    for name in names:
        if name not in channels:
            raise ValueError(
                f"point channel {name!r} is not one the inverse model was trained on; "
                f"allowed: {list(channels)}"
            )
        idx.append(channels.index(name))
    n = len(idx)
    return PointSets(
        channels=channels, case=np.zeros(n, np.int64), channel=np.array(idx, np.int64),
        amplitude=amplitude.reshape(n), frequency=frequency.reshape(n),
        kn=np.array([np.nan]), delta=np.array([np.nan]),
        noise_db=None if noise is None else np.array(noise, dtype=float).reshape(n),
        rate=None if rate is None else np.array(rate, dtype=float).reshape(n),
    )

"""The in-memory data set every layer passes: :class:`Dataset` of :class:`Run` records.

The file format (``manifest.yaml`` and one file per run) is :mod:`freeplayid.io`'s; a simulated
test (:func:`freeplayid.simulate.sweep_dataset`) and a replay build the same objects in memory.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .quantity import UNIT_SCALE

__all__ = ["Dataset", "Run"]


@dataclass(frozen=True)
class Run:
    """One sweep run.

    Attributes
    ----------
    file : str
        Run file name, relative to the manifest.
    time : ndarray, shape (T,) [s]
    data : ndarray, shape (channel, T) [units of the data set]
        Columns in the order of the data set's ``channels``.
    level_g : float or None [g]
        Informational base level.
    sweep : dict or None
        Optional hint ``{start_hz, stop_hz, rate_hz_per_s}`` (linear sweep) or
        ``{start_hz, stop_hz, octaves_per_min}`` (logarithmic), the keys of
        :class:`freeplayid.sweep.Sweep`.
    base : ndarray, shape (T,), or None
        The base (control) channel, if the data set has one.
    reason : str
        Empty for a usable run; else why it is rejected, set by :func:`read_dataset` (an
        unreadable or malformed file, NaN samples, a sweep hint that does not fit the record).
        A run rejected because its file could not be read has empty ``time`` and ``data``.
    """

    file: str
    time: np.ndarray
    data: np.ndarray
    level_g: float | None = None
    sweep: dict | None = None
    base: np.ndarray | None = None
    reason: str = ""


@dataclass(frozen=True)
class Dataset:
    """A data set read from (or to be written to) a folder.

    Attributes
    ----------
    name : str
    model : Path or None
        Absolute path of the linear model file.
    quantity : str
    units : str
    sample_rate : float [Hz]
    channels : dict of str -> str
        Run-file column -> model DOF name, in column order.
    runs : tuple of Run
    base_channel : str or None
    truth : dict or None
        ``{"kn": [N m/rad], "delta": [rad]}`` of a simulated data set (informational).
    path : Path or None
        Absolute path of the manifest read.
    reference_modes : dict or None
        Modes of the fin with its clearance sealed (the zero-clearance check, paper's Table 11):
        ``{"frequencies_hz": [m], "shapes": [[m] per DOF], "dofs": [DOF names]}``.
    """

    name: str
    model: Path | None
    quantity: str
    units: str
    sample_rate: float
    channels: dict
    runs: tuple
    base_channel: str | None = None
    truth: dict | None = None
    path: Path | None = None
    reference_modes: dict | None = None

    @property
    def si_scale(self) -> float:
        """Factor from the data set's units to SI (m, m/s or m/s^2); 9.80665 for g."""
        return UNIT_SCALE[self.units]

    def to_si(self, values) -> np.ndarray:
        """``values`` in the data set's units -> SI units of its quantity (m, m/s, m/s^2)."""
        return np.asarray(values, dtype=float) * self.si_scale

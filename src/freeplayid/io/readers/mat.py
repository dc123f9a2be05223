"""MATLAB run files (``.mat``), in either of two layouts.

**Matrix layout** (what vibration controllers export): one matrix holding every channel (time ×
channels or channels × time: the axis whose length is the number of names is the channel axis),
the channel names, their units (optional) and the time increment, by default the variables

- ``TimeData``: N×C or C×N real numeric matrix [the channels' units];
- ``ChanName``: cell array of C strings (or a C-row char matrix), the run-file column names that
  the manifest's ``channels`` keys and ``base_channel`` refer to;
- ``Unit``: cell array of C unit strings (optional; checked against the manifest's ``units``);
- ``hDelta``: the sample interval [s] (time = k · hDelta, k = 0 … N−1).

Other variable names are declared in the manifest's ``mat:`` block (:class:`MatLayout`).

**Vector layout**: one vector variable per column, named as the manifest's columns: ``time`` [s],
the ``channels`` keys and the ``base_channel``, each a real numeric vector (1×N or N×1, any
numeric class), all of one length.

The matrix layout is used when the file has the matrix variable, else the vector layout; when
neither fits, the error lists the variables the file has. Other variables are ignored. Versions 4
to 7.2 are read with :func:`scipy.io.loadmat`, version 7.3 (HDF5 inside) with ``h5py``
(:mod:`~freeplayid.io.readers.matfile`).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from ...errors import DatasetError
from .matfile import MatFile, open_mat
from .runfile import RunFile

__all__ = ["MatLayout", "read"]

_IDENTIFIER = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,62}")  # a MATLAB variable name


@dataclass(frozen=True)
class MatLayout:
    """The variable names of the matrix layout (the manifest's ``mat:`` block).

    Attributes
    ----------
    data : str
        The N×C (or C×N) matrix of samples.
    names : str
        Cell array (or char matrix) of the C channel names.
    units : str
        Cell array (or char matrix) of the C units; a file without it is not unit-checked.
    increment : str
        The scalar sample interval [s].
    """

    data: str = "TimeData"
    names: str = "ChanName"
    units: str = "Unit"
    increment: str = "hDelta"

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not isinstance(value, str) or not _IDENTIFIER.fullmatch(value):
                raise ValueError(f"`{f.name}` must be a MATLAB variable name (a letter, then "
                                 f"letters, digits or _), got {value!r}")


def read(path: Path, columns: Sequence[str], layouts=None) -> RunFile:
    """The time and the channels named ``columns`` of one MAT file (either layout).

    Parameters
    ----------
    path : Path
    columns : sequence of str
        Channel names (matrix layout) or variable names (vector layout), besides the time.
    layouts : Layouts, optional
        Its ``mat`` gives the matrix layout's variable names (default :class:`MatLayout`).

    Returns
    -------
    RunFile
        Float vectors [s, data-set units]; the units of the matrix layout's ``Unit`` variable.
    """
    layout = layouts.mat if layouts is not None else MatLayout()
    with open_mat(path) as f:
        if layout.data in f.classes:
            return _read_matrix(f, columns, layout)
        need = ["time", *columns]
        missing = [c for c in need if c not in f.classes]
        if missing:
            raise DatasetError(
                f"{path}: variable(s) {missing} not found; the file has {list(f.classes)} (a MAT "
                "run holds one vector per column: 'time' and the manifest's `channels` keys and "
                f"`base_channel`; or a matrix {layout.data!r} with {layout.names!r} and "
                f"{layout.increment!r}, names declared in the manifest's `mat:` block)"
            )
        return RunFile(columns={c: _vector(f, c) for c in need})


# --------------------------------------------------------------------------- vector layout
def _vector(f: MatFile, name: str) -> np.ndarray:
    """A variable as a float vector, or a DatasetError naming the file and the variable."""
    value = f.numeric(name)
    if value.ndim not in (1, 2) or (value.ndim == 2 and min(value.shape) != 1) or value.size == 0:
        raise DatasetError(
            f"{f.path}: variable {name!r} must be a vector (1xN or Nx1), got shape {value.shape}"
        )
    return value.ravel()


# --------------------------------------------------------------------------- matrix layout
def _read_matrix(f: MatFile, columns: Sequence[str], layout: MatLayout) -> RunFile:
    """The requested channels of the matrix, their units and the time of its increment."""
    missing = [v for v in (layout.names, layout.increment) if v not in f.classes]
    if missing:
        raise DatasetError(
            f"{f.path}: matrix {layout.data!r} found but not the variable(s) {missing} (the "
            f"channel names `mat.names` and the sample interval [s] `mat.increment`); the file "
            f"has {list(f.classes)}"
        )
    names = f.strings(layout.names)
    data = _channels_by_rows(f, layout, len(names))
    dt = f.numeric(layout.increment)
    if dt.size != 1 or not np.isfinite(dt.ravel()[0]) or dt.ravel()[0] <= 0:
        raise DatasetError(f"{f.path}: variable {layout.increment!r} (the sample interval [s]) "
                           f"must be one number > 0, got {dt.ravel()[:3].tolist()}")
    units = _units(f, layout, len(names))
    absent = [c for c in columns if c not in names]
    if absent:
        raise DatasetError(
            f"{f.path}: channel(s) {absent} not in {layout.names!r}; it names {names} (the "
            "manifest's `channels` keys and `base_channel` must be channel names)"
        )
    dup = sorted({c for c in columns if names.count(c) > 1})
    if dup:
        raise DatasetError(f"{f.path}: channel name(s) {dup} occur more than once in "
                           f"{layout.names!r}")
    out = {"time": float(dt.ravel()[0]) * np.arange(data.shape[1])}
    out.update({c: data[names.index(c)] for c in columns})
    return RunFile(columns=out, units={c: units[names.index(c)] for c in columns
                                       if units and units[names.index(c)]})


def _channels_by_rows(f: MatFile, layout: MatLayout, n_names: int) -> np.ndarray:
    """The matrix as (channel, sample): its channel axis is the one as long as the names."""
    data = f.numeric(layout.data)
    if data.ndim != 2:
        raise DatasetError(f"{f.path}: variable {layout.data!r} must be a matrix (samples × "
                           f"channels), got shape {data.shape}")
    rows, cols = data.shape
    if rows == cols == n_names and n_names > 1:
        raise DatasetError(f"{f.path}: variable {layout.data!r} has shape {data.shape} and "
                           f"{layout.names!r} {n_names} names: which axis holds the channels "
                           "is ambiguous")
    if cols == n_names:
        return data.T
    if rows == n_names:
        return data
    raise DatasetError(
        f"{f.path}: variable {layout.data!r} has shape {data.shape} but {layout.names!r} has "
        f"{n_names} names; one axis of the matrix must be the channels"
    )


def _units(f: MatFile, layout: MatLayout, n_names: int) -> list[str] | None:
    """The unit of each channel, or None when the file has no units variable."""
    if layout.units not in f.classes:
        return None
    units = f.strings(layout.units)
    if len(units) != n_names:
        raise DatasetError(f"{f.path}: variable {layout.units!r} has {len(units)} units but "
                           f"{layout.names!r} has {n_names} names")
    return units

"""Run-file readers, one per file type, chosen by the file's suffix (docs/identify.md).

Every reader has one signature::

    read(path: Path, columns: Sequence[str], layouts: Layouts | None = None) -> RunFile

and returns a :class:`RunFile`: ``{"time": (T,) [s], column: (T,) [data-set units], ...}`` as
float arrays for the requested ``columns`` (the manifest's channel columns and its base channel;
never ``"time"``), with the units the file states for them. ``layouts`` holds what the
manifest declares about the files' layout (:class:`Layouts`: its ``csv:`` and ``mat:``
blocks); a reader uses its own part and its defaults without one. It raises
:class:`~freeplayid.io.DatasetError` naming the file and the column (or variable, channel,
record) that is missing or malformed.
Everything the file types share (the time column is finite, strictly increasing and uniform,
agrees with ``sample_rate``; non-finite samples reject the run) is checked once, by
:func:`freeplayid.io.read_dataset`, after the reader.

A reader imports its file type's library (pyuff, npTDMS, h5py) when it is called, so
``import freeplayid.io`` stays light and a missing optional library only matters for its files.

Adding a file type is one module here with a ``read`` function and one line in ``READERS``
(and, if the manifest may declare its layout, one field of :class:`Layouts`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import DatasetError
from . import csv, mat, tdms, uff
from .csv import CsvLayout
from .mat import MatLayout
from .runfile import RunFile

__all__ = ["READERS", "Layouts", "Reader", "RunFile", "read_run", "reader_for"]


@dataclass(frozen=True)
class Layouts:
    """What a manifest declares about its run files' layout, one field per manifest block.

    Attributes
    ----------
    csv : CsvLayout
        The ``csv:`` block: delimiter, decimal mark, units row, preamble.
    mat : MatLayout
        The ``mat:`` block: the variable names of the MATLAB matrix layout.
    """

    csv: CsvLayout = field(default_factory=CsvLayout)
    mat: MatLayout = field(default_factory=MatLayout)


Reader = Callable[[Path, Sequence[str], Layouts | None], RunFile]

# suffix (lower case, with the dot; may be compound like ".csv.gz") -> reader
READERS: dict[str, Reader] = {
    ".csv": csv.read,
    ".csv.gz": csv.read,
    ".uff": uff.read,
    ".unv": uff.read,
    ".mat": mat.read,
    ".tdms": tdms.read,
}


def reader_for(path: str | Path) -> Reader:
    """The reader of a run file, chosen by the longest registered suffix its name ends with.

    Raises
    ------
    DatasetError
        No registered suffix matches; the message names the file and lists the valid suffixes.
    """
    name = Path(path).name.lower()
    for suffix in sorted(READERS, key=len, reverse=True):
        if name.endswith(suffix):
            return READERS[suffix]
    raise DatasetError(
        f"{path}: unknown run-file type; the file name must end in one of {list(READERS)}"
    )


def read_run(path: str | Path, columns: Sequence[str], layouts: Layouts | None = None) -> RunFile:
    """Read ``"time"`` and ``columns`` of one run file with the reader of its suffix.

    Parameters
    ----------
    path : path
    columns : sequence of str
        Column names other than ``"time"``.
    layouts : Layouts, optional
        The manifest's layout declarations (default: every reader's defaults).

    Returns
    -------
    RunFile
        ``columns``: ``{"time": ndarray (T,) [s], column: ndarray (T,), ...}``, float, all of
        one length; ``units``: the units the file states, for the requested columns only.

    Raises
    ------
    DatasetError
        Unknown suffix, or whatever the reader finds wrong with the file; a column the reader
        returned with another length than ``time``.
    """
    path = Path(path)
    columns = [c for c in columns if c != "time"]
    found = reader_for(path)(path, columns, layouts)
    if not isinstance(found, RunFile):
        raise DatasetError(f"{path}: the reader returned a {type(found).__name__}, not a RunFile")
    cols = found.columns
    # the reader's contract, checked here once so no file type can slip past it
    out = {}
    for c in ["time", *columns]:
        if c not in cols:
            raise DatasetError(f"{path}: the reader returned no column {c!r}")
        x = np.asarray(cols[c])
        if x.ndim != 1 or x.dtype.kind not in "iuf":
            raise DatasetError(
                f"{path}: column {c!r} must be a real numeric vector, got dtype {x.dtype} and "
                f"shape {x.shape}"
            )
        out[c] = x.astype(float, copy=False)
    n = out["time"].size
    for c in columns:
        if out[c].size != n:
            raise DatasetError(
                f"{path}: column {c!r} has {out[c].size} samples but 'time' has {n}"
            )
    units = {c: str(found.units[c]).strip() for c in ["time", *columns] if found.units.get(c)}
    return RunFile(columns=out, units=units)

"""Run-file readers, one per file type, chosen by the file's suffix (docs/identify.md).

Every reader has one signature::

    read(path: Path, columns: Sequence[str]) -> dict[str, ndarray]

and returns ``{"time": (T,) [s], column: (T,) [data-set units], ...}`` as float arrays for the
requested ``columns`` (the manifest's channel columns and its base channel; never ``"time"``).
It raises :class:`~freeplayid.io.DatasetError` naming the file and the column (or variable,
channel, record) that is missing or malformed. Everything the file types share (the time column
is finite, strictly increasing and uniform, agrees with ``sample_rate``; non-finite samples
reject the run) is checked once, by :func:`freeplayid.io.read_dataset`, after the reader.

A reader imports its file type's library (pyuff, npTDMS, h5py) when it is called, so
``import freeplayid.io`` stays light and a missing optional library only matters for its files.

Adding a file type is one module here with a ``read`` function and one line in ``READERS``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from ...errors import DatasetError
from . import csv, mat, tdms, uff

__all__ = ["READERS", "Reader", "read_run", "reader_for"]

Reader = Callable[[Path, Sequence[str]], dict[str, np.ndarray]]

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


def read_run(path: str | Path, columns: Sequence[str]) -> dict[str, np.ndarray]:
    """Read ``"time"`` and ``columns`` of one run file with the reader of its suffix.

    Parameters
    ----------
    path : path
    columns : sequence of str
        Column names other than ``"time"``.

    Returns
    -------
    dict
        ``{"time": ndarray (T,) [s], column: ndarray (T,), ...}``, float, all of one length.

    Raises
    ------
    DatasetError
        Unknown suffix, or whatever the reader finds wrong with the file; a column the reader
        returned with another length than ``time``.
    """
    path = Path(path)
    columns = [c for c in columns if c != "time"]
    cols = reader_for(path)(path, columns)
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
    return out

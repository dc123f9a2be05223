"""CSV run files (``.csv``, gzip-compressed ``.csv.gz``): a header row, then one row per sample."""

from __future__ import annotations

import gzip
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ...errors import DatasetError
from .runfile import RunFile

__all__ = ["read"]


def read(path: Path, columns: Sequence[str], layouts=None) -> RunFile:
    """The 'time' column and ``columns`` of one CSV (or ``.csv.gz``) file as float arrays."""
    need = ["time", *columns]
    opener = gzip.open if path.suffix.lower() == ".gz" else open
    try:
        with opener(path, "rt") as fh:
            header = [h.strip() for h in fh.readline().strip().split(",")]
    except (OSError, UnicodeDecodeError) as exc:
        raise DatasetError(f"{path}: not a readable CSV text file ({exc})") from None
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise DatasetError(f"{path}: duplicate column name(s) {dup}")
    missing = [c for c in need if c not in header]
    if missing:
        raise DatasetError(
            f"{path}: column(s) {missing} not in the header; the header has {header} "
            "(the manifest's `channels` keys, `base_channel` and 'time' must be columns)"
        )
    cols = [header.index(c) for c in need]
    try:
        table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, usecols=cols)
    except ValueError as exc:  # numpy names the row and column of the bad value
        raise DatasetError(f"{path}: non-numeric value ({exc}); columns: {list(need)}") from None
    return RunFile(columns={c: table[:, k] for k, c in enumerate(need)})

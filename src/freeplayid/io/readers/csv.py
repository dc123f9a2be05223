"""CSV run files (``.csv``, gzip-compressed ``.csv.gz``): a header row, then one row per sample.

The layout is declared in the manifest's ``csv:`` block (:class:`CsvLayout`); without one it is
plain CSV: ``,``-delimited, ``.`` decimal point, one header row. A controller's export such as::

    Kanal;time;a1;a2;ab            <- header row (a name may be "quoted")
    -;s;m/s^2;m/s^2;m/s^2          <- units row: csv: {units_row: true}
    0;0,000;0,125;-1,5E-02;0       <- decimal comma: csv: {delimiter: ";", decimal: ","}

is read with ``csv: {delimiter: ";", decimal: ",", units_row: true}``; ``skip_rows`` skips a
preamble above the header row. Units in the units row may be bracketed (``[g]``, ``(g)``).
"""

from __future__ import annotations

import gzip
import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import DatasetError
from .runfile import RunFile

__all__ = ["CsvLayout", "DELIMITERS", "read"]

# the delimiters a manifest may declare: the character, or its name
DELIMITERS = {",": ",", ";": ";", "\t": "\t", "|": "|", "comma": ",", "semicolon": ";",
              "tab": "\t"}
DECIMALS = (".", ",")


@dataclass(frozen=True)
class CsvLayout:
    """The layout of the CSV run files (the manifest's ``csv:`` block).

    Attributes
    ----------
    delimiter : str
        ``","``, ``";"``, ``"\\t"`` (or ``tab``), ``"|"``; a name (``comma``, ``semicolon``,
        ``tab``) is kept as its character.
    decimal : str
        ``"."`` or ``","`` (decimal comma; the delimiter must then be another character).
    units_row : bool
        The row below the header holds each column's unit (checked against the manifest's
        ``units``; an empty cell is not checked).
    skip_rows : int
        Lines above the header row to skip (a preamble).
    """

    delimiter: str = ","
    decimal: str = "."
    units_row: bool = False
    skip_rows: int = 0

    def __post_init__(self) -> None:
        if not isinstance(self.delimiter, str) or self.delimiter not in DELIMITERS:
            raise ValueError(f"`delimiter` must be one of [',', ';', 'tab', '|'], got "
                             f"{self.delimiter!r}")
        object.__setattr__(self, "delimiter", DELIMITERS[self.delimiter])
        if self.decimal not in DECIMALS:
            raise ValueError(f"`decimal` must be one of {list(DECIMALS)}, got {self.decimal!r}")
        if self.decimal == self.delimiter:
            raise ValueError(f"`decimal` {self.decimal!r} cannot be the `delimiter` too; a "
                             "decimal comma needs another delimiter (';' or tab)")
        if not isinstance(self.units_row, bool):
            raise ValueError(f"`units_row` must be true or false, got {self.units_row!r}")
        if isinstance(self.skip_rows, bool) or not isinstance(self.skip_rows, int) \
                or self.skip_rows < 0:
            raise ValueError(f"`skip_rows` must be an integer >= 0, got {self.skip_rows!r}")


def read(path: Path, columns: Sequence[str], layouts=None) -> RunFile:
    """The 'time' column and ``columns`` of one CSV (or ``.csv.gz``) file as float arrays, with
    the units of its units row (when the layout declares one).

    Parameters
    ----------
    path : Path
    columns : sequence of str
    layouts : Layouts, optional
        Its ``csv`` gives the delimiter, decimal mark, units row and preamble (default plain
        CSV).
    """
    layout = layouts.csv if layouts is not None else CsvLayout()
    need = ["time", *columns]
    text = _text(path)
    lines = text.splitlines()
    head = layout.skip_rows + 1 + layout.units_row  # lines above the first sample
    if len(lines) < head:
        raise DatasetError(f"{path}: {len(lines)} line(s), fewer than the header rows the "
                           f"manifest's `csv:` layout declares ({head})")
    header = _fields(lines[layout.skip_rows], layout.delimiter)
    dup = sorted({h for h in header if h and header.count(h) > 1})
    if dup:
        raise DatasetError(f"{path}: duplicate column name(s) {dup}")
    missing = [c for c in need if c not in header]
    if missing:
        raise DatasetError(
            f"{path}: column(s) {missing} not in the header; the header has {header} "
            "(the manifest's `channels` keys, `base_channel` and 'time' must be columns)"
            + _delimiter_hint(lines[layout.skip_rows], layout)
        )
    cols = [header.index(c) for c in need]
    units = {}
    if layout.units_row:
        row = [_unit(u) for u in _fields(lines[layout.skip_rows + 1], layout.delimiter)]
        units = {c: row[k] for c, k in zip(need, cols) if k < len(row) and row[k]}
    if layout.decimal == ",":  # the delimiter is not ',' then: every ',' is a decimal mark
        text = text.replace(",", ".")
    try:
        table = np.loadtxt(io.StringIO(text), delimiter=layout.delimiter, skiprows=head,
                           ndmin=2, usecols=cols, quotechar='"')
    except ValueError as exc:  # numpy names the row and column of the bad value
        hint = "" if layout.units_row or "at row 0," not in str(exc) else (
            " (a units row below the header? declare it: csv: {units_row: true})")
        raise DatasetError(f"{path}: non-numeric value ({exc}); columns: {list(need)}{hint}") \
            from None
    return RunFile(columns={c: table[:, k] for k, c in enumerate(need)}, units=units)


def _text(path: Path) -> str:
    """The file's text (UTF-8, with or without a byte-order mark; else Latin-1, as Windows
    programs write units such as m/s²)."""
    opener = gzip.open if path.suffix.lower() == ".gz" else open
    try:
        with opener(path, "rb") as fh:
            raw = fh.read()
    except OSError as exc:
        raise DatasetError(f"{path}: not a readable CSV text file ({exc})") from None
    if b"\x00" in raw[:4096]:
        raise DatasetError(f"{path}: not a readable CSV text file (binary data)")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


def _fields(line: str, delimiter: str) -> list[str]:
    """The cells of a header or units row, stripped of blanks and quotes."""
    return [f.strip().strip('"').strip() for f in line.rstrip("\r\n").split(delimiter)]


def _unit(cell: str) -> str:
    """A units-row cell without its brackets: ``[m/s^2]`` -> ``m/s^2``."""
    if len(cell) >= 2 and (cell[0], cell[-1]) in (("[", "]"), ("(", ")")):
        cell = cell[1:-1].strip()
    return cell


def _delimiter_hint(line: str, layout: CsvLayout) -> str:
    """When the header is one cell holding another delimiter, say which one to declare."""
    if len(line.split(layout.delimiter)) > 1:
        return ""
    for name, char in (("';'", ";"), ("tab", "\t"), ("','", ","), ("'|'", "|")):
        if char != layout.delimiter and char in line:
            return (f"; the header looks {name}-delimited: declare it in the manifest "
                    f"(csv: {{delimiter: {name}}})")
    return ""

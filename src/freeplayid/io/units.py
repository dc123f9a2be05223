"""The unit fields of run files, read and checked against the manifest (docs/identify.md).

A run file may state each column's unit (a UFF record's ordinate label, a TDMS ``unit_string``,
a MAT ``Unit`` entry, a CSV units row). :func:`check_file_units` compares every unit it
recognises (:func:`parse_unit`: the spellings of :data:`SPELLINGS`, written as controllers write
them: ``m/s^2``, ``m/s2``, ``m/s²``, ``m s^-2``, ``G``, ``mm/s``, ``in/s``, ...) with the
manifest's ``quantity`` and ``units``: another quantity, or another scale of the same one
(``mm/s^2`` for ``m/s^2``, ``m/s^2`` for ``g``), is an error naming the file, the column and both
units. A unit field that is absent, empty, ``NONE`` or not a recognised spelling (``V``, ``EU``,
``-``) is not checked: the manifest's ``units`` are then taken as they are.

The time column's unit, where the file gives one, must be seconds.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass

from ..errors import DatasetError
from ..quantity import QUANTITY, UNIT_SCALE, G

__all__ = ["FileUnit", "SPELLINGS", "check_file_units", "parse_unit"]

_IN = 0.0254  # [m]
_FT = 0.3048  # [m]


@dataclass(frozen=True)
class FileUnit:
    """A recognised unit: its quantity (``"time"`` for a time unit) and its factor to SI."""

    quantity: str
    si_factor: float


# normalised spelling (see _normalise) -> unit; lower case, so G and g are both gravity
SPELLINGS = {
    **{u: FileUnit("acceleration", G) for u in ("g", "gn", "g0", "g's", "gs")},
    "m/s^2": FileUnit("acceleration", 1.0),
    "cm/s^2": FileUnit("acceleration", 1e-2),
    "mm/s^2": FileUnit("acceleration", 1e-3),
    "in/s^2": FileUnit("acceleration", _IN),
    "ft/s^2": FileUnit("acceleration", _FT),
    "m/s": FileUnit("velocity", 1.0),
    "cm/s": FileUnit("velocity", 1e-2),
    "mm/s": FileUnit("velocity", 1e-3),
    "in/s": FileUnit("velocity", _IN),
    "ips": FileUnit("velocity", _IN),
    "ft/s": FileUnit("velocity", _FT),
    "m": FileUnit("displacement", 1.0),
    "cm": FileUnit("displacement", 1e-2),
    "mm": FileUnit("displacement", 1e-3),
    "um": FileUnit("displacement", 1e-6),
    "micron": FileUnit("displacement", 1e-6),
    "in": FileUnit("displacement", _IN),
    "mil": FileUnit("displacement", 1e-3 * _IN),
    "ft": FileUnit("displacement", _FT),
    "s": FileUnit("time", 1.0),
    "ms": FileUnit("time", 1e-3),
    "us": FileUnit("time", 1e-6),
    "min": FileUnit("time", 60.0),
}


def _normalise(text: str) -> str:
    """One spelling per unit: no blanks, ``²``/``**2``/``s2``/``s^-2``/``/s/s`` as ``/s^2``,
    ``sec`` as ``s``, ``µ`` as ``u``, lower case."""
    u = text.strip().lower().replace("µ", "u").replace("μ", "u")
    u = u.replace("²", "^2").replace("**", "^").replace("sec", "s")
    u = re.sub(r"\s+", " ", u).strip()
    u = re.sub(r"^(\w+)[ ·*.]?s\^-2$", r"\1/s^2", u)  # m s^-2, m·s^-2
    u = re.sub(r"^(\w+)[ ·*.]?s\^-1$", r"\1/s", u)  # m s^-1
    u = u.replace(" ", "")
    u = re.sub(r"/s/s$", "/s^2", u)
    u = re.sub(r"/s2$", "/s^2", u)
    return u


def parse_unit(text) -> FileUnit | None:
    """The unit a file's unit field names, or None for an absent or unrecognised one."""
    if not isinstance(text, str) or not text.strip():
        return None
    return SPELLINGS.get(_normalise(text))


def check_file_units(units: Mapping[str, str], quantity: str, data_units: str, where: str) -> None:
    """Check the units a run file states against the data set's quantity and units.

    Parameters
    ----------
    units : mapping column -> str
        The file's unit field of each column (``RunFile.units``; ``"time"`` included).
    quantity, data_units : str
        The manifest's ``quantity`` and ``units`` (already valid).
    where : str
        The run file, the prefix of the message.

    Raises
    ------
    DatasetError
        A recognised unit of another quantity or scale, naming the file, the column and both
        units; a time column not in seconds.
    """
    for column, text in units.items():
        unit = parse_unit(text)
        if unit is None:
            continue  # absent or unknown: no check (docs/identify.md)
        if column == "time":
            if unit.quantity != "time" or unit.si_factor != 1.0:
                raise DatasetError(f"{where}: column 'time' is in {text!r} by the file's unit "
                                   "field; the time must be in s (seconds)")
            continue
        want = UNIT_SCALE[data_units]
        if unit.quantity == quantity and abs(unit.si_factor - want) <= 1e-9 * want:
            continue
        raise DatasetError(f"{where}: channel {column!r}: the file says {text!r}, the manifest "
                           f"says {data_units!r} ({quantity}); "
                           + _advice(unit, quantity, text))


def _advice(unit: FileUnit, quantity: str, text: str) -> str:
    """What to change: the manifest's `units` when the file's unit is one it may declare."""
    for q in QUANTITY.values():
        for u in q.units:
            if q.name == unit.quantity and UNIT_SCALE[u] == unit.si_factor:
                fix = f"`units: {u}`" + ("" if q.name == quantity else f" and `quantity: {q.name}`")
                return f"if the file is right, set {fix} in the manifest"
    allowed = QUANTITY[unit.quantity].units if unit.quantity in QUANTITY else ()
    return f"a data set's {unit.quantity} is in one of {allowed}: export the data in one of those"

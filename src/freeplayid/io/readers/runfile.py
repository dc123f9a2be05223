"""What every run-file reader returns: :class:`RunFile`."""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["RunFile"]


@dataclass(frozen=True)
class RunFile:
    """The columns of one run file, with the units the file itself states.

    Attributes
    ----------
    columns : dict str -> ndarray, shape (T,)
        ``"time"`` [s] and every requested column [the file's units], as float vectors.
    units : dict str -> str
        Column -> the unit string the file gives for it (a UFF record's ordinate label, a TDMS
        ``unit_string``, a MAT ``Unit`` entry, a CSV units row), as written. A column the file
        gives no unit for is absent: it is not checked.
    """

    columns: dict
    units: dict = field(default_factory=dict)

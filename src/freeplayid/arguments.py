"""Checks of single arguments, each a one-line ``ValueError`` naming the argument.

The option records (:class:`freeplayid.signal.Extraction`, :class:`freeplayid.fit.FitOptions`,
:class:`freeplayid.replay.Replay`) validate their fields with these on construction, so a bad
value from a notebook or from a command line ends in the same message: "`jump_ratio` must be a
finite number > 0 and < 1, got 1.5". A value of the wrong type is refused, not converted
(``n_bootstrap=2.7`` is an error, not 2); NumPy numbers count as numbers.
"""

from __future__ import annotations

import math
import numbers

__all__ = ["check_int", "check_number", "check_bool", "check_choice", "check_range"]


def _bound(lo, hi, open_lo: bool, open_hi: bool) -> str:
    parts = []
    if lo is not None:
        parts.append(f"{'>' if open_lo else '>='} {lo:g}")
    if hi is not None:
        parts.append(f"{'<' if open_hi else '<='} {hi:g}")
    return " " + " and ".join(parts) if parts else ""


def is_int(v) -> bool:
    return isinstance(v, numbers.Integral) and not isinstance(v, bool)


def is_number(v) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v)


def check_int(name: str, v, lo: int | None = None, hi: int | None = None) -> int:
    """``v`` as an int within [lo, hi]; ValueError naming ``name`` otherwise."""
    if not (is_int(v) and (lo is None or v >= lo) and (hi is None or v <= hi)):
        raise ValueError(f"`{name}` must be an integer{_bound(lo, hi, False, False)}, got {v!r}")
    return int(v)


def check_number(name: str, v, lo: float | None = None, hi: float | None = None, *,
                 open_lo: bool = False, open_hi: bool = False) -> float:
    """``v`` as a finite float within its bounds; ValueError naming ``name`` otherwise."""
    ok = is_number(v) and (lo is None or (v > lo if open_lo else v >= lo)) \
        and (hi is None or (v < hi if open_hi else v <= hi))
    if not ok:
        raise ValueError(f"`{name}` must be a finite number"
                         f"{_bound(lo, hi, open_lo, open_hi)}, got {v!r}")
    return float(v)


def check_bool(name: str, v) -> bool:
    if not isinstance(v, bool):
        raise ValueError(f"`{name}` must be true or false, got {v!r}")
    return v


def check_choice(name: str, v, options) -> str:
    """``v`` one of ``options`` (the message lists them)."""
    if not (isinstance(v, str) and v in options):
        raise ValueError(f"`{name}` must be one of {sorted(options)}, got {v!r}")
    return v


def check_range(name: str, v) -> tuple[float, float]:
    """Two increasing finite numbers > 0, e.g. a prior range."""
    try:
        lo, hi = v
    except (TypeError, ValueError):
        lo = hi = None
    if not (is_number(lo) and is_number(hi) and 0 < lo < hi):
        raise ValueError(f"`{name}` must be [2 values each a finite number > 0, increasing], "
                         f"got {v!r}")
    return (float(lo), float(hi))

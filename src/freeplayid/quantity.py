"""The measured quantities and their units: the one place that defines them.

A response is recorded as displacement, velocity or acceleration; its first-harmonic amplitude
becomes a displacement amplitude by Eq. 9, ``X = V / w = A / w^2`` (the quantity's derivative
order). Data sets give their values in one of the quantity's units; :data:`UNIT_SCALE` is the
factor to SI (m, m/s, m/s^2). Base levels are given in g (:data:`G`).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "G",
    "QUANTITIES",
    "Quantity",
    "UNIT_SCALE",
    "check_quantity",
    "check_units",
    "derivative_order",
    "si_unit",
]

G = 9.80665  # standard gravity [m/s^2]; base levels and acceleration data may be given in g


@dataclass(frozen=True)
class Quantity:
    """One measurable quantity.

    Attributes
    ----------
    name : str
        "displacement", "velocity" or "acceleration".
    order : int
        Time-derivative order of displacement (0, 1, 2): Eq. 9 divides by ``w**order``.
    si_unit : str
        "m", "m/s" or "m/s^2".
    units : tuple of str
        Units a data set may use for it (the SI unit first).
    prefix : str
        Short column prefix of simulated data sets ("disp", "vel", "acc").
    """

    name: str
    order: int
    si_unit: str
    units: tuple[str, ...]
    prefix: str


_TABLE = (
    Quantity("displacement", 0, "m", ("m",), "disp"),
    Quantity("velocity", 1, "m/s", ("m/s",), "vel"),
    Quantity("acceleration", 2, "m/s^2", ("g", "m/s^2"), "acc"),
)
QUANTITY = {q.name: q for q in _TABLE}
QUANTITIES = tuple(QUANTITY)
# factor from a data-set unit to SI
UNIT_SCALE = {"m": 1.0, "m/s": 1.0, "m/s^2": 1.0, "g": G}


def check_quantity(quantity, name: str = "quantity") -> Quantity:
    """The :class:`Quantity` called ``quantity``; ValueError naming the valid names otherwise."""
    q = QUANTITY.get(quantity) if isinstance(quantity, str) else None
    if q is None:
        raise ValueError(f"`{name}` must be one of {QUANTITIES}, got {quantity!r}")
    return q


def check_units(quantity: str, units, name: str = "units") -> float:
    """SI factor of ``units`` for ``quantity``; ValueError naming the allowed units otherwise."""
    q = check_quantity(quantity)
    if units not in q.units:
        raise ValueError(f"`{name}` for {q.name} must be one of {q.units}, got {units!r}")
    return UNIT_SCALE[units]


def derivative_order(quantity: str) -> int:
    """0, 1 or 2: the time-derivative order of displacement that ``quantity`` is."""
    return check_quantity(quantity).order


def si_unit(quantity: str) -> str:
    """SI unit of ``quantity``: "m", "m/s" or "m/s^2"."""
    return check_quantity(quantity).si_unit

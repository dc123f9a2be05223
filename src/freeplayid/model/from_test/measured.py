"""Measured modes of the paper's three modal tests, as plain values (read by
:func:`freeplayid.io.read_modal_test`, used by :func:`freeplayid.model.model_from_modal_test`).

The tests (the paper's Tables 7 and 8), each on one part before assembly:

- ``outboard_free``: the outboard fin, free-free;
- ``inboard_free``: the inboard fin, free-free;
- ``inboard_clamped``: the inboard fin clamped on its root edge (the fixed-boundary check).

Mode shapes are out-of-plane displacements w at named points. A point is named in the fin
configuration (``top_left``, ``lower_right``, ``exciting``) or declared with its fin coordinates
(x, y) [m] in the modal-test file; every point lies on the tested part.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...errors import ModalTestError

__all__ = ["ModalTestError", "MeasuredModes", "ModalTest", "TEST_NAMES", "CONFIG_POINTS"]

TEST_NAMES = ("outboard_free", "inboard_free", "inboard_clamped")
CONFIG_POINTS = ("top_left", "lower_right", "exciting")  # points named in the fin configuration


@dataclass(frozen=True)
class MeasuredModes:
    """The modes of one test.

    Attributes
    ----------
    frequencies_hz : ndarray, shape (m,) [Hz]
    damping : ndarray, shape (m,) [-]
        Viscous damping ratio of each mode, NaN where not measured.
    shapes : ndarray, shape (n_points, m) [-] or None
        Mode-shape values (w, any scale) at ``points``; None: pair modes by order.
    points : tuple of str, shape (n_points,)
        Point names of the rows of ``shapes``.
    where : str
        ``FILE: TEST`` for messages.
    """

    frequencies_hz: np.ndarray
    damping: np.ndarray
    shapes: np.ndarray | None = None
    points: tuple = ()
    where: str = ""

    def __post_init__(self) -> None:
        f = np.asarray(self.frequencies_hz, float).reshape(-1)
        if f.size == 0 or not np.all(np.isfinite(f) & (f > 0)):
            raise ModalTestError(f"{self.where}: frequencies must be finite numbers > 0 [Hz], "
                                 f"got {f.tolist()}")
        object.__setattr__(self, "frequencies_hz", f)
        z = np.broadcast_to(np.asarray(self.damping, float), f.shape).copy()
        object.__setattr__(self, "damping", z)
        if self.shapes is not None:
            s = np.asarray(self.shapes, float)
            if s.shape != (len(self.points), f.size):
                raise ModalTestError(f"{self.where}: shapes must have shape ({len(self.points)}, "
                                     f"{f.size}), got {s.shape}")
            object.__setattr__(self, "shapes", s)

    @property
    def n_modes(self) -> int:
        return self.frequencies_hz.size


@dataclass(frozen=True)
class ModalTest:
    """The measured modes of one or more of :data:`TEST_NAMES`.

    Attributes
    ----------
    tests : dict str -> MeasuredModes
        Keys among :data:`TEST_NAMES`.
    points : dict str -> (float, float) [m]
        Points declared with fin coordinates (besides :data:`CONFIG_POINTS`).
    source : str
        The file read (for messages).
    name : str
    """

    tests: dict
    points: dict = field(default_factory=dict)
    source: str = "modal test"
    name: str = ""

    def __post_init__(self) -> None:
        unknown = sorted(set(self.tests) - set(TEST_NAMES))
        if unknown:
            raise ModalTestError(f"{self.source}: unknown test(s) {unknown}; allowed: "
                                 f"{list(TEST_NAMES)}")
        if not self.tests:
            raise ModalTestError(f"{self.source}: no test; give one or more of {list(TEST_NAMES)}")

    @property
    def n_modes(self) -> int:
        """Measured modes over all tests."""
        return sum(t.n_modes for t in self.tests.values())

    def part_damping(self, part_of: dict) -> dict:
        """Mean measured damping ratio of each part {part: ratio} over its tests' modes
        (``part_of``: test name -> part); a part without a measured ratio is left out."""
        out = {}
        for part in dict.fromkeys(part_of.values()):
            z = np.concatenate([np.asarray(t.damping, float) for name, t in self.tests.items()
                                if part_of.get(name) == part] or [np.empty(0)])
            z = z[np.isfinite(z)]
            if z.size:
                out[part] = float(z.mean())
        return out

    def mean_damping(self) -> float | None:
        """Mean of the measured damping ratios of all modes, None if none was measured."""
        z = np.concatenate([t.damping for t in self.tests.values()])
        z = z[np.isfinite(z)]
        return float(z.mean()) if z.size else None

"""The zero-clearance check of an identified model: closed-hinge modes against reference modes.

With the hinges closed at the identified ``kn`` (delta = 0) the model must reproduce the modes of a
sealed-hinge test (the paper's Table 11): paired by MAC, each frequency within ``max_error_hz``
and each MAC above ``min_mac``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..modal import modal_analysis, pair_modes
from ..system import FreeplaySystem

__all__ = ["ModeValidation", "validate_modes"]


@dataclass(frozen=True)
class ModeValidation:
    """Zero-clearance (delta = 0) model vs reference modes (the paper's Table 11 check).

    Attributes
    ----------
    reference_hz, model_hz : ndarray, shape (m,) [Hz]
    error_hz : ndarray, shape (m,) [Hz]
        model - reference for each paired mode.
    mac : ndarray, shape (m,) [-]
    pairing : ndarray, shape (m,) of int
        Model mode index paired with each reference mode (by MAC).
    passed : bool
        All |error| < ``max_error_hz`` and all MAC > ``min_mac``.
    """

    reference_hz: np.ndarray
    model_hz: np.ndarray
    error_hz: np.ndarray
    mac: np.ndarray
    pairing: np.ndarray
    passed: bool

    def table(self) -> str:
        """Markdown table of the comparison."""
        rows = [
            "| mode | reference [Hz] | model [Hz] | error [Hz] | MAC |",
            "|---|---|---|---|---|",
        ]
        for i in range(self.reference_hz.size):
            rows.append(
                f"| {i + 1} | {self.reference_hz[i]:.2f} | {self.model_hz[i]:.2f} | "
                f"{self.error_hz[i]:+.2f} | {self.mac[i]:.4f} |"
            )
        return "\n".join(rows)


def validate_modes(
    system: FreeplaySystem,
    kn: float,
    reference_hz,
    reference_shapes,
    shape_dofs: Sequence[str],
    *,
    max_error_hz: float = 1.0,
    min_mac: float = 0.98,
) -> ModeValidation:
    """Compare the identified zero-clearance model (hinges closed at ``kn``) with reference modes.

    Parameters
    ----------
    system : FreeplaySystem
    kn : float [N m/rad]
        Identified contact stiffness.
    reference_hz : array_like, shape (m,) [Hz]
        Reference (e.g. hammer test of the sealed hinge) natural frequencies.
    reference_shapes : array_like, shape (len(shape_dofs), m)
        Reference mode shapes at ``shape_dofs``.
    shape_dofs : sequence of str
        Model DOF names of the rows of ``reference_shapes``.
    max_error_hz, min_mac : float
        Pass criteria (paper: < 1 Hz and MAC > 0.98).
    """
    ref_hz = np.asarray(reference_hz, dtype=float).reshape(-1)
    ref_phi = np.asarray(reference_shapes, dtype=float)
    if ref_phi.ndim != 2 or ref_phi.shape != (len(shape_dofs), ref_hz.size):
        raise ValueError(
            f"`reference_shapes` must have shape ({len(shape_dofs)}, {ref_hz.size}), "
            f"got {ref_phi.shape}"
        )
    idx = system.dof_index(list(shape_dofs))
    modes = modal_analysis(system.M, system.closed_stiffness(kn))
    pairing, macs = pair_modes(ref_phi, modes.shapes[idx, :],
                               frequencies=(ref_hz, modes.frequencies_hz))
    model_hz = np.where(pairing >= 0, modes.frequencies_hz[np.clip(pairing, 0, None)], np.nan)
    err = model_hz - ref_hz
    passed = bool(np.all(np.abs(err) < max_error_hz) and np.all(macs > min_mac))
    return ModeValidation(ref_hz, model_hz, err, macs, pairing, passed)

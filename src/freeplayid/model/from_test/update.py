"""Model updating: adjust structural parameters so that modal frequencies match measured ones.

The model is given as a builder ``build(params) -> (M, K)``; the parameters (e.g. per-part
Young's modulus, density, thickness) are updated as log scale factors ``x_i = ln(p_i / p0_i)``,
which keeps them positive and the problem well scaled whatever their units. The residual is the
relative frequency error of each measured mode::

    r_i(x) = (f_model,pair(i)(x) - f_meas,i) / f_meas,i

Modes are paired by MAC against measured shapes when they are given (at the model DOFs
``shape_dofs``), otherwise by order. The pairing is recomputed at every evaluation so a mode
swap during the iteration is followed, not fought.

Identifiability: plate frequencies depend on E, rho and t only through t*sqrt(E/rho) per part
when parts are homogeneous, so updating E and rho (or t) of one part together is rank deficient;
the result reports the Jacobian's condition number and the caller is warned when it is large.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from ..modal import modal_analysis, pair_modes

__all__ = ["UpdateResult", "update_model", "mode_table", "condition_number"]


@dataclass(frozen=True)
class UpdateResult:
    """Outcome of :func:`update_model`.

    Attributes
    ----------
    parameters : dict[str, float]
        Updated parameter values (same units as the initial values).
    scale : dict[str, float]
        Updated / initial value of each parameter.
    frequencies_hz : ndarray, shape (m,) [Hz]
        Model frequencies paired with the measured modes, at the optimum.
    measured_hz : ndarray, shape (m,) [Hz]
    relative_error : ndarray, shape (m,) [-]
        (model - measured) / measured at the optimum.
    pairing : ndarray, shape (m,) of int
        Model mode index paired with each measured mode.
    mac : ndarray, shape (m,) or None
        MAC of each pair when measured shapes were given.
    condition : float
        Condition number of the scaled Jacobian at the optimum (large: parameters not separable).
    n_evaluations : int
        Number of model builds + eigen-solutions.
    success : bool
    message : str
    """

    parameters: dict
    scale: dict
    frequencies_hz: np.ndarray
    measured_hz: np.ndarray
    relative_error: np.ndarray
    pairing: np.ndarray
    mac: np.ndarray | None
    condition: float
    n_evaluations: int
    success: bool
    message: str


def update_model(
    build: Callable[[dict], tuple],
    initial: Mapping[str, float],
    measured_hz: Sequence[float],
    *,
    measured_shapes: np.ndarray | None = None,
    shape_dofs: Sequence[int] | None = None,
    n_modes: int | None = None,
    bounds: tuple[float, float] = (0.2, 5.0),
    weights: Sequence[float] | None = None,
    xtol: float = 1e-10,
    max_evaluations: int = 200,
) -> UpdateResult:
    """Least-squares update of ``initial`` parameters against measured modal frequencies.

    Parameters
    ----------
    build : callable
        ``build(params: dict[str, float]) -> (M, K)`` (dense or sparse, same DOFs every call).
    initial : mapping str -> float
        Parameters to update and their starting values (> 0); other model inputs stay fixed
        inside ``build``.
    measured_hz : sequence of float, shape (m,) [Hz]
        Measured natural frequencies (> 0).
    measured_shapes : ndarray, shape (n_meas_dofs, m), optional
        Measured mode shapes; if given, model modes are paired by MAC at ``shape_dofs``.
    shape_dofs : sequence of int, shape (n_meas_dofs,), optional
        Model DOF indices of the rows of ``measured_shapes`` (required with it).
    n_modes : int, optional
        Model modes computed for the pairing (default ``2 m + 4``, or ``m`` without shapes).
    bounds : (float, float)
        Allowed range of each scale factor p/p0.
    weights : sequence of float, shape (m,), optional
        Weight of each mode's residual (default 1).

    Returns
    -------
    UpdateResult
    """
    names, p0 = _initial_values(initial)
    f_meas = np.asarray(measured_hz, dtype=float).reshape(-1)
    if f_meas.size == 0 or np.any(~np.isfinite(f_meas)) or np.any(f_meas <= 0):
        raise ValueError(f"`measured_hz` must be finite frequencies > 0, got {measured_hz!r}")
    m = f_meas.size
    if m < len(names):
        warnings.warn(
            f"{m} measured frequencies for {len(names)} parameters: the update is underdetermined",
            stacklevel=2,
        )
    measured_shapes, shape_dofs = _shape_rows(measured_shapes, shape_dofs, m)
    w = np.ones(m) if weights is None else np.asarray(weights, dtype=float).reshape(-1)
    if w.shape != (m,):
        raise ValueError(f"`weights` must have shape ({m},), got {w.shape}")
    if not (0 < bounds[0] < 1 < bounds[1]):
        raise ValueError(f"`bounds` must satisfy 0 < lo < 1 < hi, got {bounds!r}")
    if n_modes is None:
        n_modes = 2 * m + 4 if measured_shapes is not None else m

    residual = _FrequencyResidual(build, names, p0, f_meas, w, n_modes, measured_shapes,
                                  shape_dofs)
    lo, hi = np.log(bounds[0]), np.log(bounds[1])
    sol = scipy.optimize.least_squares(
        residual, np.zeros(len(names)), bounds=(np.full(len(names), lo), np.full(len(names), hi)),
        x_scale=1.0, xtol=xtol, ftol=1e-14, gtol=1e-14, max_nfev=max_evaluations, diff_step=1e-6)
    residual(sol.x)  # make the residual's pairing describe the optimum
    condition = condition_number(sol.jac)
    if condition > 1e6:
        warnings.warn(
            f"model updating: Jacobian condition number {condition:.2e}; the parameters "
            f"{names} are not separately identifiable from these frequencies",
            stacklevel=2,
        )
    p = p0 * np.exp(sol.x)
    return UpdateResult(
        parameters=dict(zip(names, p.tolist())),
        scale=dict(zip(names, np.exp(sol.x).tolist())),
        frequencies_hz=residual.f,
        measured_hz=f_meas,
        relative_error=(residual.f - f_meas) / f_meas,
        pairing=residual.idx,
        mac=residual.macs,
        condition=condition,
        n_evaluations=residual.n_evaluations,
        success=bool(sol.success),
        message=str(sol.message),
    )


def condition_number(jac) -> float:
    """Ratio of the largest to the smallest singular value of a Jacobian (inf if singular)."""
    sv = np.linalg.svd(jac, compute_uv=False)
    return float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")


def _initial_values(initial: Mapping[str, float]) -> tuple[list[str], np.ndarray]:
    """The names of the parameters to update and their starting values (finite, > 0)."""
    names = list(initial)
    if not names:
        raise ValueError("`initial` must name at least one parameter to update")
    p0 = np.array([float(initial[k]) for k in names])
    if np.any(~np.isfinite(p0)) or np.any(p0 <= 0):
        raise ValueError(f"`initial` values must be finite and > 0, got {dict(initial)!r}")
    return names, p0


def _shape_rows(measured_shapes, shape_dofs, m: int):
    """``measured_shapes`` (n_meas_dofs, m) and its model DOF indices, checked (or None, as
    given)."""
    if measured_shapes is None:
        return None, shape_dofs
    measured_shapes = np.asarray(measured_shapes)
    if measured_shapes.ndim != 2 or measured_shapes.shape[1] != m:
        raise ValueError(
            f"`measured_shapes` must have shape (n_meas_dofs, {m}), got {measured_shapes.shape}"
        )
    if shape_dofs is None or len(shape_dofs) != measured_shapes.shape[0]:
        raise ValueError(
            "`shape_dofs` must list one model DOF index per row of `measured_shapes`"
        )
    return measured_shapes, np.asarray(shape_dofs, dtype=int)


class _FrequencyResidual:
    """The weighted relative frequency errors of log scale factors ``x`` (the least-squares
    residual); remembers the pairing of its last evaluation and counts the evaluations."""

    def __init__(self, build, names, p0, f_meas, w, n_modes, measured_shapes, shape_dofs):
        self.build, self.names, self.p0, self.f_meas, self.w = build, names, p0, f_meas, w
        self.n_modes, self.shapes, self.shape_dofs = n_modes, measured_shapes, shape_dofs
        self.n_evaluations = 0
        self.f = self.idx = self.macs = None

    def __call__(self, x) -> np.ndarray:
        params = dict(zip(self.names, self.p0 * np.exp(x)))
        M, K = self.build(params)
        self.n_evaluations += 1
        m = self.f_meas.size
        k = min(self.n_modes, M.shape[0])
        modes = modal_analysis(M, K, n_modes=k)
        if self.shapes is not None:
            idx, macs = pair_modes(self.shapes, modes.shapes[self.shape_dofs, :])
            if np.any(idx < 0):
                raise RuntimeError("a measured mode found no model partner by MAC")
        else:
            if k < m:
                raise ValueError(f"the model has {k} modes, fewer than the {m} measured")
            idx, macs = np.arange(m), None
        self.f, self.idx, self.macs = modes.frequencies_hz[idx], idx, macs
        return self.w * (self.f - self.f_meas) / self.f_meas


def mode_table(result: UpdateResult) -> str:
    """Markdown table of measured vs updated frequencies (and MAC) of an :class:`UpdateResult`."""
    head = "| mode | measured [Hz] | model [Hz] | error [%] |" + (
        " MAC |" if result.mac is not None else ""
    )
    sep = "|---|---|---|---|" + ("---|" if result.mac is not None else "")
    rows = [head, sep]
    for i, (fm, f, e) in enumerate(
        zip(result.measured_hz, result.frequencies_hz, result.relative_error)
    ):
        row = f"| {i + 1} | {fm:.3f} | {f:.3f} | {100 * e:+.3f} |"
        if result.mac is not None:
            row += f" {result.mac[i]:.4f} |"
        rows.append(row)
    return "\n".join(rows)

"""Least-squares fit of the analytical backbone curve to resonance (jump) points: kn and delta.

Objective (docs/backbone.md), over x = (ln kn, ln delta)::

    J(x) = sum_i (w_i (f_BC(X_i; kn, delta) - f_i) / f_i)^2

where f_BC(X; kn, delta) is the backbone frequency at first-harmonic amplitude X of the point's
channel (:class:`~.objective.BackboneModel`) and w_i the point's weight (1 by default).
Levenberg-Marquardt from one or many starts (:mod:`.starts`); the multi-start phase runs on the
cheap equal-hinge DFA, the winner is polished on the consistent backbone. Intervals:
:mod:`.uncertainty`.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize

from ..backbone import amplitude_grid, backbone_method
from ..model import FreeplaySystem
from ..progress import progress_bar
from ..signal import BackbonePoints
from .fitting_points import FittingPoints
from .objective import BackboneModel
from .starts import count_resonances, plausible_first, resolve_start
from .uncertainty import bootstrap_intervals, jacobian_intervals

__all__ = ["FitResult", "fit_backbone"]

# curve nodes per decade of kn of the multi-start's scouting model (objective.py): its optima only
# choose the start that the accurate model polishes, and its 25 starts span five decades
SCOUT_KN_NODES = 32


@dataclass(frozen=True)
class FitResult:
    """Identified (kn, delta) with uncertainty and diagnostics.

    Attributes
    ----------
    kn : float [N m/rad]
    delta : float [rad]
    kn_ci95, delta_ci95 : (float, float)
        95 % intervals from the Jacobian (Gauss-Newton), in the parameter's units.
    kn_ci95_bootstrap, delta_ci95_bootstrap : (float, float) or None
        95 % percentile intervals from a bootstrap over points (if requested).
    residuals : ndarray, shape (p,) [-]
        Relative frequency residual (f_BC - f) / f of each point at the optimum.
    residual_rms : float [-]
    n_points : int
    backbone : str
        "dfa" or "hb".
    init : str
        "multistart", "given" or "inverse".
    start : (float, float)
        Starting (kn, delta) of the winning run.
    n_evaluations : int
        Objective evaluations over all starts (the cost measure of the comparison studies).
    runtime_s : float [s]
    success : bool
    message : str
    starts : list of dict
        Every start's outcome (start, kn, delta, cost).
    kn_ci95_by_run, delta_ci95_by_run : (float, float) or None
        The Jacobian intervals with each run's points taken as one observation
        (:func:`.uncertainty.jacobian_intervals` with ``groups``): the points of one run share
        its jump, so their residuals are not independent. None when the points have no runs.
    jacobian : ndarray, shape (p, 2) or None [-]
        d (weighted residuals) / d (ln kn, ln delta) at the optimum, for intervals from other
        residuals at the same points (:func:`freeplayid.replay.replayed_intervals`).
    weights : ndarray, shape (p,) or None [-]
        The points' weights (all 1 when the fit was unweighted).
    """

    kn: float
    delta: float
    kn_ci95: tuple
    delta_ci95: tuple
    residuals: np.ndarray
    residual_rms: float
    n_points: int
    backbone: str
    init: str
    start: tuple
    n_evaluations: int
    runtime_s: float
    success: bool
    message: str
    kn_ci95_bootstrap: tuple | None = None
    delta_ci95_bootstrap: tuple | None = None
    starts: list = field(default_factory=list)
    kn_ci95_by_run: tuple | None = None
    delta_ci95_by_run: tuple | None = None
    jacobian: np.ndarray | None = None
    weights: np.ndarray | None = None


def _as_fitting_points(points) -> FittingPoints:
    """``points`` as FittingPoints: itself, or the used points of a BackbonePoints."""
    if isinstance(points, FittingPoints):
        return points
    if isinstance(points, BackbonePoints):
        return FittingPoints.from_extraction(points)
    raise TypeError(
        "`points` must be a freeplayid.fit.FittingPoints or a freeplayid.signal.BackbonePoints "
        f"(build one with FittingPoints.from_records(records)), got {type(points).__name__}"
    )


class _Objective:
    """The weighted relative frequency residuals of the points, counting its evaluations."""

    def __init__(self, points: FittingPoints, cidx, weights):
        self.amp, self.f, self.cidx, self.w = points.amplitude_m, points.f_hz, cidx, weights
        self.n = 0

    def residual(self, model: BackboneModel, pick=slice(None)):
        def r(x):
            self.n += 1
            with np.errstate(over="ignore"):  # a start running off: kn = inf, ValueError below
                kn, delta = np.exp(x)
            f = self.f[pick]
            return self.w[pick] * (model.frequency(self.amp[pick], self.cidx[pick], kn, delta)
                                   - f) / f
        return r

    def solve(self, model: BackboneModel, x0):
        return scipy.optimize.least_squares(self.residual(model), x0, method="lm", x_scale=1.0,
                                            xtol=1e-12, ftol=1e-12, diff_step=1e-7, max_nfev=400)


def _weights(weights, p: int) -> np.ndarray:
    w = np.ones(p) if weights is None else np.asarray(weights, dtype=float).reshape(-1)
    if w.size != p or not np.all(np.isfinite(w) & (w > 0)):
        raise ValueError(f"`weights` must be {p} finite numbers > 0 (one per point), "
                         f"got {np.asarray(weights).tolist()!r}")
    return w


def _best_start(obj: _Objective, starts, system, ch, mode, dfa_model, points,
                progress: bool = False):
    """(cost, solution, start) of every start that converged, sorted by cost, and the winner.

    With several starts (and hinges) the starts run on the cheap equal-hinge DFA (one
    eigen-batch per curve, 200 points); the winner is the most plausible low-cost optimum
    (:func:`.starts.plausible_first`), polished on the consistent (unequal-hinge) DFA.
    """
    scout = dfa_model
    if len(starts) > 1 and system.n_hinges > 1:
        scout = BackboneModel(system, ch, backbone="dfa", mode=mode, equal_hinges=True,
                              s=amplitude_grid(200, s_min=1.0005, s_max=2000.0),
                              kn_nodes=SCOUT_KN_NODES)
    runs = []
    bar = progress_bar(starts, desc="fitting the backbone", unit="start",
                       show=progress and len(starts) > 1, leave=False, delay=2.0)
    for k0, d0 in bar:
        try:
            sol = obj.solve(scout, np.log([k0, d0]))
        except ValueError:  # a start that runs off to kn or delta = inf/0 is a lost start
            continue
        runs.append((2 * sol.cost, sol, (k0, d0)))
    if not runs:
        raise ValueError(f"every start of the fit diverged (starts: {starts})")
    runs.sort(key=lambda r: r[0])
    _, sol, start = plausible_first(runs, points, dfa_model) if len(runs) > 1 else runs[0]
    if scout is not dfa_model:
        sol = obj.solve(dfa_model, sol.x)
    return runs, sol, start


def fit_backbone(
    points: FittingPoints,
    system: FreeplaySystem,
    *,
    init: tuple[float, float] | Sequence[tuple[float, float]] | None = None,
    init_label: str | None = None,
    backbone: str = "dfa",
    mode: int = 0,
    n_bootstrap: int = 0,
    seed: int = 0,
    weights=None,
    progress: bool = False,
) -> FitResult:
    """Identify (kn, delta) by fitting the backbone curve of ``system`` to resonance points.

    Parameters
    ----------
    points : FittingPoints or freeplayid.signal.BackbonePoints
        Fitting points: channel (DOF name), first-harmonic displacement amplitude [m] (relative
        to the base), frequency [Hz]. A BackbonePoints gives its used points
        (:meth:`FittingPoints.from_extraction`, channel names taken as DOF names).
    system : FreeplaySystem
        The linear model (M, K, hinges).
    init : (kn, delta), list of them, or an inverse model, optional
        Start(s) (:func:`.starts.resolve_start`). Default: the multi-start baseline
        (:class:`MultiStart`: 25 starts spanning kn in [1e2, 1e7] N m/rad and delta in
        [1e-4, 1e-2] rad); the best optimum wins. An object with
        ``predict_points(points) -> (kn, delta, ...)`` (a
        :class:`freeplayid.inverse.InverseModel`) gives one start from the points themselves.
    init_label : str, optional
        What produced ``init`` ("inverse", "given"); recorded in the result.
    backbone : str
        A key of :data:`freeplayid.backbone.BACKBONE_METHODS`; "hb" refines from the DFA
        optimum (harmonic balance is ~100x dearer).
    mode : int
        Backbone mode (0: the lowest).
    n_bootstrap, seed : int
        Bootstrap resamples of the points for percentile intervals (0: none) and their seed.
    weights : array_like, shape (p,), optional
        Weight of each point's residual (weighted least squares: 1 / each residual's standard
        deviation, e.g. from the amplitude noise); default all 1. The intervals come from the
        weighted residuals; ``FitResult.residuals`` are the unweighted ones.
    progress : bool
        Progress bars over the starts and the bootstrap's resamples, shown when they last
        over 2 s.

    Returns
    -------
    FitResult

    Raises
    ------
    TypeError
        ``points`` or ``system`` of the wrong type.
    ValueError
        Unknown ``backbone`` (the valid names listed), channels that are not DOFs of the model,
        bad ``init``, or every start diverged.
    """
    t0 = time.perf_counter()
    if not isinstance(system, FreeplaySystem):
        raise TypeError(f"`system` must be a FreeplaySystem, got {type(system).__name__}")
    backbone_method(backbone, argument="backbone")
    points = _as_fitting_points(points)
    ch = np.asarray(points.channel, dtype=str)
    w = _weights(weights, len(points))
    if count_resonances(points.f_hz) < 2:
        warnings.warn(
            f"fit_backbone: the {len(points)} points lie at one resonance "
            f"({np.median(points.f_hz):.3f} Hz): one (amplitude, frequency) pair does not fix "
            "both kn and delta; the result depends on the start. Add runs at other levels.",
            stacklevel=2,
        )
    start = resolve_start(init, points, label=init_label)
    dfa_model = BackboneModel(system, ch, backbone="dfa", mode=mode)
    obj = _Objective(points, np.array([dfa_model.channels.index(c) for c in ch]), w)
    runs, sol, best = _best_start(obj, start.points, system, ch, mode, dfa_model, points,
                                  progress)
    active = dfa_model
    if backbone != "dfa":  # another method refines from the DFA optimum
        active = BackboneModel(system, ch, backbone=backbone, mode=mode)
        sol = obj.solve(active, sol.x)
    return _result(obj, sol, points, active, start.label, best, runs, n_bootstrap, seed, t0,
                   progress)


def _result(obj: _Objective, sol, points, active, label, best, runs, n_bootstrap, seed,
            t0, progress: bool = False) -> FitResult:
    """The :class:`FitResult` at the optimum ``sol``: intervals (Jacobian, by run, bootstrap)."""
    res, w = sol.fun, obj.w
    kn_ci, delta_ci = jacobian_intervals(sol.x, res, sol.jac)
    kn_ci_run = delta_ci_run = None
    if points.run is not None:
        kn_ci_run, delta_ci_run = jacobian_intervals(sol.x, res, sol.jac, groups=points.run)
    kn, delta = np.exp(sol.x)
    boot_kn = boot_delta = None
    if n_bootstrap > 0:
        boot_kn, boot_delta = bootstrap_intervals(
            lambda x, pick: obj.residual(active, pick)(x), sol.x, len(points),
            n_bootstrap=n_bootstrap, seed=seed, progress=progress)
    with np.errstate(over="ignore"):  # a start that ran off to ln kn > 709 is recorded as inf
        tried = [{"start": s_, "kn": float(np.exp(r.x[0])), "delta": float(np.exp(r.x[1])),
                  "cost": c} for c, r, s_ in runs]
    return FitResult(
        kn=float(kn), delta=float(delta), kn_ci95=kn_ci, delta_ci95=delta_ci,
        residuals=res / w, residual_rms=float(np.sqrt(np.mean((res / w) ** 2))),
        n_points=len(points), backbone=active.backbone, init=label,
        start=tuple(float(v) for v in best), n_evaluations=obj.n,
        runtime_s=time.perf_counter() - t0, success=bool(sol.success), message=str(sol.message),
        kn_ci95_bootstrap=boot_kn, delta_ci95_bootstrap=boot_delta,
        kn_ci95_by_run=kn_ci_run, delta_ci95_by_run=delta_ci_run,
        starts=tried, jacobian=np.asarray(sol.jac, float), weights=np.asarray(w, float),
    )

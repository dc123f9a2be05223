"""Studies on held-out simulated cases: the network alone and the fits it is compared with.

Methods compared on the same cases (``METHODS``):

- ``network``: the inverse model's estimate, no fit;
- ``network+fit``: one backbone fit started from the network's estimate;
- ``single-start``: one fit started from a fixed guess (the centre of the priors);
- ``multi-start``: the pure-fitting baseline, a grid of starts (the best optimum wins);
- ``network+corrected``: the bias-corrected fit (``identify(...)`` with its default replay,
  docs/identify.md section 3b) started from the network's estimate;
- ``multi-start+corrected``: the bias-corrected fit started from the multi-start grid.

The two corrected methods replay the test by simulation, so they need each case's records, not
only its points: :func:`corrected_cases` rebuilds them from the bank
(:func:`freeplayid.studies.rebuild_case`) and runs on a chosen subset of the cases (each costs
several simulated replays). Their cost is the plain fit's evaluations plus every replay's refit.

Errors are relative, ``estimate / truth - 1``; a case succeeds when ``|delta error| <
success_delta`` and ``|kn error| < success_kn``. The cost of a fit is its number of objective
(residual-vector) evaluations, finite-difference Jacobians included.

:func:`network_metrics` summarises the network alone on held-out cases (errors per axis value,
share within bounds, calibration of its uncertainty).
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..fit import FitOptions
from ..identification import identify
from ..inverse.pointsets import PointSets
from ..model.system import FreeplaySystem
from ..progress import progress_bar, warnings_wanted
from ..replay import Replay
from ..signal import Extraction

if TYPE_CHECKING:
    from .bank import SweepBank
    from .cases import CaseSpec

__all__ = ["METHODS", "CORRECTED", "fit_cases", "corrected_cases", "summarise", "network_rows",
           "network_metrics"]

CORRECTED = ("network+corrected", "multi-start+corrected")
METHODS = ("network", "network+fit", "single-start", "multi-start", *CORRECTED)


def network_rows(ps: PointSets, kn, delta, *, wall_s: float) -> list[dict]:
    """Per-case rows of the network-alone method (``wall_s``: total prediction time [s])."""
    per = wall_s / max(ps.n_cases, 1)
    return [_row(ps, i, "network", kn[i], delta[i], 0, per, True) for i in range(ps.n_cases)]


def _row(ps, i, method, kn, delta, n_eval, wall, ok) -> dict:
    return {
        "case": int(i), "method": method,
        "axis_value": float(ps.meta["axis_value"][i]) if "axis_value" in ps.meta else np.nan,
        "noise_g": float(ps.meta["noise_g"][i]) if "noise_g" in ps.meta else np.nan,
        "kn_true": float(ps.kn[i]), "delta_true": float(ps.delta[i]),
        "kn": float(kn), "delta": float(delta),
        "kn_error": float(kn / ps.kn[i] - 1), "delta_error": float(delta / ps.delta[i] - 1),
        "n_evaluations": int(n_eval), "wall_s": float(wall), "converged": bool(ok),
        "n_points": int(ps.n_points[i]),
    }


def _fit_one(points, system, init, label, backbone):
    from ..fit import fit_backbone

    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            if not warnings_wanted():  # a case at one resonance: its row says how it went
                warnings.filterwarnings("ignore", message=r"fit_backbone: the \d+ points lie at "
                                        "one resonance")
            r = fit_backbone(points, system, init=init, init_label=label, backbone=backbone)
    except ValueError:  # every start diverged: a failed case, not a failed study
        return np.nan, np.nan, 0, time.perf_counter() - t0, False
    return r.kn, r.delta, r.n_evaluations, time.perf_counter() - t0, r.success


def fit_cases(
    ps: PointSets,
    system: FreeplaySystem,
    *,
    network_estimate: tuple[np.ndarray, np.ndarray] | None,
    single_start: tuple[float, float],
    multistart: Sequence[tuple[float, float]],
    backbone: str = "dfa",
    n_jobs: int = 1,
    progress: bool = True,
) -> list[dict]:
    """Run the fitting methods on every case of ``ps``; one row per (case, method).

    Parameters
    ----------
    network_estimate : (kn (N,), delta (N,)) or None
        Starts of ``network+fit``; None skips that method.
    single_start : (kn [N m/rad], delta [rad])
    multistart : list of (kn, delta)
        The baseline's starts.
    n_jobs : int
        Worker processes (joblib; -1: all cores). The per-fit wall time is measured in the
        worker, so it stays comparable between methods.
    """
    from joblib import Parallel, delayed

    jobs = []
    for i in range(ps.n_cases):
        rec = ps.fitting_points(i)  # FittingPoints of case i
        if network_estimate is not None:
            init = (float(network_estimate[0][i]), float(network_estimate[1][i]))
            jobs.append((i, "network+fit", rec, init, "inverse"))
        jobs.append((i, "single-start", rec, tuple(single_start), "given"))
        jobs.append((i, "multi-start", rec, list(multistart), "multistart"))
    out = Parallel(n_jobs=n_jobs, batch_size=1)(
        delayed(_fit_one)(rec, system, init, label, backbone)
        for _, _, rec, init, label in progress_bar(jobs, desc="fits", unit="fit", show=progress)
    )
    return [_row(ps, i, m, *res) for (i, m, *_), res in zip(jobs, out, strict=True)]


def _corrected_one(dataset, system, init, fit: FitOptions, extraction: Extraction):
    """(kn, delta, evaluations, wall [s], replay converged, replays, verdict, failure, kn_ci95,
    delta_ci95, failed checks) of one case's corrected fit; a case that cannot be identified
    gives NaN estimates and intervals, verdict "failed", the reason and no failed check."""
    t0 = time.perf_counter()
    try:
        # from the network: its estimate starts the plain fit and the replays
        replay = Replay(start="statistic" if init is None else "network")
        res = identify(dataset, system=system, extraction=extraction,
                       fit=dataclasses.replace(fit, init=init), replay=replay, progress=False)
    except ValueError as err:  # IdentificationError, or every start diverged: a failed case
        nan = (np.nan, np.nan)
        return (np.nan, np.nan, 0, time.perf_counter() - t0, False, 0, "failed", str(err), nan,
                nan, "")
    rep = res.replay
    n_eval = res.plain_fit.n_evaluations + sum(it.n_evaluations for it in rep.iterations)
    return (res.kn, res.delta, n_eval, time.perf_counter() - t0, bool(rep.converged),
            len(rep.iterations), res.verdict.status, rep.failure, tuple(res.kn_ci95),
            tuple(res.delta_ci95), ";".join(c.name for c in res.verdict.checks if not c.passed))


def corrected_cases(
    ps: PointSets,
    cases: Sequence[int],
    system: FreeplaySystem,
    *,
    bank: SweepBank,
    spec: CaseSpec,
    network_estimate: tuple[np.ndarray, np.ndarray] | None,
    fit: FitOptions,
    n_jobs: int = 1,
    progress: bool = True,
    base_channel: bool = False,
) -> list[dict]:
    """The bias-corrected fits (``CORRECTED``) on the cases ``cases`` of ``ps``.

    Each case's records are rebuilt (:func:`freeplayid.studies.rebuild_case`) and identified
    by :func:`freeplayid.identify` with the default replay, the sweep hints and the spec's
    extraction: ``network+corrected`` starts its plain fit from the network's estimate,
    ``multi-start+corrected`` from the multi-start grid.

    Parameters
    ----------
    ps : PointSets
        Cases of ``build_cases(bank, spec)`` (or a subset), with ``meta["plan_index"]``.
    cases : sequence of int
        Indices into ``ps``.
    system : FreeplaySystem
        The model the bank was simulated with (the replays use its damping).
    bank : SweepBank
    spec : CaseSpec
    network_estimate : (kn (N,) [N m/rad], delta (N,) [rad]) or None
        The network's estimate of every case of ``ps``; None skips ``network+corrected``.
    fit : FitOptions
        The backbone and the multi-start grid of the plain fits.
    n_jobs : int
        Worker processes (joblib; -1: all cores); the records are rebuilt here, one case ahead
        of the workers, and the wall time is measured in the worker.
    base_channel : bool
        Rebuild the records as a shaker test records them: absolute accelerations with the base
        (control) channel, which the replay is then driven by and whose phase gives the
        quadrature points (:func:`freeplayid.studies.rebuild_case`, ``base_influence``); False
        (default): the relative accelerations the points were extracted from, no base channel.

    Returns
    -------
    list of dict
        One row per (case, method), the keys of :func:`fit_cases`'s rows with ``case`` the
        index into ``ps``, plus ``n_replays`` (simulated replays), ``verdict`` ("ok",
        "suspect", or "failed" when the case could not be identified: NaN estimates, 0
        evaluations), ``failure`` (why it failed, why a replay could not be fitted, or ""),
        ``failed_checks`` (the names of the verdict's failed checks, ";"-joined; "" when ``ok``
        or failed), the answer's 95 % intervals (``kn_ci95_low``, ``kn_ci95_high``,
        ``delta_ci95_low``, ``delta_ci95_high``; NaN when failed) and ``ci_holds`` (both hold
        the truth); ``converged`` says whether the replay loop converged and
        ``n_evaluations`` is the plain fit's objective evaluations plus those of every
        replay's refit.

    Raises
    ------
    ValueError
        ``ps`` has no ``meta["plan_index"]`` (:func:`freeplayid.studies.rebuild_case`).
    """
    from joblib import Parallel, delayed

    from .cases import plan_cases, rebuild_case, require_plan_index

    require_plan_index(bank, spec, ps)
    plan = plan_cases(bank, spec)
    extraction = Extraction(**{**spec.extraction, "use_sweep_hint": True})
    influence = None
    if base_channel:
        if system.base_influence is None:
            raise ValueError("`base_channel`: the model has no `base_influence`, so the records' "
                             "absolute motion is not known")
        influence = system.base_influence[system.dof_index(list(bank.spec.channels))]
    jobs = []
    for i in (int(c) for c in cases):
        if network_estimate is not None:
            init = (float(network_estimate[0][i]), float(network_estimate[1][i]))
            jobs.append((i, "network+corrected", init))
        jobs.append((i, "multi-start+corrected", None))
    out = Parallel(n_jobs=n_jobs, batch_size=1)(
        delayed(_corrected_one)(rebuild_case(bank, spec, ps, i, plan=plan,
                                             base_influence=influence), system, init, fit,
                                extraction)
        for i, _, init in progress_bar(jobs, desc="corrected fits", unit="fit",
                                       show=progress)
    )
    rows = []
    for (i, m, _), (kn, delta, n_eval, wall, conv, n_rep, verdict, why, kci, dci, checks) in zip(
            jobs, out, strict=True):
        row = _row(ps, i, m, kn, delta, n_eval, wall, conv)
        holds = bool(kci[0] <= ps.kn[i] <= kci[1] and dci[0] <= ps.delta[i] <= dci[1])
        row.update(n_replays=int(n_rep), verdict=str(verdict), failure=str(why),
                   failed_checks=str(checks),
                   kn_ci95_low=float(kci[0]), kn_ci95_high=float(kci[1]),
                   delta_ci95_low=float(dci[0]), delta_ci95_high=float(dci[1]), ci_holds=holds)
        rows.append(row)
    return rows


def summarise(
    rows: Sequence[dict],
    *,
    success_delta: float = 0.01,
    success_kn: float = 0.02,
) -> list[dict]:
    """Per (axis value, method): error distributions, success rate, cost.

    Returns
    -------
    list of dict
        ``axis_value``, ``method``, ``n``, ``delta_err_median``, ``delta_err_p95``,
        ``kn_err_median``, ``kn_err_p95`` (absolute relative errors), ``success_rate``,
        ``evaluations_mean``, ``wall_s_mean``.
    """
    out = []
    values = sorted({r["axis_value"] for r in rows})
    methods = [m for m in METHODS if any(r["method"] == m for r in rows)]
    for v in values:
        for m in methods:
            sel = [r for r in rows if r["axis_value"] == v and r["method"] == m]
            if not sel:
                continue
            de = np.abs([r["delta_error"] for r in sel])
            ke = np.abs([r["kn_error"] for r in sel])
            de = np.where(np.isfinite(de), de, np.inf)
            ke = np.where(np.isfinite(ke), ke, np.inf)
            ok = (de < success_delta) & (ke < success_kn)
            out.append({
                "axis_value": v, "method": m, "n": len(sel),
                "delta_err_median": float(np.median(de)),
                # "higher": a failed fit (inf) stays visible instead of turning into NaN
                "delta_err_p95": float(np.percentile(de, 95, method="higher")),
                "kn_err_median": float(np.median(ke)),
                "kn_err_p95": float(np.percentile(ke, 95, method="higher")),
                "success_rate": float(ok.mean()),
                "evaluations_mean": float(np.mean([r["n_evaluations"] for r in sel])),
                "wall_s_mean": float(np.mean([r["wall_s"] for r in sel])),
            })
    return out


def network_metrics(test: PointSets, pred, *, bounds: dict) -> dict:
    """Network-alone errors on ``test`` per axis value and overall (absolute relative errors).

    Parameters
    ----------
    test : PointSets
        Cases with true ``kn``, ``delta`` and ``meta["axis_value"]``.
    pred : InversePrediction
        The network's ``kn`` (N,) [N m/rad], ``delta`` (N,) [rad] and their ``log_kn_std``,
        ``log_delta_std`` (N,) (ln scale).
    bounds : dict
        ``{"delta": ..., "kn": ...}``: a case is within bounds when both absolute relative
        errors are below them.

    Returns
    -------
    dict
        ``overall`` and ``per_value`` (keyed by ``f"{value:g}"``) blocks of ``n``,
        ``delta_err_median``, ``delta_err_p90``, ``kn_err_median``, ``kn_err_p90``,
        ``within_bounds``, ``delta_within_2sigma``, ``kn_within_2sigma``; and ``bounds``.
    """
    de = np.abs(pred.delta / test.delta - 1)
    ke = np.abs(pred.kn / test.kn - 1)
    inside = (de < bounds["delta"]) & (ke < bounds["kn"])
    # calibration: share of cases whose truth lies within the predicted +-2 sigma (ln scale);
    # 95 % for a calibrated Gaussian
    z_d = np.abs(np.log(pred.delta / test.delta)) / pred.log_delta_std
    z_k = np.abs(np.log(pred.kn / test.kn)) / pred.log_kn_std

    def block(sel):
        return {
            "n": int(sel.sum()),
            "delta_err_median": float(np.median(de[sel])),
            "delta_err_p90": float(np.percentile(de[sel], 90)),
            "kn_err_median": float(np.median(ke[sel])),
            "kn_err_p90": float(np.percentile(ke[sel], 90)),
            "within_bounds": float(inside[sel].mean()),
            "delta_within_2sigma": float(np.mean(z_d[sel] < 2)),
            "kn_within_2sigma": float(np.mean(z_k[sel] < 2)),
        }

    axis = test.meta["axis_value"]
    return {
        "overall": block(np.ones(test.n_cases, bool)),
        "per_value": {f"{v:g}": block(axis == v) for v in np.unique(axis)},
        "bounds": dict(bounds),
    }

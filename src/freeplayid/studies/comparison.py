"""A comparison study as one library function: :func:`compare_methods` -> :class:`Comparison`.

On held-out simulated cases (kn values never seen in training), per value of the ablation axis
(noise level or clearance): the network alone, the fit started from the network's estimate, a
single-start fit and the multi-start baseline; on ``corrected_per_value`` of the cases per
value also the bias-corrected fit (replay) started from the network and from the multi-start
grid, their records rebuilt from the bank (:mod:`.compare`).
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass

import numpy as np

from ..fit import FitOptions
from ..inverse.pointsets import PointSets
from ..model.system import FreeplaySystem
from .bank import SweepBank
from .cases import CaseSpec
from .methods import CORRECTED, METHODS, corrected_cases, fit_cases, network_rows, summarise

__all__ = ["Comparison", "compare_methods", "pick_cases"]


def pick_cases(test: PointSets, per_value: int) -> np.ndarray:
    """Up to ``per_value`` test cases per axis value, spread over the kn values."""
    axis = test.meta["axis_value"]
    keep = []
    for v in np.unique(axis):
        idx = np.flatnonzero(axis == v)
        take = np.unique(np.linspace(0, idx.size - 1, min(per_value, idx.size)).round().astype(int))
        keep.extend(idx[take].tolist())
    return np.array(sorted(keep), dtype=int)


def _mean(values) -> float:
    """Mean of ``values``; NaN (no warning) when there are none."""
    v = [float(x) for x in values]
    return float(np.mean(v)) if v else float("nan")


def _check_counts(rows) -> dict[str, int]:
    """How often each of the verdict's checks failed in ``rows`` (their ``failed_checks``)."""
    counts = Counter(name for r in rows
                     for name in str(r.get("failed_checks", "")).split(";") if name)
    return dict(sorted(counts.items()))


@dataclass(frozen=True)
class Comparison:
    """The outcome of :func:`compare_methods`.

    Attributes
    ----------
    axis : str
        The ablation axis ("noise_g" or "delta").
    rows : list of dict
        One per (case, method) (:func:`.compare.fit_cases`, :func:`.compare.corrected_cases`).
    summary : list of dict
        Per (axis value, method) over every compared case (:func:`.compare.summarise`).
    corrected : ndarray of int
        The cases (indices into the compared test cases) that also got the corrected fits.
    corrected_summary : list of dict
        Every method on those cases alone (empty without corrected fits).
    corrected_plan_index : list of int
        Those cases' index in the case plan (:func:`.cases.plan_cases`: their records).
    single_start : (float, float)
        The single-start fit's start (kn [N m/rad], delta [rad]).
    n_multistart : int
        Starts of the multi-start grid.
    network_within_bounds : float [-]
        Share of the cases the network alone puts within ``network_bounds``.
    bounds : dict
        Success bounds {"delta", "kn"} (relative errors).
    base_channel : bool
        The corrected fits ran on absolute records with the base channel (else on the relative
        records the points came from).
    """

    axis: str
    rows: list
    summary: list
    corrected: np.ndarray
    corrected_summary: list
    corrected_plan_index: list
    single_start: tuple
    n_multistart: int
    network_within_bounds: float
    bounds: dict
    base_channel: bool = False

    def total(self, method: str, key: str, corrected: bool = False) -> float:
        """Mean of ``key`` over the axis values of ``method`` (the corrected cases' summary)."""
        table = self.corrected_summary if corrected else self.summary
        return float(np.mean([r[key] for r in table if r["method"] == method]))

    def metrics(self) -> dict:
        """The acceptance figures and both summaries (``metrics.json`` of the compare task)."""
        out = {
            "axis": self.axis, "n_cases": len({r["case"] for r in self.rows}),
            "single_start": list(self.single_start), "n_multistart": self.n_multistart,
            "summary": self.summary, "network_within_bounds": self.network_within_bounds,
            "success_network_fit": self.total("network+fit", "success_rate"),
            "success_multistart": self.total("multi-start", "success_rate"),
            "success_single_start": self.total("single-start", "success_rate"),
            "evaluation_ratio_multistart_to_network_fit":
                self.total("multi-start", "evaluations_mean")
                / self.total("network+fit", "evaluations_mean"),
        }
        if self.corrected_summary:
            out["corrected"] = self._corrected_metrics()
        return out

    def _corrected_metrics(self) -> dict:
        corr = [r for r in self.rows if r["method"] in CORRECTED]
        ran = [r for r in corr if r["verdict"] != "failed"]  # a failed case has no replay
        by = {m: [r for r in ran if r["method"] == m] for m in CORRECTED}
        return {
            "base_channel": self.base_channel,  # their records: absolute with the base channel
            "cases": self.corrected.tolist(),  # indices into the compared test cases
            "plan_index": list(self.corrected_plan_index),
            "summary": self.corrected_summary,  # every method on these cases
            **{f"success_{m}": self.total(m, "success_rate", True) for m in METHODS},
            **{f"evaluations_{m}": self.total(m, "evaluations_mean", True) for m in METHODS},
            "replays_mean": {m: _mean(r["n_replays"] for r in by[m]) for m in CORRECTED},
            "converged": {m: _mean(r["converged"] for r in by[m]) for m in CORRECTED},
            "suspect": {m: int(sum(r["verdict"] == "suspect" for r in by[m]))
                        for m in CORRECTED},
            "failed": {m: int(sum(r["verdict"] == "failed" for r in corr if r["method"] == m))
                       for m in CORRECTED},
            # both intervals hold the truth; `ok` outside the bounds (|delta|, |kn| errors), and
            # of those the ones whose intervals hold the truth
            "ci_holds": {m: _mean(r["ci_holds"] for r in by[m]) for m in CORRECTED},
            "ok_outside": {m: int(sum(self._ok_outside(r) for r in by[m])) for m in CORRECTED},
            "ok_outside_ci_holds": {m: int(sum(self._ok_outside(r) and r["ci_holds"]
                                               for r in by[m])) for m in CORRECTED},
            # `suspect` on an answer inside the bounds: how often each check failed there
            "suspect_inside_checks": {m: _check_counts(r for r in by[m] if self._suspect_inside(r))
                                      for m in CORRECTED},
        }

    def _inside(self, row: dict) -> bool:
        """An answer inside the success bounds (|delta| and |kn| errors)."""
        return (abs(row["delta_error"]) < self.bounds["delta"]
                and abs(row["kn_error"]) < self.bounds["kn"])

    def _suspect_inside(self, row: dict) -> bool:
        """A `suspect` verdict on an answer inside the success bounds."""
        return row["verdict"] == "suspect" and self._inside(row)

    def _ok_outside(self, row: dict) -> bool:
        """An `ok` verdict on an answer outside the success bounds."""
        return row["verdict"] == "ok" and not self._inside(row)

    def markdown(self) -> str:
        """The summary table, and every method on the corrected cases alone."""
        table = _markdown(self.summary, self.axis, self.bounds)
        if self.corrected_summary:
            records = ("absolute accelerations with the base channel (quadrature points)"
                       if self.base_channel else
                       "the relative accelerations the points came from, no base channel")
            table += (f"\n## The {self.corrected.size} cases with corrected fits, every method\n\n"
                      "The corrected fits run on these cases only, on " + records + "; the plain "
                      "methods on the same cases, for a like-for-like comparison.\n\n"
                      + _markdown(self.corrected_summary, self.axis, self.bounds, lead=False))
        return table


def _markdown(summary: list[dict], axis: str, bounds: dict, *, lead: bool = True) -> str:
    unit = "g" if axis == "noise_g" else "mrad"
    scale = 1.0 if axis == "noise_g" else 1e3
    head = (f"| {axis.replace('_g', '')} [{unit}] | method | cases | δ err median / p95 [%] | "
            f"kn err median / p95 [%] | success [%] | evaluations | wall [s] |")
    lines = [
        f"Success: |δ error| < {100 * bounds['delta']:g} % and |kn error| < "
        f"{100 * bounds['kn']:g} %. Errors are absolute relative errors on held-out kn values; "
        "evaluations count objective (residual vector) calls, Jacobians included (a corrected "
        "fit: its plain fit's and every replay's refit).", "",
    ] if lead else []
    lines += [head, "|---|---|---|---|---|---|---|---|"]
    for r in summary:
        lines.append(
            f"| {scale * r['axis_value']:g} | {r['method']} | {r['n']} | "
            f"{100 * r['delta_err_median']:.3g} / {100 * r['delta_err_p95']:.3g} | "
            f"{100 * r['kn_err_median']:.3g} / {100 * r['kn_err_p95']:.3g} | "
            f"{100 * r['success_rate']:.0f} | {r['evaluations_mean']:.0f} | "
            f"{r['wall_s_mean']:.3f} |"
        )
    return "\n".join(lines) + "\n"


def compare_methods(test: PointSets, system: FreeplaySystem, *, network, axis: str,
                    single_start: tuple, fit: FitOptions, bounds: dict, network_bounds: dict,
                    corrected_per_value: int = 0, bank: SweepBank | None = None,
                    case_spec: CaseSpec | None = None, n_jobs: int = 1,
                    progress: bool = True, base_channel: bool = False) -> Comparison:
    """Every method of :data:`.compare.METHODS` on the held-out cases ``test``.

    Parameters
    ----------
    test : PointSets
        The compared cases (with ``meta["axis_value"]``; ``meta["plan_index"]`` for the
        corrected fits).
    system : FreeplaySystem
    network : InverseModel
        The trained network (its estimates and the network-started fits).
    axis : str
        The ablation axis.
    single_start : (float, float)
        The single-start fit's start.
    fit : FitOptions
        The fits' backbone and multi-start grid.
    bounds, network_bounds : dict
        {"delta", "kn"}: success bounds of the fits and of the network alone.
    corrected_per_value : int
        Cases per axis value that also get the corrected fits (0: none); they need the
        ``bank`` and ``case_spec`` the cases were drawn with.
    n_jobs : int
        Worker processes of the fits (-1: all cores).
    base_channel : bool
        The corrected fits on absolute records with the base channel, as a shaker test records
        them (:func:`.methods.corrected_cases`); False: on the relative records.
    """
    t1 = time.perf_counter()
    pred = network.predict(test)
    t_net = time.perf_counter() - t1
    starts = fit.multistart.starts()
    rows = network_rows(test, pred.kn, pred.delta, wall_s=t_net)
    rows += fit_cases(test, system, network_estimate=(pred.kn, pred.delta),
                      single_start=single_start, multistart=starts, backbone=fit.backbone,
                      n_jobs=n_jobs, progress=progress)
    picked = pick_cases(test, corrected_per_value) if corrected_per_value else np.zeros(0, int)
    if picked.size:
        rows += corrected_cases(test, picked, system, bank=bank, spec=case_spec,
                                network_estimate=(pred.kn, pred.delta), fit=fit,
                                n_jobs=n_jobs, progress=progress, base_channel=base_channel)
    summary = summarise(rows, success_delta=bounds["delta"], success_kn=bounds["kn"])
    on_picked = set(picked.tolist())
    sub_summary = summarise([r for r in rows if r["case"] in on_picked],
                            success_delta=bounds["delta"], success_kn=bounds["kn"])
    de = np.abs(pred.delta / test.delta - 1)
    ke = np.abs(pred.kn / test.kn - 1)
    return Comparison(
        axis=axis, rows=rows, summary=summary, corrected=picked, corrected_summary=sub_summary,
        corrected_plan_index=[int(test.meta["plan_index"][i]) for i in picked],
        single_start=tuple(single_start), n_multistart=len(starts),
        network_within_bounds=float(np.mean((de < network_bounds["delta"])
                                            & (ke < network_bounds["kn"]))),
        bounds=dict(bounds), base_channel=bool(base_channel and picked.size))

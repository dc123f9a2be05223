"""An :class:`Identification` back from its ``identification.json``: :func:`read_identification`.

The file holds the result, not everything behind it, so the object read back has the fields the
file holds and None (or NaN) for the rest:

- as written: ``kn``, ``delta``, ``kn_ci95``, ``delta_ci95``, ``runtime_s``, ``rejected_runs``,
  ``inverse_estimate``, ``truth``, ``interval_source``, ``mode``, ``dataset`` (files written
  before these two held them: 0 and ``{}``), the ``verdict`` (every check), the record checks'
  findings (``records``, without their data set) and the zero-clearance check
  (``validation``, without the model modes' pairing);
- ``points``: every point (run, channel, f_hz, amplitude_m, used, reason) without its
  amplitude curve (``points.curves`` is empty) nor its time and SNR (NaN); ``dofs`` from the
  points' DOF names;
- ``plain_fit``: the plain fit's estimate (``replay.kn_fit``, ``replay.delta_fit`` with the
  replay, else the result's), ``residual_rms``, ``backbone``, ``init``, bootstrap intervals, the
  residuals of the used points (NaN in files written before they were recorded) and
  ``n_evaluations``; its Jacobian intervals and start are not in the file (NaN);
- not in the file: ``system`` (the linear model), ``replay`` (its record stays in the raw
  dict: ``read_identification(path, raw=True)["replay"]``) and ``model_error``: None.

``summary()``, ``repr``, ``points_table()``, ``to_dataframe()`` and ``plot("residuals")`` work
on it; the backbone and replay figures need what the file does not hold.
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..fit import FitResult
from ..io.result_file import read_result_record
from ..model import ModeValidation
from ..quality import Finding, RecordReport
from ..signal import BackbonePoint, BackbonePoints
from .result import Identification
from .verdict import Check, Verdict

__all__ = ["identification_from_record", "read_identification"]

_NAN2 = (math.nan, math.nan)


def read_identification(path: str | os.PathLike, *, raw: bool = False):
    """Read and check an ``identification.json`` (a file or the run folder holding it).

    Parameters
    ----------
    path : path
        The file, or the run folder (then ``folder/identification.json``).
    raw : bool
        Return the record as written (a dict, ``null`` numbers as None) instead.

    Returns
    -------
    Identification or dict
        The result with the fields the file holds (module docstring), or with ``raw`` the dict.

    Raises
    ------
    freeplayid.io.ResultFileError
        Naming the file and the field: not JSON, a missing field, a non-positive kn or delta,
        an interval that is not [lo, hi], a point or a finding without its fields.
    """
    record = read_result_record(path)
    return record if raw else identification_from_record(record)


def _num(v) -> float:
    return math.nan if v is None else float(v)


def _pair(v) -> tuple | None:
    return None if v is None else (_num(v[0]), _num(v[1]))


def identification_from_record(record: dict) -> Identification:
    """An :class:`Identification` from a checked ``identification.json`` record (see
    :func:`read_identification` for what it holds)."""
    points = tuple(BackbonePoint(run=p["run"], channel=p["channel"], f_hz=_num(p["f_hz"]),
                                 amplitude_m=_num(p["amplitude_m"]), used=bool(p["used"]),
                                 reason=p["reason"] or "", time_s=math.nan, snr_db=math.nan,
                                 noise_db=_num(p.get("noise_db")))
                   for p in record["points"])
    rejected = tuple((r["run"], r["reason"]) for r in record["rejected_runs"])
    dataset = dict(record.get("dataset") or {})
    rep = record.get("replay")
    if rep and not dataset.get("levels"):  # a file written before the data set was recorded
        dataset["levels"] = {run: v["level_g"] for run, v in (rep.get("levels") or {}).items()}
    return Identification(
        kn=float(record["kn"]), delta=float(record["delta"]),
        kn_ci95=_pair(record["kn_ci95"]), delta_ci95=_pair(record["delta_ci95"]),
        plain_fit=_plain_fit(record, points), runtime_s=_num(record["runtime_s"]),
        points=BackbonePoints(points=points, rejected_runs=tuple(dict.fromkeys(
            r for r, _ in rejected)), curves=(), quantity=dataset.get("quantity") or "",
            method=""),
        dofs={p["channel"]: p.get("dof") for p in record["points"]}, rejected_runs=rejected,
        system=None, mode=int(record.get("mode", 0)),
        inverse_estimate=record.get("inverse_estimate"), truth=record.get("truth"),
        dataset=dataset, verdict=_verdict(record), replay=None,
        interval_source=record.get("interval_source", "Jacobian"),
        validation=_validation(record.get("validation")), model_error=None,
        records=_records(record.get("records")),
    )


def _plain_fit(record: dict, points: tuple) -> FitResult:
    """The plain fit as far as the file holds it (module docstring)."""
    rep = record.get("replay") or {}
    used = [p for p in record["points"] if p["used"]]
    residuals = np.array([_num(p.get("residual")) for p in used], dtype=float)
    return FitResult(
        kn=float(rep.get("kn_fit", record["kn"])), delta=float(rep.get("delta_fit",
                                                                       record["delta"])),
        kn_ci95=_NAN2, delta_ci95=_NAN2, residuals=residuals,
        residual_rms=_num(record["residual_rms"]), n_points=len(used),
        backbone=record["backbone"], init=record["init"], start=_NAN2,
        n_evaluations=record.get("n_evaluations"), runtime_s=math.nan, success=True,
        message="read from identification.json",
        kn_ci95_bootstrap=_pair(record.get("kn_ci95_bootstrap")),
        delta_ci95_bootstrap=_pair(record.get("delta_ci95_bootstrap")))


def _verdict(record: dict) -> Verdict | None:
    if "verdict" not in record:
        return None
    checks = tuple(Check(c["name"], bool(c["passed"]), c["message"],
                         None if c.get("value") is None else float(c["value"]))
                   for c in record.get("checks") or ())
    return Verdict(record["verdict"], checks)


def _validation(v: dict | None) -> ModeValidation | None:
    if v is None:
        return None
    arrays = {k: np.asarray(v[k], dtype=float) for k in ("reference_hz", "model_hz",
                                                         "error_hz", "mac")}
    return ModeValidation(**arrays, pairing=np.full(arrays["mac"].size, -1),
                          passed=bool(v["passed"]))


def _records(r: dict | None) -> RecordReport | None:
    if r is None:
        return None
    findings = tuple(Finding(check=f["check"], run=f["run"], channel=f["channel"],
                             size=_num(f["size"]), unit=f["unit"], action=f["action"],
                             message=f["message"]) for f in r["findings"])
    return RecordReport(findings=findings, dataset=None, skipped=dict(r.get("skipped") or {}))

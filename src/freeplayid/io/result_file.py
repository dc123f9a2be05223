"""``identification.json``: the result of one identification (the contract of docs/identify.md).

The file holds plain JSON: ``kn`` [N m/rad], ``delta`` [rad], their 95 % intervals ``kn_ci95`` and
``delta_ci95`` ([lo, hi]), the fitting ``points`` (run, channel, dof, f_hz, amplitude_m, used,
reason), ``rejected_runs`` (run, reason), ``residual_rms``, ``backbone``, ``init`` and
``runtime_s``; optional keys (``mode``, ``n_evaluations``, the ``dataset`` identified from,
each point's ``residual`` and ``noise_db`` (its record's noise floor re the point), bootstrap
intervals, the inverse model's estimate, the truth of a
simulated data set, the verdict and its checks, the replay) may follow. ``records`` holds what
the record checks found before the extraction (docs/record_checks.md): ``{"findings": [{check,
run, channel, size, unit, action, message}], "skipped": {check: why}}``, ``null`` when they were
off (a file written before they existed has no such key). Non-finite numbers are written as
``null``.

:func:`read_result_record` reads the record as a dict (this layer knows no ``Identification``);
``freeplayid.read_identification`` builds the :class:`freeplayid.Identification` from it.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path

from ..atomic import atomic_write_text
from ..errors import ResultFileError

__all__ = ["ResultFileError", "read_result_record", "read_identification",
           "write_identification", "RESULT_FILE"]

RESULT_FILE = "identification.json"
REQUIRED = ("kn", "delta", "kn_ci95", "delta_ci95", "points", "rejected_runs", "residual_rms",
            "backbone", "init", "runtime_s")
POINT_KEYS = ("run", "channel", "f_hz", "amplitude_m", "used", "reason")
FINDING_KEYS = ("check", "run", "channel", "size", "unit", "action", "message")


def _json_safe(obj):
    """``obj`` with NaN/inf as None, tuples and arrays as lists, NumPy scalars as Python ones."""
    if isinstance(obj, Mapping):
        return {str(k): _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if hasattr(obj, "tolist"):  # NumPy arrays and scalars
        return _json_safe(obj.tolist())
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    return obj


def _target(path: str | os.PathLike) -> Path:
    path = Path(path)
    return path / RESULT_FILE if path.is_dir() else path


def write_identification(path: str | os.PathLike, result) -> Path:
    """Write an identification result as JSON, atomically; return the file's path.

    Parameters
    ----------
    path : path
        The file, or a folder (then ``folder/identification.json``).
    result : Identification or mapping
        An object with ``to_dict()`` (:class:`freeplayid.Identification`) or the mapping itself;
        it must hold the keys of the contract (module docstring).
    """
    record = result.to_dict() if hasattr(result, "to_dict") else result
    if not isinstance(record, Mapping):
        raise TypeError(
            f"`result` must be an Identification or a mapping, got {type(result).__name__}"
        )
    missing = [k for k in REQUIRED if k not in record]
    if missing:
        raise ValueError(f"`result` misses the field(s) {missing} of the result contract")
    text = json.dumps(_json_safe(record), indent=2, allow_nan=False)
    return atomic_write_text(_target(path), text + "\n")


def _positive(rec: Mapping, key: str, where: str) -> float:
    v = rec.get(key)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
        raise ResultFileError(f"{where}`{key}` must be a finite number > 0, got {v!r}")
    return float(v)


def read_result_record(path: str | os.PathLike) -> dict:
    """Read and check an ``identification.json`` (a file or the run folder holding it).

    Returns
    -------
    dict
        The record as written (``null`` numbers as None). ``freeplayid.read_identification``
        gives the :class:`freeplayid.Identification` instead.

    Raises
    ------
    ResultFileError
        Naming the file and the field: not JSON, a missing field, a non-positive kn or delta, an
        interval that is not [lo, hi], a point or a record check's finding without its fields.
    """
    file = _target(path)
    where = f"{file}: "
    try:
        record = json.loads(file.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ResultFileError(f"{file}: no such result file") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ResultFileError(f"{where}not a readable JSON file ({exc})") from None
    if not isinstance(record, dict):
        raise ResultFileError(f"{where}must be a JSON object with the fields {list(REQUIRED)}")
    missing = [k for k in REQUIRED if k not in record]
    if missing:
        raise ResultFileError(f"{where}missing field(s) {missing}")
    for key in ("kn", "delta"):
        _positive(record, key, where)
        ci = record[f"{key}_ci95"]
        if not (isinstance(ci, list) and len(ci) == 2):
            raise ResultFileError(f"{where}`{key}_ci95` must be [lo, hi], got {ci!r}")
    if not isinstance(record["points"], list):
        raise ResultFileError(f"{where}`points` must be a list of point records")
    for i, p in enumerate(record["points"]):
        miss = [k for k in POINT_KEYS if not isinstance(p, dict) or k not in p]
        if miss:
            raise ResultFileError(f"{where}`points[{i}]` misses the field(s) {miss}")
    _check_records(record.get("records"), where)
    return record


# the name this reader had before ``freeplayid.read_identification`` (the Identification): the
# dict, for the scripts written against it
read_identification = read_result_record


def _check_records(records, where: str) -> None:
    """The ``records`` entry: absent or null (no record checks), else its findings."""
    if records is None:
        return
    if not (isinstance(records, dict) and isinstance(records.get("findings"), list)):
        raise ResultFileError(f"{where}`records` must be null or {{\"findings\": [...], "
                              f"\"skipped\": {{...}}}}")
    for i, f in enumerate(records["findings"]):
        miss = [k for k in FINDING_KEYS if not isinstance(f, dict) or k not in f]
        if miss:
            raise ResultFileError(f"{where}`records.findings[{i}]` misses the field(s) {miss}")

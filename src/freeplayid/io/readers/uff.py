"""UFF (universal file format) dataset-58 run files (``.uff``, ``.unv``; ASCII 58 or binary 58b),
via ``pyuff``.

One dataset-58 record per channel (function type 1, "time response"), all on the same evenly
spaced time abscissa. A manifest column (a ``channels`` key or the ``base_channel``) names a
record in one of two ways:

- by its **ID line 1** (``id1``, stripped): ``acc_tl``;
- by its **response node and direction**, ``NODE:DIR``: ``101:+Z``, ``101:Z``, ``101:3``,
  ``101:-Y``, ``7:+RX`` (directions X Y Z RX RY RZ = 1 … 6, signed; the sign must be the
  record's: a ``-Z`` record is not read as ``+Z``). Quote such keys in YAML (``"101:3"``; the
  manifest reader also keeps an unquoted one a string).

An ID line 1 that equals the column wins; otherwise the column is read as ``NODE:DIR``. Several
records of one name or at one node and direction are an error only if a column asks for them.

A binary (58b) file that pyuff cannot read, or whose record holds another number of values than
its header says (the symptom of an exporter's misplaced ``-1`` delimiter), is read again after
pyuff's ``fix_58b`` repair (on a temporary copy; the file itself is not changed); if that fails
too, the error says so and what to try.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ...atomic import atomic_path
from ...errors import DatasetError
from .runfile import RunFile

__all__ = ["read", "read_uff", "write_uff", "DIRECTIONS"]

_TIME_RESPONSE = 1  # dataset 58 function type: time response
# dataset 58 response direction codes (record 6, field 7); negative for the opposite sense
DIRECTIONS = {"X": 1, "Y": 2, "Z": 3, "RX": 4, "RY": 5, "RZ": 6}
_NODE_DIR = re.compile(r"\s*(\d+)\s*:\s*([+-]?)\s*(RX|RY|RZ|X|Y|Z|[0-6])\s*", re.IGNORECASE)
_BINARY_58 = re.compile(rb"(?m)^ {0,6}58b ")  # a record header line of a binary record


class _Unreadable(Exception):
    """pyuff failed on the file, or returned a record that contradicts its own header."""


def read_uff(path: str | os.PathLike, *, columns: Sequence[str]) -> dict[str, np.ndarray]:
    """Time and the named channels of a UFF dataset-58 file.

    Parameters
    ----------
    path : path
    columns : sequence of str
        Records to return, each by its ID line 1 or as ``NODE:DIR`` (``101:+Z``, ``101:3``).

    Returns
    -------
    dict
        ``{"time": ndarray (T,) [s], column: ndarray (T,) [data-set units], ...}``.

    Raises
    ------
    DatasetError
        Unreadable file (a binary one also after pyuff's ``fix_58b`` repair), no dataset-58
        records, a missing column (the message lists the records' names and node:directions),
        one asked for by a name or node:direction that several records have, a record that is not
        a real time response, records with different time axes.
    """
    return read(Path(path), columns).columns


def read(path: Path, columns: Sequence[str], layouts=None) -> RunFile:
    """The reader of the registry: the time abscissa and the records ``columns`` (ID line 1 or
    ``NODE:DIR``) of one UFF file, with their unit labels (ordinate; abscissa for the time)."""
    picked = _pick(_records(path), columns, path)
    out, units = {}, {}
    time = None
    for c, r in picked.items():
        if int(r.get("func_type", _TIME_RESPONSE)) != _TIME_RESPONSE:
            raise DatasetError(
                f"{path}: record {c!r} has function type {r.get('func_type')}, need 1 "
                "(time response)"
            )
        x = np.asarray(r["x"], dtype=float)
        data = np.asarray(r["data"])
        if np.iscomplexobj(data):
            raise DatasetError(f"{path}: record {c!r} holds complex data; need a real time history")
        if time is None:
            time = x
        elif x.shape != time.shape or not np.allclose(x, time, rtol=0, atol=1e-9 + 1e-6 * (
                time[1] - time[0] if time.size > 1 else 1.0)):
            raise DatasetError(
                f"{path}: record {c!r} has a different time axis than {columns[0]!r}")
        out[c] = data.astype(float)
        units[c] = _label(r, "ordinate_axis_units_lab")
    out["time"] = time
    units["time"] = _label(next(iter(picked.values()), {}), "abscissa_axis_units_lab")
    return RunFile(columns=out, units={c: u for c, u in units.items() if u})


def _label(record: dict, key: str) -> str:
    """A record's unit label; empty for none (``NONE`` is pyuff's and many exporters' "no
    label")."""
    label = str(record.get(key, "")).strip()
    return "" if label.upper() == "NONE" else label


# --------------------------------------------------------------------------- the file
def _records(path: Path) -> list[dict]:
    """The dataset-58 records of the file; a binary file pyuff cannot read is read again after
    ``pyuff.fix_58b``."""
    try:
        records = _read_records(path)
    except _Unreadable as exc:
        first = str(exc)
        if not _BINARY_58.search(path.read_bytes()):
            raise DatasetError(f"{path}: not a readable UFF file ({first})") from None
        with tempfile.TemporaryDirectory() as tmp:
            fixed = Path(tmp) / f"fixed{path.suffix}"
            try:
                import pyuff

                with contextlib.redirect_stdout(io.StringIO()):  # fix_58b prints its file name
                    pyuff.fix_58b(str(path), str(fixed))
                records = _read_records(fixed)
            except Exception:  # noqa: BLE001 - pyuff raises bare Exceptions
                raise DatasetError(
                    f"{path}: binary UFF 58b record(s) unreadable ({first}), also after pyuff's "
                    "fix_58b repair; export the run again as ASCII UFF 58 (or as CSV or MAT), "
                    "or check that the file is complete"
                ) from None
    if not records:
        raise DatasetError(f"{path}: no dataset-58 (function at nodal DOF) records")
    return records


def _read_records(path: Path) -> list[dict]:
    """pyuff's dataset-58 records; _Unreadable if pyuff fails or a record holds another number
    of values than its header's ``num_pts`` (a misplaced delimiter read as data)."""
    import pyuff

    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as exc:  # pyuff raises bare Exceptions on malformed files
        raise _Unreadable(" ".join(str(exc).split())) from None
    if isinstance(sets, dict):
        sets = [sets]
    records = [s for s in sets if s.get("type") == 58]
    for r in records:
        n, data = r.get("num_pts"), r.get("data")
        if n is not None and data is not None and len(data) != int(n):
            raise _Unreadable(f"record {_name(r)!r} holds {len(data)} values but its header "
                              f"says {int(n)}")
    return records


# --------------------------------------------------------------------------- the records
def _name(r: dict) -> str:
    return str(r.get("id1", "")).strip()


def _node_dir(r: dict) -> str:
    """A record's response node and direction as ``NODE:±DIR`` (``101:+Z``)."""
    node, d = int(r.get("rsp_node", 0)), int(r.get("rsp_dir", 0))
    names = {v: k for k, v in DIRECTIONS.items()}
    return f"{node}:{'-' if d < 0 else '+'}{names.get(abs(d), abs(d))}"


def _parse_node_dir(column: str) -> tuple[int, int] | None:
    """``"101:+Z"``, ``"101:3"``, ``"101:-z"`` -> (101, ±3); None if not of that form."""
    m = _NODE_DIR.fullmatch(column)
    if m is None:
        return None
    node, sign, d = m.groups()
    code = DIRECTIONS[d.upper()] if d.upper() in DIRECTIONS else int(d)
    return int(node), -code if sign == "-" else code


def _pick(records: list[dict], columns: Sequence[str], path: Path) -> dict[str, dict]:
    """The one record each column names (ID line 1, else ``NODE:DIR``)."""
    picked, missing = {}, []
    for column in columns:
        hits = [r for r in records if _name(r) == column]
        how = "ID line 1"
        if not hits and (nd := _parse_node_dir(column)) is not None:
            hits = [r for r in records
                    if (int(r.get("rsp_node", -1)), int(r.get("rsp_dir", 0))) == nd]
            how = "node:direction"
        if len(hits) > 1:
            raise DatasetError(
                f"{path}: {len(hits)} records match {column!r} by {how} (ID lines "
                f"{[_name(r) for r in hits]}, at {[_node_dir(r) for r in hits]}); name one "
                "record by a unique ID line 1 or node:direction"
            )
        if hits:
            picked[column] = hits[0]
        else:
            missing.append(column)
    if missing:
        have = [f"{_name(r)} ({_node_dir(r)})" for r in records]
        raise DatasetError(
            f"{path}: channel(s) {missing} not found; its dataset-58 records are (ID line 1 "
            f"(node:direction)) {have}; a column names a record by its ID line 1 or as "
            "NODE:DIR (101:+Z, 101:3)"
        )
    return picked


# --------------------------------------------------------------------------- writing
def write_uff(
    path: str | os.PathLike,
    time,
    channels: Mapping[str, np.ndarray],
    *,
    nodes: Mapping[str, int] | None = None,
    directions: Mapping[str, int] | None = None,
    units: str | Mapping[str, str] | None = None,
    binary: bool = False,
) -> Path:
    """Write time histories as UFF dataset-58 records (one per channel), atomically.

    Parameters
    ----------
    path : path
        Replaced if it exists.
    time : array_like, shape (T,) [s]
        Evenly spaced.
    channels : mapping name -> array_like, shape (T,)
        Record name (ID line 1) -> values in the data set's units.
    nodes : mapping name -> int, optional
        Response node number of each record (default 1, 2, ...).
    directions : mapping name -> int, optional
        Response direction code of each record (:data:`DIRECTIONS`, signed; default 3, +Z).
    units : str or mapping name -> str, optional
        The ordinate's unit label (``"g"``, ``"m/s^2"``): one for every record, or per record;
        default none (``NONE``), which a reader does not check.
    binary : bool
        Binary UFF (58b) instead of ASCII.
    """
    import pyuff

    t = np.asarray(time, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise ValueError(f"`time` must be a 1-D array of >= 2 samples, got shape {t.shape}")
    path = Path(path)
    with atomic_path(path) as tmp:
        uff = pyuff.UFF(str(tmp))
        for k, (name, values) in enumerate(channels.items()):
            v = np.asarray(values, dtype=float)
            if v.shape != t.shape:
                raise ValueError(f"`channels[{name!r}]` must have shape {t.shape}, got {v.shape}")
            unit = units.get(name) if isinstance(units, Mapping) else units
            uff.write_sets(
                pyuff.prepare_58(
                    binary=int(binary), id1=name, id2="freeplayid", id3="", id4="", id5="",
                    func_type=_TIME_RESPONSE, rsp_node=int((nodes or {}).get(name, k + 1)),
                    rsp_dir=int((directions or {}).get(name, 3)), ref_node=0, ref_dir=0,
                    data=v, x=t, abscissa_spacing=1, abscissa_min=float(t[0]),
                    abscissa_inc=float(t[1] - t[0]),
                    abscissa_spec_data_type=17,  # time
                    abscissa_axis_units_lab="s",
                    ordinate_spec_data_type=12,  # acceleration (informational only)
                    ordinate_axis_units_lab=unit or "NONE",
                    orddenom_spec_data_type=0, z_axis_spec_data_type=0,
                    ver_num=0, load_case_id=0, rsp_ent_name="fin", ref_ent_name="none",
                ),
                mode="add",
            )
    return path

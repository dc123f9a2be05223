"""UFF (universal file format) dataset-58 run files (``.uff``, ``.unv``), via ``pyuff``.

A run file of a data set may be a ``.uff``/``.unv`` file instead of a CSV: one dataset-58 record
per channel (function type 1, "time response"), all on the same evenly spaced time abscissa.
A record's channel name is its ID line 1 (``id1``, stripped), matched against the manifest's
``channels`` keys and ``base_channel``; the values are in the manifest's ``units`` (the UFF unit
fields are not used, so one manifest rule covers both formats).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ...atomic import atomic_path
from ...errors import DatasetError
from .runfile import RunFile

__all__ = ["read", "read_uff", "write_uff"]

_TIME_RESPONSE = 1  # dataset 58 function type: time response


def read_uff(path: str | os.PathLike, *, columns: Sequence[str]) -> dict[str, np.ndarray]:
    """Time and the named channels of a UFF dataset-58 file.

    Parameters
    ----------
    path : path
    columns : sequence of str
        Channel names (records' ID line 1) to return.

    Returns
    -------
    dict
        ``{"time": ndarray (T,) [s], name: ndarray (T,) [data-set units], ...}``.

    Raises
    ------
    DatasetError
        Unreadable file, no dataset-58 records, a missing or duplicated channel name, records
        with different time axes.
    """
    import pyuff

    path = Path(path)
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as exc:  # pyuff raises bare Exceptions on malformed files
        raise DatasetError(f"{path}: not a readable UFF file ({exc})") from None
    if isinstance(sets, dict):
        sets = [sets]
    records = [s for s in sets if s.get("type") == 58]
    if not records:
        raise DatasetError(f"{path}: no dataset-58 (function at nodal DOF) records")
    names = [str(r.get("id1", "")).strip() for r in records]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise DatasetError(f"{path}: duplicate record name(s) (ID line 1) {dup}")
    missing = [c for c in columns if c not in names]
    if missing:
        raise DatasetError(
            f"{path}: channel(s) {missing} not found; its dataset-58 records are named "
            f"(ID line 1) {names}"
        )
    out = {}
    time = None
    for c in columns:
        r = records[names.index(c)]
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
    out["time"] = time
    return out


def read(path: Path, columns: Sequence[str], layouts=None) -> RunFile:
    """The reader of the registry: the time abscissa and the records named (ID line 1)
    ``columns`` of one UFF file (:func:`read_uff`)."""
    return RunFile(columns=read_uff(path, columns=columns))


def write_uff(
    path: str | os.PathLike,
    time,
    channels: Mapping[str, np.ndarray],
    *,
    nodes: Mapping[str, int] | None = None,
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
    binary : bool
        Binary UFF instead of ASCII.
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
            uff.write_sets(
                pyuff.prepare_58(
                    binary=int(binary), id1=name, id2="freeplayid", id3="", id4="", id5="",
                    func_type=_TIME_RESPONSE, rsp_node=int((nodes or {}).get(name, k + 1)),
                    rsp_dir=3, ref_node=0, ref_dir=0, data=v, x=t,
                    abscissa_spacing=1, abscissa_min=float(t[0]),
                    abscissa_inc=float(t[1] - t[0]),
                    abscissa_spec_data_type=17,  # time
                    ordinate_spec_data_type=12,  # acceleration (informational only)
                    orddenom_spec_data_type=0, z_axis_spec_data_type=0,
                    ver_num=0, load_case_id=0, rsp_ent_name="fin", ref_ent_name="none",
                ),
                mode="add",
            )
    return path

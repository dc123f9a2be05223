"""Measured-data sets: a folder with ``manifest.yaml`` and one CSV per sweep run (DESIGN.md §3).

```yaml
name: fin A, 2026-05 campaign
model: model.npz                # relative to the manifest
quantity: acceleration          # displacement | velocity | acceleration
units: g                        # g | m/s^2 for acceleration; m, m/s otherwise
sample_rate: 2048               # Hz; if absent, the CSV 'time' column defines it
channels: {acc_tl: uz_top_left, acc_lr: uz_lower_right}   # CSV column -> model DOF
base_channel: acc_base          # optional
runs:
  - {file: sweep_0.60g.csv, level_g: 0.60, sweep: {start_hz: 30, stop_hz: 50, rate_hz_per_s: 0.1}}
```

Every file is written under a temporary name and renamed, and the manifest is written last, so a
reader never sees a manifest that points at a missing or half-written file.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

__all__ = ["Dataset", "DatasetError", "Run", "read_dataset", "write_dataset"]

QUANTITIES = ("displacement", "velocity", "acceleration")
UNITS = {"displacement": ("m",), "velocity": ("m/s",), "acceleration": ("g", "m/s^2")}


class DatasetError(ValueError):
    """A data set does not satisfy the contract of DESIGN.md §3."""


@dataclass(frozen=True)
class Run:
    """One sweep run.

    Attributes
    ----------
    file : str
        CSV file name, relative to the manifest.
    time : ndarray, shape (T,) [s]
    data : ndarray, shape (channel, T) [units of the data set]
        Columns in the order of the data set's ``channels``.
    level_g : float or None [g]
        Informational base level.
    sweep : dict or None
        Optional hint ``{start_hz, stop_hz, rate_hz_per_s}``.
    base : ndarray, shape (T,), or None
        The base (control) channel, if the data set has one.
    """

    file: str
    time: np.ndarray
    data: np.ndarray
    level_g: float | None = None
    sweep: dict | None = None
    base: np.ndarray | None = None


@dataclass(frozen=True)
class Dataset:
    """A data set read from (or to be written to) a folder.

    Attributes
    ----------
    name : str
    model : Path or None
        Absolute path of the linear model file.
    quantity : str
    units : str
    sample_rate : float [Hz]
    channels : dict of str -> str
        CSV column -> model DOF name, in column order.
    runs : tuple of Run
    base_channel : str or None
    """

    name: str
    model: Path | None
    quantity: str
    units: str
    sample_rate: float
    channels: dict
    runs: tuple
    base_channel: str | None = None


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def _check_quantity_units(quantity: str, units: str, where: str) -> None:
    if quantity not in QUANTITIES:
        raise DatasetError(f"{where}`quantity` must be one of {QUANTITIES}, got {quantity!r}")
    if units not in UNITS[quantity]:
        raise DatasetError(
            f"{where}`units` for {quantity} must be one of {UNITS[quantity]}, got {units!r}"
        )


def write_dataset(
    folder: str | os.PathLike,
    *,
    name: str,
    quantity: str,
    units: str,
    sample_rate: float,
    channels: Mapping[str, str],
    runs: Sequence[Run],
    system=None,
    model_file: str = "model.npz",
    base_channel: str | None = None,
) -> Path:
    """Write a data set folder and return the path of its ``manifest.yaml``.

    Parameters
    ----------
    folder : path
        Created if missing; existing files of the same names are replaced.
    name : str
    quantity : {"displacement", "velocity", "acceleration"}
    units : str
        "g" or "m/s^2" for acceleration, "m" / "m/s" otherwise; the run data are in these units.
    sample_rate : float [Hz]
    channels : mapping CSV column -> DOF name
        Column order = row order of every ``Run.data``.
    runs : sequence of Run
    system : FreeplaySystem, optional
        Saved as ``model_file`` next to the manifest (the manifest's ``model`` entry).
    model_file : str
    base_channel : str, optional
        Column name of ``Run.base`` (each run must then carry it).
    """
    _check_quantity_units(quantity, units, "")
    if not (np.isfinite(sample_rate) and sample_rate > 0):
        raise DatasetError(f"`sample_rate` must be > 0, got {sample_rate!r}")
    cols = list(channels)
    if not cols or "time" in cols or (base_channel is not None and base_channel in cols):
        raise DatasetError(
            f"`channels` must be non-empty and must not use the names 'time' or the base "
            f"channel; got {cols} (base {base_channel!r})"
        )
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    entries = []
    for k, run in enumerate(runs):
        data = np.asarray(run.data, dtype=float)
        t = np.asarray(run.time, dtype=float)
        if data.ndim != 2 or data.shape != (len(cols), t.shape[0]):
            raise DatasetError(
                f"`runs[{k}].data` must have shape ({len(cols)}, {t.shape[0]}), got {data.shape}"
            )
        header = ["time", *cols]
        table = [t, *data]
        if base_channel is not None:
            if run.base is None:
                raise DatasetError(f"`runs[{k}].base` is missing but `base_channel` is set")
            header.append(base_channel)
            table.append(np.asarray(run.base, dtype=float))
        path = folder / run.file
        tmp = path.with_name(path.name + ".tmp")
        np.savetxt(tmp, np.column_stack(table), delimiter=",", header=",".join(header),
                   comments="", fmt="%.10g")
        os.replace(tmp, path)
        entry = {"file": run.file}
        if run.level_g is not None:
            entry["level_g"] = float(run.level_g)
        if run.sweep is not None:
            entry["sweep"] = {k2: float(v) for k2, v in dict(run.sweep).items()}
        entries.append(entry)
    manifest = {"name": str(name)}
    if system is not None:
        from ..model.system import save_system

        save_system(folder / model_file, system)
        manifest["model"] = model_file
    manifest.update(
        quantity=quantity,
        units=units,
        sample_rate=float(sample_rate),
        channels={c: str(channels[c]) for c in cols},
    )
    if base_channel is not None:
        manifest["base_channel"] = base_channel
    manifest["runs"] = entries
    out = folder / "manifest.yaml"
    _atomic_write_text(out, yaml.safe_dump(manifest, sort_keys=False))
    return out


def read_dataset(path: str | os.PathLike) -> Dataset:
    """Read a data set from its folder or ``manifest.yaml``.

    Raises
    ------
    DatasetError
        Naming the file and field: missing manifest or run file, unknown quantity/units,
        missing CSV column, non-uniform time column.
    """
    path = Path(path)
    manifest_path = path / "manifest.yaml" if path.is_dir() else path
    if not manifest_path.is_file():
        raise DatasetError(f"{manifest_path}: manifest not found")
    where = f"{manifest_path}: "
    try:
        m = yaml.safe_load(manifest_path.read_text())
    except yaml.YAMLError as exc:
        raise DatasetError(f"{where}not valid YAML ({exc})") from None
    if not isinstance(m, dict):
        raise DatasetError(f"{where}must be a mapping")
    for key in ("quantity", "units", "channels", "runs"):
        if key not in m:
            raise DatasetError(f"{where}missing field `{key}`")
    _check_quantity_units(m["quantity"], m["units"], where)
    channels = m["channels"]
    if not isinstance(channels, dict) or not channels:
        raise DatasetError(f"{where}`channels` must map CSV columns to DOF names")
    base_channel = m.get("base_channel")
    root = manifest_path.parent
    runs = []
    fs = m.get("sample_rate")
    for k, entry in enumerate(m["runs"]):
        f = root / entry["file"]
        if not f.is_file():
            raise DatasetError(f"{where}`runs[{k}].file` {entry['file']!r} not found")
        with open(f) as fh:
            header = fh.readline().strip().split(",")
        table = np.loadtxt(f, delimiter=",", skiprows=1, ndmin=2)
        need = ["time", *channels] + ([base_channel] if base_channel else [])
        missing = [c for c in need if c not in header]
        if missing:
            raise DatasetError(f"{f}: missing column(s) {missing}; header is {header}")
        t = table[:, header.index("time")]
        if fs is None:
            steps = np.diff(t)
            if len(steps) == 0 or np.ptp(steps) > 1e-6 * np.mean(steps):
                raise DatasetError(f"{f}: 'time' is not uniformly sampled and no sample_rate")
            fs = 1.0 / float(np.mean(steps))
        runs.append(
            Run(
                file=entry["file"],
                time=t,
                data=np.stack([table[:, header.index(c)] for c in channels]),
                level_g=entry.get("level_g"),
                sweep=entry.get("sweep"),
                base=table[:, header.index(base_channel)] if base_channel else None,
            )
        )
    model = m.get("model")
    return Dataset(
        name=str(m.get("name", "")),
        model=(root / model).resolve() if model else None,
        quantity=m["quantity"],
        units=m["units"],
        sample_rate=float(fs),
        channels=dict(channels),
        runs=tuple(runs),
        base_channel=base_channel,
    )

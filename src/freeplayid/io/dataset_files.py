"""Measured-data sets on disk: :func:`read_dataset` and :func:`write_dataset`.

A data set is a folder with ``manifest.yaml`` (the contract: :mod:`freeplayid.io.manifest`,
docs/identify.md) and one file per sweep run. A run file is read by the reader of its suffix
(:mod:`freeplayid.io.readers`: CSV, gzipped CSV, UFF 58, MATLAB ``.mat``, NI ``.tdms``); every
check that does not depend on the file type (the time column, non-finite samples) is made here,
after the reader, the same for all of them. :func:`write_dataset` writes CSV (``.csv`` or
``.csv.gz``).

Every file is written under a temporary name and renamed (:func:`freeplayid.atomic.atomic_path`),
and the manifest is written last, so a
reader never sees a manifest that points at a missing or half-written file.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import yaml

from ..acquisition import FilterResponse, check_antialias, check_base_delay
from ..atomic import atomic_path, atomic_write_text
from ..dataset import (
    Dataset,
    Run,
    check_channels,
    check_frame,
    check_gravity,
    check_number,
    check_quantity_units,
    check_time,
    run_reason,
)
from ..errors import DatasetError
from ..model.system import save_system
from .manifest import Manifest, RunEntry, read_manifest
from .readers import RunFile, read_run
from .units import check_file_units

__all__ = ["Dataset", "DatasetError", "Run", "bundled_example", "read_dataset", "write_dataset"]

CSV_SUFFIXES = (".csv", ".csv.gz")  # what write_dataset writes


# --------------------------------------------------------------------------- reading
def bundled_example() -> Path:
    """The ``manifest.yaml`` of the bundled example data set (five simulated sweeps of the
    default fin, examples/README.md), package data: ``freeplayid/data/fin_sweeps`` in any install
    (``examples/fin_sweeps`` of a checkout links to it)."""
    return Path(__file__).resolve().parents[1] / "data" / "fin_sweeps" / "manifest.yaml"


def read_dataset(path: str | os.PathLike, *, check_model: bool = True) -> Dataset:
    """Read and validate a data set from its folder or ``manifest.yaml`` (docs/identify.md).

    A run file is read by the reader of its suffix (:data:`freeplayid.io.readers.READERS`):
    CSV (``.csv``, ``.csv.gz``), UFF dataset 58 (``.uff``, ``.unv``; a channel is a record's
    ID line 1 or its ``NODE:DIR`` such as ``101:+Z``, see :func:`freeplayid.io.read_uff`),
    MATLAB (``.mat``; a controller's matrix with channel names and time increment, as declared
    by the manifest's ``mat:`` block, or one vector variable per column) and NI TDMS
    (``.tdms``; one channel per column); CSV in the layout of the manifest's ``csv:`` block.
    The checks below that concern the time column, the samples and the units a file states are
    the same for every file type.

    Parameters
    ----------
    path : path
        The data-set folder or its manifest.
    check_model : bool
        Load the manifest's model file and check that every channel names one of its DOFs.

    Returns
    -------
    Dataset
        Run data in the data set's units (:meth:`Dataset.to_si` converts). A run's own problem
        keeps the run with ``Run.reason`` saying why (a rejected run, not an error), so one
        broken record does not stop a campaign: its file cannot be read (truncated or corrupt,
        any error of its reader: missing or non-numeric columns, variables, channels), a unit
        the file states is not the manifest's (:func:`freeplayid.io.units.check_file_units`:
        the message names the file, the channel and both units), its time
        column is non-monotonic, non-uniform, shorter than 16 samples or off the data set's
        sample rate, NaN/inf samples, or its ``sweep`` hint does not fit the record
        (:meth:`freeplayid.sweep.Sweep.record_mismatch`: above Nyquist, a sample rate below
        2.5 x the top frequency, a record length that disagrees with the hint's duration).
        Such a run of an unreadable file has empty ``time`` and ``data``.

    Raises
    ------
    DatasetError
        One line naming the file, the run, the field or column and the allowed values, before
        any run file is read for the manifest's own problems: no manifest, a path that is not a
        ``.yaml`` manifest, a binary file, invalid YAML, a key given twice in a mapping (with
        its line), unknown fields, bad quantity/units, two columns on one DOF, channels not in
        the model, a run file that is missing, outside the data-set folder (absolute or
        ``..``) or of an unknown suffix (the message lists the valid ones), no runs. After the
        files: no run could be read at all (the first run's problem, e.g. a ``sample_rate``
        that every run's time column disagrees with, or a channel no run file has).
    """
    manifest = read_manifest(path, check_model=check_model)
    runs, errors, fs = _read_runs(manifest)
    if len(errors) == len(runs):
        k = len(errors) - 1
        more = "" if k == 0 else " (no run is readable: the other run fails too)" if k == 1 \
            else f" (no run is readable: the other {k} runs fail too)"
        raise DatasetError(errors[0] + more)
    return Dataset(
        name=manifest.name,
        model=manifest.model,
        quantity=manifest.quantity,
        units=manifest.units,
        sample_rate=float(fs),
        channels=dict(manifest.channels),
        runs=tuple(runs),
        base_channel=manifest.base_channel,
        truth=manifest.truth,
        path=manifest.path.resolve(),
        reference_modes=manifest.reference_modes,
        frame=manifest.frame,
        antialias=manifest.antialias,
        base_delay_s=manifest.base_delay_s,
        gravity_g=manifest.gravity_g,
    )


def _read_runs(manifest: Manifest) -> tuple[list[Run], list[str], float | None]:
    """Every run file of the manifest, in order: the runs (a run's own problem, such as an
    unreadable or malformed file, a time column off the data set's sample rate, NaN samples or
    a hint that does not fit it, rejects that run with its reason), the messages of the runs that
    could not be read, and the data set's sample rate (the manifest's, else the first readable
    run's)."""
    fs = manifest.sample_rate
    runs, errors = [], []
    for entry in manifest.runs:
        try:
            found = _read_run_file(entry.path, manifest)
            check_file_units(found.units, manifest.quantity, manifest.units, str(entry.path))
            cols = found.columns
            fs = check_time(cols["time"], fs, str(entry.path))
        except DatasetError as exc:
            errors.append(str(exc))
            runs.append(_unreadable_run(entry, manifest, str(exc)))
            continue
        runs.append(_run_of(entry, cols, manifest, fs))
    return runs, errors, fs


def _unreadable_run(entry: RunEntry, manifest: Manifest, reason: str) -> Run:
    """A rejected run whose file could not be read: empty time and data."""
    empty = np.empty(0)
    return Run(file=entry.name, time=empty, data=np.empty((len(manifest.channels), 0)),
               level_g=entry.level_g, sweep=entry.sweep,
               base=empty if manifest.base_channel else None, reason=reason)


def _run_of(entry: RunEntry, cols: dict, manifest: Manifest, fs: float) -> Run:
    """The run of a readable file; rejected (``reason``) for NaN samples or a hint that does
    not fit the record."""
    t = cols["time"]
    data = np.stack([cols[c] for c in manifest.channels])
    base = cols[manifest.base_channel] if manifest.base_channel else None
    reason = run_reason({c: cols[c] for c in manifest.columns}, t, entry.sweep, fs)
    return Run(file=entry.name, time=t, data=data, level_g=entry.level_g, sweep=entry.sweep,
               base=base, reason=reason)


def _read_run_file(f: Path, manifest: Manifest) -> RunFile:
    """``read_run`` with any failure of the file itself as a one-line DatasetError naming it
    (a truncated ``.csv.gz``, a corrupt ``.mat``, a library's own exception)."""
    try:
        return read_run(f, manifest.columns, manifest.layouts)
    except DatasetError as exc:
        raise DatasetError(" ".join(str(exc).split())) from None
    except Exception as exc:  # noqa: BLE001 - a library's own error on a corrupt file (zlib,
        # pyuff, npTDMS, scipy.io raise what they like): the run's problem, not the campaign's
        kind = type(exc).__qualname__
        if type(exc).__module__ != "builtins":
            kind = f"{type(exc).__module__}.{kind}"  # zlib.error, not "error"
        why = " ".join(str(exc).split())
        raise DatasetError(f"{f}: unreadable run file ({kind}: {why})") from None



# --------------------------------------------------------------------------- writing
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
    truth: Mapping[str, float] | None = None,
    float_format: str = "%.10g",
    time_format: str | None = None,
    frame: str = "absolute",
    antialias="unknown",
    base_delay_s: float = 0.0,
    gravity_g: float = 0.0,
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
        Each ``file`` must end in ``.csv`` or ``.csv.gz`` (written gzipped).
    system : FreeplaySystem, optional
        Saved as ``model_file`` next to the manifest (the manifest's ``model`` entry).
    model_file : str
    base_channel : str, optional
        Column name of ``Run.base`` (each run must then carry it).
    truth : mapping, optional
        ``{"kn": [N m/rad], "delta": [rad]}`` of a simulated data set (informational; the
        identification report compares with it).
    float_format, time_format : str
        printf formats of the data columns and of the time column (default: ``float_format``);
        fewer digits make smaller files (4-5 significant digits are plenty for noisy data).
    frame : {"absolute", "relative"}
        What the runs record (:attr:`freeplayid.dataset.Dataset.frame`); written to the manifest
        when relative (absolute is the manifest's default).
    antialias : {"unknown", "flat", "replay"}, FilterResponse or mapping
        The records' anti-alias filter (:mod:`freeplayid.acquisition`); written to the manifest
        when stated (a response as its lists).
    base_delay_s : float [s]
        How late the base channel was read against the others; written when not 0.
    gravity_g : float [g]
        Gravity's component along the shaking axis (:attr:`freeplayid.dataset.Dataset.
        gravity_g`); written when not 0.
    """
    cols = _check_columns(quantity, units, sample_rate, channels, base_channel)
    check_frame(frame, base_channel, "")
    antialias = check_antialias(antialias)
    base_delay_s = check_base_delay(base_delay_s, base_channel)
    gravity_g = check_gravity(gravity_g)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    fmt = (time_format or float_format, float_format)
    entries = [_write_run(folder, k, run, cols, base_channel, fmt) for k, run in enumerate(runs)]
    manifest = {"name": str(name)}
    if system is not None:
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
    if frame != "absolute":
        manifest["frame"] = frame
    if isinstance(antialias, FilterResponse):
        manifest["antialias"] = antialias.to_dict()
    elif antialias != "unknown":
        manifest["antialias"] = antialias
    if base_delay_s != 0:
        manifest["base_delay_s"] = base_delay_s
    if gravity_g != 0:
        manifest["gravity_g"] = gravity_g
    if truth is not None:
        manifest["truth"] = {k: float(v) for k, v in dict(truth).items()}
    manifest["runs"] = entries
    out = folder / "manifest.yaml"
    atomic_write_text(out, yaml.safe_dump(manifest, sort_keys=False))
    return out


def _check_columns(quantity: str, units: str, sample_rate: float, channels: Mapping[str, str],
                   base_channel: str | None) -> list[str]:
    """The arguments of :func:`write_dataset` that describe the columns; the channel columns."""
    check_quantity_units(quantity, units, "")
    check_number(sample_rate, "`sample_rate` [Hz]")
    return list(check_channels(channels, base_channel, "")[0])


def _write_run(folder: Path, k: int, run: Run, cols: list[str], base_channel: str | None,
               fmt: tuple[str, str]) -> dict:
    """Write ``runs[k]`` as a CSV file (atomically) and return its manifest entry."""
    if not str(run.file).lower().endswith(CSV_SUFFIXES):
        raise DatasetError(
            f"`runs[{k}].file` must end in one of {list(CSV_SUFFIXES)} (write_dataset "
            f"writes CSV), got {run.file!r}"
        )
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
    with atomic_path(folder / run.file) as tmp:  # same suffix: a .csv.gz is written gzipped
        np.savetxt(tmp, np.column_stack(table), delimiter=",", header=",".join(header),
                   comments="", fmt=[fmt[0]] + [fmt[1]] * (len(table) - 1))
    entry = {"file": run.file}
    if run.level_g is not None:
        entry["level_g"] = float(run.level_g)
    if run.sweep is not None:
        entry["sweep"] = {k2: float(v) for k2, v in dict(run.sweep).items()}
    return entry

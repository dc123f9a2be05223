"""Measured-data sets: a folder with ``manifest.yaml`` and one file per sweep run.

The contract (docs/identify.md):

```yaml
name: fin A, 2026-05 campaign
model: model.npz                # relative to the manifest
quantity: acceleration          # displacement | velocity | acceleration
units: g                        # g | m/s^2 for acceleration; m, m/s otherwise
sample_rate: 2048               # Hz; if absent, the runs' 'time' column defines it
channels: {acc_tl: uz_top_left, acc_lr: uz_lower_right}   # run-file column -> model DOF
base_channel: acc_base          # optional
runs:
  - {file: sweep_0.60g.csv, level_g: 0.60, sweep: {start_hz: 30, stop_hz: 50, rate_hz_per_s: 0.1}}
  - {file: sweep_0.80g.csv, level_g: 0.80, sweep: {start_hz: 20, stop_hz: 80, octaves_per_min: 2}}
```

A ``sweep`` hint gives a linear (``rate_hz_per_s``) or a logarithmic (``octaves_per_min``) law,
not both (:class:`freeplayid.sweep.Sweep`).

A run file is read by the reader of its suffix (:mod:`freeplayid.io.readers`: CSV, gzipped CSV,
UFF 58, MATLAB ``.mat``, NI ``.tdms``); every check that does not depend on the file type (the
time column, non-finite samples) is made here, after the reader, the same for all of them.
:func:`write_dataset` writes CSV (``.csv`` or ``.csv.gz``).

Every file is written under a temporary name and renamed, and the manifest is written last, so a
reader never sees a manifest that points at a missing or half-written file.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import yaml

from ..dataset import Dataset, Run
from ..errors import DatasetError
from ..quantity import check_units
from ..sweep import Sweep
from .atomic import atomic_write_text
from .readers import read_run, reader_for

__all__ = ["Dataset", "DatasetError", "Run", "read_dataset", "write_dataset"]

# the one place where data-set units become SI: factor to m, m/s or m/s^2
MANIFEST_KEYS = ("name", "model", "quantity", "units", "sample_rate", "channels",
                 "base_channel", "truth", "runs", "reference_modes")
RUN_KEYS = ("file", "level_g", "sweep")
SWEEP_RATE_KEYS = ("rate_hz_per_s", "octaves_per_min")  # linear, logarithmic: exactly one
SWEEP_KEYS = ("start_hz", "stop_hz", *SWEEP_RATE_KEYS)
CSV_SUFFIXES = (".csv", ".csv.gz")  # what write_dataset writes


def _check_quantity_units(quantity: str, units: str, where: str) -> None:
    try:
        check_units(quantity, units)
    except ValueError as exc:
        raise DatasetError(f"{where}{exc}") from None


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
    _check_one_column_per_dof(channels, "")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    entries = []
    for k, run in enumerate(runs):
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
        path = folder / run.file
        tmp = path.with_name(".tmp-" + path.name)  # same suffix: a .csv.gz is written gzipped
        fmt = [time_format or float_format] + [float_format] * (len(table) - 1)
        np.savetxt(tmp, np.column_stack(table), delimiter=",", header=",".join(header),
                   comments="", fmt=fmt)
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
    if truth is not None:
        manifest["truth"] = {k: float(v) for k, v in dict(truth).items()}
    manifest["runs"] = entries
    out = folder / "manifest.yaml"
    atomic_write_text(out, yaml.safe_dump(manifest, sort_keys=False))
    return out


def _check_one_column_per_dof(channels: Mapping[str, str], where: str) -> None:
    """Two columns on one DOF would give two points of one curve, weighted twice in the fit
    (or a mapping typo that silently drops a DOF): an error naming both columns and the DOF."""
    by_dof = {}
    for col, dof in channels.items():
        by_dof.setdefault(dof, []).append(col)
    for dof, cols in by_dof.items():
        if len(cols) > 1:
            raise DatasetError(
                f"{where}`channels` map the columns {cols} to the same model DOF {dof!r}; each "
                "DOF takes one column (drop one, or map it to its own DOF)"
            )


def _check_keys(entry, allowed, where: str) -> None:
    unknown = sorted(set(entry) - set(allowed))
    if unknown:
        raise DatasetError(f"{where}unknown field(s) {unknown}; allowed: {list(allowed)}")


def _number(value, where: str, *, positive: bool = True) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    if not ok or not np.isfinite(value) or (positive and value <= 0):
        need = "a finite number > 0" if positive else "a finite number"
        raise DatasetError(f"{where} must be {need}, got {value!r}")
    return float(value)


class _ManifestLoader(yaml.SafeLoader):
    """yaml's SafeLoader, but a key given twice in one mapping is an error, not "last one wins"
    (``units: g`` ... ``units: m/s^2`` would otherwise silently keep the second)."""


def _construct_unique_mapping(loader, node, deep=False):
    seen = {}
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        try:
            first = seen.get(key)
        except TypeError:  # an unhashable key: let yaml's own message say so
            break
        line = key_node.start_mark.line + 1
        if first is not None:
            raise DatasetError(
                f"{loader.name}: line {line}: duplicate key `{key}` (first at line {first}); "
                "each field may be given once"
            )
        seen[key] = line
    return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)


_ManifestLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG,
                                _construct_unique_mapping)


def _load_manifest(manifest_path: Path):
    """The manifest's YAML document; DatasetError for a binary file, bad YAML, a duplicate key."""
    raw = manifest_path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DatasetError(
            f"{manifest_path}: not a text (UTF-8) file (byte 0x{raw[exc.start]:02x} at offset "
            f"{exc.start}); give the data-set folder or its manifest.yaml"
        ) from None
    if "\x00" in text:
        raise DatasetError(f"{manifest_path}: a binary file (NUL bytes), not a YAML manifest; "
                           "give the data-set folder or its manifest.yaml")
    loader = _ManifestLoader(text)
    loader.name = str(manifest_path)
    try:
        return loader.get_single_data()
    except yaml.YAMLError as exc:
        msg = " ".join(str(exc).split())  # one line
        raise DatasetError(f"{manifest_path}: not valid YAML ({msg})") from None
    finally:
        loader.dispose()


def _check_inside(name: str, where: str) -> None:
    """A run file must be a relative path that stays inside the data-set folder."""
    parts = Path(os.path.normpath(name)).parts
    if os.path.isabs(name) or Path(name).is_absolute() or (parts and parts[0] == ".."):
        raise DatasetError(
            f"{where}.file {name!r} must be a path inside the data-set folder (relative, no "
            "'..' leaving it, no absolute path)"
        )


def _check_time(t: np.ndarray, fs: float | None, where: str) -> float:
    """Validate a time column [s]; return the sample rate [Hz] it implies (or ``fs``)."""
    if t.size < 16:
        raise DatasetError(f"{where}: {t.size} samples; a sweep run needs many more")
    if not np.all(np.isfinite(t)):
        k = int(np.flatnonzero(~np.isfinite(t))[0])
        raise DatasetError(f"{where}: column 'time' has a non-finite value at data row {k + 1}")
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0])
        raise DatasetError(
            f"{where}: column 'time' must increase strictly; data rows {k + 1}-{k + 2} go "
            f"{t[k]:.9g} -> {t[k + 1]:.9g} s"
        )
    # rate from a straight-line fit, robust to rounding of the printed times
    k = np.arange(t.size)
    step = float(np.polyfit(k, t, 1)[0])
    dev = np.abs(t - (t[0] + k * step))
    if dev.max() > 0.25 * step:
        j = int(np.argmax(dev))
        raise DatasetError(
            f"{where}: column 'time' is not uniformly sampled (data row {j + 1} is off the "
            f"{1 / step:.6g} Hz grid by {dev[j] / step:.2f} samples); resample the record"
        )
    if fs is not None and abs(1.0 / step - fs) > 1e-3 * fs:
        raise DatasetError(
            f"{where}: column 'time' implies {1 / step:.6g} Hz but the data set's sample rate "
            f"is {fs:g} Hz (the manifest's `sample_rate`, else the first run's time column)"
        )
    return fs if fs is not None else 1.0 / step


def _read_run_file(f: Path, columns: Sequence[str]) -> dict:
    """``read_run`` with any failure of the file itself as a one-line DatasetError naming it
    (a truncated ``.csv.gz``, a corrupt ``.mat``, a library's own exception)."""
    try:
        return read_run(f, columns)
    except DatasetError as exc:
        raise DatasetError(" ".join(str(exc).split())) from None
    except Exception as exc:  # noqa: BLE001 - a library's own error on a corrupt file (zlib,
        # pyuff, npTDMS, scipy.io raise what they like): the run's problem, not the campaign's
        kind = type(exc).__qualname__
        if type(exc).__module__ != "builtins":
            kind = f"{type(exc).__module__}.{kind}"  # zlib.error, not "error"
        why = " ".join(str(exc).split())
        raise DatasetError(f"{f}: unreadable run file ({kind}: {why})") from None


def _nonfinite_reason(columns: Mapping[str, np.ndarray], t: np.ndarray) -> str:
    for name, x in columns.items():
        bad = ~np.isfinite(x)
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            return (
                f"non-finite values (NaN/inf) in column {name!r}: {int(bad.sum())} samples, "
                f"first at t = {t[k]:.6g} s"
            )
    return ""


def read_dataset(path: str | os.PathLike, *, check_model: bool = True) -> Dataset:
    """Read and validate a data set from its folder or ``manifest.yaml`` (docs/identify.md).

    A run file is read by the reader of its suffix (:data:`freeplayid.io.readers.READERS`):
    CSV (``.csv``, ``.csv.gz``), UFF dataset 58 (``.uff``, ``.unv``; channel names = the
    records' ID line 1, see :func:`freeplayid.io.read_uff`), MATLAB (``.mat``; one vector
    variable per column) and NI TDMS (``.tdms``; one channel per column). The checks below that
    concern the time column and the samples are the same for every file type.

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
        any error of its reader: missing or non-numeric columns, variables, channels), its time
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
    path = Path(path)
    manifest_path = path / "manifest.yaml" if path.is_dir() else path
    if not manifest_path.is_file():
        raise DatasetError(
            f"{manifest_path}: manifest not found (give a data-set folder or its manifest.yaml)"
        )
    if manifest_path.suffix.lower() not in (".yaml", ".yml"):
        raise DatasetError(
            f"{manifest_path}: not a manifest (a .yaml file); give the data-set folder or its "
            "manifest.yaml, not a run or model file"
        )
    where = f"{manifest_path}: "
    m = _load_manifest(manifest_path)
    if not isinstance(m, dict):
        raise DatasetError(f"{where}must be a YAML mapping of the fields {list(MANIFEST_KEYS)} "
                           "(give the data-set folder or its manifest.yaml)")
    _check_keys(m, MANIFEST_KEYS, where)
    for key in ("quantity", "units", "channels", "runs"):
        if key not in m:
            raise DatasetError(f"{where}missing field `{key}`")
    _check_quantity_units(m["quantity"], m["units"], where)
    channels = m["channels"]
    if not isinstance(channels, dict) or not channels or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in channels.items()
    ):
        raise DatasetError(
            f"{where}`channels` must map run-file column names to model DOF names, got "
            f"{channels!r}"
        )
    _check_one_column_per_dof(channels, where)
    base_channel = m.get("base_channel")
    if base_channel is not None and (not isinstance(base_channel, str) or base_channel in
                                     channels or base_channel == "time"):
        raise DatasetError(
            f"{where}`base_channel` must be a column name other than 'time' and the channels "
            f"{list(channels)}, got {base_channel!r}"
        )
    if "time" in channels:
        raise DatasetError(f"{where}`channels` must not use the column name 'time'")
    fs = m.get("sample_rate")
    if fs is not None:
        fs = _number(fs, f"{where}`sample_rate` [Hz]")
    truth = m.get("truth")
    if truth is not None:
        if not isinstance(truth, dict):
            raise DatasetError(f"{where}`truth` must be a mapping {{kn, delta}}, got {truth!r}")
        _check_keys(truth, ("kn", "delta"), f"{where}`truth`: ")
        truth = {k: _number(v, f"{where}`truth.{k}`") for k, v in truth.items()}
    root = manifest_path.parent
    model = m.get("model")
    model_path = None
    if model is not None:
        if not isinstance(model, str):
            raise DatasetError(f"{where}`model` must be a file name, got {model!r}")
        model_path = (root / model).resolve()
        if not model_path.is_file():
            raise DatasetError(f"{where}`model` file {model!r} not found (looked at {model_path})")
        if check_model:
            from ..model.system import SystemFileError, load_system

            try:
                dofs = load_system(model_path).dof_names
            except SystemFileError as exc:
                raise DatasetError(f"{where}`model`: {exc}") from None
            unknown = {c: d for c, d in channels.items() if d not in dofs}
            if unknown:
                raise DatasetError(
                    f"{where}`channels` map to DOF(s) the model {model!r} does not have: "
                    f"{unknown}; its DOFs are {list(dofs)}"
                )
    reference_modes = None
    if m.get("reference_modes") is not None:
        reference_modes = _reference_modes(m["reference_modes"], f"{where}`reference_modes`",
                                           root, dofs if model_path and check_model else None)
    entries = m["runs"]
    if not isinstance(entries, list) or not entries:
        raise DatasetError(f"{where}`runs` must be a non-empty list of {{file, ...}} entries")
    # every manifest check of every run first, before any run file is read
    specs = []
    seen = set()
    for k, entry in enumerate(entries):
        at = f"{where}`runs[{k}]`"
        if not isinstance(entry, dict) or "file" not in entry:
            raise DatasetError(f"{at} must be a mapping with a `file`, got {entry!r}")
        _check_keys(entry, RUN_KEYS, f"{at}: ")
        name = entry["file"]
        if not isinstance(name, str) or not name or name in seen:
            raise DatasetError(f"{at}.file must be a file name used once, got {name!r}")
        seen.add(name)
        _check_inside(name, at)
        f = root / name
        if not f.is_file():
            raise DatasetError(f"{at}.file {name!r} not found (looked at {f})")
        reader_for(f)  # an unknown suffix is the manifest's error: it lists the valid ones
        level = entry.get("level_g")
        if level is not None:
            level = _number(level, f"{at}.level_g [g]")
        sweep = entry.get("sweep")
        if sweep is not None:
            if not isinstance(sweep, dict):
                raise DatasetError(f"{at}.sweep must be a mapping of {list(SWEEP_KEYS)}")
            _check_keys(sweep, SWEEP_KEYS, f"{at}.sweep: ")
            miss = [s_ for s_ in ("start_hz", "stop_hz") if s_ not in sweep]
            rates = [s_ for s_ in SWEEP_RATE_KEYS if s_ in sweep]
            if miss or not rates:
                raise DatasetError(
                    f"{at}.sweep misses {miss + ([] if rates else [' or '.join(SWEEP_RATE_KEYS)])}"
                    "; it needs `start_hz`, `stop_hz` and `rate_hz_per_s` (linear) or "
                    "`octaves_per_min` (logarithmic)")
            if len(rates) > 1:
                raise DatasetError(f"{at}.sweep gives both `rate_hz_per_s` and "
                                   "`octaves_per_min`; give one (linear or logarithmic sweep)")
            sweep = {s_: _number(sweep[s_], f"{at}.sweep.{s_}")
                     for s_ in ("start_hz", "stop_hz", *rates)}
            if sweep["start_hz"] == sweep["stop_hz"]:
                raise DatasetError(f"{at}.sweep: `start_hz` and `stop_hz` must differ")
        specs.append((name, f, level, sweep))
    # then the files: a run's own problem (unreadable, malformed, off the data set's sample
    # rate, NaN samples, a hint that does not fit it) rejects that run with its reason; only
    # when no run can be read at all is it the data set's problem
    need = [*channels] + ([base_channel] if base_channel else [])
    runs, errors = [], []
    for name, f, level, sweep in specs:
        try:
            cols = _read_run_file(f, need)
            fs = _check_time(cols["time"], fs, str(f))
        except DatasetError as exc:
            errors.append(str(exc))
            empty = np.empty(0)
            runs.append(Run(file=name, time=empty, data=np.empty((len(channels), 0)),
                            level_g=level, sweep=sweep,
                            base=empty if base_channel else None, reason=str(exc)))
            continue
        t = cols["time"]
        data = np.stack([cols[c] for c in channels])
        base = cols[base_channel] if base_channel else None
        reason = _nonfinite_reason({c: cols[c] for c in need}, t)
        if not reason and sweep is not None:
            reason = Sweep(**sweep).record_mismatch(t.size, fs)
        runs.append(Run(file=name, time=t, data=data, level_g=level, sweep=sweep, base=base,
                        reason=reason))
    if len(errors) == len(runs):
        k = len(errors) - 1
        more = "" if k == 0 else " (no run is readable: the other run fails too)" if k == 1 \
            else f" (no run is readable: the other {k} runs fail too)"
        raise DatasetError(errors[0] + more)
    return Dataset(
        name=str(m.get("name", "")),
        model=model_path,
        quantity=m["quantity"],
        units=m["units"],
        sample_rate=float(fs),
        channels=dict(channels),
        runs=tuple(runs),
        base_channel=base_channel,
        truth=truth,
        path=manifest_path.resolve(),
        reference_modes=reference_modes,
    )


def _reference_modes(entry, where: str, root: Path, dofs) -> dict:
    """The manifest's optional ``reference_modes`` (docs/identify.md): ``{modes: [{frequency_hz,
    shape: {dof: value}}]}`` or ``{uff: FILE, nodes: {node: dof}}`` (UFF dataset 55)."""
    from .modal import ModalTestError, parse_modes

    try:
        if isinstance(entry, dict) and "uff" in entry:
            nodes = entry.get("nodes")
            if not isinstance(nodes, dict) or not nodes:
                raise ModalTestError(f"{where}.nodes must map UFF node numbers to model DOFs")
            modes = parse_modes({"uff": entry["uff"]}, where, root=root, known_points=None)
            missing = [n for n in modes.points if str(n) not in {str(k) for k in nodes}]
            if missing:
                raise ModalTestError(f"{where}.nodes: UFF node(s) {missing} not mapped to DOFs")
            names = [str({str(k): v for k, v in nodes.items()}[n]) for n in modes.points]
        else:
            modes = parse_modes(entry, where, root=root, known_points=dofs)
            names = list(modes.points)
    except ModalTestError as exc:
        raise DatasetError(str(exc)) from None
    if modes.shapes is None:
        raise DatasetError(f"{where}: every mode needs a `shape` at model DOFs (the check pairs "
                           "modes by MAC)")
    unknown = [d for d in names if dofs is not None and d not in dofs]
    if unknown:
        raise DatasetError(f"{where}: DOF(s) {unknown} not in the model; its DOFs are "
                           f"{list(dofs)}")
    return {"frequencies_hz": modes.frequencies_hz.tolist(), "shapes": modes.shapes.tolist(),
            "dofs": names}

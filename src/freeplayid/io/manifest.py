"""A data set's ``manifest.yaml``, parsed and checked into one :class:`Manifest` record.

The contract (docs/identify.md):

```yaml
name: fin A, 2026-05 campaign
model: model.npz                # relative to the manifest
quantity: acceleration          # displacement | velocity | acceleration
units: g                        # g | m/s^2 for acceleration; m, m/s otherwise
sample_rate: 2048               # Hz; if absent, the runs' 'time' column defines it
channels: {acc_tl: uz_top_left, acc_lr: uz_lower_right}   # run-file column -> model DOF
base_channel: acc_base          # optional
antialias: flat                 # optional: unknown | flat | replay | {response: filter.csv}
base_delay_s: 0.0               # optional: how late the base channel is read against the others [s]
gravity_g: 0                    # optional: gravity along the shaking axis [g] (+1: vertical, + up)
runs:
  - {file: sweep_0.60g.csv, level_g: 0.60, sweep: {start_hz: 30, stop_hz: 50, rate_hz_per_s: 0.1}}
  - {file: sweep_0.80g.csv, level_g: 0.80, sweep: {start_hz: 20, stop_hz: 80, octaves_per_min: 2}}
csv: {delimiter: ";", decimal: ",", units_row: true}   # optional: CSV layout (default plain)
mat: {data: TimeData, names: ChanName, units: Unit, increment: hDelta}   # optional: MAT layout
```

A ``sweep`` hint gives a linear (``rate_hz_per_s``) or a logarithmic (``octaves_per_min``) law,
not both (:class:`freeplayid.sweep.Sweep`).

:func:`read_manifest` makes every check of the manifest itself, in a fixed order, before any run
file is read (:func:`freeplayid.io.read_dataset` reads them afterwards): each problem is a
one-line :class:`~freeplayid.errors.DatasetError` naming the file, the field and the allowed
values. The rules a data set obeys whatever its source (quantity and units, the channel map,
sweep hints, ...) are :mod:`freeplayid.dataset`'s, shared with :meth:`Dataset.from_arrays`.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field, fields
from pathlib import Path

import yaml

from ..acquisition import check_antialias, check_base_delay
from ..dataset import (
    SWEEP_KEYS,
    SWEEP_RATE_KEYS,
    check_channel_dofs,
    check_channels,
    check_frame,
    check_gravity,
    check_keys,
    check_number,
    check_one_column_per_dof,
    check_quantity_units,
    check_sweep_hint,
)
from ..errors import DatasetError, ModalTestError, SystemFileError
from ..model.system import load_system
from .modal_tests import parse_modes
from .readers import Layouts, reader_for

__all__ = ["Manifest", "RunEntry", "read_manifest", "check_quantity_units",
           "check_one_column_per_dof", "MANIFEST_KEYS", "RUN_KEYS", "SWEEP_KEYS",
           "SWEEP_RATE_KEYS"]

LAYOUT_KEYS = tuple(f.name for f in fields(Layouts))  # the blocks that declare a file layout
MANIFEST_KEYS = ("name", "model", "quantity", "units", "sample_rate", "channels",
                 "base_channel", "frame", "truth", "runs", "reference_modes", "antialias",
                 "base_delay_s", "gravity_g", *LAYOUT_KEYS)
RUN_KEYS = ("file", "level_g", "sweep")


@dataclass(frozen=True)
class RunEntry:
    """One checked ``runs`` entry of a manifest (its file not read yet).

    Attributes
    ----------
    name : str
        The ``file`` as written, relative to the manifest.
    path : Path
        The run file (exists, inside the data-set folder, of a known suffix).
    level_g : float or None [g]
    sweep : dict or None
        ``{start_hz, stop_hz, rate_hz_per_s | octaves_per_min}`` as floats.
    """

    name: str
    path: Path
    level_g: float | None = None
    sweep: dict | None = None


@dataclass(frozen=True)
class Manifest:
    """A checked ``manifest.yaml``: every field of the contract, typed.

    Attributes
    ----------
    path : Path
        The manifest file as given (:attr:`freeplayid.dataset.Dataset.path` is its resolved form).
    name : str
    model : Path or None
        The resolved model file (exists).
    quantity, units : str
    sample_rate : float or None [Hz]
        None: the first readable run's time column defines it.
    channels : dict str -> str
        Run-file column -> model DOF, in column order.
    base_channel : str or None
    truth : dict or None
        ``{"kn": [N m/rad], "delta": [rad]}``.
    frame : {"absolute", "relative"}
        What the channels record (:attr:`freeplayid.dataset.Dataset.frame`; default absolute).
    reference_modes : dict or None
        ``{"frequencies_hz", "shapes", "dofs"}`` (see :class:`freeplayid.dataset.Dataset`).
    runs : tuple of RunEntry
    layouts : Layouts
        The run files' layout as declared by the ``csv:`` and ``mat:`` blocks (defaults
        without them).
    antialias : {"unknown", "flat", "replay"} or FilterResponse
        The records' anti-alias filter (:mod:`freeplayid.acquisition`; default "unknown").
    base_delay_s : float [s]
        How late the base channel is read against the responses (default 0).
    """

    path: Path
    name: str
    model: Path | None
    quantity: str
    units: str
    sample_rate: float | None
    channels: dict
    base_channel: str | None
    truth: dict | None
    reference_modes: dict | None
    runs: tuple
    layouts: Layouts = field(default_factory=Layouts)
    frame: str = "absolute"
    antialias: object = "unknown"
    base_delay_s: float = 0.0
    gravity_g: float = 0.0

    @property
    def columns(self) -> list[str]:
        """The columns every run file must have besides 'time': the channels, then the base."""
        return [*self.channels] + ([self.base_channel] if self.base_channel else [])


def read_manifest(path: str | os.PathLike, *, check_model: bool = True) -> Manifest:
    """Parse and check a data set's manifest (a folder holding ``manifest.yaml``, or the file).

    Parameters
    ----------
    path : path
    check_model : bool
        Load the manifest's model file and check that every channel names one of its DOFs.

    Raises
    ------
    DatasetError
        One line naming the file, the field and the allowed values: no manifest, a path that is
        not a ``.yaml`` manifest, a binary file, invalid YAML, a key given twice in a mapping
        (with its line), unknown fields, bad quantity/units, two columns on one DOF, channels
        not in the model, a `frame` not absolute or relative (or relative with a base
        channel), bad reference modes, an ``antialias`` that is none of its forms (a name, a
        response's lists or its CSV file), a ``base_delay_s`` that is not a number within
        +-0.05 s or is stated without a base channel, a ``gravity_g`` that is not a number
        within +-1, a run file that is missing, outside the
        data-set folder (absolute or ``..``) or of an unknown suffix (the message lists the valid
        ones), no runs, a ``csv:`` or ``mat:`` block with an unknown field or a value outside its
        allowed set (:class:`~freeplayid.io.readers.csv.CsvLayout`,
        :class:`~freeplayid.io.readers.mat.MatLayout`).
    """
    manifest_path = _manifest_path(Path(path))
    where = f"{manifest_path}: "
    m = _load_manifest(manifest_path)
    _check_fields(m, where)
    channels, base_channel = check_channels(m["channels"], m.get("base_channel"), where)
    frame = check_frame(m.get("frame", "absolute"), base_channel, where)
    fs = m.get("sample_rate")
    if fs is not None:
        fs = check_number(fs, f"{where}`sample_rate` [Hz]")
    truth = _truth(m.get("truth"), where)
    root = manifest_path.parent
    model_path, dofs = _model(m.get("model"), root, channels, where, check_model=check_model)
    reference_modes = None
    if m.get("reference_modes") is not None:
        reference_modes = _reference_modes(m["reference_modes"], f"{where}`reference_modes`",
                                           root, dofs)
    return Manifest(
        path=manifest_path,
        name=str(m.get("name", "")),
        model=model_path,
        quantity=m["quantity"],
        units=m["units"],
        sample_rate=fs,
        channels=dict(channels),
        base_channel=base_channel,
        truth=truth,
        reference_modes=reference_modes,
        runs=_run_entries(m["runs"], root, where),
        layouts=_layouts(m, where),
        frame=frame,
        antialias=check_antialias(m.get("antialias"), where, root),
        base_delay_s=check_base_delay(m.get("base_delay_s"), base_channel, where),
        gravity_g=check_gravity(m.get("gravity_g"), where),
    )


# --------------------------------------------------------------------------- the file itself
def _manifest_path(path: Path) -> Path:
    """The manifest file of a data-set folder or path; an error for a missing or non-YAML one."""
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
    return manifest_path


class _ManifestLoader(yaml.SafeLoader):
    """yaml's SafeLoader, but a key given twice in one mapping is an error, not "last one wins"
    (``units: g`` ... ``units: m/s^2`` would otherwise silently keep the second)."""


# YAML 1.1 reads 101:3 as the base-60 integer 6063 (and 1:30.5 as 90.5): a UFF channel
# NODE:DIR written unquoted must stay a string, so the manifest's YAML has no base-60 numbers
_NO_BASE_60 = {
    "tag:yaml.org,2002:int": re.compile(
        r"^(?:[-+]?0b[0-1_]+|[-+]?0[0-7_]+|[-+]?(?:0|[1-9][0-9_]*)|[-+]?0x[0-9a-fA-F_]+)$"),
    "tag:yaml.org,2002:float": re.compile(
        r"^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+][0-9]+)?|\.[0-9][0-9_]*(?:[eE][-+][0-9]+)?"
        r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"),
}
_ManifestLoader.yaml_implicit_resolvers = {
    first: [(tag, _NO_BASE_60.get(tag, regexp)) for tag, regexp in resolvers]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}


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


# --------------------------------------------------------------------------- the fields
def _check_fields(m, where: str) -> None:
    """A mapping of known fields with the required ones, a valid quantity and its units."""
    if not isinstance(m, dict):
        raise DatasetError(f"{where}must be a YAML mapping of the fields {list(MANIFEST_KEYS)} "
                           "(give the data-set folder or its manifest.yaml)")
    check_keys(m, MANIFEST_KEYS, where)
    for key in ("quantity", "units", "channels", "runs"):
        if key not in m:
            raise DatasetError(f"{where}missing field `{key}`")
    check_quantity_units(m["quantity"], m["units"], where)


def _truth(truth, where: str) -> dict | None:
    if truth is None:
        return None
    if not isinstance(truth, dict):
        raise DatasetError(f"{where}`truth` must be a mapping {{kn, delta}}, got {truth!r}")
    check_keys(truth, ("kn", "delta"), f"{where}`truth`: ")
    return {k: check_number(v, f"{where}`truth.{k}`") for k, v in truth.items()}


def _model(model, root: Path, channels: dict, where: str, *,
           check_model: bool) -> tuple[Path | None, tuple | None]:
    """The resolved model file and, when ``check_model``, its DOF names (every channel's DOF
    among them); (None, None) without a ``model`` field."""
    if model is None:
        return None, None
    if not isinstance(model, str):
        raise DatasetError(f"{where}`model` must be a file name, got {model!r}")
    model_path = (root / model).resolve()
    if not model_path.is_file():
        raise DatasetError(f"{where}`model` file {model!r} not found (looked at {model_path})")
    if not check_model:
        return model_path, None
    try:
        dofs = load_system(model_path).dof_names
    except SystemFileError as exc:
        raise DatasetError(f"{where}`model`: {exc}") from None
    check_channel_dofs(channels, dofs, model, where)
    return model_path, dofs


def _reference_modes(entry, where: str, root: Path, dofs) -> dict:
    """The manifest's optional ``reference_modes`` (docs/identify.md): ``{modes: [{frequency_hz,
    shape: {dof: value}}]}`` or ``{uff: FILE, nodes: {node: dof}}`` (UFF dataset 55)."""
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


def _layouts(m: dict, where: str) -> Layouts:
    """The layout blocks (``csv:``, ``mat:``) as a :class:`~freeplayid.io.readers.Layouts`: each a
    mapping of its record's fields, checked by the record."""
    given = {}
    for f in fields(Layouts):
        entry = m.get(f.name)
        if entry is None:
            continue
        cls = type(f.default_factory())
        names = [g.name for g in fields(cls)]
        at = f"{where}`{f.name}`"
        if not isinstance(entry, dict):
            raise DatasetError(f"{at} must be a mapping of (some of) {names}, got {entry!r}")
        check_keys(entry, names, f"{at}: ")
        try:
            given[f.name] = cls(**entry)
        except ValueError as exc:
            raise DatasetError(f"{at}: {exc}") from None
    return Layouts(**given)


# --------------------------------------------------------------------------- the runs
def _run_entries(entries, root: Path, where: str) -> tuple[RunEntry, ...]:
    """Every manifest check of every run, before any run file is read."""
    if not isinstance(entries, list) or not entries:
        raise DatasetError(f"{where}`runs` must be a non-empty list of {{file, ...}} entries")
    out = []
    seen = set()
    for k, entry in enumerate(entries):
        at = f"{where}`runs[{k}]`"
        if not isinstance(entry, dict) or "file" not in entry:
            raise DatasetError(f"{at} must be a mapping with a `file`, got {entry!r}")
        check_keys(entry, RUN_KEYS, f"{at}: ")
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
            level = check_number(level, f"{at}.level_g [g]")
        sweep = entry.get("sweep")
        if sweep is not None:
            sweep = check_sweep_hint(sweep, f"{at}.sweep")
        out.append(RunEntry(name=name, path=f, level_g=level, sweep=sweep))
    return tuple(out)


def _check_inside(name: str, where: str) -> None:
    """A run file must be a relative path that stays inside the data-set folder."""
    parts = Path(os.path.normpath(name)).parts
    if os.path.isabs(name) or Path(name).is_absolute() or (parts and parts[0] == ".."):
        raise DatasetError(
            f"{where}.file {name!r} must be a path inside the data-set folder (relative, no "
            "'..' leaving it, no absolute path)"
        )

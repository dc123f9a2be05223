"""Modal-test files: the measured modes of the paper's three part tests (docs/model.md).

A YAML file (``modal.yaml``); every test is optional, at least one is needed::

    name: my fin, hammer tests 2024-05        # optional
    points:                                   # optional: extra named points, fin coordinates [m]
      tip_mid: [0.10, 0.26]
      "101": [0.0, 0.26]                      # UFF node 101
    outboard_free:                            # outboard fin, free-free
      modes:
        - frequency_hz: 512.3                 # [Hz], required
          damping: 0.004                      # [-], viscous ratio, optional
          shape: {top_left: 1.0, tip_mid: -0.42}   # w at named points, optional
    inboard_free:
      uff: inboard_free.unv                   # or: UFF dataset-55 records (node N = point "N")
    inboard_clamped:                          # inboard fin clamped on its root (Table 8)
      modes: [...]

Points are the fin configuration's (``top_left``, ``lower_right``, ``exciting``) or declared in
``points``. Within one test either no mode has a ``shape`` or all give values at the same points.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import yaml

from ..errors import ModalTestError
from ..model.from_test.measured import CONFIG_POINTS, TEST_NAMES, MeasuredModes, ModalTest

__all__ = ["read_modal_test", "parse_modes", "read_uff_modes", "ModalTestError"]

MODE_KEYS = ("frequency_hz", "damping", "shape")
TOP_KEYS = ("name", "points") + TEST_NAMES


def _number(value, where: str, *, lo: float = 0.0, lo_open: bool = True) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ModalTestError(f"{where} must be a number, got {value!r}") from None
    if not np.isfinite(v) or v < lo or (lo_open and v == lo):
        raise ModalTestError(f"{where} must be a finite number {'>' if lo_open else '>='} {lo:g}, "
                             f"got {value!r}")
    return v


def read_uff_modes(path: str | os.PathLike, where: str = "") -> tuple:
    """Modes of the dataset-55 (data at nodes) records of a UFF file.

    Returns
    -------
    frequencies_hz : ndarray, shape (m,) [Hz]
    damping : ndarray, shape (m,) [-]
        ``modal_damp_vis`` of each record (NaN if absent).
    nodes : tuple of str, shape (n,)
        Node numbers (as strings) of the shape rows.
    shapes : ndarray, shape (n, m)
        Uz (``r3``) of each node, real part.
    """
    import pyuff

    path = Path(path)
    at = where or str(path)
    if not path.is_file():
        raise ModalTestError(f"{at}: UFF file {path} not found")
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as exc:  # pyuff raises bare Exceptions on malformed files
        raise ModalTestError(f"{at}: {path} is not a readable UFF file ({exc})") from None
    records = [s for s in ([sets] if isinstance(sets, dict) else sets) if s.get("type") == 55]
    if not records:
        raise ModalTestError(f"{at}: {path} has no dataset-55 (mode shape) records")
    nodes = tuple(str(int(n)) for n in records[0]["node_nums"])
    f, z, shapes = [], [], []
    for k, r in enumerate(records):
        if tuple(str(int(n)) for n in r["node_nums"]) != nodes:
            raise ModalTestError(f"{at}: {path} record {k} has other nodes than record 0")
        if "freq" not in r:
            raise ModalTestError(f"{at}: {path} record {k} has no frequency (analysis type 2, "
                                 "normal modes, is needed)")
        f.append(_number(r["freq"], f"{at}: record {k} frequency [Hz]"))
        z.append(float(r.get("modal_damp_vis", np.nan)))
        shapes.append(np.real(np.asarray(r["r3"], dtype=complex)))
    return np.array(f), np.array(z), nodes, np.array(shapes).T


def parse_modes(entry, where: str, *, root: Path, known_points) -> MeasuredModes:
    """One test's (or a manifest's ``reference_modes``) modes from a YAML entry.

    ``entry`` is ``{modes: [{frequency_hz, damping?, shape?: {point: value}}]}`` or
    ``{uff: FILE}`` (relative to ``root``); shape rows are named by ``known_points`` (None: any
    name).
    """
    if not isinstance(entry, Mapping) or len({"modes", "uff"} & set(entry)) != 1:
        raise ModalTestError(f"{where} must be a mapping with `modes` (a list) or `uff` (a file)")
    extra = sorted(set(entry) - {"modes", "uff"})
    if extra:
        raise ModalTestError(f"{where}: unknown field(s) {extra}; allowed: ['modes', 'uff']")
    known = None if known_points is None else set(known_points)
    if "uff" in entry:
        f, z, nodes, shapes = read_uff_modes(root / str(entry["uff"]), f"{where}.uff")
        unknown = [n for n in nodes if known is not None and n not in known]
        if unknown:
            raise ModalTestError(f"{where}.uff: node(s) {unknown} are unknown points; declare "
                                 f"them in `points` (known: {sorted(known)})")
        return MeasuredModes(f, z, shapes, nodes, where=where)
    modes = entry["modes"]
    if not isinstance(modes, list) or not modes:
        raise ModalTestError(f"{where}.modes must be a non-empty list of {{frequency_hz, ...}}")
    f, z, rows, pts = [], [], [], None
    for i, m in enumerate(modes):
        at = f"{where}.modes[{i}]"
        if not isinstance(m, Mapping):
            raise ModalTestError(f"{at} must be a mapping of {list(MODE_KEYS)}, got {m!r}")
        extra = sorted(set(m) - set(MODE_KEYS))
        if extra:
            raise ModalTestError(f"{at}: unknown field(s) {extra}; allowed: {list(MODE_KEYS)}")
        if "frequency_hz" not in m:
            raise ModalTestError(f"{at}: missing field `frequency_hz` [Hz]")
        f.append(_number(m["frequency_hz"], f"{at}.frequency_hz"))
        z.append(np.nan if m.get("damping") is None else
                 _number(m["damping"], f"{at}.damping", lo_open=False))
        shape = m.get("shape")
        if (shape is None) != (pts is None) and i > 0:
            raise ModalTestError(f"{at}.shape: give a shape for every mode of the test or for "
                                 "none")
        if shape is None:
            continue
        if not isinstance(shape, Mapping) or not shape:
            raise ModalTestError(f"{at}.shape must map point names to values, got {shape!r}")
        names = tuple(str(k) for k in shape)
        unknown = [n for n in names if known is not None and n not in known]
        if unknown:
            raise ModalTestError(f"{at}.shape: unknown point(s) {unknown}; known: "
                                 f"{sorted(known)}")
        if pts is None:
            pts = names
        elif set(names) != set(pts):
            raise ModalTestError(f"{at}.shape: points {sorted(names)} differ from those of "
                                 f"mode 0 {sorted(pts)}; give every mode the same points")
        rows.append([_number(shape[k], f"{at}.shape.{k}", lo=-np.inf) for k in pts])
    shapes = None if pts is None else np.array(rows).T
    if shapes is not None and not np.all(np.any(shapes != 0, axis=0)):
        raise ModalTestError(f"{where}: a mode shape is all zero")
    return MeasuredModes(np.array(f), np.array(z), shapes, pts or (), where=where)


def read_modal_test(path: str | os.PathLike) -> ModalTest:
    """Read and validate a modal-test file (module docstring).

    Raises
    ------
    ModalTestError
        Naming the file and the field: missing file, not YAML, unknown or missing fields, bad
        numbers, unknown points, an unreadable UFF file.
    """
    path = Path(path)
    if not path.is_file():
        raise ModalTestError(f"{path}: modal-test file not found")
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except yaml.YAMLError as exc:
        raise ModalTestError(f"{path}: not valid YAML ({exc})") from None
    if not isinstance(data, Mapping):
        raise ModalTestError(f"{path}: must be a YAML mapping of {list(TOP_KEYS)}")
    extra = sorted(set(data) - set(TOP_KEYS))
    if extra:
        raise ModalTestError(f"{path}: unknown field(s) {extra}; allowed: {list(TOP_KEYS)}")
    points = {}
    for k, v in (data.get("points") or {}).items():
        try:
            x, y = (float(c) for c in v)
        except (TypeError, ValueError):
            raise ModalTestError(f"{path}: `points.{k}` must be [x, y] in m, got {v!r}") from None
        if str(k) in CONFIG_POINTS:
            raise ModalTestError(f"{path}: `points.{k}` is the configuration's point; rename it")
        points[str(k)] = (x, y)
    known = set(points) | set(CONFIG_POINTS)
    tests = {t: parse_modes(data[t], f"{path}: `{t}`", root=path.parent, known_points=known)
             for t in TEST_NAMES if t in data}
    if not tests:
        raise ModalTestError(f"{path}: no test; give one or more of {list(TEST_NAMES)}")
    return ModalTest(tests=tests, points=points, source=str(path), name=str(data.get("name", "")))

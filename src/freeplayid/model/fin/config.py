"""Configuration of the folding fin: geometry, per-part plates, hinges, points, damping, reduction.

Built from a plain mapping (a YAML file or a Hydra cfg converted to a dict); every level rejects
unknown keys with a ``ValueError`` that lists the allowed ones. Units are SI (m, Pa, kg/m^3, rad,
N m/rad). The layout of the mapping is the one of the default fin ``freeplayid/model/fin/fin.yaml``
(package data, :func:`fin_config_path`; also the scripts' Hydra option ``model=fin``)::

    kind: fin
    geometry: {root_chord, inboard_span, outboard_span, outboard_chord}
    parts: {inboard: {E, rho, nu, thickness}, outboard: {...}}
    mesh: {element_size}
    hinge: {x: [left, mid, right], knuckle_width, kn, delta}
    points: {top_left: [x, y], lower_right: [x, y], exciting: [x, y]}
    damping: {model: modal | rayleigh, zeta, f1, f2, parts: {inboard: zeta, outboard: zeta}}
    reduction: {method: craig_bampton | guyan, n_modes, interior: system | fixed_interface}
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import yaml

if TYPE_CHECKING:
    from importlib.resources.abc import Traversable

__all__ = [
    "PartProperties",
    "FinConfig",
    "fin_config_path",
    "load_fin_config",
    "default_fin_parameters",
]

PARTS = ("inboard", "outboard")
HINGES = ("left", "mid", "right")


def fin_config_path() -> Traversable:
    """The default fin configuration, shipped as package data: ``freeplayid/model/fin/fin.yaml``.

    Found through :mod:`importlib.resources`, so in a source checkout and in an installed wheel
    alike. The same file is the scripts' Hydra option ``model=fin``
    (:func:`freeplayid.tasks.register_configs`). A ``Path`` for a package on disk; in general a
    ``Traversable`` (``.read_text()``, ``.is_file()``).
    """
    return files("freeplayid.model.fin") / "fin.yaml"


def _keys(mapping, allowed: tuple[str, ...], where: str, *, required: tuple[str, ...] = ()):
    if not isinstance(mapping, Mapping):
        raise ValueError(f"`{where}` must be a mapping, got {type(mapping).__name__}")
    unknown = sorted(set(mapping) - set(allowed))
    if unknown:
        raise ValueError(f"`{where}` has unknown key(s) {unknown}; allowed: {list(allowed)}")
    missing = [k for k in required if k not in mapping]
    if missing:
        raise ValueError(f"`{where}` is missing key(s) {missing}; required: {list(required)}")
    return mapping


def _pos(value, where: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"`{where}` must be a number, got {value!r}") from None
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"`{where}` must be a finite number > 0, got {value!r}")
    return v


def _point(value, where: str) -> tuple[float, float]:
    try:
        x, y = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"`{where}` must be a pair [x, y] in m, got {value!r}") from None
    return (x, y)


@dataclass(frozen=True)
class PartProperties:
    """Isotropic plate of one part: E [Pa], rho [kg/m^3], nu [-], thickness [m]."""

    E: float
    rho: float
    nu: float
    thickness: float

    def __post_init__(self) -> None:
        for name in ("E", "rho", "thickness"):
            object.__setattr__(self, name, _pos(getattr(self, name), name))
        nu = float(self.nu)
        if not (-1.0 < nu < 0.5):
            raise ValueError(f"`nu` must lie in (-1, 0.5), got {self.nu!r}")
        object.__setattr__(self, "nu", nu)

    @classmethod
    def from_mapping(cls, m, where: str = "part") -> PartProperties:
        _keys(m, ("E", "rho", "nu", "thickness"), where, required=("E", "rho", "nu", "thickness"))
        try:
            return cls(**dict(m))
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None


@dataclass(frozen=True)
class FinConfig:
    """The folding fin (docs/model.md). Fin in the x-y plane, root edge y = 0, hinge line y = s_in.

    Inboard plate [0, root_chord] x [0, inboard_span] clamped on y = 0; outboard plate
    [0, outboard_chord] x [inboard_span, inboard_span + outboard_span]. Hinge axis along x.

    Attributes
    ----------
    root_chord, inboard_span, outboard_span, outboard_chord : float [m]
    parts : dict str -> PartProperties
        "inboard" and "outboard".
    element_size : float [m]
        Target element side; each plate gets ceil(side / element_size) elements per side.
    hinge_x : tuple of 3 float [m]
        x of the left, middle and right hinge node pairs on the hinge line.
    knuckle_width : float [m]
        Width of the rigid knuckle of each hinge (plate hinge-edge nodes within +-width/2 of the
        hinge are rigidly linked to it).
    kn : float [N m/rad]
        Default contact stiffness of each freeplay spring (also the stiffness at which the damping
        is defined).
    delta : float [rad]
        Default half-gap.
    top_left, lower_right : (float, float) [m]
        Measure points on the outboard plate (snapped to the nearest node).
    exciting : (float, float) [m]
        Exciting point on the clamped root edge (the base; its Uz is the large-mass DOF).
    damping_model : "modal" or "rayleigh"
    zeta : float [-]
    part_zeta : tuple of (str, float)
        Modal damping only: a ratio per part (``(("inboard", z1), ("outboard", z2))``; YAML
        ``damping.parts``). Each zero-clearance mode then gets the ratio of its strain energy's
        parts (the modal strain energy method, :func:`freeplayid.model.fin.fe.mode_damping`),
        the hinge springs' share at ``zeta``. Empty (default): ``zeta`` in every mode.
    rayleigh_hz : (float, float) [Hz]
        f1, f2 of Rayleigh damping (ignored for modal damping).
    reduction : "craig_bampton" or "guyan"
    n_modes : int
        Interior (modal) coordinates kept by Craig-Bampton.
    interior : "system" or "fixed_interface"
        Interior vectors: the zero-clearance modes of the assembled fin at kn (their interior
        residuals; keeps those modes exact) or the classical fixed-interface modes.
    """

    root_chord: float
    inboard_span: float
    outboard_span: float
    outboard_chord: float
    parts: dict
    element_size: float
    hinge_x: tuple
    knuckle_width: float
    kn: float
    delta: float
    top_left: tuple
    lower_right: tuple
    exciting: tuple
    damping_model: str = "modal"
    zeta: float = 0.02
    rayleigh_hz: tuple = (30.0, 60.0)
    part_zeta: tuple = ()
    reduction: str = "craig_bampton"
    n_modes: int = 6
    interior: str = "system"

    def __post_init__(self) -> None:
        for name in ("root_chord", "inboard_span", "outboard_span", "outboard_chord"):
            object.__setattr__(self, name, _pos(getattr(self, name), f"geometry.{name}"))
        object.__setattr__(self, "element_size", _pos(self.element_size, "mesh.element_size"))
        object.__setattr__(self, "knuckle_width", _pos(self.knuckle_width, "hinge.knuckle_width"))
        object.__setattr__(self, "kn", _pos(self.kn, "hinge.kn"))
        delta = float(self.delta)
        if not (np.isfinite(delta) and delta >= 0):
            raise ValueError(f"`hinge.delta` must be >= 0, got {self.delta!r}")
        object.__setattr__(self, "delta", delta)
        if set(self.parts) != set(PARTS):
            raise ValueError(
                f"`parts` must have exactly the keys {list(PARTS)}, got {list(self.parts)}"
            )
        hx = tuple(float(v) for v in self.hinge_x)
        x_max = min(self.root_chord, self.outboard_chord)
        if len(hx) != 3 or not (0 <= hx[0] < hx[1] < hx[2] <= x_max):
            raise ValueError(
                f"`hinge.x` must be 3 increasing positions (left, mid, right) in [0, {x_max}] m "
                f"(on both hinge edges), got {self.hinge_x!r}"
            )
        if self.knuckle_width >= min(np.diff(hx)):
            raise ValueError(
                f"`hinge.knuckle_width` = {self.knuckle_width} m must be smaller than the hinge "
                f"spacing {min(np.diff(hx)):.4g} m"
            )
        object.__setattr__(self, "hinge_x", hx)
        y0, y1 = self.inboard_span, self.inboard_span + self.outboard_span
        for name in ("top_left", "lower_right"):
            x, y = _point(getattr(self, name), f"points.{name}")
            if not (0 <= x <= self.outboard_chord and y0 < y <= y1):
                raise ValueError(
                    f"`points.{name}` = {(x, y)} must lie on the outboard plate "
                    f"[0, {self.outboard_chord}] x ({y0}, {y1}] m, off the hinge line"
                )
            object.__setattr__(self, name, (x, y))
        ex = _point(self.exciting, "points.exciting")
        if not (0 <= ex[0] <= self.root_chord and ex[1] == 0.0):
            raise ValueError(f"`points.exciting` = {ex} must lie on the root edge y = 0")
        object.__setattr__(self, "exciting", ex)
        self._check_damping_and_reduction()

    def _check_damping_and_reduction(self) -> None:
        """The ``damping`` and ``reduction`` fields, checked and normalised in place."""
        if self.damping_model not in ("modal", "rayleigh"):
            raise ValueError(
                f"`damping.model` must be 'modal' or 'rayleigh', got {self.damping_model!r}"
            )
        z = float(self.zeta)
        if not (0 <= z < 1):
            raise ValueError(f"`damping.zeta` must lie in [0, 1), got {self.zeta!r}")
        object.__setattr__(self, "zeta", z)
        f1, f2 = (float(v) for v in self.rayleigh_hz)
        if not (0 < f1 < f2):
            raise ValueError(f"`damping.f1`, `damping.f2` must satisfy 0 < f1 < f2, got {f1}, {f2}")
        object.__setattr__(self, "rayleigh_hz", (f1, f2))
        try:
            pz = dict(self.part_zeta)
            bad = bool(set(pz) - set(PARTS)) or not all(0 <= float(v) < 1 for v in pz.values())
        except (TypeError, ValueError):
            pz, bad = self.part_zeta, True
        if bad:
            raise ValueError(f"`damping.parts` must map parts among {list(PARTS)} to ratios in "
                             f"[0, 1), got {pz!r}")
        if pz and self.damping_model != "modal":
            raise ValueError("`damping.parts` needs `damping.model` 'modal' (a ratio per part "
                             f"is given to each mode by its strain energy), got "
                             f"{self.damping_model!r}")
        object.__setattr__(self, "part_zeta", tuple((k, float(pz[k])) for k in PARTS if k in pz))
        if self.reduction not in ("craig_bampton", "guyan"):
            raise ValueError(
                f"`reduction.method` must be 'craig_bampton' or 'guyan', got {self.reduction!r}"
            )
        if int(self.n_modes) != self.n_modes or self.n_modes < 0:
            raise ValueError(f"`reduction.n_modes` must be an integer >= 0, got {self.n_modes!r}")
        object.__setattr__(self, "n_modes", int(self.n_modes))
        if self.interior not in ("system", "fixed_interface"):
            raise ValueError(
                f"`reduction.interior` must be 'system' or 'fixed_interface', got {self.interior!r}"
            )

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_mapping(cls, mapping) -> FinConfig:
        """Build from a nested mapping laid out like the default ``fin.yaml`` (``kind``: 'fin')."""
        top = ("kind", "geometry", "parts", "mesh", "hinge", "points", "damping", "reduction")
        m = _keys(mapping, top, "model", required=top[1:6])
        if m.get("kind", "fin") != "fin":
            raise ValueError(f"`model.kind` must be 'fin' for a fin model, got {m['kind']!r}")
        geo_keys = ("root_chord", "inboard_span", "outboard_span", "outboard_chord")
        g = _keys(m["geometry"], geo_keys, "geometry", required=geo_keys[:3])
        p = _keys(m["parts"], PARTS, "parts", required=PARTS)
        parts = {k: PartProperties.from_mapping(p[k], f"parts.{k}") for k in PARTS}
        mesh = _keys(m["mesh"], ("element_size",), "mesh", required=("element_size",))
        hinge_keys = ("x", "knuckle_width", "kn", "delta")
        h = _keys(m["hinge"], hinge_keys, "hinge", required=hinge_keys)
        pt_keys = ("top_left", "lower_right", "exciting")
        pts = _keys(m["points"], pt_keys, "points", required=pt_keys[:2])
        d = _keys(m.get("damping", {}), ("model", "zeta", "f1", "f2", "parts"), "damping")
        r = _keys(m.get("reduction", {}), ("method", "n_modes", "interior"), "reduction")
        return cls(
            root_chord=g["root_chord"],
            inboard_span=g["inboard_span"],
            outboard_span=g["outboard_span"],
            outboard_chord=g.get("outboard_chord", g["root_chord"]),
            parts=parts,
            element_size=mesh["element_size"],
            hinge_x=tuple(h["x"]),
            knuckle_width=h["knuckle_width"],
            kn=h["kn"],
            delta=h["delta"],
            top_left=tuple(pts["top_left"]),
            lower_right=tuple(pts["lower_right"]),
            exciting=tuple(pts.get("exciting", (0.5 * float(g["root_chord"]), 0.0))),
            damping_model=d.get("model", "modal"),
            zeta=d.get("zeta", 0.02),
            rayleigh_hz=(d.get("f1", 30.0), d.get("f2", 60.0)),
            part_zeta=d.get("parts") or (),
            reduction=r.get("method", "craig_bampton"),
            n_modes=r.get("n_modes", 6),
            interior=r.get("interior", "system"),
        )

    def replace(self, **changes) -> FinConfig:
        """A copy with some fields replaced (validated again)."""
        return dataclasses.replace(self, **changes)

    def with_part(self, part: str, **props) -> FinConfig:
        """A copy with some properties (E, rho, nu, thickness) of one part changed."""
        if part not in PARTS:
            raise ValueError(f"`part` must be one of {list(PARTS)}, got {part!r}")
        parts = dict(self.parts)
        parts[part] = dataclasses.replace(parts[part], **props)
        return self.replace(parts=parts)


def load_fin_config(path=None) -> FinConfig:
    """Read a fin configuration YAML (default: the package's default fin, :func:`fin_config_path`).

    Parameters
    ----------
    path : str or path-like, optional
        A YAML file laid out like the default one; ``None`` reads the default fin.
    """
    if path is None:
        path = fin_config_path()
        if not path.is_file():  # a broken install: the wheel was built without its package data
            raise FileNotFoundError(
                f"the default fin configuration {path} is missing from the installed package "
                "(package data freeplayid/model/fin/fin.yaml, pyproject "
                "[tool.setuptools.package-data])"
            )
    else:
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(
                f"`path`: fin configuration {path} not found (None reads the package's default "
                "fin; a mapping goes to fin_from_config())"
            )
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    try:
        return FinConfig.from_mapping(data)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def default_fin_parameters() -> dict:
    """Default hinge values of the default fin (:func:`fin_config_path`).

    Returns ``{'kn': float [N m/rad], 'delta': float [rad]}``.
    """
    cfg = load_fin_config()
    return {"kn": cfg.kn, "delta": cfg.delta}

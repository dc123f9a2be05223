"""The linear structure with freeplay hinges, and its `.npz` file contract.

A :class:`FreeplaySystem` is the fixed-base (relative-coordinate) model of docs/backbone.md::

    M y'' + C y' + K y + sum_j b_j f(b_j^T y) = -M r a_g(t)

``K`` excludes the freeplay springs; ``hinge_pairs`` names the (outboard, inboard) DOFs of each
spring, so ``b_j`` has +1 at the outboard DOF and -1 at the inboard one. All springs share one
(kn, delta). ``base_influence`` is ``r``: the motion of each DOF per unit base displacement, so the
absolute acceleration is ``y'' + r a_g``.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..errors import SystemFileError

__all__ = ["FreeplaySystem", "load_system", "save_system", "SystemFileError"]

_REQUIRED_KEYS = ("M", "K", "dof_names", "hinge_pairs")
_OPTIONAL_KEYS = ("C", "base_influence")


def _check_square_symmetric(name: str, a: np.ndarray, n: int, *, rtol: float = 1e-8) -> None:
    if a.shape != (n, n):
        raise ValueError(f"`{name}` must have shape ({n}, {n}) to match `dof_names`, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"`{name}` contains NaN or inf")
    scale = max(float(np.max(np.abs(a))), np.finfo(float).tiny)
    asym = float(np.max(np.abs(a - a.T)))
    if asym > rtol * scale:
        raise ValueError(
            f"`{name}` must be symmetric, max |{name} - {name}^T| = {asym:.3g} "
            f"(relative {asym / scale:.3g} > {rtol:g})"
        )


def _dof_names(dof_names) -> tuple[str, ...]:
    """The DOF names as a tuple of unique non-empty strings (at least one)."""
    names = tuple(str(s) for s in np.asarray(dof_names, dtype=object).ravel())
    if len(set(names)) != len(names):
        dup = sorted({s for s in names if names.count(s) > 1})
        raise ValueError(f"`dof_names` must be unique, duplicated: {dup}")
    if any(not s for s in names):
        raise ValueError("`dof_names` must be non-empty strings")
    if len(names) == 0:
        raise ValueError("`dof_names` is empty: a system needs at least one DOF")
    return names


def _mass_and_stiffness(M, K, n: int) -> tuple[np.ndarray, np.ndarray]:
    """M (symmetric positive definite) and K (symmetric positive semidefinite), (n, n),
    symmetrised."""
    M = np.array(M, dtype=float)
    K = np.array(K, dtype=float)
    _check_square_symmetric("M", M, n)
    _check_square_symmetric("K", K, n)
    M = 0.5 * (M + M.T)
    K = 0.5 * (K + K.T)
    try:
        np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        w = np.linalg.eigvalsh(M)
        raise ValueError(
            f"`M` must be positive definite, smallest eigenvalue is {w[0]:.3g}"
        ) from None
    kmin = float(np.linalg.eigvalsh(K)[0])
    if kmin < -1e-8 * max(float(np.max(np.abs(np.diag(K)))), 1.0):
        raise ValueError(
            f"`K` must be positive semidefinite, smallest eigenvalue is {kmin:.3g}"
        )
    return M, K


def _hinge_pairs(hinge_pairs, index: dict) -> tuple[tuple[str, str], ...]:
    """(outboard, inboard) DOF names of each spring, both known ("" inboard: to ground)."""
    pairs_in = np.asarray(hinge_pairs, dtype=object)
    if pairs_in.size == 0:
        pairs_in = pairs_in.reshape(0, 2)
    if pairs_in.ndim != 2 or pairs_in.shape[1] != 2:
        raise ValueError(
            f"`hinge_pairs` must have shape (h, 2) of (outboard, inboard) DOF names, "
            f"got shape {pairs_in.shape}"
        )
    pairs = []
    for j, (out, inn) in enumerate(pairs_in):
        out = str(out)
        inn = "" if inn is None else str(inn)
        for role, name in (("outboard", out), ("inboard", inn)):
            if role == "inboard" and name == "":
                continue
            if name not in index:
                raise ValueError(
                    f"`hinge_pairs[{j}]` {role} DOF {name!r} is not in `dof_names` "
                    f"(known: {list(index)})"
                )
        if out == inn:
            raise ValueError(f"`hinge_pairs[{j}]` connects DOF {out!r} to itself")
        pairs.append((out, inn))
    return tuple(pairs)


@dataclass(frozen=True, eq=False)
class FreeplaySystem:
    """Fixed-base linear structure plus freeplay hinge springs sharing one (kn, delta).

    Parameters
    ----------
    M : ndarray, shape (n, n) [kg, kg m^2, ...]
        Mass matrix, symmetric positive definite.
    K : ndarray, shape (n, n) [N/m, N m/rad, ...]
        Stiffness matrix without the freeplay springs, symmetric positive semidefinite (an open
        hinge may leave a mechanism).
    dof_names : sequence of str, length n
        Unique DOF names.
    hinge_pairs : sequence of (str, str), length h
        (outboard, inboard) DOF names of each freeplay spring; the spring acts on
        ``x_outboard - x_inboard``. An inboard name may be ``None``/"" for a spring to ground.
    C : ndarray, shape (n, n) [N s/m, ...], optional
        Viscous damping matrix; zero if absent.
    base_influence : ndarray, shape (n,) [-], optional
        Rigid-body influence vector ``r`` of the base excitation.
    """

    M: np.ndarray
    K: np.ndarray
    dof_names: tuple[str, ...]
    hinge_pairs: tuple[tuple[str, str], ...]
    C: np.ndarray | None = None
    base_influence: np.ndarray | None = None
    _index: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        names = _dof_names(self.dof_names)
        n = len(names)
        M, K = _mass_and_stiffness(self.M, self.K, n)
        index = {s: i for i, s in enumerate(names)}
        pairs = _hinge_pairs(self.hinge_pairs, index)
        C = None
        if self.C is not None:
            C = np.array(self.C, dtype=float)
            _check_square_symmetric("C", C, n)
            C = 0.5 * (C + C.T)
        r = None
        if self.base_influence is not None:
            r = np.array(self.base_influence, dtype=float).reshape(-1)
            if r.shape != (n,):
                raise ValueError(f"`base_influence` must have shape ({n},), got {r.shape}")
            if not np.all(np.isfinite(r)):
                raise ValueError("`base_influence` contains NaN or inf")
        for arr in (M, K, C, r):
            if arr is not None:
                arr.setflags(write=False)
        object.__setattr__(self, "M", M)
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "C", C)
        object.__setattr__(self, "base_influence", r)
        object.__setattr__(self, "dof_names", names)
        object.__setattr__(self, "hinge_pairs", pairs)
        object.__setattr__(self, "_index", index)

    # ------------------------------------------------------------------ structure
    @property
    def n_dof(self) -> int:
        return len(self.dof_names)

    @property
    def n_hinges(self) -> int:
        return len(self.hinge_pairs)

    def dof_index(self, name: str | list[str] | tuple[str, ...]) -> int | list[int]:
        """Index of a DOF name (or list of indices for a list of names)."""
        if isinstance(name, (list, tuple)):
            return [self.dof_index(s) for s in name]
        try:
            return self._index[name]
        except KeyError:
            raise KeyError(f"unknown DOF {name!r}; known DOFs: {list(self.dof_names)}") from None

    def hinge_matrix(self) -> np.ndarray:
        """B with columns b_j: +1 at the outboard, -1 at the inboard DOF; shape (n, h)."""
        B = np.zeros((self.n_dof, self.n_hinges))
        for j, (out, inn) in enumerate(self.hinge_pairs):
            B[self._index[out], j] = 1.0
            if inn:
                B[self._index[inn], j] = -1.0
        return B

    def closed_stiffness(self, kn: float) -> np.ndarray:
        """Stiffness with every hinge spring engaged (zero clearance): K + kn B B^T."""
        B = self.hinge_matrix()
        return self.K + float(kn) * B @ B.T

    @property
    def damping(self) -> np.ndarray:
        """Damping matrix (zeros if the system has none)."""
        return np.zeros_like(self.M) if self.C is None else self.C

    @property
    def influence(self) -> np.ndarray:
        """Base influence vector r (zeros if the system has none)."""
        return np.zeros(self.n_dof) if self.base_influence is None else self.base_influence

    def replace(self, **changes) -> FreeplaySystem:
        """A copy with some fields replaced (e.g. ``system.replace(C=C)``)."""
        kw = dict(
            M=self.M,
            K=self.K,
            dof_names=self.dof_names,
            hinge_pairs=self.hinge_pairs,
            C=self.C,
            base_influence=self.base_influence,
        )
        unknown = set(changes) - set(kw)
        if unknown:
            raise TypeError(f"unknown FreeplaySystem fields {sorted(unknown)}; allowed: {list(kw)}")
        kw.update(changes)
        return FreeplaySystem(**kw)

    def fingerprint(self) -> str:
        """Stable hash of the structure (M, K, C, r, names, hinges) for caches and checkpoints."""
        h = hashlib.sha256()
        for arr in (self.M, self.K, self.damping, self.influence):
            h.update(np.ascontiguousarray(np.round(arr, 12), dtype="<f8").tobytes())
        h.update("\x1f".join(self.dof_names).encode())
        h.update("\x1f".join(f"{a}>{b}" for a, b in self.hinge_pairs).encode())
        return h.hexdigest()[:16]

    def structure(self) -> dict:
        """The structure as plain Python (M, K, C, r as nested lists [SI], DOF names, hinges):
        what a checkpoint stores to be compared with :meth:`structure_mismatch`."""
        return {
            "M": self.M.tolist(), "K": self.K.tolist(), "C": self.damping.tolist(),
            "r": self.influence.tolist(), "dof_names": list(self.dof_names),
            "hinge_pairs": [list(p) for p in self.hinge_pairs],
        }

    def structure_mismatch(self, other: Mapping, *, rtol: float = 1e-8) -> str | None:
        """How this structure differs from ``other`` (a :meth:`structure` dict), or None.

        Matrices agree when ``|A - B| <= rtol * max|B|`` element-wise (the scale of each matrix:
        round-off of a model built on another CPU, ~1e-10 relative, passes; a changed model
        does not). :meth:`fingerprint`, exact to 12 decimals, stays the key of caches.
        """
        if list(other.get("dof_names", ())) != list(self.dof_names):
            return "other DOF names"
        if [tuple(p) for p in other.get("hinge_pairs", ())] != list(self.hinge_pairs):
            return "other hinges"
        for key, mine in (("M", self.M), ("K", self.K), ("C", self.damping),
                          ("r", self.influence)):
            theirs = np.asarray(other.get(key, ()), dtype=float)
            if theirs.shape != mine.shape:
                return f"`{key}` of shape {theirs.shape}, not {mine.shape}"
            scale = float(np.max(np.abs(theirs), initial=0.0))
            if not np.all(np.abs(mine - theirs) <= rtol * scale):
                worst = float(np.max(np.abs(mine - theirs))) / (scale or 1.0)
                return f"`{key}` differs by {worst:.2g} relative (tolerance {rtol:g})"
        return None

    def __repr__(self) -> str:
        return (
            f"FreeplaySystem(n_dof={self.n_dof}, hinges={list(self.hinge_pairs)}, "
            f"damped={self.C is not None}, base_influence={self.base_influence is not None})"
        )


# ---------------------------------------------------------------------- file contract
def save_system(path: str | os.PathLike, system: FreeplaySystem) -> Path:
    """Write ``system`` in the `.npz` contract of docs/identify.md and return the path.

    The file is written to a temporary name first and renamed
    (:func:`freeplayid.atomic.atomic_path`), so a failure never leaves a half-written model file.
    """
    if not isinstance(system, FreeplaySystem):
        raise TypeError(f"`system` must be a FreeplaySystem, got {type(system).__name__}")
    path = Path(path)
    if path.suffix != ".npz":
        path = path.with_suffix(path.suffix + ".npz") if path.suffix else path.with_suffix(".npz")
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {
        "M": system.M,
        "K": system.K,
        "dof_names": np.array(system.dof_names, dtype=str),
        "hinge_pairs": np.array(system.hinge_pairs, dtype=str).reshape(-1, 2),
    }
    if system.C is not None:
        arrays["C"] = system.C
    if system.base_influence is not None:
        arrays["base_influence"] = system.base_influence
    with atomic_path(path) as tmp:
        np.savez(tmp, **arrays)
    return path


def load_system(path: str | os.PathLike) -> FreeplaySystem:
    """Read and validate a linear model file (`.npz`, docs/identify.md).

    Raises
    ------
    SystemFileError
        Naming the file and the offending field: missing file or key, wrong shape, asymmetric or
        indefinite matrix, unknown DOF name in ``hinge_pairs``.
    """
    path = Path(path)
    if not path.is_file():
        raise SystemFileError(f"{path}: linear model file not found")
    try:
        with np.load(path, allow_pickle=False) as data:
            contents = {k: data[k] for k in data.files}
    except Exception as exc:  # zipfile/pickle/format errors all mean "not a model file"
        raise SystemFileError(f"{path}: not a readable .npz file ({exc})") from None
    missing = [k for k in _REQUIRED_KEYS if k not in contents]
    if missing:
        raise SystemFileError(
            f"{path}: missing required field(s) {missing}; a model file needs "
            f"{list(_REQUIRED_KEYS)} and may have {list(_OPTIONAL_KEYS)}"
        )
    unknown = sorted(set(contents) - set(_REQUIRED_KEYS) - set(_OPTIONAL_KEYS))
    if unknown:
        raise SystemFileError(
            f"{path}: unknown field(s) {unknown}; allowed: "
            f"{list(_REQUIRED_KEYS) + list(_OPTIONAL_KEYS)}"
        )
    for key in ("M", "K", "C", "base_influence"):
        if key in contents and not np.issubdtype(contents[key].dtype, np.number):
            raise SystemFileError(
                f"{path}: field '{key}' must be numeric, got dtype {contents[key].dtype}"
            )
    names = contents["dof_names"]
    if names.ndim != 1:
        raise SystemFileError(f"{path}: field 'dof_names' must be 1-D, got shape {names.shape}")
    pairs = contents["hinge_pairs"]
    if pairs.size == 0:
        pairs = pairs.reshape(0, 2)
    if pairs.ndim != 2 or pairs.shape[1] != 2:
        raise SystemFileError(
            f"{path}: field 'hinge_pairs' must have shape (h, 2) of (outboard, inboard) DOF "
            f"names, got shape {pairs.shape}"
        )
    try:
        return FreeplaySystem(
            M=contents["M"],
            K=contents["K"],
            dof_names=tuple(str(s) for s in names),
            hinge_pairs=tuple((str(a), str(b)) for a, b in pairs),
            C=contents.get("C"),
            base_influence=contents.get("base_influence"),
        )
    except ValueError as exc:
        msg = str(exc).replace("`", "'")
        raise SystemFileError(f"{path}: field {msg}") from None

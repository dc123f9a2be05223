"""MATLAB run files (``.mat``): one vector variable per column.

The variables are named as the manifest's columns: ``time`` [s], the ``channels`` keys and the
``base_channel``; each is a real numeric vector (1×N or N×1, any numeric class), all of the same
length. Other variables in the file are ignored. Versions 4 to 7.2 are read with
:func:`scipy.io.loadmat`; version 7.3 files (HDF5 inside) need ``h5py`` (the ``mat73`` extra).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ...errors import DatasetError

__all__ = ["read"]

# MATLAB classes of numeric arrays (the MATLAB_class attribute of a v7.3 variable)
_NUMERIC_CLASSES = ("double", "single", "int8", "uint8", "int16", "uint16", "int32", "uint32",
                    "int64", "uint64")


def read(path: Path, columns: Sequence[str]) -> dict[str, np.ndarray]:
    """The variables ``time`` and ``columns`` of one MAT file as float vectors."""
    from scipy.io.matlab import matfile_version

    need = ["time", *columns]
    try:
        with open(path, "rb") as fh:
            major, _ = matfile_version(fh)
    except Exception as exc:  # OSError, ValueError, MatReadError (empty file)
        raise DatasetError(f"{path}: not a readable MAT file ({exc})") from None
    if major == 2:
        return _read_v73(path, need)
    import scipy.io

    try:
        classes = {name: cls for name, _, cls in scipy.io.whosmat(path)}  # headers only
        missing = [c for c in need if c not in classes]
        if missing:
            raise DatasetError(
                f"{path}: variable(s) {missing} not found; the file has {list(classes)} (the "
                "manifest's `channels` keys, `base_channel` and 'time' must be variables)"
            )
        for c in need:  # loadmat would give a logical as uint8: check the MATLAB class
            _check_class(classes[c], path, c)
        found = scipy.io.loadmat(path, variable_names=need)
    except DatasetError:
        raise
    except Exception as exc:  # scipy raises several types on corrupt files
        raise DatasetError(f"{path}: not a readable MAT file ({exc})") from None
    return {c: _vector(found[c], path, c) for c in need}


def _check_class(cls: str, path: Path, name: str) -> None:
    if cls not in _NUMERIC_CLASSES:
        raise DatasetError(f"{path}: variable {name!r} must be numeric, got MATLAB {cls}")


def _vector(value, path: Path, name: str) -> np.ndarray:
    """A variable as a float vector, or a DatasetError naming the file and the variable."""
    if not isinstance(value, np.ndarray):  # e.g. a sparse matrix
        raise DatasetError(
            f"{path}: variable {name!r} must be a numeric vector, got {type(value).__name__}"
        )
    if np.iscomplexobj(value):
        raise DatasetError(f"{path}: variable {name!r} is complex; need a real time history")
    if value.dtype.kind not in "iuf":  # char, logical, cell, struct
        raise DatasetError(
            f"{path}: variable {name!r} must be numeric, got MATLAB data of dtype {value.dtype}"
        )
    if value.ndim not in (1, 2) or (value.ndim == 2 and min(value.shape) != 1) or value.size == 0:
        raise DatasetError(
            f"{path}: variable {name!r} must be a vector (1xN or Nx1), got shape {value.shape}"
        )
    return value.astype(float).ravel()


def _read_v73(path: Path, need: Sequence[str]) -> dict[str, np.ndarray]:
    """MATLAB 7.3: an HDF5 file, one dataset per variable in the root group."""
    try:
        import h5py
    except ImportError:
        raise DatasetError(
            f"{path}: a MATLAB v7.3 (HDF5) file; reading it needs h5py (pip install h5py, or "
            "the package's `mat73` extra), or save it with -v7"
        ) from None
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise DatasetError(f"{path}: not a readable MATLAB v7.3 (HDF5) file ({exc})") from None
    with f:
        names = [k for k in f if not k.startswith("#")]  # '#refs#', '#subsystem#': internal
        missing = [c for c in need if c not in names]
        if missing:
            raise DatasetError(
                f"{path}: variable(s) {missing} not found; the file has {names} (the manifest's "
                "`channels` keys, `base_channel` and 'time' must be variables)"
            )
        out = {}
        for c in need:
            node = f[c]
            if not isinstance(node, h5py.Dataset):  # a struct is a group
                raise DatasetError(f"{path}: variable {c!r} must be a numeric vector, got a struct")
            cls = node.attrs.get("MATLAB_class", b"")
            cls = cls.decode() if isinstance(cls, bytes) else str(cls)
            if node.dtype.names and {"real", "imag"} <= set(node.dtype.names):
                raise DatasetError(f"{path}: variable {c!r} is complex; need a real time history")
            if cls:
                _check_class(cls, path, c)
            if node.attrs.get("MATLAB_empty", 0):
                raise DatasetError(f"{path}: variable {c!r} is empty")
            out[c] = _vector(np.asarray(node[()]), path, c)
    return out

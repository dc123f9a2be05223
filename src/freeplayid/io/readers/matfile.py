"""The variables of a MATLAB file, whatever its version: one interface over ``scipy.io`` (v4 to
v7.2) and ``h5py`` (v7.3, HDF5 inside), so that :mod:`~freeplayid.io.readers.mat` reads its two
layouts once.

A variable is returned in MATLAB's orientation (an N×C matrix as shape ``(N, C)``): v7.3 stores
arrays column-major, so h5py sees them transposed and :class:`_V73` transposes them back.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import DatasetError

__all__ = ["MatFile", "open_mat"]

# MATLAB classes of numeric arrays (whosmat's class, the MATLAB_class attribute of a v7.3 variable)
NUMERIC_CLASSES = ("double", "single", "int8", "uint8", "int16", "uint16", "int32", "uint32",
                   "int64", "uint64")


class MatFile:
    """The variables of one MAT file (use :func:`open_mat`).

    Attributes
    ----------
    path : Path
    classes : dict str -> str
        Variable name -> MATLAB class (``double``, ``char``, ``cell``, ``struct``, ...), in file
        order; internal HDF5 groups (``#refs#``) are not variables.
    """

    path: Path
    classes: dict

    def numeric(self, name: str) -> np.ndarray:
        """A real numeric variable as a float array in MATLAB's orientation; a DatasetError
        naming the file and the variable for any other class, a complex or an empty one."""
        raise NotImplementedError

    def strings(self, name: str) -> list[str]:
        """A cell array of char rows or a char matrix as a list of stripped strings (a single
        char row is one string); a DatasetError naming the file and the variable otherwise."""
        raise NotImplementedError

    def close(self) -> None:
        """Release the file."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def check_numeric_class(self, name: str) -> None:
        cls = self.classes[name]
        if cls not in NUMERIC_CLASSES:
            raise DatasetError(f"{self.path}: variable {name!r} must be numeric, got MATLAB {cls}")

    def not_strings(self, name: str) -> DatasetError:
        return DatasetError(
            f"{self.path}: variable {name!r} must be a cell array of strings or a char matrix, "
            f"got MATLAB {self.classes[name]}"
        )


def open_mat(path: Path) -> MatFile:
    """The :class:`MatFile` of ``path``; a one-line DatasetError for a file that is not a MAT
    file, or a v7.3 file without h5py installed."""
    from scipy.io.matlab import matfile_version

    try:
        with open(path, "rb") as fh:
            major, _ = matfile_version(fh)
    except Exception as exc:  # OSError, ValueError, MatReadError (empty file)
        raise DatasetError(f"{path}: not a readable MAT file ({exc})") from None
    return _V73(path) if major == 2 else _V5(path)


# --------------------------------------------------------------------------- v4 to v7.2: scipy
class _V5(MatFile):
    def __init__(self, path: Path) -> None:
        import scipy.io

        self.path = path
        try:
            self.classes = {name: cls for name, _, cls in scipy.io.whosmat(path)}  # headers only
        except Exception as exc:  # scipy raises several types on corrupt files
            raise DatasetError(f"{path}: not a readable MAT file ({exc})") from None

    def _load(self, name: str):
        import scipy.io

        try:
            return scipy.io.loadmat(self.path, variable_names=[name])[name]
        except Exception as exc:  # a corrupt variable
            raise DatasetError(f"{self.path}: not a readable MAT file ({exc})") from None

    def numeric(self, name: str) -> np.ndarray:
        self.check_numeric_class(name)  # loadmat would give a logical as uint8
        value = self._load(name)
        if not isinstance(value, np.ndarray):  # e.g. a sparse matrix
            raise DatasetError(f"{self.path}: variable {name!r} must be numeric, got "
                               f"{type(value).__name__}")
        if np.iscomplexobj(value):
            raise DatasetError(f"{self.path}: variable {name!r} is complex; need a real time "
                               "history")
        if value.dtype.kind not in "iuf":
            raise DatasetError(f"{self.path}: variable {name!r} must be numeric, got MATLAB "
                               f"data of dtype {value.dtype}")
        return value.astype(float)

    def strings(self, name: str) -> list[str]:
        cls = self.classes[name]
        if cls not in ("cell", "char"):
            raise self.not_strings(name)
        value = self._load(name)
        if cls == "char":  # chars_as_strings: one string per row
            return [str(s).strip() for s in np.asarray(value).ravel()]
        out = []
        for cell in np.asarray(value, dtype=object).ravel(order="F"):  # MATLAB's element order
            chars = np.asarray(cell)
            if chars.dtype.kind != "U" or chars.size > 1:
                raise self.not_strings(name)
            out.append(str(chars.ravel()[0]).strip() if chars.size else "")
        return out


# --------------------------------------------------------------------------- v7.3: HDF5 via h5py
class _V73(MatFile):
    def __init__(self, path: Path) -> None:
        try:
            import h5py
        except ImportError:
            raise DatasetError(
                f"{path}: a MATLAB v7.3 (HDF5) file; reading it needs h5py (pip install h5py, or "
                "the package's `mat73` extra), or save it with -v7"
            ) from None
        self.path = path
        self._h5py = h5py
        try:
            self._f = h5py.File(path, "r")
        except OSError as exc:
            raise DatasetError(f"{path}: not a readable MATLAB v7.3 (HDF5) file ({exc})") from None
        self.classes = {k: self._class(self._f[k]) for k in self._f if not k.startswith("#")}

    def close(self) -> None:
        self._f.close()

    def _class(self, node) -> str:
        if isinstance(node, self._h5py.Group):  # a struct (or an object) is a group
            return _text(node.attrs.get("MATLAB_class", b"struct"))
        return _text(node.attrs.get("MATLAB_class", b"")) or "double"

    def numeric(self, name: str) -> np.ndarray:
        node = self._f[name]
        if isinstance(node, self._h5py.Group):
            raise DatasetError(f"{self.path}: variable {name!r} must be numeric, got a "
                               f"{self.classes[name]}")
        if node.dtype.names and {"real", "imag"} <= set(node.dtype.names):
            raise DatasetError(f"{self.path}: variable {name!r} is complex; need a real time "
                               "history")
        self.check_numeric_class(name)
        if node.attrs.get("MATLAB_empty", 0):
            raise DatasetError(f"{self.path}: variable {name!r} is empty")
        value = np.asarray(node[()])
        if value.dtype.kind not in "iuf":
            raise DatasetError(f"{self.path}: variable {name!r} must be numeric, got dtype "
                               f"{value.dtype}")
        return value.T.astype(float)  # HDF5 holds MATLAB's column-major array transposed

    def strings(self, name: str) -> list[str]:
        cls = self.classes[name]
        node = self._f[name]
        if cls == "char":  # a C×L char matrix: one string per MATLAB row
            return [_chars(row) for row in np.atleast_2d(self._char_array(node).T)]
        if cls != "cell":
            raise self.not_strings(name)
        out = []
        for ref in np.asarray(node[()]).T.ravel(order="F"):  # MATLAB's element order
            cell = self._f[ref]
            if self._class(cell) != "char":
                raise self.not_strings(name)
            out.append(_chars(self._char_array(cell).ravel(order="F")))
        return out

    @staticmethod
    def _char_array(node) -> np.ndarray:
        """A char variable's UTF-16 code units (an empty one holds its dimensions instead)."""
        if node.attrs.get("MATLAB_empty", 0):
            return np.zeros((0, 1), dtype=np.uint16)
        return np.asarray(node[()])


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _chars(codes) -> str:
    return "".join(chr(int(c)) for c in np.asarray(codes).ravel()).strip().strip("\x00")

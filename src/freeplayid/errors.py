"""Every error a user's input can cause, in one place.

Every such error (a data set or model file that breaks its contract, a checkpoint of another
structure, data that cannot support an identification) derives from :class:`InputError`, so a
command can end with its one-line message instead of a traceback by catching this class alone.
The modules that raise them re-export their own (``freeplayid.io.DatasetError``,
``freeplayid.model.SystemFileError``, ...).
"""

from __future__ import annotations

__all__ = ["InputError", "ConfigError", "OutputError", "DatasetError", "SystemFileError",
           "ModalTestError", "ResultFileError", "IdentificationError", "InverseModelError",
           "SuspectResultError", "InverseDomainWarning"]


class InputError(ValueError):
    """An input problem; the message names the file, run or field and what was expected."""


class ConfigError(InputError):
    """A command's configuration value outside its allowed set; the message names the field
    (``multistart.n``) and the allowed values."""


class OutputError(InputError):
    """An output folder that cannot take a command's results: a file, not writable, holding an
    earlier run's results, or a write that failed (a full disk); the message names the folder."""


class DatasetError(InputError):
    """A data set does not satisfy the data-set contract of docs/identify.md."""


class SystemFileError(InputError):
    """A linear model file does not satisfy the `.npz` contract (docs/identify.md)."""


class ModalTestError(InputError):
    """A modal test (file or values) that cannot update the model; the message names the file
    and the field."""


class ResultFileError(InputError):
    """An ``identification.json`` that does not satisfy the result contract."""


class IdentificationError(InputError):
    """The data set is valid but does not support an identification (e.g. too few points).

    ``points`` holds what the extraction found (a ``BackbonePoints``), when it got that far.
    """

    def __init__(self, message: str, *, points=None) -> None:
        super().__init__(message)
        self.points = points


class InverseModelError(InputError):
    """An inverse-model checkpoint is missing, not ours, or made for another linear model."""


class InverseDomainWarning(UserWarning):
    """A case lies outside what the inverse model was trained on: its estimate is an
    extrapolation (the network's points, point count or prior; :mod:`freeplayid.inverse`)."""


class SuspectResultError(InputError):
    """An identification whose verdict is ``suspect``, refused by a command (its reasons say why;
    ``allow_suspect=true`` accepts it)."""

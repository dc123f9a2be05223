"""The one base class of the errors a user's input can cause.

Every such error (a data set or model file that breaks its contract, a checkpoint of another
structure, data that cannot support an identification) derives from :class:`InputError`, so a
command can end with its one-line message instead of a traceback by catching this class alone.
"""

from __future__ import annotations

__all__ = ["InputError", "ConfigError", "OutputError"]


class InputError(ValueError):
    """An input problem; the message names the file, run or field and what was expected."""


class ConfigError(InputError):
    """A command's configuration value outside its allowed set; the message names the field
    (``multistart.n``) and the allowed values."""


class OutputError(InputError):
    """An output folder that cannot take a command's results: a file, not writable, holding an
    earlier run's results, or a write that failed (a full disk); the message names the folder."""

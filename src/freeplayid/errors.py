"""The one base class of the errors a user's input can cause.

Every such error (a data set or model file that breaks its contract, a checkpoint of another
structure, data that cannot support an identification) derives from :class:`InputError`, so a
command can end with its one-line message instead of a traceback by catching this class alone.
"""

from __future__ import annotations

__all__ = ["InputError"]


class InputError(ValueError):
    """An input problem; the message names the file, run or field and what was expected."""

"""The one error type of :mod:`freeplayid.io`."""

from __future__ import annotations

from ..errors import InputError

__all__ = ["DatasetError"]


class DatasetError(InputError):
    """A data set does not satisfy the data-set contract of docs/identify.md."""

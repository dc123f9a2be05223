"""The one error type of :mod:`freeplayid.io`."""

from __future__ import annotations

__all__ = ["DatasetError"]


class DatasetError(ValueError):
    """A data set does not satisfy the contract of DESIGN.md §3."""

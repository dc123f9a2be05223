"""UFF dataset-58 run files (``.uff``, ``.unv``): see :func:`freeplayid.io.read_uff`."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..uff import read_uff

__all__ = ["read"]


def read(path: Path, columns: Sequence[str]) -> dict[str, np.ndarray]:
    """The time abscissa and the records named (ID line 1) ``columns`` of one UFF file."""
    return read_uff(path, columns=columns)

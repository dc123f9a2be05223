"""Base terms of the numba engines' signals, added in place in one compiled pass.

The kernels write their decimated outputs straight into ``SweepResult.signals`` (batch, channel,
time); what is left is the part that no member integrates, ``level * (base_coef * base[0] +
static_coef * base[1])`` (the base motion in the absolute frame and the quasi-static
base-load response, decimated in float64 by the caller). numpy would need a (batch, channel,
time) temporary for it; this pass reads and writes each value once, in float64, rounded once.
"""

from __future__ import annotations

import numba
import numpy as np

from .cache import CACHE

__all__ = ["add_base_terms"]


@numba.njit(parallel=True, cache=CACHE)
def _add(y, tb, lev):
    batch, C, n = y.shape
    for b in numba.prange(batch):
        lb = lev[b]
        for c in range(C):
            yb = y[b, c]
            t = tb[c]
            for i in range(n):
                yb[i] = float(yb[i]) + lb * t[i]


def add_base_terms(y: np.ndarray, *, base_coef, static_coef, base: np.ndarray,
                   level_g) -> np.ndarray:
    """``y += level_g * (base_coef * base[0] + static_coef * base[1])`` in place.

    Parameters
    ----------
    y : ndarray, shape (batch, channels, n), float32 or float64, C-contiguous
    base_coef, static_coef : array_like, shape (channels,)
        Coefficients of the unit base terms ``base[0]``, ``base[1]`` (per g of level).
    base : ndarray, shape (2, >= n)
    level_g : array_like, shape (batch,)

    Returns
    -------
    ndarray
        ``y`` (unchanged if every coefficient is zero).
    """
    if y.ndim != 3 or not y.flags.c_contiguous or y.dtype not in (np.float32, np.float64):
        raise ValueError(f"`y` must be a C-contiguous float32/float64 (batch, channels, n) "
                         f"array, got {y.dtype} {y.shape}")
    batch, C, n = y.shape
    bc = np.asarray(base_coef, dtype=np.float64).reshape(-1)
    sc = np.asarray(static_coef, dtype=np.float64).reshape(-1)
    lev = np.ascontiguousarray(np.asarray(level_g, dtype=np.float64).reshape(-1))
    base = np.asarray(base, dtype=np.float64)
    if bc.shape != (C,) or sc.shape != (C,) or lev.shape != (batch,):
        raise ValueError(f"coefficients {bc.shape}, {sc.shape} and levels {lev.shape} do not "
                         f"match y {y.shape}")
    if base.ndim != 2 or base.shape[0] != 2 or base.shape[1] < n:
        raise ValueError(f"`base` must be (2, >= {n}), got {base.shape}")
    tb = np.ascontiguousarray(bc[:, None] * base[0, :n] + sc[:, None] * base[1, :n])
    if np.any(tb):
        _add(y, tb, lev)
    return y

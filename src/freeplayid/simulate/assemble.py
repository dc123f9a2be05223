"""Compiled assembly of the numba engines' record into ``SweepResult.signals`` (one pass).

The kernels emit the decimated record as (time, channel, padded batch), members innermost. The
result wants (batch, channel, time) with the base terms added and, for the quasi-static model's
velocity/acceleration, the derivative of its fast part (extra channels C .. 2C-1) added too.
Done with numpy (a transpose, np.gradient twice, temporaries in float64) this took ~4x the
kernel's own time on the quasi-static model (1024 members, acceleration). Here one parallel pass
reads each recorded value once and writes each result once.

The derivative is that of ``run._differentiate`` (5-point central stencils inside, np.gradient
at the two samples of each end; tests/test_simulate_assemble.py holds the two together).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["assemble_record"]

_TILE = 16  # members per task: one 64-byte line of float32 record values


@numba.njit(inline="always", cache=True)
def _grad1(x, c, b, i, n, inv_dt):
    # np.gradient (edge_order=1) of x[:, c, b] at sample i, n samples
    if i == 0:
        return (float(x[1, c, b]) - float(x[0, c, b])) * inv_dt
    if i == n - 1:
        return (float(x[n - 1, c, b]) - float(x[n - 2, c, b])) * inv_dt
    return (float(x[i + 1, c, b]) - float(x[i - 1, c, b])) * (0.5 * inv_dt)


@numba.njit(inline="always", cache=True)
def _grad2(x, c, b, i, n, inv_dt):
    # np.gradient of np.gradient at sample i
    if i == 0:
        return (_grad1(x, c, b, 1, n, inv_dt) - _grad1(x, c, b, 0, n, inv_dt)) * inv_dt
    if i == n - 1:
        return (_grad1(x, c, b, n - 1, n, inv_dt) - _grad1(x, c, b, n - 2, n, inv_dt)) * inv_dt
    return (_grad1(x, c, b, i + 1, n, inv_dt) - _grad1(x, c, b, i - 1, n, inv_dt)) * (
        0.5 * inv_dt)


@numba.njit(parallel=True, cache=True)
def _assemble(rec, n, order, inv_dt, base_coef, static_coef, base, lev, y):
    batch, C = y.shape[0], y.shape[1]
    ntile = (batch + _TILE - 1) // _TILE
    for tile in numba.prange(ntile):
        b0 = tile * _TILE
        b1 = min(batch, b0 + _TILE)
        for c in range(C):
            ce = C + c  # the fast part of channel c (order > 0)
            for i in range(n):
                tb = base_coef[c] * base[0, i] + static_coef[c] * base[1, i]
                interior = order > 0 and n >= 5 and 2 <= i <= n - 3
                for b in range(b0, b1):
                    v = float(rec[i, c, b]) + lev[b] * tb
                    if order == 1:
                        if interior:
                            v += (float(rec[i - 2, ce, b]) - 8.0 * float(rec[i - 1, ce, b])
                                  + 8.0 * float(rec[i + 1, ce, b]) - float(rec[i + 2, ce, b])
                                  ) * (inv_dt / 12.0)
                        elif n >= 2:
                            v += _grad1(rec, ce, b, i, n, inv_dt)
                    elif order == 2:
                        if interior:
                            v += (-float(rec[i - 2, ce, b]) + 16.0 * float(rec[i - 1, ce, b])
                                  - 30.0 * float(rec[i, ce, b]) + 16.0 * float(rec[i + 1, ce, b])
                                  - float(rec[i + 2, ce, b])) * (inv_dt * inv_dt / 12.0)
                        elif n >= 3:
                            v += _grad2(rec, ce, b, i, n, inv_dt)
                    y[b, c, i] = v


def assemble_record(rec: np.ndarray, *, n_out: int, batch: int, channels: int, order: int,
                    sample_rate: float, base_coef, static_coef, base: np.ndarray,
                    level_g) -> np.ndarray:
    """``signals`` (batch, channels, n_out) from a numba engine's record.

    Parameters
    ----------
    rec : ndarray, shape (>= n_out, width, padded batch), float32 or float64
        Decimated record; ``width`` is ``channels`` or, for the quasi-static model's velocity and
        acceleration, ``2 channels`` (the fast part to differentiate last).
    order : {0, 1, 2}
        0: no fast part; 1 or 2: add its first or second derivative.
    base_coef, static_coef : ndarray, shape (channels,)
        Coefficients of the unit base terms ``base[0]``, ``base[1]`` (per g of level).
    base : ndarray, shape (2, >= n_out), float64
    level_g : ndarray, shape (batch,)

    Returns
    -------
    ndarray, shape (batch, channels, n_out), dtype of ``rec``
        Sum in float64, rounded once.
    """
    if order not in (0, 1, 2):
        raise ValueError(f"`order` must be 0, 1 or 2, got {order!r}")
    width = rec.shape[1]
    if width != channels * (2 if order else 1):
        raise ValueError(f"record width {width} does not match channels={channels}, "
                         f"order={order}")
    if rec.shape[0] < n_out or base.shape[1] < n_out or rec.shape[2] < batch:
        raise ValueError(f"record {rec.shape} / base {base.shape} shorter than n_out={n_out}, "
                         f"batch={batch}")
    y = np.empty((batch, channels, n_out), dtype=rec.dtype)
    f = lambda a: np.ascontiguousarray(np.asarray(a, dtype=np.float64))  # noqa: E731
    _assemble(rec, int(n_out), int(order), 1.0 * float(sample_rate), f(base_coef),
              f(static_coef), f(base), f(level_g), y)
    return y

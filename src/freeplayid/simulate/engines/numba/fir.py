"""The anti-aliasing FIR fused into the compiled kernels' step loops (a ring of open outputs).

The decimating FIR of the output is fused into the step loop: each recorded step value is added
to the open outputs it contributes to (a ring of accumulators per member); an output is emitted
when its last tap arrives. The ring persists between chunks, so a chunk boundary changes nothing.
With the padded filter index ``j = gi + half`` of step ``gi``, open output k gets the weight
``taps[j - k m]`` for ``k m <= j <= k m + ntap - 1`` and is complete at ``j = k m + ntap - 1``;
at gi = 0 the value also stands for the padding j < half (the state at rest), with the summed
weights :func:`start_weights`.

Two forms of the same arithmetic: over a block of ``BLOCK`` member lanes (the RK4 kernels,
``rk4.py`` and ``rk4_qs.py``: ring ``(R, channels, BLOCK)``) and for one member (the exponential
kernel, ``expo/kernel.py``: ring ``(R, channels)``). The kernels inline these functions; a
change of this file must come with a change of the digest recorded by every kernel file
(``...cache.cache_unless_stale``).
"""

from __future__ import annotations

import numba
import numpy as np

from ...cache import CACHE
from .arith import FASTMATH, fma

__all__ = ["BLOCK", "ring_load", "ring_store", "fir_add", "fir_add2", "fir_emit", "ring_load1",
           "ring_store1", "fir_add1", "fir_emit1", "start_weights", "emitted_outputs"]

# members per block of the RK4 kernels: 4 AVX-512 float32 vectors; block state ~ 8 x 12 x 64 words
BLOCK = 64


def start_weights(taps, m: int, dtype) -> np.ndarray:
    """Summed weights of ``taps`` over the constant pre-history (steps before the first) that
    output k sees, k = 0 .. half // m (``half = (len(taps) - 1) // 2``; see :func:`fir_add`)."""
    half = (len(taps) - 1) // 2
    w = [np.sum(taps[: half - k * m + 1]) for k in range(half // m + 1)]
    return np.ascontiguousarray(np.asarray(w, dtype=dtype))


def emitted_outputs(gi0: int, L: int, half: int, m: int) -> int:
    """Number of output samples that the steps ``gi0 .. gi0 + L - 1`` complete."""
    k_first = max(0, -(-(gi0 - half) // m))
    k_last = (gi0 + L - 1 - half) // m
    return max(0, k_last - k_first + 1)


# ------------------------------------------------------------------ a block of BLOCK members


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def ring_load(ring, acc_r, b0):
    """Open outputs of the member block starting at b0: ring -> acc_r (R, channels, BLOCK)."""
    for r in range(acc_r.shape[0]):
        for c in range(acc_r.shape[1]):
            for b in range(BLOCK):
                acc_r[r, c, b] = ring[r, c, b0 + b]


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def ring_store(ring, acc_r, b0):
    """Open outputs back to the ring for the next chunk: acc_r -> ring."""
    for r in range(acc_r.shape[0]):
        for c in range(acc_r.shape[1]):
            for b in range(BLOCK):
                ring[r, c, b0 + b] = acc_r[r, c, b]


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def fir_add(acc_r, val, gi, half, ntap, m, taps, w0):
    """Add the recorded value of global step ``gi`` to its open outputs.

    ``val`` (channels, BLOCK); ``w0`` are the summed weights of the constant pre-history at
    gi = 0 (the value at gi = 0 also stands for the padding j < half, the state at rest).
    """
    R = acc_r.shape[0]
    C = acc_r.shape[1]
    j = gi + half
    if gi == 0:
        for kk in range(w0.shape[0]):
            wk = w0[kk]
            r = kk % R
            for c in range(C):
                for b in range(BLOCK):
                    acc_r[r, c, b] = fma(wk, val[c, b], acc_r[r, c, b])
    else:
        for kk in range(max(0, (j - ntap + m) // m), j // m + 1):
            wk = taps[j - kk * m]
            r = kk % R
            for c in range(C):
                for b in range(BLOCK):
                    acc_r[r, c, b] = fma(wk, val[c, b], acc_r[r, c, b])


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def fir_add2(acc_r, val, valf, gi, half, ntap, m, taps, tapsd, w0, w0d):
    # fir_add of val through `taps` plus valf through `tapsd` (the quasi-static kernel's fast
    # part, whose derivative the derivative taps take), in one pass over the open outputs
    R = acc_r.shape[0]
    C = acc_r.shape[1]
    j = gi + half
    if gi == 0:
        for kk in range(w0.shape[0]):
            wk = w0[kk]
            wd = w0d[kk]
            r = kk % R
            for c in range(C):
                for b in range(BLOCK):
                    acc_r[r, c, b] = fma(wd, valf[c, b], fma(wk, val[c, b], acc_r[r, c, b]))
    else:
        for kk in range(max(0, (j - ntap + m) // m), j // m + 1):
            wk = taps[j - kk * m]
            wd = tapsd[j - kk * m]
            r = kk % R
            for c in range(C):
                for b in range(BLOCK):
                    acc_r[r, c, b] = fma(wd, valf[c, b], fma(wk, val[c, b], acc_r[r, c, b]))


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def fir_emit(acc_r, gi, half, ntap, m, out, col, b0):
    """Emit the output that step ``gi`` completed, if any, to ``out[b0 + b, c, col]``.

    Only the members of ``out`` are written (not the padding of the last block) and only the
    samples inside it (not the filter's tail). Returns 1 if an output was completed, else 0.
    """
    R = acc_r.shape[0]
    C = acc_r.shape[1]
    jd = gi + half - ntap + 1
    if jd < 0 or jd % m != 0:
        return 0
    r = (jd // m) % R
    nb = min(BLOCK, out.shape[0] - b0)
    if col < out.shape[2]:
        for c in range(C):
            for b in range(nb):
                out[b0 + b, c, col] = acc_r[r, c, b]
    for c in range(C):
        for b in range(BLOCK):
            acc_r[r, c, b] = 0.0
    return 1


# ------------------------------------------------------------------ one member


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def ring_load1(ring, acc_r, i):
    # open outputs of member i: ring (batch, R, C) -> acc_r (R, C)
    for r in range(acc_r.shape[0]):
        for c in range(acc_r.shape[1]):
            acc_r[r, c] = ring[i, r, c]


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def ring_store1(ring, acc_r, i):
    # open outputs of member i back to the ring for the next chunk
    for r in range(acc_r.shape[0]):
        for c in range(acc_r.shape[1]):
            ring[i, r, c] = acc_r[r, c]


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def fir_add1(acc_r, val, gi, half, ntap, m, taps, w0):
    # fir_add for one member: acc_r (R, C), val (C,)
    R = acc_r.shape[0]
    C = acc_r.shape[1]
    j = gi + half
    if gi == 0:
        for kk in range(w0.shape[0]):
            wk = w0[kk]
            r = kk % R
            for c in range(C):
                acc_r[r, c] = fma(wk, val[c], acc_r[r, c])
    else:
        for kk in range(max(0, (j - ntap + m) // m), j // m + 1):
            wk = taps[j - kk * m]
            r = kk % R
            for c in range(C):
                acc_r[r, c] = fma(wk, val[c], acc_r[r, c])


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def fir_emit1(acc_r, gi, half, ntap, m, out, col, i):
    # fir_emit for member i: the output step gi completed, if any, to out[i, :, col]
    R = acc_r.shape[0]
    C = acc_r.shape[1]
    jd = gi + half - ntap + 1
    if jd < 0 or jd % m != 0:
        return 0
    r = (jd // m) % R
    if col < out.shape[2]:
        for c in range(C):
            out[i, c, col] = acc_r[r, c]
    for c in range(C):
        acc_r[r, c] = 0.0
    return 1

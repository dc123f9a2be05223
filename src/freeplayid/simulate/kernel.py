"""Compiled CPU RK4 kernel (numba): the same arithmetic as :class:`.engines.TorchRK4`.

Layout: every per-member array is (N, batch) with the batch innermost, so each line of a step is
a loop over contiguous members that LLVM vectorises (SIMD lanes = members). Blocks of ``BLOCK``
members run the whole chunk in one thread (their state stays in L1 cache); blocks are spread
over threads with ``prange``. The step is fused: no temporaries leave the block. The four RK4
stages are one loop around one copy of the stage code (a quarter of the code to compile; docs/
simulate.md, "Compile time").

numba is optional: this module imports it, so import it only after
:func:`.engines.numba_available` says yes (the simulator falls back to the torch engine).
"""

from __future__ import annotations

import sys
import time

import numba
import numpy as np
from llvmlite import ir
from numba.core import event, types
from numba.core.extending import intrinsic

from .cache import CACHE
from .formulation import BLOWUP, MODES, ModalForm

__all__ = ["NumbaRK4", "FASTMATH", "compile_kernel"]

BLOCK = 64  # members per block: 4 AVX-512 float32 vectors; block state ~ 8 x 12 x 64 words

# Fast-math flags of the kernels: only those that leave every finite result as written (operands
# and results are neither NaN nor inf; a diverged member is caught outside the kernel). Not
# `fastmath=True`: numba compiles a prange body twice, on its own (the code that a process runs
# right after compiling) and linked into the calling function, where LLVM optimises it again (the
# code that the on-disk cache stores and every later process runs). With re-association and FMA
# contraction the two copies round differently (quasi-static kernel, float32: 868 vs 1064 FMA
# instructions), and the freeplay dynamics amplify a last-bit difference to the size of the
# signal: a cached and a freshly compiled kernel gave different sweeps. Without them both copies
# compute the IEEE result of the operations in source order (tests/test_simulate_determinism.py).
FASTMATH = {"nnan", "ninf"}
# Every function of the kernels says `error_model="numpy"` (a division by zero gives inf or NaN,
# no exception): what `parallel=True` compiles a prange body with, so also the helpers compiled
# on their own (kernel_qs._active_set, _solve_block_h) and any kernel without prange compile as
# the body did (the Python error model puts a zero-divisor branch into every division, which
# kept the quasi-static kernel's loops from being vectorised: 2x slower as a plain function).


@intrinsic
def _fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (``llvm.fma``), for three floats of one type.

    The fused multiply-adds of the kernels are written out with this: with no contraction
    flag (see FASTMATH) every compiled copy fuses exactly these operations, so the kernels stay
    the same arithmetic in every copy and on every machine (``llvm.fma`` is exact also where
    the CPU has no FMA unit, only slower), while on the ones that have it (x86-64 since 2013,
    ARMv8) each is one vectorised instruction instead of a multiply and an add.
    """
    if not (isinstance(a, types.Float) and a == b == c):
        return None

    def codegen(context, builder, signature, args):
        t = args[0].type
        fn = builder.module.declare_intrinsic("llvm.fma", [t], ir.FunctionType(t, [t, t, t]))
        return builder.call(fn, args)

    return a(a, b, c), codegen


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def _accel(eta, v, s, kn, dl, lev, lam, cm, cdiag, diag, D, g, th, acc):
    N, H = D.shape
    for j in range(H):
        for b in range(BLOCK):
            th[j, b] = 0.0
        for k in range(N):
            d = D[k, j]
            for b in range(BLOCK):
                th[j, b] = _fma(d, eta[k, b], th[j, b])
        for b in range(BLOCK):
            x = th[j, b]
            c = min(max(x, -dl[b]), dl[b])
            th[j, b] = kn[b] * (x - c)
    for i in range(N):
        gi = g[i] * s
        li = lam[i]
        for b in range(BLOCK):
            acc[i, b] = _fma(-li, eta[i, b], gi * lev[b])
        if diag:
            ci = cdiag[i]
            for b in range(BLOCK):
                acc[i, b] = _fma(-ci, v[i, b], acc[i, b])
        else:
            for k in range(N):
                c = cm[i, k]
                for b in range(BLOCK):
                    acc[i, b] = _fma(-c, v[k, b], acc[i, b])
        for j in range(H):
            d = D[i, j]
            for b in range(BLOCK):
                acc[i, b] = _fma(-d, th[j, b], acc[i, b])

# ------------------------------------------------------------------ anti-aliasing FIR ring
# The decimating FIR of the output is fused into the step loop: each recorded step value is added
# to the open outputs it contributes to (a ring of accumulators per member block); an output is
# emitted when its last tap arrives. The ring persists between chunks (`ring`), so a chunk
# boundary changes nothing. Shared by both kernels (kernel_qs.py).


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def _ring_load(ring, acc_r, b0):
    """Open outputs of the member block starting at b0: ring -> acc_r (R, channels, BLOCK)."""
    for r in range(acc_r.shape[0]):
        for c in range(acc_r.shape[1]):
            for b in range(BLOCK):
                acc_r[r, c, b] = ring[r, c, b0 + b]


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def _ring_store(ring, acc_r, b0):
    """Open outputs back to the ring for the next chunk: acc_r -> ring."""
    for r in range(acc_r.shape[0]):
        for c in range(acc_r.shape[1]):
            for b in range(BLOCK):
                ring[r, c, b0 + b] = acc_r[r, c, b]


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def _fir_add(acc_r, val, gi, half, ntap, m, taps, w0):
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
                    acc_r[r, c, b] = _fma(wk, val[c, b], acc_r[r, c, b])
    else:
        for kk in range(max(0, (j - ntap + m) // m), j // m + 1):
            wk = taps[j - kk * m]
            r = kk % R
            for c in range(C):
                for b in range(BLOCK):
                    acc_r[r, c, b] = _fma(wk, val[c, b], acc_r[r, c, b])


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=CACHE)
def _fir_emit(acc_r, gi, half, ntap, m, out, col, b0):
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


@numba.njit(parallel=True, fastmath=FASTMATH, error_model="numpy", cache=CACHE)
def rk4_chunk(blk0, blk1, eta, v, kn, dl, lev, lam, cm, cdiag, diag, D, g, S, mode, s_half, coef,
              out, col0, taps, m, half, w0, ring, gi0):
    # RK4 steps gi0 .. gi0 + L - 1 of the member blocks blk0 .. blk1 - 1 (members
    # blk0 BLOCK .. blk1 BLOCK - 1; no blocks: compile only) with the anti-aliasing FIR fused
    # in: the recorded value of step gi (padded filter index j = gi + half) is added to every
    # open output k with k m <= j <= k m + ntap - 1 (weight taps[j - k m]) in a ring of
    # accumulators kept in `ring` between chunks; output k is written to
    # `out[:, :, col0 + n]` (out: members, channels, samples; n counts this chunk's outputs)
    # once j = k m + ntap - 1. At gi = 0 the value also stands for the padding j < half (the
    # state at rest), with weights w0[k].
    N = eta.shape[0]
    H = D.shape[1]
    C = S.shape[0]
    L = (s_half.shape[0] - 1) // 2
    R = ring.shape[0]
    ntap = taps.shape[0]
    dt = eta.dtype
    for blk in numba.prange(blk0, blk1):
        b0 = blk * BLOCK
        e = np.empty((N, BLOCK), dt)
        w = np.empty((N, BLOCK), dt)
        et = np.empty((N, BLOCK), dt)
        vt = np.empty((N, BLOCK), dt)
        se = np.zeros((N, BLOCK), dt)
        sv = np.zeros((N, BLOCK), dt)
        k = np.empty((N, BLOCK), dt)
        th = np.empty((H, BLOCK), dt)
        knb = np.empty(BLOCK, dt)
        dlb = np.empty(BLOCK, dt)
        lvb = np.empty(BLOCK, dt)
        for b in range(BLOCK):
            knb[b] = kn[b0 + b]
            dlb[b] = dl[b0 + b]
            lvb[b] = lev[b0 + b]
        for i in range(N):
            for b in range(BLOCK):
                e[i, b] = eta[i, b0 + b]
                w[i, b] = v[i, b0 + b]
        val = np.empty((C, BLOCK), dt)
        acc_r = np.empty((R, C, BLOCK), dt)
        _ring_load(ring, acc_r, b0)
        n_emit = 0
        h = coef[0]
        h2 = coef[1]
        h6 = coef[2]
        two = coef[3]
        for step in range(L):
            # the four RK4 stages as one loop around one copy of the stage code: the same
            # operations in the same order as four written-out stages, a quarter of the code to
            # compile (docs/simulate.md, "Compile time")
            for stage in range(4):
                x = e if stage == 0 else et
                y = w if stage == 0 else vt
                s = s_half[2 * step + (stage + 1) // 2]
                _accel(x, y, s, knb, dlb, lvb, lam, cm, cdiag, diag, D, g, th, k)
                if stage == 0:
                    src = e if mode == 0 else (w if mode == 1 else k)
                    for c in range(C):
                        for b in range(BLOCK):
                            val[c, b] = 0.0
                        for i in range(N):
                            sc = S[c, i]
                            for b in range(BLOCK):
                                val[c, b] = _fma(sc, src[i, b], val[c, b])
                    _fir_add(acc_r, val, gi0 + step, half, ntap, m, taps, w0)
                    n_emit += _fir_emit(acc_r, gi0 + step, half, ntap, m, out, col0 + n_emit, b0)
                    for i in range(N):
                        for b in range(BLOCK):
                            se[i, b] = w[i, b]
                            sv[i, b] = k[i, b]
                            et[i, b] = _fma(h2, w[i, b], e[i, b])
                            vt[i, b] = _fma(h2, k[i, b], w[i, b])
                elif stage < 3:
                    a = h2 if stage == 1 else h
                    for i in range(N):
                        for b in range(BLOCK):
                            se[i, b] = _fma(two, vt[i, b], se[i, b])
                            sv[i, b] = _fma(two, k[i, b], sv[i, b])
                            et[i, b] = _fma(a, vt[i, b], e[i, b])
                            vt[i, b] = _fma(a, k[i, b], w[i, b])
                else:
                    for i in range(N):
                        for b in range(BLOCK):
                            e[i, b] = _fma(h6, (se[i, b] + vt[i, b]), e[i, b])
                            w[i, b] = _fma(h6, (sv[i, b] + k[i, b]), w[i, b])
        for i in range(N):
            for b in range(BLOCK):
                eta[i, b0 + b] = e[i, b]
                v[i, b0 + b] = w[i, b]
        # the open outputs carry over to the next chunk (without this every chunk boundary
        # drops the partial sums: a glitch to ~0 and a filter-length recovery in the record)
        _ring_store(ring, acc_r, b0)


# ------------------------------------------------------------------ first compile


class _Announce(event.Listener):
    # "compiling ..." on stderr when numba compiles `dispatcher` (not when it loads the cache)
    def __init__(self, dispatcher, what):
        self.dispatcher, self.what, self.t0 = dispatcher, what, None

    def on_start(self, ev):
        if ev.data["dispatcher"] is self.dispatcher and self.t0 is None:
            print(f"compiling the numba RK4 kernel ({self.what})...", end=" ", file=sys.stderr,
                  flush=True)
            self.t0 = time.perf_counter()

    def on_end(self, ev):
        pass


def compile_kernel(kernel, args: tuple, what: str) -> None:
    """Compile ``kernel`` for ``args`` (or load it from numba's cache) by a call on no blocks.

    A compile prints one line to stderr, e.g. ``compiling the numba RK4 kernel (float32, full
    model)... 12.3 s, cached for later runs``; a cache load prints nothing.
    """
    listener = _Announce(kernel, what)
    with event.install_listener("numba:compile", listener):
        kernel(0, 0, *args)
    if listener.t0 is not None:
        path = kernel.stats.cache_path
        where = f"cached for later runs in {path}" if path else "not cached"
        print(f"{time.perf_counter() - listener.t0:.1f} s, {where}", file=sys.stderr, flush=True)


class NumbaRK4:
    """Compiled CPU engine with the interface of :class:`.engines.TorchRK4`.

    Parameters are those of :class:`.engines.TorchRK4`; ``dtype`` is a numpy or torch float
    dtype (float32 or float64).
    """

    def __init__(self, form: ModalForm, kn, delta, level_g, eta0, v0, *, h, quantity, dtype,
                 taps, factor):
        import torch

        if dtype in (torch.float32, np.float32):
            nd = np.float32
        elif dtype in (torch.float64, np.float64):
            nd = np.float64
        else:
            raise ValueError(f"`dtype` must be float32 or float64, got {dtype!r}")
        a = lambda x: np.ascontiguousarray(np.asarray(x, dtype=nd))  # noqa: E731
        self.nd = nd
        self.mode = MODES[quantity]
        self.lam, self.cm, self.cdiag = a(form.lam), a(form.Cm), a(np.diag(form.Cm))
        self.diag = bool(form.c_diagonal)
        self.D, self.g, self.S = a(form.D), a(form.g), a(form.S)
        # pad the batch to whole blocks (constant trip counts vectorise cleanly); padded members
        # have no load and no contact stiffness, so they stay at rest
        self.batch = B = len(np.atleast_1d(kn))
        pad = -B % BLOCK
        p1 = lambda x: a(np.concatenate([np.asarray(x, dtype=float), np.zeros(pad)]))  # noqa: E731
        self.kn, self.dl, self.lev = p1(kn), p1(delta), p1(level_g)
        p2 = lambda x: a(np.hstack([np.asarray(x, dtype=float).T,  # noqa: E731
                                    np.zeros((form.n_modes, pad))]))
        self.eta, self.v = p2(eta0), p2(v0)
        self.coef = a([h, 0.5 * h, h / 6.0, 2.0])
        self.alive = np.ones(len(self.kn), dtype=np.bool_)
        # fused decimation (see rk4_chunk): taps, ring of open outputs, start-padding weights
        self.taps = a(taps)
        self.m = int(factor)
        self.half = (len(taps) - 1) // 2
        self.w0 = self.start_weights(taps)
        self.ring = np.zeros((len(taps) // self.m + 2, len(form.S), len(self.kn)), dtype=nd)
        self.gi = 0  # steps integrated
        self.outputs = 0  # output samples completed
        self.width = len(form.S)  # output channels of the kernel
        self._compiled = False  # compile_kernel has run (first chunk)

    def start_weights(self, taps) -> np.ndarray:
        """Summed weights of ``taps`` over the constant pre-history (steps before the first) that
        output k sees, k = 0 .. half // m (see ``_fir_add``)."""
        w = [np.sum(taps[: self.half - k * self.m + 1]) for k in range(self.half // self.m + 1)]
        return np.ascontiguousarray(np.asarray(w, dtype=self.nd))

    def emitted(self, L: int) -> int:
        """Number of output samples the next chunk of ``L`` steps completes."""
        m, half, gi0 = self.m, self.half, self.gi
        k_first = max(0, -(-(gi0 - half) // m))
        k_last = (gi0 + L - 1 - half) // m
        return max(0, k_last - k_first + 1)

    def run(self, s_half: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Integrate one chunk and decimate on the fly.

        Parameters
        ----------
        s_half : ndarray, shape (2 L + 1,)
            sin(phase) at the half steps of the chunk's L steps.
        out : ndarray, shape (n_members, width, n_samples), optional
            The whole signal array (C-contiguous, the engine's dtype, ``n_members`` <= the
            padded batch): the outputs this chunk completes go to its columns
            ``outputs .. outputs + emitted(L) - 1`` (the count so far, over the calls), those
            at or past ``n_samples`` (the filter's tail) are dropped. Without it the chunk's
            outputs are returned alone, for every padded member.

        Returns
        -------
        ndarray
            ``out``, or a new (padded batch, width, ``emitted(L)``) array.
        """
        L = (len(s_half) - 1) // 2
        m, half, gi0 = self.m, self.half, self.gi
        n_new = self.emitted(L)
        if out is None:
            out = np.empty((self.kn.shape[0], self.width, n_new), dtype=self.nd)
            col0 = 0
        else:
            if (out.ndim != 3 or out.shape[0] > self.kn.shape[0] or out.shape[1] != self.width
                    or out.dtype != self.nd or not out.flags.c_contiguous):
                raise ValueError(
                    f"`out` must be a C-contiguous {np.dtype(self.nd)} array of shape (<= "
                    f"{self.kn.shape[0]}, {self.width}, n_samples), got {out.dtype} {out.shape}")
            col0 = self.outputs
        self._kernel(s_half, out, col0, m, half, gi0)
        self.gi += L
        self.outputs += n_new
        # divergence check once per chunk, outside the fast-math kernel (which may assume that
        # no NaN occurs); a diverged member is frozen at rest with no load
        with np.errstate(invalid="ignore"):
            bad = ~((np.abs(self.eta) <= BLOWUP).all(0) & (np.abs(self.v) <= BLOWUP).all(0))
        if bad.any():
            self.alive &= ~bad
            self.lev[bad] = 0.0
            self.eta[:, bad] = 0.0
            self.v[:, bad] = 0.0
        return out

    def _kernel(self, s_half, out, col0, m, half, gi0):
        self._call(rk4_chunk, "full model", (
            self.eta, self.v, self.kn, self.dl, self.lev, self.lam, self.cm, self.cdiag,
            self.diag, self.D, self.g, self.S, self.mode, np.asarray(s_half, dtype=self.nd),
            self.coef, out, col0, self.taps, m, half, self.w0, self.ring, gi0,
        ))

    def _call(self, kernel, model: str, args: tuple) -> None:
        # the first chunk compiles (or loads) the kernel in this thread, announced on stderr
        if not self._compiled:
            compile_kernel(kernel, args, f"{np.dtype(self.nd).name}, {model}")
            self._compiled = True
        kernel(0, self.kn.shape[0] // BLOCK, *args)

    @property
    def diverged(self) -> np.ndarray:
        return ~self.alive[: self.batch]

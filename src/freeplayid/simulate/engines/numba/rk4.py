"""Compiled CPU RK4 kernel (numba): the same arithmetic as :class:`..torch.TorchRK4`.

Layout: every per-member array is (N, batch) with the batch innermost, so each line of a step is
a loop over contiguous members that LLVM vectorises (SIMD lanes = members). Blocks of ``BLOCK``
members run the whole chunk in one thread (their state stays in L1 cache); blocks are spread
over threads with ``prange``. The step is fused: no temporaries leave the block. The four RK4
stages are one loop around one copy of the stage code (a quarter of the code to compile; docs/
simulate.md, "Compile time"). The anti-aliasing FIR is fused into the step loop (``fir.py``).

numba is optional: this module imports it, so import it only after
:func:`.engine.numba_available` says yes (the simulator falls back to the torch engine).
"""

from __future__ import annotations

import numba
import numpy as np

from ...cache import cache_unless_stale
from ...formulation import BLOWUP, MODES, ModalForm
from . import arith, fir
from .arith import FASTMATH, fma
from .fir import BLOCK, emitted_outputs, fir_add, fir_emit, ring_load, ring_store, start_weights
from .jit import compile_kernel, float_dtype

__all__ = ["NumbaRK4", "rk4_chunk", "load_block", "store_block", "modal_accel", "rk4_stage",
           "project", "INLINED_SHA256"]

# numba keys the cache of this file's kernels on this file alone, but they inline arith.py and
# fir.py: the digest of those (tests/test_simulate_determinism.py checks it), so that an edit
# there comes with an edit here, which invalidates the cache (on a mismatch: no cache)
INLINED_SHA256 = "30521c5fa19c9eb4026374afeccc2d5a7db5fd82c842976bd5b91ddec60e3266"
_CACHE = cache_unless_stale(__name__, INLINED_SHA256, arith, fir)


# ------------------------------------------------------------------ one RK4 step of a block
# What the full-model kernel (rk4_chunk) and the quasi-static one (rk4_qs.rk4_qs_chunk) share,
# written once: they differ only in how the hinge moments f are found (f(D^T eta) here, the
# algebraic hinge equation there) and in what a step records. One step of x = (eta, v), with
# a(eta, v, s) the right-hand side of (ETA) and s = sin(phase):
#
#     k1 = a(eta, v, s0)                                  (recorded: the acceleration at t_i)
#     k2 = a(eta + h/2 v, v + h/2 k1, s1/2)
#     k3 = a(eta + h/2 v2, v + h/2 k2, s1/2)              v2 = v + h/2 k1
#     k4 = a(eta + h v3, v + h k3, s1)                    v3 = v + h/2 k2
#     eta += h/6 (v + 2 v2 + 2 v3 + v4),  v += h/6 (k1 + 2 k2 + 2 k3 + k4)   v4 = v + h k3
#
# The kernels run the four stages as one loop around one copy of the stage code (the same
# operations in the same order as four written-out stages, a quarter of the code to compile;
# docs/simulate.md, "Compile time"): stage q evaluates k at (x, y) = (e, w) for q = 0, else
# (et, vt), then rk4_stage(q) updates the sums (se, sv) and the next stage's (et, vt).


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def load_block(b0, eta, v, kn, dl, lev, e, w, knb, dlb, lvb):
    """Members ``b0 .. b0 + BLOCK - 1``: state (eta, v) -> (e, w), parameters -> knb, dlb, lvb."""
    N = e.shape[0]
    for b in range(BLOCK):
        knb[b] = kn[b0 + b]
        dlb[b] = dl[b0 + b]
        lvb[b] = lev[b0 + b]
    for i in range(N):
        for b in range(BLOCK):
            e[i, b] = eta[i, b0 + b]
            w[i, b] = v[i, b0 + b]


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def store_block(b0, e, w, eta, v):
    """The block's state back: (e, w) -> (eta, v) of members ``b0 .. b0 + BLOCK - 1``."""
    N = e.shape[0]
    for i in range(N):
        for b in range(BLOCK):
            eta[i, b0 + b] = e[i, b]
            v[i, b0 + b] = w[i, b]


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def modal_accel(eta, v, s, lev, lam, cm, cdiag, diag, D, g, f, acc):
    """acc = g s lev - lam eta - Cm v - D f: the right-hand side of (ETA) for a block, given
    its hinge moments ``f`` (H, BLOCK); ``diag``: Cm is diagonal (``cdiag``)."""
    N, H = D.shape
    for i in range(N):
        gi = g[i] * s
        li = lam[i]
        for b in range(BLOCK):
            acc[i, b] = fma(-li, eta[i, b], gi * lev[b])
        if diag:
            ci = cdiag[i]
            for b in range(BLOCK):
                acc[i, b] = fma(-ci, v[i, b], acc[i, b])
        else:
            for k in range(N):
                c = cm[i, k]
                for b in range(BLOCK):
                    acc[i, b] = fma(-c, v[k, b], acc[i, b])
        for j in range(H):
            d = D[i, j]
            for b in range(BLOCK):
                acc[i, b] = fma(-d, f[j, b], acc[i, b])


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def rk4_stage(stage, e, w, et, vt, se, sv, k, h, h2, h6, two):
    """After stage ``stage`` (0-3) evaluated ``k``: stage 0 starts the sums (se, sv) = (v, k1)
    and sets (et, vt) for stage 1, stages 1 and 2 add 2 v_q, 2 k_q and set the next stage's
    (et, vt), stage 3 completes the step in (e, w)."""
    N = e.shape[0]
    if stage == 0:
        for i in range(N):
            for b in range(BLOCK):
                se[i, b] = w[i, b]
                sv[i, b] = k[i, b]
                et[i, b] = fma(h2, w[i, b], e[i, b])
                vt[i, b] = fma(h2, k[i, b], w[i, b])
    elif stage < 3:
        a = h2 if stage == 1 else h
        for i in range(N):
            for b in range(BLOCK):
                se[i, b] = fma(two, vt[i, b], se[i, b])
                sv[i, b] = fma(two, k[i, b], sv[i, b])
                et[i, b] = fma(a, vt[i, b], e[i, b])
                vt[i, b] = fma(a, k[i, b], w[i, b])
    else:
        for i in range(N):
            for b in range(BLOCK):
                e[i, b] = fma(h6, (se[i, b] + vt[i, b]), e[i, b])
                w[i, b] = fma(h6, (sv[i, b] + k[i, b]), w[i, b])


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def project(mode, e, w, k, S, val):
    """val = S @ (e, w or k for ``mode`` 0, 1, 2): the recorded channels of a block."""
    N = e.shape[0]
    C = S.shape[0]
    src = e if mode == 0 else (w if mode == 1 else k)
    for c in range(C):
        for b in range(BLOCK):
            val[c, b] = 0.0
        for i in range(N):
            sc = S[c, i]
            for b in range(BLOCK):
                val[c, b] = fma(sc, src[i, b], val[c, b])


# ------------------------------------------------------------------ the full model


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _accel(eta, v, s, kn, dl, lev, lam, cm, cdiag, diag, D, g, th, acc):
    # the hinge moments f(D^T eta) into th (branch-free: kn (theta - clamp(theta, -dl, dl))),
    # then the modal acceleration
    N, H = D.shape
    for j in range(H):
        for b in range(BLOCK):
            th[j, b] = 0.0
        for k in range(N):
            d = D[k, j]
            for b in range(BLOCK):
                th[j, b] = fma(d, eta[k, b], th[j, b])
        for b in range(BLOCK):
            x = th[j, b]
            c = min(max(x, -dl[b]), dl[b])
            th[j, b] = kn[b] * (x - c)
    modal_accel(eta, v, s, lev, lam, cm, cdiag, diag, D, g, th, acc)


@numba.njit(parallel=True, fastmath=FASTMATH, error_model="numpy", cache=_CACHE)
def rk4_chunk(blk0, blk1, eta, v, kn, dl, lev, lam, cm, cdiag, diag, D, g, S, mode, s_half, coef,
              out, col0, taps, m, half, w0, ring, gi0):
    # RK4 steps gi0 .. gi0 + L - 1 of the member blocks blk0 .. blk1 - 1 (members
    # blk0 BLOCK .. blk1 BLOCK - 1; no blocks: compile only) with the anti-aliasing FIR fused
    # in (fir.py): the recorded value of step gi goes to the open outputs of `ring` (kept
    # between chunks); a completed output is written to `out[:, :, col0 + n]` (out: members,
    # channels, samples; n counts this chunk's outputs)
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
        load_block(b0, eta, v, kn, dl, lev, e, w, knb, dlb, lvb)
        val = np.empty((C, BLOCK), dt)
        acc_r = np.empty((R, C, BLOCK), dt)
        ring_load(ring, acc_r, b0)
        n_emit = 0
        h = coef[0]
        h2 = coef[1]
        h6 = coef[2]
        two = coef[3]
        for step in range(L):
            for stage in range(4):  # one copy of the stage code (see rk4_stage)
                x = e if stage == 0 else et
                y = w if stage == 0 else vt
                s = s_half[2 * step + (stage + 1) // 2]
                _accel(x, y, s, knb, dlb, lvb, lam, cm, cdiag, diag, D, g, th, k)
                if stage == 0:
                    project(mode, e, w, k, S, val)
                    fir_add(acc_r, val, gi0 + step, half, ntap, m, taps, w0)
                    n_emit += fir_emit(acc_r, gi0 + step, half, ntap, m, out, col0 + n_emit, b0)
                rk4_stage(stage, e, w, et, vt, se, sv, k, h, h2, h6, two)
        store_block(b0, e, w, eta, v)
        # the open outputs carry over to the next chunk (without this every chunk boundary
        # drops the partial sums: a glitch to ~0 and a filter-length recovery in the record)
        ring_store(ring, acc_r, b0)


class NumbaRK4:
    """Compiled CPU engine with the interface of :class:`..torch.TorchRK4`.

    Parameters are those of :class:`..torch.TorchRK4`; ``dtype`` is a numpy or torch float
    dtype (float32 or float64).
    """

    def __init__(self, form: ModalForm, kn, delta, level_g, eta0, v0, *, h, quantity, dtype,
                 taps, factor):
        nd = float_dtype(dtype)
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
        """:func:`.fir.start_weights` of ``taps`` in the engine's dtype."""
        return start_weights(taps, self.m, self.nd)

    def emitted(self, L: int) -> int:
        """Number of output samples the next chunk of ``L`` steps completes."""
        return emitted_outputs(self.gi, L, self.half, self.m)

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
            compile_kernel(kernel, args, f"RK4 kernel ({np.dtype(self.nd).name}, {model})")
            self._compiled = True
        kernel(0, self.kn.shape[0] // BLOCK, *args)

    @property
    def diverged(self) -> np.ndarray:
        return ~self.alive[: self.batch]

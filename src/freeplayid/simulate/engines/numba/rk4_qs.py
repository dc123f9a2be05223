"""Compiled CPU kernel of the quasi-statically condensed model (``...quasistatic``).

The RK4 step, the layout (members innermost, blocks of ``BLOCK`` per thread) and the fused
anti-aliasing FIR are those of ``rk4.py``; the hinge moments are the solution of the algebraic
hinge equation (QS) ``theta + F f(theta) = c``, ``c = D^T eta + e a - Gam eta'``, instead of
``f(D^T eta)``. (QS) is solved per member (scalar code, a branchy active set) by semismooth
Newton over the contact states, started from the member's previous state (kept between stages,
steps and chunks), with the exhaustive search over the 3^h states as the fallback; each state is
a linear h x h solve.
"""

from __future__ import annotations

import numba
import numpy as np

from ...cache import cache_unless_stale
from ...quasistatic import QuasiStaticForm
from . import arith, fir, rk4
from .arith import FASTMATH, fma
from .fir import BLOCK, fir_add, fir_add2, fir_emit, ring_load, ring_store
from .rk4 import NumbaRK4, load_block, modal_accel, project, rk4_stage, store_block

__all__ = ["NumbaQSRK4", "rk4_qs_chunk", "INLINED_SHA256"]

# numba keys the cache of this file's kernels on this file alone, but they inline arith.py,
# fir.py and rk4.py: the digest of those (tests/test_simulate_determinism.py checks it), so that
# an edit there comes with an edit here, which invalidates the cache (on a mismatch: no cache)
INLINED_SHA256 = "c86745b401e5c9a0c1eec196f7d930ad0bc1ca82350f154a5f6918d6931b1779"
_CACHE = cache_unless_stale(__name__, INLINED_SHA256, arith, fir, rk4)


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _solve_state(F, c, st, b, kn, d, A, tv):
    # (I + kn F P) theta = c + kn F P s delta, P = diag|s|: elimination without pivoting (the
    # leading minors are >= 1), result in tv
    H = F.shape[0]
    for i in range(H):
        r = c[i, b]
        for j in range(H):
            sj = st[j, b]
            a = kn * F[i, j] * abs(sj)
            A[i, j] = a + (1.0 if i == j else 0.0)
            r += a * sj * d
        tv[i] = r
    for k in range(H):
        piv = 1.0 / A[k, k]
        for i in range(k + 1, H):
            m = A[i, k] * piv
            for j in range(k + 1, H):
                A[i, j] -= m * A[k, j]
            tv[i] -= m * tv[k]
    for i in range(H - 1, -1, -1):
        r = tv[i]
        for j in range(i + 1, H):
            r -= A[i, j] * tv[j]
        tv[i] = r / A[i, i]


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _solve_block(F, c, st, kn, dl, A3, T):
    # _solve_state for every member of the block at once (each in its own state), vectorised
    # over the members: the elimination has no pivoting, so no branch
    H = F.shape[0]
    for i in range(H):
        for b in range(BLOCK):
            T[i, b] = c[i, b]
        for j in range(H):
            fij = F[i, j]
            one = 1.0 if i == j else 0.0
            for b in range(BLOCK):
                sj = st[j, b]
                a = fij * kn[b] * abs(sj)
                A3[i, j, b] = a + one
                T[i, b] = fma(a * sj, dl[b], T[i, b])
    for k in range(H):
        for i in range(k + 1, H):
            for b in range(BLOCK):
                m = A3[i, k, b] / A3[k, k, b]
                for j in range(k + 1, H):
                    A3[i, j, b] = fma(-m, A3[k, j, b], A3[i, j, b])
                T[i, b] = fma(-m, T[k, b], T[i, b])
    for i in range(H - 1, -1, -1):
        for b in range(BLOCK):
            r = T[i, b]
            for j in range(i + 1, H):
                r = fma(-A3[i, j, b], T[j, b], r)
            T[i, b] = r / A3[i, i, b]


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _violation(x, s, d, e):
    # how far theta = x violates contact state s (open |x| <= d, closed s x >= d), tolerance e;
    # branch-free, 0 when consistent
    p = abs(s)
    return (1.0 - p) * max(abs(x) - d - e, 0.0) + p * max(d - e - s * x, 0.0)


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _solve_block2(F, c, st, kn, dl, T, bad, tol):
    # _solve_block and the violation check of _hinge_states for two hinges, one pass over the
    # members with the 2 x 2 system in registers: the same operations in the same order, so the
    # same T and violations bit for bit (tests/test_simulate_determinism.py)
    f00 = F[0, 0]
    f01 = F[0, 1]
    f10 = F[1, 0]
    f11 = F[1, 1]
    one = T.dtype.type(1.0)  # typed: in float32, `a + 1.0` would be float64
    zero = T.dtype.type(0.0)
    for b in range(BLOCK):
        k = kn[b]
        d = dl[b]
        s0 = st[0, b]
        s1 = st[1, b]
        p0 = abs(s0)
        p1 = abs(s1)
        c0 = c[0, b]
        c1 = c[1, b]
        a00 = f00 * k * p0
        a01 = f01 * k * p1
        a10 = f10 * k * p0
        a11 = f11 * k * p1
        t0 = fma(a01 * s1, d, fma(a00 * s0, d, c0))
        t1 = fma(a11 * s1, d, fma(a10 * s0, d, c1))
        u00 = a00 + one
        u01 = a01 + zero
        m = (a10 + zero) / u00
        u11 = fma(-m, u01, a11 + one)
        t1 = fma(-m, t0, t1) / u11
        t0 = fma(-u01, t1, t0) / u00
        T[0, b] = t0
        T[1, b] = t1
        v = _violation(t0, s0, d, tol * (d + abs(c0)))
        bad[b] = v + _violation(t1, s1, d, tol * (d + abs(c1)))


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _consistent(tv, c, st, b, d, tol):
    H = tv.shape[0]
    ok = True
    for j in range(H):
        x = tv[j]
        t = tol * (d + abs(c[j, b]))
        sj = st[j, b]
        if sj > 0.5:
            ok = ok and x >= d - t
        elif sj < -0.5:
            ok = ok and x <= -d + t
        else:
            ok = ok and abs(x) <= d + t
    return ok


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="never", cache=_CACHE)
def _solve_block_h(F, c, st, kn, dl, A3, T, bad, tol):
    # _solve_block and the violations for h != 2 hinges. Not inlined (nor _active_set): a
    # function of its own is compiled once, not as part of the kernel, which saves 1.5 s and 4 s
    # of the quasi-static kernel's cold compile (float32; docs/simulate.md, "Compile time"), for
    # a call per stage and block (the default fin's two hinges take _solve_block2, inlined)
    H = F.shape[0]
    _solve_block(F, c, st, kn, dl, A3, T)
    for b in range(BLOCK):
        bad[b] = 0.0
    for j in range(H):
        for b in range(BLOCK):
            bad[b] += _violation(T[j, b], st[j, b], dl[b], tol * (dl[b] + abs(c[j, b])))


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="never", cache=_CACHE)
def _active_set(F, c, st, kn, dl, A, tv, T, bad, tol):
    # the scalar active set of _hinge_states for the members whose state changed (bad != 0):
    # semismooth Newton from the previous state, the exhaustive search as the fallback
    H = F.shape[0]
    for b in range(BLOCK):
        if bad[b] == 0.0:
            continue
        knb = kn[b]
        d = dl[b]
        for j in range(H):
            x = T[j, b]
            st[j, b] = 1.0 if x > d else (-1.0 if x < -d else 0.0)
        done = False
        for _ in range(H + 3):  # active set (semismooth Newton) from the previous state
            _solve_state(F, c, st, b, knb, d, A, tv)
            if _consistent(tv, c, st, b, d, tol):
                done = True
                break
            for j in range(H):
                x = tv[j]
                st[j, b] = 1.0 if x > d else (-1.0 if x < -d else 0.0)
        if not done:  # exhaustive fallback
            for idx in range(3**H):
                t = idx
                for j in range(H):
                    st[j, b] = float(t % 3 - 1)
                    t //= 3
                _solve_state(F, c, st, b, knb, d, A, tv)
                if _consistent(tv, c, st, b, d, tol):
                    break
        for j in range(H):
            T[j, b] = tv[j]


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _hinge_states(F, c, st, kn, dl, A, tv, A3, T, bad, tol):
    # solution T of (QS) and its contact state st (updated in place) for every member
    H = F.shape[0]
    # every member in its previous contact state (vectorised); the few whose state changed (the
    # solution is inconsistent with it) go through the scalar active set
    if H == 2:
        _solve_block2(F, c, st, kn, dl, T, bad, tol)
    else:
        _solve_block_h(F, c, st, kn, dl, A3, T, bad, tol)
    nbad = 0.0
    for b in range(BLOCK):  # a loop of its own: a reduction (no reassociation) inside the ones
        nbad += bad[b]      # above would keep them from being vectorised
    if nbad == 0.0:
        return
    _active_set(F, c, st, kn, dl, A, tv, T, bad, tol)


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _accel_qs(eta, v, s, kn, dl, lev, lam, cm, cdiag, diag, D, g, F, e, gam, st, c, fo, acc, A,
              tv, A3, T, bad, tol):
    # the hinge moments fo of (QS), c = D^T eta + e a - Gam eta', then the modal acceleration
    N, H = D.shape
    for j in range(H):
        ej = e[j] * s
        for b in range(BLOCK):
            c[j, b] = ej * lev[b]
        for k in range(N):
            dk = D[k, j]
            gk = gam[j, k]
            for b in range(BLOCK):
                c[j, b] = fma(-gk, v[k, b], fma(dk, eta[k, b], c[j, b]))
    _hinge_states(F, c, st, kn, dl, A, tv, A3, T, bad, tol)
    for j in range(H):
        for b in range(BLOCK):
            sj = st[j, b]
            fo[j, b] = kn[b] * abs(sj) * (T[j, b] - sj * dl[b])
    modal_accel(eta, v, s, lev, lam, cm, cdiag, diag, D, g, fo, acc)


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _record_qs(e_, w, k, fo, S, hout, vout, mode, val, valf, acc_r, gi, half, ntap, m, taps,
               tapsd, w0, w0d):
    # the recorded value of the step (the output quantity of the slow modes, plus the fast
    # part q = hout @ f + vout @ eta': added as it is (mode 0), else to `valf`, whose derivative
    # the derivative taps take) into the open outputs of the FIR ring
    N = e_.shape[0]
    C = S.shape[0]
    H = fo.shape[0]
    project(mode, e_, w, k, S, val)
    dst = val if mode == 0 else valf
    for c in range(C):
        if mode != 0:
            for b in range(BLOCK):
                valf[c, b] = 0.0
        for j in range(H):
            hc = hout[c, j]
            for b in range(BLOCK):
                dst[c, b] = fma(hc, fo[j, b], dst[c, b])
        for i in range(N):
            vc = vout[c, i]
            for b in range(BLOCK):
                dst[c, b] = fma(vc, w[i, b], dst[c, b])
    if mode == 0:
        fir_add(acc_r, val, gi, half, ntap, m, taps, w0)
    else:
        fir_add2(acc_r, val, valf, gi, half, ntap, m, taps, tapsd, w0, w0d)


@numba.njit(parallel=True, fastmath=FASTMATH, error_model="numpy", cache=_CACHE)
def rk4_qs_chunk(blk0, blk1, eta, v, stp, kn, dl, lev, lam, cm, cdiag, diag, D, g, F, e, gam,
                 S, hout, vout, mode, s_half, coef, out, col0, taps, tapsd, m, half, w0, w0d, ring,
                 gi0):
    # rk4.rk4_chunk (blocks blk0 .. blk1 - 1) with the condensed hinge moments and their
    # contact states `stp` (kept between chunks); the fast modes' quasi-static response
    # q = hout @ f + vout @ eta' is added to the displacement output (mode 0), else filtered
    # through the derivative taps `tapsd` (its derivative, decimated) into the same outputs
    N = eta.shape[0]
    H = D.shape[1]
    C = S.shape[0]
    L = (s_half.shape[0] - 1) // 2
    R = ring.shape[0]
    ntap = taps.shape[0]
    dt = eta.dtype
    tol = coef[4]
    for blk in numba.prange(blk0, blk1):
        b0 = blk * BLOCK
        e_ = np.empty((N, BLOCK), dt)
        w = np.empty((N, BLOCK), dt)
        et = np.empty((N, BLOCK), dt)
        vt = np.empty((N, BLOCK), dt)
        se = np.zeros((N, BLOCK), dt)
        sv = np.zeros((N, BLOCK), dt)
        k = np.empty((N, BLOCK), dt)
        cc = np.empty((H, BLOCK), dt)
        fo = np.empty((H, BLOCK), dt)
        st = np.empty((H, BLOCK), dt)
        A = np.empty((H, H), dt)
        tv = np.empty(H, dt)
        A3 = np.empty((H, H, BLOCK), dt)
        T = np.empty((H, BLOCK), dt)
        bad = np.empty(BLOCK, dt)
        knb = np.empty(BLOCK, dt)
        dlb = np.empty(BLOCK, dt)
        lvb = np.empty(BLOCK, dt)
        load_block(b0, eta, v, kn, dl, lev, e_, w, knb, dlb, lvb)
        for j in range(H):
            for b in range(BLOCK):
                st[j, b] = stp[j, b0 + b]
        val = np.empty((C, BLOCK), dt)
        valf = np.empty((C, BLOCK), dt)
        acc_r = np.empty((R, C, BLOCK), dt)
        ring_load(ring, acc_r, b0)
        n_emit = 0
        h = coef[0]
        h2 = coef[1]
        h6 = coef[2]
        two = coef[3]
        for step in range(L):
            for stage in range(4):  # one copy of the (large) stage code (see rk4.rk4_stage)
                x = e_ if stage == 0 else et
                y = w if stage == 0 else vt
                s = s_half[2 * step + (stage + 1) // 2]
                _accel_qs(x, y, s, knb, dlb, lvb, lam, cm, cdiag, diag, D, g, F, e, gam, st, cc,
                          fo, k, A, tv, A3, T, bad, tol)
                if stage == 0:
                    _record_qs(e_, w, k, fo, S, hout, vout, mode, val, valf, acc_r, gi0 + step,
                               half, ntap, m, taps, tapsd, w0, w0d)
                    n_emit += fir_emit(acc_r, gi0 + step, half, ntap, m, out, col0 + n_emit, b0)
                rk4_stage(stage, e_, w, et, vt, se, sv, k, h, h2, h6, two)
        store_block(b0, e_, w, eta, v)
        for j in range(H):
            for b in range(BLOCK):
                stp[j, b0 + b] = st[j, b]
        # the open outputs carry over to the next chunk (see rk4.rk4_chunk)
        ring_store(ring, acc_r, b0)


class NumbaQSRK4(NumbaRK4):
    """:class:`.rk4.NumbaRK4` for a :class:`...quasistatic.QuasiStaticForm`.

    For velocity and acceleration, ``taps_d`` (from :func:`...resample.derivative_taps`, the same
    length as ``taps``) decimate the derivative of the fast part (``hinge_out @ f + vel_out @
    eta'``) into the same outputs.
    """

    def __init__(self, qs: QuasiStaticForm, kn, delta, level_g, eta0, v0, *, taps_d=None, **kw):
        super().__init__(qs.slow, kn, delta, level_g, eta0, v0, **kw)
        a = lambda x: np.ascontiguousarray(np.asarray(x, dtype=self.nd))  # noqa: E731
        self.F, self.e, self.gam = a(qs.F), a(qs.e), a(qs.Gam)
        self.hout, self.vout = a(qs.hinge_out), a(qs.vel_out)
        self.st = np.zeros((qs.F.shape[0], len(self.kn)), dtype=self.nd)
        if self.mode == 0:
            taps_d = np.zeros_like(self.taps)  # the fast part goes through `taps` as it is
        elif taps_d is None or len(taps_d) != len(self.taps):
            raise ValueError(f"velocity and acceleration need `taps_d` of length "
                             f"{len(self.taps)} (resample.derivative_taps)")
        self.taps_d = a(taps_d)
        self.w0d = self.start_weights(taps_d)
        tol = 1e-5 if self.nd == np.float32 else 1e-11  # contact-state consistency (round-off)
        self.coef = a(list(self.coef[:4]) + [tol])

    def _kernel(self, s_half, out, col0, m, half, gi0):
        self._call(rk4_qs_chunk, "quasi-static model", (
            self.eta, self.v, self.st, self.kn, self.dl, self.lev, self.lam, self.cm, self.cdiag,
            self.diag, self.D, self.g, self.F, self.e, self.gam, self.S, self.hout,
            self.vout, self.mode,
            np.asarray(s_half, dtype=self.nd), self.coef, out, col0, self.taps, self.taps_d, m,
            half, self.w0, self.w0d, self.ring, gi0,
        ))

"""Compiled CPU kernel of the exponential integrator (``steps.py``), numba.

Layout for small batches: one member per ``prange`` iteration, its state ``z = (eta, eta')``
contiguous, so the 2N-long column updates of ``z <- Phi z`` vectorise (``Phi`` stored
transposed: ``z_new += Phi[:, j] z_j`` is an independent fused multiply-add per row, no
reassociation needed). With classical damping (diagonal ``Cm``) ``Phi`` is 2 x 2 per mode and
the kernel uses those four diagonals only. One member costs what one member costs: a batch of
5 uses 2 cores for 5 members, not 64 lanes of padding as the RK4 kernel does.

The contact solve ``theta + Gamma f(theta) = a`` is per member and exact: each hinge's state
(-1, 0, +1) is guessed from ``a``, the state's linear h x h system solved (elimination without
pivoting: ``I + kn Gamma P`` is close to I for the short steps of the step rule), the state
re-checked and the iteration repeated (at most ``MAX_ACTIVE_SET`` times), then the exhaustive
search over the 3^h states; a member with no consistent state is flagged and frozen at rest.

The anti-aliasing FIR is fused as in the RK4 kernels (same ring arithmetic, ``..numba.fir``:
each recorded value is added to its open outputs, an output is emitted when its last tap
arrives, the ring persists between chunks), in its single-lane form ``fir_add1`` /
``fir_emit1``. The FASTMATH flags, the numpy error model and the explicit ``fma`` are those of
the RK4 kernels (``..numba.arith``: cached and fresh compiles give the same bits).
"""

from __future__ import annotations

import numba
import numpy as np

from ...cache import cache_unless_stale
from ...formulation import BLOWUP, MODES, ModalForm
from ..numba import arith, fir
from ..numba.arith import FASTMATH, fma
from ..numba.fir import emitted_outputs, fir_add1, fir_emit1, ring_load1, ring_store1, start_weights
from ..numba.jit import compile_kernel, float_dtype
from .steps import MAX_STATE_SETS, discretize, discretize_states, per_state_scheme, switch_levels

__all__ = ["NumbaExpo", "expo_chunk", "expo_states_chunk", "INLINED_SHA256", "MAX_ACTIVE_SET",
           "MAX_STATE_SETS"]

# numba keys the cache of this file's kernels on this file alone, but they inline the numba
# engines' arith.py and fir.py: the digest of those (tests/test_simulate_determinism.py checks
# it), so that an edit there comes with an edit here (on a mismatch: no cache)
INLINED_SHA256 = "30521c5fa19c9eb4026374afeccc2d5a7db5fd82c842976bd5b91ddec60e3266"
_CACHE = cache_unless_stale(__name__, INLINED_SHA256, arith, fir)
MAX_ACTIVE_SET = 8  # active-set iterations before the exhaustive search


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="never", cache=_CACHE)
def _solve_state(G, a, st, kn, d, A, tv):
    # (I + kn G P) theta = a + kn G P s d, P = diag|s|, d the hinges' half-gaps (H,), into tv:
    # elimination without pivoting
    H = G.shape[0]
    for i in range(H):
        r = a[i]
        for j in range(H):
            sj = st[j]
            q = kn * G[i, j] * abs(sj)
            A[i, j] = q + (1.0 if i == j else 0.0)
            r = fma(q * sj, d[j], r)
        tv[i] = r
    for k in range(H):
        for i in range(k + 1, H):
            f = A[i, k] / A[k, k]
            for j in range(k + 1, H):
                A[i, j] = fma(-f, A[k, j], A[i, j])
            tv[i] = fma(-f, tv[k], tv[i])
    for i in range(H - 1, -1, -1):
        r = tv[i]
        for j in range(i + 1, H):
            r = fma(-A[i, j], tv[j], r)
        tv[i] = r / A[i, i]


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="never", cache=_CACHE)
def _contact(G, a, st, kn, d, A, tv, tol):
    # theta + G f(theta) = a: the contact state of each hinge (st, -1/0/+1) and theta (tv), d
    # the hinges' half-gaps (H,); returns False if no state is consistent
    H = G.shape[0]
    for j in range(H):
        st[j] = 1.0 if a[j] > d[j] else (-1.0 if a[j] < -d[j] else 0.0)
    for _ in range(MAX_ACTIVE_SET):
        _solve_state(G, a, st, kn, d, A, tv)
        same = True
        for j in range(H):
            x = tv[j]
            dj = d[j]
            e = tol * (abs(x) + dj)
            s = 1.0 if x > dj + e else (-1.0 if x < -dj - e else (0.0 if abs(x) < dj - e
                                                                    else st[j]))
            if s != st[j]:
                same = False
                st[j] = s
        if same:
            return True
    # exhaustive search over the 3^H states (an iteration that cycles)
    n = 1
    for _ in range(H):
        n *= 3
    for code in range(n):
        q = code
        for j in range(H):
            st[j] = float(q % 3 - 1)
            q //= 3
        _solve_state(G, a, st, kn, d, A, tv)
        ok = True
        for j in range(H):
            x = tv[j]
            dj = d[j]
            e = tol * (abs(x) + dj)
            if st[j] == 0.0:
                ok = ok and abs(x) <= dj + e
            else:
                ok = ok and st[j] * x >= dj - e
        if ok:
            return True
    return False


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _record(O, Of, Og, zc, f0, u, val, acc_r, gi, half, ntap, m, taps, w0, out, col, i):
    # the recorded value at t_k, O z + Of f + Og u (u = level sin phase + the constant load),
    # into the open outputs
    # of member i; returns 1 if an output was completed (fir_emit1)
    C = O.shape[0]
    n2 = zc.shape[0]
    H = f0.shape[0]
    for c in range(C):
        x = Og[c] * u
        for k in range(n2):
            x = fma(O[c, k], zc[k], x)
        for j in range(H):
            x = fma(Of[c, j], f0[j], x)
        val[c] = x
    fir_add1(acc_r, val, gi, half, ntap, m, taps, w0)
    return fir_emit1(acc_r, gi, half, ntap, m, out, col, i)


@numba.njit(parallel=True, nogil=True, fastmath=FASTMATH, error_model="numpy", cache=_CACHE)
def expo_chunk(i0, i1, z, fz, kn, dl, sh, lev, ust, PhiT, p11, p12, p21, p22, diag, W, P0T, P1T, D,
               G, O, Of, Og, s_half, tol, out, col0, taps, m, half, w0, ring, gi0, bad):
    # steps gi0 .. gi0 + L - 1 of members i0 .. i1 - 1 (none: compile only). z (batch, 2N) state
    # at the chunk start, fz (batch, H) f(theta) there, ring (batch, R, C) the open outputs of
    # the fused FIR (..numba.fir: output k gets weight taps[j - k m] of the value of step
    # gi, j = gi + half, and is written to out[i, :, col0 + n] once complete). The recorded value
    # at t_k is O z_k + Of f_k + Og level s_k (eta, eta' or eta'' through S). A member without a
    # consistent contact state is flagged in `bad` and frozen at rest with no load. Hinge j's
    # half-gap is dl[i] sh[j] (sh: the gap shares, all 1 for one common gap). ust[i] is member
    # i's constant load (a static acceleration of the frame, in level units), added to u.
    n2 = z.shape[1]
    N = n2 // 2
    H = D.shape[1]
    C = O.shape[0]
    L = (s_half.shape[0] - 1) // 2
    R = ring.shape[1]
    ntap = taps.shape[0]
    dt = z.dtype
    zero = z.dtype.type(0.0)  # typed: in float32 a bare 0.0 would make the _fma float64
    for i in numba.prange(i0, i1):
        zc = np.empty(n2, dt)
        zn = np.empty(n2, dt)
        f0 = np.empty(H, dt)
        f1 = np.empty(H, dt)
        a = np.empty(H, dt)
        st = np.empty(H, dt)
        tv = np.empty(H, dt)
        A = np.empty((H, H), dt)
        dv = np.empty(H, dt)
        val = np.empty(C, dt)
        acc_r = np.empty((R, C), dt)
        for k in range(n2):
            zc[k] = z[i, k]
        for j in range(H):
            f0[j] = fz[i, j]
        ring_load1(ring, acc_r, i)
        k_n = kn[i]
        for j in range(H):
            dv[j] = dl[i] * sh[j]
        lv = lev[i]
        us = ust[i]
        n_emit = 0
        for step in range(L):
            u0 = fma(lv, s_half[2 * step], us)
            n_emit += _record(O, Of, Og, zc, f0, u0, val, acc_r, gi0 + step, half, ntap,
                              m, taps, w0, out, col0 + n_emit, i)  # record at t_k
            # free response and the base load
            um = fma(lv, s_half[2 * step + 1], us)
            u1 = fma(lv, s_half[2 * step + 2], us)
            if diag:
                for k in range(N):
                    e_ = zc[k]
                    v_ = zc[N + k]
                    zn[k] = fma(p12[k], v_, p11[k] * e_)
                    zn[N + k] = fma(p22[k], v_, p21[k] * e_)
            else:
                for k in range(n2):
                    zn[k] = 0.0
                for j in range(n2):
                    zj = zc[j]
                    for k in range(n2):
                        zn[k] = fma(PhiT[j, k], zj, zn[k])
            for k in range(n2):
                zn[k] = fma(W[0, k], u0, fma(W[1, k], um, fma(W[2, k], u1, zn[k])))
            for j in range(H):
                fj = f0[j]
                for k in range(n2):
                    zn[k] = fma(-P0T[j, k], fj, zn[k])
            # the contact at t_{k+1}: theta = a - G f(theta)
            for j in range(H):
                x = zero
                for k in range(N):
                    x = fma(D[k, j], zn[k], x)
                a[j] = x
            if not _contact(G, a, st, k_n, dv, A, tv, tol):
                bad[i] = True
                lv = zero
                us = zero
                for k in range(n2):
                    zn[k] = 0.0
                for j in range(H):
                    f1[j] = 0.0
            else:
                for j in range(H):
                    f1[j] = k_n * abs(st[j]) * (tv[j] - st[j] * dv[j])
                for j in range(H):
                    fj = f1[j]
                    for k in range(n2):
                        zn[k] = fma(-P1T[j, k], fj, zn[k])
            for k in range(n2):
                zc[k] = zn[k]
            for j in range(H):
                f0[j] = f1[j]
        for k in range(n2):
            z[i, k] = zc[k]
        for j in range(H):
            fz[i, j] = f0[j]
        ring_store1(ring, acc_r, i)


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _state_prop(PhiT, W, c, zc, zn, ua, um, ub, d):
    # zn = Phi_s zc + W0_s ua + Wm_s um + W1_s ub + d c_s (u already times the level)
    n2 = zc.shape[0]
    for k in range(n2):
        zn[k] = fma(W[0, k], ua, fma(W[1, k], um, fma(W[2, k], ub, d * c[k])))
    for j in range(n2):
        zj = zc[j]
        for k in range(n2):
            zn[k] = fma(PhiT[j, k], zj, zn[k])


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _quad(u0, um, u1, x, one):
    # the quadratic through u0, um, u1 at x = 0, 1/2, 1 (Lagrange), at x (one: 1 in the dtype)
    two = one + one
    return (u0 * (one - x) * (one - two * x) + um * (two + two) * x * (one - x)
            + u1 * x * (two * x - one))


@numba.njit(fastmath=FASTMATH, error_model="numpy", inline="always", cache=_CACHE)
def _hinge_state(D, z, d, th, st):
    # theta = D^T eta into th, the contact state of each hinge (half-gaps d, (H,)) into st;
    # returns the state code
    H = D.shape[1]
    N = D.shape[0]
    code = 0
    mult = 1
    for j in range(H):
        x = z.dtype.type(0.0)
        for k in range(N):
            x = fma(D[k, j], z[k], x)
        th[j] = x
        s = 1.0 if x > d[j] else (-1.0 if x < -d[j] else 0.0)
        st[j] = s
        code += (int(s) + 1) * mult
        mult *= 3
    return code


@numba.njit(parallel=True, nogil=True, fastmath=FASTMATH, error_model="numpy", cache=_CACHE)
def expo_states_chunk(i0, i1, z, kset, dl, sh, lev, ust, kns, levels, PhiT, Ws, cs, P1T, Gm, Ms,
                      es, D, O, Of, Og, s_half, tol, out, col0, taps, m, half, w0, ring, gi0, bad):
    # as expo_chunk, with exact steps per contact state (steps.discretize_states): member
    # i uses the matrices kset[i] (its kn, kns[kset[i]]). A step is taken in the state of its
    # start; if a hinge's state at its end differs, it is halved (down to h / 2^levels) and the
    # sub-step holding the switch is corrected by the residual moment held linear. The state
    # and f(theta) follow from z, so z is the whole member state. Hinge j's half-gap is
    # dl[i] sh[j] (cs and es have the shares sh folded in: per unit dl).
    n2 = z.shape[1]
    H = D.shape[1]
    C = O.shape[0]
    L = (s_half.shape[0] - 1) // 2
    R = ring.shape[1]
    ntap = taps.shape[0]
    dt = z.dtype
    cast = z.dtype.type
    one = cast(1.0)
    full = 1 << levels
    for i in numba.prange(i0, i1):
        zc = np.empty(n2, dt)
        zn = np.empty(n2, dt)
        th = np.empty(H, dt)
        st0 = np.empty(H, dt)
        st1 = np.empty(H, dt)
        f0 = np.empty(H, dt)
        a = np.empty(H, dt)
        st = np.empty(H, dt)
        tv = np.empty(H, dt)
        A = np.empty((H, H), dt)
        dv = np.empty(H, dt)
        val = np.empty(C, dt)
        acc_r = np.empty((R, C), dt)
        for k in range(n2):
            zc[k] = z[i, k]
        ring_load1(ring, acc_r, i)
        ki = kset[i]
        k_n = kns[ki]
        d = dl[i]
        for j in range(H):
            dv[j] = d * sh[j]
        lv = lev[i]
        us = ust[i]
        n_emit = 0
        for step in range(L):
            u0 = fma(lv, s_half[2 * step], us)
            code = _hinge_state(D, zc, dv, th, st0)
            for j in range(H):
                f0[j] = k_n * abs(st0[j]) * (th[j] - st0[j] * dv[j])
            n_emit += _record(O, Of, Og, zc, f0, u0, val, acc_r, gi0 + step, half, ntap,
                              m, taps, w0, out, col0 + n_emit, i)  # record at t_k
            um = fma(lv, s_half[2 * step + 1], us)
            u1 = fma(lv, s_half[2 * step + 2], us)
            # the step in sub-steps of h / 2^lvl at pos (units h / 2^levels)
            pos = 0
            lvl = 0
            while pos < full:
                ln = 1 << (levels - lvl)
                if lvl == 0:
                    ua, uc, ub = u0, um, u1
                else:
                    # the step's quadratic base load at the sub-step's ends and middle
                    xa = cast(pos / full)
                    xb = cast((pos + ln) / full)
                    xm = cast(0.5) * (xa + xb)
                    ua = _quad(u0, um, u1, xa, one)
                    uc = _quad(u0, um, u1, xm, one)
                    ub = _quad(u0, um, u1, xb, one)
                _state_prop(PhiT[ki, lvl, code], Ws[ki, lvl, code], cs[ki, lvl, code], zc, zn,
                            ua, uc, ub, d)
                _hinge_state(D, zn, dv, a, st1)
                same = True
                for j in range(H):
                    if st1[j] != st0[j]:
                        same = False
                if not same and lvl < levels:
                    lvl += 1
                    continue
                if not same:
                    # switch inside the finest sub-step: residual moment held linear
                    Gs = Gm[ki, code]
                    Mm = Ms[ki, code]
                    for j in range(H):
                        x = -d * es[ki, code, j]
                        for q in range(H):
                            x = fma(Mm[j, q], a[q], x)
                        th[j] = x
                    if not _contact(Gs, th, st, k_n, dv, A, tv, tol):
                        bad[i] = True
                        lv = cast(0.0)
                        us = cast(0.0)
                        u0 = um = u1 = cast(0.0)
                        for k in range(n2):
                            zn[k] = 0.0
                    else:
                        for j in range(H):
                            rj = (k_n * abs(st[j]) * (tv[j] - st[j] * dv[j])
                                  - k_n * abs(st0[j]) * (tv[j] - st0[j] * dv[j]))
                            for k in range(n2):
                                zn[k] = fma(-P1T[ki, code, j, k], rj, zn[k])
                for k in range(n2):
                    zc[k] = zn[k]
                pos += ln
                while lvl > 0 and pos % (2 * ln) == 0:
                    lvl -= 1
                    ln *= 2
                if not same:
                    code = _hinge_state(D, zc, dv, th, st0)
        for k in range(n2):
            z[i, k] = zc[k]
        ring_store1(ring, acc_r, i)


def _record_map(form: ModalForm, quantity: str):
    """(O, Of, Og), float64: the recorded value is ``O z + Of f + Og level s`` (eta, eta' or
    eta'' = -lam eta - Cm eta' - D f + g level s, all through S)."""
    N, H = form.D.shape
    S = form.S
    mode = MODES[quantity]
    C = S.shape[0]
    O, Of, Og = np.zeros((C, 2 * N)), np.zeros((C, H)), np.zeros(C)
    if mode == 0:
        O[:, :N] = S
    elif mode == 1:
        O[:, N:] = S
    else:
        O[:, :N] = -S * form.lam[None, :]
        O[:, N:] = -S @ form.Cm
        Of = -S @ form.D
        Og = S @ form.g
    return O, Of, Og


class NumbaExpo:
    """Exponential-integrator engine state: the members, the step matrices, the fused FIR.

    Parameters
    ----------
    form : ModalForm
    kn, delta, level_g : ndarray, shape (batch,) [N m/rad], [rad], [g]
    eta0, v0 : ndarray, shape (batch, N)
        Initial modal state.
    h : float [s]
        Step.
    quantity : str
        Recorded quantity (displacement | velocity | acceleration).
    dtype : numpy or torch float32 / float64
    taps : ndarray, shape (n_taps,)
        Anti-aliasing FIR at the step rate.
    factor : int
        Steps per output sample.
    gap_shares : ndarray, shape (H,), optional
        Hinge j's half-gap is ``delta * gap_shares[j]`` (default all 1: one common gap).
    static_g : float [g]
        A constant acceleration of the frame added to every member's excitation (default 0).
    contact_damping : ndarray, shape (H,), optional [N m s/rad]
        A damper across hinge j acting only in contact (:func:`.steps.discretize_states`):
        the per-state scheme and a recorded displacement only.
    """

    def __init__(self, form: ModalForm, kn, delta, level_g, eta0, v0, *, h, quantity, dtype,
                 taps, factor, gap_shares=None, static_g: float = 0.0, contact_damping=None):
        nd = float_dtype(dtype)
        a = lambda x: np.ascontiguousarray(np.asarray(x, dtype=nd))  # noqa: E731
        self.nd = nd
        N, H = form.D.shape
        shares = np.ones(H) if gap_shares is None else np.asarray(gap_shares, float).reshape(H)
        self.sh = a(shares)
        B = len(np.atleast_1d(kn))
        kn_u, kset = np.unique(np.asarray(kn, float).reshape(B), return_inverse=True)
        # the scheme depends on the batch's distinct kn only, each set on its kn only: a
        # member's result is the same in every batch that takes the same scheme
        self.per_state = per_state_scheme(len(kn_u))
        if contact_damping is not None and not self.per_state:
            raise NotImplementedError(
                f"damping in contact is simulated with at most {MAX_STATE_SETS} distinct kn in "
                f"a batch (the exact per-state scheme), got {len(kn_u)}")
        if contact_damping is not None and MODES[quantity] != 0:
            raise NotImplementedError("damping in contact is simulated recording displacement "
                                      f"(its derivatives by the FIR), got {quantity!r}")
        self.contact_damping = contact_damping
        if self.per_state:
            self._state_sets(form, h, kn_u, kset, shares)
        st = discretize(form, h)
        self.step = st
        self.PhiT = a(st.Phi.T)
        self.diag = bool(form.c_diagonal)
        idx = np.arange(N)
        self.p11, self.p12 = a(st.Phi[idx, idx]), a(st.Phi[idx, N + idx])
        self.p21, self.p22 = a(st.Phi[N + idx, idx]), a(st.Phi[N + idx, N + idx])
        self.W, self.P0T, self.P1T = a(st.W), a(st.P0.T), a(st.P1.T)
        self.D, self.G = a(form.D), a(st.Gamma)
        self.O, self.Of, self.Og = (a(x) for x in _record_map(form, quantity))
        C = self.O.shape[0]
        self.batch = B = len(np.atleast_1d(kn))
        self.kn, self.dl, self.lev = a(kn), a(delta), a(level_g)
        self.ust = a(np.full(B, float(static_g)))
        self.z = a(np.hstack([np.asarray(eta0, float).reshape(B, N),
                              np.asarray(v0, float).reshape(B, N)]))
        theta0 = np.asarray(eta0, float).reshape(B, N) @ form.D
        dl0 = np.asarray(delta, float)[:, None] * shares[None, :]
        self.fz = a(np.asarray(kn, float)[:, None] * (theta0 - np.clip(theta0, -dl0, dl0)))
        self.tol = nd(64 * np.finfo(nd).eps)
        self.alive = np.ones(B, dtype=np.bool_)
        self.bad = np.zeros(B, dtype=np.bool_)
        self.taps = a(taps)
        self.m = int(factor)
        self.half = (len(taps) - 1) // 2
        self.w0 = start_weights(taps, self.m, nd)
        self.ring = np.zeros((B, len(taps) // self.m + 2, C), dtype=nd)
        self.gi = 0
        self.outputs = 0
        self.width = C
        self._compiled = False

    def _state_sets(self, form: ModalForm, h: float, kn_u: np.ndarray, kset: np.ndarray,
                    shares: np.ndarray):
        # the per-state step matrices (steps.discretize_states) of each distinct kn, stacked
        a = lambda x: np.ascontiguousarray(np.asarray(x, dtype=self.nd))  # noqa: E731
        self.levels = max(switch_levels(form, h, k) for k in kn_u)
        sets = [discretize_states(form, h, float(k), levels=self.levels, gap_shares=shares,
                                  contact_damping=self.contact_damping) for k in kn_u]
        self.sets = sets
        self.kset = np.ascontiguousarray(kset, dtype=np.int64)
        self.kns = a(kn_u)
        self.sPhiT = a(np.stack([q.Phi.transpose(0, 1, 3, 2) for q in sets]))
        self.sW = a(np.stack([q.W for q in sets]))
        self.sc = a(np.stack([q.c for q in sets]))
        self.sP1T = a(np.stack([q.P1.transpose(0, 2, 1) for q in sets]))
        self.sGm = a(np.stack([q.Gm for q in sets]))
        self.sM = a(np.stack([q.M for q in sets]))
        self.se = a(np.stack([q.e for q in sets]))

    def emitted(self, L: int) -> int:
        """Number of output samples the next chunk of ``L`` steps completes."""
        return emitted_outputs(self.gi, L, self.half, self.m)

    def run(self, s_half: np.ndarray, out: np.ndarray) -> np.ndarray:
        """Integrate one chunk of ``L = (len(s_half) - 1) / 2`` steps, decimating into ``out``
        (batch, width, n_samples), columns ``outputs .. outputs + emitted(L) - 1``."""
        if (out.ndim != 3 or out.shape[0] != self.batch or out.shape[1] != self.width
                or out.dtype != self.nd or not out.flags.c_contiguous):
            raise ValueError(
                f"`out` must be a C-contiguous {np.dtype(self.nd).name} array of shape "
                f"({self.batch}, {self.width}, n_samples), got {out.dtype} {out.shape}")
        L = (len(s_half) - 1) // 2
        n_new = self.emitted(L)
        s_half = np.ascontiguousarray(s_half, dtype=self.nd)
        args = (self.z, self.fz, self.kn, self.dl, self.sh, self.lev, self.ust, self.PhiT,
                self.p11, self.p12, self.p21, self.p22, self.diag, self.W, self.P0T, self.P1T,
                self.D, self.G, self.O, self.Of, self.Og, s_half, self.tol, out, self.outputs,
                self.taps, self.m, self.half, self.w0, self.ring, self.gi, self.bad)
        kernel = expo_chunk
        if self.per_state:
            kernel = expo_states_chunk
            args = (self.z, self.kset, self.dl, self.sh, self.lev, self.ust, self.kns,
                    self.levels,
                    self.sPhiT, self.sW, self.sc, self.sP1T, self.sGm, self.sM, self.se, self.D,
                    self.O, self.Of, self.Og, s_half, self.tol, out, self.outputs, self.taps,
                    self.m, self.half, self.w0, self.ring, self.gi, self.bad)
        if not self._compiled:
            compile_kernel(kernel, args, f"exponential kernel ({np.dtype(self.nd).name})")
            self._compiled = True
        kernel(0, self.batch, *args)
        self.gi += L
        self.outputs += n_new
        with np.errstate(invalid="ignore"):
            bad = self.bad | ~(np.abs(self.z) <= BLOWUP).all(1)
        if bad.any():
            self.alive &= ~bad
            self.lev[bad] = 0.0
            self.ust[bad] = 0.0
            self.z[bad] = 0.0
            self.fz[bad] = 0.0
        return out

    @property
    def diverged(self) -> np.ndarray:
        return ~self.alive

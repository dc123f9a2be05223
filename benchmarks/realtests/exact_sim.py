"""An exact piecewise-linear integrator of base-excited freeplay structures, independent of
freeplayid's simulator, for benchmark data ("real tests") that the package did not make.

    python benchmarks/realtests/exact_sim.py --check      # convergence + agreement table

Equation (relative coordinates y, absolute acceleration y'' + r a_g)::

    M y'' + C y' + K y + sum_j b_j f_j(b_j^T y) + sum_j c_j(s_j) b_j b_j^T y' = -p a_g(t)

with one freeplay law per hinge j, f_j(th) = kn (th - s_j delta_j), s_j = sign(th) outside
+-delta_j and f_j = 0 inside (every hinge has its own half-gap delta_j), an optional viscous
damper c_h across each hinge (always on) and optional extra damping c_c only while the hinge is
in contact. ``p`` is the load vector (M r for the data-set contract; the exact consistent-mass load
of a clamped beam otherwise), ``r`` the base influence of the outputs. a_g(t) is ANY base
acceleration: a function of time or an array sampled finely (level profiles, notches, ramps,
down-sweeps, log sweeps are all the same code).

Method (nothing is shared with freeplayid.simulate / replay / signal):

1. Regimes. The state z = (y, y') obeys z' = A_s z + c_s - e a_g(t) inside each contact regime
   s = (s_1, .., s_h), s_j in {-1, 0, +1}, with A_s, c_s from K + kn sum_{s_j != 0} b_j b_j^T,
   C + sum_j (c_h + c_c |s_j|) b_j b_j^T and the offsets kn s_j delta_j b_j; e = (0, M^-1 p).
   Inside one regime the system is linear and time-invariant.
2. Forcing. a_g is represented by a C2 cubic spline through samples at the knot rate (a
   function is sampled at the knots; an array must be at the knot rate / an integer). On each
   knot interval a_g is an exact cubic, so the solution over a sub-interval of length tau from
   offset s0 is, exactly,
       z(s0 + tau) = Phi(tau) z(s0) + P_c(tau) - sum_{i=0..3} i! beta_i P_i(tau),
   with beta_i the cubic's Taylor coefficients at s0 and Phi = e^{A tau},
   P_i = int_0^tau e^{A (tau - u)} e u^i / i! du, P_c = int_0^tau e^{A (tau - u)} c du, all read
   from ONE matrix exponential of the augmented (2n+5)x(2n+5) matrix (Van Loan), computed by
   scipy.linalg.expm for every regime and every dyadic length tau = h / 2^l, l = 0..L.
3. Switching. Each knot interval is walked in dyadic pieces (the largest piece its offset's
   alignment allows). A piece whose end state leaves the regime's region (|th_j| <= delta_j open,
   s_j th_j >= delta_j in contact) is halved and retried, down to h / 2^L (L = 26:
   ~1e-12 s at 16384 knots/s), where the switch is taken: the exact solution is evaluated at
   every trial point, so the switching instant th_j = +-delta_j is located by bisection on the
   exact solution to h / 2^L, and the new regime restarts from the exact state there. A
   crossing pair within one knot interval (a graze shorter than h) can be missed; halving h
   (--check) bounds that.
4. Outputs. The absolute velocity y' + r v_g (v_g = the exact integral of the spline) is taken
   at every knot; the 5-point central difference of it is the mean of the absolute acceleration
   over windows of 2h and 4h combined, (4/3) box_2h - (1/3) box_4h: an exact linear filter of
   the continuous signal, flat to (pi f h)^4 and zero at every multiple of knot_rate / 2, so
   the stiff knuckle modes cannot alias into the band. Then one zero-phase Kaiser FIR (120 dB
   from the output Nyquist frequency, pass band to 0.3 fs) decimates it to the sample rate
   (scipy.signal.resample_poly). Time 0 is the start of a_g; the structure is at rest before.

Default 64 knots per output sample (16384 knots/s at 256 Hz): from 32 to 64 knots the records
move by ~5e-4 of their peak (short grazes of the stiff knuckle modes missed at 32), from 64 to
128 by < 1e-5 (--check). Near a drop (the jump down of an up-sweep) the trajectory itself is
sensitive: tiny differences move the drop and its transient slightly, so the records differ
there briefly (up to ~3e-2 of the peak within ~1 s, the drop instant by < 0.1 ms) between any
two accurate integrations; --check reports that window apart.

What --check prints: (i) the records at knots/sample = 32 vs 64 vs 128 (and L = 26 vs 30); (ii) the
records of freeplayid.simulate.simulate_sweeps at one shared idealised case (default fin, modal
C of the model file, constant levels, linear up-sweep, 256 Hz) against these, by RMS difference
and by each run's first-harmonic peak amplitude and its frequency from a lock-in written here, and
on a short sweep the project's records at its default step and at half of it (the difference
that remains is the project's: it shrinks with its step); (iii) the exact SDOF backbone period
against the switching instants of a free vibration.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass

import numba
import numpy as np
import scipy.interpolate
import scipy.linalg
import scipy.signal

G0 = 9.80665  # [m/s^2] standard gravity (the data sets' g)
LEVELS = 26  # dyadic halvings of a knot interval when locating a switch


# --------------------------------------------------------------------------- the structure
@dataclass(frozen=True)
class Structure:
    """The true structure of a simulated test (SI units).

    M, K, C : (n, n) mass, stiffness without the freeplay springs, damping.
    B : (n, h) hinge vectors b_j (+1 outboard, -1 inboard).
    load : (n,) p of the right-hand side -p a_g.  influence : (n,) r of the outputs.
    kn : contact stiffness [N m/rad] (all hinges).  deltas : (h,) half-gaps [rad].
    hinge_damping, contact_damping : (h,) [N m s/rad] always on / only while in contact.
    """

    M: np.ndarray
    K: np.ndarray
    C: np.ndarray
    B: np.ndarray
    load: np.ndarray
    influence: np.ndarray
    dof_names: tuple
    kn: float
    deltas: tuple
    hinge_damping: tuple = ()
    contact_damping: tuple = ()

    @property
    def n(self) -> int:
        return self.M.shape[0]

    @property
    def h(self) -> int:
        return self.B.shape[1]

    def index(self, name: str) -> int:
        return list(self.dof_names).index(name)

    def with_(self, **kw) -> Structure:
        d = {k: getattr(self, k) for k in self.__dataclass_fields__}
        d.update(kw)
        return Structure(**d)


def structure_from_arrays(M, K, C, B, *, kn, deltas, dof_names, influence, load=None,
                          hinge_damping=0.0, contact_damping=0.0) -> Structure:
    M, K = np.asarray(M, float), np.asarray(K, float)
    C = np.zeros_like(M) if C is None else np.asarray(C, float)
    B = np.asarray(B, float).reshape(M.shape[0], -1)
    h = B.shape[1]
    r = np.asarray(influence, float)
    p = M @ r if load is None else np.asarray(load, float)
    deltas = tuple(np.broadcast_to(np.asarray(deltas, float), (h,)).tolist())
    hd = tuple(np.broadcast_to(np.asarray(hinge_damping, float), (h,)).tolist())
    cd = tuple(np.broadcast_to(np.asarray(contact_damping, float), (h,)).tolist())
    return Structure(M, K, C, B, p, r, tuple(dof_names), float(kn), deltas, hd, cd)


def regime_matrices(st: Structure, signs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, c, e) of z' = A z + c - e a_g in the contact regime ``signs`` (h values in -1, 0, 1)."""
    n = st.n
    Kr, Cr, f0 = st.K.copy(), st.C.copy(), np.zeros(n)
    for j, s in enumerate(signs):
        b = st.B[:, j]
        Cr += st.hinge_damping[j] * np.outer(b, b)
        if s != 0:
            Kr += st.kn * np.outer(b, b)
            Cr += st.contact_damping[j] * np.outer(b, b)
            f0 += st.kn * s * st.deltas[j] * b  # kn (th - s delta) b: the offset moves right
    Minv = np.linalg.inv(st.M)
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -Minv @ Kr
    A[n:, n:] = -Minv @ Cr
    c = np.r_[np.zeros(n), Minv @ f0]
    e = np.r_[np.zeros(n), Minv @ st.load]
    return A, c, e


def propagators(st: Structure, h: float, levels: int = LEVELS):
    """Phi, P_c, P_i of every regime and dyadic length h / 2^l (module docstring, step 2).

    Returns Phi (R, L+1, N, N), Pc (R, L+1, N), P (R, L+1, 4, N) with regime index
    R = sum_j (s_j + 1) 3^j.
    """
    N, nh = 2 * st.n, st.h
    R = 3 ** nh
    Phi = np.zeros((R, levels + 1, N, N))
    Pc = np.zeros((R, levels + 1, N))
    P = np.zeros((R, levels + 1, 4, N))
    for r in range(R):
        signs = [(r // 3 ** j) % 3 - 1 for j in range(nh)]
        A, c, e = regime_matrices(st, signs)
        aug = np.zeros((N + 5, N + 5))
        aug[:N, :N] = A
        aug[:N, N] = e  # z' = A z + e q0 + c qc;  q0' = q1, q1' = q2, q2' = q3
        aug[:N, N + 4] = c
        aug[N, N + 1] = aug[N + 1, N + 2] = aug[N + 2, N + 3] = 1.0
        for lev in range(levels + 1):
            E = scipy.linalg.expm(aug * (h / 2 ** lev))
            Phi[r, lev] = E[:N, :N]
            P[r, lev] = E[:N, N:N + 4].T
            Pc[r, lev] = E[:N, N + 4]
    return Phi, Pc, P


# --------------------------------------------------------------------------- the kernel
@numba.njit(cache=True)
def _piece(Phi, Pc, P, r, lev, z, coef, s0, out):
    """Exact state after a piece of length h/2^lev from offset s0 [s] in knot interval coef."""
    a0, a1, a2, a3 = coef[0], coef[1], coef[2], coef[3]
    b0 = a0 + s0 * (a1 + s0 * (a2 + s0 * a3))
    b1 = a1 + s0 * (2.0 * a2 + 3.0 * s0 * a3)
    b2 = a2 + 3.0 * s0 * a3
    b3 = a3
    N = z.shape[0]
    for i in range(N):
        acc = Pc[r, lev, i] - (b0 * P[r, lev, 0, i] + b1 * P[r, lev, 1, i]
                               + 2.0 * b2 * P[r, lev, 2, i] + 6.0 * b3 * P[r, lev, 3, i])
        for k in range(N):
            acc += Phi[r, lev, i, k] * z[k]
        out[i] = acc


@numba.njit(cache=True)
def _region_ok(z, signs, Bt, deltas):
    nh = signs.shape[0]
    for j in range(nh):
        th = 0.0
        for k in range(Bt.shape[1]):
            th += Bt[j, k] * z[k]
        s = signs[j]
        if s == 0:
            if th > deltas[j] or th < -deltas[j]:
                return False
        elif s * th < deltas[j]:
            return False
    return True


@numba.njit(cache=True)
def _walk(Phi, Pc, P, coefs, h, z0, Bt, deltas, out_idx, theta_out, ev_t, ev_j):
    """Integrate over every knot interval; return (velocities at knots, thetas, n_events).

    coefs (n_knots, 4): a_g's cubic on each knot interval.  out_idx: rows of z recorded.
    theta_out: bool, also record every hinge angle.  ev_t, ev_j: event log (time, hinge*3+kind)
    filled up to its length.
    """
    n_int = coefs.shape[0]
    L = Phi.shape[1] - 1
    full = np.int64(1) << L
    nh = Bt.shape[0]
    N = z0.shape[0]
    z = z0.copy()
    z1 = np.empty(N)
    signs = np.zeros(nh, np.int64)
    for j in range(nh):
        th = 0.0
        for k in range(Bt.shape[1]):
            th += Bt[j, k] * z[k]
        signs[j] = 1 if th > deltas[j] else (-1 if th < -deltas[j] else 0)
    rec = np.empty((out_idx.shape[0], n_int + 1))
    thr = np.empty((nh if theta_out else 0, n_int + 1))
    for i in range(out_idx.shape[0]):
        rec[i, 0] = z[out_idx[i]]
    n_ev = 0
    unit = h / full
    for kk in range(n_int):
        r = 0
        p3 = 1
        for j in range(nh):
            r += (signs[j] + 1) * p3
            p3 *= 3
        pos = np.int64(0)
        while pos < full:
            # largest piece the offset's alignment allows
            lev = 0
            if pos != 0:
                tz = 0
                q = pos
                while (q & 1) == 0:
                    q >>= 1
                    tz += 1
                lev = L - tz
            while True:
                _piece(Phi, Pc, P, r, lev, z, coefs[kk], pos * unit, z1)
                if _region_ok(z1, signs, Bt, deltas):
                    pos += np.int64(1) << (L - lev)
                    z[:] = z1
                    break
                if lev < L:
                    lev += 1
                    continue
                # finest piece: the switch lies inside it; restart in the new regime
                for j in range(nh):
                    thb = 0.0
                    tha = 0.0
                    for k in range(Bt.shape[1]):
                        thb += Bt[j, k] * z[k]
                        tha += Bt[j, k] * z1[k]
                    sn = 1 if tha > deltas[j] else (-1 if tha < -deltas[j] else 0)
                    if sn != signs[j]:
                        if n_ev < ev_t.shape[0]:
                            edge = deltas[j] if (tha + thb) > 0 else -deltas[j]
                            fr = 0.5 if tha == thb else (edge - thb) / (tha - thb)
                            ev_t[n_ev] = kk * h + (pos + min(max(fr, 0.0), 1.0)) * unit
                            ev_j[n_ev] = j * 3 + (sn + 1)
                        n_ev += 1
                        signs[j] = sn
                pos += 1
                z[:] = z1
                r = 0
                p3 = 1
                for j in range(nh):
                    r += (signs[j] + 1) * p3
                    p3 *= 3
                break
        for i in range(out_idx.shape[0]):
            rec[i, kk + 1] = z[out_idx[i]]
        if theta_out:
            for j in range(nh):
                th = 0.0
                for k in range(Bt.shape[1]):
                    th += Bt[j, k] * z[k]
                thr[j, kk + 1] = th
    if theta_out:
        for j in range(nh):
            th = 0.0
            for k in range(Bt.shape[1]):
                th += Bt[j, k] * z0[k]
            thr[j, 0] = th
    return rec, thr, n_ev


# --------------------------------------------------------------------------- forcing, outputs
def spline_pieces(samples: np.ndarray, rate: float, per_sample: int, n_knots: int):
    """Cubic coefficients (n_knots, 4) of a_g on each knot interval, and v_g at the knots.

    ``samples`` at ``rate`` [Hz] from t = 0; knots at ``rate * per_sample``. The C2 cubic spline
    through the samples (not-a-knot) is a_g; past the last sample it is extrapolated by its last
    piece (callers give a tail of samples past what they keep).
    """
    t = np.arange(samples.size) / rate
    cs = scipy.interpolate.CubicSpline(t, samples, bc_type="not-a-knot")
    c = cs.c  # (4, pieces): c0 dx^3 + c1 dx^2 + c2 dx + c3
    k = np.arange(n_knots)
    piece = np.minimum(k // per_sample, c.shape[1] - 1)
    s = (k - piece * per_sample) / (rate * per_sample)
    s = np.where(k // per_sample > c.shape[1] - 1, k / (rate * per_sample) - t[piece], s)
    d3, d2, d1, d0 = c[0, piece], c[1, piece], c[2, piece], c[3, piece]
    coefs = np.stack([d0 + s * (d1 + s * (d2 + s * d3)), d1 + s * (2 * d2 + 3 * s * d3),
                      d2 + 3 * s * d3, d3], axis=1)
    h = 1.0 / (rate * per_sample)
    integ = (coefs[:, 0] * h + coefs[:, 1] * h**2 / 2 + coefs[:, 2] * h**3 / 3
             + coefs[:, 3] * h**4 / 4)
    v_g = np.r_[0.0, np.cumsum(integ)]
    return coefs, v_g


def decimator(factor: int, fs_out: float) -> np.ndarray:
    """Zero-phase Kaiser low-pass for resample_poly(.., 1, factor): pass to 0.3 fs_out, 120 dB
    from 0.5 fs_out (the output Nyquist frequency); unit DC gain, odd length."""
    if factor == 1:
        return np.ones(1)
    width = 0.2 * fs_out / (0.5 * fs_out * factor)  # transition in units of the knot Nyquist
    numtaps, beta = scipy.signal.kaiserord(120.0, width)
    numtaps += 1 - numtaps % 2
    taps = scipy.signal.firwin(numtaps, 0.4 / factor * 2, window=("kaiser", beta))
    return taps / taps.sum()


def _acc_from_velocity(v: np.ndarray, h: float) -> np.ndarray:
    """5-point central derivative (module docstring, step 4); rest before t = 0, the last two
    knots repeat (they lie in the tail that is cut)."""
    pad = np.concatenate([np.zeros(v.shape[:-1] + (2,)), v,
                          np.repeat(v[..., -1:], 2, axis=-1)], axis=-1)
    return (-pad[..., 4:] + 8 * pad[..., 3:-1] - 8 * pad[..., 1:-3] + pad[..., :-4]) / (12 * h)


@dataclass(frozen=True)
class Record:
    """Simulated records at the output rate (absolute accelerations [m/s^2])."""

    time: np.ndarray  # (T,) [s]
    accel: np.ndarray  # (channel, T) [m/s^2], absolute
    base: np.ndarray  # (T,) [m/s^2], the base acceleration through the same filter
    channels: tuple
    n_events: int
    events: tuple = ()  # (times [s], codes hinge*3 + new sign + 1) if requested
    theta_knots: np.ndarray | None = None  # (h, knots) [rad] if requested
    knot_rate: float = 0.0
    wall_s: float = 0.0


def static_equilibrium(st: Structure, accel: float) -> np.ndarray:
    """The state z = (y, 0) at rest under a constant base acceleration ``accel`` [m/s^2]
    (K y + sum_j f_j(b_j^T y) b_j = -p accel), every hinge in contact on the side the load
    pushes it: the open structure is a mechanism at its hinges, so a load rests on the stops."""
    Kc, deltas = st.K + st.kn * st.B @ st.B.T, np.asarray(st.deltas, float)
    y = np.linalg.solve(Kc, -st.load * accel)
    s = np.sign(st.B.T @ y)
    y = np.linalg.solve(Kc, -st.load * accel + st.kn * st.B @ (s * deltas))
    th = st.B.T @ y
    if np.any(s * th < deltas):
        raise ValueError(f"a hinge rests inside its gap under {accel} m/s^2: rotations {th}")
    return np.r_[y, np.zeros(st.n)]


def simulate(st: Structure, a_g, *, duration: float, sample_rate: float, channels,
             knots_per_sample: int = 64, levels: int = LEVELS, z0=None, base_rate=None,
             log_events: int = 0, keep_theta: bool = False, tail_s: float | None = None,
             props=None, base_delay_knots: int = 0, static_accel: float = 0.0) -> Record:
    """Absolute accelerations of ``channels`` (DOF names) for base acceleration ``a_g``.

    a_g : callable t [s] -> [m/s^2] (sampled at the knots), or an array sampled at
        ``base_rate`` = knot rate / an integer, from t = 0 to at least duration + tail.
    duration : [s] of the kept record; the integration runs on for the decimator's tail.
    base_delay_knots : the base channel read this many knots late (< 0: early) against the
        responses, before the common decimation: a scanning acquisition's channel skew.
    static_accel : [m/s^2] a constant acceleration of the frame along the base axis added to
        a_g (gravity, on a shaker whose axis is vertical: +G0 when the outputs' +direction is
        up); the records leave it out, as AC-coupled accelerometers do. Give ``z0`` = the
        static equilibrium (:func:`static_equilibrium`) to start without its transient.
    """
    fs_k = sample_rate * knots_per_sample
    h = 1.0 / fs_k
    taps = decimator(knots_per_sample, sample_rate)
    tail = (len(taps) // 2 + 8) * h + 0.01 if tail_s is None else tail_s
    n_keep = int(math.floor(duration * sample_rate + 1e-9)) + 1
    n_knots = int(math.ceil((duration + tail) * fs_k))
    if callable(a_g):
        samples = np.asarray(a_g(np.arange(n_knots + 1) * h), float) + static_accel
        coefs, v_g = spline_pieces(samples, fs_k, 1, n_knots)
    else:
        per = int(round(fs_k / base_rate))
        if abs(per * base_rate - fs_k) > 1e-9 * fs_k:
            raise ValueError(f"knot rate {fs_k} Hz is not an integer multiple of {base_rate}")
        coefs, v_g = spline_pieces(np.asarray(a_g, float) + static_accel, base_rate, per,
                                   n_knots)
    Phi, Pc, P = propagators(st, h, levels) if props is None else props
    n = st.n
    idx = np.array([st.index(c) for c in channels])
    z_init = np.zeros(2 * n) if z0 is None else np.asarray(z0, float)
    ev_t, ev_j = np.zeros(max(log_events, 1)), np.zeros(max(log_events, 1), np.int64)
    t0 = time.perf_counter()
    vel, thr, n_ev = _walk(Phi, Pc, P, coefs, h, z_init, np.ascontiguousarray(st.B.T),
                           np.asarray(st.deltas, float), n + idx, keep_theta, ev_t, ev_j)
    wall = time.perf_counter() - t0
    if static_accel:  # the frame's constant acceleration is no record's (AC-coupled sensors)
        v_g = v_g - static_accel * np.arange(v_g.size) * h
    v_abs = vel + st.influence[idx, None] * v_g[None, :]
    acc = _acc_from_velocity(v_abs, h)
    base = _acc_from_velocity(v_g[None, :], h)
    if base_delay_knots:  # sample i of the late channel holds the base at knot i - m
        m = int(base_delay_knots)
        late = np.zeros_like(base)
        if m > 0:
            late[:, m:] = base[:, :-m]
        else:
            late[:, :m] = base[:, -m:]
        base = late
    dec = scipy.signal.resample_poly(np.vstack([acc, base]), 1, knots_per_sample, axis=1,
                                     window=taps, padtype="constant")[:, :n_keep]
    events = (ev_t[:min(n_ev, log_events)], ev_j[:min(n_ev, log_events)]) if log_events else ()
    return Record(time=np.arange(n_keep) / sample_rate, accel=dec[:-1], base=dec[-1],
                  channels=tuple(channels), n_events=int(n_ev), events=events,
                  theta_knots=thr if keep_theta else None, knot_rate=fs_k, wall_s=wall)


# --------------------------------------------------------------------------- sweeps
def sweep_phase(t, start_hz: float, stop_hz: float, *, rate_hz_per_s=None,
                octaves_per_min=None):
    """Phase [rad] of a linear (signed rate) or logarithmic sweep from phase 0 at t = 0."""
    t = np.asarray(t, float)
    sign = 1.0 if stop_hz > start_hz else -1.0
    if rate_hz_per_s is not None:
        return 2 * np.pi * (start_hz * t + 0.5 * sign * rate_hz_per_s * t * t)
    k = sign * octaves_per_min * math.log(2.0) / 60.0
    return 2 * np.pi * start_hz * np.expm1(k * t) / k


def sweep_frequency(t, start_hz, stop_hz, *, rate_hz_per_s=None, octaves_per_min=None):
    t = np.asarray(t, float)
    sign = 1.0 if stop_hz > start_hz else -1.0
    if rate_hz_per_s is not None:
        return start_hz + sign * rate_hz_per_s * t
    return start_hz * np.exp(sign * octaves_per_min * math.log(2.0) / 60.0 * t)


def sweep_duration(start_hz, stop_hz, *, rate_hz_per_s=None, octaves_per_min=None):
    if rate_hz_per_s is not None:
        return abs(stop_hz - start_hz) / rate_hz_per_s
    return abs(math.log2(stop_hz / start_hz)) * 60.0 / octaves_per_min


def lockin(x: np.ndarray, t: np.ndarray, phase: np.ndarray, window_s: float) -> np.ndarray:
    """First-harmonic amplitude of x against a known phase: 2 |moving mean of x e^{-i phase}|."""
    fs = 1.0 / (t[1] - t[0])
    n = max(1, int(round(window_s * fs)))
    prod = x * np.exp(-1j * phase)
    c = np.concatenate([[0.0], np.cumsum(prod)])
    mean = np.full(x.shape, np.nan, complex)
    half = n // 2
    mean[half:half + x.size - n + 1] = (c[n:] - c[:-n]) / n
    return 2 * np.abs(mean)


# --------------------------------------------------------------------------- --check
def _fin_structure(delta=0.003, kn=480.0):
    from freeplayid.model import default_fin

    fin = default_fin()
    return fin, structure_from_arrays(fin.M, fin.K, fin.C, fin.hinge_matrix(), kn=kn,
                                      deltas=delta, dof_names=fin.dof_names,
                                      influence=fin.base_influence)


def drop_time(x: np.ndarray, t: np.ndarray, phase: np.ndarray) -> float:
    """Instant [s] where the first-harmonic envelope (0.25 s lock-in) first falls below half of
    its maximum after the maximum (the drop of an up-sweep; linear interpolation between
    samples), NaN if it never does."""
    env = lockin(x, t, phase, 0.25)
    i = int(np.nanargmax(env))
    below = np.flatnonzero(env[i:] < 0.5 * env[i])
    if not below.size:
        return float("nan")
    k = i + below[0]
    e0, e1, half = env[k - 1], env[k], 0.5 * env[i]
    return float(t[k - 1] + (t[k] - t[k - 1]) * (e0 - half) / (e0 - e1))


def _compare(a: np.ndarray, b: np.ndarray, t: np.ndarray, t_drop: float) -> tuple:
    """(max |a-b| / peak away from the drop, same within it, RMS / peak overall); the drop's
    window is [-0.5, +1.5] s around it (the transient after the drop included)."""
    pk = np.max(np.abs(b))
    near = ((t - t_drop >= -0.5) & (t - t_drop <= 1.5) if np.isfinite(t_drop)
            else np.zeros(t.shape, bool))
    d = np.abs(a - b).max(axis=0) / pk
    far_max = float(d[~near].max())
    near_max = float(d[near].max()) if near.any() else 0.0
    return far_max, near_max, float(np.sqrt(np.mean((a - b) ** 2)) / pk)


def check(levels_g=(0.6, 1.0), rate=0.1) -> None:
    """The evidence table (module docstring)."""
    fin, st = _fin_structure()
    chans = ("uz_top_left", "uz_lower_right")
    f0, f1, fs = 30.0, 46.5, 256.0
    dur = sweep_duration(f0, f1, rate_hz_per_s=rate)

    def a_fn(level):
        return lambda t: level * G0 * np.sin(sweep_phase(t, f0, f1, rate_hz_per_s=rate))

    print("## exact_sim --check\n")
    print(f"default fin (12 DOF, 2 hinges), kn 480, delta 3 mrad, model C; sweep {f0:g} -> "
          f"{f1:g} Hz at {rate:g} Hz/s, {fs:g} Hz. Differences are max over both channels of "
          "|a - b| / record peak, away from the drop and within it (0.5 s before to 1.5 s "
          "after it: the drop and its transient); "
          "the drop instant is where the 0.25 s lock-in envelope of uz_top_left falls below "
          "half its maximum.\n")
    print("### (i) convergence (64 knots/sample and L = 26 is the default)\n")
    print("| level [g] | change | max away from drop | max within the drop window | "
          "drop instant shift [ms] | events | wall [s] |")
    print("|---|---|---|---|---|---|---|")
    ours = {}
    for lv in levels_g:
        runs = {key: simulate(st, a_fn(lv), duration=dur, sample_rate=fs, channels=chans,
                              knots_per_sample=key[0], levels=key[1])
                for key in ((32, 26), (64, 26), (128, 26), (64, 30))}
        t = runs[(64, 26)].time
        ph = sweep_phase(t, f0, f1, rate_hz_per_s=rate)
        td = {k: drop_time(r.accel[0], t, ph) for k, r in runs.items()}
        for a, b in (((32, 26), (64, 26)), ((64, 26), (128, 26)), ((64, 26), (64, 30))):
            far, near, _ = _compare(runs[a].accel, runs[b].accel, t, td[b])
            what = (f"{a[0]} -> {b[0]} knots/sample" if a[1] == b[1] else f"L {a[1]} -> {b[1]}")
            print(f"| {lv:g} | {what} | {far:.1e} | {near:.1e} | "
                  f"{1e3 * (td[a] - td[b]):+.3f} | {runs[a].n_events} / {runs[b].n_events} | "
                  f"{runs[a].wall_s:.1f} / {runs[b].wall_s:.1f} |")
        ours[lv] = runs[(64, 26)]
    print("\n### (ii) against freeplayid.simulate.simulate_sweeps (numba RK4, float64)\n")
    import torch

    from freeplayid.simulate import Sweep, simulate_sweeps

    t0 = time.perf_counter()
    res = simulate_sweeps(fin, kn=480.0, delta=0.003, level_g=list(levels_g),
                          sweep=Sweep(f0, f1, rate), channels=list(chans),
                          quantity="acceleration", frame="absolute", sample_rate=fs,
                          dtype=torch.float64, progress=False)
    wall = time.perf_counter() - t0
    print(f"(project simulator: {wall:.1f} s for {len(levels_g)} runs, dt {res.dt:.3g} s; "
          "first-harmonic amplitudes from a 1 s lock-in with the known sweep phase)\n")
    print("| level [g] | channel | RMS diff / peak | max away from drop | within drop | "
          "drop shift [ms] | peak amp ours [g] | theirs [g] | rel. diff | f at peak ours [Hz] | "
          "theirs [Hz] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for i, lv in enumerate(levels_g):
        a, b = ours[lv].accel, res.signals[i]
        n = min(a.shape[1], b.shape[1])
        a, b, tt = a[:, :n], b[:, :n], ours[lv].time[:n]
        ph = sweep_phase(tt, f0, f1, rate_hz_per_s=rate)
        fr = sweep_frequency(tt, f0, f1, rate_hz_per_s=rate)
        ta, tb = drop_time(a[0], tt, ph), drop_time(b[0], tt, ph)
        for c, name in enumerate(chans):
            far, near, rms = _compare(a[c:c + 1], b[c:c + 1], tt, tb)
            A1, A2 = lockin(a[c], tt, ph, 1.0), lockin(b[c], tt, ph, 1.0)
            i1, i2 = np.nanargmax(A1), np.nanargmax(A2)
            print(f"| {lv:g} | {name} | {rms:.1e} | {far:.1e} | {near:.1e} | "
                  f"{1e3 * (ta - tb):+.2f} | {A1[i1] / G0:.4f} | {A2[i2] / G0:.4f} | "
                  f"{A1[i1] / A2[i2] - 1:+.1e} | {fr[i1]:.3f} | {fr[i2]:.3f} |")
    check_their_step(fin, st, chans)
    print("\n### (iii) exact SDOF backbone (free vibration, k only in contact)\n")
    print("| A / delta | exact f/f_n | simulated f/f_n (switching instants) | rel. error |")
    print("|---|---|---|---|")
    m, k, d = 1.0, (2 * np.pi * 50.0) ** 2, 1e-3
    sd = structure_from_arrays([[m]], [[0.0]], None, [[1.0]], kn=k, deltas=d,
                               dof_names=("x",), influence=[0.0])
    wn = math.sqrt(k / m)
    for ratio in (1.2, 1.5, 2.0, 3.0):
        A = ratio * d
        rec = simulate(sd, lambda t: 0.0 * t, duration=0.5, sample_rate=1000.0, channels=("x",),
                       knots_per_sample=16, z0=[A, 0.0], log_events=2000)
        tev, code = rec.events
        ent = tev[code == 2]  # entries into +contact (hinge 0, new sign +1 -> code 2)
        period = np.mean(np.diff(ent))
        exact = 1.0 / (1.0 + 2 * d / (math.pi * (A - d)))
        sim = (2 * np.pi / period) / wn
        print(f"| {ratio:g} | {exact:.9f} | {sim:.9f} | {sim / exact - 1:+.1e} |")


def check_their_step(fin, st, chans, level=0.8, rate=0.5) -> None:
    """Is the remaining difference the project's? Halve its step on a short sweep."""
    import torch

    from freeplayid.simulate import Sweep, simulate_sweeps

    f0, f1, fs = 30.0, 46.5, 256.0
    dur = sweep_duration(f0, f1, rate_hz_per_s=rate)
    ours = simulate(st, lambda t: level * G0 * np.sin(sweep_phase(t, f0, f1, rate_hz_per_s=rate)),
                    duration=dur, sample_rate=fs, channels=chans)
    t = ours.time
    td = drop_time(ours.accel[0], t, sweep_phase(t, f0, f1, rate_hz_per_s=rate))
    print(f"\n{level:g} g, {f0:g} -> {f1:g} Hz at {rate:g} Hz/s: the project's records against "
          "ours at its default step and at half of it\n")
    print("| project dt [s] | max away from drop | within drop | RMS / peak |")
    print("|---|---|---|---|")
    spm = None
    for halve in (False, True):
        kw = {"steps_per_sample": 2 * spm} if halve else {}
        res = simulate_sweeps(fin, kn=480.0, delta=0.003, level_g=[level],
                              sweep=Sweep(f0, f1, rate), channels=list(chans),
                              sample_rate=fs, dtype=torch.float64, progress=False, **kw)
        spm = round(1.0 / (res.dt * fs))
        b = res.signals[0]
        n = min(b.shape[1], t.size)
        far, near, rms = _compare(ours.accel[:, :n], b[:, :n], t[:n], td)
        print(f"| {res.dt:.3g} | {far:.1e} | {near:.1e} | {rms:.1e} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="print the evidence table")
    args = ap.parse_args()
    if args.check:
        check()
    else:
        ap.print_help()


if __name__ == "__main__":
    main()

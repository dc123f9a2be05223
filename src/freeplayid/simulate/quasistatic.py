"""Quasi-static condensation of the fast open-hinge modes (singular perturbation).

The open-hinge modal form (ETA) is split into slow modes (lam <= (2 pi f_qs)^2) and fast ones.
The fast modes are treated as massless, so they follow their load algebraically; of their
damping only the force of the slow velocities, C_fs eta_s', is kept::

    lam_f eta_f + D_f f(theta) + C_fs eta_s' = g_f a(t),   theta = D_s^T eta_s + D_f^T eta_f
    => eta_f = lam_f^-1 (g_f a - D_f f(theta) - C_fs eta_s'),  theta + F f(theta) = c       (QS)
       F = D_f^T lam_f^-1 D_f  (h x h, symmetric positive semi-definite)
       c = D_s^T eta_s + e a - Gam eta_s',  e = D_f^T lam_f^-1 g_f,  Gam = D_f^T lam_f^-1 C_fs
       a = level * sin(phase)

Why C_fs: with dense modal damping the resonance's damping is partly carried by its quasi-static
fast part; dropping every slow-fast damping term errs by 0.3-1 % in the resonance amplitude of
the default fin (linear frequency response, thresholds 1.5 kHz-600 Hz), keeping C_fs eta_s' by
1.3e-5-1.4e-4 (keeping C_sf too, without its C_ff, would double count: +0.3-1 %).

f is monotone piecewise linear, ``f_j = kn (theta_j - clamp(theta_j, -delta, delta))``, so
theta -> theta + F f(theta) is a monotone (strongly: its slope I + kn F P has positive leading
minors) piecewise-affine map and (QS) has one solution. In a contact state s in {-1, 0, +1}^h,
``f_j = kn |s_j| (theta_j - s_j delta)`` is affine and (QS) is the linear system

    (I + kn F P) theta = c + kn F P s delta,    P = diag(|s|)

(its leading principal minors are det(I + kn F_kk P_k) >= 1, so elimination without pivoting is
safe). The solve is an active-set (semismooth Newton) iteration from the previous state, with an
exhaustive search over the 3^h states as the fallback. Only the slow subsystem is integrated::

    eta_s'' = g_s a - lam_s eta_s - C_ss eta_s' - D_s f(theta(eta_s, t))

Neglected: the fast modes' inertia (error O((omega/omega_f)^2) in the band, the
mode-acceleration argument), their own damping C_ff eta_f' and the coupling C_sf eta_f' of the
slow equations. Outputs: the fast part of a displacement channel is ``S_f eta_f`` as above
(base-load part through the residual-flexibility gain, hinge part ``hinge_out @ f``, damping part
``vel_out @ eta_s'``); for velocity and acceleration the base-load part is exact (derivatives of
sin phase) and the rest, ``q = hinge_out @ f + vel_out @ eta_s'``, is decimated through the
derivative taps of the same FIR (``resample.derivative_taps``: 5-point stencil at the step rate,
relative error (omega h)^4 / 30 or / 90, 6e-8 at 40 Hz and h = 244 us) into the same outputs.

The RK4 step of the slow subsystem is bounded by the Jacobians of every contact state, with the
condensed hinge stiffness and damping ``Q = kn P (I + kn F P)^-1``,
``K_s = lam_s + D_s Q D_s^T``, ``C_s = C_ss - D_s Q Gam``.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from .formulation import ModalForm

__all__ = ["QuasiStaticForm", "QuasiStatic", "condense_modal_form", "solve_hinge_states"]


@dataclass(frozen=True)
class QuasiStatic:
    """What the quasi-static condensation did (reported in ``SweepResult.quasi_static``).

    Attributes
    ----------
    threshold_hz : float [Hz]
        Open-hinge modes above this frequency are quasi-static.
    slow, total : int
        Modes integrated / in the full model.
    fast_hz : tuple of float [Hz]
        Frequencies of the condensed modes.
    damping_coupling : float [-]
        max |C_sf| / max |C_ss| of the modal damping: the neglected slow-fast damping coupling.
    """

    threshold_hz: float
    slow: int
    total: int
    fast_hz: tuple[float, ...]
    damping_coupling: float


@dataclass(frozen=True)
class QuasiStaticForm:
    """Slow subsystem plus the algebraic hinge equation (QS).

    Attributes
    ----------
    slow : ModalForm
        (ETA) of the slow modes: ``lam``, ``Cm`` (= C_ss), ``D`` (= D_s), ``g``, ``S`` (= S_s),
        ``static_coef`` (fast base-load output gain per g), ``omega_max`` of the condensed
        Jacobians.
    F : ndarray, shape (h, h) [rad per N m]
        Fast-mode flexibility seen by the hinges.
    e : ndarray, shape (h,) [rad per g]
        Quasi-static hinge rotation of the fast modes per unit level.
    Gam : ndarray, shape (h, N_s) [rad s per modal unit]
        Hinge rotation of the fast modes per slow velocity (their damping load).
    hinge_out : ndarray, shape (C, h)
        Displacement output of the fast modes per hinge moment, ``-S_f lam_f^-1 D_f`` (for
        velocity and acceleration the kernel decimates its derivative through derivative taps).
    vel_out : ndarray, shape (C, N_s)
        Displacement output of the fast modes per slow velocity, ``-S_f lam_f^-1 C_fs``.
    info : QuasiStatic
    """

    slow: ModalForm
    F: np.ndarray
    e: np.ndarray
    Gam: np.ndarray
    hinge_out: np.ndarray
    vel_out: np.ndarray
    info: QuasiStatic


def _condensed_omega_max(lam, Cm, D, F, Gam, kn_max):
    N, h = D.shape
    best = 0.0
    for p in itertools.product((0.0, 1.0), repeat=h):
        P = np.diag(p)
        Q = kn_max * P @ np.linalg.inv(np.eye(h) + kn_max * F @ P)
        Ks = np.diag(lam) + D @ (0.5 * (Q + Q.T)) @ D.T
        J = np.block([[np.zeros((N, N)), np.eye(N)], [-Ks, -(Cm - D @ Q @ Gam)]])
        best = max(best, float(np.max(np.abs(np.linalg.eigvals(J)))))
    return best


def condense_modal_form(form: ModalForm, *, threshold_hz: float, quantity: str,
                        kn_max: float) -> QuasiStaticForm:
    """Split ``form`` (full open-hinge modal form) at ``threshold_hz`` and condense the fast modes.

    Parameters
    ----------
    form : ModalForm
        Untruncated relative-form (ETA).
    threshold_hz : float [Hz], > 0
    quantity : {"displacement", "velocity", "acceleration"}
        Recorded quantity (the hinge part of the fast output is kept for displacement only).
    kn_max : float [N m/rad]
        Largest contact stiffness of the batch (step bound).
    """
    if not threshold_hz > 0:
        raise ValueError(f"`quasi_static_hz` must be > 0 or None, got {threshold_hz!r}")
    wq2 = (2 * np.pi * threshold_hz) ** 2
    slow = form.lam <= wq2
    fast = ~slow
    if not np.any(slow):
        raise ValueError(f"`quasi_static_hz`={threshold_hz!r} leaves no slow mode")
    lam_f = form.lam[fast]
    Df = form.D[fast]
    F = Df.T @ (Df / lam_f[:, None])
    F = 0.5 * (F + F.T)
    e = Df.T @ (form.g[fast] / lam_f)
    Sf = form.S[:, fast]
    hinge_out = -Sf @ (Df / lam_f[:, None])
    Cfs = form.Cm[np.ix_(fast, slow)]
    Gam = Df.T @ (Cfs / lam_f[:, None])
    vel_out = -Sf @ (Cfs / lam_f[:, None])
    static_coef = form.static_coef + Sf @ (form.g[fast] / lam_f)
    Css = form.Cm[np.ix_(slow, slow)]
    Csf = form.Cm[np.ix_(slow, fast)]
    coupling = float(np.max(np.abs(Csf), initial=0.0) / max(np.max(np.abs(Css)), 1e-300))
    Ds = form.D[slow]
    omega = _condensed_omega_max(form.lam[slow], Css, Ds, F, Gam, kn_max)
    off = Css - np.diag(np.diag(Css))
    c_diagonal = bool(np.max(np.abs(off)) <= 1e-10 * max(float(np.max(np.abs(Css))), 1e-300))
    slow_form = ModalForm(
        lam=form.lam[slow], Cm=Css, c_diagonal=c_diagonal, D=Ds, g=form.g[slow],
        S=form.S[:, slow], base_coef=form.base_coef, static_coef=static_coef,
        x0_per_ub=form.x0_per_ub[slow], v0_per_vb=form.v0_per_vb[slow], omega_max=omega,
        truncation=None,
    )
    info = QuasiStatic(
        threshold_hz=float(threshold_hz), slow=int(slow.sum()), total=form.n_modes,
        fast_hz=tuple(float(x) for x in np.sqrt(lam_f) / (2 * np.pi)),
        damping_coupling=coupling,
    )
    return QuasiStaticForm(slow=slow_form, F=F, e=e, Gam=Gam, hinge_out=hinge_out,
                           vel_out=vel_out, info=info)


def _solve_state(F, c, kn, delta, s):
    """theta of (QS) in contact state s (the affine piece), by (I + kn F P) theta = rhs."""
    p = np.abs(s).astype(float)
    A = np.eye(len(c)) + kn * F * p[None, :]
    return np.linalg.solve(A, c + kn * F @ (p * s * delta))


def _consistent(theta, s, delta, tol):
    lo = np.where(s > 0, delta - tol, np.where(s < 0, -np.inf, -delta - tol))
    hi = np.where(s < 0, -delta + tol, np.where(s > 0, np.inf, delta + tol))
    return bool(np.all((theta >= lo) & (theta <= hi)))


def solve_hinge_states(F, c, kn, delta, *, state=None, exhaustive=False):
    """Solve ``theta + F f(theta) = c`` exactly (reference implementation of the kernel's solve).

    Parameters
    ----------
    F : ndarray, shape (h, h)
        Symmetric positive semi-definite flexibility.
    c : ndarray, shape (h,)
    kn, delta : float [N m/rad], [rad]
    state : ndarray of int, shape (h,), optional
        Starting contact state (-1, 0, +1 per hinge); default all open.
    exhaustive : bool
        Try all 3^h states instead of the active-set iteration.

    Returns
    -------
    theta : ndarray, shape (h,)
    state : ndarray of int, shape (h,)
        The contact state of the solution.
    """
    F, c = np.asarray(F, dtype=float), np.asarray(c, dtype=float)
    h = len(c)
    tol = 1e-12 * (delta + np.abs(c).max() + 1e-300)
    if not exhaustive:
        s = np.zeros(h, dtype=int) if state is None else np.asarray(state, dtype=int).copy()
        for _ in range(h + 3):
            th = _solve_state(F, c, kn, delta, s)
            if _consistent(th, s, delta, tol):
                return th, s
            s = np.where(th > delta, 1, np.where(th < -delta, -1, 0))
    for s in itertools.product((-1, 0, 1), repeat=h):
        s = np.array(s)
        th = _solve_state(F, c, kn, delta, s)
        if _consistent(th, s, delta, tol):
            return th, s
    raise AssertionError("no consistent contact state: F is not positive semi-definite?")

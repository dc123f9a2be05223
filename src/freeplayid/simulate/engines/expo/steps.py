"""Exponential integrator of the modal equations (ETA): the step matrices and the step rule.

State ``z = (eta, eta')`` in R^{2N}; (ETA) is ``z' = A z + b_g u(t) - b_f f(theta)`` with::

    A = [[0, I], [-diag(lam), -Cm]],   b_g = [0; g],   b_f = [0; D],   theta = D^T eta,

``u = level * sin(phase(t))`` and f the freeplay moments. Over one step ``[t_k, t_k + h]`` the
base term is replaced by the quadratic through u at ``t_k, t_k + h/2, t_k + h`` (Lagrange basis
``L0 = (1 - x)(1 - 2x)``, ``Lm = 4x(1 - x)``, ``L1 = x(2x - 1)`` of ``x = tau / h``) and the
contact moment by the straight line through ``f_k`` and ``f_{k+1}``; both are integrated exactly
against ``exp(A (h - tau))``. With ``Psi_k = h int_0^1 exp(h A (1 - x)) x^k dx``::

    z_{k+1} = Phi z_k + level (W0 s_k + Wm s_{k+1/2} + W1 s_{k+1}) - P0 f_k - P1 f_{k+1}
    Phi = exp(A h),  W0 = (Psi0 - 3 Psi1 + 2 Psi2) b_g,  Wm = 4 (Psi1 - Psi2) b_g,
    W1 = (2 Psi2 - Psi1) b_g,  P0 = (Psi0 - Psi1) b_f,  P1 = Psi1 b_f.

``Psi_k b`` are blocks of one matrix exponential (Van Loan 1978): the exponential of
``[[A h, B h, 0, 0], [0, 0, I, 0], [0, 0, 0, I], [0, 0, 0, 0]]`` (B = [b_g, -b_f]) holds
``Psi0 B``, ``Psi1 B`` and ``Psi2 B / 2`` in its first block row (the chain integrates 1, x,
x^2/2). Everything is float64.

The contact is implicit: ``theta_{k+1} = a - Gamma f(theta_{k+1})`` with ``a`` the hinge
rotations of everything else and ``Gamma = D^T (P1)_eta`` (h x h, ~ h^2/6 D^T D for a short
step). f is piecewise linear, so in each contact state (-1, 0, +1 per hinge) this is a linear
h x h system: the kernel solves it exactly, whatever kn. The linear part is exact at any step
(no stability bound: overdamped or stiff modes cost nothing), so the step is set by accuracy:
the quadratic base load, the linear contact moment and the contact switches inside a step.

With one kn per batch (or a few), the kernel uses the exact step of each contact state instead
(:func:`discretize_states`, block comment there): the contact stiffness inside A, the linear
hold only on the sub-step holding a switch.

Step rule (:func:`expo_step_limit`, measured in docs/simulate.md, "Exponential engine"): at least
``STEPS_PER_SWEEP_PERIOD`` steps per period of the sweep's top frequency; a switch is located to
``1 / SWITCH_STEPS_PER_RINGING_PERIOD`` of the period of the fastest mode that rings with the
hinges closed (:func:`ringing_hz`, :func:`switch_levels`). The engine records the displacement
and takes velocity and acceleration as its derivative inside the decimating FIR
(``resample.derivative_taps``): the 4-9 kHz knuckle ringing after each switch is then a small
displacement, which the point samples at the step rate do not alias into the band (an
acceleration point-sampled at that step would, and needed ``STEPS_PER_RINGING_PERIOD`` steps per
ringing period, four times as many on the default fin). The linear-hold scheme (more distinct kn
than :data:`MAX_STATE_SETS`) holds the contact moment linear over a whole step, so its step
keeps that ringing rule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ...formulation import ModalForm

__all__ = ["ExpoStep", "StateSteps", "discretize", "discretize_states", "expo_step_limit",
           "MAX_STATE_SETS", "per_state_scheme",
           "switch_levels", "ringing_hz", "closed_hinge_hz", "contact_states", "state_code",
           "STEPS_PER_SWEEP_PERIOD", "STEPS_PER_RINGING_PERIOD",
           "SWITCH_STEPS_PER_RINGING_PERIOD"]

# per-state propagation for batches with at most this many distinct kn (one matrix set per kn,
# 3^H states x (levels + 1) sub-steps each); more distinct kn: the linear-hold scheme
MAX_STATE_SETS = 8
STEPS_PER_SWEEP_PERIOD = 100  # steps per period of the sweep's top frequency
# the linear-hold scheme's steps per period of the fastest ringing mode
STEPS_PER_RINGING_PERIOD = 2.0
SWITCH_STEPS_PER_RINGING_PERIOD = 400.0  # switch sub-steps per period of that mode


@dataclass(frozen=True)
class ExpoStep:
    """The matrices of one exponential step of length ``h`` (float64).

    Attributes
    ----------
    h : float [s]
    Phi : ndarray, shape (2N, 2N)
        ``exp(A h)``.
    W : ndarray, shape (3, 2N)
        Base-load vectors per unit level (W0, Wm, W1: weights of sin(phase) at t, t + h/2, t + h).
    P0, P1 : ndarray, shape (2N, H)
        Contact-moment input of f(theta_k) and f(theta_{k+1}) (subtracted).
    Gamma : ndarray, shape (H, H)
        ``D^T (P1)_eta``: hinge rotations at t + h per unit f(theta_{k+1}) (subtracted).
    """

    h: float
    Phi: np.ndarray
    W: np.ndarray
    P0: np.ndarray
    P1: np.ndarray
    Gamma: np.ndarray


def state_matrix(form: ModalForm) -> np.ndarray:
    """A = [[0, I], [-diag(lam), -Cm]], shape (2N, 2N)."""
    N = form.n_modes
    return np.block([[np.zeros((N, N)), np.eye(N)], [-np.diag(form.lam), -form.Cm]])


def discretize(form: ModalForm, h: float) -> ExpoStep:
    """The step matrices of (module docstring) for ``form`` and step ``h`` [s], float64."""
    if not (math.isfinite(h) and h > 0):
        raise ValueError(f"`h` must be > 0, got {h!r}")
    N, H = form.D.shape
    n2, p = 2 * N, 1 + H
    B = np.zeros((n2, p))
    B[N:, 0] = form.g
    B[N:, 1:] = -form.D
    E = np.zeros((n2 + 3 * p, n2 + 3 * p))
    E[:n2, :n2] = state_matrix(form) * h
    E[:n2, n2:n2 + p] = B * h
    E[n2:n2 + p, n2 + p:n2 + 2 * p] = np.eye(p)
    E[n2 + p:n2 + 2 * p, n2 + 2 * p:] = np.eye(p)
    X = scipy.linalg.expm(E)
    Phi = X[:n2, :n2]
    psi0 = X[:n2, n2:n2 + p]
    psi1 = X[:n2, n2 + p:n2 + 2 * p]
    psi2 = 2.0 * X[:n2, n2 + 2 * p:]
    W = np.stack([psi0[:, 0] - 3 * psi1[:, 0] + 2 * psi2[:, 0],
                  4 * (psi1[:, 0] - psi2[:, 0]),
                  2 * psi2[:, 0] - psi1[:, 0]])
    # B's contact columns are -b_f: P = -(Psi B)
    P0 = -(psi0[:, 1:] - psi1[:, 1:])
    P1 = -psi1[:, 1:]
    Gamma = form.D.T @ P1[:N]
    return ExpoStep(h=float(h), Phi=Phi, W=W, P0=P0, P1=P1, Gamma=Gamma)


def closed_hinge_hz(form: ModalForm, kn: float) -> np.ndarray:
    """Undamped natural frequencies [Hz] with every hinge closed at ``kn``, ascending."""
    K = np.diag(form.lam) + kn * form.D @ form.D.T
    w2 = np.clip(np.linalg.eigvalsh(0.5 * (K + K.T)), 0.0, None)
    return np.sqrt(w2) / (2 * np.pi)


def ringing_hz(form: ModalForm, kn: float) -> float:
    """Fastest damped natural frequency [Hz] with every hinge closed at ``kn`` (max |Im| of the
    eigenvalues of A_s): the fastest mode that rings after a contact switch (an overdamped mode
    does not)."""
    N = form.n_modes
    A = state_matrix(form)
    A[N:, :N] -= kn * form.D @ form.D.T
    return float(np.abs(np.linalg.eigvals(A).imag).max(initial=0.0) / (2 * np.pi))


def per_state_scheme(distinct_kn: int) -> bool:
    """Whether a batch with ``distinct_kn`` distinct contact stiffnesses takes the exact
    per-state scheme (else the linear-hold one): the kernel's choice and the step rule's."""
    return distinct_kn <= MAX_STATE_SETS


def expo_step_limit(form: ModalForm, *, top_hz: float, kn_max: float,
                    per_state: bool = False) -> float:
    """Largest step [s] of the exponential engine by the accuracy rule (module docstring).

    Parameters
    ----------
    form : ModalForm
    top_hz : float [Hz]
        The sweep's top frequency.
    kn_max : float [N m/rad]
        The batch's largest contact stiffness.
    per_state : bool
        The batch takes the exact per-state scheme (at most :data:`MAX_STATE_SETS` distinct
        kn): the sweep's rule alone (its switches are located by halving, its record is the
        displacement's, differentiated by the decimating FIR). Else the linear-hold scheme,
        whose contact moment is held linear over a step: also the ringing rule.
    """
    if not (math.isfinite(top_hz) and top_hz > 0):
        raise ValueError(f"`top_hz` must be > 0, got {top_hz!r}")
    h = 1.0 / (STEPS_PER_SWEEP_PERIOD * top_hz)
    if per_state:
        return h
    f_ring = ringing_hz(form, kn_max)
    if f_ring > 0:
        h = min(h, 1.0 / (STEPS_PER_RINGING_PERIOD * f_ring))
    return h


# ----------------------------------------------------------------------------- per contact state
#
# Exact propagation per contact state. With the hinges in state s in {-1, 0, +1}^H (hinge j open
# if |theta_j| <= delta, else closed on the side s_j), f_j = kn |s_j| (theta_j - s_j delta) is
# linear, so (ETA) is linear:
#
#     z' = A_s z + b_g u(t) + delta kn [0; D s],   A_s = A - [[0, 0], [kn D P_s D^T, 0]],
#
# P_s = diag|s_j| (|s_j| s_j = s_j). Over a step h in state s, with the quadratic base load:
#
#     z_{k+1} = Phi_s z_k + level (W0_s s_k + Wm_s s_{k+1/2} + W1_s s_{k+1}) + delta c_s,
#     Phi_s = exp(A_s h),  c_s = Psi0_s kn [0; D s],
#
# exact whatever kn and the knuckle modes (W as in the module docstring, with A_s). A step whose
# end state differs from its start state (a hinge opened or closed inside it) is halved until
# the switch lies in a sub-step of length h / 2^levels; on that sub-step the state-s step is
# corrected by the residual contact moment r = f(theta) - f_s(theta) (zero at the start, f_s the
# state's linear law) held linear in time: z_end = z_s - P1_s r_end, P1_s = Psi1_s [0; D], and
# theta_end = a - Gamma_s r_end (a the state-s prediction, Gamma_s = D^T (P1_s)_eta). With
# r = f - kn P_s (theta - s delta):
#
#     (I - kn Gamma_s P_s) theta + Gamma_s f(theta) = a - delta kn Gamma_s s,
#
# i.e. with M_s = (I - kn Gamma_s P_s)^{-1}: theta + (M_s Gamma_s) f(theta) = M_s a - delta e_s,
# e_s = kn M_s Gamma_s s, the contact equation of the linear-hold scheme, solved exactly.
#
# Unequal gaps: hinge j's half-gap delta_j = delta r_j (r the gap shares, common to a batch).
# delta s becomes delta (s * r) in the contact moment, so c_s and e_s take s * r in place of s
# (still per unit delta) and the hinge states and moments compare theta_j with delta r_j.


def state_code(s) -> int:
    """Index of the contact state ``s`` (sequence of -1/0/+1 per hinge): sum (s_j + 1) 3^j."""
    return int(sum((int(sj) + 1) * 3**j for j, sj in enumerate(s)))


def contact_states(H: int) -> np.ndarray:
    """All 3^H contact states, shape (3^H, H), row ``state_code(s)`` holding s."""
    S = 3**H
    out = np.empty((S, H))
    for code in range(S):
        q = code
        for j in range(H):
            out[code, j] = q % 3 - 1
            q //= 3
    return out


@dataclass(frozen=True)
class StateSteps:
    """Exact step matrices per contact state for one kn (float64); see the block comment above.

    Attributes
    ----------
    kn : float [N m/rad]
    h : float [s]
        The step; level l holds the sub-step ``h / 2^l``.
    levels : int
        Halvings to locate a switch (the finest sub-step is ``h / 2^levels``).
    states : ndarray, shape (S, H)
        The contact states, ``S = 3^H``, row = :func:`state_code`.
    Phi : ndarray, shape (levels + 1, S, 2N, 2N)
    W : ndarray, shape (levels + 1, S, 3, 2N)
        Base-load vectors per unit level.
    c : ndarray, shape (levels + 1, S, 2N)
        Response to the state's constant contact moment per unit delta [1/rad].
    P1 : ndarray, shape (S, 2N, H)
        Finest sub-step: input of the residual moment at its end (subtracted).
    Gm : ndarray, shape (S, H, H)
        ``M_s Gamma_s``.
    M : ndarray, shape (S, H, H)
    e : ndarray, shape (S, H)
        ``kn M_s Gamma_s s`` [N m/rad].
    """

    kn: float
    h: float
    levels: int
    states: np.ndarray
    Phi: np.ndarray
    W: np.ndarray
    c: np.ndarray
    P1: np.ndarray
    Gm: np.ndarray
    M: np.ndarray
    e: np.ndarray


def discretize_states(form: ModalForm, h: float, kn: float, *, levels: int = 0,
                      gap_shares=None, contact_damping=None) -> StateSteps:
    """The per-state step matrices (block comment above) for ``form``, step ``h`` [s], contact
    stiffness ``kn`` [N m/rad] and ``levels`` halvings, by Van Loan exponentials in float64.
    ``gap_shares`` (H,): hinge j's half-gap is ``delta * gap_shares[j]`` (default: all 1, one
    common gap); folded into ``c`` and ``e``, which are then per unit delta of the hinges'
    common scale (``kn D (s * shares)`` in place of ``kn D s``; with shares of 1 the same bits).
    ``contact_damping`` (H,) [N m s/rad]: a damper across hinge j acting only in contact, inside
    each state's A as its stiffness is (``-D diag(c |s|) D^T`` in the velocity block; default
    none). Within the finest sub-step that holds a switch it acts in the state of the sub-step's
    start (the residual held linear is the spring's moment only): an error of the order of that
    sub-step's share of the contact."""
    if not (math.isfinite(h) and h > 0):
        raise ValueError(f"`h` must be > 0, got {h!r}")
    if not (math.isfinite(kn) and kn >= 0):
        raise ValueError(f"`kn` must be >= 0, got {kn!r}")
    if not (isinstance(levels, (int, np.integer)) and levels >= 0):
        raise ValueError(f"`levels` must be an int >= 0, got {levels!r}")
    N, H = form.D.shape
    shares = np.ones(H) if gap_shares is None else np.asarray(gap_shares, float).reshape(H)
    damper = np.zeros(H) if contact_damping is None else \
        np.asarray(contact_damping, float).reshape(H)
    n2, p = 2 * N, 2 + H
    states = contact_states(H)
    S = len(states)
    A = state_matrix(form)
    Phi = np.empty((levels + 1, S, n2, n2))
    W = np.empty((levels + 1, S, 3, n2))
    c = np.empty((levels + 1, S, n2))
    P1 = np.empty((S, n2, H))
    Gm = np.empty((S, H, H))
    M = np.empty((S, H, H))
    e = np.empty((S, H))
    for k, s in enumerate(states):
        Ps = np.diag(np.abs(s))
        As = A.copy()
        As[N:, :N] -= kn * form.D @ Ps @ form.D.T
        As[N:, N:] -= form.D @ (Ps * damper) @ form.D.T
        B = np.zeros((n2, p))
        B[N:, 0] = form.g
        B[N:, 1] = kn * form.D @ (s * shares)
        B[N:, 2:] = -form.D
        for lv in range(levels + 1):
            hl = h / 2**lv
            E = np.zeros((n2 + 3 * p, n2 + 3 * p))
            E[:n2, :n2] = As * hl
            E[:n2, n2:n2 + p] = B * hl
            E[n2:n2 + p, n2 + p:n2 + 2 * p] = np.eye(p)
            E[n2 + p:n2 + 2 * p, n2 + 2 * p:] = np.eye(p)
            X = scipy.linalg.expm(E)
            psi0 = X[:n2, n2:n2 + p]
            psi1 = X[:n2, n2 + p:n2 + 2 * p]
            psi2 = 2.0 * X[:n2, n2 + 2 * p:]
            Phi[lv, k] = X[:n2, :n2]
            W[lv, k] = np.stack([psi0[:, 0] - 3 * psi1[:, 0] + 2 * psi2[:, 0],
                                 4 * (psi1[:, 0] - psi2[:, 0]),
                                 2 * psi2[:, 0] - psi1[:, 0]])
            c[lv, k] = psi0[:, 1]
            if lv == levels:
                P1[k] = -psi1[:, 2:]
        Gamma = form.D.T @ P1[k, :N]
        M[k] = np.linalg.inv(np.eye(H) - kn * Gamma @ Ps)
        Gm[k] = M[k] @ Gamma
        e[k] = kn * Gm[k] @ (s * shares)
    return StateSteps(kn=float(kn), h=float(h), levels=int(levels), states=states, Phi=Phi, W=W,
                      c=c, P1=P1, Gm=Gm, M=M, e=e)


def switch_levels(form: ModalForm, h: float, kn: float) -> int:
    """Halvings of the step ``h`` [s] that locate a contact switch to within
    ``1 / (SWITCH_STEPS_PER_RINGING_PERIOD f_ring)`` (:func:`ringing_hz` at ``kn`` [N m/rad]:
    the modes a switch excites)."""
    f_ring = ringing_hz(form, kn)
    if f_ring <= 0:
        return 0
    h_sw = 1.0 / (SWITCH_STEPS_PER_RINGING_PERIOD * f_ring)
    return max(0, math.ceil(math.log2(h / h_sw) - 1e-9))

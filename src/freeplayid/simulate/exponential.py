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

Step rule (:func:`expo_step_limit`, measured in docs/simulate.md, "Exponential engine"): at least
``STEPS_PER_SWEEP_PERIOD`` steps per period of the sweep's top frequency and
``STEPS_PER_CONTACT_PERIOD`` per period of the fastest closed-hinge mode below
``CONTACT_MODE_HZ_FACTOR`` x the sweep's top frequency (the modes a contact excites in step with
the response; the faster ones respond to a linear-in-time moment exactly).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .formulation import ModalForm

__all__ = ["ExpoStep", "discretize", "expo_step_limit", "closed_hinge_hz",
           "STEPS_PER_SWEEP_PERIOD", "STEPS_PER_CONTACT_PERIOD", "CONTACT_MODE_HZ_FACTOR"]

STEPS_PER_SWEEP_PERIOD = 500  # steps per period of the sweep's top frequency
STEPS_PER_CONTACT_PERIOD = 20  # steps per period of the contact modes that count
CONTACT_MODE_HZ_FACTOR = 10.0  # closed-hinge modes below this x the top sweep frequency count


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


def expo_step_limit(form: ModalForm, *, top_hz: float, kn_max: float) -> float:
    """Largest step [s] of the exponential engine by the accuracy rule (module docstring).

    Parameters
    ----------
    form : ModalForm
    top_hz : float [Hz]
        The sweep's top frequency.
    kn_max : float [N m/rad]
        The batch's largest contact stiffness.
    """
    if not (math.isfinite(top_hz) and top_hz > 0):
        raise ValueError(f"`top_hz` must be > 0, got {top_hz!r}")
    f_contact = closed_hinge_hz(form, kn_max)
    counted = f_contact[f_contact <= CONTACT_MODE_HZ_FACTOR * top_hz]
    h = 1.0 / (STEPS_PER_SWEEP_PERIOD * top_hz)
    if counted.size and counted[-1] > 0:
        h = min(h, 1.0 / (STEPS_PER_CONTACT_PERIOD * counted[-1]))
    return h

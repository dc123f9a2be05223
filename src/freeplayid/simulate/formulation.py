"""The equations the RK4 engines integrate: modal form, large-mass option, truncation, step.

Both excitation forms are reduced to one modal problem in coordinates ``eta`` (``x = Phi eta``,
``Phi^T M Phi = I``, ``Phi^T K Phi = diag(lam)`` with K the hinge-open stiffness)::

    eta'' = -lam * eta - Cm eta' - D f(D^T eta) + g * level * sin(phase(t))            (ETA)

with ``D = Phi^T B`` (so ``theta = D^T eta`` are the hinge rotations) and ``f`` the freeplay force
of each member's (kn, delta). The stiffness is diagonal in this basis, which halves the work of a
step; ``Cm = Phi^T C Phi`` is dense in general and diagonal for classical (e.g. Rayleigh) damping,
which the engines exploit.

Relative form (docs/simulate.md): x = y (displacement relative to the base), forcing ``-M r a_g``,
so ``g = -Phi^T M r G``; the system starts at rest relative to the base.

Large-mass form (the paper's method): the free-base model with the base DOF ``u_b`` appended,
built from the fixed-base one by the kinematic map ``x = y + r u_b``::

    M_full = [[M, 0], [0, M_L]],   K_full = [[K, -K r], [-r^T K, r^T K r]]   (C alike)

(strain energy ½ (x - r u_b)^T K (x - r u_b); the rigid-body motion ``x = r u_b`` is free), the
hinges act on ``b_j^T (x - r u_b)`` and the base DOF is driven by the force ``M_L a_g``.
It starts on the rigid-body motion of the base (``x = r u_b``, ``x' = r v_b``).

Modal truncation (optional, ``cutoff_hz``): the basis is restricted to the span of the open-hinge
and the closed-hinge (at the batch's largest kn) modes below the cut-off (the in-gap motion and the
contact state both stay representable) and re-diagonalised for the open stiffness inside it.
A contact mode above the cut-off that the in-gap motion needs cannot be dropped: then the span is
the whole space and nothing is gained (a stiff contact needs a small step). The quasi-static
response of the dropped modes to the base load is added back to the outputs (residual
flexibility, mode-acceleration correction) and its size is reported.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..dataset import FRAMES
from ..model.system import FreeplaySystem
from ..quantity import QUANTITY, G, check_quantity

__all__ = [
    "ModalForm",
    "ModalTruncation",
    "build_modal_form",
    "static_equilibrium",
    "rk4_step_limit",
    "RK4_STABILITY_LIMIT",
    "MODES",
    "BLOWUP",
]

RK4_STABILITY_LIMIT = 2.785  # |mu dt| on the negative real axis; 2.828 on the imaginary axis
# what every engine records of the state of (ETA) for each quantity: eta, eta' or eta'' (the
# quantity's derivative order), and the size above which a member's state counts as diverged
MODES = {name: q.order for name, q in QUANTITY.items()}
BLOWUP = 1e12  # |modal state| above this (or non-finite) marks a member as diverged

METHODS = ("relative", "large_mass")


@dataclass(frozen=True)
class ModalTruncation:
    """What modal truncation dropped and how much it matters.

    Attributes
    ----------
    cutoff_hz : float [Hz]
        Closed-hinge modes above this frequency were dropped.
    kept, total : int
        Number of modes kept / in the full model.
    static_error : float [-]
        Largest relative quasi-static error, over the output channels, that the truncation would
        make in the response to the base load without the residual-flexibility correction
        (the correction, applied to the outputs, removes it for slow loading).
    missing_mass : float [-]
        Fraction of the base load ``F^T M^-1 F`` outside the kept subspace.
    """

    cutoff_hz: float
    kept: int
    total: int
    static_error: float
    missing_mass: float


@dataclass(frozen=True)
class ModalForm:
    """Arrays of (ETA) for one system, formulation, output request and kn range (float64).

    Attributes
    ----------
    lam : ndarray, shape (N,) [1/s^2]
        Open-hinge modal stiffnesses omega^2 (>= 0).
    Cm : ndarray, shape (N, N) [1/s]
        Modal damping matrix.
    c_diagonal : bool
        True if ``Cm`` is diagonal (to round-off), so the engines may use its diagonal only.
    D : ndarray, shape (N, h) [rad per modal unit]
        Hinge rotations ``theta = D^T eta``.
    g : ndarray, shape (N,) [modal force per g]
        Modal forcing per unit level: the excitation is ``g * level_g * sin(phase)``.
    S : ndarray, shape (C, N)
        Output map: channel quantity = ``S @ eta`` (or of eta', eta'').
    base_coef : ndarray, shape (C,) [per g]
        Channel gain of the base motion per unit level (absolute frame of the relative form:
        ``G r``; else 0), multiplied by the unit base signal of the quantity.
    static_coef : ndarray, shape (C,) [per g]
        Residual-flexibility correction gain of truncation (0 without truncation), multiplied by
        the unit quasi-static signal (a_g, a_g', a_g'' for displacement, velocity, acceleration).
    x0_per_ub, v0_per_vb : ndarray, shape (N,)
        Modal initial state per unit base displacement / velocity (large-mass form; else 0).
    omega_max : float [rad/s]
        Largest |eigenvalue| of the first-order Jacobian over every open/closed hinge state at the
        largest kn: the RK4 step bound.
    truncation : ModalTruncation or None
    """

    lam: np.ndarray
    Cm: np.ndarray
    c_diagonal: bool
    D: np.ndarray
    g: np.ndarray
    S: np.ndarray
    base_coef: np.ndarray
    static_coef: np.ndarray
    x0_per_ub: np.ndarray
    v0_per_vb: np.ndarray
    omega_max: float
    truncation: ModalTruncation | None

    @property
    def n_modes(self) -> int:
        return self.lam.shape[0]


def _physical_form(system: FreeplaySystem, method: str, large_mass_ratio: float):
    """(M, K, C, B, F, r_full, base_index) of the chosen formulation in physical coordinates.

    F is the load per unit level [N per g]; r_full the rigid-body vector of the base motion.
    """
    M, K, C, B = system.M, system.K, system.damping, system.hinge_matrix()
    r = system.influence
    if method == "relative":
        return M, K, C, B, -(M @ r) * G, r, None
    # large mass: x = y + r u_b
    n = system.n_dof
    mass = float(r @ M @ r) if np.any(r) else float(np.trace(M))
    ML = large_mass_ratio * mass

    def lift(A):
        Ar = A @ r
        out = np.zeros((n + 1, n + 1))
        out[:n, :n] = A
        out[:n, n] = -Ar
        out[n, :n] = -Ar
        out[n, n] = r @ Ar
        return out

    Mf = np.zeros((n + 1, n + 1))
    Mf[:n, :n] = M
    Mf[n, n] = ML
    Bf = np.vstack([B, -(r @ B)[None, :]])
    F = np.zeros(n + 1)
    F[n] = ML * G
    r_full = np.append(r, 1.0)
    return Mf, lift(K), lift(C), Bf, F, r_full, n


def _omega_max(lam: np.ndarray, Cm: np.ndarray, D: np.ndarray, kn_max: float) -> float:
    """Largest |mu| of the first-order Jacobian [[0, I], [-(Lam + kn D_s D_s^T), -Cm]].

    Every subset s of closed hinges is tried (for up to 4 hinges; else all-open and all-closed):
    the piecewise-linear system visits these Jacobians.
    """
    N, h = D.shape
    subsets = (
        itertools.product((0.0, 1.0), repeat=h) if h <= 4 else [(0.0,) * h, (1.0,) * h]
    )
    best = 0.0
    for s in subsets:
        Ks = np.diag(lam) + kn_max * (D * np.asarray(s)) @ D.T
        J = np.block([[np.zeros((N, N)), np.eye(N)], [-Ks, -Cm]])
        best = max(best, float(np.max(np.abs(np.linalg.eigvals(J)))))
    return best


def build_modal_form(
    system: FreeplaySystem,
    *,
    channels: tuple[str, ...],
    quantity: str,
    frame: str,
    method: str = "relative",
    kn_max: float,
    cutoff_hz: float | None = None,
    large_mass_ratio: float = 1e6,
) -> ModalForm:
    """Assemble (ETA) for ``system`` (see the module docstring for the maths).

    Parameters
    ----------
    system : FreeplaySystem
    channels : tuple of str
        DOF names of the output channels.
    quantity : {"displacement", "velocity", "acceleration"}
    frame : {"absolute", "relative"}
    method : {"relative", "large_mass"}
    kn_max : float [N m/rad]
        Largest contact stiffness of the batch (sets the step and the truncation basis).
    cutoff_hz : float [Hz], optional
        Drop closed-hinge modes above this frequency.
    large_mass_ratio : float [-]
        Seismic mass over the structure's rigid-body mass (large-mass form).
    """
    check_quantity(quantity)
    if frame not in FRAMES:
        raise ValueError(f"`frame` must be one of {FRAMES}, got {frame!r}")
    if method not in METHODS:
        raise ValueError(f"`method` must be one of {METHODS}, got {method!r}")
    if not large_mass_ratio > 0:
        raise ValueError(f"`large_mass_ratio` must be > 0, got {large_mass_ratio!r}")
    M, K, C, B, F, r_full, ib = _physical_form(system, method, large_mass_ratio)
    n = M.shape[0]
    idx = system.dof_index(list(channels))
    S_phys, base_coef = _output_rows(system.influence, idx, n, method=method, frame=frame,
                                     base_index=ib)
    # basis: full space, or closed-hinge modes below the cut-off
    truncation = None
    static_coef = np.zeros(len(idx))
    if cutoff_hz is not None:
        V, static_coef, truncation = _truncated_basis(M, K, B, F, S_phys, kn_max=kn_max,
                                                      cutoff_hz=cutoff_hz)
    else:
        V = np.eye(n)
    # open-hinge modal basis inside the subspace: Phi^T M Phi = I, Phi^T K Phi = diag(lam)
    lam, R = scipy.linalg.eigh(V.T @ K @ V, V.T @ M @ V)
    Phi = V @ R
    lam = np.clip(lam, 0.0, None)
    Cm = Phi.T @ C @ Phi
    Cm = 0.5 * (Cm + Cm.T)
    off = Cm - np.diag(np.diag(Cm))
    scale = max(float(np.max(np.abs(Cm))), 1e-300)
    c_diagonal = bool(np.max(np.abs(off)) <= 1e-10 * scale)
    D = Phi.T @ B
    g = Phi.T @ F
    if method == "large_mass":
        Minv_phys = Phi.T @ M  # eta = Phi^T M x
        x0 = Minv_phys @ r_full
        v0 = x0.copy()
    else:
        x0 = v0 = np.zeros(Phi.shape[1])
    return ModalForm(
        lam=lam,
        Cm=Cm,
        c_diagonal=c_diagonal,
        D=D,
        g=g,
        S=S_phys @ Phi,
        base_coef=base_coef,
        static_coef=static_coef,
        x0_per_ub=x0,
        v0_per_vb=v0,
        omega_max=_omega_max(lam, Cm, D, kn_max),
        truncation=truncation,
    )


def _output_rows(r, idx, n, *, method, frame, base_index):
    """(S_phys, base_coef): the output rows in physical coordinates (C, n) and the channel gain
    of the base motion per g (absolute frame of the relative form; the relative frame of the
    large-mass form subtracts the base DOF ``base_index`` instead)."""
    S_phys = np.zeros((len(idx), n))
    S_phys[np.arange(len(idx)), idx] = 1.0
    base_coef = np.zeros(len(idx))
    if method == "relative" and frame == "absolute":
        base_coef = G * r[idx]
    if method == "large_mass" and frame == "relative":
        S_phys[:, base_index] -= r[idx]
    return S_phys, base_coef


def _truncated_basis(M, K, B, F, S_phys, *, kn_max, cutoff_hz):
    """(V, static_coef, ModalTruncation): the M-orthonormal span of the open- and closed-hinge
    modes below ``cutoff_hz`` (the in-gap motion and the contact state), the residual-flexibility
    gain of the outputs and what was dropped (module docstring)."""
    Kc = K + kn_max * B @ B.T
    if not cutoff_hz > 0:
        raise ValueError(f"`cutoff_hz` must be > 0 or None, got {cutoff_hz!r}")
    lam_c, phi_c = scipy.linalg.eigh(Kc, M)
    lam_c = np.clip(lam_c, 0.0, None)
    lam_o, phi_o = scipy.linalg.eigh(K, M)
    fc = (2 * np.pi * cutoff_hz) ** 2
    keep_c, keep_o = lam_c <= fc, lam_o <= fc
    if not np.any(keep_c):
        raise ValueError(
            f"`cutoff_hz`={cutoff_hz!r} keeps no mode; the lowest closed-hinge mode is at "
            f"{math.sqrt(lam_c[0]) / (2 * np.pi):.4g} Hz"
        )
    # span of the open- and closed-hinge modes below the cut-off (the in-gap motion and the
    # contact state), M-orthonormalised with rank detection
    W = np.hstack([phi_o[:, keep_o], phi_c[:, keep_c]])
    gw, U = np.linalg.eigh(W.T @ M @ W)
    ok = gw > 1e-10 * gw.max()
    V = W @ (U[:, ok] / np.sqrt(gw[ok]))
    # residual flexibility: full elastic flexibility minus the subspace's (pinv: rigid modes)
    elastic = lam_c > 1e-9 * lam_c[-1]
    flex_full = (phi_c[:, elastic] / lam_c[elastic]) @ phi_c[:, elastic].T
    flex_sub = V @ np.linalg.pinv(V.T @ Kc @ V, rcond=1e-10, hermitian=True) @ V.T
    full_static = S_phys @ flex_full @ F
    static_coef = S_phys @ (flex_full - flex_sub) @ F
    denom = np.maximum(np.abs(full_static), 1e-300)
    total = float(F @ np.linalg.solve(M, F))
    captured = float(np.sum((V.T @ F) ** 2))
    truncation = ModalTruncation(
        cutoff_hz=float(cutoff_hz),
        kept=int(V.shape[1]),
        total=M.shape[0],
        static_error=float(np.max(np.abs(static_coef) / denom)),
        missing_mass=max(0.0, 1.0 - captured / max(total, 1e-300)),
    )
    return V, static_coef, truncation


def rk4_step_limit(omega_max: float, *, omega_dt: float) -> float:
    """Largest RK4 step [s] with ``omega_max * dt <= omega_dt``.

    Parameters
    ----------
    omega_max : float [rad/s]
    omega_dt : float [-], in (0, 0.9 * 2.785]
        Accuracy/stability target of the fastest mode.
    """
    if not (0 < omega_dt <= 0.9 * RK4_STABILITY_LIMIT):
        raise ValueError(
            f"`omega_dt` must be in (0, {0.9 * RK4_STABILITY_LIMIT:.3f}] (90 % of the RK4 "
            f"stability limit {RK4_STABILITY_LIMIT}), got {omega_dt!r}"
        )
    if omega_max <= 0:
        return math.inf
    return omega_dt / omega_max


def static_equilibrium(form: ModalForm, kn, delta, static_g: float, gap_shares=None) -> np.ndarray:
    """Each member's modal displacement at rest under a constant load ``g * static_g`` (a static
    acceleration of the frame along the base axis [g], gravity on a vertical shaker):
    ``lam * eta + D f(D^T eta) = g * static_g``.

    f is piecewise linear, so each hinge's contact state (-1 / 0 / +1) gives a linear system;
    the state whose solution is consistent with it is the equilibrium (f is monotone: at most
    one). A hinge whose structure is a mechanism while it is open rests on the stop that the
    load pushes it to.

    Parameters
    ----------
    form : ModalForm
    kn, delta : array_like, shape (batch,) [N m/rad], [rad]
    static_g : float [g]
    gap_shares : array_like, shape (H,), optional
        Hinge j's half-gap is ``delta * gap_shares[j]`` (default: one common gap).

    Returns
    -------
    ndarray, shape (batch, N)

    Raises
    ------
    ValueError
        A member with no equilibrium (kn = 0 on a mechanism: nothing holds the load).
    """
    kn = np.atleast_1d(np.asarray(kn, dtype=float))
    delta = np.atleast_1d(np.asarray(delta, dtype=float))
    N, H = form.D.shape
    shares = np.ones(H) if gap_shares is None else np.asarray(gap_shares, float).reshape(H)
    load = form.g * float(static_g)
    out = np.zeros((len(kn), N))
    if static_g == 0:
        return out
    states = [np.array(c, float) for c in itertools.product((-1, 0, 1), repeat=H)]
    for i, (k, d) in enumerate(zip(kn, delta)):
        dv = d * shares
        for s in states:
            P = np.abs(s)
            A = np.diag(form.lam) + k * (form.D * P) @ form.D.T
            try:
                eta = np.linalg.solve(A, load + k * form.D @ (P * s * dv))
            except np.linalg.LinAlgError:
                continue
            if not np.all(np.isfinite(eta)) or np.linalg.cond(A) > 1e12:
                continue
            th = form.D.T @ eta
            tol = 1e-9 * (np.abs(th) + dv)
            ok = np.where(s == 0, np.abs(th) <= dv + tol, s * th >= dv - tol)
            if ok.all():
                out[i] = eta
                break
        else:
            raise ValueError(f"no static equilibrium under {static_g:g} g at kn={k:g}, "
                             f"delta={d:g}: nothing holds the load")
    return out

"""Multi-harmonic balance (HB) backbone curves, accurate near contact where the DFA is not.

Conservative periodic motion in normalised time tau = w t, even in tau (a backbone/NNM passes
through a turning point with zero velocity) and, for the odd freeplay force, with odd harmonics
only::

    y(tau) = sum_{k in H} Y_k cos(k tau),   H = (1, 3, 5, ...)

Galerkin projection of M w^2 y'' + K y + B f(B^T y) = 0 onto cos(k tau)::

    R_k = (K - (k w)^2 M) Y_k + F_k = 0,
    F_k = (1/pi) int_0^{2 pi} B f(B^T y(tau)) cos(k tau) d tau

with F_k computed by alternating frequency/time (AFT): y on N equispaced tau samples, the force
in time, its cosine coefficients by the (exact for trigonometric polynomials) rectangle rule.
The phase condition is implicit (cosine series); the amplitude condition fixes the first harmonic
of the reference hinge, b_ref^T Y_1 = s delta. Newton's method with the analytic Jacobian
(dF_k/dY_l = (1/pi) int B diag(f'(theta)) B^T cos(k tau) cos(l tau), f' = kn outside the gap),
continued in s from the large-amplitude end (started from the DFA mode) towards contact.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg

from ..model import FreeplaySystem, describing_function, freeplay_force
from .dfa import BackboneCurve, amplitude_grid, dfa_backbone

__all__ = ["hb_backbone"]


def hb_backbone(
    system: FreeplaySystem,
    *,
    kn: float,
    delta: float,
    mode: int = 0,
    s: np.ndarray | None = None,
    n_harmonics: int = 5,
    n_time: int = 512,
    tol: float = 1e-10,
    max_iter: int = 50,
) -> BackboneCurve:
    """Harmonic-balance backbone of ``system`` for one (kn, delta).

    Parameters
    ----------
    system : FreeplaySystem
    kn : float [N m/rad]
    delta : float [rad], > 0
    mode : int
        Mode counted from the lowest, as in :func:`dfa_backbone` (used for the start).
    s : ndarray, shape (m,), optional
        First-harmonic amplitude of the reference hinge over delta (> 1); default
        :func:`amplitude_grid`. The reference hinge is the one with the largest amplitude.
    n_harmonics : int
        Number of odd harmonics (1, 3, ..., 2 n_harmonics - 1).
    n_time : int
        AFT time samples per period (>= 4 x the highest harmonic).
    tol : float
        Newton tolerance on the scaled residual.

    Returns
    -------
    BackboneCurve
        k = 1; ``amplitude``/``hinge_amplitude`` are first-harmonic amplitudes (what the
        extraction measures); ``peak_amplitude`` holds max |y| over the period.
    """
    if np.ndim(kn) or np.ndim(delta):
        raise ValueError("`hb_backbone` takes one scalar (kn, delta); loop or use dfa_backbone")
    if n_harmonics < 1:
        raise ValueError(f"`n_harmonics` must be >= 1, got {n_harmonics!r}")
    orders = 2 * np.arange(n_harmonics) + 1
    if n_time < 4 * orders[-1]:
        raise ValueError(f"`n_time` must be >= {4 * orders[-1]} for {n_harmonics} harmonics")
    s = amplitude_grid() if s is None else np.asarray(s, dtype=float).reshape(-1)
    start = dfa_backbone(system, kn=kn, delta=delta, mode=mode, s=s)
    kn, delta = float(kn), float(delta)
    # reference hinge: the largest one on the DFA curve at its large-amplitude end, where the
    # continuation starts from the DFA solution (signed mode shape)
    ref = int(np.argmax(start.hinge_amplitude[0, -1]))
    hb = _Balance(system, kn, delta, orders, n_time, ref,
                  w_ref=2 * np.pi * max(start.frequency_hz[0, -1], 1e-6))
    phi = _signed_mode(system, kn, start.kappa[0, -1], mode)
    curve = _continue(hb, phi * s[-1] / (hb.b_ref @ phi), s, tol, max_iter)
    freq, amp1, peak, conv, hinge_amp = curve
    if not conv.all():
        warnings.warn(
            f"hb_backbone: Newton did not converge at {np.count_nonzero(~conv)} of {s.size} "
            f"points (s = {s[~conv][:5]}...)",
            stacklevel=2,
        )
    _replace_locked(system, kn, mode, s, orders, start, curve)
    return BackboneCurve(
        frequency_hz=freq[None],
        amplitude=amp1[None],
        hinge_amplitude=hinge_amp[None],
        kappa=describing_function(hinge_amp, delta)[None],
        kn=np.array([kn]),
        delta=np.array([delta]),
        dof_names=system.dof_names,
        method="hb",
        converged=conv[None],
        peak_amplitude=peak[None],
    )


class _Balance:
    """The harmonic-balance residual and its analytic Jacobian for one (kn, delta) (module
    docstring); unknowns z = (Y / delta flattened, w / w_ref)."""

    def __init__(self, system, kn, delta, orders, n_time, ref, *, w_ref):
        self.M, self.K, self.B = system.M, system.K, system.hinge_matrix()
        self.n, self.nh, self.orders = system.n_dof, orders.size, orders
        self.kn, self.delta, self.n_time, self.w_ref = kn, delta, n_time, w_ref
        self.cos = np.cos(np.outer(orders, 2 * np.pi * np.arange(n_time) / n_time))  # (H, N)
        self.b_ref = self.B[:, ref]
        self.scale_r = (np.max(np.abs(np.diag(self.K))) + 2 * kn) * delta  # residual scale [N]

    def shapes(self, z) -> np.ndarray:
        """The harmonics Y, shape (H, n) [m]."""
        return z[:-1].reshape(self.nh, self.n) * self.delta

    def __call__(self, z, s_val):
        M, K, B, cos, orders, delta = self.M, self.K, self.B, self.cos, self.orders, self.delta
        n, nh, n_time = self.n, self.nh, self.n_time
        Y = self.shapes(z)  # (H, n)
        w = z[-1] * self.w_ref
        theta = (cos.T @ Y) @ B  # (N, h)
        F = (2.0 / n_time) * cos @ (freeplay_force(theta, self.kn, delta) @ B.T)  # (H, n)
        R = np.einsum("hab,hb->ha", K[None] - (orders[:, None, None] * w) ** 2 * M[None], Y) + F
        # Jacobian w.r.t. Y/delta and w/w_ref
        stiff = self.kn * (np.abs(theta) > delta)  # (N, h): f'(theta)
        # dF_k/dY_l = (2/N) sum_t cos_k(t) cos_l(t) B diag(stiff(t)) B^T
        wkl = (2.0 / n_time) * np.einsum("kt,lt,tj->klj", cos, cos, stiff)  # (H, H, h)
        J = np.einsum("klj,aj,bj->kalb", wkl, B, B)  # (H, n, H, n)
        for i, k in enumerate(orders):
            J[i, :, i, :] += K - (k * w) ** 2 * M
        J = J.reshape(nh * n, nh * n) * delta
        dw = (-2 * orders[:, None] ** 2 * w * (Y @ M.T)).reshape(-1) * self.w_ref
        res = np.concatenate([R.reshape(-1) / self.scale_r,
                              [(self.b_ref @ Y[0]) / delta - s_val]])
        jac = np.zeros((nh * n + 1, nh * n + 1))
        jac[:-1, :-1] = J / self.scale_r
        jac[:-1, -1] = dw / self.scale_r
        jac[-1, :n] = self.b_ref
        return res, jac


def _newton(hb: _Balance, z, s_val, tol, max_iter):
    """Damped Newton from ``z`` at amplitude ``s_val``: (solution, converged)."""
    for _ in range(max_iter):
        res, jac = hb(z, s_val)
        if np.max(np.abs(res)) < tol:
            return z, True
        try:
            step = np.linalg.solve(jac, -res)
        except np.linalg.LinAlgError:
            return z, False
        # damped Newton: halve the step until the residual decreases
        lam = 1.0
        r0 = np.linalg.norm(res)
        for _ in range(20):
            r1, _j = hb(z + lam * step, s_val)
            if np.linalg.norm(r1) < r0:
                break
            lam *= 0.5
        z = z + lam * step
    return z, False


def _continue(hb: _Balance, y_start, s, tol, max_iter):
    """The backbone continued in ``s`` from the large-amplitude end (first harmonic
    ``y_start`` there) towards contact: frequency [Hz], first-harmonic and peak amplitudes,
    convergence and first-harmonic hinge amplitudes per point."""
    m, n = s.size, hb.n
    freq, conv = np.full(m, np.nan), np.zeros(m, dtype=bool)
    amp1, peak, y1 = np.full((m, n), np.nan), np.full((m, n), np.nan), np.full((m, n), np.nan)
    z = np.zeros(hb.nh * n + 1)
    z[:n] = y_start
    z[-1] = 1.0
    for i in range(m - 1, -1, -1):
        if i < m - 1:  # continuation: scale the previous solution to the new amplitude
            z[:-1] *= s[i] / s[i + 1]
        z, conv[i] = _newton(hb, z, s[i], tol, max_iter)
        Y = hb.shapes(z)
        freq[i] = abs(z[-1]) * hb.w_ref / (2 * np.pi)
        amp1[i] = np.abs(Y[0])
        y1[i] = Y[0]
        peak[i] = np.max(np.abs(hb.cos.T @ Y), axis=0)
    return freq, amp1, peak, conv, np.abs(y1 @ hb.B)


def _replace_locked(system, kn, mode, s, orders, start, curve) -> None:
    """Caught on a k:1 internal resonance, the continuation follows the branch where the k-th
    harmonic drives another mode, not the fundamental backbone: those points of ``curve`` are
    replaced (in place) by the consistent DFA ones of ``start`` and flagged unconverged."""
    freq, amp1, peak, conv, hinge_amp = curve
    lin = _linear_frequencies(system, kn, mode)
    locked = _internal_resonance(lin, s, freq, start.frequency_hz[0], orders)
    if not locked.any():
        return
    k_hit = sorted({int(k) for k in orders[1:] if np.any(_near_mode(lin, k * freq[locked]))})
    warnings.warn(
        f"hb_backbone: at kn = {kn:g} the continuation locked onto an internal resonance "
        f"(harmonic {k_hit} x {np.nanmedian(freq[locked]):.2f} Hz = a linear mode) for "
        f"s in [{s[locked].min():.4g}, {s[locked].max():.4g}] ({locked.sum()} of {s.size} "
        "points); the DFA backbone is used there. Fewer harmonics (n_harmonics) move the "
        "resonance out of a band.",
        stacklevel=3,
    )
    freq[locked] = start.frequency_hz[0, locked]
    amp1[locked] = start.amplitude[0, locked]
    peak[locked] = start.amplitude[0, locked]
    hinge_amp[locked] = start.hinge_amplitude[0, locked]
    conv[locked] = False


def _linear_frequencies(system: FreeplaySystem, kn: float, mode: int) -> np.ndarray:
    """Natural frequencies [Hz] with the hinges open and closed, the backbone's mode left out."""
    out = []
    for k in (0.0, kn):
        w2 = scipy.linalg.eigh(system.closed_stiffness(k), system.M, eigvals_only=True)
        f = np.sqrt(np.clip(w2, 0.0, None)) / (2 * np.pi)
        out.append(np.delete(f, mode))
    return np.concatenate(out)


def _near_mode(lin, f, tol=0.03) -> np.ndarray:
    """Whether each frequency in ``f`` [Hz] lies within ``tol`` of one of ``lin`` [Hz]."""
    lin = lin[lin > 0]
    if lin.size == 0:
        return np.zeros(np.shape(f), dtype=bool)
    f = np.asarray(f, dtype=float)
    return np.min(np.abs(f[..., None] - lin) / lin, axis=-1) < tol


def _internal_resonance(lin, s, f_hb, f_dfa, orders) -> np.ndarray:
    """Points (m,) where the HB continuation sits on a k:1 internal resonance.

    ``lin``: the other linear modes' frequencies [Hz] (:func:`_linear_frequencies`).

    The fundamental freeplay backbone hardens: its frequency rises with s wherever the DFA one
    does. A stretch where the HB frequency stays flat (slope in ln s below 20 % of the DFA's,
    where the DFA still rises by more than 2 % per unit ln s) and a harmonic k >= 3 of it lies
    within 3 % of another linear mode is the branch of that internal resonance.
    """
    if s.size < 3 or orders.size < 2:
        return np.zeros(s.size, dtype=bool)
    ls = np.log(s)
    g_h = np.gradient(np.nan_to_num(f_hb), ls)
    g_d = np.gradient(f_dfa, ls)
    with np.errstate(divide="ignore", invalid="ignore"):
        flat = (g_d > 0.02 * f_dfa) & (g_h < 0.2 * g_d)
    if not flat.any():
        return flat
    hit = np.zeros(s.size, dtype=bool)
    for k in orders[1:]:
        hit |= _near_mode(lin, k * np.nan_to_num(f_hb))
    return flat & hit


def _signed_mode(system: FreeplaySystem, kn: float, kappa: np.ndarray, mode: int) -> np.ndarray:
    """Mode shape (signed, physical coordinates) of K + kn sum_j kappa_j b_j b_j^T."""
    B = system.hinge_matrix()
    A = system.K + kn * (B * kappa) @ B.T
    _, vec = scipy.linalg.eigh(A, system.M)
    return vec[:, mode]

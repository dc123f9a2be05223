"""Describing-function (DFA) backbone curves of a reduced model with freeplay hinges.

Harmonic ansatz y = Y cos(w t) in the unforced, undamped EOM (docs/backbone.md). Each hinge spring j
is replaced by its equivalent stiffness kappa_j kn with kappa_j = kappa(delta / Theta_j),
Theta_j = |b_j^T Y| its first-harmonic amplitude, so a backbone point solves::

    [K + kn sum_j kappa_j b_j b_j^T] phi = w^2 M phi,   Theta_j = c |b_j^T phi|      (BC)

Parametrisation: s = max_j Theta_j / delta in (1, inf). For the hinge j* with the largest
amplitude kappa_j* = kappa(1/s); the others follow from the mode shape,
kappa_j = kappa(|b_j*^T phi| / (s |b_j^T phi|)), found by iteration from equal kappas
(``equal_hinges=True`` stops after the first step: every hinge gets kappa(1/s), the paper-style
approximation). Amplitudes are Y = s delta phi / |b_j*^T phi|. The consistency
kappa = F(kappa) is solved by Newton's method (a plain fixed point oscillates when the hinges are
strongly unequal).

Two exact reductions make the curve cheap:
- delta only scales amplitudes (scale invariance), so curves are computed for delta = 1 and
  multiplied;
- all s-points and all kn values form one batch of small symmetric eigenproblems, solved at once
  by ``numpy.linalg.eigh`` after the Cholesky transform A = L^-1 K L^-T (M = L L^T).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import FreeplaySystem, kappa_of_ratio

__all__ = ["BackboneCurve", "dfa_backbone", "amplitude_grid"]


@dataclass(frozen=True)
class BackboneCurve:
    """Backbone curve(s): first-harmonic amplitude vs frequency of one nonlinear normal mode.

    Batch dimension k over (kn, delta) pairs, m points along the curve.

    Attributes
    ----------
    frequency_hz : ndarray, shape (k, m) [Hz]
    amplitude : ndarray, shape (k, m, n_dof) [m or rad]
        First-harmonic amplitude of every DOF (relative to the base).
    hinge_amplitude : ndarray, shape (k, m, h) [rad]
        First-harmonic amplitude Theta_j of each hinge's relative rotation.
    kappa : ndarray, shape (k, m, h) [-]
        Equivalent-stiffness ratio of each hinge.
    kn, delta : ndarray, shape (k,) [N m/rad], [rad]
    dof_names : tuple of str
    method : str
        The registry name of the method (a key of ``BACKBONE_METHODS``: "dfa", "hb").
    converged : ndarray, shape (k, m) of bool
        Whether the unequal-hinge fixed point (or harmonic balance) converged at each point.
    peak_amplitude : ndarray, shape (k, m, n_dof), optional [m or rad]
        Largest |y| over a period (harmonic balance only; the DFA has one harmonic).
    """

    frequency_hz: np.ndarray
    amplitude: np.ndarray
    hinge_amplitude: np.ndarray
    kappa: np.ndarray
    kn: np.ndarray
    delta: np.ndarray
    dof_names: tuple
    method: str
    converged: np.ndarray
    peak_amplitude: np.ndarray | None = None

    def channel(self, name: str) -> np.ndarray:
        """First-harmonic amplitude of DOF ``name`` along the curve(s), shape (k, m)."""
        if name not in self.dof_names:
            raise KeyError(f"unknown channel {name!r}; known DOFs: {list(self.dof_names)}")
        return self.amplitude[..., self.dof_names.index(name)]

    def frequency_at(self, amplitude, channel: str) -> np.ndarray:
        """Backbone frequency [Hz] at first-harmonic ``amplitude`` of ``channel``.

        Linear interpolation along the curve (whose amplitudes increase with s); NaN outside the
        computed amplitude range. Returns shape (k, p) for amplitudes of shape (p,).
        """
        amp = np.atleast_1d(np.asarray(amplitude, dtype=float))
        x = self.channel(channel)
        out = np.empty((x.shape[0], amp.size))
        for i in range(x.shape[0]):
            order = np.argsort(x[i])
            out[i] = np.interp(
                amp, x[i, order], self.frequency_hz[i, order], left=np.nan, right=np.nan
            )
        return out


def amplitude_grid(
    n_points: int = 200, *, s_max: float = 50.0, s_min: float = 1.0005
) -> np.ndarray:
    """Grid of s = Theta_max / delta, dense near contact (s -> 1) where the curve bends most."""
    if n_points < 2:
        raise ValueError(f"`n_points` must be >= 2, got {n_points!r}")
    if not (1.0 < s_min < s_max):
        raise ValueError(f"need 1 < s_min < s_max, got s_min={s_min!r}, s_max={s_max!r}")
    return 1.0 + np.geomspace(s_min - 1.0, s_max - 1.0, n_points)


def _as_batch(kn, delta) -> tuple[np.ndarray, np.ndarray]:
    kn = np.atleast_1d(np.asarray(kn, dtype=float))
    delta = np.atleast_1d(np.asarray(delta, dtype=float))
    try:
        kn, delta = np.broadcast_arrays(kn, delta)
    except ValueError:
        raise ValueError(
            f"`kn` and `delta` must broadcast to one batch, got shapes {kn.shape} and {delta.shape}"
        ) from None
    if kn.ndim != 1:
        raise ValueError(f"`kn` and `delta` must be scalars or 1-D, got shape {kn.shape}")
    if np.any(~np.isfinite(kn)) or np.any(kn <= 0):
        raise ValueError(f"`kn` must be finite and > 0, got {kn!r}")
    if np.any(~np.isfinite(delta)) or np.any(delta <= 0):
        raise ValueError(f"`delta` must be finite and > 0 for a backbone, got {delta!r}")
    return kn.copy(), delta.copy()


class _Cycles:
    """The Newton points whose iterates repeat exactly, with period 1 or 2. They never converge,
    and the loop would run them to ``max_iter``. This happens where the mode switches to the
    other hinge as one falls into its gap: kappa = (a, b) and (b, a) in turn, the two hinges'
    states swapped. Each such point is set at once to the iterate that ``max_iter`` would have
    left it at. A two-hinge model whose mode flips there then costs a few eigen-batches per
    curve instead of ``max_iter (1 + h)`` of them (an 18-DOF two-hinge beam: 22 instead
    of 301, 60 ms per curve instead of 1 s). The curve is the same up to rounding: the batch's
    matrix products round by its size, so the other points' Newton paths differ in their last
    bits (measured: frequencies within 2e-11, amplitudes 3e-12 of the largest).

    A point's iterate depends on its own kappa only while every step is a Newton solve. The
    relaxed step, taken when any point's Jacobian is singular, is the whole batch's. So from
    the first relaxed step on, nothing is settled early. A settled point's Jacobians are those
    of the states it cycles through, already solved in the batch, so removing it cannot spare
    the others a relaxed step."""

    def __init__(self, max_iter: int, kappa: np.ndarray, state: tuple):
        self.max_iter = max_iter
        self.on = True
        self.back1 = kappa.copy()  # each point's iterate one iteration back
        self.back2 = np.full(kappa.shape, np.nan)  # and two back
        self.prev = tuple(x.copy() for x in state)  # the solve's outputs one iteration back

    def relaxed(self):
        self.on = False

    def settle(self, active: np.ndarray, it: int, kappa: np.ndarray, state: tuple) -> np.ndarray:
        """``active`` less the points that cycle, each set (in ``kappa`` and ``state``, in
        place) to the iterate of ``max_iter``; ``it`` iterations are done."""
        if not self.on:
            return active
        new = kappa[active]
        one = np.all(new == self.back1[active], axis=-1)  # fixed: it stays
        two = ~one & np.all(new == self.back2[active], axis=-1)
        if (self.max_iter - it) % 2:  # period 2, an odd number of steps left: the one before
            back = active[two]
            kappa[back] = self.back1[back]
            for x, keep in zip(state, self.prev):
                x[back] = keep[back]
        go = active[~(one | two)]
        self.back2[go] = self.back1[go]
        self.back1[go] = kappa[go]
        for keep, x in zip(self.prev, state):
            keep[go] = x[go]
        return go


def _newton(solve, kappa: np.ndarray, state: tuple, converged: np.ndarray, *, tol: float,
            max_iter: int) -> None:
    """Newton on G(kappa) = kappa - F(kappa) = 0 for the points not ``converged``, with a
    forward-difference Jacobian (h extra eigen-batches per iteration) and a fall-back to the
    relaxed fixed point; ``kappa`` (P, h), ``state`` (``solve``'s outputs: lam, vec, theta,
    implied) and ``converged`` (P,) are updated in place."""
    lam, vec, theta, implied = state
    h = kappa.shape[1]
    eps = 1e-7
    active = np.flatnonzero(~converged)
    cycles = _Cycles(max_iter, kappa, state)
    for it in range(1, max_iter + 1):
        G = kappa[active] - implied[active]
        done = np.max(np.abs(G), axis=-1) <= tol
        converged[active[done]] = True
        active, G = active[~done], G[~done]
        if active.size == 0:
            return
        ka = kappa[active]
        J = np.empty((active.size, h, h))
        for j in range(h):
            kp = ka.copy()
            kp[:, j] += eps
            J[:, :, j] = ((kp - solve(kp, active)[3]) - G) / eps
        try:
            step = -np.linalg.solve(J, G[..., None])[..., 0]
        except np.linalg.LinAlgError:
            step = -0.5 * G
            cycles.relaxed()
        bad = ~np.all(np.isfinite(step), axis=-1, keepdims=True)
        step = np.where(bad, -0.5 * G, step)
        kappa[active] = np.clip(ka + step, 0.0, 1.0)
        la, ve, th, im = solve(kappa[active], active)
        lam[active], vec[active], theta[active], implied[active] = la, ve, th, im
        active = cycles.settle(active, it, kappa, state)
        if active.size == 0:
            return
    G = kappa[active] - implied[active]
    converged[active] = np.max(np.abs(G), axis=-1) <= tol


def dfa_backbone(
    system: FreeplaySystem,
    *,
    kn,
    delta,
    mode: int = 0,
    s: np.ndarray | None = None,
    equal_hinges: bool = False,
    gaps=None,
    tol: float = 1e-10,
    max_iter: int = 100,
) -> BackboneCurve:
    """DFA backbone curve(s) of ``system`` for one or many (kn, delta).

    Parameters
    ----------
    system : FreeplaySystem
        Linear model with at least one hinge spring.
    kn : float or array_like, shape (k,) [N m/rad]
    delta : float or array_like, shape (k,) [rad]
        Broadcast with ``kn``.
    mode : int
        Which mode, counted from the lowest (0) at every amplitude.
    s : ndarray, shape (m,), optional
        Largest hinge amplitude over delta at each point (> 1); default :func:`amplitude_grid`.
    equal_hinges : bool
        Give every hinge the largest hinge's kappa (no fixed point).
    gaps : array_like, shape (h,), optional [-]
        Each hinge's half-gap over ``delta`` (default 1 for every hinge): hinge j's spring is
        kappa(gaps_j delta / Theta_j) kn; ``s`` stays the largest hinge amplitude over
        ``delta``. Gaps that differ make the curve bend in two places, which is how the data
        could tell them apart (:func:`freeplayid.identification.model_error.gap_split`).
    tol, max_iter : float, int
        Fixed-point tolerance on kappa and iteration cap.

    Returns
    -------
    BackboneCurve
        With k = batch size and m = len(s); ``converged`` flags the fixed point per point.
    """
    if not isinstance(system, FreeplaySystem):
        raise TypeError(f"`system` must be a FreeplaySystem, got {type(system).__name__}")
    if system.n_hinges == 0:
        raise ValueError("`system` has no hinge springs: its backbone is linear")
    if not (0 <= mode < system.n_dof):
        raise ValueError(f"`mode` must be in [0, {system.n_dof - 1}], got {mode!r}")
    kn, delta = _as_batch(kn, delta)
    s = amplitude_grid() if s is None else np.asarray(s, dtype=float).reshape(-1)
    if s.size == 0 or np.any(s <= 1.0) or np.any(~np.isfinite(s)):
        raise ValueError("`s` (largest hinge amplitude / delta) must be finite and > 1")

    L = np.linalg.cholesky(system.M)
    Linv = np.linalg.inv(L)
    Kt = Linv @ system.K @ Linv.T
    B = system.hinge_matrix()  # (n, h)
    g = Linv @ B  # (n, h): hinge vectors in the transformed coordinates

    k_, m_, h = kn.size, s.size, B.shape[1]
    gap = np.ones(h) if gaps is None else np.asarray(gaps, dtype=float).reshape(-1)
    if gap.shape != (h,) or not np.all(np.isfinite(gap) & (gap > 0)):
        raise ValueError(f"`gaps` must be {h} finite numbers > 0 (one per hinge), got {gaps!r}")
    if equal_hinges and gaps is not None:
        raise ValueError("`equal_hinges` gives every hinge one kappa: it takes no `gaps`")
    # flatten the (kn, s) batch to P points; Newton then works on the unconverged ones only
    kn_p = np.repeat(kn, m_)
    s_p = np.tile(s, k_)

    def solve(kappa, idx):
        """Eigen-solution for the hinge kappas of points ``idx``, and the kappas it implies."""
        A = Kt + np.einsum("p,pj,aj,bj->pab", kn_p[idx], kappa, g, g)  # (P, n, n)
        lam, psi = np.linalg.eigh(A)
        vec = psi[..., mode]  # (P, n), transformed coordinates
        theta = np.abs(vec @ g)  # (P, h): |b_j^T phi| up to a common scale
        # a mode whose hinges are at rest to rounding (kn ~ 1e25, where a fit's lost start
        # goes) gives NaN, which the caller reads as no curve
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = theta / theta.max(axis=-1, keepdims=True)
            implied = kappa_of_ratio(gap / (s_p[idx, None] * ratio))
        return lam[:, mode], vec, theta, implied

    P = kn_p.size
    kappa = kappa_of_ratio(gap[None, :] / s_p[:, None])
    state = solve(kappa, np.arange(P))  # (lam, vec, theta, implied)
    converged = np.full(P, equal_hinges or (h == 1 and gaps is None))
    if not converged.all():
        _newton(solve, kappa, state, converged, tol=tol, max_iter=max_iter)
    lam, vec, theta, _ = state
    kappa = kappa.reshape(k_, m_, h)
    lam = lam.reshape(k_, m_)
    vec = vec.reshape(k_, m_, -1)
    theta = theta.reshape(k_, m_, h)
    converged = converged.reshape(k_, m_)

    phi = vec @ Linv  # (k, m, n): back to physical coordinates, phi = L^-T psi
    with np.errstate(divide="ignore", invalid="ignore"):  # hinges at rest: NaN (above)
        scale = s[None, :] / theta.max(axis=-1)  # for delta = 1: Theta_max = s
        amplitude = np.abs(phi) * scale[..., None] * delta[:, None, None]
        hinge_amp = theta * scale[..., None] * delta[:, None, None]
    freq = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
    return BackboneCurve(
        frequency_hz=freq,
        amplitude=amplitude,
        hinge_amplitude=hinge_amp,
        kappa=kappa,
        kn=kn,
        delta=delta,
        dof_names=system.dof_names,
        method="dfa",
        converged=converged,
    )

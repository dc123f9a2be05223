"""Freeplay (dead-zone) restoring force and its describing function.

Half-gap convention (docs/backbone.md): contact at theta = +-delta, the total free play 2 delta::

    f(theta) = kn (theta - delta)   theta >  delta
             = 0                    |theta| <= delta
             = kn (theta + delta)   theta < -delta

which is ``kn * (theta - clip(theta, -delta, delta))``: one expression, branch-free, that works on
NumPy arrays and torch tensors alike and broadcasts over batches.

Describing function (first Fourier coefficient of f(Theta cos phi) over Theta), r = delta / Theta::

    kappa(r) = k_eq / kn = 1 - (2/pi) (asin r + r sqrt(1 - r^2)),   kappa = 0 for Theta <= delta

d kappa / d r = -(4/pi) sqrt(1 - r^2) < 0, so kappa is strictly decreasing in r (increasing in
Theta) and can be inverted by Newton's method (:func:`gap_ratio`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["freeplay_force", "describing_function", "kappa_of_ratio", "gap_ratio"]


def _is_torch(x) -> bool:
    mod = type(x).__module__
    return mod.startswith("torch")


def freeplay_force(theta, kn, delta):
    """Freeplay restoring force (or moment) of the relative rotation ``theta``.

    Parameters
    ----------
    theta : array_like or Tensor, any shape (broadcast with kn, delta) [rad]
        Relative hinge rotation.
    kn : float, array_like or Tensor [N m/rad]
        Contact stiffness, >= 0.
    delta : float, array_like or Tensor [rad]
        Half-gap, >= 0 (0 gives the linear spring kn theta).

    Returns
    -------
    ndarray or Tensor, broadcast shape [N m]
        Same library as ``theta`` (torch in, torch out; differentiable).
    """
    if _is_torch(theta) or _is_torch(kn) or _is_torch(delta):
        import torch

        theta = torch.as_tensor(theta)
        delta = torch.as_tensor(delta, dtype=theta.dtype, device=theta.device)
        kn = torch.as_tensor(kn, dtype=theta.dtype, device=theta.device)
        return kn * (theta - torch.clamp(theta, -delta, delta))
    theta = np.asarray(theta, dtype=float)
    delta = np.asarray(delta, dtype=float)
    if np.any(delta < 0):
        raise ValueError(f"`delta` must be >= 0, got {delta!r}")
    return np.asarray(kn, dtype=float) * (theta - np.clip(theta, -delta, delta))


def kappa_of_ratio(r):
    """kappa(r) = k_eq/kn as a function of r = delta/Theta in [0, 1]; 0 for r >= 1.

    Parameters
    ----------
    r : array_like [-]

    Returns
    -------
    ndarray, same shape as ``r`` [-], in [0, 1]
    """
    r = np.asarray(r, dtype=float)
    rc = np.clip(r, 0.0, 1.0)
    kappa = 1.0 - (2.0 / np.pi) * (np.arcsin(rc) + rc * np.sqrt(1.0 - rc * rc))
    return np.where(r >= 1.0, 0.0, np.clip(kappa, 0.0, 1.0))


def describing_function(amplitude, delta):
    """Equivalent-stiffness ratio kappa = k_eq/kn of freeplay for a harmonic of given amplitude.

    Parameters
    ----------
    amplitude : array_like [rad]
        First-harmonic amplitude Theta >= 0 of the relative hinge rotation.
    delta : array_like [rad]
        Half-gap >= 0; broadcasts with ``amplitude``.

    Returns
    -------
    ndarray, broadcast shape [-]
        kappa in [0, 1): 0 for amplitude <= delta, -> 1 as amplitude -> inf; 1 where delta = 0.
    """
    amplitude = np.asarray(amplitude, dtype=float)
    delta = np.asarray(delta, dtype=float)
    if np.any(delta < 0):
        raise ValueError(f"`delta` must be >= 0, got {delta!r}")
    if np.any(amplitude < 0):
        raise ValueError("`amplitude` must be >= 0")
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(amplitude > 0, delta / np.where(amplitude > 0, amplitude, 1.0), np.inf)
    r = np.where(delta == 0, 0.0, r)
    return kappa_of_ratio(r)


def gap_ratio(kappa, *, tol: float = 1e-14, max_iter: int = 60):
    """Invert kappa(r): the r = delta/Theta in [0, 1] with kappa(r) = ``kappa``.

    Newton on g(r) = kappa(r) - kappa with g'(r) = -(4/pi) sqrt(1 - r^2), started from the
    bisection-safe guess; the iteration is kept inside [0, 1]. Near r = 1, g' -> 0 and
    kappa ~ (4 sqrt 2 / 3 pi) (1 - r)^{3/2}, so that branch is started from the exact asymptote.

    Parameters
    ----------
    kappa : array_like [-], values in [0, 1]

    Returns
    -------
    ndarray, same shape [-]
    """
    k = np.asarray(kappa, dtype=float)
    if np.any((k < 0) | (k > 1)) or np.any(~np.isfinite(k)):
        raise ValueError("`kappa` must lie in [0, 1]")
    # initial guess: blend of the large-amplitude (kappa ~ 1 - 4r/pi) and near-contact asymptotes
    r_far = np.clip((1.0 - k) * np.pi / 4.0, 0.0, 1.0)
    r_near = 1.0 - (k * 3.0 * np.pi / (4.0 * np.sqrt(2.0))) ** (2.0 / 3.0)
    r = np.where(k < 0.2, np.clip(r_near, 0.0, 1.0), r_far)
    lo = np.zeros_like(r)
    hi = np.ones_like(r)
    for _ in range(max_iter):
        g = kappa_of_ratio(r) - k
        # kappa decreasing in r: g > 0 means r too small
        lo = np.where(g > 0, r, lo)
        hi = np.where(g <= 0, r, hi)
        dg = -(4.0 / np.pi) * np.sqrt(np.clip(1.0 - r * r, 0.0, 1.0))
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(dg != 0, g / dg, 0.0)
        r_new = r - step
        bad = ~np.isfinite(r_new) | (r_new <= lo) | (r_new >= hi)
        r_new = np.where(bad, 0.5 * (lo + hi), r_new)
        if np.all(np.abs(r_new - r) <= tol):
            r = r_new
            break
        r = r_new
    return r

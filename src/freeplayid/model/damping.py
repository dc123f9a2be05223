"""Viscous damping models for the linear structure.

The paper gives no damping values; these helpers build the usual proportional forms.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = ["rayleigh_damping", "rayleigh_coefficients", "modal_damping"]


def rayleigh_coefficients(f1: float, f2: float, zeta: float) -> tuple[float, float]:
    """(a, b) of C = a M + b K with damping ratio ``zeta`` at the frequencies f1 and f2.

    zeta(w) = a / (2 w) + b w / 2, matched at w1 = 2 pi f1 and w2 = 2 pi f2::

        a = 2 zeta w1 w2 / (w1 + w2),   b = 2 zeta / (w1 + w2)

    Parameters
    ----------
    f1, f2 : float [Hz], 0 < f1 < f2
    zeta : float [-], >= 0
    """
    if not (f1 > 0 and f2 > f1):
        raise ValueError(f"need 0 < f1 < f2, got f1={f1!r}, f2={f2!r}")
    if zeta < 0:
        raise ValueError(f"`zeta` must be >= 0, got {zeta!r}")
    w1, w2 = 2 * np.pi * f1, 2 * np.pi * f2
    return 2 * zeta * w1 * w2 / (w1 + w2), 2 * zeta / (w1 + w2)


def rayleigh_damping(
    M: np.ndarray, K: np.ndarray, *, f1: float, f2: float, zeta: float
) -> np.ndarray:
    """Rayleigh damping C = a M + b K with ratio ``zeta`` at f1 and f2 [Hz]; shape (n, n)."""
    a, b = rayleigh_coefficients(f1, f2, zeta)
    return a * np.asarray(M, float) + b * np.asarray(K, float)


def modal_damping(M: np.ndarray, K: np.ndarray, zeta, exponent: float = 0.0) -> np.ndarray:
    """Damping matrix with modal damping ratio(s) ``zeta`` in every mode of (K, M).

    C = M Phi diag(2 zeta_i w_i) Phi^T M with mass-normalised modes Phi (Phi^T M Phi = I), so
    Phi^T C Phi = diag(2 zeta_i w_i). Rigid-body/mechanism modes (w = 0) get no damping.

    Parameters
    ----------
    M, K : ndarray, shape (n, n)
    zeta : float or array_like, shape (n,) [-]
        One ratio for all modes, or one per mode in ascending frequency order.
    exponent : float [-]
        With it, mode i's ratio is ``zeta_i (w_i / w_1)^exponent`` (w_1 the lowest elastic
        mode's): damping that grows (or falls) with the mode's frequency.

    Returns
    -------
    ndarray, shape (n, n)
    """
    M = np.asarray(M, float)
    K = np.asarray(K, float)
    lam, phi = scipy.linalg.eigh(K, M)
    w = np.sqrt(np.clip(lam, 0.0, None))
    z = np.broadcast_to(np.asarray(zeta, float), w.shape)
    if exponent and np.any(w > 0):
        w1 = w[w > 0].min()
        z = z * (np.maximum(w, w1) / w1) ** exponent
    if np.any(z < 0):
        raise ValueError("`zeta` must be >= 0")
    Mphi = M @ phi
    C = (Mphi * (2 * z * w)) @ Mphi.T
    return 0.5 * (C + C.T)

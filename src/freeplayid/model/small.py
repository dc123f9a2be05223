"""Small freeplay models for tests, examples and sanity checks.

Both are translational lumped models under base excitation, so their base influence vector is
exactly the rigid-body vector (all ones) and the "absolute = relative + base" relation is exact.
"""

from __future__ import annotations

import numpy as np

from .system import FreeplaySystem

__all__ = ["sdof_system", "two_dof_system"]


def sdof_system(
    *, mass: float = 1.0, stiffness: float = 0.0, damping: float = 0.0
) -> FreeplaySystem:
    """Single-DOF freeplay oscillator on a moving base.

    ``m y'' + c y' + k y + f(y) = -m a_g`` with the freeplay spring f from the mass to the base
    (``hinge_pairs = [("x", "")]``: an empty inboard name means ground). With ``stiffness = 0`` the
    freeplay spring is the only spring and the exact backbone of docs/backbone.md applies:
    ``w(A) = w_n / (1 + 2 delta / (pi (A - delta)))`` with ``w_n = sqrt(kn / m)``.

    Parameters
    ----------
    mass : float [kg], > 0
    stiffness : float [N/m], >= 0
        Linear spring in parallel with the freeplay spring.
    damping : float [N s/m], >= 0
    """
    if mass <= 0:
        raise ValueError(f"`mass` must be > 0, got {mass!r}")
    if stiffness < 0 or damping < 0:
        raise ValueError("`stiffness` and `damping` must be >= 0")
    return FreeplaySystem(
        M=[[mass]],
        K=[[stiffness]],
        C=[[damping]],
        dof_names=("x",),
        hinge_pairs=(("x", ""),),
        base_influence=[1.0],
    )


def two_dof_system(
    *,
    m_in: float = 1.0,
    m_out: float = 0.5,
    k_in: float = 4.0e4,
    zeta: float = 0.02,
) -> FreeplaySystem:
    """Two-DOF lumped folding fin: inboard mass on a root spring, outboard mass on the hinge.

    DOFs ``uz_in`` (inboard fin, spring ``k_in`` to the base) and ``uz_out`` (outboard fin); the
    freeplay spring acts on ``uz_out - uz_in``. Damping is stiffness-proportional on the root
    spring only, ``c_in = 2 zeta sqrt(k_in m_in)``, so it does not depend on kn.

    Parameters
    ----------
    m_in, m_out : float [kg], > 0
    k_in : float [N/m], > 0
    zeta : float [-], >= 0
    """
    if min(m_in, m_out, k_in) <= 0 or zeta < 0:
        raise ValueError("`m_in`, `m_out`, `k_in` must be > 0 and `zeta` >= 0")
    c_in = 2.0 * zeta * np.sqrt(k_in * m_in)
    return FreeplaySystem(
        M=np.diag([m_in, m_out]),
        K=[[k_in, 0.0], [0.0, 0.0]],
        C=[[c_in, 0.0], [0.0, 0.0]],
        dof_names=("uz_in", "uz_out"),
        hinge_pairs=(("uz_out", "uz_in"),),
        base_influence=[1.0, 1.0],
    )

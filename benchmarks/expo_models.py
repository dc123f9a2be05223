"""A Rayleigh-damped 15-DOF beam-like fin for the exponential-engine benchmarks.

Inboard part: 5 lumped masses in a chain clamped to the base; outboard part: 10 masses in a
chain, its root joined to the inboard tip by the freeplay spring (open hinge: a mechanism). The
outboard tip masses are light and stiffly joined, so the top mode is above 40 kHz, and Rayleigh
damping (2 % at 30 and 50 Hz, on the open-hinge stiffness: classical, diagonal in the modal
basis) makes every mode above a few kHz overdamped (zeta ~ f / 2 kHz), the case that forces RK4
to a sub-microsecond step. kn closes the first mode to ~50 Hz.
"""

from __future__ import annotations

import numpy as np


def beam_fin():
    """(system, channels, kn [N/m], delta [m]) of the beam-like fin."""
    from freeplayid.model import FreeplaySystem, rayleigh_damping

    m_in = np.full(5, 0.2)  # kg
    k_in = np.full(5, 2e6)  # N/m, base -> in0 -> ... -> in4
    m_out = np.array([0.1, 0.1, 0.08, 0.06, 0.05, 0.04, 0.03, 0.02, 0.005, 0.0003])  # kg
    k_out = np.array([3e6, 3e6, 2e6, 2e6, 1.5e6, 1.5e6, 1e6, 2e7, 3e7])  # N/m, out_i -> out_i+1
    n = 15
    names = [f"in{i}" for i in range(5)] + [f"out{i}" for i in range(10)]
    M = np.diag(np.concatenate([m_in, m_out]))
    K = np.zeros((n, n))
    for i, k in enumerate(k_in):  # spring i between node i-1 (base for i = 0) and node i
        K[i, i] += k
        if i > 0:
            K[i - 1, i - 1] += k
            K[i - 1, i] -= k
            K[i, i - 1] -= k
    for i, k in enumerate(k_out):
        a, b = 5 + i, 6 + i
        K[a, a] += k
        K[b, b] += k
        K[a, b] -= k
        K[b, a] -= k
    C = rayleigh_damping(M, K, f1=30.0, f2=50.0, zeta=0.02)
    system = FreeplaySystem(M=M, K=K, dof_names=names, hinge_pairs=(("out0", "in4"),), C=C,
                            base_influence=np.ones(n))
    kn = float(1.16 * m_out.sum() * (2 * np.pi * 50.0) ** 2)
    return system, ("out9", "out4"), kn, 8e-4


if __name__ == "__main__":
    from freeplayid.simulate import build_modal_form
    from freeplayid.simulate.engines.expo.steps import closed_hinge_hz

    s, ch, kn, d = beam_fin()
    f = build_modal_form(s, channels=ch, quantity="acceleration", frame="relative", kn_max=kn)
    print("open Hz", np.round(np.sqrt(f.lam) / 2 / np.pi, 1))
    print("closed Hz", np.round(closed_hinge_hz(f, kn), 1))
    print("omega_max Hz", f.omega_max / 2 / np.pi, "diag", f.c_diagonal, "kn", kn)

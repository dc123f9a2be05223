"""ACM plate element against published plate frequencies (Leissa) and its own mesh convergence."""

import numpy as np
import pytest

from freeplayid.model import modal_analysis
from freeplayid.model.fin.plate import (
    acm_element,
    assemble_plate,
    flexural_rigidity,
    rectangular_mesh,
)

# Cantilever (CFFF) square plate, nu = 0.3: lambda = omega a^2 sqrt(rho h / D), first 5 modes.
# A. W. Leissa, "The free vibration of rectangular plates", J. Sound Vib. 31(3) 257-293 (1973),
# Ritz with 36 beam-function terms; the same five values are the reference of Code_Aster test
# SDLS01 (manual V2.03.001, after M. V. Barton, J. Appl. Mech. 18, 129-134, 1951).
LEISSA_CFFF = np.array([3.492, 8.525, 21.43, 27.33, 31.11])
E, NU, RHO, H, A = 2.1e11, 0.3, 7800.0, 0.01, 1.0


def _cantilever_lambdas(n: int) -> np.ndarray:
    mesh = rectangular_mesh(width=A, height=A, nx=n, ny=n)
    K, M = assemble_plate(mesh, E=E, nu=NU, rho=RHO, thickness=H)
    fixed = np.concatenate([3 * mesh.edge_nodes("bottom") + k for k in range(3)])
    free = np.setdiff1d(np.arange(mesh.n_dof), fixed)
    modes = modal_analysis(M[free][:, free], K[free][:, free], n_modes=5, sparse=True)
    return modes.omega * A**2 * np.sqrt(RHO * H / flexural_rigidity(E, H, NU))


def test_cantilever_square_plate_matches_leissa():
    lam = _cantilever_lambdas(16)
    np.testing.assert_allclose(lam, LEISSA_CFFF, rtol=0.02)


def test_cantilever_plate_mesh_convergence():
    lams = [_cantilever_lambdas(n) for n in (4, 8, 16, 32)]
    steps = [np.max(np.abs(lams[k + 1] / lams[k] - 1)) for k in range(3)]
    # successive changes shrink (roughly O(h^2) for the ACM element) and end tiny
    assert steps[0] > steps[1] > steps[2]
    assert steps[2] < 2e-3
    assert steps[1] / steps[2] > 2.5


def test_element_rigid_modes_and_patch():
    Ke, Me = acm_element(0.3, 0.2, E=E, nu=NU, rho=RHO, thickness=H)
    np.testing.assert_allclose(Ke, Ke.T, atol=1e-9 * np.abs(Ke).max())
    w = np.linalg.eigvalsh(Ke)
    assert np.all(np.abs(w[:3]) < 1e-9 * w[-1]) and w[3] > 1e-6 * w[-1]  # exactly 3 rigid modes
    assert np.all(np.linalg.eigvalsh(Me) > 0)
    # rigid translation: total mass; rigid rotation w = y: rotary moment of inertia of the plate
    xy = np.array([(-0.15, -0.1), (0.15, -0.1), (0.15, 0.1), (-0.15, 0.1)])
    ut = np.tile([1.0, 0.0, 0.0], 4)
    ur = np.concatenate([[y, 1.0, 0.0] for _, y in xy])  # w = y, theta_x = dw/dy = 1
    mass = RHO * H * 0.3 * 0.2
    assert ut @ Me @ ut == pytest.approx(mass, rel=1e-12)
    assert ur @ Me @ ur == pytest.approx(mass * 0.2**2 / 12, rel=1e-12)
    assert np.abs(Ke @ ut).max() < 1e-6 and np.abs(Ke @ ur).max() < 1e-6
    # constant curvature w = x^2/2: energy D/2 * area exactly (patch test)
    uc = np.concatenate([[x * x / 2, 0.0, -x] for x, _ in xy])
    D = flexural_rigidity(E, H, NU)
    assert 0.5 * uc @ Ke @ uc == pytest.approx(0.5 * D * 0.3 * 0.2, rel=1e-10)


def test_plate_input_errors():
    with pytest.raises(ValueError, match="`thickness`"):
        acm_element(0.1, 0.1, E=E, nu=NU, rho=RHO, thickness=0.0)
    with pytest.raises(ValueError, match="`nu`"):
        acm_element(0.1, 0.1, E=E, nu=0.5, rho=RHO, thickness=H)
    with pytest.raises(ValueError, match="`nx`"):
        rectangular_mesh(width=1.0, height=1.0, nx=0, ny=2)
    with pytest.raises(ValueError, match="`edge`"):
        rectangular_mesh(width=1.0, height=1.0, nx=2, ny=2).edge_nodes("north")

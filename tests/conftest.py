"""Shared fixtures: a stand-in for the default fin until ``freeplayid.model.default_fin`` lands,
and Lightning's info lines kept out of the inverse model's tests."""

import logging

import numpy as np
import pytest

from freeplayid.model import FreeplaySystem, modal_damping

FIN_DOFS = (
    "uz_top_left", "uz_lower_right", "rx_left_in", "rx_left_out", "rx_mid_in", "rx_mid_out",
    "q1", "q2", "q3", "q4", "q5", "q6",
)
KN_PAPER = 2.35e6  # N m/rad
DELTA_PAPER = 3e-3  # rad
UZ_SCALE = 0.01  # uz rows of the open modes [m per modal unit]


def standin_fin(*, seed: int = 0, dense_damping: bool = True) -> FreeplaySystem:
    """Random 12-DOF reduced-like fin: open-hinge mechanism, two hinge springs, 20 Hz - 3 kHz.

    Built from chosen open-hinge modes Phi (M = Phi^-T Phi^-1, K = Phi^-T diag(w^2) Phi^-1) so that
    the hinge rotations of each mode, D = Phi^T B, are chosen too: the mechanism mode closes to
    ~55 Hz at the paper's kn, the others couple weakly. 2 % damping on the closed-hinge modes
    (dense in the open basis) or, with ``dense_damping=False``, on the open modes.
    """
    rng = np.random.default_rng(seed)
    n = len(FIN_DOFS)
    f_open = np.array([0.0, 20, 90, 160, 300, 480, 700, 1000, 1400, 1900, 2400, 3000])
    w = 2 * np.pi * f_open
    Phi = rng.normal(size=(n, n))
    Phi[:2] *= UZ_SCALE
    Phi[2:6] *= 0.2  # hinge rotations [rad per modal unit]
    d0 = np.sqrt((2 * np.pi * 55.0) ** 2 / (2 * KN_PAPER))
    d = d0 * np.column_stack([0.15 * rng.normal(size=n), 0.15 * rng.normal(size=n)])
    d[0] = d0
    i = {s: k for k, s in enumerate(FIN_DOFS)}
    Phi[i["rx_left_out"]] = Phi[i["rx_left_in"]] + d[:, 0]
    Phi[i["rx_mid_out"]] = Phi[i["rx_mid_in"]] + d[:, 1]
    Pinv = np.linalg.inv(Phi)
    M = Pinv.T @ Pinv
    K = Pinv.T @ np.diag(w**2) @ Pinv
    r = np.zeros(n)
    r[[i["uz_top_left"], i["uz_lower_right"]]] = 1.0
    hinges = (("rx_left_out", "rx_left_in"), ("rx_mid_out", "rx_mid_in"))
    sys0 = FreeplaySystem(M=M, K=K, dof_names=FIN_DOFS, hinge_pairs=hinges, base_influence=r)
    C = modal_damping(M, sys0.closed_stiffness(KN_PAPER) if dense_damping else K, 0.02)
    # scale the base influence so that 0.6 g drives the closed-hinge resonance to ~4 delta
    B = sys0.hinge_matrix()
    wr = 2 * np.pi * 55.0
    H = np.linalg.solve(sys0.closed_stiffness(KN_PAPER) - wr**2 * M + 1j * wr * C, -M @ r)
    theta = np.max(np.abs(B.T @ H)) * 0.6 * 9.80665
    return sys0.replace(C=C, base_influence=r * 4 * DELTA_PAPER / theta)


@pytest.fixture(scope="session")
def fin():
    return standin_fin()


@pytest.fixture
def quiet_lightning(caplog):
    """Lightning's "GPU available: ..." and "`Trainer.fit` stopped: ..." info lines off; its
    warnings still show (``pytestmark = pytest.mark.usefixtures("quiet_lightning")``)."""
    caplog.set_level(logging.WARNING, logger="pytorch_lightning")
    caplog.set_level(logging.WARNING, logger="lightning_fabric")

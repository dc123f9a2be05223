import numpy as np
import pytest
import scipy.integrate
import torch

from freeplayid.model import describing_function, freeplay_force, gap_ratio, kappa_of_ratio


def test_force_branches_numpy():
    theta = np.array([-0.01, -0.003, 0.0, 0.002, 0.003, 0.01])
    f = freeplay_force(theta, 2.0e6, 0.003)
    expected = 2.0e6 * np.array([-0.007, 0.0, 0.0, 0.0, 0.0, 0.007])
    np.testing.assert_allclose(f, expected, atol=1e-9)


def test_force_torch_matches_numpy_and_broadcasts():
    theta = torch.linspace(-0.02, 0.02, 101, dtype=torch.float64)[None, :]
    kn = torch.tensor([[1.0e6], [3.0e6]], dtype=torch.float64)
    delta = torch.tensor([[0.001], [0.004]], dtype=torch.float64)
    f = freeplay_force(theta, kn, delta)
    assert isinstance(f, torch.Tensor) and f.shape == (2, 101)
    ref = freeplay_force(theta.numpy(), kn.numpy(), delta.numpy())
    np.testing.assert_allclose(f.numpy(), ref, rtol=1e-15)


def test_zero_gap_is_linear():
    theta = np.linspace(-1, 1, 7)
    np.testing.assert_allclose(freeplay_force(theta, 5.0, 0.0), 5.0 * theta)
    np.testing.assert_allclose(describing_function(np.array([0.1, 3.0]), 0.0), [1.0, 1.0])


def test_negative_gap_rejected():
    with pytest.raises(ValueError, match="delta"):
        freeplay_force(0.1, 1.0, -0.01)
    with pytest.raises(ValueError, match="delta"):
        describing_function(0.1, -0.01)


@pytest.mark.parametrize("ratio", [1.0001, 1.05, 1.2, 1.5, 2.0, 3.0, 10.0, 1e3])
def test_describing_function_matches_quadrature(ratio):
    # first Fourier cosine coefficient of f(Theta cos phi), divided by kn * Theta
    delta, kn = 0.003, 2.35e6
    amp = ratio * delta

    def integrand(phi):
        return freeplay_force(amp * np.cos(phi), kn, delta) * np.cos(phi)

    # split at the contact angles so the quadrature sees smooth pieces
    pc = np.arccos(min(delta / amp, 1.0))
    pts = [0.0, pc, np.pi - pc, np.pi + pc, 2 * np.pi - pc, 2 * np.pi]
    total = sum(
        scipy.integrate.quad(integrand, a, b, epsabs=1e-14, epsrel=1e-13)[0]
        for a, b in zip(pts[:-1], pts[1:])
    )
    kappa_num = total / (np.pi * amp) / kn
    assert abs(describing_function(amp, delta) - kappa_num) < 1e-6


def test_describing_function_limits_and_monotone():
    amp = np.geomspace(1.0, 1e4, 400)
    k = describing_function(amp, 1.0)
    assert k[0] == 0.0
    assert np.all(np.diff(k) > 0)
    assert 1 - k[-1] < 4 / np.pi * 1e-4 * 1.01  # kappa ~ 1 - 4 r / pi
    assert describing_function(0.5, 1.0) == 0.0


def test_gap_ratio_inverts_kappa():
    r = np.concatenate([[0.0, 1.0], np.linspace(1e-6, 1 - 1e-9, 500)])
    np.testing.assert_allclose(gap_ratio(kappa_of_ratio(r)), r, atol=2e-6)
    k = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(kappa_of_ratio(gap_ratio(k)), k, atol=1e-13)
    with pytest.raises(ValueError):
        gap_ratio(1.5)

"""The compiled record assembly (simulate/assemble.py) against a numpy reference."""

import numpy as np
import pytest

pytest.importorskip("numba")

from freeplayid.simulate.assemble import assemble_record  # noqa: E402


def _differentiate(x, dt, order):
    """Reference: 5-point central stencils inside, np.gradient at the two samples of each end."""
    d = np.gradient(x, dt, axis=-1)
    if order == 2:
        d = np.gradient(d, dt, axis=-1)
    if x.shape[-1] < 5:
        return d
    xm2, xm1, x0, xp1, xp2 = (x[..., k: x.shape[-1] - 4 + k] for k in range(5))
    if order == 1:
        d[..., 2:-2] = (xm2 - 8.0 * xm1 + 8.0 * xp1 - xp2) / (12.0 * dt)
    else:
        d[..., 2:-2] = (-xm2 + 16.0 * xm1 - 30.0 * x0 + 16.0 * xp1 - xp2) / (12.0 * dt * dt)
    return d


def _reference(rec, n_out, batch, C, order, fs, bc, sc, base, lev):
    y = rec[:n_out, :, :batch].transpose(2, 1, 0).astype(float)
    out = y[:, :C].copy()
    if order:
        out += _differentiate(y[:, C:], 1.0 / fs, order)
    out += lev[:, None, None] * (bc[None, :, None] * base[0, :n_out]
                                 + sc[None, :, None] * base[1, :n_out])
    return out


# (order, n_out): np.gradient needs order + 1 samples; 3-4 samples use no 5-point stencil
CASES = [(0, 1), (0, 200)] + [(o, n) for o in (1, 2) for n in (3, 4, 5, 6, 200)]


@pytest.mark.parametrize(("order", "n_out"), CASES)
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_assemble_matches_numpy(order, n_out, dtype):
    rng = np.random.default_rng(order * 1000 + n_out)
    C, batch, padded = 2, 37, 64
    width = C * (2 if order else 1)
    t = np.arange(n_out + 3) / 100.0
    # smooth fast part (its derivatives are large against the main part at 100 Hz sampling)
    rec = rng.normal(size=(n_out + 3, width, padded))
    rec[:, C:] = np.sin(2 * np.pi * 3.0 * t)[:, None, None] * rng.normal(size=(1, width - C,
                                                                           padded))
    rec = rec.astype(dtype)
    bc, sc = rng.normal(size=C), rng.normal(size=C)
    base = rng.normal(size=(2, n_out + 1))
    lev = rng.uniform(0.1, 1.0, batch)
    got = assemble_record(rec, n_out=n_out, batch=batch, channels=C, order=order,
                          sample_rate=100.0, base_coef=bc, static_coef=sc, base=base,
                          level_g=lev)
    assert got.shape == (batch, C, n_out) and got.dtype == dtype
    want = _reference(rec, n_out, batch, C, order, 100.0, bc, sc, base, lev)
    tol = 1e-6 if dtype == np.float32 else 1e-12
    np.testing.assert_allclose(got, want, rtol=tol, atol=tol * np.abs(want).max())


def test_assemble_rejects_bad_width():
    rec = np.zeros((10, 3, 64))
    with pytest.raises(ValueError, match="width 3"):
        assemble_record(rec, n_out=10, batch=4, channels=2, order=2, sample_rate=1.0,
                        base_coef=[0, 0], static_coef=[0, 0], base=np.zeros((2, 10)),
                        level_g=np.ones(4))

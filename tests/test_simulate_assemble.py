"""The numba engines' output path: the derivative taps of the fused FIR
(resample.derivative_taps) and the in-place base terms (simulate/assemble.py)."""

import math

import numpy as np
import pytest
import torch

from freeplayid.simulate import StreamingDecimator, design_decimator
from freeplayid.simulate.resample import derivative_taps


# ----------------------------------------------------------------------------- derivative taps
def _fir(x, taps, m):
    """Output k = sum_i taps[i] x[k m + i - K m] where every index is inside x (reference)."""
    half = (len(taps) - 1) // 2
    ks = np.arange(half // m + 1, (len(x) - 1 - half) // m)
    return ks, np.array([taps @ x[k * m - half: k * m + half + 1] for k in ks])


@pytest.mark.parametrize("m", [1, 2, 3, 6])
@pytest.mark.parametrize("order", [1, 2])
def test_derivative_taps_differentiate_the_decimated_signal(m, order):
    fs_out = 2048.0
    h = 1.0 / (m * fs_out)
    taps = design_decimator(m)
    padded, td = derivative_taps(taps, m, h, order)
    pad = m * math.ceil(2 / m)
    assert len(padded) == len(td) == len(taps) + 2 * pad
    assert (len(padded) - 1) % (2 * m) == 0  # still 2 K m + 1 taps
    np.testing.assert_array_equal(padded[pad:-pad], taps)
    t = np.arange(4000) * h
    for f in (40.0, 300.0):  # in the pass band (up to 0.3 fs_out)
        w = 2 * np.pi * f
        x = np.sin(w * t + 0.3)
        ks, y = _fir(x, td, m)
        tk = ks * m * h
        want = (w * np.cos(w * tk + 0.3) if order == 1 else -w * w * np.sin(w * tk + 0.3))
        # pass-band ripple ~1e-6 and the stencil's (w h)^4 / 30 (first) or / 90 (second)
        bound = 3e-6 + (w * h) ** 4 / (30 if order == 1 else 90)
        assert np.abs(y - want).max() <= bound * w**order, (f, np.abs(y - want).max() / w**order)
        # the zero padding leaves the signal's own outputs as they were
        ks0, y0 = _fir(x, taps, m)
        ks1, y1 = _fir(x, padded, m)
        common = np.intersect1d(ks0, ks1)
        np.testing.assert_allclose(y1[np.isin(ks1, common)], y0[np.isin(ks0, common)],
                                   rtol=0, atol=1e-14)


def test_derivative_taps_of_the_pre_history_match_the_streaming_decimator():
    # the fused FIR continues the signal before t = 0 by its first value, as StreamingDecimator
    # does: the derivative filter of a signal that starts at rest is that of the decimator
    m, h = 2, 1.0 / 4096
    taps = design_decimator(m)
    padded, td = derivative_taps(taps, m, h, 2)
    t = np.arange(3000) * h
    x = np.where(t > 0.03, np.sin(2 * np.pi * 50 * (t - 0.03)) ** 3, 0.0) + 0.7
    dec = StreamingDecimator(td, m, dtype=torch.float64, device="cpu")
    y = dec.push(torch.from_numpy(x[None])).numpy()[0]
    assert np.abs(y[:8]).max() < 1e-9 * np.abs(y).max()  # at rest: no derivative
    ks, y_ref = _fir(x, td, m)
    np.testing.assert_allclose(y[ks], y_ref, rtol=0, atol=1e-9 * np.abs(y_ref).max())


def test_derivative_taps_reject_bad_arguments():
    taps = design_decimator(2)
    for kw, word in (({"order": 3}, "order"), ({"factor": 0}, "factor"), ({"h": -1.0}, "h")):
        args = {"factor": 2, "h": 1e-4, "order": 2, **kw}
        with pytest.raises(ValueError, match=word):
            derivative_taps(taps, **args)


# ----------------------------------------------------------------------------- base terms
pytest.importorskip("numba")
from freeplayid.simulate.assemble import add_base_terms  # noqa: E402


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("n", [1, 7, 300])
def test_add_base_terms_matches_numpy(dtype, n):
    rng = np.random.default_rng(n)
    batch, C = 37, 3
    y0 = rng.normal(size=(batch, C, n)).astype(dtype)
    bc, sc = rng.normal(size=C), rng.normal(size=C)
    base = rng.normal(size=(2, n + 4))
    lev = rng.uniform(0.1, 1.0, batch)
    want = y0.astype(float) + lev[:, None, None] * (bc[None, :, None] * base[0, :n]
                                                     + sc[None, :, None] * base[1, :n])
    y = y0.copy()
    got = add_base_terms(y, base_coef=bc, static_coef=sc, base=base, level_g=lev)
    assert got is y and y.dtype == dtype
    # float64 sum, rounded once
    np.testing.assert_array_equal(y, want.astype(dtype))


def test_add_base_terms_zero_coefficients_leave_y_alone_and_bad_shapes_raise():
    y = np.arange(24.0).reshape(2, 3, 4)
    add_base_terms(y, base_coef=np.zeros(3), static_coef=np.zeros(3), base=np.ones((2, 4)),
                   level_g=np.ones(2))
    np.testing.assert_array_equal(y, np.arange(24.0).reshape(2, 3, 4))
    with pytest.raises(ValueError, match="coefficients"):
        add_base_terms(y, base_coef=np.ones(2), static_coef=np.ones(3), base=np.ones((2, 4)),
                       level_g=np.ones(2))
    with pytest.raises(ValueError, match="base"):
        add_base_terms(y, base_coef=np.ones(3), static_coef=np.ones(3), base=np.ones((2, 3)),
                       level_g=np.ones(2))
    with pytest.raises(ValueError, match="C-contiguous"):
        add_base_terms(y[:, :, ::2], base_coef=np.ones(3), static_coef=np.ones(3),
                       base=np.ones((2, 4)), level_g=np.ones(2))

"""Tests of freeplayid.signal: ACMP, lock-in, Eq. 9, peak/jump detection and rejections.

References: synthetic chirps with a known envelope and frequency law, dense solves of the banded
systems, and a self-contained RK4 of the SDOF freeplay oscillator under a base sweep whose exact
backbone is known (docs/backbone.md): w(A) = w_n / (1 + 2 delta / (pi (A - delta))).
"""

import importlib
import math

import numpy as np
import pytest
import scipy.signal

from freeplayid.quantity import G
from freeplayid.signal import (
    REASON_EDGE,
    REASON_NO_JUMP,
    REASON_NOISY,
    acmp,
    add_noise_for_snr,
    bandwidth_weight,
    extract_backbone_points,
    find_jump_peak,
    lockin,
    narrowest_bandwidth,
    noise_floor,
    ridge_frequency,
    to_displacement,
    white_noise,
)
from freeplayid.signal.banded import (
    demodulate,
    smooth_pair_into,
    smooth_second_difference,
    smoothing_factor,
)
from freeplayid.sweep import Sweep
from lockin_reference import numpy_lockin
from sdof_reference import DELTA, FS, ZETA, exact_backbone_hz, simulate_sdof_sweep

RATE = 0.2  # [Hz/s] test sweep rate (paper: 0.1)
LEVELS = (0.3, 0.6, 1.0)  # [g]; 0.3 g stays in the gap: a_g / w^2 < delta from 30 Hz on


@pytest.fixture(scope="module")
def sweep():
    return Sweep(30.0, 50.0, RATE)


@pytest.fixture(scope="module")
def sdof_runs(sweep):
    """dict quantity -> (runs, 1, T) relative responses, plus 'base' (runs, T)."""
    sims = [simulate_sdof_sweep(level, sweep) for level in LEVELS]
    out = {q: np.stack([s[i][None, :] for s in sims]) for i, q in
           enumerate(("displacement", "velocity", "acceleration"))}
    out["base"] = np.stack([s[3] for s in sims])
    return out


RUNS = [f"{lv:.1f}g" for lv in LEVELS]


# --- banded operators against dense references --------------------------------------------------


def _dense_d(n):
    d = np.zeros((n - 2, n))
    for k in range(n - 2):
        d[k, k : k + 3] = (1.0, -2.0, 1.0)
    return d


def test_demodulate_matches_dense_solve():
    rng = np.random.default_rng(0)
    n, alpha = 40, 0.05
    x, phase = rng.normal(size=n), np.cumsum(rng.uniform(0.1, 0.5, size=n))
    d = _dense_d(n)
    k = np.hstack([np.diag(np.cos(phase)), np.diag(np.sin(phase))])
    phi = np.kron(np.eye(2), d)
    y = np.linalg.solve(phi.T @ phi / alpha + k.T @ k, k.T @ x)
    u, v = demodulate(x, phase, alpha)
    np.testing.assert_allclose(np.concatenate([u, v]), y, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("n", [4, 5, 8, 41, 5_000])
def test_demodulate_is_the_band_factored_then_solved_to_the_bit(n):
    # the one-pass demodulation (assembly ahead of the factorisation, the forward solve behind
    # it) against its composition: the band assembled in numpy from the docstring's matrix,
    # cholesky_banded, solve_factored; the same operations in the same order, so the same bits
    # (and against LAPACK within rounding)
    from scipy.linalg import solveh_banded

    from freeplayid.signal.banded import cholesky_banded, second_difference_gram, solve_factored

    rng = np.random.default_rng(n)
    x, phase = rng.normal(size=n), np.cumsum(rng.uniform(0.1, 0.5, size=n))
    alpha = 0.5 if n < 8 else 0.05
    p0, p1, p2 = second_difference_gram(n)
    c, s_ = np.cos(phase), np.sin(phase)
    ab = np.zeros((5, 2 * n))  # upper form: ab[4 + i - j, j] = A[i, j], y = [u0, v0, u1, ...]
    inv = 1.0 / alpha
    ab[4, 0::2], ab[4, 1::2] = c * c + inv * p0, s_ * s_ + inv * p0
    ab[3, 1::2] = c * s_
    ab[2, 2::2] = ab[2, 3::2] = inv * p1
    ab[0, 4::2] = ab[0, 5::2] = inv * p2
    rhs = np.empty(2 * n)
    rhs[0::2], rhs[1::2] = c * x, s_ * x
    y = solve_factored(cholesky_banded(ab.copy()), rhs)
    u, v = demodulate(x, phase, alpha)
    assert np.array_equal(u, y[0::2]) and np.array_equal(v, y[1::2])
    ref = solveh_banded(ab, rhs)
    np.testing.assert_allclose(np.concatenate([u, v]), np.concatenate([ref[0::2], ref[1::2]]),
                               rtol=1e-9, atol=1e-12 * np.max(np.abs(ref)))


def test_smoothing_matches_dense_and_passes_lines():
    rng = np.random.default_rng(1)
    n, beta = 30, 0.01
    z = rng.normal(size=n)
    d = _dense_d(n)
    np.testing.assert_allclose(
        smooth_second_difference(z, beta), np.linalg.solve(d.T @ d / beta + np.eye(n), z),
        rtol=1e-10,
    )
    line = 3.0 + 0.2 * np.arange(n)
    np.testing.assert_allclose(smooth_second_difference(line, 1e-6), line, rtol=1e-8)


def test_smooth_pair_is_the_dense_solve_of_each():
    rng = np.random.default_rng(5)
    for n in (3, 4, 57):
        zr, zi = rng.normal(size=n), rng.normal(size=n)
        d = _dense_d(n)
        a = d.T @ d / 0.05 + np.eye(n)
        ar, ai = zr.copy(), zi.copy()
        smooth_pair_into(smoothing_factor(n, 0.05), ar, ai)
        np.testing.assert_allclose(ar, np.linalg.solve(a, zr), rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(ai, np.linalg.solve(a, zi), rtol=1e-10, atol=1e-12)


def test_smoothing_factor_kept_per_length_and_weight():
    # the kept factor is keyed by (N, beta): other weights and lengths after it stay exact
    rng = np.random.default_rng(2)
    for n, beta in ((30, 0.01), (30, 0.2), (31, 0.01), (30, 0.01)):
        z = rng.normal(size=n)
        d = _dense_d(n)
        np.testing.assert_allclose(smooth_second_difference(z, beta),
                                   np.linalg.solve(d.T @ d / beta + np.eye(n), z), rtol=1e-10)


def _numpy_pursuit(x, f, fsd, *, alpha, alpha_min, beta, adapt, tol, max_iter, step=None):
    """The pursuit's loop written with the numpy operators checked above against dense solves
    (the module's phase rule, np.gradient): the reference of the compiled loop. ``step(df,
    a2)``: the increment's smoothing (default every sample alike, P / beta + I)."""
    phase = importlib.import_module("freeplayid.signal.acmp")._phase
    prev, converged, it = None, False, 0
    for it in range(1, max_iter + 1):  # noqa: B007
        phi = phase(f, fsd)
        u, v = demodulate(x, phi, alpha)
        xm = u * np.cos(phi) + v * np.sin(phi)
        du, dv = np.gradient(u) * fsd, np.gradient(v) * fsd
        a2 = u * u + v * v
        df = (v * du - u * dv) / (2 * np.pi * np.maximum(a2, 1e-300))
        smoothed = smooth_second_difference(df, beta) if step is None else step(df, a2)
        f = np.clip(f + smoothed, 1e-6 * fsd, 0.5 * fsd)
        if adapt and float(xm @ x) > 0:
            alpha = max(alpha_min, min(alpha * float(xm @ xm) / float(xm @ x), alpha))
        if prev is not None and float(np.sum((xm - prev) ** 2)) / float(prev @ prev) < tol:
            converged = True
            break
        prev = xm
    return f, alpha, it, converged


@pytest.mark.parametrize("adapt", [True, False])
def test_compiled_pursuit_is_the_numpy_composition(adapt):
    # a chirp through a resonance-like amplitude bump, noise, a wrong start: several iterations
    acmp_module = importlib.import_module("freeplayid.signal.acmp")
    fs = 200.0
    t = np.arange(int(30 * fs)) / fs
    amp = 1.0 + 2.0 * np.exp(-(((t - 18.0) / 3.0) ** 2))
    x = amp * np.sin(2 * np.pi * (20 * t + 0.25 * t * t)) \
        + 0.2 * np.random.default_rng(4).normal(size=t.size)
    f0 = 20.3 + 0.48 * t
    opts = {"alpha": acmp_module.bandwidth_weight(2.0, fs),
            "alpha_min": acmp_module.bandwidth_weight(0.5, fs),
            "beta": acmp_module.bandwidth_weight(1.0, fs), "adapt": adapt, "tol": 1e-8,
            "max_iter": 40}
    f, alpha, it, converged = acmp_module._pursue(x, f0.copy(), fs, **opts)
    f_ref, alpha_ref, it_ref, converged_ref = _numpy_pursuit(x, f0.copy(), fs, **opts)
    assert it > 3 and (it, converged) == (it_ref, converged_ref)
    assert alpha == pytest.approx(alpha_ref, rel=1e-9)
    np.testing.assert_allclose(f, f_ref, rtol=0, atol=1e-9)
    assert np.median(np.abs(f - (20 + 0.5 * t))) < 0.05  # and it pursued the chirp


def _weighted_step(df, a2, beta, span):
    """The locally weighted smoothing of the frequency increment, from scipy alone: weights
    a^2 / (max of a^2 within +-span samples), (P / beta + W) s = W df solved by LAPACK."""
    import scipy.linalg
    import scipy.ndimage

    n = df.shape[0]
    w = np.maximum(a2 / scipy.ndimage.maximum_filter1d(a2, 2 * span + 1, mode="nearest"), 1e-9)
    d = np.diff(np.eye(n), 2, axis=0)
    p = d.T @ d / beta + np.diag(w)
    ab = np.zeros((3, n))
    for m in range(3):
        ab[2 - m, m:] = np.diag(p, m)
    return scipy.linalg.solveh_banded(ab, w * df)


def test_compiled_weighted_pursuit_is_the_scipy_composition():
    # a chirp whose amplitude collapses, then a free transient at another frequency: the
    # weights matter; the compiled loop (running maximum, banded factor) against scipy's
    acmp_module = importlib.import_module("freeplayid.signal.acmp")
    fs = 100.0
    t = np.arange(int(12 * fs)) / fs
    x = np.where(t < 7.0, 1.0 + 0.1 * t, 0.05) * np.sin(2 * np.pi * (10 * t + 0.25 * t * t))
    ta = t[t >= 7.0] - 7.0
    x[t >= 7.0] += np.exp(-ta * 2.0) * np.sin(2 * np.pi * 8.0 * ta)
    x += 0.01 * np.random.default_rng(5).normal(size=t.size)
    f0 = 10.2 + 0.5 * t
    opts = {"alpha": acmp_module.bandwidth_weight(2.0, fs),
            "beta": acmp_module.bandwidth_weight(1.0, fs), "tol": 1e-8, "max_iter": 30}
    f, _, it, converged = acmp_module._pursue(x, f0.copy(), fs, alpha_min=opts["alpha"],
                                              adapt=False, span=37, **opts)
    f_ref, _, it_ref, converged_ref = _numpy_pursuit(
        x, f0.copy(), fs, alpha_min=opts["alpha"], adapt=False,
        step=lambda df, a2: _weighted_step(df, a2, opts["beta"], 37), **opts)
    assert it > 3 and (it, converged) == (it_ref, converged_ref)
    np.testing.assert_allclose(f, f_ref, rtol=0, atol=1e-7)
    plain, *_ = acmp_module._pursue(x, f0.copy(), fs, alpha_min=opts["alpha"], adapt=False,
                                    **opts)
    assert np.max(np.abs(plain - f)) > 1e-3  # the weights changed the pursuit


@pytest.mark.parametrize(("n", "h"), [(1000, 7), (50, 30), (13, 1), (999, 0), (720, 100)])
def test_running_max_is_scipys(n, h):
    import scipy.ndimage

    acmp_module = importlib.import_module("freeplayid.signal.acmp")
    a = np.random.default_rng(n + h).random(n)
    out = acmp_module._running_max(a, h, np.empty(n), np.empty(n), np.empty(n))
    np.testing.assert_array_equal(out, scipy.ndimage.maximum_filter1d(a, 2 * h + 1,
                                                                      mode="nearest"))


def _drop_record(fs=256.0, drop_s=100.0):
    """A 30 -> 46 Hz, 0.1 Hz/s sweep's response whose amplitude grows to the drop, then falls
    to 1 % of it under a decaying free vibration at 41 Hz (3 % damped), 0.02 of noise: the
    shape of a freeplay jump. (record, fs, sweep, the forced amplitude per sample)"""
    t = np.arange(int(160 * fs)) / fs
    amp = np.where(t < drop_s, 1.0 + 0.04 * t, 0.05)
    x = amp * np.sin(2 * np.pi * (30.0 * t + 0.05 * t * t))
    after = t >= drop_s
    ta = t[after] - drop_s
    x[after] += (1.0 + 0.04 * drop_s) * np.exp(-ta * 2 * np.pi * 41.0 * 0.03) \
        * np.sin(2 * np.pi * 41.0 * ta)
    x += 0.02 * np.random.default_rng(3).normal(size=t.size)
    return x, fs, Sweep(30.0, 46.0, 0.1), amp


def test_local_if_weighting_converges_through_a_drop():
    # the plain pursuit chases the free transient after the drop and never settles: where it
    # stops moves the mode (measured here: by 56 % between 100 and 400 iterations); the locally
    # weighted one converges, the same at any larger max_iter, and reads the forced amplitude
    # before the drop as the plain one does (the analytic amplitude, within the smoothing of
    # the drop by the demodulation filter)
    x, fs, sweep, amp = _drop_record()
    k = int(99.0 * fs)  # one second before the drop
    plain = [acmp(x, fs, sweep=sweep, bandwidth_hz=1.0, max_iter=m, if_weighting="none")
             for m in (100, 400)]
    local = [acmp(x, fs, sweep=sweep, bandwidth_hz=1.0, max_iter=m) for m in (100, 400)]
    assert not plain[0].converged
    assert np.max(np.abs(plain[1].amplitude / plain[0].amplitude - 1)) > 0.1
    assert local[0].converged and local[0].iterations < 100
    np.testing.assert_array_equal(local[1].amplitude, local[0].amplitude)
    assert local[0].amplitude[k] == pytest.approx(amp[k], rel=0.01)
    assert local[0].amplitude[k] == pytest.approx(plain[0].amplitude[k], rel=1e-3)
    # the frequency before the drop is the sweep's
    t = np.arange(x.shape[0]) / fs
    before = slice(int(10 * fs), int(98 * fs))
    assert np.max(np.abs(local[0].frequency[before] - sweep.frequency(t[before]))) < 0.01


def test_if_weighting_must_be_known():
    x, fs, sweep, _ = _drop_record()
    with pytest.raises(ValueError, match="if_weighting.*'none', 'local'.*'amplitude'"):
        acmp(x, fs, sweep=sweep, if_weighting="amplitude")


@pytest.mark.parametrize("how", ["up", "down_wrapping"])
def test_compiled_lockin_is_the_numpy_composition(how):
    # noise, a resonance's phase lag of ~pi and (down) a response off the sweep by 0.4 Hz, whose
    # phase wraps every 2.5 s: the unwrapping and both solves are exercised
    fs = 256.0
    sw = Sweep(30.0, 50.0, 0.2) if how == "up" else Sweep(50.0, 30.0, 0.2)
    t = np.arange(int(sw.duration * fs)) / fs
    lag = 0.5 * np.pi * (1.0 + np.tanh((t - 50.0) / 8.0))
    if how == "down_wrapping":
        lag = lag + 2 * np.pi * 0.4 * t
    x = (1.0 + 0.5 * np.exp(-(((t - 50.0) / 15.0) ** 2))) * np.cos(sw.phase(t) - lag) \
        + 0.3 * np.random.default_rng(3).normal(size=t.size)
    bw = 2.0 if how == "down_wrapping" else 0.5
    m = lockin(x, fs, sweep=sw, bandwidth_hz=bw, decimate_to=None)
    ref = numpy_lockin(x, fs, sw, bw)
    if how == "down_wrapping":
        assert np.ptp(ref.phase - sw.phase(t)) > 20 * np.pi  # it did wrap, many times
    np.testing.assert_allclose(m.amplitude, ref.amplitude, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(m.phase, ref.phase, rtol=0, atol=1e-8)
    np.testing.assert_allclose(m.frequency, ref.frequency, rtol=0, atol=1e-8)
    np.testing.assert_allclose(m.mode, ref.mode, rtol=0, atol=1e-9)
    assert m.snr_db == pytest.approx(ref.snr_db, rel=1e-10)


def test_acmp_pursuit_kept_for_identical_inputs(monkeypatch):
    acmp_module = importlib.import_module("freeplayid.signal.acmp")

    monkeypatch.setattr(acmp_module, "_PURSUITS", acmp_module._Pursuits())
    calls = []
    pursue = acmp_module._pursue
    monkeypatch.setattr(acmp_module, "_pursue", lambda *a, **k: calls.append(1) or pursue(*a, **k))
    fs = 400.0
    t = np.arange(int(20 * fs)) / fs
    x = np.sin(2 * np.pi * (20 * t + 0.25 * t * t)) + 0.1 * np.random.default_rng(3).normal(
        size=t.size)
    first = acmp_module.acmp(x, fs, init_freq=20 + 0.5 * t)
    again = acmp_module.acmp(x.copy(), fs, init_freq=20 + 0.5 * t)
    assert len(calls) == 1
    for name in ("amplitude", "frequency", "phase", "mode"):
        np.testing.assert_array_equal(getattr(first, name), getattr(again, name))
    first.frequency[:] = 0.0  # the caller's arrays are its own: the kept ones do not change
    np.testing.assert_array_equal(again.frequency, acmp_module.acmp(
        x, fs, init_freq=20 + 0.5 * t).frequency)
    x2 = x.copy()
    x2[1000] += 1e-9  # another record, another pursuit
    acmp_module.acmp(x2, fs, init_freq=20 + 0.5 * t)
    acmp_module.acmp(x, fs, init_freq=20 + 0.6 * t)  # another initial frequency
    acmp_module.acmp(x, fs, init_freq=20 + 0.5 * t, bandwidth_hz=1.0)  # another option
    assert len(calls) == 4


def test_acmp_pursuits_kept_within_their_memory_bound(monkeypatch):
    acmp_module = importlib.import_module("freeplayid.signal.acmp")

    kept = acmp_module._Pursuits(max_bytes=1)  # room for the newest entry only
    monkeypatch.setattr(acmp_module, "_PURSUITS", kept)
    fs = 400.0
    t = np.arange(int(10 * fs)) / fs
    for f0 in (20.0, 21.0, 22.0):
        acmp_module.acmp(np.sin(2 * np.pi * f0 * t), fs, init_freq=f0)
    assert len(kept.entries) == 1


# --- synthetic chirp, SNR 20 dB -----------------------------------------------------------------


def _chirp(kind):
    """A 30 -> 50 Hz chirp at 0.2 Hz/s with a known envelope bump, SNR 20 dB.

    ``"lag"``: the phase lags the sweep by 0 -> pi through a resonance-like tanh (the frequency is
    off the sweep law by up to 0.03 Hz); ``"wander"``: the frequency wanders 0.4 Hz off the
    sweep law (beyond a narrow lock-in, an ACMP-only test).
    """
    sw = Sweep(30.0, 50.0, 0.2)
    t = np.arange(int(sw.duration * FS)) / FS
    env = 1.0 + 0.5 * np.exp(-(((t - 50.0) / 15.0) ** 2))
    if kind == "lag":
        tau = 8.0  # [s] (a 4 % damped resonance passed at 0.1 Hz/s takes ~36 s)
        lag = 0.5 * np.pi * (1.0 + np.tanh((t - 50.0) / tau))
        dev = -0.5 * np.pi / tau / np.cosh((t - 50.0) / tau) ** 2 / (2 * np.pi)  # [Hz]
    else:
        lag = 0.4 * 80.0 * np.cos(2 * np.pi * t / 80.0)
        dev = 0.4 * np.sin(2 * np.pi * t / 80.0)  # [Hz]
    x = add_noise_for_snr(env * np.cos(sw.phase(t) - lag + 0.3), 20.0, seed=7)
    interior = (t > 10.0) & (t < sw.duration - 10.0)
    return sw, x, env, sw.frequency(t) + dev, interior


@pytest.fixture(scope="module")
def noisy_chirp():
    return _chirp("lag")


@pytest.mark.parametrize(
    "how, kind",
    [("acmp_hint", "lag"), ("acmp_ridge", "lag"), ("lockin", "lag"), ("acmp_hint", "wander"),
     ("acmp_ridge", "wander")],
)
def test_chirp_amplitude_and_frequency_at_20db(how, kind):
    sw, x, env, f_true, interior = _chirp(kind)
    if how == "lockin":
        # the sweep-locked base band rotates with the lag: a wider band than ACMP needs
        m = lockin(x, FS, sweep=sw, bandwidth_hz=0.3)
    else:
        m = acmp(x, FS, sweep=sw if how == "acmp_hint" else None, bandwidth_hz=0.2,
                 if_bandwidth_hz=0.2)
        assert m.converged
    assert m.amplitude.shape == m.frequency.shape == x.shape
    amp_err = np.max(np.abs(m.amplitude[interior] / env[interior] - 1.0))
    f_err = np.max(np.abs(m.frequency[interior] - f_true[interior]))
    assert amp_err < 0.005, amp_err
    assert f_err < 0.05, f_err
    assert 17.0 < m.snr_db < 23.0  # the mode holds the chirp, the residual the noise
    np.testing.assert_allclose(m.mode, m.amplitude * np.cos(m.phase), atol=1e-9)


def test_acmp_tracks_frequency_far_from_initial_guess():
    """Without a hint and with a constant-offset guess, ACMP still converges onto the chirp."""
    t = np.arange(int(20 * FS)) / FS
    x = np.cos(2 * np.pi * (35.0 * t + 0.25 * t * t))
    m = acmp(x, FS, init_freq=36.0, bandwidth_hz=2.0)
    sl = slice(int(2 * FS), int(18 * FS))
    assert np.max(np.abs(m.frequency[sl] - (35.0 + 0.5 * t[sl]))) < 0.01
    assert np.max(np.abs(m.amplitude[sl] - 1.0)) < 1e-3


def test_bandwidth_in_hz_is_sample_rate_independent():
    """The same Hz bandwidth gives the same amplitude at 1024 and 2048 Hz (alpha rescaled)."""
    out = []
    for fs in (1024.0, 2048.0):
        t = np.arange(int(30 * fs)) / fs
        env = 1.0 + 0.5 * np.sin(2 * np.pi * 0.5 * t)  # 0.5 Hz modulation, partly attenuated
        m = acmp(env * np.cos(2 * np.pi * 40.0 * t), fs, init_freq=40.0, bandwidth_hz=1.0,
                 adapt=False, decimate_to=None)
        out.append(np.interp(np.linspace(5, 25, 400), t, m.amplitude))
    np.testing.assert_allclose(out[0], out[1], rtol=2e-3)
    assert bandwidth_weight(1.0, 1024.0) == pytest.approx(16 * bandwidth_weight(1.0, 2048.0))


def test_decimation_does_not_change_the_result(noisy_chirp):
    sw, x, env, f_true, interior = noisy_chirp
    a = acmp(x, FS, sweep=sw, bandwidth_hz=0.5, adapt=False)
    b = acmp(x, FS, sweep=sw, bandwidth_hz=0.5, adapt=False, decimate_to=None)
    np.testing.assert_allclose(a.amplitude[interior], b.amplitude[interior], rtol=5e-4)
    np.testing.assert_allclose(a.frequency[interior], b.frequency[interior], atol=5e-3)


def test_ridge_frequency_follows_a_sweep(noisy_chirp):
    sw, x, env, f_true, interior = noisy_chirp
    f = ridge_frequency(x, FS)
    assert np.max(np.abs(f[interior] - sw.frequency(np.arange(x.size) / FS)[interior])) < 0.6


def test_narrow_band_stays_accurate_through_decimation():
    """0.1 Hz at 2048 Hz is ill-conditioned (1/alpha ~ 1e14) and refused at the full rate; after
    the default decimation (256 Hz) it is fine and averages noise as expected."""
    assert narrowest_bandwidth(2048.0) == pytest.approx(0.326, abs=1e-3)
    t = np.arange(int(60 * FS)) / FS
    x = add_noise_for_snr(np.cos(2 * np.pi * (40.0 * t + 0.05 * t * t)), 10.0, seed=4)
    m = acmp(x, FS, init_freq=40.0 + 0.1 * t, bandwidth_hz=0.1, adapt=False)
    sl = slice(int(10 * FS), int(50 * FS))
    assert np.max(np.abs(m.amplitude[sl] - 1.0)) < 0.01


def test_adaptation_narrows_band_down_to_floor_only():
    rng = np.random.default_rng(3)
    t = np.arange(int(20 * FS)) / FS
    x = (1 + 0.3 * np.sin(2 * np.pi * 0.05 * t)) * np.cos(2 * np.pi * 40 * t)
    x = x + 0.5 * rng.normal(size=t.size)
    m = acmp(x, FS, init_freq=40.0, bandwidth_hz=8.0, min_bandwidth_hz=2.0, max_iter=300)
    assert 2.0 - 1e-9 <= m.bandwidth_hz < 8.0


# --- Eq. 9 -----------------------------------------------------------------------------------


def test_to_displacement_is_eq9():
    f = np.array([30.0, 45.0])
    w = 2 * np.pi * f
    x = np.array([1e-3, 2e-3])
    np.testing.assert_allclose(to_displacement(x * w, f, "velocity"), x)
    np.testing.assert_allclose(to_displacement(x * w**2, f, "acceleration"), x)
    np.testing.assert_allclose(to_displacement(x, f, "displacement"), x)
    with pytest.raises(ValueError, match="quantity"):
        to_displacement(x, f, "jerk")


# --- SDOF freeplay sweeps -----------------------------------------------------------------------


@pytest.mark.parametrize("method", ["acmp", "lockin"])
def test_sdof_peaks_lie_on_exact_backbone(sdof_runs, sweep, method):
    res = extract_backbone_points(sdof_runs["displacement"], FS, quantity="displacement",
                                  run_names=RUNS, channel_names=["x"], sweep=sweep, method=method)
    used = res.used()
    assert [p.run for p in used] == RUNS[1:]
    for p in used:
        # the reference amplitude is the peak displacement of the record near the point
        f_bb = exact_backbone_hz(p.amplitude_m)
        assert abs(p.f_hz / f_bb - 1.0) < 0.01, (p, f_bb)
        assert p.amplitude_m > 5 * DELTA  # really on the upper branch
    # higher level, higher amplitude, higher frequency: a rising backbone
    assert used[0].f_hz < used[1].f_hz and used[0].amplitude_m < used[1].amplitude_m
    f, x = res.arrays("x")
    np.testing.assert_array_equal(f, [p.f_hz for p in used])
    np.testing.assert_array_equal(x, [p.amplitude_m for p in used])


def test_noise_floor_reads_the_noise_not_a_transient():
    """The floor of white noise with a burst of 10x its level over 8 % of the record: within
    the low quantile's own bias (0.96 sigma for 1 s windows of 256 samples) of the noise."""
    rng = np.random.default_rng(0)
    fs, sigma = 256.0, 0.3
    r = rng.normal(0.0, sigma, int(100 * fs))
    r[int(40 * fs):int(48 * fs)] += rng.normal(0.0, 10 * sigma, int(8 * fs))
    assert 0.93 * sigma < noise_floor(r, fs) < 1.0 * sigma
    assert np.sqrt(np.mean(r ** 2)) > 2.5 * sigma  # what the whole record's RMS reads
    assert noise_floor(r[:100], fs) == pytest.approx(np.sqrt(np.mean(r[:100] ** 2)))


@pytest.mark.parametrize("method", ["acmp", "lockin"])
def test_point_noise_is_the_records_noise_relative_to_the_point(sdof_runs, sweep, method):
    """Freeplay SDOF sweeps with a jump, and the same with white noise of a known std: the noisy
    point's floor is the noise's power (that std relative to the point, as displacement at the
    point's frequency) plus the noise-free record's floor (this SDOF's free mass rattles in its
    gap), within 0.6 dB (the low quantile's bias is -0.35 dB); the jump's transient does not
    enter it."""
    kw = dict(quantity="acceleration", run_names=RUNS, channel_names=["x"], sweep=sweep,
              method=method)
    clean = extract_backbone_points(sdof_runs["acceleration"], FS, **kw)
    sigma = 1.0 * G  # [m/s^2]
    noisy_runs = sdof_runs["acceleration"] + np.random.default_rng(3).normal(
        0.0, sigma, sdof_runs["acceleration"].shape)
    noisy = extract_backbone_points(noisy_runs, FS, **kw)
    assert [p.run for p in noisy.used()] == [p.run for p in clean.used()] == RUNS[1:]
    for p, q in zip(noisy.used(), clean.used(), strict=True):
        noise = 20 * np.log10(sigma / (2 * np.pi * p.f_hz) ** 2 / p.amplitude_m)
        assert q.noise_db < noise - 6, (q, noise)
        want = 10 * np.log10(10 ** (noise / 10) + 10 ** (q.noise_db / 10))
        assert abs(p.noise_db - want) < 0.6, (p, want)


def test_peak_amplitude_is_first_harmonic_of_the_record(sdof_runs, sweep):
    """X* is the first harmonic: just below the record's max |y|, by the harmonic content."""
    res = extract_backbone_points(sdof_runs["displacement"], FS, quantity="displacement",
                                  sweep=sweep)
    for i, p in enumerate(res.points):
        if p.used:
            ymax = np.max(np.abs(sdof_runs["displacement"][i, 0]))
            assert 0.98 * ymax < p.amplitude_m <= 1.001 * ymax


def test_same_peak_from_displacement_velocity_acceleration(sdof_runs):
    """Output-only (no sweep hint): Eq. 9 makes the three quantities give one point."""
    pts = {}
    for q in ("displacement", "velocity", "acceleration"):
        res = extract_backbone_points(sdof_runs[q][1:], FS, quantity=q, run_names=RUNS[1:])
        pts[q] = [(p.f_hz, p.amplitude_m) for p in res.used()]
        assert len(pts[q]) == 2
    ref = np.array(pts["displacement"])
    for q in ("velocity", "acceleration"):
        np.testing.assert_allclose(np.array(pts[q]), ref, rtol=0.005)


def test_in_gap_run_is_rejected_with_reason(sdof_runs):
    res = extract_backbone_points(sdof_runs["acceleration"], FS, quantity="acceleration",
                                  run_names=RUNS)
    gap = [p for p in res.points if p.run == "0.3g"]
    assert len(gap) == 1 and not gap[0].used and gap[0].reason == REASON_NO_JUMP
    assert res.rejected_runs == ("0.3g",)
    assert gap[0].amplitude_m < DELTA  # it really never left the gap
    rec = res.to_records()
    assert rec[0]["reason"] == REASON_NO_JUMP and rec[1]["used"] is True


def test_base_subtraction_recovers_relative_points(sdof_runs):
    rel = extract_backbone_points(sdof_runs["acceleration"], FS, quantity="acceleration")
    absolute = sdof_runs["acceleration"] + sdof_runs["base"][:, None, :]
    sub = extract_backbone_points(absolute, FS, quantity="acceleration", base=sdof_runs["base"])
    for a, b in zip(rel.points, sub.points, strict=True):
        assert a.reason == b.reason
        assert b.f_hz == pytest.approx(a.f_hz, rel=1e-4)
        assert b.amplitude_m == pytest.approx(a.amplitude_m, rel=1e-4)
    # without subtraction the absolute motion gives a visibly different point
    raw = extract_backbone_points(absolute[2:], FS, quantity="acceleration")
    assert abs(raw.points[0].amplitude_m / rel.points[2].amplitude_m - 1) > 2e-3


def test_sweep_ending_before_the_jump_is_band_edge(sdof_runs):
    """Cut the 0.6 g record at 43 Hz, before its jump (~45 Hz): maximum at the band end."""
    n = int((43.0 - 30.0) / RATE * FS)
    cut = sdof_runs["displacement"][1:2, :, :n]
    res = extract_backbone_points(cut, FS, quantity="displacement", sweep=Sweep(30.0, 43.0, RATE))
    assert res.points[0].reason == REASON_EDGE and not res.points[0].used


def test_jump_at_band_start_is_band_edge(sdof_runs):
    """Start the 0.6 g record 0.3 Hz before its jump: a jump, but at the band edge."""
    pts = extract_backbone_points(sdof_runs["displacement"][1:2], FS, quantity="displacement")
    f_jump = pts.points[0].f_hz
    k0 = int((f_jump - 0.3 - 30.0) / RATE * FS) - int(FS)  # trim_s = 1 s is cut again
    res = extract_backbone_points(sdof_runs["displacement"][1:2, :, k0:], FS,
                                  quantity="displacement")
    assert res.points[0].reason == REASON_EDGE


def test_moderate_noise_keeps_points_heavy_noise_rejects(sdof_runs, sweep):
    acc = sdof_runs["acceleration"][1:]
    clean = extract_backbone_points(acc, FS, quantity="acceleration", sweep=sweep)
    moderate = acc + white_noise(acc.shape, std_g=0.3, seed=2)  # the paper's worst case
    res = extract_backbone_points(moderate, FS, quantity="acceleration", sweep=sweep)
    for a, b in zip(clean.used(), res.used(), strict=True):
        # noise moves the maximum along the flat top of the curve, not off the backbone
        assert abs(b.f_hz / exact_backbone_hz(b.amplitude_m) - 1.0) < 0.01
        assert b.f_hz == pytest.approx(a.f_hz, rel=5e-3)
        assert b.amplitude_m == pytest.approx(a.amplitude_m, rel=5e-3)
    heavy = acc[:1] + white_noise(acc[:1].shape, std_g=20.0, seed=3)
    res = extract_backbone_points(heavy, FS, quantity="acceleration", sweep=sweep)
    assert res.points[0].reason == REASON_NOISY and not res.points[0].used
    assert res.rejected_runs == ("run0",)


def test_linear_resonance_is_not_a_jump():
    """A linear 45 Hz resonance (zeta = 0.04) is symmetric: no jump, unless not required."""
    sw = Sweep(30.0, 60.0, 0.5)
    t = np.arange(int(sw.duration * FS)) / FS
    wn = 2 * np.pi * 45.0
    sys = scipy.signal.lti([-1.0], [1.0, 2 * ZETA * wn, wn * wn])
    _, y, _ = scipy.signal.lsim(sys, sw.acceleration(t, 0.5), t)
    res = extract_backbone_points(y[None, None, :], FS, quantity="displacement", sweep=sw)
    assert res.points[0].reason == REASON_NO_JUMP
    res = extract_backbone_points(y[None, None, :], FS, quantity="displacement", sweep=sw,
                                  require_jump=False)
    p = res.points[0]
    assert p.used and p.f_hz == pytest.approx(45.0 * math.sqrt(1 - 2 * ZETA**2), rel=5e-3)


def test_find_jump_peak_down_sweep_mirrors_up_sweep():
    t = np.linspace(0, 10, 1001)
    x = np.where(t < 6, 1 + t, 0.2)  # slow rise, sharp fall at t = 6
    f = 30 + t
    k, reason = find_jump_peak(t, f, x, sweep_rate=1.0, band=(30.0, 40.0))
    assert reason == "" and t[k] == pytest.approx(5.99, abs=0.02)
    k, reason = find_jump_peak(t, f[::-1], x[::-1], sweep_rate=-1.0, band=(40.0, 30.0))
    assert reason == ""
    k, reason = find_jump_peak(t, f, x[::-1], sweep_rate=1.0, band=(30.0, 40.0))
    assert reason == REASON_NO_JUMP  # sharp rise then slow fall is not an up-sweep jump


def test_a_run_already_on_its_upper_branch_at_the_start_is_told_from_one_in_the_gap():
    """An up-sweep whose displacement is largest where the band starts and that drops later
    (by half within the jump's 2 Hz: a damped run in contact from the start, which climbs no
    branch in band) is rejected as starting on its upper branch, not as staying in the gap; a
    response in the gap (falling as 1 / f^2 across the band) and the same curve swept down
    keep their reasons."""
    from freeplayid.signal import REASON_START

    rate = 0.15  # [Hz/s] the curves' sweep: 32 -> 50 Hz
    t = np.arange(0.0, 120.0, 1 / 64)
    f = 32.0 + rate * t
    upper = np.where(f < 38.3, 1.0 - 0.02 * (f - 32.0), 0.12)  # drops within one sample
    k, reason = find_jump_peak(t, f, upper, sweep_rate=rate, band=(32.0, 50.0))
    assert k == 0 and reason == REASON_START
    in_gap = (32.0 / f) ** 2  # to 0.41 across the band, no half within 2 Hz
    assert find_jump_peak(t, f, in_gap, sweep_rate=rate, band=(32.0, 50.0))[1] == REASON_NO_JUMP
    # a fall too slow for a jump (by half every 3 Hz) is no upper branch's either
    slow = np.where(f < 38.0, 1.0 - 0.1 * (f - 32.0) / 6.0, 0.9 * 2.0 ** (-(f - 38.0) / 3.0))
    assert find_jump_peak(t, f, slow, sweep_rate=rate, band=(32.0, 50.0))[1] == REASON_NO_JUMP
    # swept down, the same shape is judged as before
    assert find_jump_peak(t, f[::-1], upper, sweep_rate=-rate,
                          band=(50.0, 32.0))[1] == REASON_NO_JUMP


def test_channels_are_handled_independently(sdof_runs):
    """Channel 1 = half of channel 0 (a second measure point): same f, half the amplitude."""
    d = sdof_runs["displacement"][1:]
    two = np.concatenate([d, 0.5 * d], axis=1)
    res = extract_backbone_points(two, FS, quantity="displacement", channel_names=["tl", "lr"])
    assert [(p.run, p.channel) for p in res.points] == [
        ("run0", "tl"), ("run0", "lr"), ("run1", "tl"), ("run1", "lr")]
    for a, b in zip(res.used("tl"), res.used("lr"), strict=True):
        assert b.f_hz == pytest.approx(a.f_hz, abs=1e-9)
        assert b.amplitude_m == pytest.approx(0.5 * a.amplitude_m, rel=1e-6)


def test_dead_channel_is_reported_not_fatal(sdof_runs):
    d = sdof_runs["displacement"][1:2]
    two = np.concatenate([d, np.zeros_like(d)], axis=1)
    res = extract_backbone_points(two, FS, quantity="displacement", channel_names=["ok", "dead"])
    ok, dead = res.points
    assert ok.used and not dead.used and dead.reason == "channel dead is dead (constant 0)"
    assert math.isnan(dead.f_hz) and res.rejected_runs == ()


def test_jump_parameters_are_honoured(sdof_runs):
    d = sdof_runs["displacement"][1:2]
    assert extract_backbone_points(d, FS, quantity="displacement").points[0].used
    strict = extract_backbone_points(d, FS, quantity="displacement", jump_asymmetry=100.0)
    assert strict.points[0].reason == REASON_NO_JUMP
    narrow = extract_backbone_points(d, FS, quantity="displacement", jump_width_hz=0.1)
    assert narrow.points[0].reason == REASON_NO_JUMP


def test_list_of_runs_with_different_lengths(sdof_runs):
    d = sdof_runs["displacement"]
    runs = [d[1], d[2, :, : d.shape[2] - int(5 * FS)]]
    res = extract_backbone_points(runs, FS, quantity="displacement", channel_names=["x"])
    assert [p.used for p in res.points] == [True, True]
    assert len(res.curves) == 2 and res.curves[0].frequency.shape == res.curves[0].amplitude_m.shape


# --- input validation -------------------------------------------------------------------------


def test_acmp_and_lockin_validate_inputs():
    x = np.cos(np.arange(1000) * 0.2)
    with pytest.raises(ValueError, match="sample_rate"):
        acmp(x, -1.0)
    with pytest.raises(TypeError, match="sample_rate"):
        acmp(x, "2048")
    with pytest.raises(ValueError, match="1-D"):
        acmp(x[None, :], 100.0)
    with pytest.raises(ValueError, match="finite"):
        acmp(np.r_[x, np.nan], 100.0)
    with pytest.raises(ValueError, match="at least"):
        acmp(x[:5], 100.0)
    with pytest.raises(ValueError, match="bandwidth_hz"):
        acmp(x, 100.0, bandwidth_hz=0.0)
    with pytest.raises(ValueError, match="max_iter"):
        acmp(x, 100.0, init_freq=3.0, max_iter=0)
    with pytest.raises(ValueError, match="init_freq"):
        acmp(x, 100.0, init_freq=-3.0)
    with pytest.raises(ValueError, match="Nyquist"):
        acmp(x, 100.0, init_freq=60.0)
    with pytest.raises(TypeError, match="sweep"):
        acmp(x, 100.0, sweep="30-50")
    with pytest.raises(TypeError, match="sweep"):
        lockin(x, 100.0, sweep=None)
    with pytest.raises(ValueError, match="decimate_to"):
        acmp(x, 100.0, init_freq=3.0, decimate_to=1.0)
    with pytest.raises(ValueError, match="too narrow"):
        acmp(x, 2048.0, init_freq=30.0, bandwidth_hz=0.1, decimate_to=None)


def test_extract_validates_inputs():
    x = np.zeros((2, 1, 4096))
    with pytest.raises(ValueError, match="quantity"):
        extract_backbone_points(x, FS, quantity="jerk")
    with pytest.raises(ValueError, match="method"):
        extract_backbone_points(x, FS, quantity="velocity", method="hilbert")
    with pytest.raises(ValueError, match="lockin"):
        extract_backbone_points(x, FS, quantity="velocity", method="lockin")
    with pytest.raises(ValueError, match=r"\(runs, channels, T\)"):
        extract_backbone_points(x[0], FS, quantity="velocity")
    with pytest.raises(ValueError, match="channel_names"):
        extract_backbone_points(x, FS, quantity="velocity", channel_names=["a", "b"])
    with pytest.raises(ValueError, match="run_names"):
        extract_backbone_points(x, FS, quantity="velocity", run_names=["a"])
    with pytest.raises(ValueError, match="base"):
        extract_backbone_points(x, FS, quantity="velocity", base=np.zeros((2, 10)))
    with pytest.raises(ValueError, match="sweep"):
        extract_backbone_points(x, FS, quantity="velocity", sweep=[Sweep(30, 50, 1)])
    with pytest.raises(ValueError, match="jump_ratio"):
        extract_backbone_points(x, FS, quantity="velocity", jump_ratio=1.5)
    with pytest.raises(ValueError, match="curve_points"):
        extract_backbone_points(x, FS, quantity="velocity", curve_points=1)
    with pytest.raises(ValueError, match="options"):
        extract_backbone_points(x, FS, quantity="velocity", options={"bandwidth_hz": 1.0})


# --- noise -----------------------------------------------------------------------------------


def test_noise_levels_and_seeds():
    n = white_noise((3, 200_000), std_g=0.3, seed=5)
    assert np.std(n) == pytest.approx(0.3 * G, rel=0.01)
    np.testing.assert_array_equal(n, white_noise((3, 200_000), std_g=0.3, seed=5))
    x = np.sin(np.linspace(0, 400, 100_000))[None, :] * np.array([[1.0], [5.0]])
    y = add_noise_for_snr(x, 20.0, seed=1)
    snr = 10 * np.log10(np.mean(x**2, axis=1) / np.mean((y - x) ** 2, axis=1))
    np.testing.assert_allclose(snr, 20.0, atol=0.1)
    with pytest.raises(ValueError, match="std_g"):
        white_noise(3, std_g=-1.0)


# --- figure ------------------------------------------------------------------------------------


def test_plot_backbone_points_draws_curves_and_marks(sdof_runs):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from freeplayid.plots import plot_backbone_points

    res = extract_backbone_points(sdof_runs["displacement"], FS, quantity="displacement",
                                  run_names=RUNS)
    fig, ax = plt.subplots()
    try:
        plot_backbone_points(ax, res, backbone=([40.0, 48.0], [5e-4, 1.5e-3]))
        lines = ax.get_lines()
        # 3 curves + 2 used dots + 1 rejected cross + backbone
        assert len(lines) == 7
        used = [ln for ln in lines if ln.get_marker() == "o"]
        assert sorted(float(ln.get_xdata()[0]) for ln in used) == sorted(
            p.f_hz for p in res.used())
        assert float(used[0].get_ydata()[0]) == pytest.approx(1e3 * res.used()[0].amplitude_m)
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert f"rejected: {REASON_NO_JUMP}" in labels
        with pytest.raises(ValueError, match="channel"):
            plot_backbone_points(ax, res, channel="nope")
    finally:
        plt.close(fig)


def test_signal_does_not_import_torch():
    """signal works on plain arrays: importing it must not pull in torch (via simulate)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    src = str(Path(__file__).resolve().parents[1] / "src")
    code = "import sys, freeplayid.signal, freeplayid.plots; print('torch' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, "PYTHONPATH": src})
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("kd, n", [(4, 20_000), (2, 9_000), (4, 7), (1, 3)])
def test_banded_cholesky_solves_as_lapack(kd, n):
    # the compiled banded Cholesky of the ACMP solves against scipy's LAPACK pbsv on random
    # symmetric positive definite band matrices (upper band storage, LAPACK's layout)
    from scipy.linalg import solveh_banded

    from freeplayid.signal.banded import cholesky_banded, solve_factored

    rng = np.random.default_rng(kd * 1000 + n)
    ab = 0.3 * rng.normal(size=(kd + 1, n))
    ab[kd] = 2 * kd + 1 + rng.random(n)
    for i in range(kd):
        ab[i, : kd - i] = 0.0  # outside the matrix
    b = rng.normal(size=n)
    ref = solveh_banded(ab.copy(), b.copy())
    x = solve_factored(cholesky_banded(ab.copy()), b)
    assert np.max(np.abs(x - ref)) <= 1e-12 * np.max(np.abs(ref))
    ab[kd, n // 2] = -1.0  # not positive definite
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        cholesky_banded(ab)

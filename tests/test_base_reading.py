"""The replay's check of the base channel's narrowed reading where the runs jump
(``freeplayid.signal.level.reading_gap``, ``replay.BaseReading``, the verdict's ``base_reading``).

References are built here by hand: base records with a known level profile (a fast dip's flank,
a constant level) under white noise of a known level, and the answer's moves that the check and
the intervals must carry, not by the code under test."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from freeplayid.dataset import Dataset, Run
from freeplayid.replay.excitation import measured_sweep
from freeplayid.signal.level import GAP_Z, reading_gap
from freeplayid.sweep import MeasuredSweep, Sweep

FS = 256.0
LAW = Sweep(start_hz=30.0, stop_hz=46.0, rate_hz_per_s=0.4)  # 40 s


def _measured(profile, level_g: float, noise_g: float, seed: int):
    """The measured excitation of a base record ``level_g x profile x sin`` plus white noise."""
    t = np.arange(0.0, LAW.duration, 1.0 / FS)
    base = level_g * profile * np.sin(LAW.phase(t))
    base = base + noise_g * np.random.default_rng(seed).standard_normal(t.size)
    run = Run(file="r.csv", time=t, data=np.zeros((1, t.size)), level_g=level_g,
              sweep=LAW.to_dict(), base=base)
    ds = Dataset(name="r", model=None, quantity="acceleration", units="g", sample_rate=FS,
                 channels={"a": "dof"}, runs=(run,), base_channel="acc_base")
    return measured_sweep(ds, run, LAW)


def _fast_dip(t, t_mid: float, depth: float = 0.3, flank_s: float = 1.5):
    """A level that falls by ``depth`` over ``flank_s`` seconds (a half cosine) centred at
    ``t_mid`` and stays down for 3 s before it rises as fast (a force-limited shaker's dip
    crossed at 0.4 Hz/s)."""
    def step(x):  # 0 before, 1 after, a half cosine over flank_s
        u = np.clip((x + flank_s / 2) / flank_s, 0.0, 1.0)
        return 0.5 * (1 - np.cos(np.pi * u))
    return 1.0 - depth * (step(t - t_mid) - step(t - t_mid - 3.0 - flank_s))


def test_the_gap_shows_a_flank_the_narrow_band_rounds_and_not_the_noise():
    """0.8 g under 0.05 g of noise: the base is read over the narrow band, and the wide band's
    reading comes with it. Halfway down a 30 % dip's 1.5-s falling flank (where a run jumps),
    the narrowed reading lies 1 % off the true level over the 2 s before, and the gap to the
    wide band's reading shows it beyond GAP_Z, as large as that error (within 0.5 %) and of the
    opposite sign; on a constant
    level with the same noise the gap stays within GAP_Z at all but a few per cent of the
    samples (three standard deviations: 0.3 % of a normal's), and the noiseless record keeps
    the wide band (no gap to read)."""
    t = np.arange(0.0, LAW.duration, 1.0 / FS)
    profile = _fast_dip(t, 20.0)
    sweep, level = _measured(profile, 0.8, 0.05, seed=1)
    assert sweep.wide is not None and sweep.reading_band_hz < 1.0
    at = int(20.0 * FS)  # the flank's middle
    gap, z = reading_gap(sweep.envelope_samples, sweep.wide.envelope_samples, FS, at,
                         sweep.reading_band_hz)
    window = slice(at - int(0.5 / sweep.reading_band_hz * FS), at)
    true_error = np.mean(sweep.envelope_samples[window] * level / 0.8 - profile[window])
    assert abs(z) > GAP_Z
    assert abs(true_error) > 0.005 and abs(gap + true_error) < 0.005

    flat, _ = _measured(np.ones_like(t), 0.8, 0.05, seed=2)
    inner = np.arange(int(8 * FS), t.size - int(8 * FS), int(0.25 * FS))
    zs = np.array([reading_gap(flat.envelope_samples, flat.wide.envelope_samples, FS, k,
                               flat.reading_band_hz)[1] for k in inner])
    assert np.mean(np.abs(zs) > GAP_Z) < 0.03
    assert _measured(profile, 0.8, 0.0, seed=3)[0].wide is None


def test_the_gap_is_nan_where_its_window_is_not_in_the_record():
    d = np.ones(2000)
    assert all(math.isnan(v) for v in reading_gap(d, d, FS, 10, 0.25))


def test_a_wide_reading_of_another_record_is_refused():
    ph, env = np.linspace(0, 100, 64), np.ones(64)
    with pytest.raises(ValueError, match="`wide`"):
        MeasuredSweep(FS, ph, env, wide=MeasuredSweep(FS, ph[:63], env[:63]))


def _reading(delta_move, kn_move, runs=("r1",), noise=(0.005, 0.004)):
    from freeplayid.replay import BaseReading

    return BaseReading(gaps={"r1": (0.012, 8.0), "r2": (0.001, 0.5)}, runs=runs,
                       kn_shift=None if kn_move is None else abs(kn_move),
                       delta_shift=None if delta_move is None else abs(delta_move),
                       kn_move=kn_move, delta_move=delta_move, delta_noise=noise[0],
                       kn_noise=noise[1], n_copies=4)


@pytest.mark.parametrize("delta_move, kn_move, runs, noise, passed", [
    (-0.034, -0.010, ("r1",), (0.005, 0.004), False),  # delta beyond its 1 % bound
    (-0.004, -0.030, ("r1",), (0.005, 0.004), False),  # kn beyond its 2 % bound
    (-0.004, -0.010, ("r1",), (0.005, 0.004), True),  # within both
    (-0.034, -0.010, ("r1",), (0.040, 0.004), True),  # within the wide reading's own noise
    (-0.017, -0.010, ("r1",), (0.009, 0.004), True),  # beyond, but not less that noise
    (-0.021, -0.010, ("r1",), (0.009, 0.004), False),  # beyond, even less that noise
    (-0.034, -0.010, ("r1",), (None, None), False),  # that noise not measured: the bounds
    (None, None, ("r1",), (None, None), False),  # a gap whose effect could not be measured
    (None, None, (), (None, None), True),  # no gap beyond GAP_Z: nothing to replay
])
def test_the_verdict_fails_where_the_wide_readings_move_less_its_noise_exceeds_the_bounds(
        delta_move, kn_move, runs, noise, passed):
    from freeplayid.identification.replay_checks import _reading_check

    reading = _reading(delta_move, kn_move, runs, noise)
    check = _reading_check(SimpleNamespace(base_reading=reading))
    assert check.name == "base_reading" and check.passed is passed
    if runs:
        assert "r1" in check.message and "r2" not in check.message.split(";")[0]
    if delta_move is not None:
        assert f"{100 * math.expm1(delta_move):+.2g} %" in check.message
    assert _reading_check(SimpleNamespace(base_reading=None)) is None


def test_intervals_take_in_the_wide_readings_move():
    """The move joins the intervals in quadrature (by hand), as the other sensitivities do."""
    from freeplayid.identification.pipeline import _corrected_intervals

    rep = SimpleNamespace(statistic_ci95=((470.0, 490.0), (2.97e-3, 3.03e-3)), kn=480.0,
                          delta=3e-3, kn_statistic=480.0, delta_statistic=3e-3, precision=None,
                          bootstrap=None, level=None, damping_sensitivity=None, damping=None,
                          excitation_noise=None, base_reading=_reading(-0.034, -0.010))
    kn_ci, delta_ci, source = _corrected_intervals(rep)
    own = math.log(3.03e-3 / 3e-3)
    assert math.log(delta_ci[1] / 3e-3) == pytest.approx(math.hypot(own, 0.034))
    assert math.log(kn_ci[1] / 480.0) == pytest.approx(math.hypot(math.log(490 / 480), 0.010))
    assert "wide band" in source

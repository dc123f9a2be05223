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
from freeplayid.signal.level import GAP_AROUND, GAP_Z, GAP_Z_AROUND, GAP_Z_STRONG, reading_gap
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


def test_the_gap_read_around_a_point_sees_the_flank_wherever_the_point_lies_on_it():
    """The narrowed reading rounds the 1.5-s flank: above the level on one side of it, below on
    the other, so a single window ending at a point crosses zero somewhere near the flank and
    shows no gap there (|z| < 2 at some point within 1.5 s of the flank's middle), while the
    window moved half its length either side (``GAP_AROUND``) shows a gap beyond its gate
    (``GAP_Z_AROUND``) at every point from 1.5 s before the flank's middle to 2.5 s after it
    (where the level rises again); on a constant level under the same noise it stays within the
    gate at all but a few per cent of the points."""
    t = np.arange(0.0, LAW.duration, 1.0 / FS)
    sweep, _ = _measured(_fast_dip(t, 20.0), 0.8, 0.05, seed=1)
    points = (np.arange(18.5, 22.51, 0.125) * FS).astype(int)

    def z(sw, k, around):
        return reading_gap(sw.envelope_samples, sw.wide.envelope_samples, FS, k,
                           sw.reading_band_hz, around=around)[1]

    single = np.array([z(sweep, k, 0.0) for k in points])
    scanned = np.array([z(sweep, k, GAP_AROUND) for k in points])
    near = np.abs(points / FS - 20.0) <= 1.5
    assert np.min(np.abs(single[near])) < 2.0
    assert np.all(np.abs(scanned) > GAP_Z_AROUND)

    flat, _ = _measured(np.ones_like(t), 0.8, 0.05, seed=2)
    inner = np.arange(int(8 * FS), t.size - int(8 * FS), int(0.25 * FS))
    assert np.mean([abs(z(flat, k, GAP_AROUND)) > GAP_Z_AROUND for k in inner]) < 0.03


def test_the_scanned_gate_is_crossed_by_noise_as_often_as_one_window_at_gap_z():
    """Sidak by hand: one window at 3 standard deviations is crossed with p = 0.0026998 (two
    tails); the scan of half a window either side spans two independent windows, each then
    allowed 1 - (1 - 0.0026998)^(1/2) = 0.0013508, two tails: 3.205 standard deviations."""
    import scipy.stats

    assert GAP_Z == 3.0 and GAP_AROUND == 0.5
    assert 1 - (1 - 2 * scipy.stats.norm.sf(3.0)) ** 0.5 == pytest.approx(0.0013508, rel=1e-4)
    assert GAP_Z_AROUND == pytest.approx(3.205, abs=1e-3)
    assert 4.0 < GAP_Z_STRONG < 8.0  # the verdict's tests below straddle it


def test_the_gap_is_nan_where_its_window_is_not_in_the_record():
    d = np.ones(2000)
    assert all(math.isnan(v) for v in reading_gap(d, d, FS, 10, 0.25))


def test_a_wide_reading_of_another_record_is_refused():
    ph, env = np.linspace(0, 100, 64), np.ones(64)
    with pytest.raises(ValueError, match="`wide`"):
        MeasuredSweep(FS, ph, env, wide=MeasuredSweep(FS, ph[:63], env[:63]))


def _reading(delta_move, kn_move, runs=("r1",), noise=(0.005, 0.004), z=8.0):
    from freeplayid.replay import BaseReading

    return BaseReading(gaps={"r1": (0.012, z), "r2": (0.001, 0.5)}, runs=runs,
                       kn_shift=None if kn_move is None else abs(kn_move),
                       delta_shift=None if delta_move is None else abs(delta_move),
                       kn_move=kn_move, delta_move=delta_move, delta_noise=noise[0],
                       kn_noise=noise[1], n_copies=4)


@pytest.mark.parametrize("delta_move, kn_move, runs, noise, z, passed", [
    (-0.034, -0.010, ("r1",), (0.005, 0.004), 4.0, False),  # delta beyond its 1 % bound
    (-0.004, -0.030, ("r1",), (0.005, 0.004), 4.0, False),  # kn beyond its 2 % bound
    (-0.004, -0.010, ("r1",), (0.005, 0.004), 8.0, True),  # within both
    (-0.034, -0.010, ("r1",), (0.040, 0.004), 4.0, True),  # within that reading's own noise
    (-0.034, -0.010, ("r1",), (0.040, 0.004), 8.0, False),  # ... on a strong gap: unmeasured
    (-0.001, -0.001, ("r1",), (0.004, 0.025), 8.0, False),  # kn's noise beyond 2 %, strong
    (-0.017, -0.010, ("r1",), (0.009, 0.004), 8.0, True),  # beyond, but not less that noise
    (-0.021, -0.010, ("r1",), (0.009, 0.004), 4.0, False),  # beyond, even less that noise
    (-0.034, -0.010, ("r1",), (None, None), 8.0, False),  # that noise not measured: the bounds
    (None, None, ("r1",), (None, None), 8.0, False),  # a gap whose effect could not be measured
    (None, None, (), (None, None), 8.0, True),  # no gap beyond the gate: nothing to replay
])
def test_the_verdict_fails_where_the_wide_readings_move_less_its_noise_exceeds_the_bounds(
        delta_move, kn_move, runs, noise, z, passed):
    """The gate ``GAP_Z_STRONG`` lies between z 4 and 8 (twice the scanned gate, 6.4)."""
    from freeplayid.identification.replay_checks import _reading_check

    reading = _reading(delta_move, kn_move, runs, noise, z)
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


def test_runs_named_wide_are_driven_by_the_wide_reading_which_follows_the_flank():
    """``replay_excitations(..., wide=runs)``: a run named there is driven by the wide band's
    reading (the same level, the wide envelope and its noise and band), and on the fast dip's
    flank that reading lies closer to the true level than the narrowed one (mean absolute error
    over the 3 s across the falling flank, against the profile built here); a run not named,
    or one read over the wide band anyway, keeps its reading."""
    from freeplayid.replay.runs import replay_excitations

    t = np.arange(0.0, LAW.duration, 1.0 / FS)
    profile = _fast_dip(t, 20.0)
    base = 0.8 * profile * np.sin(LAW.phase(t)) \
        + 0.05 * np.random.default_rng(1).standard_normal(t.size)
    run = Run(file="r.csv", time=t, data=np.zeros((1, t.size)), level_g=0.8,
              sweep=LAW.to_dict(), base=base)
    ds = Dataset(name="r", model=None, quantity="acceleration", units="g", sample_rate=FS,
                 channels={"a": "dof"}, runs=(run,), base_channel="acc_base")
    sweeps = {"r.csv": (LAW, "hint", None)}
    narrow, levels = replay_excitations(ds, sweeps)
    wide, levels_w = replay_excitations(ds, sweeps, wide=("r.csv",))
    assert levels == levels_w
    m, w = narrow["r.csv"], wide["r.csv"]
    assert m.wide is not None and w is m.wide or np.array_equal(
        w.envelope_samples, m.wide.envelope_samples)
    assert w.reading_band_hz > m.reading_band_hz and w.reading_sd > m.reading_sd
    flank = (t > 18.5) & (t < 21.5)
    level = levels["r.csv"][0]

    def error(sweep):
        return float(np.mean(np.abs(sweep.envelope_samples[flank] * level / 0.8
                                    - profile[flank])))
    assert error(w) < 0.5 * error(m)
    kept, _ = replay_excitations(ds, sweeps, wide=("other.csv",))
    assert np.array_equal(kept["r.csv"].envelope_samples, m.envelope_samples)


def test_wide_base_names_runs():
    from freeplayid.replay import Replay

    assert Replay().wide_base == ()
    assert Replay(wide_base=["a.csv", "b.csv"]).wide_base == ("a.csv", "b.csv")
    for bad in ("a.csv", [1], [""], 3):
        with pytest.raises(ValueError, match="`wide_base` must be a list of run file names"):
            Replay(wide_base=bad)


@pytest.mark.parametrize("noise, passed", [
    ((0.006, 0.004), True),  # the wide reading's own noise within both bounds
    ((0.015, 0.004), False),  # beyond delta's 1 %
    ((0.006, 0.025), False),  # beyond kn's 2 %
    ((None, None), False),  # not measured
])
def test_the_answer_read_wide_passes_where_that_readings_noise_keeps_it_within_the_bounds(
        noise, passed):
    """``base_reading`` of the answer replayed with the wide reading: it names the runs read so,
    says how far the narrowed reading's answer lay (by hand: 2.9 / 3.0 - 1 = -3.3 %) and passes
    only where the wide reading's own noise (95 %) lies within the accuracy bounds."""
    from freeplayid.identification.pipeline import _wide_reading_check

    reading = _reading(0.034, 0.010, noise=noise)
    first = SimpleNamespace(kn=890.0, delta=2.9e-3)
    second = SimpleNamespace(kn=900.0, delta=3.0e-3)
    check = _wide_reading_check(reading, first, second)
    assert check.name == "base_reading" and check.passed is passed
    assert "r1" in check.message and "r2" not in check.message
    assert "delta -3.3 %" in check.message and "kn -1.1 %" in check.message
    assert "the answer rested on it" in check.message
    noisy = _wide_reading_check(_reading(0.005, 0.001, noise=(0.03, 0.004)), first, second)
    assert not noisy.passed and "too noisy to say how far" in noisy.message


def test_only_an_answer_resting_on_the_narrowed_reading_is_replayed_wide():
    from freeplayid.identification.pipeline import _base_misread
    from freeplayid.replay import Replay

    def result(reading):  # judged by the verdict's own check, as identify judges it
        from freeplayid.identification.replay_checks import _reading_check

        rep = SimpleNamespace(failure="", base_reading=reading)
        check = _reading_check(rep)
        return SimpleNamespace(replay=rep, verdict=SimpleNamespace(
            checks=() if check is None else (check,)))

    failing = _reading(0.034, 0.010)  # 3.4 % less 0.5 % of noise: beyond delta's 1 %
    assert _base_misread(result(failing), Replay()) == ("r1",)
    assert _base_misread(result(failing), Replay(wide_base=["r1"])) == ()  # done
    assert _base_misread(result(_reading(0.034, 0.010, noise=(0.03, 0.004), z=4.0)),
                         Replay()) == ()  # within that reading's own noise: no better known
    assert _base_misread(result(_reading(0.034, 0.010, noise=(0.03, 0.004), z=8.0)),
                         Replay()) == ("r1",)  # ... unless the narrowed reading plainly misses
    assert _base_misread(result(_reading(0.004, 0.010)), Replay()) == ()  # within the bounds
    assert _base_misread(result(_reading(None, None)), Replay()) == ()  # no move
    assert _base_misread(result(None), Replay()) == ()


def test_identify_refuses_a_wide_base_run_the_data_set_does_not_have():
    from pathlib import Path

    import freeplayid
    from freeplayid.errors import ConfigError

    example = Path(freeplayid.__file__).parent / "data" / "fin_sweeps"
    with pytest.raises(ConfigError, match=r"`replay.wide_base`: 'nope.csv' is not a run of .*"
                       r"sweep_0.40g.csv.gz"):
        freeplayid.identify(example, replay={"wide_base": ["nope.csv"]}, progress=False)


def test_a_gated_run_whose_point_the_wide_reading_loses_is_named_and_fails_the_check():
    from freeplayid.identification.replay_checks import _reading_check
    from freeplayid.replay import BaseReading

    reading = BaseReading({"r1": (0.013, 23.0), "r2": (0.001, 0.5)}, ("r1",), lost=("r1",))
    check = _reading_check(SimpleNamespace(base_reading=reading))
    assert not check.passed and "lost the point of r1" in check.message
    assert "not measured" in check.message

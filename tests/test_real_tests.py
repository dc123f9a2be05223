"""The real-test pieces of the identification: the quadrature jump point, the measured
excitation, the model's update to the sealed fin's modes and the verdict's resonance check.

References are built here by hand (a record whose phase crosses quadrature at a known time, a
base record with a known level profile, a model whose stiffness is scaled by a known factor),
not by the code under test."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import scipy.linalg

from freeplayid.dataset import Dataset, Run
from freeplayid.model import default_fin
from freeplayid.model.from_test import update_to_sealed_modes
from freeplayid.replay.excitation import measured_sweep, read_again
from freeplayid.signal import extract_backbone_points
from freeplayid.sweep import MeasuredSweep, Sweep

FS = 256.0
LAW = Sweep(start_hz=30.0, stop_hz=46.0, rate_hz_per_s=0.5)


def _record(t_quad: float, t_drop: float, *, phase_swing: float = 1.2):
    """(absolute response, base) in m/s^2: the base a cos(psi), the response relative to it
    A(t) cos(psi - phi(t)), whose lag phi passes pi/2 at ``t_quad`` (if ``phase_swing`` > 0)
    and whose amplitude grows to the drop at ``t_drop`` and falls to a tenth within 0.1 s."""
    t = np.arange(0.0, LAW.duration, 1.0 / FS)
    psi = LAW.phase(t)
    base = 2.0 * np.cos(psi)
    grow = 2.0 + 18.0 * np.clip(t / t_drop, 0, 1)
    fall = 1.0 - 0.9 * np.clip((t - t_drop) / 0.1, 0, 1)
    amp = grow * fall
    if phase_swing:
        lag = np.pi / 2 + phase_swing * np.arctan((t - t_quad) / 0.5) * 2 / np.pi
    else:
        lag = np.full_like(t, 0.3)
    lag = np.where(t > t_drop, np.pi - 0.2, lag)
    rel = amp * np.cos(psi - lag)
    return t, rel + base, base


def _points(rule: str, response, base):
    pts = extract_backbone_points(response[None, None, :], FS, quantity="acceleration",
                                  sweep=LAW, base=base[None, :], jump_point=rule)
    p = pts.points[0]
    assert p.used, p.reason
    return p


def test_quadrature_point_is_where_the_phase_lag_crosses_a_quarter_period():
    t_quad, t_drop = 14.0, 18.0  # 37.0 Hz and 39.0 Hz
    _, response, base = _record(t_quad, t_drop)
    quad = _points("quadrature", response, base)
    drop = _points("drop", response, base)
    assert quad.f_hz == pytest.approx(LAW.frequency(t_quad), abs=0.1)
    assert drop.f_hz == pytest.approx(LAW.frequency(t_drop), abs=0.15)
    # the amplitude is read at the quadrature point, below the drop's (the envelope grows)
    assert quad.amplitude_m < drop.amplitude_m


def test_quadrature_point_without_a_crossing_is_the_drop_point():
    _, response, base = _record(14.0, 18.0, phase_swing=0.0)
    quad = _points("quadrature", response, base)
    drop = _points("drop", response, base)
    assert quad.f_hz == pytest.approx(drop.f_hz, abs=1e-9)
    assert quad.amplitude_m == pytest.approx(drop.amplitude_m, rel=1e-9)


def test_quadrature_needs_the_base_channel():
    _, response, _ = _record(14.0, 18.0)
    with pytest.raises(ValueError, match="base"):
        extract_backbone_points(response[None, None, :], FS, quantity="acceleration",
                                sweep=LAW, jump_point="quadrature")


def test_measured_sweep_keeps_the_level_profile_and_the_law():
    """A base record dipping 30 % around 37 Hz: the measured excitation's envelope dips by
    30 % there and is flat elsewhere; its frequency is the law's."""
    t = np.arange(0.0, LAW.duration, 1.0 / FS)
    f = LAW.frequency(t)
    dip = 1.0 - 0.3 * np.exp(-0.5 * ((f - 37.0) / 0.4) ** 2)
    level = 0.8
    base_g = level * dip * np.sin(LAW.phase(t))
    run = Run(file="r.csv", time=t, data=np.zeros((1, t.size)), level_g=level,
              sweep={"start_hz": 30.0, "stop_hz": 46.0, "rate_hz_per_s": 0.5}, base=base_g)
    ds = Dataset(name="dip", model=None, quantity="acceleration", units="g", sample_rate=FS,
                 channels={"a": "dof"}, runs=(run,), base_channel="acc_base")
    sweep, lvl = measured_sweep(ds, run, LAW)
    assert isinstance(sweep, MeasuredSweep)
    inner = (t > 3) & (t < LAW.duration - 3)  # away from the extractor's edges
    ref_median = np.median(dip[inner])
    assert lvl == pytest.approx(level * np.median(dip), rel=0.02)
    env = sweep.envelope(t[inner])
    i37 = np.argmin(np.abs(f[inner] - 37.0))
    assert env[i37] == pytest.approx(0.7 / ref_median, rel=0.03)
    far = np.abs(f[inner] - 37.0) > 2.0
    assert np.allclose(env[far], 1.0 / ref_median, rtol=0.02)
    assert np.allclose(sweep.frequency(t[inner]), f[inner], atol=0.05)
    # the phase is the recorded one: sin(phase) reproduces the base record's shape
    corr = np.corrcoef(np.sin(sweep.phase(t[inner])), base_g[inner] / dip[inner])[0, 1]
    assert corr > 0.999


def test_update_to_sealed_modes_recovers_a_global_stiffness_scale():
    """The true fin is 2 % stiffer than the model; its sealed modes (the hinges at kn,
    delta = 0) come from a plain generalised eigen-solve here. The update finds the scale and
    kn, and the updated model has the sealed fin's frequencies."""
    model = default_fin()
    kn_true, scale = 480.0, 1.02
    hinge = model.closed_stiffness(kn_true) - model.K
    w2, shapes = scipy.linalg.eigh(scale * model.K + hinge, model.M)
    ref_hz = np.sqrt(w2[:3]) / (2 * np.pi)
    upd = update_to_sealed_modes(model, 400.0, ref_hz, shapes[:, :3], list(model.dof_names))
    assert upd is not None
    assert upd.scale == pytest.approx(scale, rel=2e-3)
    assert upd.kn == pytest.approx(kn_true, rel=0.02)
    w2_after = scipy.linalg.eigh(upd.system.closed_stiffness(upd.kn), upd.system.M,
                                 eigvals_only=True)[:3]
    assert np.sqrt(w2_after) / (2 * np.pi) == pytest.approx(ref_hz, rel=1e-3)


def test_update_to_three_sealed_modes_takes_a_plate_off_alone_out_of_kn():
    """The true fin's inboard plate is 10 % softer (the default fin's FE model rebuilt with that
    Young's modulus: mode 1 -1 %), the model file is the nominal fin. Its exact DFA backbone
    (true M, K, kn 480, delta 3 mrad) gives points from 1.9 to 3.9 gaps; the points are fitted
    against the model updated to the true sealed modes (a plain eigen-solve at kn 480). With three
    modes the update scales the lowest elastic open-hinge mode apart from the rest and kn lands
    within 0.5 %; two modes allow one scale only, which puts the plate's error into kn (2 %)."""
    import dataclasses

    from freeplayid.backbone import backbone_curve
    from freeplayid.fit import FittingPoints, fit_backbone
    from freeplayid.model import build_fin_fe, load_fin_config, reduce_fin

    model = default_fin()
    cfg = load_fin_config()
    parts = dict(cfg.parts)
    parts["inboard"] = dataclasses.replace(parts["inboard"], E=0.9 * parts["inboard"].E)
    truth = reduce_fin(build_fin_fe(dataclasses.replace(cfg, parts=parts)))
    w2, shapes = scipy.linalg.eigh(truth.closed_stiffness(480.0), truth.M)
    ref_hz = np.sqrt(w2[:3]) / (2 * np.pi)
    f1 = np.sqrt(scipy.linalg.eigh(model.closed_stiffness(480.0), model.M,
                                   eigvals_only=True)[0]) / (2 * np.pi)
    assert ref_hz[0] / f1 - 1 == pytest.approx(-0.01, abs=0.002)
    chs = ["uz_top_left", "uz_lower_right"]
    rows = truth.dof_index(chs)
    bc = backbone_curve(truth, kn=480.0, delta=3e-3)
    ratio = bc.hinge_amplitude[0].max(axis=1) / 3e-3
    picks = [int(np.argmin(np.abs(ratio - r))) for r in (1.9, 2.4, 2.9, 3.4, 3.9)]
    points = FittingPoints(channel=np.repeat(chs, 5).tolist(),
                           amplitude_m=np.concatenate([bc.channel(c)[0, picks] for c in chs]),
                           f_hz=np.tile(bc.frequency_hz[0, picks], 2))

    def kn_error(n, own_scale_mode=0):
        upd = update_to_sealed_modes(model, 450.0, ref_hz[:n], shapes[rows, :n], chs,
                                     own_scale_mode=own_scale_mode)
        fit = fit_backbone(points, upd.system, init=(480.0, 3e-3))
        after = np.sqrt(scipy.linalg.eigh(upd.system.closed_stiffness(upd.kn), upd.system.M,
                                          eigvals_only=True)[:n]) / (2 * np.pi)
        assert after == pytest.approx(ref_hz[:n], rel=1e-4)  # the sealed modes reproduced
        assert abs(fit.delta / 3e-3 - 1) < 0.002
        return fit.kn / 480.0 - 1, upd

    three, upd = kn_error(3)
    assert abs(three) < 0.005 and upd.first_scale > upd.scale  # the plate: its lowest mode
    assert "lowest elastic open-hinge mode" in upd.describe()
    # the second scale on the next elastic mode fits the three modes exactly too, with another
    # kn: three sealed frequencies cannot tell the forms apart (benchmarks/sealed_forms.py)
    other, upd_other = kn_error(3, own_scale_mode=1)
    assert upd_other.parameters == 3 and "open-hinge elastic mode 2" in upd_other.describe()
    print(f"kn error: default form {100 * three:+.2f} %, the other {100 * other:+.2f} %")
    assert other < -0.01 and abs(other) > 3 * abs(three)
    two, upd2 = kn_error(2)
    assert abs(two) > 0.015 and upd2.first_scale == upd2.scale
    # each fits its modes exactly (three parameters to three modes, two to two), which measures
    # no model error: the option's uncertainty stands for kn's interval, not the 0.1 % floor
    from freeplayid.identification.model_error import frequency_uncertainty
    from freeplayid.model import ModelOptions

    assert (upd.parameters, upd2.parameters) == (3, 2)
    assert not upd.residual_measured and not upd2.residual_measured
    opts = ModelOptions(frequency_uncertainty=0.005)
    assert frequency_uncertainty(opts, upd) == max(0.005, upd.residual)
    assert frequency_uncertainty(opts, upd2) == 0.005
    # a fourth mode is more than the two scales and kn fit: the residual is then measured
    four = update_to_sealed_modes(model, 450.0, np.sqrt(w2[:4]) / (2 * np.pi),
                                  shapes[rows, :4], chs)
    assert four.parameters == 3 and four.residual_measured
    assert frequency_uncertainty(opts, four) == max(four.residual, 1e-3)


def test_update_needs_two_sealed_modes():
    model = default_fin()
    w2, shapes = scipy.linalg.eigh(model.closed_stiffness(480.0), model.M)
    assert update_to_sealed_modes(model, 400.0, np.sqrt(w2[:1]) / (2 * np.pi), shapes[:, :1],
                                  list(model.dof_names)) is None


def test_the_report_says_what_one_mode_can_tell_of_each_hinges_gap():
    """The default fin's two hinges turn together in mode 1 (their rotations within 10 % of
    each other, from a plain eigen-solve here): delta is their common (mean) half-gap."""
    from freeplayid.identification.model_error import ModelError, hinge_ratio

    model = default_fin()
    w2, phi = scipy.linalg.eigh(model.closed_stiffness(480.0), model.M)
    theta = np.abs(model.hinge_matrix().T @ phi[:, 0])
    ratio = hinge_ratio(model, 480.0, 0)
    assert ratio == pytest.approx(theta.min() / theta.max(), rel=1e-6)
    text = ModelError(None, 0.005, 0.015, ratio).describe()
    assert "turn together" in text and "mean" in text
    assert "hinge" not in ModelError(None, 0.005, 0.015, None).describe()


def _points_on_the_backbone(system, kn, delta, scatter, gaps=None):
    """A plain estimate stand-in: eight points on the DFA backbone (gaps per hinge, ``gaps``) of
    both measure points at the largest hinge amplitude 1.8-3.6 delta, fitted at (kn, delta)
    with RMS relative residual ``scatter``."""
    from types import SimpleNamespace

    from freeplayid.backbone import dfa_backbone
    from freeplayid.fit import FittingPoints

    curve = dfa_backbone(system, kn=kn, delta=delta, gaps=gaps, s=np.linspace(1.8, 3.6, 4))
    chans = ("uz_top_left", "uz_lower_right")
    amp = [curve.channel(c)[0, k] for c in chans for k in range(4)]
    f = [curve.frequency_hz[0, k] for _ in chans for k in range(4)]
    pts = FittingPoints(channel=tuple(c for c in chans for _ in range(4)),
                        amplitude_m=np.array(amp), f_hz=np.array(f))
    return SimpleNamespace(kn=kn, delta=delta, fitting_points=lambda: pts,
                           fit=SimpleNamespace(residual_rms=scatter))


def test_what_the_points_cannot_tell_of_unequal_gaps_grows_with_their_scatter():
    """The default fin at kn 480, delta 3 mrad: points with no scatter about the fit show any
    split of the gaps (split 0); the more they scatter, the larger the split they hide; a
    scatter of 5 % hides every split tried. The common delta's move grows with the split it
    hides; one hinge: no statement."""
    from freeplayid.identification.model_error import GAP_SPLITS, gap_split
    from freeplayid.model import sdof_system

    model = default_fin()
    splits = [gap_split(model, _points_on_the_backbone(model, 480.0, 3e-3, r))
              for r in (0.0, 2e-4, 1e-3, 5e-2)]
    assert splits[0].split == 0.0 and not splits[0].beyond
    assert 0.0 < splits[1].split < splits[2].split < GAP_SPLITS[-1]
    assert splits[1].delta_bias <= splits[2].delta_bias
    assert splits[3].beyond and splits[3].split == GAP_SPLITS[-1]
    assert "cannot tell such gaps apart" in splits[2].describe()
    assert gap_split(sdof_system(), _points_on_the_backbone(model, 480.0, 3e-3, 1e-3)) is None


def test_the_split_a_common_fit_leaves_unexplained_is_the_one_it_hides():
    """Points on the backbone of gaps 1.3 and 0.7 x delta (noise-free) fitted with one delta:
    their residual is what that split leaves visible, so taking it as the scatter, the split
    the points hide is close to 0.3 (the criterion compares the largest visible move with the
    RMS scatter, so somewhat below it). The common delta's move it states at that split is
    that of the common fit of points made with that split (its delta off the hinges' mean
    3 mrad) within a quarter (interpolated between the splits tried; the largest move of the
    splits below it, as before, stated 0.68 % against the fit's 1.46 %; now 1.43 %)."""
    from freeplayid.fit import fit_backbone
    from freeplayid.identification.model_error import gap_split

    model = default_fin()
    split = _points_on_the_backbone(model, 480.0, 3e-3, 0.0, gaps=[1.3, 0.7])
    fitted = fit_backbone(split.fitting_points(), model, init=(480.0, 3e-3))
    est = _points_on_the_backbone(model, fitted.kn, fitted.delta, fitted.residual_rms)
    got = gap_split(model, est)
    assert 0.1 < got.split < 0.3
    at = _points_on_the_backbone(model, 480.0, 3e-3, 0.0, gaps=[1 + got.split, 1 - got.split])
    moved = abs(fit_backbone(at.fitting_points(), model, init=(480.0, 3e-3)).delta / 3e-3 - 1)
    assert abs(got.delta_bias / moved - 1) < 0.25, (got, moved)



def test_points_at_a_fold_of_the_curve_are_left_out_of_what_a_split_hides(monkeypatch):
    """A two-hinge beam's curve folds at low amplitude: below it the hinges' fixed point does not
    converge and the lowest mode is a mechanism near 0 Hz. Made so here on the split curves
    below s = 2 (the lowest run of the points lies at 1.8), a point there would be read across
    the fold (6-8 % moves for a 5 % split on the beam, which stated a split of 0.15 % unseen);
    it is left out, and the split these data hide is that of the points without that run."""
    from types import SimpleNamespace

    from freeplayid.fit import FittingPoints
    from freeplayid.identification import model_error as me

    model = default_fin()
    est = _points_on_the_backbone(model, 480.0, 3e-3, 1e-3)
    pts = est.fitting_points()
    keep = np.arange(8) % 4 != 0  # the runs above the fold
    above = SimpleNamespace(kn=480.0, delta=3e-3, fit=est.fit, fitting_points=lambda: FittingPoints(
        channel=tuple(np.asarray(pts.channel)[keep]), amplitude_m=pts.amplitude_m[keep],
        f_hz=pts.f_hz[keep]))
    want = me.gap_split(model, above)
    real = me.dfa_backbone

    def folded(system, *, gaps=None, s=None, **kw):
        curve = real(system, gaps=gaps, s=s, **kw)
        if gaps is None:
            return curve
        fold = np.broadcast_to(s < 2.0, curve.frequency_hz.shape)
        return dataclasses.replace(curve, frequency_hz=np.where(fold, 1e-4, curve.frequency_hz),
                                   converged=curve.converged & ~fold)

    monkeypatch.setattr(me, "dfa_backbone", folded)
    got = me.gap_split(model, est)
    assert got.split == pytest.approx(want.split, rel=0.02)
    assert got.delta_bias == pytest.approx(want.delta_bias, rel=0.05)

def test_a_noisy_base_is_followed_over_a_narrower_band():
    """A 30 % dip (Gaussian, 0.4 Hz) of a 0.1 Hz/s sweep under 0.05 g of white noise (0.8 g
    level): the envelope the replay is driven by scatters less about the true profile than the
    response extraction's band gives (the narrow band is taken: envelope_noise >
    ENVELOPE_NOISE) and still dips by 30 %; the noiseless record keeps the wide band."""
    from freeplayid.replay.excitation import ENVELOPE_NOISE, envelope_noise
    from freeplayid.signal import acmp

    law = Sweep(start_hz=30.0, stop_hz=40.0, rate_hz_per_s=0.1)
    t = np.arange(0.0, law.duration, 1.0 / FS)
    f = law.frequency(t)
    dip = 1.0 - 0.3 * np.exp(-0.5 * ((f - 35.0) / 0.4) ** 2)
    clean = 0.8 * dip * np.sin(law.phase(t))
    noisy = clean + 0.05 * np.random.default_rng(3).standard_normal(t.size)
    inner = (t > 5) & (t < law.duration - 5)

    def envelope(base_g):
        run = Run(file="r.csv", time=t, data=np.zeros((1, t.size)), level_g=0.8,
                  sweep=law.to_dict(), base=base_g)
        ds = Dataset(name="dip", model=None, quantity="acceleration", units="g",
                     sample_rate=FS, channels={"a": "dof"}, runs=(run,), base_channel="acc_base")
        sweep, lvl = measured_sweep(ds, run, law)
        return sweep.envelope(t[inner]) * lvl / 0.8

    wide = acmp(noisy, FS, sweep=law, bandwidth_hz=1.0).amplitude[inner] / 0.8
    taken = envelope(noisy)
    truth = dip[inner]
    assert envelope_noise(wide, taken) > ENVELOPE_NOISE
    assert np.std(taken / truth - 1) < 0.7 * np.std(wide / truth - 1)
    assert taken[np.argmin(np.abs(f[inner] - 35.0))] == pytest.approx(0.7, abs=0.02)
    assert np.max(np.abs(envelope(clean) / truth - 1)) < 0.01  # noiseless: as recorded


def test_the_frequency_uncertainty_moves_the_identified_mode_by_that_much():
    """The model's frequency uncertainty u scales the structure's stiffness so that the closed
    mode 1 of the default fin moves by u (a plain eigen-solve here), not by the third of it a
    scale (1 + u)^2 of K gives with the hinge springs carrying two thirds of that mode."""
    from freeplayid.identification.model_error import frequency_scale

    model = default_fin()

    def f1(K):
        w2 = scipy.linalg.eigh(model.replace(K=K).closed_stiffness(480.0), model.M,
                               eigvals_only=True)
        return np.sqrt(w2[0])

    for u in (0.005, 0.01):
        s = frequency_scale(model, 480.0, u)
        assert f1(model.K * s) / f1(model.K) - 1 == pytest.approx(u, rel=0.05)
    assert f1(model.K * 1.005 ** 2) / f1(model.K) - 1 < 0.5 * 0.005


def _chain():
    """Three masses in a row (1, 0.5, 0.5 kg), the first on a 1e5 N/m spring to the base, each
    joined to the next by a freeplay spring only: at kn 2e4 N/m, in the closed mode 1 the
    outer hinge's relative motion is 0.6 of the inner one's (both gaps bend the backbone, at
    different amplitudes)."""
    from freeplayid.model import FreeplaySystem

    return FreeplaySystem(M=np.diag([1.0, 0.5, 0.5]), K=np.diag([1e5, 0.0, 0.0]),
                          dof_names=("x1", "x2", "x3"), hinge_pairs=(("x2", "x1"), ("x3", "x2")),
                          base_influence=np.ones(3))


def _noisy_points(system, kn, delta, gaps, chans, s, noise, seed=0):
    """Points on the DFA backbone of hinge gaps ``gaps`` x delta at largest hinge amplitudes
    ``s`` x delta, one run per amplitude (its channels), frequencies times 1 + noise x N(0, 1)."""
    from freeplayid.backbone import dfa_backbone
    from freeplayid.fit import FittingPoints

    curve = dfa_backbone(system, kn=kn, delta=delta, gaps=gaps, s=np.asarray(s, float))
    rng = np.random.default_rng(seed)
    n = len(s)
    noisy = 1 + noise * rng.standard_normal(n * len(chans))
    f = np.tile(curve.frequency_hz[0], len(chans)) * noisy
    return FittingPoints(channel=tuple(c for c in chans for _ in range(n)),
                         amplitude_m=np.concatenate([curve.channel(c)[0] for c in chans]),
                         f_hz=f, run=tuple(f"run{k}" for _ in chans for k in range(n)))


def test_one_half_gap_per_hinge_where_the_hinges_turn_unequally():
    """The chain (hinges turning 1 : 0.6) with half-gaps 0.8 and 1.2 x 2 mrad, points on
    that backbone with 0.05 % of frequency noise: the per-hinge fit finds each hinge's share
    within 3 %, both intervals hold it, and one common delta does not explain the points (the
    common fit's residual is many times the noise)."""
    from freeplayid.fit import fit_backbone
    from freeplayid.identification.model_error import fit_hinge_gaps, hinge_ratio

    chain = _chain()
    assert hinge_ratio(chain, 2e4, 0) == pytest.approx(0.6, abs=0.05)
    pts = _noisy_points(chain, 2e4, 2e-3, [0.8, 1.2], ("x2", "x3"),
                        np.linspace(2.8, 6.0, 7), 5e-4)
    common = fit_backbone(pts, chain, init=(2e4, 2e-3))
    got = fit_hinge_gaps(chain, pts, common.kn, common.delta, common_residuals=common.residuals)
    assert got.shares == pytest.approx((0.8, 1.2), rel=0.03)
    for r, share, w in zip((0.8, 1.2), got.shares, got.log_halfwidth, strict=True):
        assert abs(np.log(share / r)) <= w < np.log(1.2)
    assert not got.common_explains and got.p_common < 1e-3
    assert got.common_rms > 4 * got.residual_rms and got.residual_rms < 1e-3
    # the replay's correction of the common delta moves every hinge's gap alike
    gaps = got.half_gaps(1.1 * got.common_delta, (got.common_delta, 1.2 * got.common_delta))
    assert [g for g, _ in gaps] == pytest.approx([1.1 * d for d in got.deltas])
    assert [g for g, _ in gaps] == pytest.approx([1.76e-3, 2.64e-3], rel=0.03)
    assert all(lo < g < hi for g, (lo, hi) in gaps)
    assert "the hinges' gaps differ" in got.describe()


def test_one_half_gap_per_hinge_where_the_hinges_turn_together():
    """The default fin (hinges within 10 % of each other) with half-gaps 0.9 and 1.1 x 3 mrad
    and 0.2 % of frequency noise (the realtests records' scatter): the shares are not
    determined (intervals beyond a factor of two), one common delta explains the points, and
    the report says so; one hinge: no fit."""
    from freeplayid.fit import fit_backbone
    from freeplayid.identification.model_error import fit_hinge_gaps
    from freeplayid.model import sdof_system

    fin = default_fin()
    pts = _noisy_points(fin, 480.0, 3e-3, [0.9, 1.1], ("uz_top_left", "uz_lower_right"),
                        np.linspace(1.9, 3.9, 5), 2e-3)
    common = fit_backbone(pts, fin, init=(480.0, 3e-3))
    got = fit_hinge_gaps(fin, pts, common.kn, common.delta, common_residuals=common.residuals)
    assert got.common_explains and got.p_common > 0.01 and max(got.log_halfwidth) > np.log(2.0)
    assert "cannot tell the gaps apart" in got.describe()
    assert fit_hinge_gaps(sdof_system(), pts, 480.0, 3e-3) is None


def test_a_model_uncertainty_that_moves_kn_beyond_its_bound_is_said_and_passes():
    """``linear_model`` says where the model's frequency uncertainty moves kn beyond kn's 2 %
    bound, and how good the model must be for kn to hold it (0.5 % moving kn 4 %: within
    0.25 %); it passes all the same (kn is conditional on the model), and says nothing more
    where the move is within the bound (the default fin: 1.5 %) or no uncertainty is stated."""
    from freeplayid.identification.model_error import ModelError
    from freeplayid.identification.verdict import model_checks

    def check(u, shift):
        return {c.name: c for c in model_checks(ModelError(None, u, shift))}["linear_model"]

    far = check(0.005, 0.04)
    assert far.passed and "conditional on the linear model" in far.message
    assert "included in kn's interval (beyond kn's 2 % bound" in far.message
    assert "within 0.25 %" in far.message
    assert "bound" not in check(0.005, 0.015).message
    assert "bound" not in check(0.0, 0.0).message


def test_a_common_delta_the_points_reject_fails_the_verdict():
    """The verdict's ``hinge_gaps`` check: made only where the per-hinge fit ran, failed when its
    test rejects one common delta, with the residuals and the cause in its message."""
    from freeplayid.identification.model_error import GapSplit, HingeGaps, ModelError
    from freeplayid.identification.verdict import model_checks

    def error(p):
        hg = HingeGaps(("a/b", "c/d"), (2.1e-3, 2.9e-3), (0.3, 0.2), 2.4e-3, 2e-4, 1e-3, p)
        return ModelError(None, 0.005, 0.015, 0.45, None, hg)

    assert [c.name for c in model_checks(ModelError(None, 0.005, 0.015, 0.45))] == \
        ["linear_model"]
    bad = {c.name: c for c in model_checks(error(4e-6))}["hinge_gaps"]
    assert not bad.passed and "does not explain" in bad.message and "0.1 %" in bad.message
    assert "replay" in bad.message and "hinge_gaps=true" in bad.message
    good = {c.name: c for c in model_checks(error(0.2))}["hinge_gaps"]
    assert good.passed and "explains" in good.message and "mean" not in good.message
    # passed, with a split the points cannot see that moves delta beyond the 1 % bound: said
    unseen = dataclasses.replace(error(0.2), gaps=GapSplit(0.14, False, 3e-4, 0.0125))
    said = {c.name: c for c in model_checks(unseen)}["hinge_gaps"]
    assert said.passed and "±14 %" in said.message and "1.2 % from delta" in said.message
    small = dataclasses.replace(error(0.2), gaps=GapSplit(0.14, False, 3e-4, 0.006))
    assert "mean" not in {c.name: c for c in model_checks(small)}["hinge_gaps"].message
    assert error(4e-6).hinge_gaps.shares == pytest.approx((0.84, 1.16))
    # with the replay's split (``ReplayedSplit``) the check reads it instead of the F test
    from freeplayid.identification.model_error import ReplayedSplit

    split = ReplayedSplit(("a/b", "c/d"), (2.0e-3, 2.8e-3), (-0.16, 0.14), (0.02, 0.02), 8,
                          2.5e-3)
    read = {c.name: c for c in model_checks(dataclasses.replace(error(0.2), split=split))}
    assert not read["hinge_gaps"].passed and "gaps differ" in read["hinge_gaps"].message
    assert "other proportions" in read["hinge_gaps"].message  # the model's shape as a cause
    assert read["hinge_gaps"].value == pytest.approx(split.p) and split.p < 1e-3
    assert split.mean_offset == pytest.approx(2.5 / 2.4 - 1)
    near = dataclasses.replace(split, half_gaps=(2.1e-3, 2.9e-3))  # delta at their mean
    kept = {c.name: c for c in model_checks(dataclasses.replace(error(4e-6), split=near))}
    assert kept["hinge_gaps"].passed and "differing a little" in kept["hinge_gaps"].message
    assert "0.00 % from delta" in kept["hinge_gaps"].message
    noisy = dataclasses.replace(split, log_se=(0.1, 0.1))
    quiet = {c.name: c for c in model_checks(dataclasses.replace(error(4e-6), split=noisy))}
    assert quiet["hinge_gaps"].passed and "explains the test" in quiet["hinge_gaps"].message
    assert "would not show" not in quiet["hinge_gaps"].message  # no GapSplit given
    # passed against the replay too, where a split the points cannot see would put the hinges'
    # mean beyond delta's bound: said there as well (fin D: ±34 %, 7.2 %), and not on a failure
    unseen_read = dataclasses.replace(error(4e-6), split=noisy,
                                      gaps=GapSplit(0.34, False, 2.4e-3, 0.072))
    both = {c.name: c for c in model_checks(unseen_read)}["hinge_gaps"]
    assert both.passed and "explains the test" in both.message
    assert "±34 % would not show" in both.message and "7.2 % from delta" in both.message
    failed = {c.name: c for c in model_checks(dataclasses.replace(
        unseen_read, split=split))}["hinge_gaps"]
    assert not failed.passed and "would not show" not in failed.message


def test_identify_reports_each_hinges_half_gap_on_request(tmp_path):
    """The bundled example (hinges turning together) with ``hinge_gaps``: the report's table
    and the JSON give each hinge's half-gap with an interval holding the reported delta's
    scale; without the option no per-hinge fit and no check (the hinges turn together)."""
    import json
    from pathlib import Path

    import freeplayid

    example = Path(__file__).resolve().parents[1] / "examples" / "fin_sweeps"
    res = freeplayid.identify(example, replay=None, model={"hinge_gaps": True}, progress=False)
    gaps = res.hinge_gap_records()
    assert len(gaps) == 2 and all(g["delta_ci95"][0] < g["delta"] < g["delta_ci95"][1]
                                  for g in gaps)
    assert np.mean([g["delta"] for g in gaps]) == pytest.approx(res.delta, rel=0.5)
    assert "One half-gap per hinge" in res.report()
    record = json.loads(json.dumps(res.to_dict()))
    assert record["hinge_gaps"][0]["hinge"] == gaps[0]["hinge"]
    assert record["model_error"]["per_hinge"] is True
    plain = freeplayid.identify(example, replay=None, progress=False)
    assert plain.model_error.hinge_gaps is None and plain.hinge_gap_records() == []
    assert "hinge_gaps" not in [c.name for c in plain.verdict.checks]


def test_the_replayed_answer_reads_each_hinges_half_gap_against_its_replay():
    """The bundled example (equal gaps) with ``hinge_gaps`` and the replay: the split is read
    against the answer's replay on every one of the eight noisy copies (none stops early), shows
    nothing beyond its noise, and the check passes, in the report, the JSON and the per-hinge
    table, whose half-gaps lie either side of the reported delta, their mean within 1 % of it.
    (Their intervals held delta too until the base's phase was read against the sweep law,
    session 37: the copies' spread halved, the split of 3.45 / 2.58 mrad did not move, and each
    hinge's interval now misses delta, docs/identify.md §3c "Hinges".)"""
    import json
    from pathlib import Path

    import freeplayid

    example = Path(__file__).resolve().parents[1] / "examples" / "fin_sweeps"
    res = freeplayid.identify(example, model={"hinge_gaps": True}, progress=False)
    split = res.model_error.split
    assert split is not None and split.n_copies == res.replay.precision.n_fitted == 8
    assert split.p > 0.01 and abs(split.mean_offset) < 0.05
    check = {c.name: c for c in res.verdict.checks}["hinge_gaps"]
    assert check.passed and "against the answer's replay" in check.message
    gaps = res.hinge_gap_records()
    assert [g["delta"] for g in gaps] == pytest.approx(split.half_gaps)
    low, high = sorted(g["delta"] for g in gaps)
    assert low < res.delta < high and abs((low + high) / 2 / res.delta - 1) < 0.01
    record = json.loads(json.dumps(res.to_dict()))
    assert record["model_error"]["split"]["n_copies"] == 8


def test_widen_adds_a_relative_move_to_the_log_half_widths_in_quadrature():
    """An interval widened by a 95 % relative move: each side's log half-width and the move in
    quadrature, by hand; no move leaves the interval as it is."""
    from freeplayid.identification.model_error import widen

    lo, hi = widen((2.7e-3, 3.4e-3), 3e-3, 0.02)
    assert math.log(3e-3 / lo) == pytest.approx(math.sqrt(math.log(3 / 2.7) ** 2 + 0.02 ** 2))
    assert math.log(hi / 3e-3) == pytest.approx(math.sqrt(math.log(3.4 / 3) ** 2 + 0.02 ** 2))
    assert widen((2.7e-3, 3.4e-3), 3e-3, 0.0) == pytest.approx((2.7e-3, 3.4e-3), rel=1e-14)
    assert widen((0.0, math.inf), 3e-3, 0.02) == (0.0, math.inf)


def test_intervals_stretch_where_the_answer_moves_further_than_its_statistic():
    """The precision's copies spread the statistic's delta by +-1 % and, carried through the
    binding's slope, the answer's by +-2 %: delta's log half-widths double (by hand), kn's
    (the same spread) stay; a slope that would narrow them, or no slope, leaves them."""
    from freeplayid.identification.pipeline import _further, _stretched
    from freeplayid.replay import ReplayPrecision

    p = ReplayPrecision(kn_halfwidth=0.005, delta_halfwidth=0.02, n=8, n_fitted=8,
                        statistic_halfwidths=(0.005, 0.01))
    kn_f, delta_f = _further(p)
    assert kn_f == 1.0 and delta_f == pytest.approx(math.log(1.02) / math.log(1.01))
    lo, hi = _stretched((2.9e-3, 3.05e-3), 3e-3, delta_f)
    assert math.log(3e-3 / lo) == pytest.approx(delta_f * math.log(3 / 2.9))
    assert math.log(hi / 3e-3) == pytest.approx(delta_f * math.log(3.05 / 3))
    narrower = ReplayPrecision(kn_halfwidth=0.004, delta_halfwidth=0.008, n=8, n_fitted=8,
                               statistic_halfwidths=(0.005, 0.01))
    assert _further(narrower) is None
    assert _further(dataclasses.replace(p, statistic_halfwidths=None)) is None
    assert _further(None) is None


def test_intervals_are_never_narrower_than_the_noise_moves_the_answer():
    """A Jacobian interval of +-0.25 % (four runs that happen to agree) under copies that spread
    delta by +-1.2 %: delta's interval becomes +-1.2 % about the answer (by hand); kn's, already
    wider than its copies' spread, stays; without copies nothing changes."""
    from types import SimpleNamespace

    from freeplayid.identification.pipeline import _corrected_intervals
    from freeplayid.replay import ReplayPrecision

    p = ReplayPrecision(kn_halfwidth=0.006, delta_halfwidth=0.012, n=8, n_fitted=8)
    rep = SimpleNamespace(statistic_ci95=((460.0, 500.0), (2.9925e-3, 3.0075e-3)), kn=480.0,
                          delta=3e-3, kn_statistic=480.0, delta_statistic=3e-3, precision=p,
                          bootstrap=None, level=None, damping_sensitivity=None, damping=None)
    kn_ci, delta_ci, source = _corrected_intervals(rep)
    assert kn_ci == pytest.approx((460.0, 500.0), rel=1e-14)
    assert delta_ci == pytest.approx((3e-3 / 1.012, 3e-3 * 1.012), rel=1e-12)
    assert "noise alone" in source
    kn_ci, delta_ci, source = _corrected_intervals(SimpleNamespace(**{**vars(rep),
                                                                     "precision": None}))
    assert delta_ci == pytest.approx((2.9925e-3, 3.0075e-3), rel=1e-14)
    assert "noise alone" not in source


def test_the_quadrature_point_under_noise_is_read_where_the_lag_crosses():
    """A lag passing a quarter period slowly (0.1 rad/s at 37.0 Hz, as near a fold), white
    noise on the base and the response half as loud as the base: over 16 draws the quadrature
    point is 37.0 Hz on average within 0.1 Hz, and no draw is 1 Hz off. The first sign change
    of the noisy phase difference read it 0.22 Hz early on average (noise makes early
    crossings); a line through the crossing does not."""
    t = np.arange(0.0, LAW.duration, 1.0 / FS)
    psi = LAW.phase(t)
    base = 2.0 * np.cos(psi)
    amp = (2.0 + 18.0 * np.clip(t / 18.0, 0, 1)) * (1.0 - 0.9 * np.clip((t - 18.0) / 0.1, 0, 1))
    lag = np.where(t > 18.0, np.pi - 0.2, np.pi / 2 + 0.1 * (t - 14.0))
    response = amp * np.cos(psi - lag) + base
    rng = np.random.default_rng(11)
    errors = []
    for _ in range(16):
        nb, nr = rng.standard_normal((2, t.size))
        errors.append(_points("quadrature", response + nb + nr, base + nb).f_hz
                      - LAW.frequency(14.0))
    errors = np.array(errors)
    assert abs(errors.mean()) < 0.1 and np.max(np.abs(errors)) < 1.0, errors


def test_a_wider_window_reads_the_quadrature_amplitude_with_less_noise_at_the_same_point():
    """``drop_window`` w on the quadrature point: its amplitude read over a Gaussian w times as
    wide (about the phase resonance, still cut at the drop), its frequency (the lag's crossing)
    not moved. On the hand-made record (the envelope a straight line in time, which a symmetric
    window averages to its centre's value) noise-free: the same frequency to 1e-9 and the same
    amplitude within 0.5 %; under white noise on the response (16 draws) the amplitude's
    standard deviation falls by sqrt(w) for a full Gaussian (theory: N = 2 sqrt(pi) sigma fs
    effective samples), so by 0.5 at w = 4, less where the drop cuts the window."""
    _, response, base = _record(12.0, 20.0, phase_swing=1.2)

    def point(x, w):
        pts = extract_backbone_points(x[None, None, :], FS, quantity="acceleration", sweep=LAW,
                                      base=base[None, :], jump_point="quadrature", drop_window=w)
        p = pts.points[0]
        assert p.used, p.reason
        return p

    one, four = point(response, 1.0), point(response, 4.0)
    assert four.f_hz == pytest.approx(one.f_hz, abs=1e-9)
    assert four.amplitude_m == pytest.approx(one.amplitude_m, rel=5e-3)
    rng = np.random.default_rng(5)
    amps = {1.0: [], 4.0: []}
    for _ in range(16):
        noisy = response + 2.0 * rng.standard_normal(response.shape)
        for w, out in amps.items():
            out.append(point(noisy, w).amplitude_m)
    ratio = float(np.std(amps[4.0], ddof=1) / np.std(amps[1.0], ddof=1))
    assert 0.3 < ratio < 0.75, ratio


def test_the_quadrature_reference_is_the_phase_the_replay_is_driven_with():
    """One reading of the base for both: on a noisy base record (the narrow band is taken) and a
    clean one (the wide band), the quadrature rule's base phase is the measured excitation's
    (``measured_sweep``'s phase is the record's ``A sin``: a quarter period ahead)."""
    from freeplayid.signal import Extraction
    from freeplayid.signal.extract import _base_phase

    t = np.arange(0.0, LAW.duration, 1.0 / FS)
    clean = 0.3 * np.sin(LAW.phase(t))
    for base_g in (clean, clean + 0.2 * np.random.default_rng(5).standard_normal(t.size)):
        run = Run(file="r.csv", time=t, data=np.zeros((1, t.size)), level_g=0.3,
                  sweep=LAW.to_dict(), base=base_g)
        ds = Dataset(name="b", model=None, quantity="acceleration", units="g", sample_rate=FS,
                     channels={"a": "dof"}, runs=(run,), base_channel="acc_base")
        sweep, _ = measured_sweep(ds, run, LAW)
        ref = _base_phase(ds.to_si(base_g), FS, trim=int(FS), sweep=LAW, opts=Extraction(),
                          quantity="acceleration")
        assert np.allclose(np.cos(sweep.phase(t) - np.pi / 2 - ref), 1.0, atol=1e-9)


def _constant_level_base(level_g: float, noise_g: float, seed: int = 5):
    """A 0.1 Hz/s sweep's base record at a constant ``level_g`` [g] under white noise: (the
    measured excitation, its level, the true relative envelope error at the inner samples, t)."""
    law = Sweep(start_hz=30.0, stop_hz=40.0, rate_hz_per_s=0.1)
    t = np.arange(0.0, law.duration, 1.0 / FS)
    base = level_g * np.sin(law.phase(t))
    if noise_g:
        base = base + noise_g * np.random.default_rng(seed).standard_normal(t.size)
    run = Run(file="r.csv", time=t, data=np.zeros((1, t.size)), level_g=level_g,
              sweep=law.to_dict(), base=base)
    ds = Dataset(name="level", model=None, quantity="acceleration", units="g", sample_rate=FS,
                 channels={"a": "dof"}, runs=(run,), base_channel="acc_base")
    sweep, lvl = measured_sweep(ds, run, law)
    inner = (t > 5) & (t < law.duration - 5)
    return sweep, lvl, sweep.envelope(t[inner]) * lvl / level_g - 1, t[inner]


def _lag_correlation(e: np.ndarray, lag_s: float) -> float:
    k = int(lag_s * FS)
    return float(np.corrcoef(e[:-k], e[k:])[0, 1])


@pytest.mark.parametrize("level_g, noise_g", [(0.4, 0.05), (1.0, 0.05), (0.3, 0.15)])
def test_the_reading_noise_of_a_noisy_base_is_the_scatter_of_its_envelope(level_g, noise_g):
    """The envelope of a constant-level base record under white noise scatters about the
    true (constant) level by what ``reading_sd`` says, within 25 %; a noiseless record is read
    as exact, and its excitation copies are itself."""
    sweep, _, err, _ = _constant_level_base(level_g, noise_g)
    assert sweep.reading_sd == pytest.approx(np.std(err), rel=0.25)
    assert sweep.reading_band_hz == pytest.approx(0.25, rel=0.1)  # the narrow band was taken
    clean, _, err0, _ = _constant_level_base(level_g, 0.0)
    assert clean.reading_sd < 1e-4 and np.std(err0) < 1e-4
    assert read_again(clean, np.random.default_rng(0)) is clean


def test_an_excitation_read_again_has_the_readings_noise_and_its_pace():
    """A copy's envelope departs from the measured one as the measured one departs from the
    truth: the same standard deviation (by construction) and the same correlation a second
    apart (about 0.75 for the narrow band, averaged over four noise draws), within 0.1; its
    phase is the measured one."""
    sweep, _, _, t = _constant_level_base(0.5, 0.05)
    truth = [_constant_level_base(0.5, 0.05, seed=s)[2] for s in range(4)]
    rng = np.random.default_rng(11)
    moves = [read_again(sweep, rng).envelope(t) / sweep.envelope(t) - 1 for _ in range(4)]
    assert np.mean([np.std(m) for m in moves]) == pytest.approx(sweep.reading_sd, rel=0.1)
    assert np.mean([_lag_correlation(m, 1.0) for m in moves]) == pytest.approx(
        np.mean([_lag_correlation(e, 1.0) for e in truth]), abs=0.1)
    copy = read_again(sweep, rng)
    assert np.array_equal(copy.phase_samples, sweep.phase_samples)


def test_one_step_reads_the_noise_as_the_whole_pursuit_does(monkeypatch):
    """The copies' reading noise read by one step of the pursuit at the excitation's own
    frequency (``READ_AGAIN_STEPS``) is the whole pursuit's to a correlation above 0.999 on the
    same noise draws (both scaled to ``reading_sd`` alike)."""
    from freeplayid.replay import excitation

    sweep, _, _, t = _constant_level_base(0.5, 0.05)

    def moves(steps):
        monkeypatch.setattr(excitation, "READ_AGAIN_STEPS", steps)
        rng = np.random.default_rng(5)
        return [read_again(sweep, rng).envelope(t) / sweep.envelope(t) - 1 for _ in range(2)]

    for one, whole in zip(moves(1), moves(100), strict=True):
        assert np.corrcoef(one, whole)[0, 1] > 0.999


def test_intervals_take_in_the_base_channels_noise():
    """The excitation copies' half-widths join the intervals in quadrature (by hand), and the
    noise check's spread alike (since session 52: on 364 stored realtests answers it caught 4
    ``ok`` answers outside the bounds and made 2 accurate ones ``suspect``)."""
    from types import SimpleNamespace

    from freeplayid.identification.pipeline import _corrected_intervals
    from freeplayid.identification.replay_checks import noise_outside_chance, precision_check
    from freeplayid.replay import ExcitationNoise, ReplayPrecision

    p = ReplayPrecision(kn_halfwidth=0.004, delta_halfwidth=0.006, n=8, n_fitted=8)
    e = ExcitationNoise(kn_halfwidth=0.003, delta_halfwidth=0.008, reading_sd={"r": 0.01},
                        n=4, n_fitted=4)
    rep = SimpleNamespace(statistic_ci95=((470.0, 490.0), (2.97e-3, 3.03e-3)), kn=480.0,
                          delta=3e-3, kn_statistic=480.0, delta_statistic=3e-3, precision=p,
                          bootstrap=None, level=None, damping_sensitivity=None, damping=None,
                          excitation_noise=e)
    _, delta_ci, source = _corrected_intervals(rep)
    own = math.log(3.03e-3 / 3e-3)
    assert math.log(delta_ci[1] / 3e-3) == pytest.approx(math.hypot(own, math.log1p(0.008)))
    assert "base channel" in source
    assert precision_check(p).value == pytest.approx(noise_outside_chance(0.006, 0.01))
    both = math.expm1(math.hypot(math.log1p(0.006), math.log1p(0.008)))
    assert precision_check(p, e).value == pytest.approx(noise_outside_chance(both, 0.01))


def test_an_excitation_copy_that_cannot_be_fitted_is_drawn_again():
    """A copy whose fit fails is no move: it is drawn again, up to the attempts allowed, so
    that two copies measure the base's noise where one failed (before, the one left counted
    for nothing, and the base's noise was left out of the noise check)."""
    from freeplayid.errors import IdentificationError
    from freeplayid.replay.corrected import EXCITATION_TRIES, fitted_moves

    def script(outcomes):
        it = iter(outcomes)
        calls = []

        def move():
            calls.append(1)
            out = next(it)
            if out is None:
                raise IdentificationError("a run's point left its window")
            return out
        return move, calls

    move, calls = script([None, 0.1, 0.2, 0.3])
    assert fitted_moves(move, 2, range(EXCITATION_TRIES * 2)) == [0.1, 0.2] and len(calls) == 3
    move, calls = script([0.1, 0.2, 0.3])  # no failure: the first two, as before the retries
    assert fitted_moves(move, 2, range(4)) == [0.1, 0.2] and len(calls) == 2
    move, calls = script([None, None, None, 0.4])  # the attempts run out
    assert fitted_moves(move, 2, range(4)) == [0.4] and len(calls) == 4
    assert EXCITATION_TRIES >= 2


def test_copies_that_stopped_early_give_their_bound_without_students_t():
    """Where two runs fit exactly the copies' spread is the interval: taken to Student's t at
    their degrees of freedom (by hand, 3.18 / 1.96 from four), but not where the copies
    stopped early, whose half-widths are 95 % upper bounds already."""
    from types import SimpleNamespace

    import scipy.stats

    from freeplayid.identification.pipeline import _corrected_intervals
    from freeplayid.replay import ReplayPrecision

    def delta_halfwidth(settled):
        p = ReplayPrecision(kn_halfwidth=0.004, delta_halfwidth=0.006, n=4, n_fitted=4,
                            settled=settled)
        rep = SimpleNamespace(statistic_ci95=((0.0, math.inf), (0.0, math.inf)), kn=480.0,
                              delta=3e-3, kn_statistic=480.0, delta_statistic=3e-3,
                              precision=p, bootstrap=None, level=None,
                              damping_sensitivity=None, damping=None, excitation_noise=None)
        _, delta_ci, _ = _corrected_intervals(rep)
        return math.log(delta_ci[1] / 3e-3)

    t = scipy.stats.t.ppf(0.975, 3) / 1.96
    assert delta_halfwidth(False) == pytest.approx(t * math.log1p(0.006))
    assert delta_halfwidth(True) == pytest.approx(math.log1p(0.006))


def test_sharpening_undoes_the_narrow_bands_rounding_of_a_short_dip():
    """A 20 % dip with 3 s flanks and a 3 s floor (0.1 Hz/s) on a noiseless base, read over a
    quarter of the response band: the plain narrow reading misses the known profile by up to
    2 % of the level about the dip; two sharpening steps leave less than half of that (0.9 %),
    at the floor 0.4 % of 0.9 %; a constant level is left as it is."""
    from freeplayid.signal import acmp
    from freeplayid.signal.level import sharpened

    law = Sweep(start_hz=30.0, stop_hz=40.0, rate_hz_per_s=0.1)
    t = np.arange(0.0, law.duration, 1.0 / FS)
    x = np.abs(law.frequency(t) - 35.0)
    taper = np.clip((x - 0.15) / 0.3, 0.0, 1.0)
    profile = 1.0 - 0.2 * np.where(x <= 0.15, 1.0, 0.5 * (1 + np.cos(np.pi * taper)))
    narrow = acmp(profile * np.sin(law.phase(t)), FS, sweep=law, bandwidth_hz=0.25)
    near = x < 1.0
    a = sharpened(narrow, FS, law)
    plain = np.max(np.abs(narrow.amplitude[near] - profile[near]))
    assert plain > 0.015
    assert np.max(np.abs(a[near] - profile[near])) < 0.5 * plain
    floor = np.argmin(x)
    assert abs(a[floor] - profile[floor]) < 0.5 * abs(narrow.amplitude[floor] - profile[floor])
    flat = acmp(np.sin(law.phase(t)), FS, sweep=law, bandwidth_hz=0.25)
    inner = (t > 5) & (t < law.duration - 5)
    assert np.max(np.abs(sharpened(flat, FS, law)[inner] - 1.0)) < 1e-3


def test_only_a_reading_that_shows_a_rounded_profile_is_sharpened():
    """Under 0.05 g of noise: a constant 0.5 g level shows nothing the band rounds (its first
    step's correction stays within noise), a 20 % dip with 3 s flanks at 0.8 g does; the
    measured excitation is sharpened (``reading_steps``) for the dip only."""
    from freeplayid.signal import acmp
    from freeplayid.signal.level import NARROW_BASE, reading_sd, rounds

    law = Sweep(start_hz=30.0, stop_hz=40.0, rate_hz_per_s=0.1)
    t = np.arange(0.0, law.duration, 1.0 / FS)
    x = np.abs(law.frequency(t) - 35.0)
    taper = np.clip((x - 0.15) / 0.3, 0.0, 1.0)
    dip = 1.0 - 0.2 * np.where(x <= 0.15, 1.0, 0.5 * (1 + np.cos(np.pi * taper)))
    noise = 0.05 * np.random.default_rng(8).standard_normal(t.size)
    for level, profile, seen in ((0.5, np.ones_like(t), False), (0.8, dip, True)):
        base = level * profile * np.sin(law.phase(t)) + noise
        wide = acmp(base, FS, sweep=law, bandwidth_hz=1.0)
        narrow = acmp(base, FS, sweep=law, bandwidth_hz=NARROW_BASE)
        assert rounds(narrow, FS, law, reading_sd(wide, narrow, narrow)) is seen
        run = Run(file="r.csv", time=t, data=np.zeros((1, t.size)), level_g=level,
                  sweep=law.to_dict(), base=base)
        ds = Dataset(name="r", model=None, quantity="acceleration", units="g", sample_rate=FS,
                     channels={"a": "dof"}, runs=(run,), base_channel="acc_base")
        assert measured_sweep(ds, run, law)[0].reading_steps == (2 if seen else 0)


def test_two_runs_take_their_intervals_from_the_noisy_copies():
    """Two runs fit exactly, so the statistic's Jacobian interval is (0, inf); eight noisy
    copies that spread delta by +-0.6 % (1.96 sd) give the answer +-0.6 % x t_0.975(7) / 1.96
    (by hand: 2.3646 / 1.96), kn alike, and the interval check passes; with fewer than three
    fitted copies, or none, the interval stays unbounded and the check names the two runs."""
    from types import SimpleNamespace

    from freeplayid.identification.pipeline import _corrected_intervals
    from freeplayid.identification.verdict import interval_check
    from freeplayid.replay import ReplayPrecision

    p = ReplayPrecision(kn_halfwidth=0.005, delta_halfwidth=0.006, n=8, n_fitted=8)
    rep = SimpleNamespace(statistic_ci95=((0.0, math.inf), (0.0, math.inf)), kn=600.0,
                          delta=4.5e-3, kn_statistic=598.0, delta_statistic=4.49e-3,
                          precision=p, bootstrap=None, level=None, damping_sensitivity=None,
                          damping=None, excitation_noise=None)
    kn_ci, delta_ci, source = _corrected_intervals(rep)
    t = 2.364624251592785 / 1.96  # scipy-free: t_0.975 at 7 degrees of freedom
    assert math.log(delta_ci[1] / 4.5e-3) == pytest.approx(t * math.log(1.006), rel=1e-6)
    assert math.log(4.5e-3 / delta_ci[0]) == pytest.approx(t * math.log(1.006), rel=1e-6)
    assert math.log(kn_ci[1] / 600.0) == pytest.approx(t * math.log(1.005), rel=1e-6)
    assert "noisy copies" in source and "two runs" in source
    assert interval_check(600.0, 4.5e-3, kn_ci, delta_ci, n_runs=2).passed
    for few in (dataclasses.replace(p, n_fitted=2), None):
        kn_ci, delta_ci, _ = _corrected_intervals(SimpleNamespace(**{**vars(rep),
                                                                     "precision": few}))
        assert math.isinf(delta_ci[1])
        check = interval_check(600.0, 4.5e-3, kn_ci, delta_ci, n_runs=2)
        assert not check.passed and "only 2 runs gave points" in check.message


def test_an_unconverged_answer_passes_only_where_its_intervals_reach_the_solution():
    """A loop that stopped 0.35 standard errors from the test's statistics (as two accurate
    contact-damping answers did after 8 replays): its intervals are joined with themselves
    moved to where the binding's slope puts the solution (by hand: delta's upper end times
    exp(0.004), the lower end kept; kn's lower end times exp(-0.002)), and the convergence check
    passes and says where; 1.5 standard errors away, or without the offset, it fails."""
    from types import SimpleNamespace

    from freeplayid.identification.pipeline import _corrected_intervals
    from freeplayid.identification.replay_checks import _converged_check
    from freeplayid.identification.report import _offset_text

    rep = SimpleNamespace(statistic_ci95=((470.0, 490.0), (2.97e-3, 3.03e-3)), kn=480.0,
                          delta=3e-3, kn_statistic=480.0, delta_statistic=3e-3, precision=None,
                          bootstrap=None, level=None, damping_sensitivity=None, damping=None,
                          excitation_noise=None, converged=False,
                          unconverged_offset=(0.002, -0.004), closest_misfit_se=0.35,
                          iterations=(None,) * 8, stopped="")
    kn_ci, delta_ci, source = _corrected_intervals(rep)
    assert kn_ci == pytest.approx((470.0 * math.exp(-0.002), 490.0), rel=1e-12)
    assert delta_ci == pytest.approx((2.97e-3, 3.03e-3 * math.exp(0.004)), rel=1e-12)
    assert "unconverged loop's solution" in source
    check = _converged_check(rep)
    assert check.passed and "did not converge in 8 replays" in check.message
    assert "delta +0.4 %" in check.message and "kn -0.2 %" in check.message
    far = SimpleNamespace(**{**vars(rep), "closest_misfit_se": 1.5})
    assert not _converged_check(far).passed
    blind = SimpleNamespace(**{**vars(rep), "unconverged_offset": None})
    assert not _converged_check(blind).passed
    said = _offset_text(rep)  # the report's replay paragraph says the same
    assert "kn -0.2 %" in said and "delta +0.4 %" in said and "intervals reach" in said
    assert _offset_text(blind) == "" and _offset_text(SimpleNamespace(**{**vars(rep),
                                                                       "converged": True})) == ""
    assert _corrected_intervals(blind)[1] == pytest.approx((2.97e-3, 3.03e-3), rel=1e-14)


class _Points:
    """Fitting points as :func:`replayed_intervals` reads them: runs and channels."""

    def __init__(self, run, channel):
        self.run, self.channel = list(run), list(channel)

    def __len__(self):
        return len(self.run)


def _estimate(run, channel, residuals, *, jacobian=None, weights=None, kn=480.0, delta=3e-3):
    from types import SimpleNamespace

    r = np.asarray(residuals, float)
    fit = SimpleNamespace(kn=kn, delta=delta, residuals=r, jacobian=jacobian,
                          weights=np.ones(r.size) if weights is None else np.asarray(weights))
    return SimpleNamespace(fit=fit, fitting_points=lambda: _Points(run, channel))


def test_intervals_come_from_the_residuals_the_replay_does_not_reproduce():
    """Four runs of two channels whose points lie off the backbone by -1.0 ... +1.5 % (a
    down-sweep's jump-ups), which the replay reproduces to within 0.02-0.05 %: the intervals
    are the by-run Gauss-Newton ones (by hand: run means, s^2 over 2 degrees of freedom,
    t_0.975(2) = 4.3027) of the measured less the replayed residuals, weighted, about the
    statistic's fit; a point the replay lacks is left out; with two runs matched, a repeated
    (run, channel) or no Jacobian there are none."""
    from freeplayid.replay import replayed_intervals

    run = ["a", "a", "b", "b", "c", "c", "d", "d"]
    ch = ["tip", "root"] * 4
    systematic = np.array([-0.010, -0.011, 0.004, 0.005, 0.015, 0.013, -0.006, -0.004])
    noise = np.array([2e-4, 3e-4, -4e-4, -2e-4, 5e-4, 1e-4, -1e-4, -3e-4])
    J = np.array([[0.2, -0.9], [0.25, -0.85], [0.4, -0.6], [0.45, -0.55],
                  [0.6, -0.35], [0.62, -0.3], [0.8, -0.15], [0.85, -0.1]])
    w = np.array([1.0, 0.5, 1.0, 0.5, 1.0, 0.5, 1.0, 0.5])
    measured = _estimate(run, ch, systematic + noise, jacobian=J, weights=w)
    # the replay lists its points in another order and has one more (not matched)
    order = [7, 6, 5, 4, 3, 2, 1, 0]
    replayed = _estimate([run[i] for i in order] + ["e"], [ch[i] for i in order] + ["tip"],
                         list(systematic[order]) + [0.0])
    kn_ci, delta_ci = replayed_intervals(measured, replayed)
    d = w * noise
    rm = np.array([d[2 * k: 2 * k + 2].mean() for k in range(4)])
    Jm = np.array([J[2 * k: 2 * k + 2].mean(axis=0) for k in range(4)])
    cov = float(rm @ rm) / 2 * np.linalg.inv(Jm.T @ Jm)
    half = 4.302652729911275 * np.sqrt(np.diag(cov))
    assert math.log(kn_ci[1] / 480.0) == pytest.approx(half[0], rel=1e-9)
    assert math.log(480.0 / kn_ci[0]) == pytest.approx(half[0], rel=1e-9)
    assert math.log(delta_ci[1] / 3e-3) == pytest.approx(half[1], rel=1e-9)
    # the measured residuals' own scatter gives intervals many times wider
    own = w * (systematic + noise)
    ro = np.array([own[2 * k: 2 * k + 2].mean() for k in range(4)])
    assert float(ro @ ro) > 100 * float(rm @ rm)
    # a point the replay lacks is left out: run d on one channel
    lacking = _estimate(run[:7], ch[:7], systematic[:7])
    kn_7, _ = replayed_intervals(measured, lacking)
    assert kn_7 != pytest.approx(kn_ci, rel=1e-6)
    two = _estimate(run[:4], ch[:4], systematic[:4])
    assert replayed_intervals(measured, two) is None
    repeated = _estimate(run, ["tip"] * 8, systematic + noise, jacobian=J, weights=w)
    assert replayed_intervals(repeated, replayed) is None
    assert replayed_intervals(_estimate(run, ch, systematic + noise), replayed) is None


def test_the_reported_intervals_start_from_the_replayed_residuals():
    """With ``replayed_ci95`` the corrected intervals are those, moved with the estimate (the
    statistic's own, +-4 %, are not used); without, the statistic's own."""
    from types import SimpleNamespace

    from freeplayid.identification.pipeline import _corrected_intervals

    rep = SimpleNamespace(statistic_ci95=((460.0, 500.0), (2.88e-3, 3.12e-3)),
                          replayed_ci95=((475.0, 485.0), (2.98e-3, 3.02e-3)), kn=490.0,
                          delta=3.03e-3, kn_statistic=480.0, delta_statistic=3e-3,
                          precision=None, bootstrap=None, level=None,
                          damping_sensitivity=None, damping=None, excitation_noise=None)
    kn_ci, delta_ci, source = _corrected_intervals(rep)
    assert kn_ci == pytest.approx((475.0 * 490 / 480, 485.0 * 490 / 480), rel=1e-14)
    assert delta_ci == pytest.approx((2.98e-3 * 1.01, 3.02e-3 * 1.01), rel=1e-14)
    assert "does not reproduce" in source
    kn_ci, _, source = _corrected_intervals(SimpleNamespace(**{**vars(rep),
                                                               "replayed_ci95": None}))
    assert kn_ci == pytest.approx((460.0 * 490 / 480, 500.0 * 490 / 480), rel=1e-14)
    assert "does not reproduce" not in source


def _biased(points, bias):
    """``points`` with each frequency times 1 + bias[i] (a sweep's bias, the same in a test and
    its replay)."""
    from freeplayid.fit import FittingPoints

    return FittingPoints(channel=points.channel, amplitude_m=points.amplitude_m,
                         f_hz=points.f_hz * (1 + np.asarray(bias)), run=points.run)


def test_the_split_read_against_the_replay_is_the_hinges_own():
    """The chain (hinges turning 1 : 0.6) with half-gaps 0.8 and 1.2 x 2 mrad as the test, its
    replay at the common fit's answer with one gap for both, and four noisy copies of that
    replay (0.05 % of frequency noise): a sweep's bias of up to 0.8 % in frequency, the same
    in all of them, drops out, and the hinges' half-gaps are the true ones within 3 %, the split
    far beyond its noise and delta off their mean (the check fails). The test with equal gaps
    (another noisy copy of the replay) shows no split beyond its noise (the check passes)."""
    from freeplayid.fit import fit_backbone
    from freeplayid.identification.model_error import replayed_split
    from freeplayid.identification.verdict import _split_check

    chain, s = _chain(), np.linspace(2.8, 6.0, 7)
    chans = ("x2", "x3")
    bias = np.tile(0.008 * np.exp(-(s - 2.8)), 2)
    test = _biased(_noisy_points(chain, 2e4, 2e-3, [0.8, 1.2], chans, s, 5e-4), bias)
    common = fit_backbone(test, chain, init=(2e4, 2e-3))
    kn, delta = common.kn, common.delta
    assert abs(delta / 2e-3 - 1) > 0.01  # one delta leans to the hinge that turns most

    def replay(seed, noise=5e-4):  # one gap for both hinges: the answer's replay
        return _biased(_noisy_points(chain, kn, delta, [1.0, 1.0], chans, s, noise, seed), bias)

    copies = [replay(seed) for seed in range(1, 5)]
    got = replayed_split(chain, test, replay(0, 0.0), copies, kn=kn, delta=delta)
    assert got.n_copies == 4 and got.hinges == ("x2/x1", "x3/x2")
    assert got.half_gaps == pytest.approx((1.6e-3, 2.4e-3), rel=0.03)
    assert got.p < 1e-6 and got.mean_offset == pytest.approx(delta / 2e-3 - 1, abs=0.01)
    # each half-gap's interval: delta's and its share's noise (not the bias's remainder, which
    # at 0.8 % of sweep bias is 2 % here and 0 without it)
    lo_hi = got.intervals((0.99 * delta, 1.01 * delta))
    assert all(lo < g < hi and hi / lo < 1.05 for g, (lo, hi) in
               zip(got.half_gaps, lo_hi, strict=True))
    check = _split_check(got)
    assert not check.passed and "gaps differ" in check.message and "mean" in check.message
    # equal gaps: nothing beyond the noise, and the check passes
    same = replayed_split(chain, replay(9), replay(0, 0.0), copies, kn=kn, delta=delta)
    assert same.p > 0.01 and max(map(abs, same.log_split)) < 3 * max(same.log_se)
    assert _split_check(same).passed and "explains" in _split_check(same).message
    # without copies no test; one hinge: nothing to split
    assert replayed_split(chain, test, replay(0, 0.0), [], kn=kn, delta=delta).p is None
    from freeplayid.model import sdof_system

    assert replayed_split(sdof_system(), test, test, copies, kn=kn, delta=delta) is None


def test_a_replay_with_the_split_the_test_shows_leaves_none_and_delta_is_the_mean():
    """The chain's test of half-gaps 0.8 and 1.2 x 2 mrad (as above), replayed with those shares
    at their mean: no split is left beyond the noise, the half-gaps are the true ones within
    3 % and the one-gap answer's lean is its distance from the mean. The verdict's check fails
    on that lean (beyond half delta's bound) unless each hinge's gap was asked for, and fails
    where the replay's shares are not the test's (a split still shown)."""
    from freeplayid.fit import fit_backbone
    from freeplayid.identification.model_error import replayed_split
    from freeplayid.identification.verdict import _unequal_check

    chain, s = _chain(), np.linspace(2.8, 6.0, 7)
    chans = ("x2", "x3")
    test = _noisy_points(chain, 2e4, 2e-3, [0.8, 1.2], chans, s, 5e-4)
    common = fit_backbone(test, chain, init=(2e4, 2e-3))
    kn, lean = common.kn, common.delta / 2e-3 - 1
    assert abs(lean) > 0.01

    def replay(shares, seed, noise=5e-4):  # the replay at the mean 2 mrad with these shares
        return _noisy_points(chain, kn, 2e-3, list(shares), chans, s, noise, seed)

    shares = (0.8, 1.2)
    copies = [replay(shares, seed) for seed in range(1, 5)]
    got = replayed_split(chain, test, replay(shares, 0, 0.0), copies, kn=kn, delta=2e-3,
                         shares=shares, common=(common.kn, common.delta))
    assert got.shares == pytest.approx(shares) and got.p > 0.01
    assert got.half_gaps == pytest.approx((1.6e-3, 2.4e-3), rel=0.03)
    assert got.lean == pytest.approx(lean, rel=1e-12)
    check = _unequal_check(dataclasses.replace(got, mean_reported=False), per_hinge=False)
    assert not check.passed and "their mean" in check.message and "model" in check.message
    assert "both answers" in check.message
    # its first words name both causes of such a split, not the gaps alone
    assert check.message.startswith("the test's points split between the hinges otherwise")
    assert "(unequal gaps, or a linear model whose hinges turn" in check.message.split(";")[0]
    assert _unequal_check(got, per_hinge=True).passed
    near = dataclasses.replace(got, common=(common.kn, 2e-3 * 1.003))
    assert _unequal_check(near, per_hinge=False).passed
    # replayed with the wrong shares (equal gaps called unequal): a split is still shown
    wrong = (1.2, 0.8)
    off = replayed_split(chain, test, replay(wrong, 0, 0.0), [replay(wrong, k) for k in
                                                               range(1, 5)],
                         kn=kn, delta=2e-3, shares=wrong, common=(common.kn, 2e-3 * 1.003))
    assert off.p < 1e-6
    check = _unequal_check(off, per_hinge=True)
    assert not check.passed and "do not explain" in check.message


def test_the_lean_is_judged_by_its_chance_of_lying_beyond_the_bound():
    """The one-gap answer's lean (its delta over the hinges' mean, less 1) carries the noise of
    the split that set it: its log se is its size over that split's t. Lean e^0.0125 - 1 read
    at t = 2.5 (se 0.005): the chance of lying beyond 1 % is Phi((0.0125 - ln 1.01) / 0.005) =
    Phi(0.5099) = 0.695 (normal table), and the check fails (limit 20 %). The same lean read at
    t = 25 fails too; a lean of 0.77 % read at t = 4.87 (an equal-gap fin C draw) passes with
    a chance of 8 %, and one of 0.3 % passes whatever its t. The split replay is made where
    the split's p is below 0.1 by default, below cross_p where the mean is reported."""
    import math
    import types

    from freeplayid.identification.model_error import ReplayedSplit
    from freeplayid.identification.pipeline import _gaps_split
    from freeplayid.identification.verdict import _unequal_check

    def split(lean, t):
        return ReplayedSplit(hinges=("a", "b"), half_gaps=(1e-3, 2e-3), log_split=(0.0, 0.0),
                             log_se=(0.1, 0.1), n_copies=8, delta=1.5e-3, shares=(0.7, 1.3),
                             common=(900.0, 1.5e-3 * (1 + lean)), mean_reported=False,
                             common_t=t)

    sp = split(math.expm1(0.0125), 2.5)
    assert sp.lean_se == pytest.approx(0.005)
    assert sp.lean_outside(0.01) == pytest.approx(0.695, abs=1e-3)
    check = _unequal_check(sp, per_hinge=False)
    assert not check.passed and "69 % chance of lying beyond 1 %" in check.message
    assert not _unequal_check(split(math.expm1(0.0125), 25.0), per_hinge=False).passed
    near = split(0.0077, 4.87)
    assert near.lean_outside(0.01) == pytest.approx(0.08, abs=0.01)
    assert _unequal_check(near, per_hinge=False).passed
    assert _unequal_check(split(0.003, 50.0), per_hinge=False).passed
    assert _unequal_check(sp, per_hinge=True).passed  # the mean reported: the lean is moot
    # which first readings are replayed with their split
    def result(p, per_hinge):
        first = ReplayedSplit(hinges=("a", "b"), half_gaps=(1e-3, 2e-3), log_split=(0.0, 0.0),
                              log_se=(0.1, 0.1), n_copies=8, delta=1.5e-3)
        first = types.SimpleNamespace(p=p, half_gaps=first.half_gaps)
        return types.SimpleNamespace(
            model_error=types.SimpleNamespace(split=first, per_hinge=per_hinge),
            replay=types.SimpleNamespace(failure=None))

    replay = types.SimpleNamespace(gap_shares=None)
    assert _gaps_split(result(0.05, False), replay) and not _gaps_split(result(0.2, False), replay)
    assert not _gaps_split(result(0.05, True), replay) and _gaps_split(result(0.001, True), replay)


def test_a_split_only_suggested_is_not_called_shown():
    """Where the one-gap replay's split was only suggested (its p between cross_p and split_p,
    as on an equal-gap fin C draw at p 0.086), the check's message says that one common gap
    explains the test too and does not open with a split shown; a split read at p 1e-4 does.
    ``common_p`` reaches the JSON."""
    from freeplayid.identification.model_error import ReplayedSplit
    from freeplayid.identification.verdict import _SPLIT_SHOWN, LIMITS, _unequal_check

    def split(common_p):
        return ReplayedSplit(hinges=("a", "b"), half_gaps=(1.3e-3, 1.9e-3), log_split=(0.0, 0.0),
                             log_se=(0.1, 0.1), n_copies=8, delta=1.6e-3, shares=(0.9, 1.1),
                             common=(909.0, 1.6e-3 * 1.003), mean_reported=False,
                             common_t=2.0, common_p=common_p)

    hinted = _unequal_check(split(0.086), per_hinge=False)
    assert hinted.passed
    assert hinted.message.startswith("the test's points lean to a split between the hinges")
    assert "p = 0.086 against one common gap's replay" in hinted.message
    assert "one common gap explains the test too" in hinted.message
    assert "unequal gaps explain the test as well" in hinted.message
    assert _SPLIT_SHOWN not in hinted.message
    shown = _unequal_check(split(1e-4), per_hinge=False)
    assert shown.passed and shown.message.startswith(_SPLIT_SHOWN)
    assert "as well" not in shown.message
    at_cut = _unequal_check(split(LIMITS["cross_p"]), per_hinge=False)
    assert at_cut.message.startswith("the test's points lean")
    assert _unequal_check(split(None), per_hinge=False).message.startswith(_SPLIT_SHOWN)
    assert split(0.086).to_dict()["common_p"] == 0.086


def _fin_c():
    """realtests' fin C (benchmarks/realtests/cases.py): hinges turning 0.86 : 1 in mode 1."""
    import freeplayid.model as fm

    cfg = fm.load_fin_config()
    parts = dict(cfg.parts)
    parts["inboard"] = dataclasses.replace(parts["inboard"], thickness=0.010)
    parts["outboard"] = dataclasses.replace(parts["outboard"], thickness=0.007)
    cfg = dataclasses.replace(cfg, root_chord=0.16, inboard_span=0.10, outboard_span=0.14,
                              outboard_chord=0.16, parts=parts, hinge_x=(0.025, 0.08, 0.135),
                              kn=900.0, delta=0.0016, top_left=(0.0, 0.235),
                              lower_right=(0.16, 0.125), exciting=(0.08, 0.0), zeta=0.02)
    return fm.reduce_fin(fm.build_fin_fe(cfg))


def test_identify_replays_the_split_the_test_shows_and_says_how_far_the_mean_lies():
    """Fin C swept with half-gaps 1.2 and 2.0 mrad (records of the exponential engine with each
    hinge's own gap, which tests/test_simulate_expo.py checks against DOP853): one common gap
    leans to the hinge that turns most (noise-free, +1.6 %). The test's split is read against
    the replay and the test replayed with it until it settles: each hinge's half-gap comes out
    its own (within 1 %). By default the one-gap answer is reported, `suspect` for its chance
    of lying beyond delta's 1 % bound from the hinges' mean (the lean, with the noise of the
    split that set it; the split could be the model's), with intervals holding both answers;
    with `hinge_gaps` (the split taken as the gaps') the mean, `ok`; with the shares given,
    the replays have them from the start. Shares that are not one per hinge: one line before
    any work."""
    import torch

    import freeplayid
    from freeplayid.simulate import Sweep, simulate_sweeps, sweep_dataset

    fin = _fin_c()
    gaps = np.array([1.2e-3, 2.0e-3])
    d = gaps.mean()
    res = simulate_sweeps(fin, kn=900.0, delta=d, level_g=[0.476, 0.714, 0.952, 1.19, 1.43],
                          sweep=Sweep(57.0, 88.4, 1.0),
                          channels=["uz_top_left", "uz_lower_right"], quantity="acceleration",
                          frame="absolute", sample_rate=1024.0, engine="expo",
                          dtype=torch.float64, gap_shares=gaps / d, progress=False)
    noise = np.random.default_rng(0).normal(0, 0.01 * 9.80665, res.signals.shape)
    ds = sweep_dataset(res, columns={"acc_tl": "uz_top_left", "acc_lr": "uz_lower_right"},
                       units="g", noise=noise)
    r = freeplayid.identify(ds, system=fin, progress=False)
    split = r.model_error.split
    assert r.replay.gap_shares is None and split.shares and not split.mean_reported
    assert r.delta == split.common[1] and split.lean == pytest.approx(r.delta / d - 1, abs=0.003)
    assert split.lean > 0.01  # one gap leans to the hinge that turns most
    assert [g["delta"] for g in r.hinge_gap_records()] == pytest.approx(gaps, rel=0.01)
    check = {c.name: c for c in r.verdict.checks}["hinge_gaps"]
    assert r.verdict.status == "suspect" and not check.passed and "their mean" in check.message
    assert split.lean_outside(0.01) > 0.2 and "chance of lying beyond 1 %" in check.message
    assert r.delta_ci95[0] <= d <= r.delta_ci95[1]
    assert "delta is the one-gap answer" in r.report()
    mean = freeplayid.identify(ds, system=fin, model={"hinge_gaps": True}, progress=False)
    assert mean.replay.gap_shares is not None and mean.model_error.split.mean_reported
    assert mean.delta == pytest.approx(d, rel=0.003) and mean.kn == pytest.approx(900, rel=0.005)
    assert {c.name: c for c in mean.verdict.checks}["hinge_gaps"].passed
    given = freeplayid.identify(ds, system=fin, replay={"gap_shares": list(gaps / d)},
                                progress=False)
    assert given.replay.gap_shares == pytest.approx(tuple(gaps / d))
    assert given.model_error.split.common is None and given.delta == pytest.approx(d, rel=0.003)
    with pytest.raises(ValueError, match="`replay.gap_shares` must give one share per hinge"):
        freeplayid.identify(ds, system=fin, replay={"gap_shares": [1.0, 1.0, 1.0]},
                            progress=False)


def _realtests_script(name: str):
    """The module of ``benchmarks/realtests/<name>.py`` (a script, not a package), loaded."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "realtests" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"realtests_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_draw_pairs_puts_two_draws_difference_in_units_of_their_precisions():
    """benchmarks/realtests/run.py's draw_pairs: two draws whose log difference is 0.018 with
    log standard deviations 0.006 and 0.008 give z = 0.018 / 0.01 = 1.8 (by hand); a pair whose
    copies stopped early is counted apart, and so is a down-sweep."""
    run = _realtests_script("run")

    def rec(case, draw, delta, sd, settled=False):
        hw = math.expm1(1.96 * sd)
        return {"case": case, "draw": draw, "fit": "corrected", "kn": 480.0, "delta": delta,
                "replay": {"precision": {"delta_halfwidth": hw, "kn_halfwidth": hw, "n": 8,
                                         "n_fitted": 8, "settled": settled}}}

    d = 3e-3
    results = [rec("a", "d0", d * math.exp(0.018), 0.006), rec("a", "d1", d, 0.008),
               rec("b", "d0", d, 0.006, settled=True), rec("b", "d1", d * math.exp(0.01), 0.008),
               rec("c_down", "d0", d, 0.01), rec("c_down", "d1", d, 0.01)]
    table = run.draw_pairs(results).splitlines()
    row = next(r for r in table if r.startswith("| up-sweeps, all copies | delta"))
    assert "| 1 | 1.80 | 0 (0.0 %) | +1.8 (a) |" in row
    row = next(r for r in table if r.startswith("| up-sweeps, a copy set stopped early | delta"))
    assert "| 1 | 1.00 |" in row and "-1.0 (b)" in row
    assert any(r.startswith("| down-sweeps | delta | 1 | 0.00 |") for r in table)
    assert not any("alone" in r for r in table)  # no records' copies pooled


def test_draw_pairs_reads_pooled_copies_again_with_the_replays_alone():
    """Answers whose precision pooled copies of the records (``replay_halfwidths`` kept): the
    pair is read with the pooled half-widths (log sds 0.006 and 0.008: z = 1.8) and again with
    the replay's alone (0.003 and 0.004: z = 0.018 / 0.005 = 3.6, by hand), in its own row."""
    run = _realtests_script("run")

    def rec(draw, delta, sd, alone):
        hw, own = math.expm1(1.96 * sd), math.expm1(1.96 * alone)
        return {"case": "a", "draw": draw, "fit": "corrected", "kn": 480.0, "delta": delta,
                "replay": {"precision": {"delta_halfwidth": hw, "kn_halfwidth": hw, "n": 8,
                                         "n_fitted": 8, "settled": False, "n_measured": 8,
                                         "replay_halfwidths": [own, own]}}}

    d = 3e-3
    table = run.draw_pairs([rec("d0", d * math.exp(0.018), 0.006, 0.003),
                            rec("d1", d, 0.008, 0.004)]).splitlines()
    row = next(r for r in table if r.startswith("| up-sweeps, all copies | delta"))
    assert "| 1 | 1.80 |" in row
    row = next(r for r in table
               if r.startswith("| up-sweeps, all copies, the replay's copies alone | delta"))
    assert "| 1 | 3.60 | 1 (100.0 %) | +3.6 (a) |" in row


def test_draw_spread_sets_the_draws_scatter_beside_what_their_copies_predicted():
    """benchmarks/realtests/run.py's draw_spread: three draws of one condition with log delta
    errors 0.01, 0.02 and 0.03 (mean 2 %, sd 1 %, by hand) whose copies predicted log sds
    0.005, 0.01 and 0.02 (median 1 %: ratio 1.00); the one ``ok`` beyond delta's 1 % bound
    counts, the two ``suspect`` do not; a condition with two draws is left out."""
    run = _realtests_script("run")
    d, kn = 3e-3, 480.0

    def rec(case, draw, err, sd, status):
        hw = math.expm1(1.96 * sd)
        return {"case": case, "condition": "c", "draw": draw, "fit": "corrected", "kn": kn,
                "delta": d * math.exp(err), "kn_ci95": [kn, kn], "delta_ci95": [d, d],
                "status": status, "reasons": [], "wall_s": 1.0,
                "truth": {"kn": kn, "delta": d, "deltas": None},
                "replay": {"precision": {"delta_halfwidth": hw, "kn_halfwidth": hw, "n": 8,
                                         "n_fitted": 8, "settled": False}}}

    results = [rec("a", "d0", 0.01, 0.005, "suspect"), rec("a", "d1", 0.02, 0.01, "ok"),
               rec("a", "d2", 0.03, 0.02, "suspect"), rec("b", "d0", 0.0, 0.01, "ok"),
               rec("b", "d1", 0.0, 0.01, "ok")]
    rows = run.draw_spread(results).splitlines()
    assert rows[2:] == ["| a | 3 | +2.00 | 1.00 | 1.00 | 1.00 | 1 |"]


def test_the_benchmarks_replay_options_are_read_as_yaml_and_checked_before_any_work():
    run = _realtests_script("run")
    assert run.replay_options(["damping_exponent=estimate", "precision_copies=4",
                               "damping=0.02"]) == {"damping_exponent": "estimate",
                                                    "precision_copies": 4, "damping": 0.02}
    assert run.replay_options([]) == {}
    for bad, words in ((["damping_exponent=5"], "damping_exponent"), (["x"], "KEY=VALUE"),
                       (["foo=1"], "foo")):
        with pytest.raises(SystemExit, match=words):
            run.replay_options(bad)
    assert run.acmp_options(["if_weighting=none", "max_iter=50"]) == {"if_weighting": "none",
                                                                       "max_iter": 50}
    for bad, words in ((["if_weighting=bogus"], "if_weighting.*'none', 'local'"),
                       (["foo=1"], "--acmp: unknown option.*foo"), (["x"], "KEY=VALUE")):
        with pytest.raises(SystemExit, match=words):
            run.acmp_options(bad)


def test_redraw_puts_the_noise_only_where_it_is_asked(tmp_path):
    """benchmarks/realtests/redraw.py on synthetic clean records of the default fin's case: the
    noise-free draw is the clean records, a responses-only draw keeps the clean base and an
    all-noise draw 0 is cases.py's d0 to the bit (its seed)."""
    import importlib.util
    import json
    import sys
    from pathlib import Path

    from freeplayid.io import read_dataset

    bench = Path(__file__).resolve().parents[1] / "benchmarks" / "realtests"
    sys.path.insert(0, str(bench))
    try:
        spec = importlib.util.spec_from_file_location("realtests_redraw", bench / "redraw.py")
        redraw = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(redraw)
        cases = redraw.cases
        case = cases.ALL_CASES["fin_nominal"]()
        rng = np.random.default_rng(0)
        t = np.arange(1024) / case.sample_rate  # 4 s: the jumps' lock-in skips the first 3
        clean = {"time": [t] * len(case.runs),
                 "accel": [rng.normal(0, 9.81, (len(case.channels), t.size))
                           for _ in case.runs],
                 "base": [9.81 * np.sin(2 * np.pi * 30 * t) for _ in case.runs]}
        src = tmp_path / "data" / "fin_nominal"
        (src / "d0").mkdir(parents=True)
        cases.save_clean(src, clean)
        cases.write_draw(src / "d0", case, clean, cases.SEEDS[0], cases.clean_jumps(case, clean))
        out = tmp_path / "out"
        assert redraw.draws("0-2,5") == [0, 1, 2, 5]
        none, = redraw.redraw("fin_nominal", tmp_path / "data", out, "none", [3, 4])
        resp, = redraw.redraw("fin_nominal", tmp_path / "data", out, "responses", [2])
        d0, = redraw.redraw("fin_nominal", tmp_path / "data", out, "all", [0])
        assert (none.name, resp.name, d0.name) == ("d_none", "d2_responses", "d0")
        ref, a, b, c = (read_dataset(f) for f in (src / "d0", none, resp, d0))
        for k, run in enumerate(a.runs):
            np.testing.assert_allclose(run.data, clean["accel"][k] / cases.es.G0, rtol=1e-5,
                                       atol=1e-6)
            np.testing.assert_allclose(run.base, clean["base"][k] / cases.es.G0, rtol=1e-5,
                                       atol=1e-6)
            np.testing.assert_allclose(b.runs[k].base, run.base)
            assert np.std(b.runs[k].data - run.data) == pytest.approx(case.noise_g, rel=0.2)
            np.testing.assert_array_equal(c.runs[k].data, ref.runs[k].data)
            np.testing.assert_array_equal(c.runs[k].base, ref.runs[k].base)
        assert json.loads((none / "truth.json").read_text())["noise_g"] == case.noise_g
        assert (d0 / "truth.json").read_text() == (src / "d0" / "truth.json").read_text()
        with pytest.raises(ValueError, match="--noise"):
            redraw.redraw("fin_nominal", tmp_path / "data", out, "some", [0])
    finally:
        sys.path.remove(str(bench))


def test_the_splits_quick_fits_start_from_the_last_zeta_and_hold_the_damping_form(monkeypatch):
    """The split's quick fits estimate zeta again, from the one-gap answer's, but hold the
    damping's form (the hinge damper's share q, the exponent p) at that answer's; a form that
    was given, or the model file's C, is left as it was."""
    from freeplayid.identification import pipeline
    from freeplayid.replay import Replay
    from freeplayid.replay.damping_estimate import ReplayDamping

    est = ReplayDamping(source="estimated", zeta=0.02, hinge=0.31, hinge_estimated=True)
    assert pipeline._held_form(Replay(), est) == {"damping_exponent": 0.0,
                                                   "damping_hinge": 0.31}
    p = dataclasses.replace(est, hinge=0.0, hinge_estimated=False, exponent=0.9,
                            exponent_estimated=True)
    assert pipeline._held_form(Replay(damping_exponent="estimate"), p) == {
        "damping_exponent": 0.9, "damping_hinge": 0.0}
    assert pipeline._held_form(Replay(), dataclasses.replace(est, source="model")) == {}
    assert pipeline._held_form(Replay(damping_hinge=0.2), est) == {}
    assert pipeline._held_form(Replay(), None) == {}

    seen = []

    def quick(*args, replay, start_zeta, **kw):  # a quick fit that fails: the loop stops
        seen.append((replay, start_zeta))
        return type("Failed", (), {"failure": "no"})()

    monkeypatch.setattr(pipeline, "corrected_fit", quick)
    shares, at = pipeline._settled_shares((1.8e-3, 2.2e-3), (500.0, 2e-3), None, None, None,
                                          None, None, Replay(), False, damping=est)
    assert shares == (1.0, 1.0) and at == (500.0, 2e-3)
    assert len(seen) == 1 and seen[0][0].damping_hinge == 0.31
    assert seen[0][0].damping_exponent == 0.0
    assert seen[0][0].start == "network" and seen[0][0].damping is None  # zeta estimated again
    assert seen[0][1] == 0.02  # from the one-gap answer's


def test_copies_scatter_pairs_the_replays_copies_with_the_truths():
    """benchmarks/realtests/copies_scatter.py's paired: copies whose log delta moves half as far
    as the true records' under the same noise give the ratio 0.5, correlation 1 and slope 0.5;
    moves orthogonal to the truth's (by hand: +-1, +-1 in other orders) give ratio 1,
    correlation 0 and slope 0; a copy not fitted (NaN) on either side drops the pair."""
    cs = _realtests_script("copies_scatter")

    t = np.log(3e-3) + 0.01 * np.array([1.0, -1.0, 1.0, -1.0, 5.0, 0.0])
    truth = np.column_stack([np.zeros(6), t])
    half = truth.copy()
    half[:, 1] = np.log(3e-3) + 0.5 * (t - np.log(3e-3))
    half[5] = np.nan  # not fitted: the sixth pair drops
    truth[4] = np.nan  # nor the fifth
    r = cs.paired(half, truth)
    assert r["pairs"] == 4
    assert r["ratio"] == pytest.approx(0.5) and r["slope"] == pytest.approx(0.5)
    assert r["corr"] == pytest.approx(1.0)
    assert r["sd_truth"] == pytest.approx(np.std([0.01, -0.01, 0.01, -0.01], ddof=1))
    other = truth.copy()
    other[:4, 1] = np.log(3e-3) + 0.01 * np.array([1.0, 1.0, -1.0, -1.0])
    other[5] = np.nan
    r = cs.paired(other, truth)
    assert r["pairs"] == 4 and r["ratio"] == pytest.approx(1.0)
    assert r["corr"] == pytest.approx(0.0, abs=1e-12)
    assert r["slope"] == pytest.approx(0.0, abs=1e-12)

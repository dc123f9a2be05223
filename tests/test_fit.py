import math
import re
import types

import numpy as np
import pytest
import scipy.optimize

from freeplayid.backbone import dfa_backbone, hb_backbone
from freeplayid.fit import (
    BackboneModel,
    FittingPoints,
    fit_backbone,
    jacobian_intervals,
    multistart_grid,
)
from freeplayid.model import two_dof_system

KN, DELTA = 2.0e4, 1.0e-3
S = np.array([1.6, 2.0, 3.0, 5.0, 8.0])


def _points(curve, noise=0.0, seed=0):
    rng = np.random.default_rng(seed)
    f = np.r_[curve.frequency_hz[0], curve.frequency_hz[0]]
    return FittingPoints(
        channel=["uz_out"] * S.size + ["uz_in"] * S.size,
        amplitude_m=np.r_[curve.channel("uz_out")[0], curve.channel("uz_in")[0]],
        f_hz=f * (1 + noise * rng.standard_normal(f.size)),
    )


def test_fit_recovers_parameters_from_exact_dfa_points():
    pts = _points(dfa_backbone(two_dof_system(), kn=KN, delta=DELTA, s=S))
    res = fit_backbone(pts, two_dof_system())
    assert res.kn == pytest.approx(KN, rel=1e-4)
    assert res.delta == pytest.approx(DELTA, rel=1e-3)
    assert res.residual_rms < 1e-4 and res.init == "multistart"
    assert res.n_evaluations > 25


def test_multistart_is_insensitive_to_the_start():
    pts = _points(dfa_backbone(two_dof_system(), kn=KN, delta=DELTA, s=S))
    sys_ = two_dof_system()
    starts = multistart_grid(3, kn_range=(1e3, 1e8), delta_range=(1e-4, 1e-2))
    results = [fit_backbone(pts, sys_, init=[s0] + multistart_grid(3)) for s0 in starts]
    kns = np.array([r.kn for r in results])
    np.testing.assert_allclose(kns, KN, rtol=1e-4)


def test_confidence_intervals_cover_truth_with_noisy_points():
    sys_ = two_dof_system()
    pts = _points(dfa_backbone(sys_, kn=KN, delta=DELTA, s=S), noise=0.003, seed=1)
    res = fit_backbone(pts, sys_, init=(1e4, 2e-3), n_bootstrap=40)
    assert res.kn_ci95[0] < KN < res.kn_ci95[1]
    assert res.delta_ci95[0] < DELTA < res.delta_ci95[1]
    assert res.kn_ci95_bootstrap[0] < res.kn < res.kn_ci95_bootstrap[1]
    assert res.init == "given"


def test_hb_backbone_fit_on_harmonic_balance_points_near_contact():
    # points close to contact (s = 1.2-2), where the DFA is biased: the HB fit removes the bias
    sys_ = two_dof_system()
    s = np.array([1.2, 1.3, 1.5, 1.8, 2.2])
    hb = hb_backbone(sys_, kn=KN, delta=DELTA, s=s, n_harmonics=5)
    pts = FittingPoints(
        channel=["uz_out"] * s.size, amplitude_m=hb.channel("uz_out")[0], f_hz=hb.frequency_hz[0]
    )
    dfa_fit = fit_backbone(pts, sys_, init=(KN, DELTA))
    hb_fit = fit_backbone(pts, sys_, init=(KN, DELTA), backbone="hb")
    assert abs(hb_fit.delta / DELTA - 1) < 0.25 * abs(dfa_fit.delta / DELTA - 1)
    assert hb_fit.delta == pytest.approx(DELTA, rel=5e-3)


def test_fit_input_errors():
    sys_ = two_dof_system()
    with pytest.raises(ValueError, match="at least 2"):
        fit_backbone(FittingPoints(channel=["uz_in"], amplitude_m=[1e-3], f_hz=[5.0]), sys_)
    with pytest.raises(ValueError, match="not DOFs"):
        fit_backbone(FittingPoints(channel=["x", "x"], amplitude_m=[1e-3, 2e-3], f_hz=[5.0, 6.0]),
                     sys_)
    with pytest.raises(ValueError, match="bad points"):
        fit_backbone(
            FittingPoints(channel=["uz_in", "uz_in"], amplitude_m=[np.nan, 2e-3], f_hz=[5.0, 6.0]),
            sys_,
        )
    with pytest.raises(ValueError, match="backbone"):
        fit_backbone(
            FittingPoints(channel=["uz_in", "uz_in"], amplitude_m=[1e-3, 2e-3], f_hz=[5.0, 6.0]),
            sys_,
            backbone="ihb",
        )


def test_validate_modes_passes_for_true_kn_and_fails_for_wrong_kn():
    from freeplayid.model import modal_analysis, validate_modes

    sys_ = two_dof_system()
    ref = modal_analysis(sys_.M, sys_.closed_stiffness(KN))
    dofs = ["uz_in", "uz_out"]
    good = validate_modes(sys_, KN * 1.001, ref.frequencies_hz, ref.shapes, dofs)
    assert good.passed and np.all(np.abs(good.error_hz) < 0.05)
    assert "MAC" in good.table()
    bad = validate_modes(sys_, KN * 3, ref.frequencies_hz, ref.shapes, dofs)
    assert not bad.passed


def test_points_at_one_resonance_are_flagged():
    """Two channels of one run share one frequency: (kn, delta) are not both identifiable."""
    import warnings

    from freeplayid.fit import count_resonances, fit_backbone
    from freeplayid.model.small import two_dof_system

    assert count_resonances([44.0, 44.09, 46.0, 46.01]) == 2
    assert count_resonances([44.0, 44.01]) == 1 and count_resonances([44.0, 45.0]) == 2
    assert count_resonances([]) == 0
    sys_ = two_dof_system()
    names = list(sys_.dof_names)
    pts = FittingPoints(channel=names[:2], amplitude_m=[2e-3, 1e-3], f_hz=[10.0, 10.001])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            fit_backbone(pts, sys_, init=(4e3, 1e-3))
        except ValueError:
            pass  # the start may also diverge: the warning is what is tested
    assert any("one resonance" in str(w.message) for w in caught)


def test_fitting_points_validation_names_the_field_and_the_bad_points():
    ok = FittingPoints(channel=("a", "b"), amplitude_m=[1e-3, 2e-3], f_hz=[5.0, 6.0])
    assert ok.channel == ("a", "b") and len(ok) == 2 and ok.run is None
    assert ok.amplitude_m.dtype == float and not ok.amplitude_m.flags.writeable
    with pytest.raises(ValueError, match=r"`f_hz` with 3"):
        FittingPoints(channel=["a", "b"], amplitude_m=[1e-3, 2e-3], f_hz=[5.0, 6.0, 7.0])
    with pytest.raises(ValueError, match=r"`run` with 1"):
        FittingPoints(channel=["a", "b"], amplitude_m=[1e-3, 2e-3], f_hz=[5.0, 6.0], run=["r0"])
    with pytest.raises(ValueError, match="at least 2 fitting points .* got 1"):
        FittingPoints(channel=["a"], amplitude_m=[1e-3], f_hz=[5.0])
    with pytest.raises(ValueError, match=r"finite `f_hz` > 0; bad points at indices \[1, 2\]"):
        FittingPoints(channel=["a"] * 3, amplitude_m=[1e-3] * 3, f_hz=[5.0, np.inf, -1.0])
    with pytest.raises(ValueError, match=r"finite `amplitude_m` > 0; .* indices \[0\]"):
        FittingPoints(channel=["a", "b"], amplitude_m=[0.0, 2e-3], f_hz=[5.0, 6.0])
    with pytest.raises(ValueError, match="`channel` must be a sequence of str"):
        FittingPoints(channel="ab", amplitude_m=[1e-3, 2e-3], f_hz=[5.0, 6.0])
    with pytest.raises(ValueError, match=r"`amplitude_m` must be 1-D"):
        FittingPoints(channel=["a", "b"], amplitude_m=[[1e-3, 2e-3]], f_hz=[5.0, 6.0])


def test_fitting_points_from_and_to_records_round_trip():
    records = [
        {"channel": "uz_in", "amplitude_m": 1e-3, "f_hz": 5.0, "run": "0.6 g"},
        {"channel": "uz_out", "amplitude_m": 3e-3, "f_hz": 5.0, "run": "0.6 g", "used": True},
        {"channel": "uz_out", "amplitude_m": 9.0, "f_hz": -1.0, "run": "0.2 g", "used": False},
        {"channel": "uz_out", "amplitude_m": 4e-3, "f_hz": 5.5, "run": "0.8 g"},
    ]
    pts = FittingPoints.from_records(records)
    assert pts.channel == ("uz_in", "uz_out", "uz_out") and pts.run == ("0.6 g", "0.6 g", "0.8 g")
    np.testing.assert_array_equal(pts.amplitude_m, [1e-3, 3e-3, 4e-3])
    np.testing.assert_array_equal(pts.f_hz, [5.0, 5.0, 5.5])
    back = pts.to_records()
    used = [r for r in records if r.get("used", True)]
    assert back == [{k: v for k, v in r.items() if k != "used"} for r in used]
    assert FittingPoints.from_records(back) == pts
    no_run = FittingPoints.from_records([{k: v for k, v in r.items() if k != "run"} for r in back])
    assert no_run.run is None and no_run != pts and "run" not in no_run.to_records()[0]
    with pytest.raises(ValueError, match=r"record 1 lacks \['amplitude_m'\]"):
        FittingPoints.from_records([back[0], {"channel": "uz_in", "amplitude": 1e-3, "f_hz": 5.0}])


def _extraction():
    from freeplayid.signal import BackbonePoint, BackbonePoints

    def pt(run, col, f, a, used=True):
        return BackbonePoint(run, col, f, a, used, "" if used else "no jump in band", 1.0, 30.0)

    return BackbonePoints(
        points=(pt("r1", "acc_out", 5.2, 2e-3), pt("r1", "acc_in", 5.2, 1e-3),
                pt("r2", "acc_out", 5.6, 4e-3), pt("r2", "acc_in", 5.6, 0.0, used=False)),
        rejected_runs=(), curves=(), quantity="acceleration", method="acmp",
    )


def test_fitting_points_from_extraction_keeps_used_points_mapped_to_dofs():
    ext = _extraction()
    dofs = {"acc_out": "uz_out", "acc_in": "uz_in"}
    pts = FittingPoints.from_extraction(ext, dofs=dofs)
    assert pts.channel == ("uz_out", "uz_in", "uz_out") and pts.run == ("r1", "r1", "r2")
    np.testing.assert_array_equal(pts.amplitude_m, [2e-3, 1e-3, 4e-3])
    np.testing.assert_array_equal(pts.f_hz, [5.2, 5.2, 5.6])
    used = [r for r in ext.to_records() if r["used"]]
    assert [(r["channel"], r["f_hz"], r["amplitude_m"]) for r in pts.to_records()] == [
        (dofs[r["channel"]], r["f_hz"], r["amplitude_m"]) for r in used]
    assert FittingPoints.from_extraction(ext).channel == ("acc_out", "acc_in", "acc_out")
    with pytest.raises(ValueError, match=r"channels \['acc_in'\] .* not in `dofs`"):
        FittingPoints.from_extraction(ext, dofs={"acc_out": "uz_out"})
    with pytest.raises(TypeError, match="BackbonePoints"):
        FittingPoints.from_extraction(pts)


def test_fit_backbone_takes_fitting_points_or_an_extraction_and_nothing_else():
    from freeplayid.signal import BackbonePoint, BackbonePoints

    sys_ = two_dof_system()
    pts = _points(dfa_backbone(sys_, kn=KN, delta=DELTA, s=S))
    ext = BackbonePoints(
        tuple(BackbonePoint(f"r{i % S.size}", c, q, a, True, "", 0.0, 30.0)
              for i, (c, a, q) in enumerate(zip(pts.channel, pts.amplitude_m, pts.f_hz)))
        + (BackbonePoint("r9", "uz_in", 1.0, 1.0, False, "no jump in band", 0.0, 0.0),),
        (), (), "displacement", "acmp",
    )
    a = fit_backbone(ext, sys_, init=(1e4, 2e-3))
    b = fit_backbone(pts, sys_, init=(1e4, 2e-3))
    assert (a.kn, a.delta, a.n_points) == (b.kn, b.delta, 2 * S.size)
    assert a.kn == pytest.approx(KN, rel=1e-4)
    for bad in (pts.to_records(), {"channel": ["uz_in"] * 2, "amplitude": [1e-3, 2e-3],
                                   "f_hz": [5.0, 6.0]}):
        with pytest.raises(TypeError, match=r"FittingPoints or a freeplayid.signal.BackbonePoints"):
            fit_backbone(bad, sys_)


def test_unknown_fit_backbone_lists_the_registered_methods():
    from freeplayid.backbone import BACKBONE_METHODS

    pts = FittingPoints(channel=["uz_in", "uz_in"], amplitude_m=[1e-3, 2e-3], f_hz=[5.0, 6.0])
    msg = f"`backbone` must be one of {sorted(BACKBONE_METHODS)}, got 'ihb'"
    with pytest.raises(ValueError, match=re.escape(msg)):
        fit_backbone(pts, two_dof_system(), backbone="ihb")
    with pytest.raises(ValueError, match=re.escape(msg)):
        BackboneModel(two_dof_system(), ["uz_in"], backbone="ihb")


def test_jacobian_intervals_by_run_count_each_run_once():
    # Reference: ordinary least squares by hand (numpy.linalg.lstsq, the t quantile from
    # scipy) on one row per run. Duplicating every run's row (two channels with the same
    # residual) must not narrow the by-run interval, while the per-point one shrinks.
    import scipy.stats

    from freeplayid.fit.uncertainty import jacobian_intervals

    rng = np.random.default_rng(3)
    J1 = np.column_stack([np.ones(5), np.linspace(-1.0, 1.0, 5)])  # 5 runs, 2 parameters
    r1 = 0.01 * rng.standard_normal(5)
    x = np.log([500.0, 3e-3])
    s2 = float(r1 @ r1) / 3
    half = scipy.stats.t.ppf(0.975, 3) * np.sqrt(np.diag(s2 * np.linalg.inv(J1.T @ J1)))
    ref_kn = (500.0 * np.exp(-half[0]), 500.0 * np.exp(half[0]))
    J2, r2 = np.repeat(J1, 2, axis=0), np.repeat(r1, 2)
    runs = [f"run{i}" for i in range(5) for _ in range(2)]
    kn_run, _ = jacobian_intervals(x, r2, J2, groups=runs)
    kn_pt, _ = jacobian_intervals(x, r2, J2)
    np.testing.assert_allclose(kn_run, ref_kn, rtol=1e-12)
    assert kn_pt[1] - kn_pt[0] < 0.5 * (ref_kn[1] - ref_kn[0])  # too narrow by ~2.6x
    # two runs fit exactly: nothing measures the noise
    kn2, delta2 = jacobian_intervals(x, r2[:4], J2[:4], groups=runs[:4])
    assert kn2 == (0.0, float("inf")) and delta2 == (0.0, float("inf"))


def test_weights_count_a_point_as_often_as_its_weight_squared():
    # weighted least squares with weight sqrt(m) on a point is the plain fit with the point
    # repeated m times: the reference needs no weights at all
    sys_ = two_dof_system()
    pts = _points(dfa_backbone(sys_, kn=KN, delta=DELTA, s=S), noise=0.004, seed=3)
    reps = np.array([1, 3, 1, 2, 1, 1, 4, 1, 1, 2])
    idx = np.repeat(np.arange(len(pts)), reps)
    repeated = FittingPoints(channel=[pts.channel[i] for i in idx],
                             amplitude_m=pts.amplitude_m[idx], f_hz=pts.f_hz[idx])
    weighted = fit_backbone(pts, sys_, init=(1.5e4, 1.2e-3), weights=np.sqrt(reps))
    plain = fit_backbone(repeated, sys_, init=(1.5e4, 1.2e-3))
    unweighted = fit_backbone(pts, sys_, init=(1.5e4, 1.2e-3))
    assert weighted.kn == pytest.approx(plain.kn, rel=1e-6)
    assert weighted.delta == pytest.approx(plain.delta, rel=1e-6)
    assert abs(weighted.delta / unweighted.delta - 1) > 1e-4  # the weights did change the fit
    # the reported residuals are the unweighted ones
    np.testing.assert_allclose(weighted.residuals, plain.residuals[np.r_[0, np.cumsum(reps)[:-1]]],
                               rtol=1e-5, atol=1e-9)
    # the weighted Jacobian and the weights it keeps give back its per-point intervals
    # (jacobian_intervals' own formula); the Jacobian agrees with central differences of the
    # weighted residuals (an independent reference)
    x = np.log([weighted.kn, weighted.delta])
    kn_ci, delta_ci = jacobian_intervals(x, weighted.weights * weighted.residuals,
                                         weighted.jacobian)
    np.testing.assert_allclose(kn_ci, weighted.kn_ci95, rtol=1e-9)
    np.testing.assert_allclose(weighted.weights, np.sqrt(reps))
    model = BackboneModel(sys_, list(pts.channel), backbone="dfa")
    cidx = np.array([model.channels.index(c) for c in pts.channel])

    def r(xx):
        f = model.frequency(pts.amplitude_m, cidx, *np.exp(xx))
        return np.sqrt(reps) * (f - pts.f_hz) / pts.f_hz

    fd = np.stack([(r(x + e) - r(x - e)) / 2e-5 for e in np.eye(2) * 1e-5], axis=1)
    np.testing.assert_allclose(weighted.jacobian, fd, rtol=1e-3, atol=1e-6)
    for bad in ([1.0] * 3, [0.0] + [1.0] * 9, [np.nan] + [1.0] * 9):
        with pytest.raises(ValueError, match="`weights` must be 10 finite numbers > 0"):
            fit_backbone(pts, sys_, init=(1.5e4, 1.2e-3), weights=bad)


def test_curves_between_kn_nodes_are_interpolated_to_the_computed_ones():
    """The fit's curve of a kn between nodes (Catmull-Rom over four node curves) against the
    curve the describing function computes at that kn (``curve_at``), on the default fin's two
    hinges (the unequal-hinge fixed point) and its equal-hinge scouting model, kn 1e2-1e6: within
    1.3e-6 in frequency and 1e-8 in ln amplitude; where the nodes are not smooth in kn (the
    fin's mode veering near contact above kn 3e4) the curve is computed at kn itself. A fit that
    moves kn by a few % computes a handful of node curves, shared by the fits of one system."""
    from freeplayid.fit import objective
    from freeplayid.model import default_fin

    fin = default_fin()
    kns = [150.0, 480.0, 2.1e3, 9.3e3, 3.53e4, 8.28e4, 1.79e5, 6.1e5]  # 3.5e4-1.8e5: veering
    for options in ({}, {"equal_hinges": True}):
        model = objective.BackboneModel(fin, ["uz_top_left", "uz_lower_right"], **options)
        for kn in kns:
            f, la = model.curve(kn)
            f0, la0 = model.curve_at(kn, keep=False)
            live = f0 > 0
            assert np.max(np.abs(f[live] / f0[live] - 1)) < 1.3e-6, kn
            both = np.isfinite(la) & np.isfinite(la0)
            assert np.array_equal(both, np.isfinite(la0)) and np.max(np.abs(la - la0)[both]) < 1e-8
    local = objective.BackboneModel(fin, ["uz_top_left"])
    before = local.n_curves
    for kn in np.linspace(470.0, 490.0, 30):
        local.curve(kn)
    assert local.n_curves - before <= 6  # 4 % of kn, 2.3 node spacings: 3 intervals, 6 nodes
    again = objective.BackboneModel(fin, ["uz_top_left"])
    again.curve(480.0)
    assert again.n_curves == 0  # the nodes of the first model, shared


def _two_dof_hinge_share(kn, m_in=1.0, m_out=0.5, k_in=4.0e4):
    """The hinge's share of the two-DOF system's closed mode 1 stiffness, by hand: the 2 x 2
    eigenproblem's lower root and its shape (x_in, x_out)."""
    a, b, c = m_in * m_out, -(m_in * kn + m_out * (k_in + kn)), k_in * kn
    w2 = (-b - math.sqrt(b * b - 4 * a * c)) / (2 * a)
    x_out = kn / (kn - m_out * w2)  # x_in = 1: the outboard row kn (x_out - 1) = m_out w2 x_out
    hinge, root = kn * (x_out - 1.0) ** 2, k_in
    return hinge / (hinge + root)


@pytest.mark.parametrize("share", [2e-3, 0.5])
def test_a_fit_whose_hinge_still_carries_the_mode_is_determined(share):
    from freeplayid.estimate import check_determined

    kn = scipy.optimize.brentq(lambda k: math.log(_two_dof_hinge_share(k) / share), 1.0, 1e15)
    check_determined(kn, 1e-3, two_dof_system(), 0, "here")  # does not raise


@pytest.mark.parametrize("kn, delta", [(None, 1e-3), (1e17, 1e-3), (math.nan, 1e-3),
                                       (math.inf, 1e-3), (2e4, 0.0), (-2e4, 1e-3)])
def test_a_fit_that_ran_off_to_a_rigid_hinge_is_refused_with_its_cause(kn, delta):
    """A fit that ran off (kn towards infinity: the two-DOF's hinge share 5e-4 of its mode 1,
    by hand; or kn, delta not finite and positive) is an IdentificationError that says so."""
    from freeplayid.errors import IdentificationError
    from freeplayid.estimate import check_determined

    if kn is None:  # the share 5e-4, below the 1e-3 that still counts
        kn = scipy.optimize.brentq(lambda k: math.log(_two_dof_hinge_share(k) / 5e-4), 1.0,
                                   1e15)
    with pytest.raises(IdentificationError, match=r"here: the fit ran off to kn = .*the points "
                       r"do not determine kn"):
        check_determined(kn, delta, two_dof_system(), 0, "here")


def test_too_few_points_under_a_stated_weight_say_the_panel_rests_on_its_stop():
    # every run without a jump: the advice is to shake harder; where the data set states the
    # weight along the axis it also says why no run crossed the gap (the panel on its stop)
    from freeplayid.errors import IdentificationError
    from freeplayid.estimate import check_enough
    from freeplayid.signal.jump import REASON_EDGE, REASON_NO_JUMP

    class NoPoints:
        def used(self):
            return []

    rejected = {"a.csv": REASON_NO_JUMP, "b.csv": REASON_EDGE}
    with pytest.raises(IdentificationError) as info:
        check_enough(NoPoints(), rejected, "here", gravity_g=1.0)
    msg = str(info.value)
    assert msg.startswith("here: 0 usable fitting point(s)")
    assert "a.csv: " + REASON_NO_JUMP in msg
    assert "under the stated weight (gravity_g 1) the panel rests on one stop" in msg
    with pytest.raises(IdentificationError) as info:
        check_enough(NoPoints(), rejected, "here")
    assert str(info.value).endswith("add runs at higher levels that resonate in the band")
    # a run already on its upper branch where the band starts: start lower, not shake harder
    from freeplayid.signal.jump import REASON_START

    with pytest.raises(IdentificationError) as info:
        check_enough(NoPoints(), {"a.csv": REASON_NO_JUMP, "c.csv": REASON_START}, "here")
    assert str(info.value).endswith(
        "start the sweeps lower: 1 run was already on its upper branch at the band's start, "
        "and add runs at levels that resonate in the band")
    # a run one of whose channels drops later did not stay in the gap, whatever the other read
    from freeplayid.estimate import run_reason

    def said(*reasons):
        return run_reason([types.SimpleNamespace(reason=r) for r in reasons])

    assert said(REASON_START, REASON_NO_JUMP, REASON_START) == REASON_START
    assert said(REASON_NO_JUMP, REASON_EDGE, REASON_NO_JUMP) == \
        f"{REASON_NO_JUMP}; {REASON_EDGE}"
    with pytest.raises(IdentificationError) as info:
        check_enough(NoPoints(), {"c.csv": REASON_START, "d.csv": REASON_START}, "here")
    assert str(info.value).endswith("start the sweeps lower: 2 runs were already on their "
                                    "upper branches at the band's start")

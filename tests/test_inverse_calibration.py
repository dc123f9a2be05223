"""The network's calibration: coverage, SBC ranks, the spreads' scale and the training domain.

References are drawn here with numpy (a posterior that is calibrated by construction, or one
whose spread is wrong by a known factor), never produced by the code under test.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from freeplayid.errors import InverseDomainWarning
from freeplayid.fit import FittingPoints, resolve_start
from freeplayid.inverse import (
    PointSets,
    TrainingDomain,
    calibrate_checkpoint,
    calibration_metrics,
    load_inverse_model,
    train_inverse_model,
)
from freeplayid.inverse.calibration import (
    LEVELS,
    coverage_curve,
    fit_std_scale,
    rank_uniformity,
    sbc_ranks,
)

pytestmark = pytest.mark.usefixtures("quiet_lightning")

CHANNELS = ("uz_top_left", "uz_root")



def _posterior(n, *, seed, spread_error=1.0):
    """Truth drawn from each case's log-normal posterior: (truth, median, stated log std), the
    stated std ``spread_error`` times the true one."""
    rng = np.random.default_rng(seed)
    mean = np.exp(rng.uniform(np.log(300), np.log(800), n))
    std = rng.uniform(0.02, 0.2, n)
    truth = mean * np.exp(std * rng.standard_normal(n))
    return truth, mean, std * spread_error


def test_coverage_follows_the_level_for_a_calibrated_posterior_and_not_otherwise():
    truth, mean, std = _posterior(20000, seed=1)
    assert np.max(np.abs(coverage_curve(truth, mean, std) - LEVELS)) < 0.015
    # over-confident by 2: the 95 % interval is really a 68 % one
    cov = coverage_curve(truth, mean, std / 2)
    assert cov[-1] == pytest.approx(0.68, abs=0.02)


@pytest.mark.parametrize("factor", [0.4, 2.5])
def test_the_recalibration_undoes_a_known_miscalibration(factor):
    truth, mean, std = _posterior(4000, seed=2)
    s = fit_std_scale(truth, mean, std * factor)
    assert s * factor == pytest.approx(1.0, rel=0.06)
    # the empirical recalibration, fitted on other cases, also undoes a shift
    t2, m2, s2 = _posterior(4000, seed=7)
    shifted = mean * np.exp(0.5 * std)  # biased by half a std
    z = np.sort((np.log(t2) - np.log(m2 * np.exp(0.5 * s2))) / (s2 * factor))
    cov = coverage_curve(truth, shifted, std * factor, z_sorted=z)
    assert np.max(np.abs(cov - LEVELS)) < 0.03
    assert np.max(np.abs(coverage_curve(truth, shifted, std * factor) - LEVELS)) > 0.1


def test_sbc_ranks_are_uniform_for_a_calibrated_posterior_and_rejected_when_overconfident():
    truth, mean, std = _posterior(2000, seed=3)
    ok = rank_uniformity(sbc_ranks(truth, mean, std, n_draws=99, seed=5), 99)
    assert ok["p_value"] > 0.01 and sum(ok["counts"]) == 2000
    bad = rank_uniformity(sbc_ranks(truth, mean, std / 2, n_draws=99, seed=5), 99)
    assert bad["p_value"] < 1e-6
    # over-confident: the truth falls at the ends of the draws (U-shaped histogram)
    assert bad["counts"][0] + bad["counts"][-1] > 2 * (2000 / 10) * 2 * 0.8


def _cases(n, *, seed, kn_range=(240.0, 960.0)):
    """Cases whose points follow a softening backbone, f = 40 Hz sqrt(kn / 480) sqrt(1 - 1/r)
    at r = A / delta in [1.5, 6], 2-6 points (the law of tests/test_inverse_network.py)."""
    rng = np.random.default_rng(seed)
    kn = np.exp(rng.uniform(*np.log(kn_range), n))
    delta = np.exp(rng.uniform(np.log(3e-4), np.log(3e-3), n))
    case = np.repeat(np.arange(n), rng.integers(2, 7, n))
    r = rng.uniform(1.5, 6.0, case.size)
    channel = rng.integers(0, 2, case.size)
    f = 40.0 * np.sqrt(kn[case] / 480.0) * np.sqrt(1.0 - 1.0 / r)
    amplitude = r * delta[case] * np.where(channel == 1, 0.6, 1.0)
    return PointSets(channels=CHANNELS, case=case, channel=channel, amplitude=amplitude,
                     frequency=f, kn=kn, delta=delta)


def test_domain_names_what_lies_outside():
    dom = TrainingDomain.from_point_sets(_cases(300, seed=0))
    inside = _cases(20, seed=1)
    assert dom.outside(inside) == [""] * 20
    stiff = _cases(3, seed=2, kn_range=(1900.0, 2100.0))  # f ~ 80 Hz, trained up to ~56 Hz
    why = dom.outside(stiff)
    assert all("frequency" in w and "outside the training points'" in w for w in why)
    # an estimate beyond the training prior is named too
    est = {"kn": np.full(20, 3000.0), "delta": inside.delta, "log_kn_std": np.full(20, 0.05),
           "log_delta_std": np.full(20, 0.05)}
    w = dom.outside(inside, est)[0]
    assert "estimated kn 3000" in w and "training prior" in w
    est["log_kn_std"] = np.full(20, 1.0)  # within twice a wide spread of the prior: inside
    assert dom.outside(inside, est)[0] == ""
    assert TrainingDomain.from_dict(dom.to_dict()) == dom


def test_only_a_miscalibrated_parameter_is_recalibrated():
    """A head calibrated for kn and over-confident (half the spread) for delta, on validation
    cases drawn here: kn is kept as the network gives it, delta recalibrated to its errors."""
    from types import SimpleNamespace

    from freeplayid.inverse import Calibration

    val = _cases(600, seed=21)
    rng = np.random.default_rng(22)
    s_kn, s_d = np.full(600, 0.05), np.full(600, 0.1)
    raw = SimpleNamespace(kn=val.kn * np.exp(-s_kn * rng.standard_normal(600)),
                          delta=val.delta * np.exp(-s_d * rng.standard_normal(600)),
                          log_kn_std=s_kn, log_delta_std=s_d / 2)
    cal = Calibration.fit(val, val, raw)
    assert cal.z["kn"] is None and cal.val_p_value["kn"] > 0.01
    assert cal.z["delta"] is not None and cal.val_p_value["delta"] < 1e-6
    assert cal.std_scale[0] == 1.0 and cal.std_scale[1] == pytest.approx(2.0, rel=0.1)
    assert "kn as the network gives it" in cal.describe() and "delta recalibrated" in cal.describe()
    assert Calibration.from_dict(cal.to_dict()) == cal


def test_a_case_the_estimate_does_not_explain_is_named():
    """Points on the default fin's backbone at kn 480, delta 3 mrad: the backbone at the truth
    explains them (misfit ~0), an estimate of kn 700 misses them; a domain bounded at 1 % names
    that case and not the other."""
    from freeplayid.fit import BackboneModel
    from freeplayid.inverse.calibration import backbone_misfit
    from freeplayid.model import default_fin

    fin = default_fin()
    ch = ("uz_top_left", "uz_lower_right")
    amp = np.array([6e-3, 9e-3, 1.4e-2, 2e-3, 3e-3])
    cidx = np.array([0, 0, 0, 1, 1])
    f = BackboneModel(fin, ch).frequency(amp, cidx, 480.0, 3e-3)
    ps = PointSets(channels=ch, case=np.array([0] * 5 + [1] * 5), channel=np.tile(cidx, 2),
                   amplitude=np.tile(amp, 2), frequency=np.tile(f, 2), kn=np.full(2, 480.0),
                   delta=np.full(2, 3e-3))
    kn, delta = np.array([480.0, 700.0]), np.full(2, 3e-3)
    m = backbone_misfit(ps, fin, kn, delta)
    assert m[0] < 1e-6 and m[1] > 0.01
    dom = TrainingDomain.from_point_sets(ps, misfit_limit=0.01)
    est = {"kn": kn, "delta": delta, "log_kn_std": np.full(2, 0.01),
           "log_delta_std": np.full(2, 0.01)}
    why = dom.outside(ps, est, system=fin)
    assert why[0] == "" and "misses the points" in why[1]
    assert "misses the points" not in dom.outside(ps, est)[1]  # without the model: unchecked


def test_a_fin_outside_the_prior_is_named_whatever_the_network_estimates():
    """Points on the default fin's backbone at kn 2000 (prior 300-800): the best backbone within
    the prior misses them, by as much as a brute-force scan of the prior's edge finds; points at
    kn 480 are explained (misfit ~0). The check needs no estimate, and without the model it is
    not made."""
    from freeplayid.fit import BackboneModel
    from freeplayid.inverse.calibration import backbone_misfit, prior_misfit
    from freeplayid.model import default_fin

    fin = default_fin()
    ch = ("uz_top_left", "uz_lower_right")
    amp = np.array([6e-3, 9e-3, 1.4e-2, 2e-3, 3e-3])
    cidx = np.array([0, 0, 0, 1, 1])
    model = BackboneModel(fin, ch)
    f = np.concatenate([model.frequency(amp, cidx, kn, 3e-3) for kn in (480.0, 2000.0)])
    ps = PointSets(channels=ch, case=np.repeat([0, 1], 5), channel=np.tile(cidx, 2),
                   amplitude=np.tile(amp, 2), frequency=f, kn=np.array([480.0, 2000.0]),
                   delta=np.full(2, 3e-3))
    kn_range, delta_range = (300.0, 800.0), (1e-3, 5e-3)
    m = prior_misfit(ps, fin, kn_range, delta_range)
    assert m[0] < 1e-4
    # the reference: the stiffest fin of the prior (the edge the points pull to) at 400 gaps
    one = ps.subset(np.array([1]))
    scan = min(backbone_misfit(one, fin, np.array([kn]), np.array([d]))[0]
               for kn in (760.0, 800.0) for d in np.geomspace(*delta_range, 400))
    assert m[1] > 0.05 and m[1] <= scan * 1.001 and m[1] >= 0.9 * scan
    dom = TrainingDomain.from_point_sets(ps.subset(np.array([0])), prior_misfit_limit=0.01)
    dom = dataclasses.replace(dom, kn=kn_range, delta=delta_range)
    why = dom.outside(ps, system=fin)
    assert why[0] == "" and "no (kn, delta) of the training prior explains" in why[1]
    assert "no (kn, delta)" not in dom.outside(ps)[1]  # without the model: unchecked
    assert TrainingDomain.from_dict(dom.to_dict()) == dom


def test_the_calibration_bounds_the_prior_misfit_by_the_training_cases_noise():
    """Training cases on the default fin's backbone (kn 400-600, delta 2-4 mrad) with 0.3 % of
    frequency noise, a network whose estimates are 10 % off: the limit at the estimates grows
    with the network's errors, the prior's best fit's stays at the noise's RMS; a fin at kn
    2000 is named by the second, a training-like case by neither."""
    from types import SimpleNamespace

    from freeplayid.fit import BackboneModel
    from freeplayid.inverse import Calibration
    from freeplayid.model import default_fin

    fin = default_fin()
    ch = ("uz_top_left", "uz_lower_right")
    model = BackboneModel(fin, ch)
    rng = np.random.default_rng(5)
    n = 60
    kn = np.r_[rng.uniform(400, 600, n), 2000.0]
    delta = np.r_[rng.uniform(2e-3, 4e-3, n), 3e-3]
    s = np.array([2.0, 3.0, 4.5, 2.0, 3.0, 4.5])
    cidx = np.array([0, 0, 0, 1, 1, 1])
    amp = np.concatenate([s * d * np.where(cidx == 1, 0.3, 1.0) for d in delta])
    f = np.concatenate([model.frequency(amp[6 * c: 6 * c + 6], cidx, kn[c], delta[c])
                        for c in range(n + 1)]) * (1 + 0.003 * rng.standard_normal(6 * (n + 1)))
    ps = PointSets(channels=ch, case=np.repeat(np.arange(n + 1), 6), channel=np.tile(cidx, n + 1),
                   amplitude=amp, frequency=f, kn=kn, delta=delta)
    train = ps.subset(np.arange(n))
    off = np.exp(0.1 * rng.standard_normal(n))
    raw = SimpleNamespace(kn=kn[:n] * off, delta=delta[:n], log_kn_std=np.full(n, 0.1),
                          log_delta_std=np.full(n, 0.1))
    cal = Calibration.fit(train, train, raw, system=fin, raw_train=raw)
    dom = cal.domain
    assert 0.002 < dom.prior_misfit_limit < 0.006 < dom.misfit_limit
    est = {"kn": kn, "delta": delta, "log_kn_std": np.full(n + 1, 0.05),
           "log_delta_std": np.full(n + 1, 0.05)}
    est["kn"] = np.r_[kn[:n], 800.0]  # the network puts the stiff fin inside the prior
    why = dom.outside(ps.subset(np.array([0, n])), {k: v[[0, n]] for k, v in est.items()},
                      system=fin)
    assert why[0] == "" and "no (kn, delta) of the training prior explains" in why[1]


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    out = tmp_path_factory.mktemp("calibrated")
    ps = _cases(1000, seed=4)  # 400 validation cases: the recalibration's quantiles to ~2.5 %
    train, val = ps.subset(np.arange(600)), ps.subset(np.arange(600, 1000))
    train_inverse_model(train, val, channels=CHANNELS, fingerprint="synthetic", hidden=32,
                        depth=2, lr=1e-2, batch_size=64, max_epochs=8, seed=0, out_dir=out,
                        enable_progress_bar=False, logger=False)
    path = out / "best.ckpt"
    cal = calibrate_checkpoint(path, train, val)
    return path, cal


def test_a_calibrated_checkpoint_has_calibrated_spreads_on_new_cases(calibrated):
    path, cal = calibrated
    model = load_inverse_model(path)
    assert model.calibration == cal and all(s > 0 for s in cal.std_scale)
    assert cal.z["kn"] is not None  # this small network's kn spread is off on its validation
    test = _cases(1500, seed=9)  # held out: neither trained nor calibrated on
    raw_pred = model.predict(test, calibrated=False)
    m = cal.metrics(test, raw_pred)
    raw = calibration_metrics(test, raw_pred)
    for p in ("kn", "delta"):
        assert m[p]["max_gap"] < 0.05, (p, m[p]["max_gap"], raw[p]["max_gap"])
        assert m[p]["sbc"]["p_value"] > 0.001, (p, m[p]["sbc"])
    # the calibrated prediction: the posterior's median and 68 % half-width
    pred = model.predict(test)
    inside68 = np.abs(np.log(test.kn / pred.kn)) <= pred.log_kn_std
    assert np.mean(inside68) == pytest.approx(0.68, abs=0.05)


def test_out_of_domain_warning_fires_outside_the_prior_and_stays_quiet_inside(calibrated):
    path, _ = calibrated
    model = load_inverse_model(path)
    inside = _cases(10, seed=11)
    with warnings.catch_warnings():
        warnings.simplefilter("error", InverseDomainWarning)
        pred = model.predict(inside)
    assert pred.outside == ("",) * 10
    stiff = _cases(1, seed=12, kn_range=(2000.0, 2000.0))  # kn 2000: outside 240-960
    with pytest.warns(InverseDomainWarning, match="outside what the network was trained on or"):
        pred = model.predict(stiff)
    assert "frequency" in pred.outside[0]
    # the fit's start from the network records it and warns before the estimate is used
    pts = _points(stiff)
    with pytest.warns(InverseDomainWarning, match="the fit starts from it all the same"):
        start = resolve_start(model, pts)
    assert "frequency" in start.inverse["outside"]
    with warnings.catch_warnings():
        warnings.simplefilter("error", InverseDomainWarning)
        assert resolve_start(model, _points(inside.subset([0]))).inverse["outside"] == ""


def _points(ps):
    """The first case of ``ps`` as the fit's points (two at least)."""
    sel = ps.case == 0
    return FittingPoints(channel=tuple(CHANNELS[c] for c in ps.channel[sel]),
                         amplitude_m=ps.amplitude[sel], f_hz=ps.frequency[sel])


def test_the_clustered_rank_test_holds_its_level_where_cases_share_a_kn():
    """Cases in clusters of 16 that err alike (a shift per cluster, the marginal posterior
    calibrated): the ranks are uniform over all cases, but not independent. The plain
    chi-square then rejects far more often than its level; the test for clustered samples holds
    it. With every case of a cluster in one bin the design effect is the cluster size."""
    from freeplayid.inverse.calibration import design_effect, rank_uniformity, sbc_ranks

    rng = np.random.default_rng(5)
    n_cl, m, tau = 40, 16, 1.0
    cl = np.repeat(np.arange(n_cl), m)
    plain, clustered = [], []
    for _ in range(200):
        err = rng.normal(0.0, tau, n_cl)[cl] + rng.standard_normal(cl.size)
        truth = np.exp(err)  # log truth - log estimate = err, spread sqrt(1 + tau^2): calibrated
        ranks = sbc_ranks(truth, np.ones(cl.size), np.full(cl.size, np.hypot(1.0, tau)),
                          seed=int(rng.integers(1 << 30)))
        u = rank_uniformity(ranks, 99, clusters=cl)
        plain.append(u["p_value"] < 0.05)
        clustered.append(u["p_value_clustered"] < 0.05)
        assert u["deff"] >= 1.0
    assert np.mean(plain) > 0.3, np.mean(plain)
    assert np.mean(clustered) < 0.12, np.mean(clustered)
    # independent cases: no design effect to speak of; no clusters: none at all
    ranks = rng.integers(0, 100, cl.size)
    assert design_effect(ranks, np.linspace(-0.5, 99.5, 11), cl) < 1.4
    u = rank_uniformity(ranks, 99)
    assert u["deff"] == 1.0 and u["p_value_clustered"] == pytest.approx(u["p_value"])
    same = np.repeat(rng.integers(0, 100, n_cl), m)
    assert design_effect(same, np.linspace(-0.5, 99.5, 11), cl) == pytest.approx(m, rel=0.15)
    with pytest.raises(ValueError, match="one label per rank"):
        design_effect(ranks, np.linspace(-0.5, 99.5, 11), cl[:-1])


def _trained_on(**bank):
    """An object with a network's stored training data set (``extra``) for ``sweep_outside``."""
    from types import SimpleNamespace

    from freeplayid.inverse import InverseModel

    holder = SimpleNamespace(extra={"dataset": {"bank": bank}})
    return lambda sweeps: InverseModel.sweep_outside(holder, sweeps)


def test_sweeps_unlike_the_training_sweeps_are_named():
    """Direction and rate at the point against the training's (a quarter either way)."""
    from freeplayid.simulate import Sweep

    one_rate = _trained_on(sweep={"start_hz": 30.0, "stop_hz": 56.0, "rate_hz_per_s": 0.1})
    assert one_rate([("a", Sweep(30.0, 50.0, 0.1), 42.0), ("b", Sweep(30.0, 50.0, 0.12), 44.0)]) \
        == ""
    why = one_rate([("a", Sweep(30.0, 50.0, 0.1), 42.0), ("fast", Sweep(30.0, 50.0, 0.5), 44.0)])
    assert why.startswith("run fast sweeps at 0.5 Hz/s at its point (44 Hz)") and "0.1 Hz/s" in why
    assert "run down sweeps down" in one_rate([("down", Sweep(50.0, 30.0, 0.1), 42.0)])
    # a log sweep's rate at its point: 2 octaves/min at 45 Hz is 1.04 Hz/s
    assert "1.04 Hz/s" in one_rate([("log", Sweep(30.0, 60.0, octaves_per_min=2.0), 45.0)])
    drawn = _trained_on(sweep={"start_hz": 30.0, "stop_hz": 56.0, "rate_hz_per_s": 0.1},
                        rate_range=[0.5, 5.0])
    assert drawn([("fast", Sweep(30.0, 50.0, 0.5), 44.0)]) == ""
    assert "0.05-0.5 Hz/s" in drawn([("faster", Sweep(30.0, 50.0, 1.0), 44.0)])
    assert _trained_on()([("fast", Sweep(30.0, 50.0, 0.5), 44.0)]) == ""  # nothing recorded


def test_the_fit_from_a_network_warns_of_sweeps_it_was_not_trained_on():
    """plain_estimate with a network as its start: the bundled example (0.1 Hz/s) against a
    network trained at 0.5 Hz/s is warned of and recorded in the estimate; at 0.1 Hz/s not."""
    from freeplayid.estimate import plain_estimate
    from freeplayid.fit import FitOptions
    from freeplayid.io import read_dataset
    from freeplayid.io.dataset_files import bundled_example
    from freeplayid.model import load_system
    from freeplayid.signal.options import Extraction

    class Network:
        def __init__(self, rate):
            self.sweep_outside = _trained_on(
                sweep={"start_hz": 30.0, "stop_hz": 56.0, "rate_hz_per_s": rate})

        def predict_points(self, points):
            return 480.0, 3e-3, 0.05, 0.05

    ds = read_dataset(bundled_example())
    system = load_system(ds.model)
    ds = dataclasses.replace(ds, runs=ds.runs[1:3])  # two runs with points: enough here
    kw = dict(extraction=Extraction(), fit=FitOptions())
    with pytest.warns(InverseDomainWarning, match=r"runs sweep_0.60g.csv.gz, sweep_0.80g.csv.gz "
                      r"sweep at 0.1 Hz/s at their points \(40.1\d-42.4\d Hz\)"):
        est = plain_estimate(ds, system, init=Network(0.5), **kw)
    assert "the network was trained on 0.5 Hz/s" in est.inverse_estimate["outside"]
    assert est.fit.kn == pytest.approx(480.0, rel=0.05)
    with warnings.catch_warnings():
        warnings.simplefilter("error", InverseDomainWarning)
        est = plain_estimate(ds, system, init=Network(0.1), **kw)
    assert est.inverse_estimate["outside"] == ""

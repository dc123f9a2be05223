"""Set network of the inverse model: invariances, learning a known law, checkpoints, refusals;
each point's noise floor as its word of the noise (measured by the extraction, carried through
FittingPoints and PointSets, read by the network, checked by the domain)."""

import warnings

import numpy as np
import pytest
import torch

from freeplayid.errors import InverseDomainWarning
from freeplayid.fit import FittingPoints
from freeplayid.inverse import (
    InverseModel,
    InverseModelError,
    InverseModule,
    InverseNet,
    Normalisation,
    PointSets,
    TrainingDomain,
    collate_point_sets,
    load_inverse_model,
    point_sets_from_records,
    train_inverse_model,
)
from freeplayid.model.small import sdof_system
from freeplayid.signal import BackbonePoint, BackbonePoints

CHANNELS = ("uz_tip", "uz_root")
QUIET = dict(enable_progress_bar=False, logger=False)
# Lightning 2.6 with torch 2.13 (harmless, outside our code)
pytestmark = [
    pytest.mark.filterwarnings("ignore:`isinstance\\(treespec, LeafSpec\\)` is deprecated"),
    pytest.mark.usefixtures("quiet_lightning"),
]



def synthetic_point_sets(n: int, *, seed: int) -> PointSets:
    """Cases whose points follow a smooth known law with both kn and delta identifiable.

    kn, delta log-uniform; 2..6 points with r = A / delta in [1.5, 6] and
    ``f = 40 Hz sqrt(kn / 480) sqrt(1 - 1/r)`` (a softening backbone, f -> f_n as A >> delta);
    channel "uz_root" sees 0.6 of the amplitude at the same frequency.
    """
    rng = np.random.default_rng(seed)
    kn = np.exp(rng.uniform(np.log(240.0), np.log(960.0), n))  # N m/rad
    delta = np.exp(rng.uniform(np.log(3e-4), np.log(3e-3), n))  # rad
    case = np.repeat(np.arange(n), rng.integers(2, 7, n))
    r = rng.uniform(1.5, 6.0, case.size)
    channel = rng.integers(0, 2, case.size)
    f = 40.0 * np.sqrt(kn[case] / 480.0) * np.sqrt(1.0 - 1.0 / r)  # Hz
    amplitude = r * delta[case] * np.where(channel == 1, 0.6, 1.0)  # m
    return PointSets(channels=CHANNELS, case=case, channel=channel, amplitude=amplitude,
                     frequency=f, kn=kn, delta=delta)


def _padded_batch(seed=0):
    torch.manual_seed(seed)
    n = torch.tensor([1, 4, 7, 3])
    mask = torch.arange(7)[None, :] < n[:, None]
    x = torch.randn(4, 7, 2 + len(CHANNELS))
    return x, mask


def test_net_is_permutation_invariant():
    torch.manual_seed(1)
    net = InverseNet(len(CHANNELS), hidden=16, depth=3)
    x, mask = _padded_batch()
    m0, v0 = net(x, mask)
    x_perm = x.clone()
    for b in range(x.shape[0]):
        k = int(mask[b].sum())
        x_perm[b, :k] = x[b, torch.randperm(k)]
    m1, v1 = net(x_perm, mask)
    torch.testing.assert_close(m1, m0, atol=1e-6, rtol=0)
    torch.testing.assert_close(v1, v0, atol=1e-6, rtol=0)
    # and it does depend on the points: changing one changes the output
    x_perm[1, 0] += 1.0
    assert not torch.allclose(net(x_perm, mask)[0][1], m0[1], atol=1e-4)


def test_net_ignores_padding_whatever_it_holds():
    torch.manual_seed(2)
    net = InverseNet(len(CHANNELS), hidden=16, depth=2, activation="gelu")
    x, mask = _padded_batch()
    alone = [net(x[b:b + 1, : int(mask[b].sum())], mask[b:b + 1, : int(mask[b].sum())])
             for b in range(4)]
    # more padding, filled with garbage (huge values, NaN, inf)
    x_pad = torch.cat([x, torch.zeros(4, 5, x.shape[-1])], dim=1)
    mask_pad = torch.cat([mask, torch.zeros(4, 5, dtype=torch.bool)], dim=1)
    x_pad[~mask_pad] = 1e6
    x_pad[0, 3, 0], x_pad[2, 9, 1] = float("nan"), float("inf")
    m, v = net(x_pad, mask_pad)
    for b in range(4):
        torch.testing.assert_close(m[b], alone[b][0][0], atol=1e-6, rtol=0)
        torch.testing.assert_close(v[b], alone[b][1][0], atol=1e-6, rtol=0)
    lo, hi = -14.0, 4.0
    assert torch.all((v > lo) & (v < hi))


def test_collate_normalises_pads_and_marks_unknown_truth():
    ps = synthetic_point_sets(5, seed=3)
    norm = Normalisation.from_point_sets(ps)
    assert norm.log_amplitude_mean == pytest.approx(np.log(ps.amplitude).mean())
    assert norm.log_kn_std == pytest.approx(np.log(ps.kn).std())
    unknown = PointSets(**{**ps.__dict__, "kn": np.r_[ps.kn[:4], np.nan]})
    b = collate_point_sets(unknown, [4, 1], norm=norm.as_dict())
    n = ps.n_points[[4, 1]]
    assert b["x"].shape == (2, n.max(), 4) and b["x"].dtype == torch.float32
    np.testing.assert_array_equal(b["mask"].sum(1).numpy(), n)
    rows = np.flatnonzero(ps.case == 1)
    np.testing.assert_allclose(
        b["x"][1, : n[1], 1].numpy(), (ps.frequency[rows] - norm.frequency_mean)
        / norm.frequency_std, rtol=1e-5)
    np.testing.assert_array_equal(b["x"][1, np.arange(n[1]), 2 + ps.channel[rows]].numpy(), 1.0)
    np.testing.assert_array_equal(b["x"][1, : n[1], 2:].sum(1).numpy(), 1.0)
    assert torch.all(b["x"][~b["mask"]] == 0)
    assert torch.isnan(b["y"][0, 0]) and torch.isfinite(b["y"][0, 1])
    assert b["y"][1, 1] == pytest.approx(
        (np.log(ps.delta[1]) - norm.log_delta_mean) / norm.log_delta_std, rel=1e-5)
    with pytest.raises(ValueError, match="`cases` must lie in"):
        collate_point_sets(ps, [5], norm=norm)


def test_tiny_model_learns_a_known_law():
    ps = synthetic_point_sets(600, seed=0)
    train, val = ps.subset(np.arange(480)), ps.subset(np.arange(480, 600))
    module, _, hist = train_inverse_model(
        train, val, channels=CHANNELS, fingerprint="synthetic", hidden=32, depth=2, lr=1e-2,
        batch_size=64, max_epochs=10, seed=0, **QUIET)
    pred = InverseModel(module).predict(val)
    mae_kn = np.mean(np.abs(np.log(pred.kn / val.kn)))
    mae_delta = np.mean(np.abs(np.log(pred.delta / val.delta)))
    base_kn = np.mean(np.abs(np.log(train.kn).mean() - np.log(val.kn)))
    base_delta = np.mean(np.abs(np.log(train.delta).mean() - np.log(val.delta)))
    assert mae_kn < 0.5 * base_kn, (mae_kn, base_kn)
    assert mae_delta < 0.5 * base_delta, (mae_delta, base_delta)
    # the logged validation MAE is the same quantity, de-normalised
    best = int(np.argmin(hist["val_loss"]))
    assert hist["val_mae_log_kn"][best] == pytest.approx(mae_kn, rel=1e-3)
    assert hist["val_mae_log_delta"][best] == pytest.approx(mae_delta, rel=1e-3)
    assert len(hist["train_loss"]) == 10 and hist["train_loss"][-1] < hist["train_loss"][0]
    # the predicted spread is calibrated to within a factor of a few of the actual errors
    assert 0.3 < np.median(pred.log_kn_std) / mae_kn < 3.0


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    out = tmp_path_factory.mktemp("inverse")
    ps = synthetic_point_sets(120, seed=4)
    train, val = ps.subset(np.arange(96)), ps.subset(np.arange(96, 120))
    extra = {"kn_range": np.array([240.0, 960.0]), "dataset": {"n_cases": 120, "seed": 4}}
    module, _, hist = train_inverse_model(
        train, val, channels=CHANNELS, fingerprint="0123456789abcdef", hidden=16, depth=2,
        max_epochs=1, out_dir=out, extra=extra, enable_progress_bar=False, logger=True)
    return module, out / "best.ckpt", val, hist


def test_checkpoint_round_trip(trained):
    module, path, val, hist = trained
    assert path.is_file() and (path.parent / "metrics.csv").is_file()
    assert len(hist["val_loss"]) == 1
    model = load_inverse_model(path, system=None)
    assert model.channels == CHANNELS and model.fingerprint == "0123456789abcdef"
    assert model.extra == {"kn_range": [240.0, 960.0], "dataset": {"n_cases": 120, "seed": 4}}
    assert model.norm == module.norm == Normalisation.from_point_sets(
        synthetic_point_sets(120, seed=4).subset(np.arange(96)))
    p0, p1 = InverseModel(module).predict(val), model.predict(val)
    for name in ("kn", "delta", "log_kn_std", "log_delta_std"):
        np.testing.assert_allclose(getattr(p1, name), getattr(p0, name), rtol=1e-6)
    # Lightning's own loader restores the same module
    again = InverseModule.load_from_checkpoint(path, map_location="cpu")
    assert again.channels == CHANNELS and again.norm == module.norm
    np.testing.assert_allclose(InverseModel(again).predict(val).kn, p0.kn, rtol=1e-6)
    # one case from records, as the fit uses it
    kn, delta, s_kn, s_delta = model.predict_records(val.records(3))
    assert (kn, delta) == pytest.approx((p0.kn[3], p0.delta[3]), rel=1e-6)
    assert s_kn > 0 and s_delta > 0


def test_early_stopping_stops_and_keeps_the_best_epoch():
    ps = synthetic_point_sets(60, seed=1)
    train, val = ps.subset(np.arange(48)), ps.subset(np.arange(48, 60))
    # no improvement can reach min_delta: it stops after `patience` epochs past the first
    module, _, hist = train_inverse_model(
        train, val, channels=CHANNELS, fingerprint="x", hidden=8, depth=1, max_epochs=20,
        early_stopping={"patience": 2, "min_delta": 1e9}, **QUIET)
    assert len(hist["val_loss"]) == 3


def test_logger_kinds_are_checked():
    from freeplayid.inverse.lightning import make_logger

    with pytest.raises(ValueError, match="`logger` must be one of"):
        make_logger("wandb", ".")
    assert make_logger("none", ".") is False and make_logger(True, None) is False
    try:
        import tensorboard  # noqa: F401
    except ImportError:
        with pytest.raises(ValueError, match="pip install tensorboard"):
            make_logger("tensorboard", ".")


def test_training_is_reproducible_on_cpu():
    ps = synthetic_point_sets(80, seed=5)
    runs = [train_inverse_model(ps.subset(np.arange(64)), ps.subset(np.arange(64, 80)),
                                channels=CHANNELS, fingerprint="x", hidden=8, depth=2,
                                max_epochs=2, seed=7, accelerator="cpu", **QUIET)
            for _ in range(2)]
    assert runs[0][2] == runs[1][2]
    for a, b in zip(runs[0][0].parameters(), runs[1][0].parameters()):
        torch.testing.assert_close(a, b, atol=0, rtol=0)


def test_refuses_a_checkpoint_of_another_linear_model(trained):
    _, path, _, _ = trained
    system = sdof_system(mass=1.0, stiffness=100.0)
    with pytest.raises(InverseModelError) as err:
        load_inverse_model(path, system=system)
    msg = str(err.value)
    assert str(path) in msg and "0123456789abcdef" in msg and system.fingerprint() in msg
    assert "different linear structure" in msg and "scripts/train.py" in msg


def test_refuses_files_that_are_not_inverse_checkpoints(tmp_path):
    text = tmp_path / "notes.ckpt"
    text.write_text("not a checkpoint")
    with pytest.raises(InverseModelError, match="notes.ckpt"):
        load_inverse_model(text)
    other = tmp_path / "other.ckpt"
    torch.save({"state_dict": {}, "hyper_parameters": {}}, other)
    with pytest.raises(InverseModelError, match="other.ckpt.*not a freeplayid inverse"):
        load_inverse_model(other)
    with pytest.raises(InverseModelError, match="missing.ckpt.*does not exist"):
        load_inverse_model(tmp_path / "missing.ckpt")


def test_prediction_refuses_unknown_channels_and_empty_cases(trained):
    _, path, val, _ = trained
    model = load_inverse_model(path)
    records = [{"channel": "rx_hinge", "amplitude_m": 1e-3, "f_hz": 40.0}]
    with pytest.raises(ValueError, match=r"'rx_hinge'.*allowed: \['uz_tip', 'uz_root'\]"):
        model.predict_records(records)
    empty = val.subset(np.arange(3))
    keep = empty.case != 1  # case 1 loses its points
    empty = PointSets(**{**empty.__dict__, "case": empty.case[keep],
                         "channel": empty.channel[keep], "amplitude": empty.amplitude[keep],
                         "frequency": empty.frequency[keep]})
    with pytest.raises(ValueError, match=r"cases \[1\] have no points"):
        model.predict(empty)


@pytest.mark.gpu
@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_trains_and_predicts_on_cuda(tmp_path):
    ps = synthetic_point_sets(120, seed=6)
    val = ps.subset(np.arange(96, 120))
    module, _, _ = train_inverse_model(
        ps.subset(np.arange(96)), val, channels=CHANNELS, fingerprint="x", hidden=16, depth=2,
        max_epochs=2, accelerator="gpu", out_dir=tmp_path, **QUIET)
    on_gpu = load_inverse_model(tmp_path / "best.ckpt", map_location="cuda")
    on_cpu = load_inverse_model(tmp_path / "best.ckpt")
    assert next(on_gpu.module.parameters()).is_cuda
    np.testing.assert_allclose(on_gpu.predict(val).kn, on_cpu.predict(val).kn, rtol=1e-5)
    np.testing.assert_allclose(InverseModel(module).predict(val).kn, on_cpu.predict(val).kn,
                               rtol=1e-5)


def test_predict_points_takes_fitting_points_as_the_fit_does(trained):
    from freeplayid.fit import FittingPoints

    _, path, val, _ = trained
    model = load_inverse_model(path)
    case = next(i for i in range(val.n_cases) if val.n_points[i] >= 2)
    points = val.fitting_points(case)
    assert isinstance(points, FittingPoints) and points.to_records() == val.records(case)
    assert model.predict_points(points) == model.predict_records(val.records(case))
    p = model.predict(val)
    assert model.predict_points(points)[:2] == pytest.approx((p.kn[case], p.delta[case]), rel=1e-6)
    with pytest.raises(TypeError, match="FittingPoints"):
        model.predict_points(val.records(case))
    other = FittingPoints(channel=["rx_hinge", "uz_tip"], amplitude_m=[1e-3, 2e-3],
                          f_hz=[40.0, 41.0])
    with pytest.raises(ValueError, match=r"'rx_hinge'.*allowed: \['uz_tip', 'uz_root'\]"):
        model.predict_points(other)


# --- the noise input ------------------------------------------------------------------------


def noisy_point_sets(n: int, *, seed: int) -> tuple[PointSets, np.ndarray]:
    """Cases of a known softening law whose frequencies carry a relative scatter of one of three
    levels (0.1 %, 1 %, 4 %) per case; each point's noise_db says the level (20 log10 of it,
    with 1 dB of jitter). Returns the cases and each case's scatter."""
    rng = np.random.default_rng(seed)
    kn = np.exp(rng.uniform(np.log(240.0), np.log(960.0), n))
    delta = np.exp(rng.uniform(np.log(3e-4), np.log(3e-3), n))
    sigma = rng.choice([1e-3, 1e-2, 4e-2], n)
    case = np.repeat(np.arange(n), rng.integers(3, 7, n))
    r = rng.uniform(1.5, 6.0, case.size)
    channel = rng.integers(0, 2, case.size)
    f = 40.0 * np.sqrt(kn[case] / 480.0) * np.sqrt(1.0 - 1.0 / r)
    f = f * (1.0 + sigma[case] * rng.standard_normal(case.size))
    amplitude = r * delta[case] * np.where(channel == 1, 0.6, 1.0)
    noise = 20.0 * np.log10(sigma[case]) + rng.normal(0.0, 1.0, case.size)
    return PointSets(channels=CHANNELS, case=case, channel=channel, amplitude=amplitude,
                     frequency=f, kn=kn, delta=delta, noise_db=noise), sigma


def test_fitting_points_carry_the_noise_through_records():
    pts = FittingPoints(channel=["a", "b"], amplitude_m=[1e-3, 2e-3], f_hz=[5.0, 6.0],
                        run=["r0", "r1"], noise_db=[-30.0, np.nan])
    rec = pts.to_records()
    assert rec[0]["noise_db"] == -30.0 and np.isnan(rec[1]["noise_db"])
    assert FittingPoints.from_records(rec) == pts
    # a record without it drops it for all; equality sees the difference
    rec[1].pop("noise_db")
    back = FittingPoints.from_records(rec)
    assert back.noise_db is None and back != pts and "noise_db" not in back.to_records()[0]
    with pytest.raises(ValueError, match="noise_db"):
        FittingPoints(channel=["a", "b"], amplitude_m=[1e-3, 2e-3], f_hz=[5.0, 6.0],
                      noise_db=[-30.0])


def test_fitting_points_from_an_extraction_take_its_noise():

    pts = (BackbonePoint("r1", "a", 5.2, 2e-3, True, "", 1.0, 31.5, -31.5),
           BackbonePoint("r1", "b", 5.2, 1e-3, False, "no jump in band", 1.0, 2.0, -2.0),
           BackbonePoint("r2", "a", 5.6, 4e-3, True, "", 2.0, 17.25, -17.25))
    fp = FittingPoints.from_extraction(BackbonePoints(
        points=pts, rejected_runs=(), curves=(), quantity="acceleration", method="acmp"))
    np.testing.assert_array_equal(fp.noise_db, [-31.5, -17.25])
    np.testing.assert_array_equal(point_sets_from_records(fp, ("a", "b")).noise_db,
                                  [-31.5, -17.25])
    # a point made without one (a saved result's): NaN
    assert np.isnan(BackbonePoint("r1", "a", 5.2, 2e-3, True, "", 1.0, 31.5).noise_db)


def test_point_sets_keep_the_noise_through_subset_concatenate_and_files(tmp_path):
    ps, _ = noisy_point_sets(7, seed=1)
    sub = ps.subset([5, 2])
    rows = np.concatenate([np.flatnonzero(ps.case == 5), np.flatnonzero(ps.case == 2)])
    np.testing.assert_array_equal(sub.noise_db, ps.noise_db[rows])
    both = PointSets.concatenate([sub, ps])
    np.testing.assert_array_equal(both.noise_db, np.r_[sub.noise_db, ps.noise_db])
    # a part without it: the whole has none
    bare = PointSets(**{**ps.__dict__, "noise_db": None})
    assert PointSets.concatenate([bare, ps]).noise_db is None
    ps.save(tmp_path / "c.npz")
    np.testing.assert_array_equal(PointSets.load(tmp_path / "c.npz").noise_db, ps.noise_db)
    bare.save(tmp_path / "b.npz")
    assert PointSets.load(tmp_path / "b.npz").noise_db is None
    np.testing.assert_array_equal(ps.fitting_points(3).noise_db, ps.noise_db[ps.case == 3])
    one = point_sets_from_records(ps.fitting_points(3), CHANNELS)
    np.testing.assert_array_equal(one.noise_db, ps.noise_db[ps.case == 3])
    recs = [{"channel": "uz_tip", "amplitude_m": 1e-3, "f_hz": 30.0, "noise_db": -21.0},
            {"channel": "uz_root", "amplitude_m": 2e-3, "f_hz": 31.0}]
    assert point_sets_from_records(recs, CHANNELS).noise_db is None
    recs[1]["noise_db"] = -19.0
    np.testing.assert_array_equal(point_sets_from_records(recs, CHANNELS).noise_db,
                                  [-21.0, -19.0])
    with pytest.raises(ValueError, match="`noise_db` must have shape"):
        PointSets(**{**ps.__dict__, "noise_db": ps.noise_db[:-1]})


def test_normalisation_and_collate_with_and_without_the_noise():
    ps, _ = noisy_point_sets(6, seed=2)
    norm = Normalisation.from_point_sets(ps)
    assert norm.uses_noise and norm.noise_db_mean == pytest.approx(ps.noise_db.mean())
    assert norm.noise_db_std == pytest.approx(ps.noise_db.std())
    assert Normalisation.from_dict(norm.as_dict()) == norm
    old = Normalisation.from_point_sets(ps, noise=False)
    assert not old.uses_noise and "noise_db_mean" not in old.as_dict()
    # a checkpoint's record from before the noise input reads back as it was
    assert Normalisation.from_dict(old.as_dict()) == old
    with pytest.raises(ValueError, match="exactly the keys"):
        Normalisation.from_dict({**old.as_dict(), "noise_db_mean": 1.0})
    bare = PointSets(**{**ps.__dict__, "noise_db": None})
    assert not Normalisation.from_point_sets(bare).uses_noise  # the default: when it is there
    with pytest.raises(ValueError, match="noise_db"):
        Normalisation.from_point_sets(bare, noise=True)
    b = collate_point_sets(ps, [4], norm=norm)
    rows = np.flatnonzero(ps.case == 4)
    k = rows.size
    assert b["x"].shape == (1, k, 3 + len(CHANNELS))
    np.testing.assert_allclose(b["x"][0, :, 2].numpy(),
                               (ps.noise_db[rows] - norm.noise_db_mean) / norm.noise_db_std,
                               rtol=1e-5)
    np.testing.assert_array_equal(b["x"][0, np.arange(k), 3 + ps.channel[rows]].numpy(), 1.0)
    np.testing.assert_array_equal(b["x"][0, :, 3:].sum(1).numpy(), 1.0)
    assert collate_point_sets(ps, [4], norm=old)["x"].shape == (1, k, 2 + len(CHANNELS))
    # a point without a measured noise floor reads the training mean (0)
    gap = PointSets(**{**ps.__dict__, "noise_db": np.where(ps.case == 4, np.nan, ps.noise_db)})
    assert np.all(collate_point_sets(gap, [4], norm=norm)["x"][0, :, 2].numpy() == 0)


def test_the_network_reads_the_noise_from_its_input(tmp_path):
    """Trained on cases whose scatter only noise_db tells, the network with the noise input gives
    the noisy cases a wider posterior than the clean ones, and its central 50 % intervals hold
    about half the truths at every level; without it, every case gets about one spread."""
    ps, sigma = noisy_point_sets(1500, seed=0)
    train, val = ps.subset(np.arange(1200)), ps.subset(np.arange(1200, 1500))
    s_val = sigma[1200:]
    spreads, inside = {}, {}
    for noise in (True, False):
        module, _, _ = train_inverse_model(
            train, val, channels=CHANNELS, fingerprint="synthetic", hidden=32, depth=2,
            lr=1e-2, batch_size=64, max_epochs=25, seed=0, noise_input=noise, **QUIET)
        assert module.norm.uses_noise is noise
        pred = InverseModel(module).predict(val)
        z = np.log(val.kn / pred.kn) / pred.log_kn_std
        spreads[noise] = [np.median(pred.log_kn_std[s_val == s]) for s in (1e-3, 4e-2)]
        inside[noise] = [np.mean(np.abs(z[s_val == s]) < 0.6745) for s in (1e-3, 4e-2)]
    wide, narrow = spreads[True][1], spreads[True][0]
    assert wide > 2.0 * narrow, spreads
    assert spreads[False][1] < 1.5 * spreads[False][0], spreads
    # the share of truths inside the central 50 %: near 0.5 for both levels with the input
    assert all(0.35 < v < 0.65 for v in inside[True]), inside
    assert abs(inside[True][0] - inside[True][1]) < 0.15, inside
    # without it the clean cases' intervals are too wide and the noisy ones' too narrow
    assert inside[False][0] - inside[False][1] > 0.25, inside


def test_a_network_with_the_noise_input_round_trips_and_warns_without_it(tmp_path):
    ps, _ = noisy_point_sets(120, seed=4)
    train, val = ps.subset(np.arange(96)), ps.subset(np.arange(96, 120))
    module, trainer, _ = train_inverse_model(
        train, val, channels=CHANNELS, fingerprint="0123456789abcdef", hidden=16, depth=2,
        max_epochs=1, out_dir=tmp_path, enable_progress_bar=False, logger=False)
    assert module.norm.uses_noise  # the default: when the cases have it
    model = load_inverse_model(tmp_path / "best.ckpt")
    assert model.norm == module.norm and model.module.net.n_features == 3 + len(CHANNELS)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        p = model.predict(val)
    np.testing.assert_allclose(p.kn, InverseModel(module).predict(val).kn, rtol=1e-6)
    bare = PointSets(**{**val.__dict__, "noise_db": None})
    with pytest.warns(InverseDomainWarning, match="carry no measured noise floor"):
        model.predict(bare)
    fp = val.fitting_points(0)
    with pytest.warns(InverseDomainWarning, match="1 of"):
        model.predict(point_sets_from_records(
            FittingPoints(channel=fp.channel, amplitude_m=fp.amplitude_m, f_hz=fp.f_hz,
                          noise_db=np.r_[np.nan, fp.noise_db[1:]]), CHANNELS))


def test_the_domain_names_a_point_noisier_than_any_training_point():
    ps, _ = noisy_point_sets(40, seed=5)
    dom = TrainingDomain.from_point_sets(ps)
    assert dom.noise_db_max > ps.noise_db.max()
    assert TrainingDomain.from_dict(dom.to_dict()) == dom
    assert dom.outside(ps) == [""] * ps.n_cases
    noisy = PointSets(**{**ps.__dict__, "noise_db": np.where(ps.case == 2, dom.noise_db_max + 3,
                                                              ps.noise_db)})
    why = dom.outside(noisy)
    assert "noisier than any training record" in why[2]
    assert why[:2] == ["", ""] and why[3:] == [""] * (ps.n_cases - 3)
    # cleaner than any training point is not outside
    clean = PointSets(**{**ps.__dict__, "noise_db": ps.noise_db - 40})
    assert dom.outside(clean) == [""] * ps.n_cases
    # no noise floor recorded on either side: no check
    bare = PointSets(**{**ps.__dict__, "noise_db": None})
    assert TrainingDomain.from_point_sets(bare).noise_db_max is None
    assert dom.outside(bare) == [""] * ps.n_cases


def rate_point_sets(n: int, *, seed: int) -> PointSets:
    """``synthetic_point_sets`` swept at a rate per case (log-uniform 0.05-0.5 Hz/s) that moves
    every point's frequency by 6 % per decade of the rate, as a faster sweep's later drop
    does: without the rate, kn is uncertain by about 3.5 % (sd; the frequency squared)."""
    ps = synthetic_point_sets(n, seed=seed)
    rate = np.exp(np.random.default_rng(seed + 100).uniform(np.log(0.05), np.log(0.5), n))
    f = ps.frequency * (1.0 + 0.06 * np.log10(rate[ps.case] / 0.15))
    return PointSets(**{**ps.__dict__, "frequency": f}).with_rate(rate[ps.case])


def test_the_rate_input_is_read_kept_and_required():
    ps = rate_point_sets(8, seed=1)
    sub = ps.subset([6, 2])
    rows = np.concatenate([np.flatnonzero(ps.case == 6), np.flatnonzero(ps.case == 2)])
    np.testing.assert_array_equal(sub.rate, ps.rate[rows])
    np.testing.assert_array_equal(PointSets.concatenate([sub, ps]).rate, np.r_[sub.rate, ps.rate])
    with pytest.raises(ValueError, match="sweep rates must be finite and > 0"):
        ps.with_rate(np.zeros(ps.case.size))
    norm = Normalisation.from_point_sets(ps, rate=True)
    assert norm.uses_rate and not norm.uses_noise
    assert norm.log_rate_mean == pytest.approx(np.log(ps.rate).mean())
    assert Normalisation.from_dict(norm.as_dict()) == norm
    assert not Normalisation.from_point_sets(ps).uses_rate  # off unless asked
    with pytest.raises(ValueError, match="rate input"):
        Normalisation.from_point_sets(PointSets(**{**ps.__dict__, "rate": None}), rate=True)
    b = collate_point_sets(ps, [3], norm=norm)
    rows = np.flatnonzero(ps.case == 3)
    assert b["x"].shape == (1, rows.size, 3 + len(CHANNELS))
    np.testing.assert_allclose(b["x"][0, :, 2].numpy(),
                               (np.log(ps.rate[rows]) - norm.log_rate_mean) / norm.log_rate_std,
                               rtol=1e-5)
    np.testing.assert_array_equal(b["x"][0, :, 3:].sum(1).numpy(), 1.0)
    with pytest.raises(ValueError, match="sweep rate"):
        collate_point_sets(PointSets(**{**ps.__dict__, "rate": None}), [3], norm=norm)


def test_a_network_reads_the_sweep_rate_from_its_input(tmp_path):
    """Cases whose frequencies the sweep rate moves: with the rate as an input the network's kn
    errs less than without it, round-trips through its checkpoint and refuses points without a
    rate."""
    ps = rate_point_sets(1500, seed=0)
    train, val = ps.subset(np.arange(1200)), ps.subset(np.arange(1200, 1500))
    err = {}
    for rate in (True, False):
        module, _, _ = train_inverse_model(
            train, val, channels=CHANNELS, fingerprint="synthetic", hidden=32, depth=2,
            lr=1e-2, batch_size=64, max_epochs=25, seed=0, rate_input=rate,
            out_dir=tmp_path / str(rate), **QUIET)
        assert module.norm.uses_rate is rate
        err[rate] = np.median(np.abs(np.log(val.kn / InverseModel(module).predict(val).kn)))
    assert err[True] < 0.6 * err[False], err
    model = load_inverse_model(tmp_path / "True" / "best.ckpt")
    assert model.uses_rate and model.module.net.n_features == 3 + len(CHANNELS)
    with pytest.raises(ValueError, match="reads each point's sweep rate"):
        model.predict(PointSets(**{**val.__dict__, "rate": None}))
    fp = val.fitting_points(0)
    kn = model.predict_points(fp, rate=val.rate[val.case == 0])[0]
    assert kn == pytest.approx(model.predict(val.subset([0])).kn[0], rel=1e-6)

import re

import numpy as np
import pytest

from freeplayid.io import DatasetError, Run, read_dataset, write_dataset
from freeplayid.model import load_system, two_dof_system


def _runs():
    t = np.arange(200) / 100.0
    rng = np.random.default_rng(0)
    return [
        Run(file=f"sweep_{lv:.2f}g.csv", time=t, data=rng.normal(size=(2, t.size)) * lv,
            level_g=lv, sweep={"start_hz": 30.0, "stop_hz": 50.0, "rate_hz_per_s": 0.1},
            base=np.sin(t))
        for lv in (0.4, 0.6)
    ]


def test_round_trip(tmp_path):
    runs = _runs()
    system = two_dof_system()
    manifest = write_dataset(
        tmp_path / "ds", name="test set", quantity="acceleration", units="g", sample_rate=100.0,
        channels={"acc_a": "uz_in", "acc_b": "uz_out"}, runs=runs, system=system,
        base_channel="acc_base",
    )
    assert manifest.name == "manifest.yaml"
    assert not list((tmp_path / "ds").glob("*.tmp"))
    ds = read_dataset(tmp_path / "ds")
    assert ds.name == "test set" and ds.quantity == "acceleration" and ds.units == "g"
    assert ds.sample_rate == 100.0 and ds.channels == {"acc_a": "uz_in", "acc_b": "uz_out"}
    assert ds.base_channel == "acc_base"
    for a, b in zip(ds.runs, runs, strict=True):
        assert a.file == b.file and a.level_g == b.level_g and a.sweep == b.sweep
        np.testing.assert_allclose(a.time, b.time, rtol=1e-9)
        np.testing.assert_allclose(a.data, b.data, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(a.base, b.base, rtol=1e-9, atol=1e-12)
    assert load_system(ds.model).fingerprint() == system.fingerprint()
    # without sample_rate in the manifest, the time column defines it
    text = manifest.read_text().replace("sample_rate: 100.0\n", "")
    manifest.write_text(text)
    assert read_dataset(manifest).sample_rate == pytest.approx(100.0)


def test_errors_name_the_problem(tmp_path):
    runs = _runs()
    with pytest.raises(DatasetError, match="units"):
        write_dataset(tmp_path, name="x", quantity="velocity", units="g", sample_rate=1.0,
                      channels={"v": "x"}, runs=runs)
    with pytest.raises(DatasetError, match="shape"):
        write_dataset(tmp_path, name="x", quantity="acceleration", units="g", sample_rate=100.0,
                      channels={"a": "x"}, runs=runs)
    write_dataset(tmp_path / "ok", name="x", quantity="acceleration", units="m/s^2",
                  sample_rate=100.0, channels={"a": "x", "b": "y"}, runs=runs)
    (tmp_path / "ok" / "sweep_0.40g.csv").unlink()
    with pytest.raises(DatasetError, match="not found"):
        read_dataset(tmp_path / "ok" / "manifest.yaml")
    with pytest.raises(DatasetError, match="manifest not found"):
        read_dataset(tmp_path / "nothing")


def test_the_frame_is_declared_read_back_and_checked(tmp_path):
    import dataclasses

    from freeplayid.dataset import Dataset

    bare = [dataclasses.replace(r, base=None) for r in _runs()]
    kw = dict(name="x", quantity="acceleration", units="g", sample_rate=100.0,
              channels={"acc_a": "uz_in", "acc_b": "uz_out"})
    # absolute (accelerometers) is the default and is not written; relative is
    absolute = write_dataset(tmp_path / "abs", runs=bare, **kw)
    relative = write_dataset(tmp_path / "rel", runs=bare, frame="relative", **kw)
    assert "frame" not in yaml.safe_load(absolute.read_text())
    assert yaml.safe_load(relative.read_text())["frame"] == "relative"
    assert read_dataset(absolute).frame == "absolute"
    assert read_dataset(relative).frame == "relative"
    # a value outside the two, or records relative to a base that is also given: one line
    # naming the file, the field and the allowed values
    for value, match in (("inertial", r"`frame` must be one of \['absolute', 'relative'\]"),
                         ("relative", r"`frame: relative` takes no `base_channel`")):
        text = yaml.safe_load(_good_set(tmp_path / value).read_text())
        text["frame"] = value
        bad = tmp_path / value / "manifest.yaml"
        bad.write_text(yaml.safe_dump(text))
        with pytest.raises(DatasetError, match=match) as err:
            read_dataset(bad)
        assert str(bad) in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(DatasetError, match="takes no `base_channel`"):
        write_dataset(tmp_path / "x", runs=_runs(), base_channel="acc_base", frame="relative",
                      **kw)
    with pytest.raises(DatasetError, match="`frame` must be one of"):
        Dataset.from_arrays(np.zeros((1, 1, 64)), channels={"a": "x"}, quantity="acceleration",
                            units="g", sample_rate=64.0, frame="rel")
    assert Dataset.from_arrays(np.zeros((1, 1, 64)), channels={"a": "x"},
                               quantity="acceleration", units="g", sample_rate=64.0,
                               frame="relative").frame == "relative"


# ------------------------------------------------------------------------------------------------
# malformed data sets: a clear DatasetError naming the file, run, field or column, or a flagged run
# ------------------------------------------------------------------------------------------------

import yaml  # noqa: E402

from freeplayid.io import read_uff, write_uff  # noqa: E402


def _good_set(folder, *, system=None, units="m/s^2"):
    t = np.arange(400) / 200.0
    runs = [Run(file=f"r{k}.csv", time=t, data=np.vstack([np.sin(40 * t), np.cos(40 * t)]) * lv,
                level_g=lv, sweep={"start_hz": 30.0, "stop_hz": 50.0, "rate_hz_per_s": 10.0},
                base=0.1 * np.sin(40 * t))
            for k, lv in enumerate((0.5, 1.0))]
    return write_dataset(folder, name="m", quantity="acceleration", units=units,
                         sample_rate=200.0, channels={"a1": "uz_in", "a2": "uz_out"}, runs=runs,
                         system=system or two_dof_system(), base_channel="ab")


def _edit_manifest(manifest, fn):
    m = yaml.safe_load(manifest.read_text())
    fn(m)
    manifest.write_text(yaml.safe_dump(m, sort_keys=False))


def _edit_csv(path, fn):
    lines = path.read_text().splitlines()
    fn(lines)
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize(
    "edit, pattern",
    [
        (lambda m: m.update(units="mm"),
         r"`units` for acceleration must be one of \('g', 'm/s\^2'\), got 'mm'"),
        (lambda m: m.update(quantity="force"), r"`quantity` must be one of"),
        (lambda m: m.update(colour="red"), r"unknown field\(s\) \['colour'\]; allowed"),
        (lambda m: m["runs"][1].update(gain=2), r"`runs\[1\]`: unknown field\(s\) \['gain'\]"),
        (lambda m: m["runs"][0].update(file="nope.csv"), r"`runs\[0\]`\.file 'nope.csv' not found"),
        (lambda m: m.update(runs=[]), r"`runs` must be a non-empty list"),
        (lambda m: m.update(channels={"a1": "uz_tip", "a2": "uz_out"}),
         r"DOF\(s\) the model 'model.npz' does not have: \{'a1': 'uz_tip'\}; its DOFs are "
         r"\['uz_in', 'uz_out'\]"),
        (lambda m: m.update(model="missing.npz"), r"`model` file 'missing.npz' not found"),
        (lambda m: m.update(sample_rate=100.0),
         r"r0.csv: column 'time' implies 200 Hz but the data set's sample rate is 100 Hz"),
        (lambda m: m["runs"][0]["sweep"].pop("rate_hz_per_s"), r"`runs\[0\]`.sweep misses"),
        (lambda m: m.update(truth={"kn": 1.0, "gap": 2.0}), r"`truth`: unknown field"),
        (lambda m: m.update(channels={"a1": "uz_in", "a9": "uz_out"}),
         r"r0.csv: column\(s\) \['a9'\] not in the header"),
    ],
)
def test_malformed_manifest(tmp_path, edit, pattern):
    manifest = _good_set(tmp_path)
    _edit_manifest(manifest, edit)
    with pytest.raises(DatasetError, match=pattern) as info:
        read_dataset(tmp_path)
    assert str(manifest) in str(info.value) or "r0.csv" in str(info.value)


@pytest.mark.parametrize(
    "edit, pattern",
    [
        (lambda ls: ls.__setitem__(5, ls[5].replace(",", ",abc", 1)), r"r1.csv: non-numeric"),
        (lambda ls: ls.__setitem__(slice(5, 7), [ls[6], ls[5]]),
         r"r1.csv: column 'time' must increase strictly; data rows 5-6 go 0.025 -> 0.02 s"),
        (lambda ls: ls.__delitem__(slice(100, 103)), r"r1.csv: column 'time' is not uniformly"),
        (lambda ls: ls.__setitem__(0, "t,a1,a2,ab"), r"r1.csv: column\(s\) \['time'\] not in"),
    ],
)
def test_malformed_csv(tmp_path, edit, pattern):
    """A malformed run file rejects that run with the message; in every run it is an error."""
    _good_set(tmp_path)
    _edit_csv(tmp_path / "r1.csv", edit)
    ds = read_dataset(tmp_path)
    assert ds.runs[0].reason == ""
    assert re.search(pattern, ds.runs[1].reason) and ds.runs[1].data.shape == (2, 0)
    _edit_csv(tmp_path / "r0.csv", edit)
    with pytest.raises(DatasetError, match=pattern.replace("r1", "r0")):
        read_dataset(tmp_path)


def test_nan_run_is_flagged_not_raised(tmp_path):
    _good_set(tmp_path)
    _edit_csv(tmp_path / "r0.csv", lambda ls: ls.__setitem__(11, ls[11].rsplit(",", 1)[0] + ",nan"))
    ds = read_dataset(tmp_path)
    assert ds.runs[1].reason == ""
    assert "non-finite" in ds.runs[0].reason and "'ab'" in ds.runs[0].reason
    assert "t = 0.05 s" in ds.runs[0].reason


def test_units_to_si(tmp_path):
    _good_set(tmp_path, units="g")
    ds = read_dataset(tmp_path)
    assert ds.si_scale == pytest.approx(9.80665)
    np.testing.assert_allclose(ds.to_si(ds.runs[0].data), ds.runs[0].data * 9.80665)
    _good_set(tmp_path / "si")
    assert read_dataset(tmp_path / "si").si_scale == 1.0


def test_gzip_csv_round_trip(tmp_path):
    t = np.arange(300) / 100.0
    run = Run(file="r.csv.gz", time=t, data=np.sin(t)[None], level_g=1.0)
    write_dataset(tmp_path, name="gz", quantity="displacement", units="m", sample_rate=100.0,
                  channels={"d": "x"}, runs=[run], float_format="%.6g", time_format="%.4f")
    assert (tmp_path / "r.csv.gz").read_bytes()[:2] == b"\x1f\x8b"
    ds = read_dataset(tmp_path)
    np.testing.assert_allclose(ds.runs[0].data[0], np.sin(t), atol=1e-6)


def test_uff_round_trip_and_dataset(tmp_path):
    t = np.arange(512) / 256.0
    cols = {"a1": np.sin(2 * np.pi * 40 * t), "a2": 0.5 * np.cos(2 * np.pi * 40 * t),
            "ab": 0.1 * np.sin(2 * np.pi * 40 * t)}
    write_uff(tmp_path / "r0.uff", t, cols)
    back = read_uff(tmp_path / "r0.uff", columns=["a2", "a1"])
    np.testing.assert_allclose(back["time"], t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(back["a1"], cols["a1"], atol=1e-10)
    np.testing.assert_allclose(back["a2"], cols["a2"], atol=1e-10)
    manifest = _good_set(tmp_path / "set")
    import shutil

    shutil.copy(tmp_path / "r0.uff", tmp_path / "set" / "r0.uff")
    _edit_manifest(manifest, lambda m: (m["runs"][0].update(file="r0.uff"),
                                        m.update(sample_rate=256.0), m["runs"].pop(1)))
    ds = read_dataset(manifest)
    assert ds.sample_rate == 256.0 and ds.runs[0].file == "r0.uff"
    np.testing.assert_allclose(ds.runs[0].data, np.vstack([cols["a1"], cols["a2"]]), atol=1e-10)
    np.testing.assert_allclose(ds.runs[0].base, cols["ab"], atol=1e-10)
    _edit_manifest(manifest, lambda m: m.update(channels={"a1": "uz_in", "acc_9": "uz_out"}))
    with pytest.raises(DatasetError, match=r"r0.uff: channel\(s\) \['acc_9'\] not found"):
        read_dataset(manifest)

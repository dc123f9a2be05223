"""Dataset.from_arrays: a data set built in a notebook is the data set read from the same numbers
written as files, and it is refused for what a manifest is refused for, with the same words."""

import numpy as np
import pytest
import yaml

from freeplayid.dataset import Dataset
from freeplayid.io import DatasetError, Run, read_dataset, write_dataset
from freeplayid.model import save_system, two_dof_system
from freeplayid.sweep import Sweep

FS = 200.0  # [Hz]
N = 600
T = np.arange(N) / FS  # [s]
CHANNELS = {"a1": "uz_in", "a2": "uz_out"}
LEVELS = [0.5, 1.0]
HINT = {"start_hz": 10.0, "stop_hz": 40.0, "rate_hz_per_s": 10.0}  # 3 s: the record's length
RNG = np.random.default_rng(7)
DATA = RNG.normal(size=(2, 2, N))  # (runs, channels, T)
BASE = RNG.normal(size=(2, N))


@pytest.fixture
def model(tmp_path):
    path = tmp_path / "model.npz"
    save_system(path, two_dof_system())
    return path


def _arrays(model, **kwargs):
    args = dict(channels=CHANNELS, quantity="acceleration", units="g", sample_rate=FS,
                base=BASE, base_channel="ab", levels_g=LEVELS, sweeps=HINT, model=model,
                name="notebook")
    data = kwargs.pop("data", DATA)
    args.update(kwargs)
    return Dataset.from_arrays(data, **args)


def _files(folder):
    runs = [Run(file=f"r{k}.csv", time=T, data=DATA[k], level_g=LEVELS[k], sweep=HINT,
                base=BASE[k]) for k in range(2)]
    return write_dataset(folder, name="notebook", quantity="acceleration", units="g",
                         sample_rate=FS, channels=CHANNELS, runs=runs, system=two_dof_system(),
                         base_channel="ab", float_format="%.17g")


def _same(a, b):
    assert (a.quantity, a.units, a.channels, a.base_channel) == \
        (b.quantity, b.units, b.channels, b.base_channel)
    assert a.sample_rate == pytest.approx(b.sample_rate, rel=1e-12)  # from a time axis: its fit
    assert len(a.runs) == len(b.runs)
    for ra, rb in zip(a.runs, b.runs, strict=True):
        assert (ra.level_g, ra.sweep, ra.reason) == (rb.level_g, rb.sweep, rb.reason)
        np.testing.assert_allclose(ra.time, rb.time, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(ra.data, rb.data)
        np.testing.assert_array_equal(ra.base, rb.base)


@pytest.mark.parametrize("form", ["array", "list", "time", "time-per-run", "sweep-object"])
def test_from_arrays_is_the_data_set_of_the_same_files(tmp_path, model, form):
    ref = read_dataset(_files(tmp_path / "files"))
    kwargs = {}
    if form == "list":
        kwargs = dict(data=list(DATA), base=list(BASE))
    elif form == "time":
        kwargs = dict(sample_rate=None, time=T)
    elif form == "time-per-run":
        kwargs = dict(sample_rate=None, time=[T, T])
    elif form == "sweep-object":
        kwargs = dict(sweeps=[Sweep(**HINT), HINT])
    ds = _arrays(model, **kwargs)
    _same(ds, ref)
    assert ds.model == model.resolve() and ds.path is None and ds.name == "notebook"
    assert [r.file for r in ds.runs] == ["run_0", "run_1"]


def test_runs_of_different_lengths_and_no_base(model):
    ds = Dataset.from_arrays([DATA[0], DATA[1][:, :400]], channels=CHANNELS,
                             quantity="velocity", units="m/s", sample_rate=FS, model=None,
                             run_names=["up", "down"])
    assert [r.data.shape for r in ds.runs] == [(2, N), (2, 400)]
    assert [r.time.size for r in ds.runs] == [N, 400] and ds.runs[1].time[-1] == 399 / FS
    assert ds.base_channel is None and ds.runs[0].base is None and ds.model is None
    assert [r.file for r in ds.runs] == ["up", "down"]


def test_nonfinite_samples_and_a_wrong_hint_reject_the_run_as_in_a_file(tmp_path, model):
    data = DATA.copy()
    data[1, 0, 100:103] = np.nan
    hint = dict(HINT, rate_hz_per_s=1.0)  # 30 s for a 3 s record
    ds = _arrays(model, data=data, sweeps=[hint, HINT])
    manifest = _files(tmp_path)
    m = yaml.safe_load(manifest.read_text())
    m["runs"][0]["sweep"] = hint
    manifest.write_text(yaml.safe_dump(m))
    text = (tmp_path / "r1.csv").read_text().splitlines()
    for k in (101, 102, 103):  # data rows 100-102 after the header
        cells = text[k].split(",")
        text[k] = ",".join([cells[0], "nan", *cells[2:]])
    (tmp_path / "r1.csv").write_text("\n".join(text) + "\n")
    ref = read_dataset(manifest)
    assert ds.runs[0].reason == ref.runs[0].reason and "the hint does not describe" in \
        ds.runs[0].reason
    assert ds.runs[1].reason == ref.runs[1].reason == (
        "non-finite values (NaN/inf) in column 'a1': 3 samples, first at t = 0.5 s")


# ------------------------------------------------------------------------------------------------
# one line naming the argument and the shapes
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, message",
    [
        # the case: a (T, channels) record where (channels, T) is expected
        (dict(data=DATA.swapaxes(1, 2)),
         "`data` has shape (2, 600, 2): axis 1 must hold the 2 `channels` ['a1', 'a2'], expected "
         "(runs, 2, T); it looks transposed: pass data.swapaxes(1, 2)"),
        (dict(data=[DATA[0].T, DATA[1]], base=list(BASE)),
         "`data[0]` has shape (600, 2) but `channels` names 2 channels ['a1', 'a2']: expected "
         "(2, T); it looks transposed: pass data[0].T"),
        (dict(data=DATA[0]),
         "`data` must have shape (runs, channels, T) = (runs, 2, T) or be a list of (channels, T) "
         "arrays, got shape (2, 600) (one run: pass data[None] or [data])"),
        (dict(data=DATA[:, :1]),
         "`data` has shape (2, 1, 600): axis 1 must hold the 2 `channels` ['a1', 'a2'], expected "
         "(runs, 2, T)"),
        (dict(levels_g=[0.5, 1.0, 1.5]), "`levels_g` has 3 values but `data` has 2 runs"),
        (dict(sweeps=[HINT]), "`sweeps` has 1 values but `data` has 2 runs"),
        (dict(run_names=["a"]), "`run_names` has 1 values but `data` has 2 runs"),
        (dict(base=BASE[:, :-1]),
         "`base[0]` has shape (599,) but `data[0]` has 600 samples: expected (600,)"),
        (dict(base=BASE[0]), "`base` must have shape (runs, T) or be a list of (T,) arrays, got "
                             "shape (600,)"),
        (dict(sample_rate=None, time=T[:-1]),
         "`time` has shape (599,) but `data[0]` has 600 samples (its last axis)"),
        (dict(time=T), "give one of `sample_rate` [Hz] and `time` [s], got both"),
        (dict(sample_rate=None), "give one of `sample_rate` [Hz] and `time` [s], got neither"),
        (dict(sample_rate=-FS), "`sample_rate` [Hz] must be a finite number > 0, got -200.0"),
        (dict(sample_rate=None, time=np.r_[T[:10], T[9:-1]]),
         "`time`: the time must increase strictly; data rows 10-11 go 0.045 -> 0.045 s"),
        (dict(sample_rate=None, time=[T, T * 2]),
         "`time[1]`: the time implies 100 Hz but the data set's sample rate is 200 Hz (the "
         "manifest's `sample_rate`, else the first run's time column)"),
        (dict(data=DATA[:, :, :10], base=BASE[:, :10]),
         "`data[0]`: 10 samples; a sweep run needs many more"),
        (dict(levels_g=[0.5, -1.0]), "`levels_g[1]` [g] must be a finite number > 0, got -1.0"),
        (dict(base=None), "`base_channel` 'ab' needs `base` arrays (and `base` a `base_channel` "
                          "name)"),
    ],
)
def test_argument_errors_name_the_argument_and_the_shapes(model, kwargs, message):
    with pytest.raises(DatasetError) as info:
        _arrays(model, **kwargs)
    assert str(info.value) == message


# the same mistake in a manifest and in from_arrays' arguments: the same words
SHARED = [
    (dict(units="mm"), lambda m: m.update(units="mm"),
     "`units` for acceleration must be one of ('g', 'm/s^2'), got 'mm'"),
    (dict(quantity="force"), lambda m: m.update(quantity="force"),
     "`quantity` must be one of ('displacement', 'velocity', 'acceleration'), got 'force'"),
    (dict(channels={"a1": "uz_in", "a2": "uz_in"}),
     lambda m: m.update(channels={"a1": "uz_in", "a2": "uz_in"}),
     "`channels` map the columns ['a1', 'a2'] to the same model DOF 'uz_in'; each DOF takes one "
     "column (drop one, or map it to its own DOF)"),
    (dict(base_channel="a1"), lambda m: m.update(base_channel="a1"),
     "`base_channel` must be a column name other than 'time' and the channels ['a1', 'a2'], got "
     "'a1'"),
    (dict(channels={"a1": "uz_tip", "a2": "uz_out"}),
     lambda m: m.update(channels={"a1": "uz_tip", "a2": "uz_out"}),
     "`channels` map to DOF(s) the model MODEL does not have: {'a1': 'uz_tip'}; its DOFs are "
     "['uz_in', 'uz_out']"),
]


@pytest.mark.parametrize("kwargs, edit, message", SHARED)
def test_the_manifest_and_from_arrays_share_their_rules(tmp_path, model, kwargs, edit, message):
    with pytest.raises(DatasetError) as arrays:
        _arrays(model, **kwargs)
    manifest = _files(tmp_path / "files")
    m = yaml.safe_load(manifest.read_text())
    edit(m)
    manifest.write_text(yaml.safe_dump(m, sort_keys=False))
    with pytest.raises(DatasetError) as files:
        read_dataset(manifest)
    assert str(arrays.value) == message.replace("MODEL", repr(str(model)))
    assert str(files.value) == f"{manifest}: " + message.replace("MODEL", "'model.npz'")


def test_sweep_hints_are_checked_as_in_a_manifest(tmp_path, model):
    bad = {"start_hz": 10.0, "stop_hz": 40.0}
    with pytest.raises(DatasetError) as arrays:
        _arrays(model, sweeps=[HINT, bad])
    assert str(arrays.value) == (
        "`sweeps[1]` misses ['rate_hz_per_s or octaves_per_min']; it needs `start_hz`, `stop_hz` "
        "and `rate_hz_per_s` (linear) or `octaves_per_min` (logarithmic)")
    manifest = _files(tmp_path)
    m = yaml.safe_load(manifest.read_text())
    m["runs"][1]["sweep"] = bad
    manifest.write_text(yaml.safe_dump(m, sort_keys=False))
    with pytest.raises(DatasetError, match=r"`runs\[1\]`.sweep misses \['rate_hz_per_s or "):
        read_dataset(manifest)


def test_model_file_errors(tmp_path):
    with pytest.raises(DatasetError, match=r"^`model` file 'nope.npz' not found \(looked at "):
        _arrays("nope.npz")
    (tmp_path / "m.npz").write_bytes(b"not a zip")
    with pytest.raises(DatasetError, match=r"^`model` '.*m.npz' is not a readable model file "
                                           r"\(.npz with `dof_names`\)"):
        _arrays(tmp_path / "m.npz")

"""Run-file readers (freeplayid.io.readers): every file type reads the same run as its CSV, and
gets the same validation (time column, sample rate, non-finite samples) from read_dataset."""

import numpy as np
import pytest
import scipy.io
import yaml

from freeplayid.io import DatasetError, Run, read_dataset, write_dataset, write_uff
from freeplayid.io.readers import READERS, RunFile, read_run, reader_for
from freeplayid.model import two_dof_system

FS = 200.0  # [Hz]
T = np.arange(400) / FS  # [s]
COLS = {"a1": np.sin(2 * np.pi * 20 * T), "a2": 0.5 * np.cos(2 * np.pi * 20 * T),
        "ab": 0.1 * np.sin(2 * np.pi * 20 * T + 0.3)}


def _csv_set(folder):
    run = Run(file="r0.csv", time=T, data=np.vstack([COLS["a1"], COLS["a2"]]), level_g=0.5,
              base=COLS["ab"])
    return write_dataset(folder, name="m", quantity="acceleration", units="m/s^2",
                         sample_rate=FS, channels={"a1": "uz_in", "a2": "uz_out"}, runs=[run],
                         system=two_dof_system(), base_channel="ab")


def _edit_manifest(manifest, fn):
    m = yaml.safe_load(manifest.read_text())
    fn(m)
    manifest.write_text(yaml.safe_dump(m, sort_keys=False))


def _use(manifest, name):
    _edit_manifest(manifest, lambda m: m["runs"][0].update(file=name))


# ------------------------------------------------------------------------------------------------
# writers of the same run in each file type; time=None: from the file's own timing (TDMS waveform,
# UFF abscissa), which are then evenly spaced at FS
# ------------------------------------------------------------------------------------------------


def _write_csv(path, t, cols):
    np.savetxt(path, np.column_stack([t, *cols.values()]), delimiter=",", comments="",
               header=",".join(["time", *cols]), fmt="%.17g")


def _write_mat(fmt, orient):
    def write(path, t, cols):
        def vec(x):
            x = np.asarray(x)
            return x[None, :] if orient == "row" else x[:, None]

        scipy.io.savemat(path, {"time": vec(t), **{c: vec(x) for c, x in cols.items()},
                                "note": np.ones((3, 3))}, format=fmt)
    return write


def _mat73_header(path):
    # what MATLAB writes in the 512-byte user block: text, subsystem offset, version 0x0200, 'IM'
    text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created by: freeplayid tests HDF5 schema 1.00"
    with open(path, "r+b") as fh:
        fh.write(text.ljust(116) + bytes(8) + b"\x00\x02IM")


def _write_mat73(path, t, cols, *, complex_=()):
    h5py = pytest.importorskip("h5py")
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, x in {"time": t, **cols}.items():
            x = np.asarray(x, dtype=float)[:, None]  # a MATLAB 1xN vector is stored (N, 1)
            if name in complex_:
                x = np.rec.fromarrays([x, x], names=["real", "imag"])
            f.create_dataset(name, data=x).attrs["MATLAB_class"] = np.bytes_("double")
        f.create_group("#refs#")
    _mat73_header(path)


def _write_tdms(path, t, cols, *, groups=None, properties=None, extra=None):
    """``extra``: (group, channel) of one more channel (a copy of a1)."""
    from nptdms import ChannelObject, TdmsWriter

    groups = groups or {}
    objs = [] if t is None else [ChannelObject("meta", "time", np.asarray(t))]
    objs += [ChannelObject(groups.get(c, "acc"), c, np.asarray(x),
                           properties=(properties or {}).get(c)) for c, x in cols.items()]
    if extra is not None:
        objs.append(ChannelObject(*extra, COLS["a1"]))
    with TdmsWriter(str(path)) as w:
        w.write_segment(objs)


def _write_tdms_waveform(path, t, cols):
    assert t is None or np.allclose(np.diff(t), 1 / FS)
    wf = {"wf_increment": 1 / FS, "wf_start_offset": 0.0, "unit_string": "m/s^2"}
    _write_tdms(path, None, cols, properties={c: wf for c in cols})


def _write_uff(path, t, cols):
    write_uff(path, T if t is None else t, cols)


FORMATS = {
    "csv": (".csv", _write_csv),
    "mat5-row": (".mat", _write_mat("5", "row")),
    "mat5-col": (".mat", _write_mat("5", "col")),
    "mat4": (".mat", _write_mat("4", "col")),
    "mat73": (".mat", _write_mat73),
    "tdms": (".tdms", _write_tdms),
    "tdms-waveform": (".tdms", _write_tdms_waveform),
    "uff": (".uff", _write_uff),
}
OWN_TIME = ("csv", "mat5-row", "mat5-col", "mat4", "mat73", "tdms")  # an explicit time column


def _set_of(tmp_path, kind, cols=COLS, t=T):
    """The CSV reference set, its run file replaced by one of type ``kind`` holding ``cols``."""
    manifest = _csv_set(tmp_path)
    suffix, write = FORMATS[kind]
    write(tmp_path / f"run{suffix}", t, cols)
    _use(manifest, f"run{suffix}")
    return manifest


@pytest.mark.parametrize("kind", list(FORMATS))
def test_each_format_reads_as_its_csv(tmp_path, kind):
    ref = read_dataset(_csv_set(tmp_path / "ref"))
    ds = read_dataset(_set_of(tmp_path / kind, kind))
    a, b = ds.runs[0], ref.runs[0]
    assert ds.sample_rate == ref.sample_rate == FS and a.reason == b.reason == ""
    assert a.file.startswith("run.") and a.level_g == b.level_g
    np.testing.assert_allclose(a.time, b.time, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.data, b.data, rtol=0, atol=1e-9)  # CSV keeps 10 digits
    np.testing.assert_allclose(a.base, b.base, rtol=0, atol=1e-9)
    assert a.data.dtype == a.time.dtype == np.float64 and a.data.shape == (2, T.size)


# ------------------------------------------------------------------------------------------------
# the validation of read_dataset applies to every file type
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", list(FORMATS))
def test_nonfinite_samples_reject_the_run_in_every_format(tmp_path, kind):
    cols = dict(COLS, a2=COLS["a2"].copy())
    cols["a2"][10:13] = np.nan if kind != "uff" else 12345.0
    manifest = _set_of(tmp_path, kind, cols=cols)
    if kind == "uff":  # write_uff (pyuff) writes NaN as 0: put NaN in the text of the record
        f = tmp_path / "run.uff"
        f.write_text(f.read_text().replace("1.23450000000e+04", "nan".rjust(17)))
    ds = read_dataset(manifest)
    reason = ds.runs[0].reason
    assert "non-finite" in reason and "'a2'" in reason and "3 samples" in reason
    assert "t = 0.05 s" in reason


@pytest.mark.parametrize("kind", list(FORMATS))
def test_sample_rate_disagreement_in_every_format(tmp_path, kind):
    manifest = _set_of(tmp_path, kind)
    _edit_manifest(manifest, lambda m: m.update(sample_rate=100.0))
    with pytest.raises(DatasetError, match=r"run\.\w+: column 'time' implies 200 Hz but the "):
        read_dataset(manifest)


@pytest.mark.parametrize("kind", OWN_TIME)
def test_time_column_checks_in_every_format(tmp_path, kind):
    t = T.copy()
    t[[5, 6]] = t[[6, 5]]
    with pytest.raises(DatasetError, match=r"run\.\w+: column 'time' must increase strictly; "
                                           r"data rows 6-7 go 0.03 -> 0.025 s"):
        read_dataset(_set_of(tmp_path / "swap", kind, t=t))
    t = T.copy()
    t[200:] += 0.5 / FS
    with pytest.raises(DatasetError, match=r"run\.\w+: column 'time' is not uniformly sampled"):
        read_dataset(_set_of(tmp_path / "gap", kind, t=t))
    with pytest.raises(DatasetError, match=r"run\.\w+: 10 samples; a sweep run needs many more"):
        read_dataset(_set_of(tmp_path / "short", kind, t=T[:10],
                             cols={c: x[:10] for c, x in COLS.items()}))


# ------------------------------------------------------------------------------------------------
# the registry
# ------------------------------------------------------------------------------------------------


def test_unknown_suffix_names_the_file_and_lists_the_valid_ones(tmp_path):
    manifest = _csv_set(tmp_path)
    (tmp_path / "r0.csv").rename(tmp_path / "r0.txt")
    _use(manifest, "r0.txt")
    valid = r"\['.csv', '.csv.gz', '.uff', '.unv', '.mat', '.tdms'\]"
    with pytest.raises(DatasetError, match=r"r0\.txt: unknown run-file type; the file name must "
                                           r"end in one of " + valid):
        read_dataset(manifest)
    assert sorted(READERS) == sorted([".csv", ".csv.gz", ".uff", ".unv", ".mat", ".tdms"])
    # the longest suffix wins and case does not matter
    assert reader_for("a/b.CSV.GZ") is READERS[".csv.gz"] and reader_for("x.Mat") is READERS[".mat"]
    with pytest.raises(DatasetError, match="x.gz: unknown run-file type"):
        reader_for("x.gz")


def test_write_dataset_writes_csv_only(tmp_path):
    run = Run(file="r0.mat", time=T, data=COLS["a1"][None])
    with pytest.raises(DatasetError, match=r"`runs\[0\].file` must end in one of \['.csv', "):
        write_dataset(tmp_path, name="m", quantity="acceleration", units="g", sample_rate=FS,
                      channels={"a1": "x"}, runs=[run])


def test_read_run_checks_the_readers_contract(tmp_path, monkeypatch):
    _write_csv(tmp_path / "r.csv", T, COLS)
    cols = read_run(tmp_path / "r.csv", ["a2", "time"]).columns
    assert list(cols) == ["time", "a2"] and cols["a2"].dtype == np.float64

    def bad_reader(path, columns, layouts=None):
        return RunFile(columns={"time": T, **{c: COLS[c][:-1] for c in columns}})

    monkeypatch.setitem(READERS, ".csv", bad_reader)
    with pytest.raises(DatasetError, match=r"column 'a1' has 399 samples but 'time' has 400"):
        read_run(tmp_path / "r.csv", ["a1"])
    monkeypatch.setitem(READERS, ".csv", lambda path, columns, layouts=None: {"time": T})
    with pytest.raises(DatasetError, match=r"r.csv: the reader returned a dict, not a RunFile"):
        read_run(tmp_path / "r.csv", ["a1"])


# ------------------------------------------------------------------------------------------------
# MATLAB errors
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "variables, pattern",
    [
        ({"a2": None}, r"run.mat: variable\(s\) \['a2'\] not found; the file has \["),
        ({"time": None}, r"run.mat: variable\(s\) \['time'\] not found"),
        ({"a1": np.ones((2, 400))},
         r"run.mat: variable 'a1' must be a vector \(1xN or Nx1\), got shape \(2, 400\)"),
        ({"ab": np.zeros((1, 400), dtype=complex)}, r"run.mat: variable 'ab' is complex"),
        ({"a1": "a string"}, r"run.mat: variable 'a1' must be numeric, got MATLAB char"),
        ({"a1": np.ones((1, 400), dtype=bool)},
         r"run.mat: variable 'a1' must be numeric, got MATLAB logical"),
        ({"a1": {"x": np.ones(400)}}, r"run.mat: variable 'a1' must be numeric, got MATLAB struct"),
        ({"a2": np.ones((1, 399))}, r"run.mat: column 'a2' has 399 samples but 'time' has 400"),
        ({"a1": np.zeros((0, 0))}, r"run.mat: variable 'a1' must be a vector"),
    ],
)
def test_mat_errors_name_file_and_variable(tmp_path, variables, pattern):
    manifest = _csv_set(tmp_path)
    out = {"time": T[None], **{c: x[None] for c, x in COLS.items()}}
    for k, v in variables.items():
        if v is None:
            del out[k]
        else:
            out[k] = v
    scipy.io.savemat(tmp_path / "run.mat", out)
    _use(manifest, "run.mat")
    with pytest.raises(DatasetError, match=pattern):
        read_dataset(manifest)


def test_mat_not_a_mat_file(tmp_path):
    manifest = _csv_set(tmp_path)
    (tmp_path / "run.mat").write_bytes(b"\x01\x02" * 100)
    _use(manifest, "run.mat")
    with pytest.raises(DatasetError, match=r"run.mat: not a readable MAT file"):
        read_dataset(manifest)


def test_mat73_errors_and_without_h5py(tmp_path, monkeypatch):
    manifest = _set_of(tmp_path, "mat73", cols={"a1": COLS["a1"], "ab": COLS["ab"]})
    with pytest.raises(DatasetError, match=r"run.mat: variable\(s\) \['a2'\] not found; the file "
                                           r"has \['a1', 'ab', 'time'\]"):
        read_dataset(manifest)
    _write_mat73(tmp_path / "run.mat", T, COLS, complex_=("a2",))
    with pytest.raises(DatasetError, match=r"run.mat: variable 'a2' is complex"):
        read_dataset(manifest)
    monkeypatch.setitem(__import__("sys").modules, "h5py", None)  # as if not installed
    with pytest.raises(DatasetError, match=r"run.mat: a MATLAB v7.3 \(HDF5\) file; reading it "
                                           r"needs h5py"):
        read_dataset(manifest)


# ------------------------------------------------------------------------------------------------
# TDMS
# ------------------------------------------------------------------------------------------------


def test_tdms_channels_in_any_group_and_timestamp_time(tmp_path):
    groups = {"a1": "left", "a2": "right", "ab": "control"}
    manifest = _csv_set(tmp_path)
    start = np.datetime64("2026-05-04T10:00:00", "ns")
    stamps = start + (T * 1e9).round().astype("timedelta64[ns]")
    _write_tdms(tmp_path / "run.tdms", stamps, COLS, groups=groups)
    _use(manifest, "run.tdms")
    run = read_dataset(manifest).runs[0]
    np.testing.assert_allclose(run.time, T, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(run.data, np.vstack([COLS["a1"], COLS["a2"]]))


def test_tdms_waveform_time_offset(tmp_path):
    manifest = _csv_set(tmp_path)
    wf = {"wf_increment": 1 / FS, "wf_start_offset": 2.5}
    _write_tdms(tmp_path / "run.tdms", None, COLS, properties={c: wf for c in COLS})
    _use(manifest, "run.tdms")
    np.testing.assert_allclose(read_dataset(manifest).runs[0].time, 2.5 + T, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        (dict(cols={"a1": COLS["a1"], "ab": COLS["ab"]}),
         r"run.tdms: channel\(s\) \['a2'\] not found; the file has \(group/channel\) "
         r"\['acc/a1', 'acc/ab', 'meta/time'\]"),
        (dict(extra=("other", "a2")),
         r"run.tdms: channel 'a2' is in several groups \['acc', 'other'\]"),
        (dict(extra=("other", "time")),
         r"run.tdms: channel 'time' is in several groups \['meta', 'other'\]"),
        (dict(t=None), r"run.tdms: no 'time' channel, and channel 'a1' has no waveform timing"),
        (dict(t=None, properties={"a1": {"wf_increment": 1 / FS}, "a2": {"wf_increment": 2 / FS},
                                  "ab": {"wf_increment": 1 / FS}}),
         r"run.tdms: no 'time' channel, and channel 'a2' has waveform timing"),
        (dict(cols=dict(COLS, a1=COLS["a1"] + 1j)), r"run.tdms: channel 'a1' is complex"),
        (dict(cols=dict(COLS, ab=np.array(["x"] * 400))),
         r"run.tdms: channel 'ab' must be numeric, got dtype"),
    ],
)
def test_tdms_errors_name_file_and_channel(tmp_path, kwargs, pattern):
    manifest = _csv_set(tmp_path)
    t = kwargs.pop("t", T)
    _write_tdms(tmp_path / "run.tdms", t, kwargs.pop("cols", COLS), **kwargs)
    _use(manifest, "run.tdms")
    with pytest.raises(DatasetError, match=pattern):
        read_dataset(manifest)


def test_tdms_not_a_tdms_file(tmp_path):
    manifest = _csv_set(tmp_path)
    (tmp_path / "run.tdms").write_bytes(b"not a tdms file" * 10)
    _use(manifest, "run.tdms")
    with pytest.raises(DatasetError, match=r"run.tdms: not a readable TDMS file"):
        read_dataset(manifest)

"""Run files as controllers export them: the MATLAB matrix layout (v5 and v7.3), read as the same
run written as plain CSV. The files are written here with scipy.io / h5py as MATLAB lays them
out, not by the code under test."""

import numpy as np
import pytest
import scipy.io
import yaml

from freeplayid.io import DatasetError, Run, read_dataset, write_dataset
from freeplayid.model import two_dof_system

FS = 200.0  # [Hz]
T = np.arange(400) / FS  # [s]
COLS = {"a1": np.sin(2 * np.pi * 20 * T), "a2": 0.5 * np.cos(2 * np.pi * 20 * T),
        "ab": 0.1 * np.sin(2 * np.pi * 20 * T + 0.3)}
# the controller's channel order differs from the manifest's, and it records one channel more
NAMES = ["ab", "a2", "spare", "a1"]
MATRIX = np.column_stack([COLS["ab"], COLS["a2"], np.zeros_like(T), COLS["a1"]])  # (T, C)
UNITS = ["m/s^2", "m/s^2", "V", "m/s^2"]


def _csv_set(folder, units="m/s^2"):
    run = Run(file="r0.csv", time=T, data=np.vstack([COLS["a1"], COLS["a2"]]), level_g=0.5,
              base=COLS["ab"])
    return write_dataset(folder, name="m", quantity="acceleration", units=units,
                         sample_rate=FS, channels={"a1": "uz_in", "a2": "uz_out"}, runs=[run],
                         system=two_dof_system(), base_channel="ab")


def _edit_manifest(manifest, fn):
    m = yaml.safe_load(manifest.read_text())
    fn(m)
    manifest.write_text(yaml.safe_dump(m, sort_keys=False))


def _use(manifest, name, **blocks):
    _edit_manifest(manifest, lambda m: (m["runs"][0].update(file=name), m.update(blocks)))


def _assert_same_run(ds, ref):
    a, b = ds.runs[0], ref.runs[0]
    assert a.reason == b.reason == "" and ds.sample_rate == ref.sample_rate == FS
    np.testing.assert_allclose(a.time, b.time, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.data, b.data, rtol=0, atol=1e-9)  # CSV keeps 10 digits
    np.testing.assert_allclose(a.base, b.base, rtol=0, atol=1e-9)


# ------------------------------------------------------------------------------------------------
# MATLAB files as MATLAB writes them
# ------------------------------------------------------------------------------------------------


def _cell(strings):
    """A 1xC MATLAB cell array of char rows, as scipy.io.savemat writes one."""
    out = np.empty((1, len(strings)), dtype=object)
    out[0, :] = [np.array([s]) for s in strings]
    return out


def _mat5(path, names=None, **variables):
    names = names or {}
    default = {"TimeData": MATRIX, "ChanName": _cell(NAMES), "Unit": _cell(UNITS),
               "hDelta": 1 / FS, "Comment": "exported by a controller"}
    out = {names.get(k, k): v for k, v in default.items()}
    out.update({k: v for k, v in variables.items() if v is not None})
    for k in [k for k, v in variables.items() if v is None]:
        out.pop(names.get(k, k))
    scipy.io.savemat(path, out, format="5")


def _h5_chars(group, name, text):
    """A MATLAB char row 1xL: uint16 code units, stored (L, 1) (column-major)."""
    import h5py  # noqa: F401

    d = group.create_dataset(name, data=np.array([ord(c) for c in text] or [0],
                                                 dtype=np.uint16)[:, None])
    d.attrs["MATLAB_class"] = np.bytes_("char")
    d.attrs["MATLAB_int_decode"] = np.int32(2)
    return d


def _h5_cell(f, name, strings):
    """A 1xC cell array: object references into '#refs#', stored (C, 1)."""
    import h5py

    refs = f.require_group("#refs#")
    items = [_h5_chars(refs, f"{name}{k}", s).ref for k, s in enumerate(strings)]
    d = f.create_dataset(name, data=np.array(items, dtype=h5py.ref_dtype)[:, None])
    d.attrs["MATLAB_class"] = np.bytes_("cell")


def _h5_double(f, name, value):
    """A MATLAB double array, stored transposed (column-major)."""
    d = f.create_dataset(name, data=np.atleast_2d(np.asarray(value, dtype=float)).T)
    d.attrs["MATLAB_class"] = np.bytes_("double")


def _mat73(path, *, char_matrix_names=False, matrix=MATRIX):
    h5py = pytest.importorskip("h5py")
    with h5py.File(path, "w", userblock_size=512) as f:
        _h5_double(f, "TimeData", matrix)
        if char_matrix_names:  # a C-row char matrix, padded with blanks: stored (L, C)
            width = max(map(len, NAMES))
            codes = np.array([[ord(c) for c in s.ljust(width)] for s in NAMES], dtype=np.uint16)
            d = f.create_dataset("ChanName", data=codes.T)
            d.attrs["MATLAB_class"] = np.bytes_("char")
        else:
            _h5_cell(f, "ChanName", NAMES)
        _h5_cell(f, "Unit", UNITS)
        _h5_double(f, "hDelta", 1 / FS)
    text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created by: freeplayid tests HDF5 schema 1.00"
    with open(path, "r+b") as fh:
        fh.write(text.ljust(116) + bytes(8) + b"\x00\x02IM")


@pytest.mark.parametrize("variant", ["v5", "v5-transposed", "v5-char-names", "v73",
                                     "v73-transposed", "v73-char-names"])
def test_mat_matrix_layout_reads_as_its_csv(tmp_path, variant):
    ref = read_dataset(_csv_set(tmp_path / "ref"))
    manifest = _csv_set(tmp_path / variant)
    f = tmp_path / variant / "run.mat"
    if variant == "v5":
        _mat5(f)
    elif variant == "v5-transposed":  # channels x time
        _mat5(f, TimeData=MATRIX.T)
    elif variant == "v5-char-names":  # a char matrix instead of a cell array
        _mat5(f, ChanName=np.array(NAMES), Unit=np.array(UNITS))
    else:
        _mat73(f, char_matrix_names="char" in variant,
               matrix=MATRIX.T if "transposed" in variant else MATRIX)
    _use(manifest, "run.mat")
    _assert_same_run(read_dataset(manifest), ref)


def test_mat_variable_names_declared_in_the_manifest(tmp_path):
    ref = read_dataset(_csv_set(tmp_path / "ref"))
    manifest = _csv_set(tmp_path / "set")
    names = {"TimeData": "Y", "ChanName": "Labels", "Unit": "EU", "hDelta": "dt"}
    _mat5(tmp_path / "set" / "run.mat", names=names)
    _use(manifest, "run.mat", mat={"data": "Y", "names": "Labels", "units": "EU",
                                   "increment": "dt"})
    _assert_same_run(read_dataset(manifest), ref)
    # without the block the defaults do not fit: the message lists what the file has
    _edit_manifest(manifest, lambda m: m.pop("mat"))
    with pytest.raises(DatasetError, match=r"run.mat: variable\(s\) \['time', 'a1', 'a2', 'ab'\] "
                                           r"not found; the file has \['Y', 'Labels', 'EU', 'dt', "
                                           r"'Comment'\] \(a MAT run holds one vector per column"):
        read_dataset(manifest)


@pytest.mark.parametrize(
    "variables, pattern",
    [
        ({"hDelta": None}, r"run.mat: matrix 'TimeData' found but not the variable\(s\) "
                           r"\['hDelta'\] \(the channel names `mat.names` and the sample interval"),
        ({"TimeData": MATRIX[:, :3]}, r"run.mat: variable 'TimeData' has shape \(400, 3\) but "
                                      r"'ChanName' has 4 names; one axis of the matrix"),
        ({"ChanName": _cell(["ab", "a2", "spare", "a9"])},
         r"run.mat: channel\(s\) \['a1'\] not in 'ChanName'; it names \['ab', 'a2', 'spare', "
         r"'a9'\]"),
        ({"ChanName": _cell(["ab", "a2", "a1", "a1"])},
         r"run.mat: channel name\(s\) \['a1'\] occur more than once in 'ChanName'"),
        ({"ChanName": np.ones((1, 4))},
         r"run.mat: variable 'ChanName' must be a cell array of strings or a char matrix, got "
         r"MATLAB double"),
        ({"Unit": _cell(["g", "g"])}, r"run.mat: variable 'Unit' has 2 units but 'ChanName' has 4"),
        ({"hDelta": -0.005}, r"run.mat: variable 'hDelta' \(the sample interval \[s\]\) must be "
                             r"one number > 0, got \[-0.005\]"),
        ({"hDelta": np.array([0.005, 0.005])}, r"variable 'hDelta' .* must be one number > 0"),
        ({"TimeData": np.ones((4, 4)), "ChanName": _cell(["a1", "a2", "ab", "x"])},
         r"run.mat: variable 'TimeData' has shape \(4, 4\) and 'ChanName' 4 names: which axis"),
        ({"TimeData": "text"}, r"run.mat: variable 'TimeData' must be numeric, got MATLAB char"),
    ],
)
def test_mat_matrix_layout_errors_name_file_and_variable(tmp_path, variables, pattern):
    manifest = _csv_set(tmp_path)
    _mat5(tmp_path / "run.mat", **variables)
    _use(manifest, "run.mat")
    with pytest.raises(DatasetError, match=pattern):
        read_dataset(manifest)


@pytest.mark.parametrize(
    "block, pattern",
    [
        ({"matrix": "Y"}, r"`mat`: unknown field\(s\) \['matrix'\]; allowed: \['data', 'names', "
                          r"'units', 'increment'\]"),
        ({"data": "2Y"}, r"`mat`: `data` must be a MATLAB variable name \(a letter, then letters, "
                         r"digits or _\), got '2Y'"),
        ("TimeData", r"`mat` must be a mapping of \(some of\) \['data', 'names', 'units', "
                     r"'increment'\], got 'TimeData'"),
    ],
)
def test_mat_block_errors_name_the_field(tmp_path, block, pattern):
    manifest = _csv_set(tmp_path)
    _edit_manifest(manifest, lambda m: m.update(mat=block))
    with pytest.raises(DatasetError, match=r"manifest.yaml: " + pattern):
        read_dataset(manifest)


# ------------------------------------------------------------------------------------------------
# UFF 58 / 58b: channels by node and direction; the fix_58b retry
# ------------------------------------------------------------------------------------------------

# the records as a controller names them: one ID line for all, told apart by node and direction
UFF_RECORDS = [("a1", 101, 3), ("a2", 102, -3), ("ab", 1, 3)]


def _uff(path, *, binary=False, records=UFF_RECORDS, units="m/s^2"):
    """Dataset-58 records written with pyuff itself, every ID line 1 "Time Response"."""
    import pyuff

    path.unlink(missing_ok=True)  # pyuff adds to an existing file
    f = pyuff.UFF(str(path))
    for col, node, direction in records:
        f.write_sets(pyuff.prepare_58(
            binary=int(binary), id1="Time Response", id2="ctrl", id3="", id4="", id5="",
            func_type=1, rsp_node=node, rsp_dir=direction, ref_node=0, ref_dir=0,
            data=COLS[col], x=T, abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=1 / FS,
            abscissa_spec_data_type=17, ordinate_spec_data_type=12, orddenom_spec_data_type=0,
            z_axis_spec_data_type=0, ver_num=0, load_case_id=0, rsp_ent_name="fin",
            ref_ent_name="none", abscissa_axis_units_lab="s", ordinate_axis_units_lab=units),
            mode="add")


def _uff_set(folder, manifest_channels):
    """The CSV reference set, its run replaced by ``run.uff``; the manifest written by hand so
    that NODE:DIR keys stay unquoted, as a user types them."""
    manifest = _csv_set(folder)
    _use(manifest, "run.uff")
    text = "\n".join(ln for ln in manifest.read_text().splitlines()
                     if not ln.startswith("base_channel")) + "\n"
    start, end = text.index("channels:"), text.index("runs:")
    manifest.write_text(text[:start] + manifest_channels + text[end:])
    return manifest


NODE_DIR_CHANNELS = "channels:\n  101:+Z: uz_in\n  102:-3: uz_out\nbase_channel: 1:3\n"


@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("channels", [
    NODE_DIR_CHANNELS,
    "channels:\n  101:3: uz_in\n  102:-Z: uz_out\nbase_channel: 1:+z\n",
    "channels:\n  '101:+Z': uz_in\n  \"102:-Z\": uz_out\nbase_channel: '1:Z'\n",
])
def test_uff_channels_by_node_and_direction(tmp_path, binary, channels):
    ref = read_dataset(_csv_set(tmp_path / "ref"))
    manifest = _uff_set(tmp_path / "set", channels)
    _uff(tmp_path / "set" / "run.uff", binary=binary)
    ds = read_dataset(manifest)
    assert list(ds.channels.values()) == ["uz_in", "uz_out"]
    _assert_same_run(ds, ref)


def test_uff_node_direction_errors(tmp_path):
    # the sign is the record's: 102 is a -Z record, not +Z
    manifest = _uff_set(tmp_path, NODE_DIR_CHANNELS.replace("102:-3", "102:+3"))
    _uff(tmp_path / "run.uff")
    with pytest.raises(DatasetError, match=(
            r"run.uff: channel\(s\) \['102:\+3'\] not found; its dataset-58 records are \(ID line "
            r"1 \(node:direction\)\) \['Time Response \(101:\+Z\)', 'Time Response \(102:-Z\)', "
            r"'Time Response \(1:\+Z\)'\]; a column names a record by its ID line 1 or as "
            r"NODE:DIR")):
        read_dataset(manifest)
    # the name every record has is ambiguous; so is a node:direction two records share
    manifest = _uff_set(tmp_path, "channels:\n  Time Response: uz_in\n  102:-3: uz_out\n")
    with pytest.raises(DatasetError, match=r"run.uff: 3 records match 'Time Response' by ID "):
        read_dataset(manifest)
    manifest = _uff_set(tmp_path, NODE_DIR_CHANNELS)
    _uff(tmp_path / "run.uff", records=[*UFF_RECORDS, ("a1", 102, -3)])
    with pytest.raises(DatasetError, match=r"run.uff: 2 records match '102:-3' by node:direction "
                                           r"\(ID lines \['Time Response', 'Time Response'\], at "
                                           r"\['102:-Z', '102:-Z'\]\); name one record"):
        read_dataset(manifest)


def _misplace_delimiters(path, before_delimiter):
    """Insert bytes between each binary record's data and its closing '    -1' line, as some
    exporters do (pyuff issue #61)."""
    raw = path.read_bytes()
    out, start = b"", 0
    ends = [i for i in range(len(raw)) if raw.startswith(b"    -1\n", i)][1::2]  # closing ones
    for i in ends:
        out += raw[start:i] + before_delimiter
        start = i
    path.write_bytes(out + raw[start:])


def test_uff_58b_retried_with_fix_58b(tmp_path):
    ref = read_dataset(_csv_set(tmp_path / "ref"))
    manifest = _uff_set(tmp_path / "set", NODE_DIR_CHANNELS)
    f = tmp_path / "set" / "run.uff"
    _uff(f, binary=True)
    # the closing -1 on its own line, right-aligned in a 12-wide field: pyuff alone reads the
    # blanks as one more sample (401 values for 400); fix_58b moves the delimiter back
    _misplace_delimiters(f, b"\n" + b" " * 8)
    broken = f.read_bytes()
    _assert_same_run(read_dataset(manifest), ref)
    assert f.read_bytes() == broken  # repaired on a copy; nothing written beside the file
    assert sorted(p.name for p in f.parent.iterdir()) == ["manifest.yaml", "model.npz", "r0.csv",
                                                          "run.uff"]


def test_uff_58b_unreadable_after_fix_58b_says_what_to_try(tmp_path):
    manifest = _uff_set(tmp_path, NODE_DIR_CHANNELS)
    _uff(tmp_path / "run.uff", binary=True)
    _misplace_delimiters(tmp_path / "run.uff", b"\n" * 9)  # nine line feeds: beyond repair
    with pytest.raises(DatasetError) as info:
        read_dataset(manifest)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith(str(tmp_path / "run.uff") + ": binary UFF 58b record(s) unreadable "
                          "(record 'Time Response' holds 401 values but its header says 400), "
                          "also after pyuff's fix_58b repair; export the run again as ASCII UFF "
                          "58 (or as CSV or MAT), or check that the file is complete")


def test_uff_ascii_unreadable(tmp_path):
    manifest = _uff_set(tmp_path, NODE_DIR_CHANNELS)
    _uff(tmp_path / "run.uff")
    text = (tmp_path / "run.uff").read_text().splitlines()
    (tmp_path / "run.uff").write_text("\n".join(text[:20]) + "\n    -1\n")  # cut in record 1
    with pytest.raises(DatasetError, match=r"run.uff: (not a readable UFF file|record)"):
        read_dataset(manifest)


# ------------------------------------------------------------------------------------------------
# CSV with a declared delimiter, decimal comma, units row and preamble
# ------------------------------------------------------------------------------------------------


def _csv_text(delimiter, decimal, *, units=None, preamble=(), quote=False, eol="\n",
              trailing=""):
    """The reference run as a controller's CSV, formatted here character by character."""
    names = ["time", "ab", "a2", "a1"]  # another column order than the manifest's
    q = '"' if quote else ""
    lines = [*preamble, delimiter.join(f"{q}{n}{q}" for n in names) + trailing]
    if units is not None:
        lines.append(delimiter.join(units) + trailing)
    for k in range(T.size):
        row = [f"{T[k]:.6f}"] + [f"{COLS[c][k]:.12e}" for c in names[1:]]
        lines.append(delimiter.join(v.replace(".", decimal) for v in row) + trailing)
    return eol.join(lines) + eol


@pytest.mark.parametrize("case", ["semicolon-comma", "tab", "gz", "plain"])
def test_csv_layout_reads_as_plain_csv(tmp_path, case):
    ref = read_dataset(_csv_set(tmp_path / "ref"))
    manifest = _csv_set(tmp_path / case)
    name = "run.csv"
    if case == "semicolon-comma":  # a German-locale export: preamble, quotes, CRLF, trailing ;
        text = _csv_text(";", ",", units=["[s]", "[m/s^2]", "[m/s^2]", "[m/s^2]"],
                         preamble=["Controller export;v2.1", "Test;fin A, 0,5 g"], quote=True,
                         eol="\r\n", trailing=";")
        block = {"delimiter": ";", "decimal": ",", "units_row": True, "skip_rows": 2}
    elif case == "tab":
        text = _csv_text("\t", ".", units=["s", "m/s^2", "", "(m/s^2)"])
        block = {"delimiter": "tab", "units_row": True}
    elif case == "gz":
        text, block, name = _csv_text(";", ","), {"delimiter": ";", "decimal": ","}, "run.csv.gz"
    else:
        text, block = _csv_text(",", "."), None
    f = tmp_path / case / name
    if name.endswith(".gz"):
        import gzip

        f.write_bytes(gzip.compress(text.encode("latin-1")))
    else:
        f.write_bytes(text.encode("latin-1"))
    _use(manifest, name, **({"csv": block} if block else {}))
    _assert_same_run(read_dataset(manifest), ref)


def test_csv_undeclared_layouts_are_named(tmp_path):
    manifest = _csv_set(tmp_path)
    (tmp_path / "run.csv").write_text(_csv_text(";", ","))
    _use(manifest, "run.csv")
    with pytest.raises(DatasetError, match=r"run.csv: column\(s\) \['time', 'a1', 'a2', 'ab'\] not "
                                           r"in the header; the header has \['time;ab;a2;a1'\] .*; "
                                           r"the header looks ';'-delimited: declare it in the "
                                           r"manifest \(csv: \{delimiter: ';'\}\)"):
        read_dataset(manifest)
    (tmp_path / "run.csv").write_text(_csv_text(",", ".", units=["s", "g", "g", "g"]))
    with pytest.raises(DatasetError, match=r"run.csv: non-numeric value \(could not convert "
                                           r"string 's' to float64 at row 0, column 1.\); .* \(a "
                                           r"units row below the header\? declare it: csv: "
                                           r"\{units_row: true\}\)"):
        read_dataset(manifest)


@pytest.mark.parametrize(
    "block, pattern",
    [
        ({"delimiter": ":"},
         r"`csv`: `delimiter` must be one of \[',', ';', 'tab', '\|'\], got ':'"),
        ({"decimal": ","}, r"`csv`: `decimal` ',' cannot be the `delimiter` too; a decimal comma "
                           r"needs another delimiter \(';' or tab\)"),
        ({"delimiter": ";", "decimal": "'"}, r"`csv`: `decimal` must be one of \['.', ','\]"),
        ({"units_row": "yes"}, r"`csv`: `units_row` must be true or false, got 'yes'"),
        ({"skip_rows": -1}, r"`csv`: `skip_rows` must be an integer >= 0, got -1"),
        ({"sep": ";"}, r"`csv`: unknown field\(s\) \['sep'\]; allowed: \['delimiter', 'decimal', "
                       r"'units_row', 'skip_rows'\]"),
    ],
)
def test_csv_block_errors_name_the_field(tmp_path, block, pattern):
    manifest = _csv_set(tmp_path)
    _edit_manifest(manifest, lambda m: m.update(csv=block))
    with pytest.raises(DatasetError, match=r"manifest.yaml: " + pattern):
        read_dataset(manifest)


def test_csv_declared_rows_beyond_the_file(tmp_path):
    manifest = _csv_set(tmp_path)
    (tmp_path / "run.csv").write_text("time,a1,a2,ab\n")
    _use(manifest, "run.csv", csv={"units_row": True, "skip_rows": 3})
    with pytest.raises(DatasetError, match=r"run.csv: 1 line\(s\), fewer than the header rows the "
                                           r"manifest's `csv:` layout declares \(5\)"):
        read_dataset(manifest)


# ------------------------------------------------------------------------------------------------
# the files' own unit fields, checked against the manifest's quantity and units
# ------------------------------------------------------------------------------------------------


def _tdms(path, units):
    from nptdms import ChannelObject, TdmsWriter

    with TdmsWriter(str(path)) as w:
        w.write_segment([ChannelObject("acc", c, COLS[c], properties={
            "wf_increment": 1 / FS, "wf_start_offset": 0.0, "wf_xunit_string": "s",
            **({"unit_string": units[c]} if units.get(c) is not None else {})}) for c in COLS])


def _write_with_units(folder, kind, units):
    """``run.<suffix>`` of the reference run whose unit fields say ``units`` (column -> unit)."""
    if kind == "csv":
        row = [units.get(c, "") for c in ("time", "ab", "a2", "a1")]
        (folder / "run.csv").write_text(_csv_text(";", ",", units=row))
        return "run.csv", {"csv": {"delimiter": ";", "decimal": ",", "units_row": True}}
    if kind == "mat":
        _mat5(folder / "run.mat", Unit=_cell([units.get(c, "") for c in NAMES]))
        return "run.mat", {}
    if kind == "tdms":
        _tdms(folder / "run.tdms", units)
        return "run.tdms", {}
    import pyuff

    f = folder / "run.uff"
    f.unlink(missing_ok=True)
    uff = pyuff.UFF(str(f))
    for k, c in enumerate(COLS):
        uff.write_sets(pyuff.prepare_58(
            binary=0, id1=c, func_type=1, rsp_node=k + 1, rsp_dir=3, ref_node=0, ref_dir=0,
            data=COLS[c], x=T, abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=1 / FS,
            abscissa_spec_data_type=17, ordinate_spec_data_type=12, orddenom_spec_data_type=0,
            z_axis_spec_data_type=0, id2="", id3="", id4="", id5="", ver_num=0, load_case_id=0,
            rsp_ent_name="fin", ref_ent_name="none",
            abscissa_axis_units_lab=units.get("time") or "NONE",
            ordinate_axis_units_lab=units.get(c) or "NONE"), mode="add")
    return "run.uff", {}


KINDS = ["csv", "mat", "tdms", "uff"]


@pytest.mark.parametrize("kind", KINDS)
def test_unit_fields_that_agree_are_accepted(tmp_path, kind):
    ref = read_dataset(_csv_set(tmp_path / "ref"))
    manifest = _csv_set(tmp_path / kind)
    # other spellings of m/s^2, a unit that is not checked (V) and an absent one
    name, blocks = _write_with_units(tmp_path / kind, kind, {"a1": "m/s2", "a2": "V",
                                                             "ab": "m/s²", "time": "s"})
    _use(manifest, name, **blocks)
    _assert_same_run(read_dataset(manifest), ref)


@pytest.mark.parametrize("kind", KINDS)
def test_unit_field_against_the_manifest(tmp_path, kind):
    """The issue's case: acceleration declared in g, the file says m/s^2 (or the reverse)."""
    manifest = _csv_set(tmp_path, units="g")
    name, blocks = _write_with_units(tmp_path, kind, {"a1": "m/s^2", "a2": "m/s^2"})
    _use(manifest, name, **blocks)
    with pytest.raises(DatasetError) as info:
        read_dataset(manifest)
    msg = str(info.value)
    assert msg == (f"{tmp_path / name}: channel 'a1': the file says 'm/s^2', the manifest says "
                   "'g' (acceleration); if the file is right, set `units: m/s^2` in the manifest")


@pytest.mark.parametrize(
    "units, manifest_units, pattern",
    [
        ({"a2": "mm/s"}, "m/s^2", r"channel 'a2': the file says 'mm/s', the manifest says "
                                  r"'m/s\^2' \(acceleration\); a data set's velocity is in one of "
                                  r"\('m/s',\): export the data in one of those"),
        ({"ab": "G"}, "m/s^2", r"channel 'ab': the file says 'G', the manifest says 'm/s\^2' "
                               r"\(acceleration\); if the file is right, set `units: g`"),
        ({"a1": "mm/s^2"}, "m/s^2", r"channel 'a1': the file says 'mm/s\^2'"),
        ({"time": "ms"}, "m/s^2", r"run.csv: column 'time' is in 'ms' by the file's unit field; "
                                  r"the time must be in s \(seconds\)"),
    ],
)
def test_unit_mismatches_name_file_channel_and_both_units(tmp_path, units, manifest_units,
                                                           pattern):
    manifest = _csv_set(tmp_path, units=manifest_units)
    name, blocks = _write_with_units(tmp_path, "csv", units)
    _use(manifest, name, **blocks)
    with pytest.raises(DatasetError, match=pattern):
        read_dataset(manifest)


def test_another_quantity_names_it(tmp_path):
    manifest = _csv_set(tmp_path)
    _edit_manifest(manifest, lambda m: m.update(quantity="velocity", units="m/s"))
    name, blocks = _write_with_units(tmp_path, "csv", {"a1": "g"})
    _use(manifest, name, **blocks)
    with pytest.raises(DatasetError, match=r"channel 'a1': the file says 'g', the manifest says "
                                           r"'m/s' \(velocity\); if the file is right, set "
                                           r"`units: g` and `quantity: acceleration`"):
        read_dataset(manifest)


def test_one_run_in_other_units_is_rejected_with_its_reason(tmp_path):
    """A unit mismatch is the run file's problem: that run is rejected, the others are read."""
    manifest = _csv_set(tmp_path)
    name, _ = _write_with_units(tmp_path, "mat", {"a1": "g"})
    _edit_manifest(manifest, lambda m: m["runs"].append({"file": name}))
    ds = read_dataset(manifest)
    assert ds.runs[0].reason == ""
    assert ds.runs[1].reason == (f"{tmp_path / name}: channel 'a1': the file says 'g', the "
                                 "manifest says 'm/s^2' (acceleration); if the file is right, "
                                 "set `units: g` in the manifest")


@pytest.mark.parametrize("text, quantity, factor", [
    ("m/s^2", "acceleration", 1.0), ("m/s2", "acceleration", 1.0), ("m s^-2", "acceleration", 1.0),
    ("m/sec²", "acceleration", 1.0), ("g", "acceleration", 9.80665), ("G", "acceleration", 9.80665),
    ("in/s^2", "acceleration", 0.0254), ("mm/s", "velocity", 1e-3), ("ips", "velocity", 0.0254),
    ("µm", "displacement", 1e-6), ("mil", "displacement", 2.54e-5), ("ms", "time", 1e-3),
])
def test_unit_spellings(text, quantity, factor):
    from freeplayid.io.units import parse_unit

    unit = parse_unit(text)
    assert unit.quantity == quantity and unit.si_factor == pytest.approx(factor, rel=1e-12)
    assert parse_unit("V") is None and parse_unit("NONE") is None and parse_unit("") is None

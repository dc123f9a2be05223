"""Data-set faults: a clear one-line error, or the faulty run rejected with its reason.

Every case builds its input from a small copy of the bundled example (examples/fin_sweeps cut to
its 0.8 g and 1.2 g runs) or from a hand-made file, and asserts the behaviour in-process through
``read_dataset`` / ``freeplayid.identify``; the representative ones also go through
``scripts/identify.py`` (one line on stderr, exit 1, no result file; or exit 0 with the run in
``rejected_runs`` and the rest identified).
"""

import gzip
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from freeplayid import identify
from freeplayid.identification import IdentificationError
from freeplayid.io import DatasetError, read_dataset

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "fin_sweeps"
RUNS = ("sweep_0.80g.csv.gz", "sweep_1.20g.csv.gz")  # the two resonating runs kept
HEADER = "time,acc_tl,acc_lr,acc_base"
HINT = {"start_hz": 30.0, "stop_hz": 46.5, "rate_hz_per_s": 0.1}  # the example's [Hz, Hz, Hz/s]


@pytest.fixture(scope="module")
def fin2(tmp_path_factory):
    """The example cut to its 0.8 g and 1.2 g runs, and the 0.8 g run's table (T, 4)."""
    folder = tmp_path_factory.mktemp("fin2")
    shutil.copy(EXAMPLE / "model.npz", folder)
    for name in RUNS:
        shutil.copy(EXAMPLE / name, folder)
    m = yaml.safe_load((EXAMPLE / "manifest.yaml").read_text())
    m["runs"] = [r for r in m["runs"] if r["file"] in RUNS]
    (folder / "manifest.yaml").write_text(yaml.safe_dump(m, sort_keys=False))
    table = np.loadtxt(folder / RUNS[0], delimiter=",", skiprows=1)
    return folder, table


def _copy(fin2, tmp_path) -> Path:
    folder = tmp_path / "data"
    shutil.copytree(fin2[0], folder)
    return folder


def _manifest(folder: Path, fn) -> None:
    m = yaml.safe_load((folder / "manifest.yaml").read_text())
    fn(m)
    (folder / "manifest.yaml").write_text(yaml.safe_dump(m, sort_keys=False))


def _write_run(path: Path, table: np.ndarray, header: str = HEADER) -> None:
    np.savetxt(path, table, delimiter=",", header=header, comments="", fmt="%.6g")


def _add_run(folder: Path, name: str, table, *, sweep="same", header=HEADER) -> None:
    """A further run (a faulty copy) appended to the manifest, with the example's hint."""
    _write_run(folder / name, table, header)

    def add(m):
        entry = {"file": name}
        if sweep == "same":
            entry["sweep"] = dict(HINT)
        elif sweep is not None:
            entry["sweep"] = sweep
        m["runs"].append(entry)

    _manifest(folder, add)


def _truncate_gz(path: Path) -> None:
    raw = path.read_bytes()
    path.write_bytes(raw[: len(raw) // 2])


# ------------------------------------------------------------------------------------------------
# faults of the data set as a whole: DatasetError, one line, naming the file and the field
# ------------------------------------------------------------------------------------------------


def _dup_units(folder, table):
    text = (folder / "manifest.yaml").read_text()
    (folder / "manifest.yaml").write_text(text.replace("units: g\n", "units: g\nunits: m/s^2\n"))
    return folder


def _dup_nested(folder, table):
    text = (folder / "manifest.yaml").read_text()
    (folder / "manifest.yaml").write_text(
        text.replace("    rate_hz_per_s: 0.1\n", "    rate_hz_per_s: 0.1\n    rate_hz_per_s: 1\n",
                     1))
    return folder


def _binary_manifest(folder, table):
    (folder / "manifest.yaml").write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe" + bytes(range(256)))
    return folder


def _csv_given(folder, table):
    return folder / RUNS[0]  # data= a run file instead of the folder


def _yaml_not_manifest(folder, table):
    (folder / "notes.yaml").write_text("- just\n- a list\n")
    return folder / "notes.yaml"


def _absolute_run(folder, table):
    _manifest(folder, lambda m: m["runs"][1].update(file=str((folder / RUNS[1]).resolve())))
    return folder


def _escaping_run(folder, table):
    shutil.copy(folder / RUNS[1], folder.parent / RUNS[1])
    _manifest(folder, lambda m: m["runs"][1].update(file=f"../{RUNS[1]}"))
    return folder


def _same_dof(folder, table):
    _manifest(folder, lambda m: m.update(channels={"acc_tl": "uz_top_left",
                                                   "acc_lr": "uz_top_left"}))
    return folder


def _rate_every_run(folder, table):
    _manifest(folder, lambda m: m.update(sample_rate=512.0))
    return folder


def _unreadable_every_run(folder, table):
    for name in RUNS:
        _truncate_gz(folder / name)
    return folder


def _unknown_suffix(folder, table):
    shutil.copy(folder / RUNS[1], folder / "sweep_1.20g.dat")
    _manifest(folder, lambda m: m["runs"][1].update(file="sweep_1.20g.dat"))
    return folder


DATASET_ERRORS = {
    # id: (fault, message pattern, file named, shown by the script too)
    "duplicate-key": (_dup_units, r"line \d+: duplicate key `units` \(first at line \d+\)",
                      "manifest.yaml", True),
    "duplicate-nested-key": (_dup_nested, r"duplicate key `rate_hz_per_s`", "manifest.yaml",
                             False),
    "binary-manifest": (_binary_manifest, r"not a text \(UTF-8\) file .*give the data-set folder",
                        "manifest.yaml", True),
    "csv-as-data": (_csv_given, r"not a manifest \(a \.yaml file\); give the data-set folder or "
                    r"its manifest\.yaml", "sweep_0.80g.csv.gz", True),
    "yaml-not-mapping": (_yaml_not_manifest, r"must be a YAML mapping .*give the data-set folder",
                         "notes.yaml", False),
    "absolute-run-path": (_absolute_run, r"`runs\[1\]`\.file '/.*' must be a path inside the "
                          r"data-set folder", "manifest.yaml", True),
    "run-path-escapes": (_escaping_run, r"`runs\[1\]`\.file '\.\./sweep_1\.20g\.csv\.gz' must be "
                         r"a path inside", "manifest.yaml", False),
    "two-columns-one-dof": (_same_dof, r"`channels` map the columns \['acc_tl', 'acc_lr'\] to the "
                            r"same model DOF 'uz_top_left'", "manifest.yaml", True),
    "rate-wrong-in-every-run": (_rate_every_run, r"column 'time' implies 256 Hz but the data set's "
                                r"sample rate is 512 Hz.*no run is readable: the other run fails "
                                r"too", RUNS[0], False),
    "every-run-unreadable": (_unreadable_every_run, r"unreadable run file \(EOFError", RUNS[0],
                             False),
    "unknown-suffix": (_unknown_suffix, r"unknown run-file type; the file name must end in one "
                       r"of \[", "sweep_1.20g.dat", False),
}


@pytest.mark.parametrize("case", list(DATASET_ERRORS))
def test_dataset_fault_is_one_line_error(fin2, tmp_path, case):
    fault, pattern, named, _ = DATASET_ERRORS[case]
    path = fault(_copy(fin2, tmp_path), fin2[1])
    with pytest.raises(DatasetError, match=pattern) as info:
        read_dataset(path)
    msg = str(info.value)
    assert "\n" not in msg and named in msg


# ------------------------------------------------------------------------------------------------
# faults of one run: the run is rejected with its reason (Run.reason), the other runs are read
# ------------------------------------------------------------------------------------------------


def _truncated_gz(folder, table):
    _truncate_gz(folder / RUNS[0])


def _corrupt_gz(folder, table):
    (folder / RUNS[0]).write_bytes(b"\x1f\x8b\x08\x00" + os.urandom(2000))


def _missing_column(folder, table):
    (folder / RUNS[0]).unlink()
    _write_run(folder / "sweep_0.80g.csv", table[:, [0, 1, 3]], "time,acc_tl,acc_base")
    _manifest(folder, lambda m: m["runs"][0].update(file="sweep_0.80g.csv"))


def _rate_one_run(folder, table):
    t = table.copy()
    t[:, 0] *= 0.5  # 512 Hz
    (folder / RUNS[0]).unlink()
    _write_run(folder / "sweep_0.80g.csv", t)
    _manifest(folder, lambda m: m["runs"][0].update(file="sweep_0.80g.csv"))


def _hint_ten_times(folder, table):
    _manifest(folder, lambda m: m["runs"][0]["sweep"].update(rate_hz_per_s=1.0))


def _hint_above_nyquist(folder, table):
    _manifest(folder, lambda m: m["runs"][0]["sweep"].update(stop_hz=150.0))


def _rate_below_2p5(folder, table):
    _manifest(folder, lambda m: m["runs"][0]["sweep"].update(stop_hz=110.0))


def _nan_samples(folder, table):
    t = table.copy()
    t[1000:1010, 2] = np.nan
    (folder / RUNS[0]).unlink()
    _write_run(folder / "sweep_0.80g.csv", t)
    _manifest(folder, lambda m: m["runs"][0].update(file="sweep_0.80g.csv"))


RUN_REJECTIONS = {
    "truncated-csv-gz": (_truncated_gz, r"sweep_0\.80g\.csv\.gz: unreadable run file \(EOFError: "
                         r"Compressed file ended"),
    "corrupt-csv-gz": (_corrupt_gz, r"sweep_0\.80g\.csv\.gz: (not a readable CSV text file|"
                       r"unreadable run file \(zlib\.error)"),
    "missing-column": (_missing_column, r"column\(s\) \['acc_lr'\] not in the header"),
    "rate-wrong-in-one-run": (_rate_one_run, r"column 'time' implies 512 Hz but the data set's "
                              r"sample rate is 256 Hz"),
    "hint-ten-times-rate": (_hint_ten_times, r"the record lasts 165 s but the sweep hint \(30 -> "
                            r"46\.5 Hz at 1 Hz/s\) lasts 16\.5 s"),
    "hint-above-nyquist": (_hint_above_nyquist, r"reaches 150 Hz, at or above the Nyquist "
                           r"frequency 128 Hz of the 256 Hz record"),
    "rate-below-2.5x-hint": (_rate_below_2p5, r"sample rate 256 Hz is below 2\.5 x the sweep "
                             r"hint's top frequency 110 Hz \(275 Hz needed\)"),
    "nan-samples": (_nan_samples, r"non-finite values \(NaN/inf\) in column 'acc_lr': 10 samples"),
}


@pytest.mark.parametrize("case", list(RUN_REJECTIONS))
def test_run_fault_rejects_that_run(fin2, tmp_path, case):
    fault, pattern = RUN_REJECTIONS[case]
    folder = _copy(fin2, tmp_path)
    fault(folder, fin2[1])
    ds = read_dataset(folder)
    bad, good = ds.runs
    assert re.search(pattern, bad.reason), bad.reason
    assert "\n" not in bad.reason
    assert good.reason == "" and good.data.shape[0] == 2 and good.data.shape[1] > 40000
    assert ds.sample_rate == 256.0


# ------------------------------------------------------------------------------------------------
# faults the extraction finds (it knows trim_s and subtracts the base): rejected with the reason
# ------------------------------------------------------------------------------------------------


def _identify_reasons(folder) -> dict:
    """{run: reason} of the rejected runs of ``identify`` on a data set whose only usable data
    are the faulty run's (so it stops with IdentificationError, quickly: no fit). The record
    checks are off: these are the extraction's own rejections (the checks would reject some of
    these runs before it, with their own reasons: tests/test_quality_wiring.py)."""
    with pytest.raises(IdentificationError) as info:
        identify(read_dataset(folder), progress=False, replay=None, records=None)
    pts = info.value.points
    out = {r: "; ".join(dict.fromkeys(p.reason for p in pts.points if p.run == r))
           for r in pts.rejected_runs}
    return out, pts, str(info.value)


def _only(folder, name, table, *, sweep="same"):
    """The data set reduced to one faulty run ``name`` holding ``table``."""
    for f in RUNS:
        (folder / f).unlink(missing_ok=True)
    _manifest(folder, lambda m: m.update(runs=[]))
    _add_run(folder, name, table, sweep=sweep)


def test_run_too_short_for_extraction(fin2, tmp_path):
    """A 1 s run: with its hint it does not fit the record; without, the extraction's trim
    (1 s at each end) leaves nothing: rejected, not a crash of the whole job."""
    folder = _copy(fin2, tmp_path)
    _only(folder, "short.csv", fin2[1][:257], sweep=None)
    reasons, _, msg = _identify_reasons(folder)
    assert re.search(r"run too short for the extraction: 257 samples \(1\.004 s at 256 Hz\) "
                     r"leave 0 after trimming `trim_s`=1 s at each end", reasons["short.csv"])
    assert "short.csv" in msg and "\n" not in msg
    assert "record whole sweeps" in msg and "higher levels" not in msg
    _only(folder, "short.csv", fin2[1][:257])
    assert "lasts 1 s but the sweep hint" in read_dataset(folder).runs[0].reason


def test_dead_channel_is_named(fin2, tmp_path):
    """acc_tl all zeros: its point says so (not "stayed in the gap", which the base's motion
    alone would give once subtracted); acc_lr still gives its point."""
    folder = _copy(fin2, tmp_path)
    t = fin2[1].copy()
    t[:, 1] = 0.0
    _only(folder, "dead_tl.csv", t)
    _, pts, _ = _identify_reasons(folder)
    by_ch = {p.channel: p for p in pts.points}
    assert by_ch["acc_tl"].reason == "channel acc_tl is dead (constant 0)"
    assert by_ch["acc_lr"].used


def test_near_dead_channel_is_named(fin2, tmp_path):
    folder = _copy(fin2, tmp_path)
    t = fin2[1][:2000].copy()  # 7.8 s; a slow extraction is not needed to see the reason
    t[:, 1] = 1e-9 * np.sin(np.arange(t.shape[0]))
    t[:, 2] = 0.0
    _only(folder, "dead_both.csv", t, sweep=None)
    reasons, pts, _ = _identify_reasons(folder)
    r = reasons["dead_both.csv"]
    assert re.search(r"channel acc_tl is dead \(std [\d.]+e-09 m/s\^2, below 1e-06 of the run's "
                     r"other channels", r), r
    assert "channel acc_lr is dead (constant 0)" in r


def test_dead_base_channel_rejects_the_run(fin2, tmp_path):
    folder = _copy(fin2, tmp_path)
    t = fin2[1].copy()
    t[:, 3] = 0.25
    _only(folder, "dead_base.csv", t)
    reasons, pts, msg = _identify_reasons(folder)
    assert reasons == {"dead_base.csv": "base channel acc_base is dead (constant 2.45166 "
                                        "m/s^2): it cannot be subtracted"}
    assert not any(p.used for p in pts.points) and "dead_base.csv" in msg


# ------------------------------------------------------------------------------------------------
# through scripts/identify.py
# ------------------------------------------------------------------------------------------------


def _script(path, run):
    cmd = [sys.executable, str(ROOT / "scripts" / "identify.py"), f"data={path}", "debug=fast",
           "plot=false", f"hydra.run.dir={run}"]
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    return subprocess.run(cmd, cwd=run.parent, env=env, capture_output=True, text=True)


@pytest.mark.parametrize("case", [c for c, v in DATASET_ERRORS.items() if v[3]])
def test_script_prints_one_line(fin2, tmp_path, case):
    fault, pattern, named, _ = DATASET_ERRORS[case]
    path = fault(_copy(fin2, tmp_path), fin2[1])
    run = tmp_path / "run"
    proc = _script(path, run)
    assert proc.returncode == 1, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("identify: "), proc.stderr[-2000:]
    assert re.search(pattern, lines[0]) and named in lines[0]
    assert not (run / "identification.json").exists()


def test_script_rejects_faulty_runs_and_identifies_the_rest(fin2, tmp_path):
    """Four faulty runs beside the two good ones: each rejected with its reason, exit 0, and
    (kn, delta) exactly those of the two good runs alone: the faulty runs take no part."""
    folder = _copy(fin2, tmp_path)
    table = fin2[1]
    _add_run(folder, "truncated.csv", table)
    (folder / "truncated.csv").write_bytes(gzip.compress(b"x"))  # not text: unreadable
    dead_base = table.copy()
    dead_base[:, 3] = 0.0
    _add_run(folder, "dead_base.csv", dead_base)
    _add_run(folder, "short.csv", table[:257], sweep=None)
    _add_run(folder, "fast_hint.csv", table,
             sweep={"start_hz": 30.0, "stop_hz": 46.5, "rate_hz_per_s": 1.0})
    run = tmp_path / "run"
    proc = _script(folder, run)
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads((run / "identification.json").read_text())
    rejected = {r["run"]: r["reason"] for r in res["rejected_runs"]}
    assert set(rejected) == {"truncated.csv", "dead_base.csv", "short.csv", "fast_hint.csv"}
    assert "truncated.csv" in rejected["truncated.csv"]
    # the record checks reject it first: its base channel flat at 0 g (a dead channel), and its
    # responses are run sweep_0.80g.csv.gz's sample for sample
    assert "acc_base" in rejected["dead_base.csv"] and "flat" in rejected["dead_base.csv"]
    # a 1 s record: the record checks find no sweep in it (the extraction, with them off, says
    # it is too short for its trim: test_run_too_short_for_extraction)
    assert rejected["short.csv"].startswith("record checks: run short.csv: no sweep found")
    assert "the sweep hint (30 -> 46.5 Hz at 1 Hz/s)" in rejected["fast_hint.csv"]
    used = {p["run"] for p in res["points"] if p["used"]}
    assert used == set(RUNS)
    clean = _script(fin2[0], tmp_path / "clean")
    assert clean.returncode == 0, clean.stderr[-3000:]
    ref = json.loads((tmp_path / "clean" / "identification.json").read_text())
    assert ref["rejected_runs"] == []
    for key, truth in (("kn", 480.0), ("delta", 0.003)):
        assert res[key] == pytest.approx(ref[key], rel=1e-9)
        assert res[key] == pytest.approx(truth, rel=0.1)  # two runs, the debug=fast grid
    assert "rejected run dead_base.csv: record checks: run dead_base.csv, channel acc_base" in \
        proc.stdout

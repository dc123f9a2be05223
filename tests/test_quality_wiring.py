"""The record checks wired into ``freeplayid.identify`` (docs/record_checks.md, "Wiring into the
identification"), and the commands' one line on Ctrl-C.

On the bundled example with a fault made in memory: a run the checks reject (clipped at 70 % of
its peak; zeros held across its jump) is left out with the checks' reason and does not make the
verdict ``suspect``; swapped channels do, naming the swap; clean records raise nothing;
``records=None`` (``records=off``) identifies from the records as they are. Every
identification here is the plain fit (``replay=None``) of lock-in points from a 3 x 3 start
grid: seconds each.
"""

import json
import os
import select
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from freeplayid import IdentificationError, identify
from freeplayid.errors import ConfigError
from freeplayid.io import read_dataset
from freeplayid.io.result_file import read_identification, write_identification
from freeplayid.model import load_system
from freeplayid.quality import RecordCheckOptions

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "fin_sweeps"
FAST = {"replay": None, "progress": False, "extraction": {"method": "lockin"},
        "fit": {"multistart": {"n": 3}}}
TOP = "sweep_1.20g.csv.gz"  # the highest level of the example
JUMP = "sweep_1.00g.csv.gz"


@pytest.fixture(scope="module")
def example():
    ds = read_dataset(EXAMPLE)
    return ds, load_system(ds.model)


def with_run(ds, file: str, fn):
    return replace(ds, runs=tuple(fn(r) if r.file == file else r for r in ds.runs))


def clipped(run, share: float = 0.7):
    """Every response channel clipped at ``share`` of its own peak."""
    x = run.data.copy()
    for k in range(x.shape[0]):
        c = share * np.max(np.abs(x[k]))
        x[k] = np.clip(x[k], -c, c)
    return replace(run, data=x)


def zeros_at_jump(run, fs: float, seconds: float = 0.5):
    """``seconds`` of zeros in every channel (the base too), centred on the largest sample."""
    i, h = int(np.argmax(np.abs(run.data[0]))), int(seconds * fs / 2)
    x, b = run.data.copy(), run.base.copy()
    x[:, i - h:i + h] = 0.0
    b[i - h:i + h] = 0.0
    return replace(run, data=x, base=b)


def swapped(ds):
    cols, dofs = list(ds.channels), list(ds.channels.values())
    return replace(ds, channels=dict(zip(cols, dofs[::-1], strict=True)))


def failed(result) -> dict:
    return {c.name: c.message for c in result.verdict.checks if not c.passed}


@pytest.fixture(scope="module")
def clean_result(example):
    ds, system = example
    return identify(ds, system=system, **FAST)


@pytest.fixture(scope="module")
def clipped_result(example):
    ds, system = example
    return identify(with_run(ds, TOP, clipped), system=system, **FAST)


# ------------------------------------------------------------------ clean records
def test_clean_records_raise_nothing_and_off_is_as_before(example, clean_result):
    ds, system = example
    res = clean_result
    assert res.verdict.ok, res.verdict.reasons
    assert res.records is not None and res.records.findings == ()
    (check,) = [c for c in res.verdict.checks if c.name == "records"]
    assert check.passed and check.message == "record checks: nothing found"
    assert "record checks" not in res.summary()
    # off: no record check, no report, the same points and answer (nothing was repaired)
    off = identify(ds, system=system, records=None, **FAST)
    assert off.records is None and "records" not in {c.name for c in off.verdict.checks}
    assert (off.kn, off.delta) == (res.kn, res.delta)
    assert off.rejected_runs == res.rejected_runs
    assert [c for c in off.verdict.checks] == [c for c in res.verdict.checks
                                               if c.name != "records"]
    assert off.to_dict()["records"] is None
    assert "## Record checks\n\nOff" in off.report()


# ------------------------------------------------------------------ a run rejected
def test_clipped_run_is_left_out_with_the_checks_reason_not_suspect(clipped_result):
    res = clipped_result
    rejected = dict(res.rejected_runs)
    assert rejected[TOP].startswith("record checks: ")
    assert "saturated" in rejected[TOP] and "acc_tl" in rejected[TOP]
    assert "stayed in the gap" not in rejected[TOP]
    assert TOP not in {p.run for p in res.points.points}  # never extracted
    assert res.verdict.ok, res.verdict.reasons  # three resonances left: a sound answer
    assert res.kn == pytest.approx(480.0, rel=0.02) and res.delta == pytest.approx(3e-3, rel=0.03)
    (check,) = [c for c in res.verdict.checks if c.name == "records"]
    assert check.passed and f"1 run rejected ({TOP})" in check.message
    lines = [ln for ln in res.summary().splitlines() if ln.startswith("record checks:")]
    assert lines == [f"record checks: 1 run rejected ({TOP}) (report.md lists them)"]


def test_zeros_across_a_jump_reject_that_run_not_the_answer(example):
    ds, system = example
    res = identify(with_run(ds, JUMP, lambda r: zeros_at_jump(r, ds.sample_rate)),
                   system=system, **FAST)
    rejected = dict(res.rejected_runs)
    assert "zeros held for 0.5 s" in rejected[JUMP] and rejected[JUMP].startswith("record")
    assert res.verdict.ok, res.verdict.reasons


def test_the_same_clipped_run_without_the_checks_is_fitted(example, clipped_result):
    """records=None: the clipped run is extracted and fitted as before the checks existed."""
    ds, system = example
    off = identify(with_run(ds, TOP, clipped), system=system, records=None, **FAST)
    assert TOP not in dict(off.rejected_runs) and TOP in {p.run for p in off.used_points}
    assert off.records is None and off.kn != clipped_result.kn


def test_every_run_rejected_is_one_line_before_the_extraction(example, monkeypatch):
    from freeplayid.identification import pipeline

    def no_extraction(*args, **kwargs):
        raise AssertionError("the extraction started")

    monkeypatch.setattr(pipeline, "plain_estimate", no_extraction)
    ds, system = example
    resonating = replace(ds, runs=tuple(zeros_at_jump(r, ds.sample_rate) for r in ds.runs[1:]))
    with pytest.raises(IdentificationError, match="every run is rejected") as err:
        identify(resonating, system=system, **FAST)
    msg = str(err.value)
    assert "\n" not in msg and msg.count("zeros held") >= 4
    assert all(r.file in msg for r in resonating.runs)


# ------------------------------------------------------------------ a suspect fault
def test_swapped_channels_make_the_answer_suspect_naming_the_swap(example):
    ds, system = example
    res = identify(swapped(ds), system=system, **FAST)
    assert res.verdict.status == "suspect"
    first = res.verdict.reasons[0]  # the record checks lead the verdict
    assert first.startswith("record check `cabling`") and "look swapped" in first
    assert "acc_tl" in first and "acc_lr" in first
    assert "records" in failed(res) and res.rejected_runs == clean_rejected(res)


def clean_rejected(res):
    """Only the example's gap run is rejected (by the extraction, not by the checks)."""
    return tuple((r, w) for r, w in res.rejected_runs if not w.startswith("record checks"))


# ------------------------------------------------------------------ where the findings go
def test_findings_go_into_the_json_record_and_the_report(clipped_result, tmp_path):
    res = clipped_result
    path = write_identification(tmp_path, res)
    back = read_identification(path)
    found = back["records"]["findings"]
    assert {(f["check"], f["run"], f["action"]) for f in found} == {
        ("saturation", TOP, "reject_run")}
    assert {f["channel"] for f in found} == {"acc_tl", "acc_lr"}
    assert back["records"]["skipped"] == {}
    assert any(c["name"] == "records" and c["passed"] for c in back["checks"])
    assert {r["run"]: r["reason"] for r in back["rejected_runs"]}[TOP].startswith("record")
    report = res.report()
    section = report.split("## Record checks\n\n", 1)[1]
    assert section.startswith(res.records.to_markdown())
    # a broken `records` entry is named
    bad = json.loads(path.read_text())
    bad["records"] = {"findings": [{"check": "saturation"}]}
    path.write_text(json.dumps(bad))
    with pytest.raises(ValueError, match=r"`records.findings\[0\]` misses the field"):
        read_identification(path)


def test_records_argument(example):
    ds, system = example
    with pytest.raises(TypeError, match="`records` has unknown field"):
        identify(ds, system=system, records={"clip_level": 0.5}, **FAST)
    with pytest.raises(TypeError, match="`records` must be a freeplayid.quality"):
        identify(ds, system=system, records=True, **FAST)
    with pytest.raises(ConfigError, match="`records.mode` \\(1\\) must be the fitted mode"):
        identify(ds, system=system, records=RecordCheckOptions(mode=1), **FAST)
    with pytest.raises(ValueError, match="`checks` must name checks"):
        identify(ds, system=system, records={"checks": ["clipping"]}, **FAST)


# ------------------------------------------------------------------ the command
def test_records_config_group():
    from hydra import compose, initialize_config_dir

    import freeplayid.tasks  # noqa: F401  (stores the option groups)
    from freeplayid.tasks.options import identify_options

    def options(*overrides):
        conf = ROOT / "src" / "freeplayid" / "conf"
        with initialize_config_dir(config_dir=str(conf), version_base="1.3"):
            return identify_options(compose(config_name="identify", overrides=list(overrides)))

    assert options()["records"] == RecordCheckOptions()
    assert options("records=off")["records"] is None
    assert options("debug=fast")["records"] == RecordCheckOptions()
    some = options("records.checks=[units,saturation]", "records.hum_lines_hz=[60]")["records"]
    assert some == RecordCheckOptions(checks=("saturation", "units"), hum_lines_hz=(60.0,))
    with pytest.raises(ConfigError, match="`records.rate_tolerance` must be a finite number"):
        options("records.rate_tolerance=-1")


def _script(tmp_path, *overrides, **popen):
    cmd = [sys.executable, str(ROOT / "scripts" / "identify.py"), *overrides,
           f"hydra.run.dir={tmp_path / 'run'}"]
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    return cmd, {"cwd": tmp_path, "env": env, **popen}


def test_identify_script_records_off(tmp_path):
    cmd, kw = _script(tmp_path, "records=false")
    proc = subprocess.run(cmd, capture_output=True, text=True, **kw)
    assert proc.returncode != 0 and "use records=off" in proc.stderr
    assert "Traceback" not in proc.stderr
    cmd, kw = _script(tmp_path, "records=off", "debug=fast", "extraction.method=lockin",
                      "plot=false")
    proc = subprocess.run(cmd, capture_output=True, text=True, **kw)
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads((tmp_path / "run" / "identification.json").read_text())
    assert res["records"] is None and res["verdict"] == "ok"
    assert "records" not in {c["name"] for c in res["checks"]}
    assert "## Record checks\n\nOff" in (tmp_path / "run" / "report.md").read_text()


def test_ctrl_c_ends_identify_with_one_line(tmp_path):
    """SIGINT to a running scripts/identify.py (the bundled example, a minute or more of work):
    one line on stderr besides the progress bar, exit status 130, no result written. Skipped if
    the command finished before the signal reached it."""
    cmd, kw = _script(tmp_path, "plot=false", stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    # a terminal starts the command with Ctrl-C's default action; a test run started in the
    # background by a non-interactive shell has SIGINT ignored, and an ignored signal stays
    # ignored in the child, which then never sees the Ctrl-C: start it from a handled SIGINT
    saved = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        proc = subprocess.Popen(cmd, **kw)
    finally:
        signal.signal(signal.SIGINT, signal.SIG_DFL if saved is None else saved)
    err, deadline = b"", time.monotonic() + 120
    try:
        # started: the extraction's progress bar is on stderr (or two minutes passed)
        while b"extracting points" not in err and proc.poll() is None \
                and time.monotonic() < deadline:
            if select.select([proc.stderr], [], [], 1.0)[0]:
                err += os.read(proc.stderr.fileno(), 4096)
        if proc.poll() is not None:
            pytest.skip("identify ended before it could be interrupted")
        proc.send_signal(signal.SIGINT)
        sent = time.monotonic()
        out, rest = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    if proc.returncode == 0:
        tail = (err + rest).decode(errors="replace").replace("\r", "\n").strip().splitlines()
        late = time.monotonic() - sent
        pytest.skip(f"identify finished before the signal reached it ({late:.1f} s after it "
                    f"was sent; its last lines: {tail[-3:]})")
    text = (err + rest).decode()
    assert proc.returncode == 130, text[-3000:]
    assert "Traceback" not in text
    # the progress bar's updates are "\r..." segments; what is left is one line
    lines = [ln for ln in text.split("\n") if ln.strip() and not ln.startswith("\r")]
    assert lines == ["identify: interrupted"], text[-3000:]
    run = tmp_path / "run"
    assert not (run / "identification.json").exists() and not (run / "report.md").exists()
    assert {p.name for p in run.iterdir()} <= {".hydra", "identify.log"}  # no staging left


def test_the_verdicts_line_names_the_checks_that_warned():
    from freeplayid.identification.records import findings_text, record_checks
    from freeplayid.quality import Finding, RecordReport

    def warn(check, run):
        return Finding(check, run, "acc_tl", 3.0, "% of 1st", "warning", f"{run}: {check}")

    report = RecordReport((warn("hum", "a.csv"), warn("even_harmonics", "a.csv"),
                           warn("hum", "b.csv")))
    assert findings_text(report) == "3 warnings (hum, even_harmonics)"
    (check,) = record_checks(report)
    assert check.passed and check.message == "record checks: 3 warnings (hum, even_harmonics)"

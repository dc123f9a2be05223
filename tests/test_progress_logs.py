"""Progress bars, the library's log, the commands' terminal lines and log files, and the warnings
kept quiet (freeplayid.progress, freeplayid.tasks.logs, docs/identify.md)."""

import logging
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml

from freeplayid import identify
from freeplayid.progress import WARNINGS_ENV, progress_bar, warnings_wanted
from freeplayid.tasks.logs import CommandFilter, LibraryFilter, PlainFormatter

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "examples" / "fin_modal" / "sweeps"  # three 32 s runs at 256 Hz: seconds to extract
LOGGING = ROOT / "src" / "freeplayid" / "conf" / "hydra" / "job_logging" / "freeplayid.yaml"


def _record(name: str, level: int, msg: str = "message") -> logging.LogRecord:
    return logging.makeLogRecord({"name": name, "levelno": level,
                                  "levelname": logging.getLevelName(level), "msg": msg})


def test_progress_false_silences_identify(capfd):
    result = identify(SMALL, replay=None, progress=False)
    out, err = capfd.readouterr()
    assert (out, err) == ("", "")
    assert result.verdict.ok


def test_each_replay_on_the_bar_and_in_the_log(capfd, caplog):
    from freeplayid.replay import Replay

    caplog.set_level(logging.DEBUG, logger="freeplayid")
    result = identify(SMALL, replay=Replay(max_iter=2), progress=True)
    err = capfd.readouterr().err.replace("\r", "\n")
    assert "extracting points" in err
    # "replay k/max_iter" with the time left and the replay's kn, delta and misfit
    assert "replay 1/2" in err and "replay 2/2" in err, err[-2000:]
    last = [ln for ln in err.splitlines() if ln.startswith("replay 2/2")][-1]
    assert "<" in last and "kn 5" in last and "delta 0.002" in last and "misfit " in last
    # the lines the loop printed before: now DEBUG records of the replay's logger
    lines = [r.getMessage() for r in caplog.records if r.name == "freeplayid.replay.corrected"]
    assert lines[0].startswith("replay 1: kn ") and "misfit of the statistics" in lines[0]
    assert len(result.replay.iterations) == 2


def test_simulation_bar_counts_simulated_seconds(capfd):
    import torch

    from freeplayid.model import sdof_system
    from freeplayid.simulate import Sweep, simulate_sweeps

    simulate_sweeps(sdof_system(mass=23.8, damping=598.0), kn=2.35e6, delta=1.2e-4,
                    level_g=[0.6], sweep=Sweep(40.0, 42.0, 2.0), channels=["x"],
                    sample_rate=512.0, engine="torch", dtype=torch.float64, progress=True)
    err = capfd.readouterr().err
    assert "1.00/1.00 s" in err and "s/s" not in err, err


def test_batch_arrays_are_writable_copies():
    # broadcast views warn when written (numba reads the flag: a FutureWarning per replay)
    from freeplayid.simulate.run import _members

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for a in _members(480.0, 3e-3, [1.0]):
            assert a.flags.writeable and a.flags.c_contiguous
            a[...] = a


def test_expected_overflows_warn_nothing():
    from freeplayid.fit import BackboneModel
    from freeplayid.fit.uncertainty import jacobian_intervals
    from freeplayid.model import load_system

    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        # a direction the points do not fix: a half-width of ~1e98 in log units
        J = np.array([[1.0, 0.0], [1.0, 1e-100], [1.0, 0.0], [2.0, 0.0]])
        kn_ci, delta_ci = jacobian_intervals(np.log([480.0, 3e-3]), np.full(4, 1e-2), J)
        assert delta_ci == (0.0, float("inf"))
        # a fit start running off to delta = 0
        model = BackboneModel(load_system(SMALL / "model.npz"), ["uz_top_left"])
        f = model.frequency(np.array([1e-3]), np.array([0]), 480.0, 0.0)
        assert f.shape == (1,)


def test_warnings_switch(monkeypatch):
    for value, wanted in (("", False), ("0", False), ("off", False), ("1", True), ("yes", True)):
        monkeypatch.setenv(WARNINGS_ENV, value)
        assert warnings_wanted() is wanted
    monkeypatch.delenv(WARNINGS_ENV)
    assert not warnings_wanted()
    assert progress_bar(range(3), desc="x", show=False).disable


def test_lightning_quiet_unless_asked(monkeypatch):
    pytest.importorskip("pytorch_lightning")
    from freeplayid.inverse.lightning import lightning_quiet

    lg = logging.getLogger("pytorch_lightning")
    before = lg.level
    monkeypatch.delenv(WARNINGS_ENV, raising=False)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        with lightning_quiet():
            assert lg.level == logging.WARNING  # its banners and tips are INFO
            warnings.warn("`LeafSpec` is deprecated", FutureWarning, stacklevel=1)
            warnings.warn("old", DeprecationWarning, stacklevel=1)
    assert not seen and lg.level == before
    monkeypatch.setenv(WARNINGS_ENV, "1")
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        with lightning_quiet():
            assert lg.level == before
            warnings.warn("old", DeprecationWarning, stacklevel=1)
    assert len(seen) == 1


def test_terminal_filters_and_format(monkeypatch):
    monkeypatch.delenv(WARNINGS_ENV, raising=False)
    command, library, plain = CommandFilter(), LibraryFilter(), PlainFormatter()
    summary = _record("freeplayid.tasks.identify", logging.INFO, "kn    = 480")
    assert command.filter(summary) and not library.filter(summary)
    assert plain.format(summary) == "kn    = 480"  # as printed before
    compiling = _record("freeplayid.simulate.engines.numba.jit", logging.INFO)
    assert library.filter(compiling) and not command.filter(compiling)
    replay = _record("freeplayid.replay.corrected", logging.DEBUG)  # the log file's only
    assert not library.filter(replay) and not command.filter(replay)
    banner = _record("pytorch_lightning.utilities.rank_zero", logging.INFO)
    assert not library.filter(banner)
    warning = _record("somewhere", logging.WARNING, "careful")
    assert library.filter(warning) and plain.format(warning) == "warning: careful"
    monkeypatch.setenv(WARNINGS_ENV, "1")
    assert library.filter(banner)
    # the commands' configuration: these classes, the log file in the run folder
    cfg = yaml.safe_load(LOGGING.read_text())
    filename = cfg["handlers"]["file"]["filename"]
    assert filename == "${hydra.runtime.output_dir}/${hydra.job.name}.log"
    assert cfg["filters"]["command"]["()"] == "freeplayid.tasks.logs.CommandFilter"
    assert cfg["loggers"]["freeplayid"]["level"] == "DEBUG"


def _identify(tmp_path, *overrides):
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    env.pop(WARNINGS_ENV, None)
    return subprocess.run([sys.executable, str(ROOT / "scripts" / "identify.py"), *overrides],
                          cwd=tmp_path, env=env, capture_output=True, text=True)


def test_the_command_prints_its_summary_and_logs_it(tmp_path):
    run = tmp_path / "run"
    proc = _identify(tmp_path, f"data={SMALL}", "replay=off", "debug=fast", "plot=false",
                     f"hydra.run.dir={run}")
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    # the terminal: the summary as the command printed it, no logging prefixes
    assert lines[0].startswith("kn    = ") and lines[1].startswith("delta = ")
    assert "verdict: ok" in lines and lines[-1].startswith("6 points, 0 rejected runs, ")
    assert "[INFO]" not in proc.stdout + proc.stderr
    assert "extracting points" in proc.stderr  # the bar, on stderr
    # the log file: the same lines with times and loggers, and the data set read (DEBUG)
    log = (run / "identify.log").read_text(encoding="utf-8")
    assert "[freeplayid.tasks.identify][INFO] - kn    = " in log and "verdict: ok" in log
    assert f"data set {SMALL / 'manifest.yaml'}: 3 runs" in log


def test_a_failed_command_ends_its_log_with_the_reason(tmp_path):
    run = tmp_path / "run"
    proc = _identify(tmp_path, f"data={tmp_path / 'missing'}", "replay=off",
                     f"hydra.run.dir={run}")
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    reason = proc.stderr.strip().splitlines()[-1]
    assert reason.startswith("identify: ")
    assert (run / "identify.log").read_text(encoding="utf-8").strip().endswith(
        reason.removeprefix("identify: "))

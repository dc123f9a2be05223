"""Configuration and output faults: one line naming the field, a non-zero exit, no result left.

Every command checks its whole configuration before any work (freeplayid.tasks.checks) and
writes its results all or none (freeplayid.atomic.staged_folder).
"""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from freeplayid.atomic import STAGE_PREFIX, staged_folder
from freeplayid.errors import ConfigError, InputError, OutputError

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ("identification.json", "dataset/manifest.yaml", "checkpoint.ckpt", "metrics.json")

SIM = ["model=sdof", "debug=fast"]
try:
    import tensorboard  # noqa: F401

    _NO_TENSORBOARD = False
except ImportError:
    _NO_TENSORBOARD = True
# (script, overrides, the field the one line must name)
FAULTS = [
    ("identify", ["fit.backbone=nonsense"], "`fit.backbone`"),
    ("identify", ["fit.n_bootstrap=abc"], "`fit.n_bootstrap`"),
    ("identify", ["fit.n_bootstrap=-5"], "`fit.n_bootstrap`"),
    ("identify", ["fit.n_bootstrap=2.7"], "`fit.n_bootstrap`"),
    ("identify", ["plot=maybe"], "`plot`"),
    ("identify", ["fit.multistart.n=0"], "`fit.multistart.n`"),
    ("identify", ["fit.multistart.kn_range=[1e8,1e3]"], "`fit.multistart.kn_range`"),
    ("identify", ["extraction.method=fft"], "`extraction.method`"),
    ("identify", ["extraction.jump_ratio=1.5"], "`extraction.jump_ratio`"),
    ("identify", ["fit.mode=99"], "`fit.mode`"),
    ("identify", ["replay.damping=1.5"], "`replay.damping`"),
    ("identify", ["replay.damping=rayleigh"], "`replay.damping`"),
    ("identify", ["replay.n_bootstrap=-1"], "`replay.n_bootstrap`"),
    ("identify", ["replay.jump_point=peak"], "`replay.jump_point`"),
    ("identify", ["+replay.nonsense=1"], "`replay.nonsense`"),
    ("simulate", SIM + ["levels=[-0.4]"], "`levels`"),
    ("simulate", SIM + ["levels=[]"], "`levels`"),
    ("simulate", SIM + ["kn=0"], "`kn`"),
    ("simulate", SIM + ["kn=-3"], "`kn`"),
    ("simulate", SIM + ["delta=-1e-3"], "`delta`"),
    ("simulate", SIM + ["noise_std_g=-0.1"], "`noise_std_g`"),
    ("simulate", SIM + ["quantity=jerk"], "`quantity`"),
    ("simulate", SIM + ["dtype=float16"], "`dtype`"),
    ("simulate", SIM + ["sample_rate=100"], "`sample_rate`"),
    ("simulate", SIM + ["kn=2.35e16", "max_steps=1e6"], "`max_steps`"),
    ("simulate", SIM + ["units=mm"], "`units`"),
    ("simulate", SIM + ["plot=maybe"], "`plot`"),
    ("simulate", SIM + ["channels={acc_x: nowhere}"], "`channels`"),
    ("simulate", ["model=npz"], "`model.path`"),
    ("train", ["debug=fast", "trainer.max_epochs=0"], "`trainer.max_epochs`"),
    ("train", ["debug=fast", "logger.kind=wandb"], "`logger.kind`"),
    *([("train", ["debug=fast", "logger=tensorboard"], "tensorboard")] if _NO_TENSORBOARD
      else []),
    ("train", ["debug=fast", "callbacks=early_stopping", "callbacks.early_stopping.patience=0"],
     "`callbacks.early_stopping.patience`"),
    ("train", ["debug=fast", "dataset.split=[0.5,0.5,0.5]"], "`dataset.split`"),
    ("train", ["debug=fast", "dataset.cases.axis=level"], "`dataset.cases.axis`"),
    ("compare", ["debug=fast", "compare.cases_per_value=0"], "`compare.cases_per_value`"),
    ("compare", ["debug=fast", "fit.backbone=nonsense"], "`fit.backbone`"),
    ("compare", ["debug=fast", "compare.corrected_cases_per_value=-1"],
     "`compare.corrected_cases_per_value`"),
]


def _run(script, args, run, cwd):
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    cmd = [sys.executable, str(ROOT / "scripts" / f"{script}.py"), *args, f"hydra.run.dir={run}"]
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)


def _assert_one_line(proc, script, *needles):
    assert proc.returncode != 0, proc.stdout[-2000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, proc.stderr[-3000:]
    assert lines[0].startswith(f"{script}: "), lines
    for n in needles:
        assert n in lines[0], lines


def _assert_nothing_left(run):
    for name in RESULTS:
        assert not (run / name).exists(), name
    if run.exists():
        assert not [p for p in run.iterdir() if p.name.startswith(STAGE_PREFIX)]


@pytest.mark.parametrize(("script", "args", "field"), FAULTS,
                         ids=[f"{s}:{' '.join(a[-2:] if s == 'simulate' else a)}"
                              for s, a, _ in FAULTS])
def test_a_config_fault_is_one_line_naming_the_field(script, args, field, tmp_path):
    run = tmp_path / "run"
    proc = _run(script, args, run, tmp_path)
    _assert_one_line(proc, script, field)
    _assert_nothing_left(run)


def test_a_huge_kn_is_refused_with_its_cost(tmp_path):
    run = tmp_path / "run"
    # 2.35e9 N/m: a 5 kHz closed-gap mode, ~6.7e3 steps for the 1 s sweep of debug=fast
    proc = _run("simulate", SIM + ["kn=2.35e9", "max_steps=1e3"], run, tmp_path)
    _assert_one_line(proc, "simulate", "RK4 steps per sweep", "force=true")
    _assert_nothing_left(run)


def test_an_output_folder_that_is_a_file_is_one_line(tmp_path):
    run = tmp_path / "run"
    run.write_text("not a folder")
    proc = _run("identify", ["debug=fast"], run, tmp_path)
    _assert_one_line(proc, "identify", "is a file")


def test_a_run_into_an_earlier_run_is_refused(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "identification.json").write_text("{}")  # an earlier run's result
    proc = _run("identify", ["debug=fast"], run, tmp_path)
    _assert_one_line(proc, "identify", "earlier run", "identification.json")
    assert (run / "identification.json").read_text() == "{}"


def test_hydra_override_errors_exit_non_zero_without_traceback(tmp_path):
    """Errors Hydra raises itself (an unknown key, an unknown group option) print its message."""
    for args in (["no_such_key=1"], ["fit=nonsense"], ["replay=false"]):
        proc = _run("identify", args, tmp_path / "run", tmp_path)
        assert proc.returncode != 0 and "Traceback" not in proc.stderr, proc.stderr


# ---------------------------------------------------------------- the staging helper
def test_staged_folder_moves_everything_into_place(tmp_path):
    (tmp_path / ".hydra").mkdir()
    (tmp_path / "identify.log").write_text("")
    with staged_folder(tmp_path) as stage:
        (stage / "a.json").write_text("1")
        (stage / "sub").mkdir()
        (stage / "sub" / "b.csv").write_text("2")
        assert not (tmp_path / "a.json").exists()  # nothing visible before the end
    assert (tmp_path / "a.json").read_text() == "1" and (tmp_path / "sub" / "b.csv").is_file()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(STAGE_PREFIX)]


@pytest.mark.parametrize("exc", [RuntimeError("boom"), KeyboardInterrupt(),
                                 OSError(28, "No space left on device")])
def test_staged_folder_leaves_nothing_on_a_failure(tmp_path, exc):
    with pytest.raises(type(exc)):
        with staged_folder(tmp_path) as stage:
            (stage / "identification.json").write_text("{}")
            raise exc
    assert list(tmp_path.iterdir()) == []


def test_staged_folder_takes_back_a_half_done_move(tmp_path, monkeypatch):
    real = os.replace
    calls = []

    def flaky(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        return real(src, dst)

    monkeypatch.setattr(os, "replace", flaky)
    with pytest.raises(OutputError, match="moving the results"):
        with staged_folder(tmp_path) as stage:
            (stage / "a").write_text("1")
            (stage / "b").write_text("2")
    assert list(tmp_path.iterdir()) == []


def test_staged_folder_refuses_a_file_an_earlier_run_and_a_read_only_folder(tmp_path):
    f = tmp_path / "file"
    f.write_text("")
    with pytest.raises(OutputError, match="is a file"):
        with staged_folder(f):
            pass
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "metrics.json").write_text("{}")
    with pytest.raises(OutputError, match="earlier run.*metrics.json"):
        with staged_folder(tmp_path / "old"):
            pass
    assert issubclass(OutputError, InputError) and issubclass(ConfigError, InputError)
    if os.geteuid() == 0:
        pytest.skip("root writes into read-only folders")
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(OutputError, match="not writable"):
            with staged_folder(ro):
                pass
    finally:
        ro.chmod(0o755)


# ---------------------------------------------------------------- checkpoint vs model
def test_checkpoint_structure_accepts_round_off_and_refuses_a_change():
    from freeplayid.model import default_fin

    system = default_fin()
    stored = system.structure()
    rng = np.random.default_rng(0)

    def scaled(rel):
        def noise(a):  # symmetric, as the matrices must stay
            e = rng.standard_normal(a.shape)
            return a * (1 + rel * (e + e.T) / 2)

        return system.replace(M=noise(system.M), K=noise(system.K), C=noise(system.damping))

    assert system.structure_mismatch(stored) is None
    round_off = scaled(1e-10)
    assert round_off.fingerprint() != system.fingerprint()  # the exact key differs ...
    assert round_off.structure_mismatch(stored) is None  # ... the structure is the same
    why = scaled(1e-4).structure_mismatch(stored)
    assert why is not None and "relative" in why
    names = list(system.dof_names)
    names[0] = "other"
    assert system.replace(dof_names=tuple(names)).structure_mismatch(stored) == "other DOF names"

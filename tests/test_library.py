"""The library without Hydra: light imports, identify() from a notebook, identification.json."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "fin_sweeps"
HEAVY = ("torch", "pytorch_lightning", "lightning", "hydra", "omegaconf")


def test_light_imports_pull_in_no_torch_lightning_or_hydra():
    code = (
        "import sys, freeplayid, freeplayid.io, freeplayid.signal, freeplayid.fit, "
        "freeplayid.identification, freeplayid.quantity\n"
        "from freeplayid import identify, Identification, InputError\n"
        f"print([m for m in {HEAVY!r} if m in sys.modules])"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "[]"


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    """The bundled example cut to two resonating runs (0.8 and 1.2 g): fast, still identifiable."""
    folder = tmp_path_factory.mktemp("two_runs")
    for f in EXAMPLE.iterdir():
        shutil.copy(f, folder / f.name)
    manifest = yaml.safe_load((folder / "manifest.yaml").read_text())
    manifest["runs"] = [r for r in manifest["runs"] if r["level_g"] in (0.8, 1.2)]
    (folder / "manifest.yaml").write_text(yaml.safe_dump(manifest, sort_keys=False))
    return folder


def test_notebook_identify_equals_the_script(two_runs, tmp_path):
    from freeplayid import identify
    from freeplayid.io import read_dataset, read_identification

    run = tmp_path / "run"
    cmd = [sys.executable, str(ROOT / "scripts" / "identify.py"), f"data={two_runs}",
           "debug=fast", "plot=false", f"hydra.run.dir={run}"]
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    script = read_identification(run)

    # the notebook: read, identify with the debug=fast grid of starts, no Hydra anywhere
    res = identify(read_dataset(two_runs), progress=False, fit={"multistart": {"n": 3}},
                   replay=None)
    assert res.kn == pytest.approx(script["kn"], rel=1e-9)
    assert res.delta == pytest.approx(script["delta"], rel=1e-9)
    assert res.init == "multistart" and len(res.used_points) == 4
    assert res.truth_error["delta"] == pytest.approx(res.delta / 3e-3 - 1)
    rec = res.to_dict()
    assert [p["f_hz"] for p in rec["points"]] == [p["f_hz"] for p in script["points"]]
    assert {p["dof"] for p in rec["points"]} == {"uz_top_left", "uz_lower_right"}
    text = res.report()
    assert "## Fitting points" in text and "sweep_1.20g" in text


def test_identification_json_round_trip_and_errors(tmp_path):
    from freeplayid.io import read_identification, write_identification
    from freeplayid.io.result_file import ResultFileError

    rec = {"kn": 480.0, "delta": 3e-3, "kn_ci95": (470.0, 490.0), "delta_ci95": [2.9e-3, 3.1e-3],
           "points": [{"run": "a", "channel": "c", "f_hz": float("nan"), "amplitude_m": 1e-3,
                       "used": False, "reason": "no jump"}],
           "rejected_runs": [{"run": "a", "reason": "no jump"}], "residual_rms": np.float64(1e-4),
           "backbone": "dfa", "init": "multistart", "runtime_s": 1.0}
    path = write_identification(tmp_path, rec)
    assert path == tmp_path / "identification.json"
    assert [p.name for p in tmp_path.iterdir()] == ["identification.json"]  # no temporary left
    back = read_identification(tmp_path)
    assert back["kn_ci95"] == [470.0, 490.0] and back["points"][0]["f_hz"] is None
    with pytest.raises(ValueError, match="runtime_s"):
        write_identification(tmp_path, {k: v for k, v in rec.items() if k != "runtime_s"})
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**back, "delta": -1.0}))
    with pytest.raises(ResultFileError, match="bad.json.*`delta` must be a finite number > 0"):
        read_identification(bad)
    bad.write_text("{not json")
    with pytest.raises(ResultFileError, match="not a readable JSON"):
        read_identification(bad)


def test_input_errors_share_one_base():
    from freeplayid import IdentificationError, InputError
    from freeplayid.io import DatasetError
    from freeplayid.io.result_file import ResultFileError
    from freeplayid.model import SystemFileError

    for cls in (DatasetError, SystemFileError, IdentificationError, ResultFileError):
        assert issubclass(cls, InputError) and issubclass(cls, ValueError)


def test_the_commands_that_need_no_network_load_no_lightning():
    """identify, simulate and model start without PyTorch Lightning (seconds per command):
    importing the commands' module and those tasks leaves it out; compare loads it when run."""
    code = ("import sys, freeplayid.tasks.cli, freeplayid.tasks.identify, "
            "freeplayid.tasks.simulate, freeplayid.tasks.model, freeplayid.tasks.compare\n"
            "print([m for m in ('pytorch_lightning', 'lightning_fabric') if m in sys.modules])")
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "[]"

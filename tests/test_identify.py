"""`scripts/identify.py` end to end on a small simulated data set, and its failure modes."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from freeplayid.io import Run, write_dataset
from freeplayid.model import sdof_system
from freeplayid.simulate import G, Sweep, simulate_sweeps

ROOT = Path(__file__).resolve().parents[1]
KN, DELTA = 2.35e6, 1.2e-4  # SDOF truth: [N/m], [m] (freeplayid/conf/model/sdof.yaml)
LEVELS = (0.15, 0.4, 0.6, 0.8, 1.0)  # [g]; 0.15 g stays in the gap
SWEEP = Sweep(30.0, 50.0, 1.0)  # [Hz], [Hz], [Hz/s]


@pytest.fixture(scope="module")
def sdof_set(tmp_path_factory):
    """Absolute SDOF accelerations [m/s^2] with a base channel, one NaN-corrupted extra run."""
    import torch

    system = sdof_system(mass=23.8, damping=598.0)
    res = simulate_sweeps(system, kn=KN, delta=DELTA, level_g=list(LEVELS), sweep=SWEEP,
                          channels=["x"], quantity="acceleration", frame="absolute",
                          sample_rate=512.0, dtype=torch.float64)
    rng = np.random.default_rng(0)
    hint = {"start_hz": SWEEP.start_hz, "stop_hz": SWEEP.stop_hz, "rate_hz_per_s": 1.0}
    runs = []
    for i, lv in enumerate(LEVELS):
        base = SWEEP.acceleration(res.time, lv) + rng.normal(0, 0.02 * G, res.time.size)
        data = res.signals[i] + rng.normal(0, 0.02 * G, res.signals[i].shape)
        runs.append(Run(file=f"s{lv:.2f}.csv", time=res.time, data=data, level_g=lv,
                        sweep=hint, base=base))
    broken = runs[-1].data.copy()
    broken[0, 100:110] = np.nan
    runs.append(Run(file="broken.csv", time=res.time, data=broken, sweep=hint,
                    base=runs[-1].base))
    folder = tmp_path_factory.mktemp("sdof_set")
    write_dataset(folder, name="sdof test", quantity="acceleration", units="m/s^2",
                  sample_rate=512.0, channels={"acc_x": "x"}, runs=runs, system=system,
                  base_channel="acc_base", truth={"kn": KN, "delta": DELTA})
    return folder


def _identify(tmp_path, *overrides):
    run = tmp_path / "run"
    cmd = [sys.executable, str(ROOT / "scripts" / "identify.py"), *overrides,
           f"hydra.run.dir={run}"]
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True)
    return proc, run


def test_identify_script_contract_and_accuracy(sdof_set, tmp_path):
    proc, run = _identify(tmp_path, f"data={sdof_set}", "debug=fast",
                          "fit.multistart.delta_range=[1e-5,1e-3]")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "kn" in proc.stdout and "delta" in proc.stdout
    res = json.loads((run / "identification.json").read_text())
    assert {"kn", "delta", "kn_ci95", "delta_ci95", "points", "rejected_runs", "residual_rms",
            "backbone", "init", "runtime_s"} <= set(res)
    assert res["backbone"] == "dfa" and res["init"] == "multistart"
    for key in ("kn", "delta"):
        lo, hi = res[f"{key}_ci95"]
        assert lo < res[key] < hi
    assert res["kn"] == pytest.approx(KN, rel=0.02)
    assert res["delta"] == pytest.approx(DELTA, rel=0.06)
    assert isinstance(res["residual_rms"], float) and res["residual_rms"] < 0.01
    assert len(res["points"]) == len(LEVELS)  # the NaN run never reaches the extractor
    for p in res["points"]:
        assert set(p) >= {"channel", "run", "f_hz", "amplitude_m", "used", "reason"}
        assert isinstance(p["used"], bool) and p["channel"] == "acc_x"
        assert p["used"] == (p["reason"] == "")
    used = {p["run"] for p in res["points"] if p["used"]}
    assert used == {f"s{lv:.2f}.csv" for lv in LEVELS[1:]}
    rejected = {r["run"]: r["reason"] for r in res["rejected_runs"]}
    assert set(rejected) == {"s0.15.csv", "broken.csv"}
    assert "no jump" in rejected["s0.15.csv"]
    assert "NaN" in rejected["broken.csv"] and "acc_x" in rejected["broken.csv"]
    report = (run / "report.md").read_text()
    assert "broken.csv" in report and "truth" in report
    metrics = json.loads((run / "metrics.json").read_text())
    assert abs(metrics["kn_rel_error"]) < 0.02 and metrics["n_points_used"] == 4
    for fig in ("backbone_fit.png", "residuals.png"):
        assert (run / fig).stat().st_size > 0


def test_identify_script_reports_bad_data_without_traceback(sdof_set, tmp_path):
    import shutil

    bad = tmp_path / "bad"
    shutil.copytree(sdof_set, bad)
    text = (bad / "manifest.yaml").read_text().replace("acc_x: x", "acc_y: x")
    (bad / "manifest.yaml").write_text(text)
    proc, run = _identify(tmp_path, f"data={bad}", "debug=fast")
    assert proc.returncode != 0
    assert "Traceback" not in proc.stderr
    assert "acc_y" in proc.stderr and "s0.15.csv" in proc.stderr
    assert not (run / "identification.json").exists()


@pytest.mark.slow
def test_bundled_example_within_2_percent(tmp_path):
    proc, run = _identify(tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    m = json.loads((run / "metrics.json").read_text())
    assert abs(m["kn_rel_error"]) < 0.02 and abs(m["delta_rel_error"]) < 0.02


def test_identify_refuses_points_at_one_resonance(tmp_path):
    """The bundled example cut to one resonating run: two channels, one frequency -> a clear
    message instead of an arbitrary (kn, delta)."""
    import shutil

    import yaml

    data = tmp_path / "one_run"
    shutil.copytree(ROOT / "examples" / "fin_sweeps", data)
    manifest = yaml.safe_load((data / "manifest.yaml").read_text())
    manifest["runs"] = [r for r in manifest["runs"] if r["level_g"] in (0.4, 1.0)]
    (data / "manifest.yaml").write_text(yaml.safe_dump(manifest))
    proc, run = _identify(tmp_path, f"data={data}", "debug=fast", "plot=false")
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    assert "one resonance" in proc.stderr and "sweep_1.00g" in proc.stderr
    assert not (run / "identification.json").exists()

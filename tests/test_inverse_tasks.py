"""End to end: train.py and compare.py with debug=fast, identify.py started by the network."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(script, args, cwd):
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.run([sys.executable, str(ROOT / "scripts" / script), *args], cwd=cwd,
                          env=env, capture_output=True, text=True)
    return proc


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A debug=fast training run of the default fin (its cached data set is shared)."""
    tmp = tmp_path_factory.mktemp("train")
    run = tmp / "run"
    proc = _run("train.py", ["debug=fast", f"dataset.cache_dir={tmp / 'datasets'}",
                             f"hydra.run.dir={run}"], tmp)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return tmp, run


def test_train_writes_checkpoint_metrics_and_curves(trained):
    tmp, run = trained
    m = json.loads((run / "metrics.json").read_text())
    assert m["axis"] == "noise_g" and m["n_train"] > 0 and m["n_test"] > 0
    assert set(m["network"]["per_value"]) == {"0", "0.1", "0.2", "0.3"}
    overall = m["network"]["overall"]
    for key in ("within_bounds", "delta_within_2sigma", "kn_within_2sigma"):
        assert 0.0 <= overall[key] <= 1.0
    assert m["epochs"] == 5
    for f in ("checkpoint.ckpt", "learning_curves.png", "predictions.png", "calibration.png"):
        assert (run / f).stat().st_size > 0
    # one checkpoint and one per-epoch record (logger=csv), nothing of Lightning's own
    assert [p.name for p in run.rglob("*.ckpt")] == ["checkpoint.ckpt"]
    assert (run / "metrics.csv").is_file() and not (run / "history.json").exists()
    assert not [p for p in run.iterdir() if p.name.startswith(".checkpoints-")]
    cal = m["calibration"]  # coverage at every level and SBC ranks on the test cases
    assert cal["n_cases"] == m["n_test"] and len(cal["levels"]) == 19
    for p in ("kn", "delta"):
        assert len(cal[p]["coverage"]) == 19 and 0 <= cal[p]["max_gap"] <= 1
        assert len(cal[p]["sbc"]["ranks"]) == m["n_test"] and 0 <= cal[p]["sbc"]["p_value"] <= 1
        assert cal["std_scale"][p] > 0 and 0 <= cal["uncalibrated_max_gap"][p] <= 1
    assert 0 <= cal["outside_domain"] <= m["n_test"]
    from freeplayid.inverse import load_inverse_model
    from freeplayid.model import default_fin

    model = load_inverse_model(run / "checkpoint.ckpt", system=default_fin())
    assert model.channels == ("uz_top_left", "uz_lower_right")
    assert model.extra["dataset"]["cases"]["axis"] == "noise_g"


def test_identify_starts_from_the_network(trained, tmp_path):
    _, run = trained
    out = tmp_path / "id"
    proc = _run("identify.py", ["debug=fast", f"inverse.checkpoint={run / 'checkpoint.ckpt'}",
                                "plot=false", f"hydra.run.dir={out}"], tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads((out / "identification.json").read_text())
    assert res["init"] == "inverse" and res["inverse_estimate"]["kn"] > 0
    # the example's truth: kn 480 N m/rad, delta 3 mrad (the multi-start result is -0.5 / -0.2 %)
    assert abs(res["kn"] / 480.0 - 1) < 0.02 and abs(res["delta"] / 3e-3 - 1) < 0.01
    m = json.loads((out / "metrics.json").read_text())
    assert m["n_evaluations"] < 200  # one start, not a grid
    assert "Start from the inverse model" in (out / "report.md").read_text()


def test_identify_refuses_a_checkpoint_of_another_model(trained, tmp_path):
    """A data set of another structure (an SDOF model) with the fin's checkpoint: a clear exit."""
    _, run = trained
    sim = tmp_path / "sim"
    proc = _run("simulate.py", ["model=sdof", "debug=fast", "plot=false",
                                f"hydra.run.dir={sim}"], tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    proc = _run("identify.py", [f"data={sim / 'dataset'}", "plot=false",
                                f"inverse.checkpoint={run / 'checkpoint.ckpt'}",
                                f"hydra.run.dir={tmp_path / 'id'}"], tmp_path)
    assert proc.returncode != 0
    assert "different linear structure" in proc.stderr and "checkpoint.ckpt" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "id" / "identification.json").exists()


def _compare(trained, name: str, *, corrected: int):
    """compare.py debug=fast on the trained run's cached data set and checkpoint, one case per
    noise value, ``corrected`` of them with the corrected fits: (run folder, process)."""
    tmp, run = trained
    out = tmp / name
    proc = _run("compare.py", ["debug=fast", "compare.cases_per_value=1", "compare.n_jobs=1",
                               f"compare.corrected_cases_per_value={corrected}",
                               f"dataset.cache_dir={tmp / 'datasets'}",
                               f"inverse.checkpoint={run / 'checkpoint.ckpt'}",
                               f"hydra.run.dir={out}"], tmp)
    return out, proc


def test_compare_writes_tables_and_figures(trained):
    """The compare task without the corrected fits: every plain method's rows, the tables and
    the figures (the corrected fits' rows: the slow test below)."""
    import csv

    out, proc = _compare(trained, "compare_plain", corrected=0)
    assert proc.returncode == 0, proc.stderr[-3000:]
    m = json.loads((out / "metrics.json").read_text())
    assert {r["method"] for r in m["summary"]} == {"network", "network+fit", "single-start",
                                                   "multi-start"}
    assert m["evaluation_ratio_multistart_to_network_fit"] > 1.0
    rows = list(csv.DictReader(open(out / "compare.csv")))
    assert len(rows) == 4 * m["n_cases"] and {r["noise_g"] for r in rows} == {
        "0.0", "0.1", "0.2", "0.3"}
    table = (out / "compare.md").read_text()
    assert "multi-start" in table and "| noise [g] |" in table
    for f in ("compare_errors.png", "compare_cost.png", "compare_summary.csv"):
        assert (out / f).stat().st_size > 0


@pytest.mark.slow
def test_compare_adds_the_corrected_fits(trained):
    """The compare task, with the corrected fits (replay) on one case per noise value (about
    two minutes on 2 cores: deselected by default, `pytest -m slow`)."""
    import csv
    import math

    out, proc = _compare(trained, "compare", corrected=1)
    assert proc.returncode == 0, proc.stderr[-3000:]
    m = json.loads((out / "metrics.json").read_text())
    methods = {r["method"] for r in m["summary"]}
    assert methods == {"network", "network+fit", "single-start", "multi-start",
                       "network+corrected", "multi-start+corrected"}
    assert m["evaluation_ratio_multistart_to_network_fit"] > 1.0
    rows = list(csv.DictReader(open(out / "compare.csv")))
    picked = m["corrected"]["cases"]
    assert len(picked) == len({r["noise_g"] for r in rows}) == 4  # one case per noise value
    assert len(rows) == 4 * m["n_cases"] + 2 * len(picked)
    assert f"corrected fits (replay) on {len(picked)} cases: case {picked[0]} (" in proc.stdout
    by = {(int(r["case"]), r["method"]): r for r in rows}
    ran = 0
    for i in picked:
        for corr, plain in (("network+corrected", "network+fit"),
                            ("multi-start+corrected", "multi-start")):
            r = by[(i, corr)]
            if r["verdict"] == "failed":  # e.g. every point at one resonance: identify refuses
                assert r["failure"] and r["n_replays"] == "0" and r["kn"] == "nan"
                continue
            ran += 1
            assert r["verdict"] in ("ok", "suspect") and int(r["n_replays"]) >= 1
            lo, hi = float(r["delta_ci95_low"]), float(r["delta_ci95_high"])
            holds = (float(r["kn_ci95_low"]) <= float(r["kn_true"]) <= float(r["kn_ci95_high"])
                     and lo <= float(r["delta_true"]) <= hi)
            assert r["ci_holds"] == str(holds)
            assert math.isfinite(float(r["kn_error"])) and math.isfinite(float(r["delta_error"]))
            # the plain fit's evaluations plus every replay's refit
            assert int(r["n_evaluations"]) > int(by[(i, plain)]["n_evaluations"])
            if float(r["noise_g"]) == 0.0:  # the replay removes most of the noise-free bias
                assert abs(float(r["delta_error"])) < 0.5 * abs(float(by[(i, plain)]
                                                                     ["delta_error"]))
    assert ran >= 4  # at least two cases ran both corrected fits
    c = m["corrected"]
    assert {s["method"] for s in c["summary"]} == methods
    assert all(s["n"] == 1 for s in c["summary"])  # every method on the same 4 cases
    assert min(c["replays_mean"].values()) >= 1
    assert set(c["ok_outside"]) == set(c["ci_holds"]) == {"network+corrected",
                                                          "multi-start+corrected"}
    assert "`ok` outside the bounds" in proc.stdout + proc.stderr
    table = (out / "compare.md").read_text()
    assert "multi-start" in table and "| noise [g] |" in table
    assert "## The 4 cases with corrected fits, every method" in table
    assert "| multi-start+corrected |" in table
    for f in ("compare_errors.png", "compare_cost.png", "compare_summary.csv"):
        assert (out / f).stat().st_size > 0


def test_compare_refuses_a_cases_cache_without_plan_index(trained, tmp_path):
    """Cases cached before plan_index: the corrected fits cannot rebuild their records."""
    import shutil

    import numpy as np

    from freeplayid.inverse import PointSets

    tmp, run = trained
    cache = tmp_path / "datasets"
    shutil.copytree(tmp / "datasets", cache)
    folders = sorted(cache.glob("cases-*"))  # train.py's, and compare.py's where it ran first
    for folder in folders:
        ps = PointSets.load(folder / "cases.npz")
        assert "plan_index" in ps.meta
        old = PointSets(**{**ps.__dict__, "meta": {k: v for k, v in ps.meta.items()
                                                    if k != "plan_index"}})
        old.save(folder / "cases.npz")
        assert np.array_equal(PointSets.load(folder / "cases.npz").kn, ps.kn)
    out = tmp_path / "compare"
    # train.py's bank (the modes above 1 kHz condensed), whose cases it cached
    proc = _run("compare.py", ["debug=fast", "compare.corrected_cases_per_value=1",
                               "dataset.bank.quasi_static_hz=1000.0", f"dataset.cache_dir={cache}",
                               f"inverse.checkpoint={run / 'checkpoint.ckpt'}",
                               f"hydra.run.dir={out}"], tmp_path)
    assert proc.returncode != 0 and "Traceback" not in proc.stderr, proc.stderr[-3000:]
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("compare: "), lines
    assert any(str(f) in lines[0] for f in folders) and "delete that folder" in lines[0]
    assert "fits" not in proc.stdout  # stopped before any fit
    assert not (out / "metrics.json").exists()


def test_fit_backbone_takes_an_inverse_model_as_its_start():
    """Any object with predict_points is asked for the start; the fit records it."""
    import numpy as np

    from freeplayid.fit import FittingPoints, fit_backbone
    from freeplayid.model.small import sdof_system

    kn, delta, m = 4.0e4, 1.0e-3, 1.0
    wn = np.sqrt(kn / m)
    amp = delta * np.array([1.5, 2.0, 3.0, 5.0])
    w = wn / (1 + 2 * delta / (np.pi * (amp - delta)))  # the exact SDOF backbone (docs/backbone.md)
    records = [{"channel": "x", "amplitude_m": a, "f_hz": q / (2 * np.pi)}
               for a, q in zip(amp, w, strict=True)]

    class Guess:
        seen = None

        def predict_points(self, points):
            Guess.seen = points.to_records()
            return 1.3 * kn, 0.8 * delta, 0.1, 0.1

    res = fit_backbone(FittingPoints.from_records(records), sdof_system(mass=m), init=Guess())
    assert res.init == "inverse" and res.start == (1.3 * kn, 0.8 * delta)
    assert [r["channel"] for r in Guess.seen] == ["x"] * 4
    assert abs(res.kn / kn - 1) < 0.02 and abs(res.delta / delta - 1) < 0.05

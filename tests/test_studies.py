"""The studies package: its place in the layout (no task imports another) and network_metrics."""

import ast
import importlib.util
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import freeplayid.inverse
import freeplayid.studies

SRC = Path(__file__).resolve().parents[1] / "src" / "freeplayid"
MOVED = ["BankSpec", "SweepBank", "DELTA_REF", "simulate_bank", "CaseSpec", "AXES",
         "build_cases", "split_by_kn", "METHODS", "network_rows", "fit_cases", "summarise",
         "network_metrics", "StudyData", "prepare_study", "train_study_network"]


def _imports(path: Path, text: str | None = None) -> set[str]:
    """Absolute names of the freeplayid modules ``path`` imports (relative imports resolved).

    ``text``: parse it as if it were the file ``path`` (default: the file's own text).
    """
    package = ["freeplayid", *path.parent.relative_to(SRC).parts]
    names = set()
    for node in ast.walk(ast.parse(path.read_text() if text is None else text)):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            mod = ".".join([*base, *([node.module] if node.module else [])])
            names.add(mod)
            names.update(f"{mod}.{a.name}" for a in node.names)  # `from . import train`
    return {n for n in names if n.startswith("freeplayid")}


def test_the_studies_moved_out_of_inverse():
    for name in MOVED:
        assert hasattr(freeplayid.studies, name), name
        assert not hasattr(freeplayid.inverse, name), name
    assert set(MOVED) <= set(freeplayid.studies.__all__)
    for gone in ("freeplayid.inverse.dataset", "freeplayid.inverse.study"):
        assert importlib.util.find_spec(gone) is None, gone
    for name in ("InverseNet", "train_inverse_model", "load_inverse_model", "PointSets"):
        assert hasattr(freeplayid.inverse, name), name


def test_inverse_does_not_import_studies():
    for path in (SRC / "inverse").glob("*.py"):
        assert not {n for n in _imports(path) if n.startswith("freeplayid.studies")}, path.name


def test_no_task_imports_another_task():
    # a task is a module named after the function it exports (helpers like common and checks
    # are shared by every task)
    import freeplayid.tasks

    tasks = {p.stem for p in (SRC / "tasks").glob("*.py")} & set(freeplayid.tasks.__all__)
    assert {"compare", "train"} <= tasks
    for name in tasks:
        imported = _imports(SRC / "tasks" / f"{name}.py")
        others = {f"freeplayid.tasks.{t}" for t in tasks - {name}}
        hits = {n for n in imported if any(n == o or n.startswith(o + ".") for o in others)}
        assert not hits, f"tasks/{name}.py imports {sorted(hits)}"
    # the case the rule was written for, spelled out
    assert "freeplayid.tasks.train" not in _imports(SRC / "tasks" / "compare.py")
    assert "freeplayid.tasks.train.prepare_cases" not in _imports(SRC / "tasks" / "compare.py")


def test_import_helper_sees_a_relative_task_import():
    """The check above can fail: relative imports of a sibling task are resolved and found."""
    text = "from .train import prepare_cases\nfrom . import simulate\nfrom .common import run_dir\n"
    names = _imports(SRC / "tasks" / "compare.py", text)
    assert {"freeplayid.tasks.train", "freeplayid.tasks.simulate"} <= names
    assert "freeplayid.tasks.common" in names


def test_network_metrics_against_hand_computed_errors():
    # two axis values, two cases each; errors chosen by hand
    test = SimpleNamespace(
        kn=np.array([400.0, 500.0, 600.0, 700.0]), delta=np.array([1e-3, 2e-3, 3e-3, 4e-3]),
        n_cases=4, meta={"axis_value": np.array([0.0, 0.0, 0.1, 0.1])},
    )
    kn_err = np.array([0.01, -0.03, 0.0, 0.05])
    d_err = np.array([0.005, 0.002, -0.02, 0.0])
    pred = SimpleNamespace(kn=test.kn * (1 + kn_err), delta=test.delta * (1 + d_err),
                           log_kn_std=np.full(4, 0.01), log_delta_std=np.full(4, 0.005))
    m = freeplayid.studies.network_metrics(test, pred, bounds={"delta": 0.01, "kn": 0.02})
    # within bounds (|d| < 1 %, |kn| < 2 %): only case 0
    assert m["overall"]["within_bounds"] == pytest.approx(0.25)
    assert m["overall"]["n"] == 4 and m["bounds"] == {"delta": 0.01, "kn": 0.02}
    assert set(m["per_value"]) == {"0", "0.1"}
    low = m["per_value"]["0"]
    assert low["n"] == 2 and low["within_bounds"] == pytest.approx(0.5)
    assert low["kn_err_median"] == pytest.approx(0.02)  # median of |0.01|, |-0.03|
    assert low["delta_err_median"] == pytest.approx(0.0035)
    # |ln(1 + e)| / sigma < 2: kn 0.01/0.01 yes, 0.03/0.01 no; delta 0.005/0.005 yes, 0.002 yes
    assert low["kn_within_2sigma"] == pytest.approx(0.5)
    assert low["delta_within_2sigma"] == pytest.approx(1.0)
    high = m["per_value"]["0.1"]
    assert high["delta_within_2sigma"] == pytest.approx(0.5)  # |ln 0.98| / 0.005 > 2
    assert high["kn_err_p90"] == pytest.approx(0.045)  # 90th percentile of 0 and 0.05


def test_corrected_metrics_count_ok_outside_the_bounds_and_intervals_holding_the_truth():
    """An `ok` answer outside the bounds is counted, and whether its intervals hold the truth
    (the noise study's 0.3 g misses were `ok` with no intervals in their rows)."""
    from freeplayid.studies.comparison import Comparison
    from freeplayid.studies.methods import summarise

    def row(case, method, d_err, k_err, verdict, holds, checks=""):
        return {"case": case, "method": method, "axis_value": 0.3, "delta_error": d_err,
                "kn_error": k_err, "n_evaluations": 10, "wall_s": 1.0, "converged": True,
                "n_replays": 3, "verdict": verdict, "ci_holds": holds, "failed_checks": checks}

    rows = [row(0, "multi-start+corrected", 0.012, 0.001, "ok", True),    # ok, outside, holds
            row(1, "multi-start+corrected", 0.015, 0.001, "ok", False),   # ok, outside
            row(2, "multi-start+corrected", 0.002, 0.025, "suspect", False,  # not ok, outside
                "replay;noise"),
            row(3, "multi-start+corrected", 0.002, 0.001, "ok", True),    # inside
            row(0, "network+corrected", 0.001, 0.001, "suspect", True,  # suspect, inside
                "replay;noise"),
            row(1, "network+corrected", 0.001, 0.0199, "suspect", False, "noise")]  # inside
    rows += [dict(r, method=m, verdict="", ci_holds=False) for r in rows[:4]
             for m in ("network", "network+fit", "single-start", "multi-start")]
    summary = summarise(rows)
    c = Comparison("noise_g", rows, summary, np.arange(4), summary, [0, 1, 2, 3], (1.0, 1.0),
                   25, 0.9, {"delta": 0.01, "kn": 0.02}).metrics()["corrected"]
    assert c["ok_outside"] == {"network+corrected": 0, "multi-start+corrected": 2}
    assert c["ok_outside_ci_holds"] == {"network+corrected": 0, "multi-start+corrected": 1}
    assert c["ci_holds"] == {"network+corrected": 0.5, "multi-start+corrected": 0.5}
    # a suspect answer inside the bounds (kn 1.99 % < 2 %) counts its failed checks; one
    # outside them (case 2: kn 2.5 %) does not
    assert c["suspect_inside_checks"] == {"network+corrected": {"noise": 2, "replay": 1},
                                          "multi-start+corrected": {}}

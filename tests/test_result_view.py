"""The result made to be looked at, and the installed commands (the notebook user's and the test
engineer's day): Identification's repr and Markdown, plot(), the points table, read_identification,
engineering units; the console entry points and the optional joblib launcher.

One plain fit (``replay=None``) of the bundled example cut to two runs (0.8 and 1.2 g) serves
every test; the numbers the tests compare with are written out here (a result with chosen kn and
delta) or come from the fit's own arrays, never from the formatting under test.
"""

import dataclasses
import io
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import matplotlib
import numpy as np
import pytest
import yaml

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "src" / "freeplayid" / "data" / "fin_sweeps"
LEVELS = {"sweep_0.80g.csv.gz": 0.8, "sweep_1.20g.csv.gz": 1.2}  # the manifest's level_g
# a result with chosen numbers: the strings below are worked out by hand from them
# (2·delta = 0.0059992 rad = 0.343729°; 2·0.0029346 = 0.33628°; 2·0.0030662 = 0.35136°)
CHOSEN = {"kn": 480.07, "delta": 0.0029996, "kn_ci95": (474.5, 485.71),
          "delta_ci95": (0.0029346, 0.0030662)}


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("two_runs")
    for f in EXAMPLE.iterdir():
        shutil.copy(f, folder / f.name)
    manifest = yaml.safe_load((folder / "manifest.yaml").read_text())
    manifest["runs"] = [r for r in manifest["runs"] if r["file"] in LEVELS]
    (folder / "manifest.yaml").write_text(yaml.safe_dump(manifest, sort_keys=False))
    return folder


@pytest.fixture(scope="module")
def result(two_runs):
    """The plain fit with the options of the command's ``debug=fast``."""
    from freeplayid import identify

    return identify(two_runs, progress=False, fit={"multistart": {"n": 3}, "n_bootstrap": 0},
                    replay=None)


@pytest.fixture(scope="module")
def chosen(result):
    return dataclasses.replace(result, **CHOSEN)


def _fake_replay(result, *, misfit: float, levels=None):
    """A replay whose curves are the measured ones 3 % higher and whose misfit is ``misfit``."""
    from freeplayid.replay import ReplayResult

    curves = tuple(dataclasses.replace(c, amplitude_m=1.03 * c.amplitude_m)
                   for c in result.points.curves)
    return ReplayResult(kn=result.kn, delta=result.delta, jump_point="drop", curves=curves,
                        misfit=dict.fromkeys(LEVELS, misfit), levels=levels or {},
                        converged=True)


# ------------------------------------------------------------------ A.1 repr and Markdown
def test_repr_is_a_few_lines_with_the_estimates_and_the_verdict(chosen):
    text = repr(chosen)
    lines = text.splitlines()
    assert len(lines) <= 5 and len(text) < 600  # the dataclass dump was 19,000 characters
    assert lines[0] == "<Identification: plain fit, dfa backbone, 4 of 4 points used>"
    assert "kn    = 480.07 N·m/rad  (95 % CI [474.5, 485.71])" in text
    assert "delta = 2.9996 mrad  (95 % CI [2.9346, 3.0662])" in text
    assert "total play 2·delta = 0.34373°" in text
    assert lines[-1] == "  verdict: ok"


def test_repr_names_the_failed_checks_of_a_suspect_result(chosen):
    from freeplayid.identification import Check, Verdict

    bad = Verdict("suspect", (Check("delta_bound", False, "delta = 0.07 rad is no freeplay"),
                              Check("residual", True, "fine")))
    assert repr(dataclasses.replace(chosen, verdict=bad)).splitlines()[-1] == (
        "  verdict: suspect (failed: delta_bound; .verdict.reasons says why)")


def test_the_dataclass_keeps_its_equality(result, chosen):
    assert dataclasses.replace(result) == result
    assert chosen != result and dataclasses.replace(result, **CHOSEN) == chosen


def test_repr_markdown_has_the_summary_and_the_verdict_table(chosen):
    md = chosen._repr_markdown_()
    for row in ("| kn [N·m/rad] | 480.07 | [474.5, 485.71] |",
                "| delta [rad] | 0.0029996 | [0.0029346, 0.0030662] |",
                "| delta [mrad] | 2.9996 | [2.9346, 3.0662] |",
                "| total play 2·delta [°] | 0.34373 | [0.33628, 0.35136] |",
                "**Verdict: ok**", "| check | passed | finding |"):
        assert row in md.splitlines(), row
    rows = [ln for ln in md.splitlines() if ln.startswith("| ") and " | yes | " in ln]
    assert [r.split(" | ")[0][2:] for r in rows] == [c.name for c in chosen.verdict.checks]


# ------------------------------------------------------------------ A.5 engineering units
def test_summary_and_report_give_delta_in_mrad_and_the_play_in_degrees(chosen):
    lines = chosen.summary().splitlines()
    assert lines[:3] == ["kn    = 480.07 N·m/rad  (95 % CI [474.5, 485.71])",
                         "delta = 0.0029996 rad = 2.9996 mrad  (95 % CI [2.9346, 3.0662] mrad)",
                         "total play 2·delta = 0.34373°  (95 % CI [0.33628, 0.35136]°)"]
    report = chosen.report(["backbone_fit.png"])
    assert "| delta [mrad] | 2.9996 | [2.9346, 3.0662] |" in report
    # a plain fit says what its verdict did not judge: the sweep's bias (a replay's does not)
    from freeplayid.identification.report import PLAIN_FIT_NOTE

    assert lines[-1] == PLAIN_FIT_NOTE and "its bias from the sweep is not measured" in report
    assert "sweep is not measured" in chosen._repr_markdown_()
    replayed = dataclasses.replace(chosen, replay=_fake_replay(chosen, misfit=0.01))
    assert PLAIN_FIT_NOTE not in replayed.summary()
    assert "sweep is not measured" not in replayed.report()
    assert "| total play 2·delta [°] | 0.34373 | [0.33628, 0.35136] |" in report
    assert "N m/rad" not in report and "| kn [N·m/rad] | 480.07 |" in report


def test_figure_titles_keep_the_digits_and_legends_name_the_levels(chosen):
    fig = chosen.plot("backbone")
    for ax, col in zip(fig.axes, ("acc_tl", "acc_lr"), strict=True):
        title = ax.get_title()
        assert title == (f"{col}: kn = 480.07 N·m/rad\ndelta = 0.0029996 rad = 2.9996 mrad, "
                         "total play 2·delta = 0.34373°")  # not "0.003" (4 significant figures)
        legend = [t.get_text() for t in ax.get_legend().get_texts()]
        assert legend == ["0.8 g", "1.2 g", "backbone"]


def test_legends_fall_back_on_the_replayed_level_then_on_the_run(result):
    from freeplayid.identification.figures import run_labels

    replayed = {run: (0.7993, "base channel") for run in LEVELS}
    no_levels = dataclasses.replace(result, dataset={**result.dataset, "levels": {}})
    assert run_labels(result) == {"sweep_0.80g.csv.gz": "0.8 g", "sweep_1.20g.csv.gz": "1.2 g"}
    assert run_labels(no_levels) == {run: run for run in LEVELS}
    with_replay = dataclasses.replace(no_levels, replay=_fake_replay(result, misfit=0.03,
                                                                     levels=replayed))
    # two runs at one level are told apart by their names
    assert run_labels(with_replay) == {run: f"0.799 g ({run})" for run in LEVELS}


def test_replay_check_says_what_its_percentage_is(result):
    rep = _fake_replay(result, misfit=0.0312)
    fig = dataclasses.replace(result, replay=rep).plot("replay")
    assert len(fig.axes) == 2
    legend = fig.axes[0].get_legend()
    assert [t.get_text() for t in legend.get_texts()] == ["0.8 g: 3.1 %", "1.2 g: 3.1 %"]
    what = legend.get_title().get_text()
    assert "median" in what and "measured peak" in what and "%" in what
    assert "N·m/rad" in fig._suptitle.get_text()
    # the dashed replayed curve is the fake's: 3 % above the measured one
    solid, dashed = fig.axes[0].get_lines()[:2]
    np.testing.assert_allclose(dashed.get_ydata(), 1.03 * solid.get_ydata())


def test_inverse_model_figures_spell_the_unit(tmp_path):
    from matplotlib.figure import Figure

    from freeplayid.plots import plot_inverse_predictions

    ax = Figure().subplots()
    plot_inverse_predictions(ax, [300.0, 500.0], [310.0, 490.0], [0.1, 0.1], quantity="kn")
    assert ax.get_xlabel() == "true kn [N·m/rad]" and ax.get_ylabel() == "network kn [N·m/rad]"


# ------------------------------------------------------------------ A.2 plot()
def test_plot_backbone_draws_every_channel_with_the_backbone_in_the_measured_band(result):
    from matplotlib.figure import Figure

    fig = result.plot("backbone")
    assert isinstance(fig, Figure) and [a.get_title().split(":")[0] for a in fig.axes] == [
        "acc_tl", "acc_lr"]
    full = result.backbone_overlay()
    for ax, col in zip(fig.axes, ("acc_tl", "acc_lr"), strict=True):
        (bb,) = [ln for ln in ax.get_lines() if ln.get_label() == "backbone"]
        f, x_mm = bb.get_xdata(), np.asarray(bb.get_ydata())
        curves = [c for c in result.points.curves if c.channel == col]
        f_lo = min(c.frequency.min() for c in curves)
        top = max(c.amplitude_m.max() for c in curves)
        assert f.min() >= f_lo - 3.0 and x_mm.max() <= 1e3 * 1.3 * top * (1 + 1e-12)
        assert full[col][0].min() < f_lo - 3.0  # the whole backbone reaches further: cropped
        used = [p for p in result.used_points if p.channel == col]
        marks = [ln for ln in ax.get_lines() if ln.get_marker() == "o"]
        assert sorted(m.get_xdata()[0] for m in marks) == sorted(p.f_hz for p in used)


def test_plot_on_a_given_axes_draws_one_channel(result):
    from matplotlib.figure import Figure

    ax = Figure().subplots()
    assert result.plot("backbone", ax=ax, channel="acc_lr") is ax
    assert ax.get_title().startswith("acc_lr: ")
    with pytest.raises(ValueError, match=r"`channel` must be one of \['acc_tl', 'acc_lr'\] when "
                                         "`ax` is given"):
        result.plot("backbone", ax=Figure().subplots())
    with pytest.raises(ValueError, match="`channel` must be one of"):
        result.plot("backbone", channel="acc_xx")


def test_plot_residuals_draws_the_fits_residuals_in_percent(result):
    fig = result.plot("residuals")
    (ax,) = fig.axes
    drawn = {ln.get_label(): ln for ln in ax.get_lines() if ln.get_marker() == "o"}
    used = result.used_points
    res = np.asarray(result.plain_fit.residuals)
    for ch in ("acc_tl", "acc_lr"):
        sel = [p.channel == ch for p in used]
        np.testing.assert_allclose(drawn[ch].get_ydata(), 100 * res[sel])
        np.testing.assert_allclose(drawn[ch].get_xdata(), [p.f_hz for p in used if p.channel == ch])


def test_plot_refuses_what_it_cannot_draw(result):
    with pytest.raises(ValueError, match=r"`kind` must be one of \['backbone', 'residuals', "
                                         r"'replay'\], got 'bode'"):
        result.plot("bode")
    with pytest.raises(ValueError, match="`kind`='replay' cannot be drawn for this result: it "
                                         "has no replay"):
        result.plot("replay")


def test_backbone_in_band_keeps_the_measured_band():
    from freeplayid.plots import backbone_in_band
    from freeplayid.signal import AmplitudeCurve

    f = np.linspace(20.0, 50.0, 31)  # [Hz]
    x = np.linspace(1.0, 4.0, 31) * 1e-3  # [m]
    curves = [AmplitudeCurve("a", "c", np.array([30.0, 40.0]), np.array([1e-3, 1.95e-3])),
              AmplitudeCurve("b", "c", np.array([]), np.array([]))]
    fk, xk = backbone_in_band((f, x), curves)
    np.testing.assert_array_equal(fk, np.arange(27.0, 36.0))  # f >= 30 - 3, x <= 2.535 mm
    np.testing.assert_allclose(xk, np.linspace(1.7, 2.5, 9) * 1e-3)


def test_the_command_writes_the_figures_the_library_draws(two_runs, result, tmp_path):
    """scripts/identify.py (the freeplayid-identify command) saves result.plot()'s figures."""
    from matplotlib.image import imread

    run = tmp_path / "run"
    cmd = [sys.executable, str(ROOT / "scripts" / "identify.py"), f"data={two_runs}",
           "debug=fast", f"hydra.run.dir={run}"]
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert sorted(p.name for p in run.iterdir()) == [
        ".hydra", "backbone_fit.png", "identification.json", "identify.log", "metrics.json",
        "report.md", "residuals.png"]
    report = (run / "report.md").read_text()
    assert "![backbone_fit.png](backbone_fit.png)" in report and "residuals.png" in report
    for kind, name in (("backbone", "backbone_fit.png"), ("residuals", "residuals.png")):
        buf = io.BytesIO()
        result.plot(kind).savefig(buf, format="png", dpi=110)
        buf.seek(0)
        mine, theirs = imread(buf), imread(run / name)
        assert mine.shape == theirs.shape and np.abs(mine - theirs).max() < 0.05, name


# ------------------------------------------------------------------ A.3 the points table
def test_points_table_has_one_row_per_point(result):
    rows = result.points_table()
    pts = result.points.points
    assert len(rows) == len(pts) == 4
    assert list(rows[0]) == ["run", "level_g", "channel", "dof", "f_hz", "amplitude_m", "used",
                             "reason", "residual", "snr_db", "noise_db", "time_s"]
    assert [(r["run"], r["channel"], r["f_hz"], r["amplitude_m"], r["used"]) for r in rows] == [
        (p.run, p.channel, p.f_hz, p.amplitude_m, p.used) for p in pts]
    assert [r["level_g"] for r in rows] == [LEVELS[p.run] for p in pts]
    assert {r["dof"] for r in rows} == {"uz_top_left", "uz_lower_right"}
    np.testing.assert_array_equal([r["residual"] for r in rows if r["used"]],
                                  result.plain_fit.residuals)


def test_to_dataframe_without_pandas_says_so_in_one_line(result, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)  # `import pandas` raises ImportError
    with pytest.raises(ImportError) as err:
        result.to_dataframe()
    msg = str(err.value)
    assert "\n" not in msg and "needs pandas" in msg and "pip install pandas" in msg


def test_to_dataframe(result):
    pd = pytest.importorskip("pandas")
    df = result.to_dataframe()
    assert isinstance(df, pd.DataFrame) and df.shape == (4, 11)
    assert df["used"].sum() == len(result.used_points)
    np.testing.assert_array_equal(df["f_hz"], [p.f_hz for p in result.points.points])
    assert df.loc[df["run"] == "sweep_1.20g.csv.gz", "level_g"].tolist() == [1.2, 1.2]


# ------------------------------------------------------------------ A.4 read_identification
def test_write_then_read_gives_the_same_result(result, tmp_path):
    from freeplayid import Identification, read_identification
    from freeplayid.io import write_identification

    path = write_identification(tmp_path, result)
    back = read_identification(tmp_path)
    assert isinstance(back, Identification)
    assert (back.kn, back.delta) == (result.kn, result.delta)
    assert back.kn_ci95 == tuple(result.kn_ci95) and back.delta_ci95 == tuple(result.delta_ci95)
    assert back.verdict.status == result.verdict.status
    assert back.verdict.reasons == result.verdict.reasons
    assert back.verdict.checks == result.verdict.checks
    def fields(points):
        return [(p.run, p.channel, p.f_hz, p.amplitude_m, p.used, p.reason) for p in points]

    assert fields(back.points.points) == fields(result.points.points)
    assert all(math.isnan(p.time_s) and math.isnan(p.snr_db) for p in back.points.points)
    # the noise floor is kept (an inverse model reads it from a saved result's points)
    np.testing.assert_array_equal([p.noise_db for p in back.points.points],
                                  [p.noise_db for p in result.points.points])
    np.testing.assert_array_equal(back.plain_fit.residuals, result.plain_fit.residuals)
    assert back.dofs == result.dofs and back.levels == result.levels == LEVELS
    assert back.rejected_runs == result.rejected_runs and back.truth == result.truth
    assert back.records.findings == result.records.findings
    assert repr(back) == repr(result) and back.summary() == result.summary()
    assert back.system is None and back.replay is None and back.points.curves == ()
    back.plot("residuals")  # the figure the file can give
    with pytest.raises(ValueError, match="not in a result read from identification.json"):
        back.plot("backbone")
    raw = read_identification(path, raw=True)
    assert raw == json.loads(path.read_text())
    from freeplayid.io import read_identification as read_record  # the old reader: the dict

    assert read_record(path) == raw


def test_read_an_older_file_and_a_corrected_one(result, tmp_path):
    from freeplayid import read_identification
    from freeplayid.io import write_identification

    record = result.to_dict()
    old = {k: v for k, v in record.items() if k not in ("dataset", "mode", "n_evaluations")}
    old["points"] = [{k: v for k, v in p.items() if k != "residual"} for p in record["points"]]
    back = read_identification(write_identification(tmp_path / "old.json", old))
    assert back.levels == dict.fromkeys(LEVELS) and back.mode == 0
    assert np.isnan(back.plain_fit.residuals).all()
    with pytest.raises(ValueError, match="it can draw nothing"):
        back.plot("residuals")
    # a corrected result's file: the plain fit is the replay's kn_fit, the levels the replay's
    rep = {"kn_fit": 470.0, "delta_fit": 2.9e-3,
           "levels": {run: {"level_g": lv, "source": "level_g"} for run, lv in LEVELS.items()}}
    corrected = {**old, "replay": rep, "interval_source": "Jacobian (moved with the estimate)"}
    back = read_identification(write_identification(tmp_path / "corr.json", corrected))
    assert (back.plain_fit.kn, back.plain_fit.delta) == (470.0, 2.9e-3)
    assert back.levels == LEVELS and back.replay is None
    assert repr(back).startswith("<Identification: corrected fit (replay), dfa backbone")


# ------------------------------------------------------------------ B.1 the commands
def _pyproject() -> dict:
    tomllib = pytest.importorskip("tomllib")
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_one_console_command_per_task():
    from freeplayid.tasks import cli

    scripts = _pyproject()["project"]["scripts"]
    assert scripts == {f"freeplayid-{n}": f"freeplayid.tasks.cli:{n}" for n in
                       ("identify", "simulate", "model", "train", "compare")}
    assert all(callable(getattr(cli, n)) for n in cli.COMMANDS)
    assert (Path(cli.CONFIG_PATH) / "identify.yaml").is_file()


def test_the_command_composes_the_packaged_configs_from_any_folder(tmp_path):
    code = ("import sys; from freeplayid.tasks.cli import identify; "
            "sys.argv[0] = 'freeplayid-identify'; identify()")
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.run([sys.executable, "-c", code, "--cfg", "job", "replay=off",
                           "debug=fast"], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    cfg = yaml.safe_load(proc.stdout)
    assert cfg["data"] is None and cfg["replay"]["enabled"] is False
    assert cfg["fit"]["multistart"]["n"] == 3
    assert list(tmp_path.iterdir()) == []  # --cfg makes no run folder


# ------------------------------------------------------------------ B.3 the joblib launcher
def test_the_joblib_launcher_is_an_extra():
    project = _pyproject()["project"]
    assert not any(d.startswith("hydra-joblib-launcher") for d in project["dependencies"])
    assert project["optional-dependencies"]["parallel"] == ["hydra-joblib-launcher>=1.2"]
    # nothing the default commands compose or import asks for a launcher plugin
    conf = ROOT / "src" / "freeplayid" / "conf"
    assert not [p for p in conf.rglob("*.yaml") if "launcher" in p.read_text()]
    src = ROOT / "src" / "freeplayid"
    assert not [p for p in src.rglob("*.py") if "import hydra_plugins" in p.read_text()
                or "from hydra_plugins" in p.read_text()]


def test_asking_for_a_missing_launcher_is_one_line(monkeypatch):
    import importlib.util

    from freeplayid.tasks import check_command_line

    real = importlib.util.find_spec

    def find_spec(name, *args):
        if name.startswith("hydra_plugins.hydra_joblib_launcher"):
            return None  # the extra is not installed
        return real(name, *args)

    argv = ["compare", "-m", "+experiment=noise,clearance", "hydra/launcher=joblib"]
    monkeypatch.setattr(importlib.util, "find_spec", find_spec)
    with pytest.raises(SystemExit) as err:
        check_command_line("compare", argv)
    assert err.value.code == ("compare: `hydra/launcher=joblib` needs the launcher plugin of the "
                              "`parallel` extra (pip install \"freeplayid[parallel]\")")
    monkeypatch.setattr(importlib.util, "find_spec", real)
    if real("hydra_plugins.hydra_joblib_launcher") is not None:  # installed: no complaint
        check_command_line("compare", argv)

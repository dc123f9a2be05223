"""Step 1 as a command: scripts/model.py (modal tests -> updated, reduced fin), the modal-test
reader, and the zero-clearance check (reference_modes) of an identification."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from freeplayid.io import ModalTestError, read_modal_test
from freeplayid.model import (
    default_fin,
    load_fin_config,
    load_system,
    modal_analysis,
    model_from_modal_test,
    part_modes,
)

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "fin_modal" / "modal.yaml"


def _model(tmp_path, *args, run="run"):
    run = tmp_path / run
    cmd = [sys.executable, str(ROOT / "scripts" / "model.py"), *args, f"hydra.run.dir={run}"]
    proc = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT / "src")})
    return proc, run


def test_example_perturbation_is_recovered(tmp_path):
    """E_out +5 %, t_in -3 % (examples/make_fin_modal.py) from the three tests' frequencies."""
    proc, run = _model(tmp_path, f"modal_test={EXAMPLE}",
                       "updating.parameters=[outboard.E,inboard.thickness]")
    assert proc.returncode == 0, proc.stderr[-3000:]
    m = json.loads((run / "metrics.json").read_text())
    assert m["parameters"]["outboard.E"]["scale"] == pytest.approx(1.05, rel=5e-3)
    assert m["parameters"]["inboard.thickness"]["scale"] == pytest.approx(0.97, rel=5e-3)
    for test in ("outboard_free", "inboard_free", "inboard_clamped"):
        assert m[test]["max_abs_error"] < 2e-3
        before = np.array(m[test]["before_hz"]) / np.array(m[test]["measured_hz"]) - 1
        assert np.abs(before).min() > 0.02  # the nominal model was off by 2.4-3.1 %
    assert m["separable"] and m["condition"] < 100 and min(m["outboard_free"]["mac"]) > 0.999
    report = (run / "report.md").read_text()
    assert "Table 8 analogue" in report and "| outboard.E | Pa |" in report
    assert "| inboard.thickness | m |" in report
    assert (run / "modes.png").stat().st_size > 0
    # the measured damping ratio (2.5 %) is the reduced model's modal damping
    sys_ = load_system(run / "model.npz")
    cfg = load_fin_config()
    modes = modal_analysis(sys_.M, sys_.closed_stiffness(cfg.kn))
    zeta = np.diag(modes.shapes.T @ sys_.C @ modes.shapes) / (2 * modes.omega)
    np.testing.assert_allclose(zeta, 0.025, rtol=1e-6)


def test_default_config_without_modal_test_is_the_default_fin(tmp_path):
    proc, run = _model(tmp_path, "plot=false")
    assert proc.returncode == 0, proc.stderr[-3000:]
    got, ref = load_system(run / "model.npz"), default_fin()
    for a, b in ((got.M, ref.M), (got.K, ref.K), (got.C, ref.C)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * np.abs(b).max())
    assert got.dof_names == ref.dof_names and got.hinge_pairs == ref.hinge_pairs
    np.testing.assert_array_equal(got.base_influence, ref.base_influence)
    assert not json.loads((run / "metrics.json").read_text())["updated"]


def _bad_file(tmp_path, doc):
    path = tmp_path / "modal.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


@pytest.mark.parametrize("case, match", [
    ("unknown_point", "unknown point(s) ['nowhere']"),
    ("few_modes", "1 measured mode(s) for 2 parameters"),
    ("unpaired", "pairs with no model mode"),
])
def test_bad_modal_input_is_one_line_exit_1(tmp_path, case, match):
    modes = yaml.safe_load(EXAMPLE.read_text())
    out = modes["outboard_free"]["modes"]
    if case == "unknown_point":
        out[0]["shape"]["nowhere"] = out[0]["shape"].pop("tip_mid")
        doc = {"points": modes["points"], "outboard_free": {"modes": out}}
    elif case == "few_modes":
        doc = {"inboard_free": {"modes": modes["inboard_free"]["modes"][:1]}}
    else:  # mode 0's shape replaced by one no model mode has
        out[0]["shape"] = {"top_left": 1.0, "lower_right": 1.0, "tip_mid": 1.0,
                           "tip_trailing": 1.0, "mid_leading": -1.0}
        doc = {"points": modes["points"], "outboard_free": {"modes": out}}
    proc, _ = _model(tmp_path, f"modal_test={_bad_file(tmp_path, doc)}", "plot=false",
                     "updating.parameters=[outboard.E,inboard.E]" if case == "few_modes" else
                     "updating.parameters=[outboard.E]")
    assert proc.returncode == 1
    assert "Traceback" not in proc.stderr
    last = proc.stderr.strip().splitlines()
    assert len(last) == 1 and match in last[0] and "modal.yaml" in last[0], proc.stderr


def test_reader_errors_name_file_and_field(tmp_path):
    for doc, match in (
        ({"outboard_free": {"modes": [{"damping": 0.01}]}},
         "modes[0]: missing field `frequency_hz`"),
        ({"outboard_free": {"modes": [{"frequency_hz": "fast"}]}}, "modes[0].frequency_hz must be"),
        ({"outboard_free": {"modes": [{"frequency_hz": -3.0}]}}, "must be a finite number > 0"),
        ({"wing_free": {"modes": [{"frequency_hz": 3.0}]}}, "unknown field(s) ['wing_free']"),
        ({"outboard_free": {"modes": [{"frequency_hz": 3.0, "shape": {"top_left": 1.0}},
                                      {"frequency_hz": 4.0}]}}, "for every mode of the test"),
    ):
        with pytest.raises(ModalTestError, match=None) as err:
            read_modal_test(_bad_file(tmp_path, doc))
        assert match in str(err.value) and "modal.yaml" in str(err.value)


def test_uff55_modes_are_read_like_yaml_ones(tmp_path):
    """UFF dataset 55 (pyuff): frequencies, damping, Uz shapes at nodes named in `points`."""
    import pyuff

    cfg = load_fin_config()
    pts = {"101": (0.0, 0.26), "102": (0.2, 0.116), "103": (0.1, 0.26), "104": (0.2, 0.26)}
    f, phi = part_modes(cfg, "outboard_free", n_modes=3, points=list(pts), coordinates=pts)
    uff = pyuff.UFF(str(tmp_path / "out.unv"))
    for i in range(3):
        uff.write_sets(pyuff.prepare_55(
            model_type=1, analysis_type=2, data_ch=2, spec_data_type=12, data_type=2,
            n_data_per_node=3, node_nums=np.array([101, 102, 103, 104]), r1=np.zeros(4),
            r2=np.zeros(4), r3=phi[:, i], mode_n=i + 1, freq=f[i], modal_m=1.0,
            modal_damp_vis=0.01, modal_damp_his=0.0, id1="mode", load_case=1), mode="add")
    path = tmp_path / "modal.yaml"
    path.write_text(yaml.safe_dump({"points": {k: list(v) for k, v in pts.items()},
                                    "outboard_free": {"uff": "out.unv"}}))
    test = read_modal_test(path)
    m = test.tests["outboard_free"]
    np.testing.assert_allclose(m.frequencies_hz, f, rtol=1e-5)  # UFF: 6 digits
    np.testing.assert_allclose(m.damping, 0.01)
    assert m.points == tuple(pts)
    build = model_from_modal_test(cfg, test, parameters=["outboard.E"])
    assert build.parameters["outboard.E"][2] == pytest.approx(1.0, abs=1e-4)
    assert np.all(build.comparisons["outboard_free"].mac_after > 0.999)


def test_clamp_spring_absorbs_a_compliant_fixture():
    """A clamped test on a compliant fixture: updating the clamp spring with inboard E recovers
    E, which a rigid clamp would bias."""
    from freeplayid.model import MeasuredModes, ModalTest

    cfg = load_fin_config()
    truth = cfg.with_part("inboard", E=1.02 * cfg.parts["inboard"].E)
    k_true = 2.0e4  # [N m/rad per m]
    free, _ = part_modes(truth, "inboard_free", n_modes=2)
    clamped, _ = part_modes(truth, "inboard_clamped", n_modes=3, clamp_stiffness=k_true)
    test = ModalTest({"inboard_free": MeasuredModes(free, np.nan),
                      "inboard_clamped": MeasuredModes(clamped, np.nan)})
    b = model_from_modal_test(cfg, test, parameters=["inboard.E", "clamp.k_theta"],
                              clamp_stiffness=1.0e4)
    assert b.parameters["inboard.E"][2] == pytest.approx(1.02, rel=5e-3)
    assert b.clamp_stiffness == pytest.approx(k_true, rel=2e-2)
    rigid = model_from_modal_test(cfg, test, parameters=["inboard.E"])
    assert max(abs(c.error).max() for c in rigid.comparisons.values()) > 5 * max(
        abs(c.error).max() for c in b.comparisons.values())


def test_non_separable_parameters_are_flagged():
    cfg = load_fin_config()
    f, _ = part_modes(cfg, "outboard_free", n_modes=3)
    from freeplayid.model import MeasuredModes, ModalTest

    test = ModalTest({"outboard_free": MeasuredModes(1.01 * f, np.nan)})
    b = model_from_modal_test(cfg, test, parameters=["outboard.E", "outboard.thickness"])
    assert not b.separable and "not separately identifiable" in b.report()


def test_identify_reports_the_zero_clearance_check(tmp_path):
    """reference_modes in the manifest -> Identification.validation, identification.json and the
    report's Table 11 analogue (pass / fail per mode)."""
    from freeplayid import identify
    from freeplayid.io import read_dataset

    src = ROOT / "examples" / "fin_sweeps"
    man = yaml.safe_load((src / "manifest.yaml").read_text())
    man["runs"] = [r for r in man["runs"] if r["level_g"] in (0.8, 1.2)]
    for r in man["runs"] + [{"file": "model.npz"}]:
        shutil.copy(src / r["file"], tmp_path / r["file"])
    fin = default_fin()
    dofs = ["uz_top_left", "uz_lower_right", "rx_left_out", "rx_mid_out"]
    modes = modal_analysis(fin.M, fin.closed_stiffness(man["truth"]["kn"]))
    shapes = modes.shapes[fin.dof_index(dofs), :2]
    ref = [{"frequency_hz": float(modes.frequencies_hz[i]) + (5.0 if i == 1 else 0.0),
            "shape": {d: float(shapes[j, i]) for j, d in enumerate(dofs)}} for i in range(2)]
    man["reference_modes"] = {"modes": ref}
    (tmp_path / "manifest.yaml").write_text(yaml.safe_dump(man))
    ds = read_dataset(tmp_path)
    assert sorted(ds.reference_modes["dofs"]) == sorted(dofs)
    # the model as it is (by default it is first updated to the sealed modes, which moves mode 2
    # onto its reference: test_real_tests.py)
    result = identify(ds, progress=False, fit={"multistart": {"n": 3}}, replay=None,
                      model={"update": False})
    v = result.validation
    assert v.mac.min() > 0.999 and abs(v.error_hz[0]) < 1.0 and v.error_hz[1] < -4.0
    assert not v.passed  # mode 2 is 5 Hz off
    assert result.to_dict()["validation"]["passed"] is False
    report = result.report()
    assert "Zero-clearance check (Table 11 analogue)" in report and "| NO |" in report
    # a DOF the model does not have is a one-line data-set error
    man["reference_modes"]["modes"][0]["shape"]["uz_nose"] = 1.0
    (tmp_path / "manifest.yaml").write_text(yaml.safe_dump(man))
    from freeplayid.io import DatasetError

    with pytest.raises(DatasetError, match="reference_modes"):
        read_dataset(tmp_path)


def test_each_parts_measured_damping_reaches_the_modes():
    """Outboard tests at 1 %, inboard at 4 %: each part's mean ratio, and each zero-clearance
    mode's ratio between them by its strain energy (the hinge springs at the mean of all);
    the fin's C carries them; the report and metrics say so."""
    from freeplayid.model import MeasuredModes, ModalTest

    cfg = load_fin_config()
    out, _ = part_modes(cfg, "outboard_free", n_modes=2)
    inb, _ = part_modes(cfg, "inboard_clamped", n_modes=2)
    test = ModalTest({"outboard_free": MeasuredModes(out, 0.01),
                      "inboard_clamped": MeasuredModes(inb, [0.04, np.nan])})
    b = model_from_modal_test(cfg, test)
    assert dict(b.config.part_zeta) == pytest.approx({"inboard": 0.04, "outboard": 0.01})
    assert b.zeta == pytest.approx(0.02)  # the mean of the three measured ratios
    z = np.array([r for _, r in b.mode_zeta])
    assert np.all((z > 0.01) & (z < 0.04)) and np.ptp(z[:3]) > 2e-3
    modes = modal_analysis(b.system.M, b.system.closed_stiffness(cfg.kn))
    w = 2 * np.pi * modes.frequencies_hz
    np.testing.assert_allclose(
        np.einsum("ij,ik,kj->j", modes.shapes, b.system.C, modes.shapes) / (2 * w), z, rtol=1e-6)
    assert "strain energy" in b.report() and "inboard 0.04" in b.report()
    assert b.metrics()["part_zeta"] == pytest.approx({"inboard": 0.04, "outboard": 0.01})
    # one ratio for every test: every mode at it, as before
    same = model_from_modal_test(cfg, ModalTest({"outboard_free": MeasuredModes(out, 0.025)}))
    assert np.allclose([r for _, r in same.mode_zeta], 0.025, rtol=1e-9)

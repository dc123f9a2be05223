"""The plausibility verdict: wrong units, quantity or channel mapping end `suspect`, not confident.

Fit checks are tested on exact backbone points of the example's model (made by the DFA backbone
itself, so the fit is exact and only the verdict is under test); data checks on the bundled
example with its manifest altered; one run of `scripts/identify.py` shows the command's refusal.
"""

import dataclasses
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.stats
import yaml

from freeplayid.backbone import dfa_backbone
from freeplayid.fit import FittingPoints, fit_backbone
from freeplayid.identification.verdict import (
    LIMITS,
    answer_checks,
    base_level_checks,
    fit_checks,
    make_verdict,
)
from freeplayid.io import read_dataset
from freeplayid.model import load_system
from freeplayid.replay import ReplayIteration
from freeplayid.signal import BackbonePoint, BackbonePoints

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "fin_sweeps"
KN, DELTA = 480.0, 3e-3
DOFS = ("uz_top_left", "uz_lower_right")


@pytest.fixture(scope="module")
def system():
    return load_system(EXAMPLE / "model.npz")


@pytest.fixture(scope="module")
def exact(system):
    """Points on the model's own DFA backbone at Theta/delta = 2.5 ... 4.5, both channels."""
    s = np.array([2.5, 3.0, 3.5, 4.5])
    bc = dfa_backbone(system, kn=KN, delta=DELTA, s=s)
    f = bc.frequency_hz[0]
    amp = {d: bc.amplitude[0][:, system.dof_names.index(d)] for d in DOFS}
    runs = [f"run{k}" for k in range(s.size)]
    channel = tuple(d for _ in s for d in DOFS)
    points = FittingPoints(channel=channel,
                           amplitude_m=np.array([amp[d][k] for k in range(s.size) for d in DOFS]),
                           f_hz=np.repeat(f, len(DOFS)), run=tuple(np.repeat(runs, len(DOFS))))
    extraction = BackbonePoints(
        tuple(BackbonePoint(r, d, fk, a, True, "", 0.0, 30.0)
              for r, fk, a, d in zip(points.run, points.f_hz, points.amplitude_m, channel,
                                     strict=True)),
        (), (), "acceleration", "acmp")
    return points, extraction


def _verdict(points, extraction, system):
    fit = fit_backbone(points, system, init=(KN, DELTA))
    return fit, make_verdict(fit_checks(points, fit, system, extraction))


def test_exact_points_are_ok(exact, system):
    fit, v = _verdict(*exact, system)
    # exact up to the fit's interpolation of the backbone between grid points
    assert fit.delta == pytest.approx(DELTA, rel=1e-4) and fit.kn == pytest.approx(KN, rel=1e-4)
    assert v.status == "ok", v.reasons
    margin = next(c for c in v.checks if c.name == "contact_margin")
    assert margin.value == pytest.approx(2.5, rel=1e-3)


def test_two_runs_leave_no_noise_measure_and_the_reason_says_so(exact, system):
    # found on a Rayleigh-damped fin whose lower levels did not jump: two runs' points, an
    # accurate answer, and intervals (0, inf) that the reason called only "wider than the
    # estimate"
    points, extraction = exact
    two = [i for i, r in enumerate(points.run) if r in ("run0", "run1")]
    few = FittingPoints(channel=tuple(points.channel[i] for i in two),
                        amplitude_m=points.amplitude_m[two], f_hz=points.f_hz[two],
                        run=tuple(points.run[i] for i in two))
    fit = fit_backbone(few, system, init=(KN, DELTA))
    # each run one observation (what the replay's intervals rest on): two fit exactly
    assert fit.kn_ci95_by_run == (0.0, math.inf) and fit.delta_ci95_by_run == (0.0, math.inf)
    checks = answer_checks(few, fit.kn, fit.delta, fit.kn_ci95_by_run, fit.delta_ci95_by_run,
                           system)
    v = make_verdict(checks)
    assert v.status == "suspect"
    (reason,) = [r for r in v.reasons if "interval" in r]
    assert "only 2 runs gave points" in reason
    # four runs: finite intervals, and no word of too few runs
    full = fit_backbone(exact[0], system, init=(KN, DELTA))
    assert np.isfinite(full.kn_ci95_by_run[1])
    check = next(c for c in answer_checks(exact[0], KN, DELTA, (0.0, math.inf), (1e-3, 4e-3),
                                          system) if c.name == "interval_width")
    assert not check.passed and "only" not in check.message


def test_swapped_channel_mapping_is_suspect(exact, system):
    points, extraction = exact
    swap = dict(zip(DOFS, DOFS[::-1], strict=True))
    wrong = dataclasses.replace(points, channel=tuple(swap[c] for c in points.channel))
    _, v = _verdict(wrong, extraction, system)
    assert v.status == "suspect"
    assert any("Theta/delta" in r or "exceeds" in r or "residual" in r for r in v.reasons)


def test_amplitudes_in_mg_read_as_g_are_suspect(exact, system):
    # every amplitude x 1000 -> delta x 1000 (3 rad), by scale invariance the only change; a
    # factor 1/9.81 (g read as m/s^2) gives a plausible delta: only the base channel tells
    # (test_base_channel_against_level)
    points, extraction = exact
    bad = dataclasses.replace(points, amplitude_m=points.amplitude_m * 1000.0)
    fit = fit_backbone(bad, system)
    v = make_verdict(fit_checks(bad, fit, system, extraction))
    assert v.status == "suspect"
    assert not next(c for c in v.checks if c.name == "delta_bound").passed


def test_channels_of_one_run_on_different_resonances_are_suspect(exact, system):
    points, extraction = exact
    moved = list(extraction.points)
    moved[0] = dataclasses.replace(moved[0], f_hz=moved[0].f_hz * 1.05)
    ex = dataclasses.replace(extraction, points=tuple(moved))
    _, v = _verdict(points, ex, system)
    check = next(c for c in v.checks if c.name == "channel_agreement")
    assert not check.passed and "run0" in check.message
    assert check.value > LIMITS["channel_spread"]


@pytest.fixture(scope="module")
def example():
    return read_dataset(EXAMPLE, check_model=False)


def _scaled(ds, k, **changes):
    runs = tuple(dataclasses.replace(r, data=r.data * k, base=r.base * k) for r in ds.runs)
    return dataclasses.replace(ds, runs=runs, **changes)


@pytest.mark.parametrize("change, words", [
    (lambda ds: ds, None),
    (lambda ds: dataclasses.replace(ds, units="m/s^2"), "g declared as m/s^2"),
    (lambda ds: _scaled(ds, 1000.0), "mg"),
    (lambda ds: _scaled(ds, 9.80665), "m/s^2 declared as g"),
    (lambda ds: dataclasses.replace(ds, quantity="displacement", units="m"),
     "look like acceleration, the manifest says displacement"),
    (lambda ds: dataclasses.replace(ds, quantity="velocity", units="m/s"),
     "look like acceleration, the manifest says velocity"),
    (lambda ds: _scaled(ds, 0.5), "0.5 x `level_g`"),
    (lambda ds: dataclasses.replace(ds, runs=tuple(dataclasses.replace(r, sweep=None)
                                                   for r in ds.runs)), None),
])
def test_base_channel_against_level(example, change, words):
    (check,) = base_level_checks(change(example))
    if words is None:
        assert check.passed, check.message
        assert check.value == pytest.approx(1.0, abs=0.02)
    else:
        assert not check.passed and words in check.message, check.message


def test_identify_script_refuses_a_suspect_result(tmp_path):
    """Swapped accelerometer mapping on the example cut to two runs: non-zero exit, one line
    saying why; allow_suspect=true accepts it and the verdict is in identification.json."""
    data = tmp_path / "swapped"
    shutil.copytree(EXAMPLE, data)
    m = yaml.safe_load((data / "manifest.yaml").read_text())
    m["runs"] = [r for r in m["runs"] if r["level_g"] in (0.8, 1.2)]
    m["channels"] = dict(zip(m["channels"], list(m["channels"].values())[::-1], strict=True))
    (data / "manifest.yaml").write_text(yaml.safe_dump(m, sort_keys=False))
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    run = tmp_path / "run"
    cmd = [sys.executable, str(ROOT / "scripts" / "identify.py"), f"data={data}", "debug=fast",
           "plot=false", f"hydra.run.dir={run}"]
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True)
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith("identify: the result is suspect") and "allow_suspect" in last
    rec = yaml.safe_load((run / "identification.json").read_text())
    assert rec["verdict"] == "suspect" and rec["verdict_reasons"]


def test_a_binding_that_jumps_is_suspect():
    # replays 3 and 4 of a noisy compare-like case (kn 327 N m/rad, delta 1.32 mrad, 0.2 g):
    # delta moved by 0.55 % and the replayed fit's delta by 5.4 % (a run's point changed branch)
    from freeplayid.identification.replay_checks import replay_checks

    def it(kn, delta, kn_rep, delta_rep):
        return ReplayIteration(kn, delta, kn_rep, delta_rep, n_evaluations=10)

    class Rep:  # the ReplayResult fields replay_checks reads
        failure, misfit, sweeps, damping, converged = "", {}, {}, None, True
        iterations = [it(353.9, 1.4612e-3, 381.10, 1.6099e-3),
                      it(328.8, 1.3263e-3, 358.67, 1.5052e-3),
                      it(322.97, 1.2741e-3, 354.43, 1.46688e-3),
                      it(322.29, 1.2667e-3, 348.12, 1.39025e-3)]

    checks = {c.name: c for c in replay_checks(Rep())}
    assert not checks["replay_binding"].passed
    assert "delta jumped by 5.4 %" in checks["replay_binding"].message
    Rep.iterations = Rep.iterations[:3]  # a smooth approach: 8 % and 4 % moves for 9 % and 4 %
    assert {c.name: c for c in replay_checks(Rep())}["replay_binding"].passed


@pytest.mark.parametrize("run, runs, without, passed", [
    ("r0", 6, (-7e-4, -1.3e-3), True),   # the default fin at 0.47 g (realtests): set aside
    ("r0", 6, (2e-3, -8e-3), False),     # without it delta moves 0.8 %: it rests on it
    ("r0", 6, (1.5e-2, 0.0), False),     # kn 1.5 %
    ("r0", 6, None, False),              # not measured
    ("r0", 3, (-7e-4, -1.3e-3), False),  # three runs: none can be set aside
    (None, 6, None, False),              # no one run makes the jump
])
def test_a_binding_jump_one_run_makes_is_set_aside_where_the_answer_does_not_rest_on_it(
        run, runs, without, passed):
    """The jump of the realtests' default fin at 0.47-1 g (its lowest run jumping near
    contact): the replayed fit's delta -25 % for a 1.4 % move of delta. It passes where one
    run makes it, of four or more, and the answer without that run moves by no more than half
    the bounds (delta 0.5 %, kn 1 %), as a run off the backbone is set aside; the reason names
    the run wherever it was found."""
    from freeplayid.identification.replay_checks import replay_checks
    from freeplayid.replay import BindingJump

    class Rep:
        failure, misfit, sweeps, damping, converged = "", {}, {}, None, True
        iterations = [ReplayIteration(482.86, 3.0431e-3, 485.16, 3.0839e-3, 9),
                      ReplayIteration(480.04, 2.9998e-3, 424.69, 2.3131e-3, 18)]
        binding_jump = BindingJump(after=1, parameter="delta", move=0.2876, cause=0.0143,
                                   run=run, runs=runs, without=without)

    check = {c.name: c for c in replay_checks(Rep())}["replay_binding"]
    assert check.passed is passed
    assert "delta jumped by 29 % when the replayed delta moved by 1.4 %" in check.message
    assert (f"run {run} changes branch" in check.message) is (run is not None)
    assert ("does not rest on that run" in check.message) is passed
    # without the run's attribution the check reads the iterations alone, as before
    Rep.binding_jump = None
    assert not {c.name: c for c in replay_checks(Rep())}["replay_binding"].passed


def test_a_binding_across_a_move_of_the_damping_exponent_is_not_read_as_a_jump():
    # the exponent's probe: the same (kn, delta) replayed at p = 0.5 fits 3 % elsewhere, which
    # is the damping's doing, not a point changing branch
    from freeplayid.identification.replay_checks import replay_checks

    class Rep:
        failure, misfit, sweeps, damping, converged = "", {}, {}, None, True
        iterations = [ReplayIteration(480.0, 3e-3, 482.0, 3.05e-3, 10, exponent=None),
                      ReplayIteration(480.0, 3e-3, 482.0, 3.14e-3, 10, exponent=0.5)]

    assert {c.name: c for c in replay_checks(Rep())}["replay_binding"].passed
    Rep.iterations[1] = dataclasses.replace(Rep.iterations[1], exponent=0.01)
    assert not {c.name: c for c in replay_checks(Rep())}["replay_binding"].passed


def test_a_binding_across_a_move_of_zeta_inside_the_forms_loop_is_not_read_as_a_jump():
    # var3_beam_kn3500_d3 d0 (realtests): the step after the hinge share's probe moved zeta
    # from 2.57 to 2.11 % with q nearly still, and the replayed fit's delta by 1.2 % for a
    # 0.1 % move of delta: zeta's doing. Outside the form's loop (no q) the pair is compared.
    from freeplayid.identification.replay_checks import replay_checks

    def it(kn, delta, kn_rep, delta_rep, zeta, hinge):
        return ReplayIteration(kn, delta, kn_rep, delta_rep, 10, zeta=zeta, hinge=hinge)

    class Rep:
        failure, misfit, sweeps, damping, converged = "", {}, {}, None, True
        iterations = [it(3499.3, 2.99404e-3, 3500.0, 3.0e-3, 0.02571, 0.10),
                      it(3493.4, 2.99133e-3, 3495.0, 3.036e-3, 0.02114, 0.105)]

    assert {c.name: c for c in replay_checks(Rep())}["replay_binding"].passed
    Rep.iterations = [dataclasses.replace(i, hinge=None) for i in Rep.iterations]
    assert not {c.name: c for c in replay_checks(Rep())}["replay_binding"].passed


def test_an_estimated_damping_form_reports_how_far_it_moved_the_answer():
    from types import SimpleNamespace

    from freeplayid.identification.replay_checks import replay_checks
    from freeplayid.replay import ReplayDamping

    damping = ReplayDamping("estimated", 0.02, (0.019, 0.021), exponent=0.9,
                            exponent_estimated=True, trend_single=-0.28,
                            single_ratio_answer=(480.0, 3e-3))
    rep = SimpleNamespace(failure="", misfit={}, sweeps={}, damping=damping, converged=True,
                          iterations=[], excitation="measured", kn=480.0, delta=3.03e-3,
                          jump_point="quadrature")
    check = {c.name: c for c in replay_checks(rep)}["damping_form"]
    assert check.passed and "moved the answer by delta +1 %, kn +0 %" in check.message
    assert "-28 % per e-fold of level with one ratio" in check.message
    assert check.value == pytest.approx(math.log(1.01) / 0.01)  # over the 1 % bound
    rep.damping = dataclasses.replace(damping, exponent_estimated=False)
    assert "damping_form" not in {c.name for c in replay_checks(rep)}


@pytest.mark.parametrize("delta, kn, passed", [(3.019e-3, 480.0, True), (3.025e-3, 480.0, False),
                                               (3e-3, 480.0 * 1.045, False)])
def test_a_damping_form_that_moved_the_answer_beyond_twice_the_bounds_fails(delta, kn, passed):
    """The answer rests on the estimated form where it moved it by more than twice the accuracy
    bounds (delta 2 %, kn 4 %): delta +0.63 % passes, +0.83 % and kn +4.4 % fail, naming it."""
    from types import SimpleNamespace

    from freeplayid.identification.replay_checks import replay_checks
    from freeplayid.replay import ReplayDamping

    damping = ReplayDamping("estimated", 0.02, (0.019, 0.021), hinge=0.09, hinge_estimated=True,
                            trend_single=-0.35, single_ratio_answer=(480.0, 2.96e-3))
    rep = SimpleNamespace(failure="", misfit={}, sweeps={}, damping=damping, converged=True,
                          iterations=[], excitation="measured", kn=kn, delta=delta,
                          jump_point="quadrature")
    check = {c.name: c for c in replay_checks(rep)}["damping_form"]
    assert check.passed is passed
    assert "the hinge damper's share 0.09" in check.message
    assert ("rests on the form the replay gave the damping" in check.message) is not passed


@pytest.mark.parametrize("converged, closest, passed, words", [
    (True, None, True, "converged in 2 replays"),
    (False, 0.1, True, "within 0.1 of their standard error"),
    (False, 0.6, False, "misses the test's statistics by 0.6 of"),
    (False, None, False, "did not converge in 2 replays"),  # two runs: no noise scale
])
def test_an_unconverged_loop_within_the_noise_is_as_good_as_converged(converged, closest,
                                                                        passed, words):
    from freeplayid.identification.replay_checks import replay_checks

    class Rep:
        failure, misfit, sweeps, damping = "", {}, {}, None
        iterations = [ReplayIteration(500.0, 2e-3, 510.0, 2.05e-3, n_evaluations=10),
                      ReplayIteration(490.0, 1.95e-3, 500.1, 2.0e-3, n_evaluations=10)]

    Rep.converged, Rep.closest_misfit_se = converged, closest
    check = {c.name: c for c in replay_checks(Rep())}["replay_converged"]
    assert check.passed is passed and words in check.message


def test_the_misfit_in_standard_errors_follows_the_by_run_intervals():
    from types import SimpleNamespace

    from freeplayid.replay.statistic import misfit_in_se

    pts = [SimpleNamespace(run=r) for r in ("a", "a", "b", "b", "c", "c", "d", "d", "e", "e")]
    # 5 runs: 3 degrees of freedom, t = 3.182; log half-widths 0.03 (kn) and 0.05 (delta)
    ci = ((500 * np.exp(-0.03), 500 * np.exp(0.03)), (2e-3 * np.exp(-0.05), 2e-3 * np.exp(0.05)))
    se = np.array([0.03, 0.05]) / 3.182446305284263
    F = np.array([0.001, -0.004])
    assert misfit_in_se(F, ci, pts, None) == pytest.approx(np.max(np.abs(F) / se))
    ratios = np.array([0.01, -0.01, 0.02, 0.0, -0.02])
    se_r = 1.2533 * np.std(ratios, ddof=1) / np.sqrt(5)
    assert misfit_in_se(np.r_[F, 0.02], ci, pts, ratios) == pytest.approx(0.02 / se_r)
    assert misfit_in_se(F, ci, pts[:4], None) is None  # two runs: nothing measures the noise
    assert misfit_in_se(F, ((0.0, np.inf), ci[1]), pts, None) is None


@pytest.mark.parametrize("offset, peak, passed", [(5e-3, 0.01, False), (-3e-3, 0.0, False),
                                                  (1e-3, 0.01, True), (1e-3, 0.15, True)])
def test_the_replay_misfit_check_reads_each_runs_point_against_the_backbone(offset, peak, passed):
    """A run whose replayed phase resonance sits off the measured one's place against the
    backbone by more than LIMITS['backbone_offset'] fails, naming the run; a peak that differs
    while the points sit where the test has them is reported, not failed."""
    from freeplayid.identification.replay_checks import replay_checks
    from freeplayid.replay.misfit import RunMisfit

    class Rep:
        failure, misfit, sweeps, damping, converged = "", {}, {}, None, True
        jump_point, excitation, cross = "quadrature", "measured", None
        iterations = [ReplayIteration(480.0, 3e-3, 480.0, 3e-3, n_evaluations=10)]
        resonance = {"run_a": RunMisfit("run_a", 1e-4, 40.0, 2e-4, 0.0, 0.01),
                     "run_b": RunMisfit("run_b", 2e-3, 42.0, offset, peak, 0.02)}

    check = {c.name: c for c in replay_checks(Rep())}["replay_misfit"]
    assert check.passed is passed
    assert ("run_b" in check.message) is (not passed)
    assert "run_a" not in check.message
    if passed and peak > LIMITS["peak_amplitude"]:
        assert "damping is not the test's" in check.message


@pytest.mark.parametrize("branch_b, branch_a, jump_point, passed", [
    (0.012, 0.004, "quadrature", True), (0.025, 0.022, "quadrature", False),
    (0.025, 0.004, "quadrature", True), (0.025, 0.022, "drop", None)])
def test_the_branch_check_reads_the_upper_branches_where_the_points_rest_on_the_base_phase(
        branch_b, branch_a, jump_point, passed):
    """With phase-resonance points (read against the base channel's phase) runs whose replayed
    upper branches miss the measured ones by more than LIMITS['branch'] of the peak (the median
    run's) fail, naming them and the base channel's timing; one run off alone passes (a damping's
    form); with drop points the check is not made."""
    from freeplayid.identification.replay_checks import replay_checks
    from freeplayid.replay.misfit import RunMisfit

    class Rep:
        failure, misfit, sweeps, damping, converged = "", {}, {}, None, True
        excitation, cross = "measured", None
        iterations = [ReplayIteration(480.0, 3e-3, 480.0, 3e-3, n_evaluations=10)]
        resonance = {"run_a": RunMisfit("run_a", 1e-4, 40.0, 2e-4, 0.0, branch_a),
                     "run_b": RunMisfit("run_b", 1e-4, 42.0, 1e-4, 0.01, branch_b)}

    Rep.jump_point = jump_point
    checks = {c.name: c for c in replay_checks(Rep())}
    if passed is None:
        assert "replay_branch" not in checks
        return
    check = checks["replay_branch"]
    assert check.passed is passed
    assert check.value == pytest.approx(np.median([branch_a, branch_b]) / LIMITS["branch"])
    assert checks["replay_misfit"].passed  # the points themselves are reproduced
    if not passed:
        assert "run_b" in check.message and "run_a" in check.message
        assert "out of step" in check.message


def _points_with_directions(directions: dict) -> BackbonePoints:
    """One used point and one analysed curve per run, the curve sweeping as ``directions`` says
    (+1 up, -1 down); a run named ``*_unused`` gets its point rejected."""
    from freeplayid.signal import AmplitudeCurve

    pts, curves = [], []
    for run, d in directions.items():
        f = np.linspace(30.0, 46.5, 50)[::d]
        used = not run.endswith("_unused")
        pts.append(BackbonePoint(run, "acc", 40.0, 1e-4, used, "" if used else "too noisy",
                                 10.0, 30.0))
        curves.append(AmplitudeCurve(run, "acc", f, np.ones_like(f)))
    return BackbonePoints(tuple(pts), (), tuple(curves), "acceleration", "acmp")


def test_a_down_sweep_fails_the_plain_fit_and_passes_the_replay():
    """Down-sweep runs with used points (jump-ups: no backbone points) make the plain fit
    `suspect` with a reason that says why; the replayed answer passes with a note; up-sweeps and
    down-sweeps without a used point raise nothing."""
    from freeplayid.identification.verdict import down_sweep_runs, sweep_direction_check

    mixed = _points_with_directions({"up": 1, "down": -1, "down_unused": -1})
    assert down_sweep_runs(mixed) == ("down",)
    plain = sweep_direction_check(mixed, replayed=False)
    assert not plain.passed and "run(s) down sweep down" in plain.message
    assert "biased" in plain.message and "down_unused" not in plain.message
    assert sweep_direction_check(mixed, replayed=True).passed
    assert sweep_direction_check(_points_with_directions({"a": 1, "b": 1}), replayed=False) is None


def test_a_down_sweeps_answer_resting_on_an_unmeasured_damping_beyond_the_bounds_is_suspect():
    """The damping's stated uncertainty moves the answer within the bounds: a note, passed;
    beyond them (either parameter): suspect, naming the damping and what measures it."""
    from freeplayid.identification.verdict import LIMITS, sweep_direction_check
    from freeplayid.replay import DampingSensitivity

    mixed = _points_with_directions({"up": 1, "down": -1})
    kn, dl = LIMITS["damping_kn"], LIMITS["damping_delta"]
    within = sweep_direction_check(mixed, replayed=True, damping=DampingSensitivity(
        0.25, 0.6 * kn, 0.3 * dl, ("down",)))
    assert within.passed and "as good as that damping" in within.message
    for shifts in ((1.2 * kn, 0.3 * dl), (0.5 * kn, 1.1 * dl)):
        beyond = sweep_direction_check(mixed, replayed=True,
                                       damping=DampingSensitivity(0.25, *shifts, ("down",)))
        assert not beyond.passed and beyond.value == pytest.approx(max(
            shifts[0] / kn, shifts[1] / dl))
        assert "do not measure the damping" in beyond.message
        assert "up-sweep run" in beyond.message and "replay.damping" in beyond.message
    # the replays at the higher damping did not converge: their closest replay's move, within
    # the bounds, is no measurement (realtests var3_fin_damper_down_sweep d1: kn +3.56 %, the
    # move 1.6 % at one engine, 3.1 % at the next, that solve unconverged): suspect, saying so
    unsettled = sweep_direction_check(mixed, replayed=True, damping=DampingSensitivity(
        0.25, 0.6 * kn, 0.3 * dl, ("down",), converged=False))
    assert not unsettled.passed and unsettled.value == 1.0
    assert "did not converge" in unsettled.message and "not measured" in unsettled.message
    assert "replay.damping" in unsettled.message
    # unconverged, but its closest replay within the statistics' noise (as the answer's own
    # loop is taken): a measured move, judged against the bounds as a converged one
    noise = LIMITS["binding_noise"]
    for close, shifts, passed in ((0.5 * noise, (0.6 * kn, 0.3 * dl), True),
                                  (0.5 * noise, (1.2 * kn, 0.3 * dl), False),
                                  (2.0 * noise, (0.6 * kn, 0.3 * dl), False)):
        c = sweep_direction_check(mixed, replayed=True, damping=DampingSensitivity(
            0.25, *shifts, ("down",), converged=False, closest_misfit_se=close))
        assert c.passed is passed
        assert ("not measured" in c.message) is (close > noise)



def test_a_damping_estimated_from_down_sweeps_alone_is_suspect():
    """Found on the fin swept down with Rayleigh damping and no C in its model file: the replay
    estimated the damping from runs that never reach the peak and landed at kn -13 to -15 %,
    `suspect` for misfits that did not name that cause. Every run with points sweeping down and
    an estimated damping: suspect, naming it; an up-sweep run with points (its peak measures the
    damping) or a damping not estimated: as before."""
    from freeplayid.identification.verdict import sweep_direction_check
    from freeplayid.replay import ReplayDamping

    est = ReplayDamping("estimated", zeta=0.052, zeta_ci95=(0.03, 0.09))
    down = _points_with_directions({"a": -1, "b": -1})
    check = sweep_direction_check(down, replayed=True, estimated=est)
    assert not check.passed and "estimated from them" in check.message
    assert "zeta 5.2 %" in check.message and "replay.damping" in check.message
    mixed = _points_with_directions({"up": 1, "down": -1})
    assert sweep_direction_check(mixed, replayed=True, estimated=est).passed
    assert sweep_direction_check(down, replayed=True).passed

def test_the_replay_misfit_of_a_down_sweep_names_the_jump_up():
    """A down-sweep run whose replayed jump up misses is named as a jump up, and the causes
    start with the down-sweep's jump-up."""
    from freeplayid.identification.replay_checks import replay_checks
    from freeplayid.replay.misfit import RunMisfit

    class Rep:
        failure, misfit, sweeps, damping, converged = "", {}, {}, None, True
        jump_point, excitation, cross = "quadrature", "measured", None
        iterations = [ReplayIteration(480.0, 3e-3, 480.0, 3e-3, n_evaluations=10)]
        resonance = {"run_d": RunMisfit("run_d", 2e-3, 42.0, 3e-3, 0.0, 0.02)}

    check = {c.name: c for c in replay_checks(Rep(), down_runs=("run_d",))}["replay_misfit"]
    assert not check.passed
    assert "run run_d: its jump up (phase resonance)" in check.message
    assert "a down-sweep's jump-up" in check.message


@pytest.mark.parametrize("se, passed", [(float("nan"), False), (5e-4, False), (2e-3, True)])
def test_the_replay_misfit_limit_is_the_larger_of_the_accuracy_and_the_noise(se, passed):
    """A run 0.3 % off the measured point's place against the backbone fails the 0.2 % limit
    unless the data's noise puts 3 standard errors of that offset above it (0.6 % here)."""
    from freeplayid.identification.replay_checks import replay_checks
    from freeplayid.replay.misfit import RunMisfit

    class Rep:
        failure, misfit, sweeps, damping, converged = "", {}, {}, None, True
        jump_point, excitation, cross = "quadrature", "measured", None
        iterations = [ReplayIteration(480.0, 3e-3, 480.0, 3e-3, n_evaluations=10)]
        resonance = {"run_a": RunMisfit("run_a", 1e-4, 40.0, 3e-3, 0.0, 0.01, se)}

    check = {c.name: c for c in replay_checks(Rep())}["replay_misfit"]
    assert check.passed is passed
    assert ("standard errors" in check.message) is bool(np.isfinite(se))


@pytest.mark.parametrize("runs, off, without, passed", [
    (4, ("r0",), (2e-3, -3e-3), True),    # one run off; the answer hardly rests on it
    (4, ("r0",), (2e-3, -8e-3), False),   # without it delta moves 0.8 %: it rests on it
    (4, ("r0",), (1.5e-2, 0.0), False),   # kn 1.5 %
    (4, ("r0",), None, False),            # not measured: not set aside
    (3, ("r0",), (2e-3, -3e-3), False),   # three runs: none can be set aside
    (5, ("r0", "r1"), (2e-3, -3e-3), False),  # two runs off: a pattern, not one run
])
def test_one_run_off_is_set_aside_only_where_the_answer_does_not_rest_on_it(runs, off, without,
                                                                            passed):
    """A run 0.27 % off the measured point's place (the 0.2 % limit; the noise 0.01 %) among
    ``runs``: it passes where it is the only one off, of four or more, and the answer without
    it moves by no more than half the bounds (delta 0.5 %, kn 1 %); the reason names it."""
    from freeplayid.identification.replay_checks import replay_checks
    from freeplayid.replay.misfit import RunMisfit

    class Rep:
        failure, misfit, sweeps, damping, converged = "", {}, {}, None, True
        jump_point, excitation, cross = "quadrature", "measured", None
        iterations = [ReplayIteration(480.0, 3e-3, 480.0, 3e-3, n_evaluations=10)]
        resonance = {f"r{k}": RunMisfit(f"r{k}", 1e-3, 40.0, 2.7e-3 if f"r{k}" in off else 1e-4,
                                        0.2, 0.02, 1e-4, without=without)
                     for k in range(runs)}

    check = {c.name: c for c in replay_checks(Rep())}["replay_misfit"]
    assert check.passed is passed
    assert "run r0: its phase resonance 0.27 %" in check.message
    assert ("without it the answer moves delta" in check.message) is (without is not None)
    assert ("does not rest on that run" in check.message) is passed


@pytest.mark.parametrize("shift, se, dof, passed", [
    (0.0063, 0.0017, 4.0, True),       # 3.7 se: chance 2 % of the time with 4 dof (t: 6.6)
    (0.0063, 0.0017, math.inf, False),  # the same se known exactly: 3.7 normal se fails
    (0.0130, 0.0017, 4.0, False),      # 7.6 se fails at 4 dof too
    (0.0045, 1e-4, 4.0, True),         # inside half the 1 % bound whatever the se
])
def test_the_cross_check_reads_its_standard_errors_with_their_degrees_of_freedom(
        shift, se, dof, passed):
    """Found on held-out cases: a shift of 3.1-3.8 standard errors estimated from 4 runs made
    3 of 32 accurate answers `suspect`; with 2-4 degrees of freedom that many happens by chance
    4-10 % of the time. The limit is t at the normal 3-se tail (0.27 %, two-sided)."""
    from freeplayid.identification.replay_checks import replay_checks
    from freeplayid.replay.corrected import CrossCheck

    class Rep:
        failure, misfit, sweeps, damping, converged, resonance = "", {}, {}, None, True, {}
        jump_point, excitation = "drop", "law"
        iterations = [ReplayIteration(480.0, 3e-3, 480.0, 3e-3, n_evaluations=10)]
        cross = CrossCheck("windowed", kn_shift=0.0, delta_shift=shift, kn_se=se,
                           delta_se=se, dof=dof)

    check = {c.name: c for c in replay_checks(Rep())}["replay_consistency"]
    assert check.passed is passed, check.message
    k = scipy.stats.t.isf(0.00135, dof) if math.isfinite(dof) else 3.0
    assert abs(k - (6.62 if math.isfinite(dof) else 3.0)) < 0.01
    assert ("limit" in check.message) is not passed


@pytest.mark.parametrize("runs", [3, 4, 5, 8, 20, 50])
def test_the_cross_checks_new_limit_is_never_below_the_old_one(runs):
    """The pooled error is at least sqrt((runs - 2) / dof) of the by-run one (the copies' spread
    may be 0), and t at dof times that stays above the 3 by-run errors of the earlier rule: no
    answer `ok` under that rule turns `suspect`."""
    from freeplayid.identification.verdict import LIMITS

    dof = runs - 2 + 2
    worst = scipy.stats.t.isf(LIMITS["cross_p"] / 2, dof) * np.sqrt((runs - 2) / dof)
    assert worst > 3.0


def test_the_cross_checks_standard_error_pools_the_runs_and_the_copies():
    """The test's by-run scatter (2 dof) and the copies' spread (2 dof), pooled by their
    degrees of freedom, then the copies' mean added: computed by hand."""
    from freeplayid.replay.corrected import _cross_se

    class Fit:  # by-run intervals of a fit with 4 runs
        kn_ci95_by_run, delta_ci95_by_run = (90.0, 110.0), (0.9e-3, 1.1e-3)
        kn_ci95, delta_ci95 = (95.0, 105.0), (0.95e-3, 1.05e-3)

    class Pt:
        def __init__(self, run):
            self.run = run

    class Points:
        def used(self):
            return [Pt(r) for r in "abcd"]

    class Est:
        fit, points = Fit(), Points()

    copies = np.log([[100.0, 1.00e-3], [101.0, 1.01e-3], [99.5, 0.99e-3]])
    se, dof = _cross_se(Est(), copies)
    tq = scipy.stats.t.ppf(0.975, 2)
    runs_var = (np.log(110 / 90) / (2 * tq)) ** 2, (np.log(1.1 / 0.9) / (2 * tq)) ** 2
    copy_var = copies.var(axis=0, ddof=1)
    want = np.sqrt((1 + 1 / 3) * (2 * np.array(runs_var) + 2 * copy_var) / 4)
    assert dof == 4.0
    np.testing.assert_allclose(se, want, rtol=1e-12)


def test_the_offsets_standard_error_is_the_noisy_copies_scatter_about_the_replay():
    """Two runs, two channels each, the noiseless replay's points at +0.1 % and 0 % from a flat
    backbone; three copies whose channels scatter about them: a (copy, run)'s deviation is the
    median over its channels less the replay's, the standard error their RMS; a copy that lost a
    run's points adds no sample for it; one sample is not enough; copies equal to the replay
    give 0."""
    from freeplayid.replay.misfit import offset_noise

    def pts(devs):  # {(run, channel): distance} -> points at 40 Hz (1 + distance)
        return [BackbonePoint(run, ch, 40.0 * (1 + d), 1e-4, True, "", 1.0, 30.0)
                for (run, ch), d in devs.items()]

    rep = pts({("a", "x"): 1e-3, ("a", "y"): 1e-3, ("b", "x"): 0.0, ("b", "y"): 0.0})
    copies = [pts({("a", "x"): 3e-3, ("a", "y"): 1e-3, ("b", "x"): -1e-3, ("b", "y"): -1e-3}),
              pts({("a", "x"): 0.0, ("a", "y"): 1e-3, ("b", "x"): 2e-3, ("b", "y"): 0.0}),
              pts({("b", "x"): 1e-3, ("b", "y"): 1e-3})]
    se, n = offset_noise(rep, copies, lambda p: 40.0)
    devs = np.array([1e-3, -1e-3, -0.5e-3, 1e-3, 1e-3])
    assert n == 5
    assert se == pytest.approx(np.sqrt(np.mean(devs ** 2)), rel=1e-9)
    assert np.isnan(offset_noise(rep, copies[2:], lambda p: 40.0)[0])
    assert offset_noise(rep, [rep, rep], lambda p: 40.0) == (0.0, 4)


def test_the_replayed_answer_judges_the_channels_spread_against_the_replays():
    """Channels 3 % apart pass when the replay's are 2.6 % apart (absolute accelerations, no
    base channel), fail when the replay's agree (a channel problem the replay does not have);
    the reverse (the replay's split) passes; one channel per run leaves the plain check in place
    (None)."""
    from freeplayid.identification.verdict import replayed_channel_check
    from freeplayid.replay.misfit import RunMisfit

    def res(measured, replayed):
        return {"r": RunMisfit("r", 0.0, 40.0, 0.0, 0.0, 0.0, 1e-4, measured, replayed)}

    assert replayed_channel_check(res(0.03, 0.026)).passed
    bad = replayed_channel_check(res(0.03, 0.002))
    assert not bad.passed and "replayed 0.2 %" in bad.message
    assert replayed_channel_check(res(float("nan"), float("nan"))) is None
    # the replay's channels split where the test's agree (a two-hinge beam's lowest run, 0.057 %
    # against 1.4 %): no fault of the records, said so
    split = replayed_channel_check(res(0.00057, 0.014))
    assert split.passed and "the replay's channels split where the test's agree" in split.message


def test_a_failed_cross_check_reports_the_other_statistics_answer(monkeypatch):
    """Without a base channel the replays match the drop points; when the windowed points put
    that answer elsewhere (a Rayleigh-damped beam: drop answer delta -17 %), identify replays
    the windowed points and reports that answer, `suspect`, saying what the drop points gave.
    A replay of that statistic that fails keeps the first answer."""
    from freeplayid.identification import pipeline
    from freeplayid.identification.verdict import Check, make_verdict
    from freeplayid.replay import Replay
    from freeplayid.replay.corrected import CrossCheck

    @dataclasses.dataclass(frozen=True)
    class Answer:
        kn: float
        delta: float
        verdict: object
        replay: object
        runtime_s: float = 0.0

    @dataclasses.dataclass(frozen=True)
    class Rep:
        jump_point: str
        cross: object = None
        failure: str = ""

    cross = CrossCheck("windowed", kn_shift=0.20, delta_shift=0.26, kn_se=0.006, delta_se=0.006,
                       dof=4.0)
    failed = make_verdict([Check("replay_consistency", False, "...: delta +26 % (limit 4 %)")])
    first = Answer(4274.4, 2.078e-3, failed, Rep("drop", cross))
    asked = []

    def fake_fit(dataset, system, est, *, extraction, fit, replay, start, precision_settled,
                 progress):
        asked.append(replay.jump_point)
        return Rep(replay.jump_point, failure=fake_fit.failure)

    fake_fit.failure = ""
    second = Answer(5010.0, 2.49e-3, make_verdict([Check("residual", True, "fine")]),
                    Rep("windowed"))
    monkeypatch.setattr(pipeline, "corrected_fit", fake_fit)
    monkeypatch.setattr(pipeline, "_corrected_result", lambda *a, **k: second)
    assert pipeline._statistics_disagree(first, Replay())
    assert not pipeline._statistics_disagree(first, Replay(jump_point="drop"))  # asked for
    ok = dataclasses.replace(first, verdict=make_verdict([Check("replay_consistency", True, "")]))
    assert not pipeline._statistics_disagree(ok, Replay())
    from freeplayid.fit import FitOptions

    args = (None, None, None, None, FitOptions(), Replay(), None, None, 0.0, False)
    got = pipeline._on_the_other_statistic(first, *args)
    assert asked == ["windowed"] and (got.kn, got.delta) == (5010.0, 2.49e-3)
    assert got.verdict.status == "suspect"
    note = got.verdict.checks[0]
    assert note.name == "replay_statistic" and not note.passed
    assert "`drop` points gave kn = 4274.4" in note.message and "delta +26 %" in note.message
    assert got.verdict.checks[1].name == "residual"
    fake_fit.failure = "the replay could not be fitted"
    assert pipeline._on_the_other_statistic(first, *args) is first


def test_the_replay_measures_what_the_resonance_check_reads_wherever_it_can_fail():
    """The replay measures the offsets' noise and each run's `without` only for offsets beyond
    OFFSET_NOISE_FROM; the check fails an offset only beyond LIMITS['backbone_offset'], so the
    first must lie below the second, or a failing run would be judged without them."""
    from freeplayid.replay.corrected import OFFSET_NOISE_FROM

    assert 0 < OFFSET_NOISE_FROM < LIMITS["backbone_offset"]


def _backbone_points(system, s):
    bc = dfa_backbone(system, kn=KN, delta=DELTA, s=np.asarray(s, float))
    amp = bc.amplitude[0]
    runs = [f"run{k}" for k in range(len(s))]
    return FittingPoints(
        channel=tuple(d for _ in s for d in DOFS),
        amplitude_m=np.array([amp[k, system.dof_names.index(d)] for k in range(len(s))
                              for d in DOFS]),
        f_hz=np.repeat(bc.frequency_hz[0], len(DOFS)), run=tuple(np.repeat(runs, len(DOFS))))


@pytest.mark.parametrize("s, plain, replayed", [
    ((1.3, 2.5, 3.0, 3.5, 4.5), False, True),  # one low run: the replay's correction covers it
    ((1.2, 1.3, 1.4, 2.5), False, False),  # the points driven to contact: suspect either way
    ((2.5, 3.0, 3.5, 4.5), True, True),
])
def test_a_point_near_contact_is_suspect_for_the_plain_fit_and_not_for_the_replay(
        system, s, plain, replayed):
    # found on a stiffer beam of the realtests integrator whose lowest run dropped at
    # Theta/delta 1.4: the corrected answer within 0.8 % and `suspect` for the margin alone
    points = _backbone_points(system, s)
    for flag, expected in ((False, plain), (True, replayed)):
        (margin,) = [c for c in answer_checks(points, KN, DELTA, (470.0, 490.0), (2.9e-3, 3.1e-3),
                                              system, replayed=flag)
                     if c.name == "contact_margin"]
        assert margin.passed is expected, (flag, margin.message)
        assert margin.value == pytest.approx(min(s), rel=1e-3)
    if not replayed:
        assert "driven to contact" in margin.message and "median" in margin.message
    elif not plain:
        assert "the replay's correction includes" in margin.message



@pytest.mark.parametrize("delta_hw, kn_hw, passed", [
    (0.004, 0.002, True),    # the default fin's copies at 0.05 g: no chance to leave 1 %
    (0.0196, 0.01, False),   # noise alone as wide as twice the bound: 32 % chance
    (0.004, 0.045, False),   # kn's own bound (2 %)
])
def test_an_answer_the_noise_alone_puts_outside_the_bounds_is_suspect(delta_hw, kn_hw, passed):
    from freeplayid.identification.replay_checks import noise_outside_chance, precision_check
    from freeplayid.replay import ReplayPrecision

    p = ReplayPrecision(kn_halfwidth=kn_hw, delta_halfwidth=delta_hw, n=8, n_fitted=8,
                        margin_hz=2.5)
    check = precision_check(p)
    assert check.name == "noise_precision" and check.passed is passed
    # the chance from the normal distribution's tails (scipy), log half-width / 1.96 the sd
    want = max(2 * scipy.stats.norm.sf(math.log(1.01) / (math.log1p(delta_hw) / 1.96)),
               2 * scipy.stats.norm.sf(math.log(1.02) / (math.log1p(kn_hw) / 1.96)))
    assert math.isclose(check.value, want, rel_tol=1e-9)
    assert math.isclose(noise_outside_chance(0.01, 0.01), 0.05, rel_tol=1e-4)  # z = 1.96
    if not passed:
        assert "only as precise as the test's noise" in check.message
        assert "8 noisy copies" in check.message


def test_a_mean_move_of_the_noise_counts_in_the_chance_of_leaving_the_bounds():
    """The copies' mean move (``noise_bias``) centres the error's distribution, its standard
    error adds to the spread: by hand, sd 0.3 % and se 0.4 % make a 0.5 % spread (3-4-5), so
    log 1.01 lies 1.99 of them out (chance 4.66 %); the same copies moved 0.5 % on average put
    it (0.995 - 0.5) / 0.5 out on that side and (0.995 + 0.5) / 0.5 on the other (16.2 % in all);
    moved 1 %, an answer whose scatter alone passed the check (5 %) fails it."""
    from freeplayid.identification.replay_checks import noise_outside_chance, precision_check
    from freeplayid.replay import ReplayPrecision

    hw = math.expm1(1.96 * 0.003)
    b = math.log(1.01)
    assert math.isclose(noise_outside_chance(hw, 0.01, 0.0, 0.004),
                        2 * scipy.stats.norm.sf(b / 0.005), rel_tol=1e-9)
    assert math.isclose(noise_outside_chance(hw, 0.01, 0.0, 0.004), 0.0466, abs_tol=5e-4)
    moved = noise_outside_chance(hw, 0.01, 0.005, 0.004)
    assert math.isclose(moved, scipy.stats.norm.sf((b - 0.005) / 0.005)
                        + scipy.stats.norm.cdf((-b - 0.005) / 0.005), rel_tol=1e-9)
    assert math.isclose(moved, 0.1625, abs_tol=2e-4)
    assert noise_outside_chance(0.0, 0.01, 0.02) == 1.0  # a move beyond the bound, no spread
    centred = ReplayPrecision(kn_halfwidth=0.002, delta_halfwidth=0.01, n=8, n_fitted=8)
    assert precision_check(centred).passed
    shifted = dataclasses.replace(centred, noise_bias=(0.0, 0.01), noise_bias_se=(0.0, 0.001))
    check = precision_check(shifted)
    assert not check.passed and check.value > 0.4
    assert "on average it moves delta by +1 ± 0.1 %" in check.message


def test_the_base_channels_noise_in_the_excitation_counts_in_the_chance_of_leaving_the_bounds():
    """An answer whose replays are driven by a noisy base record carries that noise too: the
    excitation copies' half-widths add to the response copies' in quadrature (log). Numbers of
    an independent record (realtests ``var17_finC_nominal_noisy`` d2, delta +1.63 % off): the
    copies alone put delta's 95 % half-width at 0.80 % (a 3 % chance of leaving 1 %, `ok`); the
    base's noise in the excitation at 1.76 %; together 1.93 %, a 32 % chance (by hand, scipy's
    normal tails about the copies' mean move)."""
    from freeplayid.identification.replay_checks import precision_check
    from freeplayid.replay import ReplayPrecision
    from freeplayid.replay.corrected import ExcitationNoise

    p = ReplayPrecision(kn_halfwidth=0.003322, delta_halfwidth=0.007961, n=8, n_fitted=8,
                        noise_bias=(-0.001011, -0.001760), noise_bias_se=(0.000598, 0.001430))
    alone = precision_check(p)
    assert alone.passed and math.isclose(alone.value, 0.031, abs_tol=0.002)
    exc = ExcitationNoise(kn_halfwidth=0.008980, delta_halfwidth=0.017557,
                          reading_sd={"run": 0.0238}, n=2, n_fitted=2)
    check = precision_check(p, exc)
    sd = math.hypot(math.hypot(math.log(1.007961), math.log(1.017557)) / 1.96, 0.001430)
    b, m = math.log(1.01), -0.001760
    want = scipy.stats.norm.sf((b - m) / sd) + scipy.stats.norm.cdf((-b - m) / sd)
    assert math.isclose(check.value, want, rel_tol=1e-6) and 0.3 < want < 0.34
    assert not check.passed
    assert "the base channel's noise, read as the replays' excitation" in check.message
    assert "together ±1.9 %" in check.message
    assert "most of it the base channel's" in check.message  # 1.76 % against the copies' 0.80 %
    # not measured (too few copies fitted): the copies' own chance, unchanged
    unmeasured = ExcitationNoise(None, None, {"run": 0.0238}, n=2, n_fitted=1)
    assert precision_check(p, unmeasured) == alone


def test_a_precision_not_measured_is_no_check():
    from freeplayid.identification.replay_checks import precision_check
    from freeplayid.replay import ReplayPrecision

    assert precision_check(None) is None
    assert precision_check(ReplayPrecision(None, None, n=8, n_fitted=2)) is None



def _level_check(level):
    """The ``replay_level`` check of a converged drop-point replay whose levels came from
    `level_g` with sensitivity ``level`` (a stand-in for the replay result)."""
    from freeplayid.identification.replay_checks import replay_checks

    class Rep:
        failure, misfit, sweeps, damping, converged, resonance = "", {}, {}, None, True, {}
        jump_point, excitation = "drop", "law"
        iterations = [ReplayIteration(480.0, 3e-3, 480.0, 3e-3, n_evaluations=10)]

    Rep.level = level
    return {c.name: c for c in replay_checks(Rep())}["replay_level"]

@pytest.mark.parametrize("errors, ratio_kn, se, passed, scale", [
    ((-0.044, -0.049), -0.0018, 0.001, True, 1.0),  # level_g 5 % high: within the uncertainty
    ((-0.09, 0.025), -0.007, 0.0014, True, 1.8),  # a ramp: levels beyond it, one level per run
    ((-0.105, -0.111), 0.05, 0.0019, False, 2.22),  # a dip: the channels' ratios put kn 5 % off
    ((-0.105, -0.111), None, None, True, 2.22),  # ... which one channel cannot tell
    ((0.003, 0.001), -0.036, 0.039, True, 1.0),  # far, but within its noise (9.2 se at 3 dof)
])
def test_the_level_check_judges_the_channels_ratio_and_widens_for_implied_levels(
        errors, ratio_kn, se, passed, scale):
    """Measured on the realtests records without a base channel (benchmarks/realtests):
    `fin_no_base_level_off` (levels 4.4-4.9 % below `level_g`, channels within 0.6 %, ratio
    kn -0.18 %), `var8_fin_no_base_ramp` (levels -9 to +2.5 %, ratio kn -0.70 +- 0.14 %),
    `fin_dip_no_base` (levels -10.5 to -11.1 %, channels 7.6-8.1 % apart, ratio kn +5.0 +-
    0.19 % where the answer is 3.7 % low); the held-out study's case 37 (an accurate answer,
    ratio kn -3.6 +- 3.9 %: runs whose channels hardly move with kn)."""
    from freeplayid.replay.corrected import LevelSensitivity
    from freeplayid.replay.misfit import ImpliedLevel

    implied = {f"run{k}": ImpliedLevel(e, 0.004, {"a": e - 0.03, "b": e + 0.03}
                                       if ratio_kn is not None else {"a": e})
               for k, e in enumerate(errors)}
    level = LevelSensitivity(0.05, 0.002, 0.003, tuple(implied), True, implied, ratio_kn, se,
                             0 if se is None else 3)
    assert level.scale == pytest.approx(scale, rel=1e-2)

    check = _level_check(level)
    assert check.passed is passed, check.message
    assert ("beyond its 5 % uncertainty" in check.message) is (scale > 1)
    if ratio_kn is None:
        assert "one channel" in check.message
    elif not passed:
        assert "+5 % from the answer" in check.message and "no base channel" in check.message


@pytest.mark.parametrize("errors, shifts, said", [
    # fin_no_base (the model's C, realtests): the levels' 5 % moves delta by 0.36 %
    ((0.0011, 0.0001, -0.0001, -0.0001), (0.0022, 0.0036),
     "their 5 % uncertainty moves delta by 0.36 % and kn by 0.22 %"),
    # var10_finB_damper_no_base (a damper across each hinge, damping estimated; delta -1.84 %)
    ((-0.0299, -0.0194, -0.0145, -0.0123), (0.0197, 0.0178),
     "their 5 % uncertainty moves delta by 1.8 % and kn by 2 %"),
    # var8_fin_no_base_ramp: the branches imply -9 %, the move measured at 5 % carried there
    ((-0.0897, -0.0425, -0.0034, 0.0247), (0.0046, 0.0042),
     "the 9 % error the upper branches imply moves delta by 0.75 % and kn by 0.83 %"),
])
def test_the_level_check_says_what_the_answer_owes_to_the_levels(errors, shifts, said):
    """Without a base channel the answer is conditional on `level_g`, as kn is on the linear
    model: where the damping is estimated from the peaks' amplitudes at those levels, a level
    error goes into the damping and the upper branches cannot show it (the held-out study's
    5 %-damped cases: branches within 0.15 % of `level_g`, while 5 % on the levels moves delta
    by 1.2-3.6 %). So the check states the move and passes (session 50: a limit on it marked 3
    of the study's first 6 accurate answers `suspect`). Numbers measured on the realtests
    records (benchmarks/realtests, the independent exact integrator)."""
    from freeplayid.replay.corrected import LevelSensitivity
    from freeplayid.replay.misfit import ImpliedLevel

    implied = {f"run{k}": ImpliedLevel(e, 0.002, {"a": e}) for k, e in enumerate(errors)}
    level = LevelSensitivity(0.05, shifts[0], shifts[1], tuple(implied), True, implied)

    check = _level_check(level)
    assert check.passed, check.message
    assert "the answer is conditional on `level_g`" in check.message
    assert said in check.message, check.message


def test_replayed_peaks_that_drift_with_the_level_say_the_damping_has_another_form():
    from freeplayid.replay import ReplayDamping

    base = ReplayDamping("estimated", 0.023, (0.021, 0.025))
    assert "drift" not in base.describe()
    text = dataclasses.replace(base, trend=-0.28, trend_se=0.02).describe()
    assert "the replayed peaks drift with the level by -28 % per e-fold" in text
    assert "`replay.damping_exponent=estimate` fits the first two" in text
    assert "drift" not in dataclasses.replace(base, trend=-0.28, trend_se=0.2).describe()
    up = dataclasses.replace(base, trend=0.07, trend_se=0.003).describe()
    assert "+7 % per e-fold" in up and "more damping in contact" in up

"""Record checks (freeplayid.quality): each fault found with its run, channel and size, clean
records pass, and the repairs leave a record within noise of the clean one.

The synthetic records are closed forms, not the package's simulator: a swept sine whose
envelope climbs to a jump and drops (a hardening resonance), two channels in the exact ratio of
a 2-DOF fin's mode shape (solved by hand below), an exact base channel, white noise. Each fault
is made by hand with known size and place. The clean references are these records, the bundled
example and a short run of the project's simulator.
"""

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from freeplayid.dataset import Dataset, Run
from freeplayid.identification.records import record_checks
from freeplayid.model import two_dof_system
from freeplayid.quality import (
    ACTIONS,
    CHECK_NAMES,
    CHECKS,
    Finding,
    RecordCheckOptions,
    RecordReport,
    check_records,
)
from freeplayid.quality.asymmetry import even_share, replayed_even_harmonics
from freeplayid.quality.cabling import shape_at_frequency
from freeplayid.quality.context import Records
from freeplayid.sweep import Sweep

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "fin_sweeps"
FS = 256.0  # [Hz]
SWEEP = Sweep(30.0, 46.5, 0.5)  # [Hz], [Hz], [Hz/s]: 33 s
JUMPS = (38.0, 40.0, 42.0)  # [Hz] jump frequency of each run
PEAKS = (4.0, 8.0, 12.0)  # [g] outboard relative acceleration at the jump
LEVELS = (0.3, 0.6, 0.9)  # [g] base level
NOISE = 0.02  # [g] white noise on every channel
M_IN, M_OUT, K_IN = 1.0, 0.5, 4.0e5  # the 2-DOF fin [kg, kg, N/m]
G = 9.80665


def ratio_in_out(f_hz: float) -> float:
    """phi_in / phi_out of the 2-DOF fin's lowest mode at f_hz, by hand: the hinge stiffness k
    with that eigenvalue solves (k_in + k - lam m_in)(k - lam m_out) = k^2, and the second row
    gives phi_in / phi_out = (k - lam m_out) / k."""
    lam = (2 * np.pi * f_hz) ** 2
    k = lam * M_OUT * (K_IN - lam * M_IN) / (K_IN - lam * (M_IN + M_OUT))
    return (k - lam * M_OUT) / k


SYSTEM = two_dof_system(m_in=M_IN, m_out=M_OUT, k_in=K_IN, zeta=0.02)


def envelope(t, f_jump: float, peak: float):
    """A hardening resonance's envelope [g]: climbs to ``peak`` at ``f_jump``, drops in 0.05 s."""
    f = SWEEP.frequency(t)
    t_j = SWEEP.time_at(f_jump)
    up = peak * (0.15 + 0.85 * ((f - SWEEP.start_hz) / (f_jump - SWEEP.start_hz)) ** 2)
    down = peak * (0.15 * (f_jump / f) ** 2 + 0.85 * np.exp(-np.clip(t - t_j, 0, None) / 0.05))
    return np.where(t < t_j, up, down)


def make_run(i: int, *, sweep: Sweep = SWEEP, seed: int = 0, fs: float = FS, hint=True):
    n = int(SWEEP.duration * fs) + 1
    t = np.arange(n) / fs
    rng = np.random.default_rng(seed + i)
    rel_out = envelope(t, JUMPS[i], PEAKS[i]) * np.sin(sweep.phase(t) - 1.2)
    base = LEVELS[i] * np.sin(sweep.phase(t))
    rel = np.array([rel_out, ratio_in_out(JUMPS[i]) * rel_out])
    data = rel + base + rng.normal(0, NOISE, rel.shape)
    return Run(file=f"run{i}.csv", time=t, data=data, level_g=LEVELS[i],
               sweep=SWEEP.to_dict() if hint else None,
               base=base + rng.normal(0, NOISE, n))


def make_dataset(runs=None, **changes) -> Dataset:
    runs = tuple(make_run(i) for i in range(3)) if runs is None else tuple(runs)
    ds = Dataset(name="synthetic", model=None, quantity="acceleration", units="g",
                 sample_rate=FS, channels={"acc_out": "uz_out", "acc_in": "uz_in"}, runs=runs,
                 base_channel="acc_base")
    return replace(ds, **changes)


def with_data(ds, i: int, data=None, base="keep"):
    runs = list(ds.runs)
    r = runs[i]
    runs[i] = replace(r, data=r.data if data is None else data,
                      base=r.base if isinstance(base, str) else base)
    return replace(ds, runs=tuple(runs))


@pytest.fixture(scope="module")
def clean():
    return make_dataset()


@pytest.fixture(scope="module")
def clean_report(clean):
    return check_records(clean, SYSTEM)


def only(report, check):
    found = report.by_check(check)
    others = [f for f in report.findings if f.check != check]
    assert not others, f"unexpected findings: {others}"
    return found


# ------------------------------------------------------------------ clean records pass
def test_clean_synthetic_records_raise_nothing(clean, clean_report):
    assert clean_report.findings == ()
    assert clean_report.dataset is clean
    assert clean_report.rejected_runs == {} and clean_report.suspect_reasons == ()


def test_bundled_example_raises_nothing():
    from freeplayid.io import read_dataset
    from freeplayid.model import load_system

    ds = read_dataset(EXAMPLE)
    report = check_records(ds, load_system(ds.model))
    assert report.findings == (), report.to_markdown()
    assert report.skipped == {}


def test_simulated_records_raise_nothing():
    import torch

    from freeplayid.simulate import simulate_sweeps, sweep_dataset

    # 1 g rattles in the gap, 1.5 g jumps at 34 Hz
    res = simulate_sweeps(SYSTEM, kn=5e4, delta=1e-3, level_g=[1.0, 1.5],
                          sweep=Sweep(30, 42, 1.5), channels=["uz_in", "uz_out"],
                          sample_rate=FS, dtype=torch.float64, engine="torch", progress=False)
    noise = np.random.default_rng(1).normal(0, 0.05 * G, res.signals.shape)
    report = check_records(sweep_dataset(res, units="g", noise=noise), SYSTEM)
    assert report.findings == (), report.to_markdown()


# ------------------------------------------------------------------ saturation
@pytest.mark.parametrize("share", [0.8, 0.7])
def test_clipping_rejects_the_run_with_its_level(clean, share):
    x = clean.runs[2].data.copy()
    c = share * np.max(np.abs(x[0]))
    x[0] = np.clip(x[0], -c, c)
    report = check_records(with_data(clean, 2, x), SYSTEM)
    (f,) = only(report, "saturation")
    assert (f.run, f.channel, f.action) == ("run2.csv", "acc_out", "reject_run")
    assert f.size == pytest.approx(100 * share, abs=3)  # the true peak re-estimated
    assert set(report.rejected_runs) == {"run2.csv"}
    assert "run2.csv" in f.message and "acc_out" in f.message


def test_an_exact_tone_meeting_its_crest_is_no_clipping():
    """A noise-free base at 256 Hz, swept from 30 Hz at 0.1 Hz/s for 260 s (the noise study's
    bank): its phase lies on a dyadic grid and its samples reach sin = 1 exactly once a cycle, a
    pile-up at the crest that cuts nothing: a warning at 100 % of the peak, not a rejected run
    (rejected before, every run of the study's noise-free cases)."""
    sweep = Sweep(30.0, 56.0, 0.1)
    t = np.arange(int(260 * FS)) / FS
    base = sweep.acceleration(t, LEVELS[1]) / G  # [g]
    assert np.count_nonzero(base == np.max(base)) >= 20  # the crest met exactly, again and again
    rng = np.random.default_rng(3)
    data = np.stack([k * base + rng.normal(0.0, NOISE, t.size) for k in (3.0, 2.0)])
    ds = Dataset(name="exact tone", model=None, quantity="acceleration", units="g",
                 sample_rate=FS, channels={"acc_out": "x_out", "acc_in": "x_in"},
                 runs=(Run(file="run.csv", time=t, data=data, level_g=LEVELS[1], base=base,
                           sweep=sweep.to_dict()),), base_channel="acc_base")
    report = check_records(ds, SYSTEM, options=RecordCheckOptions(checks=("saturation",)))
    (f,) = only(report, "saturation")
    assert (f.run, f.channel, f.action) == ("run.csv", "acc_base", "warning")
    assert f.size == pytest.approx(100, abs=0.1)
    assert not report.rejected_runs
    # a cut at 97 % of the tone's crest still rejects the run
    c = 0.97 * 3.0 * np.max(base)
    cut = replace(ds, runs=(replace(ds.runs[0], data=np.stack([np.clip(data[0], -c, c),
                                                                data[1]])),))
    report = check_records(cut, SYSTEM, options=RecordCheckOptions(checks=("saturation",)))
    assert "run.csv" in report.rejected_runs


# ------------------------------------------------------------------ dropouts
def test_zeros_at_the_jump_reject_the_run(clean):
    t_jump = SWEEP.time_at(JUMPS[1])
    a = int(t_jump * FS)
    x, base = clean.runs[1].data.copy(), clean.runs[1].base.copy()
    x[:, a:a + int(0.5 * FS)] = 0.0
    base[a:a + int(0.5 * FS)] = 0.0
    report = check_records(with_data(clean, 1, x, base), SYSTEM)
    found = only(report, "dropout")
    assert {f.channel for f in found} == {"acc_out", "acc_in", "acc_base"}
    for f in found:
        assert f.run == "run1.csv" and f.action == "reject_run"
        assert f.size == pytest.approx(0.5, abs=2 / FS)
    assert set(report.rejected_runs) == {"run1.csv"}


def test_held_value_away_from_the_resonance_is_a_warning(clean):
    x = clean.runs[2].data.copy()
    a = int(3.0 * FS)  # 3 s into the sweep, far below the 42 Hz jump
    x[1, a:a + int(0.2 * FS)] = x[1, a]
    report = check_records(with_data(clean, 2, x), SYSTEM)
    (f,) = only(report, "dropout")
    assert (f.run, f.channel, f.action) == ("run2.csv", "acc_in", "warning")
    assert f.size == pytest.approx(0.2, abs=2 / FS)


# ------------------------------------------------------------------ spikes
def test_spikes_are_found_and_repaired_within_noise(clean):
    rng = np.random.default_rng(5)
    where = np.sort(rng.choice(np.arange(int(2 * FS), clean.runs[0].time.size - int(2 * FS)),
                               6, replace=False))
    x = clean.runs[0].data.copy()
    x[1, where] += 50.0 * rng.choice([-1.0, 1.0], where.size)
    report = check_records(with_data(clean, 0, x), SYSTEM)
    (f,) = only(report, "spike")
    assert (f.run, f.channel, f.action) == ("run0.csv", "acc_in", "repaired")
    assert f.message.startswith(f"run run0.csv, channel acc_in: {where.size} spike(s)")
    assert 45 < f.size < 55
    fixed = report.dataset.runs[0].data[1]
    clean_x = clean.runs[0].data[1]
    assert np.max(np.abs(fixed[where] - clean_x[where])) < 4 * NOISE
    untouched = np.setdiff1d(np.arange(fixed.size), where)
    assert np.array_equal(fixed[untouched], clean_x[untouched])


# ------------------------------------------------------------------ offset and drift
def test_offset_and_drift_are_removed_within_noise(clean):
    t = clean.runs[1].time
    x = clean.runs[1].data.copy()
    x[0] += 0.3 + 0.4 * t / t[-1]  # [g] offset and ramp
    drifting = with_data(clean, 1, x)
    report = check_records(drifting, SYSTEM)
    assert drifting.runs[1].data is x and np.allclose(x[0] - clean.runs[1].data[0],
                                                     0.3 + 0.4 * t / t[-1])  # input kept
    (f,) = only(report, "offset")
    assert (f.run, f.channel, f.action) == ("run1.csv", "acc_out", "repaired")
    assert "+0.5" in f.message  # the mean offset, 0.3 + 0.4 / 2
    diff = report.dataset.runs[1].data[0] - clean.runs[1].data[0]
    inner = slice(int(1 * FS), -int(1 * FS))
    assert np.max(np.abs(diff[inner])) < 2 * NOISE


# ------------------------------------------------------------------ hum
def test_hum_is_notched_within_noise(clean):
    t = clean.runs[2].time
    x = clean.runs[2].data.copy()
    x[0] += 0.1 * np.sin(2 * np.pi * 50.02 * t + 0.3)  # [g], the mains 0.02 Hz off nominal
    report = check_records(with_data(clean, 2, x), SYSTEM)
    (f,) = only(report, "hum")
    assert (f.run, f.channel, f.action) == ("run2.csv", "acc_out", "repaired")
    assert f.size == pytest.approx(0.1, rel=0.1)
    assert "50.0" in f.message
    diff = report.dataset.runs[2].data[0] - clean.runs[2].data[0]
    assert np.sqrt(np.mean(diff**2)) < 0.2 * NOISE


def test_hum_at_the_resonance_is_not_notched(clean):
    # a line at 2 x 20 Hz = 40 Hz, on run 1's 40 Hz jump; 0.2 g is 2.5 % of its 8 g peak
    t = clean.runs[1].time
    x = clean.runs[1].data.copy()
    x[0] += 0.2 * np.sin(2 * np.pi * 40.0 * t)
    hummed = with_data(clean, 1, x)
    report = check_records(hummed, SYSTEM,
                           options=RecordCheckOptions(checks=("hum",), hum_lines_hz=(20.0,)))
    (f,) = report.by_check("hum")
    assert (f.run, f.channel, f.action) == ("run1.csv", "acc_out", "suspect")
    assert "not notched" in f.message
    assert report.dataset is hummed


# ------------------------------------------------------------------ sweep law
def test_wrong_sample_rate_is_suspect_with_its_factor(clean):
    declared = FS * 2000 / 2048  # 2048-like data declared at 2000
    runs = [replace(r, time=np.arange(r.time.size) / declared) for r in clean.runs]
    report = check_records(make_dataset(runs, sample_rate=declared), SYSTEM)
    (f,) = only(report, "sample_rate")
    assert (f.run, f.action) == ("", "suspect")
    assert f.size == pytest.approx(100 * (2000 / 2048 - 1), abs=0.02)
    assert f"{FS:.6g} Hz" in f.message


@pytest.mark.parametrize("law", [Sweep(30, 46.5, octaves_per_min=1.5), Sweep(46.5, 30, 0.5)],
                         ids=["log", "down"])
def test_log_and_down_sweeps_pass_and_their_rate_is_checked(law):
    runs = [replace(make_run(i, sweep=law), sweep=law.to_dict()) for i in range(3)]
    assert check_records(make_dataset(runs), SYSTEM).findings == ()
    declared = FS * 2000 / 2048
    runs = [replace(r, time=np.arange(r.time.size) / declared) for r in runs]
    report = check_records(make_dataset(runs, sample_rate=declared), SYSTEM,
                           options=RecordCheckOptions(checks=("sample_rate", "sweep_hint",
                                                              "foreign_record")))
    (f,) = report.findings
    assert f.check == "sample_rate" and f.size == pytest.approx(-2.34375, abs=0.02)


def test_another_tests_record_is_rejected_as_such(clean):
    other = Sweep(46.5, 63.0, 0.5)  # the band above: never resonates, "stayed in the gap"
    runs = list(clean.runs)
    runs[1] = replace(make_run(1, sweep=other), file="run1.csv")
    report = check_records(make_dataset(runs), SYSTEM,
                           options=RecordCheckOptions(checks=("sample_rate", "sweep_hint",
                                                              "foreign_record")))
    (f,) = report.findings
    assert (f.check, f.run, f.action) == ("foreign_record", "run1.csv", "reject_run")
    assert "46.5 -> 63 Hz" in f.message and "not a record of its sweep hint" in f.message


def test_another_tests_record_without_hints_is_suspect():
    other = Sweep(46.5, 63.0, 0.5)
    runs = [make_run(i, hint=False) for i in range(3)]
    runs.append(replace(make_run(1, sweep=other, hint=False), file="run3.csv"))
    report = check_records(make_dataset(runs), SYSTEM,
                           options=RecordCheckOptions(checks=("foreign_record",)))
    (f,) = report.findings
    assert (f.check, f.run, f.action) == ("foreign_record", "run3.csv", "suspect")


def test_hint_starting_late_is_suspect(clean):
    t0 = 2.0  # [s] the record starts 2 s into the sweep its hint describes
    late = Sweep(SWEEP.start_hz + SWEEP.rate_hz_per_s * t0, SWEEP.stop_hz, SWEEP.rate_hz_per_s)
    runs = list(clean.runs)
    runs[0] = replace(make_run(0, sweep=late), sweep=SWEEP.to_dict())
    report = check_records(make_dataset(runs), SYSTEM,
                           options=RecordCheckOptions(checks=("sweep_hint", "foreign_record")))
    (f,) = report.findings
    assert (f.check, f.run, f.action) == ("sweep_hint", "run0.csv", "suspect")
    assert f.size == pytest.approx(SWEEP.rate_hz_per_s * t0, rel=0.02)


# ------------------------------------------------------------------ cabling
def test_mode_shape_at_a_frequency_is_the_hand_solved_one():
    for f in (35.0, 40.0, 45.0):
        phi = shape_at_frequency(SYSTEM, f)
        i, o = SYSTEM.dof_index(["uz_in", "uz_out"])
        assert phi[i] / phi[o] == pytest.approx(ratio_in_out(f), rel=1e-6)


def test_swapped_channels_are_named(clean):
    swapped = replace(clean, channels={"acc_out": "uz_in", "acc_in": "uz_out"})
    report = check_records(swapped, SYSTEM)
    (f,) = only(report, "cabling")
    assert f.action == "suspect" and "look swapped" in f.message
    assert f.channel == "acc_out, acc_in"


def test_channel_gain_off_by_two_is_suspect(clean):
    # acc_in's sensitivity doubled: its motion relative to the base reads twice too large
    runs = [replace(r, data=np.array([r.data[0], 2 * (r.data[1] - r.base) + r.base]))
            for r in clean.runs]
    report = check_records(make_dataset(runs), SYSTEM,
                           options=RecordCheckOptions(checks=("cabling",)))
    (f,) = report.findings
    assert (f.channel, f.action) == ("acc_in", "suspect")
    assert f.size == pytest.approx(2.0, rel=0.1)


def test_inverted_polarity_with_a_base_channel_is_suspect(clean):
    runs = [replace(r, data=np.array([r.data[0], -r.data[1]])) for r in clean.runs]
    report = check_records(make_dataset(runs), SYSTEM,
                           options=RecordCheckOptions(checks=("cabling",)))
    assert [(f.channel, f.action) for f in report.findings] == [("acc_in", "suspect")]
    assert "inverted sensor" in report.findings[0].message


def test_without_a_base_channel_cabling_compares_amplitudes_only(clean):
    only_cabling = RecordCheckOptions(checks=("cabling",))
    no_base = make_dataset([replace(r, base=None) for r in clean.runs], base_channel=None)
    inverted = make_dataset([replace(r, data=np.array([r.data[0], -r.data[1]]), base=None)
                             for r in clean.runs], base_channel=None)
    for ds in (no_base, inverted):
        report = check_records(ds, SYSTEM, options=only_cabling)
        assert report.findings == () and "cabling (polarity)" in report.skipped
    swapped = replace(no_base, channels={"acc_out": "uz_in", "acc_in": "uz_out"})
    (f,) = check_records(swapped, SYSTEM, options=only_cabling).findings
    assert f.action == "suspect" and "look swapped" in f.message


def test_cabling_needs_the_model(clean):
    report = check_records(clean, None, options=RecordCheckOptions(checks=("cabling",)))
    assert report.findings == () and "cabling" in report.skipped


# ------------------------------------------------------------------ units
@pytest.fixture(scope="module")
def example():
    from freeplayid.io import read_dataset
    from freeplayid.model import load_system

    ds = read_dataset(EXAMPLE)
    return ds, load_system(ds.model)


def _no_base(ds, units):
    return replace(ds, base_channel=None, units=units,
                   runs=tuple(replace(r, base=None) for r in ds.runs))


def test_g_declared_as_ms2_without_base_is_suspect(example):
    ds, system = example
    only_units = RecordCheckOptions(checks=("units",))
    report = check_records(_no_base(ds, "m/s^2"), system, options=only_units)
    (f,) = report.findings
    assert (f.check, f.action) == ("units", "suspect")
    assert f.size < 0.5  # below half the floor; 1 / 9.81 lifts every reading above it
    assert "g data declared as m/s^2" in f.message
    assert check_records(_no_base(ds, "g"), system, options=only_units).findings == ()


def test_base_level_off_by_g_is_suspect(clean):
    runs = [replace(r, data=r.data * G, base=r.base * G) for r in clean.runs]  # m/s^2 in g
    report = check_records(make_dataset(runs), SYSTEM,
                           options=RecordCheckOptions(checks=("units",)))
    assert {f.run for f in report.findings} == {"run0.csv", "run1.csv", "run2.csv"}
    for f in report.findings:
        assert f.size == pytest.approx(G, rel=0.05) and "m/s^2 data declared as g" in f.message


# ------------------------------------------------------------------ even harmonics
EVEN = RecordCheckOptions(checks=("even_harmonics",))


def _with_second_harmonic(run, share: float, *, base_share: float = 0.0):
    """``run`` with ``share`` x its relative response's envelope at twice the phase added to
    every response channel, and the base distorted by ``base_share`` of its level at twice the
    phase (the responses moving with it, as absolute records of a rigid base do)."""
    t = run.time
    i = int(run.file[3])
    phase = SWEEP.phase(t)
    env = envelope(t, JUMPS[i], PEAKS[i])
    even = share * env * np.sin(2 * (phase - 1.2) + 0.4)
    shaken = base_share * LEVELS[i] * np.sin(2 * phase + 0.3)
    rel = np.array([even, ratio_in_out(JUMPS[i]) * even])
    return replace(run, data=run.data + rel + shaken, base=run.base + shaken)


def test_an_even_harmonic_a_centred_gap_cannot_make_is_reported(clean):
    """A second harmonic of 3 % of the first on one run's responses (the panel resting on a
    stop) makes the answer suspect, on that run and channel with its size; the others raise
    nothing."""
    runs = list(clean.runs)
    runs[1] = _with_second_harmonic(runs[1], 0.03)
    (f,) = check_records(make_dataset(runs), SYSTEM, options=EVEN).findings
    assert (f.check, f.run, f.channel, f.action) == ("even_harmonics", "run1.csv", "acc_out",
                                                     "suspect")
    assert f.size == pytest.approx(3.0, abs=0.3) and f.unit == "% of 1st"
    assert "rests on one stop" in f.message and "could put at most" in f.message
    # without a base channel the message says what it cannot tell apart
    no_base = make_dataset([replace(r, base=None) for r in runs], base_channel=None)
    (f,) = check_records(no_base, SYSTEM, options=EVEN).findings
    assert f.run == "run1.csv" and "distortion cannot be told" in f.message


def test_an_even_harmonic_the_answers_replay_makes_too_is_a_warning(clean):
    """A 3 % second harmonic on run 1, judged again against the answer's replay (a centred gap
    makes some near its contact threshold): where the replay makes 2.8 % the 0.2 % it does not
    make is no finding, and the finding becomes a warning naming the replay's share; where the
    replay makes 1 %, the 2 % left is, and it stays suspect, saying so. A replay without the
    run, or none, leaves the report as it was."""
    runs = list(clean.runs)
    runs[1] = _with_second_harmonic(runs[1], 0.03)
    report = check_records(make_dataset(runs), SYSTEM, options=EVEN)
    replay = list(clean.runs)
    replay[1] = _with_second_harmonic(clean.runs[1], 0.028)
    (f,) = replayed_even_harmonics(report, make_dataset(replay)).findings
    assert (f.run, f.action) == ("run1.csv", "warning")
    assert "makes 2.8% there" in f.message and "not an asymmetric hinge" in f.message
    assert record_checks(replayed_even_harmonics(report, make_dataset(replay)))[0].passed
    replay[1] = _with_second_harmonic(clean.runs[1], 0.01)
    (f,) = replayed_even_harmonics(report, make_dataset(replay)).findings
    assert f.action == "suspect" and "rests on one stop" in f.message
    assert "makes 1.0% there" in f.message
    without = make_dataset([r for r in clean.runs if r.file != "run1.csv"])
    assert replayed_even_harmonics(report, without).findings == report.findings
    assert replayed_even_harmonics(report, None) is report


def test_even_harmonics_of_a_stated_weight_are_not_reported(clean):
    """A data set that states gravity along its axis (a vertical shaker) is replayed with the
    weight, which makes the even harmonics: no warning; unstated, the warning says to state it."""
    runs = list(clean.runs)
    runs[1] = _with_second_harmonic(runs[1], 0.03)
    (f,) = check_records(make_dataset(runs), SYSTEM, options=EVEN).findings
    assert "state `gravity_g`" in f.message
    assert not check_records(make_dataset(runs, gravity_g=1.0), SYSTEM, options=EVEN).findings


def test_even_harmonics_below_the_noise_or_the_bound_or_from_the_base_are_not_reported(clean):
    """Clean records raise nothing; a second harmonic of 0.5 % (below delta's 1 % accuracy
    bound) neither; nor a shaker's 5 % distortion of the base (its second harmonic in the
    absolute records, none in the relative response)."""
    assert check_records(clean, SYSTEM, options=EVEN).findings == ()
    small = [_with_second_harmonic(r, 0.005) for r in clean.runs]
    assert check_records(make_dataset(small), SYSTEM, options=EVEN).findings == ()
    shaken = [_with_second_harmonic(r, 0.0, base_share=0.05) for r in clean.runs]
    assert check_records(make_dataset(shaken), SYSTEM, options=EVEN).findings == ()


def test_the_base_distortion_passed_on_by_the_structure_is_not_reported(clean):
    """A base distorted by 5 % at twice its frequency, passed on to the relative response
    3 times amplified (a mode near twice the frequency, less sharp than the resonance's 13 x):
    within what the base can put there, no finding, though it is 1.1 % of the first."""
    runs = []
    for r in clean.runs:
        i = int(r.file[3])
        share = 3 * 0.05 * LEVELS[i] / PEAKS[i]  # at the peak; the envelope falls below it
        runs.append(_with_second_harmonic(r, share, base_share=0.05))
    ds = make_dataset(runs)
    assert check_records(ds, SYSTEM, options=EVEN).findings == ()
    records = Records(ds, SYSTEM, EVEN)
    shares = [even_share(records, rec) for rec in records.runs]
    assert all(0.01 < s["even"] < 0.012 and s["even"] > 4 * s["noise"] and s["base"] > 0.04
               for s in shares)  # only the base's bound keeps it quiet


# ------------------------------------------------------------------ the API
def test_report_views_and_records():
    fs = (Finding("saturation", "a.csv", "x", 80.0, "% of peak", "reject_run", "cut"),
          Finding("dropout", "a.csv", "y", 0.5, "s", "reject_run", "held"),
          Finding("sample_rate", "", "", -2.3, "%", "suspect", "rate"),
          Finding("hum", "b.csv", "x", 0.1, "g", "repaired", "hum"),
          Finding("spike", "b.csv", "x", 50.0, "g", "warning", "spikes"))
    report = RecordReport(fs, None, {"cabling": "no model"})
    assert report.rejected_runs == {"a.csv": "cut; held"}
    assert report.suspect_reasons == ("rate",)
    assert report.warnings == ("spikes",) and report.repairs == ("hum",)
    assert repr(report) == ("RecordReport(2 reject_run, 1 suspect, 1 warning, 1 repaired; "
                            "skipped: cabling)")
    md = report.to_markdown()
    assert md.count("\n| ") == 5 and "cabling not checked: no model" in md
    assert report.to_records()[2] == {"check": "sample_rate", "run": "", "channel": "",
                                      "size": -2.3, "unit": "%", "action": "suspect",
                                      "message": "rate"}
    with pytest.raises(ValueError, match="`action` must be one of"):
        Finding("hum", "", "", math.nan, "", "ignore", "")


def test_options_are_validated_and_the_registry_lists_every_check():
    assert tuple(CHECKS) == CHECK_NAMES and ACTIONS[0] == "reject_run"
    with pytest.raises(ValueError, match="`checks` must name checks of .*saturation"):
        RecordCheckOptions(checks=("clipping",))
    with pytest.raises(ValueError, match="`rate_tolerance` must be a finite number > 0"):
        RecordCheckOptions(rate_tolerance=-1.0)
    with pytest.raises(ValueError, match="`hum_lines_hz`"):
        RecordCheckOptions(hum_lines_hz=())
    assert RecordCheckOptions(checks=("units", "hum")).checks == ("hum", "units")
    with pytest.raises(TypeError, match="`dataset` must be"):
        check_records("examples/fin_sweeps")


def test_a_copied_run_and_a_dead_channel(clean):
    runs = list(clean.runs)
    runs.append(replace(runs[1], file="copy.csv", level_g=1.2))
    dead = runs[0].data.copy()
    dead[1] = 0.0
    runs[0] = replace(runs[0], data=dead)
    report = check_records(make_dataset(runs), SYSTEM,
                           options=RecordCheckOptions(checks=("dropout", "foreign_record")))
    found = {(f.check, f.run, f.channel, f.action) for f in report.findings}
    assert found == {("foreign_record", "copy.csv", "", "reject_run"),
                     ("dropout", "run0.csv", "acc_in", "warning")}
    assert "run1.csv" in report.rejected_runs["copy.csv"]

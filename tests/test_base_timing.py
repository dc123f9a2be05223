"""The base channel's timing read from a test against its replay
(freeplayid.replay.base_timing), its verdict check, and identify's shift of a base read out of
step.

The reference records are analytic: a single-degree-of-freedom base-excited oscillator's
absolute response to a slow linear sweep, written with its transmissibility at the sweep's
instantaneous frequency, and the base itself evaluated at the instants a late channel reads it;
nothing of the package makes them."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from freeplayid.identification.replay_checks import _timing_check
from freeplayid.identification.verdict import LIMITS
from freeplayid.io import Dataset
from freeplayid.replay import BaseTiming, base_timing
from freeplayid.sweep import Sweep

FS = 256.0
LAW = Sweep(start_hz=30.0, stop_hz=50.0, rate_hz_per_s=0.5)
F0 = 40.0  # the oscillator's natural frequency [Hz]


def _records(zeta: float, late_s: float = 0.0, seconds: float = 40.0):
    """(base, response) of one run: the base read ``late_s`` late."""
    t = np.arange(int(seconds * FS)) / FS
    f = LAW.frequency(t)
    r = f / F0
    transmissibility = (1 + 2j * zeta * r) / (1 - r ** 2 + 2j * zeta * r)
    phase = LAW.phase(t)
    base = np.sin(LAW.phase(t - late_s))
    response = np.abs(transmissibility) * np.sin(phase + np.angle(transmissibility))
    return base, response


def _dataset(zeta: float, late_s: float = 0.0) -> Dataset:
    runs = [_records(zeta, late_s) for _ in range(2)]
    return Dataset.from_arrays([np.vstack([resp, 0.5 * resp]) for _, resp in runs],
                               channels={"a": "uz_top_left", "b": "uz_lower_right"},
                               quantity="acceleration", units="g", sample_rate=FS,
                               base=[b for b, _ in runs], sweeps=[LAW.to_dict()] * 2)


SWEEPS = {"run_0": (LAW, "hint", None), "run_1": (LAW, "hint", None)}


@pytest.mark.parametrize("late_samples", [0.25, -0.5, 0.75])
def test_the_delay_is_read_against_a_replay_in_step(late_samples):
    late = late_samples / FS
    timing = base_timing(_dataset(0.03, late), _dataset(0.03), SWEEPS, f_hz=F0)
    assert timing.delay_s == pytest.approx(late, rel=0.02)
    assert set(timing.runs) == {"run_0", "run_1"} and timing.agree
    assert timing.turn_deg == pytest.approx(360 * F0 * late, rel=0.02)
    assert 0.3 < timing.share < 1.0  # the resonant lobe is not read


def test_a_damping_the_replay_does_not_have_is_not_read_as_a_delay():
    # the test damped at 4.5 %, its replay at 3 %: the phase differs most on the resonant lobe,
    # which is not read, and on the flanks it turns one way below the resonance and the other
    # way above, which a delay does not
    timing = base_timing(_dataset(0.045), _dataset(0.03), SWEEPS, f_hz=F0)
    assert timing.below_s < 0 < timing.above_s
    assert not timing.agree
    assert abs(timing.turn_deg) < LIMITS["timing_turn"]
    assert _timing_check(_Replay(timing)).passed
    late = base_timing(_dataset(0.045, 0.5 / FS), _dataset(0.03), SWEEPS, f_hz=F0)
    assert late.agree and late.delay_s == pytest.approx(0.5 / FS, rel=0.1)
    in_step = base_timing(_dataset(0.03), _dataset(0.03), SWEEPS, f_hz=F0)
    assert abs(in_step.delay_s) < 1e-6
    assert base_timing(dataclasses.replace(_dataset(0.03), base_channel=None, runs=tuple(
        dataclasses.replace(r, base=None) for r in _dataset(0.03).runs)), _dataset(0.03),
        SWEEPS) is None


class _Replay:
    def __init__(self, timing):
        self.base_timing = timing


def _timing(runs_ms, f_hz=40.0):
    runs = {f"r{k}": v * 1e-3 for k, v in enumerate(runs_ms)}
    return BaseTiming(delay_s=float(np.median(list(runs.values()))), runs=runs,
                      sample_rate=FS, share=0.7, f_hz=f_hz)


def test_the_check_reads_the_turn_at_the_points_and_whether_the_runs_agree():
    ok = _timing_check(_Replay(_timing([0.1, 0.12, 0.09])))  # 1.5 degrees at 40 Hz
    assert ok.passed and "limit 3 degrees" in ok.message
    late = _timing_check(_Replay(_timing([0.9, 0.89, 0.88])))  # 13 degrees, one delay
    assert not late.passed and "`base_delay_s`" in late.message
    assert late.value == pytest.approx(360 * 40 * 0.89e-3 / 3, rel=1e-6)
    mixed = _timing_check(_Replay(_timing([0.9, -0.2, 0.5])))
    assert not mixed.passed and "not by one delay" in mixed.message
    assert _timing_check(_Replay(None)) is None
    assert _timing_check(_Replay(dataclasses.replace(_timing([0.1]), delay_s=math.nan))) is None


def test_identify_shifts_a_base_read_out_of_step_by_its_estimate():
    from freeplayid import identify
    from freeplayid.acquisition import shifted
    from freeplayid.io import bundled_example, read_dataset

    example = read_dataset(bundled_example())
    example = dataclasses.replace(example, runs=tuple(
        r for r in example.runs if r.level_g in (0.8, 1.0, 1.2)))
    late = 0.25 / example.sample_rate  # 14 degrees at the points' 40-44 Hz
    skewed = dataclasses.replace(example, runs=tuple(
        dataclasses.replace(r, base=shifted(r.base, example.sample_rate, -late))
        for r in example.runs))
    res = identify(skewed, progress=False)
    assert res.dataset["base_delay_source"] == "estimated"
    assert res.dataset["base_delay_s"] == pytest.approx(late, rel=0.15)
    timing = next(c for c in res.verdict.checks if c.name == "base_timing")
    assert timing.passed and "shifted back into step" in timing.message
    assert abs(res.truth_error["delta"]) < 0.01 and abs(res.truth_error["kn"]) < 0.02
    assert "base channel's timing: the base channel read" in res.report()
    # the delay's uncertainty: what the answer's replay still reads at least, and in the
    # intervals (wider than the answer's own by the move it makes)
    u = res.dataset["base_delay_uncertainty_s"]
    assert u >= abs(res.replay.base_timing.delay_s) and u < 0.5 * late
    assert "widened by the estimated base delay's uncertainty" in res.interval_source
    assert "the delay is known to" in timing.message


def test_the_estimated_delays_uncertainty_and_the_move_it_makes():
    from types import SimpleNamespace

    from freeplayid.identification.pipeline import _delay_moves, _delay_uncertainty

    timing = _timing([0.1, 0.2, 0.3])  # ms
    remains = dataclasses.replace(timing, delay_s=-0.5e-4)
    answer = SimpleNamespace(replay=_Replay(remains))
    # what remains, plus 1.96 standard errors of the median of three runs (sd 1e-4)
    assert _delay_uncertainty(answer) == pytest.approx(0.5e-4 + 1.96 * 1.25e-4 / math.sqrt(3))
    # plus half what the two sides of the resonance read apart
    sided = dataclasses.replace(remains, below_s=-2e-4, above_s=1e-4)
    assert _delay_uncertainty(SimpleNamespace(replay=_Replay(sided))) == pytest.approx(
        0.5e-4 + 1.96 * 1.25e-4 / math.sqrt(3) + 1.5e-4)
    assert math.isnan(_delay_uncertainty(SimpleNamespace(replay=_Replay(None))))
    # the slope the shift showed: 1 ms moved delta by 2 % and kn by -1 %
    first = SimpleNamespace(kn=1.0, delta=1.0)
    shifted = SimpleNamespace(kn=0.99, delta=1.02)
    kn, delta = _delay_moves(first, shifted, 1e-3, 2e-4)
    assert delta == pytest.approx(0.2 * math.log(1.02))
    assert kn == pytest.approx(0.2 * abs(math.log(0.99)))
    assert _delay_moves(first, shifted, 1e-3, math.nan) == (0.0, 0.0)


def test_a_turn_that_the_shift_does_not_remove_is_not_called_a_delay():
    from freeplayid.identification.replay_checks import timing_not_a_delay

    one_delay = _Replay(_timing([0.9, 0.89, 0.88]))  # 13 degrees at 40 Hz, the runs agree
    note = timing_not_a_delay(one_delay, "did not remove it")
    assert not note.passed and note.name == "base_timing"
    assert "did not remove it, so the turn is not a delay" in note.message
    assert "`base_delay_s`" not in note.message and "damping of another form" in note.message
    assert note.value == pytest.approx(_timing_check(one_delay).value)
    assert timing_not_a_delay(_Replay(_timing([0.1, 0.12, 0.09])), "x") is None  # 1.5 degrees
    assert timing_not_a_delay(_Replay(None), "x") is None


@dataclasses.dataclass(frozen=True)
class _Result:  # the fields of an Identification that the shift reads
    replay: object
    verdict: object
    failure: str = ""


def _answer_of(timing):
    from freeplayid.identification.pipeline import _Answer
    from freeplayid.identification.verdict import make_verdict

    replay = _Replay(timing)
    replay.failure = ""
    checks = [_timing_check(replay)]
    return _Answer(dataset=_dataset(0.03), system=None, est=None, error=None,
                   result=_Result(replay, make_verdict(checks)))


def test_a_shift_that_leaves_the_delay_keeps_the_first_answer_and_says_why(monkeypatch):
    from freeplayid.identification import pipeline

    first = _answer_of(_timing([0.9, 0.89, 0.88]))
    # the test identified again with its base shifted reads the same delay: not a delay
    monkeypatch.setattr(pipeline, "_answer", lambda *a, **k: _answer_of(_timing([0.9, 0.88])))
    kept, delay, rejected = pipeline._with_the_base_in_step(first, None, None, None, None, None,
                                                            None, 0.0, False)
    assert kept is first and delay is None
    assert rejected == "did not remove it (its replay read +0.89 ms, against +0.89 ms before)"
    said = pipeline._not_a_delay(first.result, rejected)
    check = next(c for c in said.verdict.checks if c.name == "base_timing")
    assert not check.passed and said.verdict.status == "suspect"
    assert "so the turn is not a delay" in check.message and rejected in check.message
    # a shift that cannot be identified is said so; a shift that halves the delay is kept
    from freeplayid.errors import IdentificationError

    def fails(*a, **k):
        raise IdentificationError("0 usable fitting point(s)")

    monkeypatch.setattr(pipeline, "_answer", fails)
    assert pipeline._with_the_base_in_step(first, *[None] * 6, 0.0, False)[2] == (
        "could not be identified (0 usable fitting point(s))")
    # and the delay stated is the one the kept answer's base was shifted by: a refining round
    # whose shift is not kept (0.1 ms read again, not halved) adds nothing to it
    monkeypatch.setattr(pipeline, "_answer", lambda *a, **k: _answer_of(_timing([0.1, 0.1])))
    kept, delay, rejected = pipeline._with_the_base_in_step(first, *[None] * 6, 0.0, False)
    assert kept is not first and delay == pytest.approx(0.89e-3) and rejected == ""
    # a base_timing check that passes (or none) is left as it is
    passing = _answer_of(_timing([0.1, 0.12, 0.09])).result
    assert pipeline._not_a_delay(passing, "x") is passing

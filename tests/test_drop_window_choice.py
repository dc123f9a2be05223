"""identify's choice of the drop points' window on a noisy test without a base channel
(``Replay.noisy_window``; docs/identify.md section 3c, "A noisy test without a base channel"):
when it is tried, and the specification test that decides between the two answers."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from freeplayid.identification.pipeline import _apart, _noisy_drops, _union, _windows_agree
from freeplayid.replay import Replay
from freeplayid.signal import Extraction


def _answer(kn, delta, *, hw_kn, hw_delta, rule="drop", failure=""):
    prec = SimpleNamespace(kn_halfwidth=hw_kn, delta_halfwidth=hw_delta)
    return SimpleNamespace(kn=kn, delta=delta, replay=SimpleNamespace(
        precision=prec, jump_point=rule, failure=failure))


@pytest.mark.parametrize(("change", "tried"), [
    ({}, True),  # drop points, noise as far as delta's 1 % bound
    ({"hw_delta": 0.009}, False),  # the noise keeps delta within its bound
    ({"rule": "quadrature"}, False),  # a base channel: tried, not kept (identify.md 3c)
    ({"failure": "no replay could be fitted"}, False),
    ({"hw_delta": None}, False),  # no precision measured
])
def test_the_wider_window_is_tried_only_on_drop_points_that_noise_could_put_beyond_the_bound(
        change, tried):
    kw = {"hw_kn": 0.006, "hw_delta": 0.012, **change}
    result = _answer(900.0, 3e-3, **kw)
    assert _noisy_drops(result, Replay(), Extraction()) is tried


def test_the_wider_window_is_not_tried_when_asked_not_to_or_already_wide():
    result = _answer(900.0, 3e-3, hw_kn=0.006, hw_delta=0.02)
    assert not _noisy_drops(result, Replay(noisy_window=1.0), Extraction())
    assert not _noisy_drops(result, Replay(), Extraction(drop_window=2.0))
    with pytest.raises(ValueError, match="`noisy_window` must be a finite number"):
        Replay(noisy_window=0.5)


@pytest.mark.parametrize(("delta_move", "passed"), [
    (1.02, True),  # log 1.02 = 1.98 % over 0.884 %: 2.24 standard deviations
    (1.03, False),  # log 1.03 = 2.96 %: 3.35 of them, beyond 3
    (0.975, True),  # -2.53 %: 2.87
])
def test_two_windows_agree_within_the_noise_of_their_difference(delta_move, passed):
    """Half-widths 2 % and 1 % of delta (s = 1.020 % and 0.510 %): the difference's standard
    deviation sqrt(s1^2 - s2^2) = 0.884 %, by hand; the limit is cross_p's 3.0."""
    first = _answer(900.0, 3.0e-3, hw_kn=0.01, hw_delta=0.02)
    second = _answer(900.0, 3.0e-3 * delta_move, hw_kn=0.005, hw_delta=0.01)
    ok, message, z = _windows_agree(first, second, 4.0)
    s1, s2 = 0.02 / 1.96, 0.01 / 1.96
    assert z == pytest.approx(abs(math.log(delta_move)) / math.sqrt(s1 ** 2 - s2 ** 2), rel=1e-9)
    assert ok is passed
    assert "read over 4 windows" in message
    if passed:
        assert "reported, the answer read over 4 windows" in message
    else:
        assert "damping of another form" in message and "one-window answer" in message


def test_the_difference_noise_is_never_below_half_the_first_answers():
    """Variances read from a few copies: a second half-width just under the first's would make
    the difference's noise all but 0; it is held at half the first's standard deviation."""
    first = _answer(900.0, 3.0e-3, hw_kn=0.01, hw_delta=0.02)
    s1 = 0.02 / 1.96
    second = _answer(900.0, 3.0e-3 * math.exp(2.9 * 0.5 * s1), hw_kn=0.0099, hw_delta=0.0199)
    ok, _, z = _windows_agree(first, second, 4.0)
    assert ok and z == pytest.approx(2.9, rel=1e-9)
    kn_off = _answer(900.0 * math.exp(3.1 * 0.5 * 0.01 / 1.96), 3.0e-3, hw_kn=0.0099,
                     hw_delta=0.0199)
    assert _windows_agree(first, kn_off, 4.0)[0] is False  # kn judged as delta is


def test_a_wider_window_no_more_precise_is_not_taken():
    first = _answer(900.0, 3.0e-3, hw_kn=0.01, hw_delta=0.02)
    ok, message, z = _windows_agree(first, _answer(900.0, 3.0e-3, hw_kn=0.01, hw_delta=0.021),
                                    4.0)
    assert ok is None and z is None and "no more precise" in message
    ok, message, _ = _windows_agree(first, _answer(900.0, 3.0e-3, hw_kn=None, hw_delta=None),
                                    4.0)
    assert ok is None and "no precision" in message


def test_the_message_names_kn_s_move_where_kn_has_no_half_width():
    """kn's copies gave no half-width: judged on delta alone, and the message still gives kn's
    own move, not delta's."""
    first = _answer(900.0, 3.0e-3, hw_kn=None, hw_delta=0.02)
    second = _answer(909.0, 3.03e-3, hw_kn=None, hw_delta=0.01)
    ok, message, z = _windows_agree(first, second, 4.0)
    s1, s2 = 0.02 / 1.96, 0.01 / 1.96
    assert z == pytest.approx(math.log(1.01) / math.sqrt(s1 ** 2 - s2 ** 2), rel=1e-9)
    assert ok and "delta +1 %, kn +1 %" in message
    second = _answer(918.0, 3.03e-3, hw_kn=None, hw_delta=0.01)
    assert "delta +1 %, kn +2 %" in _windows_agree(first, second, 4.0)[1]


@pytest.mark.parametrize(("kn2", "delta2", "named"), [
    (900.0 * 1.015, 3.0e-3 * 1.009, ()),  # both moves within the bounds
    (900.0, 3.0e-3 * 1.02, ("delta +2 %",)),  # delta moves past its 1 % bound
    (900.0 * 0.97, 3.0e-3, ("kn -3 %",)),  # kn past its 2 %
    (900.0 * 1.03, 3.0e-3 * 0.98, ("delta -2 %", "kn +3 %")),
])
def test_answers_that_agree_within_the_noise_but_lie_further_apart_than_the_bounds_are_named(
        kn2, delta2, named):
    """At a half-width at delta's bound the specification test passes moves of 2-3 %, which
    damping of another form gives the wider reading: such a pair cannot both be called within
    the bounds, and the reason names each move past its bound."""
    first = _answer(900.0, 3.0e-3, hw_kn=0.01, hw_delta=0.02)
    second = _answer(kn2, delta2, hw_kn=0.004, hw_delta=0.006)
    why = _apart(first, second)
    if not named:
        assert why is None
        return
    assert all(n in why for n in named) and "another form" in why
    assert ("delta" in why) == any("delta" in n for n in named)


def test_the_joined_interval_holds_both_intervals_and_so_the_first_answer():
    """The answers' intervals hold their answers, so the join of the two holds the one-window
    answer too (the hinges' split joins its intervals with the same ``_union``)."""
    assert _union((1.0, 2.0), (1.5, 2.5)) == (1.0, 2.5)
    assert _union((1.2, 2.0), (1.5, 2.5)) == (1.2, 2.5)

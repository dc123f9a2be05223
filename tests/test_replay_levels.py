"""The levels a test's upper branches imply (:func:`freeplayid.replay.misfit.implied_levels`),
against the steady-state curves of a freeplay oscillator by harmonic balance, written here.

The reference: one mode with a symmetric freeplay (half-gap ``DELTA``, contact stiffness
w_n^2), whose describing-function stiffness at amplitude A > DELTA is
k(A) = w_n^2 (1 - (2 / pi) (asin(r) + r sqrt(1 - r^2))), r = DELTA / A; the forced response at
level L and angular frequency w solves A^2 ((k(A) - w^2)^2 + (2 zeta w_n w)^2) = L^2. Swept up,
the response rides the largest root (the upper branch) until it vanishes at the fold, then
falls to the smallest: the jump. Inside the gap (A <= DELTA) k = 0.
"""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from freeplayid.replay.misfit import implied_levels
from freeplayid.signal import AmplitudeCurve

WN, ZETA, DELTA = 2 * math.pi * 40.0, 0.02, 1e-3
F = np.linspace(20.0, 45.0, 2501)  # [Hz], an up-sweep
A = np.geomspace(0.01 * DELTA, 40 * DELTA, 40000)


def _stiffness(a):
    r = np.minimum(DELTA / a, 1.0)  # in the gap (A <= DELTA) no contact: k = 0
    return WN**2 * (1 - (2 / math.pi) * (np.arcsin(r) + r * np.sqrt(1 - r * r)))


def up_sweep(level) -> np.ndarray:
    """Amplitude [m] of the up-sweep at each F: the upper branch until its fold, then the lower
    one. ``level``: one level, or one per frequency of F (a level that varies along the sweep)."""
    level = np.broadcast_to(np.asarray(level, float), F.shape)
    k = _stiffness(A)
    out, upper = np.empty(F.size), True
    for i, (f, lv) in enumerate(zip(F, level, strict=True)):
        w = 2 * math.pi * f
        res = A * A * ((k - w * w) ** 2 + (2 * ZETA * WN * w) ** 2) - lv * lv
        s = np.nonzero(np.sign(res[:-1]) != np.sign(res[1:]))[0]
        roots = A[s] - res[s] * (A[s + 1] - A[s]) / (res[s + 1] - res[s])
        # on the upper branch while its root goes on from the last one; past the fold only
        # the lower branch is left, far below
        upper = upper and (i == 0 or roots.max() > 0.8 * out[i - 1])
        out[i] = roots.max() if upper else roots.min()
    return out


def _curve(x, channel="c"):
    return AmplitudeCurve("r", channel, F, x)


def _point(x):
    j = int(np.argmax(x))  # the jump: the last sample on the upper branch
    return SimpleNamespace(run="r", channel="c", f_hz=float(F[j]), amplitude_m=float(x[j]))


@pytest.fixture(scope="module")
def curves():
    level = 20.0  # [m/s^2]: the fold near 37 Hz at 8.6 half-gaps
    u = 0.05
    return level, u, up_sweep(level), up_sweep(level * (1 + u))


@pytest.mark.parametrize("error", [0.0, 0.03, -0.04])
def test_a_constant_level_error_is_read_from_the_upper_branch(curves, error):
    level, u, replayed, raised = curves
    measured = up_sweep(level * (1 + error))
    got = implied_levels([_point(measured)], [_curve(measured)], [_curve(replayed)],
                         [_curve(raised)], u)
    e, rest = got["r"].error, got["r"].rest
    # first order in the level: the error of the linear reading grows as e (e - u) / 2
    assert e == pytest.approx(error, abs=0.15 * abs(error) + 1e-4)
    assert rest < 2e-3  # of the peak: a constant level explains the branch


def test_a_level_that_dips_before_the_jump_is_not_a_constant_level(curves):
    level, u, replayed, raised = curves
    measured = up_sweep(level * (1 - 0.03))
    fold = F[np.argmax(measured)]
    dip = 1 - 0.3 * np.exp(-0.5 * ((F - fold) / 0.8) ** 2)  # 30 % at the jump
    dipped = up_sweep(level * dip)
    rest_const = implied_levels([_point(measured)], [_curve(measured)], [_curve(replayed)],
                                [_curve(raised)], u)["r"].rest
    got = implied_levels([_point(dipped)], [_curve(dipped)], [_curve(replayed)],
                         [_curve(raised)], u)["r"]
    e, rest = got.error, got.rest
    assert e < -0.01  # a lower level on the branch, on average (-2.7 % here)
    assert rest > 10 * rest_const  # 0.39 % of the peak against 0.02 %


def test_one_level_explains_every_channel_and_another_structure_does_not(curves):
    # two channels of one mode, the second half the first in the replay: a level error scales
    # both alike (one level for both); a measured second channel 6 % stronger than the replay
    # has it (another mode shape: another structure) needs a level of its own
    level, u, replayed, raised = curves
    measured = up_sweep(level * 1.03)

    def implied(ratio):
        m = [_curve(measured), _curve(ratio * measured, "b")]
        r = [_curve(replayed), _curve(0.5 * replayed, "b")]
        q = [_curve(raised), _curve(0.5 * raised, "b")]
        return implied_levels([_point(measured)], m, r, q, u)["r"]

    same = implied(0.5)
    assert same.channels["c"] == pytest.approx(same.channels["b"], abs=1e-9)
    assert same.error == pytest.approx(0.03, abs=0.005) and same.spread < 1e-9
    other = implied(0.53)
    assert other.channels["c"] == pytest.approx(same.channels["c"], abs=1e-9)
    assert other.spread > 0.1  # 6 % of the amplitude near the fold is a far larger level

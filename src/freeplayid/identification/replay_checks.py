"""The verdict's checks of the replay: does the replay at the reported answer reproduce the test?

- ``replay_failed``: the test could not be replayed, or a replay could not be fitted.
- ``replay_misfit``: each run's replay at the answer against the test where the fit takes its
  information: the statistic point's place against the backbone at the answer (its relative
  distance f / f_BC(X) - 1, replayed minus measured) within ``backbone_offset`` (0.2 %, about a
  0.4 % move of kn), or within ``offset_se`` (3) standard errors of that offset where the data's
  noise makes that larger (:attr:`freeplayid.replay.RunMisfit.offset_se`: the answer's replay
  read through the test's noise, on noisy copies with each channel's and the base's measured
  noise; what the replay does not reproduce does not count as noise). A point that only moves
  along the backbone
  (another damping puts the phase resonance at another amplitude) does not move the answer and
  does not fail; the peaks and the upper branches are reported beside it (a replay of the right
  model lands 0.01-0.03 % from each run's jump and 0.1-0.5 % from its peak on the bundled
  example, 0.05 g noise). One run off among four or more passes where the answer without that
  run (:attr:`freeplayid.replay.RunMisfit.without`) moves by no more than ``without_delta`` /
  ``without_kn`` (half the accuracy bounds): the answer does not rest on it; the reason still
  names the run and its offset.
- ``replay_consistency`` (the drop or maxima statistics): the answer's replay against the test
  on a second statistic it was not fitted to (:class:`freeplayid.replay.CrossCheck`); apart by
  more than ``cross_delta`` / ``cross_kn`` (half the accuracy bounds) and as many standard errors
  as a two-sided ``cross_p`` (3 normal standard errors' 0.27 %) allows at their degrees of
  freedom (Student's t: 6.6 with four).
- ``noise_precision``: how far the test's noise alone moves the answer, measured on noisy copies
  of its replay (:class:`freeplayid.replay.ReplayPrecision`: 1.96 standard deviations of their
  fits, carried to the answer through the binding's slope): fails where the chance that the
  noise alone puts delta beyond its accuracy bound (``accuracy_delta``, 1 %) or kn beyond its
  own (``accuracy_kn``, 2 %) exceeds ``noise_outside`` (20 %), the error taken as normal with
  that spread about the mean move the copies show against the same replay read without noise
  (``noise_bias``: a statistic read under noise need not be centred on the noise-free one),
  that mean's standard error added to the spread, and where the replays are driven by a noisy
  base record, that noise's own spread (:class:`freeplayid.replay.ExcitationNoise`) added in
  quadrature, as in the intervals. On the default
  fin at 0.05 g of noise the copies spread by about 0.5 % (sd) in delta (a 5 % chance), on a
  fin whose responses are three times weaker against the same noise by about 1 % (32 %).
- ``replay_level`` (runs whose levels come from ``level_g``: no base channel): the levels the
  runs' upper branches imply at the answer (:class:`freeplayid.replay.LevelSensitivity`: each
  run's level error, read on the branch short of its jump against the answer's replay and the
  same replay at levels 5 % higher) are reported, and an error beyond the stated uncertainty
  widens the intervals. A level scales every channel alike, so where two or more channels read
  the branches, each channel's own level error differs from the others' only where the replay's
  amplitude ratio between them is not the test's: that difference, carried to kn through one
  more replay at kn 2 % higher, is kn's error that the channels' ratios imply
  (``ratio_kn``), and the runs' scatter about it its standard error. Beyond kn's accuracy bound
  (``accuracy_kn``, 2 %) and as many standard errors as the two-sided ``cross_p`` allows at its
  degrees of freedom (as ``replay_consistency``) the check fails: the replay at the answer is
  another structure than the tested one by more than the answer may be off. On the held-out
  study two accurate answers put it +2.8 / -3.6 % off with standard errors of 2.1 / 3.9 %
  (runs whose channels hardly move with kn); the dips below, 19-71 standard errors. On
  a level that dips 20-45 % around each jump, which no record shows without a base channel, the
  drop points put kn 2.7-5.5 % low and the channels' ratios put it +3.5 to +5.8 % from the
  answer; a constant level 4-5 % off, a level ramp, Rayleigh damping, a log sweep, more noise
  leave it within 1.3 % (40 answers of benchmarks/realtests, docs/results.md).
  The check also states how far the levels' stated uncertainty moves the answer
  (:meth:`freeplayid.replay.LevelSensitivity.describe`, which the report shows too): the
  answer is conditional on ``level_g``, with no limit, since where the damping is estimated
  from the same amplitudes the branches cannot show a level error (docs/identify.md §3c,
  "What the answer owes to the levels").
- ``damping_form`` (the damping's exponent or its hinge damper's share estimated,
  ``replay.damping_exponent`` / ``replay.damping_hinge``): how far it moved the answer from
  one ratio's (its value: that move over the accuracy bounds); beyond twice them
  (``form_move``) the check fails: the answer then rests on a one-parameter form, which has
  left up to half its move on independent beams. It is estimated only with a base channel to
  replay: without one a level that drifts during the runs drifts the replayed peaks with the
  level as damping that rises with the mode does. There (``replay.damping_forms``, default on)
  the binding is solved again under three other forms, damping rising with the mode (p = 1), a
  damper across each hinge (q = 0.5) and one acting only in contact (qc, its share searched
  along the curves); the form whose replay meets the measured curves more
  than 10 % nearer than one ratio's and than the other form's is reported, a form whose
  replay meets them within 10 % of the reported answer's is not ruled out by them (so where
  two forms meet them about as near, neither is taken and both count), and the check fails
  where such a form moves the answer beyond the accuracy bounds (``damping_delta``,
  ``damping_kn``); its move is in the intervals (:class:`freeplayid.replay.FormSensitivity`).
- ``antialias`` (points above 0.3 of the sample rate, where the simulator's default
  anti-alias filter attenuates: -0.8 % at 0.336; the replays are then decimated flat): the
  answer's move were the records' own filter that default instead
  (:class:`freeplayid.replay.AcquisitionFilter`; the intervals reach to it); fails beyond half
  the accuracy bounds (``antialias_delta`` 0.5 %, ``antialias_kn`` 1 %), as a second
  statistic's move does: the answer then rests on a filter the data set does not state
  (``Replay.antialias``). Fin C's points at 0.31-0.34 fs move delta by about 1.2 %.
- ``replay_branch`` (points read at the phase resonance, against the base channel's phase):
  each run's upper branch, the replay at the answer against the test (:attr:`freeplayid.replay.
  RunMisfit.branch`: the median difference over the lobe up to the point, relative to the
  peak): the median run's within ``branch`` (1.5 %). With the base channel the replay is driven
  at the measured level and phase, so its branches follow the test's; where the points
  themselves are read wrong, the fit matches them at another (kn, delta) and every run's branch
  parts from the test's: a base channel read a quarter sample late at 256 Hz (14 degrees at 40
  Hz) gave delta -3 %, kn +2 % and every run's branch 2.1-2.5 % off; the points (their relative
  motion and phase) rest on the base's timing against the responses, which no other check
  reads. Damping of another form than the replay's parts the lowest run's branch most (more
  damping in contact: 1.8 % there, 0.2-0.9 % on the others), so one run is not a reading error.
- ``base_timing`` (a base channel): how late the base channel reads against the responses,
  from the test's phase against the replay's at the answer away from the resonances
  (:class:`freeplayid.replay.BaseTiming`), as the turn it gives the phase at the points'
  frequency: within ``timing_turn`` (3 degrees). Where the runs read one delay beyond it, the
  answer rests on a base read out of step (``identify`` then shifts the base by the estimate
  and identifies the test again, :func:`freeplayid.identification.pipeline.identify`); where
  they disagree, or where that shift did not bring the replay closer to the test
  (:func:`timing_not_a_delay`), the phase is not turned by a delay but by a structure the
  replay is not.
- ``sweep_law``, ``replay_binding``, ``replay_converged``, ``damping_estimate``: where the laws
  came from, a replayed fit that jumps, convergence and an estimated damping the amplitudes pin
  down (:mod:`freeplayid.identification.verdict`).

Each reason names what it measured and the causes that produce it.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.stats

from ..replay.binding_jump import worst_jump
from ..replay.corrected import FORM_ATOL, FORM_FIT_NOISE
from .verdict import LIMITS, Check, within_binding_noise

__all__ = ["replay_checks", "run_branches", "precision_check", "noise_outside_chance", "settled_sd",
           "SETTLED_CHANCE", "timing_not_a_delay"]


def _causes(replay, down: bool = False) -> str:
    """What makes a replay miss a test it was fitted to, given what it already replays
    (``down``: a run that sweeps down is among the ones missed)."""
    causes = ["damping of another form than the replay's", "a linear model that is not the "
              "tested structure", "unequal gaps"]
    if down:
        causes.insert(0, "a down-sweep's jump-up, which leaves the lower branch at a place "
                      "that small differences move")
    if getattr(replay, "excitation", "law") != "measured":
        causes.append("a level profile or sweep law the replay does not know (no base channel "
                      "to replay)")
    return ", ".join(causes[:-1]) + " or " + causes[-1]


def _resonance_check(replay, down_runs=()) -> Check:
    """``replay_misfit``: every run's statistic point against the backbone at the answer, with
    its peak and upper branch for the record (module docstring); ``down_runs`` sweep down (their
    statistic is the jump up)."""
    misfits = getattr(replay, "resonance", None) or {}
    if not misfits:
        return Check("replay_misfit", True, "no replayed point to compare")
    what = "phase resonance" if replay.jump_point == "quadrature" else "jump"

    def limit(m):  # the accuracy that matters, or the data's noise where that is larger
        se = getattr(m, "offset_se", math.nan)
        noise = LIMITS["offset_se"] * se if math.isfinite(se) else 0.0
        return max(LIMITS["backbone_offset"], noise)

    def point(run):
        return f"jump up ({what})" if run in down_runs else what

    off = {run: m for run, m in misfits.items()
           if math.isfinite(m.backbone_offset) and abs(m.backbone_offset) > limit(m)}

    def without(m):  # the answer's move were the run left out, as words ("" if not measured)
        w = getattr(m, "without", None)
        return "" if w is None else (f"; without it the answer moves delta {100 * w[1]:+.2g} %, "
                                     f"kn {100 * w[0]:+.2g} %")

    bad = [f"run {run}: its {point(run)} {100 * abs(m.backbone_offset):.2g} % "
           f"{'above' if m.backbone_offset > 0 else 'below'} the measured one's place against "
           f"the backbone ({m.f_offset * m.f_hz:+.2g} Hz, the peak {100 * m.peak_offset:+.2g} %;"
           f" limit {100 * limit(m):.2g} %{without(m)})" for run, m in off.items()]
    alone = _one_run_aside(off, misfits)
    ratios = [abs(m.backbone_offset) / limit(m) for m in misfits.values()
              if math.isfinite(m.backbone_offset)]
    worst = max(ratios, default=0.0)
    largest = max((abs(m.backbone_offset) for m in misfits.values()
                   if math.isfinite(m.backbone_offset)), default=0.0)
    noise = [LIMITS["offset_se"] * m.offset_se for m in misfits.values()
             if math.isfinite(getattr(m, "offset_se", math.nan))]
    samples = max((getattr(m, "offset_se_samples", 0) for m in misfits.values()), default=0)
    rule = (f"limit {100 * LIMITS['backbone_offset']:g} %, or {LIMITS['offset_se']:g} standard "
            f"errors of the data's noise where larger: {100 * max(noise):.2g} %, measured on "
            f"{samples} points of the replay's noisy copies"
            if noise else f"limit {100 * LIMITS['backbone_offset']:g} %")
    peaks = max(abs(m.peak_offset) for m in misfits.values())
    branch = max((m.branch for m in misfits.values() if math.isfinite(m.branch)), default=0.0)
    shape = (f"; its peaks differ by up to {100 * peaks:.2g} % and its upper branches by "
             f"{100 * branch:.2g} % of the peak")
    if peaks > LIMITS["peak_amplitude"] and not bad:
        shape += (f" (the replay's damping is not the test's; the {what} points the answer "
                  "rests on are reproduced)")
    if not bad:
        return Check("replay_misfit", True,
                     f"the replay at the answer puts every run's {what} where the test has it "
                     f"against the backbone (within {100 * largest:.2g} %; {rule})" + shape,
                     worst)
    if alone:
        return Check("replay_misfit", True,
                     f"the replay at the answer puts every run's {what} where the test has it "
                     f"against the backbone but one ({rule}): " + bad[0] + ", within half the "
                     f"accuracy bounds, so the answer does not rest on that run{shape} (that "
                     f"run's point: {_causes(replay, bool(set(off) & set(down_runs)))}?)", worst)
    down = any(run in down_runs for run in off)
    return Check("replay_misfit", False,
                 f"the replay at the answer does not reproduce the test's {what} points: "
                 + "; ".join(bad) + f" ({rule}){shape} ({_causes(replay, down)}?)", worst)


def _one_run_aside(off: dict, misfits: dict) -> bool:
    """Whether the only run off (``off``, of four or more in ``misfits``) can be set aside: the
    answer without it moves by no more than ``without_delta`` / ``without_kn``."""
    return len(off) == 1 and _set_aside(getattr(next(iter(off.values())), "without", None),
                                       len(misfits))


def _set_aside(without, runs: int) -> bool:
    """Whether the answer does not rest on one run of ``runs``: four runs or more, and its move
    were that run left out (``without``: relative kn, delta; None where not measured) no more
    than ``without_delta`` / ``without_kn`` (half the accuracy bounds)."""
    return (without is not None and runs >= 4 and abs(without[1]) <= LIMITS["without_delta"]
            and abs(without[0]) <= LIMITS["without_kn"])


def _noise_limit(se: float, dof: float) -> float:
    """``se`` times Student's t at the two-sided ``cross_p`` (the normal's 3 standard errors)
    and ``dof`` degrees of freedom (inf: the normal); inf without a degree of freedom."""
    if not dof >= 1:
        return math.inf
    return float(scipy.stats.t.isf(LIMITS["cross_p"] / 2, dof)) * se


def _consistency_check(replay) -> Check | None:
    """``replay_consistency``: the answer on a second statistic (module docstring)."""
    cross = getattr(replay, "cross", None)
    if cross is None:
        return None
    off = []
    for name, shift, se, tol in (("delta", cross.delta_shift, cross.delta_se,
                                  LIMITS["cross_delta"]),
                                 ("kn", cross.kn_shift, cross.kn_se, LIMITS["cross_kn"])):
        limit = max(tol, _noise_limit(se, cross.dof)) if math.isfinite(se) else tol
        if abs(shift) > limit:
            off.append(f"{name} {100 * shift:+.2g} % (limit {100 * limit:.2g} %)")
    value = max(abs(cross.delta_shift) / LIMITS["cross_delta"],
                abs(cross.kn_shift) / LIMITS["cross_kn"])
    if not off:
        return Check("replay_consistency", True,
                     f"the replay at the answer also reproduces the points taken with "
                     f"`{cross.rule}` (delta {100 * cross.delta_shift:+.2g} %, kn "
                     f"{100 * cross.kn_shift:+.2g} %)", value)
    return Check("replay_consistency", False,
                 f"the replay at the answer reproduces the `{replay.jump_point}` points it was "
                 f"fitted to but not the `{cross.rule}` points, which put the answer elsewhere: "
                 + ", ".join(off) + f" ({_causes(replay)}?)", value)


def _form_check(replay) -> Check | None:
    """``damping_form``: with the damping's exponent (or its hinge damper's share) estimated, how
    far it moved the answer from the one ratio's (reported; the move is in the intervals through
    its own uncertainty). None where neither was estimated."""
    formed = getattr(replay, "form_sensitivity", None)
    if formed is not None:
        return _unread_form_check(formed)
    d = getattr(replay, "damping", None)
    form = getattr(d, "form_estimated", None)
    if form is None or getattr(d, "single_ratio_answer", None) is None:
        return None
    kn1, delta1 = d.single_ratio_answer
    move = (math.log(replay.kn / kn1), math.log(replay.delta / delta1))
    what = (f"the damping's exponent {d.exponent:.2g} (the higher closed modes damped more"
            if form == "exponent" else
            f"the hinge damper's share {d.hinge:.2g} (a damper across each hinge")
    said = (what + ", estimated from how the replayed peaks change with the level"
            + ("" if d.trend_single is None else
               f": {100 * d.trend_single:+.2g} % per e-fold of level with one ratio")
            + f") moved the answer by delta {100 * move[1]:+.2g} %, kn {100 * move[0]:+.2g} %")
    value = max(abs(move[1]) / LIMITS["accuracy_delta"], abs(move[0]) / LIMITS["accuracy_kn"])
    if value <= LIMITS["form_move"]:
        return Check("damping_form", True, said, value)
    return Check("damping_form", False,
                 "the answer rests on the form the replay gave the damping: " + said
                 + f", more than {LIMITS['form_move']:g} times the accuracy bounds. That form "
                 "fits the peaks' trend with the level, not the structure's damping (Rayleigh "
                 "damping or a damper elsewhere than the hinges), and half such a move would "
                 "reach the bounds; the structure's damping matrix in the model file (the "
                 "replay then uses it) or its measured modal ratios would settle it", value)


def _unread_form_check(formed) -> Check:
    """``damping_form`` where the test cannot read the damping's form from the peaks' trend (no
    base channel): the answer's largest move under the other forms whose replays meet the
    measured curves about as near as the answer's or nearer (:meth:`freeplayid.replay.
    FormSensitivity.counted`) over the accuracy bounds; beyond them (as a down-sweep's
    unmeasured damping, ``damping_delta`` / ``damping_kn``) the check fails: a form the data do
    not rule out would put the answer outside."""
    said = ("the damping's form, which a test without a base channel does not measure, "
            "replayed otherwise moves the answer: " + formed.describe())
    tied = formed.tied()
    if tied:
        said += ("; the curves rule out one ratio in every mode but cannot tell "
                 + " from ".join(a.label for a in tied) + " (their replays meet them within "
                 f"{100 * FORM_FIT_NOISE:g} % of each other), so neither was taken")
    value = max(formed.delta_shift / LIMITS["damping_delta"],
                formed.kn_shift / LIMITS["damping_kn"])
    if value <= 1.0:
        return Check("damping_form", True, said + " (where the curves do not rule a form out, "
                     "within the accuracy bounds; in the intervals)", value)
    return Check("damping_form", False,
                 "the answer rests on a damping form the data cannot tell: "
                 + said + "; a form the curves do not rule out moves it beyond the accuracy "
                 f"bounds (delta {100 * LIMITS['damping_delta']:g} %, kn "
                 f"{100 * LIMITS['damping_kn']:g} %). A base channel to replay (the form "
                 "is then estimated from the peaks' trend with the level), the structure's "
                 "damping matrix in the model file, or its measured modal ratios would settle it",
                 value)


def _level_check(replay) -> Check | None:
    """``replay_level``: the levels the upper branches imply and the kn their channels' ratios
    imply (module docstring); None where no run's level came from ``level_g``."""
    level = getattr(replay, "level", None)
    if level is None or not getattr(level, "implied", None):
        return None
    errors = [v.error for v in level.implied.values()]
    said = (f"the runs' upper branches put their levels {100 * min(errors):+.2g} to "
            f"{100 * max(errors):+.2g} % from `level_g`")
    said += (f" (within its {100 * level.uncertainty:g} % uncertainty)"
             if level.implied_error <= level.uncertainty else
             f" (beyond its {100 * level.uncertainty:g} % uncertainty: the intervals take "
             f"{100 * level.implied_error:.2g} %; a `level_g` off the true level, or a level that "
             "varies during the runs, which no base channel records)")
    said += "; " + level.describe()
    ratio = getattr(level, "ratio_kn", None)
    if ratio is None:
        return Check("replay_level", True, said + "; one channel reads them, so their ratio "
                     "does not check the answer's kn")
    se, dof = getattr(level, "ratio_kn_se", None), getattr(level, "ratio_dof", 0)
    limit = max(LIMITS["accuracy_kn"], math.inf if se is None else _noise_limit(se, dof))
    value = abs(ratio) / limit
    spread = max(v.spread for v in level.implied.values())
    rule = (f"limit {100 * limit:.2g} %: the bound {100 * LIMITS['accuracy_kn']:g} %, or its "
            f"standard error {100 * se:.2g} % (the runs' scatter, {dof} degrees of freedom) "
            "times Student's t at the 3-sigma tail where larger" if se is not None and dof >= 1
            else "no degree of freedom to measure its scatter by")
    if value <= 1:
        return Check("replay_level", True,
                     f"{said}; one level explains every channel (theirs differ by up to "
                     f"{100 * spread:.2g} %), as far as kn matters: their amplitude ratios put kn "
                     f"{100 * ratio:+.2g} % from the answer ({rule})", value)
    return Check("replay_level", False,
                 f"no level explains every channel's upper branch: the channels' own levels "
                 f"differ by up to {100 * spread:.2g} %, and their amplitude ratios put kn "
                 f"{100 * ratio:+.2g} % from the answer ({rule}),"
                 " so the replay at the answer is not the tested structure ("
                 "a level that dips or swells near the jumps, which no base channel records, "
                 "damping of another form or a linear model that is not the tested structure?); "
                 + said, value)


def reading_rests(reading) -> float:
    """How far an answer rests on the base's narrowed reading (:class:`freeplayid.replay.
    BaseReading` with its move measured): the least move the wide reading's own noise leaves
    it (95 %), over the accuracy bounds (the larger of delta's and kn's); beyond 1 the answer
    rests on it."""
    least = (reading.delta_shift - (reading.delta_noise or 0.0),
             reading.kn_shift - (reading.kn_noise or 0.0))
    return max(least[0] / LIMITS["reading_delta"], least[1] / LIMITS["reading_kn"])


def reading_unmeasured(reading) -> float | None:
    """Where the narrowed reading plainly misses a profile (some gated run's gap beyond
    :data:`freeplayid.signal.level.GAP_Z_STRONG` standard deviations) and the wide reading is
    too noisy to bound what that does to the answer: its own noise (95 %) over the accuracy
    bounds, the larger of delta's and kn's (beyond 1: not measured within them); None where the
    gaps are weaker or that noise was not measured."""
    from ..signal.level import GAP_Z_STRONG

    zmax = max((abs(reading.gaps[r][1]) for r in reading.runs), default=0.0)
    if zmax < GAP_Z_STRONG or reading.delta_noise is None:
        return None
    return reading_noise(reading)


def reading_noise(reading) -> float:
    """The wide reading's own noise in the answer (95 %, its copies' measured
    ``delta_noise`` / ``kn_noise``) over the accuracy bounds, the larger of delta's and kn's."""
    return max(reading.delta_noise / LIMITS["reading_delta"],
               reading.kn_noise / LIMITS["reading_kn"])


def _reading_check(replay) -> Check | None:
    """``base_reading``: where the base channel's narrowed reading misses the level around a
    run's point (:class:`freeplayid.replay.BaseReading`), the answer replayed with the wide
    band's reading moves, less what that reading's own noise can move it (95 %), by no more than
    the accuracy bounds (``reading_delta``, ``reading_kn``): only a move that noise cannot
    explain beyond them fails (the answer rests on the narrowed reading); so does a wide
    reading too noisy to measure the move within the bounds where the gap is strong
    (:func:`reading_unmeasured`: fin C's fast dip d1, gaps 8-19 standard deviations, the wide
    reading's noise +-6.2 %, delta -3.7 %). Where the gaps are weaker such noise passes:
    failing there too (tried, 2026-12-02) turned as many accurate answers ``suspect``, on
    constant levels whose gaps of 3.2-3.9 standard deviations are the noise's, as it caught
    answers outside the bounds (docs/results.md, session 35). None where no run with a point
    was read narrowed."""
    reading = getattr(replay, "base_reading", None)
    if reading is None:
        return None
    said = reading.describe()
    if not reading.runs:
        return Check("base_reading", True, said, 0.0)
    if reading.delta_shift is None:
        return Check("base_reading", False, said + ": the answer's dependence on how the level "
                     "is read there is not measured")
    value = reading_rests(reading)
    bounds = (f"the accuracy bounds {100 * LIMITS['reading_delta']:g} % and "
              f"{100 * LIMITS['reading_kn']:g} %")
    if value > 1:
        return Check("base_reading", False, said + f"; even less that noise, beyond {bounds}: "
                     "the answer rests on how the level is read where the runs jump; a slower "
                     "sweep or a base channel with less noise would resolve it", value)
    noisy = reading_unmeasured(reading)
    if noisy is not None and noisy > 1:
        return Check("base_reading", False, said + f"; that noise alone lies beyond {bounds}, "
                     "where the narrowed reading plainly misses the level: how far the answer "
                     "rests on it cannot be measured within them; a slower sweep or a base "
                     "channel with less noise would resolve it", noisy)
    return Check("base_reading", True, said + f"; less that noise, within {bounds}; in the "
                 "intervals", value)


def run_branches(replay) -> dict:
    """Each run's upper branch, the replay at the answer against the test
    (:attr:`freeplayid.replay.RunMisfit.branch`), where it was read."""
    misfits = getattr(replay, "resonance", None) or {}
    return {run: m.branch for run, m in misfits.items() if math.isfinite(m.branch)}


def _branch_check(replay) -> Check | None:
    """``replay_branch``: the replay's upper branches against the test's where the points are
    read at the phase resonance (module docstring); None where they are not or no run has one."""
    if getattr(replay, "jump_point", None) != "quadrature":
        return None
    branch = run_branches(replay)
    if not branch:
        return None
    limit = LIMITS["branch"]
    typical, worst = float(np.median(list(branch.values()))), max(branch.values())
    rule = (f"the median run's {100 * typical:.2g} % of the peak against the limit "
            f"{100 * limit:g} %")
    if typical <= limit:
        return Check("replay_branch", True,
                     f"the replay at the answer follows the runs' upper branches ({rule}; the "
                     f"farthest run {100 * worst:.2g} %: one run's branch is a damping's form, "
                     "every run's a reading)", typical / limit)
    off = [f"{run} {100 * b:.2g} %" for run, b in branch.items() if b > limit]
    return Check("replay_branch", False,
                 f"the replay at the answer misses the test's upper branches ({rule}; "
                 f"{', '.join(off)}) "
                 "though it is driven at the base's measured level: the test's motion relative "
                 "to the base and its phase-resonance points are read from the responses "
                 "against the base channel at the same instants, so a base channel read out of "
                 "step with the response channels (a delay t turns the phase by 360 f t "
                 "degrees: a quarter sample at 256 Hz is 14 degrees at 40 Hz; a multiplexed "
                 "acquisition, or a base channel from another front end; where the delay is "
                 "known, the data set's `base_delay_s` shifts the base back into step), or a "
                 "structure the replay is not (its damping or linear model)?", typical / limit)


# what turns the phase where a delay does not
_NOT_A_DELAY = ("a structure the replay is not (a damping of another form, a linear model off) "
                "or a base channel that does not follow the table")


def timing_not_a_delay(replay, tried: str) -> Check | None:
    """``base_timing`` where the test, identified again with its base shifted back by the delay
    it read, did not come closer to its replay (``tried``: how it did not): the turn is then not
    a delay, whatever the runs agree on; None where the turn is within ``timing_turn``."""
    timing = getattr(replay, "base_timing", None)
    if timing is None or not math.isfinite(timing.delay_s):
        return None
    limit = LIMITS["timing_turn"]
    value = abs(timing.turn_deg) / limit
    if value <= 1:
        return None
    return Check("base_timing", False,
                 f"{timing.describe()}; limit {limit:g} degrees: the runs read one delay, but "
                 f"the test identified again with its base shifted back by it {tried}, so the "
                 f"turn is not a delay: {_NOT_A_DELAY}", value)


def _timing_check(replay) -> Check | None:
    """``base_timing``: the base channel's delay against the responses, read from the test's
    phase against the replay's at the answer (:mod:`freeplayid.replay.base_timing`); None
    without a base channel or where no run could be read."""
    timing = getattr(replay, "base_timing", None)
    if timing is None or not math.isfinite(timing.delay_s):
        return None
    limit = LIMITS["timing_turn"]
    value = abs(timing.turn_deg) / limit
    said = f"{timing.describe()}; limit {limit:g} degrees"
    if value <= 1:
        return Check("base_timing", True, said, value)
    if not timing.agree:
        return Check("base_timing", False,
                     f"{said}: the responses' phase against the base differs from the replay's "
                     "away from the resonances, but not by one delay (the runs, or the two "
                     f"sides of the resonance, read different delays): {_NOT_A_DELAY}", value)
    return Check("base_timing", False,
                 f"{said}: the points are read against the base channel at the same instants, "
                 "so the answer rests on a base read out of step with the responses (a "
                 "multiplexed acquisition, another front end's filter delay); the data set's "
                 "`base_delay_s` shifts it back into step", value)


def _antialias_check(replay) -> Check | None:
    """``antialias``: the answer's move were the records' anti-alias filter flat where the
    replay's attenuates (module docstring); None where every point lies in its flat band."""
    acquisition = getattr(replay, "antialias", None)
    if acquisition is None:
        return None
    value = max(abs(acquisition.delta_shift) / LIMITS["antialias_delta"],
                abs(acquisition.kn_shift) / LIMITS["antialias_kn"])
    said = acquisition.describe()
    if value <= 1:
        return Check("antialias", True, said, value)
    return Check("antialias", False,
                 f"{said}; that is beyond half the accuracy bounds (delta "
                 f"{100 * LIMITS['antialias_delta']:g} %, kn {100 * LIMITS['antialias_kn']:g} %), "
                 "so the answer rests on a filter the data set does not state; say which "
                 "(`replay.antialias=flat` for an acquisition flat to 0.45 of its rate, "
                 "`replay.antialias=replay` for records decimated as the simulator's are) or "
                 "sample faster (points below 0.3 of the sample rate)", value)


def replay_checks(replay, *, down_runs=()) -> list[Check]:
    """The replay's self-check (module docstring); ``down_runs``: the runs that sweep down."""
    if getattr(replay, "failure", ""):
        return [Check("replay_failed", False, replay.failure)]
    misfit = {r: m for r, m in (replay.misfit or {}).items() if math.isfinite(m)}
    checks = [_resonance_check(replay, tuple(down_runs)), _consistency_check(replay),
              _level_check(replay), _form_check(replay), _reading_check(replay),
              _antialias_check(replay), _branch_check(replay), _timing_check(replay),
              _sweep_law_check(replay, misfit, LIMITS["replay_misfit"]),
              _binding_check(replay), _converged_check(replay),
              precision_check(getattr(replay, "precision", None),
                              getattr(replay, "excitation_noise", None))]
    damping = getattr(replay, "damping", None)
    if damping is not None and damping.source == "estimated":
        ci = damping.zeta_ci95
        ratio = None if ci is None else ci[1] / ci[0]
        ok = ratio is not None and ratio <= LIMITS["zeta_ci_ratio"]
        checks.append(Check(
            "damping_estimate", ok,
            f"damping estimated from the peak amplitudes: zeta = {damping.zeta:.3g}"
            + ("" if ci is None else f" (95 % CI {ci[0]:.3g} to {ci[1]:.3g})")
            + ("" if ok else "; the amplitudes do not pin it down (give `damping=` or C in "
               "the model file)"), ratio))
    return [c for c in checks if c is not None]


def solution_move(offset) -> str:
    """Where an unconverged loop's solution lies from its answer (``unconverged_offset``, log
    kn and log delta), in %."""
    return (f"kn {100 * math.expm1(-offset[0]):+.2g} %, "
            f"delta {100 * math.expm1(-offset[1]):+.2g} %")


def _converged_check(replay) -> Check:
    """``replay_converged``: converged, or the closest replay within a quarter of the
    statistics' standard error (``binding_noise``), or within one (``binding_reach``) where the
    intervals reach to the solution that the binding's slope puts a step away."""
    n = len(replay.iterations)
    if replay.converged:
        return Check("replay_converged", True, f"the corrected fit converged in {n} replays")
    close = getattr(replay, "closest_misfit_se", None)
    stopped = getattr(replay, "stopped", "")
    if within_binding_noise(close):
        return Check("replay_converged", True,
                     f"the corrected fit did not converge in {n} replays"
                     + (" (the loop stopped where a step could not be replayed)" if stopped
                        else "")
                     + f", but its closest replay matches the test's statistics within "
                     f"{close:.2g} of their standard error", close)
    offset = getattr(replay, "unconverged_offset", None)
    if close is not None and offset is not None and close <= LIMITS["binding_reach"]:
        return Check("replay_converged", True,
                     f"the corrected fit did not converge in {n} replays"
                     + (" (the loop stopped where a step could not be replayed)" if stopped
                        else "")
                     + f"; its closest replay, the answer, misses the test's statistics by "
                     f"{close:.2g} of their standard error, and the intervals reach to where the "
                     f"binding's slope puts the solution ({solution_move(offset)})", close)
    return Check("replay_converged", False,
                 f"the corrected fit did not converge in {n} replays"
                 + ("" if close is None else
                    f" (its closest replay, the answer, misses the test's statistics by "
                    f"{close:.2g} of their standard error)")
                 + (f"; the loop stopped: {stopped}" if stopped else ""), close)


def _binding_check(replay) -> Check:
    """``replay_binding``: no two replays whose fits differ by a jump (module docstring), or
    one whose jump one run makes (:class:`freeplayid.replay.BindingJump`) that the answer does
    not rest on: of four runs or more, the answer without it moves by no more than
    ``without_delta`` / ``without_kn`` (half the accuracy bounds), as ``replay_misfit`` sets a
    run aside."""
    jump = getattr(replay, "binding_jump", None)
    if jump is None:
        jump = worst_jump(replay.iterations, FORM_ATOL)
    if jump is None:
        return Check("replay_binding", True, "the replayed fits move smoothly with (kn, delta)")
    name, move, cause = jump.parameter, jump.move, jump.cause
    said = (f"the replayed fit's {name} jumped by {100 * move:.2g} % when the replayed "
            f"{name} moved by {100 * cause:.2g} %")
    w = jump.without
    if jump.run is not None:
        said += f": run {jump.run} changes branch there (without it the fits do not jump)"
        if w is not None:
            said += (f"; without it the answer moves delta {100 * w[1]:+.2g} %, "
                     f"kn {100 * w[0]:+.2g} %")
        if _set_aside(w, jump.runs):
            return Check("replay_binding", True,
                         f"{said}, within half the accuracy bounds, so the answer does not rest "
                         "on that run (a run at the edge of jumping)", move)
        return Check("replay_binding", False,
                     f"{said}: the answer rests on a run at the edge of jumping, and can lie "
                     "anywhere across that jump", move)
    return Check("replay_binding", False,
                 f"{said}: a replayed point changes branch near the estimate (a run at the "
                 "edge of jumping?), which can lie anywhere across that jump", move)


def _sweep_law_check(replay, misfit: dict, limit: float) -> Check:
    """Where the replayed sweep laws came from; a law guessed from the responses passes only
    when the replay reproduces that run (module docstring)."""
    sweeps = replay.sweeps or {}
    by_source: dict[str, list[str]] = {}
    for run, sw in sweeps.items():
        by_source.setdefault(sw["source"], []).append(run)
    where = "; ".join(f"{src}: {', '.join(runs)}" for src, runs in by_source.items())
    guessed = by_source.get("response", [])
    if not guessed:
        return Check("sweep_law", True, f"sweep laws from {where or 'no run'}")
    worst = max((sweeps[r].get("residual_hz", 0.0) for r in guessed), default=0.0)
    bad = [r for r in guessed if not misfit.get(r, math.inf) <= limit]
    text = (f"sweep law of run(s) {', '.join(guessed)} estimated from the response channels "
            f"(no hint, no base channel; fit residual up to {worst:.2g} Hz)")
    if bad:
        return Check("sweep_law", False, text + f"; the replay does not reproduce {', '.join(bad)}"
                     ": the estimated law may be wrong (give the runs' `sweep` hints)", worst)
    return Check("sweep_law", True, text + "; the replay reproduces them (caution: no hint)",
                 worst)


def noise_outside_chance(halfwidth: float, bound: float, shift: float = 0.0,
                         shift_se: float = 0.0) -> float:
    """The chance that an error with the 95 % half-width ``halfwidth`` (relative, normal in
    log) lies beyond ``bound`` (relative): centred, or about a mean ``shift`` (log) known to
    a standard error ``shift_se`` (log), which adds to its spread (the predictive chance of a
    mean estimated from the copies)."""
    sd = math.hypot(math.log1p(halfwidth) / 1.96, shift_se)
    b = math.log1p(bound)
    if sd <= 0:
        return float(abs(shift) > b)
    return float(scipy.stats.norm.sf((b - shift) / sd) + scipy.stats.norm.cdf((-b - shift) / sd))


# the chance of leaving the accuracy bounds by noise alone below which the precision's noisy
# copies may stop early (replay.precision_by_replay): far below ``noise_outside``
SETTLED_CHANCE = 0.01


def settled_sd() -> tuple[float, float]:
    """The standard deviations of log kn and log delta at which the noise alone leaves kn's and
    delta's accuracy bounds with a :data:`SETTLED_CHANCE` chance (normal in log, as
    :func:`noise_outside_chance`): the precision's copies stop early below them."""
    z = float(scipy.stats.norm.isf(SETTLED_CHANCE / 2))
    return (math.log1p(LIMITS["accuracy_kn"]) / z, math.log1p(LIMITS["accuracy_delta"]) / z)


def precision_check(precision, excitation=None) -> Check | None:
    """``noise_precision`` (module docstring); None when not measured (no copies, or fewer
    than three of them could be fitted). ``excitation``: the base channel's noise in the
    replays' excitation (:class:`freeplayid.replay.ExcitationNoise`), where measured, adds its
    half-widths to the copies' in quadrature (log), as the intervals do."""
    if precision is None or precision.delta_halfwidth is None:
        return None
    own = hw = {"delta": precision.delta_halfwidth, "kn": precision.kn_halfwidth}
    base = None if excitation is None or excitation.delta_halfwidth is None else \
        {"delta": excitation.delta_halfwidth, "kn": excitation.kn_halfwidth}
    if base is not None:
        hw = {k: math.expm1(math.hypot(math.log1p(own[k]), math.log1p(base[k]))) for k in own}
    bound = {"delta": LIMITS["accuracy_delta"], "kn": LIMITS["accuracy_kn"]}
    shift = dict(zip(("kn", "delta"), getattr(precision, "noise_bias", None) or (0.0, 0.0)))
    shift_se = dict(zip(("kn", "delta"),
                        getattr(precision, "noise_bias_se", None) or (0.0, 0.0)))
    chance = {k: noise_outside_chance(hw[k], bound[k], shift[k], shift_se[k]) for k in hw}
    worst = max(chance, key=chance.get)
    said = precision.describe()
    if base is not None:
        said += (f"; {excitation.describe()}; together ±{100 * hw['delta']:.2g} % and "
                 f"±{100 * hw['kn']:.2g} %")
    said = (f"{said}: a {100 * chance['delta']:.2g} % chance that the noise puts delta "
            f"beyond {100 * bound['delta']:g} %, {100 * chance['kn']:.2g} % that it puts kn "
            f"beyond {100 * bound['kn']:g} %")
    if chance[worst] <= LIMITS["noise_outside"]:
        return Check("noise_precision", True, said, chance[worst])
    mostly_base = base is not None and base[worst] > own[worst]
    return Check("noise_precision", False,
                 f"{said} (limit {100 * LIMITS['noise_outside']:g} %): the answer is only as "
                 "precise as the test's noise allows, whatever the intervals; "
                 + ("most of it the base channel's, which drives the replays: a quieter base "
                    "accelerometer would narrow it most; more runs or "
                    "a slower sweep would too" if mostly_base else
                    "more runs at levels whose jumps lie well inside the band, a slower sweep "
                    "or less noise would narrow it"), chance[worst])

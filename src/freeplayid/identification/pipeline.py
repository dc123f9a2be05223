"""The measured-data pipeline: :func:`identify` a data set -> :class:`Identification`."""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import time
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
import scipy.stats

from ..acquisition import (
    FilterResponse,
    base_aligned,
    describe_antialias,
    describe_base_delay,
    equalized,
)
from ..errors import ConfigError, DatasetError, IdentificationError
from ..estimate import PlainEstimate, plain_estimate
from ..fit import FitOptions
from ..io import read_dataset
from ..model import FreeplaySystem, ModelOptions, load_system, validate_modes
from ..quality import RecordCheckOptions, replayed_even_harmonics
from ..replay import Replay, corrected_fit
from ..signal import Extraction
from ..threads import one_blas_thread
from .model_error import (
    ModelError,
    hinge_names,
    model_error,
    replayed_split,
    update_model,
    widen,
)
from .records import checked_dataset, record_checks, record_options
from .replay_checks import (
    reading_noise,
    reading_rests,
    replay_checks,
    run_branches,
    settled_sd,
    timing_not_a_delay,
)
from .result import Identification
from .verdict import (
    LIMITS,
    Check,
    answer_checks,
    base_level_checks,
    channel_checks,
    down_sweep_runs,
    fit_checks,
    make_verdict,
    model_checks,
    replayed_channel_check,
    stated_filter_checks,
    sweep_direction_check,
    validation_checks,
)

__all__ = ["identify"]

log = logging.getLogger(__name__)

DEFAULT_REPLAY = Replay()  # identify corrects the plain fit by replaying the test unless told not
DEFAULT_RECORDS = RecordCheckOptions()  # ... and checks the records first unless told not


@one_blas_thread()
def identify(dataset, *, system: FreeplaySystem | None = None,
             extraction: Extraction | Mapping | None = None,
             fit: FitOptions | Mapping | None = None,
             replay: Replay | Mapping | None = DEFAULT_REPLAY,
             model: ModelOptions | Mapping | None = None,
             records: RecordCheckOptions | Mapping | None = DEFAULT_RECORDS,
             progress: bool = True) -> Identification:
    """Identify (kn, delta) from a measured (or simulated) sine-sweep data set.

    Steps: the data set's linear model (or ``system``); the record checks
    (:func:`freeplayid.quality.check_records`: the repaired records identified from, the runs
    they reject left out with their reasons, their ``suspect`` findings failed verdict checks
    ``records``); the plain estimate
    (:func:`freeplayid.estimate.plain_estimate`: the resonance point of every channel of every
    usable run, the fit's start, the backbone least squares with its intervals); the corrected
    fit (:func:`freeplayid.replay.corrected_fit`: the fit's bias removed by replaying the test);
    the checks behind the verdict.

    Parameters
    ----------
    dataset : freeplayid.io.Dataset or path
        A data set (:func:`freeplayid.io.read_dataset`, or built in memory) or the path of its
        folder or ``manifest.yaml``.
    system : FreeplaySystem, optional
        The linear model; default the data set's ``model`` file.
    extraction : Extraction or mapping, optional
        How the points are taken (:class:`freeplayid.signal.Extraction`; a mapping of its
        fields is accepted); default ``Extraction()``.
    fit : FitOptions or mapping, optional
        How the backbone is fitted (:class:`freeplayid.fit.FitOptions`: backbone, mode,
        bootstrap, the multi-start grid, and ``init``, the fit's start: a trained inverse model
        (:func:`freeplayid.inverse.load_inverse_model`), given (kn, delta) start(s), or None for
        the grid); default ``FitOptions()``.
    replay : Replay, mapping or None
        The bias correction by replaying the test (:class:`freeplayid.replay.Replay`: damping,
        statistic, weights, bootstrap by replay, convergence, engine). On by default (the plain
        fit is biased by 2-7 % in delta on swept, damped tests); None: the plain backbone fit.
    model : ModelOptions or mapping, optional
        What the identification assumes of the linear model
        (:class:`freeplayid.model.ModelOptions`): its update to the data set's sealed-fin modes
        (``reference_modes``), and its frequency uncertainty, which enters kn's interval.
    progress : bool
        Progress bars and the replays' progress lines.

    Returns
    -------
    Identification

    Raises
    ------
    DatasetError
        The data set breaks its contract (the message names the file, run, field or column).
    SystemFileError
        The model file is broken.
    IdentificationError
        Every run rejected (by the reader or the record checks), fewer than two usable points,
        or all of them at one resonance.
    InverseModelError
        The inverse model cannot take these points (e.g. a channel it was not trained on).
    """
    t0 = time.perf_counter()
    extraction = _option(Extraction, extraction, "extraction")
    fit = _option(FitOptions, fit, "fit")
    replay = None if replay is None else _option(Replay, replay, "replay")
    model = _option(ModelOptions, model, "model")
    records = record_options(records, fit.mode)
    if isinstance(dataset, (str, os.PathLike)):
        dataset = read_dataset(dataset)
    system = _system(dataset, system)
    _check_gap_shares(replay, system)
    _check_wide_base(replay, dataset)
    dataset, checked = checked_dataset(dataset, system, records)
    dataset, replay = _stated_filter(dataset, replay)
    dataset = base_aligned(dataset)
    first = _answer(dataset, system, checked, extraction, fit, replay, model, t0, progress)
    if replay is None:
        return first.result
    answer, delay, rejected = _with_the_base_in_step(first, system, checked, extraction, fit,
                                                     replay, model, t0, progress)
    dataset, system, est, error, result = answer
    result = _followed_up(result, dataset, system, est, extraction, fit, replay, error, checked,
                          t0, progress)
    if rejected:
        result = _not_a_delay(result, rejected)
    return (result if delay is None
            else _shifted_result(result, first.result, answer.result, delay))


def _followed_up(result: Identification, dataset, system, est, extraction, fit, replay, error,
                 checked, t0, progress) -> Identification:
    """``result`` identified again where its checks point at a better reading of the test: the
    base's wide reading, the drop points over wider windows, the other statistic, the hinges'
    gaps split."""
    misread = _base_misread(result, replay)
    if misread:
        result = _on_the_wide_reading(result, misread, dataset, system, est, extraction, fit,
                                      replay, error, checked, t0, progress)
        if getattr(result.replay, "wide_base", ()):  # the replays that follow read so too
            replay = dataclasses.replace(replay, wide_base=result.replay.wide_base)
    if _noisy_drops(result, replay, extraction):
        result, extraction = _on_a_wider_window(result, dataset, system, est, extraction, fit,
                                                replay, error, checked, t0, progress)
    if _statistics_disagree(result, replay):
        result = _on_the_other_statistic(result, dataset, system, est, extraction, fit, replay,
                                         error, checked, t0, progress)
    if _gaps_split(result, replay):
        result = _with_unequal_gaps(result, dataset, system, est, extraction, fit, replay,
                                    error, checked, t0, progress)
    return result


class _Answer(NamedTuple):
    """One answer and what it was identified from (the data set as read, the linear model as
    updated, the plain estimate, the model's error)."""

    dataset: object
    system: object
    est: PlainEstimate
    error: object
    result: Identification


def _answer(dataset, system, checked, extraction, fit, replay, model, t0,
            progress) -> _Answer:
    """The plain estimate, the model's update and error, and the corrected fit's answer (the
    plain one where ``replay`` is None); ``system``: the data set's model as given."""
    est = _plain_estimate(dataset, system, checked, extraction=extraction, fit=fit,
                          init=fit.init, progress=progress)
    system, est, update = update_model(dataset, system, est, fit, model)
    error = model_error(system, est, fit, model, update)
    if replay is None:
        return _Answer(dataset, system, est, error,
                       _plain_result(dataset, system, est, fit.mode, t0, error, checked))
    rep = corrected_fit(dataset, system, est, extraction=extraction, fit=fit, replay=replay,
                        start=_network_start(est, fit, replay), precision_settled=_settled(error),
                        progress=progress)
    return _Answer(dataset, system, est, error,
                   _corrected_result(dataset, system, est, rep, fit.mode, t0, error, checked))


TIMING_ROUNDS = 3  # most identifications of the test with its base shifted by the estimate
# [deg] once a shift has shown the delay, the estimate is refined while what remains turns the
# points' phase by more than this: about delta 0.25 %, a quarter of its bound, on the default
# fin (14 degrees moved it by 3.3 %). The first estimate, read at an answer the delay put off,
# falls 0-8 % short of it.
TIMING_REFINE_DEG = 1.0


def _out_of_step(result: Identification, limit: float | None = None):
    """The answer's :class:`freeplayid.replay.BaseTiming` where it turns the phase at the points
    by more than ``limit`` degrees (default the ``base_timing`` check's) with the runs and both
    sides of the resonance reading one delay (a base channel read out of step); None
    otherwise."""
    rep = result.replay
    timing = None if rep is None or rep.failure else getattr(rep, "base_timing", None)
    if timing is None or not math.isfinite(timing.delay_s) or not timing.agree:
        return None
    limit = LIMITS["timing_turn"] if limit is None else limit
    return timing if abs(timing.turn_deg) > limit else None


def _branch(result: Identification) -> float:
    """The median run's upper branch, replayed against measured (NaN where none was read)."""
    values = list(run_branches(result.replay).values())
    return float(np.median(values)) if values else math.nan


def _with_the_base_in_step(first: _Answer, system, checked, extraction, fit, replay, model, t0,
                           progress) -> tuple[_Answer, float | None, str]:
    """(``first``, None, ''), or where its base channel reads out of step with the responses
    (:func:`_out_of_step`) and the data set states no delay, the answer of the test with its
    base shifted back by the estimated delay (up to ``TIMING_ROUNDS`` times, each shift adding
    what the last answer's replay still reads, while that exceeds ``TIMING_REFINE_DEG``). A
    shifted answer is kept only where its replay reads less than half the delay before and
    follows the test's upper branches more closely (where both answers read them): a turn that
    a shift does not remove is not a delay. Then (that answer, the delay [s] shifted, ''),
    which :func:`_shifted_result` states on the answer finally reported; where the first shift
    is not kept, (``first``, None, how it failed), which :func:`_not_a_delay` states."""
    timing = _out_of_step(first.result)
    if timing is None or getattr(first.dataset, "base_delay_s", 0.0):
        return first, None, ""
    best, kept, total, rejected = first, 0.0, 0.0, ""
    for _ in range(TIMING_ROUNDS):
        total = kept + timing.delay_s
        log.info("the base channel reads %.3g ms (%.2g sample) %s against the responses "
                 "(the test's phase against its replay's): identifying the test again with the "
                 "base shifted back by %.3g ms", 1e3 * abs(timing.delay_s), abs(timing.samples),
                 "late" if timing.delay_s > 0 else "early", 1e3 * total)
        shifted = base_aligned(dataclasses.replace(first.dataset, base_delay_s=total))
        try:
            nxt = _answer(shifted, system, checked, extraction, fit, replay, model, t0,
                          progress)
        except IdentificationError as err:
            log.info("the test with its base shifted could not be identified (%s)", err)
            rejected = f"could not be identified ({err})"
            break
        after = getattr(nxt.result.replay, "base_timing", None)
        branches = (_branch(nxt.result), _branch(best.result))
        read = after is not None and math.isfinite(after.delay_s)
        halved = read and abs(after.delay_s) < abs(timing.delay_s) / 2
        nearer = not all(map(math.isfinite, branches)) or branches[0] < branches[1]
        if not (halved and nearer):
            log.info("the shift did not bring the replay closer to the test: kept the answer "
                     "before it")
            rejected = _not_closer(timing, after if read else None, branches, halved)
            break
        best, kept = nxt, total  # the delay the kept answer's base was shifted by
        timing = _out_of_step(best.result, TIMING_REFINE_DEG)
        if timing is None:
            break
    return (first, None, rejected) if best is first else (best, kept, "")


def _not_closer(before, after, branches: tuple, halved: bool) -> str:
    """How the answer with the base shifted did not come closer to the test (for
    :func:`_not_a_delay`): what its replay still read of the delay, or its upper branches."""
    if not halved:
        return ("did not remove it (" + (
            "its replay's delay could not be read" if after is None else
            f"its replay read {1e3 * after.delay_s:+.3g} ms") +
            f", against {1e3 * before.delay_s:+.3g} ms before)")
    return (f"followed the test's upper branches less closely (the median run's "
            f"{100 * branches[0]:.2g} % of the peak off, against {100 * branches[1]:.2g} % "
            "before)")


def _not_a_delay(result: Identification, tried: str) -> Identification:
    """``result`` with its failed ``base_timing`` check saying that the base shifted back by the
    delay it read did not bring the test closer to its replay (``tried``), so that the turn is
    not a delay (:func:`.replay_checks.timing_not_a_delay`); as it is otherwise."""
    own = next((c for c in result.verdict.checks if c.name == "base_timing"), None)
    note = None if own is None or own.passed else timing_not_a_delay(result.replay, tried)
    if note is None:
        return result
    checks = [note if c.name == "base_timing" else c for c in result.verdict.checks]
    return dataclasses.replace(result, verdict=make_verdict(checks))


def _delay_uncertainty(result: Identification) -> float:
    """[s] How far the shifted delay may lie from the base channel's true one (95 %): what the
    reported answer's replay still reads (left unshifted below ``TIMING_REFINE_DEG``), plus 1.96
    standard errors of the median of its runs' readings (their standard deviation over the
    square root of their number, times 1.25 for a median), plus half the difference of the
    readings below and above the resonances (what a damping of another form than the replay's,
    which turns the two sides apart, may leave in their mean). NaN where its replay reads
    none (measured in docs/identify.md section 3c)."""
    timing = getattr(result.replay, "base_timing", None)
    if timing is None or not math.isfinite(timing.delay_s):
        return math.nan
    runs = [v for v in timing.runs.values() if math.isfinite(v)]
    se = 1.25 * float(np.std(runs, ddof=1)) / math.sqrt(len(runs)) if len(runs) > 1 else 0.0
    sides = [v for v in (timing.below_s, timing.above_s) if math.isfinite(v)]
    apart = abs(sides[0] - sides[1]) / 2 if len(sides) == 2 else 0.0
    return abs(timing.delay_s) + 1.96 * se + apart


def _delay_moves(first: Identification, shifted: Identification, delay: float,
                 uncertainty: float) -> tuple[float, float]:
    """(kn, delta): the log moves of the answer that ``uncertainty`` [s] of the shifted delay
    makes, at the slope the shift itself showed (``first``: the answer with the base as read,
    ``shifted``: with it shifted by ``delay`` [s])."""
    if not math.isfinite(uncertainty) or delay == 0.0:
        return 0.0, 0.0
    return tuple(abs(math.log(getattr(shifted, name) / getattr(first, name)) / delay)
                 * uncertainty for name in ("kn", "delta"))


def _shifted_result(result: Identification, first: Identification, shifted: Identification,
                    delay: float) -> Identification:
    """``result`` (the answer with the base shifted by ``delay`` [s], estimated; ``shifted``:
    that answer before its follow-ups) with its data set's record and its ``base_timing``
    check saying so, and its intervals widened by the move that the delay's uncertainty
    (:func:`_delay_uncertainty`) makes at the slope from ``first`` to ``shifted``."""
    fs = float(result.dataset["sample_rate"])
    timing = first.replay.base_timing
    uncertainty = _delay_uncertainty(result)
    moves = _delay_moves(first, shifted, delay, uncertainty)
    said = (f"the base channel read {1e3 * abs(delay):.3g} ms ({abs(delay) * fs:.2g} sample) "
            f"{'late' if delay > 0 else 'early'} against the responses, estimated from the "
            "test's phase against its replay's away from the resonances (the first answer's "
            f"replay: {1e3 * timing.delay_s:+.3g} ms, the runs "
            f"{1e3 * min(timing.runs.values()):+.3g} to {1e3 * max(timing.runs.values()):+.3g}"
            " ms); the base records were shifted back into step and the test identified "
            f"again: the answer before lay delta {100 * (first.delta / result.delta - 1):+.2g} "
            f"%, kn {100 * (first.kn / result.kn - 1):+.2g} % from this one, the median run's "
            f"upper branch {100 * _branch(first):.2g} % of the peak off against "
            f"{100 * _branch(result):.2g} % now")
    widened = {}
    if math.isfinite(uncertainty):
        said += (f"; the delay is known to +-{1e3 * uncertainty:.2g} ms (95 %), which moves "
                 f"delta by +-{100 * math.expm1(moves[1]):.2g} % and kn by "
                 f"+-{100 * math.expm1(moves[0]):.2g} %, in the intervals")
        widened = dict(
            kn_ci95=_reaching(_reaching(result.kn_ci95, moves[0]), -moves[0]),
            delta_ci95=_reaching(_reaching(result.delta_ci95, moves[1]), -moves[1]),
            interval_source=f"{result.interval_source}, widened by the estimated base delay's "
            "uncertainty")
    dataset = {**result.dataset, "base_delay_s": delay, "base_delay_source": "estimated",
               "base_delay_uncertainty_s": uncertainty, "base_delay_said": said}
    own = next((c for c in result.verdict.checks if c.name == "base_timing"), None)
    note = Check("base_timing", True if own is None else own.passed,
                 said + ("" if own is None else f"; what remains: {own.message}"),
                 None if own is None else own.value)
    checks = [c for c in result.verdict.checks if c.name != "base_timing"] + [note]
    return dataclasses.replace(result, dataset=dataset, verdict=make_verdict(checks),
                               **widened)


def _stated_filter(dataset, replay: Replay | None):
    """The records' anti-alias filter as the data set states it (:mod:`freeplayid.acquisition`):
    a stated response divided out of the records (then replayed flat), a named filter handed
    to the replay. ``replay.antialias``, where set, overrides the data set's statement (the
    records then left as they are, the data set's record saying what was used)."""
    stated = getattr(dataset, "antialias", "unknown")
    if replay is not None and replay.antialias != "unknown":
        if stated != "unknown" and stated != replay.antialias:
            log.warning("replay.antialias=%s overrides the data set's `antialias` (%s)",
                        replay.antialias, describe_antialias(stated))
            dataset = dataclasses.replace(dataset, antialias=replay.antialias)
        return dataset, replay
    if isinstance(stated, FilterResponse):
        dataset = equalized(dataset)
        stated = "flat"
    if replay is not None and stated != "unknown":
        replay = dataclasses.replace(replay, antialias=stated)
    return dataset, replay


def _check_gap_shares(replay: Replay | None, system) -> None:
    """``replay.gap_shares`` must give one share per hinge of the model (before any work)."""
    shares = None if replay is None else replay.gap_shares
    if shares is not None and len(shares) != system.n_hinges:
        raise ConfigError(f"`replay.gap_shares` must give one share per hinge of the model "
                         f"({system.n_hinges}: {', '.join(hinge_names(system))}), got "
                         f"{len(shares)}")


def _check_wide_base(replay: Replay | None, dataset) -> None:
    """``replay.wide_base`` must name runs of the data set (before any work)."""
    runs = [r.file for r in dataset.runs]
    for name in () if replay is None else replay.wide_base:
        if name not in runs:
            raise ConfigError(f"`replay.wide_base`: {name!r} is not a run of {dataset.name} "
                              f"(its runs: {', '.join(runs)})")


def _gaps_split(result: Identification, replay: Replay) -> bool:
    """Whether the test suggests the hinges' gaps split against the answer's replay with one
    common gap (the split's p below the verdict's ``split_p``): then it is replayed with the
    split it shows (:func:`_with_unequal_gaps`), which measures how far the hinges' mean lies
    from the one-gap answer. With ``linear_model.hinge_gaps`` that replay's answer, the
    hinges' mean, is reported, so the split must be shown (p below ``cross_p``)."""
    err, rep = result.model_error, result.replay
    sp = None if err is None else err.split
    cut = LIMITS["cross_p"] if err is not None and err.per_hinge else LIMITS["split_p"]
    return (replay.gap_shares is None and rep is not None and not rep.failure
            and sp is not None and sp.p is not None and sp.p < cut
            and all(g > 0 and math.isfinite(g) for g in sp.half_gaps))


def _with_unequal_gaps(first: Identification, dataset, system, est, extraction, fit, replay,
                       error, checked, t0, progress) -> Identification:
    """The answer of replays with the hinges' gaps split as the test shows against the one-gap
    answer ``first``: each hinge's half-gap in the replays is delta times its share, so that
    delta is the hinges' mean half-gap, which one common gap is not where they differ (it
    leans to the hinge that turns most: fin C's 1.3 / 1.9 mrad with a damper, noise-free
    records, +1.16 %). The shares are the split read against the replay (half-gaps over their
    mean), read again against each new replay until they settle (:func:`_settled_shares`);
    the answer is then replayed with all its checks. The verdict's ``hinge_gaps`` reads the
    split left against that replay, and how far the one-gap answer lay from the mean
    (:attr:`~freeplayid.identification.model_error.ReplayedSplit.lean`). The one-gap answer
    is reported (:func:`_one_gap_stands`), the mean with ``linear_model.hinge_gaps``.
    ``first`` where these replays cannot be fitted."""
    sp = first.model_error.split
    log.info("the test shows the hinges' gaps split (%s, p = %.2g): replaying with those gaps",
             ", ".join(f"{1e3 * g:.4g} mrad" for g in sp.half_gaps), sp.p)
    rule = first.replay.jump_point
    shares, at = _settled_shares(sp.half_gaps, (first.kn, first.delta), dataset, system, est,
                                 extraction, fit, dataclasses.replace(replay, jump_point=rule),
                                 progress, damping=first.replay.damping)
    if np.allclose(shares, 1.0, rtol=0, atol=1e-12):  # not even one such replay could be fitted
        return first
    # the answer from the last one's, with every check (the start is not the network's: said)
    other = dataclasses.replace(replay, jump_point=rule, gap_shares=shares)
    rep = _refit_from(at, other, "the answer with the gaps' split read before",
                      "with unequal gaps", dataset, system, est, extraction, fit, error, progress)
    if rep is None:
        return first
    second = _corrected_result(dataset, system, est, rep, fit.mode, t0, error, checked,
                               common=(first.kn, first.delta), mean_reported=error.per_hinge,
                               common_t=sp.t, common_p=sp.p)
    if error.per_hinge:  # the model's proportions taken as right: the hinges' mean
        # what led to these replays: another statistic, the base read wide in some runs
        names = {"replay_statistic"} | ({"base_reading"} if replay.wide_base else set())
        kept = tuple(c for c in first.verdict.checks if c.name in names)
        own = tuple(c for c in second.verdict.checks if c.name not in {c.name for c in kept})
        return dataclasses.replace(second, verdict=make_verdict((*kept, *own)),
                                   runtime_s=time.perf_counter() - t0)
    return _one_gap_stands(first, second, t0)


def _one_gap_stands(first: Identification, second: Identification,
                    t0: float) -> Identification:
    """``first``, the one-gap answer, judged by the ``hinge_gaps`` check of ``second``, the
    test replayed with the split it shows (how far the hinges' mean lies), its intervals
    holding ``second``'s where that check fails. The split may be the gaps', or the linear
    model's (its hinges turning otherwise) or the noise's, which the data cannot tell apart: on
    realtests' fin C, the mean answer was within 0.3 % on three unequal-gap records where one
    gap was 1.35–1.62 % off, and 0.03–2.8 % further off than one gap on six equal-gap records
    whose model was off or whose base channel was missing."""
    check = next(c for c in second.verdict.checks if c.name == "hinge_gaps")
    checks = [c for c in first.verdict.checks if c.name != "hinge_gaps"] + [check]
    out = dataclasses.replace(first, verdict=make_verdict(checks),
                              model_error=second.model_error,
                              runtime_s=time.perf_counter() - t0)
    if check.passed:
        return out
    return dataclasses.replace(
        out, kn_ci95=_union(first.kn_ci95, second.kn_ci95),
        delta_ci95=_union(first.delta_ci95, second.delta_ci95),
        interval_source=first.interval_source + (
            ", joined with the answer of the test replayed with the hinges' gaps split as it "
            "shows them (their mean)"))


def _refit_from(at: tuple, replay: Replay, began: str, what: str, dataset, system, est,
                extraction, fit, error, progress):
    """The corrected fit with ``replay``'s options started at ``at`` (kn, delta), every check
    made, its start said as ``began``; None (logged: the replays ``what`` could not be fitted,
    the answer before stands) where it fails."""
    rep = corrected_fit(dataset, system, est, extraction=extraction, fit=fit,
                        replay=dataclasses.replace(replay, start="network"), start=at,
                        precision_settled=_settled(error), progress=progress)
    if rep.failure:
        log.info("the replays %s could not be fitted (%s): the answer before stands", what,
                 rep.failure)
        return None
    return dataclasses.replace(rep, start=began if rep.start == "network" else rep.start)


def _union(a: tuple, b: tuple) -> tuple:
    """The smallest interval holding intervals ``a`` and ``b``."""
    return (min(a[0], b[0]), max(a[1], b[1]))


SPLIT_ROUNDS = 4  # most quick replays of the test with the gaps' split read again
SPLIT_RTOL = 0.002  # [-] the shares have settled when none moves by more than this (log)


def _held_form(replay: Replay, damping) -> dict:
    """The options that hold the damping's form (the hinge damper's share q, the exponent p)
    at what the one-gap answer's ``damping`` (:class:`~freeplayid.replay.ReplayDamping`)
    estimated, for the split's quick fits: they estimate zeta again, but not the form, whose
    own loop is most of a quick fit's replays and which the shares hardly move. The answer
    after them estimates it again. Nothing changes where the form was not estimated (given,
    or the model file's C)."""
    if damping is None or damping.source == "model" or \
            "estimate" not in (replay.damping_exponent, replay.damping_hinge):
        return {}
    return {"damping_exponent": float(damping.exponent), "damping_hinge": float(damping.hinge)}


def _estimated_zeta(damping) -> float | None:
    """The damping ratio of an answer's replays where it was estimated, else None."""
    if damping is None or damping.source != "estimated" or damping.zeta is None:
        return None
    return float(damping.zeta)


def _settled_shares(half_gaps, at, dataset, system, est, extraction, fit, replay: Replay,
                    progress: bool, damping=None) -> tuple[tuple, tuple]:
    """(shares, (kn, delta)): the hinges' gap shares at which the split read against the
    replay with those shares is the replay's own, by quick corrected fits (no noisy copies,
    intervals or cross-check: only their answer and its replay's points count), each started
    from the last answer. The split read against a replay whose shares are off by a factor
    is off by a smaller one (fin C, 1.3 / 1.9 mrad: 1.34 / 1.87 against one gap, 1.32 / 1.89
    against those), so the reading is repeated, and from the third on the step is the
    secant's of the last two (capped at three plain steps), until no share moves by more than
    ``SPLIT_RTOL`` or after ``SPLIT_ROUNDS``. The damping's form is held at the one-gap
    answer's ``damping`` (:func:`_held_form`), and each quick fit's estimated zeta starts
    from the last answer's: a zeta of that form. The answer after them, which estimates the
    form again from its first loop with none, starts its zeta afresh."""
    def norm(g):
        g = np.log(np.asarray(g, float))
        return g - np.log(np.mean(np.exp(g)))

    x, y = np.zeros(len(half_gaps)), norm(half_gaps)  # log shares replayed, and read
    prev = None
    zeta = _estimated_zeta(damping)
    # quick: corrected_fit's answer_only leaves out every copy, interval and diagnostic
    quick = dataclasses.replace(replay, start="network", **_held_form(replay, damping))
    for _ in range(SPLIT_ROUNDS):
        step = y - x
        if prev is not None:  # the secant of g(x) = y - x through the last two readings
            dx, dg = x - prev[0], step - (prev[1] - prev[0])
            ok = np.abs(dg) > 1e-12
            secant = np.where(ok, -step * dx / np.where(ok, dg, 1.0), step)
            step = np.clip(secant, -3 * np.abs(step), 3 * np.abs(step))
        prev = (x, y)
        x = norm(np.exp(x + step))
        if np.max(np.abs(x - prev[0])) < SPLIT_RTOL:
            break
        shares = tuple(float(v) for v in np.exp(x))
        rep = corrected_fit(dataset, system, est, extraction=extraction, fit=fit,
                            replay=dataclasses.replace(quick, gap_shares=shares), start=at,
                            answer_only=True, start_zeta=zeta, progress=progress)
        if rep.failure:
            x = prev[0]
            break
        at, zeta = (rep.kn, rep.delta), _estimated_zeta(rep.damping)
        sp = replayed_split(system, rep.statistic_points, rep.replayed_points, (), kn=rep.kn,
                            delta=rep.delta, mode=fit.mode, shares=shares)
        if sp is None:
            break
        y = norm(sp.half_gaps)
    return tuple(float(v) for v in np.exp(x)), at


def _network_start(est, fit: FitOptions, replay: Replay) -> tuple[float, float] | None:
    """With ``replay.start="network"``: the network's estimate that started the plain fit
    (``inverse.checkpoint``), else the fit's given start, else None; None otherwise."""
    if replay.start != "network":
        return None
    inv = est.inverse_estimate
    if inv is not None:
        return float(inv["kn"]), float(inv["delta"])
    try:  # one given (kn, delta); a model or several starts are not one start
        pair = np.asarray(fit.init, dtype=float)
    except (TypeError, ValueError):
        return None
    return (float(pair[0]), float(pair[1])) if pair.shape == (2,) else None


def _settled(error: ModelError | None):
    """Where the precision's noisy copies may stop early (:func:`settled_sd`): not where the
    hinges' split is read against the replay (``error.hinge_gaps``), whose noise they measure
    too, with every copy (four copies left one equal-gap test of fin C 3.7 standard errors
    off, eight put the same record's split 1.4 standard errors off)."""
    return None if getattr(error, "hinge_gaps", None) is not None else settled_sd()


def _base_misread(result: Identification, replay: Replay) -> tuple:
    """The runs whose narrowed base reading fails the verdict's ``base_reading`` with the wide
    reading's move measured (:func:`.replay_checks._reading_check`): the answer rests on it
    beyond the accuracy bounds even less the wide reading's own noise, or the gap is strong and
    that noise too large to bound the move (the narrowed reading plainly off, the wide one only
    noisier; fin C's fast dips, delta -3.7 -> -0.6 % and -2.8 -> -0.2 %); the replays not yet
    driven by the wide reading (``replay.wide_base`` empty); () otherwise. Not where the move
    lies within that noise on weaker gaps (the check passes): there the wide reading's answer
    is no better known than the narrowed one's (realtests, the default fin's and fin B's weak
    bases, replayed wide so: two answers came closer to the truth and two went further, by
    0.7-2.7 %)."""
    rep = result.replay
    reading = None if rep is None or rep.failure else getattr(rep, "base_reading", None)
    if replay.wide_base or reading is None or not reading.runs or reading.delta_move is None:
        return ()
    failed = any(c.name == "base_reading" and not c.passed for c in result.verdict.checks)
    return tuple(reading.runs) if failed else ()


def _on_the_wide_reading(first: Identification, runs: tuple, dataset, system, est, extraction,
                         fit, replay, error, checked, t0, progress) -> Identification:
    """The answer of replays driven by the base's wide reading in ``runs``, where the narrowed
    reading misses the level around their points and ``first``'s answer rests on it beyond the
    accuracy bounds (its ``base_reading`` failed): the narrow band rounds a flank the runs
    cross in a second or two (a force-limited dip on a fast sweep), so ``first`` is biased by
    that rounding (realtests' fin C at 0.4 Hz/s: delta -2.4 and -3.7 %), while the wide band
    follows the flank at twice the noise, which its copies measured. Started where the wide
    reading's replay put the answer; judged as any answer, the ``base_reading`` check then
    saying what was read wide and why, and passing where the wide reading's own noise (95 %,
    in the intervals) moves the answer within the bounds. ``first`` where those replays cannot
    be fitted."""
    reading = first.replay.base_reading
    log.info("the base's narrowed reading misses the level around the points of %s, and the "
             "answer rests on it (delta %+.2g %% read wide): replaying them with the wide "
             "band's reading", ", ".join(runs), 100 * math.expm1(reading.delta_move))
    other = dataclasses.replace(replay, jump_point=first.replay.jump_point, wide_base=runs)
    at = (first.kn * math.exp(reading.kn_move), first.delta * math.exp(reading.delta_move))
    rep = _refit_from(at, other, "the answer the wide reading's replay implied",
                      "with the wide reading", dataset, system, est, extraction, fit, error,
                      progress)
    if rep is None:
        return first
    second = _corrected_result(dataset, system, est, rep, fit.mode, t0, error, checked)
    kn_ci, delta_ci = second.kn_ci95, second.delta_ci95
    noise = (reading.kn_noise, reading.delta_noise)
    if None not in noise:  # that reading's own noise, measured by its copies
        kn_ci, delta_ci = widen(kn_ci, second.kn, noise[0]), widen(delta_ci, second.delta,
                                                                     noise[1])
    note = _wide_reading_check(reading, first, second)
    own = next((c for c in second.verdict.checks if c.name == "base_reading"), None)
    if own is not None:  # other runs' narrowed readings, checked on the second answer
        note = Check("base_reading", note.passed and own.passed,
                     f"{note.message}; the other runs: {own.message}", note.value)
    checks = [c for c in second.verdict.checks if c.name != "base_reading"] + [note]
    return dataclasses.replace(
        second, verdict=make_verdict(checks), kn_ci95=kn_ci, delta_ci95=delta_ci,
        interval_source=second.interval_source + (
            ", with the wide band's reading's own noise where it drives the replays"
            if None not in noise else ""),
        runtime_s=time.perf_counter() - t0)


def _wide_reading_check(reading, first: Identification, second: Identification) -> Check:
    """``base_reading`` of an answer replayed with the wide reading in ``reading.runs``: what was
    read so and why, how far the narrowed reading's answer ``first`` lay, and whether that
    reading's own noise (95 %, :class:`freeplayid.replay.BaseReading`'s copies) moves the
    answer within the accuracy bounds."""
    why = ("the answer rested on it" if reading_rests(reading) > 1 else
           "the wide band's reading was too noisy to say how far the answer rested on it")
    said = (f"around the points of {reading.gated()}, the base's narrowed reading missed the "
            f"level (a level profile faster than the narrow band follows) and {why}: "
            "those runs were replayed with the wide band's reading, which follows it; the "
            f"narrowed reading's answer lay delta {100 * (first.delta / second.delta - 1):+.2g} "
            f"% and kn {100 * (first.kn / second.kn - 1):+.2g} % from this one")
    if reading.delta_noise is None:
        return Check("base_reading", False, said + "; the wide reading's own noise in the answer "
                     "is not measured")
    value = reading_noise(reading)
    said += (f"; the wide reading's own noise moves it by ±{100 * reading.delta_noise:.2g} % and "
             f"±{100 * reading.kn_noise:.2g} % (95 %, {reading.n_copies} copies; in the "
             "intervals)")
    bounds = (f"the accuracy bounds {100 * LIMITS['reading_delta']:g} % and "
              f"{100 * LIMITS['reading_kn']:g} %")
    if value <= 1:
        return Check("base_reading", True, f"{said}, within {bounds}", value)
    return Check("base_reading", False, f"{said}, beyond {bounds}: the answer is only as good as "
                 "a noisy reading of the level where the runs jump; a slower sweep or a base "
                 "channel with less noise would resolve it", value)


def _statistics_disagree(result: Identification, replay: Replay) -> bool:
    """Whether the replays matched the rule ``auto`` chose (the drop points, without a base
    channel) and the cross-check found the other statistic putting the answer elsewhere."""
    failed = {c.name for c in result.verdict.checks if not c.passed}
    rep = result.replay
    return (replay.jump_point == "auto" and rep is not None and not rep.failure
            and rep.cross is not None and "replay_consistency" in failed)


def _noisy_drops(result: Identification, replay: Replay, extraction: Extraction) -> bool:
    """Whether the replays matched drop points read over one window (no base channel) and the
    test's noise alone could put delta beyond its bound: the precision copies' 95 % half-width
    of delta reaches ``accuracy_delta`` (``Replay.noisy_window``). Not the quadrature points
    (with a base channel), whose amplitudes ``Extraction.drop_window`` reads wider too: tried so,
    the two answers disagreed beyond their noise on 7 of the project's own noise-study cases
    and the rule passed a Rayleigh-damped fin 1.6 % off on another integrator's records
    (docs/identify.md section 3c)."""
    rep = result.replay
    prec = None if rep is None else rep.precision
    return (extraction.drop_window == 1.0 and replay.noisy_window > 1.0 and rep is not None
            and not rep.failure and rep.jump_point == "drop" and prec is not None
            and prec.delta_halfwidth is not None
            and prec.delta_halfwidth >= LIMITS["accuracy_delta"])


def _on_a_wider_window(first: Identification, dataset, system, est, extraction: Extraction, fit,
                       replay: Replay, error, checked, t0,
                       progress) -> tuple[Identification, Extraction]:
    """(answer, extraction): the test replayed again with its drop points read over
    ``replay.noisy_window`` windows (:func:`_windows_agree` judges the two answers), and the
    extraction of the answer reported (for the replays that follow). A wider window averages
    more of the noise (the noise study's 0.3 g cases: the statistic's scatter of delta 1.15 ->
    0.53 % rms per case) but reads the amplitude further down the upper branch, which damping
    of another form than the replay's moves more (up-sweep fins without a base channel, on
    records of another integrator: +0.3 to +1.0 points of delta; docs/inverse.md section 4).
    So it is taken only where the noise could put the one-window answer beyond delta's bound,
    and only where the two answers agree within the noise their difference has (the
    specification test of Hausman, 1978: under the replay's model both estimate the same
    answer, the wider one with less noise, so their difference's variance is the difference
    of their variances); ``first`` otherwise, with the verdict's ``drop_window``."""
    w = replay.noisy_window
    wide = dataclasses.replace(extraction, drop_window=w)
    hw1 = first.replay.precision.delta_halfwidth
    log.info("the test's noise alone moves delta by +-%.2g %% (95 %%) on drop points read over one "
             "window: replaying them read over %g windows", 100 * hw1, w)
    rep = _refit_from((first.kn, first.delta), dataclasses.replace(
        replay, jump_point=first.replay.jump_point), "the answer with the drop points read over "
        "one window", f"with the drop points read over {w:g} windows", dataset, system, est,
        wide, fit, error, progress)
    if rep is None:
        return first, extraction
    second = _corrected_result(dataset, system, est, rep, fit.mode, t0, error, checked)
    passed, message, value = _windows_agree(first, second, w)
    if passed is None:  # the wider window was no more precise: nothing gained
        log.info("%s", message)
        return first, extraction
    chosen, apart = (second, _apart(first, second)) if passed else (first, None)
    if apart is not None:  # within the noise, but not within the bounds: the interval holds both
        message = f"{message}; {apart}"
        chosen = dataclasses.replace(
            chosen, kn_ci95=_union(first.kn_ci95, second.kn_ci95),
            delta_ci95=_union(first.delta_ci95, second.delta_ci95),
            interval_source=f"{chosen.interval_source}, joined with the one-window answer's "
            "interval")
    verdict = make_verdict((Check("drop_window", passed and apart is None, message, value),
                            *chosen.verdict.checks))
    return (dataclasses.replace(chosen, verdict=verdict, runtime_s=time.perf_counter() - t0),
            wide if passed else extraction)


def _apart(first: Identification, second: Identification) -> str | None:
    """Why two answers that agree within their difference's noise still cannot both be
    reported as within the accuracy bounds: the wider reading lies further from the one-window
    answer than delta's or kn's bound. At the first answer's noise (a half-width at delta's
    bound) the specification test cannot tell such a move from a bias of the wider reading,
    which damping of another form than the replay's gives it (Rayleigh-damped fin C without a
    base channel at 0.3-0.5 g of noise, another integrator's records: +2 to +3 % of delta;
    docs/identify.md section 3c). None where both moves lie within the bounds."""
    far = [f"{name} {100 * m:+.2g} % (bound {100 * LIMITS[key]:g} %)"
           for name, key in (("delta", "accuracy_delta"), ("kn", "accuracy_kn"))
           for m in [math.log(getattr(second, name) / getattr(first, name))]
           if abs(m) > math.log1p(LIMITS[key])]
    if not far:
        return None
    return (f"but the two answers lie further apart than the accuracy bounds ({', '.join(far)}): "
            "under the replay's model that is the noise in the one-window answer, but damping "
            "of another form than the replay's, or a level that is not the one replayed, moves "
            "the wider reading that far too, and the data cannot tell which; the interval "
            "holds the one-window answer too")


def _windows_agree(first: Identification, second: Identification,
                   w: float) -> tuple[bool | None, str, float | None]:
    """(passed, message, largest z): whether ``second``, the answer with the drop points read
    over ``w`` windows, agrees with ``first``, read over one, in log kn and log delta within
    ``cross_p`` (3 standard deviations) of their difference's noise, the square root of the
    difference of their precision copies' variances (at least half the first's standard
    deviation: each variance is read from a few copies). passed None where ``second`` is no
    more precise in delta."""
    p1, p2 = first.replay.precision, second.replay.precision
    z_lim = float(scipy.stats.norm.isf(LIMITS["cross_p"] / 2))
    h2 = None if p2 is None else p2.delta_halfwidth
    if h2 is None or h2 >= p1.delta_halfwidth:
        return None, (f"the drop points read over {w:g} windows gave no more precise answer "
                      f"(delta +-{100 * h2:.2g} % against +-{100 * p1.delta_halfwidth:.2g} %)"
                      if h2 is not None else f"the answer with the drop points read over {w:g} "
                      "windows has no precision (too few of its noisy copies fitted)"), None
    moves = {name: math.log(getattr(second, name) / getattr(first, name))
             for name in ("delta", "kn")}
    z = 0.0
    for name in moves:  # delta's half-widths exist here; kn's where its copies gave them
        a, b = getattr(p1, f"{name}_halfwidth"), getattr(p2, f"{name}_halfwidth")
        if a is not None and b is not None:
            s1, s2 = a / 1.96, b / 1.96  # half-widths are 1.96 standard deviations
            z = max(z, abs(moves[name]) / max(math.sqrt(max(s1 * s1 - s2 * s2, 0.0)), 0.5 * s1))
    said = (f"the test's noise alone moves delta by +-{100 * p1.delta_halfwidth:.2g} % (95 %) "
            f"with the drop points read over one window, as far as its "
            f"{100 * LIMITS['accuracy_delta']:.0f} % bound; read over {w:g} windows, by "
            f"+-{100 * h2:.2g} %, and that answer lies delta {100 * moves['delta']:+.2g} %, kn "
            f"{100 * moves['kn']:+.2g} % from the first")
    if z <= z_lim:
        return True, (f"{said}, within the noise of their difference ({z:.1f} of its standard "
                      f"deviations; limit {z_lim:.0f}): reported, the answer read over {w:g} "
                      "windows"), z
    return False, (f"{said}, beyond the noise of their difference ({z:.1f} of its standard "
                   f"deviations; limit {z_lim:.0f}): something other than the noise moves the "
                   "upper branch before the drop (damping of another form than the replay's, a "
                   "level that is not the one replayed), or the noise moved this test's points "
                   "further than it moves the answer's replay's; either can move the "
                   "one-window answer reported too (another damping form less than the wider "
                   "reading), and with its noise reaching delta's bound the data cannot confirm "
                   "it"), z


def _on_the_other_statistic(first: Identification, dataset, system, est, extraction, fit,
                            replay, error, checked, t0, progress) -> Identification:
    """The answer of replays matching the cross-check's statistic (the windowed maxima, which
    damping of another form than the replay's moves less than the drop: a Rayleigh-damped beam
    without base channel, docs/results.md), judged as any answer, with a failed check that says
    what the first statistic gave. ``first`` when that statistic's replays cannot be fitted."""
    rule = first.replay.cross.rule
    log.info("the `%s` points put the answer of the replays matching the `%s` points elsewhere "
             "(delta %+.2g %%): replaying the `%s` points", rule, first.replay.jump_point,
             100 * first.replay.cross.delta_shift, rule)
    other = dataclasses.replace(replay, jump_point=rule)
    rep = corrected_fit(dataset, system, est, extraction=extraction, fit=fit, replay=other,
                        start=_network_start(est, fit, other), precision_settled=_settled(error),
                        progress=progress)
    if rep.failure:
        return first
    second = _corrected_result(dataset, system, est, rep, fit.mode, t0, error, checked)
    cross = first.replay.cross
    note = Check("replay_statistic", False,
                 f"the replays matching the `{first.replay.jump_point}` points gave kn = "
                 f"{first.kn:.5g} N·m/rad, delta = {first.delta:.5g} rad, which the `{rule}` "
                 f"points put elsewhere (delta {100 * cross.delta_shift:+.2g} %, kn "
                 f"{100 * cross.kn_shift:+.2g} %); reported: the replays matching the `{rule}` "
                 "points, which damping of another form than the replay's moves less; the two "
                 "statistics disagree, so neither answer is confirmed")
    return dataclasses.replace(second, verdict=make_verdict((note, *second.verdict.checks)),
                               runtime_s=time.perf_counter() - t0)


def _plain_estimate(dataset, system, checked, **options) -> PlainEstimate:
    """:func:`plain_estimate`; when it finds too few points, its error also names what the record
    checks found that makes any answer from these records ``suspect``."""
    try:
        return plain_estimate(dataset, system, **options)
    except IdentificationError as err:
        suspects = () if checked is None else checked.suspect_reasons
        if not suspects:
            raise
        raise IdentificationError(f"{err}; the record checks also found: "
                                  f"{'; '.join(suspects)}", points=err.points) from None


def _option(cls, value, name: str):
    """``value`` as a ``cls`` option record (None: the defaults; a mapping: its fields)."""
    if value is None:
        return cls()
    if isinstance(value, cls):
        return value
    if isinstance(value, Mapping):
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(value) - names)
        if unknown:
            raise TypeError(f"`{name}` has unknown field(s) {unknown}; valid: {sorted(names)}")
        return cls(**value)
    raise TypeError(f"`{name}` must be a {cls.__module__.rsplit('.', 1)[0]}.{cls.__name__} or a "
                    f"mapping of its fields, got {type(value).__name__}")


def _system(dataset, system) -> FreeplaySystem:
    """``system``, else the data set's model file."""
    if system is None:
        if dataset.model is None:
            raise DatasetError(f"{dataset.path}: missing field `model` (the linear model file, "
                               ".npz); or pass `system`")
        return load_system(dataset.model)
    if not isinstance(system, FreeplaySystem):
        raise TypeError(f"`system` must be a FreeplaySystem, got {type(system).__name__}")
    return system


def _zero_clearance_check(dataset, system, kn: float):
    """:func:`freeplayid.model.validate_modes` of the closed model against the data set's
    ``reference_modes`` (None without them)."""
    ref = getattr(dataset, "reference_modes", None)
    if not ref:
        return None
    return validate_modes(system, kn, ref["frequencies_hz"], ref["shapes"], ref["dofs"])


def _record(dataset) -> dict:
    """What the report says of the data set (``levels``: each run's ``level_g`` [g] or None)."""
    return {"name": dataset.name, "path": str(dataset.path) if dataset.path else None,
            "model": str(dataset.model) if dataset.model else None,
            "quantity": dataset.quantity, "units": dataset.units,
            "sample_rate": float(dataset.sample_rate), "n_runs": len(dataset.runs),
            "channels": dict(dataset.channels), "base_channel": dataset.base_channel,
            "frame": getattr(dataset, "frame", "absolute"),
            **_filter_record(getattr(dataset, "antialias", "unknown")),
            **_delay_record(dataset),
            **({"gravity_g": float(dataset.gravity_g)} if getattr(dataset, "gravity_g", 0.0)
               else {}),
            "levels": {run.file: None if run.level_g is None else float(run.level_g)
                       for run in dataset.runs}}


def _filter_record(stated) -> dict:
    """The records' anti-alias filter as the data set stated it: its name or response."""
    if isinstance(stated, FilterResponse):
        return {"antialias": "response", "antialias_response": stated.to_dict(),
                "antialias_said": describe_antialias(stated)}
    return {"antialias": stated, "antialias_said": describe_antialias(stated)}


def _delay_record(dataset) -> dict:
    """The base channel's delay as the data set stated it (nothing where it states none)."""
    delay = float(getattr(dataset, "base_delay_s", 0.0) or 0.0)
    if delay == 0:
        return {}
    return {"base_delay_s": delay,
            "base_delay_said": describe_base_delay(delay, float(dataset.sample_rate))}


def _plain_result(dataset, system, est: PlainEstimate, mode: int, t0: float,
                  error: ModelError, records=None) -> Identification:
    """The plain estimate as an :class:`Identification`, judged on its own fit and the record
    checks' report (``records``, None when off); kn's interval takes in the model's error."""
    validation = _zero_clearance_check(dataset, system, est.kn)
    verdict = make_verdict(record_checks(records) + base_level_checks(dataset)
                           + stated_filter_checks(dataset, est.points)
                           + fit_checks(est.fitting_points(), est.fit, system, est.points,
                                        mode=mode)
                           + model_checks(error) + validation_checks(validation))
    return Identification(
        kn=est.kn, delta=est.delta, kn_ci95=widen(est.fit.kn_ci95, est.kn, error.kn_shift),
        delta_ci95=tuple(est.fit.delta_ci95), plain_fit=est.fit,
        runtime_s=time.perf_counter() - t0, points=est.points, dofs=est.dofs,
        rejected_runs=est.rejected_runs, system=system, mode=mode,
        inverse_estimate=est.inverse_estimate,
        truth=dict(dataset.truth) if dataset.truth else None, dataset=_record(dataset),
        verdict=verdict, validation=validation, model_error=error, records=records,
    )


def _further(precision) -> tuple[float, float] | None:
    """How many times further the answer moves than its statistic under the same noise (kn,
    delta; each at least 1): the precision's half-widths carried through the binding's slope
    over the copies' own (:class:`freeplayid.replay.ReplayPrecision`). None where it was not
    measured or neither exceeds 1 (a slope that would narrow the intervals is not trusted to:
    it is learnt from a few replays)."""
    own = getattr(precision, "statistic_halfwidths", None)
    if own is None or precision.kn_halfwidth is None:
        return None
    hw = (precision.kn_halfwidth, precision.delta_halfwidth)
    ratio = tuple(max(1.0, math.log1p(h) / math.log1p(o)) if o > 0 else 1.0
                  for h, o in zip(hw, own))
    return ratio if max(ratio) > 1.0 else None


def _stretched(ci: tuple, value: float, factor: float) -> tuple:
    """``ci`` of ``value`` with both log half-widths times ``factor``."""
    lo, hi = ci
    return (value * (lo / value) ** factor if lo > 0 else lo, value * (hi / value) ** factor)


def _noise_floor(precision) -> tuple[float, float] | None:
    """The log half-widths (kn, delta) that the noise alone gives the answer, measured on noisy
    copies of its replay (:class:`freeplayid.replay.ReplayPrecision`); None where not measured.

    A floor under the intervals: the Jacobian interval of the statistic's fit takes each run as
    one observation, so with three or four runs its scatter is estimated from one or two degrees
    of freedom and can come out several times narrower than the noise makes the answer move (on
    the realtests records, exact integrator: 25 of 176 delta intervals, 6 of which then missed
    a truth that lay within the copies' spread)."""
    if precision is None or precision.kn_halfwidth is None or precision.delta_halfwidth is None:
        return None
    return math.log1p(precision.kn_halfwidth), math.log1p(precision.delta_halfwidth)


def _reaching(ci: tuple, move: float) -> tuple:
    """``ci`` joined with itself moved by ``move`` in log: the interval of an answer and of
    the solution ``answer * exp(move)`` alike."""
    lo, hi = ci
    return lo * math.exp(min(0.0, move)), hi * math.exp(max(0.0, move))


def _bounded(*cis) -> bool:
    """Whether every interval is finite with a positive lower end."""
    return all(ci[0] > 0 and math.isfinite(ci[1]) for ci in cis)


def _copies_interval(precision) -> tuple[float, float] | None:
    """The log half-widths (kn, delta) of a 95 % interval made of the noisy copies' spread
    alone (:class:`freeplayid.replay.ReplayPrecision`): their 1.96 standard deviations taken
    to Student's t at the copies' degrees of freedom (2.36 / 1.96 from eight; none where the
    copies stopped early and their half-widths are upper bounds already). For the answer
    whose statistic's fit measures no scatter (two runs, two parameters); None where the
    copies were not measured."""
    floor = _noise_floor(precision)
    if floor is None or precision.n_fitted < 3:
        return None
    t = 1.0 if getattr(precision, "settled", False) else \
        float(scipy.stats.t.ppf(0.975, precision.n_fitted - 1)) / 1.96
    return floor[0] * t, floor[1] * t


def _at_least(ci: tuple, value: float, half: float) -> tuple:
    """``ci`` of ``value`` with each log half-width at least ``half``."""
    lo, hi = ci
    return (min(lo, value * math.exp(-half)), max(hi, value * math.exp(half)))


def _corrected_intervals(rep) -> tuple[tuple, tuple, str]:
    """The corrected estimate's intervals: the Jacobian ones of the statistic's fit (the points
    the replays match, each run's points one observation; where a run with points sweeps
    down, with the residuals the answer's replay does not reproduce, ``replayed_ci95``: the
    measured points' less the replayed ones') moved with the estimate (same
    relative width; where two runs fit exactly and measure no scatter, the noisy copies'
    spread, :func:`_copies_interval`) and stretched where the answer moves further than its
    statistic (the binding's slope, :func:`_further`); with the bootstrap by replay, the
    smallest interval holding both; where the loop did not converge, reaching to where the
    binding's slope puts its solution (:func:`_reaching`); never narrower than the spread the
    noise alone gives the answer (:func:`_noise_floor`), and reaching back by the mean move it
    gives the answer's noisy copies (``ReplayPrecision.noise_bias``); widened by the answer's
    move for the levels' uncertainty where they came from ``level_g``, for the damping's where
    down-sweeps rest on one they do not measure, for an estimated damping's, and for the base
    channel's noise that the replays' measured excitation carries."""
    replayed = getattr(rep, "replayed_ci95", None)
    (kn_ci, delta_ci) = rep.statistic_ci95 if replayed is None else replayed
    sk, sd = rep.kn / rep.kn_statistic, rep.delta / rep.delta_statistic
    kn_ci = tuple(v * sk for v in kn_ci)
    delta_ci = tuple(v * sd for v in delta_ci)
    source = "Jacobian (moved with the estimate)" if replayed is None else \
        ("Jacobian of the residuals the answer's replay does not reproduce (moved with the "
         "estimate)")
    copies = _copies_interval(getattr(rep, "precision", None))
    if copies is not None and not _bounded(kn_ci, delta_ci):
        # two runs fit exactly: no scatter to measure, but the noisy copies measured the noise
        kn_ci, delta_ci = (_at_least((v, v), v, h) for v, h in zip((rep.kn, rep.delta), copies))
        source = (f"the spread of {rep.precision.n_fitted} noisy copies of the answer's replay "
                  "(Student's t; the points of two runs fit exactly, so their scatter measures "
                  "nothing)")
    further = _further(getattr(rep, "precision", None))
    if further is not None:  # the answer moves further than its statistic
        kn_ci = _stretched(kn_ci, rep.kn, further[0])
        delta_ci = _stretched(delta_ci, rep.delta, further[1])
        source += (f" and stretched {further[0]:.3g}x (kn), {further[1]:.3g}x (delta): the "
                   "answer moves that much further than its statistic")
    boot = rep.bootstrap
    if boot is not None and boot.kn_ci95 is not None:
        kn_ci = (min(kn_ci[0], boot.kn_ci95[0]), max(kn_ci[1], boot.kn_ci95[1]))
        delta_ci = (min(delta_ci[0], boot.delta_ci95[0]), max(delta_ci[1], boot.delta_ci95[1]))
        source = f"bootstrap by replay ({boot.n} copies) joined with the Jacobian interval"
    offset = getattr(rep, "unconverged_offset", None)
    if offset is not None and not rep.converged:  # the solution lies a step from the answer
        kn_ci, delta_ci = _reaching(kn_ci, -offset[0]), _reaching(delta_ci, -offset[1])
        source += ", reaching to where the binding's slope puts the unconverged loop's solution"
    floor = _noise_floor(getattr(rep, "precision", None))
    if floor is not None:  # never narrower than the noise alone moves the answer
        kn_ci, delta_ci = (_at_least(ci, v, h) for ci, v, h in
                           ((kn_ci, rep.kn, floor[0]), (delta_ci, rep.delta, floor[1])))
        source += (", at least the spread that the noise alone gives the answer on noisy "
                   "copies of its replay")
    shift = getattr(getattr(rep, "precision", None), "noise_bias", None)
    if shift is not None:  # the noise moves the answer on average: the truth lies that far back
        kn_ci, delta_ci = _reaching(kn_ci, -shift[0]), _reaching(delta_ci, -shift[1])
        source += ", reaching back by the mean move the noise gives its copies"
    level = getattr(rep, "level", None)
    if level is not None:  # the levels taken from `level_g` are uncertain
        scale = getattr(level, "scale", 1.0)  # or off by more, as the upper branches say
        kn_ci = widen(kn_ci, rep.kn, scale * level.kn_shift)
        delta_ci = widen(delta_ci, rep.delta, scale * level.delta_shift)
        source += (f", with the levels' {100 * level.uncertainty:g} % uncertainty (no base "
                   "channel)" if scale <= 1 else
                   f", with the levels' error that the upper branches imply "
                   f"({100 * level.implied_error:.2g} %, no base channel)")
    excited = getattr(rep, "excitation_noise", None)
    if excited is not None and excited.delta_halfwidth is not None:  # the base's noise
        kn_ci = widen(kn_ci, rep.kn, math.log1p(excited.kn_halfwidth))
        delta_ci = widen(delta_ci, rep.delta, math.log1p(excited.delta_halfwidth))
        source += ", with the base channel's noise in the replays' excitation"
    reading = getattr(rep, "base_reading", None)
    if reading is not None and reading.delta_shift is not None:  # a level read too narrowly
        kn_ci = widen(kn_ci, rep.kn, reading.kn_shift)
        delta_ci = widen(delta_ci, rep.delta, reading.delta_shift)
        source += ", with the answer's move for the base read over the wide band where its " \
            "narrowed reading misses the level near a jump"
    acquisition = getattr(rep, "antialias", None)
    if acquisition is not None:  # the records' anti-alias filter, where the replay's attenuates
        kn_ci = _reaching(kn_ci, acquisition.kn_shift)
        delta_ci = _reaching(delta_ci, acquisition.delta_shift)
        source += (", reaching to the answer for records whose anti-alias filter is flat at "
                   "the points")
    damped = getattr(rep, "damping_sensitivity", None)
    if damped is not None:  # a damping the down-sweeps do not measure
        kn_ci = widen(kn_ci, rep.kn, damped.kn_shift)
        delta_ci = widen(delta_ci, rep.delta, damped.delta_shift)
        source += (f", with the damping's {100 * damped.uncertainty:g} % uncertainty "
                   "(down-sweeps do not measure it)")
    formed = getattr(rep, "form_sensitivity", None)
    if formed is not None and (formed.kn_shift > 0 or formed.delta_shift > 0):
        kn_ci = widen(kn_ci, rep.kn, formed.kn_shift)  # a damping form the test cannot read
        delta_ci = widen(delta_ci, rep.delta, formed.delta_shift)
        source += (", with the answer's move under other forms of the estimated damping (no "
                   "base channel to read the form)")
    damping = rep.damping
    if damping is not None and damping.kn_shift is not None:  # an estimated zeta is uncertain
        kn_ci = widen(kn_ci, rep.kn, damping.kn_shift)
        delta_ci = widen(delta_ci, rep.delta, damping.delta_shift)
        source += ", with the estimated damping's uncertainty"
    return kn_ci, delta_ci, source


def _corrected_result(dataset, system, plain: PlainEstimate, rep, mode: int, t0: float,
                      error: ModelError, records=None, common=None,
                      mean_reported: bool = True, common_t: float = math.nan,
                      common_p: float | None = None) -> Identification:
    """The corrected estimate as an :class:`Identification`, judged as reported: the data's
    checks, the answer's own (bound, contact margin, backbone range and intervals at the
    corrected estimate), the replay's at the answer and the zero-clearance check at the
    reported kn. A replay that failed keeps the plain estimate, judged on its fit, and makes
    the verdict ``suspect``. ``common``: the one-gap answer (kn, delta) where the replays had
    unequal gaps (``rep.gap_shares``), ``common_t`` and ``common_p`` the t and p of the split
    it left. The record checks' even harmonics are judged again against the answer's replay
    (:func:`freeplayid.quality.replayed_even_harmonics`: a centred gap makes some of its own)."""
    if records is not None and not rep.failure:
        records = replayed_even_harmonics(records, rep.replayed_dataset)
    result = _plain_result(dataset, system, plain, mode, t0, error, records)
    if rep.failure:
        verdict = make_verdict(result.verdict.checks + tuple(replay_checks(rep)))
        return dataclasses.replace(result, verdict=verdict, replay=rep,
                                   runtime_s=time.perf_counter() - t0)
    kn_ci, delta_ci, source = _corrected_intervals(rep)
    kn_ci = widen(kn_ci, rep.kn, error.kn_shift)
    if error.hinge_gaps is not None:  # the hinges' split, read against the answer's replay
        precision = getattr(rep, "precision", None)
        error = dataclasses.replace(error, split=replayed_split(
            system, rep.statistic_points, rep.replayed_points,
            () if precision is None else precision.copy_points, kn=rep.kn, delta=rep.delta,
            mode=mode, shares=getattr(rep, "gap_shares", None), common=common,
            common_t=common_t, common_p=common_p))
        if error.split is not None and common is not None:
            error = dataclasses.replace(error, split=dataclasses.replace(
                error.split, mean_reported=mean_reported))
    validation = _zero_clearance_check(dataset, system, rep.kn)
    estimated = rep.damping if getattr(rep.damping, "source", None) == "estimated" else None
    direction = sweep_direction_check(plain.points, replayed=True,
                                      damping=getattr(rep, "damping_sensitivity", None),
                                      estimated=estimated)
    channels = replayed_channel_check(rep.resonance or {})
    verdict = make_verdict(
        record_checks(records) + base_level_checks(dataset)
        + stated_filter_checks(dataset, plain.points)
        + (channel_checks(plain.points) if channels is None else [channels])
        + answer_checks(plain.fitting_points(), rep.kn, rep.delta, kn_ci, delta_ci, system,
                        mode=mode, replayed=True) + ([direction] if direction is not None else [])
        + replay_checks(rep, down_runs=down_sweep_runs(plain.points))
        + model_checks(error) + validation_checks(validation))
    return dataclasses.replace(
        result, kn=rep.kn, delta=rep.delta, verdict=verdict, kn_ci95=kn_ci, delta_ci95=delta_ci,
        runtime_s=time.perf_counter() - t0, replay=rep, interval_source=source,
        validation=validation, model_error=error,
    )

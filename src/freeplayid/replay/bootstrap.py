"""Intervals that see the bias: the bootstrap by replay; the answer's precision under the noise.

The precision (:func:`precision_by_replay`): how far the test's noise alone moves the answer,
measured on noisy copies of the answer's replay (each channel's measured noise added, the base
channel's too), each read as the test was (the statistic's points, fitted from the replay's
estimate). The copies need only the stretch of each run around its statistic point
(``PRECISION_MARGIN_HZ`` either side, :func:`windowed`), which makes a copy about 2.5 times
cheaper than the whole record; 1.96 standard deviations of the copies' log kn and log delta,
each copy's move carried to the answer through the binding's slope (:func:`answer_slope`: the
answer makes its replay's statistic equal the test's, so where the replayed statistic follows
delta at half its rate the answer moves twice as far as the statistic), are the 95 %
half-widths that noise alone gives; their mean, less the fit of the same windowed replay
read without noise, is how far the noise moves the answer on average (``noise_bias``, which
the verdict's ``noise_precision`` centres its chance on). Against an independent reference (the SDOF
reference's records, 0.05 g of noise, tests/test_replay.py): 8 copies +-1.2 % in delta and
+-0.21 % in kn, 12 independent noise draws of the records themselves +-1.46 % and +-0.23 %. On
another fin whose responses are three times weaker against the same 0.05 g (realtests
``var5_finB_nominal``) eight draws of the test scattered delta by 1.1 % and kn by 0.5 % (sd),
and 16 copies gave +-1.8 % and +-0.94 %; on the default fin (``fin_nominal``) +-1.0-1.2 % and
+-0.44-0.54 % (16 copies, cut or whole).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import scipy.stats
from tqdm.auto import tqdm

from ..errors import IdentificationError
from ..estimate import plain_estimate
from ..sweep import Sweep

__all__ = ["ReplayBootstrap", "ReplayPrecision", "MeasuredRecords", "bootstrap_by_replay",
           "noisy_copy",
           "answer_sd", "point_centres",
           "precision_by_replay", "windowed", "sd_upper", "answer_slope", "history_jacobian",
           "PRECISION_MARGIN_HZ", "PRECISION_MIN_COPIES", "MAX_SLOPE", "MIN_SPREAD"]

# fitted copies before the precision may stop early (``settled_sd``): the chi-square bound on a
# standard deviation from 4 is 2.92 times it, from 8 1.83 times
PRECISION_MIN_COPIES = 4
# [Hz] the stretch of each run a precision copy keeps either side of its statistic point: the
# point and the jump after it (the quadrature point lies within 1 Hz of the drop on the bundled
# example), the extraction's trim (1 s) and its bandwidth's memory (1 s at 1 Hz) well inside it
PRECISION_MARGIN_HZ = 2.5


@dataclass(frozen=True)
class ReplayBootstrap:
    """Percentile 95 % intervals of the bootstrap by replay.

    Attributes
    ----------
    kn_ci95, delta_ci95 : (float, float) or None [N m/rad], [rad]
        None when fewer than max(5, n / 2) copies could be fitted.
    n : int
        Noisy copies of the final replay.
    n_fitted : int
        Copies whose plain estimate could be made (the others' noise hid a jump).
    noise : dict of str -> list of float
        Per run: each channel's measured noise level the copies got, then the base channel's
        where the runs have one [data units].
    """

    kn_ci95: tuple | None
    delta_ci95: tuple | None
    n: int
    n_fitted: int
    noise: dict


def bootstrap_by_replay(replayed, system, noise: dict, *, theta, theta_rep, n: int, seed: int,
                        extraction, fit, point_weights, binding_slope=None,
                        progress: bool = False):
    """Percentile 95 % intervals of theta * theta_b / theta_rep over ``n`` noisy copies of the
    replayed test ``replayed`` (a Dataset): a :class:`ReplayBootstrap`.

    Each copy gets fresh white noise of each channel's measured level (``noise``: per run, one
    level per channel; ``corrected_fit`` passes :func:`freeplayid.replay.weights.record_noise`,
    the record less what the replay explains of it, not the plain difference, which counts a
    replayed phase a little off as noise) and passes through the plain
    estimate with the statistic's options; its fit theta_b maps to a corrected estimate by the
    binding function's local factor theta / theta_rep (the factor varies much less than the
    noise, so it is not solved again per copy), its move carried through ``binding_slope``
    where given (:func:`precision_by_replay`): theta * exp(S log(theta_b / theta_rep)).
    """
    slope = None if binding_slope is None else np.asarray(binding_slope, float)

    def corrected(est):
        moved = np.array([est.kn, est.delta]) / theta_rep
        return theta * (moved if slope is None else np.exp(slope @ np.log(moved)))

    samples = [corrected(est) for est in _copy_estimates(
        replayed, system, noise, np.random.default_rng(seed), n=n, theta_rep=theta_rep,
        extraction=extraction, fit=fit, point_weights=point_weights,
        desc="bootstrap by replay", progress=progress) if est is not None]
    kn_ci = delta_ci = None
    if len(samples) >= max(5, n // 2):
        lo, hi = np.percentile(np.asarray(samples), [2.5, 97.5], axis=0)
        kn_ci, delta_ci = (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))
    return ReplayBootstrap(kn_ci95=kn_ci, delta_ci95=delta_ci, n=int(n), n_fitted=len(samples),
                           noise={k: [float(x) for x in v] for k, v in noise.items()})


def _copy_estimates(replayed, system, noise: dict, rng, *, n: int, theta_rep, extraction, fit,
                    point_weights, desc: str, progress: bool):
    """The plain estimates of ``n`` noisy copies of ``replayed`` (:func:`noisy_copy`), one at
    a time, each fitted from ``theta_rep`` with the statistic's options; None for a copy whose
    noise hides a jump (``IdentificationError``)."""
    for _ in tqdm(range(n), desc=desc, disable=not progress, leave=False):
        copy = noisy_copy(replayed, noise, rng)
        try:
            yield plain_estimate(copy, system, init=tuple(theta_rep), extraction=extraction,
                                 fit=fit, point_weights=point_weights)
        except IdentificationError:
            yield None


def noisy_copy(replayed, noise: dict, rng):
    """``replayed`` (a Dataset) with fresh white noise of each channel's measured level added
    to its responses, and to its base channel where the level list has one more entry
    (``noise``: per run, one level per data channel, then the base's:
    :func:`freeplayid.replay.weights.record_noise`): a replay as the test's sensors would have
    recorded it."""
    runs = []
    for run in replayed.runs:
        sd = noise.get(run.file)
        if sd is None:
            runs.append(run)
            continue
        sd = np.asarray(sd, float)
        n = run.data.shape[0]
        noisy = run.data + sd[:n, None] * rng.standard_normal(run.data.shape)
        base = run.base
        if base is not None and sd.size > n:
            base = base + sd[n] * rng.standard_normal(base.shape)
        runs.append(dataclasses.replace(run, data=noisy, base=base))
    return dataclasses.replace(replayed, runs=tuple(runs))


@dataclass(frozen=True)
class MeasuredRecords:
    """The test's own records, for a second set of the precision's copies
    (:func:`precision_by_replay`'s ``measured``): noise added to records that already carry
    it, read as the test was.

    Attributes
    ----------
    dataset : Dataset
        The records the statistic was read from.
    points : sequence of BackbonePoint
        The statistic's used points (where the copies are cut, and which curves they must
        read).
    theta : (2,) array [N m/rad], [rad]
        The statistic's (kn, delta): where each copy's fit starts.
    n : int
        Copies to make.
    """

    dataset: object
    points: tuple
    theta: np.ndarray
    n: int


@dataclass(frozen=True)
class ReplayPrecision:
    """How far the test's noise alone moves the answer (:func:`precision_by_replay`).

    Attributes
    ----------
    kn_halfwidth, delta_halfwidth : float or None [-]
        1.96 standard deviations of log kn and log delta over the fitted copies: the 95 %
        half-width of the answer's error that the noise alone makes (relative). None with
        fewer than three fitted copies.
    n : int
        Noisy copies of the answer's replay made (fewer than asked where they settled early).
    n_fitted : int
        Copies whose points could be fitted (the others' noise hid a jump).
    margin_hz : float or None [Hz]
        The stretch of each run kept either side of its statistic point (None: the whole
        records).
    statistic_halfwidths : (float, float) or None [-]
        The same of the copies' own fits (kn, delta): the replayed statistic's scatter, before
        it is carried to the answer through ``slope``; None without a slope (the same).
    slope : ((float, float), (float, float)) or None
        How the answer moves with the statistic (:func:`answer_slope`), through which the
        copies' spread was carried; None: the identity.
    copy_points : tuple of FittingPoints
        Each fitted copy's points (what else their noise moves, e.g. each hinge's share of
        the gaps: :func:`freeplayid.identification.model_error.replayed_split`). Not saved.
    noise_bias, noise_bias_se : (float, float) or None [-]
        The copies' mean log (kn, delta) less that of the same replay read without noise,
        carried to the answer through ``slope``, and its standard error (their spread over the
        square root of their number): how far the noise moves the answer on average, besides
        its scatter (a statistic read under noise need not be centred on the noise-free one).
        On 188 realtests answers 0.2 % rms in delta, up to 1.3 %, with standard errors of
        0.03-0.27 % (10th-90th percentiles). None where the noise-free replay could not be
        fitted.
    settled : bool
        The copies stopped early (``settled_sd``), so the half-widths are the upper 95 %
        confidence bounds of their spread (:func:`sd_upper`), not the spread itself: a spread
        read where it first came out small understates the true one (12 realtests answers
        that stopped at four to six copies, run to eight: the eight spread 0.8-4.4 times as
        far, median 1.4 over kn and delta; the bound fell short of them in 2 of 24).
    n_measured : int
        Fitted noisy copies of the test's own records pooled with the replay's
        (:class:`MeasuredRecords`, ``Replay.precision_record_copies``); 0: none were made.
    replay_halfwidths, measured_halfwidths : (float, float) or None [-]
        Where records' copies were pooled: the half-widths (kn, delta) of the replay's copies
        alone and of the records' copies alone (each carried through ``slope``); the pooled ones
        are ``kn_halfwidth`` and ``delta_halfwidth``.
    """

    kn_halfwidth: float | None
    delta_halfwidth: float | None
    n: int
    n_fitted: int
    margin_hz: float | None = None
    statistic_halfwidths: tuple | None = None
    slope: tuple | None = None
    copy_points: tuple = dataclasses.field(default=(), repr=False, compare=False)
    settled: bool = False
    noise_bias: tuple | None = None
    noise_bias_se: tuple | None = None
    n_measured: int = 0
    replay_halfwidths: tuple | None = None
    measured_halfwidths: tuple | None = None

    def to_dict(self) -> dict:
        return {"kn_halfwidth": self.kn_halfwidth, "delta_halfwidth": self.delta_halfwidth,
                "n": self.n, "n_fitted": self.n_fitted, "settled": self.settled,
                "margin_hz": self.margin_hz,
                "statistic_halfwidths": None if self.statistic_halfwidths is None
                else list(self.statistic_halfwidths),
                "slope": None if self.slope is None else [list(r) for r in self.slope],
                "noise_bias": None if self.noise_bias is None else list(self.noise_bias),
                "noise_bias_se": None if self.noise_bias_se is None
                else list(self.noise_bias_se),
                "n_measured": self.n_measured,
                "replay_halfwidths": None if self.replay_halfwidths is None
                else list(self.replay_halfwidths),
                "measured_halfwidths": None if self.measured_halfwidths is None
                else list(self.measured_halfwidths)}

    def describe(self) -> str:
        if self.kn_halfwidth is None:
            return (f"not measured ({self.n_fitted} of {self.n} noisy copies of the replay "
                    "could be fitted)")
        via, own = "", self.statistic_halfwidths
        if own is not None and own[1] > 0 and abs(self.delta_halfwidth / own[1] - 1) > 0.1:
            via = (f"; their fits scatter delta by ±{100 * own[1]:.2g} %, and the answer, "
                   "which makes its replay's fit match the test's, moves "
                   f"{self.delta_halfwidth / own[1]:.2g} times as far")
        if self.noise_bias is not None:
            b, se = self.noise_bias, self.noise_bias_se
            via += (f"; on average it moves delta by {100 * math.expm1(b[1]):+.2g} ± "
                    f"{100 * se[1]:.2g} % and kn by {100 * math.expm1(b[0]):+.2g} ± "
                    f"{100 * se[0]:.2g} % (the copies' mean against the replay read without "
                    "noise)")
        if self.settled:
            return (f"the data's noise alone moves delta by at most ±"
                    f"{100 * self.delta_halfwidth:.2g} % and kn by at most "
                    f"±{100 * self.kn_halfwidth:.2g} % (the upper 95 % bounds from "
                    f"{self.n_fitted} noisy copies of the answer's replay, which stopped there: "
                    f"far below what matters{via})")
        copies = f"{self.n_fitted} noisy copies of the answer's replay"
        if self.n_measured and self.replay_halfwidths and self.measured_halfwidths:
            copies += (f" and {self.n_measured} of the test's own records, pooled: delta "
                       f"±{100 * self.replay_halfwidths[1]:.2g} % on the replay's alone, "
                       f"±{100 * self.measured_halfwidths[1]:.2g} % on the records'")
        return (f"the data's noise alone moves delta by ±{100 * self.delta_halfwidth:.2g} % and "
                f"kn by ±{100 * self.kn_halfwidth:.2g} % (95 %, {copies}{via})")


def windowed(replayed, centres: dict, margin_hz: float):
    """``replayed`` (a Dataset) with each run in ``centres`` ({run: frequency [Hz]}) that has a
    sweep hint cut to where its sweep passes ``centre +- margin_hz`` (within its band), the hint
    moved with it (the same law from the cut's first sample); other runs as they are."""
    runs = []
    for run in replayed.runs:
        f0 = centres.get(run.file)
        if f0 is None or not run.sweep or run.reason:
            runs.append(run)
            continue
        sw = Sweep(**run.sweep)
        lo_band, hi_band = sorted((sw.start_hz, sw.stop_hz))
        f_lo, f_hi = max(f0 - margin_hz, lo_band), min(f0 + margin_hz, hi_band)
        t_a, t_b = sorted(float(t) for t in sw.time_at(np.array([f_lo, f_hi])))
        n, fs = run.data.shape[-1], float(replayed.sample_rate)
        i0, i1 = max(int(np.floor(t_a * fs)), 0), min(int(np.ceil(t_b * fs)) + 1, n)
        if i1 - i0 >= n or i1 - i0 < 16:
            runs.append(run)
            continue
        hint = dict(run.sweep, start_hz=float(sw.frequency(i0 / fs)),
                    stop_hz=float(sw.frequency((i1 - 1) / fs)))
        runs.append(dataclasses.replace(
            run, time=run.time[i0:i1] - run.time[i0], data=run.data[..., i0:i1], sweep=hint,
            base=None if run.base is None else run.base[i0:i1]))
    return dataclasses.replace(replayed, runs=tuple(runs))


def precision_by_replay(replayed, system, noise: dict, *, points, theta_rep, n: int, seed: int,
                        extraction, fit, point_weights,
                        margin_hz: float | None = PRECISION_MARGIN_HZ,
                        settled_sd: tuple[float, float] | None = None,
                        binding_slope=None, measured: MeasuredRecords | None = None,
                        progress: bool = False) -> ReplayPrecision:
    """How far the noise alone moves the answer (module docstring): ``n`` noisy copies of the
    answer's replay ``replayed`` (a Dataset; each run cut to ``margin_hz`` either side of its
    statistic point in ``points``, the replay's used points; None keeps the whole records, as
    does a cut whose noise-free reading takes its points from other curves than ``points``: a
    down-sweep's second channel, which the whole record's checks leave out, can enter the cut's
    fit and make it another statistic),
    each channel's measured ``noise`` added (:func:`noisy_copy`), their points fitted from
    ``theta_rep`` with the statistic's options; 1.96 standard deviations of their log
    (kn, delta) carried to the answer.

    ``binding_slope`` (2, 2), optional: how the answer moves with the statistic, d log
    (kn, delta) of the answer per d log (kn, delta) of the statistic (the inverse of the
    binding function's Jacobian, :func:`answer_slope`). The answer solves replay(answer) =
    statistic, so a statistic moved by the noise moves the answer by this matrix times that
    move: where the replayed statistic follows delta at half its rate, the answer scatters twice
    as far as the statistic (measured on the noise study's cases: up to 3.7 times). Each copy's
    deviation from the copies' mean is carried through it, so the copies' correlation of kn and
    delta counts; None: the identity (the answer as noisy as the statistic).

    ``settled_sd`` (log kn, log delta): the copies stop early, from the
    :data:`PRECISION_MIN_COPIES`-th fitted one on, once the upper 95 % confidence bound of
    both standard deviations (chi-square, :func:`sd_upper`) lies below these: more copies could
    only confirm that the noise is far below what matters (the verdict passes
    ``identification.replay_checks.settled_sd``, a 1 % chance of leaving the accuracy bounds).
    Those bounds are then the half-widths returned (``settled``): copies that stop where their
    spread first comes out small have, by that choice, a spread below the true one.

    ``measured`` (:class:`MeasuredRecords`), optional: that many noisy copies of the test's own
    records as well (noise on records that carry it already: their own noise is common to
    every copy, so the copies scatter by the added noise alone, at the tested structure rather
    than at its replay), read the same way; their spread, carried through the slope, is pooled
    with the replay's copies' (each about its own mean), so that where the replay is moved by
    the noise less than the structure (a fin whose responses are weak against the noise: its
    replay's copies read the noise 7-21 % narrow) the records' copies count too. Not made where
    the replay's copies settled early. The mean move (``noise_bias``) stays the replay's."""
    def read(ds):  # the copies' centre: ``ds`` read without noise (None: not fitted)
        return _read_clean(ds, system, theta_rep, extraction, fit, point_weights)

    clean = None
    if margin_hz is not None:
        cut, clean = _cut_reading(replayed, points, margin_hz, read)
        if cut is not None:
            replayed = cut
        else:  # the cut reads other points than the whole records: the whole records
            margin_hz = None
    if clean is None:
        clean = read(replayed)
    clean = None if clean is None else np.log([clean.kn, clean.delta])
    rng = np.random.default_rng([seed, 2])  # not the bootstrap's or the cross-check's copies
    slope = np.eye(2) if binding_slope is None else np.asarray(binding_slope, float)
    logs, made, points, settled = [], 0, [], False  # each copy's log (kn, delta) and points
    for est in _copy_estimates(
            replayed, system, noise, rng, n=n, theta_rep=theta_rep, extraction=extraction,
            fit=fit, point_weights=point_weights, desc="the answer's precision: noisy copies",
            progress=progress):
        made += 1
        if est is not None and est.fit.success:
            logs.append(np.log([est.kn, est.delta]))
            points.append(est.fitting_points())
        if settled_sd is not None and len(logs) >= PRECISION_MIN_COPIES and np.all(
                sd_upper(answer_sd(np.asarray(logs), slope), len(logs))
                <= np.asarray(settled_sd)):
            settled = made < n
            break
    kn_hw = delta_hw = own = bias = bias_se = alone = others = None
    n_measured = 0
    if len(logs) >= 3:
        if clean is not None:  # the copies' mean move from the replay read without noise
            moved = (np.asarray(logs) - clean) @ slope.T
            bias = tuple(float(v) for v in moved.mean(axis=0))
            bias_se = tuple(float(v) for v in moved.std(axis=0, ddof=1) / math.sqrt(len(logs)))
        # the answer's scatter: each copy's log (kn, delta) carried through the slope, never
        # below the copies' own (a slope learnt from a few replays is not trusted to narrow it);
        # where the copies stopped early, the upper bounds that stopped them (``settled``)
        bound = (lambda sd: sd_upper(sd, len(logs))) if settled else (lambda sd: sd)
        raw = bound(np.std(np.asarray(logs), axis=0, ddof=1))
        carried = bound(answer_sd(np.asarray(logs), slope))
        m_logs = None if settled or measured is None or measured.n <= 0 else _measured_logs(
            measured, system, noise, seed=seed, extraction=extraction, fit=fit,
            point_weights=point_weights, margin_hz=margin_hz, progress=progress)
        if m_logs is not None:  # pooled with the records' copies, each about its own mean
            m_carried = answer_sd(m_logs, slope)
            alone, others = _halfwidths(carried), _halfwidths(m_carried)
            n_measured = len(m_logs)
            raw = pooled_sd(raw, len(logs), np.std(m_logs, axis=0, ddof=1), n_measured)
            carried = pooled_sd(carried, len(logs), m_carried, n_measured)
        own = _halfwidths(raw)
        kn_hw, delta_hw = _halfwidths(carried)
    return ReplayPrecision(
        kn_halfwidth=kn_hw, delta_halfwidth=delta_hw, n=made, n_fitted=len(logs),
        margin_hz=margin_hz, statistic_halfwidths=None if binding_slope is None else own,
        slope=None if binding_slope is None else tuple(tuple(float(v) for v in r) for r in slope),
        copy_points=tuple(points), settled=settled, noise_bias=bias, noise_bias_se=bias_se,
        n_measured=n_measured, replay_halfwidths=alone, measured_halfwidths=others)


def pooled_sd(sd_a, k_a: int, sd_b, k_b: int) -> np.ndarray:
    """The pooled standard deviation of two sets of ``k_a`` and ``k_b`` samples whose own
    (``ddof=1``) standard deviations are ``sd_a`` and ``sd_b``, each about its own mean."""
    a, b = np.asarray(sd_a, float), np.asarray(sd_b, float)
    return np.sqrt(((k_a - 1) * a ** 2 + (k_b - 1) * b ** 2) / (k_a + k_b - 2))


def _measured_logs(measured: MeasuredRecords, system, noise: dict, *, seed: int, extraction,
                   fit, point_weights, margin_hz, progress: bool) -> np.ndarray | None:
    """Log (kn, delta) of the fitted noisy copies of the test's own records (``measured``),
    cut as the replay's copies were (``margin_hz``; the whole records where the cut reads
    other curves than the statistic's points), each fitted from the statistic's estimate;
    None with fewer than three fitted."""
    records = measured.dataset
    if margin_hz is not None:
        cut, _ = _cut_reading(records, measured.points, margin_hz, lambda ds: _read_clean(
            ds, system, measured.theta, extraction, fit, point_weights))
        records = records if cut is None else cut
    rng = np.random.default_rng([seed, 6])  # not the replay's copies' or any other's
    logs = [np.log([e.kn, e.delta]) for e in _copy_estimates(
        records, system, noise, rng, n=measured.n, theta_rep=measured.theta,
        extraction=extraction, fit=fit, point_weights=point_weights,
        desc="the answer's precision: noisy copies of the records", progress=progress)
        if e is not None and e.fit.success]
    return np.asarray(logs) if len(logs) >= 3 else None


def _read_clean(ds, system, theta, extraction, fit, point_weights):
    """``ds`` read as the test was (its statistic's points fitted from ``theta``), without
    adding noise; None where it cannot be identified or its fit fails."""
    try:
        est = plain_estimate(ds, system, init=tuple(theta), extraction=extraction, fit=fit,
                             point_weights=point_weights)
    except IdentificationError:
        return None
    return est if est.fit.success else None


def _cut_reading(records, points, margin_hz: float, read) -> tuple:
    """``records`` cut to ``margin_hz`` about ``points`` (:func:`windowed`) and the cut's
    reading (``read(cut)``), where that reading takes its points from the same curves as
    ``points``; (None, None) where it does not or cannot be read."""
    cut = windowed(records, point_centres(points), margin_hz)
    est = read(cut)
    if est is None or _pairs(est.points.used()) != _pairs(points):
        return None, None
    return cut, est


def _pairs(points) -> frozenset:
    """The (run, channel) pairs of ``points``: which curves gave the statistic."""
    return frozenset((p.run, p.channel) for p in points)


def answer_sd(logs: np.ndarray, slope, about=None) -> np.ndarray:
    """Standard deviations of log kn and log delta of the copies' fits ``logs`` (k, 2) carried
    through ``slope`` (None: the identity), never below their own: about their mean, or with
    ``about`` (2,) the root mean square of their moves from it (a known centre)."""
    logs = np.asarray(logs, float)
    slope = np.eye(2) if slope is None else np.asarray(slope, float)

    def spread(x):
        if about is None:
            return np.std(x, axis=0, ddof=1)
        return np.sqrt(np.mean(x ** 2, axis=0))

    moves = logs if about is None else logs - np.asarray(about, float)
    return np.maximum(spread(moves @ slope.T), spread(moves))


def point_centres(points) -> dict:
    """Per run: the median frequency [Hz] of its ``points`` (the runs' statistic points, where
    the copies cut each run: :func:`windowed`)."""
    by_run: dict = {}
    for p in points:
        by_run.setdefault(p.run, []).append(p.f_hz)
    return {r: float(np.median(f)) for r, f in by_run.items()}


def _halfwidths(sd) -> tuple[float, float]:
    """The relative 95 % half-widths (kn, delta) of standard deviations ``sd`` of log kn and
    log delta: expm1(1.96 sd)."""
    return float(np.expm1(1.96 * sd[0])), float(np.expm1(1.96 * sd[1]))


# [-] the largest factor by which the answer's scatter may exceed the statistic's through the
# binding's slope (:func:`answer_slope`); a loop's learnt Jacobian flatter than this in some
# direction is taken as this flat (an answer 10 times noisier than its statistic already fails
# the verdict's ``noise_precision`` on any test with noise)
MAX_SLOPE = 10.0


# [-] the least spread (smallest singular value of the centred log (kn, delta), in log units) of
# the loop's replays from which their regression gives the binding's slope (history_jacobian):
# four times the loop's tolerance (``Replay.rtol``, 5e-4), so the replays' steps, not their last
# digits, set it
MIN_SPREAD = 2e-3


def history_jacobian(theta: np.ndarray, rep: np.ndarray) -> np.ndarray | None:
    """The binding function's Jacobian d log rep / d log theta regressed on the loop's replays
    (``theta``, ``rep``: (n, 2) replayed (kn, delta) and their fits), an affine least-squares
    fit over all of them rather than Broyden's rank-one updates from the identity (which learn
    only the directions stepped along, and on the noise study's cases put the slope up to 3
    times off that regression). None with fewer than four replays or where they spread less
    than :data:`MIN_SPREAD` in some direction."""
    x, y = np.log(np.asarray(theta, float)), np.log(np.asarray(rep, float))
    if x.shape[0] < 4 or not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        return None
    xc = x - x.mean(axis=0)
    if np.linalg.svd(xc, compute_uv=False).min() < MIN_SPREAD:
        return None
    coef, *_ = np.linalg.lstsq(xc, y - y.mean(axis=0), rcond=None)
    return coef.T


def answer_slope(jacobian) -> np.ndarray | None:
    """d log (kn, delta) of the answer per d log (kn, delta) of the statistic: the first two
    rows and columns of the inverse of the binding function's Jacobian ``jacobian`` (the replay
    loop's, (2, 2), or (3, 3) with the estimated damping's equation, which then stays solved);
    its singular values are capped at :data:`MAX_SLOPE`. None where it cannot be inverted."""
    J = np.asarray(jacobian, float)
    try:
        inv = np.linalg.inv(J)[:2, :2]
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(inv)):
        return None
    u, s, vt = np.linalg.svd(inv)
    return (u * np.minimum(s, MAX_SLOPE)) @ vt


def sd_upper(sd, k: int):
    """Upper 95 % confidence bound of a standard deviation ``sd`` estimated from ``k`` normal
    samples (``ddof=1``): ``sd * sqrt((k - 1) / chi2_{0.05}(k - 1))`` (2.92 sd from 4)."""
    return np.asarray(sd) * math.sqrt((k - 1) / scipy.stats.chi2.ppf(0.05, k - 1))

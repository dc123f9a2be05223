"""The linear model's error in the answer: the update to sealed modes and kn's interval.

kn is conditional on the model (:class:`freeplayid.model.ModelOptions`). With the sealed fin's
modes the model is updated to them before the identification
(:func:`freeplayid.model.update_to_sealed_modes`); without, or for what the update could not
explain, kn's interval takes in the move of kn that the model's frequency uncertainty makes
(:func:`frequency_uncertainty`: where the update has as many parameters as sealed modes, two
modes with one scale or three with two, it fits them exactly whatever the model's error, and the
option's uncertainty stands):
the plain fit's points refitted against the model with that mode's frequency moved by ``u``
give kn's relative move ``m``, and the interval's log half-width becomes sqrt(h^2 + m^2). The
mode's frequency is moved by scaling the structure's stiffness (not the hinges'): its share of
the closed mode's stiffness at the estimate, phi^T K phi / w^2 (0.35 on the default fin: the
hinge springs carry the rest), sets the scale, 1 + ((1 + u)^2 - 1) / share, that moves the
closed mode's frequency by ``u`` (:func:`frequency_scale`).

One delta stands for every hinge. Where the hinges' gaps differ, what the points show of it is
measured (:func:`gap_split`): hinge j's half-gap (1 + a) delta and the others' (1 - a / (h - 1))
delta (their mean delta), the DFA backbone at the answer moves each point's frequency by v_i
(log); the common fit absorbs the part of v along its two directions (d log f / d log kn,
d log delta), and what is left, the part the points could show, is compared with their scatter
about the fit (the plain fit's RMS relative residual). The largest a it stays within that
scatter at every point, over the hinges, is the split these data cannot see; the common fit's
delta then differs from the hinges' mean by the move it absorbs (on the bundled example: a split
up to +-0.57 cannot be seen; at +-0.1 delta is the mean within 0.6 %; the realtests fin with
half-gaps 2.7 and 3.3 mrad gave the mean +0.33 %, the model +0.37 %).

One half-gap per hinge (:func:`fit_hinge_gaps`): the plain fit's points fitted again with each
hinge's half-gap free, x = (ln kn, ln delta_1, ..., ln delta_h), the DFA backbone with
``gaps = delta_j / mean`` (the curve bends where each hinge reaches its gap), started from the
common fit. Each hinge's share of the gaps has a Gauss-Newton interval (each run one observation,
as kn's and delta's: :func:`freeplayid.fit.jacobian_halfwidths`, ln share's variance through
the mean). Where the hinges turn unequally in the identified mode (rotation ratio below
:data:`HINGES_TOGETHER`) this fit runs by default and an F test says whether one common delta
explains the points (:func:`_common_gap_p`; the verdict's ``hinge_gaps``): where it does not,
delta is no hinge's half-gap (on a two-hinge beam with half-gaps 2 and 3 mrad, turning 1 : 0.45,
the corrected delta was 2.30 mrad, 8 % below their mean, with an interval of +-2.6 %), and the
replay, which gives every hinge that delta, does not correct it. With
``ModelOptions.hinge_gaps`` each hinge's half-gap is reported: the plain per-hinge gap moved by
the replay's correction of the common delta, its log half-width those of delta and of its share
in quadrature (:meth:`HingeGaps.half_gaps`); the sweep's bias of the split itself is not
corrected (that beam: 2.11 and 2.81 mrad, intervals x/÷ 2.6 and 2.0 holding 2 and 3). Where
the hinges turn together the shares are not determined (the default fin at half-gaps 2.7 / 3.3
mrad: shares 0.70 / 1.30, intervals beyond x/÷ 10), and the report says the data cannot tell
the gaps apart.

With the replay, the split is read against the answer's replay (:func:`replayed_split`): the
per-hinge fit of the test's statistic points and of its replay's at the answer, where every hinge
has the answer's delta. The sweep bends each hinge's share as much in the replay as in the test
(on fin C's equal-gap records the test's shares lie up to 18 % off one, and the replay's follow
them within their noise, 0.04-0.07 in log), so their ratio is the split the hinges' gaps make,
and the noisy copies of the replay (:func:`freeplayid.replay.precision_by_replay`) give its
noise. Where that split is suggested (p below the verdict's ``split_p``; Student's t at the
copies' count), the identification replays the test with it, and the verdict's ``hinge_gaps``
judges how far the one-gap answer lies from the hinges' mean (:attr:`ReplayedSplit.lean`) by
its chance of lying beyond delta's bound (:meth:`ReplayedSplit.lean_outside`). Without that
replay, ``hinge_gaps`` fails where the split lies beyond its noise as far as the two-sided
``cross_p`` allows and puts delta beyond half its bound from the hinges' mean
(``without_delta``): delta is then no hinge's half-gap. Each hinge's half-gap is estimated as
delta times its split share (:attr:`ReplayedSplit.half_gaps`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import scipy.optimize
import scipy.stats

from ..backbone import amplitude_grid, dfa_backbone
from ..estimate import PlainEstimate, check_determined, refit, structure_share
from ..fit import FitOptions, gap_ratios, jacobian_halfwidths
from ..model import ModelOptions, SealedUpdate, modal_analysis, update_to_sealed_modes
from .replay_checks import noise_outside_chance

__all__ = ["ModelError", "GapSplit", "HingeGaps", "ReplayedSplit", "update_model", "model_error",
           "hinge_ratio", "frequency_scale", "frequency_uncertainty", "gap_split",
           "fit_hinge_gaps", "replayed_split", "hinge_names"]

# [-] hinge rotation ratio in the identified mode above which the hinges count as turning together
HINGES_TOGETHER = 0.9

# [-] the gap splits a tried (hinge j's half-gap (1 + a) delta); the split the points cannot see
# is interpolated between them, and reported as at least the last where even that is not seen
GAP_SPLITS = (0.05, 0.1, 0.2, 0.4, 0.8)

# the F test's p-value below which one common delta does not explain the points (point by point:
# a liberal test, :func:`_common_gap_p`)
COMMON_GAP_P = 1e-3
# the amplitude grid of the per-hinge fits that read the split against the replay
# (:func:`replayed_split`): over the points' range only
SPLIT_GRID = 64
# [-] a share's 95 % log half-width from which it counts as not determined (a factor of 10)
NOT_DETERMINED = math.log(10.0)


@dataclass(frozen=True)
class GapSplit:
    """How unequal the hinges' gaps could be without the points showing it (:func:`gap_split`).

    Attributes
    ----------
    split : float [-]
        The largest a such that a hinge's half-gap (1 + a) delta (the others' smaller, their
        mean delta) moves no point's frequency, beyond what the common fit absorbs, by more than
        the points' scatter; ``GAP_SPLITS[-1]`` when even that split is not seen (``beyond``).
    beyond : bool
        Whether ``split`` is only a lower bound (no split tried was seen).
    scatter : float [-]
        The points' RMS relative frequency residual about the plain fit.
    delta_bias : float [-]
        |common delta / the hinges' mean - 1| at ``split``: interpolated between the splits
        tried (the largest move of those up to each), as ``split`` is.
    """

    split: float
    beyond: bool
    scatter: float
    delta_bias: float

    def describe(self) -> str:
        up = f"{'more than ' if self.beyond else 'up to '}±{100 * self.split:.2g} %"
        return (f"gaps split by {up} between the hinges move no point by more than the points' "
                f"scatter about the fit ({100 * self.scatter:.2g} %) once the common fit absorbs "
                "what it can, so these data cannot tell such gaps apart: a hinge's own half-gap "
                f"may be that much over delta, and delta is then their mean within "
                f"{100 * self.delta_bias:.2g} %")

    def to_dict(self) -> dict:
        return {"split": self.split, "beyond": self.beyond, "scatter": self.scatter,
                "delta_bias": self.delta_bias}


@dataclass(frozen=True)
class HingeGaps:
    """One half-gap per hinge from the plain fit's points (:func:`fit_hinge_gaps`).

    Attributes
    ----------
    hinges : tuple of str
        Each hinge's name, "outboard/inboard" DOFs.
    deltas : tuple of float [rad]
        Each hinge's half-gap fitted to the plain fit's points (with their sweep bias).
    log_halfwidth : tuple of float [-]
        The 95 % half-width of each hinge's share of the gaps' sum, in log (inf: not determined
        by the points).
    common_delta : float [rad]
        The common fit's delta on the same points.
    residual_rms, common_rms : float [-]
        The points' RMS relative frequency residual about this fit and about the common one.
    p_common : float or None
        The F test's p-value that one common delta explains the points as well (each point one
        observation, :func:`_common_gap_p`; None: too few points to test).
    """

    hinges: tuple
    deltas: tuple
    log_halfwidth: tuple
    common_delta: float
    residual_rms: float
    common_rms: float
    p_common: float | None

    @property
    def shares(self) -> tuple:
        """Each hinge's half-gap over the hinges' mean."""
        m = float(np.mean(self.deltas))
        return tuple(d / m for d in self.deltas)

    @property
    def common_explains(self) -> bool:
        """The F test does not reject one common delta at :data:`COMMON_GAP_P` (or cannot be
        made)."""
        return self.p_common is None or self.p_common >= COMMON_GAP_P

    def half_gaps(self, delta: float, delta_ci95) -> list[tuple[float, tuple[float, float]]]:
        """Each hinge's half-gap [rad] and its 95 % interval for the reported (corrected)
        ``delta`` with its interval ``delta_ci95``: the plain per-hinge gaps moved by the
        replay's correction of the common delta (delta / common_delta), their log half-widths
        those of delta and of each hinge's share in quadrature (module docstring)."""
        out = []
        for d, w in zip(self.deltas, self.log_halfwidth, strict=True):
            v = d * delta / self.common_delta
            out.append((v, (0.0, math.inf) if w >= NOT_DETERMINED else
                        _gap_interval(v, delta, delta_ci95, w)))
        return out

    def test(self) -> str:
        """The common-delta test in words."""
        if self.p_common is None:
            return "too few points to test whether one common half-gap explains them"
        return (f"one half-gap per hinge lowers the points' RMS residual from "
                f"{100 * self.common_rms:.2g} % to {100 * self.residual_rms:.2g} % (F test: "
                f"p = {self.p_common:.2g})")

    def outcome(self) -> str:
        """Whether one common delta explains the points, in words."""
        return ("one common half-gap explains the points" if self.common_explains else
                "one common half-gap does not explain the points: the hinges' gaps differ")

    def describe(self) -> str:
        shares = ", ".join(f"{n} {r:.3g} (95 % x/÷ {math.exp(w):.3g})"
                           if w < NOT_DETERMINED else f"{n} {r:.3g} (not determined)"
                           for n, r, w in zip(self.hinges, self.shares, self.log_halfwidth,
                                              strict=True))
        verdict = self.outcome()
        wide = max(self.log_halfwidth) > math.log(2.0)
        return (f"one half-gap per hinge (the backbone fitted with each hinge's gap free), each "
                f"hinge's over their mean: {shares}; {verdict} ({self.test()})"
                + ("; the points cannot tell the gaps apart beyond a factor of two" if wide
                   else ""))

    def to_dict(self) -> dict:
        return {"hinges": list(self.hinges), "deltas": list(self.deltas),
                "shares": list(self.shares),
                "log_halfwidth": [w if math.isfinite(w) else None for w in self.log_halfwidth],
                "common_delta": self.common_delta, "residual_rms": self.residual_rms,
                "common_rms": self.common_rms, "p_common": self.p_common,
                "common_explains": self.common_explains}


@dataclass(frozen=True)
class ReplayedSplit:
    """The hinges' split of the gaps read against the answer's replay (:func:`replayed_split`).

    Attributes
    ----------
    hinges : tuple of str
        Each hinge's name, "outboard/inboard" DOFs.
    half_gaps : tuple of float [rad]
        Each hinge's half-gap: its gap in the replay (delta, or delta times its share with
        ``shares``) times the test's per-hinge gap over the replay's (the sweep bends each
        hinge's fitted gap alike in both).
    log_split : tuple of float [-]
        Each hinge's log share of the gaps (its half-gap over their mean) in the test less that
        in the replay: 0 where one common delta explains the test as its replay.
    log_se : tuple of float [-]
        Each one's standard error: the root mean square of the noisy copies' log shares about
        the replay's (nan without copies).
    n_copies : int
        Noisy copies of the replay whose points were fitted.
    delta : float [rad]
        The answer's delta.
    shares : tuple of float
        The replay's unequal gaps (each hinge's half-gap over their mean; ``Replay.gap_shares``),
        () where every hinge had delta.
    common : (float, float) or None
        With ``shares``: the answer (kn [N m/rad], delta [rad]) of the replays with one common
        gap, whose split put the shares (how far the hinges' mean lies from it: ``lean``).
    mean_reported : bool
        With ``common``: whether the reported answer is the hinges' mean (this replay's; with
        ``linear_model.hinge_gaps``) or the one-gap answer (the default: the split may be the
        linear model's or the noise's, and this replay measures how far the mean could lie).
    common_t : float
        With ``common``: the ``t`` of the split that one common gap left (the reading that set
        the shares; nan where not known). The lean is in proportion to that split, so its
        relative standard error is one over it (:meth:`lean_outside`).
    common_p : float or None
        With ``common``: that split's p (None where not known). At or above the verdict's
        ``cross_p`` one common gap explains the test too: the split was only suggested.
    """

    hinges: tuple
    half_gaps: tuple
    log_split: tuple
    log_se: tuple
    n_copies: int
    delta: float
    shares: tuple = ()
    common: tuple | None = None
    mean_reported: bool = True
    common_t: float = math.nan
    common_p: float | None = None

    @property
    def lean(self) -> float | None:
        """The common gap's delta over the hinges' mean (delta replayed with ``shares``), less
        1; None without them."""
        return None if self.common is None else self.common[1] / self.delta - 1.0

    @property
    def lean_se(self) -> float | None:
        """The lean's standard error in log: its size over ``common_t``, the split that set it
        read to that many standard errors (0 where ``common_t`` is not known); None without
        ``common``."""
        if self.common is None:
            return None
        t = self.common_t
        return abs(math.log1p(self.lean)) / t if math.isfinite(t) and t > 0 else 0.0

    def lean_outside(self, bound: float) -> float | None:
        """The chance that the one-gap answer lies beyond ``bound`` (relative) from the hinges'
        mean, were the gaps split as the test shows them: the lean (log), normal about its
        reading with :attr:`lean_se`; None without ``common``."""
        if self.common is None:
            return None
        return noise_outside_chance(0.0, bound, math.log1p(self.lean), self.lean_se)

    @property
    def t(self) -> float:
        """The largest |log share| over its standard error (nan with fewer than two copies)."""
        if self.n_copies < 2:
            return math.nan
        out = 0.0
        for c, e in zip(self.log_split, self.log_se, strict=True):
            if e > 0:
                out = max(out, abs(c) / e)
            elif c != 0:
                return math.inf
        return out

    @property
    def p(self) -> float | None:
        """Two-sided p-value of ``t`` (Student's t with ``n_copies`` degrees of freedom: the
        standard errors are root mean squares about a known centre); None with fewer than two
        copies."""
        t = self.t
        return None if math.isnan(t) else float(2 * scipy.stats.t.sf(t, self.n_copies))

    @property
    def mean_offset(self) -> float:
        """delta over the hinges' mean half-gap, less 1 (0 at equal gaps)."""
        return self.delta / float(np.mean(self.half_gaps)) - 1.0

    def intervals(self, delta_ci95) -> list[tuple[float, float]]:
        """Each hinge's half-gap's 95 % interval: delta's log half-widths (``delta_ci95``) and
        its share's (Student's t at the copies' count times its standard error) in quadrature;
        unbounded without copies."""
        t = float(scipy.stats.t.ppf(0.975, self.n_copies)) if self.n_copies >= 2 else math.inf
        return [_gap_interval(g, self.delta, delta_ci95,
                              t * e if math.isfinite(t) and np.isfinite(e) else math.inf)
                for g, e in zip(self.half_gaps, self.log_se, strict=True)]

    def describe(self) -> str:
        gaps = ", ".join(f"{n} {1e3 * g:.4g} mrad" for n, g in zip(self.hinges, self.half_gaps,
                                                                    strict=True))
        shares = ", ".join(f"{100 * math.expm1(c):+.2g} % (se {100 * e:.2g} %)"
                           for c, e in zip(self.log_split, self.log_se, strict=True))
        p = self.p
        if self.shares:
            given = ", ".join(f"{n} {1e3 * self.delta * r:.4g} mrad"
                              for n, r in zip(self.hinges, self.shares, strict=True))
            if self.common is None:
                why = "as given, `replay.gap_shares`"
            else:
                kn0, d0 = self.common
                why = (f"the split that one common gap left, kn {kn0:.5g} N·m/rad, delta "
                       f"{1e3 * d0:.5g} mrad, {100 * self.lean:+.2f} % from this mean")
            return (f"replayed with unequal gaps ({given}, their mean delta; {why}), the "
                    f"test's points put the hinges' shares of the gaps {shares} off that "
                    f"replay's ({self.n_copies} noisy copies; p = "
                    f"{'n/a' if p is None else f'{p:.2g}'}): half-gaps {gaps}")
        return (f"against the answer's replay (one delta for every hinge), the test's points "
                f"put the hinges' shares of the gaps {shares} off ({self.n_copies} noisy "
                f"copies of the replay; p = {'n/a' if p is None else f'{p:.2g}'}): as unequal "
                f"gaps, half-gaps {gaps}, their mean "
                f"{100 * -self.mean_offset / (1 + self.mean_offset):+.2f} % from delta")

    def to_dict(self) -> dict:
        def num(v):
            return float(v) if math.isfinite(v) else None

        return {"hinges": list(self.hinges), "half_gaps": list(self.half_gaps),
                "log_split": list(self.log_split), "log_se": [num(v) for v in self.log_se],
                "n_copies": self.n_copies, "t": num(self.t), "p": self.p,
                "mean_offset": self.mean_offset, "shares": list(self.shares),
                "common": None if self.common is None else list(self.common),
                "lean": self.lean, "lean_se": self.lean_se,
                "common_t": num(self.common_t), "common_p": self.common_p,
                "mean_reported": self.mean_reported}


def _gap_interval(gap: float, delta: float, delta_ci95, share: float) -> tuple[float, float]:
    """A hinge's half-gap's 95 % interval: ``delta_ci95`` moved to ``gap`` and widened by the
    share's log half-width ``share`` in quadrature (:func:`widen`)."""
    lo, hi = delta_ci95
    return widen((lo * gap / delta, hi * gap / delta), gap, share)


def _keyed(points) -> dict:
    """{(run, DOF): record} of FittingPoints (:meth:`~freeplayid.fit.FittingPoints.to_records`)."""
    return {(r.get("run"), r["channel"]): r for r in points.to_records()}


def _subset(keyed: dict, keys: list):
    """FittingPoints of ``keyed`` at ``keys`` (in that order); None where one is missing."""
    from ..fit import FittingPoints

    if any(k not in keyed for k in keys):
        return None
    return FittingPoints.from_records(keyed[k] for k in keys)


def replayed_split(system, measured, replayed, copies, *, kn: float, delta: float,
                   mode: int = 0, shares=None, common=None,
                   common_t: float = math.nan,
                   common_p: float | None = None) -> ReplayedSplit | None:
    """The hinges' split of the gaps read against the answer's replay (module docstring).

    Parameters
    ----------
    system : FreeplaySystem
        The model the answer was identified with (two hinges or more).
    measured, replayed : FittingPoints
        The test's statistic points and its replay's at the answer (kn, delta).
    copies : sequence of FittingPoints
        The points of noisy copies of that replay (their noise is the test's).
    kn, delta : float [N m/rad], [rad]
        The answer.
    shares : sequence of float or None
        The replay's gap shares (hinge j at ``delta * shares[j]``); None: one common gap.
    common : (float, float) or None
        With ``shares``: the one-gap answer whose split set them (:attr:`ReplayedSplit.lean`).
    common_t, common_p : float
        With ``common``: the ``t`` of that split (:attr:`ReplayedSplit.lean_se`) and its p.

    Returns None with one hinge, fewer than three points the test and its replay share, or
    where a per-hinge fit cannot be made.
    """
    if system.n_hinges < 2 or measured is None or replayed is None:
        return None
    m, r = _keyed(measured), _keyed(replayed)
    keys = [k for k in m if k in r]
    if len(keys) < system.n_hinges + 2:
        return None

    test = _subset(m, keys)
    ratios, _ = gap_ratios(test, system, kn, delta, mode)
    if not np.all(np.isfinite(ratios)):
        return None
    # one grid for all: the points' range, a hinge's gap halving or doubling (SPLIT_GRID
    # points, where the whole curve's 256 cost four times as much)
    grid = np.geomspace(max(1.0005, 0.5 * float(ratios.min())), 4.0 * float(ratios.max()),
                        SPLIT_GRID)

    def gaps(points):
        if points is None:
            return None
        hg = fit_hinge_gaps(system, points, kn, delta, mode=mode, grid=grid)
        return None if hg is None else np.asarray(hg.deltas, float)

    g_m, g_r = gaps(test), gaps(_subset(r, keys))
    if g_m is None or g_r is None:
        return None

    def log_shares(g):
        return np.log(g) - np.log(np.mean(g))

    noise = [log_shares(g) - log_shares(g_r) for g in
             (gaps(_subset(_keyed(c), keys)) for c in copies) if g is not None]
    se = (np.sqrt(np.mean(np.square(noise), axis=0)) if len(noise) else
          np.full(g_m.size, np.nan))
    r = np.ones(g_m.size) if shares is None else np.asarray(shares, float)
    return ReplayedSplit(
        hinges=hinge_names(system),
        half_gaps=tuple(float(v) for v in delta * r * g_m / g_r),
        log_split=tuple(float(v) for v in log_shares(g_m) - log_shares(g_r)),
        log_se=tuple(float(v) for v in se), n_copies=len(noise), delta=float(delta),
        shares=() if shares is None else tuple(float(v) for v in r),
        common=None if shares is None or common is None else tuple(float(v) for v in common),
        common_t=math.nan if shares is None or common is None else float(common_t),
        common_p=None if shares is None or common is None else common_p)


@dataclass(frozen=True)
class ModelError:
    """What the answer's kn owes to the linear model.

    Attributes
    ----------
    update : SealedUpdate or None
        The model's update to the sealed modes, when there was one.
    frequency_uncertainty : float [-]
        The relative uncertainty (95 %) of the identified mode's frequency taken into kn's
        interval (the option's, or the update's residual).
    kn_shift : float [-]
        kn's relative move for that frequency error.
    hinge_ratio : float or None [-]
        With two or more hinges: the smallest over the largest hinge rotation in the identified
        mode of the closed model (1: the hinges turn together, and one mode's backbone cannot
        tell their gaps apart; delta is then one half-gap for all, the hinges' mean when they
        differ).
    gaps : GapSplit or None
        With two or more hinges: how unequal their gaps could be without the points showing it.
    hinge_gaps : HingeGaps or None
        With two or more hinges, where they turn unequally (``hinge_ratio`` below
        :data:`HINGES_TOGETHER`) or with ``ModelOptions.hinge_gaps``: the fit with one half-gap
        per hinge and its test whether one common delta explains the points.
    per_hinge : bool
        ``ModelOptions.hinge_gaps``: each hinge's half-gap is reported.
    split : ReplayedSplit or None
        With the replay, where ``hinge_gaps`` was fitted: the split read against the answer's
        replay (:func:`replayed_split`), which the verdict's ``hinge_gaps`` then judges.
    """

    update: SealedUpdate | None
    frequency_uncertainty: float
    kn_shift: float
    hinge_ratio: float | None = None
    gaps: GapSplit | None = None
    hinge_gaps: HingeGaps | None = None
    per_hinge: bool = False
    split: ReplayedSplit | None = None

    def describe(self, kn_note: str = "") -> str:
        """What kn owes to the model, and what the data tell of each hinge; ``kn_note`` follows
        the kn clause (the verdict's word on kn's bound)."""
        if self.update is not None:
            head = "the model was updated: " + self.update.describe()
            if not self.update.residual_measured:
                head += (f" (its {self.update.parameters} parameters fit its "
                         f"{self.update.reference_hz.size} modes exactly, which measures no "
                         "model error: the option's frequency uncertainty stands)")
        else:
            head = "kn is conditional on the linear model (no sealed-fin modes to update it to)"
        return (head + f"; a {100 * self.frequency_uncertainty:.2g} % error of the identified "
                f"mode's frequency moves kn by {100 * self.kn_shift:.2g} %, included in kn's "
                "interval" + kn_note + self.hinges())

    def hinges(self) -> str:
        """What the data can tell of each hinge's gap ('' with one hinge)."""
        r = self.hinge_ratio
        if r is None:
            return ""
        split = "" if self.gaps is None else "; " + self.gaps.describe()
        hg = self.hinge_gaps
        if self.split is not None:  # read against the answer's replay
            split += "; " + self.split.describe()
        elif hg is not None:
            split += "; " + (hg.describe() if self.per_hinge else
                             f"{hg.outcome()} ({hg.test()})")
        if self.split is not None and self.split.shares:
            return (f"; the hinges turn {'together' if r >= HINGES_TOGETHER else 'unequally'} "
                    f"in the identified mode (rotation ratio {r:.2f}), and the test was "
                    "replayed with their gaps split as it showed: " + (
                        "delta is the hinges' mean half-gap" if self.split.mean_reported else
                        "delta is the one-gap answer, and that replay measured how far the "
                        "hinges' mean could lie") + split)
        if r >= HINGES_TOGETHER:
            return (f"; the hinges turn together in the identified mode (rotation ratio "
                    f"{r:.2f}): delta is one half-gap for all of them, their mean if they "
                    "differ" + split)
        return (f"; the hinges turn unequally in the identified mode (rotation ratio {r:.2f}): "
                "delta is one half-gap for all of them, weighted towards the hinge that turns "
                "most if they differ" + split)

    def to_dict(self) -> dict:
        return {"update": None if self.update is None else self.update.to_dict(),
                "frequency_uncertainty": self.frequency_uncertainty, "kn_shift": self.kn_shift,
                "hinge_ratio": self.hinge_ratio,
                "gaps": None if self.gaps is None else self.gaps.to_dict(),
                "hinge_gaps": None if self.hinge_gaps is None else self.hinge_gaps.to_dict(),
                "split": None if self.split is None else self.split.to_dict(),
                "per_hinge": self.per_hinge}


def update_model(dataset, system, est: PlainEstimate, fit: FitOptions,
                 options: ModelOptions) -> tuple[object, PlainEstimate, SealedUpdate | None]:
    """The model updated to the data set's sealed modes (two or more) and the plain estimate
    refitted against it; unchanged without them or with ``options.update`` False."""
    ref = getattr(dataset, "reference_modes", None)
    if not (options.update and ref):
        return system, est, None
    upd = update_to_sealed_modes(system, est.kn, ref["frequencies_hz"], ref["shapes"],
                                 ref["dofs"], mode=fit.mode)
    if upd is None:
        return system, est, None
    est = refit(est, upd.system, fit)
    check_determined(est.kn, est.delta, upd.system, fit.mode,
                     f"{dataset.path or dataset.name or 'data set'} (the model updated to its "
                     "sealed modes)", est.points)
    return upd.system, est, upd


def frequency_uncertainty(options: ModelOptions, update: SealedUpdate | None) -> float:
    """The identified mode's relative frequency uncertainty taken into kn's interval: the
    update's residual where its fit measures one (more sealed modes than its parameters; at
    least 0.1 %), else the option's, or the residual after one scale where that is larger."""
    u = options.frequency_uncertainty
    if update is None:
        return u
    return max(update.residual, 1e-3) if update.residual_measured else max(u, update.residual)


def model_error(system, est: PlainEstimate, fit: FitOptions, options: ModelOptions,
                update: SealedUpdate | None) -> ModelError:
    """kn's relative move for the model's frequency uncertainty (module docstring)."""
    u = frequency_uncertainty(options, update)
    ratio = hinge_ratio(system, est.kn, fit.mode)
    gaps = gap_split(system, est, fit.mode)
    per = None
    if options.hinge_gaps or (ratio is not None and ratio < HINGES_TOGETHER):
        per = fit_hinge_gaps(system, est.fitting_points(), est.kn, est.delta, mode=fit.mode,
                             common_residuals=est.fit.residuals)
    if u == 0:
        return ModelError(update, 0.0, 0.0, ratio, gaps, per, options.hinge_gaps)
    moved = system.replace(K=system.K * frequency_scale(system, est.kn, u, fit.mode))
    kn_moved = refit(est, moved, fit).kn
    return ModelError(update, float(u), abs(math.log(kn_moved / est.kn)), ratio, gaps, per,
                      options.hinge_gaps)


def fit_hinge_gaps(system, points, kn: float, delta: float, *, mode: int = 0,
                   common_residuals=None, grid=None) -> HingeGaps | None:
    """One half-gap per hinge from fitting points (module docstring), started from the common
    fit (``kn``, ``delta``) whose relative residuals at the points were ``common_residuals``
    (for the test whether one delta explains them); None with one hinge or where the backbone
    does not reach the points.

    Parameters
    ----------
    system : FreeplaySystem
    points : freeplayid.fit.FittingPoints
        The plain fit's points (their ``run`` groups the intervals' observations).
    kn, delta : float [N m/rad], [rad]
    grid : array_like, optional
        The backbone's amplitude grid (largest hinge amplitude over the hinges' mean half-gap);
        default 256 points from contact to four times the points' largest.
    """
    h = system.n_hinges
    if h < 2:
        return None
    ratios, _ = gap_ratios(points, system, kn, delta, mode)
    if not np.all(np.isfinite(ratios)):
        return None
    f = np.asarray(points.f_hz, float)
    # a hinge's gap may halve: its amplitude over it then doubles
    grid = (amplitude_grid(256, s_max=4.0 * float(ratios.max())) if grid is None else
            np.asarray(grid, float))

    def residual(x):
        deltas = np.exp(x[1:])
        mean = float(deltas.mean())
        curve = dfa_backbone(system, kn=float(np.exp(x[0])), delta=mean, mode=mode,
                             gaps=deltas / mean, s=grid)
        out = _at_points(curve, points)[0] / f - 1.0
        return np.where(np.isfinite(out), out, 1.0)  # a point off the curve's range

    x0 = np.log(np.r_[kn, np.full(h, delta)])
    span = np.r_[2.0, np.full(h, 3.0)]
    sol = scipy.optimize.least_squares(residual, x0, method="trf", diff_step=1e-4,
                                       bounds=(x0 - span, x0 + span))
    deltas = np.exp(sol.x[1:])
    w = deltas / deltas.sum()
    # ln r_j = ln delta_j - ln mean: its gradient in (ln kn, ln delta_1..h) is e_j - w
    G = np.zeros((h, h + 1))
    G[:, 1:] = np.eye(h) - w[None, :]
    half = jacobian_halfwidths(sol.fun, sol.jac, points.run, combinations=G)
    p = None
    if common_residuals is not None:
        p = _common_gap_p(np.asarray(common_residuals, float), sol.fun, h)
    common_rms = float("nan") if common_residuals is None else _rms(common_residuals)
    return HingeGaps(hinge_names(system),
                     tuple(float(v) for v in deltas), tuple(float(v) for v in half),
                     float(delta), _rms(sol.fun), common_rms, p)


def hinge_names(system) -> tuple:
    """Each hinge's name, "outboard/inboard" DOFs."""
    return tuple(f"{o}/{i}" for o, i in system.hinge_pairs)


def _rms(r) -> float:
    return float(np.sqrt(np.mean(np.square(r))))


def _common_gap_p(common, per_hinge, h: int) -> float | None:
    """The F test's p-value of the common fit (2 parameters) against the per-hinge one (h + 1)
    on the same points, each point one observation; None with no degree of freedom left.

    Not by run, as the intervals are: the common fit's misfit of unequal gaps is a disagreement
    of a run's channels (each reads the hinges' bends in its own proportion), which the run
    means average away (p = 1.0 by run on the two-hinge beam's data at 2 / 3 mrad). Point by
    point, the noise the channels of a run share makes the test liberal, hence its level
    :data:`COMMON_GAP_P` (0.1 %): on that beam (benchmarks/realtests, exact integrator, two noise
    draws) p = 4e-6 and 1e-4 at 2 / 3 mrad, 1.0 and 0.006 at equal gaps."""
    dof = common.size - (h + 1)
    if dof < 1:
        return None
    rss_c, rss_h = float(common @ common), float(per_hinge @ per_hinge)
    if rss_h <= 0:
        return 0.0 if rss_c > 0 else 1.0
    F = max(rss_c - rss_h, 0.0) / (h - 1) / (rss_h / dof)
    return float(scipy.stats.f.sf(F, h - 1, dof))


def gap_split(system, est: PlainEstimate, mode: int = 0) -> GapSplit | None:
    """How unequal the hinges' gaps could be without the fitted points showing it (module
    docstring); None with one hinge or where the backbone does not reach a point."""
    if system.n_hinges < 2:
        return None
    pts = est.fitting_points()
    kn, delta = float(est.kn), float(est.delta)
    ratios, _ = gap_ratios(pts, system, kn, delta, mode)
    if not np.all(np.isfinite(ratios)):
        return None
    # the curves over the points' range only (the largest hinge amplitude over delta), where a
    # split moves them by up to 0.8 x
    grid = np.geomspace(max(1.0005, 0.5 * ratios.min()), 2.0 * ratios.max(), 128)

    def logf(kn_, delta_, gaps=None):  # (members, points) for one or more (kn, delta)
        curve = dfa_backbone(system, kn=kn_, delta=delta_, mode=mode, gaps=gaps, s=grid)
        # where the hinges' fixed point did not converge (a two-hinge beam's curve below its
        # fold: one hinge in its gap, the lowest mode a mechanism near 0 Hz) no frequency is
        # read, nor between such a node and the next, which a point would interpolate across
        # the fold
        return np.log(_at_points(dataclasses.replace(curve, frequency_hz=np.where(
            curve.converged, curve.frequency_hz, np.nan)), pts))

    eps = 1e-3  # the answer and a step in each of (kn, delta), one batch
    base, *steps = logf([kn, kn * (1 + eps), kn], [delta, delta, delta * (1 + eps)])
    h = system.n_hinges
    moved_by = {}  # each split's curve at the points
    for a in GAP_SPLITS:
        for j in range(h):
            gaps = np.full(h, 1.0 - a / (h - 1))
            gaps[j] = 1.0 + a
            moved_by[a, j] = logf(kn, delta, gaps)[0]
    # the points every curve reads (on a two-hinge beam with equal gaps the lowest run's lay
    # at the fold, where a 5 % split moved them by 6-8 %: read across it, a split of 0.15 %
    # "unseen" and delta 4.6 % from the hinges' mean)
    read = np.all(np.isfinite([base, *steps, *moved_by.values()]), axis=0)
    if np.count_nonzero(read) < 3:
        return None
    base = base[read]
    J = np.stack([(f[read] - base) / eps for f in steps], axis=1)
    seen, bias = [], []
    for a in GAP_SPLITS:
        worst = moved = 0.0
        for j in range(h):
            v = moved_by[a, j][read] - base
            step = np.linalg.lstsq(J, v, rcond=None)[0]  # what the common fit absorbs
            worst = max(worst, float(np.max(np.abs(v - J @ step))))
            moved = max(moved, abs(float(np.expm1(step[1]))))
        seen.append(worst)
        bias.append(moved)
    scatter = float(est.fit.residual_rms)
    splits = np.array((0.0, *GAP_SPLITS))
    shown = np.array((0.0, *seen))
    beyond = bool(shown[-1] <= scatter)
    k = int(np.argmax(shown > scatter)) if not beyond else len(splits) - 1
    split = float(splits[-1]) if beyond else float(
        np.interp(scatter, shown[k - 1: k + 1], splits[k - 1: k + 1]))
    # the common delta's move at that split (interpolated as the split is; the largest move of
    # the splits up to each one, so that it never falls as the split grows)
    moves = np.maximum.accumulate(np.array((0.0, *bias)))
    return GapSplit(split, beyond, scatter, float(np.interp(split, splits, moves)))


def _at_points(curve, points) -> np.ndarray:
    """The backbone frequency [Hz] of every member of ``curve`` at each point's amplitude on its
    channel, shape (members, points); NaN off the curve's amplitude range."""
    amp = np.asarray(points.amplitude_m, float)
    ch = np.asarray(points.channel, dtype=str)
    out = np.empty((curve.frequency_hz.shape[0], amp.size))
    for c in dict.fromkeys(ch):
        idx = np.flatnonzero(ch == c)
        out[:, idx] = curve.frequency_at(amp[idx], c)
    return out


def frequency_scale(system, kn: float, u: float, mode: int = 0) -> float:
    """The factor on the structure's stiffness K (the hinges' kn kept) that moves the closed
    mode ``mode`` at ``kn`` by the relative frequency ``u`` to first order: 1 + ((1 + u)^2 - 1)
    / share, share = phi^T K phi / w^2 of that mode (mass-normalised phi)."""
    return 1.0 + ((1.0 + u) ** 2 - 1.0) / max(structure_share(system, kn, mode), 1e-3)


def hinge_ratio(system, kn: float, mode: int) -> float | None:
    """The smallest over the largest hinge rotation |b_j^T phi| in mode ``mode`` of the closed
    model at ``kn`` (None with one hinge)."""
    if system.n_hinges < 2:
        return None
    phi = modal_analysis(system.M, system.closed_stiffness(kn)).shapes[:, mode]
    theta = np.abs(system.hinge_matrix().T @ phi)
    return float(theta.min() / theta.max()) if theta.max() > 0 else None


def widen(ci: tuple, value: float, shift: float) -> tuple:
    """``ci`` of ``value`` with ``shift`` (a relative 95 % half-width) added in quadrature to its
    own log half-widths."""
    lo, hi = ci
    h_lo = math.hypot(math.log(value / lo), shift) if lo > 0 else math.inf
    h_hi = math.hypot(math.log(hi / value), shift)
    return (value * math.exp(-h_lo), value * math.exp(h_hi))

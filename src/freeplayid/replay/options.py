"""The replay's options as one record: :class:`Replay`."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..acquisition import ANTIALIAS
from ..arguments import check_bool, check_choice, check_int, check_number, is_number
from ..signal import JUMP_POINTS

__all__ = ["Replay", "DAMPING_FORMS", "EXCITATIONS", "STARTS"]

# the replay's damping by name (a number is a modal damping ratio)
DAMPING_FORMS = ("model", "estimate")
# what drives the replays: the base channel's record ("measured", when the data set has one) or
# the sweep law at one level per run ("law")
EXCITATIONS = ("measured", "law")
# where the replay loop starts: the fit of the measured statistic (the binding's target) or the
# network's estimate (the plain fit's given start)
STARTS = ("statistic", "network")
# the replays' decimating filter's flat band over the sample rate with antialias="flat" (None:
# the simulator's own, 0.3; freeplayid.simulate.resample.MAX_PASSBAND)
FLAT_PASSBAND = 0.45


@dataclass(frozen=True)
class Replay:
    """How the test is replayed to correct the fit's bias (:func:`corrected_fit`).

    Validated on construction; a bad value raises ``ValueError`` naming the field.

    Attributes
    ----------
    damping : None, "model", "estimate" or float
        None: the model file's C when it has one and its replay at the answer reproduces the
        test's amplitudes at the matched points (within ``DAMPING_MISMATCH``, 5 %), else one
        modal damping ratio estimated from those amplitudes (solved again from the answer; from
        the statistic's fit where no replay with the file's C could be fitted at all, its
        jumps run past the band); "model" / "estimate" force either; a float in (0, 1) fixes
        the modal damping ratio of every closed-hinge mode.
    n_bootstrap : int
        Noisy copies of the final replay for bootstrap intervals that see the bias (0: none;
        the intervals are then the Jacobian ones, moved with the estimate).
    seed : int
        Seed of those copies' noise.
    jump_point : str or None
        Jump-point rule of the points the replays match (:data:`freeplayid.signal.JUMP_POINTS`):
        "auto" (default): "quadrature" when the data set has a base channel (the phase
        resonance, on the backbone whatever the damping's form), else "drop" (the frequency
        where each curve drops, far less noisy than the maximum's on a flat top); a rule's
        name; or None for the extraction's own rule.
    weighted : bool
        Weight the matched points by their amplitude noise, measured against the first replay.
    rtol : float [-]
        Convergence: (kn, delta) move by less than this between replays.
    max_iter : int
        Most replays.
    engine : str or None
        Simulator engine of the replays (:data:`freeplayid.simulate.engines.ENGINES` or
        "auto"); None: the exponential engine when available, else "auto".
    cross_check : bool
        With a statistic other than "quadrature": at the answer, compare the replay with the test
        on a second statistic it was not fitted to (the drop's maxima, the maxima's drop); a
        model that is not the test's (damping of another form) puts the two apart, and the
        verdict says so (:class:`CrossCheck`).
    excitation : {"measured", "law"}
        What drives the replays of a data set with a base channel: "measured" (default) its
        first harmonic as recorded (:func:`measured_sweep`: the level profile, the controller's
        notching, the sweep law and its direction, as they happened); "law" each run's sweep
        law at one level. Without a base channel: always the law at ``level_g``.
    level_uncertainty : float [-]
        The relative uncertainty (95 %) of a level the replay takes from the manifest's
        ``level_g`` (a run replayed without its base channel's record): one more replay at those
        levels times (1 + this) measures how far such an error moves the answer, which is added
        to its intervals (:class:`LevelSensitivity`). 0: the levels are taken as exact.
    damping_uncertainty : float [-]
        The relative uncertainty (95 %) of a damping the replay takes without the test measuring
        it: the model file's C or a given ratio, where the runs with points all sweep down (a
        down-sweep jumps up where its lower branch ends and never reaches the peak, so its
        amplitudes hardly measure the damping, while where it jumps up depends on it). The
        binding solved again with that damping times (1 + this) measures how far such an error
        moves the answer, which is added to its intervals (:class:`DampingSensitivity`). 0: the
        damping is taken as exact. An up-sweep run with points needs none: its peak measures
        the damping (the model's C is replaced by an estimated ratio when its replay misses it
        by 5 %).
    damping_exponent : float or "estimate" [-]
        The form of an estimated or given damping ratio across the closed-hinge modes: mode i
        gets ``zeta (w_i / w_1)^p`` (w_1 the lowest closed mode's circular frequency, which
        ``zeta`` describes); 0 (default): one ratio in every mode. "estimate": p in [0, 2]
        estimated with the damping ratio, so that the replayed amplitudes at the points have
        no trend with the level (one more unknown of the replay loop, after it has solved
        with p = 0; :data:`freeplayid.replay.corrected.EXPONENT_BOUNDS`). Structures that damp their
        higher modes more (Rayleigh damping: p near 1) lose energy there at each contact, which
        one ratio can only put into mode 1 (docs/identify.md §3c, "Where the estimated ζ
        errs"); the per-run peak offsets' trend with the level shows it. Estimated or given
        other than 0, it takes the place of the default hinge damper's share (``damping_hinge``
        is then held at 0 unless a number is given). Not used with the model file's C.
    damping_hinge : float or "estimate" [-]
        The form of an estimated or given damping ratio: a viscous damper across each hinge
        carries the share q (in [0, 0.95]) of the lowest closed mode's ratio, every mode keeps
        ``(1 - q)`` of its own (:func:`freeplayid.replay.damping_estimate.damped_system`; the
        damper acts with the hinges open too, and damps the modes that turn the hinges, among
        them those a contact excites). "estimate" (default): q estimated with an estimated
        damping ratio where a base channel is replayed, so that the replayed peaks have no trend
        with the level (one more unknown of the replay loop, after it has solved with q = 0;
        bounds :data:`freeplayid.replay.corrected.HINGE_BOUNDS`; where it cannot be read, or
        ends on its upper bound or with its 95 % interval reaching it, q stays 0 and the report
        says why). A number: that share.
        ``damping_exponent="estimate"`` estimates p instead, with q held at 0 (or at the number
        given). On the real-tests records q takes the drift out of the Rayleigh-damped beams
        (every δ within 0.45 %, one ratio's up to 1.02 %) and leaves fins within 0.05 % of one
        ratio's mean error (docs/identify.md §3c). Not used with the model file's C.
    damping_forms : bool
        Where the damping is estimated and its form cannot be (no base channel to replay: the
        form is then one ratio in every mode), the binding solved again under two other forms
        that the data cannot tell from it, from the answer with its loop's Jacobian: a damping
        that rises with the mode (exponent p = 1, as Rayleigh damping does above its lower
        anchor), a damper across each hinge carrying half the lowest closed mode's ratio
        (q = 0.5), and such a damper acting only while the hinge is in contact (qc = 0.5 and
        0.25, the share then searched along the curves where they lie clearly nearer one of
        them than one ratio's, the other shares tried counted as forms between)
        (:class:`freeplayid.replay.FormSensitivity`). The form whose replay meets
        the measured curves nearest is reported where it does so more than 10 % nearer than
        one ratio's and than the other form's (``FORM_FIT_NOISE``; two forms about as near:
        neither is taken, both count); a form whose replay meets them within 10 % of the
        reported answer's, or whose loop did not converge (its closest replay is not the
        form's answer, so its curves do not rule the form out; unless it came within 0.25 of
        the statistics' standard error, as good as converged), counts: its move is added to
        the intervals, and the verdict's ``damping_form`` fails where it exceeds the accuracy
        bounds (the answer then rests on a form the test does not measure). A form between,
        p = 0.5 (``FORM_PROBES``), is solved too and counts the same way where its loop
        converged, but is never taken (the curves do not locate a form between one ratio and
        p = 1). Five more solves (a few replays each) on such tests only, up to eleven where
        damping in contact is indicated. False: one ratio, not measured.
    precision_copies : int
        Noisy copies of the answer's replay that measure how far the test's noise alone moves
        the answer (:func:`freeplayid.replay.precision_by_replay`; each run only around its
        statistic point, about half a second per copy on the bundled example): the verdict's
        ``noise_precision`` fails where that exceeds the accuracy bounds. At most this many:
        they stop after four where even the upper 95 % bound of their spread gives a chance
        below 1 % of leaving the bounds (a quiet test). 0: not measured.
    precision_record_copies : int
        Noisy copies of the test's own records (noise added to records that carry it already),
        read as the precision's copies are and pooled with them
        (:class:`freeplayid.replay.MeasuredRecords`): the tested structure's own sensitivity to
        the noise where its replay's differs (on a fin whose responses are weak against the
        noise, the replay's copies read it 7-21 % narrow). Not made where the replay's copies
        stopped early. 0 (default): none. Not the default, measured: on 34 realtests conditions
        they read the noise 0.83 times as wide as the replay's copies (geometric mean), moved
        verdicts both ways near the limit and turned one answer outside the bounds ``ok``
        (docs/identify.md §3b, "Copies of the test's own records").
    excitation_copies : int
        Replays at the answer driven by the measured excitation read again under fresh noise of
        the base record's level (:class:`freeplayid.replay.ExcitationNoise`): how far the base
        channel's noise, which the replays' excitation carries, moves the answer; added to the
        intervals and to the noise check's spread; a copy that cannot be fitted is drawn again
        (up to twice as many attempts). Only with a measured excitation read with noise; one
        replay each (about 2.2 s on the bundled example: two keep it under 15 s; the root mean
        square of two moves is known to about 50 %, of four to 35 %). 0: not measured.
    start : {"statistic", "network"}
        Where the replay loop starts: "statistic" (default) the fit of the measured points with
        the replays' rule; "network" the inverse model's estimate (``inverse.checkpoint``), or
        the plain fit's given start (``FitOptions.init``), when there is one (else the
        statistic's fit). The answer solves the same equations from either start; a start
        closer to it can save replays (docs/inverse.md §4).
    gap_shares : sequence of float or None [-]
        Unequal gaps in the replays: each hinge's half-gap over the hinges' mean, one per hinge
        in the model's hinge order (scaled to a mean of 1; the answer's delta is then the
        hinges' mean half-gap, hinge j's ``delta * gap_shares[j]``). None (default): one common
        gap. ``identify`` replays with the shares the test shows where one common gap does not
        explain it (the verdict's ``hinge_gaps``; docs/identify.md §3c, "Replayed with the
        split it shows").
    wide_base : sequence of str [-]
        Runs (their file names) whose base channel drives the replays as read over the wide
        band (the extraction's) even where its envelope is noisy enough for the narrow one
        (:func:`freeplayid.replay.excitation.measured_sweep`). Empty (default): each run's band
        as the noise chooses. ``identify`` names the runs where the narrowed reading misses the
        level around a run's point and the answer rests on it (the verdict's ``base_reading``;
        docs/identify.md §3c, "The reading checked where the runs jump").
    noisy_window : float [-]
        Where the replays match drop points (no base channel, ``jump_point`` "auto" or
        "drop"), the extraction reads them over one window (``Extraction.drop_window``) and the
        test's noise alone could put delta beyond its 1 % bound (the precision copies' 95 %
        half-width reaches it), ``identify`` replays the test again with the drop points read
        over this many windows (about half the noise, but read further down the upper branch,
        which damping of another form than the replay's moves more) and reports that answer
        where it agrees with the first within the noise their difference allows (3 standard
        deviations); the first stands otherwise, with the verdict's ``drop_window`` failed (the
        two windows disagree: something other than noise moves the upper branch);
        ``drop_window`` fails too where they agree but lie further apart than delta's or kn's
        accuracy bound (the intervals then hold both answers). 1: never
        (docs/identify.md §3c, "A noisy test without a base channel").
    antialias : {"unknown", "replay", "flat"}
        The anti-alias filter the test's records went through, where the points lie above 0.3
        of the sample rate (the simulator's default filter attenuates there: -0.8 % at 0.336,
        -6 dB at 0.4; below 0.3 nothing depends on it). "unknown" (default): as the data set
        states (:attr:`freeplayid.io.Dataset.antialias`; a stated response is divided out of
        the records and the replays decimated flat); where it states nothing and the test's
        points lie there, the replays are decimated flat to 0.45 of the sample rate (as an
        acquisition's filter, scipy's ``decimate`` and ``resample_poly``, or records sampled
        from an integrator's output are flat there), and the answer's move were the records'
        filter the simulator's default instead is measured
        (:class:`freeplayid.replay.AcquisitionFilter`), reached to by the intervals and checked
        by the verdict (``antialias``). "flat": the records' filter is flat to 0.45 of the
        sample rate: the replays are decimated so (``FLAT_PASSBAND``; 4 x the filter's taps)
        wherever the points lie, nothing measured. "replay": the records were decimated as the
        simulator's are (:func:`freeplayid.simulate.design_decimator`, or a filter of the same
        response; benchmarks/realtests/exact_sim.py's), nothing measured. Either overrides the
        data set's statement.
    """

    damping: float | str | None = None
    n_bootstrap: int = 0
    seed: int = 0
    jump_point: str | None = "auto"
    weighted: bool = True
    rtol: float = 5e-4
    max_iter: int = 8
    engine: str | None = None
    excitation: str = "measured"
    cross_check: bool = True
    level_uncertainty: float = 0.05
    damping_uncertainty: float = 0.25
    damping_exponent: float | str = 0.0
    damping_hinge: float | str = "estimate"
    damping_forms: bool = True
    precision_copies: int = 8
    precision_record_copies: int = 0
    excitation_copies: int = 2
    start: str = "statistic"
    gap_shares: tuple | None = None
    wide_base: tuple = ()
    noisy_window: float = 4.0
    antialias: str = "unknown"

    def __post_init__(self):
        d = self.damping
        ok = d is None or (isinstance(d, str) and d in DAMPING_FORMS) or \
            (is_number(d) and 0 < d < 1)
        if not ok:
            raise ValueError(f"`damping` must be None, 'model', 'estimate' or a ratio in (0, 1), "
                             f"got {d!r}")
        check_int("n_bootstrap", self.n_bootstrap, 0)
        check_int("seed", self.seed, 0)
        check_int("precision_copies", self.precision_copies, 0)
        check_int("precision_record_copies", self.precision_record_copies, 0)
        check_int("excitation_copies", self.excitation_copies, 0)
        if self.jump_point is not None and self.jump_point not in ("auto", *JUMP_POINTS):
            raise ValueError(f"`jump_point` must be one of {['auto', *sorted(JUMP_POINTS)]} or "
                             f"None, got {self.jump_point!r}")
        check_bool("weighted", self.weighted)
        check_bool("cross_check", self.cross_check)
        check_bool("damping_forms", self.damping_forms)
        check_number("rtol", self.rtol, 0.0, 1.0, open_lo=True, open_hi=True)
        check_int("max_iter", self.max_iter, 1)
        check_choice("excitation", self.excitation, EXCITATIONS)
        check_number("level_uncertainty", self.level_uncertainty, 0.0, 0.5)
        check_number("damping_uncertainty", self.damping_uncertainty, 0.0, 1.0)
        check_number("noisy_window", self.noisy_window, 1.0, 16.0)
        check_choice("antialias", self.antialias, ANTIALIAS)
        p = self.damping_exponent
        if p != "estimate" and not (is_number(p) and -1.0 <= p <= 2.0):
            raise ValueError(f"`damping_exponent` must be a number in [-1, 2] or 'estimate', "
                             f"got {p!r}")
        q = self.damping_hinge
        if q != "estimate" and not (is_number(q) and 0.0 <= q <= 0.95):
            raise ValueError(f"`damping_hinge` must be a number in [0, 0.95] or 'estimate', "
                             f"got {q!r}")
        check_choice("start", self.start, STARTS)
        g = self.gap_shares
        if g is not None:
            ok = not isinstance(g, str)
            try:
                vals = [float(v) for v in g] if ok else []
            except (TypeError, ValueError):
                ok = False
            ok = ok and len(vals) >= 2 and all(math.isfinite(v) and v > 0 for v in vals)
            if not ok:
                raise ValueError(f"`gap_shares` must be None or one number > 0 per hinge (two "
                                 f"or more), got {g!r}")
            mean = sum(vals) / len(vals)
            object.__setattr__(self, "gap_shares", tuple(v / mean for v in vals))
        w = self.wide_base
        if w is None:
            w = ()
        if isinstance(w, str) or not isinstance(w, (list, tuple)) or \
                not all(isinstance(r, str) and r for r in w):
            raise ValueError(f"`wide_base` must be a list of run file names, got {w!r}")
        object.__setattr__(self, "wide_base", tuple(w))
        if self.engine is not None:
            # the engines' registry imports torch: only when an engine is named
            from ..simulate.engines import ENGINES

            if self.engine not in ("auto", *ENGINES):
                raise ValueError(f"`engine` must be None or one of {['auto', *ENGINES]}, "
                                 f"got {self.engine!r}")

    @property
    def passband(self) -> float | None:
        """The replays' decimating filter's flat band over the sample rate (None: the
        simulator's default)."""
        return FLAT_PASSBAND if self.antialias == "flat" else None

    def statistic(self, extraction_rule: str, has_base: bool) -> str:
        """The jump-point rule the replays match for a data set with (or without) a base
        channel whose plain points were taken with ``extraction_rule``."""
        if self.jump_point is None:
            return extraction_rule
        if self.jump_point == "auto":
            return "quadrature" if has_base else "drop"
        return self.jump_point

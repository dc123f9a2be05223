"""The plain estimate of a data set: its fitting points extracted and the backbone fitted to them.

This is what :func:`freeplayid.identify` runs on the measured test and what the replay
(:mod:`freeplayid.replay`) runs on every simulated copy of it, so both go through the same
steps: each usable run's sweep law (its hint, else estimated from the record), the resonance
(jump) point of every channel (:func:`freeplayid.signal.extract_backbone_points`, the base
channel subtracted), at least two resonances, the fit's start (an inverse model's estimate,
given starts or the multi-start grid) and the backbone least squares
(:func:`freeplayid.fit.fit_backbone`). No verdict and no replay here: those judge and correct
this estimate one layer up.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .errors import IdentificationError, InverseDomainWarning
from .fit import (
    FitOptions,
    FitResult,
    FittingPoints,
    Start,
    count_resonances,
    fit_backbone,
    resolve_start,
)
from .model import modal_analysis
from .progress import progress_bar
from .signal import (
    REASON_EDGE,
    REASON_NO_JUMP,
    REASON_START,
    BackbonePoints,
    Extraction,
    estimate_sweep,
    extract_backbone_points,
)
from .sweep import Sweep, rate_at
from .threads import each

__all__ = ["PlainEstimate", "plain_estimate", "refit", "extract_points", "run_sweep_law",
           "run_sweeps", "point_rates", "weights_of"]


@dataclass(frozen=True)
class PlainEstimate:
    """The extract-and-fit of one data set.

    Attributes
    ----------
    points : freeplayid.signal.BackbonePoints
        Every run's and channel's candidate point, used or not, with its amplitude curve.
    rejected_runs : tuple of (str, str)
        (run, reason) of every run without a usable point.
    fit : freeplayid.fit.FitResult
        The backbone fit of the used points.
    dofs : dict of str -> str
        Channel (data-set column) -> model DOF name.
    inverse_estimate : dict or None
        The inverse model's estimate that started the fit (kn, delta, log_kn_std,
        log_delta_std, checkpoint), when one did.
    """

    points: BackbonePoints
    rejected_runs: tuple
    fit: FitResult
    dofs: dict
    inverse_estimate: dict | None = None

    @property
    def kn(self) -> float:
        return self.fit.kn

    @property
    def delta(self) -> float:
        return self.fit.delta

    def fitting_points(self) -> FittingPoints:
        """The used points with their model DOF names (the points of :attr:`fit`)."""
        return FittingPoints.from_extraction(self.points, dofs=self.dofs)


def run_sweep_law(dataset, run, *, use_hint: bool = True):
    """One run's sweep law: its ``sweep`` hint (``use_hint``), else estimated from the base
    channel when the data set has one, else from the response channels (the best-tracked one:
    a channel dominated by another mode's ringing, e.g. the tip acceleration of a beam, can
    track that mode instead of the sweep; the run has one excitation).

    Returns
    -------
    (Sweep, source, residual [Hz] or None)
        source is "hint", "base channel" or "response"; the residual is the estimate's
        (:class:`freeplayid.signal.SweepEstimate`).

    Raises
    ------
    ValueError
        No sweep law can be found in the run (and no hint used).
    """
    if use_hint and run.sweep is not None:
        return Sweep(**run.sweep), "hint", None
    source, x = ("base channel", run.base) if run.base is not None else ("response", run.data)
    try:
        est = estimate_sweep(dataset.to_si(x), dataset.sample_rate, quantity=dataset.quantity)
    except ValueError as exc:
        raise ValueError(f"run {run.file}: no sweep hint and no sweep law in its {source} "
                         f"({exc}); give the run's `sweep` hint") from None
    return est.sweep, source, est.residual_hz


def extract_points(dataset, *, extraction: Extraction, progress: bool = False,
                   desc: str = "extracting points") -> tuple[BackbonePoints, dict]:
    """Points of every usable run and the rejected runs {run: reason}; with ``progress``, a bar
    ``desc`` over the runs. The runs are extracted at once on threads
    (:func:`freeplayid.threads.each`: the pursuit's compiled loop releases the GIL); each run's
    points are those of one thread.

    A run without a hint (or with ``extraction.use_sweep_hint`` False) gets one law for all its
    channels,
    from its base channel, else from its best-tracked response channel (each channel's own
    estimate can lock onto another mode); none found: the extraction tries each channel and
    rejects the ones without a sweep, with the reason.
    """
    bar = progress_bar(total=len(dataset.runs), desc=desc, unit="run",
                       show=progress and len(dataset.runs) > 1)

    def one_run(run):
        try:
            return None if run.reason else _run_extraction(dataset, run, extraction)
        finally:
            bar.update()

    with bar:
        results = each(one_run, dataset.runs, name="extract")
    points, curves, rejected = [], [], {}
    for run, res in zip(dataset.runs, results, strict=True):
        if res is None:
            rejected[run.file] = run.reason
            continue
        points += res.points
        curves += res.curves
        if res.rejected_runs:
            rejected[run.file] = run_reason(res.points)
    pts = BackbonePoints(tuple(points), tuple(rejected), tuple(curves), dataset.quantity,
                         extraction.method)
    return pts, rejected


def _run_extraction(dataset, run, extraction: Extraction) -> BackbonePoints:
    """The points of one run (a ``Dataset`` run) of ``dataset``."""
    if run.sweep and extraction.use_sweep_hint:
        sweep = Sweep(**run.sweep)
    else:
        try:
            sweep = run_sweep_law(dataset, run, use_hint=False)[0]
        except ValueError:
            sweep = None
    base = None if run.base is None else [dataset.to_si(run.base)]
    return extract_backbone_points(
        [dataset.to_si(run.data)], dataset.sample_rate, quantity=dataset.quantity,
        channel_names=list(dataset.channels), run_names=[run.file], sweep=sweep, base=base,
        base_name=dataset.base_channel or "base", extraction=extraction,
    )


def run_reason(points) -> str:
    """Why a run none of whose channels gave a point was rejected: its channels' reasons, each
    once. A run is one motion: where a channel saw it on its upper branch at the band's start
    (:data:`..signal.jump.REASON_START`), the run did not stay in the gap, however another
    channel read it (on the realtests fins with a damper at each hinge, a channel far from the
    hinges showed no drop where the other did)."""
    reasons = list(dict.fromkeys(p.reason for p in points))
    if any(REASON_START in r for r in reasons):
        reasons = [r for r in reasons if REASON_NO_JUMP not in r]
    return "; ".join(reasons)


def check_enough(points: BackbonePoints, rejected: dict, where, gravity_g: float = 0.0) -> None:
    """IdentificationError unless the used points span two resonances or more (``gravity_g``:
    the data set's stated weight along the axis, which the advice then names)."""
    used = points.used()
    if len(used) < 2:
        why = "; ".join(f"{r}: {w}" for r, w in rejected.items()) or "none rejected"
        raise IdentificationError(
            f"{where}: {len(used)} usable fitting point(s), at least 2 are needed "
            f"(rejected runs: {why}); {_advice(rejected, gravity_g)}", points=points)
    if count_resonances([p.f_hz for p in used]) < 2:
        raise IdentificationError(
            f"{where}: the {len(used)} usable points lie at one resonance (within 0.5 %: "
            f"{used[0].f_hz:.3f} Hz, run {used[0].run}): kn and delta need resonances at two "
            "or more levels; add runs at other levels that resonate in the band",
            points=points,
        )


# below this share of the identified closed mode's stiffness the hinges are rigid in it:
# doubling kn moves the mode by under 0.035 % (d ln f / d ln kn is half the share), so kn is no
# longer read from the points and a fit that reaches it has run off. The stiffest hinge of the
# project's data sets holds a tenth (the kn 8000 N m/rad beam).
HINGE_SHARE_MIN = 1e-3
# and beyond this kn over the structure's stiffness the eigensolution cannot resolve the share
KN_OVER_K_MAX = 1e12


def structure_share(system, kn: float, mode: int = 0) -> float:
    """The structure's share of the closed mode ``mode``'s stiffness at ``kn``: phi^T K phi /
    w^2 (mass-normalised phi; the hinges carry the rest). NaN where the eigensolution gives no
    positive frequency (kn so large that it cannot resolve the mode)."""
    try:
        modes = modal_analysis(system.M, system.closed_stiffness(kn))
        w2 = float(modes.omega[mode]) ** 2
        phi = modes.shapes[:, mode]
    except (np.linalg.LinAlgError, ValueError, IndexError):
        return math.nan
    return float(phi @ (system.K @ phi)) / w2 if w2 > 0 else math.nan


def check_determined(kn: float, delta: float, system, mode: int, where, points=None) -> None:
    """IdentificationError unless (``kn``, ``delta``) is a fit that the points determine: both
    finite and positive, and the hinges still carrying a share of the closed mode ``mode``'s
    stiffness at ``kn`` (:data:`HINGE_SHARE_MIN`). A fit that ran off to a rigid hinge (kn
    towards infinity, where the backbone no longer depends on it) would give a model nothing
    downstream can use (a fin's closed mode 1 reads 0 Hz at kn 2e17)."""
    share = math.nan
    if math.isfinite(kn) and kn > 0 and math.isfinite(delta) and delta > 0:
        k_scale = float(np.linalg.norm(system.K))
        b2 = float(np.max(np.sum(system.hinge_matrix() ** 2, axis=0)))
        unresolved = k_scale > 0 and kn * b2 > KN_OVER_K_MAX * k_scale
        share = 0.0 if unresolved else 1.0 - structure_share(system, kn, mode)
    if not share >= HINGE_SHARE_MIN:
        raise IdentificationError(
            f"{where}: the fit ran off to kn = {kn:.3g} N·m/rad, delta = {delta:.3g} rad, where "
            f"the hinges are rigid in mode {mode + 1} (their share of its stiffness "
            f"{share:.2g}, below {HINGE_SHARE_MIN:g}): the points do not determine kn; add "
            "runs at other levels that resonate in the band", points=points)


def _advice(rejected: dict, gravity_g: float = 0.0) -> str:
    """What to do when too few runs give points, from why they were rejected (a run already on
    its upper branch at the band's start needs the sweep started lower, not a higher level) and
    the stated weight along the axis, ``gravity_g``, under which a run that never leaves the
    stop it rests on reads as one that stayed in the gap."""
    reasons = list(rejected.values())
    if reasons and all("too short" in r for r in reasons):
        return ("record whole sweeps: the runs are too short to extract (a `simulate.py "
                "debug=fast` data set is a smoke test of the simulator, not identifiable)")
    started = sum(REASON_START in r for r in reasons)
    if reasons and all(REASON_NO_JUMP in r or REASON_EDGE in r or REASON_START in r
                       for r in reasons):
        if started:  # higher levels would start higher on their upper branch still
            return (f"start the sweeps lower: {started} run"
                    + ("s were already on their upper branches" if started > 1 else
                       " was already on its upper branch") + " at the band's start"
                    + ("" if started == len(reasons) else
                       ", and add runs at levels that resonate in the band"))
        if gravity_g:
            return (f"add runs at higher levels that resonate in the band: under the stated "
                    f"weight (gravity_g {gravity_g:g}) the panel rests on one stop, and a run "
                    "too weak to lift it off never crosses the gap")
        return "add runs at higher levels that resonate in the band"
    return "see each rejected run's reason; add runs at higher levels that resonate in the band"


def weights_of(points: FittingPoints, point_weights: Mapping | None):
    """Each point's weight from a mapping (run, DOF name) -> weight (the median weight for a
    point without an entry), or None without a mapping."""
    if point_weights is None:
        return None
    default = float(np.median(list(point_weights.values())))
    runs = points.run if points.run is not None else (None,) * len(points)
    return np.array([float(point_weights.get((r, c), default))
                     for r, c in zip(runs, points.channel, strict=True)])


def plain_estimate(dataset, system, *, extraction: Extraction, fit: FitOptions, init=None,
                   point_weights: Mapping | None = None, progress: bool = False,
                   desc: str = "extracting points") -> PlainEstimate:
    """The plain estimate of ``dataset`` (module docstring).

    Parameters
    ----------
    dataset : Dataset
    system : FreeplaySystem
    extraction, fit : Extraction, FitOptions
        How the points are taken and fitted.
    init : InverseModel, (kn, delta), sequence of them, or None
        The fit's start: a trained inverse model (its estimate from the points), given
        start(s), or None for ``fit.multistart``'s grid.
    point_weights : mapping of (run, DOF name) -> float, optional
        Weights of the fit's points (the replay's weighted statistic; None: all equal).
    progress : bool
        Progress bars: over the runs (named ``desc``) and over the fit's starts.

    Raises
    ------
    IdentificationError
        Fewer than two usable points, or all of them at one resonance.
    InverseModelError
        The inverse model cannot take these points.
    """
    where = dataset.path or dataset.name or "data set"
    pts, rejected = extract_points(dataset, extraction=extraction, progress=progress, desc=desc)
    check_enough(pts, rejected, where, getattr(dataset, "gravity_g", 0.0) or 0.0)
    points = FittingPoints.from_extraction(pts, dofs=dataset.channels)
    # a network's start: its input may take each point's rate, its domain the runs' sweeps
    sweeps = run_sweeps(dataset, pts, extraction) if hasattr(init, "sweep_outside") else None
    start = resolve_start(init, points, multistart=fit.multistart,
                          rate=None if sweeps is None else point_rates(points, sweeps))
    if sweeps is not None:
        start = _sweep_domain(start, init, sweeps)
    result = fit_backbone(points, system, init=start.points, init_label=start.label,
                          backbone=fit.backbone, mode=fit.mode, n_bootstrap=fit.n_bootstrap,
                          seed=fit.seed, weights=weights_of(points, point_weights),
                          progress=progress)
    check_determined(result.kn, result.delta, system, fit.mode, where, pts)
    return PlainEstimate(points=pts, rejected_runs=tuple(rejected.items()), fit=result,
                         dofs=dict(dataset.channels), inverse_estimate=start.inverse)


def run_sweeps(dataset, pts, extraction: Extraction) -> list:
    """(run, Sweep, median frequency of its points [Hz]) of each run with used points of the
    extraction ``pts`` (:func:`run_sweep_law`: its hint, else its estimated law; a run
    without one is left out)."""
    at = {}
    for p in pts.used():
        at.setdefault(p.run, []).append(p.f_hz)
    out = []
    for run in dataset.runs:
        if run.file in at:
            try:
                sweep = run_sweep_law(dataset, run, use_hint=extraction.use_sweep_hint)[0]
            except ValueError:  # no law: the extraction found its points without one
                continue
            out.append((run.file, sweep, float(np.median(at[run.file]))))
    return out


def point_rates(points: FittingPoints, sweeps) -> np.ndarray | None:
    """Each point's sweep rate [Hz/s] at its frequency, from ``sweeps`` (:func:`run_sweeps`);
    None when a point's run has no law (or the points no runs)."""
    law = {run: sweep for run, sweep, _ in sweeps}
    if points.run is None or any(r not in law for r in points.run):
        return None
    return np.array([float(rate_at(law[r], f)) for r, f in zip(points.run, points.f_hz,
                                                               strict=True)])


def _sweep_domain(start: Start, model, sweeps) -> Start:
    """``start`` with the runs whose sweep at their point lies outside the network's training
    (:meth:`freeplayid.inverse.InverseModel.sweep_outside`; ``sweeps`` of :func:`run_sweeps`)
    added to its estimate's ``outside`` and warned of (:class:`InverseDomainWarning`), as
    points outside its domain are, before the estimate starts the fit."""
    why = model.sweep_outside(sweeps)
    if not why:
        return start
    warnings.warn(why + "; the fit starts from its estimate all the same", InverseDomainWarning,
                  stacklevel=3)
    inverse = dict(start.inverse)
    inverse["outside"] = "; ".join(w for w in (inverse.get("outside"), why) if w)
    return dataclasses.replace(start, inverse=inverse)


def refit(est: PlainEstimate, system, fit: FitOptions, *,
          point_weights: Mapping | None = None, runs=None) -> PlainEstimate:
    """``est`` fitted again to its own points (the extraction does not depend on the model)
    against ``system``, started from its estimate, with ``point_weights``; with ``runs`` (a
    collection of run names) to the used points of those runs only, the others marked unused
    in the returned estimate's points."""
    if runs is not None:
        keep = frozenset(runs)
        points = tuple(p if p.run in keep or not p.used else
                       dataclasses.replace(p, used=False, reason="run left out")
                       for p in est.points.points)
        est = dataclasses.replace(est, points=dataclasses.replace(est.points, points=points))
    pts = est.fitting_points()
    result = fit_backbone(pts, system, init=(est.kn, est.delta), init_label=est.fit.init,
                          backbone=fit.backbone, mode=fit.mode,
                          weights=weights_of(pts, point_weights))
    return dataclasses.replace(est, fit=result)

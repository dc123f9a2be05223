"""The measured-data pipeline: :func:`identify` a data set -> :class:`Identification`."""

from __future__ import annotations

import os
import time
from collections.abc import Mapping

import numpy as np

from .result import Identification, IdentificationError

__all__ = ["identify"]


def _zero_clearance_check(dataset, system, kn: float):
    """:func:`freeplayid.model.validate_modes` of the closed model against the data set's
    ``reference_modes`` (None without them)."""
    ref = getattr(dataset, "reference_modes", None)
    if not ref:
        return None
    from ..model import validate_modes

    return validate_modes(system, kn, ref["frequencies_hz"], ref["shapes"], ref["dofs"])


def _extract(ds, *, extraction: Mapping, use_sweep_hint: bool, progress: bool):
    """Points of every usable run (one run at a time) and the rejected runs {run: reason}."""
    from tqdm import tqdm

    from ..replay.runs import run_sweep_law
    from ..signal import BackbonePoints, extract_backbone_points
    from ..sweep import Sweep

    points, curves, rejected = [], [], {}
    bar = tqdm(ds.runs, desc="extracting points", unit="run",
               disable=not progress or len(ds.runs) < 2)
    for run in bar:
        if run.reason:
            rejected[run.file] = run.reason
            continue
        if run.sweep and use_sweep_hint:
            sweep = Sweep(**run.sweep)
        else:
            # output-only: one law per run, from its base channel or its best-tracked response
            # channel (each channel's own estimate can lock onto another mode); none found: the
            # extraction tries each channel and rejects the ones without a sweep, with the reason
            try:
                sweep = run_sweep_law(ds, run, use_hint=False)[0]
            except ValueError:
                sweep = None
        base = None if run.base is None else [ds.to_si(run.base)]
        res = extract_backbone_points(
            [ds.to_si(run.data)], ds.sample_rate, quantity=ds.quantity,
            channel_names=list(ds.channels), run_names=[run.file], sweep=sweep, base=base,
            base_name=ds.base_channel or "base", **extraction,
        )
        points += res.points
        curves += res.curves
        if res.rejected_runs:
            rejected[run.file] = "; ".join(dict.fromkeys(p.reason for p in res.points))
    pts = BackbonePoints(tuple(points), tuple(rejected), tuple(curves), ds.quantity,
                         extraction.get("method", "acmp"))
    return pts, rejected


def _check_enough(pts, rejected: dict, where) -> None:
    """IdentificationError unless the used points span two resonances or more."""
    from ..fit import count_resonances

    used = pts.used()
    if len(used) < 2:
        why = "; ".join(f"{r}: {w}" for r, w in rejected.items()) or "none rejected"
        raise IdentificationError(
            f"{where}: {len(used)} usable fitting point(s), at least 2 are needed "
            f"(rejected runs: {why}); add runs at higher levels that resonate in the band",
            points=pts,
        )
    if count_resonances([p.f_hz for p in used]) < 2:
        raise IdentificationError(
            f"{where}: the {len(used)} usable points lie at one resonance (within 0.5 %: "
            f"{used[0].f_hz:.3f} Hz, run {used[0].run}): kn and delta need resonances at two "
            "or more levels; add runs at other levels that resonate in the band",
            points=pts,
        )


def _inverse_start(model, points) -> dict:
    """The inverse model's estimate of (kn, delta) from the fitting points (the fit's start)."""
    try:
        kn, delta, s_kn, s_delta = model.predict_points(points)
    except ValueError as exc:  # e.g. a channel the network was not trained on
        from ..inverse import InverseModelError

        raise InverseModelError(f"{model.path}: {exc}") from None
    return {"kn": float(kn), "delta": float(delta), "log_kn_std": float(s_kn),
            "log_delta_std": float(s_delta), "checkpoint": str(model.path)}


def identify(
    dataset,
    *,
    system=None,
    backbone: str = "dfa",
    init=None,
    extraction: Mapping | None = None,
    use_sweep_hint: bool = True,
    multistart: Mapping | None = None,
    mode: int = 0,
    n_bootstrap: int = 0,
    seed: int = 0,
    progress: bool = True,
    replay: bool = True,
    damping=None,
    replay_bootstrap: int = 0,
    replay_jump_point: str | None = "drop",
    replay_weighted: bool = True,
    point_weights: Mapping | None = None,
) -> Identification:
    """Identify (kn, delta) from a measured (or simulated) sine-sweep data set.

    Parameters
    ----------
    dataset : freeplayid.io.Dataset or path
        A data set (:func:`freeplayid.io.read_dataset`, or built in memory) or the path of its
        folder or ``manifest.yaml``.
    system : FreeplaySystem, optional
        The linear model; default the data set's ``model`` file.
    backbone : str
        Backbone method of the fit (``freeplayid.backbone`` registry: "dfa", "hb").
    init : InverseModel, (kn, delta), sequence of them, or None
        The fit's start: a trained inverse model (:func:`freeplayid.inverse.load_inverse_model`;
        its estimate from the points), given start(s), or None for the multi-start grid.
    extraction : mapping, optional
        Options of :func:`freeplayid.signal.extract_backbone_points` (``method``,
        ``bandwidth_hz``, ``trim_s``, the jump rule, ``min_snr_db``).
    use_sweep_hint : bool
        Use the runs' ``sweep`` hints (ACMP's start, the band, the rate). A run without one
        (or with ``False``) gets its law estimated once from its base channel, else from its
        best-tracked response channel, for all its channels.
    multistart : mapping, optional
        ``n``, ``kn_range`` [N m/rad], ``delta_range`` [rad] of the multi-start grid (default:
        those of :func:`freeplayid.fit.multistart_grid`).
    mode : int
        Backbone mode (0: the lowest, first bending).
    n_bootstrap : int
        Bootstrap resamples over the points for percentile intervals (0: none).
    seed : int
        Bootstrap seed.
    progress : bool
        Show a progress bar over the runs.
    replay : bool
        Correct the fit's bias by replaying the test with the simulator at the estimate
        (:func:`freeplayid.replay.corrected_fit`, indirect inference): the result's kn and delta
        are then the corrected ones, the intervals shifted with them, and ``replay`` holds the
        iterations, the levels used and each point's offset. On by default (the plain fit is
        biased by 2-7 % in delta on swept, damped tests); False: the plain backbone fit.
    damping : None, "model", "estimate" or float
        Damping of the replay: None takes the model's C when it has one and estimates one modal
        damping ratio from the peak amplitudes otherwise; a float in (0, 1) fixes that ratio.
    replay_bootstrap : int
        With ``replay``: noisy copies of the final replay for bootstrap intervals that see the
        bias (0: none; the intervals are then the Jacobian ones, moved with the estimate).
    replay_jump_point : str or None
        With ``replay``: the jump-point rule of the points the replays match
        (:func:`freeplayid.replay.corrected_fit`): "drop" (default; the frequency where the
        curve drops, far less noisy than the maximum's on a flat top), or None for
        ``extraction``'s own rule.
    replay_weighted : bool
        With ``replay``: the statistic's fit weights each point by its amplitude noise
        (:func:`freeplayid.replay.point_weights`; default); False: every point weighs the same.
    point_weights : mapping of (run, DOF name) -> float, optional
        Weights of the fit's points (weighted least squares); a point without an entry gets the
        median weight. The replay sets them; the plain fit leaves them None (all equal).

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
        Fewer than two usable points, or all of them at one resonance.
    InverseModelError
        The inverse model cannot take these points (e.g. a channel it was not trained on).
    """
    from ..backbone import backbone_method
    from ..fit import FittingPoints, fit_backbone, multistart_grid
    from ..io import DatasetError, read_dataset
    from ..model import FreeplaySystem, load_system
    from ..verdict import base_level_checks, fit_checks, make_verdict, validation_checks

    t0 = time.perf_counter()
    backbone_method(backbone, argument="backbone")  # an unknown name fails before any work
    if replay and replay_jump_point is not None:
        from ..signal.peak import JUMP_POINTS

        if replay_jump_point not in JUMP_POINTS:
            raise ValueError(f"`replay_jump_point` must be one of {sorted(JUMP_POINTS)} or "
                             f"None, got {replay_jump_point!r}")
    if isinstance(dataset, (str, os.PathLike)):
        dataset = read_dataset(dataset)
    if system is None:
        if dataset.model is None:
            raise DatasetError(f"{dataset.path}: missing field `model` (the linear model file, "
                               ".npz); or pass `system`")
        system = load_system(dataset.model)
    elif not isinstance(system, FreeplaySystem):
        raise TypeError(f"`system` must be a FreeplaySystem, got {type(system).__name__}")
    where = dataset.path or dataset.name or "data set"
    pts, rejected = _extract(dataset, extraction=dict(extraction or {}),
                             use_sweep_hint=use_sweep_hint, progress=progress)
    _check_enough(pts, rejected, where)
    points = FittingPoints.from_extraction(pts, dofs=dataset.channels)
    inverse = None
    if hasattr(init, "predict_points"):
        inverse = _inverse_start(init, points)
        starts, label = (inverse["kn"], inverse["delta"]), "inverse"
    elif init is None and multistart:
        starts, label = multistart_grid(**{k: v if k == "n" else tuple(v)
                                           for k, v in multistart.items()}), "multistart"
    else:
        starts, label = init, None
    fit = fit_backbone(points, system, init=starts, init_label=label, backbone=backbone,
                       mode=int(mode), n_bootstrap=int(n_bootstrap), seed=int(seed),
                       weights=weights_of(points, point_weights))
    validation = _zero_clearance_check(dataset, system, fit.kn)
    verdict = make_verdict(base_level_checks(dataset)
                           + fit_checks(points, fit, system, pts, mode=int(mode))
                           + validation_checks(validation))
    result = Identification(
        kn=fit.kn,
        delta=fit.delta,
        kn_ci95=tuple(fit.kn_ci95),
        delta_ci95=tuple(fit.delta_ci95),
        residual_rms=fit.residual_rms,
        backbone=fit.backbone,
        init=fit.init,
        runtime_s=time.perf_counter() - t0,
        points=pts,
        dofs=dict(dataset.channels),
        rejected_runs=tuple(rejected.items()),
        fit=fit,
        system=system,
        mode=int(mode),
        kn_ci95_bootstrap=fit.kn_ci95_bootstrap,
        delta_ci95_bootstrap=fit.delta_ci95_bootstrap,
        inverse_estimate=inverse,
        truth=dict(dataset.truth) if dataset.truth else None,
        dataset={
            "name": dataset.name, "path": str(dataset.path) if dataset.path else None,
            "model": str(dataset.model) if dataset.model else None,
            "quantity": dataset.quantity, "units": dataset.units,
            "sample_rate": float(dataset.sample_rate), "n_runs": len(dataset.runs),
            "channels": dict(dataset.channels), "base_channel": dataset.base_channel,
        },
        verdict=verdict,
        validation=validation,
    )
    if replay:
        result = _with_replay(result, dataset, system, backbone=backbone, extraction=extraction,
                              use_sweep_hint=use_sweep_hint, mode=int(mode), t0=t0,
                              damping=damping, n_bootstrap=int(replay_bootstrap), seed=int(seed),
                              jump_point=replay_jump_point, weighted=replay_weighted,
                              progress=progress)
    return result


def weights_of(points, point_weights: Mapping | None):
    """Each point's weight from a mapping (run, DOF name) -> weight (the median weight for a
    point without an entry), or None without a mapping."""
    if point_weights is None:
        return None
    default = float(np.median(list(point_weights.values())))
    runs = points.run if points.run is not None else (None,) * len(points)
    return np.array([float(point_weights.get((r, c), default))
                     for r, c in zip(runs, points.channel, strict=True)])


def _with_replay(result, dataset, system, *, t0, damping, n_bootstrap, seed, jump_point,
                 weighted, progress, **fit_kwargs):
    """``result`` with the bias-corrected (kn, delta) of :func:`freeplayid.replay.corrected_fit`.

    Intervals: the Jacobian ones of the statistic's fit (the points the replays match, each
    run's points one observation: :func:`freeplayid.fit.uncertainty.jacobian_intervals`) moved
    with the estimate (same relative width); with the bootstrap by replay, the smallest
    interval holding both (``interval_source`` says which).
    A replay that failed keeps the plain estimate and makes the verdict ``suspect``.
    """
    import dataclasses

    from ..replay import corrected_fit
    from ..verdict import interval_check, make_verdict, replay_checks

    rep = corrected_fit(dataset, system, result, fit_kwargs=fit_kwargs, damping=damping,
                        n_bootstrap=n_bootstrap, seed=seed, jump_point=jump_point,
                        weighted=weighted, progress=progress)
    checks = result.verdict.checks + tuple(replay_checks(rep))
    if rep.failure:
        return dataclasses.replace(result, verdict=make_verdict(checks), replay=rep,
                                   runtime_s=time.perf_counter() - t0)
    (kn_ci, delta_ci) = rep.statistic_ci95
    sk, sd = rep.kn / rep.kn_statistic, rep.delta / rep.delta_statistic
    kn_ci = tuple(v * sk for v in kn_ci)
    delta_ci = tuple(v * sd for v in delta_ci)
    source = "Jacobian (moved with the estimate)"
    if rep.kn_ci95_replay is not None:
        kn_ci = (min(kn_ci[0], rep.kn_ci95_replay[0]), max(kn_ci[1], rep.kn_ci95_replay[1]))
        delta_ci = (min(delta_ci[0], rep.delta_ci95_replay[0]),
                    max(delta_ci[1], rep.delta_ci95_replay[1]))
        source = (f"bootstrap by replay ({rep.n_bootstrap} copies) joined with the Jacobian "
                  "interval")
    # the interval check on the reported intervals, not the plain fit's
    verdict = make_verdict([c for c in checks if c.name != "interval_width"]
                           + [interval_check(rep.kn, rep.delta, kn_ci, delta_ci)])
    return dataclasses.replace(
        result, kn=rep.kn, delta=rep.delta, verdict=verdict, kn_ci95=kn_ci, delta_ci95=delta_ci,
        runtime_s=time.perf_counter() - t0, replay=rep, interval_source=source,
    )

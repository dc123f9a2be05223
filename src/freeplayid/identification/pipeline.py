"""The measured-data pipeline: :func:`identify` a data set -> :class:`Identification`."""

from __future__ import annotations

import os
import time
from collections.abc import Mapping

from ..estimate import plain_estimate
from .result import Identification

__all__ = ["identify"]


def _zero_clearance_check(dataset, system, kn: float):
    """:func:`freeplayid.model.validate_modes` of the closed model against the data set's
    ``reference_modes`` (None without them)."""
    ref = getattr(dataset, "reference_modes", None)
    if not ref:
        return None
    from ..model import validate_modes

    return validate_modes(system, kn, ref["frequencies_hz"], ref["shapes"], ref["dofs"])


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
    est = plain_estimate(dataset, system, backbone=backbone, init=init, extraction=extraction,
                         use_sweep_hint=use_sweep_hint, multistart=multistart, mode=mode,
                         n_bootstrap=n_bootstrap, seed=seed, point_weights=point_weights,
                         progress=progress)
    pts, fit, rejected, inverse = est.points, est.fit, dict(est.rejected_runs), \
        est.inverse_estimate
    points = est.fitting_points()
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
        result = _with_replay(result, est, dataset, system, backbone=backbone,
                              extraction=extraction,
                              use_sweep_hint=use_sweep_hint, mode=int(mode), t0=t0,
                              damping=damping, n_bootstrap=int(replay_bootstrap), seed=int(seed),
                              jump_point=replay_jump_point, weighted=replay_weighted,
                              progress=progress)
    return result


def _with_replay(result, plain, dataset, system, *, t0, damping, n_bootstrap, seed, jump_point,
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

    rep = corrected_fit(dataset, system, plain, fit_kwargs=fit_kwargs, damping=damping,
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

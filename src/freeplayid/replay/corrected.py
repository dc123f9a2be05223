"""The bias-corrected fit: the binding function solved by Broyden's method (package docstring)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..errors import IdentificationError
from ..estimate import plain_estimate, weights_of
from ..fit import fit_backbone
from .damping import ZETA_RTOL, ReplayDamping, _damping_mode, damped_system, initial_zeta
from .misfit import curve_misfit
from .noise import _bootstrap_by_replay, _median_se, _misfit_in_se, noise_levels, point_weights
from .runs import _with_sweep_hints, replay_dataset, replay_levels, replay_sweeps

__all__ = ["ReplayResult", "corrected_fit"]


@dataclass(frozen=True)
class ReplayResult:
    """The bias-corrected estimate and its iterations.

    Attributes
    ----------
    kn, delta : float [N m/rad], [rad]
        Corrected estimate.
    kn_fit, delta_fit : float
        The plain fit of the measured points (theta_hat).
    iterations : list of dict
        Per iteration: the replayed parameters (kn, delta), the fit of their replay
        (kn_rep, delta_rep) and that fit's objective evaluations (n_evaluations).
    converged : bool
    levels : dict of str -> (float, str)
        Each replayed run's level [g] and where it came from ("base channel" or "level_g").
    sweeps : dict of str -> dict
        Each replayed run's sweep law (``Sweep.to_dict()`` keys and ``law``) and where it came
        from (``source``: "hint", "base channel" or "response"; an estimated law also has its
        fit ``residual_hz``).
    offsets : list of dict
        Per measured point (run, channel): the replayed point's frequency and amplitude
        relative to the measured one at the final estimate (f_rep/f - 1, X_rep/X - 1).
    curves : tuple of AmplitudeCurve
        The last replay's first-harmonic displacement curves (the self-check figure).
    misfit : dict of str -> float
        Per run: :func:`curve_misfit` of its measured and replayed curves (largest channel).
    damping : ReplayDamping
        The damping of the replays (the model's C, given, or estimated with its interval).
    failure : str
        Why a replay could not be fitted (e.g. the replayed fin never left the gap), or "".
    kn_ci95_replay, delta_ci95_replay : (float, float) or None
        Percentile intervals of the bootstrap by replay (``n_bootstrap`` copies), or None.
    noise : dict of str -> list of float or None
        Per run: each channel's measured noise level used by the bootstrap [data units].
    jump_point : str
        The jump-point rule of the statistic the replays match (module docstring).
    kn_statistic, delta_statistic : float
        The fit of the measured points taken with ``jump_point`` (the binding's target; the
        plain fit itself when it used that rule).
    statistic_ci95 : ((float, float), (float, float)) or None
        That fit's Jacobian 95 % intervals of kn and delta.
    weights : list of dict or None
        Per measured point of the statistic (run, channel): ``noise_ratio`` (the record's noise
        level over the point's amplitude), ``residual_scale`` (the frequency residual that makes
        through the backbone's slope) and ``weight`` in the statistic's fit
        (:func:`point_weights`); None when every point weighs the same.
    closest_misfit_se : float or None
        Without convergence: how far the answer's replay (the one closest to the test) missed
        the test's statistics, in standard errors of the statistics (largest over kn, delta and
        an estimated damping's amplitude ratio); None when converged or when nothing measures
        the noise (two runs). Each iteration has its own ``misfit_se``.
    """

    kn: float
    delta: float
    kn_fit: float
    delta_fit: float
    iterations: list
    converged: bool
    levels: dict
    offsets: list
    curves: tuple = ()
    misfit: dict | None = None
    damping: ReplayDamping | None = None
    failure: str = ""
    kn_ci95_replay: tuple | None = None
    delta_ci95_replay: tuple | None = None
    n_bootstrap: int = 0
    noise: dict | None = None
    sweeps: dict | None = None
    jump_point: str = ""
    kn_statistic: float = float("nan")
    delta_statistic: float = float("nan")
    statistic_ci95: tuple | None = None
    weights: list | None = None
    closest_misfit_se: float | None = None


def corrected_fit(dataset, system, identification, *, fit_kwargs: dict, damping=None,
                  n_bootstrap: int = 0, seed: int = 0, rtol: float = 5e-4, max_iter: int = 8,
                  jump_point: str | None = "drop", weighted: bool = True,
                  progress: bool = False) -> ReplayResult:
    """Bias-corrected (kn, delta) by replaying the test (module docstring).

    Parameters
    ----------
    dataset : Dataset
        The measured data set.
    system : FreeplaySystem
    identification : Identification
        The plain identification of ``dataset`` (theta_hat, its points).
    fit_kwargs : dict
        The options of that identification (backbone, extraction, use_sweep_hint, mode), so the
        replays go through the same extraction and fit.
    damping : None, "model", "estimate" or float
        The replay's damping: None uses the model's C when it has one and estimates a modal
        ratio otherwise; a float in (0, 1) is the modal damping ratio of every closed-hinge mode.
    n_bootstrap : int
        Copies of the final replay with measured-level noise for the bootstrap intervals (0: none).
    seed : int
        Seed of the bootstrap's noise.
    rtol : float
        Convergence: (kn, delta) move by less than this between replays.
    max_iter : int
        Most replays.
    jump_point : str or None
        Jump-point rule of the statistic (:data:`freeplayid.signal.JUMP_POINTS`): the measured
        data are extracted again with it when the plain identification used another rule, and
        every replay is extracted with it. "drop" (default): the frequency where the curve
        drops, the amplitude just ahead of it (module docstring). None: the plain
        identification's own rule.
    weighted : bool
        Weight the statistic's points by their amplitude noise (:func:`point_weights`, from the
        measured noise against the first replay; the same weights in every later fit).

    A replay that cannot be fitted (the replayed fin stays in the gap, no jump: a model far
    from the test) ends the loop with ``failure`` set; the verdict then says ``suspect``.
    """

    source, zeta = _damping_mode(system, damping)
    plain = identification
    extraction = dict(fit_kwargs.get("extraction") or {})
    own_rule = extraction.get("jump_point", "smoothed")
    jump_point = own_rule if jump_point is None else jump_point

    def plain_only(why: str) -> ReplayResult:  # nothing to correct with: the plain fit stays
        return ReplayResult(kn=float(plain.kn), delta=float(plain.delta), kn_fit=float(plain.kn),
                            delta_fit=float(plain.delta), iterations=[], converged=False,
                            levels={}, offsets=[], damping=None, jump_point=jump_point,
                            failure=why)

    # replay only the runs whose points were fitted: a run rejected in the test (e.g. it stayed
    # in the gap) must not enter the replayed fit as a point the measured fit did not have
    used = {p.run for p in plain.points.used()}
    try:
        laws = replay_sweeps(dataset)
        sweeps = {k: v for k, v in laws.items() if k in used}
        levels = replay_levels(dataset, sweeps)
    except ValueError as err:  # no level or no sweep law for a run: the test cannot be replayed
        return plain_only(f"the test cannot be replayed: {err}")
    stat_ds = dataset  # what the statistic is extracted from, and the replays' template
    if jump_point != own_rule:
        # the statistic: the measured data extracted with the statistic's jump point and with
        # the sweep law the replays are simulated with as every run's hint (its frequency is
        # read off that law, and a law estimated again from each replayed record would move by
        # up to 0.1 Hz between replays); the replays carry the same hints
        stat_ds = _with_sweep_hints(dataset, sweeps)
        fit_kwargs = {**fit_kwargs, "use_sweep_hint": True,
                      "extraction": {**extraction, "jump_point": jump_point}}
        try:
            identification = plain_estimate(stat_ds, system, init=(plain.kn, plain.delta),
                                            **fit_kwargs)
        except IdentificationError as err:
            return plain_only(f"the measured points taken with jump_point {jump_point!r} "
                              f"cannot be fitted: {err}")
    stat = {"jump_point": jump_point, "kn_statistic": float(identification.kn),
            "delta_statistic": float(identification.delta),
            "statistic_ci95": _by_run_intervals(identification)}
    measured = identification.points.used()
    if {p.run for p in measured} != used:  # the statistic fitted other runs: replay those
        used = {p.run for p in measured}
        sweeps = {k: v for k, v in laws.items() if k in used}
        try:
            levels = replay_levels(dataset, sweeps)
        except ValueError as err:
            return plain_only(f"the test cannot be replayed: {err}")
    hat = np.array([identification.kn, identification.delta])
    kn_damping = float(plain.kn)  # closed-hinge stiffness of an estimated/given modal damping
    estimate = source == "estimated"
    if estimate:
        zeta = initial_zeta(system, measured, levels, kn_damping, identification.dofs,
                            int(fit_kwargs.get("mode", 0)))
    # unknowns u = log(kn, delta[, zeta]); residual F(u) = statistics of the replay minus those
    # of the test: log(kn_rep / kn_hat), log(delta_rep / delta_hat)[, median log(X_rep / X)]
    u = np.log(np.append(hat, zeta) if estimate else hat.copy())
    J = np.diag([1.0, 1.0, -1.0][: u.size])  # identity binding; amplitude ~ 1 / zeta
    history, converged, rep, rep_ds, failure = [], False, None, None, ""
    weight_table = None
    ratios = np.array([])
    prev = None  # (u, F) of the last replay, for Broyden's update
    best = None  # (u, max |F|, index) of the replay closest to the test (the fallback answer)
    for _ in range(max_iter):
        theta = np.exp(u[:2])
        zeta_k = float(np.exp(u[2])) if estimate else zeta
        sys_k = system if source == "model" else damped_system(system, zeta_k, kn_damping)
        rep_ds = replay_dataset(stat_ds, sys_k, *theta, levels=levels, sweeps=sweeps)
        try:
            rep_k = plain_estimate(rep_ds, system, init=tuple(theta), **fit_kwargs)
        except IdentificationError as err:
            failure = (f"the replay at kn = {theta[0]:.5g} N·m/rad, delta = {theta[1]:.5g} rad "
                       f"could not be identified ({err}): the model does not behave like the "
                       "test")
            break
        if weighted and weight_table is None:
            # the first replay is the clean reference of the measured noise: weight the points
            # by it, refit the test's statistic and this replay with the weights, and keep them
            # for every later fit (the binding needs one fixed statistic)
            fitted = identification.fitting_points()
            weights, weight_table = point_weights(
                fitted, noise_levels(stat_ds, rep_ds), stat_ds, system, *hat,
                mode=int(fit_kwargs.get("mode", 0)))
            if weights:
                identification = _refit(identification, system, weights, fit_kwargs)
                rep_k = _refit(rep_k, system, weights, fit_kwargs)
                fit_kwargs = {**fit_kwargs, "point_weights": weights}
                hat = np.array([identification.kn, identification.delta])
                stat.update(kn_statistic=float(identification.kn),
                            delta_statistic=float(identification.delta),
                            statistic_ci95=_by_run_intervals(identification))
            else:
                weight_table = []
        rep = rep_k
        theta_rep = np.array([rep.kn, rep.delta])
        F = np.log(theta_rep / hat)
        item = {"kn": float(theta[0]), "delta": float(theta[1]),
                "kn_rep": float(theta_rep[0]), "delta_rep": float(theta_rep[1]),
                "n_evaluations": int(rep.fit.n_evaluations)}
        if estimate:
            ratios = _amplitude_ratios(measured, rep.points.used())
            r = float(np.median(ratios)) if ratios.size else 0.0
            F = np.append(F, r)
            item.update(zeta=zeta_k, amplitude_log_ratio=r)
        elif source == "given":
            item.update(zeta=float(zeta))
        item["misfit_se"] = _misfit_in_se(F, stat["statistic_ci95"], measured,
                                          ratios if estimate else None)
        history.append(item)
        if best is None or np.abs(F).max() < best[1]:
            best = (u.copy(), float(np.abs(F).max()), len(history) - 1)
        if prev is not None:
            # Broyden's rank-one update of the binding function's Jacobian (kept while it stays
            # well conditioned): near the gap the binding can even fall as delta rises (a larger
            # gap at the same levels moves the lowest points towards it), which the identity
            # start does not know
            du, dF = u - prev[0], F - prev[1]
            if float(du @ du) > 1e-12:
                J_new = J + np.outer(dF - J @ du, du) / float(du @ du)
                if np.all(np.isfinite(J_new)) and np.linalg.cond(J_new) < 1e4:
                    J = J_new
        step = -np.linalg.solve(J, F)
        step = np.clip(step, -np.log(1.5), np.log(1.5))  # at most a factor 1.5 per replay
        prev = (u.copy(), F.copy())
        if progress:
            print(f"replay {len(history)}: kn {theta[0]:.5g}, delta {theta[1]:.5g}"
                  + (f", zeta {zeta_k:.4g}" if estimate else "")
                  + f"; misfit of the statistics {np.abs(F).max():.2e}")
        u = u + step
        done = bool(np.all(np.abs(step[:2]) < np.log1p(rtol)))
        if estimate:
            done = done and abs(step[2]) < np.log1p(ZETA_RTOL)
        if done:
            converged = True
            break
    closest_se = None
    if not converged and best is not None:
        u = best[0]  # no convergence: the replayed parameters whose fit came closest to the test
        closest_se = history[best[2]]["misfit_se"]
    theta = np.exp(u[:2])
    if estimate:
        zeta = float(np.exp(u[2]))
    zeta_ci = None
    if estimate and ratios.size >= 2:
        # spread of the per-point log ratios -> standard error of their median, through the
        # amplitude's sensitivity to log zeta (the Jacobian's last diagonal entry)
        se = _median_se(ratios)
        half = 1.96 * se / max(abs(float(J[2, 2])), 0.1)
        zeta_ci = (float(zeta * np.exp(-half)), float(zeta * np.exp(half)))
    damping_used = ReplayDamping(source=source, zeta=None if zeta is None else float(zeta),
                                 zeta_ci95=zeta_ci)
    offsets = []
    if rep is not None:
        replayed = {(p.run, p.channel): p for p in rep.points.used()}
        for p in measured:
            q = replayed.get((p.run, p.channel))
            if q is not None:
                offsets.append({"run": p.run, "channel": p.channel,
                                "f_offset": q.f_hz / p.f_hz - 1,
                                "amplitude_offset": q.amplitude_m / p.amplitude_m - 1})
    misfit: dict[str, float] = {}
    if rep is not None:
        replayed_curves = {(c.run, c.channel): c for c in rep.points.curves}
        for c in plain.points.curves:
            r = replayed_curves.get((c.run, c.channel))
            if r is not None and c.run in levels:
                misfit[c.run] = max(misfit.get(c.run, 0.0), curve_misfit(c, r))
    ci_kn = ci_delta = noise = None
    if n_bootstrap > 0 and rep is not None and not failure:
        noise = noise_levels(dataset, rep_ds)
        ci_kn, ci_delta = _bootstrap_by_replay(
            rep_ds, system, noise, theta=theta, theta_rep=np.array([rep.kn, rep.delta]),
            n=int(n_bootstrap), seed=int(seed), fit_kwargs=fit_kwargs, progress=progress)
    if failure:
        theta = np.array([plain.kn, plain.delta])  # nothing to correct with: the plain fit stays
    return ReplayResult(kn=float(theta[0]), delta=float(theta[1]), kn_fit=float(plain.kn),
                        delta_fit=float(plain.delta), iterations=history, converged=converged,
                        **stat, weights=weight_table or None, closest_misfit_se=closest_se,
                        levels=levels, offsets=offsets,
                        curves=tuple(rep.points.curves) if rep is not None else (),
                        misfit=misfit, damping=damping_used, failure=failure,
                        kn_ci95_replay=ci_kn, delta_ci95_replay=ci_delta,
                        n_bootstrap=int(n_bootstrap) if ci_kn is not None else 0,
                        noise=None if noise is None else
                        {k: [float(x) for x in v] for k, v in noise.items()},
                        sweeps={run: {"source": src, "law": sw.law, **sw.to_dict(),
                                      **({} if res is None else {"residual_hz": float(res)})}
                                for run, (sw, src, res) in sweeps.items()})


def _refit(est, system, weights: dict, fit_kwargs: dict):
    """``est`` (a PlainEstimate) fitted again to its own points with ``weights``."""
    pts = est.fitting_points()
    fit = fit_backbone(pts, system, init=(est.kn, est.delta), init_label=est.fit.init,
                       backbone=fit_kwargs.get("backbone", "dfa"),
                       mode=int(fit_kwargs.get("mode", 0)), weights=weights_of(pts, weights))
    return dataclasses.replace(est, fit=fit)


def _amplitude_ratios(measured_points, replayed_points) -> np.ndarray:
    """log(X_replayed / X_measured) of the points found in both, matched by (run, channel)."""
    rep = {(p.run, p.channel): p for p in replayed_points}
    out = [np.log(rep[(p.run, p.channel)].amplitude_m / p.amplitude_m)
           for p in measured_points if (p.run, p.channel) in rep]
    return np.asarray(out, float)


def _by_run_intervals(estimate) -> tuple:
    """The statistic fit's Jacobian intervals with each run's points as one observation (the
    channels of a run share its jump); the per-point ones when the fit has no runs."""
    fit = estimate.fit
    if fit.kn_ci95_by_run is None:
        return tuple(fit.kn_ci95), tuple(fit.delta_ci95)
    return tuple(fit.kn_ci95_by_run), tuple(fit.delta_ci95_by_run)

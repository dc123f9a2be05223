"""The statistic the replays match, and how far a replay misses it in its own standard errors."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.stats

from ..fit import jacobian_intervals

__all__ = ["AmplitudeTrend", "amplitude_ratios", "amplitude_trend", "by_run_intervals",
           "median_se", "misfit_in_se", "replayed_intervals"]


def by_run_intervals(estimate) -> tuple:
    """The statistic fit's Jacobian intervals with each run's points as one observation (the
    channels of a run share its jump); the per-point ones when the fit has no runs.
    ``estimate`` is a :class:`freeplayid.estimate.PlainEstimate`."""
    fit = estimate.fit
    if fit.kn_ci95_by_run is None:
        return tuple(fit.kn_ci95), tuple(fit.delta_ci95)
    return tuple(fit.kn_ci95_by_run), tuple(fit.delta_ci95_by_run)


def replayed_intervals(estimate, replayed) -> tuple | None:
    """The statistic fit's by-run Jacobian intervals (:func:`by_run_intervals`) with the
    residuals its replay at the answer does not reproduce: at each point (matched by run and
    channel) the measured point's weighted residual less the replayed point's, both at their
    own fits (at convergence the same (kn, delta)). The statistic's points lie off the backbone
    by what the replay reproduces (a down-sweep's jump-up where the lower branch ends, a drop
    ahead of the peak) and what it does not (the noise, a model that is not the test's); only
    the latter moves the corrected answer, while a run-to-run scatter of the former made the
    intervals of the runs' own residuals up to 30 times wider than the noise moves the answer
    (down-sweeps, three runs). ``estimate`` and ``replayed`` are
    :class:`freeplayid.estimate.PlainEstimate`; None where the statistic's fit lacks its Jacobian
    or weights,
    the points have no runs or repeat a (run, channel), or fewer than three runs are matched
    (two runs fit exactly and measure nothing)."""
    fs, fr = estimate.fit, replayed.fit
    if fs.jacobian is None or fs.weights is None:
        return None
    ps, pr = estimate.fitting_points(), replayed.fitting_points()
    if ps.run is None or pr.run is None or len(ps) != fs.residuals.size or \
            len(pr) != fr.residuals.size:
        return None
    keys = list(zip(ps.run, ps.channel, strict=True))
    rep = dict(zip(zip(pr.run, pr.channel, strict=True), fr.residuals, strict=True))
    if len(set(keys)) != len(keys) or len(rep) != len(pr):
        return None
    keep = [i for i, k in enumerate(keys) if k in rep]
    if len({keys[i][0] for i in keep}) < 3:
        return None
    w = fs.weights[keep]
    d = w * (fs.residuals[keep] - np.array([rep[keys[i]] for i in keep]))
    cis = jacobian_intervals(np.log([fs.kn, fs.delta]), d, fs.jacobian[keep],
                             [keys[i][0] for i in keep])
    return cis if all(lo > 0 and np.isfinite(hi) for lo, hi in cis) else None


def amplitude_ratios(measured_points, replayed_points) -> np.ndarray:
    """log(X_replayed / X_measured) of the points found in both, matched by (run, channel)."""
    rep = {(p.run, p.channel): p for p in replayed_points}
    out = [np.log(rep[(p.run, p.channel)].amplitude_m / p.amplitude_m)
           for p in measured_points if (p.run, p.channel) in rep]
    return np.asarray(out, float)


class AmplitudeTrend(NamedTuple):
    """How the replay's amplitudes at the points drift from the test's with the level: the slope
    of each run's median log(X_replayed / X_measured) against the log of its level, its
    standard error and the number of runs (levels) it rests on."""

    slope: float
    se: float
    runs: int


def amplitude_trend(measured_points, replayed_points, levels: dict) -> AmplitudeTrend | None:
    """:class:`AmplitudeTrend` of the points found in both (matched by run and channel), each
    run at its level (``levels``: run -> (level [g], source)); None with fewer than three
    distinct levels. The slope is that of the runs' medians; its standard error the larger of
    the straight line's through those medians (four runs or more) and through the points with
    each channel about its own mean (a channel's constant ratio is not scatter; a run's error
    shared by its channels the points alone would understate)."""
    rep = {(p.run, p.channel): p for p in replayed_points}
    by_run: dict[str, dict] = {}
    for p in measured_points:
        q = rep.get((p.run, p.channel))
        if q is not None and p.run in levels and p.amplitude_m > 0 and q.amplitude_m > 0 \
                and float(levels[p.run][0]) > 0:
            by_run.setdefault(p.run, {})[p.channel] = float(np.log(q.amplitude_m /
                                                                    p.amplitude_m))
    runs = list(by_run)
    if len({round(float(levels[r][0]), 9) for r in runs}) < 3:
        return None
    x = {r: float(np.log(float(levels[r][0]))) for r in runs}
    xr = np.array([x[r] for r in runs])
    yr = np.array([float(np.median(list(by_run[r].values()))) for r in runs])
    dx, dy = xr - xr.mean(), yr - yr.mean()
    slope = float(dx @ dy) / float(dx @ dx)
    se = _pooled_slope_se(dx, dy, 1) if len(runs) >= 4 else float("nan")
    xs, ys, groups = [], [], 0
    for ch in {c for v in by_run.values() for c in v}:
        rs = [r for r in runs if ch in by_run[r]]
        if len(rs) < 2:
            continue
        xc = np.array([x[r] for r in rs])
        yc = np.array([by_run[r][ch] for r in rs])
        xs.append(xc - xc.mean())
        ys.append(yc - yc.mean())
        groups += 1
    if xs:
        se_points = _pooled_slope_se(np.concatenate(xs), np.concatenate(ys), groups)
        se = se_points if not np.isfinite(se) else max(se, se_points)
    return AmplitudeTrend(float(slope), float(se), len(runs))


def _pooled_slope_se(dx: np.ndarray, dy: np.ndarray, groups: int) -> float:
    """Standard error of the least-squares slope through deviations ``dx``, ``dy`` from their
    ``groups`` groups' own means (each mean costs a degree of freedom; NaN without one)."""
    sxx = float(dx @ dx)
    dof = dx.size - 1 - groups
    if dof <= 0 or not sxx > 0:
        return float("nan")
    e = dy - float(dx @ dy) / sxx * dx
    return float(np.sqrt(float(e @ e) / dof / sxx))


def median_se(values: np.ndarray) -> float:
    """Standard error of the median of ``values`` (n >= 2): 1.2533 s / sqrt(n)."""
    return 1.2533 * float(np.std(values, ddof=1)) / np.sqrt(values.size)


# [-] an unconverged replay loop whose closest replay misses the test's statistics by at most
# this many of their standard errors (:func:`misfit_in_se`) is as good as converged: the answer
# then lies that far from the solution, which lowers a 95 % interval's coverage to 94.3 % at
# most (the verdict's ``binding_noise``; a damping form's loop alike, ``FormAlternative``)
BINDING_NOISE_SE = 0.25


def misfit_in_se(F, statistic_ci95, measured, ratios) -> float | None:
    """The largest |F_i| over its statistic's standard error: log(kn_rep / kn_hat) and
    log(delta_rep / delta_hat) over the standard errors of the statistic's log kn and log delta
    (its by-run 95 % intervals over 2 t_0.975(runs - 2)), and with an estimated damping the
    median log amplitude ratio over its own (1.2533 s / sqrt(n) of the per-point ratios).
    None when nothing measures the noise (two runs or fewer, an infinite interval)."""
    runs = len({p.run for p in measured})
    if statistic_ci95 is None or runs <= 2:
        return None
    t = float(scipy.stats.t.ppf(0.975, runs - 2))
    se = [np.log(hi / lo) / (2 * t) if lo > 0 else np.inf for lo, hi in statistic_ci95]
    if ratios is not None:
        se.append(median_se(ratios) if ratios.size >= 2 else np.inf)
    se = np.asarray(se, dtype=float)
    if not np.all(np.isfinite(se) & (se > 0)):
        return None
    return float(np.max(np.abs(np.asarray(F, dtype=float)[: se.size]) / se))

"""The statistic the replays match, and how far a replay misses it in its own standard errors."""

from __future__ import annotations

import numpy as np
import scipy.stats

__all__ = ["amplitude_ratios", "by_run_intervals", "median_se", "misfit_in_se"]


def by_run_intervals(estimate) -> tuple:
    """The statistic fit's Jacobian intervals with each run's points as one observation (the
    channels of a run share its jump); the per-point ones when the fit has no runs.
    ``estimate`` is a :class:`freeplayid.estimate.PlainEstimate`."""
    fit = estimate.fit
    if fit.kn_ci95_by_run is None:
        return tuple(fit.kn_ci95), tuple(fit.delta_ci95)
    return tuple(fit.kn_ci95_by_run), tuple(fit.delta_ci95_by_run)


def amplitude_ratios(measured_points, replayed_points) -> np.ndarray:
    """log(X_replayed / X_measured) of the points found in both, matched by (run, channel)."""
    rep = {(p.run, p.channel): p for p in replayed_points}
    out = [np.log(rep[(p.run, p.channel)].amplitude_m / p.amplitude_m)
           for p in measured_points if (p.run, p.channel) in rep]
    return np.asarray(out, float)


def median_se(values: np.ndarray) -> float:
    """Standard error of the median of ``values`` (n >= 2): 1.2533 s / sqrt(n)."""
    return 1.2533 * float(np.std(values, ddof=1)) / np.sqrt(values.size)


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

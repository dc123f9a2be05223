"""95 % intervals of the fitted (kn, delta): Gauss-Newton (Jacobian) and bootstrap over points.

Jacobian: the fit works in x = (ln kn, ln delta); at the optimum the Gauss-Newton covariance is

    cov(x) = s^2 (J^T J)^-1,   s^2 = RSS / (p - 2)

(p points, two parameters; p - 2 floored at 1), and the interval of x_k is
x_k +- t_0.975(p - 2) sqrt(cov_kk), mapped back by exp (so it is asymmetric in kn and delta).

By run (``groups``): the points of one sweep run (its channels) share one jump, so their
residuals move together with the run's noise and the formula above, counting them as independent,
is too narrow (with two channels whose residuals are equal, by sqrt((p - 2) / (g - 2)) and
through the t quantile's degrees of freedom). Averaging the residuals and the Jacobian rows of
each run's points and applying the formula to those g run means (g - 2 degrees of freedom,
floored at 1) is right both when the channels' errors are shared and when they are independent
(then s^2 / m and J^T J / m cancel; only the degrees of freedom are fewer).

Bootstrap: the points are resampled with replacement, the fit is re-solved from the optimum for
each resample, and the 2.5 / 97.5 percentiles of the estimates form the interval.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.optimize
import scipy.stats

from ..progress import progress_bar

__all__ = ["jacobian_intervals", "jacobian_halfwidths", "bootstrap_intervals"]

Interval = tuple[float, float]


def jacobian_halfwidths(residuals, jacobian, groups=None, combinations=None) -> np.ndarray:
    """Gauss-Newton 95 % half-widths of the fitted parameters (module docstring, any number
    n of them: p - n degrees of freedom), shape (n,), or of the linear combinations
    ``combinations @ x`` (shape (k, n): k half-widths); inf where J^T J is singular or, by
    run, with no more runs than parameters (nothing measures their noise).

    Parameters
    ----------
    residuals : ndarray, shape (p,) [-]
        Residuals at the optimum.
    jacobian : ndarray, shape (p, n) [-]
        d residuals / d x at the optimum.
    groups : sequence, shape (p,), optional
        Each point's run: one observation per run (module docstring).
    """
    res = np.asarray(residuals, float)
    J = np.asarray(jacobian, float)
    n = J.shape[1]
    G = np.eye(n) if combinations is None else np.asarray(combinations, float)
    if groups is not None:  # one observation per group: its points' mean residual and row
        labels = list(dict.fromkeys(groups))
        idx = np.array([labels.index(g) for g in groups])
        res = np.array([res[idx == k].mean() for k in range(len(labels))])
        J = np.array([J[idx == k].mean(axis=0) for k in range(len(labels))])
        if res.size <= n:  # as many runs as parameters fit exactly: nothing measures noise
            return np.full(G.shape[0], np.inf)
    dof = max(res.size - n, 1)
    s2 = float(res @ res) / dof
    try:
        cov = s2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return np.full(G.shape[0], np.inf)
    var = np.einsum("ij,jk,ik->i", G, cov, G)
    return scipy.stats.t.ppf(0.975, dof) * np.sqrt(np.clip(var, 0, None))


def jacobian_intervals(x, residuals, jacobian, groups=None) -> tuple[Interval, Interval]:
    """Gauss-Newton 95 % intervals of (kn, delta) from the fit in log parameters.

    Parameters
    ----------
    x : ndarray, shape (2,) [-]
        Optimum (ln kn, ln delta).
    residuals, jacobian, groups
        As :func:`jacobian_halfwidths`; with two runs or fewer by run the intervals are
        (0, inf).

    Returns
    -------
    kn_ci95 : (float, float) [N m/rad]
    delta_ci95 : (float, float) [rad]
        (inf-wide when J^T J is singular).
    """
    half = jacobian_halfwidths(residuals, jacobian, groups)
    kn, delta = np.exp(x)
    with np.errstate(over="ignore", invalid="ignore"):  # an unbounded direction: to inf
        kn_ci = (float(kn * np.exp(-half[0])), float(kn * np.exp(half[0])))
        delta_ci = (float(delta * np.exp(-half[1])), float(delta * np.exp(half[1])))
    return kn_ci, delta_ci


def bootstrap_intervals(
    residual: Callable[[np.ndarray, np.ndarray], np.ndarray],
    x,
    n_points: int,
    *,
    n_bootstrap: int,
    seed: int = 0,
    progress: bool = False,
) -> tuple[Interval, Interval]:
    """Percentile 95 % intervals of (kn, delta) from a bootstrap over the points.

    Parameters
    ----------
    residual : callable ``(x, pick) -> ndarray, shape (len(pick),)``
        Residuals of the points ``pick`` (indices, with repeats) at x = (ln kn, ln delta).
    x : ndarray, shape (2,) [-]
        The fit's optimum, the start of every resample's fit.
    n_points : int
        p, the number of points resampled.
    n_bootstrap : int
        Resamples (> 0); a resample with fewer than 2 distinct points is skipped.
    seed : int
        Seed of the resampling.
    progress : bool
        A bar over the resamples, shown when they last over 2 s.

    Returns
    -------
    kn_ci95 : (float, float) [N m/rad]
    delta_ci95 : (float, float) [rad]
    """
    if n_bootstrap <= 0:
        raise ValueError(f"`n_bootstrap` must be > 0, got {n_bootstrap!r}")
    rng = np.random.default_rng(seed)
    p = n_points
    est = []
    for _ in progress_bar(range(n_bootstrap), desc="bootstrap over the points", unit="fit",
                          show=progress, leave=False, delay=2.0):
        pick = rng.integers(0, p, p)
        if np.unique(pick).size < 2:
            continue

        def r_boot(x_, pick=pick):
            return residual(x_, pick)

        bs = scipy.optimize.least_squares(r_boot, x, method="lm", xtol=1e-10, ftol=1e-10)
        est.append(np.exp(bs.x))
    est = np.array(est)
    kn_ci = tuple(np.percentile(est[:, 0], [2.5, 97.5]).tolist())
    delta_ci = tuple(np.percentile(est[:, 1], [2.5, 97.5]).tolist())
    return kn_ci, delta_ci

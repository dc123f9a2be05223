"""The test's noise as the replay measures it: noise levels, point weights, standard errors and
the bootstrap by replay."""

from __future__ import annotations

import numpy as np

__all__ = ["noise_levels", "point_weights", "WEIGHT_FLOOR"]

# [-] each point's residual noise is taken as at least this fraction of the median point's, so
# no point weighs more than 1 / WEIGHT_FLOOR times the median one (its noise is estimated, not
# known, and the model's own error is not noise)
WEIGHT_FLOOR = 0.25


def noise_levels(measured, replayed, *, window: int = 256) -> dict:
    """Each run's per-channel noise level in the data's units: the median over windows of
    ``window`` samples of the RMS of the measured minus the replayed record.

    The median, not the RMS of the whole record: where the measured and replayed jumps fall a
    few cycles apart, or the start transients differ, the difference is as large as the signal,
    but only in a few windows; elsewhere it is the noise plus the model's misfit (so the level
    errs on the large side: wider intervals, not narrower).
    """
    rep = {r.file: r for r in replayed.runs}
    out = {}
    for run in measured.runs:
        r = rep.get(run.file)
        if r is None or run.reason:
            continue
        n = min(run.data.shape[-1], r.data.shape[-1])
        d = np.asarray(run.data[..., :n], float) - np.asarray(r.data[..., :n], float)
        w = max(8, min(int(window), n))
        k = n // w
        blocks = d[..., : k * w].reshape(d.shape[0], k, w)
        out[run.file] = np.median(np.sqrt(np.mean(blocks * blocks, axis=-1)), axis=-1)
    return out


def point_weights(points, noise: dict, dataset, system, kn: float, delta: float, *,
                  mode: int = 0) -> tuple[dict, list]:
    """Each point's weight in the statistic's fit: 1 / the noise of its relative frequency
    residual that its amplitude noise makes, relative to the median point's.

    A point's amplitude X is read off its channel's first-harmonic curve; white noise of level
    sigma (:func:`noise_levels`, data units) moves it by about sigma / A relative, A = X w^order
    (the amplitude in the data's units), the same for every point up to the extraction's noise
    bandwidth, which only scales all weights. Through the backbone that is a relative frequency
    residual of |d ln f_BC / d ln X| sigma / A. The weaker channel of a run (the lower-right
    accelerometer on the fin, 4x smaller) then counts less; its amplitude scatters by 1-4 % at
    0.2-0.3 g where the jump frequency itself moves by < 0.01 %. Each point's residual noise is
    floored at ``WEIGHT_FLOOR`` times the median's.

    Parameters
    ----------
    points : FittingPoints
        The statistic's points (channel = DOF name, with runs).
    noise : dict of str -> ndarray
        Per run, each data channel's noise level (:func:`noise_levels`).
    dataset : Dataset
        For the channel order, quantity and units.
    system, kn, delta, mode
        The backbone at the estimate (its slope at each point).

    Returns
    -------
    weights : dict of (run, DOF name) -> float
    table : list of dict
        Per point: run, channel, noise_ratio (record noise / the point's amplitude, data
        units), residual_scale (|slope| times that) and weight.
    """
    from ..fit import BackboneModel
    from ..quantity import check_quantity

    order = check_quantity(dataset.quantity).order
    column = {dof: i for i, dof in enumerate(dataset.channels.values())}
    model = BackboneModel(system, points.channel, mode=mode)
    cidx = np.array([model.channels.index(c) for c in points.channel])
    amp, f = np.asarray(points.amplitude_m), np.asarray(points.f_hz)
    h = 0.02  # [-] about one step of the curve's ln X grid (the slope across it)
    slope = np.log(model.frequency(amp * np.exp(h), cidx, kn, delta)
                   / model.frequency(amp * np.exp(-h), cidx, kn, delta)) / (2 * h)
    a_data = amp * (2 * np.pi * f) ** order / dataset.si_scale
    runs = points.run or (None,) * len(points)
    sigma = np.array([noise[r][column[c]] if r in noise else np.nan
                      for r, c in zip(runs, points.channel, strict=True)], dtype=float)
    rel = sigma / a_data
    res = np.abs(slope) * rel
    known = np.isfinite(res) & (res > 0)
    if not np.any(known):
        return {}, []
    med = float(np.median(res[known]))
    res = np.where(known, np.maximum(res, WEIGHT_FLOOR * med), med)
    w = med / res
    table = [{"run": r, "channel": c, "noise_ratio": float(a), "residual_scale": float(e),
              "weight": float(x)}
             for r, c, a, e, x in zip(runs, points.channel, rel, res, w, strict=True)]
    return {(r, c): float(x) for r, c, x in zip(runs, points.channel, w, strict=True)}, table


def _median_se(values: np.ndarray) -> float:
    """Standard error of the median of ``values`` (n >= 2): 1.2533 s / sqrt(n)."""
    return 1.2533 * float(np.std(values, ddof=1)) / np.sqrt(values.size)


def _misfit_in_se(F, statistic_ci95, measured, ratios) -> float | None:
    """The largest |F_i| over its statistic's standard error: log(kn_rep / kn_hat) and
    log(delta_rep / delta_hat) over the standard errors of the statistic's log kn and log delta
    (its by-run 95 % intervals over 2 t_0.975(runs - 2)), and with an estimated damping the
    median log amplitude ratio over its own (1.2533 s / sqrt(n) of the per-point ratios).
    None when nothing measures the noise (two runs or fewer, an infinite interval)."""
    import scipy.stats

    runs = len({p.run for p in measured})
    if statistic_ci95 is None or runs <= 2:
        return None
    t = float(scipy.stats.t.ppf(0.975, runs - 2))
    se = [np.log(hi / lo) / (2 * t) if lo > 0 else np.inf for lo, hi in statistic_ci95]
    if ratios is not None:
        se.append(_median_se(ratios) if ratios.size >= 2 else np.inf)
    se = np.asarray(se, dtype=float)
    if not np.all(np.isfinite(se) & (se > 0)):
        return None
    return float(np.max(np.abs(np.asarray(F, dtype=float)[: se.size]) / se))


def _bootstrap_by_replay(rep_ds, system, noise, *, theta, theta_rep, n, seed, fit_kwargs,
                         progress):
    """Percentile 95 % intervals of theta * theta_b / theta_rep over ``n`` noisy copies of the
    replay ``rep_ds`` (module docstring)."""
    import dataclasses

    from tqdm.auto import tqdm

    from ..errors import IdentificationError
    from ..estimate import plain_estimate

    rng = np.random.default_rng(seed)
    samples = []
    for _ in tqdm(range(n), desc="bootstrap by replay", disable=not progress, leave=False):
        runs = []
        for run in rep_ds.runs:
            sd = noise.get(run.file)
            if sd is None:
                runs.append(run)
                continue
            noisy = run.data + sd[:, None] * rng.standard_normal(run.data.shape)
            runs.append(dataclasses.replace(run, data=noisy))
        copy = dataclasses.replace(rep_ds, runs=tuple(runs))
        try:
            fit = plain_estimate(copy, system, init=tuple(theta_rep), **fit_kwargs)
        except IdentificationError:
            continue  # a copy whose noise hides a jump: it adds no sample
        samples.append(theta * np.array([fit.kn, fit.delta]) / theta_rep)
    if len(samples) < max(5, n // 2):
        return None, None
    arr = np.asarray(samples)
    lo, hi = np.percentile(arr, [2.5, 97.5], axis=0)
    return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))

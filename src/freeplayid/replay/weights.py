"""The test's noise as the replay measures it, and the weights of the statistic's points."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fit import BackboneModel
from ..quantity import check_quantity

__all__ = ["PointWeight", "noise_levels", "record_noise", "point_weights", "WEIGHT_FLOOR"]

# [-] each point's residual noise is taken as at least this fraction of the median point's, so
# no point weighs more than 1 / WEIGHT_FLOOR times the median one (its noise is estimated, not
# known, and the model's own error is not noise)
WEIGHT_FLOOR = 0.25


@dataclass(frozen=True)
class PointWeight:
    """One point's weight in the statistic's fit.

    Attributes
    ----------
    run, channel : str
        The point (channel: the model DOF name).
    noise_ratio : float [-]
        The record's noise level over the point's amplitude (data units).
    residual_scale : float [-]
        The frequency residual that noise makes through the backbone's slope (floored).
    weight : float [-]
        Its weight, the median point's being 1.
    """

    run: str
    channel: str
    noise_ratio: float
    residual_scale: float
    weight: float


def noise_levels(measured, replayed, *, window: int = 256) -> dict:
    """Each run's per-channel noise level in the data's units: the median over windows of
    ``window`` samples of the RMS of the measured minus the replayed record.

    The median, not the RMS of the whole record: where the measured and replayed jumps fall a
    few cycles apart, or the start transients differ, the difference is as large as the signal,
    but only in a few windows; elsewhere it is the noise plus the model's misfit (so the level
    errs on the large side: wider intervals, not narrower).
    """
    out = {}
    for file, x, y in _pairs(measured, replayed):
        d = x - y
        w = max(8, min(int(window), d.shape[-1]))
        k = d.shape[-1] // w
        blocks = d[..., : k * w].reshape(d.shape[0], k, w)
        out[file] = np.median(np.sqrt(np.mean(blocks * blocks, axis=-1)), axis=-1)
    return out


def _pairs(measured, replayed):
    """(file, measured record, replayed record) of every usable run both have, cut to the
    shorter length, as float arrays (channels, samples)."""
    rep = {r.file: r for r in replayed.runs}
    for run in measured.runs:
        r = rep.get(run.file)
        if r is None or run.reason:
            continue
        n = min(run.data.shape[-1], r.data.shape[-1])
        yield run.file, np.asarray(run.data[..., :n], float), np.asarray(r.data[..., :n], float)


def record_noise(measured, replayed, *, window: int = 128) -> dict:
    """Each run's per-channel noise level in the data's units, from the measured record less
    what the replay explains of it: in each window of ``window`` samples the measured record is
    regressed on the replayed one, its quadrature (Hilbert transform) and their slopes, which
    absorbs a slowly varying amplitude, phase and time shift between them (a replayed sweep's
    phase a little off, a damping a little off), and the residual's RMS (4 degrees of freedom
    less) is the noise there; the median over windows.

    :func:`noise_levels` takes the plain difference: it counts such a phase misfit as noise and
    overestimates it (20-25x on a 5 %-damped fin swept at 0.5 Hz/s, against 1.05-1.14x here).
    The noisy copies that read a replay as the test's sensors would (the cross-check, the
    offsets' noise) need the noise itself. Where both runs have a base channel its level comes
    last, after the data channels' (:func:`freeplayid.replay.bootstrap.noisy_copy`): the test's
    points are taken relative to the base, so its noise moves them too.
    """
    bases = {r.file: r.base for r in measured.runs}, {r.file: r.base for r in replayed.runs}
    out = {}
    for file, x, y in _pairs(measured, replayed):
        out[file] = _regressed_noise(x, y, window)
        xb, yb = bases[0][file], bases[1][file]
        if xb is not None and yb is not None:
            n = min(xb.shape[-1], yb.shape[-1])
            base = _regressed_noise(np.asarray(xb[None, :n], float),
                                    np.asarray(yb[None, :n], float), window)
            out[file] = np.concatenate([out[file], base])
    return out


def _regressed_noise(x: np.ndarray, y: np.ndarray, window: int) -> np.ndarray:
    """Per channel of ``x`` (channels, samples): the median over windows of the RMS of ``x``
    less its regression on ``y``, its quadrature and their slopes (:func:`record_noise`)."""
    from scipy.signal import hilbert

    n = x.shape[-1]
    w = max(16, min(int(window), n))
    k = n // w
    x = x[..., : k * w].reshape(-1, k, w)
    q = np.imag(hilbert(y, axis=-1))
    # the regressors: the replay, its quadrature (a phase rotation) and their slopes (a
    # small time shift, which moves every harmonic by its own phase)
    basis = np.stack([u[..., : k * w].reshape(-1, k, w)
                      for u in (y, q, np.gradient(y, axis=-1), np.gradient(q, axis=-1))],
                     axis=-1)
    rms = np.empty(x.shape[:2])
    for c in range(x.shape[0]):
        for j in range(k):
            coef, *_ = np.linalg.lstsq(basis[c, j], x[c, j], rcond=None)
            res = x[c, j] - basis[c, j] @ coef
            rms[c, j] = np.sqrt(np.sum(res * res) / (w - basis.shape[-1]))
    return np.median(rms, axis=-1)


def point_weights(points, noise: dict, dataset, system, kn: float, delta: float, *,
                  mode: int = 0) -> tuple[dict, tuple]:
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
    table : tuple of PointWeight
        Per point: its noise ratio, residual scale and weight.
    """
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
        return {}, ()
    med = float(np.median(res[known]))
    res = np.where(known, np.maximum(res, WEIGHT_FLOOR * med), med)
    w = med / res
    table = tuple(PointWeight(r, c, float(a), float(e), float(x))
                  for r, c, a, e, x in zip(runs, points.channel, rel, res, w, strict=True))
    return {(r, c): float(x) for r, c, x in zip(runs, points.channel, w, strict=True)}, table



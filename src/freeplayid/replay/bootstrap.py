"""Intervals that see the bias: the bootstrap by replay."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from ..errors import IdentificationError
from ..estimate import plain_estimate

__all__ = ["ReplayBootstrap", "bootstrap_by_replay", "noisy_copy"]


@dataclass(frozen=True)
class ReplayBootstrap:
    """Percentile 95 % intervals of the bootstrap by replay.

    Attributes
    ----------
    kn_ci95, delta_ci95 : (float, float) or None [N m/rad], [rad]
        None when fewer than max(5, n / 2) copies could be fitted.
    n : int
        Noisy copies of the final replay.
    n_fitted : int
        Copies whose plain estimate could be made (the others' noise hid a jump).
    noise : dict of str -> list of float
        Per run: each channel's measured noise level the copies got, then the base channel's
        where the runs have one [data units].
    """

    kn_ci95: tuple | None
    delta_ci95: tuple | None
    n: int
    n_fitted: int
    noise: dict


def bootstrap_by_replay(replayed, system, noise: dict, *, theta, theta_rep, n: int, seed: int,
                        extraction, fit, point_weights, progress: bool = False):
    """Percentile 95 % intervals of theta * theta_b / theta_rep over ``n`` noisy copies of the
    replayed test ``replayed`` (a Dataset): a :class:`ReplayBootstrap`.

    Each copy gets fresh white noise of each channel's measured level (``noise``: per run, one
    level per channel; ``corrected_fit`` passes :func:`freeplayid.replay.weights.record_noise`,
    the record less what the replay explains of it, not the plain difference, which counts a
    replayed phase a little off as noise) and passes through the plain
    estimate with the statistic's options; its fit theta_b maps to a corrected estimate by the
    binding function's local factor theta / theta_rep (the factor varies much less than the
    noise, so it is not solved again per copy).
    """
    rng = np.random.default_rng(seed)
    samples = []
    for _ in tqdm(range(n), desc="bootstrap by replay", disable=not progress, leave=False):
        copy = noisy_copy(replayed, noise, rng)
        try:
            est = plain_estimate(copy, system, init=tuple(theta_rep), extraction=extraction,
                                 fit=fit, point_weights=point_weights)
        except IdentificationError:
            continue  # a copy whose noise hides a jump: it adds no sample
        samples.append(theta * np.array([est.kn, est.delta]) / theta_rep)
    kn_ci = delta_ci = None
    if len(samples) >= max(5, n // 2):
        lo, hi = np.percentile(np.asarray(samples), [2.5, 97.5], axis=0)
        kn_ci, delta_ci = (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))
    return ReplayBootstrap(kn_ci95=kn_ci, delta_ci95=delta_ci, n=int(n), n_fitted=len(samples),
                           noise={k: [float(x) for x in v] for k, v in noise.items()})


def noisy_copy(replayed, noise: dict, rng):
    """``replayed`` (a Dataset) with fresh white noise of each channel's measured level added
    to its responses, and to its base channel where the level list has one more entry
    (``noise``: per run, one level per data channel, then the base's:
    :func:`freeplayid.replay.weights.record_noise`): a replay as the test's sensors would have
    recorded it."""
    runs = []
    for run in replayed.runs:
        sd = noise.get(run.file)
        if sd is None:
            runs.append(run)
            continue
        sd = np.asarray(sd, float)
        n = run.data.shape[0]
        noisy = run.data + sd[:n, None] * rng.standard_normal(run.data.shape)
        base = run.base
        if base is not None and sd.size > n:
            base = base + sd[n] * rng.standard_normal(base.shape)
        runs.append(dataclasses.replace(run, data=noisy, base=base))
    return dataclasses.replace(replayed, runs=tuple(runs))

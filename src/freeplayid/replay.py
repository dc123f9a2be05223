"""Replay the measured test with the simulator, and the bias-corrected fit (indirect inference).

The swept, damped resonance peaks are not points of the undamped backbone, and the extraction
adds its own offsets at the jump; a backbone fit turns both into a biased (kn, delta). The
replay simulates the test as it was run -- each run's level and sweep law, the measured sample
rate, quantity and frame, the model's damping -- at given (kn, delta), and passes the records
through the SAME extraction and fit as the measured data. With theta_hat = fit(measured) and
theta_rep(theta) = fit(replay(theta)), the corrected estimate solves

    theta_rep(theta) = theta_hat                                     (binding function)

by the fixed point (in log parameters, every bias a factor)

    theta_{k+1} = theta_k * theta_hat / theta_rep(theta_k),

which stops when both parameters move by less than ``rtol`` (0.05 %). Whatever the bias comes
from (damping, sweep rate, the describing function, the extraction), the replay has it too, so it
cancels; what is left is the measurement noise and the model's own error.

Each run's sweep law (linear or logarithmic) is its ``sweep`` hint; a run without one gets the
law estimated from the base channel when the data set has one, else from its response channels
(:func:`freeplayid.signal.estimate_sweep`), and the result says which (``sweeps``). The damping
is the model file's (its ``C``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .quantity import G, check_quantity

__all__ = ["ReplayResult", "replay_sweeps", "replay_levels", "replay_dataset", "corrected_fit",
           "curve_misfit"]


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
        Per iteration: the replayed parameters (kn, delta) and the fit of their replay
        (kn_rep, delta_rep).
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
    sweeps: dict | None = None


def replay_sweeps(dataset) -> dict:
    """Each usable run's sweep law: its ``sweep`` hint, else estimated from the base channel
    when the data set has one, else from the response channels (the best-tracked one).

    Returns
    -------
    dict of run file -> (Sweep, source, residual [Hz] or None)
        source is "hint", "base channel" or "response"; the residual is the estimate's
        (:class:`freeplayid.signal.SweepEstimate`).

    Raises
    ------
    ValueError
        No sweep law can be found in a run without a hint.
    """
    from .signal import estimate_sweep
    from .sweep import Sweep

    out = {}
    for run in dataset.runs:
        if run.reason:
            continue
        if run.sweep is not None:
            out[run.file] = (Sweep(**run.sweep), "hint", None)
            continue
        source, x = ("base channel", run.base) if run.base is not None else ("response", run.data)
        try:
            est = estimate_sweep(dataset.to_si(x), dataset.sample_rate)
        except ValueError as exc:
            raise ValueError(f"run {run.file}: no sweep hint and no sweep law in its {source} "
                             f"({exc}); give the run's `sweep` hint") from None
        out[run.file] = (est.sweep, source, est.residual_hz)
    return out


def replay_levels(dataset, sweeps: dict | None = None) -> dict:
    """Each usable run's base level [g]: from the base channel's first harmonic when the data set
    has one (least squares at the sweep's phase), else the manifest's ``level_g``.

    ``sweeps`` is :func:`replay_sweeps` of the data set (computed when not given).

    Returns
    -------
    dict of run file -> (level [g], source)
    """
    from .signal import window_amplitudes

    sweeps = replay_sweeps(dataset) if sweeps is None else sweeps
    order = check_quantity(dataset.quantity).order
    out = {}
    for run in dataset.runs:
        if run.reason or run.file not in sweeps:
            continue
        sweep = sweeps[run.file][0]
        if run.base is not None:
            f, a = window_amplitudes(dataset.to_si(run.base), dataset.sample_rate, sweep)
            # the base moves as A sin(phase): its amplitude in the data's quantity is A / w^(2-k)
            level = float(np.median(a * (2 * np.pi * f) ** (2 - order))) / G
            out[run.file] = (level, "base channel")
        elif run.level_g:
            out[run.file] = (float(run.level_g), "level_g")
        else:
            raise ValueError(f"run {run.file}: no base channel and no `level_g`: the replay "
                             "cannot know the run's level")
    return out


def replay_dataset(dataset, system, kn: float, delta: float, *, levels: dict | None = None,
                   sweeps: dict | None = None, dtype=None):
    """The data set's usable runs simulated at (kn, delta): a data set of the same layout.

    Runs sharing a sweep law are simulated in one batch; absolute frame with the base channel
    when the data set has one, else relative. ``sweeps`` and ``levels`` are
    :func:`replay_sweeps` and :func:`replay_levels` (computed when not given). A replayed run
    carries a sweep hint only where the measured run has one, so both go through the same
    extraction.
    """
    import dataclasses

    import torch

    from .io import Dataset
    from .simulate import simulate_sweeps, sweep_dataset

    sweeps = replay_sweeps(dataset) if sweeps is None else sweeps
    levels = replay_levels(dataset, sweeps) if levels is None else levels
    frame = "absolute" if dataset.base_channel else "relative"
    hinted = {run.file for run in dataset.runs if run.sweep is not None}
    groups: dict = {}
    for run in dataset.runs:
        if run.file in levels:
            groups.setdefault(sweeps[run.file][0], []).append(run.file)
    runs = []
    for sweep, files in groups.items():
        res = simulate_sweeps(system, kn=kn, delta=delta, level_g=[levels[f][0] for f in files],
                              sweep=sweep, channels=list(dataset.channels.values()),
                              quantity=dataset.quantity, frame=frame,
                              sample_rate=dataset.sample_rate,
                              dtype=torch.float64 if dtype is None else dtype, progress=False)
        ds = sweep_dataset(res, columns=dataset.channels, units=dataset.units, run_names=files)
        runs += [r if r.file in hinted else dataclasses.replace(r, sweep=None) for r in ds.runs]
    order = {r.file: i for i, r in enumerate(dataset.runs)}
    runs.sort(key=lambda r: order[r.file])
    return Dataset(name=f"replay of {dataset.name}", model=None, quantity=dataset.quantity,
                   units=dataset.units, sample_rate=dataset.sample_rate,
                   channels=dict(dataset.channels), runs=tuple(runs),
                   base_channel=dataset.base_channel if frame == "absolute" else None)


def corrected_fit(dataset, system, identification, *, fit_kwargs: dict, rtol: float = 5e-4,
                  max_iter: int = 6) -> ReplayResult:
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
    """
    from .identification.pipeline import identify

    # replay only the runs whose points were fitted: a run rejected in the test (e.g. it stayed
    # in the gap) must not enter the replayed fit as a point the measured fit did not have
    used = {p.run for p in identification.points.used()}
    sweeps = {k: v for k, v in replay_sweeps(dataset).items() if k in used}
    levels = replay_levels(dataset, sweeps)
    hat = np.array([identification.kn, identification.delta])
    theta = hat.copy()
    history, converged, rep = [], False, None
    for _ in range(max_iter):
        rep_ds = replay_dataset(dataset, system, *theta, levels=levels, sweeps=sweeps)
        rep = identify(rep_ds, system=system, init=tuple(theta), progress=False, replay=False,
                       **fit_kwargs)
        theta_rep = np.array([rep.kn, rep.delta])
        new = theta * hat / theta_rep
        history.append({"kn": float(theta[0]), "delta": float(theta[1]),
                        "kn_rep": float(theta_rep[0]), "delta_rep": float(theta_rep[1])})
        step = np.abs(new / theta - 1)
        theta = new
        if np.all(step < rtol):
            converged = True
            break
    offsets = []
    if rep is not None:
        replayed = {(p.run, p.channel): p for p in rep.points.used()}
        for p in identification.points.used():
            q = replayed.get((p.run, p.channel))
            if q is not None:
                offsets.append({"run": p.run, "channel": p.channel,
                                "f_offset": q.f_hz / p.f_hz - 1,
                                "amplitude_offset": q.amplitude_m / p.amplitude_m - 1})
    misfit: dict[str, float] = {}
    if rep is not None:
        replayed_curves = {(c.run, c.channel): c for c in rep.points.curves}
        for c in identification.points.curves:
            r = replayed_curves.get((c.run, c.channel))
            if r is not None and c.run in levels:
                misfit[c.run] = max(misfit.get(c.run, 0.0), curve_misfit(c, r))
    return ReplayResult(kn=float(theta[0]), delta=float(theta[1]), kn_fit=float(hat[0]),
                        delta_fit=float(hat[1]), iterations=history, converged=converged,
                        levels=levels, offsets=offsets,
                        curves=tuple(rep.points.curves) if rep is not None else (),
                        misfit=misfit, sweeps={
                            run: {"source": src, "law": sw.law, **sw.to_dict(),
                                  **({} if res is None else {"residual_hz": float(res)})}
                            for run, (sw, src, res) in sweeps.items()})


def curve_misfit(measured, replayed) -> float:
    """Median of |X_replayed(f) - X_measured(f)| over the measured curve's band, relative to the
    measured peak: 0 for identical amplitude-frequency curves, 0.1 for a 10 % offset.

    The median, not the RMS: at the jump the amplitude falls by half within a fraction of a Hz,
    so a jump 0.01 Hz apart (a start transient, the sweep's phase) puts a few samples far apart
    that say nothing about the model; a model that does not fit the test differs over the band.

    Both curves are ``AmplitudeCurve`` (frequency [Hz], displacement amplitude [m]) of one run
    and channel; the replayed one is interpolated at the measured frequencies (an up- or
    down-sweep's frequency track is monotonic in time; it is sorted for the interpolation).
    """
    f, x = np.asarray(measured.frequency), np.asarray(measured.amplitude_m)
    fr, xr = np.asarray(replayed.frequency), np.asarray(replayed.amplitude_m)
    ok, okr = np.isfinite(f) & np.isfinite(x), np.isfinite(fr) & np.isfinite(xr)
    if np.count_nonzero(ok) < 2 or np.count_nonzero(okr) < 2:
        return float("nan")
    order = np.argsort(fr[okr])
    inside = ok & (f >= fr[okr].min()) & (f <= fr[okr].max())
    if np.count_nonzero(inside) < 2:
        return float("nan")
    xi = np.interp(f[inside], fr[okr][order], xr[okr][order])
    return float(np.median(np.abs(xi - x[inside])) / np.max(x[ok]))

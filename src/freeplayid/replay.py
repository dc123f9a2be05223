"""Replay the measured test with the simulator, and the bias-corrected fit (indirect inference).

The swept, damped resonance peaks are not points of the undamped backbone, and the extraction
adds its own offsets at the jump; a backbone fit turns both into a biased (kn, delta). The
replay simulates the test as it was run -- each run's level and sweep law, the measured sample
rate, quantity and frame, the model's damping -- at given (kn, delta), and passes the records
through the SAME extraction and fit as the measured data. With theta_hat = fit(measured) and
theta_rep(theta) = fit(replay(theta)), the corrected estimate solves

    theta_rep(theta) = theta_hat                                     (binding function)

in log parameters (every bias a factor) by Broyden's quasi-Newton method: it starts from the
fixed point theta_{k+1} = theta_k * theta_hat / theta_rep(theta_k) (an identity Jacobian) and
learns the binding function's Jacobian from the replays, so a binding that couples kn and delta,
or moves less than one to one, still converges; each step is at most a factor 1.5, and the loop
stops when both parameters move by less than ``rtol`` (0.05 %). Without convergence in
``max_iter`` replays the answer is the replayed parameters whose fit came closest to the test's,
and the verdict says that it did not converge. Whatever the bias comes
from (damping, sweep rate, the describing function, the extraction), the replay has it too, so it
cancels; what is left is the measurement noise and the model's own error.

The statistic (``jump_point``). theta_hat and theta_rep may be any statistic of the test, biased
or not, as long as both go through the same steps; what matters is its noise. The plain fit's
points sit at the maximum of each run's curve, which lies on a flat top 0.1-0.5 Hz of sweep long,
so its frequency wanders with the noise (0.03-0.17 Hz between noise draws at 0.2 g on the fin).
By default the replays therefore match the points taken with ``jump_point="drop"``
(:mod:`freeplayid.signal.peak`): the excitation frequency where the curve drops through half its
maximum (0.0001-0.0008 Hz between the same draws) and the amplitude one filter time ahead of
the drop, both from windows that stop at the drop: the grazing transient after it changes with
any 1e-9 change of the parameters, and a statistic that saw it made the binding function
jitter by 0.1-0.2 % (benchmarks/binding_jitter.py). The measured data are extracted once more with that rule; the plain fit stays what it
was (``kn_fit``, ``delta_fit``). The Jacobian intervals moved with the estimate are the
statistic fit's, with each run's points counted as one observation (the channels of a run share
its jump).

Weights (``weighted``): the statistic's fit weights each point by the inverse of the frequency
residual its amplitude noise makes (:func:`point_weights`): the noise level measured against the
first replay over the point's amplitude, times the backbone's slope d ln f / d ln X there. The
first replay is made at the unweighted fit; the measured points and that replay are refitted
with the weights, which stay fixed for every later fit (one fixed statistic).

Damping (``damping=``): the model file's ``C`` when it has one; else (or with
``damping="estimate"``) one modal damping ratio zeta for every mode of the closed-hinge stiffness
at the plain fit's kn, estimated in the same loop from the points' amplitudes: the jump peak of a
hardening resonance is held down by damping (its amplitude goes roughly as 1/zeta), so the
statistic r = median over the points of log(X_rep / X) joins the two fit statistics as a third
equation r(zeta) = 0 of the same Broyden solve (slope -1 to start); its first guess is
:func:`initial_zeta`. Its interval comes from the spread of the per-point log ratios. A number
(``damping=0.02``) fixes zeta.

Intervals that see the bias (``n_bootstrap``): B copies of the last replay (the test as the model
at the corrected estimate runs it), each with fresh white noise of each channel's measured noise
level (robust standard deviation of the measured minus the replayed record), pass through the
whole plain pipeline (extraction and fit); each copy's fit theta_b maps to a corrected estimate
by the binding function's local factor, theta * theta_b / theta_rep, and the 2.5/97.5 %
percentiles of those are the interval. The bootstrap reuses the last replay's correction factor
instead of re-running the fixed point per copy (the factor varies much less than the noise).

Each run's sweep law (linear or logarithmic) is its ``sweep`` hint; a run without one gets the
law estimated from the base channel when the data set has one, else from its response channels
(:func:`freeplayid.signal.estimate_sweep`), and the result says which (``sweeps``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .quantity import G, check_quantity

__all__ = ["ReplayResult", "ReplayDamping", "replay_sweeps", "replay_levels", "replay_dataset",
           "corrected_fit", "curve_misfit", "damped_system", "noise_levels", "initial_zeta",
           "point_weights"]

ZETA_START = 0.02  # [-] first guess of an estimated damping ratio (the loop moves it)
ZETA_RTOL = 0.01  # [-] an estimated zeta has converged when it moves by less than 1 %
# [-] each point's residual noise is taken as at least this fraction of the median point's, so
# no point weighs more than 1 / WEIGHT_FLOOR times the median one (its noise is estimated, not
# known, and the model's own error is not noise)
WEIGHT_FLOOR = 0.25


@dataclass(frozen=True)
class ReplayDamping:
    """The damping the replay used.

    Attributes
    ----------
    source : {"model", "given", "estimated"}
        The model file's C, a ratio given by the user, or one estimated from the amplitudes.
    zeta : float or None [-]
        Modal damping ratio of every closed-hinge mode (None with the model's C).
    zeta_ci95 : (float, float) or None
        95 % interval of an estimated zeta (from the per-point amplitude ratios).
    """

    source: str
    zeta: float | None = None
    zeta_ci95: tuple | None = None

    def to_dict(self) -> dict:
        return {"source": self.source, "zeta": self.zeta,
                "zeta_ci95": None if self.zeta_ci95 is None else list(self.zeta_ci95)}

    def describe(self) -> str:
        if self.source == "model":
            return "the model file's C"
        text = f"zeta = {self.zeta:.4g} in every closed-hinge mode"
        if self.source == "given":
            return text + " (given)"
        ci = "" if self.zeta_ci95 is None else \
            f", 95 % CI [{self.zeta_ci95[0]:.4g}, {self.zeta_ci95[1]:.4g}]"
        return text + f" (estimated from the peak amplitudes{ci})"


def damped_system(system, zeta: float, kn: float):
    """``system`` with modal damping ratio ``zeta`` in every mode of its closed-hinge stiffness
    at ``kn`` (``model.modal_damping``), replacing its C."""
    from .model import modal_damping

    return system.replace(C=modal_damping(system.M, system.closed_stiffness(kn), zeta))


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
                   sweeps: dict | None = None, dtype=None, engine: str | None = None):
    """The data set's usable runs simulated at (kn, delta): a data set of the same layout.

    Runs sharing a sweep law are simulated in one batch; absolute frame with the base channel
    when the data set has one, else relative. ``sweeps`` and ``levels`` are
    :func:`replay_sweeps` and :func:`replay_levels` (computed when not given). A replayed run
    carries a sweep hint only where the measured run has one, so both go through the same
    extraction. ``engine``: a simulator engine name (:data:`freeplayid.simulate.engines.ENGINES`
    or "auto"); None: the exponential engine when available, else "auto".
    """
    import dataclasses

    import torch

    from .io import Dataset
    from .simulate import simulate_sweeps, sweep_dataset
    from .simulate.engines import ENGINES

    # the exponential engine (docs/simulate.md): exact between hinge switches, a step set by
    # accuracy, one member per core; as accurate as RK4 at its default step and about 6x faster
    # for one replay's few members. RK4 where numba is missing.
    if engine is None:
        engine = "expo" if ENGINES["expo"].available() else "auto"
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
                              dtype=torch.float64 if dtype is None else dtype, progress=False,
                              engine=engine)
        ds = sweep_dataset(res, columns=dataset.channels, units=dataset.units, run_names=files)
        runs += [r if r.file in hinted else dataclasses.replace(r, sweep=None) for r in ds.runs]
    order = {r.file: i for i, r in enumerate(dataset.runs)}
    runs.sort(key=lambda r: order[r.file])
    return Dataset(name=f"replay of {dataset.name}", model=None, quantity=dataset.quantity,
                   units=dataset.units, sample_rate=dataset.sample_rate,
                   channels=dict(dataset.channels), runs=tuple(runs),
                   base_channel=dataset.base_channel if frame == "absolute" else None)


def _damping_mode(system, damping) -> tuple[str, float | None]:
    """("model" | "given" | "estimated", zeta) from the ``damping`` argument."""
    if damping is None:
        has_c = system.C is not None and bool(np.any(system.C))
        return ("model", None) if has_c else ("estimated", ZETA_START)
    if isinstance(damping, str):
        if damping == "model":
            if system.C is None or not np.any(system.C):
                raise ValueError("`damping`='model' but the model file has no damping matrix C; "
                                 "use damping='estimate' or a ratio such as 0.02")
            return "model", None
        if damping == "estimate":
            return "estimated", ZETA_START
        raise ValueError(f"`damping` must be None, 'model', 'estimate' or a ratio in (0, 1), "
                         f"got {damping!r}")
    z = float(damping)
    if not (0 < z < 1):
        raise ValueError(f"`damping` must be None, 'model', 'estimate' or a ratio in (0, 1), "
                         f"got {damping!r}")
    return "given", z


def initial_zeta(system, points, levels: dict, kn: float, dofs: dict, mode: int = 0) -> float:
    """First guess of the modal damping ratio from the points: at the top of a resonance the
    damping force balances the excitation, 2 zeta w_c w q = gamma a_g, so with the closed-hinge
    mode (w_c, mass-normalised shape phi, modal load gamma per g) and a point of displacement
    amplitude X at the DOF of its channel, excitation w and level a_g::

        zeta = |phi_dof gamma| a_g / (2 w_c w X)

    (median over the points, kept in [0.002, 0.3]). A swept jump falls before the phase
    resonance and the absolute frame adds the base motion, so this is only the loop's start.
    """
    from .model import modal_analysis

    modes = modal_analysis(system.M, system.closed_stiffness(kn))
    phi = modes.shapes[:, mode]
    wc = 2 * np.pi * float(modes.frequencies_hz[mode])
    gamma = float(phi @ (system.M @ system.influence)) * G
    guesses = []
    for p in points:
        if p.run not in levels or p.channel not in dofs or not p.amplitude_m > 0:
            continue
        pd = float(phi[system.dof_index(dofs[p.channel])])
        w = 2 * np.pi * p.f_hz
        guesses.append(abs(pd * gamma) * levels[p.run][0] / (2 * wc * w * p.amplitude_m))
    if not guesses or wc <= 0:
        return ZETA_START
    return float(np.clip(np.median(guesses), 0.002, 0.3))


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
    from .fit import BackboneModel
    from .quantity import check_quantity

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


def _refit(ident, system, weights: dict, fit_kwargs: dict):
    """``ident`` (an Identification) fitted again to its own points with ``weights``."""
    import dataclasses

    from .fit import FittingPoints, fit_backbone
    from .identification.pipeline import weights_of

    pts = FittingPoints.from_extraction(ident.points, dofs=ident.dofs)
    fit = fit_backbone(pts, system, init=(ident.kn, ident.delta), init_label=ident.fit.init,
                       backbone=fit_kwargs.get("backbone", "dfa"),
                       mode=int(fit_kwargs.get("mode", 0)), weights=weights_of(pts, weights))
    return dataclasses.replace(ident, kn=fit.kn, delta=fit.delta, kn_ci95=tuple(fit.kn_ci95),
                               delta_ci95=tuple(fit.delta_ci95),
                               residual_rms=fit.residual_rms, fit=fit)


def _amplitude_ratios(measured_points, replayed_points) -> np.ndarray:
    """log(X_replayed / X_measured) of the points found in both, matched by (run, channel)."""
    rep = {(p.run, p.channel): p for p in replayed_points}
    out = [np.log(rep[(p.run, p.channel)].amplitude_m / p.amplitude_m)
           for p in measured_points if (p.run, p.channel) in rep]
    return np.asarray(out, float)


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
    from .fit import FittingPoints
    from .identification.pipeline import identify
    from .identification.result import IdentificationError

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
            identification = identify(stat_ds, system=system, init=(plain.kn, plain.delta),
                                      progress=False, replay=False, **fit_kwargs)
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
            rep_k = identify(rep_ds, system=system, init=tuple(theta), progress=False,
                             replay=False, **fit_kwargs)
        except IdentificationError as err:
            failure = (f"the replay at kn = {theta[0]:.5g} N·m/rad, delta = {theta[1]:.5g} rad "
                       f"could not be identified ({err}): the model does not behave like the "
                       "test")
            break
        if weighted and weight_table is None:
            # the first replay is the clean reference of the measured noise: weight the points
            # by it, refit the test's statistic and this replay with the weights, and keep them
            # for every later fit (the binding needs one fixed statistic)
            fitted = FittingPoints.from_extraction(identification.points,
                                                   dofs=identification.dofs)
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


def _with_sweep_hints(dataset, sweeps: dict):
    """``dataset`` with each run of ``sweeps`` that has no hint given its replayed law as one."""
    import dataclasses

    runs = tuple(dataclasses.replace(r, sweep=sweeps[r.file][0].to_dict())
                 if r.sweep is None and r.file in sweeps else r for r in dataset.runs)
    return dataclasses.replace(dataset, runs=runs)


def _by_run_intervals(identification) -> tuple:
    """The statistic fit's Jacobian intervals with each run's points as one observation (the
    channels of a run share its jump); the per-point ones when the fit has no runs."""
    fit = identification.fit
    if fit.kn_ci95_by_run is None:
        return tuple(identification.kn_ci95), tuple(identification.delta_ci95)
    return tuple(fit.kn_ci95_by_run), tuple(fit.delta_ci95_by_run)


def _bootstrap_by_replay(rep_ds, system, noise, *, theta, theta_rep, n, seed, fit_kwargs,
                         progress):
    """Percentile 95 % intervals of theta * theta_b / theta_rep over ``n`` noisy copies of the
    replay ``rep_ds`` (module docstring)."""
    import dataclasses

    from tqdm.auto import tqdm

    from .identification.pipeline import identify
    from .identification.result import IdentificationError

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
            fit = identify(copy, system=system, init=tuple(theta_rep), progress=False,
                           replay=False, **fit_kwargs)
        except IdentificationError:
            continue  # a copy whose noise hides a jump: it adds no sample
        samples.append(theta * np.array([fit.kn, fit.delta]) / theta_rep)
    if len(samples) < max(5, n // 2):
        return None, None
    arr = np.asarray(samples)
    lo, hi = np.percentile(arr, [2.5, 97.5], axis=0)
    return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))


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

"""Least-squares fit of the analytical backbone curve to resonance (jump) points: kn and delta.

Objective (DESIGN.md §1), over x = (ln kn, ln delta)::

    J(x) = sum_i ((f_BC(X_i; kn, delta) - f_i) / f_i)^2

where f_BC(X; kn, delta) is the backbone frequency at first-harmonic amplitude X of the point's
channel. Scale invariance makes this cheap: the curve of (kn, delta) is the curve of (kn, 1) with
amplitudes times delta, so f_BC(X; kn, delta) = f_BC(X / delta; kn, 1) and a change of delta needs
no new eigen-solutions. Curves are computed once per kn (cached) and interpolated in ln X.
Points whose amplitude lies outside the curve's range take the end value (the open-hinge or the
closed-hinge frequency), which keeps J continuous for any start.

Uncertainty: 95 % intervals from the Jacobian (Gauss-Newton covariance s^2 (J^T J)^-1 in the log
parameters, s^2 = RSS / (p - 2), t quantile) and, optionally, by bootstrap over the points.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize
import scipy.stats

from .backbone import amplitude_grid, dfa_backbone, hb_backbone
from .model import FreeplaySystem

__all__ = [
    "count_resonances",
    "FitResult",
    "BackboneModel",
    "fit_backbone",
    "multistart_grid",
    "ModeValidation",
    "validate_modes",
]

BACKBONES = ("dfa", "hb")


@dataclass(frozen=True)
class FitResult:
    """Identified (kn, delta) with uncertainty and diagnostics.

    Attributes
    ----------
    kn : float [N m/rad]
    delta : float [rad]
    kn_ci95, delta_ci95 : (float, float)
        95 % intervals from the Jacobian (Gauss-Newton), in the parameter's units.
    kn_ci95_bootstrap, delta_ci95_bootstrap : (float, float) or None
        95 % percentile intervals from a bootstrap over points (if requested).
    residuals : ndarray, shape (p,) [-]
        Relative frequency residual (f_BC - f) / f of each point at the optimum.
    residual_rms : float [-]
    n_points : int
    backbone : str
        "dfa" or "hb".
    init : str
        "multistart", "given" or "inverse".
    start : (float, float)
        Starting (kn, delta) of the winning run.
    n_evaluations : int
        Objective evaluations over all starts (the cost measure of the comparison studies).
    runtime_s : float [s]
    success : bool
    message : str
    starts : list of dict
        Every start's outcome (start, kn, delta, cost).
    """

    kn: float
    delta: float
    kn_ci95: tuple
    delta_ci95: tuple
    residuals: np.ndarray
    residual_rms: float
    n_points: int
    backbone: str
    init: str
    start: tuple
    n_evaluations: int
    runtime_s: float
    success: bool
    message: str
    kn_ci95_bootstrap: tuple | None = None
    delta_ci95_bootstrap: tuple | None = None
    starts: list = field(default_factory=list)


class BackboneModel:
    """Backbone frequencies f_BC(X; kn, delta) of one system, with per-kn curve caching.

    Parameters
    ----------
    system : FreeplaySystem
    channels : sequence of str
        DOF names the points are measured at.
    backbone : {"dfa", "hb"}
    s : ndarray, optional
        Grid of largest hinge amplitude / delta (default: 400 points from 1.0002 to 2000).
    mode : int
        Mode of the backbone (0: lowest).
    hb_harmonics : int
        Odd harmonics of the harmonic-balance backbone.
    equal_hinges : bool
        DFA with every hinge at the largest hinge's kappa (one eigen-batch per curve instead of a
        Newton solve): the cheap model of the multi-start phase.
    """

    def __init__(
        self,
        system: FreeplaySystem,
        channels: Sequence[str],
        *,
        backbone: str = "dfa",
        s: np.ndarray | None = None,
        mode: int = 0,
        hb_harmonics: int = 5,
        equal_hinges: bool = False,
    ) -> None:
        if backbone not in BACKBONES:
            raise ValueError(f"`backbone` must be one of {BACKBONES}, got {backbone!r}")
        missing = sorted(set(channels) - set(system.dof_names))
        if missing:
            raise ValueError(
                f"channels {missing} are not DOFs of the model (known: {list(system.dof_names)})"
            )
        self.system = system
        self.channels = tuple(dict.fromkeys(channels))
        self.index = [system.dof_names.index(c) for c in self.channels]
        self.backbone = backbone
        self.s = amplitude_grid(400, s_min=1.0002, s_max=2000.0) if s is None else np.asarray(s)
        self.mode = mode
        self.hb_harmonics = hb_harmonics
        self.equal_hinges = equal_hinges
        self._cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        self.n_curves = 0

    def curve(self, kn: float) -> tuple[np.ndarray, np.ndarray]:
        """(frequency (m,) [Hz], ln amplitude (m, c) at delta = 1) of the backbone for ``kn``."""
        key = float(kn)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        if self.backbone == "dfa":
            bc = dfa_backbone(
                self.system,
                kn=key,
                delta=1.0,
                mode=self.mode,
                s=self.s,
                equal_hinges=self.equal_hinges,
            )
        else:
            bc = hb_backbone(
                self.system,
                kn=key,
                delta=1.0,
                mode=self.mode,
                s=self.s,
                n_harmonics=self.hb_harmonics,
            )
        amp = bc.amplitude[0][:, self.index]
        with np.errstate(divide="ignore"):
            out = (bc.frequency_hz[0], np.log(amp))
        self.n_curves += 1
        if len(self._cache) > 512:
            self._cache.clear()
        self._cache[key] = out
        return out

    def frequency(self, amplitude, channel_index, kn: float, delta: float) -> np.ndarray:
        """Backbone frequency [Hz] at each point's amplitude [m]; shape (p,)."""
        freq, log_amp = self.curve(kn)
        x = np.log(np.asarray(amplitude, dtype=float) / delta)
        out = np.empty(x.shape)
        for c in range(len(self.channels)):
            sel = channel_index == c
            if np.any(sel):
                la = log_amp[:, c]
                ok = np.isfinite(la)
                if np.count_nonzero(ok) < 2:  # channel does not move in this mode at this kn
                    out[sel] = 0.0
                    continue
                order = np.argsort(la[ok])
                out[sel] = np.interp(x[sel], la[ok][order], freq[ok][order])
        return out


def multistart_grid(
    n: int = 5,
    *,
    kn_range: tuple[float, float] = (1e3, 1e8),
    delta_range: tuple[float, float] = (1e-4, 1e-2),
) -> list[tuple[float, float]]:
    """n x n log-uniform grid of (kn [N m/rad], delta [rad]) starts."""
    kns = np.geomspace(*kn_range, n)
    deltas = np.geomspace(*delta_range, n)
    return [(float(k), float(d)) for k in kns for d in deltas]


def _points_as_arrays(points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(channels (p,) str, amplitude (p,) [m], f_hz (p,)) from the accepted point formats."""
    if hasattr(points, "points"):  # freeplayid.signal.BackbonePoints
        points = points.points
    if isinstance(points, dict):
        ch, amp, f = points["channel"], points["amplitude"], points["f_hz"]
    elif hasattr(points, "channels") and hasattr(points, "amplitudes"):
        ch, amp, f = points.channels, points.amplitudes, points.frequencies
    else:
        rows = list(points)
        if rows and isinstance(rows[0], dict):
            rows = [r for r in rows if r.get("used", True)]
            ch = [r["channel"] for r in rows]
            amp = [r.get("amplitude", r.get("amplitude_m")) for r in rows]
            f = [r["f_hz"] for r in rows]
        else:
            rows = [r for r in rows if getattr(r, "used", True)]
            ch = [r.channel for r in rows]
            amp = [getattr(r, "amplitude", None) or r.amplitude_m for r in rows]
            f = [r.f_hz for r in rows]
    ch = np.asarray(ch, dtype=str).reshape(-1)
    amp = np.asarray(amp, dtype=float).reshape(-1)
    f = np.asarray(f, dtype=float).reshape(-1)
    if not (ch.size == amp.size == f.size):
        raise ValueError(
            f"points must have one channel, amplitude and frequency each, got "
            f"{ch.size}, {amp.size}, {f.size}"
        )
    if ch.size < 2:
        raise ValueError(f"at least 2 fitting points are needed for (kn, delta), got {ch.size}")
    bad = ~np.isfinite(amp) | ~np.isfinite(f) | (amp <= 0) | (f <= 0)
    if np.any(bad):
        raise ValueError(
            f"fitting points must have finite amplitude > 0 and frequency > 0; "
            f"bad points at indices {np.flatnonzero(bad).tolist()}"
        )
    return ch, amp, f


def count_resonances(f_hz, *, rel_tol: float = 5e-3) -> int:
    """Distinct resonance frequencies among points (the channels of one run share one).

    Points closer than ``rel_tol`` (relative) to their neighbour count as one resonance. The
    default, 0.5 %, covers the scatter between the channels of one noisy run (0.2 % measured on
    the bundled example's 1.0 g run) and stays below the spacing of the peaks of different
    levels (1-3 Hz at 40-50 Hz on the default fin).
    """
    f = np.sort(np.asarray(f_hz, dtype=float).reshape(-1))
    if f.size == 0:
        return 0
    return int(1 + np.count_nonzero(np.diff(f) > rel_tol * f[1:]))


def fit_backbone(
    points,
    system: FreeplaySystem,
    *,
    init: tuple[float, float] | Sequence[tuple[float, float]] | None = None,
    init_label: str | None = None,
    backbone: str = "dfa",
    mode: int = 0,
    n_bootstrap: int = 0,
    seed: int = 0,
    model: BackboneModel | None = None,
) -> FitResult:
    """Identify (kn, delta) by fitting the backbone curve of ``system`` to resonance points.

    Parameters
    ----------
    points : mapping, sequence of point records, or object with ``channels``, ``amplitudes``,
        ``frequencies``
        Fitting points: channel (DOF name), first-harmonic displacement amplitude [m] (relative
        to the base), frequency [Hz]. Records with ``used = False`` are skipped.
    system : FreeplaySystem
        The linear model (M, K, hinges).
    init : (kn, delta), list of them, or an inverse model, optional
        Start(s). Default: the multi-start baseline :func:`multistart_grid` (25 starts spanning
        kn in [1e3, 1e8] N m/rad and delta in [1e-4, 1e-2] rad); the best optimum wins.
        An object with ``predict_records(records) -> (kn, delta, ...)`` (a
        :class:`freeplayid.inverse.InverseModel`) gives one start from the points themselves
        (``init_label`` "inverse").
    init_label : str, optional
        What produced ``init`` ("inverse", "given"); recorded in the result.
    backbone : {"dfa", "hb"}
        Backbone model; "hb" refines from the DFA optimum (harmonic balance is ~100x dearer).
    n_bootstrap : int
        Bootstrap resamples of the points for percentile intervals (0: none).

    Returns
    -------
    FitResult
    """
    t0 = time.perf_counter()
    if not isinstance(system, FreeplaySystem):
        raise TypeError(f"`system` must be a FreeplaySystem, got {type(system).__name__}")
    if backbone not in BACKBONES:
        raise ValueError(f"`backbone` must be one of {BACKBONES}, got {backbone!r}")
    ch, amp, f = _points_as_arrays(points)
    if count_resonances(f) < 2:
        warnings.warn(
            f"fit_backbone: the {f.size} points lie at one resonance ({np.median(f):.3f} Hz): "
            "one (amplitude, frequency) pair does not fix both kn and delta; the result "
            "depends on the start. Add runs at other levels.",
            stacklevel=2,
        )
    if hasattr(init, "predict_records"):  # the neural inverse model: its estimate is the start
        records = [{"channel": c, "amplitude_m": a, "f_hz": q}
                   for c, a, q in zip(ch.tolist(), amp.tolist(), f.tolist(), strict=True)]
        init = tuple(float(v) for v in init.predict_records(records)[:2])
        init_label = init_label or "inverse"
    if init is None:
        starts, label = multistart_grid(), "multistart"
    else:
        arr = np.asarray(init, dtype=float)
        starts = [tuple(arr)] if arr.ndim == 1 else [tuple(r) for r in arr]
        label = init_label or ("given" if len(starts) == 1 else "multistart")
        for k0, d0 in starts:
            if not (np.isfinite(k0) and np.isfinite(d0) and k0 > 0 and d0 > 0):
                raise ValueError(f"`init` values must be finite and > 0, got {(k0, d0)!r}")

    dfa_model = model if (model is not None and model.backbone == "dfa") else None
    dfa_model = dfa_model or BackboneModel(system, ch, backbone="dfa", mode=mode)
    cidx = np.array([dfa_model.channels.index(c) for c in ch])
    evals = {"n": 0}

    def make_residual(bm):
        def residual(x):
            evals["n"] += 1
            kn, delta = np.exp(x)
            return (bm.frequency(amp, cidx, kn, delta) - f) / f

        return residual

    def solve(bm, x0):
        return scipy.optimize.least_squares(
            make_residual(bm),
            x0,
            method="lm",
            x_scale=1.0,
            xtol=1e-12,
            ftol=1e-12,
            diff_step=1e-7,
            max_nfev=400,
        )

    # Multi-start phase on the cheap equal-hinge DFA (one eigen-batch per curve, 200 points),
    # then the winner is polished on the consistent (unequal-hinge) DFA backbone.
    scout = dfa_model
    if len(starts) > 1 and system.n_hinges > 1:
        scout = BackboneModel(
            system,
            ch,
            backbone="dfa",
            mode=mode,
            equal_hinges=True,
            s=amplitude_grid(200, s_min=1.0005, s_max=2000.0),
        )
    runs = []
    for k0, d0 in starts:
        try:
            sol = solve(scout, np.log([k0, d0]))
        except ValueError:  # a start that runs off to kn or delta = inf/0 is a lost start
            continue
        runs.append((2 * sol.cost, sol, (k0, d0)))
    if not runs:
        raise ValueError(f"every start of the fit diverged (starts: {starts})")
    runs.sort(key=lambda r: r[0])
    _, sol, start = runs[0]
    if scout is not dfa_model:
        sol = solve(dfa_model, sol.x)
    active = dfa_model
    if backbone == "hb":
        active = BackboneModel(system, ch, backbone="hb", mode=mode)
        sol = solve(active, sol.x)

    p = ch.size
    res = sol.fun
    J = sol.jac
    dof = max(p - 2, 1)
    s2 = float(res @ res) / dof
    try:
        cov = s2 * np.linalg.inv(J.T @ J)
        half = scipy.stats.t.ppf(0.975, dof) * np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        half = np.array([np.inf, np.inf])
    kn, delta = np.exp(sol.x)
    kn_ci = (float(kn * np.exp(-half[0])), float(kn * np.exp(half[0])))
    delta_ci = (float(delta * np.exp(-half[1])), float(delta * np.exp(half[1])))

    boot_kn = boot_delta = None
    if n_bootstrap > 0:
        rng = np.random.default_rng(seed)
        est = []
        for _ in range(n_bootstrap):
            pick = rng.integers(0, p, p)
            if np.unique(pick).size < 2:
                continue

            def r_boot(x, pick=pick):
                evals["n"] += 1
                k, d = np.exp(x)
                return (active.frequency(amp[pick], cidx[pick], k, d) - f[pick]) / f[pick]

            bs = scipy.optimize.least_squares(r_boot, sol.x, method="lm", xtol=1e-10, ftol=1e-10)
            est.append(np.exp(bs.x))
        est = np.array(est)
        boot_kn = tuple(np.percentile(est[:, 0], [2.5, 97.5]).tolist())
        boot_delta = tuple(np.percentile(est[:, 1], [2.5, 97.5]).tolist())

    return FitResult(
        kn=float(kn),
        delta=float(delta),
        kn_ci95=kn_ci,
        delta_ci95=delta_ci,
        residuals=res,
        residual_rms=float(np.sqrt(np.mean(res**2))),
        n_points=p,
        backbone=backbone,
        init=label,
        start=tuple(float(v) for v in start),
        n_evaluations=evals["n"],
        runtime_s=time.perf_counter() - t0,
        success=bool(sol.success),
        message=str(sol.message),
        kn_ci95_bootstrap=boot_kn,
        delta_ci95_bootstrap=boot_delta,
        starts=[
            {"start": s_, "kn": float(np.exp(r.x[0])), "delta": float(np.exp(r.x[1])), "cost": c}
            for c, r, s_ in runs
        ],
    )


@dataclass(frozen=True)
class ModeValidation:
    """Zero-clearance (delta = 0) model vs reference modes (the paper's Table 11 check).

    Attributes
    ----------
    reference_hz, model_hz : ndarray, shape (m,) [Hz]
    error_hz : ndarray, shape (m,) [Hz]
        model - reference for each paired mode.
    mac : ndarray, shape (m,) [-]
    pairing : ndarray, shape (m,) of int
        Model mode index paired with each reference mode (by MAC).
    passed : bool
        All |error| < ``max_error_hz`` and all MAC > ``min_mac``.
    """

    reference_hz: np.ndarray
    model_hz: np.ndarray
    error_hz: np.ndarray
    mac: np.ndarray
    pairing: np.ndarray
    passed: bool

    def table(self) -> str:
        """Markdown table of the comparison."""
        rows = [
            "| mode | reference [Hz] | model [Hz] | error [Hz] | MAC |",
            "|---|---|---|---|---|",
        ]
        for i in range(self.reference_hz.size):
            rows.append(
                f"| {i + 1} | {self.reference_hz[i]:.2f} | {self.model_hz[i]:.2f} | "
                f"{self.error_hz[i]:+.2f} | {self.mac[i]:.4f} |"
            )
        return "\n".join(rows)


def validate_modes(
    system: FreeplaySystem,
    kn: float,
    reference_hz,
    reference_shapes,
    shape_dofs: Sequence[str],
    *,
    max_error_hz: float = 1.0,
    min_mac: float = 0.98,
) -> ModeValidation:
    """Compare the identified zero-clearance model (hinges closed at ``kn``) with reference modes.

    Parameters
    ----------
    system : FreeplaySystem
    kn : float [N m/rad]
        Identified contact stiffness.
    reference_hz : array_like, shape (m,) [Hz]
        Reference (e.g. hammer test of the sealed hinge) natural frequencies.
    reference_shapes : array_like, shape (len(shape_dofs), m)
        Reference mode shapes at ``shape_dofs``.
    shape_dofs : sequence of str
        Model DOF names of the rows of ``reference_shapes``.
    max_error_hz, min_mac : float
        Pass criteria (paper: < 1 Hz and MAC > 0.98).
    """
    from .model import modal_analysis, pair_modes

    ref_hz = np.asarray(reference_hz, dtype=float).reshape(-1)
    ref_phi = np.asarray(reference_shapes, dtype=float)
    if ref_phi.ndim != 2 or ref_phi.shape != (len(shape_dofs), ref_hz.size):
        raise ValueError(
            f"`reference_shapes` must have shape ({len(shape_dofs)}, {ref_hz.size}), "
            f"got {ref_phi.shape}"
        )
    idx = system.dof_index(list(shape_dofs))
    modes = modal_analysis(system.M, system.closed_stiffness(kn))
    pairing, macs = pair_modes(ref_phi, modes.shapes[idx, :])
    model_hz = np.where(pairing >= 0, modes.frequencies_hz[np.clip(pairing, 0, None)], np.nan)
    err = model_hz - ref_hz
    passed = bool(np.all(np.abs(err) < max_error_hz) and np.all(macs > min_mac))
    return ModeValidation(ref_hz, model_hz, err, macs, pairing, passed)

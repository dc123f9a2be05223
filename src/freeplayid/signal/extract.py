"""Backbone fitting points: first-harmonic displacement curves, resonance peak / jump detection.

For each run and channel: (optionally) subtract the base channel, extract the first harmonic
(ACMP or lock-in), convert the whole amplitude curve to displacement with Eq. 9,
``X = V / w = A / w^2`` with ``w = 2 pi f(t)`` the instantaneous frequency, and take its
maximum as the fitting point (f*, X*), or reject the run with a reason.

The jump rule and the rejection reasons are in :mod:`.jump`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..quantity import check_quantity
from .acmp import ChirpMode
from .jump import REASON_FAILED, REASON_NOISY, find_jump_peak, reason_dead
from .level import NARROW_BASE, quiet_phase
from .options import EXTRACTION_METHODS, Extraction, with_options
from .peak import JUMP_POINTS, NEEDS_BASE
from .sweeplaw import estimate_sweep
from .validate import check_positive, dead_channel

__all__ = [
    "BackbonePoint",
    "BackbonePoints",
    "AmplitudeCurve",
    "extract_backbone_points",
    "to_displacement",
    "noise_floor",
    "EXTRACTION_METHODS",
    "JUMP_POINTS",
]

# samples a run must keep after trimming `trim_s` at each end (the extractor's and the jump rule's
# minimum; a shorter run is rejected with its reason)
MIN_SAMPLES = 16
# the noise floor (BackbonePoint.noise_db): a low quantile of the residual's RMS over windows
NOISE_WINDOW_S = 1.0  # [s]
NOISE_FLOOR_QUANTILE = 0.2  # [-]
NOISE_DB_MIN = -80.0  # [dB] a noise-free record's floor (0.01 % of the point)


@dataclass(frozen=True)
class BackbonePoint:
    """One candidate fitting point (one run, one channel).

    Attributes
    ----------
    run, channel : str
    f_hz : float [Hz]
        Excitation frequency at the jump point (``jump_point="windowed"``: the sweep law, the
        hint's or the record's own from :func:`.sweeplaw.estimate_sweep`; ``"smoothed"``: the
        extracted instantaneous frequency at the curve's maximum).
    amplitude_m : float [m]
        First-harmonic displacement amplitude there (Eq. 9 applied before the maximum).
    used : bool
        False when rejected; ``f_hz`` and ``amplitude_m`` then describe the maximum found.
    reason : str
        Empty when used, else one of ``REASON_*``.
    time_s : float [s]
        Time of the maximum from the start of the record.
    snr_db : float [dB]
        SNR of the extracted mode against the residual (over the whole record: the jump's
        transient and the harmonics count as residual).
    noise_db : float [dB]
        The record's noise floor relative to the point: 20 log10 of the residual's floor (the
        :data:`NOISE_FLOOR_QUANTILE` quantile of its RMS over :data:`NOISE_WINDOW_S` windows,
        which the jump's transient and the harmonics near resonance do not reach) over the
        point's amplitude, both as displacement at the point's frequency; at least
        :data:`NOISE_DB_MIN` (a noise-free record). NaN where not measured.
    """

    run: str
    channel: str
    f_hz: float
    amplitude_m: float
    used: bool
    reason: str
    time_s: float
    snr_db: float
    noise_db: float = math.nan


@dataclass(frozen=True)
class AmplitudeCurve:
    """A first-harmonic displacement curve for figures (thinned to at most ``curve_points``).

    Attributes
    ----------
    run, channel : str
    frequency : ndarray, shape (M,) [Hz]
    amplitude_m : ndarray, shape (M,) [m]
    """

    run: str
    channel: str
    frequency: np.ndarray
    amplitude_m: np.ndarray


@dataclass(frozen=True)
class BackbonePoints:
    """Result of :func:`extract_backbone_points`.

    Attributes
    ----------
    points : tuple of BackbonePoint
        One per (run, channel), run-major, used or not.
    rejected_runs : tuple of str
        Runs none of whose channels gave a point.
    curves : tuple of AmplitudeCurve
        Same order as ``points``.
    quantity : str
    method : str
    """

    points: tuple[BackbonePoint, ...]
    rejected_runs: tuple[str, ...]
    curves: tuple[AmplitudeCurve, ...]
    quantity: str
    method: str

    def used(self, channel: str | None = None) -> tuple[BackbonePoint, ...]:
        """The used points (of one channel if given)."""
        return tuple(p for p in self.points if p.used and (channel is None or p.channel == channel))

    def arrays(self, channel: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Used points as arrays for a fit.

        Returns
        -------
        f_hz : ndarray, shape (P,) [Hz]
        amplitude_m : ndarray, shape (P,) [m]
        """
        used = self.used(channel)
        return (
            np.array([p.f_hz for p in used], dtype=float),
            np.array([p.amplitude_m for p in used], dtype=float),
        )

    def to_records(self) -> list[dict]:
        """JSON-ready dicts (run, channel, f_hz, amplitude_m, used, reason) for the result file."""
        return [
            {
                "run": p.run,
                "channel": p.channel,
                "f_hz": p.f_hz,
                "amplitude_m": p.amplitude_m,
                "used": p.used,
                "reason": p.reason,
            }
            for p in self.points
        ]


def to_displacement(amplitude, frequency, quantity: str) -> np.ndarray:
    """Eq. 9: first-harmonic displacement amplitude ``X = V / w = A / w^2``, w = 2 pi f.

    Parameters
    ----------
    amplitude : array_like, shape (..., N) [m, m/s or m/s^2]
    frequency : array_like, shape (..., N) [Hz], > 0
    quantity : {"displacement", "velocity", "acceleration"}

    Returns
    -------
    ndarray, shape (..., N) [m]
    """
    order = check_quantity(quantity).order
    w = 2 * np.pi * np.asarray(frequency, dtype=float)
    return np.asarray(amplitude, dtype=float) / w**order


def _as_runs(signals, name: str) -> list[np.ndarray]:
    if isinstance(signals, np.ndarray) or not isinstance(signals, Sequence):
        a = np.asarray(signals, dtype=float)
        if a.ndim != 3:
            raise ValueError(
                f"`{name}` must have shape (runs, channels, T) or be a list of "
                f"(channels, T) arrays, got shape {a.shape}"
            )
        return list(a)
    runs = [np.asarray(r, dtype=float) for r in signals]
    for i, r in enumerate(runs):
        if r.ndim != 2:
            raise ValueError(f"`{name}[{i}]` must have shape (channels, T), got {r.shape}")
    return runs


def extract_backbone_points(
    signals,
    sample_rate: float,
    *,
    quantity: str,
    channel_names: Sequence[str] | None = None,
    run_names: Sequence[str] | None = None,
    sweep=None,
    base=None,
    base_name: str = "base",
    extraction: Extraction | None = None,
    **options,
) -> BackbonePoints:
    """Backbone fitting points (resonance peak / jump) of every channel of every sweep run.

    Parameters
    ----------
    signals : ndarray, shape (runs, channels, T), or list of ndarray, shape (channels, T_r)
        Responses in SI units of ``quantity`` (m, m/s, m/s^2); runs may differ in length.
    sample_rate : float [Hz]
    quantity : {"displacement", "velocity", "acceleration"}
    channel_names, run_names : sequence of str, optional
        Default "ch0", "ch1", ... and "run0", "run1", ...
    sweep : Sweep or sequence of Sweep (one per run), optional
        Sweep hint (sample 0 at the sweep's t = 0): initial frequency of ACMP, the band, the
        rate. Required by ``method="lockin"``.
    base : ndarray, shape (runs, T), or list of ndarray, shape (T_r,), optional
        Base (control) channel in the same quantity; subtracted from every channel first, so
        absolute motion becomes motion relative to the base.
    base_name : str
        The base channel's name in rejection reasons (a data set's ``base_channel``).
    extraction : Extraction, optional
        The options (:class:`Extraction`: method, bandwidth, trim, jump rule, jump point, SNR
        floor, curve points); default ``Extraction()``.
    **options
        Fields of :class:`Extraction` to replace (``method="lockin"``, ``jump_point="drop"``).

    The bandwidth (``bandwidth_hz`` None) is ``max(1 Hz, 2 s x |sweep rate|)``: the hint's
    rate, else the record's own law from :func:`estimate_sweep` (the median rate of a log
    sweep), narrow enough to keep the noise bias of the maximum small, wide enough to follow the
    drop after the peak without overshoot. The jump point (:mod:`.peak`): "smoothed" (default)
    the maximum of the extractor's smoothed curve at its instantaneous frequency (the filter
    overshoots ahead of the drop: up to 0.2 Hz late, 0.4-2.7 % high on
    benchmarks/jump_point.py); "windowed" the maximum of a Gaussian-weighted least-squares
    first harmonic of the raw record, which cannot overshoot, at the excitation frequency
    there; "drop" where the curve drops (docs/signal.md, section 6).

    Returns
    -------
    BackbonePoints
        A run's own problem rejects its points with the reason instead of raising: a run too
        short for ``trim_s`` (:data:`MIN_SAMPLES` must remain), a ``sweep`` hint that does not
        fit the record (:meth:`freeplayid.sweep.Sweep.record_mismatch`), a dead base channel
        (the whole run), a dead channel (that channel's point; :func:`.validate.dead_channel`).
    """
    check_quantity(quantity)
    opts = with_options(extraction, options)
    fs = check_positive(sample_rate, "sample_rate")
    runs = _as_runs(signals, "signals")
    channel_names, run_names = _names(runs, channel_names, run_names)
    sweeps = _sweeps(sweep, len(runs))
    if opts.method == "lockin" and any(s is None for s in sweeps):
        raise ValueError("`method='lockin'` needs the sweep law: pass `sweep`")
    bases = _bases(base, runs)
    if opts.jump_point in NEEDS_BASE and bases is None:
        raise ValueError(f"`jump_point={opts.jump_point!r}` needs the base channel (its phase is "
                         "the reference): pass `base`")
    points, curves = [], []
    for i, run in enumerate(runs):
        got = _run_points(run, fs, run_names[i], channel_names, sweep=sweeps[i],
                          base=None if bases is None else bases[i], base_name=base_name,
                          opts=opts, quantity=quantity)
        points += [p for p, _ in got]
        curves += [c for _, c in got]
    rejected = tuple(r for r in run_names if not any(p.used for p in points if p.run == r))
    return BackbonePoints(tuple(points), rejected, tuple(curves), quantity, opts.method)


def _names(runs, channel_names, run_names) -> tuple[list[str], list[str]]:
    """The channel and run names, checked against the signals' shapes."""
    n_runs = len(runs)
    if n_runs == 0:
        raise ValueError("`signals` holds no run")
    n_ch = runs[0].shape[0]
    if any(r.shape[0] != n_ch for r in runs):
        raise ValueError(
            f"every run must have the same number of channels, got {[r.shape[0] for r in runs]}"
        )
    if channel_names is None:
        channel_names = [f"ch{i}" for i in range(n_ch)]
    if run_names is None:
        run_names = [f"run{i}" for i in range(n_runs)]
    channel_names, run_names = [str(c) for c in channel_names], [str(r) for r in run_names]
    if len(channel_names) != n_ch:
        raise ValueError(f"`channel_names` must have {n_ch} names, got {len(channel_names)}")
    if len(run_names) != n_runs:
        raise ValueError(f"`run_names` must have {n_runs} names, got {len(run_names)}")
    return channel_names, run_names


def _sweeps(sweep, n_runs: int) -> list:
    """One sweep law (or None) per run."""
    if sweep is None or hasattr(sweep, "phase"):
        return [sweep] * n_runs
    sweeps = list(sweep)
    if len(sweeps) != n_runs:
        raise ValueError(f"`sweep` must be one Sweep or {n_runs} of them, got {len(sweeps)}")
    return sweeps


def _bases(base, runs) -> list | None:
    """The base channel of each run (None without one), checked against the runs' lengths."""
    if base is None:
        return None
    bases = [np.asarray(b, dtype=float) for b in base]
    if len(bases) != len(runs):
        raise ValueError(f"`base` must hold {len(runs)} runs, got {len(bases)}")
    for i, (b, r) in enumerate(zip(bases, runs, strict=True)):
        if b.shape != r.shape[1:]:
            raise ValueError(f"`base[{i}]` must have shape {r.shape[1:]}, got {b.shape}")
    return bases


def _run_reason(run, fs, *, trim, opts, sweep, base, base_name, quantity) -> str:
    """Why a whole run cannot give points ("" when it can): too short, a hint that does not
    fit it, a dead base channel."""
    n = run.shape[1]
    if n - 2 * trim < MIN_SAMPLES:
        return (
            f"run too short for the extraction: {n} samples ({n / fs:.4g} s at {fs:g} Hz) "
            f"leave {max(n - 2 * trim, 0)} after trimming `trim_s`={opts.trim_s:g} s at each "
            f"end; at least {MIN_SAMPLES} are needed"
        )
    if sweep is not None:
        why = sweep.record_mismatch(n, fs)
        if why:
            return why
    if base is not None:
        why = dead_channel(base, list(run), quantity=quantity)
        if why:
            return f"base channel {base_name} is dead ({why}): it cannot be subtracted"
    return ""


def _run_points(run, fs, run_name, channel_names, *, sweep, base, base_name, opts, quantity):
    """(point, curve) of every channel of one run; a run's or a channel's own problem rejects
    its points with the reason, never the batch."""
    nan = float("nan")
    trim = int(round(opts.trim_s * fs))
    run_reason = _run_reason(run, fs, trim=trim, opts=opts, sweep=sweep, base=base,
                             base_name=base_name, quantity=quantity)
    out = []
    n_ch = run.shape[0]
    base_phase = None
    if opts.jump_point in NEEDS_BASE and not run_reason:
        try:
            base_phase = _base_phase(base, fs, trim=trim, sweep=sweep, opts=opts,
                                     quantity=quantity)
        except (np.linalg.LinAlgError, _ExtractionError) as e:
            run_reason = f"{REASON_FAILED}: the base channel {base_name}: {e}"
    for j in range(n_ch):
        names = (run_name, channel_names[j])
        reason = run_reason or reason_dead(channel_names[j], dead_channel(
            run[j], [run[k] for k in range(n_ch) if k != j]
            + ([base] if base is not None else []), quantity=quantity))
        if reason:
            out.append((BackbonePoint(*names, nan, nan, False, reason, nan, nan),
                        AmplitudeCurve(*names, np.empty(0), np.empty(0))))
            continue
        x = run[j] - base if base is not None else run[j]
        try:
            out.append(_channel_point(x, fs, names, sweep=sweep, trim=trim, opts=opts,
                                      quantity=quantity, base_phase=base_phase))
        except (np.linalg.LinAlgError, _ExtractionError) as e:
            # one bad channel (no sweep in it, a failed solve) does not stop the batch
            out.append((BackbonePoint(*names, nan, nan, False, f"{REASON_FAILED}: {e}", nan, nan),
                        AmplitudeCurve(*names, np.empty(0), np.empty(0))))
    return out


def _linear_law(t, f, weight):
    """The straight line through the instantaneous frequency ``f(t)`` (a linear sweep's law).

    Least squares weighted by ``weight`` (the mode's amplitude: the noise-dominated in-gap part
    counts little), with two robust re-weightings so the transients after a jump, where the
    response leaves the excitation's frequency for a few cycles, do not pull it.
    """
    w = np.asarray(weight, dtype=float)
    coef = np.polyfit(t, f, 1, w=np.sqrt(w))
    for _ in range(2):
        r = f - np.polyval(coef, t)
        scale = 1.4826 * np.median(np.abs(r)) + 1e-12
        coef = np.polyfit(t, f, 1, w=np.sqrt(w / (1.0 + (r / (2 * scale)) ** 2)))
    return np.poly1d(coef)


class _ExtractionError(Exception):
    """A channel that cannot be processed (reported as a rejected point, not raised)."""


def _sweep_band(x, fs, n, sl, ti, *, sweep, run_opts, quantity):
    """The sweep law (or None), each analysed sample's rate [Hz/s] and the swept band [Hz].

    Output-only: without a hint (and without a given ``init_freq``) the record's own law (linear
    or log, :func:`estimate_sweep`) gives the rate, the band and ACMP's start, written into
    ``run_opts``.
    """
    law = sweep
    if law is None and "init_freq" not in run_opts:
        try:
            law = estimate_sweep(x, fs, fmin=2.0, quantity=quantity).sweep
        except ValueError as exc:
            raise _ExtractionError(f"no sweep found in the record ({exc})") from None
        run_opts["init_freq"] = law.frequency(np.arange(n) / fs)
    if law is not None:
        rate = law.rate(ti)  # df/dt [Hz/s] per sample: a log sweep's varies
        return law, rate, (float(law.frequency(ti[0])), float(law.frequency(ti[-1])))
    f_init = np.broadcast_to(np.asarray(run_opts["init_freq"], dtype=float), (n,))
    rate = np.full(ti.shape, (f_init[sl][-1] - f_init[sl][0]) / (ti[-1] - ti[0]))
    if not np.isfinite(rate[0]) or rate[0] == 0:
        raise _ExtractionError("the initial frequency is not a sweep (pass `sweep`)")
    return None, rate, (float(f_init[sl][0]), float(f_init[sl][-1]))


def _first_harmonic(x, fs, *, trim, sweep, opts: Extraction, quantity, band_scale=1.0):
    """(mode, law, rate [Hz/s] per analysed sample, band [Hz], bandwidth [Hz]) of one record;
    ``band_scale`` scales the bandwidth the mode is extracted over (not the one returned)."""
    n = x.shape[0]
    if np.ptp(x) == 0:
        raise _ExtractionError("constant signal")
    sl = slice(trim, n - trim)
    ti = np.arange(n)[sl] / fs
    run_opts = dict(opts.options)
    law, rate, band = _sweep_band(x, fs, n, sl, ti, sweep=sweep, run_opts=run_opts,
                                  quantity=quantity)
    bw = max(1.0, 2.0 * float(np.median(np.abs(rate)))) if opts.bandwidth_hz is None \
        else opts.bandwidth_hz
    mode: ChirpMode = EXTRACTION_METHODS[opts.method](x, fs, sweep=sweep,
                                                      bandwidth_hz=band_scale * bw, **run_opts)
    return mode, law, rate, band, bw


def _base_phase(base, fs, *, trim, sweep, opts: Extraction, quantity) -> np.ndarray:
    """The base channel's first-harmonic phase [rad] at every sample (the quadrature rule's
    reference), extracted as the responses are, over the band the replay's excitation is read
    over and read as it is (:func:`.level.quiet_phase`: a quarter of the responses' band where
    the base is noisy, its phase then read against the sweep law where it follows it)."""
    (wide, law, *_), (narrow, *_) = (_first_harmonic(base, fs, trim=trim, sweep=sweep, opts=opts,
                                                     quantity=quantity, band_scale=scale)
                                     for scale in (1.0, NARROW_BASE))
    return quiet_phase(wide, narrow, law, fs)


def noise_floor(residual, fs: float) -> float:
    """The noise floor of a residual record (record minus its first harmonic) [its units]: the
    :data:`NOISE_FLOOR_QUANTILE` quantile of its RMS over windows of :data:`NOISE_WINDOW_S`.

    White noise is the same in every window; what the first harmonic misses near resonance
    (the jump's transient, the harmonics of the contact) is confined to a few, so a low quantile
    reads the noise alone: 0.096-0.102 g for 0.1 g of noise and 0.287-0.294 g for 0.3 g on the
    noise study's records, where the residual's whole RMS reads up to 0.17 g and 0.42 g. A
    record shorter than one window: the RMS of all of it.
    """
    r = np.asarray(residual, dtype=float)
    w = max(int(round(NOISE_WINDOW_S * fs)), 1)
    k = r.shape[0] // w
    if k < 1:
        return float(np.sqrt(np.mean(r ** 2))) if r.size else math.nan
    rms = np.sqrt(np.mean(r[: k * w].reshape(k, w) ** 2, axis=1))
    return float(np.quantile(rms, NOISE_FLOOR_QUANTILE))


def _channel_point(x, fs, names, *, sweep, trim, opts: Extraction, quantity,
                   base_phase=None) -> tuple[BackbonePoint, AmplitudeCurve]:
    """Fitting point and thinned curve of one channel of one run (see extract_backbone_points)."""
    n = x.shape[0]
    sl = slice(trim, n - trim)
    ti = np.arange(n)[sl] / fs
    mode, law, rate, band, bw = _first_harmonic(x, fs, trim=trim, sweep=sweep, opts=opts,
                                                quantity=quantity)
    fi = mode.frequency[sl]
    # the first harmonic lives in the swept band; keep a wild IF (noise, after a jump) from
    # blowing up X = A / w^2
    lo, hi = min(band), max(band)
    def clip(f):
        return np.clip(f, 0.5 * lo, 2.0 * hi)

    xi = to_displacement(mode.amplitude[sl], clip(fi), quantity)
    # the jump rule's widths [Hz] at the sweep's rate where the curve peaks (a log sweep's rate
    # varies along the record)
    peak_rate = float(rate[int(np.argmax(np.where(np.isfinite(xi), xi, -np.inf)))])
    k, reason = find_jump_peak(ti, fi, xi, sweep_rate=peak_rate, band=band,
                               jump_ratio=opts.jump_ratio, jump_width_hz=opts.jump_width_hz,
                               jump_asymmetry=opts.jump_asymmetry, edge_hz=opts.edge_hz,
                               require_jump=opts.require_jump)
    if mode.snr_db < opts.min_snr_db:
        reason = REASON_NOISY
    kp, xp = JUMP_POINTS[opts.jump_point](
        k, x=x, fs=fs, mode=mode, trim=trim, xi=xi, ratio=opts.jump_ratio,
        bandwidth_hz=bw, to_disp=lambda a, f: to_displacement(a, f, quantity), clip=clip,
        steep_after=peak_rate > 0, base_phase=base_phase, window=opts.drop_window,
    )
    t_point = float(np.interp(kp, np.arange(ti.shape[0]), ti))  # "drop": a fractional index
    if xp is None:  # the smoothed curve's own maximum and frequency
        f_point, xp = float(fi[kp]), float(xi[kp])
    elif law is not None:  # the hint, else the record's own law (estimate_sweep)
        f_point = float(law.frequency(t_point))
    else:  # a given `init_freq`: the straight line through the response's frequency
        f_point = float(_linear_law(ti, fi, mode.amplitude[sl])(t_point))
    noise = noise_floor(x[sl] - mode.mode[sl], fs)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = float(to_displacement(noise, f_point, quantity)) / float(xp)
    noise_db = (math.nan if not (math.isfinite(rel) and rel >= 0) else
                max(20.0 * math.log10(max(rel, 1e-300)), NOISE_DB_MIN))
    point = BackbonePoint(
        run=names[0],
        channel=names[1],
        f_hz=f_point,
        amplitude_m=xp,
        used=reason == "",
        reason=reason,
        time_s=t_point,
        snr_db=mode.snr_db,
        noise_db=noise_db,
    )
    step = max(1, xi.shape[0] // opts.curve_points)
    return point, AmplitudeCurve(*names, fi[::step].copy(), xi[::step].copy())

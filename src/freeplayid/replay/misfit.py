"""The self-check: measured against replayed amplitude-frequency curves."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

__all__ = ["ImpliedLevel", "RunMisfit", "curve_misfit", "implied_levels", "offset_noise",
           "resonance_misfits", "run_misfits"]


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


def run_misfits(measured_curves, replayed_curves, runs) -> dict:
    """Per run of ``runs``: the largest :func:`curve_misfit` over its channels' measured and
    replayed curves (matched by run and channel)."""
    replayed = {(c.run, c.channel): c for c in replayed_curves}
    out: dict[str, float] = {}
    for c in measured_curves:
        r = replayed.get((c.run, c.channel))
        if r is not None and c.run in runs:
            out[c.run] = max(out.get(c.run, 0.0), curve_misfit(c, r))
    return out


@dataclass(frozen=True)
class RunMisfit:
    """How far one run's replay at the answer misses the test, where the information lies.

    Attributes
    ----------
    run : str
    f_offset : float [-]
        The replayed statistic point's frequency over the measured one, minus 1 (median over the
        run's channels): a jump 0.7 Hz late at 40 Hz is +0.0175.
    f_hz : float [Hz]
        The measured point's frequency (median over the channels).
    backbone_offset : float [-]
        The replayed point's relative distance from the backbone at the answer, minus the
        measured point's (f / f_BC(X) - 1 each; median over the channels): what the fit sees. A
        point that moves along the backbone (another damping puts the phase resonance at another
        amplitude) has none.
    peak_offset : float [-]
        The replayed curve's peak over the measured one, minus 1 (the run's strongest channel).
    branch : float [-]
        Median |X_replayed - X_measured| over the measured curve's upper branch (from where it
        rises through half its peak to the point), relative to the peak.
    offset_se : float [-]
        The standard error of ``backbone_offset`` from the measurement's noise, one for all
        runs: the noiseless replay's point against the same replay read through the test's
        noise (:func:`offset_noise`, noisy copies), measured where some run's offset is large
        enough to matter (NaN where it was not measured).
    channel_spread, channel_spread_replayed : float [-]
        The spread of the run's channels' point frequencies, (max - min) / mean, measured and
        replayed (absolute accelerations without a base channel spread by a few % through the
        base motion each channel adds: the replay reproduces that, a faulty channel it does not).
    """

    run: str
    f_offset: float
    f_hz: float
    backbone_offset: float
    peak_offset: float
    branch: float
    offset_se: float = float("nan")
    channel_spread: float = float("nan")
    channel_spread_replayed: float = float("nan")
    offset_se_samples: int = 0
    without: tuple | None = None

    def to_dict(self) -> dict:
        return {"run": self.run, "f_offset": self.f_offset, "f_hz": self.f_hz,
                "backbone_offset": self.backbone_offset, "peak_offset": self.peak_offset,
                "branch": self.branch, "offset_se": self.offset_se,
                "channel_spread": self.channel_spread,
                "channel_spread_replayed": self.channel_spread_replayed,
                "offset_se_samples": self.offset_se_samples,
                "without": None if self.without is None else list(self.without)}


def _upper_branch(curve, f_point: float) -> np.ndarray:
    """Indices of ``curve`` on its upper branch: the lobe around its peak (at or above half the
    peak) on the point's side away from the jump: from the lobe's start up to the point on an
    up-sweep, from the point (the jump-up) to the lobe's end on a down-sweep."""
    if np.count_nonzero(np.isfinite(curve.amplitude_m) & np.isfinite(curve.frequency)) < 4:
        return np.zeros(0, dtype=int)
    x, f, k, low = _peak(curve)
    start = int(low[low < k][-1]) + 1 if np.any(low < k) else 0
    stop = int(low[low > k][0]) if np.any(low > k) else x.shape[0]
    lobe = np.arange(start, stop)
    j = int(lobe[np.argmin(np.abs(f[lobe] - f_point))])
    return np.arange(start, j + 1) if f[-1] > f[0] else np.arange(j, stop)


def resonance_misfits(measured_points, replayed_points, measured_curves, replayed_curves,
                      backbone_f=None) -> dict[str, RunMisfit]:
    """Per run: the replayed statistic point's frequency (and its distance from the backbone),
    the replayed curve's peak and its upper branch against the measured ones
    (:class:`RunMisfit`), for the runs found in both. ``backbone_f(point)``: the backbone's
    frequency [Hz] at the point's amplitude and channel (None: no backbone offsets)."""
    rep = {(p.run, p.channel): p for p in replayed_points}
    curves = {(c.run, c.channel): c for c in measured_curves}
    rcurves = {(c.run, c.channel): c for c in replayed_curves}
    by_run: dict[str, list] = {}
    for p in measured_points:
        q = rep.get((p.run, p.channel))
        c, r = curves.get((p.run, p.channel)), rcurves.get((p.run, p.channel))
        if q is None or c is None or r is None or not c.amplitude_m.size or not r.amplitude_m.size:
            continue
        peak = float(np.nanmax(c.amplitude_m))
        idx = _upper_branch(c, p.f_hz)
        branch = float("nan")
        if idx.size >= 2:
            xr = _at(r, c.frequency[idx])
            branch = float(np.median(np.abs(xr - c.amplitude_m[idx])) / peak)
        dist, dist_rep = float("nan"), float("nan")
        if backbone_f is not None:
            dist, dist_rep = p.f_hz / backbone_f(p) - 1, q.f_hz / backbone_f(q) - 1
        by_run.setdefault(p.run, []).append(_Channel(
            p.f_hz, q.f_hz, peak, float(np.nanmax(r.amplitude_m)) / peak - 1, branch, dist,
            dist_rep))

    def median(rows, value):
        return float(np.median([value(ch) for ch in rows]))

    out = {}
    for run, rows in by_run.items():
        strongest = max(rows, key=lambda ch: ch.peak)
        out[run] = RunMisfit(
            run, median(rows, lambda ch: ch.f_rep / ch.f - 1), median(rows, lambda ch: ch.f),
            median(rows, lambda ch: ch.dist_rep - ch.dist), strongest.peak_offset,
            strongest.branch, float("nan"), _spread([ch.f for ch in rows]),
            _spread([ch.f_rep for ch in rows]))
    return out


class _Channel(NamedTuple):
    """One channel's measured (``f``, ``dist``) and replayed (``f_rep``, ``dist_rep``) point
    frequency [Hz] and distance from the backbone [-], its measured peak [m], the replayed
    peak's relative offset and the upper branch's misfit (:class:`RunMisfit`)."""

    f: float
    f_rep: float
    peak: float
    peak_offset: float
    branch: float
    dist: float
    dist_rep: float


def _spread(f) -> float:
    """(max - min) / mean of one run's channel frequencies (NaN for one channel)."""
    f = np.asarray(f, float)
    return float((f.max() - f.min()) / f.mean()) if f.size > 1 else float("nan")


def offset_noise(replayed_points, copies, backbone_f) -> tuple[float, int]:
    """(standard error, samples) of a run's point distance from the backbone from the test's
    noise: for each noisy copy of the answer's replay (``copies``: each copy's used points) and
    run, the median over its channels of the copy's point's relative distance from the backbone
    (``backbone_f``, as in :func:`resonance_misfits`) less the noiseless replay's; their RMS over
    the copies and runs. The replay is the test's model at the answer, so what the copies scatter
    by is the noise alone, which the measured point carries and the noiseless replay does not:
    the noise of :attr:`RunMisfit.backbone_offset`. NaN with fewer than two samples."""
    ref = {(p.run, p.channel): p.f_hz / backbone_f(p) - 1 for p in replayed_points}
    devs = []
    for points in copies:
        by_run: dict[str, list] = {}
        for p in points:
            r = ref.get((p.run, p.channel))
            if r is not None:
                by_run.setdefault(p.run, []).append(p.f_hz / backbone_f(p) - 1 - r)
        devs += [float(np.median(d)) for d in by_run.values()]
    if len(devs) < 2:
        return float("nan"), len(devs)
    return float(np.sqrt(np.mean(np.square(devs)))), len(devs)


@dataclass(frozen=True)
class ImpliedLevel:
    """The level error one run's upper branches imply at the answer (:func:`implied_levels`).

    Attributes
    ----------
    error : float [-]
        The relative level error, pooled over the run's channels: the replay at level_g x
        (1 + error) reproduces the measured upper branches best.
    rest : float [-]
        The strongest channel's branch misfit that no constant level explains (median, relative
        to its peak).
    channels : dict str -> float [-]
        Each channel's own level error, over the frequencies all the run's channels share.
    """

    error: float
    rest: float
    channels: dict

    @property
    def spread(self) -> float:
        """How far apart the channels' own level errors lie (max - min; 0 for one channel)."""
        v = list(self.channels.values())
        return float(max(v) - min(v)) if v else 0.0

    def to_dict(self) -> dict:
        return {"error": self.error, "rest": self.rest, "channels": dict(self.channels),
                "spread": self.spread}


def implied_levels(measured_points, measured_curves, replayed_curves, raised_curves,
                   u: float) -> dict[str, ImpliedLevel]:
    """Per run: the relative level error its upper branches imply (:class:`ImpliedLevel`).

    ``replayed_curves`` are the answer's replay, ``raised_curves`` the same replay at the
    levels times (1 + ``u``). On each channel's measured upper branch (the lobe's side of the
    run's jump, the median frequency of its ``measured_points``, as :attr:`RunMisfit.branch`)
    short of the jump (:func:`_short_of_jump`), d = X_measured - X_replayed and g = X_raised -
    X_replayed: the level error e (relative, to first order in the level) is the least-squares
    fit of d by (e / u) g, pooled over the run's channels; the rest, median |d - (e / u) g|
    over the strongest channel's branch relative to its peak, is what a constant level does not
    reproduce. Each channel's own e, over the frequencies all its channels share, tells whether
    one level explains them all: a level scales the excitation of every channel alike, while a
    replay of another structure (another kn, damping of another form) misses their ratio. Runs
    without such a branch, or whose replay does not move with the level there, are left out.
    """
    curves = {(c.run, c.channel): c for c in measured_curves}
    rep = {(c.run, c.channel): c for c in replayed_curves}
    up = {(c.run, c.channel): c for c in raised_curves}
    jumps: dict[str, list] = {}
    for p in measured_points:
        jumps.setdefault(p.run, []).append(p.f_hz)
    by_run: dict[str, list] = {}
    for (run, channel), c in curves.items():
        r, q = rep.get((run, channel)), up.get((run, channel))
        if run not in jumps or r is None or q is None or not (
                c.amplitude_m.size and r.amplitude_m.size and q.amplitude_m.size):
            continue
        idx = _short_of_jump(c, _upper_branch(c, float(np.median(jumps[run]))), (r, q))
        if idx.size < 2:
            continue
        f = c.frequency[idx]
        x_rep = _at(r, f)
        by_run.setdefault(run, []).append(
            (channel, f, c.amplitude_m[idx] - x_rep, _at(q, f) - x_rep,
             float(np.nanmax(c.amplitude_m))))
    out = {}
    for run, rows in by_run.items():
        gg = sum(float(np.dot(g, g)) for _, _, _, g, _ in rows)
        if not gg > 0:
            continue
        a = sum(float(np.dot(d, g)) for _, _, d, g, _ in rows) / gg  # in units of u
        _, _, d, g, peak = max(rows, key=lambda row: row[4])
        lo = max(f.min() for _, f, _, _, _ in rows)
        hi = min(f.max() for _, f, _, _, _ in rows)
        own = {}
        for channel, f, d, g, _ in rows:
            shared = (f >= lo) & (f <= hi)
            if np.count_nonzero(shared) >= 2 and np.dot(g[shared], g[shared]) > 0:
                own[channel] = float(u * np.dot(d[shared], g[shared])
                                     / np.dot(g[shared], g[shared]))
        out[run] = ImpliedLevel(float(u * a), float(np.median(np.abs(d - a * g)) / peak), own)
    return out


def _short_of_jump(curve, idx: np.ndarray, others) -> np.ndarray:
    """The indices ``idx`` of ``curve``'s upper branch that lie short of every curve's jump
    (``curve`` and ``others``, a replay of it): below the lowest of their peaks' frequencies
    (the upper branch of a hardening freeplay lies below its jump, up- or down-sweep) by the
    width of ``curve``'s own jump edge (its peak to half of it, on the jump's side), over which
    the extraction smears the jump. Near a jump a replay's edge 0.01 Hz off the test's differs
    by half the peak, which says nothing about the level."""
    if idx.size == 0:
        return idx
    x, f, k, low = _peak(curve)
    edge = low[low > k] if f[-1] > f[0] else low[low < k][::-1]  # the jump's side
    if edge.size == 0:
        return idx[:0]
    guard = abs(f[edge[0]] - f[k])
    peaks = [f[k]] + [float(np.asarray(o.frequency)[np.nanargmax(o.amplitude_m)])
                      for o in others]
    return idx[f[idx] < min(peaks) - guard]


def _peak(curve) -> tuple[np.ndarray, np.ndarray, int, np.ndarray]:
    """``curve``'s amplitudes and frequencies, the index of its peak and the indices below half
    of it (or not finite): what bounds the lobe around the peak."""
    x = np.asarray(curve.amplitude_m, float)
    f = np.asarray(curve.frequency, float)
    ok = np.isfinite(x) & np.isfinite(f)
    k = int(np.argmax(np.where(ok, x, -np.inf)))
    return x, f, k, np.nonzero(~ok | (x < 0.5 * x[k]))[0]


def _at(curve, f) -> np.ndarray:
    """``curve``'s amplitude interpolated at the frequencies ``f`` (its track sorted)."""
    order = np.argsort(curve.frequency)
    return np.interp(f, curve.frequency[order], curve.amplitude_m[order])

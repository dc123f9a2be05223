"""Units of acceleration data (g or m/s^2) against each run's ``level_g``.

With a base channel: its first-harmonic amplitude (median over the record) is the level. A ratio
to ``level_g`` beyond ``units_factor`` (2) either way is reported ``suspect``, naming the units
error (9.81, 1 / 9.81, 1000, 1 / 1000) within that factor of it (the test of the verdict's
``base_level``, here before the identification).

Without a base channel only a lower bound is physical. A response's first harmonic over the
base's is the transmissibility ``|r_j + H_j(f)|`` (absolute records) or ``|H_j(f)|`` (relative
ones) of the model with its hinge springs at some stiffness k between open and rigid (wherever
the hinge amplitude puts the describing function). The smallest of both over all k,
``L_j(f)``, is a floor for channel j at any time of the sweep (0.2-0.55 at the default fin's
tip over 30-46.5 Hz; a DOF with an anti-resonance in that range has a floor near 0). Only the
times where the floor is 0.1 or more count, and a channel needs a fifth of the record there.
The measured first harmonic over ``level_g x L_j(f(t))`` must reach ``1 / units_factor`` over
most of the record: its 5th percentile is the statistic (the in-gap stretches and the lower
branch after a jump come close to the floor: 1.00-1.01 on the bundled example; a resonance
stands far above it). When most channel records stay below, the values read too small
(0.10-0.25 for g data declared as m/s^2, which gave delta -89 %): ``suspect``, naming the
smallest units error that lifts them all above the bound.

No upper bound exists: a resonance at the sweep's start, light damping or a small gap make any
amplitude possible, so m/s^2 data declared as g (values 9.81 times too large) are not caught
without a base channel. The check needs the model (``system``) and ``level_g``.
"""

from __future__ import annotations

import numpy as np

from ..quantity import G
from .context import demodulate, extraction_bandwidth
from .report import Finding

__all__ = ["check_units", "transmissibility_floor"]

# measured / expected level -> what makes it (values read too large or too small)
FACTORS = {9.80665: "m/s^2 data declared as g", 1 / 9.80665: "g data declared as m/s^2",
           1000.0: "a factor 1000 (mm/s^2 data declared as m/s^2?)", 1e-3: "a factor 1/1000"}
MIN_FLOOR = 0.1  # [-] where a channel's floor is below this, it bounds nothing useful ...
MIN_SHARE = 0.2  # [-] ... and a channel needs this share of the record above it


def transmissibility_floor(system, dofs, f_hz: float, *, n_k: int = 200) -> np.ndarray:
    """``min_k min(|r + H(f; k)|, |H(f; k)|)`` at ``dofs``, k from 0 to rigid (log grid), shape
    (len(dofs),): the least a channel can read per unit base acceleration, absolute or relative.

    ``H = -w^2 y`` with ``(K + k B B^T - w^2 M + i w C) y = -M r`` (relative acceleration per
    unit base acceleration), with the model's C (none: undamped, a lower floor).
    """
    w = 2 * np.pi * f_hz
    idx = system.dof_index(list(dofs))
    scale = float(np.max(np.abs(np.diag(system.K)))) or 1.0
    B = system.hinge_matrix()
    r = system.influence
    ks = np.concatenate([[0.0], np.geomspace(scale * 1e-9, scale * 1e6, n_k)])
    A0 = system.K - w * w * system.M + 1j * w * system.damping
    A = A0[None] + ks[:, None, None] * (B @ B.T)[None]
    rhs = np.broadcast_to(-(system.M @ r)[:, None], (ks.size, r.size, 1))
    y = np.linalg.solve(A, rhs)[:, :, 0]
    relative = np.abs(w * w * y[:, idx])
    absolute = np.abs(r[idx][None] - w * w * y[:, idx])
    return np.min(np.minimum(relative, absolute), axis=0)


def _first_harmonic(records, rec, x, t_from: float, t_to: float) -> tuple[float, float]:
    """Median first-harmonic amplitude of ``x`` over [t_from, t_to] [data units], and the
    sweep frequency in the middle [Hz]."""
    t = records.time(rec)
    bw = extraction_bandwidth(rec.law, t)
    z = np.abs(demodulate(x, records.fs, rec.law.phase(t), bw))
    sel = (t >= t_from) & (t <= t_to)
    return float(np.median(z[sel])), float(rec.law.frequency(0.5 * (t_from + t_to)))


def _explain(ratio: float, factor: float) -> str:
    """The units error a level ratio (measured / expected) is within ``factor`` of, or ""."""
    for k, what in FACTORS.items():
        if abs(np.log(ratio / k)) <= np.log(factor):
            return f": {what}?"
    return ""


def _explain_floor(ratios, factor: float) -> str:
    """The smallest units error that lifts every reading (over its floor) to 1 / ``factor``."""
    for k, what in sorted(FACTORS.items(), key=lambda kv: abs(np.log(kv[0]))):
        if k < 1 and min(ratios) / k >= 1 / factor:
            return f": {what}?"
    return ""


def _with_base(records) -> list[Finding]:
    opts, ds = records.options, records.dataset
    out = []
    for rec in records.runs:
        if rec.law is None or not rec.run.level_g:
            continue
        T = (rec.n - 1) / records.fs
        amp, _ = _first_harmonic(records, rec, rec.base, 0.1 * T, 0.9 * T)
        ratio = ds.to_si(amp) / (rec.run.level_g * G)
        if abs(np.log(ratio)) > np.log(opts.units_factor):
            out.append(Finding(
                "units", rec.file, records.base_name, ratio, "x", "suspect",
                f"run {rec.file}, base channel {records.base_name}: its level is {ratio:.3g} x "
                f"level_g {rec.run.level_g:g} g in the declared units "
                f"{ds.units}{_explain(ratio, opts.units_factor)}"))
    return out


def _floor_track(system, dofs, band, n: int = 16):
    """Transmissibility floors on a frequency grid over ``band``: (grid [Hz], floors (n, C))."""
    grid = np.linspace(band[0], band[1], n)
    return grid, np.array([transmissibility_floor(system, dofs, f) for f in grid])


def _cached_floor_track(records, dofs, band):
    """:func:`_floor_track`, once per band (the runs of a test usually share one)."""
    cache = records.__dict__.setdefault("_floor_tracks", {})
    key = (round(band[0], 1), round(band[1], 1))  # [Hz]; the floor varies slowly with f
    if key not in cache:
        cache[key] = _floor_track(records.system, dofs, key)
    return cache[key]


def _run_ratios(records, rec, dofs):
    """Per channel with a floor (at least ``MIN_FLOOR`` over ``MIN_SHARE`` of the record): the
    5th percentile of first harmonic over (level_g x floor) there, and the floor's smallest
    value there [-]."""
    t = records.time(rec)
    bw = extraction_bandwidth(rec.law, t)
    grid, floors = _cached_floor_track(records, dofs, records.band(rec))
    edge = 2.0 / bw
    inner = (t >= edge) & (t <= t[-1] - edge)
    f = rec.law.frequency(t[inner])
    z = np.abs(demodulate(rec.data, records.fs, rec.law.phase(t), bw))[:, inner]
    level = rec.run.level_g * G
    out = {}
    for j, name in enumerate(records.names):
        floor = np.interp(f, grid, floors[:, j])
        use = floor >= MIN_FLOOR
        if use.mean() < MIN_SHARE:
            continue
        m = records.dataset.to_si(z[j][use]) / level / floor[use]
        out[name] = (float(np.quantile(m, 0.05)), float(floor[use].min()))
    return out


def _without_base(records) -> list[Finding]:
    opts, ds = records.options, records.dataset
    dofs = [ds.channels[c] for c in records.names]
    rows = []
    for rec in records.runs:
        if rec.law is None or not rec.run.level_g:
            continue
        rows += [(rec.file, name, q, fl) for name, (q, fl) in
                 _run_ratios(records, rec, dofs).items()]
    if not rows:
        records.skipped["units"] = ("no base channel, and no channel whose transmissibility has "
                                    "a floor in the model (or no level_g)")
        return []
    bad = [r for r in rows if r[2] < 1 / opts.units_factor]
    if len(bad) <= len(rows) / 2:
        return []
    ratio = float(np.median([b[2] for b in bad]))
    run, name, _, floor = bad[0]
    return [Finding(
        "units", "", ", ".join(dict.fromkeys(b[1] for b in bad)), ratio, "x", "suspect",
        f"units: without a base channel, {len(bad)} of {len(rows)} channel records stay at "
        f"{ratio:.2g} x the least the model lets them read (level_g x its lowest "
        f"transmissibility, e.g. {floor:.2f} for run {run}, channel {name}) in the declared "
        f"units {ds.units}{_explain_floor([b[2] for b in bad], opts.units_factor)}")]


def check_units(records) -> list[Finding]:
    """Acceleration levels against ``level_g`` (module docstring)."""
    ds = records.dataset
    if ds.quantity != "acceleration":
        records.skipped["units"] = (f"{ds.quantity} data: levels are given in g only for "
                                    "accelerations")
        return []
    if ds.base_channel is not None and any(r.base is not None for r in records.runs):
        return _with_base(records)
    if records.system is None:
        records.skipped["units"] = "no base channel and no linear model (`system`)"
        return []
    return _without_base(records)

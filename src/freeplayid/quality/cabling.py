"""Cabling: each channel's amplitude at resonance against the model's mode shape at its DOF.

At a run's resonance the relative response is the resonating mode: channel j reads
``phi_j x q`` (q the modal amplitude), so the complex ratio of two channels' first harmonics is
the ratio of the mode shape at their DOFs, whatever the level, the damping or the gap. The mode
is the model's with its hinge springs at the stiffness that puts it at the measured resonance
frequency (``K + k B B^T``, k found by bisection; the backbone's own shape at that point), so
it needs no kn. Measured: the least-squares ratio ``sum z_j conj(z_ref) / sum |z_ref|^2`` of
the first-harmonic envelopes (relative to the base) over the resonance's lobe (above 70 % of
its maximum), the median over the resonating runs; ref is the channel with the largest
mode-shape amplitude. A run resonates when its strongest envelope's maximum lies away from
the record's ends, at twice its median or more, and at five times the base level or more
(the base channel's, else ``level_g``): at a resonance the relative motion is the base's times
the mode's amplification (about 20 on the bundled fin, 9-15 on a 2-DOF fin), while an outboard
part rattling in its gap moves 1-3 times the base and not in the mode (seen on the 2-DOF fin
swept too fast to jump). A mismatch that no swap or inverted sensor explains is reported only
when every resonating run shows it.

- A channel whose amplitude ratio differs from the model's by more than the factor
  ``1 + shape_tolerance`` (1.5; the describing function's shape holds within 0.1 % at the
  default fin's two DOFs, within 27 % at a 2-DOF fin's weakly moving inboard DOF, where the
  contacts' harmonics weigh more) makes the answer ``suspect``: the fit reads delta from each
  channel's amplitude over its mode-shape value (a wrong DOF, a sensitivity or units error).
  When exchanging two channels' DOFs explains
  the ratios, the message says they look swapped (two channels cabled the wrong way round
  gave delta -97 %).
- A channel in antiphase with the mode shape (a sensor mounted upside down, a polarity
  inverted in the recorder): with a base channel its subtraction adds the base instead of
  removing it (its motion relative to the base reads ``-(rel + 2 base)``), so ``suspect``.
  Without a base channel the channels read absolute motion (relative + base), whose phase
  says nothing reliable at a weakly moving DOF, and an inverted sensor is harmless to the
  amplitudes: signs are not compared, and each ratio may differ from the mode shape by the
  base's share on top of the tolerance, ``(1 + b / |z_j|)(1 + b / |z_ref|)``, b the base level
  from ``level_g``.

Channels whose mode-shape amplitudes lie within the tolerance of each other cannot be told
apart: a swap between them is invisible, and the report says so.
"""

from __future__ import annotations

import itertools

import numpy as np
import scipy.linalg

from ..quantity import G
from .context import demodulate, extraction_bandwidth
from .report import Finding

__all__ = ["check_cabling", "shape_at_frequency"]

LOBE = 0.7  # [-] the resonance's lobe: first-harmonic envelope above this x its maximum
MIN_PEAK_RATIO = 2.0  # [-] a resonating run: envelope maximum / median at least this ...
MIN_AMPLIFICATION = 5.0  # [-] ... and its relative motion this many times the base's


def _mode(system, k: float, mode: int):
    """(frequency [Hz], shape (n,)) of mode ``mode`` with hinge stiffness k [N m/rad]."""
    K = system.closed_stiffness(k) if k > 0 else system.K
    lam, phi = scipy.linalg.eigh(K, system.M, subset_by_index=(mode, mode))
    return float(np.sqrt(max(lam[0], 0.0)) / (2 * np.pi)), phi[:, 0]


def shape_at_frequency(system, f_hz: float, *, mode: int = 0) -> np.ndarray:
    """The mode shape, shape (n_dof,) [mass-normalised], of ``system`` with every hinge spring
    at the stiffness that puts mode ``mode`` at ``f_hz`` [Hz].

    The frequency rises with the hinge stiffness (from the open to the rigid hinge); outside
    that range the nearer end's shape is returned.
    """
    scale = float(np.max(np.abs(np.diag(system.K)))) or float(np.max(np.diag(system.M)))
    lo, hi = scale * 1e-9, scale * 1e6
    if _mode(system, hi, mode)[0] <= f_hz:
        return _mode(system, hi, mode)[1]
    if _mode(system, 0.0, mode)[0] >= f_hz:
        return _mode(system, 0.0, mode)[1]
    for _ in range(60):  # bisection in log k: 2^-60 of 15 decades
        mid = np.sqrt(lo * hi)
        lo, hi = (mid, hi) if _mode(system, mid, mode)[0] < f_hz else (lo, mid)
    return _mode(system, np.sqrt(lo * hi), mode)[1]


def _lobes(records):
    """Per resonating run: (resonance frequency [Hz], relative envelopes over the lobe
    (channel, L), the base's envelope over the lobe (L,) or None)."""
    out = []
    for rec in records.runs:
        res = records.resonance(rec)
        if res is None or not res.interior or res.peak_ratio < MIN_PEAK_RATIO:
            continue
        a = np.abs(res.envelopes[res.row])
        k = res.index
        zb, level = None, None
        if rec.base is not None:
            t = records.time(rec)
            zb = demodulate(rec.base, records.fs, rec.law.phase(t),
                            extraction_bandwidth(rec.law, t))
            level = float(np.median(np.abs(zb)))
        elif rec.run.level_g:
            level = rec.run.level_g * G / records.dataset.si_scale
        if level is not None and a[k] < MIN_AMPLIFICATION * level:
            continue  # no resonance: an in-gap part moves with the base, not in the mode
        lobe = a >= LOBE * a[k]
        before, after = np.nonzero(~lobe[:k])[0], np.nonzero(~lobe[k:])[0]
        sl = slice(before[-1] + 1 if before.size else 0, k + after[0] if after.size else a.size)
        out.append((res.f_hz, res.envelopes[:, sl], None if zb is None else zb[sl]))
    return out


def _ratios(z, ref: int) -> np.ndarray:
    """Least-squares complex ratio of every channel's envelope to channel ``ref``'s."""
    return (z @ np.conj(z[ref])) / float(np.sum(np.abs(z[ref]) ** 2))


def _flipped(z, zb, c: int):
    """The envelopes if channel c's sensor were inverted: its absolute reading -(rel + base),
    so its motion relative to the base is -(rel + 2 base) (-rel without a base channel)."""
    z = z.copy()
    z[c] = -(z[c] + 2 * zb) if zb is not None else -z[c]
    return z


def _misfit(ratios, model, ref: int, slack=None) -> float:
    """Largest |log| amplitude-ratio misfit over the channels beyond its ``slack`` (log, per
    channel); infinite when a channel's sign (phase within 90 degrees) disagrees with the mode
    shape's, unless ``slack`` is given (no base channel: signs are not compared)."""
    others = [j for j in range(model.size) if j != ref]
    if slack is None:
        if any(np.real(ratios[j] * np.conj(model[j])) <= 0 for j in others):
            return np.inf
        slack = np.zeros(model.size)
    return float(max(abs(np.log(abs(ratios[j]) / abs(model[j]))) - slack[j] for j in others))


def _base_slack(records, lobes, ref: int):
    """Without a base channel the channels read absolute motion, relative + base: each ratio
    may be off by up to ``(1 + b / |z_j|)(1 + b / |z_ref|)`` with b the base level (level_g;
    0 without one), a log slack per channel."""
    b = [r.run.level_g * G / records.dataset.si_scale for r in records.runs if r.run.level_g]
    level = float(np.median(b)) if b else 0.0
    mags = np.median(np.array([np.median(np.abs(z), axis=1) for _, z, _ in lobes]), axis=0)
    return np.log1p(level / mags) + np.log1p(level / mags[ref])


def _median_ratios(lobes, ref: int, transform=None) -> np.ndarray:
    rs = np.array([_ratios(transform(z, zb) if transform else z, ref) for _, z, zb in lobes])
    return np.median(rs.real, axis=0) + 1j * np.median(rs.imag, axis=0)


def check_cabling(records) -> list[Finding]:
    """Channel amplitude ratios at resonance against the model's mode shape (module docstring)."""
    system = records.system
    if system is None:
        records.skipped["cabling"] = "no linear model given (`system`)"
        return []
    names = records.names
    if len(names) < 2:
        records.skipped["cabling"] = "one response channel: no amplitude ratio to compare"
        return []
    dofs = [records.dataset.channels[c] for c in names]
    if any(d not in system.dof_names for d in dofs):
        records.skipped["cabling"] = "a channel's DOF is not in the model"
        return []
    lobes = _lobes(records)
    if not lobes:
        records.skipped["cabling"] = "no run resonates (no amplitude ratio at a resonance)"
        return []
    f_res = float(np.median([f for f, _, _ in lobes]))
    phi = shape_at_frequency(system, f_res, mode=records.options.mode)[system.dof_index(dofs)]
    return _judge(records, lobes, phi, f_res)


def _judge(records, lobes, phi, f_res) -> list[Finding]:
    """Identity, then each swap of two channels' DOFs and each inverted sensor (module
    docstring): the first that fits names the fault."""
    names = records.names
    tol = float(np.log1p(records.options.shape_tolerance))
    ref = int(np.argmax(np.abs(phi)))  # the channel with the largest mode-shape amplitude
    _note_invisible(records, phi, tol)
    with_base = lobes[0][2] is not None
    slack = None if with_base else _base_slack(records, lobes, ref)
    if not with_base:
        records.skipped["cabling (polarity)"] = ("no base channel: an inverted sensor is "
                                                 "harmless to the amplitudes, not looked for")
    ratios = _median_ratios(lobes, ref)
    if _misfit(ratios, phi / phi[ref], ref, slack) <= tol:
        return []
    hypotheses = []
    for a, b in itertools.combinations(range(len(names)), 2):
        perm = list(range(len(names)))
        perm[a], perm[b] = b, a
        model = phi[perm] / phi[perm][ref]
        hypotheses.append((_misfit(ratios, model, ref, slack), "swap", (a, b)))
    for c in range(len(names) if with_base else 0):
        flipped = _median_ratios(lobes, ref, lambda z, zb, c=c: _flipped(z, zb, c))
        hypotheses.append((_misfit(flipped, phi / phi[ref], ref), "flip", (c,)))
    best = min(hypotheses, key=lambda h: h[0])
    if best[0] <= tol and best[1] == "swap":
        return [_swap(records, ratios, phi, ref, best[2], f_res)]
    if best[0] <= tol:
        return [_flip(records, best[2][0])]
    runs = [_misfit(_ratios(z, ref), phi / phi[ref], ref, slack) for _, z, _ in lobes]
    if min(runs) <= tol:  # not in every run: no consistent fault of the cabling
        return []
    return [_mismatch(records, ratios, phi, ref, f_res)]


def _note_invisible(records, phi, tol) -> None:
    names = records.names
    close = [(names[a], names[b]) for a, b in itertools.combinations(range(len(names)), 2)
             if abs(np.log(abs(phi[a]) / abs(phi[b]))) <= 2 * tol]
    if close:
        pairs = ", ".join(f"{a} and {b}" for a, b in close)
        records.skipped["cabling (swaps)"] = (f"{pairs} have mode-shape amplitudes within "
                                              f"{100 * (np.exp(2 * tol) - 1):.0f} % of each "
                                              "other: a swap between them would not show")


def _worst(ratios, model, ref):
    others = [j for j in range(model.size) if j != ref]
    return max(others, key=lambda j: abs(np.log(abs(ratios[j]) / abs(model[j]))))


def _swap(records, ratios, phi, ref, pair, f_res) -> Finding:
    names = records.names
    model = phi / phi[ref]
    j = _worst(ratios, model, ref)
    factor = float(abs(ratios[j]) / abs(model[j]))
    a, b = names[pair[0]], names[pair[1]]
    return Finding(
        "cabling", "", f"{a}, {b}", factor, "x", "suspect",
        f"channels {a} and {b} look swapped: the amplitude ratio {names[j]} / {names[ref]} at "
        f"resonance ({f_res:.1f} Hz) is {abs(ratios[j]):.3g}, the model's mode shape gives "
        f"{abs(model[j]):.3g} and the swapped DOFs fit: check the cabling and the manifest's "
        "`channels`")


def _flip(records, c: int) -> Finding:
    name, base = records.names[c], records.base_name
    return Finding(
        "cabling", "", name, 180.0, "deg", "suspect",
        f"channel {name}: reads in antiphase with the model's mode shape at resonance, as an "
        f"inverted sensor (mounted upside down, or its polarity inverted) would: its base "
        f"subtraction adds {base} instead of removing it")


def _mismatch(records, ratios, phi, ref, f_res) -> Finding:
    names = records.names
    model = phi / phi[ref]
    j = _worst(ratios, model, ref)
    factor = float(abs(ratios[j]) / abs(model[j]))
    return Finding(
        "cabling", "", names[j], factor, "x", "suspect",
        f"channel {names[j]}: its amplitude ratio {names[j]} / {names[ref]} at resonance "
        f"({f_res:.1f} Hz) is {abs(ratios[j]):.3g}, {factor:.2f} x the model's mode shape "
        f"({abs(model[j]):.3g}), and no swap or inverted sensor explains it: a wrong DOF in "
        "`channels`, a sensor sensitivity or the model's shape is off")

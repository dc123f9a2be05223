"""Dropouts and constant stretches: a channel that holds one value (zeros, or a repeated sample).

A vibration that the recorder resolves crosses its mean twice per period, so it cannot hold
one value for a whole period of the lowest swept frequency; a lost connection, a recorder
that writes zeros or repeats its last sample does. A stretch of exactly equal consecutive
samples is a dropout when

- it lasts ``dropout_periods`` (1) periods of the lowest swept frequency or more, and
- the signal around it (one such period on either side) spans more than four quantisation
  steps, so a resolvable vibration was there (a signal below the recorder's resolution may
  legitimately hold its value).

Where the stretch overlaps the run's resonance (the envelope's lobe above half its maximum,
widened by the extraction's smoothing) the fitting point is missing or cut (0.5 s of zeros at
each jump moved kn by -0.96 % with an interval that missed): the run is rejected. Elsewhere the
points do not see it: a warning. A response channel held over the whole record is dead: the
extraction rejects its points and keeps the run's others (a warning); a dead base channel
cannot be subtracted and rejects the run.
"""

from __future__ import annotations

import numpy as np

from .report import Finding

__all__ = ["check_dropout", "held_stretches"]


def held_stretches(x, min_len: int) -> np.ndarray:
    """Stretches of at least ``min_len`` exactly equal consecutive samples.

    Parameters
    ----------
    x : ndarray, shape (T,)
    min_len : int [samples]

    Returns
    -------
    ndarray of int, shape (k, 2)
        (start, stop) sample indices of each stretch (stop exclusive).
    """
    same = np.diff(x) == 0
    d = np.diff(np.concatenate([[0], same.astype(np.int8), [0]]))
    starts, stops = np.nonzero(d == 1)[0], np.nonzero(d == -1)[0] + 1
    keep = stops - starts >= min_len
    return np.column_stack([starts[keep], stops[keep]])


def _resolution(x) -> float:
    u = np.unique(x)
    gaps = np.diff(u)
    gaps = gaps[gaps > 0]
    return float(gaps.min()) if gaps.size else 0.0


def _resolvable(x, a: int, b: int, span: int, q: float) -> bool:
    """The signal next to [a, b) spans more than four quantisation steps (or the stretch is the
    whole record: a dead channel)."""
    around = np.concatenate([x[max(0, a - span):a], x[b:b + span]])
    return around.size == 0 or float(np.ptp(around)) > 4 * q


def _finding(records, rec, name, x, a, b, unit) -> Finding:
    fs = records.fs
    dur = (b - a) / fs
    value = float(x[a])
    res = records.resonance(rec)
    at_peak = res is not None and bool(res.window[a:b].any())
    what = "zeros" if value == 0 else f"the value {value:.5g} {unit}"
    if b - a >= x.size and name != records.base_name:
        return Finding("dropout", rec.file, name, dur, "s", "warning",
                       f"run {rec.file}, channel {name}: {what} over the whole record, a dead "
                       "channel (the extraction rejects its points and keeps the others')")
    where = ("over the whole record, a dead base channel" if b - a >= x.size else
             f"for {dur:.3g} s from t = {a / fs:.2f} s")
    if at_peak:
        action, tail = "reject_run", ", across the resonance: its fitting point is lost"
    else:
        action, tail = "warning", ", away from the resonance"
    msg = f"run {rec.file}, channel {name}: {what} held {where}{tail}"
    return Finding("dropout", rec.file, name, dur, "s", action, msg)


def check_dropout(records) -> list[Finding]:
    """Held values of at least ``dropout_periods`` periods (module docstring)."""
    out = []
    unit = records.dataset.units
    for rec in records.runs:
        span = records.period_samples(rec, records.options.dropout_periods)
        min_len = max(3, span)
        for name, x, _ in records.signals(rec):
            stretches = held_stretches(x, min_len)
            if stretches.size == 0:
                continue
            q = _resolution(x)
            found = [(a, b) for a, b in stretches if _resolvable(x, a, b, span, q)]
            if not found:
                continue
            # one finding per channel: the longest stretch, with the count
            fs = [_finding(records, rec, name, x, a, b, unit) for a, b in found]
            worst = max(fs, key=lambda f: (f.action == "reject_run", f.size))
            if len(found) > 1:
                total = sum(f.size for f in fs)
                worst = Finding(worst.check, worst.run, worst.channel, worst.size, worst.unit,
                                worst.action, f"{worst.message} ({len(found)} held stretches, "
                                f"{total:.3g} s in all)")
            out.append(worst)
    return out

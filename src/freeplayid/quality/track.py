"""A record's frequency track against its sweep hint: sample rate, the hint's start, a foreign run.

Each run's own law ``f_r(t)`` comes from its base channel's instantaneous frequency (else the
best-tracked response's; :func:`freeplayid.signal.estimate_sweep`), on the declared time axis
``t = k / fs``. Against the hint ``f_h`` three explanations are fitted by least squares over the
record (201 times), each judged by its largest relative deviation:

- none: ``f_r(t) = f_h(t)``;
- a sample rate wrong by the factor r (data sampled at fs / r, declared fs): every frequency
  is scaled by r and time by 1 / r, ``f_r(t) = r f_h(r t)``;
- a record that starts t0 into the hint's sweep (a pre-trigger, a trimmed record):
  ``f_r(t) = f_h(t + t0)``, |t0| at most 10 % of the sweep + 1 s (what the reader lets a
  record outlast its hint by); a larger shift is another sweep.

An explanation fits when its deviation is at most ``tol = max(rate_tolerance, 3 x the law's
residual / its mean frequency)``, and at least ``RESPONSE_LAW_TOLERANCE`` (1.5 %) for a track
read off a response channel (no base channel), which lags the excitation through the resonance
(the sweep-law estimate's own error from a response: up to ~1.1 % in the rate at 2 Hz/s).
The first that fits decides:

- none: nothing to report;
- a rate factor with ``|r - 1| > rate_tolerance`` (0.1 %), shared by the runs: every jump
  frequency moves by ``r - 1`` (2000 Hz declared for 2048 Hz data: -2.3 %, kn -5 %, delta +11 %):
  ``suspect``, naming the rate the data look sampled at (``sample_rate``);
- a start offset whose frequency shift ``|f_h(t0) - f_h(0)|`` exceeds ``rate_tolerance`` of the
  band's centre: points read off the hint are that far off: ``suspect`` (``sweep_hint``);
- nothing fits: the run is not a record of its hint (another test's record): rejected
  (``foreign_record``) with its own track in the reason, instead of "stayed in the gap".

Without a hint a run is compared with the other runs' common law (the median start, stop and
rate): a run off it while two others agree on it is ``suspect`` (``foreign_record``): nothing
says which sweep the test used. A run in which no sweep can be found at all is rejected, and so
is a run whose record is sample for sample another run's (a copied file: its points would count
twice and narrow the intervals).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

from ..sweep import Sweep
from .report import Finding

__all__ = ["check_sample_rate", "check_sweep_hint", "check_foreign_record", "compare_track"]

N_TIMES = 201
# [-] a law read off a response channel (no base channel) lags the excitation through the
# resonance and the jump: its rate errs by up to ~1.1 % at 2 Hz/s on the default fin
# (docs/identify.md §3b, benchmarks/sweep_law.py); a track from a response is judged within this
RESPONSE_LAW_TOLERANCE = 0.015
MAX_OFFSET_SHARE, MAX_OFFSET_S = 0.1, 1.0  # [-], [s] the largest start offset of a hint


def _deviation(f_rec, f_model) -> float:
    return float(np.max(np.abs(f_rec - f_model) / np.abs(f_model)))


def compare_track(law: Sweep, hint: Sweep, duration_s: float) -> dict:
    """Fit the three explanations of the module docstring.

    Parameters
    ----------
    law : Sweep
        The record's own law (declared time axis).
    hint : Sweep
        The run's sweep hint.
    duration_s : float [s]
        The record's length.

    Returns
    -------
    dict
        ``none``: deviation [-]; ``rate``: (r, deviation); ``offset``: (t0 [s], deviation).
    """
    t = np.linspace(0.0, duration_s, N_TIMES)
    fr = law.frequency(t)

    def scaled(r):
        return r * hint.frequency(r * t)

    def shifted(t0):
        return hint.frequency(t + t0)

    def fit(model, bounds):
        res = minimize_scalar(lambda p: float(np.sum((fr - model(p)) ** 2)), bounds=bounds,
                              method="bounded", options={"xatol": 1e-9 * max(map(abs, bounds))})
        return float(res.x), _deviation(fr, model(res.x))

    r = fit(scaled, (0.5, 2.0))
    # a start offset of at most what the reader allows a record to outlast its hint by
    # (10 % + 1 s, Sweep.record_mismatch), never past 0 Hz: more is another sweep
    span = MAX_OFFSET_SHARE * hint.duration + MAX_OFFSET_S
    lo = -span if hint.law == "log" else max(-span, -0.99 * hint.start_hz / abs(hint.mean_rate))
    t0 = fit(shifted, (lo, span))
    return {"none": _deviation(fr, hint.frequency(t)), "rate": r, "offset": t0}


def _verdicts(records) -> dict:
    """Each run's outcome (cached): ("ok" | "rate" | "offset" | "foreign" | "no_law" |
    "no_hint", details)."""
    if getattr(records, "_track_verdicts", None) is not None:
        return records._track_verdicts
    tol_rate = records.options.rate_tolerance
    out = {}
    for rec in records.runs:
        if rec.law_source == "sweep hint" or rec.law is None:
            out[rec.file] = ("no_law", rec.law_error)
            continue
        if rec.hint is None:
            out[rec.file] = ("no_hint", None)
            continue
        T = (rec.n - 1) / records.fs
        cmp = compare_track(rec.law, rec.hint, T)
        f_mid = float(np.mean(rec.law.frequency(np.array([0.0, T]))))
        tol = max(tol_rate, 3 * rec.law_residual_hz / f_mid)
        if not rec.law_source.startswith("base channel"):
            tol = max(tol, RESPONSE_LAW_TOLERANCE)
        if cmp["none"] <= tol:
            out[rec.file] = ("ok", cmp)
        elif cmp["rate"][1] <= tol and abs(cmp["rate"][0] - 1) > tol_rate:
            out[rec.file] = ("rate", cmp)
        elif cmp["offset"][1] <= tol:
            shift = abs(float(rec.hint.frequency(cmp["offset"][0])) - rec.hint.start_hz)
            out[rec.file] = ("offset" if shift > tol_rate * f_mid else "ok", cmp)
        else:
            out[rec.file] = ("foreign", cmp)
    records._track_verdicts = out
    return out


def _track_text(rec, records) -> str:
    T = (rec.n - 1) / records.fs
    return f"{rec.law.describe()} over {T:.4g} s (from its {rec.law_source})"


def check_sample_rate(records) -> list[Finding]:
    """The declared sample rate against the runs' tracks and hints (module docstring)."""
    verdicts = _verdicts(records)
    rates = {f: v[1]["rate"][0] for f, v in verdicts.items() if v[0] == "rate"}
    if not any(v[0] in ("ok", "rate", "offset", "foreign") for v in verdicts.values()):
        records.skipped.setdefault("sample_rate", "no run has both a sweep hint and a frequency "
                                   "track: nothing to compare the declared rate with")
        return []
    if not rates:
        return []
    fs = records.fs
    agree = [f for f, v in verdicts.items() if v[0] in ("ok", "offset")]
    if agree:  # the others match the declared rate: these runs were recorded at another one
        return [Finding(
            "sample_rate", f, "", 100 * (r - 1), "%", "reject_run",
            f"run {f}: its frequency track is its sweep hint's with every frequency scaled by "
            f"{r:.4f} (sampled at {fs / r:.6g} Hz, not the declared {fs:g} Hz, while "
            f"{len(agree)} other run(s) match the declared rate)") for f, r in rates.items()]
    r = float(np.median(list(rates.values())))
    return [Finding(
        "sample_rate", "", "", 100 * (r - 1), "%", "suspect",
        f"sample rate: the frequency tracks of all {len(rates)} checked runs are their sweep "
        f"hints with every frequency scaled by {r:.4f}: the data look sampled at {fs / r:.6g} Hz, "
        f"not the declared {fs:g} Hz, which moves every jump frequency by "
        f"{100 * (r - 1):+.2f} %")]


def check_sweep_hint(records) -> list[Finding]:
    """A hint whose start is off the record's (module docstring)."""
    out = []
    for rec in records.runs:
        kind, cmp = _verdicts(records)[rec.file]
        if kind != "offset":
            continue
        t0 = cmp["offset"][0]
        shift = float(rec.hint.frequency(t0)) - rec.hint.start_hz
        when = f"{t0:.3g} s after" if t0 > 0 else f"{-t0:.3g} s before"
        out.append(Finding(
            "sweep_hint", rec.file, "", shift, "Hz", "suspect",
            f"run {rec.file}: the record starts {when} the start of its sweep hint "
            f"({rec.hint.describe()}): frequencies read off the hint are {shift:+.3g} Hz off; "
            "fix the hint's start_hz or the record's start"))
    return out


def _common_law(recs) -> Sweep | None:
    laws = [r.law for r in recs]
    if len(laws) < 3 or any(lw.law != laws[0].law for lw in laws):
        return None
    start = float(np.median([lw.start_hz for lw in laws]))
    stop = float(np.median([lw.stop_hz for lw in laws]))
    key = "rate_hz_per_s" if laws[0].law == "linear" else "octaves_per_min"
    return Sweep(start, stop, **{key: float(np.median([getattr(lw, key) for lw in laws]))})


def _unhinted(records, verdicts) -> list[Finding]:
    """Runs without a hint against the other runs' common law."""
    recs = [r for r in records.runs if verdicts[r.file][0] == "no_hint"]
    common = _common_law(recs)
    if common is None:
        return []
    tol = records.options.rate_tolerance
    off = {}
    for rec in recs:
        t = np.linspace(0.0, (rec.n - 1) / records.fs, N_TIMES)
        dev = _deviation(rec.law.frequency(t), common.frequency(t))
        res = 3 * rec.law_residual_hz / float(np.mean(rec.law.frequency(t)))
        if dev > max(tol, res):
            off[rec.file] = (rec, dev)
    if len(recs) - len(off) < 2:
        return []
    return [Finding("foreign_record", f, "", 100 * dev, "%", "suspect",
                    f"run {f}: its sweep ({_track_text(rec, records)}) is not the other runs' "
                    f"({common.describe()}; off by up to {100 * dev:.2g} %): another test's "
                    "record? (no sweep hint says which)") for f, (rec, dev) in off.items()]


def _copies(records) -> list[Finding]:
    """Runs whose records are sample for sample another run's (a file copied under another
    name): their points would count twice and narrow the intervals."""
    out, seen = [], {}
    for rec in records.runs:
        key = (rec.data.shape, hash(rec.data.tobytes()))
        first = seen.get(key)
        if first is not None and np.array_equal(first.data, rec.data):
            out.append(Finding(
                "foreign_record", rec.file, "", float("nan"), "", "reject_run",
                f"run {rec.file}: its record is sample for sample run {first.file}'s (a copied "
                "file?): its points would count twice"))
        else:
            seen.setdefault(key, rec)
    return out


def check_foreign_record(records) -> list[Finding]:
    """Runs that are not records of their hint, or of the other runs' sweep, and copies of
    another run (module docstring)."""
    verdicts = _verdicts(records)
    out = _copies(records)
    for rec in records.runs:
        kind, cmp = verdicts[rec.file]
        if kind == "no_law":
            out.append(Finding(
                "foreign_record", rec.file, "", float("nan"), "", "reject_run",
                f"run {rec.file}: no sweep found in its record ({rec.law_error})"))
        elif kind == "foreign":
            out.append(Finding(
                "foreign_record", rec.file, "", 100 * cmp["none"], "%", "reject_run",
                f"run {rec.file} is not a record of its sweep hint ({rec.hint.describe()}): "
                f"its frequency track is {_track_text(rec, records)}, off by up to "
                f"{100 * cmp['none']:.3g} %; another test's record?"))
    return out + _unhinted(records, verdicts)

"""Even harmonics: a response that a gap centred on the rest position cannot make.

A freeplay hinge whose gap is centred on the panel's rest position has an odd restoring law,
f(-th) = -f(th), so under a sinusoidal base motion its steady response holds the first
harmonic and odd ones only. An even harmonic needs an asymmetric law: the panel resting on one
stop under a static load (its weight, where the shaker's axis is vertical; a preload), or stops
that are not symmetric about the rest position. The replay gives every hinge a centred gap, so
it does not describe such a test, and the answer may be biased (on another integrator's records
of three fins shaken vertically, 1 g along the axis: delta -0.2 to -10 %, docs/results.md).

Per run, on its strongest relative response (the resonance of :class:`.context.Records`), the
complex demodulation at the sweep's phase, at twice it and at 2.5 times it (no harmonic there:
the noise and the jump's broadband transient), all at the extraction's bandwidth. Over the
resonance's lobe above half its maximum, less two filter times either side of the maximum
(the jump's transient), the medians of ``|z_2| / |z_1|`` (the even harmonic's share) and of
``|z_2.5| / |z_1|`` (the noise's). A finding where the even share

- exceeds ``even_noise`` (4) times the noise's share: the medians of two noise readings over the
  same samples differ by far less (0.5-1.7 times on 640 runs of 78 conditions of the independent
  records, docs/results.md);
- exceeds ``amplitude_tolerance`` (1 %, delta's accuracy bound) of the first harmonic: below,
  it is too small to matter, and a noise-free record's numerical floor (below 1e-4 of the first
  on those records) never reaches it;
- and, with a base channel, exceeds what the base's own second harmonic could put into the
  response: its share of the base's first harmonic times the run's resonant amplification
  (the peak relative response over the base's first harmonic), an upper bound for a mode at
  twice the frequency as sharp as the one at the resonance (a distorted shaker).

Without a base channel a distorted base cannot be told from an asymmetric gap; the message says
so. A data set that states gravity along its shaking axis (``gravity_g``, a vertical shaker) is
not checked: its replays carry the weight, and with it the even harmonics it makes. Otherwise
the finding makes the answer ``suspect``: a weight the replay does not carry biased delta by
-0.2 to -10 % on those fins and by -1.1 to -2.2 % on an SDOF oscillator at 1 g, and the data
cannot tell which; stating ``gravity_g`` removes the bias (docs/results.md).

A centred gap makes even harmonics of its own where a run first meets the stops: just above
its contact threshold the steady motion can favour one stop (a response that breaks the law's
symmetry, as impact oscillators' do near grazing), and a sweep crosses that band before the
symmetric motion takes over. On another integrator's records of a two-hinge beam the lowest
run's second harmonic was 2-2.6 % of its first over a third of its lobe (median 1.5 %), and the
project's simulator at the truth made the same, 1.55 %. The records alone cannot tell this from
an asymmetric gap, so :func:`replayed_even_harmonics` judges each finding again against the
answer's replay, which has a centred gap: only the share the replay does not make counts, by
the same three tests.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .context import Records, demodulate, extraction_bandwidth
from .options import RecordCheckOptions
from .report import Finding, RecordReport

__all__ = ["check_even_harmonics", "even_share", "replayed_even_harmonics"]

NOISE_ORDER = 2.5  # [-] the noise's reference: demodulated at this multiple of the phase


def even_share(records, rec) -> dict | None:
    """The run's second-harmonic share of its first around the resonance (module docstring):
    ``{"even", "noise", "base", "row"}`` ([-]; ``base`` NaN without a base channel), or None
    where the run has no sweep law, no interior resonance or too short a lobe."""
    res = records.resonance(rec)
    if res is None or not res.interior:
        return None
    fs = records.fs
    t = records.time(rec)
    bw = extraction_bandwidth(rec.law, t)
    rel = rec.data - rec.base if rec.base is not None else rec.data
    x = rel[res.row]
    phase = rec.law.phase(t)
    a1 = np.abs(res.envelopes[res.row])
    edge = int(round(2.0 * fs / bw))
    lobe = (res.window & (a1 > 0.5 * a1[res.index])
            & (np.abs(np.arange(rec.n) - res.index) > edge))
    if np.count_nonzero(lobe) < edge:
        return None
    a2 = np.abs(demodulate(x, fs, 2.0 * phase, bw))
    ar = np.abs(demodulate(x, fs, NOISE_ORDER * phase, bw))
    out = {"even": float(np.median(a2[lobe] / a1[lobe])),
           "noise": float(np.median(ar[lobe] / a1[lobe])), "base": float("nan"), "row": res.row}
    if rec.base is not None:
        b1 = np.abs(demodulate(rec.base, fs, phase, bw))
        b2 = np.abs(demodulate(rec.base, fs, 2.0 * phase, bw))
        gain = a1[res.index] / max(float(np.median(b1[lobe])), np.finfo(float).tiny)
        out["base"] = float(gain * np.median(b2[lobe]) / np.median(a1[lobe]))
    return out


def _fires(share: float, s: dict, opts) -> bool:
    """Whether an even share ``share`` (of the run read as ``s``) is a finding: above the
    noise's share, above the amplitude tolerance and above what the base could put there."""
    return bool(share > opts.even_noise * s["noise"] and share > opts.amplitude_tolerance
                and not share <= s["base"])


def _measured(records, rec, s: dict) -> str:
    """What the run's even share is, against the noise's and the base's."""
    if np.isnan(s["base"]):
        source = "; without a base channel a shaker's distortion cannot be told from this"
    else:
        source = f"; the base's own second harmonic could put at most {s['base']:.2%} there"
    return (f"{rec.file}: {records.names[s['row']]}'s second harmonic is {s['even']:.1%} of its "
            f"first around the resonance (the noise's share {s['noise']:.2%}{source})")


def check_even_harmonics(records) -> list[Finding]:
    """One ``suspect`` finding per run whose response carries an even harmonic that the data
    set's ``gravity_g`` does not explain (module docstring)."""
    opts = records.options
    found = []
    if records.dataset.gravity_g:
        return found  # the weight is stated: the replays make its even harmonics
    for rec in records.runs:
        s = even_share(records, rec)
        if s is None:
            continue
        share = s["even"]
        if not _fires(share, s, opts):
            continue
        found.append(Finding(
            "even_harmonics", rec.file, records.names[s["row"]], 100.0 * share, "% of 1st",
            "suspect", f"{_measured(records, rec, s)}: a gap centred on the rest position makes "
            "none. The hinge rests on one stop (its weight on a vertical shaking axis, a "
            "preload) or its stops are asymmetric, which the replay does not carry, so the "
            "answer may be biased; on a vertical shaker state `gravity_g` in the data set (+1 "
            "with the channels' + direction up) and the replays carry the weight"))
    return found


def replayed_even_harmonics(report: RecordReport, replayed) -> RecordReport:
    """``report`` with each ``suspect`` ``even_harmonics`` finding judged again against the
    answer's replay (module docstring): where the share the replay does not make (the
    measured one less the replay's, on the run's strongest response) would not be a finding,
    the finding becomes a ``warning`` saying that a centred gap makes it; else it stays
    ``suspect`` and says how much the replay makes. Runs the replay does not hold keep their
    finding.

    Parameters
    ----------
    report : RecordReport
        The record checks' report on the measured data set (its ``dataset``: the records
        identified from).
    replayed : Dataset or None
        The test replayed at the answer (``ReplayResult.replayed_dataset``); None: ``report``.
    """
    found = [f for f in report.findings if f.check == "even_harmonics" and f.action == "suspect"]
    if replayed is None or not found or report.dataset is None:
        return report
    opts = report.options or RecordCheckOptions()
    files = {f.run for f in found}

    def prepared(dataset) -> dict:  # only the runs found: each is read on its own
        kept = dataclasses.replace(dataset, runs=tuple(r for r in dataset.runs if r.file in files))
        records = Records(kept, None, opts)
        return {rec.file: (records, rec) for rec in records.runs}

    runs, again = prepared(report.dataset), prepared(replayed)
    judged = {}
    for f in found:
        if f.run not in runs or f.run not in again:
            continue
        s, r = even_share(*runs[f.run]), even_share(*again[f.run])
        if s is None or r is None:
            continue
        made = f"the answer's replay, a centred gap, makes {r['even']:.1%} there"
        if _fires(s["even"] - r["even"], s, opts):
            judged[f] = dataclasses.replace(f, message=f"{f.message} ({made})")
        else:
            judged[f] = dataclasses.replace(f, action="warning", message=(
                f"{_measured(*runs[f.run], s)}, and {made}: the response of a gap "
                "centred on the rest position where the run first meets the stops (the motion "
                "favours one stop), not an asymmetric hinge"))
    if not judged:
        return report
    return dataclasses.replace(report, findings=tuple(judged.get(f, f) for f in report.findings))

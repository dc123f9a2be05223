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
"""

from __future__ import annotations

import numpy as np

from .context import demodulate, extraction_bandwidth
from .report import Finding

__all__ = ["check_even_harmonics", "even_share"]

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
        if not (share > opts.even_noise * s["noise"] and share > opts.amplitude_tolerance
                and not share <= s["base"]):
            continue
        name = records.names[s["row"]]
        if np.isnan(s["base"]):
            source = ("; without a base channel a shaker's distortion cannot be told from this")
        else:
            source = (f"; the base's own second harmonic could put at most {s['base']:.2%} "
                      "there")
        found.append(Finding(
            "even_harmonics", rec.file, name, 100.0 * share, "% of 1st", "suspect",
            f"{rec.file}: {name}'s second harmonic is {share:.1%} of its first around the "
            f"resonance (the noise's share {s['noise']:.2%}{source}): a gap centred on the "
            "rest position makes none. The hinge rests on one stop (its weight on a vertical "
            "shaking axis, a preload) or its stops are asymmetric, which the replay does not "
            "carry, so the answer may be biased; on a vertical shaker state `gravity_g` in the "
            "data set (+1 with the channels' + direction up) and the replays carry the weight"))
    return found

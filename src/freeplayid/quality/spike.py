"""Spikes: isolated samples far beyond the local envelope (a connector glitch, an EMI burst).

With ``m`` the running median over two periods of the lowest swept frequency (the signal's
centre) and ``e = |x - m|``, a sample is a spike when

- ``e > spike_envelope x E``, E the largest ``e`` within two periods on either side, leaving
  out ``spike_width`` samples around it (the local envelope; the larger side, so the drop after
  a jump, where one side is quiet, is never a spike): a structure's response envelope changes
  by a few per cent per period (a resonance builds up over 1 / (pi zeta) cycles, a free decay
  loses 2 pi zeta per cycle); the grazing contacts after a jump make single cycles up to 1.4 x
  their neighbours (bundled example), never twice; and
- ``e - E > spike_sigma x s``, s the signal's white-noise level (:mod:`.context`): where the
  envelope is noise (a quiet in-gap stretch) no noise sample stands 7 sigma above it.

The first and last second of a record are not searched: a simulated test starts from rest
with a transient that stands out as much, and the extraction trims them (``trim_s``). A spike
against the signal's own sign near a peak may stay inside twice the envelope: it is not found,
and the first harmonic hardly sees it.

Up to ``spike_width`` consecutive such samples make one spike. A few spikes (at most
``spike_max_rate`` per second) are repaired by least-squares autoregressive interpolation
(order 8, fitted to four periods on either side; Janssen, Veldhuis & Vries 1986): the missing
samples are those that make the local prediction errors smallest, which for a swept sine plus
noise restores the sine to within the noise. Denser spikes are left and reported: the
narrow-band first-harmonic extraction averages them out (+-50 g spikes left the answer right),
so they make a warning, not a rejection.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from .report import Finding

__all__ = ["check_spike", "find_spikes", "fill_gaps"]

AR_ORDER = 8  # [samples] order of the interpolating autoregressive model
EDGE_S = 1.0  # [s] not searched at each end (the extraction's default trim_s)


def _shift(a: np.ndarray, k: int) -> np.ndarray:
    """``a`` moved by k samples (``out[i] = a[i - k]``), zeros shifted in."""
    out = np.zeros_like(a)
    if k > 0:
        out[k:] = a[:-k]
    elif k < 0:
        out[:k] = a[-k:]
    else:
        out[:] = a
    return out


def find_spikes(x, *, span: int, noise: float, envelope: float, sigma: float,
                width: int) -> np.ndarray:
    """Boolean mask of spike samples in ``x`` (module docstring), shape (T,).

    Parameters
    ----------
    x : ndarray, shape (T,)
    span : int [samples]
        Two periods of the lowest swept frequency.
    noise : float [x's units]
        White-noise standard deviation.
    envelope, sigma : float
        ``spike_envelope`` and ``spike_sigma``.
    width : int [samples]
        ``spike_width``: the samples left out of the envelope on either side.
    """
    m = ndimage.median_filter(x, size=2 * (span // 2) + 1, mode="nearest")
    e = np.abs(x - m)
    h = max(1, span // 2)
    run_max = ndimage.maximum_filter1d(e, size=2 * h + 1, mode="constant", cval=0.0)
    left = _shift(run_max, width + 1 + h)  # max of e over [k - width - 1 - 2h, k - width - 1]
    right = _shift(run_max, -(width + 1 + h))
    env = np.maximum(left, right)
    return (e > envelope * env) & (e - env > sigma * noise)


def _clusters(mask: np.ndarray) -> np.ndarray:
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.column_stack([np.nonzero(d == 1)[0], np.nonzero(d == -1)[0]])


def _fill_one(x, bad, a: int, b: int, half: int) -> None:
    """Interpolate x[a:b] in place from the AR model of the window around it."""
    p = AR_ORDER
    lo, hi = max(0, a - half), min(x.size, b + half)
    seg, segbad = x[lo:hi].copy(), bad[lo:hi].copy()
    n = seg.size
    rows = np.arange(p, n)
    lags = rows[:, None] - np.arange(p + 1)[None, :]  # [n, n-1, ..., n-p]
    clean = ~segbad[lags].any(axis=1)
    if clean.sum() < 4 * p:
        return
    coef = np.linalg.lstsq(seg[lags[clean, 1:]], seg[lags[clean, 0]], rcond=None)[0]
    # prediction errors e_n = x_n - sum_i c_i x_{n-i}, linear in the unknown samples
    E = np.zeros((rows.size, n))
    E[np.arange(rows.size), rows] = 1.0
    for i in range(1, p + 1):
        E[np.arange(rows.size), rows - i] = -coef[i - 1]
    unknown = np.zeros(n, dtype=bool)
    unknown[a - lo:b - lo] = True
    # rows that touch another unrepaired spike say nothing about this one
    other = segbad & ~unknown
    use = ~other[lags].any(axis=1)
    Eu, Ek = E[use][:, unknown], E[use][:, ~unknown]
    u = np.linalg.lstsq(Eu, -Ek @ seg[~unknown], rcond=None)[0]
    x[a:b] = u
    bad[a:b] = False


def fill_gaps(x, mask, *, span: int) -> np.ndarray:
    """``x`` with the samples of ``mask`` interpolated (module docstring).

    Parameters
    ----------
    x : ndarray, shape (T,)
    mask : ndarray of bool, shape (T,)
        Samples to replace (clusters of a few).
    span : int [samples]
        Two periods of the lowest swept frequency: the AR model is fitted to twice that on
        either side of each cluster (at least 8 x its order).

    Returns
    -------
    ndarray, shape (T,)
    """
    y = np.array(x, dtype=float)
    bad = np.array(mask, dtype=bool)
    half = max(2 * span, 8 * AR_ORDER)
    for a, b in _clusters(bad):
        _fill_one(y, bad, int(a), int(b), half)
    return y


def _channel(records, rec, name, x, row, unit) -> Finding | None:
    opts = records.options
    span = max(2 * records.period_samples(rec), 16)
    mask = find_spikes(x, span=span, noise=records.noise(rec, row),
                       envelope=opts.spike_envelope, sigma=opts.spike_sigma,
                       width=opts.spike_width)
    edge = min(int(EDGE_S * records.fs), x.size // 4)
    mask[:edge], mask[x.size - edge:] = False, False
    if not mask.any():
        return None
    clusters = _clusters(mask)
    m = ndimage.median_filter(x, size=2 * (span // 2) + 1, mode="nearest")
    size = float(np.max(np.abs(x - m)[mask]))
    rate = len(clusters) / (x.size / records.fs)
    wide = int(np.max(clusters[:, 1] - clusters[:, 0]))
    what = (f"run {rec.file}, channel {name}: {len(clusters)} spike(s) up to {size:.4g} {unit} "
            f"off the local envelope")
    if rate <= opts.spike_max_rate and wide <= opts.spike_width:
        records.replace_signal(rec, row, fill_gaps(x, mask, span=span))
        return Finding("spike", rec.file, name, size, unit, "repaired",
                       f"{what}, interpolated from the samples around them")
    return Finding("spike", rec.file, name, size, unit, "warning",
                   f"{what} ({rate:.2g} per second, up to {wide} samples wide): too many to "
                   "repair; the first-harmonic extraction averages them out")


def check_spike(records) -> list[Finding]:
    """Spikes in every channel (module docstring); a few are repaired."""
    return records.each_signal(_channel)

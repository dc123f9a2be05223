"""Resonance peak / jump detection on a first-harmonic displacement curve, and rejection reasons.

Jump rule. Freeplay stiffens the hinge with amplitude (the backbone rises from 0 toward the
closed-hinge frequency), so an up-sweep climbs the upper branch to the peak, near the fold, and
then drops to the lower branch. Widths are measured in sweep frequency (time x |rate|) at the
level ``jump_ratio`` x maximum (default 1/2): ``fall`` after the maximum, ``rise`` before it
(infinite if the curve never gets that low on that side). The maximum is a *jump* when, for an
up-sweep, ``fall <= jump_width_hz`` (default 2 Hz) and ``rise >= jump_asymmetry * fall``
(default 3); for a down-sweep (which jumps up) the roles swap. Measured on the SDOF freeplay
oscillator (f_n = 50 Hz, zeta = 0.04, 0.6-1 g, 0.1-1 Hz/s) the fall takes 0.6-1.3 Hz and the rise
> 10 Hz. An in-gap response (amplitude ~ a_g / w^2, monotonic) has no fall, and a symmetric
linear resonance fails the asymmetry test.

Rejections, checked in this order (the reason string is stored with the point):
- ``too noisy``: the extracted mode's SNR over the record (mode vs residual) < ``min_snr_db``;
- no jump and the maximum sits at the end of the sweep: ``peak at band edge`` (the resonance may
  lie beyond the band);
- no jump, an up-sweep whose maximum sits at the start of the band and whose curve still drops
  later by the jump's ratio within ``jump_width_hz``: ``peak at the band's start`` (the response
  was already on its upper branch when the analysed band began, as on a damped fin whose lowest
  run in contact climbs no branch in band; the run is not used: a sweep started lower would
  let it climb its branch in band);
- no jump otherwise: ``no jump in band (response stayed in the gap)``;
- a jump whose peak is within ``edge_hz`` of either end of the analysed band: ``peak at band edge``.

A dead channel (constant, or a standard deviation far below the run's other channels or any
sensor's noise floor; :func:`.validate.dead_channel`) is ``channel <name> is dead (<why>)``, and a
dead base channel rejects the whole run (``base channel <name> is dead (<why>): it cannot be
subtracted``): subtracted, or extracted, a dead record would read as an in-gap response.
A channel that cannot be processed at all (constant, no sweep found in it, a failed solve) is
reported as ``extraction failed: <why>`` with NaN values instead of stopping the batch.
"""

from __future__ import annotations

import numpy as np
import scipy.ndimage

__all__ = ["find_jump_peak", "reason_dead", "REASON_NO_JUMP", "REASON_EDGE", "REASON_START",
           "REASON_NOISY", "REASON_FAILED"]

REASON_NO_JUMP = "no jump in band (response stayed in the gap)"
REASON_EDGE = "peak at band edge"
REASON_START = ("peak at the band's start (already on its upper branch there, it dropped later: "
                "start the sweep lower)")
REASON_NOISY = "too noisy"
REASON_FAILED = "extraction failed"  # followed by ": <why>" (no sweep found, a failed solve)


def reason_dead(channel: str, why: str) -> str:
    """The rejection reason of a dead channel (``why`` from ``dead_channel``), "" if alive."""
    return f"channel {channel} is dead ({why})" if why else ""


def find_jump_peak(
    time,
    frequency,
    amplitude_m,
    *,
    sweep_rate: float,
    band: tuple[float, float],
    jump_ratio: float = 0.5,
    jump_width_hz: float = 2.0,
    jump_asymmetry: float = 3.0,
    edge_hz: float = 0.5,
    require_jump: bool = True,
) -> tuple[int, str]:
    """Index of the displacement maximum and the rejection reason ("" when accepted).

    Parameters
    ----------
    time, frequency, amplitude_m : array_like, shape (N,) [s], [Hz], [m]
        The analysed (interior) part of one curve.
    sweep_rate : float [Hz/s]
        Signed; converts ``jump_width_hz`` to a time window.
    band : (float, float) [Hz]
        Frequencies at the two ends of the analysed part, in time order.
    jump_ratio, jump_width_hz, jump_asymmetry, edge_hz : float
        See the module docstring.
    require_jump : bool
        If False, an interior maximum without a jump is accepted too.
    """
    t = np.asarray(time, dtype=float)
    f = np.asarray(frequency, dtype=float)
    x = np.asarray(amplitude_m, dtype=float)
    k = int(np.argmax(x))
    low = np.nonzero(x <= jump_ratio * x[k])[0]
    after, before = low[low > k], low[low < k]
    # widths [Hz] of the fall after and the rise before the maximum, in time order
    fall = abs(sweep_rate) * (t[after[0]] - t[k]) if after.size else np.inf
    rise = abs(sweep_rate) * (t[k] - t[before[-1]]) if before.size else np.inf
    sharp, slow = (fall, rise) if sweep_rate > 0 else (rise, fall)
    jump = sharp <= jump_width_hz and slow >= jump_asymmetry * sharp
    at_edge = min(abs(f[k] - band[0]), abs(f[k] - band[1])) <= edge_hz
    at_end = abs(f[k] - band[1]) <= edge_hz
    if jump or not require_jump:
        return k, (REASON_EDGE if at_edge else "")
    if at_end:
        return k, REASON_EDGE
    if (sweep_rate > 0 and abs(f[k] - band[0]) <= edge_hz
            and _drops_later(t[k:], x[k:], jump_ratio, jump_width_hz / sweep_rate)):
        return k, REASON_START
    return k, REASON_NO_JUMP


def _drops_later(t, x, ratio: float, window_s: float) -> bool:
    """Whether the curve ``x`` (from its maximum, at ``x[0]``) falls anywhere, from at least
    ``ratio`` of that maximum, to ``ratio`` of where it fell from within ``window_s``: a drop
    off an upper branch, which a response in the gap (falling as 1 / f^2 over the band) has
    not."""
    if x.size < 2:
        return False
    dt = float(np.median(np.diff(t)))
    n = max(1, int(round(window_s / dt))) if dt > 0 else 1
    # the least value over [i, i + n] (forward window; past the end, the last value)
    ahead = np.concatenate([x, np.full(n, x[-1])])
    least = scipy.ndimage.minimum_filter1d(ahead, size=n + 1, origin=-(n // 2) - (n % 2),
                                           mode="nearest")[:x.size]
    high = x >= ratio * x[0]
    return bool(np.any(high & (least <= ratio * x)))

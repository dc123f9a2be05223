"""Where the fit starts: given starts, an inverse model's estimate or the multi-start grid, and
which of the multi-start's optima wins."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import InverseDomainWarning, InverseModelError
from .objective import MIN_GAP_RATIO, gap_ratios
from .options import MultiStart

__all__ = ["Start", "resolve_start", "count_resonances", "plausible_first"]


@dataclass(frozen=True)
class Start:
    """The fit's start(s).

    Attributes
    ----------
    points : list of (float, float)
        (kn [N m/rad], delta [rad]) of every start.
    label : str
        What produced them: "inverse", "multistart" or "given".
    inverse : dict or None
        The inverse model's estimate (kn, delta, log_kn_std, log_delta_std, checkpoint) when
        one started the fit.
    """

    points: list
    label: str
    inverse: dict | None = None


def _inverse_estimate(model, points, rate=None) -> dict:
    """The inverse model's estimate of (kn, delta) from the fitting points (and each point's
    sweep rate ``rate`` [Hz/s], for a network that reads it); ``outside``: the model's warning
    when the points lie outside its training domain (warned again here, before the estimate
    starts the fit), else ''."""
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", InverseDomainWarning)
            kn, delta, s_kn, s_delta = (model.predict_points(points, rate=rate)
                                        if getattr(model, "uses_rate", False) else
                                        model.predict_points(points))
    except ValueError as exc:  # e.g. a channel the network was not trained on
        raise InverseModelError(f"{getattr(model, 'path', 'inverse model')}: {exc}") from None
    outside = [str(w.message) for w in caught if issubclass(w.category, InverseDomainWarning)]
    for w in caught:  # the start is used anyway (the fit corrects it): say so
        domain = issubclass(w.category, InverseDomainWarning)
        warnings.warn_explicit(str(w.message) + ("; the fit starts from it all the same"
                                                 if domain else ""),
                               w.category, w.filename, w.lineno)
    return {"kn": float(kn), "delta": float(delta), "log_kn_std": float(s_kn),
            "log_delta_std": float(s_delta), "checkpoint": str(getattr(model, "path", "")),
            "outside": "; ".join(outside)}


def resolve_start(init, points, *, label: str | None = None,
                  multistart: MultiStart | None = None, rate=None) -> Start:
    """The start(s) of a fit of ``points`` from ``init``.

    ``init``: an object with ``predict_points(points) -> (kn, delta, log-stds...)`` (a
    :class:`freeplayid.inverse.InverseModel`: one start at its estimate, label "inverse"),
    one (kn, delta) or a sequence of them (label ``label``, else "given" for one and
    "multistart" for several), or None (``multistart``'s grid, default :class:`MultiStart`).
    ``rate``: each point's sweep rate [Hz/s], for an inverse model that reads it.

    Raises
    ------
    ValueError
        A start that is not finite and > 0.
    InverseModelError
        The inverse model cannot take these points.
    """
    if hasattr(init, "predict_points"):
        est = _inverse_estimate(init, points, rate)
        return Start([(est["kn"], est["delta"])], label or "inverse", est)
    if init is None:
        return Start((multistart or MultiStart()).starts(), "multistart")
    arr = np.asarray(init, dtype=float)
    starts = [tuple(arr)] if arr.ndim == 1 else [tuple(r) for r in arr]
    for k0, d0 in starts:
        if not (np.isfinite(k0) and np.isfinite(d0) and k0 > 0 and d0 > 0):
            raise ValueError(f"`init` values must be finite and > 0, got {(k0, d0)!r}")
    return Start(starts, label or ("given" if len(starts) == 1 else "multistart"))


def count_resonances(f_hz, *, rel_tol: float = 5e-3) -> int:
    """Distinct resonance frequencies among points (the channels of one run share one).

    Points closer than ``rel_tol`` (relative) to their neighbour count as one resonance. The
    default, 0.5 %, covers the scatter between the channels of one noisy run (0.2 % measured on
    the bundled example's 1.0 g run) and stays below the spacing of the peaks of different
    levels (1-3 Hz at 40-50 Hz on the default fin).
    """
    f = np.sort(np.asarray(f_hz, dtype=float).reshape(-1))
    if f.size == 0:
        return 0
    return int(1 + np.count_nonzero(np.diff(f) > rel_tol * f[1:]))


def plausible_first(runs, points, model):
    """The lowest-cost start whose optimum puts every point at Theta/delta >=
    :data:`MIN_GAP_RATIO` (1.5), else the lowest-cost one.

    Near contact the describing-function backbone is wrong (-7 % at 1.5), and with few points a
    start can find an optimum that fits them there, with a huge kn and a delta at the lowest
    point's amplitude, at a lower cost than the physical one (seen with 2 runs: kn 2e7 at cost
    4e-8 against kn 465 at 1.2e-7). ``runs`` is sorted by cost, each (cost, solution, start);
    ``model`` is the fit's DFA backbone model (its curves are cached per kn).
    """
    tried = set()
    for r in runs:
        kn, delta = (float(v) for v in np.exp(r[1].x))
        key = (round(np.log(kn), 6), round(np.log(delta), 6))
        if key in tried or not (np.isfinite(kn) and np.isfinite(delta)):
            continue
        tried.add(key)
        ratios, _ = gap_ratios(points, model.system, kn, delta, model.mode, model=model)
        if np.all(np.isfinite(ratios)) and ratios.min() >= MIN_GAP_RATIO:
            return r
    return runs[0]

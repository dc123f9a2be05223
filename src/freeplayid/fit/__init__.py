"""Backbone least squares: fitting points, the model function, the starts, the fit and its
intervals.

``points``: :class:`FittingPoints`, the point-record type of the fit and the inverse model.
``objective``: :class:`BackboneModel`, f_BC(X; kn, delta) with per-kn curve caching, and the
points' distance from contact (:func:`gap_ratios`).
``options``: :class:`FitOptions`, :class:`MultiStart`.
``starts``: :func:`resolve_start`, :func:`count_resonances`, the multi-start's choice.
``least_squares``: :func:`fit_backbone` -> :class:`FitResult`.
``uncertainty``: :func:`jacobian_intervals` (:func:`jacobian_halfwidths` for any number of
parameters), :func:`bootstrap_intervals`.
"""

from .fitting_points import FittingPoints
from .least_squares import FitResult, fit_backbone
from .objective import MIN_GAP_RATIO, BackboneModel, gap_ratios
from .options import FitOptions, MultiStart, multistart_grid
from .starts import Start, count_resonances, resolve_start
from .uncertainty import bootstrap_intervals, jacobian_halfwidths, jacobian_intervals

__all__ = [
    "FittingPoints",
    "FitOptions",
    "MultiStart",
    "BackboneModel",
    "FitResult",
    "Start",
    "fit_backbone",
    "multistart_grid",
    "resolve_start",
    "count_resonances",
    "gap_ratios",
    "MIN_GAP_RATIO",
    "jacobian_intervals",
    "jacobian_halfwidths",
    "bootstrap_intervals",
]

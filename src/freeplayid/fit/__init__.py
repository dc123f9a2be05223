"""Backbone least squares: fitting points, the model function, the fit and its intervals.

``points``: :class:`FittingPoints`, the point-record type of the fit and the inverse model.
``objective``: :class:`BackboneModel`, f_BC(X; kn, delta) with per-kn curve caching.
``lsq``: :func:`fit_backbone` -> :class:`FitResult`, :func:`multistart_grid`,
:func:`count_resonances`.
``uncertainty``: :func:`jacobian_intervals`, :func:`bootstrap_intervals`.
"""

from .lsq import FitResult, count_resonances, fit_backbone
from .objective import BackboneModel
from .options import FitOptions, MultiStart, multistart_grid
from .points import FittingPoints
from .uncertainty import bootstrap_intervals, jacobian_intervals

__all__ = [
    "FittingPoints",
    "FitOptions",
    "MultiStart",
    "BackboneModel",
    "FitResult",
    "fit_backbone",
    "multistart_grid",
    "count_resonances",
    "jacobian_intervals",
    "bootstrap_intervals",
]

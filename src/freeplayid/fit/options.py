"""The fit's options as records: :class:`FitOptions` and its :class:`MultiStart` grid."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..arguments import check_int, check_range
from ..backbone import backbone_method

__all__ = ["FitOptions", "MultiStart", "multistart_grid"]


def multistart_grid(
    n: int = 5,
    *,
    kn_range: tuple[float, float] = (1e2, 1e7),
    delta_range: tuple[float, float] = (1e-4, 1e-2),
) -> list[tuple[float, float]]:
    """n x n log-uniform grid of (kn [N m/rad], delta [rad]) starts."""
    kns = np.geomspace(*kn_range, n)
    deltas = np.geomspace(*delta_range, n)
    return [(float(k), float(d)) for k in kns for d in deltas]


@dataclass(frozen=True)
class MultiStart:
    """The pure-fitting baseline's grid of starts: ``n`` x ``n`` log-uniform in the ranges.

    Attributes
    ----------
    n : int
        Starts per axis.
    kn_range : (float, float) [N m/rad]
        Default [1e2, 1e7]: hinge stiffnesses of folding fins (rotational, N m/rad: the default
        fin's 480) and of translational hinges (N/m: 5e4-2e5 in benchmarks/replay_beam.py).
        The studies' documented runs used [1e3, 1e8] (pinned in their experiment configs);
        both grids give the same fits, [1e2, 1e7] at 12-26 % more evaluations
        (benchmarks/multistart_range.py).
    delta_range : (float, float) [rad]
    """

    n: int = 5
    kn_range: tuple = (1e2, 1e7)
    delta_range: tuple = (1e-4, 1e-2)

    def __post_init__(self):
        check_int("n", self.n, 1)
        object.__setattr__(self, "kn_range", check_range("kn_range", self.kn_range))
        object.__setattr__(self, "delta_range", check_range("delta_range", self.delta_range))

    def starts(self) -> list[tuple[float, float]]:
        """The grid's (kn, delta) starts (:func:`multistart_grid`)."""
        return multistart_grid(self.n, kn_range=self.kn_range, delta_range=self.delta_range)


@dataclass(frozen=True)
class FitOptions:
    """How the backbone is fitted to the points (:func:`freeplayid.fit.fit_backbone`).

    Validated on construction; a bad value raises ``ValueError`` naming the field.

    Attributes
    ----------
    backbone : str
        Backbone method (:data:`freeplayid.backbone.BACKBONE_METHODS`: "dfa", or "hb" refined
        from the DFA optimum).
    mode : int
        Backbone mode (0: the lowest, first bending).
    n_bootstrap : int
        Bootstrap resamples over the points for percentile intervals (0: none).
    seed : int
        Seed of that bootstrap.
    multistart : MultiStart
        The grid of starts used when nothing else starts the fit (a mapping of its fields is
        accepted).
    init : InverseModel, (kn, delta), sequence of them, or None
        The fit's start: a trained inverse model (:func:`freeplayid.inverse.load_inverse_model`;
        one start at its estimate from the points), given start(s) [N m/rad, rad], or None for
        the ``multistart`` grid. Not a config key (the scripts' ``init`` key picks it).
    """

    backbone: str = "dfa"
    mode: int = 0
    n_bootstrap: int = 0
    seed: int = 0
    multistart: MultiStart = field(default_factory=MultiStart)
    init: object = field(default=None, metadata={"config": False})

    def __post_init__(self):
        backbone_method(self.backbone, argument="backbone")
        check_int("mode", self.mode, 0)
        check_int("n_bootstrap", self.n_bootstrap, 0)
        check_int("seed", self.seed, 0)
        ms = self.multistart
        if isinstance(ms, Mapping):
            names = {f.name for f in dataclasses.fields(MultiStart)}
            if set(ms) - names:
                raise ValueError(f"`multistart` has unknown field(s) {sorted(set(ms) - names)}; "
                                 f"valid: {sorted(names)}")
            try:
                ms = MultiStart(**ms)
            except ValueError as exc:
                raise ValueError(str(exc).replace("`", "`multistart.", 1)) from None
        if not isinstance(ms, MultiStart):
            raise ValueError(f"`multistart` must be a MultiStart, got {type(ms).__name__}")
        object.__setattr__(self, "multistart", ms)
        object.__setattr__(self, "init", _checked_init(self.init))


def _checked_init(init):
    """``init`` as stored: an inverse model as given, starts as a tuple of (kn, delta) floats
    (one start stays one pair); ValueError naming ``init`` unless every value is finite > 0."""
    if init is None or hasattr(init, "predict_points"):
        return init
    try:
        arr = np.asarray(init, dtype=float)
    except (TypeError, ValueError):
        arr = np.empty(0)
    if arr.ndim not in (1, 2) or arr.shape[-1] != 2 or arr.size == 0:
        raise ValueError("`init` must be an inverse model, one (kn, delta) or a sequence of "
                         f"them, got {init!r}")
    if not (np.all(np.isfinite(arr)) and np.all(arr > 0)):
        raise ValueError(f"`init` values must be finite and > 0, got {init!r}")
    return tuple(map(float, arr)) if arr.ndim == 1 else tuple(tuple(map(float, r)) for r in arr)

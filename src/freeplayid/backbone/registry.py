"""The backbone-method registry: one name per method, :func:`backbone_curve` picks by name.

Adding a method is one new module with a function
``f(system, *, kn, delta, mode=0, **options) -> BackboneCurve`` and one line in
:data:`BACKBONE_METHODS` (torchdiffeq's ``SOLVERS``, diffrax's solvers). Everything that picks a
backbone by name (the fit, the identification task) goes through :func:`backbone_method`, so the
valid names live here only.
"""

from __future__ import annotations

from collections.abc import Callable

from ..model import FreeplaySystem
from .dfa import BackboneCurve, dfa_backbone
from .hb import hb_backbone

__all__ = ["BACKBONE_METHODS", "backbone_method", "backbone_curve"]

BACKBONE_METHODS: dict[str, Callable[..., BackboneCurve]] = {
    "dfa": dfa_backbone,
    "hb": hb_backbone,
}


def backbone_method(name: str, *, argument: str = "method") -> Callable[..., BackboneCurve]:
    """The backbone function registered as ``name``.

    Parameters
    ----------
    name : str
        A key of :data:`BACKBONE_METHODS`.
    argument : str
        The caller's argument name, used in the error message (e.g. ``"backbone"``).

    Raises
    ------
    ValueError
        ``name`` is not registered; the message lists the valid names.
    """
    try:
        return BACKBONE_METHODS[name]
    except (KeyError, TypeError):  # TypeError: an unhashable name
        raise ValueError(
            f"`{argument}` must be one of {sorted(BACKBONE_METHODS)}, got {name!r}"
        ) from None


def backbone_curve(
    system: FreeplaySystem, *, method: str = "dfa", kn, delta, mode: int = 0, **options
) -> BackboneCurve:
    """Backbone curve of ``system`` by the method registered as ``method``.

    Parameters
    ----------
    system : FreeplaySystem
    method : str
        A key of :data:`BACKBONE_METHODS`: ``"dfa"`` (describing function, batched over
        (kn, delta)) or ``"hb"`` (multi-harmonic balance, one (kn, delta)).
    kn : float or array_like, shape (k,) [N m/rad]
    delta : float or array_like, shape (k,) [rad]
    mode : int
        Mode counted from the lowest (0).
    **options
        Passed to the method (e.g. ``s``, ``equal_hinges`` for "dfa"; ``s``, ``n_harmonics`` for
        "hb").

    Returns
    -------
    BackboneCurve

    Raises
    ------
    ValueError
        Unknown ``method`` (the message lists the valid names), or the method's own checks.
    """
    return backbone_method(method)(system, kn=kn, delta=delta, mode=mode, **options)

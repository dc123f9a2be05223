"""Backbone curves of freeplay systems: describing function (DFA) and multi-harmonic balance."""

from .dfa import BackboneCurve, amplitude_grid, dfa_backbone

__all__ = ["BackboneCurve", "amplitude_grid", "dfa_backbone"]
from .hb import hb_backbone  # noqa: E402

__all__ += ["hb_backbone"]

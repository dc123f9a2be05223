"""Backbone curves of freeplay systems: describing function (DFA) and multi-harmonic balance,
picked by name through :func:`backbone_curve` (registry :data:`BACKBONE_METHODS`)."""

from .dfa import BackboneCurve, amplitude_grid, dfa_backbone
from .hb import hb_backbone
from .registry import BACKBONE_METHODS, backbone_curve, backbone_method

__all__ = [
    "BackboneCurve",
    "amplitude_grid",
    "dfa_backbone",
    "hb_backbone",
    "BACKBONE_METHODS",
    "backbone_curve",
    "backbone_method",
]

"""Sine-sweep base excitation and the batched RK4 simulator."""

from .sweep import G, Sweep

__all__ = ["G", "Sweep"]

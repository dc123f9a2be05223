"""The exponential engine: exact linear part and contact per step, step set by accuracy.

``steps.py``: the step matrices and the step rule (NumPy/SciPy); ``kernel.py``: the compiled
kernel (numba, imported when an engine is built); ``engine.py``: the registry entry.
"""

from .engine import ExpoEngine

__all__ = ["ExpoEngine"]

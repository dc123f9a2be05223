"""The numba engine: compiled CPU RK4 kernels of the full (``rk4.py``) and the quasi-static
(``rk4_qs.py``) model, with what the compiled kernels share (also the exponential one of
``..expo``): their arithmetic (``arith.py``), the fused anti-aliasing FIR (``fir.py``) and their
first call (``jit.py``).

Importing this package does not import numba (optional): the kernels are imported when an
engine is built.
"""

from .engine import NumbaEngine, numba_available

__all__ = ["NumbaEngine", "numba_available"]

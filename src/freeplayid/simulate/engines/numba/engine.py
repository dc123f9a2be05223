"""The numba engine: the compiled CPU RK4 kernels (``rk4.py``, and ``rk4_qs.py`` for the
quasi-static model), which decimate on the fly into the signal array.

numba is optional and its kernels compile on first use, so this module imports neither: the
kernels are imported when an engine is built.
"""

from __future__ import annotations

import numpy as np

from ..protocol import EngineSetup, rk4_max_step

__all__ = ["NumbaEngine", "numba_available"]


def numba_available() -> bool:
    """True if numba imports, so the compiled engines (``rk4.py``, ``..expo``) can be used."""
    try:
        import numba  # noqa: F401
    except Exception:  # pragma: no cover - depends on the environment
        return False
    return True


class NumbaEngine:
    """:class:`..protocol.Engine` of :class:`.rk4.NumbaRK4` (full model) and
    :class:`.rk4_qs.NumbaQSRK4` (quasi-static): CPU only, decimates in place."""

    devices = ("cpu",)
    quasi_static = True
    decimates = True
    differentiates = False
    gap_shares = False  # one common gap (the RK4 kernels take delta per member only)
    static_load = False
    contact_damping = False  # damping in contact: the exponential engine only
    max_step = staticmethod(rk4_max_step)
    name = "numba"

    def __init__(self, setup: EngineSetup):
        s = setup
        kw = dict(h=s.h, quantity=s.quantity, dtype=s.dtype, taps=s.taps, factor=s.factor)
        if s.quasi_static is None:
            from .rk4 import NumbaRK4

            self.kernel = NumbaRK4(s.form, s.kn, s.delta, s.level_g, s.eta0, s.v0, **kw)
        else:
            from .rk4_qs import NumbaQSRK4

            self.kernel = NumbaQSRK4(s.quasi_static, s.kn, s.delta, s.level_g, s.eta0, s.v0,
                                     taps_d=s.taps_d, **kw)
        self.record_width = self.kernel.width  # output channels: the kernel records no steps

    @classmethod
    def available(cls) -> bool:
        return numba_available()

    def run(self, s_half: np.ndarray, out: np.ndarray | None = None) -> int:
        if out is None:
            raise ValueError(f"the {self.name} engine decimates into `out`; it must be given")
        before = self.kernel.outputs
        self.kernel.run(s_half, out=out)
        return self.kernel.outputs - before

    @property
    def diverged(self) -> np.ndarray:
        return self.kernel.diverged

"""The exponential engine: the compiled CPU kernel of the exponential integrator (the step
matrices and step rule in ``steps.py``, the kernel in ``kernel.py``), which decimates on the fly
into the signal array.

Its step is set by accuracy, not stability (:meth:`ExpoEngine.max_step`): the linear modal
dynamics are integrated exactly, the contact implicitly and exactly per member, so a stiff or
overdamped mode costs nothing. numba is optional; the kernel is imported when an engine is built.
"""

from __future__ import annotations

from ....sweep import Sweep
from ...formulation import ModalForm
from ..numba.engine import NumbaEngine, numba_available
from ..protocol import EngineSetup
from .steps import expo_step_limit, per_state_scheme

__all__ = ["ExpoEngine"]


class ExpoEngine(NumbaEngine):
    """:class:`..protocol.Engine` of :class:`.kernel.NumbaExpo`: CPU only, full model,
    decimates in place, step by the accuracy rule (:func:`.steps.expo_step_limit`).
    Running and divergence are the numba engine's (its kernel has the same interface)."""

    devices = ("cpu",)
    quasi_static = False
    decimates = True
    differentiates = True
    gap_shares = True
    static_load = True
    contact_damping = True
    name = "expo"

    def __init__(self, setup: EngineSetup):
        from .kernel import NumbaExpo

        s = setup
        # velocity and acceleration: the displacement, differentiated by the decimating FIR
        # (taps_d), so the point samples do not alias the ringing after each switch
        derived = s.taps_d is not None
        self.kernel = NumbaExpo(s.form, s.kn, s.delta, s.level_g, s.eta0, s.v0, h=s.h,
                                quantity="displacement" if derived else s.quantity,
                                dtype=s.dtype, taps=s.taps_d if derived else s.taps,
                                factor=s.factor, gap_shares=s.gap_shares,
                                static_g=s.static_g, contact_damping=s.contact_damping)
        self.record_width = self.kernel.width

    @staticmethod
    def max_step(form: ModalForm, *, sweep: Sweep, kn_max: float, omega_dt: float,
                 distinct_kn: int = 1) -> float:
        """:meth:`..protocol.Engine.max_step` by accuracy (:func:`.steps.expo_step_limit`: steps
        per period of the sweep's top frequency, and, where the batch's distinct kn are too many
        for the exact per-state scheme, of the closed-hinge modes that a contact excites);
        ``omega_dt`` is not used (no stability bound)."""
        return expo_step_limit(form, top_hz=max(sweep.start_hz, sweep.stop_hz), kn_max=kn_max,
                               per_state=per_state_scheme(distinct_kn))

    @classmethod
    def available(cls) -> bool:
        return numba_available()

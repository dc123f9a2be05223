"""Sine-sweep base excitation and the batched RK4 simulator.

``simulate_sweeps`` integrates a batch of (kn, delta, level) members with fixed-step RK4 on a
torch engine (CPU or CUDA) or a compiled numba CPU kernel, or with the exponential integrator,
and returns a :class:`SweepResult` at the output sample rate; ``sweep_dataset`` makes it a
data set. See docs/simulate.md.
"""

from ..quantity import G
from ..sweep import Sweep
from .formulation import ModalForm, ModalTruncation, build_modal_form, rk4_step_limit
from .plan import DEFAULT_OMEGA_DT, rk4_step_count
from .quasistatic import QuasiStatic
from .records import default_columns, sweep_dataset
from .resample import StreamingDecimator, decimator_gain, design_decimator
from .run import SweepResult, simulate_sweeps

__all__ = [
    "G",
    "Sweep",
    "simulate_sweeps",
    "sweep_dataset",
    "default_columns",
    "SweepResult",
    "ModalForm",
    "ModalTruncation",
    "QuasiStatic",
    "build_modal_form",
    "rk4_step_limit",
    "rk4_step_count",
    "design_decimator",
    "decimator_gain",
    "StreamingDecimator",
    "DEFAULT_OMEGA_DT",
]

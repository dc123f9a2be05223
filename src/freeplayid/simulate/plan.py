"""The step plan of a simulation: the equations, the step and the step count, before running.

:func:`step_plan` builds the modal form of the request (with the quasi-static condensation when
asked), takes the engine's step rule (``Engine.max_step``) down to a whole fraction of the
output sample interval, and designs the decimating filter, which sets how far past the sweep's
end the integration runs. :func:`rk4_step_count` is the same plan without the filter: what a
simulation would cost, known up front.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.system import FreeplaySystem
from ..sweep import Sweep
from .engines.protocol import rk4_max_step
from .formulation import ModalForm, build_modal_form
from .quasistatic import QuasiStaticForm, condense_modal_form
from .resample import PASSBAND, derivative_taps, design_decimator

__all__ = ["StepPlan", "step_plan", "output_samples", "rk4_step_count", "DEFAULT_OMEGA_DT"]

# omega_max * dt of the fastest closed-hinge mode. Measured on the 12-DOF test fin (3 kHz top
# mode, docs/simulate.md): at 1.5 the linear response is within ~3e-7 of the matrix-exponential
# solution and the first-harmonic peak of the freeplay response within ~2e-5 of a 6x finer step;
# the RK4 stability limit is 2.785.
DEFAULT_OMEGA_DT = 1.5


@dataclass(frozen=True)
class StepPlan:
    """What a simulation will integrate, with which step, for how many steps (before running).

    Attributes
    ----------
    form : ModalForm
        The equations an engine integrates (with ``qs``, the slow part ``qs.slow``).
    qs : QuasiStaticForm or None
        The quasi-static condensation (``quasi_static_hz``).
    m : int
        Steps per output sample.
    h : float [s]
        The step, ``1 / (sample_rate m)``.
    taps, taps_d : ndarray, shape (n_taps,), or None
        The anti-aliasing FIR at the step rate and, with ``qs`` and velocity or acceleration,
        the derivative FIR of the fast part (``taps`` then the fused one); None without filters.
    n_out : int
        Output samples, from 0 to the sweep's duration.
    look : int
        Output samples of the filter's look-ahead integrated past the end.
    n_steps : int
        Recorded step-rate samples t_0 .. t_{n_steps - 1}.
    """

    form: ModalForm
    qs: QuasiStaticForm | None
    m: int
    h: float
    taps: np.ndarray | None
    taps_d: np.ndarray | None
    n_out: int
    look: int
    n_steps: int


def output_samples(sweep, sample_rate: float) -> int:
    """Samples of a simulated record: [0, ``sweep.duration``] at ``sample_rate``."""
    return int(math.floor(sweep.duration * sample_rate + 1e-9)) + 1


def step_plan(system, *, kn_max, sweep, sample_rate, channels, quantity, frame, method,
              cutoff_hz, quasi_static_hz, omega_dt, steps_per_sample, large_mass_ratio,
              filters: bool = True, max_step=rk4_max_step, distinct_kn: int = 1,
              differentiate: bool = False, passband: float = PASSBAND) -> StepPlan:
    """The :class:`StepPlan` of a simulation: the modal form, the step and the step count.

    The arguments are those of :func:`.run.simulate_sweeps` (``kn_max``: the batch's largest
    kn). Without ``filters`` no decimator is designed (its length grows with m) and the count
    leaves out the filter look-ahead (a few samples). ``max_step`` is the engine's step rule
    (``Engine.max_step``; default the RK4 engines' stability rule), given the batch's
    ``distinct_kn``. ``differentiate`` (an engine that records velocity and acceleration as
    derivatives of its displacement, ``Engine.differentiates``): ``taps_d`` is the decimating
    FIR of that derivative (``resample.derivative_taps``), ``taps`` the same FIR's padded form
    for the base signals.
    """
    qs = None
    if quasi_static_hz is not None:
        if cutoff_hz is not None:
            raise ValueError("`quasi_static_hz` and `cutoff_hz` cannot be combined")
        if method != "relative":
            raise ValueError(f"`quasi_static_hz` needs method='relative', got {method!r}")
    form = build_modal_form(
        system, channels=channels, quantity=quantity, frame=frame, method=method,
        kn_max=kn_max, cutoff_hz=cutoff_hz, large_mass_ratio=large_mass_ratio,
    )
    if quasi_static_hz is not None:
        qs = condense_modal_form(form, threshold_hz=quasi_static_hz, quantity=quantity,
                                 kn_max=kn_max)
        form = qs.slow
    if steps_per_sample is None:
        h_max = max_step(form, sweep=sweep, kn_max=kn_max, omega_dt=omega_dt,
                         distinct_kn=distinct_kn)
        # a differentiated record needs a decimating FIR (m >= 2): the derivative stencil alone
        # would pass the displacement's aliased ringing at its full derivative
        m = max(2 if differentiate else 1, math.ceil(1.0 / (sample_rate * h_max) - 1e-9))
    else:
        if not (isinstance(steps_per_sample, (int, np.integer)) and steps_per_sample >= 1):
            raise ValueError(f"`steps_per_sample` must be an int >= 1, got {steps_per_sample!r}")
        m = int(steps_per_sample)
    h = 1.0 / (sample_rate * m)

    n_out = output_samples(sweep, sample_rate)
    if not filters:
        return StepPlan(form=form, qs=qs, m=m, h=h, taps=None, taps_d=None, n_out=n_out,
                         look=0, n_steps=(n_out - 1) * m + 1)
    taps = design_decimator(m, passband=passband)
    taps_d = None
    if (qs is not None or differentiate) and quantity != "displacement":
        # the fast part's derivative (or the whole record's, ``differentiate``) is decimated by
        # the same fused FIR (resample.derivative_taps)
        taps, taps_d = derivative_taps(taps, m, h, 1 if quantity == "velocity" else 2)
    look = (len(taps) - 1) // 2 // m + 1  # filter look-ahead (+1: the polyphase block padding)
    n_steps = (n_out - 1 + look) * m + 1  # recorded step-rate samples t_0 .. t_{n_steps-1}
    return StepPlan(form=form, qs=qs, m=m, h=h, taps=taps, taps_d=taps_d, n_out=n_out,
                     look=look, n_steps=n_steps)


def rk4_step_count(
    system: FreeplaySystem, *, kn: float, sweep: Sweep, sample_rate: float, channels,
    quantity: str = "acceleration", frame: str = "absolute", method: str = "relative",
    omega_dt: float = DEFAULT_OMEGA_DT, cutoff_hz: float | None = None,
    quasi_static_hz: float | None = None, large_mass_ratio: float = 1e6,
) -> tuple[int, float]:
    """RK4 steps per batch member :func:`.run.simulate_sweeps` would take, without simulating.

    The step follows the fastest closed-hinge mode (``omega_max * dt <= omega_dt``), so it
    shrinks as sqrt(kn) grows: the cost of a huge contact stiffness is known up front.

    Parameters
    ----------
    kn : float [N m/rad]
        The largest contact stiffness of the batch.
    sweep, sample_rate, channels, quantity, frame, method, omega_dt, cutoff_hz,
    quasi_static_hz, large_mass_ratio
        As :func:`.run.simulate_sweeps`.

    Returns
    -------
    n_steps : int
        Steps per member over the whole sweep (less the filter's look-ahead, a few samples).
    dt : float [s]
        The step.
    """
    if isinstance(channels, str):
        channels = (channels,)
    plan = step_plan(system, kn_max=float(kn), sweep=sweep, sample_rate=float(sample_rate),
                      channels=tuple(channels), quantity=quantity, frame=frame, method=method,
                      cutoff_hz=cutoff_hz, quasi_static_hz=quasi_static_hz, omega_dt=omega_dt,
                      steps_per_sample=None, large_mass_ratio=large_mass_ratio, filters=False)
    return plan.n_steps, plan.h

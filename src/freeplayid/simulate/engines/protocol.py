"""What an engine is: the :class:`Engine` protocol, the :class:`EngineSetup` it is built from,
and the RK4 engines' step rule :func:`rk4_max_step` (the constants every engine shares,
``MODES`` and ``BLOWUP``, are the formulation's)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Protocol

import numpy as np
import torch

from ...sweep import Sweep
from ..formulation import ModalForm, rk4_step_limit
from ..quasistatic import QuasiStaticForm

__all__ = ["Engine", "EngineSetup", "rk4_max_step"]


@dataclass(frozen=True)
class EngineSetup:
    """Everything an engine is built from: the equations, the members and the step.

    Attributes
    ----------
    form : ModalForm
        The modal equations to integrate (with ``quasi_static``, its slow part ``.slow``).
    quasi_static : QuasiStaticForm or None
        The condensed fast modes (only for engines with ``Engine.quasi_static``).
    kn, delta, level_g : ndarray, shape (batch,) [N m/rad], [rad], [g]
    eta0, v0 : ndarray, shape (batch, form.n_modes) [modal units]
        Initial modal state.
    h : float [s]
        RK4 step.
    quantity : str
        Recorded quantity: displacement | velocity | acceleration.
    dtype : torch.float32 or torch.float64
    device : torch.device
    taps : ndarray, shape (n_taps,) [-]
        Anti-aliasing FIR at the step rate (``resample.design_decimator``); engines that decimate
        apply it themselves.
    taps_d : ndarray, shape (n_taps,) or None [-]
        With ``quasi_static`` and velocity or acceleration: the FIR of the fast part's
        derivative (``resample.derivative_taps``); ``taps`` then are the fused ones. For an
        engine that ``differentiates``: the FIR of the displacement's derivative.
    factor : int
        Steps per output sample (the decimation factor).
    cuda_graphs : bool or None
        Replay the step loop as CUDA graphs (engines on CUDA; None: their default).
    gap_shares : ndarray, shape (H,) or None [-]
        Unequal gaps: hinge j's half-gap is ``delta * gap_shares[j]`` for every member (only for
        engines with ``Engine.gap_shares``); None: one common gap.
    static_g : float [g]
        A constant acceleration of the frame along the base axis (gravity on a vertical shaker),
        added to every member's excitation (only for engines with ``Engine.static_load``; the
        members then start in its static equilibrium, ``eta0``); 0: none.
    contact_damping : ndarray, shape (H,) or None [N m s/rad]
        A viscous damper across hinge j that acts only while it is in contact (its moment
        ``c_j theta_j'``; only for engines with ``Engine.contact_damping``); None: none.
    """

    form: ModalForm
    quasi_static: QuasiStaticForm | None
    kn: np.ndarray
    delta: np.ndarray
    level_g: np.ndarray
    eta0: np.ndarray
    v0: np.ndarray
    h: float
    quantity: str
    dtype: torch.dtype
    device: torch.device
    taps: np.ndarray
    taps_d: np.ndarray | None
    factor: int
    cuda_graphs: bool | None = None
    gap_shares: np.ndarray | None = None
    static_g: float = 0.0
    contact_damping: np.ndarray | None = None


class Engine(Protocol):
    """A fixed-step engine of the modal equations, run chunk by chunk by ``simulate_sweeps``.

    The class declares what it can do; ``simulate_sweeps`` validates the engine, device and
    quasi-static combination from these declarations and never branches on an engine's name.

    Attributes
    ----------
    devices : tuple of str or None
        ``torch.device.type`` values it runs on (``("cpu",)``); None: any torch device.
    quasi_static : bool
        Whether it integrates a quasi-statically condensed model (``quasi_static_hz``).
    decimates : bool
        True: ``run`` decimates on the fly and writes the output samples that a chunk
        completes into the signal array ``out`` in place (the caller then adds the base terms in
        one compiled pass). False: ``run`` returns the chunk's step-rate records, which the
        caller decimates.
    differentiates : bool
        True: it records velocity and acceleration as the derivative of its displacement,
        taken by its decimating FIR (``EngineSetup.taps_d``), so that the fast modes' ringing
        after each contact switch, which point samples of an acceleration would alias into the
        band, does not set its step (docs/simulate.md, "Exponential engine").
    gap_shares : bool
        Whether it takes unequal gaps (``EngineSetup.gap_shares``).
    static_load : bool
        Whether it takes a constant acceleration of the frame (``EngineSetup.static_g``).
    contact_damping : bool
        Whether it takes damping that acts only in contact (``EngineSetup.contact_damping``).
    record_width : int
        Values held per member and step of a chunk (bounds the steps per chunk in memory).
    """

    devices: ClassVar[tuple[str, ...] | None]
    quasi_static: ClassVar[bool]
    decimates: ClassVar[bool]
    differentiates: ClassVar[bool] = False
    gap_shares: ClassVar[bool] = False
    static_load: ClassVar[bool] = False
    contact_damping: ClassVar[bool] = False
    record_width: int

    def __init__(self, setup: EngineSetup) -> None: ...

    @staticmethod
    def max_step(form: ModalForm, *, sweep: Sweep, kn_max: float, omega_dt: float,
                 distinct_kn: int = 1) -> float:
        """The largest step [s] this engine takes for ``form`` (its step rule).

        ``simulate_sweeps`` runs at the largest whole fraction of the output sample interval
        that is not longer (``steps_per_sample`` overrides it). The RK4 engines' rule is set by
        stability (:func:`rk4_max_step`); an engine with no stability bound (the exponential one)
        sets it by accuracy and need not use ``omega_dt``.

        Parameters
        ----------
        form : ModalForm
            The equations it integrates (the slow part of a quasi-static condensation).
        sweep : Sweep
        kn_max : float [N m/rad]
            The batch's largest contact stiffness.
        omega_dt : float [-]
            The caller's bound on ``omega_max * dt`` for a stability rule.
        """
        ...

    @classmethod
    def available(cls) -> bool:
        """Whether it can run here (its optional dependencies import)."""
        ...

    def run(self, s_half: np.ndarray, out: np.ndarray | None = None) -> torch.Tensor | int:
        """Integrate one chunk of ``L = (len(s_half) - 1) / 2`` steps.

        Parameters
        ----------
        s_half : ndarray, shape (2 L + 1,) [-], float64
            sin(phase) at t_i + k h / 2, k = 0..2L, of the chunk's steps t_i.
        out : ndarray, shape (batch, channel, n_out), optional
            Engines that decimate: the whole signal array (C-contiguous, the simulation dtype),
            the chunk's completed output samples go to the columns after those written so far
            (samples at or past ``n_out``, the filter's tail, are dropped). Others: None.

        Returns
        -------
        int or Tensor
            Engines that decimate: the number of output samples the chunk completed (written or
            dropped). Others: the recorded channels at t_0 .. t_{L-1} of the chunk, shape
            (batch, channel, L), in the simulation dtype, on the engine's device.
        """
        ...

    @property
    def diverged(self) -> np.ndarray:
        """(batch,) bool: members flagged as diverged so far (frozen at rest since)."""
        ...


def rk4_max_step(form: ModalForm, *, sweep: Sweep, kn_max: float, omega_dt: float,
                 distinct_kn: int = 1) -> float:
    """The RK4 engines' :meth:`Engine.max_step`, set by stability: ``omega_max * dt <= omega_dt``
    of the fastest closed-hinge mode (:func:`..formulation.rk4_step_limit`; ``form.omega_max``
    is that of ``kn_max``, and the sweep does not matter)."""
    return rk4_step_limit(form.omega_max, omega_dt=omega_dt)

"""`simulate_sweeps`: batched sine-sweep responses of a freeplay system, and its result.

The steps: check the request, resolve the engine, plan the step (``plan.py``), build the
engine on the members at rest, integrate chunk by chunk (``chunks.py``), collect the result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from ..model.system import FreeplaySystem
from ..quantity import G, si_unit
from ..sweep import MeasuredSweep, Sweep
from .chunks import integrate_chunks
from .engines import AUTO, ENGINES, EngineSetup, resolve_engine
from .formulation import METHODS, ModalTruncation, static_equilibrium
from .plan import DEFAULT_OMEGA_DT, StepPlan, step_plan
from .quasistatic import QuasiStatic
from .resample import PASSBAND

__all__ = ["simulate_sweeps", "SweepResult"]


@dataclass(frozen=True)
class SweepResult:
    """Responses of a batch of sine sweeps at the output sample rate.

    Attributes
    ----------
    time : ndarray, shape (T,) [s]
        Output times k / sample_rate, from 0 to the sweep duration.
    signals : ndarray, shape (batch, channel, T) [m, m/s or m/s^2; rad for rotations]
        Numpy array in the simulation dtype (float32 or float64) on the CPU, so that the
        array-based ``signal``/``io`` code can use it directly. Rows of diverged members are NaN.
    channels : tuple of str
        DOF name of each channel.
    quantity : str
        displacement | velocity | acceleration.
    frame : str
        absolute (what accelerometers measure) | relative (to the base).
    diverged : ndarray, shape (batch,) bool
        Members whose state became non-finite or absurdly large; frozen, the others unaffected.
    dt : float [s]
        Step actually used (1 / (sample_rate * steps_per_sample)).
    sample_rate : float [Hz]
    kn, delta, level_g : ndarray, shape (batch,) [N m/rad], [rad], [g]
        Broadcast parameters of each member.
    sweep : Sweep
    method : str
        relative | large_mass.
    engine : str
        The registry name (``engines.ENGINES``) of the engine that ran: torch | numba | expo.
    omega_max : float [rad/s]
        Fastest closed-hinge eigenvalue magnitude that set the step.
    truncation : ModalTruncation or None
        What modal truncation dropped, with its error estimate.
    quasi_static : QuasiStatic or None
        What quasi-static condensation of the fast modes did (``quasi_static_hz``).
    gap_shares : tuple of float or None
        Unequal gaps: hinge j's half-gap was ``delta * gap_shares[j]``; None: one common gap.
    static_g : float [g]
        The constant acceleration of the frame along the base axis (gravity) that was added.
    contact_damping : tuple of float or None [N m s/rad]
        Each hinge's damper acting only in contact; None: none.
    """

    time: np.ndarray
    signals: np.ndarray
    channels: tuple[str, ...]
    quantity: str
    frame: str
    diverged: np.ndarray
    dt: float
    sample_rate: float
    kn: np.ndarray
    delta: np.ndarray
    level_g: np.ndarray
    sweep: Sweep
    method: str
    engine: str
    omega_max: float
    truncation: ModalTruncation | None = None
    quasi_static: QuasiStatic | None = None
    gap_shares: tuple | None = None
    static_g: float = 0.0
    contact_damping: tuple | None = None

    @property
    def steps_per_sample(self) -> int:
        return int(round(1.0 / (self.dt * self.sample_rate)))

    @property
    def units(self) -> str:
        return si_unit(self.quantity)


def _as_batch(name: str, value, *, minimum: float | None) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim > 1:
        raise ValueError(f"`{name}` must be a scalar or 1-D, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"`{name}` must be finite, got {value!r}")
    if minimum is not None and np.any(a < minimum):
        raise ValueError(f"`{name}` must be >= {minimum}, got {value!r}")
    return a


def simulate_sweeps(
    system: FreeplaySystem,
    *,
    kn,
    delta,
    level_g,
    sweep: Sweep,
    channels,
    quantity: str = "acceleration",
    frame: str = "absolute",
    sample_rate: float = 2048.0,
    method: str = "relative",
    device=None,
    dtype=torch.float32,
    engine: str = "auto",
    omega_dt: float = DEFAULT_OMEGA_DT,
    steps_per_sample: int | None = None,
    cutoff_hz: float | None = None,
    quasi_static_hz: float | None = None,
    large_mass_ratio: float = 1e6,
    progress: bool | None = None,
    cuda_graphs: bool | None = None,
    gap_shares=None,
    antialias_passband: float = PASSBAND,
    static_g: float = 0.0,
    contact_damping=None,
) -> SweepResult:
    """Simulate sine sweeps of a freeplay system for a batch of (kn, delta, level).

    Integrates ``M y'' + C y' + K y + sum_j b_j f(b_j^T y) = -M r a_g(t)`` (or the large-mass
    form) with fixed-step RK4 from rest (from the static equilibrium under ``static_g``),
    records the requested channels and decimates them to ``sample_rate`` through a streaming
    anti-aliasing filter (docs/simulate.md).

    Parameters
    ----------
    system : FreeplaySystem
    kn : float or array_like, shape (batch,) [N m/rad], >= 0
    delta : float or array_like, shape (batch,) [rad], >= 0
        Half-gap.
    level_g : float or array_like, shape (batch,) [g]
        Base acceleration amplitude; kn, delta, level_g broadcast to one batch.
    sweep : Sweep or MeasuredSweep
        Linear or logarithmic sweep (up or down), or an excitation as a base channel measured it
        (its envelope times ``level_g``); the output covers [0, sweep.duration].
    channels : sequence of str
        DOF names to record.
    quantity : {"displacement", "velocity", "acceleration"}
    frame : {"absolute", "relative"}
        Absolute motion (what accelerometers measure) or motion relative to the base.
    sample_rate : float [Hz]
        Output rate; the RK4 step is ``1 / (sample_rate * m)`` for an integer m.
    method : {"relative", "large_mass"}
        Base excitation in relative coordinates or by a seismic mass ``large_mass_ratio`` times
        the structure's mass driven by the force M_L a_g (the paper's method).
    device : str or torch.device, optional
        Default: CUDA if available and the engine runs there, else CPU. ``"auto"`` with numba
        installed, ``"expo"``, ``"numba"`` and ``quasi_static_hz`` run on the CPU of a machine
        with a GPU (numba there is faster than the torch engine on the GPU: docs/simulate.md);
        ``engine="torch"`` runs on its GPU.
    dtype : torch.float32 or torch.float64
    engine : {"auto", "torch", "numba", "expo"} or another key of ``engines.ENGINES``
        "auto": the compiled numba RK4 kernel on CPU when numba is installed, else torch.
        "expo": the exponential integrator (CPU, numba; docs/simulate.md, "Exponential
        engine"): exact linear part and contact, step by accuracy, fast for small batches.
    omega_dt : float [-]
        RK4 engines: bound on omega_max * dt for the fastest closed-hinge mode (<= 2.5). Not
        used by an engine whose step is set by accuracy (its ``Engine.max_step``).
    steps_per_sample : int, optional
        Override the automatic m (no stability check: a member may then diverge).
    cutoff_hz : float [Hz], optional
        Modal truncation: drop closed-hinge modes above this frequency (a stiff model then runs
        at the step of the kept modes); the dropped modes' quasi-static response is added back.
    quasi_static_hz : float [Hz], optional
        Quasi-static condensation (``quasistatic.py``, docs/simulate.md): open-hinge modes above
        this frequency are massless (of their damping, only the slow velocities' load is kept),
        the hinge moments solve the exact algebraic piecewise-linear equation, and only the
        slower modes are integrated (their step). The fast modes' quasi-static response is in
        the outputs (for velocity and acceleration differentiated inside the decimating FIR). numba
        engine and ``method="relative"`` only; not with ``cutoff_hz``.
    large_mass_ratio : float [-]
    progress : bool, optional
        A progress bar over the simulated time; default: on for long runs (a few seconds or
        more) watched on a terminal or in a notebook; False: none.
    cuda_graphs : bool, optional
        torch engine on CUDA: replay the step loop as CUDA graphs (default on CUDA).
    gap_shares : sequence of float, shape (n_hinges,), optional
        Unequal gaps: hinge j's half-gap is ``delta * gap_shares[j]`` in every member (the
        system's hinge order; > 0). Engines "expo" (the choice of "auto" here) and "torch";
        default: one common gap.
    antialias_passband : float [-], in [0.1, 0.45]
        Where the decimating filter stays flat, as a fraction of ``sample_rate``
        (:func:`.resample.design_decimator`): 0.3 (default; -0.8 % at 0.336, -6 dB at 0.4) or
        up to 0.45, as flat as a sigma-delta acquisition (4 x the filter's taps).
    static_g : float [g], within +-1
        A constant acceleration of the frame along the base axis: gravity's component on a
        shaker whose axis is not horizontal (+1: vertical with the outputs' + direction up).
        It is added to ``a_g`` in the equations and left out of the records (as AC-coupled
        accelerometers and the base motion leave it out); the members start at rest in its
        static equilibrium (:func:`.formulation.static_equilibrium`). Engine "expo" (the choice
        of "auto" here) and the relative method; default 0.
    contact_damping : sequence of float, shape (n_hinges,), optional [N m s/rad]
        A viscous damper across hinge j acting only while it is in contact (moment
        ``c_j theta_j'``, on top of C): damping that the closed hinge adds. Engine "expo" (the
        choice of "auto" here), with at most ``expo.steps.MAX_STATE_SETS`` distinct kn in the
        batch; default none.

    Returns
    -------
    SweepResult
    """
    _check_types(system, sweep, dtype)
    static_g = _static_g(static_g, method)
    dampers = _contact_damping(system, contact_damping)
    if (engine == "auto" and (gap_shares is not None or static_g or dampers is not None)
            and ENGINES["expo"].available()):
        engine = "expo"  # unequal gaps, a static load, damping in contact: AUTO's do not
    device = torch.device(_default_device(engine, quasi_static_hz) if device is None else device)
    # the engine's name (unknown: the valid ones listed), and whether it does device and options
    engine, engine_cls = resolve_engine(engine, device=device,
                                        quasi_static=quasi_static_hz is not None)
    channels = _check_request(system, method=method, sample_rate=sample_rate, channels=channels)
    kn_a, dl_a, lv_a = _members(kn, delta, level_g)
    shares = _gap_shares(system, gap_shares, engine, engine_cls)
    if dampers is not None and not engine_cls.contact_damping:
        able = [n for n, c in ENGINES.items() if c.contact_damping]
        raise NotImplementedError(f"`contact_damping` (damping in contact) is implemented in "
                                  f"the engines {able} only, got engine={engine!r}")
    if static_g and not engine_cls.static_load:
        able = [n for n, c in ENGINES.items() if c.static_load]
        raise NotImplementedError(f"`static_g` (a static load) is implemented in the engines "
                                  f"{able} only, got engine={engine!r}")
    # the step rule is the engine's (Engine.max_step), not implied by its name
    plan = step_plan(system, kn_max=float(kn_a.max()), sweep=sweep, sample_rate=sample_rate,
                     channels=channels, quantity=quantity, frame=frame, method=method,
                     cutoff_hz=cutoff_hz, quasi_static_hz=quasi_static_hz, omega_dt=omega_dt,
                     steps_per_sample=steps_per_sample, large_mass_ratio=large_mass_ratio,
                     max_step=engine_cls.max_step, distinct_kn=len(np.unique(kn_a)),
                     differentiate=engine_cls.differentiates, passband=antialias_passband)
    base_state = np.array(sweep.unit_start(), dtype=float)  # unit (u_b, v_b)(0)
    eng = engine_cls(_engine_setup(plan, kn_a, dl_a, lv_a, base_state, quantity=quantity,
                                   dtype=dtype, device=device, cuda_graphs=cuda_graphs,
                                   gap_shares=shares, static_g=static_g,
                                   contact_damping=dampers))
    shape = (len(kn_a), len(channels), plan.n_out)
    y = integrate_chunks(eng, plan, sweep=sweep, quantity=quantity, level_g=lv_a, shape=shape,
                         base_state=base_state, dtype=dtype, device=device, progress=progress,
                         desc=f"sweeps x{len(kn_a)} ({engine})")
    diverged = np.asarray(eng.diverged, dtype=bool)
    y[diverged] = np.nan
    return SweepResult(
        time=np.arange(plan.n_out) / sample_rate, signals=y, channels=channels,
        quantity=quantity, frame=frame, diverged=diverged, dt=plan.h,
        sample_rate=float(sample_rate), kn=kn_a, delta=dl_a, level_g=lv_a, sweep=sweep,
        method=method, engine=engine, omega_max=plan.form.omega_max,
        truncation=plan.form.truncation,
        quasi_static=None if plan.qs is None else plan.qs.info,
        gap_shares=None if shares is None else tuple(float(v) for v in shares),
        static_g=static_g,
        contact_damping=None if dampers is None else tuple(float(v) for v in dampers),
    )


def _contact_damping(system, contact_damping) -> np.ndarray | None:
    """``contact_damping`` checked: None where not given or all 0, else a float array of one
    value >= 0 per hinge [N m s/rad]."""
    if contact_damping is None:
        return None
    a = np.asarray(contact_damping, dtype=float)
    H = system.n_hinges
    if a.shape != (H,) or not np.all(np.isfinite(a)) or np.any(a < 0):
        raise ValueError(f"`contact_damping` must be {H} finite values >= 0 [N m s/rad] (one "
                         f"per hinge), got {contact_damping!r}")
    return None if not np.any(a) else a


def _static_g(static_g, method: str) -> float:
    """``static_g`` checked: a finite number within +-1 [g], and 0 unless ``method`` is
    relative (the large-mass form's base is free: a constant load would carry it away)."""
    ok = isinstance(static_g, (int, float, np.integer, np.floating)) and not isinstance(
        static_g, (bool, np.bool_))
    if not ok or not math.isfinite(static_g) or abs(static_g) > 1:
        raise ValueError(f"`static_g` must be gravity's component along the base axis in g, "
                         f"a number within +-1, got {static_g!r}")
    if static_g and method != "relative":
        raise ValueError(f"`static_g` takes method='relative', got method={method!r}")
    return float(static_g)


def _gap_shares(system, gap_shares, engine: str, engine_cls) -> np.ndarray | None:
    """``gap_shares`` checked: None where not given or all 1 (one common gap), else a float
    array of one share > 0 per hinge, for an engine that takes them."""
    if gap_shares is None:
        return None
    a = np.asarray(gap_shares, dtype=float)
    H = system.n_hinges
    if a.shape != (H,) or not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise ValueError(f"`gap_shares` must be {H} finite values > 0 (one per hinge), "
                         f"got {gap_shares!r}")
    if np.all(a == 1.0):
        return None
    if not engine_cls.gap_shares:
        able = [n for n, c in ENGINES.items() if c.gap_shares]
        raise NotImplementedError(f"`gap_shares` (unequal gaps) is implemented in the engines "
                                  f"{able} only, got engine={engine!r}")
    return a


def _default_device(engine: str, quasi_static_hz: float | None) -> str:
    """The device of a run that names none: CUDA when present and the engine (for ``"auto"``,
    the first available one of :data:`engines.AUTO`) runs there, else the CPU.

    So ``"auto"`` with numba installed runs on the CPU of a GPU machine too: on an H200 machine
    the numba kernel on its 16 cores outran the torch engine on the GPU at every batch measured
    (docs/simulate.md, "On a GPU"), and a training bank of 480-sweep chunks ran there over 10x
    slower on the GPU than numba does on 2 cores. ``engine="torch"`` (or a ``device``) asks for
    the GPU.
    """
    if not torch.cuda.is_available() or quasi_static_hz is not None:
        return "cpu"
    if engine == "auto":
        engine = next((n for n in AUTO if ENGINES[n].available()), "torch")
    named = ENGINES.get(engine)
    runs_there = named is None or named.devices is None or "cuda" in named.devices
    return "cuda" if runs_there else "cpu"


def _check_types(system, sweep, dtype) -> None:
    if not isinstance(system, FreeplaySystem):
        raise TypeError(f"`system` must be a FreeplaySystem, got {type(system).__name__}")
    if not isinstance(sweep, (Sweep, MeasuredSweep)):
        raise TypeError(f"`sweep` must be a Sweep or a MeasuredSweep, got {type(sweep).__name__}")
    if dtype not in (torch.float32, torch.float64):
        raise ValueError(f"`dtype` must be torch.float32 or torch.float64, got {dtype!r}")


def _check_request(system, *, method, sample_rate, channels) -> tuple[str, ...]:
    """``channels`` as a tuple of the system's DOF names, once ``method`` and ``sample_rate``
    are checked."""
    if method not in METHODS:
        raise ValueError(f"`method` must be one of {METHODS}, got {method!r}")
    if not (math.isfinite(sample_rate) and sample_rate > 0):
        raise ValueError(f"`sample_rate` must be > 0, got {sample_rate!r}")
    if isinstance(channels, str):
        channels = (channels,)
    channels = tuple(channels)
    if not channels:
        raise ValueError("`channels` must name at least one DOF")
    for c in channels:
        if c not in system.dof_names:
            raise ValueError(f"`channels`: unknown DOF {c!r}; known: {list(system.dof_names)}")
    return channels


def _members(kn, delta, level_g) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(kn, delta, level_g) checked and broadcast to one batch: three C-contiguous (batch,)."""
    kn_a = _as_batch("kn", kn, minimum=0.0)
    dl_a = _as_batch("delta", delta, minimum=0.0)
    lv_a = _as_batch("level_g", level_g, minimum=None)
    try:
        # copies: broadcast views warn when numba reads their write flag (numpy >= 2.3)
        kn_a, dl_a, lv_a = (np.array(x, order="C") for x in np.broadcast_arrays(kn_a, dl_a, lv_a))
    except ValueError:
        raise ValueError(
            f"`kn`, `delta`, `level_g` must broadcast to one batch, got shapes "
            f"{kn_a.shape}, {dl_a.shape}, {lv_a.shape}"
        ) from None
    return tuple(x.reshape(-1) for x in (kn_a, dl_a, lv_a))


def _engine_setup(plan: StepPlan, kn, delta, level_g, base_state, *, quantity, dtype, device,
                  cuda_graphs, gap_shares=None, static_g: float = 0.0,
                  contact_damping=None) -> EngineSetup:
    """The engine's setup: the plan's equations, step and filters, and the members at rest
    relative to the base (the large-mass form starts on the base motion ``base_state``), in
    the static equilibrium under ``static_g``."""
    form = plan.form
    G_lv = level_g * G
    eta0 = np.outer(G_lv * base_state[0], form.x0_per_ub)
    if static_g:
        eta0 = eta0 + static_equilibrium(form, kn, delta, static_g, gap_shares)
    v0 = np.outer(G_lv * base_state[1], form.v0_per_vb)
    return EngineSetup(
        form=form, quasi_static=plan.qs, kn=kn, delta=delta, level_g=level_g, eta0=eta0, v0=v0,
        h=plan.h, quantity=quantity, dtype=dtype, device=device, taps=plan.taps,
        taps_d=plan.taps_d, factor=plan.m, cuda_graphs=cuda_graphs, gap_shares=gap_shares,
        static_g=static_g, contact_damping=contact_damping,
    )

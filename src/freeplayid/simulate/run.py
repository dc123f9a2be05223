"""`simulate_sweeps`: batched sine-sweep responses of a freeplay system, and its result."""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

import numpy as np
import torch

from ..model.system import FreeplaySystem
from ..quantity import G, derivative_order, si_unit
from ..sweep import Sweep
from .engines import Engine, EngineSetup, resolve_engine
from .engines.protocol import rk4_max_step
from .formulation import METHODS, ModalTruncation, build_modal_form
from .quasistatic import QuasiStatic, condense_modal_form
from .resample import StreamingDecimator, derivative_taps, design_decimator

__all__ = ["simulate_sweeps", "rk4_step_count", "SweepResult", "DEFAULT_OMEGA_DT"]

# omega_max * dt of the fastest closed-hinge mode. Measured on the 12-DOF test fin (3 kHz top
# mode, docs/simulate.md): at 1.5 the linear response is within ~3e-7 of the matrix-exponential
# solution and the first-harmonic peak of the freeplay response within ~2e-5 of a 6x finer step;
# the RK4 stability limit is 2.785.
DEFAULT_OMEGA_DT = 1.5
_CHUNK_ELEMENTS = 1 << 24  # recorded values per chunk (memory bound of the chunked loop)
_MAX_CHUNK_STEPS = 1 << 16  # steps per chunk at most (sin/base arrays of a chunk stay small)


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


def _base_signals(sweep: Sweep, t0_index: int, L: int, h: float, s_half: np.ndarray, state):
    """Unit base motion (u_b, v_b, a_g = sin phase) and the derivatives of sin phase on t_i.

    u_b, v_b are integrated by the RK4 rule of the structure (for u'' = a(t) it is Simpson's rule
    on the half steps); ``state`` = [u_b, v_b] at the chunk start, updated in place.
    """
    a = s_half
    dv = h / 6.0 * (a[0:-1:2] + 4.0 * a[1::2] + a[2::2])
    v = state[1] + np.concatenate([[0.0], np.cumsum(dv)])
    du = h * v[:-1] + h * h / 6.0 * (a[0:-1:2] + 2.0 * a[1::2])
    u = state[0] + np.concatenate([[0.0], np.cumsum(du)])
    state[0], state[1] = u[-1], v[-1]
    t = (t0_index + np.arange(L)) * h
    phase = sweep.phase(t)
    w = 2 * np.pi * sweep.frequency(t)
    c, s = np.cos(phase), np.sin(phase)
    return {
        "base": np.stack([u[:-1], v[:-1], a[0:-1:2]]),
        "quasi_static": np.stack([s, w * c, 2 * np.pi * sweep.rate(t) * c - w * w * s]),
    }


class _DecimatedRecords:
    """Signals of an engine that returns step-rate records: decimated here, chunk by chunk."""

    def __init__(self, eng: Engine, shape: tuple[int, int, int], *, taps, factor: int, dtype,
                 device):
        self.eng, self.shape = eng, shape
        self.dec = StreamingDecimator(taps, factor, dtype=dtype, device=device)
        self.outs = []

    def run(self, s_half: np.ndarray) -> None:
        rec = self.eng.run(s_half)  # (batch, C, L)
        batch, C, _ = self.shape
        self.outs.append(self.dec.push(rec.reshape(batch * C, rec.shape[-1])))

    def signals(self, base: np.ndarray, *, base_coef, static_coef, level_g) -> np.ndarray:
        """(batch, C, n_out) member signals plus ``level_g * (base_coef * base[0] + static_coef
        * base[1])``."""
        n_out = self.shape[-1]
        y = torch.cat(self.outs, dim=1)[:, :n_out].reshape(self.shape)
        y = y.cpu().numpy()
        extra = base_coef[None, :, None] * base[0] + static_coef[None, :, None] * base[1]
        if np.any(extra):
            y = y + (level_g[:, None, None] * extra).astype(y.dtype)
        return y


class _InPlaceOutputs:
    """Signals of an engine that decimates on the fly into the (batch, C, n_out) array."""

    def __init__(self, eng: Engine, shape: tuple[int, int, int], *, dtype):
        self.eng = eng
        nd = np.float32 if dtype == torch.float32 else np.float64
        self.y = np.empty(shape, dtype=nd)
        self.written = 0  # output samples completed so far (those past n_out are dropped)

    def run(self, s_half: np.ndarray) -> None:
        self.written += self.eng.run(s_half, out=self.y)

    def signals(self, base: np.ndarray, *, base_coef, static_coef, level_g) -> np.ndarray:
        """The signals plus the base terms, added in place in one compiled pass."""
        n_out = self.y.shape[-1]
        if self.written < n_out:  # columns left unwritten would be garbage (np.empty)
            raise AssertionError(f"{type(self.eng).__name__}: {self.written} outputs of "
                                 f"{n_out} written")
        from .assemble import add_base_terms

        add_base_terms(self.y, base_coef=base_coef, static_coef=static_coef, base=base,
                       level_g=level_g)
        return self.y


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
) -> SweepResult:
    """Simulate sine sweeps of a freeplay system for a batch of (kn, delta, level).

    Integrates ``M y'' + C y' + K y + sum_j b_j f(b_j^T y) = -M r a_g(t)`` (or the large-mass
    form) with fixed-step RK4 from rest, records the requested channels and decimates them to
    ``sample_rate`` through a streaming anti-aliasing filter (docs/simulate.md).

    Parameters
    ----------
    system : FreeplaySystem
    kn : float or array_like, shape (batch,) [N m/rad], >= 0
    delta : float or array_like, shape (batch,) [rad], >= 0
        Half-gap.
    level_g : float or array_like, shape (batch,) [g]
        Base acceleration amplitude; kn, delta, level_g broadcast to one batch.
    sweep : Sweep
        Linear or logarithmic sweep (up or down); the output covers [0, sweep.duration].
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
        Default: CUDA if available, else CPU; the CPU with ``quasi_static_hz`` (numba only).
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
        tqdm progress bar; default: on for long runs on an interactive terminal.
    cuda_graphs : bool, optional
        torch engine on CUDA: replay the step loop as CUDA graphs (default on CUDA).

    Returns
    -------
    SweepResult
    """
    if not isinstance(system, FreeplaySystem):
        raise TypeError(f"`system` must be a FreeplaySystem, got {type(system).__name__}")
    if not isinstance(sweep, Sweep):
        raise TypeError(f"`sweep` must be a Sweep, got {type(sweep).__name__}")
    if dtype not in (torch.float32, torch.float64):
        raise ValueError(f"`dtype` must be torch.float32 or torch.float64, got {dtype!r}")
    if device is None:
        use_cuda = torch.cuda.is_available() and quasi_static_hz is None
        device = "cuda" if use_cuda else "cpu"
    device = torch.device(device)
    # the engine's name (unknown: the valid ones listed), and whether it does device and options
    engine, engine_cls = resolve_engine(engine, device=device,
                                        quasi_static=quasi_static_hz is not None)
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
    kn_a = _as_batch("kn", kn, minimum=0.0)
    dl_a = _as_batch("delta", delta, minimum=0.0)
    lv_a = _as_batch("level_g", level_g, minimum=None)
    try:
        kn_a, dl_a, lv_a = (np.ascontiguousarray(x) for x in np.broadcast_arrays(kn_a, dl_a, lv_a))
    except ValueError:
        raise ValueError(
            f"`kn`, `delta`, `level_g` must broadcast to one batch, got shapes "
            f"{kn_a.shape}, {dl_a.shape}, {lv_a.shape}"
        ) from None
    kn_a, dl_a, lv_a = (x.reshape(-1) for x in (kn_a, dl_a, lv_a))
    batch = kn_a.shape[0]

    # the step rule is the engine's (Engine.max_step), not implied by its name
    plan = _step_plan(system, kn_max=float(kn_a.max()), sweep=sweep, sample_rate=sample_rate,
                      channels=channels, quantity=quantity, frame=frame, method=method,
                      cutoff_hz=cutoff_hz, quasi_static_hz=quasi_static_hz, omega_dt=omega_dt,
                      steps_per_sample=steps_per_sample, large_mass_ratio=large_mass_ratio,
                      max_step=engine_cls.max_step)
    form, qs, m, h, taps, taps_d = plan.form, plan.qs, plan.m, plan.h, plan.taps, plan.taps_d
    n_out, n_steps = plan.n_out, plan.n_steps

    # initial state: at rest relative to the base; the large-mass form starts on the base motion
    base_state = np.array([0.0, -1.0 / (2 * np.pi * sweep.start_hz)])  # unit (u_b, v_b)(0)
    G_lv = lv_a * G
    eta0 = np.outer(G_lv * base_state[0], form.x0_per_ub)
    v0 = np.outer(G_lv * base_state[1], form.v0_per_vb)
    eng = engine_cls(EngineSetup(
        form=form, quasi_static=qs, kn=kn_a, delta=dl_a, level_g=lv_a, eta0=eta0, v0=v0, h=h,
        quantity=quantity, dtype=dtype, device=device, taps=taps, taps_d=taps_d, factor=m,
        cuda_graphs=cuda_graphs,
    ))
    # where the decimation happens is declared by the engine (Engine.decimates), not its name
    shape = (batch, len(channels), n_out)
    if eng.decimates:
        outputs = _InPlaceOutputs(eng, shape, dtype=dtype)
    else:
        outputs = _DecimatedRecords(eng, shape, taps=taps, factor=m, dtype=dtype, device=device)
    dec_base = StreamingDecimator(taps, m, dtype=torch.float64, device=torch.device("cpu"))
    # steps per chunk: bounded by the recorded values and by the per-chunk sweep arrays
    chunk = max(m, min(_CHUNK_ELEMENTS // max(1, batch * eng.record_width),
                       _MAX_CHUNK_STEPS) // m * m)

    if progress is None:
        progress = n_steps * batch > 5e8 and sys.stderr.isatty()
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=round(sweep.duration, 3), unit="s", desc=f"sweeps x{batch} ({engine})")
    base_outs = []
    i0 = 0
    while i0 < n_steps:
        L = min(chunk, n_steps - i0)
        s_half = np.sin(sweep.phase((i0 + 0.5 * np.arange(2 * L + 1)) * h))
        outputs.run(s_half)
        sig = _base_signals(sweep, i0, L, h, s_half, base_state)
        q = derivative_order(quantity)
        rows = np.stack([sig["base"][q], sig["quasi_static"][q]])
        base_outs.append(dec_base.push(torch.from_numpy(rows)))
        i0 += L
        if bar is not None:
            bar.update(round(min(i0 * h, sweep.duration) - bar.n, 3))
    if bar is not None:
        bar.close()
    base = torch.cat(base_outs, dim=1)[:, :n_out].numpy()
    y = outputs.signals(base, base_coef=form.base_coef, static_coef=form.static_coef,
                        level_g=lv_a)
    diverged = np.asarray(eng.diverged, dtype=bool)
    y[diverged] = np.nan
    return SweepResult(
        time=np.arange(n_out) / sample_rate,
        signals=y,
        channels=channels,
        quantity=quantity,
        frame=frame,
        diverged=diverged,
        dt=h,
        sample_rate=float(sample_rate),
        kn=kn_a,
        delta=dl_a,
        level_g=lv_a,
        sweep=sweep,
        method=method,
        engine=engine,
        omega_max=form.omega_max,
        truncation=form.truncation,
        quasi_static=None if qs is None else qs.info,
    )


@dataclass(frozen=True)
class _StepPlan:
    form: object
    qs: object
    m: int
    h: float
    taps: np.ndarray | None
    taps_d: np.ndarray | None
    n_out: int
    look: int
    n_steps: int


def _step_plan(system, *, kn_max, sweep, sample_rate, channels, quantity, frame, method,
               cutoff_hz, quasi_static_hz, omega_dt, steps_per_sample, large_mass_ratio,
               filters: bool = True, max_step=rk4_max_step) -> _StepPlan:
    """The modal form, the step and the step count of a simulation (before running it);
    without ``filters`` no decimator is designed (its length grows with m) and the count leaves
    out the filter look-ahead (a few samples). ``max_step`` is the engine's step rule
    (``Engine.max_step``; default the RK4 engines' stability rule)."""
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
        h_max = max_step(form, sweep=sweep, kn_max=kn_max, omega_dt=omega_dt)
        m = max(1, math.ceil(1.0 / (sample_rate * h_max) - 1e-9))
    else:
        if not (isinstance(steps_per_sample, (int, np.integer)) and steps_per_sample >= 1):
            raise ValueError(f"`steps_per_sample` must be an int >= 1, got {steps_per_sample!r}")
        m = int(steps_per_sample)
    h = 1.0 / (sample_rate * m)

    n_out = int(math.floor(sweep.duration * sample_rate + 1e-9)) + 1
    if not filters:
        return _StepPlan(form=form, qs=qs, m=m, h=h, taps=None, taps_d=None, n_out=n_out,
                         look=0, n_steps=(n_out - 1) * m + 1)
    taps = design_decimator(m)
    taps_d = None
    if qs is not None and quantity != "displacement":
        # the fast part's derivative is decimated by the same fused FIR (resample.derivative_taps)
        taps, taps_d = derivative_taps(taps, m, h, 1 if quantity == "velocity" else 2)
    look = (len(taps) - 1) // 2 // m + 1  # filter look-ahead (+1: the polyphase block padding)
    n_steps = (n_out - 1 + look) * m + 1  # recorded step-rate samples t_0 .. t_{n_steps-1}
    return _StepPlan(form=form, qs=qs, m=m, h=h, taps=taps, taps_d=taps_d, n_out=n_out,
                     look=look, n_steps=n_steps)


def rk4_step_count(
    system: FreeplaySystem, *, kn: float, sweep: Sweep, sample_rate: float, channels,
    quantity: str = "acceleration", frame: str = "absolute", method: str = "relative",
    omega_dt: float = DEFAULT_OMEGA_DT, cutoff_hz: float | None = None,
    quasi_static_hz: float | None = None, large_mass_ratio: float = 1e6,
) -> tuple[int, float]:
    """RK4 steps per batch member :func:`simulate_sweeps` would take, without simulating.

    The step follows the fastest closed-hinge mode (``omega_max * dt <= omega_dt``), so it
    shrinks as sqrt(kn) grows: the cost of a huge contact stiffness is known up front.

    Parameters
    ----------
    kn : float [N m/rad]
        The largest contact stiffness of the batch.
    sweep, sample_rate, channels, quantity, frame, method, omega_dt, cutoff_hz,
    quasi_static_hz, large_mass_ratio
        As :func:`simulate_sweeps`.

    Returns
    -------
    n_steps : int
        Steps per member over the whole sweep (less the filter's look-ahead, a few samples).
    dt : float [s]
        The step.
    """
    if isinstance(channels, str):
        channels = (channels,)
    plan = _step_plan(system, kn_max=float(kn), sweep=sweep, sample_rate=float(sample_rate),
                      channels=tuple(channels), quantity=quantity, frame=frame, method=method,
                      cutoff_hz=cutoff_hz, quasi_static_hz=quasi_static_hz, omega_dt=omega_dt,
                      steps_per_sample=None, large_mass_ratio=large_mass_ratio, filters=False)
    return plan.n_steps, plan.h

"""The chunked integration loop of ``simulate_sweeps``: the engine run over the whole sweep.

Chunk by chunk (a bounded number of steps, so the per-chunk arrays stay small), the engine
integrates the members and its outputs are decimated to the sample rate, by the engine in place
(``Engine.decimates``) or here; the unit base signals (the base motion of the absolute frame,
the quasi-static base-load response) are integrated and decimated alongside in float64, and
added per member at the end.
"""

from __future__ import annotations

import numpy as np
import torch

from ..progress import progress_bar, watched
from ..quantity import derivative_order
from ..sweep import Sweep
from .engines import Engine
from .plan import StepPlan
from .resample import StreamingDecimator

__all__ = ["integrate_chunks", "CHUNK_ELEMENTS", "MAX_CHUNK_STEPS"]

CHUNK_ELEMENTS = 1 << 24  # recorded values per chunk (memory bound of the chunked loop)
MAX_CHUNK_STEPS = 1 << 16  # steps per chunk at most (sin/base arrays of a chunk stay small)
LONG_RUN = 5e8  # member-steps of a run that shows its bar by default (a few seconds or more)
# the bar counts simulated seconds: "sweeps x24 (numba):  23%|##   | 4.98/22.00 s [00:15<00:37]"
SWEEP_BAR = "{desc}: {percentage:3.0f}%|{bar}| {n:.2f}/{total:.2f} s [{elapsed}<{remaining}]"


def _base_signals(sweep: Sweep, t0_index: int, L: int, h: float, s_half: np.ndarray, state,
                  quasi_static: bool = True):
    """Unit base motion (u_b, v_b, a_g = the sweep's unit excitation) and the derivatives of the
    unit excitation (sin phase, or a measured envelope times it) on t_i (zeros without
    ``quasi_static``: a model without condensed fast modes does not use them, and a measured
    excitation's six spline evaluations per step cost 16 % of a replay).

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
    return {
        "base": np.stack([u[:-1], v[:-1], a[0:-1:2]]),
        "quasi_static": np.stack(sweep.unit_derivatives(t)) if quasi_static else
        np.zeros((3, L)),
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
        from .assemble import add_base_terms  # numba (optional): only engines that decimate

        add_base_terms(self.y, base_coef=base_coef, static_coef=static_coef, base=base,
                       level_g=level_g)
        return self.y


def integrate_chunks(eng: Engine, plan: StepPlan, *, sweep: Sweep, quantity: str, level_g,
                     shape: tuple[int, int, int], base_state: np.ndarray, dtype, device,
                     progress: bool | None, desc: str) -> np.ndarray:
    """Run ``eng`` over the whole sweep, chunk by chunk; its signals at the output rate.

    Parameters
    ----------
    eng : Engine
        Built on ``plan`` (its step and filters).
    plan : StepPlan
    sweep : Sweep
    quantity : str
        The recorded quantity (which base signal is added).
    level_g : ndarray, shape (batch,) [g]
    shape : (batch, channels, n_out)
    base_state : ndarray, shape (2,)
        Unit base displacement and velocity at t = 0 (updated in place).
    dtype, device
        The simulation's (torch) dtype and device.
    progress : bool or None
        A bar over the simulated time (``desc``); None: on for long runs (:data:`LONG_RUN`)
        that someone watches (a terminal or a notebook, :func:`freeplayid.progress.watched`).

    Returns
    -------
    ndarray, shape ``shape``
        The members' signals plus ``level_g`` times the base terms, in the simulation dtype.
    """
    batch, m, h, n_steps = shape[0], plan.m, plan.h, plan.n_steps
    if eng.decimates:  # where the decimation happens is the engine's declaration, not its name
        outputs = _InPlaceOutputs(eng, shape, dtype=dtype)
    else:
        outputs = _DecimatedRecords(eng, shape, taps=plan.taps, factor=m, dtype=dtype,
                                    device=device)
    dec_base = StreamingDecimator(plan.taps, m, dtype=torch.float64, device=torch.device("cpu"))
    # steps per chunk: bounded by the recorded values and by the per-chunk sweep arrays
    chunk = max(m, min(CHUNK_ELEMENTS // max(1, batch * eng.record_width),
                       MAX_CHUNK_STEPS) // m * m)
    if progress is None:
        progress = n_steps * batch > LONG_RUN and watched()
    # leave=None: a bar under another (a bank's) goes when done, a bar of its own stays
    bar = progress_bar(total=float(sweep.duration), desc=desc, unit="s", show=progress,
                       leave=None, bar_format=SWEEP_BAR) if progress else None
    q = derivative_order(quantity)
    quasi_static = bool(np.any(plan.form.static_coef))  # zero without condensed fast modes
    base_outs = []
    i0 = 0
    while i0 < n_steps:
        L = min(chunk, n_steps - i0)
        s_half = sweep.unit((i0 + 0.5 * np.arange(2 * L + 1)) * h)
        outputs.run(s_half)
        sig = _base_signals(sweep, i0, L, h, s_half, base_state, quasi_static)
        rows = np.stack([sig["base"][q], sig["quasi_static"][q]])
        base_outs.append(dec_base.push(torch.from_numpy(rows)))
        i0 += L
        if bar is not None:
            bar.update(min(i0 * h, sweep.duration) - bar.n)
    if bar is not None:
        bar.close()
    base = torch.cat(base_outs, dim=1)[:, :plan.n_out].numpy()
    return outputs.signals(base, base_coef=plan.form.base_coef,
                           static_coef=plan.form.static_coef, level_g=level_g)

"""The torch engine: batched RK4 on tensors, on any device (CPU or CUDA), float32/float64.

This is the GPU path; on CPU a step costs ~30 small tensor operations, so it is overhead-bound
at any batch. It returns step-rate records, which ``simulate_sweeps`` decimates.
"""

from __future__ import annotations

import warnings

import numpy as np
import torch

from ..formulation import BLOWUP, MODES, ModalForm
from .protocol import EngineSetup, rk4_max_step

__all__ = ["TorchEngine", "TorchRK4"]


class TorchEngine:
    """:class:`.protocol.Engine` of :class:`TorchRK4`: any device, full model, raw records."""

    devices = None
    quasi_static = False
    decimates = False
    differentiates = False
    gap_shares = True
    static_load = False
    contact_damping = False  # damping in contact: the exponential engine only
    max_step = staticmethod(rk4_max_step)

    def __init__(self, setup: EngineSetup):
        s = setup
        self.rk4 = TorchRK4(s.form, s.kn, s.delta, s.level_g, s.eta0, s.v0, h=s.h,
                            quantity=s.quantity, dtype=s.dtype, device=s.device,
                            cuda_graphs=s.cuda_graphs, gap_shares=s.gap_shares)
        self.record_width = s.form.n_modes  # the modal state is recorded, projected per chunk

    @classmethod
    def available(cls) -> bool:
        return True

    def run(self, s_half: np.ndarray, out: np.ndarray | None = None) -> torch.Tensor:
        if out is not None:
            raise ValueError("the torch engine returns its records; `out` must be None")
        return self.rk4.run(s_half)

    @property
    def diverged(self) -> np.ndarray:
        return self.rk4.diverged


class TorchRK4:
    """Batched RK4 on torch tensors.

    Parameters
    ----------
    form : ModalForm
    kn, delta, level_g : ndarray, shape (batch,) [N m/rad], [rad], [g]
    eta0, v0 : ndarray, shape (batch, N)
        Initial modal state.
    h : float [s]
        Step.
    quantity : str
        Recorded quantity (displacement | velocity | acceleration).
    dtype, device : torch dtype and device.
    cuda_graphs : bool, optional
        Replay the step loop as CUDA graphs of ``graph_steps`` steps (default: on CUDA). The
        Python loop issues ~30 kernels per step, so on a GPU it is launch-bound without them.
    graph_steps : int
    gap_shares : ndarray, shape (H,), optional
        Hinge j's half-gap is ``delta * gap_shares[j]`` (default all 1: one common gap).
    """

    def __init__(self, form: ModalForm, kn, delta, level_g, eta0, v0, *, h, quantity, dtype,
                 device, cuda_graphs: bool | None = None, graph_steps: int = 128,
                 gap_shares=None):
        t = lambda a: torch.as_tensor(np.asarray(a), dtype=dtype, device=device)  # noqa: E731
        self.h = float(h)
        self.mode = MODES[quantity]
        self.lam = t(form.lam)
        self.c_diag = form.c_diagonal
        self.cdiag = t(np.diag(form.Cm).copy())
        self.CmT = t(form.Cm.T.copy())
        self.D = t(form.D)
        self.DT = t(form.D.T.copy())
        self.g = t(form.g)
        self.ST = t(form.S.T.copy())
        self.kn = t(kn)[:, None]
        self.delta = t(delta)[:, None]  # (batch, 1), or (batch, H) with unequal gaps
        if gap_shares is not None:
            self.delta = self.delta * t(gap_shares)[None, :]
        self.lev = t(level_g)[:, None]
        self.eta = t(eta0).clone()
        self.v = t(v0).clone()
        self.alive = torch.ones(len(kn), dtype=torch.bool, device=device)
        self.dtype, self.device = dtype, device
        device = torch.device(device)
        self.use_graphs = device.type == "cuda" if cuda_graphs is None else bool(cuda_graphs)
        self.graph_steps = int(graph_steps)
        self._graph = None

    def _accel(self, eta, v, s):
        th = eta @ self.D
        f = self.kn * (th - torch.clamp(th, -self.delta, self.delta))
        a = (self.lev * s) * self.g - self.lam * eta - f @ self.DT
        if self.c_diag:
            a -= self.cdiag * v
        else:
            a -= v @ self.CmT
        return a

    def _steps(self, s: torch.Tensor, rec: torch.Tensor, L: int) -> None:
        """L RK4 steps from (self.eta, self.v), in place; ``rec[i]`` gets the recorded quantity."""
        h, h2, h6 = self.h, 0.5 * self.h, self.h / 6.0
        eta, v = self.eta, self.v
        for i in range(L):
            s0, s1, s2 = s[2 * i], s[2 * i + 1], s[2 * i + 2]
            k1 = self._accel(eta, v, s0)
            rec[i] = (eta, v, k1)[self.mode]
            v2 = v + h2 * k1
            k2 = self._accel(eta + h2 * v, v2, s1)
            v3 = v + h2 * k2
            k3 = self._accel(eta + h2 * v2, v3, s1)
            v4 = v + h * k3
            k4 = self._accel(eta + h * v3, v4, s2)
            eta = eta + h6 * (v + 2.0 * (v2 + v3) + v4)
            v = v + h6 * (k1 + 2.0 * (k2 + k3) + k4)
        # in place, so that a captured CUDA graph keeps working on the same storage
        self.eta.copy_(eta)
        self.v.copy_(v)

    def _capture(self) -> None:
        """Record ``graph_steps`` steps as one CUDA graph (a Python step loop is launch-bound)."""
        G = self.graph_steps
        self._s_static = torch.zeros(2 * G + 1, dtype=self.dtype, device=self.device)
        self._rec_static = torch.empty((G,) + self.eta.shape, dtype=self.dtype,
                                       device=self.device)
        e0, v0 = self.eta.clone(), self.v.clone()
        side = torch.cuda.Stream()
        side.wait_stream(torch.cuda.current_stream())
        with torch.cuda.stream(side):  # warm-up outside the capture, then restore the state
            self._steps(self._s_static, self._rec_static, G)
            self.eta.copy_(e0)
            self.v.copy_(v0)
        torch.cuda.current_stream().wait_stream(side)
        graph = torch.cuda.CUDAGraph()
        with torch.cuda.graph(graph):
            self._steps(self._s_static, self._rec_static, G)
        self._graph = graph

    def run(self, s_half: np.ndarray) -> torch.Tensor:
        """Integrate ``L = (len(s_half) - 1) / 2`` steps; return the recorded channels.

        Parameters
        ----------
        s_half : ndarray, shape (2 L + 1,) [-]
            sin(phase) at t_i + k h / 2, k = 0..2L (float64).

        Returns
        -------
        Tensor, shape (batch, C, L)
            The recorded quantity at t_0 .. t_{L-1} of this chunk.
        """
        L = (len(s_half) - 1) // 2
        s = torch.as_tensor(s_half, dtype=self.dtype, device=self.device)
        rec = torch.empty((L,) + self.eta.shape, dtype=self.dtype, device=self.device)
        i = 0
        G = self.graph_steps
        while self.use_graphs and L - i >= G:
            if self._graph is None:
                try:
                    self._capture()
                except RuntimeError as exc:  # pragma: no cover - needs CUDA
                    warnings.warn(f"CUDA graph capture failed ({exc}); eager steps", stacklevel=2)
                    self.use_graphs = False
                    break
            self._s_static.copy_(s[2 * i : 2 * i + 2 * G + 1])
            self._graph.replay()
            rec[i : i + G].copy_(self._rec_static)
            i += G
        if i < L:
            self._steps(s[2 * i :], rec[i:], L - i)
        # divergence: freeze the member at zero with no load, so it stays there (in place)
        eta, v = self.eta, self.v
        bad = ~(torch.isfinite(eta).all(1) & torch.isfinite(v).all(1))
        bad |= (eta.abs().amax(1) > BLOWUP) | (v.abs().amax(1) > BLOWUP)
        self.alive &= ~bad
        keep = self.alive[:, None]
        eta.copy_(torch.where(keep, eta, torch.zeros_like(eta)))
        v.copy_(torch.where(keep, v, torch.zeros_like(v)))
        self.lev.mul_(keep)
        out = rec @ self.ST  # (L, batch, C)
        return out.permute(1, 2, 0)

    @property
    def diverged(self) -> np.ndarray:
        """(batch,) bool: members flagged as diverged so far (synchronises the device)."""
        return (~self.alive).cpu().numpy()

"""Fixed-step RK4 engines of the modal equations (ETA) of :mod:`..formulation`, by name.

Every engine integrates the same arithmetic, chunk by chunk, with the members of the batch
independent (one member's divergence never touches another):

- ``"torch"`` (:class:`TorchEngine`, ``torch.py``): batched tensors, any device (CPU or CUDA).
- ``"numba"`` (:class:`NumbaEngine`, ``numba/``): the compiled CPU kernels (``numba/rk4.py``,
  ``numba/rk4_qs.py``), a fused RK4 step with the members in the innermost (SIMD) loop, blocks
  of members spread over threads, decimating on the fly.
- ``"expo"`` (:class:`ExpoEngine`, ``expo/``): not RK4 but the exponential integrator of
  ``expo/steps.py`` (exact linear part, exact implicit contact per member, step by accuracy),
  compiled (``expo/kernel.py``), one member per thread task, decimating on the fly.

One RK4 step of x = (eta, v), a(eta, v, s) the right-hand side of (ETA) and s = sin(phase)::

    k1 = a(eta, v, s0)                                  (recorded: the acceleration at t_i)
    k2 = a(eta + h/2 v, v + h/2 k1, s1/2)
    k3 = a(eta + h/2 v2, v + h/2 k2, s1/2)              v2 = v + h/2 k1
    k4 = a(eta + h v3, v + h k3, s1)                    v3 = v + h/2 k2
    eta += h/6 (v + 2 v2 + 2 v3 + v4),  v += h/6 (k1 + 2 k2 + 2 k3 + k4)   v4 = v + h k3

The freeplay force is branch-free: ``kn * (theta - clamp(theta, -delta, delta))``.

An engine is a class of the :class:`Engine` protocol (``protocol.py``) that declares its
devices, whether it does ``quasi_static_hz`` and whether it decimates in place; adding one is
one module and one line in :data:`ENGINES`. ``engine="auto"`` picks the first of :data:`AUTO`
that is available and runs on the device (and does ``quasi_static_hz`` when asked).
"""

from __future__ import annotations

import torch

from ..formulation import BLOWUP, MODES
from .expo import ExpoEngine
from .numba import NumbaEngine, numba_available
from .protocol import Engine, EngineSetup
from .torch import TorchEngine, TorchRK4

__all__ = [
    "ENGINES",
    "AUTO",
    "Engine",
    "EngineSetup",
    "TorchEngine",
    "NumbaEngine",
    "ExpoEngine",
    "TorchRK4",
    "resolve_engine",
    "numba_available",
    "MODES",
    "BLOWUP",
]

# name -> engine class: the names that ``simulate_sweeps(engine=...)`` accepts, with "auto"
ENGINES: dict[str, type[Engine]] = {
    "torch": TorchEngine,
    "numba": NumbaEngine,
    "expo": ExpoEngine,
}
# preference of engine="auto": the compiled RK4 kernels on the CPU, torch everywhere else (not
# "expo": the training bank's cache key and pinned results are RK4's)
AUTO = ("numba", "torch")
_DEVICE_NAMES = {"cpu": "CPU", "cuda": "CUDA"}


def _runs_on(cls: type[Engine], device: torch.device) -> bool:
    return cls.devices is None or device.type in cls.devices


def resolve_engine(name: str, *, device: torch.device,
                   quasi_static: bool = False) -> tuple[str, type[Engine]]:
    """The engine called ``name`` (or chosen by ``"auto"``), checked against the run.

    Parameters
    ----------
    name : str
        A key of :data:`ENGINES`, or ``"auto"``: the first engine of :data:`AUTO` that is
        available and runs on ``device`` (one that does ``quasi_static`` when asked, if any).
    device : torch.device
    quasi_static : bool
        Whether the run condenses fast modes (``quasi_static_hz``).

    Returns
    -------
    name : str
        The engine's registry name (never ``"auto"``).
    cls : type[Engine]

    Raises
    ------
    ValueError
        Unknown name (the message lists the valid ones), or an engine that does not run on
        ``device``.
    NotImplementedError
        ``quasi_static`` with an engine that does not do it.
    """
    if name != "auto" and name not in ENGINES:
        raise ValueError(f"`engine` must be one of {('auto', *ENGINES)}, got {name!r}")
    if name == "auto":
        usable = [n for n in AUTO if ENGINES[n].available() and _runs_on(ENGINES[n], device)]
        if not usable:
            raise ValueError(f"no engine of {AUTO} is available on device {device}")
        fits = [n for n in usable if ENGINES[n].quasi_static or not quasi_static]
        # none fits: the first usable one, which then raises the quasi-static error below
        name = (fits or usable)[0]
    cls = ENGINES[name]
    if not _runs_on(cls, device):
        where = " or ".join(_DEVICE_NAMES.get(d, d) for d in cls.devices)
        raise ValueError(f"`engine`={name!r} runs on the {where} only, got device {device}")
    if quasi_static and not cls.quasi_static:
        able = [n for n, c in ENGINES.items() if c.quasi_static]
        where = (f"the {' and '.join(able)} engine{'s' if len(able) > 1 else ''} only" if able
                 else "no engine")
        raise NotImplementedError(
            f"`quasi_static_hz` is implemented in {where}, got engine={name!r}")
    return name, cls

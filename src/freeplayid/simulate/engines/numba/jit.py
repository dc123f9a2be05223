"""Around the compiled kernels, on the Python side: the float dtype they run in and their first
call, which compiles them (or loads them from numba's cache) with a line in the log (INFO: a
command shows it on the terminal).

Nothing here is compiled into a kernel, so an edit here leaves the cached kernels valid.
"""

from __future__ import annotations

import logging
import time

import numpy as np
import torch
from numba.core import event

__all__ = ["float_dtype", "compile_kernel"]

log = logging.getLogger(__name__)


def float_dtype(dtype) -> type:
    """``np.float32`` or ``np.float64`` for a numpy or torch float32 / float64 ``dtype``."""
    if dtype in (torch.float32, np.float32):
        return np.float32
    if dtype in (torch.float64, np.float64):
        return np.float64
    raise ValueError(f"`dtype` must be float32 or float64, got {dtype!r}")


class _Announce(event.Listener):
    # "compiling ..." in the log when numba compiles `dispatcher` (not when it loads the cache)
    def __init__(self, dispatcher, what):
        self.dispatcher, self.what, self.t0 = dispatcher, what, None

    def on_start(self, ev):
        if ev.data["dispatcher"] is self.dispatcher and self.t0 is None:
            log.info("compiling the numba %s...", self.what)
            self.t0 = time.perf_counter()

    def on_end(self, ev):
        pass


def compile_kernel(kernel, args: tuple, what: str) -> None:
    """Compile ``kernel`` for ``args`` (or load it from numba's cache) by a call on no blocks or
    members (its first two arguments, ``0, 0``).

    A compile logs two lines (INFO), e.g. ``compiling the numba RK4 kernel (float32, full
    model)...`` and ``compiled in 12.3 s, cached for later runs in
    ...`` (``what`` = "RK4 kernel (float32, full model)"); a cache load logs nothing.
    """
    listener = _Announce(kernel, what)
    with event.install_listener("numba:compile", listener):
        kernel(0, 0, *args)
    if listener.t0 is not None:
        path = kernel.stats.cache_path
        where = f"cached for later runs in {path}" if path else "not cached"
        log.info("compiled in %.1f s, %s", time.perf_counter() - listener.t0, where)

"""The arithmetic of every compiled kernel (the RK4 ones here, the exponential one in ``expo/``):
the fast-math flags they are compiled with and the fused multiply-add they spell out.

The kernels inline :func:`fma`; a change of this file must come with a change of the digest
recorded by every kernel file (``..cache.cache_unless_stale``).
"""

from __future__ import annotations

from llvmlite import ir
from numba.core import types
from numba.core.extending import intrinsic

__all__ = ["FASTMATH", "fma"]

# Fast-math flags of the kernels: only those that leave every finite result as written (operands
# and results are neither NaN nor inf; a diverged member is caught outside the kernel). Not
# `fastmath=True`: numba compiles a prange body twice, on its own (the code that a process runs
# right after compiling) and linked into the calling function, where LLVM optimises it again (the
# code that the on-disk cache stores and every later process runs). With re-association and FMA
# contraction the two copies round differently (quasi-static kernel, float32: 868 vs 1064 FMA
# instructions), and the freeplay dynamics amplify a last-bit difference to the size of the
# signal: a cached and a freshly compiled kernel gave different sweeps. Without them both copies
# compute the IEEE result of the operations in source order (tests/test_simulate_determinism.py).
FASTMATH = {"nnan", "ninf"}
# Every function of the kernels says `error_model="numpy"` (a division by zero gives inf or NaN,
# no exception): what `parallel=True` compiles a prange body with, so also the helpers compiled
# on their own (rk4_qs._active_set, _solve_block_h) and any kernel without prange compile as
# the body did (the Python error model puts a zero-divisor branch into every division, which
# kept the quasi-static kernel's loops from being vectorised: 2x slower as a plain function).


@intrinsic
def fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (``llvm.fma``), for three floats of one type.

    The fused multiply-adds of the kernels are written out with this: with no contraction
    flag (see FASTMATH) every compiled copy fuses exactly these operations, so the kernels stay
    the same arithmetic in every copy and on every machine (``llvm.fma`` is exact also where
    the CPU has no FMA unit, only slower), while on the ones that have it (x86-64 since 2013,
    ARMv8) each is one vectorised instruction instead of a multiply and an add.
    """
    if not (isinstance(a, types.Float) and a == b == c):
        return None

    def codegen(context, builder, signature, args):
        t = args[0].type
        fn = builder.module.declare_intrinsic("llvm.fma", [t], ir.FunctionType(t, [t, t, t]))
        return builder.call(fn, args)

    return a(a, b, c), codegen

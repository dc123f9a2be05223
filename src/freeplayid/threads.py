"""Work on several threads at once where the heavy part releases the GIL.

A replay's runs are independent: each is simulated alone (the exponential engine's numba
kernels, which release the GIL), with the same arithmetic on any thread, so doing them at once
changes no number. So are a test's runs for the extraction (ACMP's pursuit is one compiled loop
that releases the GIL). :func:`each` does that on up to :func:`cores` threads.

The BLAS library's own threads (OpenBLAS's, under numpy and scipy) are held to one meanwhile
(:func:`one_blas_thread`): the linear algebra here is small (eigen-batches of a fin's few degrees
of freedom, two-parameter least squares), and its threads, which wait for work spinning, took
the core the other thread needed (``identify`` on the bundled example 14.9 → 11.4 s on 2 cores:
docs/identify.md §3b, "11 s").
"""

from __future__ import annotations

import os
from contextlib import contextmanager

__all__ = ["cores", "each", "one_blas_thread"]

# a process told to use one thread per library (as `benchmarks/realtests/run.py --jobs N` users
# do, to share the cores between N processes) uses one for this too
THREAD_LIMITS = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS")


def cores() -> int:
    """Threads to use: the cores this process may run on (its CPU affinity), capped by
    ``NUMBA_NUM_THREADS`` and ``OMP_NUM_THREADS`` when they are set."""
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        n = os.cpu_count() or 1
    for var in THREAD_LIMITS:
        try:
            n = min(n, int(os.environ[var]))
        except (KeyError, ValueError):
            pass
    return max(1, n)


def each(work, items, *, name: str = "worker", workers: int | None = None) -> list:
    """``[work(item) for item in items]``, on up to ``workers`` threads (default
    :func:`cores`). An exception is raised as the serial loop would raise it (the first failing
    item's)."""
    items = list(items)
    n = min(len(items), cores() if workers is None else workers)
    if n < 2:
        return [work(item) for item in items]
    from concurrent.futures import ThreadPoolExecutor

    with one_blas_thread(), ThreadPoolExecutor(n, thread_name_prefix=name) as pool:
        return [future.result() for future in [pool.submit(work, item) for item in items]]


# threads the BLAS libraries may use inside :func:`one_blas_thread`; None: their own count
# (``benchmarks/identify_time.py``'s comparison row)
BLAS_THREADS = 1


@contextmanager
def one_blas_thread():
    """The BLAS libraries loaded in the process (OpenBLAS, MKL, BLIS: ``threadpoolctl``) on
    :data:`BLAS_THREADS` threads each while the block runs, as they were after it; usable as a
    decorator. A function's own threads (:func:`each`) are its parallelism (module
    docstring)."""
    if BLAS_THREADS is None:
        yield
        return
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=BLAS_THREADS, user_api="blas"):
        yield

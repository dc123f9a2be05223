"""Where numba's on-disk cache of the compiled kernels lives.

numba caches a compiled function next to its source (``__pycache__`` of ``simulate/``) when that
folder is writable (an editable install, a checkout), else in the user-wide cache folder
(``~/.cache/numba``: a package installed read-only, checked on a read-only bind mount of
``src/``). Only when neither is writable (no home, a read-only home) does numba refuse to
decorate a ``cache=True`` function at all; then, and only then, this module points numba at a
private folder of the temporary directory (``NUMBA_CACHE_DIR``), and if that fails too the kernels
are compiled without a cache (``CACHE`` is False).
"""

from __future__ import annotations

import os
import tempfile

import numba

__all__ = ["CACHE"]


def _probe():  # pragma: no cover - never called: decorated only to ask numba for a cache folder
    return 0


def _cache_available() -> bool:
    # numba looks for a cache folder of this file (the folder of the kernels) when it decorates
    try:
        numba.njit(cache=True)(_probe)
    except RuntimeError:  # "cannot cache function ...: no locator available"
        return False
    return True


def _set_cache_dir() -> bool:
    uid = os.getuid() if hasattr(os, "getuid") else 0
    path = os.path.join(tempfile.gettempdir(), f"freeplayid-numba-cache-{uid}")
    try:
        os.makedirs(path, mode=0o700, exist_ok=True)
        if hasattr(os, "getuid") and os.stat(path).st_uid != uid:
            return False  # someone else's folder: do not load compiled code from it
    except OSError:
        return False
    os.environ["NUMBA_CACHE_DIR"] = path  # for numba's config reloads and child processes
    numba.config.CACHE_DIR = path
    return _cache_available()


CACHE = _cache_available() or _set_cache_dir()

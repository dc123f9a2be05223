"""Where numba's on-disk cache of the compiled kernels lives, and when a cached kernel is stale.

numba caches a compiled function next to its source (``__pycache__`` of the kernel's folder
under ``simulate/``) when that folder is writable (an editable install, a checkout), else in the
user-wide cache folder (``~/.cache/numba``: a package installed read-only, checked on a
read-only bind mount of ``src/``). Only when neither is writable (no home, a read-only home)
does numba refuse to decorate a ``cache=True`` function at all; then, and only then, this module
points numba at a private folder of the temporary directory (``NUMBA_CACHE_DIR``), and if that
fails too the kernels are compiled without a cache (``CACHE`` is False).

numba keys a cached function on its own source file only (its modification time and size), but
a kernel also holds the functions it inlines or calls from other files: after an edit there,
numba would go on loading the kernel compiled from the old sources, silently. So a kernel file
that uses another file's kernels records the digest of those sources (:func:`source_digest`) and
caches only while they match (:func:`cache_unless_stale`); an edit of an inlined file then has to
come with an edit of the digest in every file that inlines it (which invalidates their caches;
``tests/test_simulate_determinism.py`` checks the digests).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import warnings
from pathlib import Path
from types import ModuleType

import numba

__all__ = ["CACHE", "source_digest", "cache_unless_stale"]


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


def source_digest(*modules: ModuleType) -> str:
    """sha256 (hex) of the sources of ``modules``, in order, line endings normalised; "" if one
    is unreadable."""
    sha = hashlib.sha256()
    for module in modules:
        try:
            src = Path(module.__file__).read_bytes()
        except (OSError, TypeError):
            return ""
        sha.update(src.replace(b"\r\n", b"\n"))
    return sha.hexdigest()


def cache_unless_stale(name: str, recorded: str, *modules: ModuleType) -> bool:
    """Whether the kernels of module ``name`` may use numba's on-disk cache: :data:`CACHE`, and
    ``recorded`` is the :func:`source_digest` of the ``modules`` they inline (else a warning
    that gives the digest to record, and the kernels are compiled without the cache)."""
    if not CACHE:
        return False
    digest = source_digest(*modules)
    if digest == recorded:
        return True
    files = ", ".join(Path(m.__file__).name for m in modules)
    warnings.warn(
        f"{files} changed since {name} recorded their digest: its kernels are compiled without "
        f"numba's on-disk cache (record INLINED_SHA256 = {digest!r} in {name})",
        RuntimeWarning,
        stacklevel=2,
    )
    return False

"""All-or-nothing writes: a reader sees the old file (or folder) or the complete new one, never
a part.

- :func:`atomic_path`: the one way every writer of the project writes a file. The writer writes
  a temporary path in the target's folder (same file system, so the final move is a rename);
  when it is done the file is flushed to disk and renamed over the target; if anything fails (an
  error, a full disk, an interrupt) the temporary file is removed and the target is untouched.
- :func:`atomic_write_text`: a text file through :func:`atomic_path`.
- :func:`staged_folder`: a command's whole run folder, all or nothing.

On the ground floor (it needs only :mod:`freeplayid.errors`), so the model's files
(:func:`freeplayid.model.save_system`), the data sets and results of :mod:`freeplayid.io`, the
studies' caches and the inverse model's point sets are written the same way.
"""

from __future__ import annotations

import fnmatch
import os
import secrets
import shutil
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from .errors import OutputError

__all__ = ["atomic_path", "atomic_write_text", "staged_folder", "STAGE_PREFIX", "TEMP_PREFIX"]

STAGE_PREFIX = ".partial-"  # the staging folder inside the output folder: .partial-<pid>
TEMP_PREFIX = ".tmp-"  # a temporary file beside its target: .tmp-<pid>-<random>-<name>


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Write ``path`` all or nothing: the block writes the yielded temporary path, which is
    renamed over ``path`` when the block completes.

    The temporary file lies in the folder of ``path`` (the rename stays on one file system) and
    its name is ``.tmp-<pid>-<random>-<name of path>``: hidden, unique to the process and the
    call (parallel jobs may write the same cache file), and ending like ``path`` (a ``.csv.gz``
    is still gzipped by ``np.savetxt``, a ``.npz`` gets no second suffix from ``np.savez``).
    On success it is flushed to disk (``fsync``) before the rename; on any exception of the
    block (including ``KeyboardInterrupt``) or of the rename it is removed and the exception
    re-raised, so no temporary file is left behind and ``path`` keeps its earlier content.

    Parameters
    ----------
    path : path-like
        The target file; its folder must exist.

    Examples
    --------
    >>> with atomic_path(folder / "model.npz") as tmp:  # doctest: +SKIP
    ...     np.savez(tmp, M=M, K=K)
    """
    path = Path(path)
    tmp = path.with_name(f"{TEMP_PREFIX}{os.getpid()}-{secrets.token_hex(4)}-{path.name}")
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` through :func:`atomic_path`; return ``path``."""
    path = Path(path)
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8") as fh:
        fh.write(text)
    return path


def _refuse_earlier(folder: Path, allow: Sequence[str]) -> None:
    earlier = sorted(e.name for e in folder.iterdir()
                     if not any(fnmatch.fnmatchcase(e.name, pat) for pat in allow))
    if earlier:
        shown = ", ".join(earlier[:6]) + (" ..." if len(earlier) > 6 else "")
        raise OutputError(
            f"output folder {str(folder)!r} already holds files of an earlier run ({shown}); "
            "choose a new folder (hydra.run.dir=...) or remove them"
        )


@contextmanager
def staged_folder(folder: str | os.PathLike, *,
                  allow: Sequence[str] = (".hydra", "*.log")) -> Iterator[Path]:
    """All-or-nothing results: write into the yielded folder; its entries appear in ``folder``
    only when the ``with`` block completes.

    The staging folder is ``folder/.partial-<pid>``: the same file system, so each entry moves
    into place by a rename. On any exception of the block (an error, a full disk's ``OSError``,
    ``KeyboardInterrupt``/SIGINT) the staging folder is removed and the exception re-raised, so
    ``folder`` keeps only what was there before (for a Hydra run, ``.hydra/`` and the log).
    Each file in the staging folder is written as the block likes (through :func:`atomic_path`
    or not: nothing outside the staging folder sees it before the whole folder is complete).

    Parameters
    ----------
    folder : path-like
        The output folder (created if missing), e.g. Hydra's run folder.
    allow : sequence of str
        Glob patterns of entries ``folder`` may already hold (Hydra's ``.hydra/`` and job log);
        any other entry is an earlier run's result and is refused (nothing is overwritten).

    Raises
    ------
    freeplayid.errors.OutputError
        ``folder`` is a file, cannot be written, or holds an earlier run's files (named), before
        the block runs; or moving the results into place failed (then none is left there).
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"output folder {str(folder)!r} is a file, not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"cannot create output folder {str(folder)!r}: "
                          f"{e.strerror or e}") from None
    _refuse_earlier(folder, allow)
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(f"output folder {str(folder)!r} is not writable")
    stage = folder / f"{STAGE_PREFIX}{os.getpid()}"
    try:
        stage.mkdir()
    except OSError as e:
        raise OutputError(f"cannot write in output folder {str(folder)!r}: "
                          f"{e.strerror or e}") from None
    moved: list[Path] = []
    try:
        yield stage
        for entry in sorted(stage.iterdir()):
            target = folder / entry.name
            os.replace(entry, target)
            moved.append(target)
        stage.rmdir()
    except BaseException as exc:
        shutil.rmtree(stage, ignore_errors=True)
        for target in moved:  # a move failed half-way: take back what already moved
            if target.is_dir():
                shutil.rmtree(target, ignore_errors=True)
            else:
                target.unlink(missing_ok=True)
        if moved and isinstance(exc, OSError):
            raise OutputError(f"moving the results into {str(folder)!r} failed: "
                              f"{exc.strerror or exc}") from None
        raise

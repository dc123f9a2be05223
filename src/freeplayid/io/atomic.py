"""All-or-nothing file writes: a reader sees the old file or the complete new one, never a part."""

from __future__ import annotations

import fnmatch
import os
import shutil
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from ..errors import OutputError

__all__ = ["atomic_write_text", "staged_folder", "STAGE_PREFIX"]

STAGE_PREFIX = ".partial-"  # the staging folder inside the output folder: .partial-<pid>


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename.

    The temporary file is flushed to disk before the rename and removed if anything fails (a full
    disk, an interrupt), so no ``.tmp`` file is left behind.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
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

"""Progress bars, and the environment switch for the warnings the package keeps quiet.

Every wait of a few seconds or more in the library (the extraction, the multi-start fit, the
replays, the bootstrap by replay, the simulations, a study's banks and fits) shows a bar made
here: a ``tqdm.auto`` bar, a widget in a notebook (text there without ipywidgets) and text on
stderr elsewhere. A function's ``progress=False`` silences its bars; a simulation's default
(``progress=None``) shows one for a long run only where someone watches it (:func:`watched`).

What the library has to say goes to its loggers (``logging.getLogger(__name__)`` in every
module): INFO for what a user waiting at a terminal wants to read (a kernel being compiled, a
bank being simulated), DEBUG for the record (each replay's numbers). A command (Hydra) shows the
INFO lines on the terminal and writes both to its log file (``freeplayid.tasks.logs``); a library
user sees them after ``logging.basicConfig(level=logging.INFO)``.

Third-party chatter (Lightning's banners and tips, its and torch's deprecation warnings) stays
quiet unless the environment variable ``FREEPLAYID_WARNINGS`` is set to 1 (:func:`warnings_wanted`).
"""

from __future__ import annotations

import os
import sys

from tqdm.auto import tqdm

__all__ = ["progress_bar", "watched", "warnings_wanted", "WARNINGS_ENV"]

WARNINGS_ENV = "FREEPLAYID_WARNINGS"


def warnings_wanted() -> bool:
    """Whether ``FREEPLAYID_WARNINGS`` asks for the third-party lines and warnings the package
    keeps quiet by default (any value but empty, 0, false, no, off)."""
    return os.environ.get(WARNINGS_ENV, "").strip().lower() not in ("", "0", "false", "no", "off")


def watched() -> bool:
    """Whether someone watches the bars: stderr is a terminal, or this runs in a notebook's
    kernel (Jupyter's ``IPKernelApp``)."""
    try:
        if sys.stderr is not None and sys.stderr.isatty():
            return True
    except (AttributeError, ValueError):  # a closed or replaced stream
        pass
    ipython = sys.modules.get("IPython")
    try:
        shell = ipython.get_ipython() if ipython is not None else None
        return shell is not None and "IPKernelApp" in shell.config
    except Exception:  # IPython's internals vary: no kernel then
        return False


def progress_bar(iterable=None, *, desc: str, total=None, unit: str = "it", show: bool = True,
                 leave: bool = True, delay: float = 0.0, **kwargs) -> tqdm:
    """A ``tqdm.auto`` bar (a notebook widget or stderr text), disabled unless ``show``.

    ``delay`` [s]: the bar appears only once a step ends that late (a wait that may be short
    leaves no bar behind); the other keyword arguments are tqdm's.
    """
    return tqdm(iterable, desc=desc, total=total, unit=unit, disable=not show, leave=leave,
                delay=delay, **kwargs)

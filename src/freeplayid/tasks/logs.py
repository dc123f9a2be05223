"""The commands' logging: what they show on the terminal and what their log file keeps.

Hydra configures it from ``conf/hydra/job_logging/freeplayid.yaml`` (every command's config
selects it) before the task runs:

- stdout: the command's own lines (``freeplayid.tasks.*`` at INFO and above: the result summary,
  what was written where), the message alone, as the commands printed them;
- stderr: the library's INFO lines (a numba kernel being compiled, a bank being simulated) and
  any logger's warnings and errors (``warning: ...``); with ``FREEPLAYID_WARNINGS=1`` also the
  other libraries' INFO lines (Lightning's banners);
- ``<name>.log`` in the run folder: all of it, with the library's DEBUG lines (each replay's
  kn, delta and misfit), each line with its time, logger and level.

The terminal lines are written around the progress bars (``tqdm.write``), so a line never lands
inside a bar.
"""

from __future__ import annotations

import logging

from tqdm import tqdm

from ..progress import warnings_wanted

__all__ = ["ConsoleHandler", "PlainFormatter", "CommandFilter", "LibraryFilter"]

COMMAND_LOGGERS = "freeplayid.tasks"  # the commands' own loggers (module loggers of tasks/)


def _of(record: logging.LogRecord, name: str) -> bool:
    return record.name == name or record.name.startswith(name + ".")


class ConsoleHandler(logging.StreamHandler):
    """A terminal handler that clears the progress bars, writes its line and draws them again."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            tqdm.write(self.format(record), file=self.stream)
            self.flush()
        except RecursionError:
            raise
        except Exception:  # as logging.StreamHandler: report, never raise
            self.handleError(record)


class PlainFormatter(logging.Formatter):
    """The message alone; a warning or an error led by ``warning: `` or ``error: ``."""

    def format(self, record: logging.LogRecord) -> str:
        message = super().format(record)
        if record.levelno >= logging.WARNING:
            return f"{record.levelname.lower()}: {message}"
        return message


class CommandFilter(logging.Filter):
    """The command's own lines: ``freeplayid.tasks.*`` at INFO and above."""

    def filter(self, record: logging.LogRecord) -> bool:
        return _of(record, COMMAND_LOGGERS) and record.levelno >= logging.INFO


class LibraryFilter(logging.Filter):
    """Every other line the terminal shows: the package's INFO and above, any logger's
    warnings; any logger's INFO too with ``FREEPLAYID_WARNINGS``."""

    def filter(self, record: logging.LogRecord) -> bool:
        if _of(record, COMMAND_LOGGERS) or record.levelno < logging.INFO:
            return False
        if record.levelno >= logging.WARNING or warnings_wanted():
            return True
        return _of(record, "freeplayid")

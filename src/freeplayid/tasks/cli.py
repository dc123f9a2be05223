"""The commands: ``freeplayid-identify``, ``-simulate``, ``-model``, ``-train``, ``-compare``.

Each is a console entry point of the installed package (pyproject's ``[project.scripts]``) and
the body of its ``scripts/<name>.py`` wrapper, which is the same command run from a checkout:
Hydra composes ``<name>.yaml`` of the package's configs (``freeplayid/conf``, package data, so
an installed wheel finds them), the command line is checked before Hydra makes the run folder
(:func:`~.common.check_command_line`), and the task runs with one-line errors
(:func:`~.common.command_errors`). The run folder, its ``.hydra/`` and ``<name>.log`` are the
same whichever way the command is started.
"""

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig

from .common import check_command_line, command_errors
from .compare import compare as _compare
from .identify import identify as _identify
from .model import model as _model
from .simulate import simulate as _simulate
from .train import train as _train

__all__ = ["COMMANDS", "CONFIG_PATH", "compare", "identify", "model", "simulate", "train"]

COMMANDS = {"identify": _identify, "simulate": _simulate, "model": _model, "train": _train,
            "compare": _compare}
# the package's configs (package data), as an absolute path: Hydra reads them as files
CONFIG_PATH = str(Path(__file__).resolve().parents[1] / "conf")


def _run(name: str) -> None:
    """Run the command ``name`` on ``sys.argv``'s overrides (Hydra's command line)."""
    task = COMMANDS[name]

    def main(cfg: DictConfig) -> dict:
        with command_errors(name):  # an input problem or Ctrl-C: one line
            return task(cfg)

    # Hydra names the job (``<name>.log``, ``hydra.job.name``) after the task function's module
    main.__module__ = task.__module__  # freeplayid.tasks.<name>
    main = hydra.main(version_base="1.3", config_path=CONFIG_PATH, config_name=name)(main)
    with command_errors(name):  # Ctrl-C while Hydra composes: one line too
        check_command_line(name, sys.argv)  # before Hydra makes the folder
        main()


def identify() -> None:
    """``freeplayid-identify [overrides]``: kn and delta of a data set (docs/identify.md)."""
    _run("identify")


def simulate() -> None:
    """``freeplayid-simulate [overrides]``: simulated sweeps written as a data set."""
    _run("simulate")


def model() -> None:
    """``freeplayid-model [overrides]``: the linear fin model from modal tests (docs/model.md)."""
    _run("model")


def train() -> None:
    """``freeplayid-train [overrides]``: the neural inverse model (docs/inverse.md)."""
    _run("train")


def compare() -> None:
    """``freeplayid-compare [overrides]``: the network-started fit against pure fitting."""
    _run("compare")

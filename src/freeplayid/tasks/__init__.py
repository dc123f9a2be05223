"""Hydra-aware entry points: one function per script, taking the composed config.

Each task instantiates the library objects from the config, seeds, runs, saves (via ``io``),
draws (via ``plots``), writes ``metrics.json`` in the run folder and returns the metrics.
This is the only package that imports Hydra/OmegaConf.
"""

from .common import (
    build_system,
    check_command_line,
    check_run_dir,
    command_errors,
    register_configs,
    run_dir,
    write_metrics,
)
from .compare import compare
from .identify import bundled_example, identify
from .model import model
from .simulate import simulate
from .train import train

register_configs()  # model=fin: the package's default fin (one copy of its numbers)

__all__ = [
    "build_system", "check_command_line", "check_run_dir", "command_errors", "register_configs",
    "run_dir",
    "write_metrics", "simulate",
    "identify", "bundled_example", "train", "compare", "model",
]

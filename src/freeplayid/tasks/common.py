"""Helpers shared by the tasks: the model from its config group, the study data set and network
from theirs (config -> :mod:`freeplayid.studies` arguments), the run folder, metrics."""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from omegaconf import DictConfig, OmegaConf

from ..atomic import atomic_write_text
from ..errors import InputError, OutputError
from ..model import FreeplaySystem, fin_from_config, load_system, sdof_system
from .options import register_option_groups

if TYPE_CHECKING:
    from ..studies import StudyData

__all__ = ["build_system", "register_configs", "study_specs", "study_data", "train_network",
           "run_dir", "write_metrics", "writing_to", "check_run_dir", "check_command_line",
           "command_errors", "debug_choice", "MODEL_KINDS", "INTERRUPTED", "LAUNCHER_EXTRAS"]

log = logging.getLogger(__name__)

MODEL_KINDS = ("fin", "npz", "sdof")
INTERRUPTED = 130  # exit status of a command stopped by Ctrl-C (128 + SIGINT, as a shell's)


def register_configs() -> None:
    """Store the package's default fin in Hydra's ConfigStore as the option ``model=fin``, and
    the option records' groups (:func:`freeplayid.tasks.options.register_option_groups`).

    The fin's numbers live once, in the package data ``freeplayid/model/fin/fin.yaml``
    (:func:`freeplayid.model.fin_config_path`, read by ``default_fin()`` in any install); the
    ``model`` group of ``freeplayid/conf/`` holds the other options (``sdof``, ``npz``). The
    ConfigStore is on every Hydra search path, so ``model=fin`` composes from every primary config,
    also from one included by another (``compare`` includes ``train``, where a ``hydra.searchpath``
    entry is refused), with the file's keys and values (OmegaConf's YAML loader), so overrides such
    as ``model.geometry.root_chord=0.25`` apply. Runs when :mod:`freeplayid.tasks` is imported (the
    scripts import it before ``@hydra.main`` composes; a compose elsewhere imports it first).
    """
    from hydra.core.config_store import ConfigStore

    from ..model.fin.config import fin_config_path

    node = OmegaConf.create(fin_config_path().read_text(encoding="utf-8"))
    ConfigStore.instance().store(group="model", name="fin", node=node, provider="freeplayid")
    register_option_groups()


def build_system(model_cfg: DictConfig | dict) -> FreeplaySystem:
    """The linear structure selected by the ``model`` config group.

    ``kind: fin`` -> :func:`freeplayid.model.fin_from_config` (the default plate-FE fin),
    ``kind: npz`` -> :func:`freeplayid.model.load_system` of ``path`` (relative to the directory
    the command was started from), ``kind: sdof`` -> :func:`freeplayid.model.sdof_system`.
    """
    cfg = OmegaConf.to_container(model_cfg, resolve=True) if isinstance(model_cfg, DictConfig) \
        else dict(model_cfg)
    kind = cfg.get("kind")
    if kind == "fin":
        return fin_from_config({k: v for k, v in cfg.items() if k != "channels"})
    if kind == "npz":
        from hydra.utils import to_absolute_path

        path = cfg.get("path")
        if not path:
            raise ValueError("model `kind`='npz' needs `path` (model.path=FILE.npz)")
        return load_system(to_absolute_path(str(path)))
    if kind == "sdof":
        return sdof_system(
            mass=float(cfg["mass"]), stiffness=float(cfg.get("stiffness", 0.0)),
            damping=float(cfg.get("damping", 0.0)),
        )
    raise ValueError(f"model `kind` must be one of {MODEL_KINDS}, got {kind!r}")


def _channels(cfg: DictConfig, system: FreeplaySystem) -> tuple:
    chosen = cfg.dataset.get("channels") or cfg.model.get("channels")
    if chosen:
        c = OmegaConf.to_container(chosen, resolve=True)
        return tuple(c.values()) if isinstance(c, dict) else tuple(c)
    return tuple(d for d in system.dof_names if d.startswith("uz_")) or tuple(system.dof_names)


def study_specs(cfg: DictConfig, system: FreeplaySystem) -> tuple:
    """What ``cfg.dataset`` asks of :func:`freeplayid.studies.prepare_study` for ``system``.

    Returns
    -------
    (BankSpec, CaseSpec, split, cache_dir)
        ``split`` the three fractions, ``cache_dir`` the absolute path of
        ``dataset.cache_dir`` (relative to the directory the command was started from); the
        channels are ``dataset.channels``, else ``model.channels``, else every ``uz_*`` DOF.
    """
    from hydra.utils import to_absolute_path

    from ..simulate import Sweep
    from ..studies import BankSpec, CaseSpec

    d = OmegaConf.to_container(cfg.dataset, resolve=True)
    b = dict(d["bank"])
    b["sweep"] = Sweep(**b["sweep"])
    return (BankSpec(channels=_channels(cfg, system), **b), CaseSpec(**d["cases"]),
            tuple(d["split"]), Path(to_absolute_path(str(d["cache_dir"]))))


def study_data(cfg: DictConfig, *, progress: bool = True) -> StudyData:
    """:func:`freeplayid.studies.prepare_study` of ``cfg.model`` and ``cfg.dataset``
    (:func:`study_specs`). The returned ``build_s`` includes building the model."""
    from ..studies import prepare_study

    t0 = time.perf_counter()
    system = build_system(cfg.model)
    bank_spec, case_spec, split, cache_dir = study_specs(cfg, system)
    data = prepare_study(system, bank_spec=bank_spec, case_spec=case_spec, split=split,
                         cache_dir=cache_dir, progress=progress)
    return dataclasses.replace(data, build_s=time.perf_counter() - t0)


def train_network(cfg: DictConfig, data: StudyData, out: Path) -> tuple[Path, dict]:
    """:func:`freeplayid.studies.train_study_network` with ``cfg.network``, ``cfg.training``
    (the optimiser and the batches), ``cfg.trainer`` (``pl.Trainer`` arguments: ``max_epochs``,
    ``accelerator`` and any other given), ``cfg.logger`` and ``cfg.callbacks``: (checkpoint,
    per-epoch history).

    The checkpoint records ``cfg.dataset`` (its ``extra["dataset"]``).
    """
    from ..studies import train_study_network

    t = cfg.training
    trainer = OmegaConf.to_container(cfg.trainer, resolve=True)
    max_epochs, accelerator = int(trainer.pop("max_epochs")), str(trainer.pop("accelerator"))
    stop = cfg.callbacks.early_stopping
    return train_study_network(
        data, out, extra={"dataset": OmegaConf.to_container(cfg.dataset, resolve=True)},
        hidden=int(cfg.network.hidden), depth=int(cfg.network.depth),
        noise_input=cfg.network.get("noise_input"),
        rate_input=bool(cfg.network.get("rate_input", False)), lr=float(t.lr),
        weight_decay=float(t.weight_decay), batch_size=int(t.batch_size),
        max_epochs=max_epochs, seed=int(cfg.seed), accelerator=accelerator,
        logger=str(cfg.logger.kind), trainer_kwargs=trainer,
        early_stopping=None if stop is None else OmegaConf.to_container(stop, resolve=True),
    )


def run_dir() -> Path:
    """Hydra's output folder of this run (the working directory outside a Hydra run)."""
    from hydra.core.hydra_config import HydraConfig

    if HydraConfig.initialized():
        return Path(HydraConfig.get().runtime.output_dir)
    return Path.cwd()


def debug_choice() -> str | None:
    """The ``debug`` option this run composed (``debug=fast``: "fast"), None without one or
    outside a Hydra run."""
    from hydra.core.hydra_config import HydraConfig

    if not HydraConfig.initialized():
        return None
    return HydraConfig.get().runtime.choices.get("debug")


def write_metrics(folder: Path, metrics: dict) -> Path:
    """Write ``metrics.json`` (atomically) and return its path."""
    return atomic_write_text(Path(folder) / "metrics.json",
                             json.dumps(metrics, indent=2, sort_keys=True))


@contextmanager
def writing_to(folder: Path) -> Iterator[None]:
    """Turn an ``OSError`` of writing results (a full disk, a lost mount) into one
    :class:`~freeplayid.errors.OutputError` line naming ``folder``."""
    try:
        yield
    except OSError as e:
        raise OutputError(f"writing the results to {str(folder)!r} failed: "
                          f"{e.strerror or e}; nothing was saved") from None


@contextmanager
def command_errors(command: str) -> Iterator[None]:
    """How every command ends on what it cannot finish, one line on stderr and no traceback:
    an :class:`~freeplayid.errors.InputError` as ``command: message`` (exit status 1), Ctrl-C
    (``KeyboardInterrupt``) as ``command: interrupted`` (exit status 130). Nothing is left half
    written: the results are staged and moved in whole (:mod:`freeplayid.atomic`), and the
    staging folder is removed on the way out.

    A script wraps both its Hydra task (where Hydra would print an ``InputError``'s traceback)
    and its whole ``__main__`` block (Ctrl-C while Hydra composes the configuration)::

        @hydra.main(...)
        def main(cfg):
            with tasks.command_errors("identify"):
                return tasks.identify(cfg)

        if __name__ == "__main__":
            with tasks.command_errors("identify"):
                main()
    """
    try:
        yield
    except InputError as exc:
        log.debug("%s: %s", command, exc)  # the log file's last line (the terminal: sys.exit's)
        sys.exit(f"{command}: {exc}")
    except KeyboardInterrupt:
        _close_progress_bars()
        sys.stdout.flush()
        log.debug("%s: interrupted", command)
        print(f"{command}: interrupted", file=sys.stderr)
        sys.exit(INTERRUPTED)


def _close_progress_bars() -> None:
    """End the progress bars an interrupt left open (a bar's loop stopped in its body does not
    close it), so that the line after them starts on a line of its own. A bar interrupted while
    it drew itself in its constructor cannot close its line itself: it gets the line's end."""
    from tqdm import tqdm

    for bar in list(getattr(tqdm, "_instances", ())):
        drawing = getattr(bar, "sp", None) is not None and not hasattr(bar, "last_print_t")
        try:
            bar.close()
            if drawing:
                bar.fp.write("\n")
        except (OSError, ValueError):  # a closed stream: nothing to end
            pass


# group overrides Hydra cannot take as values (a bool where a group option is due), with what to
# write instead
_GROUP_VALUES = {("replay", "false"): "replay=off", ("replay", "true"): "replay=default",
                 ("records", "false"): "records=off", ("records", "true"): "records=default"}


# Hydra launchers of the optional extras: option -> (the plugin's module, the extra)
LAUNCHER_EXTRAS = {
    "joblib": ("hydra_plugins.hydra_joblib_launcher", "parallel"),
    "submitit_slurm": ("hydra_plugins.hydra_submitit_launcher", "slurm"),
    "submitit_local": ("hydra_plugins.hydra_submitit_launcher", "slurm"),
}


def check_command_line(command: str, argv: list[str]) -> None:
    """Exit with one line for an override Hydra would end in a traceback (``replay=false``:
    the plain fit is ``replay=off``; a launcher whose plugin, an optional extra, is not
    installed), then check the run folder (:func:`check_run_dir`)."""
    for arg in argv[1:]:
        key, _, value = arg.partition("=")
        key, value = key.lstrip("+~"), value.strip()
        fix = _GROUP_VALUES.get((key, value.lower()))
        if fix:
            sys.exit(f"{command}: `{arg}` is not a choice of the `{key}` group; use {fix}")
        if key == "hydra/launcher" and value in LAUNCHER_EXTRAS:
            module, extra = LAUNCHER_EXTRAS[value]
            if not _installed(module):
                sys.exit(f"{command}: `{arg}` needs the launcher plugin of the `{extra}` extra "
                         f"(pip install \"freeplayid[{extra}]\")")
    check_run_dir(command, argv)


def _installed(module: str) -> bool:
    """Whether ``module`` can be imported (without importing it)."""
    import importlib.util

    try:
        return importlib.util.find_spec(module) is not None
    except ModuleNotFoundError:  # its parent package is not there either
        return False


def check_run_dir(command: str, argv: list[str]) -> None:
    """Exit with one line when ``hydra.run.dir=PATH`` in ``argv`` cannot be a run folder.

    Hydra creates the run folder and writes ``.hydra/`` before the task runs, so a file there or
    a folder that cannot be written would end in its traceback; a script calls this first.
    """
    for arg in argv[1:]:
        key, sep, value = arg.partition("=")
        if key.lstrip("+~") != "hydra.run.dir" or not sep or "${" in value:
            continue
        path = Path(value).expanduser().absolute()
        if path.exists() and not path.is_dir():
            sys.exit(f"{command}: output folder {str(path)!r} (hydra.run.dir) is a file, "
                     "not a folder")
        parent = path
        while not parent.exists():
            parent = parent.parent
        if not parent.is_dir():
            sys.exit(f"{command}: output folder {str(path)!r} (hydra.run.dir) cannot be made: "
                     f"{str(parent)!r} is a file")
        if not os.access(parent, os.W_OK | os.X_OK):
            sys.exit(f"{command}: output folder {str(path)!r} (hydra.run.dir) is not "
                     f"writable ({str(parent)!r})")

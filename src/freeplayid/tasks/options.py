"""The option records of the library as Hydra config groups, and back.

The groups ``extraction``, ``fit``, ``replay``, ``linear_model`` and ``records`` are made from
:class:`freeplayid.signal.Extraction`, :class:`freeplayid.fit.FitOptions`,
:class:`freeplayid.replay.Replay`, :class:`freeplayid.model.ModelOptions` and
:class:`freeplayid.quality.RecordCheckOptions` themselves (their defaults, stored in Hydra's
ConfigStore by :func:`register_option_groups`), so an option is one field of one dataclass and
its default lives there only. The nodes are
stored untyped: a wrong value (``fit.n_bootstrap=2.7``) reaches the record's own validation and
ends as one line naming the field (``fit.n_bootstrap``), where OmegaConf's typed nodes would end
in Hydra's five-line error. ``replay=off`` selects the plain fit, ``records=off`` identifies
from the records as they are (no record checks).
"""

from __future__ import annotations

import dataclasses
import re

from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from ..errors import ConfigError
from ..fit import FitOptions
from ..model import ModelOptions
from ..quality import RecordCheckOptions
from ..replay import Replay
from ..signal import Extraction

__all__ = ["OPTION_GROUPS", "register_option_groups", "options_from_config", "identify_options"]

# config group -> the option record it is made of
OPTION_GROUPS = {"extraction": Extraction, "fit": FitOptions, "replay": Replay,
                 "linear_model": ModelOptions, "records": RecordCheckOptions}
# config group -> the argument of freeplayid.identify it becomes
IDENTIFY_ARGUMENTS = {"extraction": "extraction", "fit": "fit", "replay": "replay",
                      "linear_model": "model", "records": "records"}
# the groups that can be switched off (the argument None): their switch is not a field of the
# record; replay=off (records=off) sets it false
SWITCHED = ("replay", "records")
ENABLED = "enabled"


def _config_fields(cls) -> list[str]:
    """The record's fields that are config keys (not those marked ``metadata={"config":
    False}``, e.g. :attr:`freeplayid.fit.FitOptions.init`, an object the task passes)."""
    return [f.name for f in dataclasses.fields(cls) if f.metadata.get("config", True)]


def _node(cls) -> dict:
    """The record's defaults as a plain config node (tuples as lists)."""
    def plain(v):
        if dataclasses.is_dataclass(v):
            return {k: plain(getattr(v, k)) for k in _config_fields(type(v))}
        if isinstance(v, dict):
            return {k: plain(x) for k, x in v.items()}
        return list(v) if isinstance(v, tuple) else v
    return plain(cls())


def register_option_groups() -> None:
    """Store each group's ``default`` (``extraction/default``, ...) and ``off`` for the groups
    that can be switched off (``replay/off``, ``records/off``)."""
    from hydra.core.config_store import ConfigStore

    cs = ConfigStore.instance()
    for group, cls in OPTION_GROUPS.items():
        node = _node(cls)
        if group in SWITCHED:
            cs.store(group=group, name="off", node={ENABLED: False}, provider="freeplayid")
            node = {ENABLED: True, **node}
        cs.store(group=group, name="default", node=node, provider="freeplayid")


def options_from_config(cfg: DictConfig, group: str):
    """The option record of config group ``group`` (None for ``replay=off``, ``records=off``).

    Raises
    ------
    ConfigError
        An unknown key or a value the record refuses, named with its group
        ("`fit.n_bootstrap` must be an integer >= 0, got 2.7").
    """
    cls = OPTION_GROUPS[group]
    try:
        values = OmegaConf.to_container(cfg[group], resolve=True)
    except OmegaConfBaseException as e:
        raise ConfigError(f"`{group}` cannot be resolved: {str(e).splitlines()[0]}") from None
    if group in SWITCHED and not values.pop(ENABLED, True):
        return None
    names = _config_fields(cls)
    unknown = sorted(set(values) - set(names))
    if unknown:
        raise ConfigError(f"`{group}.{unknown[0]}` is not an option of `{group}`; valid: {names}")
    try:
        return cls(**values)
    except (TypeError, ValueError) as e:
        # the record names its field: `n_bootstrap` -> `fit.n_bootstrap`
        raise ConfigError(re.sub(r"`([A-Za-z_.]+)`", rf"`{group}.\1`", str(e), count=1)) from None


def identify_options(cfg: DictConfig) -> dict:
    """The option arguments of :func:`freeplayid.identify` from the config's groups."""
    return {arg: options_from_config(cfg, group) for group, arg in IDENTIFY_ARGUMENTS.items()}

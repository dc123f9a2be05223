"""Up-front validation of a command's whole configuration: every field against its type and
allowed values before any long work, each failure one :class:`~freeplayid.errors.ConfigError`
line naming the field (``multistart.n``) and what is allowed.

A rule is a function ``(value) -> str | None``: None when the value is allowed, else the
allowed values in words ("an integer >= 1"). :func:`check_fields` applies a ``{field: rule}``
table to a config; the tables of the four commands are :data:`IDENTIFY`, :data:`SIMULATE`,
:data:`TRAIN` and :data:`COMPARE`. OmegaConf parses command-line values itself (``2.7`` a float,
``abc`` a string, ``true`` a bool), so a rule sees a typed value and refuses a wrong type
instead of converting it (``n_bootstrap=2.7`` is an error, not 2).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import PurePath

from omegaconf import DictConfig, ListConfig, OmegaConf
from omegaconf.errors import MissingMandatoryValue, OmegaConfBaseException

from ..errors import ConfigError
from ..quantity import QUANTITIES

__all__ = ["ConfigError", "check_fields", "check_config", "IDENTIFY", "SIMULATE", "TRAIN",
           "COMPARE"]

Rule = Callable[[object], "str | None"]
_MISSING = object()


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _bound(lo, hi, lo_open) -> str:
    parts = []
    if lo is not None:
        parts.append(f"{'>' if lo_open else '>='} {lo:g}")
    if hi is not None:
        parts.append(f"<= {hi:g}")
    return " " + " and ".join(parts) if parts else ""


def integer(lo: int | None = None, hi: int | None = None) -> Rule:
    def rule(v):
        ok = _is_int(v) and (lo is None or v >= lo) and (hi is None or v <= hi)
        return None if ok else f"an integer{_bound(lo, hi, False)}"
    return rule


def number(lo: float | None = None, hi: float | None = None, *, open_lo: bool = False) -> Rule:
    def rule(v):
        ok = _is_num(v) and (lo is None or (v > lo if open_lo else v >= lo)) \
            and (hi is None or v <= hi)
        return None if ok else f"a finite number{_bound(lo, hi, open_lo)}"
    return rule


def positive() -> Rule:
    return number(0.0, open_lo=True)


def boolean() -> Rule:
    return lambda v: None if isinstance(v, bool) else "true or false"


def choice(*options) -> Rule:
    return lambda v: None if isinstance(v, str) and v in options else f"one of {list(options)}"


def text() -> Rule:
    return lambda v: None if isinstance(v, str) and v.strip() else "a non-empty text"


def either(first: Rule, second: Rule) -> Rule:
    """A value allowed by ``first`` or by ``second``."""
    def rule(v):
        a, b = first(v), second(v)
        return None if a is None or b is None else f"{a} or {b}"
    return rule


def optional(inner: Rule) -> Rule:
    def rule(v):
        why = None if v is None else inner(v)
        return None if why is None else f"null or {why}"
    return rule


def numbers(inner: Rule, *, length: int | None = None, increasing: bool = False) -> Rule:
    """A non-empty list of values each allowed by ``inner`` (``length`` of them)."""
    def rule(v):
        size = f"{length} " if length else "a non-empty list of "
        what = f"{size}values each {inner(None) or 'allowed'}"
        if increasing:
            what += ", increasing"
        if not isinstance(v, (list, tuple, ListConfig)) or not len(v) or \
                (length and len(v) != length):
            return f"[{what}]" if length else what
        if any(inner(x) is not None for x in v):
            return f"[{what}]" if length else what
        if increasing and any(b <= a for a, b in zip(v, v[1:], strict=False)):
            return what
        return None
    return rule


def relative_path() -> Rule:
    def rule(v):
        ok = isinstance(v, str) and v.strip() and not PurePath(v).is_absolute() \
            and ".." not in PurePath(v).parts
        return None if ok else "a folder name inside the run folder (relative, no '..')"
    return rule


def channel_map(*, lists: bool = False) -> Rule:
    def rule(v):
        ok = v is None or (isinstance(v, dict) and len(v) and all(
            isinstance(k, str) and isinstance(x, str) for k, x in v.items())) or (
            lists and isinstance(v, list) and len(v) and all(isinstance(x, str) for x in v))
        return None if ok else ("null, a list of DOF names or a mapping column -> DOF name"
                                if lists else "null or a mapping CSV column -> DOF name")
    return rule


def _value(cfg, field: str):
    try:
        return OmegaConf.select(cfg, field, default=_MISSING, throw_on_missing=True)
    except MissingMandatoryValue:
        raise ConfigError(f"`{field}` must be given ({field}=...)") from None
    except OmegaConfBaseException as e:  # an interpolation that does not resolve
        first = str(e).splitlines()[0] if str(e) else type(e).__name__
        first = first.removeprefix("MissingMandatoryValue while resolving interpolation: ")
        raise ConfigError(f"`{field}` cannot be resolved: {first}") from None


def check_fields(cfg: DictConfig, rules: Mapping[str, Rule], *, required: bool = True) -> None:
    """Check every ``field: rule`` of ``rules`` in ``cfg``; the first failure is raised.

    Raises
    ------
    ConfigError
        "`field` must be <allowed>, got <value>", or a missing field (``required``).
    """
    for field, rule in rules.items():
        v = _value(cfg, field)
        if v is _MISSING:
            if required:
                raise ConfigError(f"`{field}` is missing from the configuration")
            continue
        plain = OmegaConf.to_container(v, resolve=True) if isinstance(
            v, (DictConfig, ListConfig)) else v
        why = rule(plain)
        if why is not None:
            raise ConfigError(f"`{field}` must be {why}, got {plain!r}")


def _sweep(prefix: str) -> dict[str, Rule]:
    return {f"{prefix}.start_hz": positive(), f"{prefix}.stop_hz": positive(),
            f"{prefix}.rate_hz_per_s": optional(positive()),
            f"{prefix}.octaves_per_min": optional(positive())}


def _check_sweep_law(node, prefix: str) -> None:
    """Exactly one of the linear rate and the log rate (freeplayid.sweep.Sweep)."""
    given = [k for k in ("rate_hz_per_s", "octaves_per_min") if node[k] is not None]
    if len(given) != 1:
        raise ConfigError(f"`{prefix}` needs exactly one of `rate_hz_per_s` (linear sweep "
                          "[Hz/s]) and `octaves_per_min` (log sweep [octaves/min]), got "
                          f"{'both' if given else 'neither'}; set the other to null")


def _extraction_method() -> Rule:
    from ..signal.extract import EXTRACTION_METHODS

    return choice(*sorted(EXTRACTION_METHODS))


def _identify() -> dict[str, Rule]:
    # extraction, fit, replay, linear_model and records are the library's option records,
    # checked by them (freeplayid.tasks.options); these are the command's own keys
    return {"data": optional(text()), "inverse.checkpoint": optional(text()),
            "plot": boolean(), "allow_suspect": boolean()}


def _model() -> dict[str, Rule]:
    from .common import MODEL_KINDS

    return {"model.kind": choice(*MODEL_KINDS)}


def _check_model(cfg: DictConfig) -> None:
    """The model group first: its fields feed interpolations (``kn: ${model.hinge.kn}``)."""
    check_fields(cfg, _model())
    if cfg.model.kind == "npz":
        check_fields(cfg, {"model.path": text()})


def _simulate() -> dict[str, Rule]:
    from ..simulate.formulation import FRAMES, METHODS

    return {
        **_model(), "name": text(), "kn": positive(), "delta": number(0.0),
        "levels": numbers(positive()), **_sweep("sweep"), "noise_std_g": number(0.0),
        "seed": integer(0), "sample_rate": positive(), "quantity": choice(*QUANTITIES),
        "units": text(), "frame": choice(*FRAMES), "channels": channel_map(),
        "method": choice(*METHODS), "dtype": choice("float32", "float64"),
        "device": optional(text()), "cutoff_hz": optional(positive()),
        "quasi_static_hz": optional(positive()), "output_dir": relative_path(),
        "plot": boolean(), "max_steps": positive(), "force": boolean(),
        "gravity_g": number(-1.0, 1.0),
    }


def _train() -> dict[str, Rule]:
    return {
        **_model(), "seed": integer(0),
        "dataset.cache_dir": text(), "dataset.channels": channel_map(lists=True),
        **_sweep("dataset.bank.sweep"), "dataset.bank.sample_rate": positive(),
        "dataset.bank.kn_range": numbers(positive(), length=2, increasing=True),
        "dataset.bank.ratio_range": numbers(positive(), length=2, increasing=True),
        "dataset.bank.n_kn": integer(3), "dataset.bank.n_ratios": integer(1),
        "dataset.bank.seed": integer(0), "dataset.bank.dtype": choice("float32", "float64"),
        "dataset.bank.chunk_sweeps": integer(1),
        "dataset.bank.quasi_static_hz": optional(positive()),
        "dataset.bank.damping_range": optional(numbers(positive(), length=2, increasing=True)),
        "dataset.bank.rate_range": optional(numbers(positive(), length=2, increasing=True)),
        "dataset.bank.rayleigh_fraction": optional(number(0.0, 1.0)),
        "dataset.bank.ramp_range": optional(numbers(number(-0.99, 0.99), length=2,
                                                    increasing=True)),
        "dataset.cases.axis": choice("noise_g", "delta"),
        "dataset.cases.values": numbers(number(0.0)), "dataset.cases.noise_g": number(0.0),
        "dataset.cases.delta_range": numbers(positive(), length=2, increasing=True),
        "dataset.cases.cases_per_value": integer(1),
        "dataset.cases.runs": numbers(integer(1), length=2),
        "dataset.cases.extraction.method": _extraction_method(),
        "dataset.cases.seed": integer(0), "dataset.cases.n_jobs": integer(),
        "dataset.split": numbers(number(0.0, 1.0, open_lo=True), length=3),
        "network.hidden": integer(1), "network.depth": integer(1),
        "network.noise_input": optional(boolean()),
        "network.rate_input": boolean(),
        "trainer.max_epochs": integer(1), "trainer.accelerator": text(),
        "training.batch_size": integer(1),
        "training.lr": positive(), "training.weight_decay": number(0.0),
        "logger.kind": choice("csv", "tensorboard", "none"),
        "callbacks.early_stopping": optional(_mapping()),
        "success.delta": positive(), "success.kn": positive(),
        "network_bounds.delta": positive(), "network_bounds.kn": positive(), "plot": boolean(),
    }


def _compare() -> dict[str, Rule]:
    return {
        **_train(), "inverse.checkpoint": optional(text()),
        "compare.cases_per_value": integer(1),
        "compare.corrected_cases_per_value": integer(0),
        "compare.base_channel": boolean(),
        "compare.single_start": optional(numbers(positive(), length=2)),
        "compare.n_jobs": integer(),
    }


IDENTIFY, SIMULATE, TRAIN, COMPARE = "identify", "simulate", "train", "compare"
_TABLES = {IDENTIFY: _identify, SIMULATE: _simulate, TRAIN: _train, COMPARE: _compare}


def check_config(cfg: DictConfig, command: str) -> None:
    """Validate the whole configuration of ``command`` (one of identify, simulate, train,
    compare) before any work; cross-field rules follow the per-field table.

    Raises
    ------
    ConfigError
        The first field outside its allowed values, named, with what is allowed.
    """
    if command != IDENTIFY:
        _check_model(cfg)
    check_fields(cfg, _TABLES[command]())
    if command in (TRAIN, COMPARE):
        _check_cases(cfg)
        _check_training(cfg)
    if command == SIMULATE:
        _check_simulate(cfg)


def _mapping() -> Rule:
    return lambda v: None if isinstance(v, dict) else "a mapping (patience: N, min_delta: X)"


def _check_training(cfg: DictConfig) -> None:
    if cfg.callbacks.early_stopping is not None:
        check_fields(cfg, {"callbacks.early_stopping.patience": integer(1)})
        check_fields(cfg, {"callbacks.early_stopping.min_delta": number(0.0)}, required=False)
    if cfg.logger.kind == "tensorboard":
        try:
            import tensorboard  # noqa: F401
        except ImportError:
            raise ConfigError("`logger=tensorboard` needs the tensorboard package: pip install "
                              "tensorboard (or logger=csv)") from None


def _check_cases(cfg: DictConfig) -> None:
    lo, hi = cfg.dataset.cases.runs
    if lo > hi:
        raise ConfigError(f"`dataset.cases.runs` must be [min, max] with min <= max, "
                          f"got [{lo}, {hi}]")
    if lo > cfg.dataset.bank.n_ratios:
        raise ConfigError(f"`dataset.cases.runs` minimum must be <= `dataset.bank.n_ratios` "
                          f"({cfg.dataset.bank.n_ratios}), got {lo}")
    split = list(cfg.dataset.split)
    if abs(sum(split) - 1.0) > 1e-6:
        raise ConfigError(f"`dataset.split` must be three fractions summing to 1, got {split}")
    if cfg.dataset.bank.sweep.start_hz == cfg.dataset.bank.sweep.stop_hz:
        raise ConfigError("`dataset.bank.sweep.start_hz` and `stop_hz` must differ")
    _check_sweep_law(cfg.dataset.bank.sweep, "dataset.bank.sweep")
    values = list(cfg.dataset.cases["values"])  # `.values` is the mapping's method
    if cfg.dataset.cases.axis == "delta" and min(values) <= 0:
        raise ConfigError("`dataset.cases.values` must be clearances > 0 [rad] for axis delta, "
                          f"got {values}")


def _check_simulate(cfg: DictConfig) -> None:
    from ..quantity import QUANTITY

    if cfg.sweep.start_hz == cfg.sweep.stop_hz:
        raise ConfigError(f"`sweep.start_hz` and `sweep.stop_hz` must differ, both are "
                          f"{cfg.sweep.start_hz!r}")
    _check_sweep_law(cfg.sweep, "sweep")
    units = QUANTITY[cfg.quantity].units
    if cfg.units not in units:
        raise ConfigError(f"`units` for {cfg.quantity} must be one of {list(units)}, "
                          f"got {cfg.units!r}")
    if cfg.noise_std_g and cfg.quantity != "acceleration":
        raise ConfigError(f"`noise_std_g` applies to acceleration data only (quantity="
                          f"{cfg.quantity!r}); set noise_std_g=0")
    top = max(cfg.sweep.start_hz, cfg.sweep.stop_hz)
    if cfg.sample_rate < 2.5 * top:
        raise ConfigError(f"`sample_rate` must be >= 2.5 x the top sweep frequency "
                          f"({2.5 * top:g} Hz for {top:g} Hz), got {cfg.sample_rate!r}")
    if cfg.quasi_static_hz is not None and cfg.cutoff_hz is not None:
        raise ConfigError("`quasi_static_hz` and `cutoff_hz` cannot be combined; set one to null")
    if cfg.quasi_static_hz is not None and cfg.method != "relative":
        raise ConfigError(f"`quasi_static_hz` needs method=relative, got {cfg.method!r}")
    if cfg.gravity_g and (cfg.method != "relative" or cfg.quasi_static_hz is not None):
        raise ConfigError("`gravity_g` (a vertical shaker) needs method=relative and "
                          "quasi_static_hz=null (the exponential engine carries it); got "
                          f"method={cfg.method!r}, quasi_static_hz={cfg.quasi_static_hz!r}")

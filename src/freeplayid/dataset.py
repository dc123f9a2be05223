"""The in-memory data set every layer passes: :class:`Dataset` of :class:`Run` records, and the
rules every data set satisfies, wherever it comes from.

The file format (``manifest.yaml`` and one file per run) is :mod:`freeplayid.io`'s; a simulated
test (:func:`freeplayid.simulate.sweep_dataset`) and a replay build the same objects in memory,
and a notebook builds one from arrays with :meth:`Dataset.from_arrays`. The checks below are the
one copy of the data-set rules that the manifest reader (:mod:`freeplayid.io.manifest`,
:func:`freeplayid.io.read_dataset`) and :meth:`Dataset.from_arrays` share: quantity and units,
the channel map, the records' frame, numbers, sweep hints, the time axis, and why a run is
rejected. Each raises a
one-line :class:`~freeplayid.errors.DatasetError` prefixed with ``where`` (the manifest file, or
nothing for a function's arguments) and naming the field or argument.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .acquisition import check_antialias, check_base_delay
from .errors import DatasetError
from .quantity import UNIT_SCALE, check_units
from .sweep import Sweep

__all__ = ["Dataset", "FRAMES", "Run", "SWEEP_KEYS", "SWEEP_RATE_KEYS", "check_channel_dofs",
           "check_channels", "check_frame", "check_gravity", "check_keys", "check_number",
           "check_one_column_per_dof", "check_quantity_units", "check_sweep_hint", "check_time",
           "run_reason"]

SWEEP_RATE_KEYS = ("rate_hz_per_s", "octaves_per_min")  # linear, logarithmic: exactly one
SWEEP_KEYS = ("start_hz", "stop_hz", *SWEEP_RATE_KEYS)
MIN_SAMPLES = 16  # a sweep run needs many more; fewer is certainly not one
# what the channels record: the structure's absolute motion (accelerometers; the default) or its
# motion relative to the base (a simulation in the relative frame; relative displacement sensors)
FRAMES = ("absolute", "relative")


@dataclass(frozen=True)
class Run:
    """One sweep run.

    Attributes
    ----------
    file : str
        Run file name, relative to the manifest.
    time : ndarray, shape (T,) [s]
    data : ndarray, shape (channel, T) [units of the data set]
        Columns in the order of the data set's ``channels``.
    level_g : float or None [g]
        Informational base level.
    sweep : dict or None
        Optional hint ``{start_hz, stop_hz, rate_hz_per_s}`` (linear sweep) or
        ``{start_hz, stop_hz, octaves_per_min}`` (logarithmic), the keys of
        :class:`freeplayid.sweep.Sweep`.
    base : ndarray, shape (T,), or None
        The base (control) channel, if the data set has one.
    reason : str
        Empty for a usable run; else why it is rejected, set by :func:`read_dataset` (an
        unreadable or malformed file, NaN samples, a sweep hint that does not fit the record).
        A run rejected because its file could not be read has empty ``time`` and ``data``.
    """

    file: str
    time: np.ndarray
    data: np.ndarray
    level_g: float | None = None
    sweep: dict | None = None
    base: np.ndarray | None = None
    reason: str = ""


@dataclass(frozen=True)
class Dataset:
    """A data set read from (or to be written to) a folder.

    Attributes
    ----------
    name : str
    model : Path or None
        Absolute path of the linear model file.
    quantity : str
    units : str
    sample_rate : float [Hz]
    channels : dict of str -> str
        Run-file column -> model DOF name, in column order.
    runs : tuple of Run
    base_channel : str or None
    truth : dict or None
        ``{"kn": [N m/rad], "delta": [rad]}`` of a simulated data set (informational).
    path : Path or None
        Absolute path of the manifest read.
    reference_modes : dict or None
        Modes of the fin with its clearance sealed (the zero-clearance check, paper's Table 11):
        ``{"frequencies_hz": [m], "shapes": [[m] per DOF], "dofs": [DOF names]}``.
    frame : {"absolute", "relative"}
        What the channels record (:data:`FRAMES`): the absolute motion (accelerometers; the
        default), from which the extraction subtracts a base channel where there is one; or the
        motion relative to the base (no base channel then). The replays are simulated in it.
    antialias : {"unknown", "flat", "replay"} or FilterResponse
        The anti-alias filter the records went through (:mod:`freeplayid.acquisition`):
        not stated (default), flat to 0.45 of the sample rate, the simulator's own, or a stated
        response that ``identify`` divides out of the records before reading them.
    base_delay_s : float [s]
        How late the base channel was read against the responses (< 0: early; 0: in step, the
        default): ``identify`` advances the base records by it (:mod:`freeplayid.acquisition`).
    gravity_g : float [g], within +-1
        Gravity's component along the shaking axis during the test: 0 on a horizontal shaker
        (the default), +1 on a vertical one whose channels' + direction points up, -1 down. Its
        weight rests the fin's panel on a stop; the replays carry it (a constant load).
    """

    name: str
    model: Path | None
    quantity: str
    units: str
    sample_rate: float
    channels: dict
    runs: tuple
    base_channel: str | None = None
    truth: dict | None = None
    path: Path | None = None
    reference_modes: dict | None = None
    frame: str = "absolute"
    antialias: object = "unknown"
    base_delay_s: float = 0.0
    gravity_g: float = 0.0

    def __post_init__(self):
        check_frame(self.frame, self.base_channel, "")
        object.__setattr__(self, "antialias", check_antialias(self.antialias))
        object.__setattr__(self, "base_delay_s",
                           check_base_delay(self.base_delay_s, self.base_channel))
        object.__setattr__(self, "gravity_g", check_gravity(self.gravity_g))

    @property
    def si_scale(self) -> float:
        """Factor from the data set's units to SI (m, m/s or m/s^2); 9.80665 for g."""
        return UNIT_SCALE[self.units]

    def to_si(self, values) -> np.ndarray:
        """``values`` in the data set's units -> SI units of its quantity (m, m/s, m/s^2)."""
        return np.asarray(values, dtype=float) * self.si_scale

    @classmethod
    def from_arrays(cls, data, *, channels: Mapping[str, str], quantity: str, units: str,
                    sample_rate: float | None = None, time=None, base=None,
                    base_channel: str | None = None, levels_g=None, sweeps=None,
                    model: str | os.PathLike | None = None, name: str = "arrays",
                    run_names: Sequence[str] | None = None, frame: str = "absolute",
                    antialias="unknown", base_delay_s: float = 0.0,
                    gravity_g: float = 0.0) -> Dataset:
        """A validated data set from arrays (a notebook's), checked as a manifest is.

        Parameters
        ----------
        data : ndarray, shape (runs, channels, T), or sequence of ndarray, shape (channels, T_k)
            The response of each run [``units``]; rows in the order of ``channels``. Runs of
            different lengths go in a list.
        channels : mapping str -> str
            Channel name -> model DOF name, in row order.
        quantity : {"displacement", "velocity", "acceleration"}
        units : str
            "g" or "m/s^2" for acceleration, "m" / "m/s" otherwise.
        sample_rate : float [Hz], optional
            Give this or ``time``: sample k of every run is at k / sample_rate.
        time : ndarray, shape (T,), or sequence of ndarray, shape (T_k,) [s], optional
            One time axis for every run (all of length T), or one per run.
        base : ndarray, shape (runs, T), or sequence of ndarray, shape (T_k,), optional
            The base (control) channel of each run [``units``], subtracted by the extraction.
        base_channel : str, optional
            Its name (default "base" when ``base`` is given).
        levels_g : sequence of (float or None), optional [g]
            Each run's informational base level.
        sweeps : Sweep, mapping, or sequence of them (or None), optional
            Sweep hints (:class:`freeplayid.sweep.Sweep` or its keys): one for every run, or one
            per run.
        model : path, optional
            The linear model file (``.npz``); every channel's DOF must be among its
            ``dof_names``. None: pass ``system=`` to :func:`freeplayid.identify`.
        name : str
        run_names : sequence of str, optional
            Default ``run_0``, ``run_1``, ...
        frame : {"absolute", "relative"}
            What ``data`` record (:attr:`Dataset.frame`): absolute motion (accelerometers), or
            motion relative to the base (then without ``base``).
        antialias : {"unknown", "flat", "replay"}, FilterResponse or mapping
            The records' anti-alias filter (:attr:`Dataset.antialias`; a mapping
            ``{frequency_hz, gain, phase_deg}`` states a response).
        base_delay_s : float [s]
            How late ``base`` was read against ``data`` (:attr:`Dataset.base_delay_s`; within
            +-0.05 s, and only with ``base``).
        gravity_g : float [g]
            Gravity's component along the shaking axis (:attr:`Dataset.gravity_g`; within +-1,
            +1: a vertical shaker, the channels' + direction up; default 0: horizontal).

        Returns
        -------
        Dataset
            As :func:`freeplayid.io.read_dataset` returns one: a run with NaN/inf samples or a
            sweep hint that does not fit its record is kept with its ``reason`` (rejected).

        Raises
        ------
        DatasetError
            One line naming the argument, what was expected and what came: bad quantity or
            units, a channel map that breaks the manifest's rules, an array of the wrong shape
            (a transposed one says so), counts of ``time``, ``base``, ``levels_g``, ``sweeps``
            or ``run_names`` that differ from the runs, a bad time axis or sample rate, a
            model file that is missing or lacks a channel's DOF, a ``frame`` not in
            :data:`FRAMES` or relative with a base, an ``antialias`` that is none of its forms, a
            ``base_delay_s`` that is not a number within +-0.05 s or is given without ``base``,
            a ``gravity_g`` that is not a number within +-1.
        """
        check_quantity_units(quantity, units, "")
        channels, base_channel = check_channels(channels, base_channel, "",
                                                default_base="base" if base is not None else None)
        check_frame(frame, base_channel, "")
        runs = _runs_of(data, list(channels))
        n = len(runs)
        if (base is None) != (base_channel is None):
            raise DatasetError(f"`base_channel` {base_channel!r} needs `base` arrays (and `base` "
                               "a `base_channel` name)")
        times, fs = _times_of(time, sample_rate, runs)
        bases = [None] * n if base is None else _per_run(base, "base", runs, ndim=1)
        levels = [None if v is None else check_number(v, f"`levels_g[{k}]` [g]")
                  for k, v in enumerate(_listed(levels_g, "levels_g", n))]
        hints = [_hint(h, f"`sweeps[{k}]`") for k, h in enumerate(_listed(sweeps, "sweeps", n,
                                                                           one=(Sweep, Mapping)))]
        names = [f"run_{k}" for k in range(n)] if run_names is None else [
            str(r) for r in _listed(run_names, "run_names", n)]
        model_path = _model_path(model, channels)
        out = []
        for k in range(n):
            cols = dict(zip(channels, runs[k]))
            if bases[k] is not None:
                cols[base_channel] = bases[k]
            out.append(Run(file=names[k], time=times[k], data=runs[k], level_g=levels[k],
                           sweep=hints[k], base=bases[k],
                           reason=run_reason(cols, times[k], hints[k], fs)))
        return cls(name=str(name), model=model_path, quantity=quantity, units=units,
                   sample_rate=float(fs), channels=dict(channels), runs=tuple(out),
                   base_channel=base_channel, frame=frame, antialias=antialias,
                   base_delay_s=base_delay_s, gravity_g=gravity_g)


# --------------------------------------------------------------------------- the shared rules
def check_keys(entry: Mapping, allowed: Sequence[str], where: str) -> None:
    """Unknown fields of a mapping are an error listing the allowed ones."""
    unknown = sorted(set(entry) - set(allowed))
    if unknown:
        raise DatasetError(f"{where}unknown field(s) {unknown}; allowed: {list(allowed)}")


def check_gravity(value, where: str = "") -> float:
    """A data set's ``gravity_g`` [g] (None: 0) as a float; a one-line :class:`DatasetError`
    naming the field for anything but a finite number within +-1."""
    if value is None:
        return 0.0
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_))
    if not ok or not math.isfinite(value) or abs(value) > 1:
        raise DatasetError(f"{where}`gravity_g` must be gravity's component along the shaking "
                           "axis in g, a number within +-1 (+1: vertical, the channels' + "
                           f"direction up; -1: down; 0: horizontal, the default), got {value!r}")
    return float(value)


def check_frame(frame, base_channel, where: str) -> str:
    """``frame`` one of :data:`FRAMES`; relative only without a base channel (records relative
    to the base have nothing of it left to subtract, and the replays of such a test are driven
    by the law and the level, not by a measured base)."""
    if frame not in FRAMES:
        raise DatasetError(f"{where}`frame` must be one of {list(FRAMES)} (what the channels "
                           f"record: absolute motion, or motion relative to the base), got "
                           f"{frame!r}")
    if frame == "relative" and base_channel is not None:
        raise DatasetError(f"{where}`frame: relative` takes no `base_channel` (got "
                           f"{base_channel!r}): records relative to the base have no base "
                           "motion to subtract; drop one of the two")
    return frame


def check_number(value, where: str, *, positive: bool = True) -> float:
    """A finite real number (> 0 when ``positive``) as a float."""
    ok = isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))
    if not ok or not np.isfinite(value) or (positive and value <= 0):
        need = "a finite number > 0" if positive else "a finite number"
        raise DatasetError(f"{where} must be {need}, got {value!r}")
    return float(value)


def check_quantity_units(quantity: str, units: str, where: str) -> None:
    """:func:`freeplayid.quantity.check_units` as a DatasetError prefixed with ``where``."""
    try:
        check_units(quantity, units)
    except ValueError as exc:
        raise DatasetError(f"{where}{exc}") from None


def check_one_column_per_dof(channels: Mapping[str, str], where: str) -> None:
    """Two columns on one DOF would give two points of one curve, weighted twice in the fit
    (or a mapping typo that silently drops a DOF): an error naming both columns and the DOF."""
    by_dof = {}
    for col, dof in channels.items():
        by_dof.setdefault(dof, []).append(col)
    for dof, cols in by_dof.items():
        if len(cols) > 1:
            raise DatasetError(
                f"{where}`channels` map the columns {cols} to the same model DOF {dof!r}; each "
                "DOF takes one column (drop one, or map it to its own DOF)"
            )


def check_channels(channels, base_channel, where: str, *,
                   default_base: str | None = None) -> tuple[dict, str | None]:
    """``channels`` (column -> DOF, one column per DOF, no 'time') and ``base_channel`` (a
    column other than 'time' and the channels), checked; ``default_base`` when it is None."""
    if not isinstance(channels, Mapping) or not channels or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in channels.items()
    ):
        raise DatasetError(
            f"{where}`channels` must map run-file column names to model DOF names, got "
            f"{channels!r}"
        )
    check_one_column_per_dof(channels, where)
    base_channel = default_base if base_channel is None else base_channel
    if base_channel is not None and (not isinstance(base_channel, str) or base_channel in
                                     channels or base_channel == "time"):
        raise DatasetError(
            f"{where}`base_channel` must be a column name other than 'time' and the channels "
            f"{list(channels)}, got {base_channel!r}"
        )
    if "time" in channels:
        raise DatasetError(f"{where}`channels` must not use the column name 'time'")
    return dict(channels), base_channel


def check_channel_dofs(channels: Mapping[str, str], dofs: Sequence[str], model: str,
                       where: str) -> None:
    """Every channel's DOF must be one of the model's (``model``: its name in the message)."""
    unknown = {c: d for c, d in channels.items() if d not in dofs}
    if unknown:
        raise DatasetError(
            f"{where}`channels` map to DOF(s) the model {model!r} does not have: "
            f"{unknown}; its DOFs are {list(dofs)}"
        )


def check_sweep_hint(sweep, where: str) -> dict:
    """A sweep hint: start, stop and one rate law, as floats (``where``: its field, e.g.
    ``manifest.yaml: `runs[0]`.sweep``)."""
    if not isinstance(sweep, Mapping):
        raise DatasetError(f"{where} must be a mapping of {list(SWEEP_KEYS)}")
    check_keys(sweep, SWEEP_KEYS, f"{where}: ")
    miss = [s_ for s_ in ("start_hz", "stop_hz") if s_ not in sweep]
    rates = [s_ for s_ in SWEEP_RATE_KEYS if s_ in sweep]
    if miss or not rates:
        raise DatasetError(
            f"{where} misses {miss + ([] if rates else [' or '.join(SWEEP_RATE_KEYS)])}"
            "; it needs `start_hz`, `stop_hz` and `rate_hz_per_s` (linear) or "
            "`octaves_per_min` (logarithmic)")
    if len(rates) > 1:
        raise DatasetError(f"{where} gives both `rate_hz_per_s` and "
                           "`octaves_per_min`; give one (linear or logarithmic sweep)")
    sweep = {s_: check_number(sweep[s_], f"{where}.{s_}") for s_ in ("start_hz", "stop_hz",
                                                                      *rates)}
    if sweep["start_hz"] == sweep["stop_hz"]:
        raise DatasetError(f"{where}: `start_hz` and `stop_hz` must differ")
    return sweep


def check_time(t: np.ndarray, fs: float | None, where: str, label: str = "column 'time'") -> float:
    """Validate a time axis [s] (``label``: how the message names it); return the sample rate
    [Hz] it implies (or ``fs``, which it must agree with within 0.1 %)."""
    if t.size < MIN_SAMPLES:
        raise DatasetError(f"{where}: {t.size} samples; a sweep run needs many more")
    if not np.all(np.isfinite(t)):
        k = int(np.flatnonzero(~np.isfinite(t))[0])
        raise DatasetError(f"{where}: {label} has a non-finite value at data row {k + 1}")
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0])
        raise DatasetError(
            f"{where}: {label} must increase strictly; data rows {k + 1}-{k + 2} go "
            f"{t[k]:.9g} -> {t[k + 1]:.9g} s"
        )
    # rate from a straight-line fit, robust to rounding of the printed times
    k = np.arange(t.size)
    step = float(np.polyfit(k, t, 1)[0])
    dev = np.abs(t - (t[0] + k * step))
    if dev.max() > 0.25 * step:
        j = int(np.argmax(dev))
        raise DatasetError(
            f"{where}: {label} is not uniformly sampled (data row {j + 1} is off the "
            f"{1 / step:.6g} Hz grid by {dev[j] / step:.2f} samples); resample the record"
        )
    if fs is not None and abs(1.0 / step - fs) > 1e-3 * fs:
        raise DatasetError(
            f"{where}: {label} implies {1 / step:.6g} Hz but the data set's sample rate "
            f"is {fs:g} Hz (the manifest's `sample_rate`, else the first run's time column)"
        )
    return fs if fs is not None else 1.0 / step


def run_reason(columns: Mapping[str, np.ndarray], t: np.ndarray, sweep: Mapping | None,
               fs: float) -> str:
    """Why a run with a valid time axis is rejected, or "": NaN/inf samples in a column, or a
    sweep hint that does not fit the record (:meth:`freeplayid.sweep.Sweep.record_mismatch`)."""
    for name, x in columns.items():
        bad = ~np.isfinite(x)
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            return (
                f"non-finite values (NaN/inf) in column {name!r}: {int(bad.sum())} samples, "
                f"first at t = {t[k]:.6g} s"
            )
    if sweep is not None:
        return Sweep(**sweep).record_mismatch(t.size, fs)
    return ""


# --------------------------------------------------------------------------- from_arrays' parts
def _runs_of(data, channels: list[str]) -> list[np.ndarray]:
    """``data`` as one (channels, T_k) float array per run; a shape error says which axis."""
    n_ch = len(channels)
    if isinstance(data, np.ndarray) and data.ndim != 3:
        one = " (one run: pass data[None] or [data])" if data.ndim == 2 else ""
        raise DatasetError(f"`data` must have shape (runs, channels, T) = (runs, {n_ch}, T) "
                           f"or be a list of (channels, T) arrays, got shape {data.shape}{one}")
    if isinstance(data, np.ndarray) and data.shape[1] != n_ch:
        flip = ("; it looks transposed: pass data.swapaxes(1, 2)" if data.shape[2] == n_ch
                else "")
        raise DatasetError(f"`data` has shape {data.shape}: axis 1 must hold the {n_ch} "
                           f"`channels` {channels}, expected (runs, {n_ch}, T){flip}")
    if not isinstance(data, (np.ndarray, Sequence)) or isinstance(data, str) or len(data) == 0:
        raise DatasetError("`data` must be a (runs, channels, T) array or a non-empty list of "
                           f"(channels, T) arrays, got {type(data).__name__}")
    runs = []
    for k, x in enumerate(data):
        x = np.asarray(x)
        if x.dtype.kind not in "iuf":
            raise DatasetError(f"`data[{k}]` must be real numbers, got dtype {x.dtype}")
        if x.ndim != 2 or x.shape[0] != n_ch:
            flip = (f"; it looks transposed: pass data[{k}].T" if x.ndim == 2 and
                    x.shape[1] == n_ch else "")
            raise DatasetError(f"`data[{k}]` has shape {x.shape} but `channels` names {n_ch} "
                               f"channels {channels}: expected ({n_ch}, T){flip}")
        runs.append(x.astype(float))
    return runs


def _times_of(time, sample_rate, runs: list[np.ndarray]) -> tuple[list[np.ndarray], float]:
    """Each run's time axis [s] and the data set's sample rate [Hz]."""
    if (time is None) == (sample_rate is None):
        raise DatasetError("give one of `sample_rate` [Hz] and `time` [s], got "
                           f"{'neither' if time is None else 'both'}")
    if sample_rate is not None:
        fs = check_number(sample_rate, "`sample_rate` [Hz]")
        times = [np.arange(x.shape[1]) / fs for x in runs]
        for k, t in enumerate(times):
            check_time(t, fs, f"`data[{k}]`")  # the sample count
        return times, fs
    one = isinstance(time, np.ndarray) and time.ndim == 1
    times = [np.asarray(time, dtype=float)] * len(runs) if one else [
        np.asarray(t, dtype=float) for t in _per_run(time, "time", runs, ndim=1)]
    fs = None
    for k, (t, x) in enumerate(zip(times, runs)):
        what = "`time`" if one else f"`time[{k}]`"
        if t.ndim != 1 or t.size != x.shape[1]:
            raise DatasetError(f"{what} has shape {t.shape} but `data[{k}]` has {x.shape[1]} "
                               "samples (its last axis)")
        fs = check_time(t, fs, what, label="the time")
    return times, fs


def _per_run(values, name: str, runs: list[np.ndarray], *, ndim: int) -> list[np.ndarray]:
    """One array per run (from an array with a leading run axis, or a list), each of ``ndim``
    dimensions with the run's sample count."""
    if isinstance(values, np.ndarray) and values.ndim != ndim + 1:
        raise DatasetError(f"`{name}` must have shape (runs, T) or be a list of (T,) arrays, "
                           f"got shape {values.shape}")
    values = list(_listed(values, name, len(runs)))
    out = []
    for k, (v, x) in enumerate(zip(values, runs)):
        v = np.asarray(v, dtype=float)
        if v.shape != (x.shape[1],):
            raise DatasetError(f"`{name}[{k}]` has shape {v.shape} but `data[{k}]` has "
                               f"{x.shape[1]} samples: expected ({x.shape[1]},)")
        out.append(v)
    return out


def _listed(values, name: str, n: int, *, one=()) -> list:
    """``values`` as a list of ``n`` (None: n Nones; one item of a type in ``one``: n copies)."""
    if values is None:
        return [None] * n
    if one and isinstance(values, one):
        return [values] * n
    if isinstance(values, str) or not isinstance(values, (Sequence, np.ndarray)):
        raise DatasetError(f"`{name}` must be a sequence of one value per run, got "
                           f"{type(values).__name__}")
    if len(values) != n:
        raise DatasetError(f"`{name}` has {len(values)} values but `data` has {n} runs")
    return list(values)


def _hint(sweep, where: str) -> dict | None:
    if sweep is None:
        return None
    return check_sweep_hint(sweep.to_dict() if isinstance(sweep, Sweep) else sweep, where)


def _model_path(model, channels: Mapping[str, str]) -> Path | None:
    """The model file, resolved; its ``dof_names`` must hold every channel's DOF (the rest of
    the file is checked when it is loaded, by :func:`freeplayid.model.load_system`)."""
    if model is None:
        return None
    path = Path(model).resolve()
    if not path.is_file():
        raise DatasetError(f"`model` file {str(model)!r} not found (looked at {path})")
    try:
        with np.load(path, allow_pickle=False) as z:
            dofs = [str(d) for d in z["dof_names"]]
    except Exception as exc:  # noqa: BLE001 - zip, format, key errors: not a model file
        raise DatasetError(f"`model` {str(model)!r} is not a readable model file (.npz with "
                           f"`dof_names`): {exc}") from None
    check_channel_dofs(channels, dofs, str(model), "")
    return path

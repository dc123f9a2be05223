"""Simulated sweeps as a data set: what a test engineer's recorder would have written.

:func:`sweep_dataset` turns a :class:`SweepResult` into an in-memory
:class:`freeplayid.dataset.Dataset` (one run per member, the sweep hint and level in each run,
the base channel with absolute accelerations), so simulated data go through the same
:func:`freeplayid.identify` as measured data; :func:`freeplayid.io.write_dataset` writes it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..dataset import Dataset, Run
from ..quantity import check_quantity, check_units
from ..sweep import Sweep

__all__ = ["sweep_dataset", "default_columns", "BASE_COLUMN"]

BASE_COLUMN = "acc_base"  # column of the base (control) accelerometer


def default_columns(quantity: str, dofs: Sequence[str]) -> dict:
    """Column name -> DOF name, ``<prefix>_<dof>`` (e.g. ``acc_uz_top_left``)."""
    prefix = check_quantity(quantity).prefix
    return {f"{prefix}_{d}": d for d in dofs}


def sweep_dataset(
    result,
    *,
    columns: Mapping[str, str] | None = None,
    units: str | None = None,
    members: Sequence[int] | None = None,
    run_names: Sequence[str] | None = None,
    noise: np.ndarray | None = None,
    name: str = "simulated sweeps",
) -> Dataset:
    """The members of a simulation as a data set, one run per member.

    Parameters
    ----------
    result : SweepResult
    columns : mapping column -> DOF name, optional
        Channels of the data set; every DOF must be one of ``result.channels``. Default
        :func:`default_columns` of every simulated channel.
    units : str, optional
        Units of the data (default the SI unit; "g" for accelerations in g).
    members : sequence of int, optional
        Members to keep (default all), in the order given.
    run_names : sequence of str, optional
        One file name per kept member (default ``sweep_<level>g.csv``).
    noise : ndarray, shape (batch, channel, T) [SI units of the quantity], optional
        Added to the signals of every member (measurement noise); not to the base channel.
    name : str

    Returns
    -------
    Dataset
        No model file (pass the system to :func:`freeplayid.identify`); the sweep hint, the level
        and, for absolute accelerations, the base channel ``acc_base`` (the sweep's
        ``A_g sin phase``) in every run; ``truth`` when all kept members share kn and delta;
        the simulation's ``static_g`` as its ``gravity_g``.
    """
    q = result.quantity
    units = check_quantity(q).si_unit if units is None else units
    scale = check_units(q, units)
    columns = dict(default_columns(q, result.channels) if columns is None else columns)
    unknown = sorted(set(columns.values()) - set(result.channels))
    if unknown:
        raise ValueError(f"`columns` map to DOF(s) {unknown} that were not simulated; "
                         f"simulated: {list(result.channels)}")
    rows = [result.channels.index(d) for d in columns.values()]
    batch = result.signals.shape[0]
    members = list(range(batch)) if members is None else [int(i) for i in members]
    if any(not 0 <= i < batch for i in members):
        raise ValueError(f"`members` must lie in [0, {batch}), got {members}")
    levels = result.level_g[members]
    if run_names is None:
        run_names = [f"sweep_{lv:.2f}g.csv" for lv in levels]
    if len(run_names) != len(members):
        raise ValueError(f"`run_names` must have {len(members)} names, got {len(run_names)}")
    if noise is not None and np.shape(noise) != result.signals.shape:
        raise ValueError(f"`noise` must have shape {result.signals.shape}, "
                         f"got {np.shape(noise)}")
    sw = result.sweep
    hint = sw.to_dict() if isinstance(sw, Sweep) else None  # a measured excitation has no law
    with_base = q == "acceleration" and result.frame == "absolute"
    runs = []
    for k, i in enumerate(members):
        data = result.signals[i][rows].astype(float)
        if noise is not None:
            data = data + noise[i][rows]
        base = sw.acceleration(result.time, float(result.level_g[i])) / scale if with_base \
            else None
        runs.append(Run(file=str(run_names[k]), time=result.time, data=data / scale,
                        level_g=float(result.level_g[i]), base=base,
                        sweep=None if hint is None else dict(hint)))
    kn, delta = result.kn[members], result.delta[members]
    truth = None
    if np.all(kn == kn[0]) and np.all(delta == delta[0]):
        truth = {"kn": float(kn[0]), "delta": float(delta[0])}
    return Dataset(name=name, model=None, quantity=q, units=units,
                   sample_rate=float(result.sample_rate), channels=columns, runs=tuple(runs),
                   base_channel=BASE_COLUMN if with_base else None, truth=truth,
                   frame=result.frame, gravity_g=result.static_g)

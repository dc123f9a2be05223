"""The test replayed: each run's sweep law and level, and the runs simulated at (kn, delta)."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from ..dataset import Dataset
from ..estimate import run_sweep_law
from ..quantity import G, check_quantity
from ..signal import window_amplitudes
from ..threads import cores, each
from .excitation import measured_sweep

__all__ = ["replay_sweeps", "replay_levels", "replay_excitations", "replay_dataset",
           "with_sweep_hints"]


def replay_sweeps(dataset) -> dict:
    """Each usable run's sweep law (:func:`run_sweep_law`).

    Returns
    -------
    dict of run file -> (Sweep, source, residual [Hz] or None)

    Raises
    ------
    ValueError
        No sweep law can be found in a run without a hint.
    """
    return {run.file: run_sweep_law(dataset, run) for run in dataset.runs if not run.reason}


def replay_levels(dataset, sweeps: dict | None = None) -> dict:
    """Each usable run's base level [g]: from the base channel's first harmonic when the data set
    has one (least squares at the sweep's phase), else the manifest's ``level_g``.

    ``sweeps`` is :func:`replay_sweeps` of the data set (computed when not given).

    Returns
    -------
    dict of run file -> (level [g], source)
    """
    sweeps = replay_sweeps(dataset) if sweeps is None else sweeps
    order = check_quantity(dataset.quantity).order
    out = {}
    for run in dataset.runs:
        if run.reason or run.file not in sweeps:
            continue
        sweep = sweeps[run.file][0]
        if run.base is not None:
            f, a = window_amplitudes(dataset.to_si(run.base), dataset.sample_rate, sweep)
            # the base moves as A sin(phase): its amplitude in the data's quantity is A / w^(2-k)
            level = float(np.median(a * (2 * np.pi * f) ** (2 - order))) / G
            out[run.file] = (level, "base channel")
        elif run.level_g:
            out[run.file] = (float(run.level_g), "level_g")
        else:
            raise ValueError(f"run {run.file}: no base channel and no `level_g`: the replay "
                             "cannot know the run's level")
    return out


def replay_excitations(dataset, sweeps: dict, wide=()) -> tuple[dict, dict]:
    """Each usable run's excitation as its base channel measured it
    (:func:`.excitation.measured_sweep`), and its level [g] from the same first harmonic. The
    runs named in ``wide`` take the wide band's reading where their base was read narrowed
    (``MeasuredSweep.wide``: the same level, the envelope and noise of the wide band).

    Returns
    -------
    excitations : dict of run file -> MeasuredSweep
    levels : dict of run file -> (level [g], "base channel, as measured")

    Raises
    ------
    ValueError
        A run without a base channel or without a usable first harmonic in it.
    """
    excitations, levels = {}, {}
    for run in dataset.runs:
        if run.reason or run.file not in sweeps:
            continue
        m, level = measured_sweep(dataset, run, sweeps[run.file][0])
        excitations[run.file] = m.wide if run.file in wide and m.wide is not None else m
        levels[run.file] = (level, "base channel, as measured")
    return excitations, levels


def replay_dataset(dataset, system, kn: float, delta: float, *, levels: dict | None = None,
                   sweeps: dict | None = None, excitations: dict | None = None, dtype=None,
                   engine: str | None = None, gap_shares=None, passband: float | None = None,
                   contact_damping=None):
    """The data set's usable runs simulated at (kn, delta): a data set of the same layout.

    Runs sharing a sweep law are simulated in one batch; a run with a measured excitation
    (``excitations``: :func:`replay_excitations`) alone, driven by it; in the data set's frame
    (:attr:`freeplayid.dataset.Dataset.frame`), with its base channel when it has one (absolute
    accelerations without one are replayed as absolute motion, and the replay keeps no base
    either: the extraction reads both alike). ``sweeps`` and ``levels`` are
    :func:`replay_sweeps` and :func:`replay_levels` (computed when not given). A replayed run
    carries the measured run's sweep hint (or none), so both go through the same extraction.
    ``engine``: a simulator engine name (:data:`freeplayid.simulate.engines.ENGINES` or
    "auto"); None: the exponential engine when available, else "auto". ``gap_shares``: hinge
    j's half-gap is ``delta * gap_shares[j]`` (None: one common gap). ``passband``: the
    decimating filter's flat band over the sample rate (``simulate_sweeps``'s
    ``antialias_passband``; None: the simulator's default, 0.3). The data set's ``gravity_g``
    (a vertical shaker) is replayed as the constant load it is (``simulate_sweeps``'s
    ``static_g``). ``contact_damping``: each hinge's damper acting only in contact [N m s/rad]
    (``simulate_sweeps``'s; None: none).
    """
    # the simulator (torch) only when a replay runs: `import freeplayid.identification` stays
    # light for a notebook that reads results
    import torch

    from ..simulate import simulate_sweeps, sweep_dataset
    from ..simulate.engines import ENGINES

    # the exponential engine (docs/simulate.md): exact between hinge switches, a step set by
    # accuracy, one member per core; as accurate as RK4 at its default step and about 6x faster
    # for one replay's few members. RK4 where numba is missing.
    if engine is None:
        engine = "expo" if ENGINES["expo"].available() else "auto"
    sweeps = replay_sweeps(dataset) if sweeps is None else sweeps
    levels = replay_levels(dataset, sweeps) if levels is None else levels
    frame, gravity = dataset.frame, dataset.gravity_g
    hints = {run.file: run.sweep for run in dataset.runs}
    excitations = excitations or {}
    groups: dict = {}
    for run in dataset.runs:
        if run.file in levels:
            key = excitations.get(run.file) or sweeps[run.file][0]
            groups.setdefault(key, []).append(run.file)
    def simulate(group):
        sweep, files = group
        res = simulate_sweeps(system, kn=kn, delta=delta, level_g=[levels[f][0] for f in files],
                              sweep=sweep, channels=list(dataset.channels.values()),
                              quantity=dataset.quantity, frame=frame,
                              sample_rate=dataset.sample_rate,
                              dtype=torch.float64 if dtype is None else dtype, progress=False,
                              engine=engine, gap_shares=gap_shares,
                              static_g=gravity, contact_damping=contact_damping,
                              **({} if passband is None else {"antialias_passband": passband}))
        ds = sweep_dataset(res, columns=dataset.channels, units=dataset.units, run_names=files)
        return [dataclasses.replace(r, sweep=hints[r.file],
                                    base=r.base if dataset.base_channel else None)
                for r in ds.runs]

    runs = [r for out in _each_group(simulate, list(groups.items()), engine) for r in out]
    order = {r.file: i for i, r in enumerate(dataset.runs)}
    runs.sort(key=lambda r: order[r.file])
    return Dataset(name=f"replay of {dataset.name}", model=None, quantity=dataset.quantity,
                   units=dataset.units, sample_rate=dataset.sample_rate,
                   channels=dict(dataset.channels), runs=tuple(runs),
                   base_channel=dataset.base_channel, frame=frame, gravity_g=gravity)


def _each_group(simulate, groups: list, engine: str) -> list:
    """``simulate`` of each group, in order; the groups at once on threads
    (:func:`freeplayid.threads.each`) where that is safe and helps: the exponential engine
    (its kernels release the GIL; a measured excitation makes each run a group of one member,
    which one core integrates) under a thread-safe numba threading layer (omp, tbb; not
    workqueue). The members and their arithmetic are the same either way: the replays are bit
    for bit those of one thread."""
    safe = engine == "expo" and len(groups) > 1 and _threadsafe_numba()
    if not safe:
        return each(simulate, groups, name="replay", workers=1)
    import numba

    share = max(1, cores() // min(len(groups), cores()))

    def alone(group):
        # this worker's parallel kernels on its share of the cores (numba's count is per
        # thread): a batch of one member on a team of several leaves the others spinning
        numba.set_num_threads(share)
        return simulate(group)

    return each(alone, groups, name="replay")


@functools.cache
def _threadsafe_numba() -> bool:
    """Whether numba's threading layer lets parallel kernels start from several threads at once
    (omp and tbb do; workqueue aborts the process). The layer is chosen at the first parallel
    launch: a trivial kernel launches it if nothing has yet."""
    import numba

    try:
        layer = numba.threading_layer()
    except ValueError:  # no parallel kernel has run yet
        prange = numba.prange

        def touch(n):
            out = np.zeros(n)
            for i in prange(n):
                out[i] = i
            return out

        numba.njit(parallel=True)(touch)(2)
        layer = numba.threading_layer()
    return layer in ("omp", "tbb")


def with_sweep_hints(dataset, sweeps: dict):
    """``dataset`` with each run of ``sweeps`` that has no hint given its replayed law as one."""
    runs = tuple(dataclasses.replace(r, sweep=sweeps[r.file][0].to_dict())
                 if r.sweep is None and r.file in sweeps else r for r in dataset.runs)
    return dataclasses.replace(dataset, runs=runs)

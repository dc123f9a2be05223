"""The excitation as it was measured: a run's base channel as a :class:`MeasuredSweep`."""

from __future__ import annotations

import numpy as np

from ..quantity import G, check_quantity
from ..signal import acmp
from ..sweep import MeasuredSweep

__all__ = ["measured_sweep", "envelope_noise", "NARROW_BASE", "ENVELOPE_NOISE"]

# The base level is what the controller holds. A replay driven by the measured envelope feels
# its noise as a level error: at the response extraction's bandwidth the envelope of a base
# record with 0.05 g of noise at 256 Hz scatters by 0.4-1.2 % (0.4-1.2 g; measured against the
# known profile of benchmarks/realtests data), and replays driven by it put delta 1-1.4 % off
# on a level ramp and a level dip (0.4-0.5 % over a quarter of the bandwidth). Over a quarter of
# the bandwidth a notch whose flanks last under a second (0.5 Hz of sweep at 0.5 Hz/s) is
# filled in, so the narrow band is taken only where the wide one is noisy.
NARROW_BASE = 0.25  # [-] the narrow band, a fraction of the response extraction's bandwidth
ENVELOPE_NOISE = 2e-3  # [-] relative scatter of the wide band's envelope that takes the narrow


def measured_sweep(dataset, run, law) -> tuple[MeasuredSweep, float]:
    """The base excitation of ``run`` as recorded by the data set's base channel.

    The base record's first harmonic (:func:`freeplayid.signal.acmp`, started on ``law``, the
    run's sweep law, with the extraction's default bandwidth ``max(1 Hz, 2 s x rate)``, or over
    :data:`NARROW_BASE` of it when the envelope is noisier than :data:`ENVELOPE_NOISE` there:
    :func:`envelope_noise`) gives its amplitude and phase at every sample; amplitudes in the
    data's quantity become accelerations (``A w^(2 - order)``). The level is their median [g];
    the envelope the amplitude over it.
    So a replay driven by it has the test's level profile (a force-limited dip, a ramp, a
    controller's notch), its sweep law and its direction, as they happened.

    Returns
    -------
    (MeasuredSweep, level [g])

    Raises
    ------
    ValueError
        The run has no base channel, or its base record has no usable first harmonic.
    """
    if run.base is None:
        raise ValueError(f"run {run.file}: no base channel to take the excitation from")
    fs = float(dataset.sample_rate)
    order = check_quantity(dataset.quantity).order
    x = dataset.to_si(run.base)
    t = np.arange(x.shape[0]) / fs
    bw = max(1.0, 2.0 * float(np.median(np.abs(law.rate(t)))))
    mode = acmp(x, fs, sweep=law, bandwidth_hz=bw)
    narrow = acmp(x, fs, sweep=law, bandwidth_hz=NARROW_BASE * bw)
    if envelope_noise(mode.amplitude, narrow.amplitude) > ENVELOPE_NOISE:
        mode = narrow
    w = 2 * np.pi * np.clip(mode.frequency, 1e-6, None)
    amp = mode.amplitude * w ** (2 - order)  # [m/s^2]
    if not np.all(np.isfinite(amp)) or np.median(amp) <= 0:
        raise ValueError(f"run {run.file}: the base channel has no usable first harmonic")
    level = float(np.median(amp))
    env = np.maximum(amp / level, 1e-6)
    # x = A cos(psi): the simulator's excitation is A sin(phase), phase = psi + pi / 2
    return MeasuredSweep(fs, mode.phase + np.pi / 2, env), level / G


def envelope_noise(wide, narrow) -> float:
    """The relative noise of the envelope ``wide`` (one extraction of a record) against
    ``narrow`` (the same over a narrower band): the robust scatter (1.4826 x the median absolute
    deviation) of their difference over the median level. A level profile both bands follow
    cancels, a notch narrower than the narrow band touches few samples and barely moves the
    median, white noise does not cancel."""
    d = np.asarray(wide, float) - np.asarray(narrow, float)
    d = d[np.isfinite(d)]
    level = float(np.median(np.abs(narrow)))
    if d.size == 0 or level <= 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / level)

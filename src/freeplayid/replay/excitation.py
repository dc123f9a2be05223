"""The excitation as it was measured: a run's base channel as a :class:`MeasuredSweep`."""

from __future__ import annotations

import numpy as np

from ..quantity import G, check_quantity
from ..signal import acmp
from ..signal.level import ENVELOPE_NOISE, NARROW_BASE, envelope_noise, quiet_base
from ..sweep import MeasuredSweep

# the band the base is read over is chosen in freeplayid.signal.level (the quadrature point's
# phase reference is read the same way); its names are kept here for the callers of this module
__all__ = ["measured_sweep", "envelope_noise", "NARROW_BASE", "ENVELOPE_NOISE"]


def measured_sweep(dataset, run, law) -> tuple[MeasuredSweep, float]:
    """The base excitation of ``run`` as recorded by the data set's base channel.

    The base record's first harmonic (:func:`freeplayid.signal.acmp`, started on ``law``, the
    run's sweep law, over the band :func:`freeplayid.signal.level.quiet_base` picks from the
    extraction's default bandwidth ``max(1 Hz, 2 s x rate)``: a quarter of it where the
    envelope is noisy) gives its amplitude and phase at every sample; amplitudes in the
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
    mode = quiet_base(acmp(x, fs, sweep=law, bandwidth_hz=bw),
                      acmp(x, fs, sweep=law, bandwidth_hz=NARROW_BASE * bw))
    w = 2 * np.pi * np.clip(mode.frequency, 1e-6, None)
    amp = mode.amplitude * w ** (2 - order)  # [m/s^2]
    if not np.all(np.isfinite(amp)) or np.median(amp) <= 0:
        raise ValueError(f"run {run.file}: the base channel has no usable first harmonic")
    level = float(np.median(amp))
    env = np.maximum(amp / level, 1e-6)
    # x = A cos(psi): the simulator's excitation is A sin(phase), phase = psi + pi / 2
    return MeasuredSweep(fs, mode.phase + np.pi / 2, env), level / G


"""The excitation as it was measured: a run's base channel as a :class:`MeasuredSweep`."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..quantity import G, check_quantity
from ..signal import acmp
from ..signal.level import (
    ENVELOPE_NOISE,
    NARROW_BASE,
    SHARPEN_STEPS,
    envelope_noise,
    quiet_base,
    quiet_phase,
    reading_sd,
    rounds,
    sharpened,
    sharpened_gain,
)
from ..sweep import MeasuredSweep

# the band the base is read over is chosen in freeplayid.signal.level (the quadrature point's
# phase reference is read the same way); its names are kept here for the callers of this module
__all__ = ["measured_sweep", "read_again", "envelope_noise", "NARROW_BASE", "ENVELOPE_NOISE"]


def measured_sweep(dataset, run, law) -> tuple[MeasuredSweep, float]:
    """The base excitation of ``run`` as recorded by the data set's base channel.

    The base record's first harmonic (:func:`freeplayid.signal.acmp`, started on ``law``, the
    run's sweep law, over the band :func:`freeplayid.signal.level.quiet_base` picks from the
    extraction's default bandwidth ``max(1 Hz, 2 s x rate)``: a quarter of it where the
    envelope is noisy, its amplitude then :func:`freeplayid.signal.level.sharpened` where the
    reading shows a profile the band rounds, :func:`freeplayid.signal.level.rounds`: a dip
    shorter than the band's time) gives its amplitude and phase at every sample; amplitudes in
    the data's quantity become accelerations (``A w^(2 - order)``). Where the band is the narrow
    one the phase is read against ``law`` (:func:`freeplayid.signal.level.quiet_phase`: the
    law's phase plus a smooth offset, unless the base's phase moves within the record). The
    level is their median [g];
    the envelope the amplitude over it; its reading noise (:func:`freeplayid.signal.level.
    reading_sd`) and band go with it (``MeasuredSweep.reading_sd``, ``reading_band_hz``: the
    replay's excitation copies, :func:`read_again`), and where the band is the narrow one the
    wide band's reading too (``MeasuredSweep.wide``: the replay's check of the level
    where the runs jump, :class:`~freeplayid.replay.BaseReading`).
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
    wide = acmp(x, fs, sweep=law, bandwidth_hz=bw)
    narrow = acmp(x, fs, sweep=law, bandwidth_hz=NARROW_BASE * bw)
    mode = quiet_base(wide, narrow)
    noise = reading_sd(wide, narrow, mode)
    # sharpened where the narrow band rounds a level profile the reading shows
    steps = SHARPEN_STEPS if mode is narrow and rounds(narrow, fs, law, noise) else 0
    amp = _acceleration(sharpened(mode, fs, law, steps) if steps else mode.amplitude, mode, order)
    if not np.all(np.isfinite(amp)) or np.median(amp) <= 0:
        raise ValueError(f"run {run.file}: the base channel has no usable first harmonic")
    level = float(np.median(amp))
    env = np.maximum(amp / level, 1e-6)
    # x = A cos(psi): the simulator's excitation is A sin(phase), phase = psi + pi / 2; a noisy
    # base's phase read against the sweep law where it follows it (signal.level.law_phase)
    phase = quiet_phase(wide, narrow, law, fs) + np.pi / 2
    # the wide band's reading beside a narrow one, for the check of the jumps' levels
    read_wide = None
    if mode is not wide:
        read_wide = MeasuredSweep(
            fs, phase, np.maximum(np.nan_to_num(_acceleration(wide.amplitude, wide, order) / level,
                                                nan=1e-6), 1e-6),
            reading_sd=reading_sd(wide, narrow, wide), reading_band_hz=float(wide.bandwidth_hz))
    return MeasuredSweep(fs, phase, env, reading_sd=noise * sharpened_gain(steps),
                         reading_band_hz=float(mode.bandwidth_hz), reading_steps=steps,
                         wide=read_wide), level / G


def _acceleration(amplitude, mode, order: int) -> np.ndarray:
    """A first harmonic's ``amplitude`` of a record in the data's quantity (``order``: 0
    displacement, 1 velocity, 2 acceleration) read at ``mode``'s frequency, as acceleration
    (``A w^(2 - order)``)."""
    w = 2 * np.pi * np.clip(mode.frequency, 1e-6, None)
    return np.asarray(amplitude) * w ** (2 - order)


# the pursuit's steps of a reading of the noise (:func:`read_again`): one, at the excitation's
# own frequency
READ_AGAIN_STEPS = 1


def read_again(sweep: MeasuredSweep, rng) -> MeasuredSweep:
    """``sweep`` (a measured excitation) with its envelope read again under fresh noise: times
    ``1 + e(t)``, ``e`` the relative amplitude error of a reading over ``reading_band_hz``
    (:func:`freeplayid.signal.acmp`, its band as adapted, kept; sharpened as it was) of this
    excitation's unit sine plus white noise from ``rng``, scaled to the standard deviation
    ``reading_sd``: the reading's own noise, its spectrum included. The phase is kept. ``sweep``
    itself where ``reading_sd`` or ``reading_band_hz`` is 0.

    The sine's frequency is the excitation's own, so the reading is one demodulation at it and
    one step of the pursuit (``max_iter`` :data:`READ_AGAIN_STEPS`): the amplitude's noise is
    linear in the noise, and the pursuit's further steps, which refine a frequency that is
    already right, change it by less than a tenth of its standard deviation anywhere
    (correlation 0.9999 with the 52-step reading on the bundled example's bases) for 1/18 of
    the time."""
    if sweep.reading_sd <= 0 or sweep.reading_band_hz <= 0:
        return sweep
    fs = float(sweep.sample_rate)
    phase = np.asarray(sweep.phase_samples, dtype=float)
    # small enough to read linearly (about 1 % of the amplitude); scaled below
    noise = 0.01 * math.sqrt(fs / (2.0 * sweep.reading_band_hz))
    x = np.sin(phase) + noise * rng.standard_normal(phase.size)
    read = acmp(x, fs, sweep=sweep, bandwidth_hz=sweep.reading_band_hz, adapt=False,
                max_iter=READ_AGAIN_STEPS)
    e = (sharpened(read, fs, sweep, sweep.reading_steps) if sweep.reading_steps else
         read.amplitude) - 1.0
    e = (e - np.mean(e)) * (sweep.reading_sd / max(float(np.std(e)), 1e-300))
    env = np.maximum(np.asarray(sweep.envelope_samples) * (1.0 + e), 1e-6)
    return dataclasses.replace(sweep, envelope_samples=env)

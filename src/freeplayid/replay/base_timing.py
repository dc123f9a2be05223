"""The base channel's timing against the responses, read from the test and its replay.

With a base channel, the replays are driven by the base's measured first harmonic, so in the
replay the responses and the base are in step by construction. In the test they are in step
only where the acquisition samples them at the same instants: a base channel read ``t``
seconds late (a multiplexed scan, another front end's filter delay) puts every response's
phase against the base ``360 f t`` degrees ahead. Away from the resonance, where the structure's
phase hardly depends on (kn, delta) or on the damping, the difference of the two phases is that
turn and little else, so

    t(f) = [arg(Y / B)_test - arg(Y / B)_replay] / (2 pi f)

read sample by sample (``Y``, ``B``: a response's and the base's first harmonics, demodulated
with the run's sweep law, :func:`freeplayid.signal.lockin`) measures the delay.

What is read: each run's samples away from its records' ends (``TRIM_S``), where the replay
reproduces the response's amplitude ratio to the base within ``RATIO_TOL`` (log) and where the
replayed phase moves slowly with frequency (below ``SLOPE_MAX`` rad/Hz: not on the resonant
lobe, where a damping of another form or a small error of the answer turns the phase far more
than any delay).

A delay turns the phase the same way below and above the resonance; a damping the replay does
not have turns it one way below (a test damped more lags more) and the other way above (its
lag falls short of the replay's): an oscillator at 40 Hz damped at 4.5 % against a replay at
3 % reads -0.27 ms on the flank below and +0.44 ms on the flank above (tests/test_base_timing.py;
read as one, -0.18 ms, 2.6 degrees at 40 Hz). So the samples are split by the side of the
resonance the replay puts them on (the motion relative to the base in phase with it below,
against it above), each side's delay is its median, and a run's delay is the mean of its two
sides (the one side it has, where it has one): the damping's parts largely cancel (+0.08 ms,
1.2 degrees, there), a delay's add. The estimate is the median run's; the runs' spread and the
sides' difference say how far the reading is one delay (:attr:`BaseTiming.agree`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..signal.lockin import lockin

__all__ = ["BaseTiming", "base_timing", "TRIM_S", "RATIO_TOL", "SLOPE_MAX", "BANDWIDTH_HZ"]

# the records' ends: the demodulation settles and a start transient decays within this [s]
TRIM_S = 2.0
# the samples where the replay reproduces the response-to-base amplitude ratio within 5 % (log)
RATIO_TOL = 0.05
# and where its phase against the base turns by less than this per Hz [rad/Hz] (a resonance of
# 3 % damping at 40 Hz turns it by 0.8 rad/Hz at its peak; a delay of 1 ms by 0.006)
SLOPE_MAX = 0.1
# the demodulation's bandwidth [Hz] (as the extraction's default)
BANDWIDTH_HZ = 1.0
# a run counts with this many samples read at least
MIN_SAMPLES = 64


@dataclass(frozen=True)
class BaseTiming:
    """How late the base channel reads against the responses, as the test and its replay tell.

    Attributes
    ----------
    delay_s : float [s]
        The median run's delay (> 0: the base read late). NaN where no run had samples to read.
    runs : dict of str -> float [s]
        Each run's delay (the median over its channels' samples read).
    sample_rate : float [Hz]
    share : float [-]
        The share of the runs' samples that were read (away from the resonant lobes and where
        the replay reproduces the amplitude ratio).
    f_hz : float [Hz]
        The median frequency of the statistic's used points, where the turn matters.
    below_s, above_s : float [s]
        The delay read on the samples below the resonance and above it, over all runs (NaN
        where a side has none).
    """

    delay_s: float
    runs: dict
    sample_rate: float
    share: float
    f_hz: float = math.nan
    below_s: float = math.nan
    above_s: float = math.nan

    @property
    def turn_deg(self) -> float:
        """The turn [deg] the delay gives the phase at the points' frequency."""
        return 360.0 * self.f_hz * self.delay_s

    @property
    def agree(self) -> bool:
        """Whether the runs read one delay, as a delay is (the same sign, within the median's
        size of each other), rather than turns that differ by run (a damping of another form
        turns each run's phase most near its own resonance)."""
        values = list(self.runs.values())
        same = all(v * self.delay_s > 0 for v in values)
        sides = [v for v in (self.below_s, self.above_s) if math.isfinite(v)]
        sided = all(v * self.delay_s > 0 for v in sides) and (
            len(sides) < 2 or abs(sides[0] - sides[1]) <= abs(self.delay_s))
        return bool(values) and same and sided and self.spread_s <= abs(self.delay_s)

    @property
    def samples(self) -> float:
        """The delay in samples."""
        return self.delay_s * self.sample_rate

    @property
    def spread_s(self) -> float:
        """The runs' range [s] (max - min; 0 with one run, NaN with none)."""
        values = [v for v in self.runs.values() if math.isfinite(v)]
        return float(max(values) - min(values)) if values else math.nan

    def describe(self) -> str:
        if not math.isfinite(self.delay_s):
            return "the base channel's timing not read (no run away from its resonance)"
        late = "late" if self.delay_s > 0 else "early"
        return (f"the base channel reads {1e3 * abs(self.delay_s):.3g} ms "
                f"({abs(self.samples):.2g} sample, {abs(self.turn_deg):.2g} degrees at the "
                f"points' {self.f_hz:.3g} Hz) {late} against the responses, the runs "
                f"{1e3 * min(self.runs.values()):+.3g} to {1e3 * max(self.runs.values()):+.3g}"
                f" ms, below the resonances {_ms(self.below_s)} and above {_ms(self.above_s)} "
                "(the test's phase against its replay's, away from the resonances)")

    def to_dict(self) -> dict:
        return {"delay_s": self.delay_s, "samples": self.samples, "runs": dict(self.runs),
                "share": self.share, "f_hz": self.f_hz, "turn_deg": self.turn_deg,
                "below_s": self.below_s, "above_s": self.above_s}


def _ms(value: float) -> str:
    return "not read" if not math.isfinite(value) else f"{1e3 * value:+.3g} ms"


def base_timing(test, replay, sweeps: dict, f_hz: float = math.nan) -> BaseTiming | None:
    """The base channel's timing (module docstring) from the ``test`` data set and its
    ``replay`` at the answer (:func:`.runs.replay_dataset`, the same runs and channels);
    ``sweeps``: run file -> (Sweep, ...) as :func:`.runs.replay_sweeps`; ``f_hz``: the points'
    frequency [Hz]. None where the test has no base channel or the replay none of its runs."""
    if test.base_channel is None or replay is None:
        return None
    fs = float(test.sample_rate)
    replayed = {r.file: r for r in replay.runs if not r.reason and r.base is not None}
    runs, read, total, sides = {}, 0, 0, ([], [])
    for run in test.runs:
        mate = replayed.get(run.file)
        if run.reason or run.base is None or mate is None or run.file not in sweeps:
            continue
        law = sweeps[run.file][0]
        (below, above), n = _run_delays(run, mate, law, fs)
        total += n
        medians = [float(np.median(v)) for v in (below, above) if v.size >= MIN_SAMPLES]
        if medians:
            runs[run.file] = float(np.mean(medians))
            read += below.size + above.size
            sides[0].append(below)
            sides[1].append(above)
    if total == 0:
        return None
    delay = float(np.median(list(runs.values()))) if runs else math.nan
    below, above = (np.concatenate(v) if v else np.empty(0) for v in sides)
    return BaseTiming(delay_s=delay, runs=runs, sample_rate=fs, share=read / total,
                      f_hz=float(f_hz), below_s=_median(below), above_s=_median(above))


def _median(values: np.ndarray) -> float:
    return float(np.median(values)) if values.size >= MIN_SAMPLES else math.nan


def _run_delays(run, mate, law, fs: float) -> tuple[tuple[np.ndarray, np.ndarray], int]:
    """The delays [s] read at each kept sample of one run's channels, below the resonance and
    above it, and the samples looked at."""
    n = min(run.base.shape[-1], mate.base.shape[-1])
    trim = int(round(TRIM_S * fs))
    if n <= 2 * trim + MIN_SAMPLES:
        return (np.empty(0), np.empty(0)), 0
    sl = slice(trim, n - trim)

    def demodulated(x):
        m = lockin(np.asarray(x[:n], float), fs, sweep=law, bandwidth_hz=BANDWIDTH_HZ)
        return m.amplitude[sl], m.phase[sl]

    f = np.asarray(law.frequency(np.arange(n) / fs), float)[sl]
    bt, pt = demodulated(run.base)
    br, pr = demodulated(mate.base)
    below, above = [], []
    for j in range(min(run.data.shape[0], mate.data.shape[0])):
        yt, qt = demodulated(run.data[j])
        yr, qr = demodulated(mate.data[j])
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.log((yt / bt) / (yr / br))
            turn = np.angle(np.exp(1j * ((qt - pt) - (qr - pr))))
            slope = np.gradient(np.unwrap(qr - pr), f)
            # the replayed motion relative to the base over the base: in phase with it below
            # the resonance (real part > 0), against it above
            relative = (yr / br) * np.exp(1j * (qr - pr)) - 1.0
        keep = (np.abs(ratio) < RATIO_TOL) & (np.abs(slope) < SLOPE_MAX) & (f > 0)
        delay = turn / (2 * np.pi * np.where(f > 0, f, 1.0))
        below.append(delay[keep & (relative.real > 0)])
        above.append(delay[keep & (relative.real <= 0)])
    joined = tuple(np.concatenate(v) if v else np.empty(0) for v in (below, above))
    return joined, (n - 2 * trim) * len(below)

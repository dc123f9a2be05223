"""What every record check reads: each usable run's signals, its sweep law, resonance and noise.

The checks share one :class:`Records` object: the runs' signals in the data set's units (copies
that the repairing checks overwrite), each run's own sweep law (estimated from the record,
whatever its hint says), the first-harmonic envelopes of its responses relative to the base, the
resonance window and each signal's white-noise level.

First-harmonic envelope (complex demodulation with the run's own law)::

    z(t) = 2 LP_B[ x(t) exp(-i phi(t)) ],   |z| the first-harmonic amplitude of x,

with ``phi`` the law's phase and LP_B a zero-phase 4th-order Butterworth low-pass at
``B = max(1 Hz, 2 s x |rate|)``, the extraction's default bandwidth (docs/signal.md).

White-noise level from the sinusoid-cancelling second difference: for x = A cos(w t + p) + n,
``r_k = x_{k-1} - 2 cos(w_k dt) x_k + x_{k+1}`` holds no first harmonic, and for white noise of
standard deviation s its standard deviation is ``s sqrt(2 + 4 cos^2(w dt))``; the median of |r|
(x 1.4826) ignores the few samples where harmonics or transients remain.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import signal as sps

from ..signal import estimate_sweep
from ..sweep import Sweep

__all__ = ["Records", "RunRecord", "Resonance", "demodulate", "extraction_bandwidth"]


def extraction_bandwidth(law: Sweep, t) -> float:
    """The extraction's default bandwidth [Hz]: max(1 Hz, 2 s x the median |rate|)."""
    return max(1.0, 2.0 * float(np.median(np.abs(law.rate(t)))))


def demodulate(x, fs: float, phase, bandwidth_hz: float, *, order: int = 4) -> np.ndarray:
    """``2 LP[x exp(-i phase)]``: the complex first harmonic of ``x`` [x's units], shape (..., T).

    Parameters
    ----------
    x : ndarray, shape (..., T)
    fs : float [Hz]
    phase : ndarray, shape (T,) [rad]
    bandwidth_hz : float [Hz]
        Cut-off of the zero-phase Butterworth low-pass (clipped below 0.4 fs).
    """
    bw = min(bandwidth_hz, 0.4 * fs)
    sos = sps.butter(order, bw, fs=fs, output="sos")
    y = np.asarray(x, dtype=float) * np.exp(-1j * np.asarray(phase))
    # pad with three filter times of the record mirrored (even: an odd reflection would add
    # twice the end sample's fast part as a step): no start-up transient at the ends
    pad = min(y.shape[-1] - 1, int(3 * fs / bw))
    re = sps.sosfiltfilt(sos, y.real, axis=-1, padtype="even", padlen=pad)
    im = sps.sosfiltfilt(sos, y.imag, axis=-1, padtype="even", padlen=pad)
    return 2.0 * (re + 1j * im)


@dataclass(frozen=True)
class Resonance:
    """A run's resonance, from the strongest first-harmonic envelope of the relative responses.

    Attributes
    ----------
    row : int
        The strongest response channel (row of the run's data).
    index : int
        Sample of its envelope's maximum.
    t_s, f_hz : float [s], [Hz]
        Time of the maximum and the sweep frequency there.
    window : ndarray of bool, shape (T,)
        The samples near the resonance: the envelope's lobe above half its maximum around the
        peak, widened by 2 / bandwidth (the extraction's smoothing) on each side.
    peak_ratio : float [-]
        Maximum over median of the envelope: a resonance stands well above the rest of the
        sweep; an in-gap response does not.
    interior : bool
        The maximum lies further than 2 / bandwidth from both ends of the record.
    envelopes : ndarray, shape (channel, T) [data units], complex
        First harmonics of every response channel relative to the base.
    """

    row: int
    index: int
    t_s: float
    f_hz: float
    window: np.ndarray
    peak_ratio: float
    interior: bool
    envelopes: np.ndarray


@dataclass
class RunRecord:
    """One usable run as the checks see it (mutable: repairs overwrite ``data`` and ``base``).

    Attributes
    ----------
    run : Run
        The run as read.
    data : ndarray, shape (channel, T) [data units]
    base : ndarray, shape (T,) [data units], or None
    hint : Sweep or None
        The run's sweep hint.
    law : Sweep or None
        The record's own sweep law (estimated from the base channel, else the best-tracked
        response), else the hint; None when neither exists.
    law_source : str
        Where ``law`` comes from ("base channel acc_base", "channel acc_tl", "sweep hint").
    law_residual_hz : float [Hz]
        The estimate's median |IF - law| (NaN for a hint).
    law_error : str
        Why no law could be estimated from the record ("" when one was).
    repaired : bool
    """

    run: object
    data: np.ndarray
    base: np.ndarray | None
    hint: Sweep | None
    law: Sweep | None = None
    law_source: str = ""
    law_residual_hz: float = float("nan")
    law_error: str = ""
    repaired: bool = False
    _resonance: Resonance | None = None
    _noise: dict | None = None

    @property
    def file(self) -> str:
        return self.run.file

    @property
    def n(self) -> int:
        return self.data.shape[1]


class Records:
    """The data set's usable runs, prepared once for every check.

    Parameters
    ----------
    dataset : Dataset
    system : FreeplaySystem or None
    options : RecordCheckOptions
    """

    def __init__(self, dataset, system, options) -> None:
        self.dataset, self.system, self.options = dataset, system, options
        self.fs = float(dataset.sample_rate)
        self.names = list(dataset.channels)
        self.base_name = dataset.base_channel or "base"
        self.skipped: dict = {}  # check -> why it could not run
        self._track_verdicts = None  # the frequency-track comparison, shared by three checks
        self.runs = [self._prepare(run) for run in dataset.runs if _usable(run)]

    # ------------------------------------------------------------------ preparation
    def _prepare(self, run) -> RunRecord:
        hint = Sweep(**run.sweep) if run.sweep else None
        base = None if run.base is None else np.array(run.base, dtype=float)
        rec = RunRecord(run=run, data=np.array(run.data, dtype=float), base=base, hint=hint)
        sources = [(f"base channel {self.base_name}", base)] if base is not None else []
        sources.append(("response", rec.data))
        errors = []
        for source, x in sources:
            try:
                est = estimate_sweep(x, self.fs, fmin=2.0, quantity=self.dataset.quantity)
            except ValueError as exc:
                errors.append(f"{source}: {exc}")
                continue
            if source == "response":
                source = f"channel {self.names[est.channel]}"
            rec.law, rec.law_source, rec.law_residual_hz = est.sweep, source, est.residual_hz
            break
        if rec.law is None:
            rec.law_error = "; ".join(errors)
            if hint is not None:
                rec.law, rec.law_source = hint, "sweep hint"
        return rec

    # ------------------------------------------------------------------ signals
    def signals(self, rec: RunRecord):
        """(column name, samples, row) of every channel of a run, the base last (row -1)."""
        out = [(name, rec.data[i], i) for i, name in enumerate(self.names)]
        if rec.base is not None:
            out.append((self.base_name, rec.base, -1))
        return out

    def each_signal(self, check) -> list:
        """The findings of ``check(records, rec, name, x, row, unit)`` (a Finding, or None for
        none) over every signal of every run, in order."""
        unit = self.dataset.units
        found = (check(self, rec, name, x, row, unit) for rec in self.runs
                 for name, x, row in self.signals(rec))
        return [f for f in found if f is not None]

    def replace_signal(self, rec: RunRecord, row: int, values) -> None:
        """Overwrite one signal of a run with its repaired samples."""
        if row < 0:
            rec.base = np.asarray(values, dtype=float)
        else:
            rec.data[row] = values
        rec.repaired = True
        rec._resonance, rec._noise = None, None

    def time(self, rec: RunRecord) -> np.ndarray:
        """Sample times [s] from the record's start (the sweep's t = 0), shape (T,)."""
        return np.arange(rec.n) / self.fs

    def band(self, rec: RunRecord) -> tuple[float, float] | None:
        """(lowest, highest) swept frequency [Hz] of the run's law over the record, or None."""
        if rec.law is None:
            return None
        f = rec.law.frequency(np.array([0.0, (rec.n - 1) / self.fs]))
        return float(np.min(f)), float(np.max(f))

    def period_samples(self, rec: RunRecord, periods: float = 1.0, *, floor: float = 1.0) -> int:
        """Samples in ``periods`` periods of the lowest swept frequency (``floor`` Hz without
        a law)."""
        band = self.band(rec)
        f_lo = band[0] if band else floor
        return max(1, int(round(periods * self.fs / f_lo)))

    # ------------------------------------------------------------------ derived quantities
    def resonance(self, rec: RunRecord) -> Resonance | None:
        """The run's :class:`Resonance` (cached), or None without a sweep law."""
        if rec.law is None:
            return None
        if rec._resonance is None:
            rec._resonance = self._find_resonance(rec)
        return rec._resonance

    def _find_resonance(self, rec: RunRecord) -> Resonance:
        t = self.time(rec)
        bw = extraction_bandwidth(rec.law, t)
        rel = rec.data - rec.base if rec.base is not None else rec.data
        z = demodulate(rel, self.fs, rec.law.phase(t), bw)
        a = np.abs(z)
        edge = min(int(round(2.0 * self.fs / bw)), rec.n // 4)
        inner = a[:, edge:rec.n - edge] if rec.n > 2 * edge + 1 else a
        row = int(np.argmax(inner.max(axis=1)))
        k = int(np.argmax(a[row]))
        low = a[row] < 0.5 * a[row, k]
        before, after = np.nonzero(low[:k])[0], np.nonzero(low[k:])[0]
        lo = before[-1] + 1 if before.size else 0
        hi = k + after[0] if after.size else rec.n
        window = np.zeros(rec.n, dtype=bool)
        window[max(0, lo - edge):min(rec.n, hi + edge)] = True
        interior = edge <= k < rec.n - edge
        ratio = float(a[row, k] / max(np.median(a[row]), np.finfo(float).tiny))
        return Resonance(row, k, float(t[k]), float(rec.law.frequency(t[k])), window, ratio,
                         interior, z)

    def noise(self, rec: RunRecord, row: int) -> float:
        """White-noise standard deviation of one signal [data units] (module docstring)."""
        if rec._noise is None:
            rec._noise = {}
        if row not in rec._noise:
            x = rec.base if row < 0 else rec.data[row]
            rec._noise[row] = self._noise_level(rec, x)
        return rec._noise[row]

    def _noise_level(self, rec: RunRecord, x: np.ndarray) -> float:
        if rec.law is None:  # no frequency to cancel: a plain second difference (an overestimate)
            c = np.ones(x.size - 2)
        else:
            c = np.cos(2 * np.pi * rec.law.frequency(self.time(rec)[1:-1]) / self.fs)
        r = x[:-2] - 2 * c * x[1:-1] + x[2:]
        gain = np.sqrt(2 + 4 * np.median(c) ** 2)
        return float(1.4826 * np.median(np.abs(r)) / gain)

    # ------------------------------------------------------------------ the repaired data set
    def repaired_dataset(self):
        """The data set with every repaired run's samples replaced (the input when none was)."""
        fixed = {rec.file: rec for rec in self.runs if rec.repaired}
        if not fixed:
            return self.dataset
        runs = tuple(replace(r, data=fixed[r.file].data.copy(),
                             base=None if fixed[r.file].base is None else fixed[r.file].base.copy())
                     if r.file in fixed else r for r in self.dataset.runs)
        return replace(self.dataset, runs=runs)


def _usable(run) -> bool:
    """A run the reader kept (no reason) with finite samples."""
    if run.reason:
        return False
    data = np.asarray(run.data, dtype=float)
    if data.ndim != 2 or data.shape[1] < 16 or not np.all(np.isfinite(data)):
        return False
    return run.base is None or bool(np.all(np.isfinite(run.base)))

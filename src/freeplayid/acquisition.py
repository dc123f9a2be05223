"""The anti-alias (decimation) filter a data set's records went through, as its manifest states it.

Where the statistic's points lie above 0.3 of the sample rate, the answer depends on the
acquisition's anti-alias filter: the simulator's default decimator attenuates there (-0.8 % at
0.336 fs), a sigma-delta acquisition's is flat to 0.45 fs, and a filter of any other response
moves the points' amplitudes by its gain (docs/identify.md §3c, "The records' anti-alias
filter"). A data set states its filter in ``antialias`` (manifest field, or
``Dataset.from_arrays(antialias=)``):

- ``unknown`` (default): the replay decides and checks (``Replay.antialias``);
- ``flat``: flat to 0.45 of the sample rate; ``replay``: decimated as the simulator's records;
- a measured or published response, ``{frequency_hz: [...], gain: [...], phase_deg: [...]}``
  (phase optional) or ``{response: filter.csv}`` (a CSV with those columns, relative to the
  manifest): :class:`FilterResponse`. ``identify`` then divides every usable record (the
  channels and the base) by it before anything is read from them (:func:`equalized`), so that
  they are the records of a flat acquisition, and replays flat.

A response is interpolated linearly in frequency and held at its end values outside its table.
Where its gain is below ``GAIN_FLOOR`` (0.5) the division is limited to 1 / ``GAIN_FLOOR``: a
point there is not restored, and the verdict's ``antialias`` check says so
(:func:`unrestored_points`).

The base channel read at another instant than the responses. The test's motion relative to the
base and its phase-resonance points are read from the responses against the base at the same
instants, so a base channel read ``t`` seconds late turns every phase by 360 f t degrees (a
quarter sample at 256 Hz is 14 degrees at 40 Hz) and moved delta by -3 % on the default fin
(docs/identify.md §3c, "The base channel's timing"). A multiplexed acquisition that reads the
base after the responses, or a base channel from the controller's front end with another filter
delay, does so. A data set states that delay in ``base_delay_s`` (manifest field, or
``Dataset.from_arrays(base_delay_s=)``; > 0: the base read late, < 0: early; at most
``MAX_BASE_DELAY`` either way, a larger one being a unit slip), and ``identify`` advances every
usable base record by it (:func:`base_aligned`: a fractional shift by the record's spectrum,
zero-padded so that nothing wraps) before anything is read from it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import DatasetError

__all__ = ["ANTIALIAS", "GAIN_FLOOR", "MAX_BASE_DELAY", "FilterResponse", "check_antialias",
           "check_base_delay", "equalized", "equalize", "shifted", "base_aligned",
           "describe_antialias", "describe_base_delay", "unrestored_points"]

# the records' filter by name (`Dataset.antialias`, `Replay.antialias`)
ANTIALIAS = ("unknown", "replay", "flat")
# below this gain a stated response is not divided out further (1 / GAIN_FLOOR at most)
GAIN_FLOOR = 0.5
RESPONSE_KEYS = ("frequency_hz", "gain", "phase_deg")
# zeros on each side of a record before its spectrum is divided (the correction's kernel is
# short where the response is smooth; this keeps its circular wrap off the record)
PAD = 2048
# the largest base channel's delay a data set may state [s]: a multiplexed scan or a front end's
# filter delay is a few samples at most; 50 ms is a duration written in ms where s was meant
MAX_BASE_DELAY = 0.05


@dataclass(frozen=True)
class FilterResponse:
    """A filter's stated frequency response.

    Attributes
    ----------
    frequency_hz : tuple of float [Hz]
        Strictly increasing, >= 0; two entries or more.
    gain : tuple of float [-]
        Amplitude gain at each frequency, >= 0 (1: passed unchanged).
    phase_deg : tuple of float or None [deg]
        Phase at each frequency (a lag is negative); None: zero phase (a linear-phase FIR
        applied forwards and backwards, or one whose delay the acquisition removed).
    source : str
        Where it was stated (a file name, or "manifest" / "arrays").
    """

    frequency_hz: tuple
    gain: tuple
    phase_deg: tuple | None = None
    source: str = ""

    def __post_init__(self):
        where = f"`antialias` ({self.source}): " if self.source else "`antialias`: "
        f = _column(self.frequency_hz, "frequency_hz", where)
        g = _column(self.gain, "gain", where)
        p = None if self.phase_deg is None else _column(self.phase_deg, "phase_deg", where)
        if f.size < 2:
            raise DatasetError(f"{where}`frequency_hz` needs two entries or more, got {f.size}")
        for name, col in (("gain", g), ("phase_deg", p)):
            if col is not None and col.size != f.size:
                raise DatasetError(f"{where}`{name}` has {col.size} entries, `frequency_hz` "
                                   f"{f.size}: one per frequency")
        if f[0] < 0 or np.any(np.diff(f) <= 0):
            raise DatasetError(f"{where}`frequency_hz` must be >= 0 and strictly increasing")
        if np.any(g < 0) or not np.any(g > 0):
            raise DatasetError(f"{where}`gain` must be >= 0 (an amplitude ratio), and not all 0")
        object.__setattr__(self, "frequency_hz", tuple(map(float, f)))
        object.__setattr__(self, "gain", tuple(map(float, g)))
        if p is not None:
            object.__setattr__(self, "phase_deg", tuple(map(float, p)))

    def __call__(self, f) -> np.ndarray:
        """The complex response at frequencies ``f`` [Hz] (linear interpolation of gain and
        phase, held at the table's ends)."""
        f = np.abs(np.asarray(f, float))
        gain = np.interp(f, self.frequency_hz, self.gain)
        if self.phase_deg is None:
            return gain.astype(complex)
        return gain * np.exp(1j * np.deg2rad(np.interp(f, self.frequency_hz, self.phase_deg)))

    def passband_edge(self) -> float:
        """The lowest frequency [Hz] where the gain falls below ``GAIN_FLOOR`` (inf: nowhere in
        the table)."""
        below = np.flatnonzero(np.asarray(self.gain) < GAIN_FLOOR)
        if below.size == 0:
            return math.inf
        k = int(below[0])
        if k == 0:
            return self.frequency_hz[0]
        f0, f1 = self.frequency_hz[k - 1], self.frequency_hz[k]
        g0, g1 = self.gain[k - 1], self.gain[k]
        return float(f0 + (g0 - GAIN_FLOOR) / (g0 - g1) * (f1 - f0))

    def to_dict(self) -> dict:
        out = {"frequency_hz": list(self.frequency_hz), "gain": list(self.gain)}
        if self.phase_deg is not None:
            out["phase_deg"] = list(self.phase_deg)
        return out


def _column(values, name: str, where: str) -> np.ndarray:
    try:
        col = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise DatasetError(f"{where}`{name}` must be a list of numbers, got {values!r}") from None
    if col.ndim != 1 or not np.all(np.isfinite(col)):
        raise DatasetError(f"{where}`{name}` must be a flat list of finite numbers")
    return col


def check_antialias(value, where: str = "", folder: Path | None = None):
    """A manifest's (or a notebook's) ``antialias`` -> one of :data:`ANTIALIAS` or a
    :class:`FilterResponse`; a one-line :class:`DatasetError` naming the field otherwise.
    ``folder``: where a ``response`` file's relative path starts."""
    if value is None:
        return "unknown"
    if isinstance(value, FilterResponse):
        return value
    allowed = (f"one of {list(ANTIALIAS)}, {{frequency_hz: [...], gain: [...], phase_deg: "
               "[...]}} or {response: file.csv}")
    if isinstance(value, str):
        if value not in ANTIALIAS:
            raise DatasetError(f"{where}`antialias` must be {allowed}, got {value!r}")
        return value
    if not isinstance(value, Mapping):
        raise DatasetError(f"{where}`antialias` must be {allowed}, got {value!r}")
    keys = set(value)
    if keys == {"response"}:
        return _response_file(value["response"], where, folder)
    unknown = sorted(keys - set(RESPONSE_KEYS))
    if unknown or not {"frequency_hz", "gain"} <= keys:
        raise DatasetError(f"{where}`antialias` must be {allowed}, got the field(s) "
                           f"{sorted(keys)}")
    return FilterResponse(value["frequency_hz"], value["gain"], value.get("phase_deg"),
                          source=where.strip().rstrip(":") or "arrays")


def _response_file(name, where: str, folder: Path | None) -> FilterResponse:
    """A CSV with a header naming ``frequency_hz``, ``gain`` and optionally ``phase_deg``."""
    if not isinstance(name, str) or not name:
        raise DatasetError(f"{where}`antialias.response` must be a CSV file name, got {name!r}")
    path = Path(name) if folder is None else Path(folder) / name
    if not path.is_file():
        raise DatasetError(f"{where}`antialias.response`: no file {str(path)!r}")
    try:
        table = np.genfromtxt(path, delimiter=",", names=True, dtype=float, encoding="utf-8")
    except (OSError, ValueError) as exc:
        raise DatasetError(f"{path}: `antialias.response` unreadable as CSV ({exc})") from None
    names = table.dtype.names or ()
    missing = [c for c in ("frequency_hz", "gain") if c not in names]
    unknown = [c for c in names if c not in RESPONSE_KEYS]
    if missing or unknown:
        raise DatasetError(f"{path}: the header must name the columns {list(RESPONSE_KEYS)} "
                           f"(phase_deg optional), got {list(names)}")
    table = np.atleast_1d(table)
    return FilterResponse(table["frequency_hz"], table["gain"],
                          table["phase_deg"] if "phase_deg" in names else None,
                          source=str(path))


def describe_antialias(value) -> str:
    """One phrase for the report."""
    if isinstance(value, FilterResponse):
        edge = value.passband_edge()
        return (f"a stated response ({len(value.frequency_hz)} frequencies, "
                f"{value.frequency_hz[0]:g}-{value.frequency_hz[-1]:g} Hz"
                + ("" if value.phase_deg is None else ", with phase")
                + (f"; gain below {GAIN_FLOOR:g} from {edge:.4g} Hz" if math.isfinite(edge)
                   else "") + "): the records were divided by it (replayed through a flat "
                "filter)")
    return {"unknown": "not stated", "flat": "stated flat to 0.45 of the sample rate",
            "replay": "stated as the replay's own"}[value]


def equalize(x, sample_rate: float, response: FilterResponse) -> np.ndarray:
    """``x`` (..., T) divided by ``response`` in the frequency domain (the gain limited below by
    ``GAIN_FLOOR``): the record a flat acquisition would have made."""
    def inverse(f):
        h = response(f)
        gain = np.abs(h)
        return 1.0 / np.where(gain >= GAIN_FLOOR, h, GAIN_FLOOR * np.exp(1j * np.angle(h)))
    return _through(x, sample_rate, inverse)


def shifted(x, sample_rate: float, advance_s: float) -> np.ndarray:
    """``x`` (..., T) read ``advance_s`` seconds earlier (a fractional shift by its spectrum:
    ``x(t + advance_s)`` for a record band-limited below half the sample rate; < 0 delays)."""
    if advance_s == 0:
        return np.asarray(x, float)
    return _through(x, sample_rate, lambda f: np.exp(2j * np.pi * f * advance_s))


def _through(x, sample_rate: float, h) -> np.ndarray:
    """``x`` (..., T) times the response ``h(f)`` in the frequency domain, zero-padded by
    ``PAD`` on each side so that the correction's kernel does not wrap onto the record."""
    x = np.asarray(x, float)
    n = x.shape[-1]
    pad = min(PAD, n)
    m = n + 2 * pad
    f = np.fft.rfftfreq(m, 1.0 / sample_rate)
    padded = np.concatenate([np.zeros(x.shape[:-1] + (pad,)), x,
                             np.zeros(x.shape[:-1] + (pad,))], axis=-1)
    y = np.fft.irfft(np.fft.rfft(padded, axis=-1) * h(f), n=m, axis=-1)
    return y[..., pad:pad + n]


def check_base_delay(value, base_channel, where: str = "") -> float:
    """A data set's ``base_delay_s`` [s] (None: 0) as a float; a one-line
    :class:`DatasetError` naming the field for anything but a finite number within
    +-``MAX_BASE_DELAY``, or a delay stated where there is no base channel."""
    if value is None:
        return 0.0
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_))
    if not ok or not math.isfinite(value) or abs(value) > MAX_BASE_DELAY:
        raise DatasetError(f"{where}`base_delay_s` must be the base channel's delay against the "
                           f"responses in seconds, a number within +-{MAX_BASE_DELAY:g} "
                           f"(> 0: read late), got {value!r}")
    if value != 0 and base_channel is None:
        raise DatasetError(f"{where}`base_delay_s` is {value!r} but the data set has no "
                           "`base_channel` to shift")
    return float(value)


def describe_base_delay(delay_s: float, sample_rate: float) -> str:
    """One phrase for the report."""
    samples = delay_s * sample_rate
    return (f"{1e3 * abs(delay_s):.4g} ms ({abs(samples):.3g} sample) "
            f"{'late' if delay_s > 0 else 'early'} against the responses, as stated: the base "
            "records were shifted back into step")


def base_aligned(dataset):
    """``dataset`` with every usable run's base record advanced by its stated ``base_delay_s``
    (the data set itself where it states none)."""
    delay = float(getattr(dataset, "base_delay_s", 0.0) or 0.0)
    if delay == 0:
        return dataset
    fs = float(dataset.sample_rate)
    runs = tuple(run if run.reason or run.base is None or np.size(run.base) == 0
                 else dataclasses.replace(run, base=shifted(run.base, fs, delay))
                 for run in dataset.runs)
    return dataclasses.replace(dataset, runs=runs)


def equalized(dataset):
    """``dataset`` with every usable run's channels and base divided by its stated
    :class:`FilterResponse` (the data set itself where it states none)."""
    response = getattr(dataset, "antialias", "unknown")
    if not isinstance(response, FilterResponse):
        return dataset
    fs = float(dataset.sample_rate)
    runs = []
    for run in dataset.runs:
        if run.reason or np.size(run.data) == 0:
            runs.append(run)
            continue
        runs.append(dataclasses.replace(
            run, data=equalize(run.data, fs, response),
            base=None if run.base is None else equalize(run.base, fs, response)))
    return dataclasses.replace(dataset, runs=tuple(runs))


def unrestored_points(response, frequencies) -> list[float]:
    """The frequencies [Hz] among ``frequencies`` where a stated response's gain is below
    ``GAIN_FLOOR`` (the records there not restored); empty where none is stated."""
    if not isinstance(response, FilterResponse):
        return []
    f = np.asarray(list(frequencies), float)
    return [float(v) for v in f[np.abs(response(f)) < GAIN_FLOOR]]

"""NI TDMS run files (``.tdms``), read with ``npTDMS``: one channel per column.

Channels are matched by name against the manifest's columns, in whichever group they are (a
name needed by the manifest that occurs in two groups is an error). The time [s] is a channel
named ``time`` if the file has one (a timestamp channel counts from its first sample), else the
waveform timing of the channels (``wf_start_offset + k * wf_increment``, npTDMS's relative
``time_track``), which must then be the same for every column. Values are the scaled data, in
the manifest's ``units``; a channel's ``unit_string`` property (and the waveform's
``wf_xunit_string``) is returned for the unit check (:mod:`freeplayid.io.units`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ...errors import DatasetError
from .runfile import RunFile

__all__ = ["read"]


def read(path: Path, columns: Sequence[str], layouts=None) -> RunFile:
    """The time and the channels named ``columns`` of one TDMS file as float vectors."""
    from nptdms import TdmsFile

    try:
        f = TdmsFile.read(path)
    except Exception as exc:  # npTDMS raises ValueError, KeyError, ... on malformed files
        raise DatasetError(f"{path}: not a readable TDMS file ({exc})") from None
    found: dict[str, list] = {}  # channel name -> [(group name, channel), ...]
    for group in f.groups():
        for ch in group.channels():
            found.setdefault(ch.name, []).append((group.name, ch))
    need = [*columns, *(["time"] if "time" in found else [])]
    missing = [c for c in columns if c not in found]
    if missing:
        have = [f"{g}/{c}" for c, gs in found.items() for g, _ in gs]
        raise DatasetError(
            f"{path}: channel(s) {missing} not found; the file has (group/channel) {have} "
            "(the manifest's `channels` keys and `base_channel` must be channels)"
        )
    for c in need:
        if len(found[c]) > 1:
            raise DatasetError(
                f"{path}: channel {c!r} is in several groups {[g for g, _ in found[c]]}; a "
                "channel the manifest names must be unique across groups"
            )
    out = {c: _vector(found[c][0][1], path, c) for c in need}
    units = {c: found[c][0][1].properties.get("unit_string") for c in need}
    if "time" not in out:
        channels = [found[c][0][1] for c in columns]
        out["time"] = _waveform_time(path, channels, columns)
        units["time"] = channels[0].properties.get("wf_xunit_string") if channels else None
    return RunFile(columns=out, units={c: str(u) for c, u in units.items() if u})


def _vector(ch, path: Path, name: str) -> np.ndarray:
    """A channel's scaled data as a float vector, or a DatasetError naming file and channel."""
    x = np.asarray(ch[:])
    if name == "time" and x.dtype.kind == "M":  # timestamps: seconds from the first sample
        return (x - x[0]) / np.timedelta64(1, "s") if x.size else x.astype(float)
    if np.iscomplexobj(x):
        raise DatasetError(f"{path}: channel {name!r} is complex; need a real time history")
    if x.dtype.kind not in "iuf":
        raise DatasetError(f"{path}: channel {name!r} must be numeric, got dtype {x.dtype}")
    return x.astype(float)


def _waveform_time(path: Path, channels: list, names: Sequence[str]) -> np.ndarray:
    """The relative time track of the first channel; every channel must share its timing."""
    timing = []
    for ch, name in zip(channels, names):
        try:
            timing.append((float(ch.properties["wf_increment"]),
                           float(ch.properties.get("wf_start_offset", 0.0))))
        except (KeyError, TypeError, ValueError):
            raise DatasetError(
                f"{path}: no 'time' channel, and channel {name!r} has no waveform timing "
                "(property `wf_increment`); add a 'time' channel [s] or the waveform properties"
            ) from None
    for (inc, off), name in zip(timing[1:], names[1:]):
        if (inc, off) != timing[0]:
            raise DatasetError(
                f"{path}: no 'time' channel, and channel {name!r} has waveform timing "
                f"(wf_increment, wf_start_offset) = ({inc:g}, {off:g}) s, but {names[0]!r} has "
                f"({timing[0][0]:g}, {timing[0][1]:g}) s"
            )
    ch = channels[0]
    if "wf_start_offset" in ch.properties:
        return np.asarray(ch.time_track(), dtype=float)
    return timing[0][0] * np.arange(len(ch))  # time_track needs the offset; it is 0 by default

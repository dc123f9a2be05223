"""The records' anti-alias filter as a data set states it (freeplayid.acquisition): the
manifest's ``antialias`` field, a stated response divided out of the records, and its check;
the base channel's stated delay (``base_delay_s``) shifted out of its records.

The references are scipy's: the filters are scipy FIR / IIR designs applied with numpy and
scipy, their responses ``scipy.signal.freqz``'s; the package only states and divides."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.signal
import yaml

from freeplayid.acquisition import (
    GAIN_FLOOR,
    FilterResponse,
    base_aligned,
    check_antialias,
    equalize,
    equalized,
    shifted,
    unrestored_points,
)
from freeplayid.errors import DatasetError
from freeplayid.identification.verdict import stated_filter_checks
from freeplayid.io import Dataset, Run, read_dataset, write_dataset

FS = 256.0


def _amplitude(x, f, fs=FS):
    """First-harmonic amplitude of ``x`` at ``f`` by least squares on its middle half."""
    n = x.size
    t = np.arange(n) / fs
    sl = slice(n // 4, 3 * n // 4)
    basis = np.column_stack([np.cos(2 * np.pi * f * t[sl]), np.sin(2 * np.pi * f * t[sl])])
    c = np.linalg.lstsq(basis, x[sl], rcond=None)[0]
    return float(np.hypot(*c)), float(np.arctan2(-c[1], c[0]))


def _kaiser(cutoff: float, width: float) -> np.ndarray:
    """A zero-phase (odd, symmetric) Kaiser low-pass at FS, 100 dB; ``cutoff``, ``width`` in
    units of FS."""
    n, beta = scipy.signal.kaiserord(100.0, width * 2)
    return scipy.signal.firwin(n | 1, cutoff * FS, window=("kaiser", beta), fs=FS)


def _stated(taps, phase: bool = False) -> FilterResponse:
    f = np.linspace(0.0, FS / 2, 513)
    _, h = scipy.signal.freqz(taps, worN=f, fs=FS)
    if not phase:  # applied centred: zero phase
        return FilterResponse(f, np.abs(h))
    return FilterResponse(f, np.abs(h), np.rad2deg(np.unwrap(np.angle(h))))


@pytest.mark.parametrize("f", [40.0, 80.0, 86.0, 90.0])
def test_a_stated_response_divided_out_restores_the_amplitude(f):
    # a filter flat to 0.25 fs whose transition band holds the tones at 0.31-0.35 fs
    taps = _kaiser(0.36, 0.1)
    t = np.arange(int(40 * FS)) / FS
    x = 2.0 * np.sin(2 * np.pi * f * t + 0.3)
    y = np.convolve(x, taps, mode="same")
    response = _stated(taps)
    gain = abs(response(f))[()]
    before = _amplitude(y, f)[0] / 2.0
    assert abs(before - gain) < 1e-6  # the stated response is what the filter does
    restored = _amplitude(equalize(y, FS, response), f)
    assert restored[0] == pytest.approx(2.0, rel=1e-5)
    assert restored[1] == pytest.approx(_amplitude(x, f)[1], abs=1e-5)
    if f >= 86.0:
        assert gain < 0.97  # the tone was filtered: the check is not empty


def test_a_causal_filters_phase_is_divided_out_too():
    # an 8th-order Butterworth applied forwards only (a lag that grows with frequency)
    b, a = scipy.signal.butter(8, 0.42 * FS, fs=FS)
    f = np.linspace(0.0, FS / 2, 2049)
    _, h = scipy.signal.freqz(b, a, worN=f, fs=FS)
    response = FilterResponse(f, np.abs(h), np.rad2deg(np.unwrap(np.angle(h))))
    t = np.arange(int(40 * FS)) / FS
    for tone in (50.0, 95.0):
        x = np.sin(2 * np.pi * tone * t)
        y = scipy.signal.lfilter(b, a, x)
        assert abs(_amplitude(y, tone)[1] - _amplitude(x, tone)[1]) > 0.3  # a real lag
        z = equalize(y, FS, response)
        amp, ph = _amplitude(z, tone)
        assert amp == pytest.approx(1.0, rel=1e-3)
        assert ph == pytest.approx(_amplitude(x, tone)[1], abs=2e-3)


def test_below_the_gain_floor_the_division_is_limited():
    taps = _kaiser(0.36, 0.1)
    response = _stated(taps)
    f = 110.0  # 0.43 fs: deep in the stop band
    assert abs(response(f))[()] < GAIN_FLOOR
    t = np.arange(int(40 * FS)) / FS
    y = np.convolve(np.sin(2 * np.pi * f * t), taps, mode="same")
    assert _amplitude(equalize(y, FS, response), f)[0] == pytest.approx(
        _amplitude(y, f)[0] / GAIN_FLOOR, rel=1e-4)
    assert unrestored_points(response, [80.0, 110.0]) == [110.0]
    assert unrestored_points("flat", [110.0]) == []
    edge = response.passband_edge()
    assert 0.33 * FS < edge < 0.40 * FS
    assert abs(abs(response(edge))[()] - GAIN_FLOOR) < 0.01


def test_responses_and_names_are_checked_with_one_line_errors(tmp_path):
    assert check_antialias(None) == "unknown"
    assert check_antialias("flat") == "flat"
    with pytest.raises(DatasetError, match=r"`antialias` must be one of \['unknown', 'replay', "
                                           r"'flat'\].*got 'sigma-delta'"):
        check_antialias("sigma-delta")
    with pytest.raises(DatasetError, match="strictly increasing"):
        check_antialias({"frequency_hz": [0, 10, 5], "gain": [1, 1, 1]})
    with pytest.raises(DatasetError, match="`gain` has 2 entries"):
        check_antialias({"frequency_hz": [0, 10, 20], "gain": [1, 1]})
    with pytest.raises(DatasetError, match=">= 0"):
        check_antialias({"frequency_hz": [0, 10], "gain": [1, -0.1]})
    with pytest.raises(DatasetError, match="the field"):
        check_antialias({"frequency_hz": [0, 10], "gains": [1, 1]})
    with pytest.raises(DatasetError, match="no file"):
        check_antialias({"response": "missing.csv"}, "m.yaml: ", tmp_path)
    (tmp_path / "bad.csv").write_text("f,g\n0,1\n10,1\n")
    with pytest.raises(DatasetError, match="the header must name the columns"):
        check_antialias({"response": "bad.csv"}, "m.yaml: ", tmp_path)
    (tmp_path / "ok.csv").write_text("frequency_hz,gain,phase_deg\n0,1,0\n100,0.9,-30\n")
    r = check_antialias({"response": "ok.csv"}, "m.yaml: ", tmp_path)
    assert r.gain == (1.0, 0.9) and r.phase_deg == (0.0, -30.0)
    assert abs(r(50.0)[()]) == pytest.approx(0.95)


def _small(antialias="unknown"):
    t = np.arange(int(4 * FS)) / FS
    runs = [Run(file=f"r{k}.csv", time=t, data=np.vstack([np.sin(2 * np.pi * 85 * t)] * 2),
                level_g=0.5, base=0.1 * np.sin(2 * np.pi * 85 * t)) for k in range(2)]
    return runs, dict(name="x", quantity="acceleration", units="g", sample_rate=FS,
                      channels={"a": "uz_top_left", "b": "uz_lower_right"}, base_channel="base",
                      antialias=antialias)


def test_the_manifest_states_the_filter_and_write_dataset_writes_it(tmp_path):
    response = _stated(_kaiser(0.36, 0.1))
    runs, kw = _small(response)
    path = write_dataset(tmp_path / "resp", runs=runs, **kw)
    ds = read_dataset(path, check_model=False)
    assert isinstance(ds.antialias, FilterResponse)
    assert ds.antialias.gain == pytest.approx(response.gain)
    # a response file next to the manifest
    m = yaml.safe_load(path.read_text())
    np.savetxt(tmp_path / "resp" / "filter.csv",
               np.column_stack([response.frequency_hz, response.gain]), delimiter=",",
               header="frequency_hz,gain", comments="")
    m["antialias"] = {"response": "filter.csv"}
    path.write_text(yaml.safe_dump(m))
    assert read_dataset(path, check_model=False).antialias.gain == pytest.approx(response.gain)
    m["antialias"] = "sigma"
    path.write_text(yaml.safe_dump(m))
    with pytest.raises(DatasetError, match=r"manifest.yaml: `antialias` must be one of"):
        read_dataset(path, check_model=False)
    runs, kw = _small("flat")
    assert read_dataset(write_dataset(tmp_path / "flat", runs=runs, **kw),
                        check_model=False).antialias == "flat"
    runs, kw = _small()
    written = write_dataset(tmp_path / "none", runs=runs, **kw)
    assert "antialias" not in yaml.safe_load(written.read_text())


def _tone(antialias) -> Dataset:
    """One 20 s run of an 85 Hz tone on both channels (amplitude 1 g) and the base (0.1 g)."""
    t = np.arange(int(20 * FS)) / FS
    tone = np.sin(2 * np.pi * 85 * t)
    return Dataset.from_arrays(np.array([np.vstack([tone] * 2)]),
                               channels={"a": "uz_top_left", "b": "uz_lower_right"},
                               quantity="acceleration", units="g", sample_rate=FS,
                               base=np.array([0.1 * tone]), antialias=antialias)


def test_every_usable_record_and_its_base_is_divided_and_the_points_checked():
    response = _stated(_kaiser(0.36, 0.1))
    ds = _tone({"frequency_hz": response.frequency_hz, "gain": response.gain})
    bad = dataclasses.replace(ds.runs[0], reason="rejected")
    ds2 = dataclasses.replace(ds, runs=(ds.runs[0], bad))
    out = equalized(ds2)
    g = abs(response(85.0))[()]
    assert _amplitude(out.runs[0].data[1], 85.0)[0] == pytest.approx(1 / g, rel=1e-4)
    assert _amplitude(out.runs[0].base, 85.0)[0] == pytest.approx(0.1 / g, rel=1e-4)
    assert out.runs[1] is bad  # a rejected run is left as it is
    assert equalized(dataclasses.replace(ds, antialias="flat")) is not None

    class _Points:
        def __init__(self, f):
            self.f = f

        def used(self):
            return [type("P", (), {"f_hz": v})() for v in self.f]

    ok = stated_filter_checks(ds, _Points([80.0, 86.0]))
    assert len(ok) == 1 and ok[0].passed
    bad_check = stated_filter_checks(ds, _Points([80.0, 110.0]))[0]
    assert not bad_check.passed and "110 Hz" in bad_check.message
    assert stated_filter_checks(dataclasses.replace(ds, antialias="flat"), _Points([110.0])) == []


def test_identify_takes_the_data_sets_statement_unless_the_replay_option_overrides_it():
    from freeplayid.identification.pipeline import _stated_filter
    from freeplayid.replay import Replay

    response = _stated(_kaiser(0.36, 0.1))
    ds = _tone(response)
    g = abs(response(85.0))[()]
    out, rep = _stated_filter(ds, Replay())
    assert rep.antialias == "flat"  # divided out: the replays decimated flat
    assert _amplitude(out.runs[0].data[0], 85.0)[0] == pytest.approx(1 / g, rel=1e-4)
    out, rep = _stated_filter(ds, None)  # the plain fit reads the divided records too
    assert rep is None and _amplitude(out.runs[0].data[0], 85.0)[0] == pytest.approx(1 / g,
                                                                                    rel=1e-4)
    out, rep = _stated_filter(ds, Replay(antialias="replay"))  # the option overrides
    assert rep.antialias == "replay" and out.antialias == "replay"
    assert out.runs[0].data is ds.runs[0].data
    named = dataclasses.replace(ds, antialias="replay")
    assert _stated_filter(named, Replay())[1].antialias == "replay"
    assert _stated_filter(dataclasses.replace(ds, antialias="unknown"),
                          Replay())[1].antialias == "unknown"


# --------------------------------------------------------------------------- the base's timing
def _chirp(t, f0=30.0, rate=0.5):
    """A linear chirp from ``f0`` [Hz] at ``rate`` [Hz/s], evaluated analytically at ``t``."""
    return np.sin(2 * np.pi * (f0 * t + 0.5 * rate * t ** 2))


@pytest.mark.parametrize("samples", [0.25, -0.5, 0.75, 3.5])
def test_shifted_reads_a_band_limited_record_at_another_instant(samples):
    # reference: the chirp evaluated analytically at the shifted instants (nothing of the package)
    t = np.arange(int(30 * FS)) / FS
    advance = samples / FS
    out = shifted(_chirp(t), FS, advance)
    middle = slice(int(2 * FS), -int(2 * FS))  # the abrupt start and end are not band-limited
    assert np.max(np.abs(out - _chirp(t + advance))[middle]) < 1e-3
    assert np.max(np.abs(_chirp(t) - _chirp(t + advance))[middle]) > 0.1  # it did move
    assert shifted(_chirp(t), FS, 0.0) == pytest.approx(_chirp(t))


def test_gravity_along_the_axis_is_stated_checked_and_written(tmp_path):
    runs, kw = _small()
    path = write_dataset(tmp_path / "vertical", runs=runs, gravity_g=-1, **kw)
    assert yaml.safe_load(path.read_text())["gravity_g"] == -1.0
    assert read_dataset(path, check_model=False).gravity_g == -1.0
    m = yaml.safe_load(path.read_text())
    for bad in ("up", 1.5, True, float("inf")):
        m["gravity_g"] = bad
        path.write_text(yaml.safe_dump(m))
        with pytest.raises(DatasetError, match=r"manifest.yaml: `gravity_g` must be gravity's "
                                               r"component along the shaking axis in g, a "
                                               r"number within \+-1 \(\+1: vertical"):
            read_dataset(path, check_model=False)
    written = write_dataset(tmp_path / "horizontal", runs=runs, **kw)
    assert "gravity_g" not in yaml.safe_load(written.read_text())
    assert read_dataset(written, check_model=False).gravity_g == 0.0
    with pytest.raises(DatasetError, match="`gravity_g` must be"):
        Dataset.from_arrays(np.zeros((1, 2, 64)), channels={"a": "x", "b": "y"},
                            quantity="acceleration", units="g", sample_rate=FS, gravity_g=9.81)


def test_the_base_delay_is_stated_checked_and_written(tmp_path):
    runs, kw = _small()
    path = write_dataset(tmp_path / "late", runs=runs, base_delay_s=0.001, **kw)
    assert yaml.safe_load(path.read_text())["base_delay_s"] == 0.001
    assert read_dataset(path, check_model=False).base_delay_s == 0.001
    m = yaml.safe_load(path.read_text())
    for bad in ("1 ms", 0.5, True, float("nan")):
        m["base_delay_s"] = bad
        path.write_text(yaml.safe_dump(m))
        with pytest.raises(DatasetError, match=r"manifest.yaml: `base_delay_s` must be the base "
                                               r"channel's delay .* within \+-0.05"):
            read_dataset(path, check_model=False)
    m["base_delay_s"] = -0.002
    del m["base_channel"]
    path.write_text(yaml.safe_dump(m))
    with pytest.raises(DatasetError, match=r"manifest.yaml: `base_delay_s` is -0.002 but the "
                                           "data set has no `base_channel`"):
        read_dataset(path, check_model=False)
    written = write_dataset(tmp_path / "none", runs=runs, **kw)
    assert "base_delay_s" not in yaml.safe_load(written.read_text())
    assert read_dataset(written, check_model=False).base_delay_s == 0.0
    with pytest.raises(DatasetError, match="no `base_channel`"):
        Dataset.from_arrays(np.zeros((1, 2, 64)), channels={"a": "x", "b": "y"},
                            quantity="acceleration", units="g", sample_rate=FS,
                            base_delay_s=0.001)


def test_a_stated_delay_puts_the_base_back_into_step_and_nothing_else():
    t = np.arange(int(30 * FS)) / FS
    late = 0.25 / FS  # the base read a quarter sample late: its sample k holds the motion at
    resp = np.vstack([3 * _chirp(t)] * 2)  # t_k - late
    ds = Dataset.from_arrays([resp, resp], channels={"a": "uz_top_left", "b": "uz_lower_right"},
                             quantity="acceleration", units="g", sample_rate=FS,
                             base=[_chirp(t - late), _chirp(t - late)], base_delay_s=late)
    bad = dataclasses.replace(ds.runs[1], reason="rejected")
    out = base_aligned(dataclasses.replace(ds, runs=(ds.runs[0], bad)))
    middle = slice(int(2 * FS), -int(2 * FS))
    assert np.max(np.abs(out.runs[0].base - _chirp(t))[middle]) < 1e-3
    assert out.runs[0].data is ds.runs[0].data and out.runs[1] is bad
    assert base_aligned(dataclasses.replace(ds, base_delay_s=0.0)).runs[0].base is \
        ds.runs[0].base


def test_identify_reads_the_base_shifted_by_the_stated_delay():
    from freeplayid import identify
    from freeplayid.io import bundled_example

    example = read_dataset(bundled_example())
    example = dataclasses.replace(example, runs=tuple(
        r for r in example.runs if r.level_g in (0.8, 1.2)))
    late = 0.5 / example.sample_rate
    skewed = dataclasses.replace(example, runs=tuple(
        dataclasses.replace(r, base=shifted(r.base, example.sample_rate, -late))
        for r in example.runs))
    opts = dict(progress=False, replay=None, records=None, fit={"multistart": {"n": 3}})

    def amplitudes(ds):
        res = identify(ds, **opts)
        return np.array([p.amplitude_m for p in res.points.points]), res

    ref, _ = amplitudes(example)
    unstated, _ = amplitudes(skewed)
    stated, res = amplitudes(dataclasses.replace(skewed, base_delay_s=late))
    assert np.max(np.abs(unstated / ref - 1)) > 1e-3  # half a sample moves the points
    assert stated == pytest.approx(ref, rel=1e-4)
    assert res.dataset["base_delay_s"] == late
    assert "base channel's timing: 1.953 ms (0.5 sample) late" in res.report()

import numpy as np
import pytest

from freeplayid.io import DatasetError, Run, read_dataset, write_dataset
from freeplayid.model import load_system, sdof_system


def _runs():
    t = np.arange(200) / 100.0
    rng = np.random.default_rng(0)
    return [
        Run(file=f"sweep_{lv:.2f}g.csv", time=t, data=rng.normal(size=(2, t.size)) * lv,
            level_g=lv, sweep={"start_hz": 30.0, "stop_hz": 50.0, "rate_hz_per_s": 0.1},
            base=np.sin(t))
        for lv in (0.4, 0.6)
    ]


def test_round_trip(tmp_path):
    runs = _runs()
    system = sdof_system(mass=2.0, damping=1.0)
    manifest = write_dataset(
        tmp_path / "ds", name="test set", quantity="acceleration", units="g", sample_rate=100.0,
        channels={"acc_a": "x", "acc_b": "x"}, runs=runs, system=system, base_channel="acc_base",
    )
    assert manifest.name == "manifest.yaml"
    assert not list((tmp_path / "ds").glob("*.tmp"))
    ds = read_dataset(tmp_path / "ds")
    assert ds.name == "test set" and ds.quantity == "acceleration" and ds.units == "g"
    assert ds.sample_rate == 100.0 and ds.channels == {"acc_a": "x", "acc_b": "x"}
    assert ds.base_channel == "acc_base"
    for a, b in zip(ds.runs, runs, strict=True):
        assert a.file == b.file and a.level_g == b.level_g and a.sweep == b.sweep
        np.testing.assert_allclose(a.time, b.time, rtol=1e-9)
        np.testing.assert_allclose(a.data, b.data, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(a.base, b.base, rtol=1e-9, atol=1e-12)
    assert load_system(ds.model).fingerprint() == system.fingerprint()
    # without sample_rate in the manifest, the time column defines it
    text = manifest.read_text().replace("sample_rate: 100.0\n", "")
    manifest.write_text(text)
    assert read_dataset(manifest).sample_rate == pytest.approx(100.0)


def test_errors_name_the_problem(tmp_path):
    runs = _runs()
    with pytest.raises(DatasetError, match="units"):
        write_dataset(tmp_path, name="x", quantity="velocity", units="g", sample_rate=1.0,
                      channels={"v": "x"}, runs=runs)
    with pytest.raises(DatasetError, match="shape"):
        write_dataset(tmp_path, name="x", quantity="acceleration", units="g", sample_rate=100.0,
                      channels={"a": "x"}, runs=runs)
    write_dataset(tmp_path / "ok", name="x", quantity="acceleration", units="m/s^2",
                  sample_rate=100.0, channels={"a": "x", "b": "x"}, runs=runs)
    (tmp_path / "ok" / "sweep_0.40g.csv").unlink()
    with pytest.raises(DatasetError, match="not found"):
        read_dataset(tmp_path / "ok" / "manifest.yaml")
    with pytest.raises(DatasetError, match="manifest not found"):
        read_dataset(tmp_path / "nothing")

"""The controller-export samples in examples/exports/: each layout reads as the same run written
as plain CSV, states its units (checked against the manifest), and is what make_exports.py
writes."""

import importlib.util
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from freeplayid.io import DatasetError, read_dataset

EXPORTS = Path(__file__).resolve().parents[1] / "examples" / "exports"
LAYOUTS = ["csv_semicolon", "mat_v5", "mat_v73", "uff", "uff_58b", "tdms"]


def _make_exports():
    spec = importlib.util.spec_from_file_location("make_exports", EXPORTS / "make_exports.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_reference_is_the_script_signal():
    t, cols = _make_exports().signals()
    ref = read_dataset(EXPORTS / "reference")
    run = ref.runs[0]
    assert ref.sample_rate == 256.0 and run.reason == "" and run.time.size == 512
    np.testing.assert_allclose(run.time, t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.data, np.vstack([cols["acc_tl"], cols["acc_lr"]]),
                               rtol=1e-8, atol=1e-9)  # 9 significant digits in the CSV
    np.testing.assert_allclose(run.base, cols["acc_base"], rtol=1e-8, atol=1e-9)


@pytest.mark.parametrize("layout", LAYOUTS)
def test_each_export_reads_as_the_plain_csv(layout):
    if layout == "mat_v73":
        pytest.importorskip("h5py")
    ref = read_dataset(EXPORTS / "reference")
    ds = read_dataset(EXPORTS / layout)
    assert (ds.quantity, ds.units, ds.sample_rate) == (ref.quantity, ref.units, ref.sample_rate)
    assert list(ds.channels.values()) == list(ref.channels.values())
    a, b = ds.runs[0], ref.runs[0]
    assert a.reason == b.reason == "" and a.sweep == b.sweep and a.level_g == b.level_g
    np.testing.assert_allclose(a.time, b.time, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.data, b.data, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(a.base, b.base, rtol=1e-8, atol=1e-9)


@pytest.mark.parametrize("layout", LAYOUTS)
def test_each_export_states_its_units(tmp_path, layout):
    """Declared in m/s^2, every sample is refused: its file says g."""
    if layout == "mat_v73":
        pytest.importorskip("h5py")
    folder = tmp_path / layout
    shutil.copytree(EXPORTS / layout, folder)
    m = yaml.safe_load((folder / "manifest.yaml").read_text())
    m["units"] = "m/s^2"
    m["model"] = str((EXPORTS / layout / m["model"]).resolve())
    (folder / "manifest.yaml").write_text(yaml.safe_dump(m, sort_keys=False))
    first = next(iter(m["channels"]))
    with pytest.raises(DatasetError) as info:
        read_dataset(folder)
    run_file = folder / m["runs"][0]["file"]
    assert str(info.value) == (f"{run_file}: channel {first!r}: the file says 'g', the manifest "
                               "says 'm/s^2' (acceleration); if the file is right, set `units: g` "
                               "in the manifest")


def test_the_samples_are_what_the_script_writes(tmp_path):
    _make_exports().main(out=tmp_path)
    for layout in ["reference", *LAYOUTS]:
        new = tmp_path / layout
        m = yaml.safe_load((new / "manifest.yaml").read_text())
        assert m == yaml.safe_load((EXPORTS / layout / "manifest.yaml").read_text())
        m["model"] = str((EXPORTS / layout / m["model"]).resolve())
        (new / "manifest.yaml").write_text(yaml.safe_dump(m, sort_keys=False))
        a, b = read_dataset(new).runs[0], read_dataset(EXPORTS / layout).runs[0]
        # the binary layouts keep every bit of np.sin, whose last bits differ between machines
        # (SIMD or libm: 1.8e-13 at a 400 rad phase, seen on a fresh CI host); the text layouts
        # keep 9 digits
        np.testing.assert_allclose(a.data, b.data, rtol=1e-11, atol=0)
        np.testing.assert_allclose(a.base, b.base, rtol=1e-11, atol=0)

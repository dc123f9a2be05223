"""The built wheel works without the source tree: its package data (the default fin) included.

The wheel is built offline from a copy of this checkout (``pip wheel --no-deps
--no-build-isolation``; the ``dev`` extra brings setuptools and wheel), installed with
``pip install --target`` into a bare folder, and used from a subprocess whose working directory
and ``PYTHONPATH`` hold only that folder, so neither the checkout (pytest's ``pythonpath = src``,
an inherited ``PYTHONPATH``) nor an editable install of it can be imported instead.
"""

import json
import os
import shutil
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _pip(*args) -> None:
    cmd = [sys.executable, "-m", "pip", "--disable-pip-version-check", "--no-input", *args]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, f"{cmd}\n{proc.stdout[-2000:]}{proc.stderr[-3000:]}"


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel of this checkout, built offline from a copy (an in-tree build would write
    build/ and *.egg-info into the checkout)."""
    tmp = tmp_path_factory.mktemp("wheel")
    tree = tmp / "tree"
    tree.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, tree / name)
    shutil.copytree(ROOT / "src", tree / "src",
                    ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    _pip("wheel", "--no-deps", "--no-build-isolation", "--no-index", "-w", tmp / "dist", tree)
    shutil.rmtree(tree)  # nothing of the sources is left next to the install
    (whl,) = (tmp / "dist").glob("freeplayid-*.whl")
    return whl


@pytest.fixture(scope="module")
def site(wheel) -> Path:
    """The wheel installed into a bare folder (no conf/, no src/, no examples/)."""
    target = wheel.parents[1] / "site"
    _pip("install", "--no-deps", "--no-index", "--target", target, wheel)
    return target


def run_installed(site: Path, code: str) -> str:
    """Run ``code`` with this interpreter in the installed wheel only; return its stdout.

    The working directory is an empty folder next to the install and ``PYTHONPATH`` is the
    install folder alone (an inherited one, e.g. the checkout's ``src``, is dropped). Before
    ``code``, the snippet checks that ``freeplayid`` is imported from the install, not from the
    checkout or an editable install of it. A failing snippet fails the test with its stderr.
    """
    cwd = site.parent / "work"
    cwd.mkdir(exist_ok=True)
    drop = ("PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP", "PYTHONSAFEPATH")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    env.update(PYTHONPATH=str(site), PYTHONNOUSERSITE="1")
    guard = textwrap.dedent(f"""
        import pathlib, freeplayid
        _where = pathlib.Path(freeplayid.__file__).resolve()
        assert _where.is_relative_to(pathlib.Path({str(site.resolve())!r})), \\
            f"freeplayid imported from {{_where}}, not from the installed wheel"
    """)
    proc = subprocess.run([sys.executable, "-c", guard + textwrap.dedent(code)], cwd=cwd, env=env,
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return proc.stdout


def test_wheel_ships_the_default_fin(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    assert "freeplayid/model/fin/fin.yaml" in names
    assert not any(n.startswith(("conf/", "tests/", "scripts/")) for n in names)


def test_default_fin_from_the_wheel(site, tmp_path):
    """default_fin() of the installed wheel, with no conf/ anywhere, is the checkout's fin."""
    out = tmp_path / "fin.npz"
    stdout = run_installed(site, f"""
        import json
        import numpy as np
        from freeplayid.model import default_fin, default_fin_parameters, fin_config_path

        fin = default_fin()
        np.savez({str(out)!r}, M=fin.M, K=fin.K, names=np.array(fin.dof_names))
        print(json.dumps({{"params": default_fin_parameters(), "yaml": str(fin_config_path())}}))
    """)
    report = json.loads(stdout.strip().splitlines()[-1])
    assert report["params"] == {"kn": 480.0, "delta": 0.003}
    assert Path(report["yaml"]).resolve().is_relative_to(site.resolve())

    from freeplayid.model import default_fin, fin_config_path

    assert Path(fin_config_path()).resolve().is_relative_to(ROOT / "src")  # the reference
    ref = default_fin()
    got = np.load(out)
    assert list(got["names"]) == list(ref.dof_names)
    for name in ("M", "K"):
        a, b = got[name], getattr(ref, name)
        assert a.shape == b.shape == (12, 12)
        assert np.linalg.norm(a - b) <= 1e-12 * np.linalg.norm(b), name


@pytest.fixture(scope="module")
def sdof_data(tmp_path_factory) -> Path:
    """A small simulated data set (SDOF, four levels, absolute accelerations with the base
    channel) written by the checkout: the wheel gets it by path, like a user's data."""
    import torch

    from freeplayid.io import write_dataset
    from freeplayid.model import sdof_system
    from freeplayid.simulate import Sweep, simulate_sweeps, sweep_dataset

    system = sdof_system(mass=23.8, damping=598.0)
    res = simulate_sweeps(system, kn=2.35e6, delta=1.2e-4, level_g=[0.4, 0.6, 0.8, 1.0],
                          sweep=Sweep(30.0, 50.0, 1.0), channels=["x"], quantity="acceleration",
                          frame="absolute", sample_rate=512.0, dtype=torch.float64,
                          progress=False)
    ds = sweep_dataset(res, columns={"acc_x": "x"})
    folder = tmp_path_factory.mktemp("sdof_data")
    return write_dataset(folder, name=ds.name, quantity=ds.quantity, units=ds.units,
                         sample_rate=ds.sample_rate, channels=ds.channels, runs=ds.runs,
                         system=system, base_channel=ds.base_channel, truth=ds.truth)


MULTISTART = {"n": 3, "kn_range": (1e5, 1e8), "delta_range": (1e-5, 1e-3)}


def test_identify_from_the_wheel(site, sdof_data):
    from freeplayid import identify

    stdout = run_installed(site, f"""
        import json
        from freeplayid import identify
        result = identify({str(sdof_data)!r}, fit={{"multistart": {MULTISTART!r}}},
                          progress=False, replay=None)
        print(json.dumps({{"kn": result.kn, "delta": result.delta}}))
    """)
    found = json.loads(stdout.strip().splitlines()[-1])
    ref = identify(sdof_data, progress=False, fit={"multistart": MULTISTART}, replay=None)
    assert found["kn"] == pytest.approx(ref.kn, rel=1e-9)
    assert found["delta"] == pytest.approx(ref.delta, rel=1e-9)
    assert found["kn"] == pytest.approx(2.35e6, rel=0.02)

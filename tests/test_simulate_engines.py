"""The engine registry: names, the "auto" rule, validation from declared capabilities, and an
engine registered from outside that ``simulate_sweeps`` runs without an edit."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from freeplayid.model import sdof_system
from freeplayid.simulate import StreamingDecimator, Sweep, simulate_sweeps
from freeplayid.simulate.engines import ENGINES, TorchRK4, numba_available, resolve_engine
from freeplayid.simulate.engines.protocol import rk4_max_step

CPU, CUDA = torch.device("cpu"), torch.device("cuda")


def _run(engine, **kw):
    system = sdof_system(mass=23.8, damping=598.0)
    args = dict(kn=[2.35e6, 1e18], delta=1.2e-4, level_g=[0.6, 1.0],
                sweep=Sweep(40.0, 44.0, 0.5), channels=["x"], sample_rate=256.0,
                dtype=torch.float64, frame="relative", quantity="displacement",
                steps_per_sample=8, device="cpu", engine=engine)
    return simulate_sweeps(system, **{**args, **kw})


class _Records:
    """A raw-record engine: the torch RK4 under another name."""

    devices = ("cpu",)
    quasi_static = False
    decimates = False
    differentiates = False
    max_step = staticmethod(rk4_max_step)
    chunks = 0

    def __init__(self, setup):
        s = setup
        self.rk4 = TorchRK4(s.form, s.kn, s.delta, s.level_g, s.eta0, s.v0, h=s.h,
                            quantity=s.quantity, dtype=s.dtype, device=s.device,
                            cuda_graphs=False)
        self.record_width = s.form.n_modes

    @classmethod
    def available(cls):
        return True

    def run(self, s_half, out=None):
        assert out is None
        type(self).chunks += 1
        return self.rk4.run(s_half)

    @property
    def diverged(self):
        return self.rk4.diverged


class _InPlace(_Records):
    """An engine that decimates itself, into the caller's signal array."""

    decimates = True

    def __init__(self, setup):
        super().__init__(setup)
        self.dec = StreamingDecimator(setup.taps, setup.factor, dtype=setup.dtype,
                                      device=setup.device)
        self.col = 0

    def run(self, s_half, out=None):
        type(self).chunks += 1
        rec = self.rk4.run(s_half)
        batch, C, L = rec.shape
        y = self.dec.push(rec.reshape(batch * C, L)).reshape(batch, C, -1).numpy()
        k = min(y.shape[-1], out.shape[-1] - self.col)
        out[:, :, self.col : self.col + k] = y[..., :k]
        self.col += y.shape[-1]
        return y.shape[-1]


def test_unknown_engine_lists_the_valid_names(monkeypatch):
    with pytest.raises(ValueError, match=r"`engine` must be one of \('auto', 'torch', 'numba', "
                                         r"'expo'\), got 'jax'"):
        _run("jax")
    monkeypatch.setitem(ENGINES, "fake", _Records)
    with pytest.raises(ValueError, match=r"\('auto', 'torch', 'numba', 'expo', 'fake'\), got 'jx'"):
        resolve_engine("jx", device=CPU)


def test_auto_picks_numba_on_the_cpu_and_torch_elsewhere():
    cpu = "numba" if numba_available() else "torch"
    assert resolve_engine("auto", device=CPU)[0] == cpu
    assert resolve_engine("auto", device=CPU, quasi_static=True)[0] == cpu
    assert resolve_engine("auto", device=CUDA) == ("torch", ENGINES["torch"])
    assert _run("auto").engine == cpu


def test_capabilities_decide_device_and_quasi_static():
    with pytest.raises(ValueError, match=r"`engine`='numba' runs on the CPU only, got device cuda"):
        resolve_engine("numba", device=CUDA)
    with pytest.raises(NotImplementedError, match=r"`quasi_static_hz` is implemented in the "
                                                  r"numba engine only, got engine='torch'"):
        resolve_engine("torch", device=CPU, quasi_static=True)


def test_no_device_on_a_gpu_machine_keeps_a_cpu_engine_on_the_cpu(monkeypatch):
    # found on an H200: the replay names engine="expo" and no device, and the default device
    # (CUDA when present) made every identify with the replay fail there. And "auto" with numba
    # installed stays on the CPU: train.py's bank ran there on the torch engine on the GPU over
    # 10x slower than numba on 2 cores
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    chosen = {}

    class Chosen(Exception):
        pass

    def spy(name, *, device, quasi_static=False):
        chosen[name, quasi_static] = device.type
        raise Chosen

    monkeypatch.setattr("freeplayid.simulate.run.resolve_engine", spy)
    for engine in ("numba", "expo", "torch", "auto"):
        with pytest.raises(Chosen):
            _run(engine, device=None)
    with pytest.raises(Chosen):
        _run("auto", device=None, quasi_static_hz=1000.0)
    auto = "cpu" if numba_available() else "cuda"
    assert chosen == {("numba", False): "cpu", ("expo", False): "cpu", ("torch", False): "cuda",
                      ("auto", False): auto, ("auto", True): "cpu"}
    # without numba, "auto" is the torch engine, and it goes to the GPU
    monkeypatch.setattr(ENGINES["numba"], "available", classmethod(lambda cls: False))
    chosen.clear()
    with pytest.raises(Chosen):
        _run("auto", device=None)
    assert chosen == {("auto", False): "cuda"}


@pytest.mark.parametrize("fake", [_Records, _InPlace])
def test_a_registered_engine_runs_without_editing_simulate_sweeps(monkeypatch, fake):
    # both output paths (records decimated by the caller, outputs written in place) with an
    # engine that simulate_sweeps has never heard of; the same arithmetic as the torch engine,
    # so the same bits (the relative displacement has no base terms to add)
    if fake.decimates and not numba_available():
        pytest.skip("the in-place path adds the base terms with a numba pass")
    monkeypatch.setitem(ENGINES, "fake", fake)
    monkeypatch.setattr(fake, "chunks", 0)
    ref = _run("torch")
    got = _run("fake")
    assert got.engine == "fake" and fake.chunks > 0
    assert got.diverged.tolist() == ref.diverged.tolist() == [False, True]
    assert np.abs(ref.signals[0]).max() > 0
    np.testing.assert_array_equal(got.signals, ref.signals)
    # its declared capabilities are what validation checks
    with pytest.raises(NotImplementedError, match=r"implemented in the numba engine only, got "
                                                  r"engine='fake'"):
        _run("fake", quasi_static_hz=1000.0)
    with pytest.raises(ValueError, match=r"`engine`='fake' runs on the CPU only, got device meta"):
        _run("fake", device="meta")


def test_the_engine_sets_the_step(monkeypatch):
    # simulate_sweeps asks the engine for its step (Engine.max_step) and runs at the largest
    # whole fraction of the output interval not above it; omega_dt reaches the rule as given
    asked = []

    class _Step(_Records):
        @staticmethod
        def max_step(form, *, sweep, kn_max, omega_dt, distinct_kn):
            asked.append((sweep.stop_hz, kn_max, omega_dt, distinct_kn))
            return 1.0 / (256.0 * 4.5)

    monkeypatch.setitem(ENGINES, "step", _Step)
    r = _run("step", steps_per_sample=None, omega_dt=0.7, sweep=Sweep(40.0, 41.0, 0.5))
    assert asked == [(41.0, 1e18, 0.7, 2)]  # two distinct kn
    assert r.steps_per_sample == 5 and r.dt == 1.0 / (256.0 * 5)


def test_the_registry_imports_no_kernel():
    # numba is optional and its kernels compile on first use: importing the simulator and its
    # registry imports no kernel module (nor numba); building an engine imports its kernels
    code = ("import sys; import freeplayid.simulate; from freeplayid.simulate.engines import "
            "ENGINES, MODES, BLOWUP; print(sorted(m for m in sys.modules if m == 'numba' or "
            "m.startswith('freeplayid.simulate.engines.') and m.split('.')[-1] in ('rk4', "
            "'rk4_qs', 'kernel', 'arith', 'fir', 'jit')))")
    src = str(Path(__file__).resolve().parents[1] / "src")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([src, os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"

"""The chunked integration loop gives the same record as one chunk (the FIR state carries over)."""

import numpy as np
import pytest
import torch

import freeplayid.simulate.chunks as chunks
from freeplayid.model import sdof_system
from freeplayid.simulate import Sweep, simulate_sweeps


@pytest.mark.parametrize("engine", ["numba", "torch"])
def test_chunk_boundaries_do_not_change_the_record(monkeypatch, engine):
    system = sdof_system(mass=23.8, damping=598.0)
    kw = dict(kn=2.35e6, delta=1.2e-4, level_g=[0.6, 1.0], sweep=Sweep(40.0, 44.0, 2.0),
              channels=["x"], sample_rate=256.0, dtype=torch.float64, engine=engine,
              frame="relative", steps_per_sample=32)  # a real FIR (factor 32)
    whole = simulate_sweeps(system, **kw).signals
    monkeypatch.setattr(chunks, "MAX_CHUNK_STEPS", 320)  # 10-sample chunks
    chunked = simulate_sweeps(system, **kw).signals
    assert np.abs(whole).max() > 0
    np.testing.assert_allclose(chunked, whole, rtol=0, atol=1e-9 * np.abs(whole).max())


def test_quasi_static_kernel_chunk_boundaries_do_not_change_the_record(monkeypatch):
    from freeplayid.model import default_fin

    kw = dict(kn=480.0, delta=3e-3, level_g=[1.0], sweep=Sweep(40.0, 41.0, 2.0),
              channels=["uz_top_left"], sample_rate=256.0, dtype=torch.float64, engine="numba",
              frame="relative", quasi_static_hz=1500.0)
    fin = default_fin()
    whole = simulate_sweeps(fin, **kw).signals
    monkeypatch.setattr(chunks, "MAX_CHUNK_STEPS", 200)
    chunked = simulate_sweeps(fin, **kw).signals
    assert np.abs(whole).max() > 0
    np.testing.assert_allclose(chunked, whole, rtol=0, atol=1e-9 * np.abs(whole).max())

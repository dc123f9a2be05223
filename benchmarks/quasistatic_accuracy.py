"""Accuracy of the quasi-static condensation (``quasi_static_hz``) against the full model.

    PYTHONPATH=src python benchmarks/quasistatic_accuracy.py [--start 36 --stop 48] [--float32]

Default fin at its configured (kn, delta), levels 0.6-1.2 g, the paper's 0.1 Hz/s sweep; the
backbone fitting points (``extract_backbone_points``: frequency and first-harmonic displacement
amplitude at the resonance peak) of the relative displacement and of the absolute acceleration of
both channels, full model (default step) vs condensed at several thresholds.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import torch

from freeplayid.model import default_fin, default_fin_parameters
from freeplayid.signal import extract_backbone_points
from freeplayid.simulate import Sweep, simulate_sweeps

CH = ("uz_top_left", "uz_lower_right")
LEVELS = [0.6, 0.8, 1.0, 1.2]  # g
FMT = {"float": lambda x: f"{x:+.1e}"}


def points(r, quantity, frame, sweep):
    base = None
    if frame == "absolute":  # the extractor wants motion relative to the base
        from freeplayid.simulate import G

        base = (np.asarray(r.level_g)[:, None] * G * np.sin(sweep.phase(r.time))[None, :])
    bp = extract_backbone_points(r.signals.astype(float), r.sample_rate, quantity=quantity,
                                 channel_names=CH, sweep=sweep, base=base, require_jump=False)
    return np.array([[p.f_hz, p.amplitude_m] for p in bp.points])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--start", type=float, default=36.0)
    p.add_argument("--stop", type=float, default=48.0)
    p.add_argument("--float32", action="store_true")
    p.add_argument("--cache", default="", help="folder to keep the full-model points in")
    p.add_argument("--thresholds", type=float, nargs="+", default=[1500.0, 1000.0, 600.0])
    a = p.parse_args()
    system, hinge = default_fin(), default_fin_parameters()
    sw = Sweep(a.start, a.stop, 0.1)
    dt = torch.float32 if a.float32 else torch.float64
    print(f"sweep {sw}, levels {LEVELS} g, {dt}")
    for quantity, frame in (("displacement", "relative"), ("acceleration", "absolute")):
        kw = dict(kn=hinge["kn"], delta=hinge["delta"], level_g=LEVELS, sweep=sw, channels=CH,
                  quantity=quantity, frame=frame, dtype=dt, progress=False)
        t0 = time.perf_counter()
        cache = Path(a.cache) / f"ref_{quantity}_{sw.start_hz:g}_{sw.stop_hz:g}_{str(dt)[6:]}.npy"
        if a.cache and cache.exists():
            ref = np.load(cache)
        else:
            ref = points(simulate_sweeps(system, **kw), quantity, frame, sw)
            if a.cache:
                np.save(cache, ref)
        print(f"\n{quantity}/{frame}: full model {time.perf_counter() - t0:.1f} s; "
              f"peaks f [Hz] {np.round(ref[:, 0], 3).tolist()}", flush=True)
        for th in a.thresholds:
            t0 = time.perf_counter()
            r = simulate_sweeps(system, **kw, quasi_static_hz=th)
            el = time.perf_counter() - t0
            pt = points(r, quantity, frame, sw)
            ef = np.abs(pt[:, 0] / ref[:, 0] - 1)
            ea = np.abs(pt[:, 1] / ref[:, 1] - 1)
            print(f"  qs {th:6.0f} Hz ({r.quasi_static.slow}/{r.quasi_static.total} modes, "
                  f"dt {r.dt * 1e6:.0f} us, {el:.1f} s): max |df/f| {ef.max():.2e}, "
                  f"max |dA/A| {ea.max():.2e}\n    per point df/f "
                  f"{np.array2string(pt[:, 0] / ref[:, 0] - 1, formatter=FMT)}\n    dA/A "
                  f"{np.array2string(pt[:, 1] / ref[:, 1] - 1, formatter=FMT)}", flush=True)


if __name__ == "__main__":
    main()

"""Regenerate the bundled example data set (about 2 min on one core): the package data
``src/freeplayid/data/fin_sweeps/`` (``examples/fin_sweeps`` links to it).

    PYTHONPATH=src python examples/make_example.py [--out src/freeplayid/data/fin_sweeps]

Five up-sweeps of the default fin (freeplayid/model/fin/fin.yaml) at its own hinge values, absolute
accelerations of the two measure points and of the base (control accelerometer) in g, with white
measurement noise on every channel, a fixed seed, and the truth written into the manifest.
The 0.4 g run stays in the gap (no resonance): the identification rejects it with its reason.
The manifest also carries the ``reference_modes`` of the sealed fin (the zero-clearance check).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import yaml

from freeplayid.io import Run, atomic_write_text, write_dataset
from freeplayid.model import default_fin, default_fin_parameters, modal_analysis
from freeplayid.simulate import G, Sweep, simulate_sweeps

LEVELS_G = (0.4, 0.6, 0.8, 1.0, 1.2)  # base acceleration amplitudes [g]; 0.4 g stays in the gap
SWEEP = Sweep(start_hz=30.0, stop_hz=46.5, rate_hz_per_s=0.1)  # [Hz], [Hz], [Hz/s]: 165 s
SAMPLE_RATE = 256.0  # [Hz]; the simulator's anti-aliasing filter passes up to 77 Hz
NOISE_STD_G = 0.05  # white measurement noise on every channel [g]
SEED = 2026
CHANNELS = {"acc_tl": "uz_top_left", "acc_lr": "uz_lower_right"}  # CSV column -> model DOF


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "src" / "freeplayid"
                                         / "data" / "fin_sweeps"))
    ap.add_argument("--noise", type=float, default=NOISE_STD_G, help="noise std [g]")
    ap.add_argument("--sweep", type=float, nargs=3, default=None, help="start stop rate")
    ap.add_argument("--levels", type=float, nargs="+", default=LEVELS_G, help="[g]")
    ap.add_argument("--fs", type=float, default=SAMPLE_RATE, help="sample rate [Hz]")
    args = ap.parse_args()
    out = Path(args.out)
    sweep = SWEEP if args.sweep is None else Sweep(*args.sweep)
    levels, noise, sample_rate = tuple(args.levels), args.noise, args.fs
    fin, truth = default_fin(), default_fin_parameters()
    import torch

    res = simulate_sweeps(
        fin, kn=truth["kn"], delta=truth["delta"], level_g=list(levels), sweep=sweep,
        channels=list(CHANNELS.values()), quantity="acceleration", frame="absolute",
        sample_rate=sample_rate, dtype=torch.float64, progress=True,
    )
    assert not res.diverged.any()
    rng = np.random.default_rng(SEED)
    hint = {"start_hz": sweep.start_hz, "stop_hz": sweep.stop_hz,
            "rate_hz_per_s": sweep.rate_hz_per_s}
    runs = []
    for i, level in enumerate(levels):
        data = res.signals[i] / G + rng.normal(0.0, noise, res.signals[i].shape)
        base = sweep.acceleration(res.time, level) / G + rng.normal(0.0, noise, res.time.size)
        runs.append(Run(file=f"sweep_{level:.2f}g.csv.gz", time=res.time, data=data, level_g=level,
                        sweep=hint, base=base))
    manifest = write_dataset(
        out, name="default fin, simulated (examples/make_example.py)", quantity="acceleration",
        units="g", sample_rate=sample_rate, channels=CHANNELS, runs=runs, system=fin,
        base_channel="acc_base", truth=truth, float_format="%.5g", time_format="%.6f",
    )
    add_reference_modes(manifest, fin, truth["kn"])
    size = sum(p.stat().st_size for p in out.iterdir())
    print(f"wrote {manifest} ({size / 1e6:.2f} MB)")


def add_reference_modes(manifest: Path, fin, kn: float, n_modes: int = 3) -> None:
    """The manifest's ``reference_modes``: the first modes of the fin with its clearance sealed
    (the model closed at the true kn) at the two accelerometers, as a hammer test of the sealed
    fin would give them; identify.py then runs the zero-clearance check (Table 11)."""
    modes = modal_analysis(fin.M, fin.closed_stiffness(kn))
    rows = fin.dof_index(list(CHANNELS.values()))
    ref = []
    for k in range(n_modes):
        phi = modes.shapes[rows, k] / np.max(np.abs(modes.shapes[rows, k]))
        ref.append({"frequency_hz": round(float(modes.frequencies_hz[k]), 3),
                    "shape": {d: round(float(v), 4) for d, v in zip(CHANNELS.values(), phi,
                                                                     strict=True)}})
    m = yaml.safe_load(manifest.read_text())
    m["reference_modes"] = {"modes": ref}
    atomic_write_text(manifest, yaml.safe_dump(m, sort_keys=False))


if __name__ == "__main__":
    main()

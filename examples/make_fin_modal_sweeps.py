"""Regenerate the example sweeps of the modal-test fin, ``examples/fin_modal/sweeps/`` (a minute).

    PYTHONPATH=src python examples/make_fin_modal_sweeps.py [--out examples/fin_modal/sweeps]

The README's "Your own fin" with a simulator in place of the shaker: step 1, ``scripts/model.py``
(the default fin updated against ``examples/fin_modal/modal.yaml``), gives the linear model, and
``scripts/simulate.py`` sweeps that model with hinge freeplay (``KN``, ``DELTA`` below) as a test
would record it: up-sweeps at three levels, absolute accelerations of the two measure points and
of the base, white noise on the measure points. Both commands run as a user would run them (in a
temporary folder); the data set is then written again small (5 significant digits, gzipped CSV)
with its truth and the ``reference_modes`` of the sealed fin (step 1's model closed at ``KN``, at
the two accelerometers, as a hammer test of the sealed fin would give them), so that step 3,
``python scripts/identify.py data=examples/fin_modal/sweeps/manifest.yaml``, also runs the
zero-clearance check.
"""

from __future__ import annotations

import argparse
import dataclasses
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

from freeplayid.atomic import atomic_write_text
from freeplayid.io import read_dataset, write_dataset
from freeplayid.model import load_system, modal_analysis

ROOT = Path(__file__).resolve().parents[1]
KN, DELTA = 520.0, 2.5e-3  # the "measured" fin's hinge: contact stiffness [N m/rad], half-gap [rad]
LEVELS_G = (0.7, 0.9, 1.1)  # base levels [g]: level / delta 280-440 g/rad, all resonate
SWEEP = {"start_hz": 34.0, "stop_hz": 50.0, "rate_hz_per_s": 0.5}  # 32 s up-sweeps
SAMPLE_RATE = 256.0  # [Hz]
NOISE_STD_G = 0.05  # white noise on the measure points [g]
SEED = 7
CHANNELS = {"acc_tl": "uz_top_left", "acc_lr": "uz_lower_right"}  # CSV column -> model DOF
NAME = "fin of examples/fin_modal, simulated (examples/make_fin_modal_sweeps.py)"


def run(script: str, *overrides: str) -> None:
    """``python scripts/<script> overrides...`` from the checkout's root; stop on a failure."""
    cmd = [sys.executable, str(ROOT / "scripts" / script), *overrides]
    print("$", " ".join(cmd[1:]), flush=True)
    subprocess.run(cmd, cwd=ROOT, check=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "examples" / "fin_modal" / "sweeps"))
    args = ap.parse_args()
    out = Path(args.out)
    with tempfile.TemporaryDirectory() as tmp:
        model_dir, sim_dir = Path(tmp) / "fin_model", Path(tmp) / "sweeps"
        run("model.py", "modal_test=examples/fin_modal/modal.yaml",
            "updating.parameters=[outboard.E,inboard.thickness]", "plot=false",
            f"hydra.run.dir={model_dir}")
        columns = ",".join(f"{c}:{d}" for c, d in CHANNELS.items())
        run("simulate.py", "model=npz", f"model.path={model_dir / 'model.npz'}",
            f"model.hinge.kn={KN}", f"model.hinge.delta={DELTA}",
            f"levels=[{','.join(str(v) for v in LEVELS_G)}]",
            *(f"sweep.{k}={v}" for k, v in SWEEP.items()), f"sample_rate={SAMPLE_RATE}",
            f"noise_std_g={NOISE_STD_G}", f"seed={SEED}", f"channels={{{columns}}}",
            "plot=false", f"hydra.run.dir={sim_dir}")
        system = load_system(model_dir / "model.npz")
        ds = read_dataset(sim_dir / "dataset")
        runs = [dataclasses.replace(r, file=r.file.replace(".csv", ".csv.gz")) for r in ds.runs]
        manifest = write_dataset(
            out, name=NAME, quantity=ds.quantity, units=ds.units, sample_rate=ds.sample_rate,
            channels=ds.channels, runs=runs, system=system, base_channel=ds.base_channel,
            truth={"kn": KN, "delta": DELTA}, float_format="%.5g", time_format="%.6f")
    add_reference_modes(manifest, system, KN)
    size = sum(p.stat().st_size for p in out.iterdir())
    print(f"wrote {manifest} ({size / 1e3:.0f} kB)")


def add_reference_modes(manifest: Path, system, kn: float, n_modes: int = 3) -> None:
    """The manifest's ``reference_modes``: the first modes of ``system`` with its clearance
    sealed (closed at ``kn``) at the two accelerometers."""
    modes = modal_analysis(system.M, system.closed_stiffness(kn))
    rows = system.dof_index(list(CHANNELS.values()))
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

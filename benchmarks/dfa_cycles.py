"""Cost of the DFA backbone where its Newton points cycle: settled at once against run to
``max_iter``, side by side in one run.

    python benchmarks/dfa_cycles.py            # after pip install -e . (or PYTHONPATH=src)
    python benchmarks/dfa_cycles.py --repeat 5

With two hinges whose mode flips from one to the other near contact (both hinges open leave two
mechanisms), the Newton points of the unequal-hinge fixed point there swap the hinges' kappas at
every iteration and never converge. Before 2026-12-05 the loop ran them to ``max_iter`` (100),
``1 + h`` eigen-batches per iteration; now they are set at once to the iterate ``max_iter``
would have left (``freeplayid.backbone.dfa._Cycles``). The rows:

- ``settled``: the code as it is;
- ``run to max_iter``: the same call with the settling switched off (the loop before).

Models: the two-hinge beam of the realtests benchmark (18 DOF, the model file that data sets
``beam_two_hinges`` carry), the default fin (two hinges, no cycles: both rows should cost the
same) and a 3-DOF chain of two flaps in series (the test's model). Per model and kn: the
default 200-point grid, delta 1 mrad. Columns: the converged share, the eigen-batches, the wall
time per curve (best of ``--repeat``) and the largest difference between the two rows'
frequencies (relative to the curve's highest: a flipping mode's curve starts at 0 Hz) and
amplitudes (relative to each point's largest).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import freeplayid.backbone.dfa as dfa
from freeplayid.model import FreeplaySystem
from freeplayid.model.fin.fe import default_fin

sys.path.insert(0, str(Path(__file__).resolve().parent / "realtests"))


def _models() -> list[tuple[str, FreeplaySystem, float]]:
    from cases import two_hinge_beam  # benchmarks/realtests (no freeplayid simulation code)

    chain = FreeplaySystem(M=np.diag([2.0, 0.5, 0.3]), K=np.diag([5.0e4, 0.0, 0.0]),
                           dof_names=("a", "b", "c"), hinge_pairs=(("b", "a"), ("c", "b")),
                           base_influence=[1.0, 1.0, 1.0])
    return [("two-hinge beam (18 DOF)", two_hinge_beam()[0], 5000.0),
            ("default fin (12 DOF)", default_fin(), 480.0),
            ("two-flap chain (3 DOF)", chain, 4000.0)]


def _curve(system, kn, settle: bool, repeat: int):
    """(curve, eigen-batches, best wall time [s])."""
    calls = []
    eigh, original = np.linalg.eigh, dfa._Cycles.settle
    dfa.np.linalg.eigh = lambda a: calls.append(1) or eigh(a)
    if not settle:
        dfa._Cycles.settle = lambda self, active, *a: active
    try:
        best = np.inf
        for _ in range(repeat):
            calls.clear()
            t = time.perf_counter()
            bc = dfa.dfa_backbone(system, kn=kn, delta=1e-3)
            best = min(best, time.perf_counter() - t)
    finally:
        dfa.np.linalg.eigh, dfa._Cycles.settle = eigh, original
    return bc, len(calls), best


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="best of this many calls per row")
    args = ap.parse_args(argv)
    print("| model | kn [N m/rad] | converged | row | eigen-batches | ms per curve | "
          "max rel. diff. frequency | amplitude |")
    print("|---|---|---|---|---|---|---|---|")
    for name, system, kn0 in _models():
        for kn in (0.5 * kn0, kn0, 2.0 * kn0):
            new, n_new, t_new = _curve(system, kn, True, args.repeat)
            old, n_old, t_old = _curve(system, kn, False, args.repeat)
            ok = np.isfinite(old.frequency_hz) & np.isfinite(new.frequency_hz)
            top = np.max(old.frequency_hz[ok])  # relative to the curve's top (it starts at 0)
            df = np.max(np.abs(new.frequency_hz[ok] - old.frequency_hz[ok]), initial=0.0) / top
            scale = np.nanmax(old.amplitude, axis=-1, keepdims=True)
            da = np.nanmax(np.abs(new.amplitude - old.amplitude) / scale, initial=0.0)
            same = np.array_equal(new.converged, old.converged)
            conv = f"{100 * new.converged.mean():.0f} %" + ("" if same else " (differs!)")
            print(f"| {name} | {kn:g} | {conv} | settled | {n_new} | {1e3 * t_new:.1f} | "
                  f"{df:.1e} | {da:.1e} |")
            print(f"| | | | run to max_iter | {n_old} | {1e3 * t_old:.1f} | | |")


if __name__ == "__main__":
    main()

"""Where the sealed fin's modes cannot take a plate's error out of kn: the update's two forms.

    python benchmarks/sealed_forms.py           # about 2 min on one core

For the three realtests fins (benchmarks/realtests/cases.py: the default fin, fin B, fin C), one
plate's Young's modulus is scaled in the TRUE structure so that its closed mode 1 moves by
-1.5 ... +1.5 %, and the model file (the nominal fin) is updated to the true structure's three
sealed modes (their frequencies to 1 mHz and shapes at the two sensors, as the realtests
manifests give them; :func:`freeplayid.model.from_test.update_to_sealed_modes`). Printed per
case: the contact stiffness the sealed modes give with the update's default form (two stiffness
scales and kn: three parameters, fitted exactly to three modes) and with one scale (two
parameters, least squares), each against the true kn, and the one-scale fit's misfit. A third
column takes the second scale on the open-hinge model's second elastic mode instead of its lowest
(``own_scale_mode=1``): three parameters again, which fit the three modes exactly too, with
another kn. Where two exact forms give kn apart, three sealed frequencies leave that much of kn
to the form the update assumes.

The sweeps take kn from the same closed mode 1, against the updated model, so the identified kn
follows the first column closely (realtests: fin B inboard +1 %, kn +2.04 / +2.26 % against
+2.03 % here). The true structure's stiffness is built by the realtests' own FE fin (the
package's plate model with one part's modulus changed), which is how the realtests records
were made; the update knows only the nominal model and the sealed modes.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent / "realtests"))

import cases as C  # noqa: E402  (benchmarks/realtests/cases.py)

import freeplayid.model.from_test.sealed as sealed  # noqa: E402

SHIFTS = (-0.015, -0.01, -0.005, 0.005, 0.01, 0.015)
FINS = {"default fin": dict, "fin B": C._fin_b_kw, "fin C": C._fin_c_kw}


def _update(spec, *, one_scale: bool, own_scale_mode: int = 0):
    ref = spec.reference_modes
    dofs = list(C.FIN_CHANNELS.values())
    f = [m["frequency_hz"] for m in ref]
    shapes = np.array([[m["shape"][d] for m in ref] for d in dofs])
    saved = sealed.MAX_CONDITION
    if one_scale:  # every two-scale solve refused: the one-scale update
        sealed.MAX_CONDITION = 0.0
    try:
        return sealed.update_to_sealed_modes(spec.model, spec.truth["kn"], f, shapes, dofs,
                                             own_scale_mode=own_scale_mode)
    finally:
        sealed.MAX_CONDITION = saved


def _misfit(upd) -> float:
    """RMS of log(f_updated / f_ref) over the sealed modes: 0 where the update fits exactly."""
    return float(np.sqrt(np.mean(np.log(upd.after_hz / upd.reference_hz) ** 2)))


def main() -> None:
    print("| fin | plate | mode 1 shift [%] | kn, two scales (default) [%] | kn, one scale [%] "
          "| one scale's misfit [%] | kn, two scales, the second elastic mode's own [%] "
          "| its misfit [%] |")
    print("|---|---|---|---|---|---|---|---|")
    for fin, kw in FINS.items():
        for part in ("inboard", "outboard"):
            for shift in SHIFTS:
                spec = C.fin_stiffness(ref=True, shift=shift, part=part, **kw())
                kn = spec.truth["kn"]
                two, one = _update(spec, one_scale=False), _update(spec, one_scale=True)
                other = _update(spec, one_scale=False, own_scale_mode=1)
                assert two.parameters == 3 and one.parameters == 2 and other.parameters == 3
                print(f"| {fin} | {part} | {100 * shift:+.1f} | {100 * (two.kn / kn - 1):+.2f} | "
                      f"{100 * (one.kn / kn - 1):+.2f} | {100 * two.residual:.2f} | "
                      f"{100 * (other.kn / kn - 1):+.2f} | {100 * _misfit(other):.3f} |",
                      flush=True)


if __name__ == "__main__":
    main()

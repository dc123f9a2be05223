"""Can the sealed fin's mode shapes take a plate's error out of kn? Tried, and not kept.

    python benchmarks/sealed_shapes.py          # about 2 min on one core

The linear model's update to the sealed modes (:func:`freeplayid.model.from_test.
update_to_sealed_modes`) fits their three frequencies with three parameters (kn, the
structure's stiffness scale ``s``, the lowest open-hinge elastic mode's own scale ``s1``), so it
fits them exactly whatever the model's error, and where a plate alone is off it can leave kn off
by up to twice the mode's error (fin B's inboard plate: ``benchmarks/sealed_forms.py``). The
sealed modes' shapes at the sensors carry more: here they are added to the least squares as
data (each mode's shape scaled to the reference's largest component, its difference from the
reference in units of 1 % of that component), with the default form and with one more or two
more modes' own scales (the second and third open-hinge elastic modes'), on the same cases as
``sealed_forms.py``: the three realtests fins (benchmarks/realtests/cases.py), one plate's
Young's modulus moving the true closed mode 1 by -1.5 ... +1.5 %, the nominal model updated to
the true structure's three sealed modes (frequencies and shapes at the two sensors, as the
realtests manifests give them). Printed: kn's error [%] and, in brackets, the fit's RMS
residual (frequency residuals in log, shape residuals in units of 1 %).

A form that scales open-hinge modes cannot move the shapes at the sensors as a plate's modulus
does, so the shapes pull kn away: this is the measurement behind docs/identify.md's "the sealed
shapes" paragraph.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import scipy.optimize

sys.path.insert(0, str(Path(__file__).resolve().parent / "realtests"))

import cases as C  # noqa: E402  (benchmarks/realtests/cases.py)

import freeplayid.model.from_test.sealed as sealed  # noqa: E402
from freeplayid.model.modal import modal_analysis, pair_modes  # noqa: E402

SHIFTS = (-0.015, -0.01, 0.01, 0.015)
FINS = {"default fin": dict, "fin B": C._fin_b_kw, "fin C": C._fin_c_kw}
# [-] a shape component's assumed error, as a fraction of the mode's largest component
SHAPE_SIGMA = 0.01
# the open-hinge elastic modes given their own scale, the shapes as data (the frequencies-only
# column is the package's own update, update_to_sealed_modes)
FORMS = ((0,), (0, 1), (0, 1, 2))


def update(system, ref_hz, ref_shapes, dofs, kn_start, own):
    """(kn, RMS residual) of the update with the open-hinge elastic modes ``own`` scaled on their
    own, the structure's stiffness by one more scale, and the shapes as data."""
    idx = system.dof_index(list(dofs))
    parts = [sealed._elastic_stiffness(system, k) for k in own]
    pairing, _ = pair_modes(ref_shapes, modal_analysis(system.M, system.closed_stiffness(
        kn_start)).shapes[idx, :])

    def residual(x):
        s = np.exp(x[1])
        K = s * system.K + sum((np.exp(v) - s) * p for v, p in zip(x[2:], parts, strict=True))
        modes = modal_analysis(system.M, sealed._closed(system, K, np.exp(x[0])))
        out = [np.log(modes.frequencies_hz[pairing] / ref_hz)]
        for k in range(ref_hz.size):
            a, b = ref_shapes[:, k], modes.shapes[idx, pairing[k]]
            i = int(np.argmax(np.abs(a)))
            out.append((b / b[i] * a[i] - a) / (SHAPE_SIGMA * abs(a[i])))
        return np.concatenate(out)

    sol = scipy.optimize.least_squares(residual, np.r_[np.log(kn_start), np.zeros(1 + len(own))])
    return float(np.exp(sol.x[0])), float(np.sqrt(np.mean(sol.fun ** 2)))


def main() -> None:
    print("| fin | plate | mode 1 shift [%] | frequencies only (the default) | + shapes | "
          "+ shapes, elastic modes 1-2 own scales | + shapes, modes 1-3 |")
    print("|---|---|---|---|---|---|---|")
    dofs = list(C.FIN_CHANNELS.values())
    for fin, kw in FINS.items():
        for part in ("inboard", "outboard"):
            for shift in SHIFTS:
                spec = C.fin_stiffness(ref=True, shift=shift, part=part, **kw())
                kn, ref = spec.truth["kn"], spec.reference_modes
                f = np.array([m["frequency_hz"] for m in ref])
                S = np.array([[m["shape"][d] for m in ref] for d in dofs])
                default = sealed.update_to_sealed_modes(spec.model, kn, f, S, dofs)
                rms = float(np.sqrt(np.mean(np.log(default.after_hz / default.reference_hz) ** 2)))
                cells = [f"{100 * (default.kn / kn - 1):+.2f} ({rms:.2g})"]
                for own in FORMS:
                    k, rms = update(spec.model, f, S, dofs, kn, own)
                    cells.append(f"{100 * (k / kn - 1):+.2f} ({rms:.2g})")
                print(f"| {fin} | {part} | {100 * shift:+.1f} | " + " | ".join(cells) + " |",
                      flush=True)


if __name__ == "__main__":
    main()

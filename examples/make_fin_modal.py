"""Regenerate the example modal test ``examples/fin_modal/modal.yaml`` (a few seconds).

    PYTHONPATH=src python examples/make_fin_modal.py [--out examples/fin_modal/modal.yaml]

The "measured" modes are those of a perturbed default fin: the outboard plate's E is 5 % higher
and the inboard plate 3 % thinner than in freeplayid/model/fin/fin.yaml. Three tests (the paper's
Tables 7 and 8): the outboard fin free-free and the inboard fin free-free and clamped; their
first modes, a damping ratio each, and mode-shape values at a few named points on the free-free
outboard fin. ``python scripts/model.py modal_test=examples/fin_modal/modal.yaml
updating.parameters=[outboard.E,inboard.thickness]`` recovers the perturbation.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import yaml

from freeplayid.atomic import atomic_write_text
from freeplayid.model import load_fin_config, part_modes

E_OUT_SCALE = 1.05  # outboard E, perturbed / nominal [-]
T_IN_SCALE = 0.97  # inboard thickness, perturbed / nominal [-]
N_MODES = {"outboard_free": 4, "inboard_free": 3, "inboard_clamped": 3}
ZETA = 0.025  # "measured" damping ratio of every mode [-] (the default fin: 0.03)
POINTS = {"tip_mid": [0.10, 0.26], "tip_trailing": [0.20, 0.26], "mid_leading": [0.0, 0.17]}
SHAPE_POINTS = ("top_left", "lower_right", "tip_mid", "tip_trailing", "mid_leading")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).parent / "fin_modal" / "modal.yaml"))
    args = ap.parse_args()
    nominal = load_fin_config()
    truth = nominal.with_part("outboard", E=E_OUT_SCALE * nominal.parts["outboard"].E)
    truth = truth.with_part("inboard", thickness=T_IN_SCALE * nominal.parts["inboard"].thickness)
    doc = {"name": f"default fin, outboard E x {E_OUT_SCALE}, inboard thickness x {T_IN_SCALE} "
                   "(examples/make_fin_modal.py)",
           "points": POINTS}
    for test, n in N_MODES.items():
        pts = SHAPE_POINTS if test == "outboard_free" else ()
        f, phi = part_modes(truth, test, n_modes=n, points=pts, coordinates=POINTS)
        modes = []
        for i in range(n):
            mode = {"frequency_hz": round(float(f[i]), 4), "damping": ZETA}
            if phi is not None:
                scale = phi[abs(phi[:, i]).argmax(), i]
                mode["shape"] = {p: round(float(phi[j, i] / scale), 4) for j, p in enumerate(pts)}
            modes.append(mode)
        doc[test] = {"modes": modes}
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    head = ("# Example modal test (examples/make_fin_modal.py): frequency_hz [Hz], damping [-],\n"
            "# shape: w at named points (any scale); points: fin coordinates [x, y] in m.\n")
    atomic_write_text(out, head + yaml.safe_dump(doc, sort_keys=False))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()

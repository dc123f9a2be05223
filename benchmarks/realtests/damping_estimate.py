"""Where the estimated damping ratio errs: the Rayleigh beam replayed with other dampings.

    python benchmarks/realtests/damping_estimate.py --data D --out OUT --jobs 2

``D`` holds ``beam_rayleigh`` (``cases.py --out D --cases beam_rayleigh``). The beam's model file
has no C, so ``identify`` estimates one modal damping ratio for every closed-hinge mode from the
peak amplitudes. Its truth is Rayleigh damping (2 % at 30 and 50 Hz), which damps the higher
closed modes more (7, 17, 34 % in modes 2-4). For each noise draw the same records are
identified with:

- ``default``: the ratio estimated (what a user gets);
- ``given``: the true mode-1 ratio given (``replay.damping``);
- ``true C``: the truth's Rayleigh C written into the model file (``replay.damping=model``);
- ``power p``: C with the closed modes' ratios ``zeta_1 (w_i / w_1)^p`` at the true mode-1
  ratio, in the model file (``replay.damping=model``), p = 0.75 and 1;
- ``exponent p``: the ratio estimated as ``default``, in that form (``replay.damping_exponent``),
  p = 0.6 and 0.9;
- and the same beam made by the exact integrator with uniform modal damping on its closed
  modes (the replay's own form, ``modal beam``), estimated as ``default``.

The table gives each answer's errors, the ratio used (or estimated, with its interval) and the
replay's peak offsets per run (replayed / measured - 1, lowest level to highest).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import json
import shutil
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import scipy.linalg

sys.path.insert(0, str(Path(__file__).resolve().parent))

RAYLEIGH_HZ, ZETA = (30.0, 50.0), 0.02  # beam_rayleigh's defaults (cases.beam)


def _variant(src: Path, dst: Path, system) -> None:
    """``src`` (a data-set folder) copied to ``dst`` with ``system`` as its model file."""
    from freeplayid.model import save_system

    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(src, dst)
    save_system(dst / "model.npz", system)


def build(data: Path, out: Path, draws: list[str]) -> list[tuple[str, str, str, dict | None]]:
    """The data sets and options: (variant, draw, folder, replay options)."""
    import cases

    from freeplayid.model import load_system, modal_damping, rayleigh_coefficients

    folder = data / "beam_rayleigh" / draws[0]
    truth = json.loads((folder / "truth.json").read_text())
    system = load_system(folder / "model.npz")
    M, Kc = system.M, system.closed_stiffness(float(truth["kn"]))
    w1 = float(np.sqrt(scipy.linalg.eigvalsh(Kc, M)[0]))
    a, b = rayleigh_coefficients(*RAYLEIGH_HZ, ZETA)
    zeta_1 = a / (2 * w1) + b * w1 / 2
    cs = {"true C": a * M + b * Kc}
    for p in (0.75, 1.0):
        cs[f"power {p:g}"] = modal_damping(M, Kc, zeta_1, exponent=p)
    modal = "realtests_modal_beam"
    cases.ALL_CASES[modal] = cases._variant(lambda **kw: _modal_beam(**kw), modal)
    cases.generate(modal, out, log=lambda s: print(s, file=sys.stderr, flush=True))
    tasks = []
    for d in draws:
        src = data / "beam_rayleigh" / d
        tasks += [("default", d, str(src), None),
                  ("given", d, str(src), {"damping": float(zeta_1)})]
        for name, C in cs.items():
            dst = out / name.replace(" ", "_") / d
            _variant(src, dst, system.replace(C=C))
            tasks.append((name, d, str(dst), {"damping": "model"}))
        tasks += [(f"exponent {p:g}", d, str(src), {"damping_exponent": p}) for p in (0.6, 0.9)]
        tasks.append(("modal beam", d, str(out / modal / d), None))
    return tasks


def _modal_beam(**kw):
    """beam_rayleigh's spec with uniform modal damping on the true closed-hinge modes."""
    import cases

    from freeplayid.model import modal_damping

    spec = cases.beam_rayleigh(**kw)
    st = spec.structure
    Kc = st.K + st.kn * st.B @ st.B.T  # the true structure's closed hinge (cases.py's arrays)
    spec.structure = dataclasses.replace(st, C=modal_damping(st.M, Kc, ZETA))
    spec.condition = f"single-hinge beam, modal damping {100 * ZETA:g} % in every closed mode"
    return spec


def run(task) -> dict:
    variant, draw, folder, replay = task
    import freeplayid

    truth = json.loads((Path(folder) / "truth.json").read_text())
    t0 = time.perf_counter()
    kw = {} if replay is None else {"replay": replay}
    with contextlib.redirect_stderr(io.StringIO()):
        r = freeplayid.identify(folder, **kw)
    peaks = [100 * m.peak_offset for _, m in sorted(
        (r.replay.resonance or {}).items(),
        key=lambda kv: r.replay.levels.get(kv[0], (0.0,))[0])]
    dmp = r.replay.damping
    return {"variant": variant, "draw": draw, "delta": 100 * (r.delta / truth["delta"] - 1),
            "kn": 100 * (r.kn / truth["kn"] - 1), "status": str(r.verdict.status),
            "zeta": dmp.zeta, "zeta_ci95": dmp.zeta_ci95, "source": dmp.source,
            "peaks": peaks, "wall_s": time.perf_counter() - t0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="cases.py --out folder with beam_rayleigh")
    ap.add_argument("--out", required=True, help="scratch folder for the variants")
    ap.add_argument("--draws", default="d0,d1")
    ap.add_argument("--jobs", type=int, default=1)
    args = ap.parse_args()
    data, out = Path(args.data), Path(args.out)
    draws = [d for d in args.draws.split(",") if d]
    missing = [d for d in draws if not (data / "beam_rayleigh" / d / "manifest.yaml").is_file()]
    if missing:
        raise SystemExit(f"{data}/beam_rayleigh/{missing[0]}/manifest.yaml not found: make it "
                         f"with python benchmarks/realtests/cases.py --out {data} "
                         "--cases beam_rayleigh")
    out.mkdir(parents=True, exist_ok=True)
    tasks = build(data, out, draws)
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(run, tasks))
    print("| replay's damping | draw | ζ [%] | δ err [%] | kn err [%] | verdict | "
          "peak offsets, lowest level to highest [%] |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        z = "–" if r["zeta"] is None else f"{100 * r['zeta']:.3g}"
        if r["zeta_ci95"]:
            z += f" [{100 * r['zeta_ci95'][0]:.3g}, {100 * r['zeta_ci95'][1]:.3g}]"
        print(f"| {r['variant']} | {r['draw']} | {z} | {r['delta']:+.2f} | {r['kn']:+.2f} | "
              f"{r['status']} | {' / '.join(f'{p:+.1f}' for p in r['peaks'])} |")


if __name__ == "__main__":
    main()

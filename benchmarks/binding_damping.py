"""How each statistic the replay could match moves when only the damping's form changes.

    python benchmarks/binding_damping.py                  # beam and fin, every statistic
    python benchmarks/binding_damping.py --structures beam --rules drop quadrature

The replay corrects the fit's bias by simulating the test with the model's damping, so its
answer is only as good as that damping's effect on the matched statistic. Here one structure at
one (kn, delta) is swept (absolute accelerations, base channel, sweep hints, no noise) under
damping forms that all give the closed-hinge first mode the same ratio zeta_1:

- ``modal``: zeta_1 in every closed-hinge mode (the replay's own form);
- ``rayleigh``: C = a M + b K (the structure's K, no hinge spring) with zeta = zeta_1 at two
  frequencies around mode 1 (more damping in the higher modes, and in the open-hinge motion);
- ``hinge``: the modal form at half zeta_1 plus a dashpot across each hinge that brings mode 1
  back to zeta_1.

Each run's records go through the same extraction with each jump-point rule (the statistics:
``drop`` where each curve drops, ``smoothed`` and ``windowed`` its maximum, ``quadrature``
where the response comes into quadrature with the base), and the backbone is fitted to each
rule's points. A form's shift of a statistic against ``modal`` is the error a replay with modal
damping would leave in the corrected answer (to first order, binding slope 1): the table prints
delta and kn of each fit relative to the truth, per form, and the largest shift between forms.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.linalg
import torch

from freeplayid.estimate import plain_estimate
from freeplayid.fit import FitOptions
from freeplayid.model import FreeplaySystem, default_fin, modal_analysis, modal_damping
from freeplayid.quantity import G
from freeplayid.signal import Extraction
from freeplayid.simulate import Sweep, simulate_sweeps, sweep_dataset

RULES = ("drop", "smoothed", "windowed", "quadrature")
FORMS = ("modal", "rayleigh", "hinge")
RATIOS = (2.0, 2.6, 3.3, 4.2)  # target Theta/delta of the levels (phase-resonance estimate)


def beam(n_in: int = 3, n_out: int = 4) -> FreeplaySystem:
    """A clamped Euler-Bernoulli beam of two segments joined by one rotational hinge.

    Inboard 0.15 m, outboard 0.3 m, steel 40 x 20 mm (closed-hinge first bending 41 Hz at
    kn = 5000 N m/rad, 80 Hz with a rigid hinge: the hinge shapes the mode); nodes carry
    (w, theta); the hinge node shares w, the inboard and outboard rotations there are separate
    DOFs joined by the freeplay spring. ``n_in + n_out`` elements: 2 (n_in + n_out) + 1 DOFs
    (15 by default).
    """
    E, rho, b, h = 2.0e11, 7850.0, 0.04, 0.02
    EI, rhoA = E * b * h**3 / 12, rho * b * h
    segments = [(0.15, n_in), (0.3, n_out)]
    names = []
    for i in range(1, n_in + 1):
        names += [f"w{i}", f"t{i}" if i < n_in else "t_hinge_in"]
    names.append("t_hinge_out")
    for i in range(n_in + 1, n_in + n_out + 1):
        names += [f"w{i}", f"t{i}"]
    index = {n: k for k, n in enumerate(names)}
    M = np.zeros((len(names),) * 2)
    K = np.zeros_like(M)
    node = 0
    for seg, (length, ne) in enumerate(segments):
        le = length / ne
        k_e = EI / le**3 * np.array([[12, 6 * le, -12, 6 * le], [6 * le, 4 * le**2, -6 * le,
                                     2 * le**2], [-12, -6 * le, 12, -6 * le],
                                    [6 * le, 2 * le**2, -6 * le, 4 * le**2]])
        m_e = rhoA * le / 420 * np.array([[156, 22 * le, 54, -13 * le], [22 * le, 4 * le**2,
                                          13 * le, -3 * le**2], [54, 13 * le, 156, -22 * le],
                                         [-13 * le, -3 * le**2, -22 * le, 4 * le**2]])
        for e in range(ne):
            a, c = node + e, node + e + 1
            rot_a = "t_hinge_out" if (seg == 1 and e == 0) else f"t{a}"
            rot_c = "t_hinge_in" if (seg == 0 and c == n_in) else f"t{c}"
            dofs = [f"w{a}", rot_a, f"w{c}", rot_c]
            idx = [index.get(d) for d in dofs]  # None: the clamped root
            for p, ip in enumerate(idx):
                for q, iq in enumerate(idx):
                    if ip is not None and iq is not None:
                        M[ip, iq] += m_e[p, q]
                        K[ip, iq] += k_e[p, q]
        node += ne
    r = np.array([1.0 if n.startswith("w") else 0.0 for n in names])  # base translation
    return FreeplaySystem(M=M, K=K, dof_names=tuple(names),
                          hinge_pairs=(("t_hinge_out", "t_hinge_in"),), base_influence=r)


def damping(system: FreeplaySystem, kn: float, zeta: float, form: str) -> np.ndarray:
    """The damping matrix of ``form`` with the closed-hinge mode 1 at ``zeta``."""
    Kc = system.closed_stiffness(kn)
    if form == "modal":
        return modal_damping(system.M, Kc, zeta)
    w1 = 2 * np.pi * float(modal_analysis(system.M, Kc).frequencies_hz[0])
    if form == "rayleigh":  # zeta at 0.75 w1 and 1.25 w1 (about 30 and 50 Hz at 40 Hz)
        wa, wb = 0.75 * w1, 1.25 * w1
        a, b = np.linalg.solve([[1 / (2 * wa), wa / 2], [1 / (2 * wb), wb / 2]], [zeta, zeta])
        C = a * system.M + b * system.K
    elif form == "hinge":
        C = modal_damping(system.M, Kc, zeta / 2)
        B = system.hinge_matrix()
        # the dashpot c across every hinge that adds zeta / 2 to mode 1: phi^T (c B B^T) phi =
        # zeta w1 (mass-normalised phi)
        lam, phi = scipy.linalg.eigh(Kc, system.M)
        p = phi[:, 0]
        c = zeta * w1 / float(np.sum((B.T @ p) ** 2))
        C = C + c * B @ B.T
    else:
        raise ValueError(f"unknown damping form {form!r}; valid: {FORMS}")
    return C


def levels(system, kn, delta, zeta) -> list[float]:
    """Levels [g] whose phase-resonance hinge amplitude is RATIOS x delta (closed mode 1)."""
    m = modal_analysis(system.M, system.closed_stiffness(kn))
    phi = m.shapes[:, 0]
    wc = 2 * np.pi * m.frequencies_hz[0]
    gain = float(np.max(np.abs(phi @ system.hinge_matrix())))
    gain *= abs(float(phi @ system.M @ system.influence)) * G
    return [float(r * delta * 2 * zeta * wc * wc / gain) for r in RATIOS]


STRUCTURES = {
    # name: (system, kn [N m/rad], delta [rad], zeta_1, measured DOFs, sweep)
    "beam": (beam, 5000.0, 2.5e-3, 0.02, ("w7", "w5"), (20.0, 42.0, 0.25)),
    "fin": (default_fin, 480.0, 3.0e-3, 0.03, ("uz_top_left", "uz_lower_right"),
            (30.0, 48.0, 0.25)),
}


def records(structure: str, form: str, sample_rate: float = 256.0):
    """The structure's sweeps under damping ``form``: (the undamped system the fits use, the
    simulation result, the data-set columns)."""
    make, kn, delta, zeta, dofs, sweep_args = STRUCTURES[structure]
    system = make().replace(C=None)
    lv = levels(system, kn, delta, zeta)
    damped = system.replace(C=damping(system, kn, zeta, form))
    res = simulate_sweeps(damped, kn=[kn] * len(lv), delta=[delta] * len(lv), level_g=lv,
                          sweep=Sweep(*sweep_args), channels=list(dofs), quantity="acceleration",
                          frame="absolute", sample_rate=sample_rate, engine="expo",
                          dtype=torch.float64, progress=False)
    return system, res, {f"a{i}": d for i, d in enumerate(dofs)}


def run(structure: str, rules, forms, sample_rate: float = 256.0) -> list[dict]:
    _, kn, delta, *_ = STRUCTURES[structure]
    rows = []
    for form in forms:
        t0 = time.perf_counter()
        system, res, columns = records(structure, form, sample_rate)
        ds = sweep_dataset(res, columns=columns)
        t_sim = time.perf_counter() - t0
        for rule in rules:
            est = plain_estimate(ds, system, extraction=Extraction(jump_point=rule),
                                 fit=FitOptions(), init=(kn, delta))
            rows.append({"structure": structure, "form": form, "rule": rule,
                         "delta_err": est.delta / delta - 1, "kn_err": est.kn / kn - 1,
                         "points": len(est.points.used()), "sim_s": t_sim})
            print(f"{structure:5s} {form:9s} {rule:11s} delta {100 * rows[-1]['delta_err']:+7.2f} %"
                  f"  kn {100 * rows[-1]['kn_err']:+7.2f} %  ({rows[-1]['points']} points)",
                  flush=True)
    return rows


def table(rows: list[dict]) -> str:
    lines = ["| structure | statistic | " + " | ".join(f"{f}: δ / kn [%]" for f in FORMS)
             + " | largest shift between forms: δ / kn [points of %] |",
             "|---|---|" + "---|" * (len(FORMS) + 1)]
    for s in dict.fromkeys(r["structure"] for r in rows):
        for rule in dict.fromkeys(r["rule"] for r in rows):
            sel = {r["form"]: r for r in rows if r["structure"] == s and r["rule"] == rule}
            cells = [f"{100 * sel[f]['delta_err']:+.2f} / {100 * sel[f]['kn_err']:+.2f}"
                     if f in sel else "–" for f in FORMS]
            d = [100 * r["delta_err"] for r in sel.values()]
            k = [100 * r["kn_err"] for r in sel.values()]
            lines.append(f"| {s} | {rule} | " + " | ".join(cells)
                         + f" | {max(d) - min(d):.2f} / {max(k) - min(k):.2f} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--structures", nargs="+", default=list(STRUCTURES), choices=STRUCTURES)
    ap.add_argument("--rules", nargs="+", default=list(RULES), choices=RULES)
    ap.add_argument("--forms", nargs="+", default=list(FORMS), choices=FORMS)
    args = ap.parse_args()
    rows = []
    for s in args.structures:
        rows += run(s, args.rules, args.forms)
    print()
    print(table(rows))


if __name__ == "__main__":
    main()

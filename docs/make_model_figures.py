"""Numbers and figure of the default fin for docs/model.md.

Run from the repository root:  python docs/make_model_figures.py
Prints the Markdown tables of docs/model.md and writes docs/figures/fin_modes.png.

The forced-response table is a describing-function (first-harmonic balance) estimate, not a
time simulation: at each base level the hinge amplitude Theta of the resonance peak is the largest
Theta for which the linearised system K + kn sum_j kappa(Theta_j/delta) b_j b_j^T, driven by the
exact base load -M r a_g with the model's damping, reaches Theta at some frequency (the fold of the
frequency-response curve, where an up-sweep jumps down).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from freeplayid.model import (  # noqa: E402
    build_fin_fe,
    describing_function,
    gap_ratio,
    load_fin_config,
    modal_analysis,
    reduce_fin,
)

G = 9.80665  # m/s^2 per g
PAPER_KN = 2.35e6  # N m/rad (2.35e9 N mm/rad)
LEVELS_G = (0.2, 0.4, 0.6, 0.8, 1.0, 1.2)
RK4_LIMIT = 2.785  # |omega dt| stability limit of classical RK4 on the imaginary axis


def hinge_amplitudes(system, kn, delta, level_g, kappa, freqs_hz):
    """|b_j^T Y| over frequency for fixed equivalent stiffness ratios kappa (2,); (nf, 2) [rad]."""
    M, K, C, B = system.M, system.K, system.damping, system.hinge_matrix()
    p = M @ system.influence * level_g * G
    w = 2 * np.pi * np.asarray(freqs_hz)[:, None, None]
    Z = (K + kn * (B * kappa) @ B.T)[None] - w**2 * M[None] + 1j * w * C[None]
    Y = np.linalg.solve(Z, np.broadcast_to(-p, (len(freqs_hz), len(p)))[..., None])[..., 0]
    return np.abs(Y @ B), Y


def df_peak(system, kn, delta, level_g, *, f_lo=10.0, f_hi=100.0, nf=1801):
    """DF estimate of the up-sweep resonance peak: (f [Hz], Theta/delta, |X| of DOFs 0, 1 [m])."""
    freqs = np.linspace(f_lo, f_hi, nf)

    def reach(a):  # max over frequency of the larger hinge amplitude, kappa set from amplitude a
        ratio = np.ones(2)
        for _ in range(30):
            kap = describing_function(a * ratio, delta)
            th, Y = hinge_amplitudes(system, kn, delta, level_g, kap, freqs)
            i = int(np.argmax(th.max(axis=1)))
            new = th[i] / th[i].max()
            if np.allclose(new, ratio, atol=1e-6):
                break
            ratio = new
        return th[i].max(), freqs[i], Y[i]

    # bisection on log(a/delta - 1): a resonance of amplitude a exists while reach(a) >= a
    lo, hi = np.log(1e-7), np.log(1e2)
    for _ in range(36):
        mid = 0.5 * (lo + hi)
        a = delta * (1 + np.exp(mid))
        if reach(a)[0] >= a:
            lo = mid
        else:
            hi = mid
    a = delta * (1 + np.exp(lo))
    _, f, Y = reach(a)
    return f, a / delta, np.abs(Y[:2])


def own_stiffness(system, kn_other):
    """Static stiffness [N m/rad] seen by each spring: structure + the other spring at kn_other."""
    B = system.hinge_matrix()
    out = []
    for j in range(2):
        o = B[:, 1 - j]
        Kx = system.K + kn_other * np.outer(o, o)
        out.append(1.0 / (B[:, j] @ np.linalg.solve(Kx, B[:, j])))
    return np.array(out)


def backbone_hz(system, kn, theta_over_delta):
    """Equal-amplitude DF backbone of the first mode at Theta/delta (array) [Hz]."""
    kap = describing_function(np.asarray(theta_over_delta, float), 1.0)
    B = system.hinge_matrix()
    G2 = B @ B.T
    return np.array(
        [modal_analysis(system.M, system.K + k * kn * G2).frequencies_hz[0] for k in kap]
    )


def main() -> None:
    cfg = load_fin_config()
    fe = build_fin_fe(cfg)
    fin = reduce_fin(fe)
    kn, delta = cfg.kn, cfg.delta
    print(f"FE: {fe.n_dof} free DOFs; mass {fe.rigid @ (fe.M @ fe.rigid):.4f} kg (free part)")

    print("\n### Frequencies [Hz]\n")
    full_closed = modal_analysis(fe.M, fe.closed_stiffness(kn), n_modes=6, sparse=True)
    full_open = modal_analysis(fe.M, fe.K, n_modes=6, sparse=True)
    full_paper = modal_analysis(fe.M, fe.closed_stiffness(PAPER_KN), n_modes=6, sparse=True)
    full_rigid = modal_analysis(fe.M, fe.closed_stiffness(1e6 * PAPER_KN), n_modes=6, sparse=True)
    red_closed = modal_analysis(fin.M, fin.closed_stiffness(kn))
    red_open = modal_analysis(fin.M, fin.K)
    fin8 = reduce_fin(fe, n_modes=8)
    red8 = modal_analysis(fin8.M, fin8.closed_stiffness(kn))
    rows = [
        (f"zero clearance, kn = {kn:g} (full FE)", full_closed.frequencies_hz),
        ("zero clearance (reduced, 12 DOFs)", red_closed.frequencies_hz[:6]),
        ("zero clearance (reduced, 8 modes, 14 DOFs)", red8.frequencies_hz[:6]),
        ("open hinges, kn = 0 (full FE)", full_open.frequencies_hz),
        ("open hinges (reduced, 12 DOFs)", red_open.frequencies_hz[:6]),
        ("paper kn = 2.35e6 (full FE)", full_paper.frequencies_hz),
        ("rigid hinges, kn -> inf (full FE)", full_rigid.frequencies_hz),
    ]
    print("| model | f1 | f2 | f3 | f4 | f5 | f6 |\n|---|---|---|---|---|---|---|")
    for name, f in rows:
        print(f"| {name} | " + " | ".join(f"{v:.2f}" for v in f) + " |")

    print("\n### Hinge stiffness [N·m/rad]\n")
    k_own = own_stiffness(fin, kn)
    k_own_rigid = own_stiffness(fin, 1e6 * PAPER_KN)
    print(f"own stiffness seen by left/mid spring, other spring at kn: {k_own}")
    print(f"own stiffness seen by left/mid spring, other spring rigid: {k_own_rigid}")

    print("\n### Highest frequency of the reduced model and RK4 step\n")
    for name, k in (("open", 0.0), ("kn", kn), ("paper kn", PAPER_KN)):
        fmax = modal_analysis(fin.M, fin.closed_stiffness(k)).frequencies_hz[-1]
        print(f"| {name} | {fmax:.0f} Hz | dt_max = {RK4_LIMIT / (2 * np.pi * fmax):.3e} s |")

    print("\n### Base influence r at the Uz DOFs\n")
    for name, s in (
        ("12 DOFs (default, rigid)", fin),
        ("12 DOFs (exact load)", reduce_fin(fe, influence="load")),
        ("14 DOFs (8 modes, exact load)", reduce_fin(fe, n_modes=8, influence="load")),
        ("13 DOFs (base_vector=True)", reduce_fin(fe, base_vector=True)),
    ):
        r = s.base_influence
        print(f"| {name} | " + " | ".join(f"{v:.4f}" for v in r[:6]) + " |")
    p = fe.base_load
    print(
        f"consistent-mass root coupling |M_fb 1_b| share of the load: "
        f"{1 - (fe.rigid @ (fe.M @ fe.rigid)) / (fe.rigid @ p):.4f}"
    )

    print("\n### DF backbone (equal hinge amplitudes) [Hz]\n")
    ratios = np.array([1.05, 1.2, 1.5, 2.0, 3.0, 5.0, 10.0])
    print("| Theta/delta | " + " | ".join(f"{r:g}" for r in ratios) + " |")
    print("|---|" + "---|" * len(ratios))
    print(f"| kn = {kn:g} | " + " | ".join(f"{f:.1f}" for f in backbone_hz(fin, kn, ratios)) + " |")
    fp = backbone_hz(fin, PAPER_KN, ratios)
    print("| kn = 2.35e6 | " + " | ".join(f"{f:.1f}" for f in fp) + " |")
    # where the paper-kn backbone reaches 90 % of its limit
    kap90 = []
    for frac in (0.5, 0.9):
        target = frac * full_paper.frequencies_hz[0]
        lo, hi = 0.0, 1.0
        for _ in range(50):
            m = 0.5 * (lo + hi)
            f = modal_analysis(
                fin.M, fin.K + m * PAPER_KN * fin.hinge_matrix() @ fin.hinge_matrix().T
            )
            lo, hi = (m, hi) if f.frequencies_hz[0] < target else (lo, m)
        kap90.append((frac, lo, 1.0 / gap_ratio(lo)))
    for frac, k, t in kap90:
        print(
            f"paper kn: f1 reaches {frac:.0%} of its limit at kappa = {k:.2e}, "
            f"Theta/delta = {t:.5f}"
        )

    print("\n### DF estimate of the up-sweep resonance (default kn, delta)\n")
    print(
        "| level [g] | peak f [Hz] | Theta/delta at peak | X_tl [mm] | X_lr [mm] | "
        "open-hinge Theta/delta at 30 Hz |"
    )
    print("|---|---|---|---|---|---|")
    for lev in LEVELS_G:
        f, t, X = df_peak(fin, kn, delta, lev)
        th_open, _ = hinge_amplitudes(fin, kn, delta, lev, np.zeros(2), [30.0])
        print(
            f"| {lev:.1f} | {f:.2f} | {t:.2f} | {1e3 * X[0]:.2f} | {1e3 * X[1]:.2f} | "
            f"{th_open.max() / delta:.2f} |"
        )

    figure(fe, full_open, full_closed, fin, kn)


def figure(fe, full_open, full_closed, fin, kn) -> None:
    fig, axes = plt.subplots(1, 5, figsize=(12.5, 3.4), constrained_layout=True)
    panels = [("open hinge: mechanism", full_open, 0)] + [
        (f"zero clearance mode {i + 1}", full_closed, i) for i in range(3)
    ]
    for ax, (title, modes, i) in zip(axes[:4], panels, strict=True):
        disp = fe.plate_displacement(modes.shapes[:, i])
        scale = max(np.abs(d[:, 0]).max() for d in disp.values())
        for part, mesh in fe.meshes.items():
            w = disp[part][:, 0].reshape(mesh.ny + 1, mesh.nx + 1) / scale
            X = mesh.nodes[:, 0].reshape(w.shape)
            Y = mesh.nodes[:, 1].reshape(w.shape)
            cs = ax.contourf(X, Y, w, levels=np.linspace(-1, 1, 21), cmap="RdBu_r")
        cfg = fe.config
        ax.plot(cfg.hinge_x, [cfg.inboard_span] * 3, "k^", ms=6)
        for name in ("top_left", "lower_right"):
            ax.plot(*getattr(cfg, name), "ko", ms=5, mfc="none")
        ax.axhline(cfg.inboard_span, color="k", lw=0.6)
        ax.set_title(f"{title}\n{modes.frequencies_hz[i]:.1f} Hz", fontsize=9)
        ax.set_aspect("equal")
        ax.set_xlabel("x [m] (hinge axis)", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0].set_ylabel("y [m]", fontsize=8)
    fig.colorbar(cs, ax=axes[3], shrink=0.8, label="w / max|w|")
    ax = axes[4]
    r = np.linspace(1.0005, 12, 200)
    ax.plot(r, backbone_hz(fin, kn, r), label=f"kn = {kn:g} N·m/rad")
    ax.plot(r, backbone_hz(fin, PAPER_KN, r), "--", label="kn = 2.35e6 (paper)")
    ax.axhspan(30, 50, color="0.9", zorder=0)
    ax.set_xlabel("hinge amplitude Theta / delta", fontsize=8)
    ax.set_ylabel("first-mode frequency [Hz]", fontsize=8)
    ax.set_title("DF backbone (gray: sweep band)", fontsize=9)
    ax.legend(fontsize=7)
    ax.tick_params(labelsize=7)
    out = Path(__file__).resolve().parent / "figures" / "fin_modes.png"
    out.parent.mkdir(exist_ok=True)
    fig.savefig(out, dpi=80)
    print(f"\nwrote {out} ({out.stat().st_size / 1024:.0f} KB)")


if __name__ == "__main__":
    main()

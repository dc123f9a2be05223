"""Paper Fig. 3 analogue: DFA and harmonic-balance backbones vs the exact SDOF backbone.

    python docs/make_backbone_figure.py     # writes docs/figures/backbone_sdof.png, prints a table

System: the pure freeplay oscillator m y'' + f(y) = 0 (m = kn = delta = 1, w_n = 1), whose exact
backbone is w(A) = w_n / (1 + 2 delta / (pi (A - delta))) with A the peak displacement.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from freeplayid.backbone import dfa_backbone, hb_backbone  # noqa: E402
from freeplayid.model import describing_function, sdof_system  # noqa: E402
from freeplayid.plots import plot_backbone_comparison  # noqa: E402

OUT = Path(__file__).resolve().parent / "figures" / "backbone_sdof.png"


def main() -> None:
    sys_ = sdof_system()
    s = np.geomspace(1.01, 6.0, 120)
    dfa = dfa_backbone(sys_, kn=1.0, delta=1.0, s=s)
    hb3 = hb_backbone(sys_, kn=1.0, delta=1.0, s=s, n_harmonics=2, n_time=256)  # harmonics 1, 3
    hb7 = hb_backbone(sys_, kn=1.0, delta=1.0, s=s, n_harmonics=7, n_time=1024)
    peak = np.linspace(1.02, 6.0, 300)
    exact = 1.0 / (1.0 + 2.0 / (np.pi * (peak - 1.0)))

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    plot_backbone_comparison(
        axes[0],
        [
            ("DFA (vs first harmonic)", dfa.channel("x")[0], dfa.frequency_hz[0]),
            ("HB, harmonics 1, 3 (vs peak)", hb3.peak_amplitude[0, :, 0], hb3.frequency_hz[0]),
            ("HB, harmonics 1..13 (vs peak)", hb7.peak_amplitude[0, :, 0], hb7.frequency_hz[0]),
        ],
        exact=(peak, exact),
    )
    axes[0].set_title("freeplay oscillator backbone")
    # error at the exact solution: DFA evaluated at the HB first harmonic of the same motion
    a_peak = hb7.peak_amplitude[0, :, 0]
    w_exact = 1.0 / (1.0 + 2.0 / (np.pi * (a_peak - 1.0)))
    w_dfa = np.sqrt(describing_function(hb7.amplitude[0, :, 0], 1.0))
    axes[1].plot(a_peak, 100 * (w_dfa / w_exact - 1), label="DFA")
    for hb, label in ((hb3, "HB 1, 3"), (hb7, "HB 1..13")):
        a = hb.peak_amplitude[0, :, 0]
        w_ex = 1.0 / (1.0 + 2.0 / (np.pi * (a - 1.0)))
        axes[1].plot(a, 100 * (2 * np.pi * hb.frequency_hz[0] / w_ex - 1), label=label)
    axes[1].axhline(0, color="k", lw=0.5)
    axes[1].set_ylim(-60, 5)
    axes[1].set_xlabel("peak amplitude / delta")
    axes[1].set_ylabel("frequency error vs exact [%]")
    axes[1].legend(fontsize="small")
    axes[1].set_title("error of the approximations")
    fig.tight_layout()
    OUT.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT, dpi=110)
    print(f"wrote {OUT} ({OUT.stat().st_size // 1024} KB)")

    print("\n| peak A / delta | exact w/w_n | DFA error | HB 1,3 error | HB 1..13 error |")
    print("|---|---|---|---|---|")
    for target in (1.2, 1.5, 2.0, 3.0, 5.0):
        row = [f"{target:g}", f"{1 / (1 + 2 / (np.pi * (target - 1))):.4f}"]
        row.append(f"{100 * np.interp(target, a_peak, w_dfa / w_exact - 1):+.2f} %")
        for hb in (hb3, hb7):
            a = hb.peak_amplitude[0, :, 0]
            err = 2 * np.pi * hb.frequency_hz[0] * (1 + 2 / (np.pi * (a - 1))) - 1
            row.append(f"{100 * np.interp(target, a, err):+.3f} %")
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()

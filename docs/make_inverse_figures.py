"""Figures of docs/inverse.md from the study runs (after scripts/train.py and scripts/compare.py).

    python docs/make_inverse_figures.py --noise outputs/study/compare_noise \
        --train outputs/study/train_noise --clearance outputs/study/compare_clearance

Copies the comparison and prediction figures into docs/figures/ and draws the fit error
against the true kn (inverse_fit_bias.png) from the noise study's compare.csv.
"""

from __future__ import annotations

import argparse
import csv
import shutil
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

FIG = Path(__file__).parent / "figures"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--noise", type=Path, required=True, help="compare run, +experiment=noise")
    ap.add_argument("--train", type=Path, required=True, help="train run, +experiment=noise")
    ap.add_argument("--clearance", type=Path, help="compare run, +experiment=clearance")
    args = ap.parse_args()
    FIG.mkdir(exist_ok=True)
    copies = [(args.noise / "compare_errors.png", "inverse_compare_noise_errors.png"),
              (args.noise / "compare_cost.png", "inverse_compare_noise_cost.png"),
              (args.train / "predictions.png", "inverse_predictions_noise.png"),
              (args.train / "learning_curves.png", "inverse_learning_curves_noise.png")]
    if args.clearance:
        copies += [(args.clearance / "compare_errors.png", "inverse_compare_clearance_errors.png"),
                   (args.clearance / "compare_cost.png", "inverse_compare_clearance_cost.png")]
    for src, name in copies:
        shutil.copyfile(src, FIG / name)
    rows = list(csv.DictReader(open(args.noise / "compare.csv")))
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, q, name in zip(axes, ("delta", "kn"), ("δ", "kn"), strict=True):
        for method, color in (("network", "tab:purple"), ("multi-start", "tab:blue")):
            sel = [r for r in rows if r["method"] == method and float(r["noise_g"]) == 0.0]
            kn = np.array([float(r["kn_true"]) for r in sel])
            err = 100 * np.array([float(r[f"{q}_error"]) for r in sel])
            ok = np.abs(err) < 50
            ax.plot(kn[ok], err[ok], "o", ms=4, color=color, alpha=0.7,
                    label=f"{method} ({(~ok).sum()} off scale)" if (~ok).any() else method)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xlabel("true kn [N·m/rad]")
        ax.set_ylabel(f"{name} error [%]")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_title("noise-free held-out cases", fontsize=9)
    fig.tight_layout()
    fig.savefig(FIG / "inverse_fit_bias.png", dpi=110)
    print(f"wrote {len(copies) + 1} figures to {FIG}")


if __name__ == "__main__":
    main()

"""How the replay's reading of the base channel follows a realtests case's level profile.

    python benchmarks/realtests/base_reading.py var12_finB_fast_dip --data D [--draw d1]
        [--figure docs/figures/realtests_base_reading.png]

For each run with a jump, the base record's first harmonic read as the replay reads it
(:func:`freeplayid.replay.excitation.measured_sweep`: a quarter of the band where the wide
band is noisy, sharpened where it shows rounding) and the wide band alone, against the same
wide reading of the case's clean base record (cases.py keeps it: the level the shaker really
had). The table gives, over the 2 s before each clean jump (where the jump is decided), the
largest and the mean relative error of each reading, the sharpening's correction there and the
reading's noise (:func:`freeplayid.signal.level.reading_sd`). The figure shows the readings
around each jump.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

BEFORE_S = 2.0  # [s] the part of each run before its jump that the table reads


def readings(case: str, data: Path, draw: str) -> list[dict]:
    """Per run with a jump: the frequency axis, the clean, replay's and wide readings and the
    jump (module docstring)."""
    import freeplayid.io as fio
    from freeplayid.quantity import G
    from freeplayid.replay.excitation import measured_sweep
    from freeplayid.signal import acmp
    from freeplayid.signal import level as lv
    from freeplayid.sweep import Sweep

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from cases import load_clean

    folder = data / case / draw
    ds = fio.read_dataset(folder)
    truth = json.loads((folder / "truth.json").read_text())
    clean = load_clean(data / case)
    fs = float(ds.sample_rate)
    out = []
    for k, run in enumerate(ds.runs):
        tr = truth["runs"][k]
        f_jump, sw = tr.get("f_jump_hz"), tr["sweep"]
        if run.base is None or f_jump is None or not np.isfinite(f_jump) \
                or "rate_hz_per_s" not in sw:
            continue
        law = Sweep(sw["start_hz"], sw["stop_hz"], sw["rate_hz_per_s"])
        x = ds.to_si(run.base)
        t = np.arange(x.size) / fs
        bw = max(1.0, 2.0 * abs(sw["rate_hz_per_s"]))  # measured_sweep's band for a linear sweep
        wide = acmp(x, fs, sweep=law, bandwidth_hz=bw)
        narrow = acmp(x, fs, sweep=law, bandwidth_hz=lv.NARROW_BASE * bw)
        ms, level_g = measured_sweep(ds, run, law)
        if ds.quantity != "acceleration":
            raise SystemExit(f"{folder}: acceleration records only (realtests' are)")
        replay = ms.envelope(t) * level_g * G
        ref = acmp(np.asarray(clean["base"][k], float), fs, sweep=law, bandwidth_hz=bw).amplitude
        t_jump = (f_jump - sw["start_hz"]) / sw["rate_hz_per_s"]
        chosen = lv.quiet_base(wide, narrow)
        out.append({"run": run.file, "f": law.frequency(t), "t": t, "t_jump": t_jump,
                    "f_jump": f_jump, "clean": ref, "replay": replay, "wide": wide.amplitude,
                    "correction": lv.sharpened(chosen, fs, law) - chosen.amplitude,
                    "noise": lv.reading_sd(wide, narrow, chosen),
                    "band": "quarter" if chosen is narrow else "wide",
                    "sharpened": ms.reading_steps > 0})
    return out


def table(rows: list[dict]) -> str:
    lines = ["| run | jump [Hz] | band | sharpened | replay's reading: largest / mean error [%] "
             "| wide band: largest / mean [%] | sharpening's correction, largest [%] "
             "| reading noise [%] |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        m = (r["t"] > r["t_jump"] - BEFORE_S) & (r["t"] <= r["t_jump"])
        ref = r["clean"][m]
        err = {k: r[k][m] / ref - 1 for k in ("replay", "wide")}
        med = float(np.median(r["clean"]))
        lines.append(
            f"| {r['run']} | {r['f_jump']:.2f} | {r['band']} | {'yes' if r['sharpened'] else 'no'} "
            + "".join(f"| {100 * e[np.argmax(np.abs(e))]:+.2f} / {100 * np.mean(e):+.2f} "
                      for e in err.values())
            + f"| {100 * np.max(np.abs(r['correction'][m])) / med:.2f} "
            f"| {100 * r['noise']:.2f} |")
    return "\n".join(lines)


def figure(rows: list[dict], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from freeplayid.quantity import G

    fig, axes = plt.subplots(1, len(rows), figsize=(3.2 * len(rows), 3.0), squeeze=False)
    for ax, r in zip(axes[0], rows):
        near = (r["f"] > r["f_jump"] - 2.0) & (r["f"] < r["f_jump"] + 1.0)
        ax.plot(r["f"][near], r["wide"][near] / G, lw=0.6, alpha=0.5, label="wide band")
        ax.plot(r["f"][near], r["replay"][near] / G, lw=1.4, label="the replay's reading")
        ax.plot(r["f"][near], r["clean"][near] / G, "k", lw=1.0, label="clean record")
        ax.axvline(r["f_jump"], color="r", lw=0.8)
        ax.set_title(r["run"], fontsize=8)
        ax.set_xlabel("frequency [Hz]", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0][0].set_ylabel("base level [g]", fontsize=8)
    axes[0][0].legend(fontsize=6)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case")
    ap.add_argument("--data", default="outputs/realtests/data")
    ap.add_argument("--draw", default="d0")
    ap.add_argument("--figure", default=None, help="save the readings around each jump here")
    args = ap.parse_args()
    rows = readings(args.case, Path(args.data), args.draw)
    if not rows:
        raise SystemExit(f"{args.case} {args.draw}: no run with a base channel and a jump")
    print(table(rows))
    if args.figure:
        figure(rows, Path(args.figure), f"{args.case} {args.draw}: the base's reading near "
               "each jump (red)")
        print(f"figure: {args.figure}")


if __name__ == "__main__":
    main()

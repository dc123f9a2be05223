"""Render docs/figures/signal_example.png: backbone points of an SDOF freeplay oscillator.

    PYTHONPATH=src python docs/figures/signal_example.py

Five base levels (0.3-1.0 g), 30 -> 50 Hz at 0.2 Hz/s, absolute acceleration with 0.1 g noise and
the base channel subtracted; ACMP without the sweep hint; the exact backbone overlaid. The sweeps
come from the reference RK4 in tests/sdof_reference.py (independent of freeplayid.simulate).
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
from freeplayid.plots import plot_backbone_points  # noqa: E402
from freeplayid.signal import extract_backbone_points, white_noise  # noqa: E402
from freeplayid.sweep import Sweep  # noqa: E402
from sdof_reference import DELTA, FS, exact_backbone_hz, simulate_sdof_sweep  # noqa: E402

levels = (0.3, 0.5, 0.6, 0.8, 1.0)  # [g]
sweep = Sweep(30.0, 50.0, 0.2)
sims = [simulate_sdof_sweep(level, sweep) for level in levels]
base = np.stack([s[3] for s in sims])
absolute = np.stack([(s[2] + s[3])[None, :] for s in sims])
absolute = absolute + white_noise(absolute.shape, std_g=0.1, seed=0)
res = extract_backbone_points(absolute, FS, quantity="acceleration", base=base,
                              run_names=[f"{lv:.1f} g" for lv in levels], channel_names=["x"])
amp = np.linspace(1.3 * DELTA, 14 * DELTA, 200)  # [m]
fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
plot_backbone_points(ax, res, backbone=(exact_backbone_hz(amp), amp))
ax.set_title("SDOF freeplay, up-sweeps: ACMP + Eq. 9 from acceleration")
fig.tight_layout()
fig.savefig(ROOT / "docs" / "figures" / "signal_example.png")
for p in res.points:
    print(p.run, f"{p.f_hz:.3f} Hz", f"{p.amplitude_m:.4e} m", p.used, p.reason)

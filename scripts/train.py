"""Train the neural inverse model (set of backbone points -> kn, delta) on simulated sweeps.

    python scripts/train.py                          # default fin, noise levels 0-0.3 g
    python scripts/train.py +experiment=noise        # the noise ablation
    python scripts/train.py +experiment=clearance    # the clearance ablation
    python scripts/train.py debug=fast               # seconds (after the numba compile)

The same command as the installed ``freeplayid-train`` (:mod:`freeplayid.tasks.cli`).
"""

from freeplayid.tasks.cli import train

if __name__ == "__main__":
    train()

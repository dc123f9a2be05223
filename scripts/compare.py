"""Compare the network-initialised fit with pure fitting on held-out simulated cases.

    python scripts/compare.py +experiment=noise                     # trains first if needed
    python scripts/compare.py +experiment=clearance inverse.checkpoint=PATH/checkpoint.ckpt
    python scripts/compare.py -m +experiment=noise,clearance hydra/launcher=joblib

The same command as the installed ``freeplayid-compare`` (:mod:`freeplayid.tasks.cli`).
"""

from freeplayid.tasks.cli import compare

if __name__ == "__main__":
    compare()

"""Train the neural inverse model (set of backbone points -> kn, delta) on simulated sweeps.

    python scripts/train.py                          # default fin, noise levels 0-0.3 g
    python scripts/train.py +experiment=noise        # the noise ablation
    python scripts/train.py +experiment=clearance    # the clearance ablation
    python scripts/train.py debug=fast               # seconds (after the numba compile)
"""

import sys

import hydra
from omegaconf import DictConfig

from freeplayid import InputError, tasks


@hydra.main(version_base="1.3", config_path="../conf", config_name="train")
def main(cfg: DictConfig) -> dict:
    try:
        return tasks.train(cfg)
    except InputError as exc:
        sys.exit(f"train: {exc}")  # a configuration, data or output problem: one line


if __name__ == "__main__":
    tasks.check_run_dir("train", sys.argv)  # before Hydra makes the folder
    main()

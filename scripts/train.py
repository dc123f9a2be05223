"""Train the neural inverse model (set of backbone points -> kn, delta) on simulated sweeps.

    python scripts/train.py                          # default fin, noise levels 0-0.3 g
    python scripts/train.py +experiment=noise        # the noise ablation
    python scripts/train.py +experiment=clearance    # the clearance ablation
    python scripts/train.py debug=fast               # seconds (after the numba compile)
"""

import sys

import hydra
from omegaconf import DictConfig

from freeplayid import tasks


@hydra.main(version_base="1.3", config_path="../conf", config_name="train")
def main(cfg: DictConfig) -> dict:
    with tasks.command_errors("train"):  # an input problem or Ctrl-C: one line
        return tasks.train(cfg)


if __name__ == "__main__":
    with tasks.command_errors("train"):  # Ctrl-C while Hydra composes: one line too
        tasks.check_run_dir("train", sys.argv)  # before Hydra makes the folder
        main()

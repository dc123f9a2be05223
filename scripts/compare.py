"""Compare the network-initialised fit with pure fitting on held-out simulated cases.

    python scripts/compare.py +experiment=noise                     # trains first if needed
    python scripts/compare.py +experiment=clearance inverse.checkpoint=PATH/checkpoint.ckpt
    python scripts/compare.py -m +experiment=noise,clearance hydra/launcher=joblib
"""

import sys

import hydra
from omegaconf import DictConfig

from freeplayid import tasks


@hydra.main(version_base="1.3", config_path="../conf", config_name="compare")
def main(cfg: DictConfig) -> dict:
    with tasks.command_errors("compare"):  # an input problem or Ctrl-C: one line
        return tasks.compare(cfg)


if __name__ == "__main__":
    with tasks.command_errors("compare"):  # Ctrl-C while Hydra composes: one line too
        tasks.check_command_line("compare", sys.argv)  # before Hydra makes the folder
        main()

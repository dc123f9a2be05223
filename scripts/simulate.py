"""Simulate sine-sweep tests and write a measured-data set (docs/identify.md).

    python scripts/simulate.py                      # default fin, paper sweep, conf/simulate.yaml
    python scripts/simulate.py model=npz model.path=my_fin.npz levels=[0.4,0.6] noise_std_g=0.1
    python scripts/simulate.py model=sdof debug=fast
"""

import sys

import hydra
from omegaconf import DictConfig

from freeplayid import tasks


@hydra.main(version_base="1.3", config_path="../conf", config_name="simulate")
def main(cfg: DictConfig) -> dict:
    with tasks.command_errors("simulate"):  # an input problem or Ctrl-C: one line
        return tasks.simulate(cfg)


if __name__ == "__main__":
    with tasks.command_errors("simulate"):  # Ctrl-C while Hydra composes: one line too
        tasks.check_run_dir("simulate", sys.argv)  # before Hydra makes the folder
        main()

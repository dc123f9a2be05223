"""Simulate sine-sweep tests and write a measured-data set (docs/identify.md).

    python scripts/simulate.py                      # default fin, paper sweep, conf/simulate.yaml
    python scripts/simulate.py model=npz model.path=my_fin.npz levels=[0.4,0.6] noise_std_g=0.1
    python scripts/simulate.py model=sdof debug=fast
"""

import hydra
from omegaconf import DictConfig

from freeplayid import tasks


@hydra.main(version_base="1.3", config_path="../conf", config_name="simulate")
def main(cfg: DictConfig) -> dict:
    return tasks.simulate(cfg)


if __name__ == "__main__":
    main()

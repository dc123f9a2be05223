"""Train the neural inverse model (set of backbone points -> kn, delta) on simulated sweeps.

    python scripts/train.py                          # default fin, noise levels 0-0.3 g
    python scripts/train.py +experiment=noise        # the noise ablation
    python scripts/train.py +experiment=clearance    # the clearance ablation
    python scripts/train.py debug=fast               # seconds (after the numba compile)
"""

import hydra
from omegaconf import DictConfig

from freeplayid import tasks


@hydra.main(version_base="1.3", config_path="../conf", config_name="train")
def main(cfg: DictConfig) -> dict:
    return tasks.train(cfg)


if __name__ == "__main__":
    main()

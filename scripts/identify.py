"""Identify hinge freeplay (kn, delta) from a measured sine-sweep data set (docs/identify.md).

    python scripts/identify.py                              # the bundled example data set
    python scripts/identify.py data=PATH/manifest.yaml      # your data set
    python scripts/identify.py data=PATH fit.backbone=hb fit.n_bootstrap=200 debug=fast
"""

import sys

import hydra
from omegaconf import DictConfig

from freeplayid import InputError, tasks


@hydra.main(version_base="1.3", config_path="../conf", config_name="identify")
def main(cfg: DictConfig) -> dict:
    try:
        return tasks.identify(cfg)
    except InputError as exc:
        sys.exit(f"identify: {exc}")  # a data or checkpoint problem: the message says where


if __name__ == "__main__":
    tasks.check_command_line("identify", sys.argv)  # before Hydra makes the folder
    main()

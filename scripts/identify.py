"""Identify hinge freeplay (kn, delta) from a measured sine-sweep data set (docs/identify.md).

    python scripts/identify.py                              # the bundled example data set
    python scripts/identify.py data=PATH/manifest.yaml      # your data set
    python scripts/identify.py data=PATH fit.backbone=hb fit.n_bootstrap=200 debug=fast
"""

import sys

import hydra
from omegaconf import DictConfig

from freeplayid import tasks


@hydra.main(version_base="1.3", config_path="../conf", config_name="identify")
def main(cfg: DictConfig) -> dict:
    with tasks.command_errors("identify"):  # an input problem or Ctrl-C: one line
        return tasks.identify(cfg)


if __name__ == "__main__":
    with tasks.command_errors("identify"):  # Ctrl-C while Hydra composes: one line too
        tasks.check_command_line("identify", sys.argv)  # before Hydra makes the folder
        main()

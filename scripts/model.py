"""Step 1: the linear fin model from modal tests (docs/model.md, "The model command").

    python scripts/model.py                                      # the configured fin, no updating
    python scripts/model.py modal_test=PATH/modal.yaml updating.parameters=[outboard.E,inboard.E]
    python scripts/model.py modal_test=... model.parts.outboard.thickness=0.005
"""

import hydra
from omegaconf import DictConfig

from freeplayid import tasks


@hydra.main(version_base="1.3", config_path="../conf", config_name="model")
def main(cfg: DictConfig) -> dict:
    with tasks.command_errors("model"):  # an input problem or Ctrl-C: one line
        return tasks.model(cfg)


if __name__ == "__main__":
    with tasks.command_errors("model"):  # Ctrl-C while Hydra composes: one line too
        main()

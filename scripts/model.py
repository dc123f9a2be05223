"""Step 1: the linear fin model from modal tests (docs/model.md, "The model command").

    python scripts/model.py                                      # the configured fin, no updating
    python scripts/model.py modal_test=PATH/modal.yaml updating.parameters=[outboard.E,inboard.E]
    python scripts/model.py modal_test=... model.parts.outboard.thickness=0.005
"""

import sys

import hydra
from omegaconf import DictConfig

from freeplayid import InputError, tasks


@hydra.main(version_base="1.3", config_path="../conf", config_name="model")
def main(cfg: DictConfig) -> dict:
    try:
        return tasks.model(cfg)
    except InputError as exc:
        sys.exit(f"model: {exc}")  # a modal-test or configuration problem: the message says where


if __name__ == "__main__":
    main()

"""Step 1: the linear fin model from modal tests (docs/model.md, "The model command").

    python scripts/model.py                                      # the configured fin, no updating
    python scripts/model.py modal_test=PATH/modal.yaml updating.parameters=[outboard.E,inboard.E]
    python scripts/model.py modal_test=... model.parts.outboard.thickness=0.005

The same command as the installed ``freeplayid-model`` (:mod:`freeplayid.tasks.cli`).
"""

from freeplayid.tasks.cli import model

if __name__ == "__main__":
    model()

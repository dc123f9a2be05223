"""The linear model from modal tests (the method's step 1) and its check against the sealed fin:
the measured modes of the part tests (``measured.py``), the updated and reduced fin
(``build.py``: :func:`model_from_modal_test`), generic model updating against measured
frequencies (``update.py``) and the zero-clearance check of an identified model
(``zero_clearance.py``: :func:`validate_modes`); docs/model.md."""

from .build import (
    CONDITION_LIMIT,
    TEST_TITLES,
    UPDATE_PARAMETERS,
    ModelBuild,
    TestComparison,
    model_from_modal_test,
    part_modes,
)
from .measured import CONFIG_POINTS, TEST_NAMES, MeasuredModes, ModalTest, ModalTestError
from .sealed import SealedUpdate, update_to_sealed_modes
from .update import UpdateResult, mode_table, update_model
from .zero_clearance import ModeValidation, validate_modes

__all__ = [
    "CONDITION_LIMIT", "TEST_TITLES", "UPDATE_PARAMETERS", "ModelBuild", "TestComparison",
    "model_from_modal_test", "part_modes",
    "CONFIG_POINTS", "TEST_NAMES", "MeasuredModes", "ModalTest", "ModalTestError",
    "UpdateResult", "mode_table", "update_model", "ModeValidation", "validate_modes",
    "SealedUpdate", "update_to_sealed_modes",
]

"""Linear structure and freeplay: system files, restoring force, describing function, modal tools,
small test models, the default folding fin (plate FE + Craig-Bampton reduction) and the model from
modal tests.

- ``system.py`` (:class:`FreeplaySystem`, ``.npz`` files), ``freeplay.py``, ``damping.py``,
  ``modal.py``, ``reduce.py``, ``small.py``: any linear structure with freeplay springs;
- ``fin/``: the default folding fin (configuration and its package data ``fin.yaml``, plate
  element, knuckle hinges, assembled FE and its reduction);
- ``from_test/``: step 1 from the part modal tests (measured modes, updating, the updated and
  reduced fin) and the zero-clearance check of an identified model.
"""

from .damping import modal_damping, rayleigh_coefficients, rayleigh_damping
from .fin import (
    FIN_HINGE_PAIRS,
    REDUCED_DOF_NAMES,
    FinConfig,
    FinFE,
    PartProperties,
    PlateMesh,
    acm_element,
    assemble_plate,
    build_fin_fe,
    default_fin,
    default_fin_parameters,
    fin_config_path,
    fin_from_config,
    fin_reduction,
    load_fin_config,
    part_matrices,
    rectangular_mesh,
    reduce_fin,
)
from .freeplay import describing_function, freeplay_force, gap_ratio, kappa_of_ratio
from .from_test import (
    TEST_NAMES,
    UPDATE_PARAMETERS,
    MeasuredModes,
    ModalTest,
    ModalTestError,
    ModelBuild,
    ModeValidation,
    SealedUpdate,
    TestComparison,
    UpdateResult,
    mode_table,
    model_from_modal_test,
    part_modes,
    update_model,
    update_to_sealed_modes,
    validate_modes,
)
from .modal import Modes, closed_mode_damping, mac, modal_analysis, pair_modes
from .options import ModelOptions
from .reduce import Reduction, craig_bampton, guyan
from .small import sdof_system, two_dof_system
from .system import FreeplaySystem, SystemFileError, load_system, save_system

__all__ = [
    "ModelOptions",
    "FreeplaySystem",
    "SystemFileError",
    "load_system",
    "save_system",
    "freeplay_force",
    "describing_function",
    "kappa_of_ratio",
    "gap_ratio",
    "rayleigh_damping",
    "rayleigh_coefficients",
    "modal_damping",
    "Modes",
    "modal_analysis",
    "closed_mode_damping",
    "mac",
    "pair_modes",
    "sdof_system",
    "two_dof_system",
    "UpdateResult",
    "update_model",
    "mode_table",
    "default_fin",
    "fin_from_config",
    "build_fin_fe",
    "reduce_fin",
    "fin_reduction",
    "part_matrices",
    "FinFE",
    "FinConfig",
    "PartProperties",
    "load_fin_config",
    "fin_config_path",
    "default_fin_parameters",
    "REDUCED_DOF_NAMES",
    "FIN_HINGE_PAIRS",
    "PlateMesh",
    "rectangular_mesh",
    "acm_element",
    "assemble_plate",
    "Reduction",
    "craig_bampton",
    "guyan",
    "ModeValidation",
    "validate_modes",
    "update_to_sealed_modes",
    "SealedUpdate",
    "ModelBuild",
    "TestComparison",
    "model_from_modal_test",
    "part_modes",
    "UPDATE_PARAMETERS",
    "MeasuredModes",
    "ModalTest",
    "ModalTestError",
    "TEST_NAMES",
]

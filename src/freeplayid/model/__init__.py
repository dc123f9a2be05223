"""Linear structure and freeplay: system files, restoring force, describing function, modal tools,
small test models and the default folding fin (plate FE + Craig-Bampton reduction)."""

from .build import (
    UPDATE_PARAMETERS,
    ModelBuild,
    TestComparison,
    model_from_modal_test,
    part_modes,
)
from .damping import modal_damping, rayleigh_coefficients, rayleigh_damping
from .fin import (
    FIN_HINGE_PAIRS,
    REDUCED_DOF_NAMES,
    FinFE,
    build_fin_fe,
    default_fin,
    fin_from_config,
    fin_reduction,
    part_matrices,
    reduce_fin,
)
from .fin_config import (
    FinConfig,
    PartProperties,
    default_fin_parameters,
    fin_config_path,
    load_fin_config,
)
from .freeplay import describing_function, freeplay_force, gap_ratio, kappa_of_ratio
from .modal import Modes, mac, modal_analysis, pair_modes
from .modal_test import TEST_NAMES, MeasuredModes, ModalTest, ModalTestError
from .plate import PlateMesh, acm_element, assemble_plate, rectangular_mesh
from .reduce import Reduction, craig_bampton, guyan
from .small import sdof_system, two_dof_system
from .system import FreeplaySystem, SystemFileError, load_system, save_system
from .update import UpdateResult, mode_table, update_model
from .validate import ModeValidation, validate_modes

__all__ = [
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

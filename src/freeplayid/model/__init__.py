"""Linear structure and freeplay: system files, restoring force, describing function, modal tools,
small test models and the default folding fin (plate FE + Craig-Bampton reduction)."""

from .damping import modal_damping, rayleigh_coefficients, rayleigh_damping
from .freeplay import describing_function, freeplay_force, gap_ratio, kappa_of_ratio
from .modal import Modes, mac, modal_analysis, pair_modes
from .small import sdof_system, two_dof_system
from .system import FreeplaySystem, SystemFileError, load_system, save_system
from .update import UpdateResult, mode_table, update_model

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
]

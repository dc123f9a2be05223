"""The default folding fin: its configuration (``config.py``, the package data ``fin.yaml``), the
Kirchhoff plate element and meshes (``plate.py``), the rigid-knuckle hinges (``knuckle.py``) and
the assembled plate FE with its reduction to a :class:`~freeplayid.model.FreeplaySystem`
(``fe.py``); docs/model.md."""

from .config import (
    FinConfig,
    PartProperties,
    default_fin_parameters,
    fin_config_path,
    load_fin_config,
)
from .fe import (
    FIN_HINGE_PAIRS,
    REDUCED_DOF_NAMES,
    FinFE,
    build_fin_fe,
    default_fin,
    fin_from_config,
    fin_reduction,
    part_matrices,
    part_meshes,
    reduce_fin,
)
from .knuckle import KnuckleMap, knuckle_map, knuckle_nodes
from .plate import PlateMesh, acm_element, assemble_plate, flexural_rigidity, rectangular_mesh

__all__ = [
    "FinConfig", "PartProperties", "default_fin_parameters", "fin_config_path", "load_fin_config",
    "FIN_HINGE_PAIRS", "REDUCED_DOF_NAMES", "FinFE", "build_fin_fe", "default_fin",
    "fin_from_config", "fin_reduction", "part_matrices", "part_meshes", "reduce_fin",
    "KnuckleMap", "knuckle_map", "knuckle_nodes",
    "PlateMesh", "acm_element", "assemble_plate", "flexural_rigidity", "rectangular_mesh",
]

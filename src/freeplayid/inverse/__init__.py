"""Neural inverse model: a set network from backbone fitting points to (kn, delta).

``points``: the flat point-set layout of many identification cases (:class:`PointSets`).
``network``: the normalisation, the padding collate and the DeepSets network (torch only).
``lightning``: training (LightningModule, DataModule, :func:`train_inverse_model`).
``inference``: :func:`load_inverse_model` -> :class:`InverseModel` -> :class:`InversePrediction`.
``calibration``: the spreads' scale, the training domain, coverage and SBC ranks.

The simulated data sets it is trained on and the comparison studies are in
:mod:`freeplayid.studies`.
"""

from .calibration import Calibration, TrainingDomain, calibration_metrics
from .inference import (
    InverseDomainWarning,
    InverseModel,
    InverseModelError,
    InversePrediction,
    calibrate_checkpoint,
    load_inverse_model,
)
from .lightning import InverseModule, PointSetDataModule, train_inverse_model
from .network import InverseNet, Normalisation, collate_point_sets
from .pointsets import PointSets, point_sets_from_records

__all__ = [
    "PointSets", "point_sets_from_records",
    "Normalisation", "collate_point_sets", "InverseNet",
    "InverseModule", "PointSetDataModule", "train_inverse_model",
    "InverseModel", "InversePrediction", "InverseModelError", "load_inverse_model",
    "InverseDomainWarning", "Calibration", "TrainingDomain", "calibrate_checkpoint",
    "calibration_metrics",
]

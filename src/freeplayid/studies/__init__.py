"""Simulated data sets and the studies of the inverse model against pure fitting.

``bank``: sweep banks at a reference gap (:class:`BankSpec` -> :func:`simulate_bank` ->
:class:`SweepBank`), cached on disk.
``cases``: identification cases drawn from a bank (:class:`CaseSpec` -> :func:`build_cases` ->
:class:`~freeplayid.inverse.PointSets`) and their split by kn (:func:`split_by_kn`).
``study``: a study's data (:func:`prepare_study` -> :class:`StudyData`) and its network
(:func:`train_study_network`).
``compare``: the network alone and the fitting methods on the same held-out cases
(:func:`network_rows`, :func:`fit_cases`, :func:`summarise`, :func:`network_metrics`).
"""

from .bank import DELTA_REF, BankSpec, SweepBank, simulate_bank
from .cases import AXES, CaseSpec, build_cases, split_by_kn
from .compare import METHODS, fit_cases, network_metrics, network_rows, summarise
from .study import StudyData, prepare_study, train_study_network

__all__ = [
    "BankSpec", "SweepBank", "DELTA_REF", "simulate_bank",
    "CaseSpec", "AXES", "build_cases", "split_by_kn",
    "StudyData", "prepare_study", "train_study_network",
    "METHODS", "network_rows", "fit_cases", "summarise", "network_metrics",
]

"""Simulated data sets and the studies of the inverse model against pure fitting.

``bank``: sweep banks at a reference gap (:class:`BankSpec` -> :func:`simulate_bank` ->
:class:`SweepBank`), cached on disk.
``cases``: identification cases drawn from a bank (:class:`CaseSpec` -> :func:`plan_cases` ->
:func:`build_cases` -> :class:`~freeplayid.inverse.PointSets`), their split by kn
(:func:`split_by_kn`) and a stored case's records rebuilt as a data set (:func:`rebuild_case`).
``study``: a study's data (:func:`prepare_study` -> :class:`StudyData`) and its network
(:func:`train_study_network`).
``compare``: the network alone and the fitting methods on the same held-out cases
(:func:`network_rows`, :func:`fit_cases`, :func:`corrected_cases`, :func:`summarise`,
:func:`network_metrics`); ``comparison``: the whole study (:func:`compare_methods` ->
:class:`Comparison`).
"""

from .bank import DELTA_REF, BankSpec, SweepBank, simulate_bank
from .cases import (
    AXES,
    CaseSpec,
    PlannedCase,
    build_cases,
    plan_cases,
    rebuild_case,
    require_plan_index,
    split_by_kn,
)
from .comparison import Comparison, compare_methods, pick_cases
from .methods import (
    CORRECTED,
    METHODS,
    corrected_cases,
    fit_cases,
    network_metrics,
    network_rows,
    summarise,
)
from .study import StudyData, prepare_study, train_study_network

__all__ = [
    "BankSpec", "SweepBank", "DELTA_REF", "simulate_bank",
    "CaseSpec", "AXES", "PlannedCase", "plan_cases", "build_cases", "rebuild_case",
    "require_plan_index", "split_by_kn",
    "StudyData", "prepare_study", "train_study_network",
    "METHODS", "CORRECTED", "network_rows", "fit_cases", "corrected_cases", "summarise",
    "network_metrics", "Comparison", "compare_methods", "pick_cases",
]

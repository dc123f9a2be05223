"""A study's data and network: the bank, the cases, their split by kn, the trained network.

:func:`prepare_study` builds (or loads from the cache) the sweep bank and the identification
cases of a model and splits them by kn into train / validation / test (:class:`StudyData`);
:func:`train_study_network` trains the set network on it and keeps the best checkpoint. The
``train`` and ``compare`` tasks both start from them.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..inverse.pointsets import PointSets
from ..model.system import FreeplaySystem
from .bank import BankSpec, simulate_bank
from .cases import CaseSpec, build_cases, split_by_kn

__all__ = ["StudyData", "prepare_study", "train_study_network"]


@dataclass(frozen=True)
class StudyData:
    """The simulated cases of a study, split by kn (no kn shared between the parts).

    Attributes
    ----------
    system : FreeplaySystem
        The model the bank was simulated with.
    channels : tuple of str
        The bank's channels (the network's input DOFs, in that order).
    train, val, test : PointSets
    bank_key, cases_key : str
        Cache keys of the bank and the cases.
    n_dropped : int
        Planned cases dropped for having fewer than 2 used points.
    build_s : float [s]
        Wall time of building (or loading) the data.
    """

    system: FreeplaySystem
    channels: tuple
    train: PointSets
    val: PointSets
    test: PointSets
    bank_key: str
    cases_key: str
    n_dropped: int
    build_s: float


def prepare_study(
    system: FreeplaySystem,
    *,
    bank_spec: BankSpec,
    case_spec: CaseSpec,
    split: Sequence[float],
    cache_dir: str | Path = "outputs/datasets",
    progress: bool = True,
) -> StudyData:
    """Build (or load from the cache) the bank and cases of ``system`` and split them by kn.

    Parameters
    ----------
    system : FreeplaySystem
    bank_spec : BankSpec
        The sweep bank (:func:`freeplayid.studies.simulate_bank`).
    case_spec : CaseSpec
        The cases drawn from it (:func:`freeplayid.studies.build_cases`).
    split : (float, float, float)
        Train / validation / test fractions of the bank's kn values (:func:`split_by_kn`).
    cache_dir : path-like
        Where the bank and the cases are cached.
    progress : bool

    Raises
    ------
    ValueError
        ``split`` is not 3 fractions, or a part of the split has no case.
    """
    t0 = time.perf_counter()
    split = tuple(split)
    if len(split) != 3:
        raise ValueError(f"`split` must give 3 fractions (train, val, test), got {split!r}")
    bank = simulate_bank(system, bank_spec, cache_dir=cache_dir, progress=progress)
    cases = build_cases(bank, case_spec, cache_dir=cache_dir, progress=progress)
    parts = split_by_kn(cases, bank_spec.n_kn, split)
    for name, p in zip(("train", "validation", "test"), parts, strict=True):
        if p.n_cases == 0:
            raise ValueError(f"the {name} split has no case with 2 or more points; raise the "
                             f"bank's `n_kn` or change `split`, or widen the level ratios")
    n_planned = bank_spec.n_kn * len(case_spec.values) * case_spec.cases_per_value
    return StudyData(system=system, channels=bank_spec.channels, train=parts[0], val=parts[1],
                     test=parts[2], bank_key=bank.key, cases_key=case_spec.key(bank),
                     n_dropped=n_planned - cases.n_cases, build_s=time.perf_counter() - t0)


def train_study_network(
    data: StudyData,
    out_dir: str | Path,
    *,
    extra: Mapping | None = None,
    **training,
) -> tuple[Path, dict]:
    """Train the set network on ``data``; the best checkpoint goes to ``out_dir/checkpoint.ckpt``,
    calibrated on ``data.val`` (:func:`freeplayid.inverse.calibrate_checkpoint`).

    Parameters
    ----------
    data : StudyData
        Trained on ``data.train``, the best epoch chosen on ``data.val``.
    out_dir : path-like
        Gets ``checkpoint.ckpt`` (the one checkpoint: Lightning's own go to a temporary folder)
        and the per-epoch log of ``logger`` (``metrics.csv`` by default).
    extra : dict, optional
        Stored in the checkpoint, with the data's ``bank`` and ``cases`` keys added.
    **training
        Further arguments of :func:`freeplayid.inverse.train_inverse_model` (``hidden``,
        ``depth``, ``lr``, ``weight_decay``, ``batch_size``, ``max_epochs``, ``seed``,
        ``accelerator``, ``logger``, ``early_stopping``, ``trainer_kwargs``...).

    Returns
    -------
    checkpoint : Path
        ``out_dir/checkpoint.ckpt``.
    history : dict of str -> list
        The per-epoch losses (:func:`freeplayid.inverse.train_inverse_model`).
    """
    from ..inverse import calibrate_checkpoint, train_inverse_model

    out = Path(out_dir)
    extra = {**(extra or {}), "bank": data.bank_key, "cases": data.cases_key}
    with tempfile.TemporaryDirectory(prefix=".checkpoints-", dir=out) as tmp:
        _, trainer, history = train_inverse_model(
            data.train, data.val, channels=data.channels, fingerprint=data.system.fingerprint(),
            structure=data.system.structure(), out_dir=tmp, log_dir=out, extra=extra,
            **training,
        )
        best = Path(trainer.checkpoint_callback.best_model_path or "")
        if not best.is_file():
            raise RuntimeError("training wrote no checkpoint")
        target = out / "checkpoint.ckpt"
        shutil.copyfile(best, target)
    calibrate_checkpoint(target, data.train, data.val, system=data.system)
    return target, history

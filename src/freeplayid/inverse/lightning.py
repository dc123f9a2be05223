"""Training of the set network (:mod:`.network`) with PyTorch Lightning.

:class:`InverseModule` (the LightningModule, whose checkpoint carries the channels, the linear
model's fingerprint, the normalisation and free metadata), :class:`PointSetDataModule` and
:func:`train_inverse_model` (seeded training with the per-epoch history). Inference is in
:mod:`.inference`.

Loss: the Gaussian negative log-likelihood of the normalised targets y (2 per case),
``0.5 * (s + (y - mu)^2 exp(-s))`` averaged over the known targets (the constant ``0.5 log 2 pi``
dropped), with mu, s the predicted mean and log-variance.
"""

from __future__ import annotations

import copy
import logging
import math
import os
import warnings
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytorch_lightning as pl
import torch

from ..progress import progress_bar, warnings_wanted
from .network import InverseNet, Normalisation, collate_point_sets
from .pointsets import PointSets

__all__ = ["InverseModule", "PointSetDataModule", "train_inverse_model", "gaussian_nll",
           "make_logger", "LOGGERS"]

_CKPT_KEY = "freeplayid_inverse"  # marks our checkpoints; the value is the format version
# 2: the normalisation may carry the noise input's (2026-11-29), and the rate input's
# (2026-11-30; a checkpoint without it reads as before)
_CKPT_VERSION = 2
# the linear structure (FreeplaySystem.structure()) the cases came from: compared with a model's
# within a relative tolerance on loading (the fingerprint alone is exact to 12 decimals)
_STRUCTURE_KEY = "freeplayid_structure"
HISTORY_KEYS = ("train_loss", "val_loss", "val_mae_log_kn", "val_mae_log_delta")
_SCHEDULES = ("onecycle", "constant")


def gaussian_nll(mean: torch.Tensor, log_var: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """Mean Gaussian NLL over the finite entries of ``y``; all shapes (batch, 2)."""
    known = torch.isfinite(y)
    r = torch.where(known, y, 0.0) - mean
    nll = 0.5 * (log_var + r.square() * torch.exp(-log_var))
    return torch.where(known, nll, 0.0).sum() / known.sum().clamp(min=1)


def _plain(obj, name: str = "extra"):
    """``obj`` as plain Python (dict/list/str/int/float/bool/None), so a checkpoint holding it
    loads with ``torch.load(weights_only=True)`` and dumps to YAML. Mappings (an OmegaConf
    ``DictConfig`` too) become dicts, sequences lists, NumPy values Python ones."""
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return obj
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if isinstance(obj, Mapping):
        return {str(k): _plain(v, f"{name}[{k!r}]") for k, v in obj.items()}
    if isinstance(obj, Sequence):
        return [_plain(v, f"{name}[{i}]") for i, v in enumerate(obj)]
    raise TypeError(f"`{name}` must hold only mappings, sequences, str, numbers, bool or None, "
                    f"got {type(obj).__name__}")


class InverseModule(pl.LightningModule):
    """LightningModule of :class:`~.network.InverseNet`.

    Parameters
    ----------
    channels : tuple of str
        DOF names of the channel indices, as in the training :class:`PointSets`.
    fingerprint : str
        ``FreeplaySystem.fingerprint()`` of the linear model the training cases came from.
    norm : dict
        ``Normalisation.as_dict()`` of the training set (a :class:`Normalisation` is accepted).
    hidden, depth : int
        Width and depth of the network (:class:`~.network.InverseNet`).
    activation : {"silu", "gelu"}
    lr : float
        Peak learning rate of AdamW.
    weight_decay : float
    schedule : {"onecycle", "constant"}
        "onecycle": linear warm-up from lr/10 over 5 % of the steps, then cosine to lr/100 at the
        trainer's last step (``trainer.estimated_stepping_batches``; constant if that is
        infinite).
    extra : dict, optional
        Free metadata stored in the checkpoint (data-set config, kn/delta prior ranges, ...);
        converted to plain Python (see ``_plain``).
    structure : dict, optional
        ``FreeplaySystem.structure()`` of that linear model, stored in the checkpoint next to the
        hyper-parameters (``load_inverse_model`` compares it within a relative tolerance).

    All of these but ``structure`` are saved as hyper-parameters, so
    ``InverseModule.load_from_checkpoint(path)`` restores the module.
    """

    def __init__(self, *, channels: Sequence[str], fingerprint: str, norm: Mapping,
                 hidden: int = 64, depth: int = 3, activation: str = "silu", lr: float = 3e-3,
                 weight_decay: float = 1e-4, schedule: str = "onecycle",
                 extra: Mapping | None = None, structure: Mapping | None = None):
        super().__init__()
        self.structure = None if structure is None else _plain(structure, "structure")
        if isinstance(channels, str) or not channels:
            raise ValueError(f"`channels` must be a non-empty sequence of DOF names, "
                             f"got {channels!r}")
        if schedule not in _SCHEDULES:
            raise ValueError(f"`schedule` must be one of {list(_SCHEDULES)}, got {schedule!r}")
        if not lr > 0 or not weight_decay >= 0:
            raise ValueError(f"`lr` must be > 0 and `weight_decay` >= 0, got {lr!r}, "
                             f"{weight_decay!r}")
        self._norm = Normalisation.from_dict(norm)
        self.save_hyperparameters({
            "channels": [str(c) for c in channels], "fingerprint": str(fingerprint),
            "norm": self._norm.as_dict(), "hidden": int(hidden), "depth": int(depth),
            "activation": str(activation), "lr": float(lr), "weight_decay": float(weight_decay),
            "schedule": schedule, "extra": _plain(extra),
        })
        self.net = InverseNet(len(channels), hidden=hidden, depth=depth, activation=activation,
                              noise_input=self._norm.uses_noise,
                              rate_input=self._norm.uses_rate)

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(self.hparams["channels"])

    @property
    def fingerprint(self) -> str:
        return self.hparams["fingerprint"]

    @property
    def norm(self) -> Normalisation:
        return self._norm

    @property
    def extra(self) -> dict | None:
        return self.hparams["extra"]

    def forward(self, x: torch.Tensor, mask: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """See :meth:`InverseNet.forward`."""
        return self.net(x, mask)

    def _step(self, batch: dict, stage: str) -> torch.Tensor:
        mean, log_var = self(batch["x"], batch["mask"])
        y = batch["y"]
        loss = gaussian_nll(mean, log_var, y)
        known = torch.isfinite(y).all(dim=1)
        n = max(int(known.sum()), 1)
        self.log(f"{stage}_loss", loss, on_step=False, on_epoch=True, prog_bar=True,
                 batch_size=n)
        if stage != "train" and known.any():
            scale = torch.as_tensor(self._norm.target_std, dtype=mean.dtype, device=mean.device)
            mae = ((mean - y).abs()[known] * scale).mean(dim=0)  # natural-log units
            self.log(f"{stage}_mae_log_kn", mae[0], on_epoch=True, prog_bar=True,
                     batch_size=int(known.sum()))
            self.log(f"{stage}_mae_log_delta", mae[1], on_epoch=True, prog_bar=True,
                     batch_size=int(known.sum()))
        return loss

    def training_step(self, batch, batch_idx):
        return self._step(batch, "train")

    def validation_step(self, batch, batch_idx):
        self._step(batch, "val")

    def test_step(self, batch, batch_idx):
        self._step(batch, "test")

    def configure_optimizers(self):
        hp = self.hparams
        opt = torch.optim.AdamW(self.parameters(), lr=hp["lr"], weight_decay=hp["weight_decay"])
        total = float(self.trainer.estimated_stepping_batches) if self._trainer else math.inf
        if hp["schedule"] == "constant" or not math.isfinite(total):
            return opt
        total = max(int(total), 1)
        warm = max(int(0.05 * total), 1)

        def factor(step: int) -> float:
            if step < warm:
                return 0.1 + 0.9 * step / warm
            t = min((step - warm) / max(total - warm, 1), 1.0)
            return 0.01 + 0.99 * 0.5 * (1.0 + math.cos(math.pi * t))

        sched = torch.optim.lr_scheduler.LambdaLR(opt, factor)
        return {"optimizer": opt, "lr_scheduler": {"scheduler": sched, "interval": "step"}}

    def on_save_checkpoint(self, checkpoint: dict) -> None:
        checkpoint[_CKPT_KEY] = _CKPT_VERSION
        if self.structure is not None:
            checkpoint[_STRUCTURE_KEY] = self.structure


class _CaseIndices(torch.utils.data.Dataset):
    def __init__(self, n: int):
        self.n = n

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, i: int) -> int:
        return i


class _Collate:
    """Picklable collate_fn: case indices -> padded batch."""

    def __init__(self, ps: PointSets, norm: Normalisation):
        self.ps, self.norm = ps, norm

    def __call__(self, cases: list[int]) -> dict:
        return collate_point_sets(self.ps, np.asarray(cases, np.int64), norm=self.norm)


def _check_training_set(ps: PointSets, name: str) -> None:
    if not isinstance(ps, PointSets):
        raise TypeError(f"`{name}` must be a PointSets, got {type(ps).__name__}")
    if ps.n_cases == 0:
        raise ValueError(f"`{name}` must have cases, got 0")
    unknown = np.flatnonzero(~(np.isfinite(ps.kn) & np.isfinite(ps.delta)
                               & (ps.kn > 0) & (ps.delta > 0)))
    if unknown.size:
        raise ValueError(f"`{name}` must have the truth (kn, delta > 0) of every case; "
                         f"{unknown.size} cases lack it, e.g. {unknown[:5].tolist()}")
    empty = np.flatnonzero(ps.n_points == 0)
    if empty.size:
        raise ValueError(f"`{name}` must have >= 1 point per case; {empty.size} cases have "
                         f"none, e.g. {empty[:5].tolist()}")


class PointSetDataModule(pl.LightningDataModule):
    """Batches of padded point sets (:func:`collate_point_sets`) of train/val(/test) cases.

    The normalisation comes from ``train`` only and is ``dm.norm``. Every case must have its
    truth and at least one point. ``num_workers=0``: collating a batch takes microseconds.
    ``noise_input``: whether the network reads each point's noise floor (``noise_db``; None:
    when every point of ``train`` has a finite one); ``rate_input``: its sweep's rate
    (``rate``).
    """

    def __init__(self, train: PointSets, val: PointSets, test: PointSets | None = None, *,
                 batch_size: int = 64, noise_input: bool | None = None,
                 rate_input: bool = False):
        super().__init__()
        for name, ps in (("train", train), ("val", val), ("test", test)):
            if ps is not None:
                _check_training_set(ps, name)
                if ps.channels != train.channels:
                    raise ValueError(f"`{name}.channels` must equal `train.channels` "
                                     f"{train.channels}, got {ps.channels}")
        if int(batch_size) < 1:
            raise ValueError(f"`batch_size` must be >= 1, got {batch_size!r}")
        self.train_set, self.val_set, self.test_set = train, val, test
        self.batch_size = int(batch_size)
        self.norm = Normalisation.from_point_sets(train, noise=noise_input, rate=rate_input)

    def _loader(self, ps: PointSets, *, shuffle: bool) -> torch.utils.data.DataLoader:
        return torch.utils.data.DataLoader(
            _CaseIndices(ps.n_cases), batch_size=self.batch_size, shuffle=shuffle,
            collate_fn=_Collate(ps, self.norm), num_workers=0,
        )

    def train_dataloader(self):
        return self._loader(self.train_set, shuffle=True)

    def val_dataloader(self):
        return self._loader(self.val_set, shuffle=False)

    def test_dataloader(self):
        if self.test_set is None:
            raise ValueError("no `test` PointSets was given to PointSetDataModule")
        return self._loader(self.test_set, shuffle=False)


class _History(pl.Callback):
    """Per-epoch metrics and the in-memory best weights (lowest ``val_loss``)."""

    def __init__(self):
        self.history: dict[str, list] = {"epoch": [], **{k: [] for k in HISTORY_KEYS}}
        self.best_loss = math.inf
        self.best_state: dict | None = None

    def on_validation_end(self, trainer, pl_module):
        if trainer.sanity_checking:
            return
        v = float(trainer.callback_metrics.get("val_loss", math.nan))
        if v < self.best_loss:  # strict, as ModelCheckpoint(mode="min")
            self.best_loss = v
            self.best_state = copy.deepcopy(pl_module.state_dict())

    def on_train_epoch_end(self, trainer, pl_module):
        # the epoch's validation has run by now; its metrics are in callback_metrics
        m = trainer.callback_metrics
        self.history["epoch"].append(trainer.current_epoch)
        for k in HISTORY_KEYS:
            self.history[k].append(float(m[k]) if k in m else math.nan)


class _EpochBar(pl.Callback):
    """One bar over the epochs with the losses as its postfix (``tqdm.auto``: a widget in a
    notebook), in place of Lightning's bars per batch and per validation."""

    def __init__(self):
        self.bar = None

    def on_train_start(self, trainer, pl_module):
        total = trainer.max_epochs if trainer.max_epochs and trainer.max_epochs > 0 else None
        self.bar = progress_bar(total=total, desc="training", unit="epoch")

    def on_train_epoch_end(self, trainer, pl_module):
        m = trainer.callback_metrics  # the epoch's validation has run by now
        self.bar.set_postfix_str(", ".join(f"{k} {float(m[k]):.4g}" for k in
                                           ("train_loss", "val_loss") if k in m), refresh=False)
        self.bar.update(1)

    def on_train_end(self, trainer, pl_module):
        self.bar.close()

    def on_exception(self, trainer, pl_module, exception):
        if self.bar is not None:
            self.bar.close()


# Lightning's loggers: its banners ("GPU available: ...", "TPU available: ..."), its tips and
# "`Trainer.fit` stopped: ..." are INFO lines on them
LIGHTNING_LOGGERS = ("pytorch_lightning", "lightning.pytorch", "lightning_fabric",
                     "lightning.fabric")


@contextmanager
def lightning_quiet() -> Iterator[None]:
    """Lightning's INFO lines and the deprecation warnings Lightning and torch raise inside it
    (e.g. torch's ``LeafSpec`` in Lightning's ``_pytree``), quiet in the block unless
    ``FREEPLAYID_WARNINGS`` is set (:func:`freeplayid.progress.warnings_wanted`). Its progress
    bar and its own warnings (a real problem of the training) stay."""
    if warnings_wanted():
        yield
        return
    loggers = [logging.getLogger(name) for name in LIGHTNING_LOGGERS]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.WARNING)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            warnings.simplefilter("ignore", FutureWarning)
            yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


LOGGERS = ("csv", "tensorboard", "none")


def make_logger(kind: bool | str, folder: str | os.PathLike | None):
    """The Lightning logger of ``kind`` (:data:`LOGGERS`; True is "csv", False "none") writing
    to ``folder`` (no logger without one).

    Raises
    ------
    ValueError
        An unknown kind, or "tensorboard" without the ``tensorboard`` package (one line that
        says how to install it).
    """
    kind = {True: "csv", False: "none"}.get(kind, kind)
    if kind not in LOGGERS:
        raise ValueError(f"`logger` must be one of {list(LOGGERS)}, got {kind!r}")
    if folder is None or kind == "none":
        return False
    if kind == "csv":
        return pl.loggers.CSVLogger(folder, name="", version="")
    try:
        import tensorboard  # noqa: F401
    except ImportError:
        raise ValueError("`logger` tensorboard needs the tensorboard package: "
                         "pip install tensorboard (or use logger=csv)") from None
    return pl.loggers.TensorBoardLogger(folder, name="tensorboard", version="",
                                        default_hp_metric=False)


def train_inverse_model(
    train: PointSets, val: PointSets, *, channels: Sequence[str], fingerprint: str,
    hidden: int = 64, depth: int = 3, activation: str = "silu", lr: float = 3e-3,
    weight_decay: float = 1e-4, schedule: str = "onecycle", batch_size: int = 64,
    max_epochs: int = 100, seed: int = 0, out_dir: str | os.PathLike | None = None,
    extra: Mapping | None = None, structure: Mapping | None = None,
    accelerator: str = "auto", enable_progress_bar: bool = True,
    logger: bool | str = True, log_dir: str | os.PathLike | None = None,
    early_stopping: Mapping | None = None, trainer_kwargs: Mapping | None = None,
    noise_input: bool | None = None, rate_input: bool = False,
) -> tuple[InverseModule, pl.Trainer, dict[str, list]]:
    """Seeded training of an :class:`InverseModule` on ``train``, validated on ``val``.

    Parameters
    ----------
    train, val : PointSets
        Every case with its truth and >= 1 point; the normalisation is ``train``'s.
    channels : sequence of str
        Must equal ``train.channels`` (the model's measured DOFs, in that order).
    fingerprint : str
        ``FreeplaySystem.fingerprint()`` of the model the cases were simulated with.
    hidden, depth, activation, lr, weight_decay, schedule, extra, structure
        See :class:`InverseModule`.
    batch_size, max_epochs, seed : int
    out_dir : path-like, optional
        Where ``best.ckpt`` (lowest ``val_loss``) goes, and the log unless ``log_dir`` is
        given. Without either nothing is written.
    accelerator : str
        ``pl.Trainer`` accelerator; "auto" takes one GPU when present. On CPU a run is
        reproducible for a given ``seed``.
    enable_progress_bar : bool
        A bar over the epochs with the losses (not Lightning's bars per batch).
    logger : bool or {"csv", "tensorboard", "none"}
        The per-epoch log: "csv" (True) ``metrics.csv`` and ``hparams.yaml``, "tensorboard"
        event files under ``tensorboard/`` (needs the ``tensorboard`` package), "none" (False).
    log_dir : path-like, optional
        The log's folder (default ``out_dir``).
    early_stopping : dict, optional
        Stop when ``val_loss`` has not fallen by ``min_delta`` (default 0) for ``patience``
        epochs (Lightning's ``EarlyStopping``); the best epoch is kept either way. With the
        "onecycle" schedule the learning rate falls to its end only at ``max_epochs``, where
        the best epochs usually are: stopping early then costs accuracy.
    trainer_kwargs : dict, optional
        Further ``pl.Trainer`` arguments (override the above).
    noise_input : bool, optional
        Whether each point's noise floor (``noise_db``) is a network input (None: when every
        training point has a finite one; :class:`PointSetDataModule`).
    rate_input : bool
        Whether each point's sweep rate (``rate``) is a network input.

    Returns
    -------
    module : InverseModule
        With the weights of the epoch with the lowest ``val_loss``.
    trainer : pl.Trainer
    history : dict of str -> list, each of length n_epochs
        ``epoch``, ``train_loss``, ``val_loss`` (NLL of normalised targets), ``val_mae_log_kn``,
        ``val_mae_log_delta`` (natural-log units).
    """
    if tuple(channels) != tuple(train.channels):
        raise ValueError(f"`channels` must equal `train.channels` {list(train.channels)}, "
                         f"got {list(channels)}")
    pl.seed_everything(seed, workers=True, verbose=False)
    dm = PointSetDataModule(train, val, batch_size=batch_size, noise_input=noise_input,
                            rate_input=rate_input)
    module = InverseModule(channels=channels, fingerprint=fingerprint, norm=dm.norm,
                           hidden=hidden, depth=depth, activation=activation, lr=lr,
                           weight_decay=weight_decay, schedule=schedule, extra=extra,
                           structure=structure)
    hist = _History()
    callbacks: list[pl.Callback] = [hist]
    if out_dir is not None:
        out_dir = Path(out_dir)
        callbacks.append(pl.callbacks.ModelCheckpoint(
            dirpath=out_dir, filename="best", monitor="val_loss", mode="min", save_top_k=1,
            auto_insert_metric_name=False, enable_version_counter=False,
        ))
    loggers = make_logger(logger, log_dir if log_dir is not None else out_dir)
    if early_stopping is not None:
        callbacks.append(pl.callbacks.EarlyStopping(
            monitor="val_loss", mode="min", patience=int(early_stopping["patience"]),
            min_delta=float(early_stopping.get("min_delta", 0.0))))
    if enable_progress_bar:
        callbacks.append(_EpochBar())
    kw = dict(
        max_epochs=max_epochs, accelerator=accelerator, devices=1, logger=loggers,
        callbacks=callbacks, enable_checkpointing=out_dir is not None,
        enable_progress_bar=False, enable_model_summary=False,  # the bar: _EpochBar
        log_every_n_steps=1, default_root_dir=out_dir,
    )
    kw.update(trainer_kwargs or {})
    with lightning_quiet(), warnings.catch_warnings():
        # num_workers=0 is deliberate (see PointSetDataModule)
        warnings.filterwarnings("ignore", message=r".*does not have many workers.*")
        trainer = pl.Trainer(**kw)
        trainer.fit(module, datamodule=dm)
    if hist.best_state is not None:
        module.load_state_dict(hist.best_state)
    module.eval()
    return module, trainer, hist.history

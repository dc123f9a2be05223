"""Inference with a trained inverse model: :func:`load_inverse_model` -> :class:`InverseModel`.

The checkpoint (``best.ckpt`` of :func:`~.lightning.train_inverse_model`) carries the channels, the
fingerprint of the linear model the training cases came from, the normalisation and free metadata;
a checkpoint made for another linear model is refused. A checkpoint calibrated by
:func:`calibrate_checkpoint` (``train.py`` does it) also carries the spread's scale and the
training domain (:mod:`.calibration`): predictions then have calibrated spreads, and a case
outside the domain is named in :attr:`InversePrediction.outside` and warned of
(:class:`InverseDomainWarning`) before its estimate is used.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..atomic import atomic_path
from ..errors import InverseDomainWarning, InverseModelError
from ..fit import FittingPoints
from .calibration import Calibration
from .lightning import _CKPT_KEY, _CKPT_VERSION, _STRUCTURE_KEY, InverseModule
from .network import Normalisation, collate_point_sets
from .pointsets import PointSets, point_sets_from_records

__all__ = ["InverseModelError", "InverseDomainWarning", "InversePrediction", "InverseModel",
           "load_inverse_model", "calibrate_checkpoint"]

_CALIBRATION_KEY = "freeplayid_calibration"  # the checkpoint's Calibration.to_dict()
# [-] a test's sweep rate at its point may differ from the training's rates by this factor
# either way before :meth:`InverseModel.sweep_outside` names it: a quarter, set a priori. The
# warning says where the training did not go, not that the estimate is off: the default network
# (0.1 Hz/s) read independent records swept at 0.15 Hz/s within 0.6 % in delta, at 0.25 Hz/s
# within 1.9 %, at 0.5 Hz/s 4-5 % off (docs/inverse.md)
RATE_TOLERANCE = 1.25


@dataclass(frozen=True)
class InversePrediction:
    """Inverse-model estimates of N cases.

    Attributes
    ----------
    kn : ndarray, shape (N,) [N m/rad]
        ``exp`` of the predicted mean of log kn (the median of the predicted log-normal).
    delta : ndarray, shape (N,) [rad]
        Likewise for delta.
    log_kn_std, log_delta_std : ndarray, shape (N,) [-]
        Predicted standard deviation of log kn, log delta (natural log); calibrated when the
        checkpoint is.
    outside : tuple of str
        Per case, why it lies outside the training domain ('' inside; all '' without a
        calibrated checkpoint, which records no domain).
    """

    kn: np.ndarray
    delta: np.ndarray
    log_kn_std: np.ndarray
    log_delta_std: np.ndarray
    outside: tuple = ()


class InverseModel:
    """Inference wrapper of a trained :class:`InverseModule` (see :func:`load_inverse_model`)."""

    def __init__(self, module: InverseModule, *, path: str | os.PathLike | None = None,
                 calibration: Calibration | None = None, system=None):
        if not isinstance(module, InverseModule):
            raise TypeError(f"`module` must be an InverseModule, got {type(module).__name__}")
        self.module = module
        self.path = None if path is None else Path(path)
        self.calibration = calibration
        self.system = system  # the linear model, when given: the domain's backbone check

    @property
    def channels(self) -> tuple[str, ...]:
        return self.module.channels

    @property
    def fingerprint(self) -> str:
        return self.module.fingerprint

    @property
    def extra(self) -> dict | None:
        return self.module.extra

    @property
    def norm(self) -> Normalisation:
        return self.module.norm

    def predict(self, ps: PointSets, *, batch_size: int = 4096,
                calibrated: bool = True) -> InversePrediction:
        """Estimates of every case of ``ps``; with a calibrated checkpoint (and ``calibrated``)
        the calibrated posterior's median and 68 % half-width (:mod:`.calibration`), and the
        cases outside the training domain named in ``outside`` and warned of (one
        :class:`InverseDomainWarning` for all of them).

        Raises
        ------
        ValueError
            ``ps.channels`` differ from the model's, or cases have no points (named), or the
            network reads the points' sweep rates (:attr:`uses_rate`) and ``ps`` has none.
        """
        if self.uses_rate and ps.rate is None:
            raise ValueError(f"inverse model {self.path or ''}: this network reads each point's "
                             "sweep rate [Hz/s] and the points have none (give them: "
                             "predict_points(points, rate=...), point_sets_from_records(..., "
                             "rate=...))")
        if ps.channels != self.channels:
            raise ValueError(f"`ps.channels` must be the model's channels {list(self.channels)}, "
                             f"got {list(ps.channels)}")
        empty = np.flatnonzero(ps.n_points == 0)
        if empty.size:
            raise ValueError(f"cases {empty[:20].tolist()}{' ...' if empty.size > 20 else ''} "
                             "have no points; the inverse model needs >= 1 point per case")
        if self.norm.uses_noise and not ps.noise_known:
            n = ps.case.size if ps.noise_db is None else int(np.sum(~np.isfinite(ps.noise_db)))
            warnings.warn(f"inverse model {self.path or ''}: {n} of {ps.case.size} points carry "
                          "no measured noise floor (noise_db), which this network reads as its "
                          "word of the noise; they get the training points' mean, so the spread is "
                          "an average test's, not this one's", InverseDomainWarning, stacklevel=2)
        net = self.module.net
        device = next(net.parameters()).device
        was_training = net.training
        net.eval()
        means, log_vars = [], []
        try:
            with torch.inference_mode():
                for s in range(0, ps.n_cases, batch_size):
                    b = collate_point_sets(ps, np.arange(s, min(s + batch_size, ps.n_cases)),
                                           norm=self.norm)
                    m, lv = net(b["x"].to(device), b["mask"].to(device))
                    means.append(m.double().cpu().numpy())
                    log_vars.append(lv.double().cpu().numpy())
        finally:
            net.train(was_training)
        mean = np.concatenate(means) if means else np.zeros((0, 2))
        log_var = np.concatenate(log_vars) if log_vars else np.zeros((0, 2))
        log_mean = self.norm.target_mean + mean * self.norm.target_std
        log_std = np.exp(0.5 * log_var) * self.norm.target_std
        kn, delta = np.exp(log_mean[:, 0]), np.exp(log_mean[:, 1])
        cal = self.calibration if calibrated else None
        if cal is None:
            return InversePrediction(kn=kn, delta=delta, log_kn_std=log_std[:, 0],
                                     log_delta_std=log_std[:, 1], outside=("",) * ps.n_cases)
        outside = tuple(cal.domain.outside(ps, {"kn": kn, "delta": delta,
                                                "log_kn_std": log_std[:, 0],
                                                "log_delta_std": log_std[:, 1]},
                                           system=self.system))
        bad = [i for i, w in enumerate(outside) if w]
        if bad:
            warnings.warn(f"inverse model {self.path or ''}: {len(bad)} of {ps.n_cases} cases lie "
                          f"outside what the network was trained on or are not explained by its "
                          f"estimate, which is not to be trusted there (case {bad[0]}: "
                          f"{outside[bad[0]]})", InverseDomainWarning, stacklevel=2)
        # the calibrated posterior's median and 68 % half-width (calibration module)
        shift = [cal.shift(p) for p in ("kn", "delta")]
        return InversePrediction(kn=kn * np.exp(log_std[:, 0] * shift[0]),
                                 delta=delta * np.exp(log_std[:, 1] * shift[1]),
                                 log_kn_std=log_std[:, 0] * cal.std_scale[0],
                                 log_delta_std=log_std[:, 1] * cal.std_scale[1], outside=outside)

    def sweep_outside(self, sweeps) -> str:
        """Why sweeps of a test lie outside those the network was trained on ('' inside, or
        when the checkpoint records no training data set).

        ``sweeps``: (run, Sweep, f [Hz]) of each run with a point, f the point's frequency. A
        point's drop depends on the sweep there: its direction and its rate at f. The training
        swept up or down, at the bank's rate at f times ``rate_range`` (one rate without it);
        a run sweeping the other way, or at a rate beyond that range by more than
        :data:`RATE_TOLERANCE`, is named (the points alone do not show it: a fast sweep's drop
        points lie near the backbone, later on it).
        """
        from ..sweep import Sweep, rate_at

        bank = ((self.extra or {}).get("dataset") or {}).get("bank") or {}
        if not bank.get("sweep"):
            return ""
        trained = Sweep(**bank["sweep"])
        lo, hi = bank.get("rate_range") or (1.0, 1.0)
        up = trained.stop_hz > trained.start_hz
        f_lo, f_hi = sorted((trained.start_hz, trained.stop_hz))
        other_way, off = [], []
        for run, sweep, f in sweeps:
            if (sweep.stop_hz > sweep.start_hz) != up:
                other_way.append(run)
                continue
            at = float(np.clip(f, f_lo, f_hi))
            rate, base = float(rate_at(sweep, f)), float(rate_at(trained, at))
            if not base * lo / RATE_TOLERANCE <= rate <= base * hi * RATE_TOLERANCE:
                off.append((run, rate, f, base))
        why = []
        if other_way:
            why.append(f"run{'s' if len(other_way) > 1 else ''} {', '.join(other_way)} "
                       f"sweep{'' if len(other_way) > 1 else 's'} {'down' if up else 'up'}; "
                       f"the network was trained on {'up' if up else 'down'}-sweeps "
                       f"({trained.describe()})")
        if off:
            runs, rates, fs, bases = zip(*off)
            b = float(np.median(bases))  # the training's rate at the points (log: it varies)
            trained_at = f"{b * lo:.3g} Hz/s" if lo == hi else f"{b * lo:.3g}-{b * hi:.3g} Hz/s"
            many = len(runs) > 1
            why.append(f"run{'s' if many else ''} {', '.join(runs)} sweep{'' if many else 's'} "
                       f"at {_span(rates, '.3g')} Hz/s at {'their points' if many else 'its point'}"
                       f" ({_span(fs, '.4g')} Hz); the network was trained on {trained_at} there "
                       f"({trained.describe()}" + ("" if lo == hi else f", rates x {lo:g}-{hi:g}")
                       + ")")
        return "; ".join(why)

    @property
    def uses_rate(self) -> bool:
        """Whether the network reads each point's sweep rate (trained with the rate input)."""
        return self.norm.uses_rate

    def predict_points(self, points: FittingPoints, *,
                       rate=None) -> tuple[float, float, float, float]:
        """One case from its fitting points (the start of ``fit_backbone(..., init=model)``);
        ``rate``: each point's sweep rate [Hz/s] (needed when :attr:`uses_rate`, else unused).

        Returns
        -------
        kn [N m/rad], delta [rad], log_kn_std, log_delta_std : float

        Raises
        ------
        TypeError
            ``points`` is not a FittingPoints.
        ValueError
            A point's channel is not one of :attr:`channels` (listed).
        """
        if not isinstance(points, FittingPoints):
            raise TypeError(f"`points` must be a freeplayid.fit.FittingPoints, got "
                            f"{type(points).__name__} (records: use predict_records)")
        p = self.predict(point_sets_from_records(points, self.channels,
                                                 rate=rate if self.uses_rate else None))
        return float(p.kn[0]), float(p.delta[0]), float(p.log_kn_std[0]), float(p.log_delta_std[0])

    def predict_records(self, records: Sequence[dict], *,
                        rate=None) -> tuple[float, float, float, float]:
        """One case from point records (``channel``, ``amplitude_m``, ``f_hz``; ``used``), as
        :meth:`predict_points` (one used record suffices here; ``rate`` for its used ones).

        Returns
        -------
        kn [N m/rad], delta [rad], log_kn_std, log_delta_std : float

        Raises
        ------
        ValueError
            A record's channel is not one of :attr:`channels` (listed), or no point is used.
        """
        p = self.predict(point_sets_from_records(records, self.channels,
                                                 rate=rate if self.uses_rate else None))
        return float(p.kn[0]), float(p.delta[0]), float(p.log_kn_std[0]), float(p.log_delta_std[0])


def _span(values, fmt: str) -> str:
    """"a" or "a-b" of the values' range, formatted."""
    a, b = f"{min(values):{fmt}}", f"{max(values):{fmt}}"
    return a if a == b else f"{a}-{b}"


def load_inverse_model(path: str | os.PathLike, *, system=None, rtol: float = 1e-8,
                       map_location: str | torch.device = "cpu") -> InverseModel:
    """Load an inverse-model checkpoint (``best.ckpt`` of :func:`train_inverse_model`).

    Parameters
    ----------
    path : path-like
    system : FreeplaySystem, optional
        The linear model the estimates are for: its ``structure()`` must be the checkpoint's
        within ``rtol`` (checkpoints without one: its ``fingerprint()`` must be theirs).
    rtol : float
        Relative tolerance of that comparison (:meth:`FreeplaySystem.structure_mismatch`):
        the same model built on another CPU differs by round-off (~1e-10) and passes.
    map_location : str or torch.device
        Device the network is put on.

    Raises
    ------
    InverseModelError
        The file is missing or not a freeplayid inverse-model checkpoint, or ``system`` has
        another structure than the one the model was trained for.
    """
    path = Path(path)
    if not path.is_file():
        raise InverseModelError(f"inverse model checkpoint {str(path)!r} does not exist")
    try:
        # weights_only: a checkpoint holds tensors and plain metadata, so nothing else may load
        ckpt = torch.load(path, map_location=map_location, weights_only=True)
    except Exception as e:
        raise InverseModelError(f"{str(path)!r} is not a freeplayid inverse model checkpoint "
                                f"(torch.load failed: {type(e).__name__}: {e})") from e
    if not isinstance(ckpt, dict) or _CKPT_KEY not in ckpt or not {
        "hyper_parameters", "state_dict"
    } <= set(ckpt):
        raise InverseModelError(f"{str(path)!r} is not a freeplayid inverse model checkpoint "
                                f"(no {_CKPT_KEY!r} entry); train one with scripts/train.py")
    if ckpt[_CKPT_KEY] > _CKPT_VERSION:
        raise InverseModelError(f"{str(path)!r} has checkpoint format {ckpt[_CKPT_KEY]}, this "
                                f"freeplayid reads up to {_CKPT_VERSION}; update freeplayid")
    hp = ckpt["hyper_parameters"]
    stored = ckpt.get(_STRUCTURE_KEY)
    if system is not None:
        if isinstance(stored, dict):
            why = system.structure_mismatch(stored, rtol=rtol)
        else:  # a checkpoint of an earlier freeplayid: the exact fingerprint
            want = system.fingerprint()
            why = None if want == hp["fingerprint"] else \
                f"checkpoint fingerprint {hp['fingerprint']}, model fingerprint {want}"
        if why is not None:
            raise InverseModelError(
                f"inverse model checkpoint {str(path)!r} was trained for a different linear "
                f"structure ({why}); retrain it for this model with "
                "`python scripts/train.py model=...` or drop `inverse.checkpoint`"
            )
    try:
        module = InverseModule(**hp, structure=stored if isinstance(stored, dict) else None)
        module.load_state_dict(ckpt["state_dict"])
    except (TypeError, ValueError, RuntimeError) as e:  # hand-edited or foreign hparams/weights
        raise InverseModelError(f"{str(path)!r} holds an inverse model this freeplayid cannot "
                                f"rebuild ({type(e).__name__}: {e})") from e
    module.to(map_location).eval()
    try:
        cal = Calibration.from_dict(ckpt[_CALIBRATION_KEY]) if _CALIBRATION_KEY in ckpt else None
    except (KeyError, TypeError, ValueError) as e:
        raise InverseModelError(f"{str(path)!r} has a calibration record this freeplayid cannot "
                                f"read ({type(e).__name__}: {e})") from e
    return InverseModel(module, path=path, calibration=cal, system=system)


def calibrate_checkpoint(path: str | os.PathLike, train: PointSets, val: PointSets, *,
                         system=None) -> Calibration:
    """Store in the checkpoint at ``path`` the :class:`~.calibration.Calibration` of its network:
    the domain of ``train`` (with ``system``, the linear model the cases came from, also the
    backbone misfit that bounds it), and the recalibration fitted on the validation cases
    ``val`` (the cases the best epoch was chosen on, never the test cases). The file is
    replaced atomically.
    """
    model = load_inverse_model(path)
    raw_train = model.predict(train, calibrated=False) if system is not None else None
    cal = Calibration.fit(train, val, model.predict(val, calibrated=False), system=system,
                          raw_train=raw_train)
    ckpt = torch.load(Path(path), map_location="cpu", weights_only=True)
    ckpt[_CALIBRATION_KEY] = cal.to_dict()
    with atomic_path(Path(path)) as tmp:
        torch.save(ckpt, tmp)
    return cal

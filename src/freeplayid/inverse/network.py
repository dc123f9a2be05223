"""Set network from one case's backbone fitting points to a Gaussian over (log kn, log delta).

A case is a *set* of points (channel c, amplitude A [m], frequency f [Hz]) of any size, in no
order. The network is a DeepSets model (Zaheer et al. 2017):

    h_i = phi([z_A,i, z_f,i, z_N,i, onehot(c_i)])     per point, shared MLP
    g   = [mean_i h_i, max_i h_i, log n]              masked pooling: order and padding free
    (mu, s) = rho(g)                                  mu, s: shape (2,)

with ``z_A = (log A - m_A) / s_A``, ``z_f = (f - m_f) / s_f`` and ``z_N = (N - m_N) / s_N``, N
the point's record's noise floor relative to the point [dB] (``noise_db`` of
:class:`freeplayid.signal.BackbonePoint`; a network trained without it, as every one before
2026-11-29, has no ``z_N``). The outputs are the mean
``mu`` and log-variance ``s`` of the normalised targets ``((log kn - m_kn) / s_kn,
(log delta - m_delta) / s_delta)``.

Why log A: scaling delta by c scales every amplitude by c at the same frequencies (the freeplay
backbone depends on A / delta only), so a delta change is a shift of log A, which the network
sees as a shift of one input feature.

Why the noise floor: the points do not say how noisy their records were, and the posterior's
spread is set by that noise (without it, the share of truths inside the central 50 % interval
fell from 0.72-0.80 on noise-free cases to 0.41-0.43 at 0.3 g, docs/inverse.md). Why not the
record's SNR (``snr_db``): its residual holds the jump's transient, so it tells the jump's size
and the sweep, and a network that read it was confidently wrong on records of another
integrator (docs/inverse.md); the floor is read where the jump is not.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields

import numpy as np
import torch
from torch import nn

from .pointsets import PointSets

__all__ = ["Normalisation", "collate_point_sets", "InverseNet", "LOGVAR_RANGE"]

#: Limits of the predicted log-variance of a normalised target: std from e^-7 (~1e-3 of the
#: training spread) to e^2 (~7 training spreads). Without a limit the NLL can run a variance to 0.
LOGVAR_RANGE = (-14.0, 4.0)

_ACTIVATIONS = {"silu": nn.SiLU, "gelu": nn.GELU}


@dataclass(frozen=True)
class Normalisation:
    """Affine normalisation of the point features and of the targets.

    Attributes
    ----------
    log_amplitude_mean, log_amplitude_std : float [log m]
        Of ``log A`` over all training points.
    frequency_mean, frequency_std : float [Hz]
        Of ``f`` over all training points.
    log_kn_mean, log_kn_std : float [log(N m/rad)]
        Of ``log kn`` over the training cases.
    log_delta_mean, log_delta_std : float [log rad]
        Of ``log delta`` over the training cases.
    noise_db_mean, noise_db_std : float or None [dB]
        Of the points' noise floor relative to them over all training points; None: the
        network has no noise input (trained without it).
    log_rate_mean, log_rate_std : float or None [log(Hz/s)]
        Of ``log`` of the sweep's rate at each training point; None: the network has no rate
        input (trained without it).
    """

    log_amplitude_mean: float
    log_amplitude_std: float
    frequency_mean: float
    frequency_std: float
    log_kn_mean: float
    log_kn_std: float
    log_delta_mean: float
    log_delta_std: float
    noise_db_mean: float | None = None
    noise_db_std: float | None = None
    log_rate_mean: float | None = None
    log_rate_std: float | None = None

    @property
    def uses_noise(self) -> bool:
        """Whether the network reads each point's noise floor (a third point feature)."""
        return self.noise_db_mean is not None

    @property
    def uses_rate(self) -> bool:
        """Whether the network reads each point's sweep rate (the feature after the noise)."""
        return self.log_rate_mean is not None

    @classmethod
    def from_point_sets(cls, ps: PointSets, *, noise: bool | None = None,
                        rate: bool = False) -> Normalisation:
        """Statistics of the training set ``ps``: features over its points, targets over its cases
        with known truth (finite, > 0 kn and delta); with ``noise``, the points' ``noise_db``
        too (the network then reads it; None: when every point has a finite one); with
        ``rate``, the log of the points' sweep rates (``ps.rate``; the network then reads it).

        Raises
        ------
        ValueError
            ``ps`` has no points, or no case with known truth, or ``noise`` and ``ps`` has no
            finite ``noise_db`` for every point, or ``rate`` and ``ps`` has no ``rate``.
        """
        if ps.case.size == 0:
            raise ValueError("`ps` must contain points to normalise by, got 0 points")
        known = np.isfinite(ps.kn) & np.isfinite(ps.delta) & (ps.kn > 0) & (ps.delta > 0)
        if not known.any():
            raise ValueError(
                f"`ps` must have cases with known truth (finite kn, delta > 0), got none of "
                f"{ps.n_cases}"
            )
        log_a = np.log(ps.amplitude)
        log_kn, log_delta = np.log(ps.kn[known]), np.log(ps.delta[known])
        extra = {}
        if noise is None:
            noise = ps.noise_known
        if noise:
            if not ps.noise_known:
                raise ValueError("`ps` must have a finite `noise_db` for every point to train the "
                                 "noise input (cases cached before it was stored lack it; or "
                                 "set network.noise_input=false)")
            extra = {"noise_db_mean": float(ps.noise_db.mean()),
                     "noise_db_std": _spread(ps.noise_db)}
        if rate:
            if ps.rate is None:
                raise ValueError("`ps` must have each point's sweep rate to train the rate input "
                                 "(or set network.rate_input=false)")
            log_rate = np.log(ps.rate)
            extra.update(log_rate_mean=float(log_rate.mean()), log_rate_std=_spread(log_rate))
        return cls(
            log_amplitude_mean=float(log_a.mean()), log_amplitude_std=_spread(log_a),
            frequency_mean=float(ps.frequency.mean()), frequency_std=_spread(ps.frequency),
            log_kn_mean=float(log_kn.mean()), log_kn_std=_spread(log_kn),
            log_delta_mean=float(log_delta.mean()), log_delta_std=_spread(log_delta),
            **extra,
        )

    def as_dict(self) -> dict[str, float]:
        """Plain ``{name: float}`` (what a checkpoint stores; the noise's and the rate's entries
        only when the network reads them)."""
        return {k: float(v) for k, v in asdict(self).items() if v is not None}

    @classmethod
    def from_dict(cls, d: Mapping) -> Normalisation:
        """Inverse of :meth:`as_dict`; a :class:`Normalisation` is returned unchanged."""
        if isinstance(d, Normalisation):
            return d
        names = [f.name for f in fields(cls)]
        base, noise, rate = names[:-4], names[-4:-2], names[-2:]  # the inputs' pairs optional
        allowed = [set(base + n + r) for n in ([], noise) for r in ([], rate)]
        if not isinstance(d, Mapping) or set(d) not in allowed:
            got = sorted(d) if isinstance(d, Mapping) else type(d).__name__
            raise ValueError(f"`norm` must be a mapping with exactly the keys {names} (or "
                             f"without the noise's or the rate's pair), got {got}")
        out = cls(**{k: float(d[k]) for k in names if k in d})
        if not all(math.isfinite(v) for v in out.as_dict().values()) or min(
            out.log_amplitude_std, out.frequency_std, out.log_kn_std, out.log_delta_std,
            out.noise_db_std if out.uses_noise else 1.0,
            out.log_rate_std if out.uses_rate else 1.0,
        ) <= 0:
            raise ValueError(f"`norm` must have finite means and stds > 0, got {out}")
        return out

    @property
    def target_mean(self) -> np.ndarray:
        """Shape (2,): means of (log kn, log delta)."""
        return np.array([self.log_kn_mean, self.log_delta_mean])

    @property
    def target_std(self) -> np.ndarray:
        """Shape (2,): stds of (log kn, log delta)."""
        return np.array([self.log_kn_std, self.log_delta_std])


def _spread(x: np.ndarray) -> float:
    # one training case (or identical values) gives std 0; 1 keeps the features unscaled then
    s = float(np.std(x))
    return s if s > 0 else 1.0


def collate_point_sets(
    ps: PointSets, cases=None, *, norm: Normalisation | Mapping
) -> dict[str, torch.Tensor]:
    """Pad the point sets of ``cases`` into one batch.

    Parameters
    ----------
    ps : PointSets
    cases : array of int, shape (batch,), optional
        Cases of ``ps`` in batch order (default: all, in order).
    norm : Normalisation or its ``as_dict()``

    Returns
    -------
    dict with
        ``x`` : Tensor, shape (batch, max_points, n_features) float32 -- features
        ``[(log A - m) / s, (f - m) / s, (noise_db - m) / s, (log rate - m) / s, one-hot
        channel]`` (the noise only when ``norm.uses_noise``, a point without one getting the
        training mean, 0; the rate only when ``norm.uses_rate``, which needs ``ps.rate``), zero
        on padding; ``n_features = 2 + norm.uses_noise + norm.uses_rate + n_channels``;
        ``mask`` : Tensor, shape (batch, max_points) bool -- True on real points;
        ``y`` : Tensor, shape (batch, 2) float32 -- normalised (log kn, log delta), NaN where the
        truth is unknown;
        ``n_points`` : Tensor, shape (batch,) int64; ``case`` : Tensor, shape (batch,) int64.
        ``max_points`` is at least 1 so that a batch of empty sets still has a point axis.
    """
    norm = Normalisation.from_dict(norm)
    if norm.uses_rate and ps.rate is None:
        raise ValueError("this network reads each point's sweep rate, and the points have none "
                         "(give `rate`: point_sets_from_records(..., rate=...))")
    n_all = ps.n_points
    idx = np.arange(ps.n_cases) if cases is None else np.asarray(cases, dtype=np.int64).ravel()
    if idx.size and (idx.min() < 0 or idx.max() >= ps.n_cases):
        raise ValueError(f"`cases` must lie in [0, {ps.n_cases}), got min {idx.min()}, "
                         f"max {idx.max()}")
    lengths = n_all[idx]
    starts = np.concatenate([[0], np.cumsum(n_all)[:-1]])
    # row r of the batch: point `pos` of case idx[b]; vectorised over all points of the batch
    batch_of = np.repeat(np.arange(idx.size), lengths)
    pos = np.arange(lengths.sum()) - np.repeat(np.cumsum(lengths) - lengths, lengths)
    rows = starts[idx][batch_of] + pos if idx.size else np.zeros(0, np.int64)

    n_ch = len(ps.channels)
    first = 2 + int(norm.uses_noise) + int(norm.uses_rate)  # the one-hot channel's first column
    x = np.zeros((idx.size, max(int(lengths.max(initial=0)), 1), first + n_ch), np.float32)
    x[batch_of, pos, 0] = (np.log(ps.amplitude[rows]) - norm.log_amplitude_mean) / (
        norm.log_amplitude_std
    )
    x[batch_of, pos, 1] = (ps.frequency[rows] - norm.frequency_mean) / norm.frequency_std
    if norm.uses_noise and ps.noise_db is not None:
        z = (ps.noise_db[rows] - norm.noise_db_mean) / norm.noise_db_std
        x[batch_of, pos, 2] = np.where(np.isfinite(z), z, 0.0)
    if norm.uses_rate:
        x[batch_of, pos, first - 1] = (np.log(ps.rate[rows]) - norm.log_rate_mean) / (
            norm.log_rate_std)
    x[batch_of, pos, first + ps.channel[rows]] = 1.0
    mask = np.zeros(x.shape[:2], bool)
    mask[batch_of, pos] = True
    with np.errstate(invalid="ignore", divide="ignore"):  # unknown truth -> NaN targets
        y = (np.log(np.column_stack([ps.kn[idx], ps.delta[idx]])) - norm.target_mean) / (
            norm.target_std
        )
    return {
        "x": torch.from_numpy(x), "mask": torch.from_numpy(mask),
        "y": torch.from_numpy(y.astype(np.float32)),
        "n_points": torch.from_numpy(lengths.astype(np.int64)),
        "case": torch.from_numpy(idx.astype(np.int64)),
    }


def _mlp(n_in: int, widths: list[int], activation: str, *, last_activation: bool) -> nn.Sequential:
    layers: list[nn.Module] = []
    for k, w in enumerate(widths):
        layers.append(nn.Linear(n_in, w))
        if last_activation or k < len(widths) - 1:
            layers.append(_ACTIVATIONS[activation]())
        n_in = w
    return nn.Sequential(*layers)


class InverseNet(nn.Module):
    """DeepSets network: padded point sets -> Gaussian over normalised (log kn, log delta).

    Parameters
    ----------
    n_channels : int
        Number of channels (length of the one-hot part of the features).
    hidden : int
        Width of every hidden layer.
    depth : int
        Linear layers of the per-point MLP phi; the set MLP rho has ``depth - 1`` hidden layers
        (at least 1) and a linear output layer.
    activation : {"silu", "gelu"}
    noise_input : bool
        Whether each point carries its noise floor as a third feature
        (:func:`collate_point_sets`).
    rate_input : bool
        Whether each point carries its sweep's rate (log) as the feature after the noise.
    """

    def __init__(self, n_channels: int, *, hidden: int = 64, depth: int = 3,
                 activation: str = "silu", noise_input: bool = False, rate_input: bool = False):
        super().__init__()
        if int(n_channels) < 1:
            raise ValueError(f"`n_channels` must be >= 1, got {n_channels!r}")
        if int(hidden) < 1 or int(depth) < 1:
            raise ValueError(f"`hidden` and `depth` must be >= 1, got {hidden!r}, {depth!r}")
        if activation not in _ACTIVATIONS:
            raise ValueError(f"`activation` must be one of {sorted(_ACTIVATIONS)}, "
                             f"got {activation!r}")
        self.n_features = 2 + int(bool(noise_input)) + int(bool(rate_input)) + int(n_channels)
        self.phi = _mlp(self.n_features, [hidden] * depth, activation, last_activation=True)
        self.rho = _mlp(2 * hidden + 1, [hidden] * max(depth - 1, 1) + [4], activation,
                        last_activation=False)
        # log-variance = lo + (hi - lo) sigmoid(raw + b): smooth limits, and b puts a zero raw
        # output at log-variance 0 (unit variance, the spread of the training targets)
        lo, hi = LOGVAR_RANGE
        self._lo, self._span = lo, hi - lo
        self._bias = math.log(-lo / hi)

    def forward(self, x: torch.Tensor, mask: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Mean and log-variance of the normalised targets.

        Parameters
        ----------
        x : Tensor, shape (batch, max_points, n_features)
            Values on padding (``mask`` False) are ignored, whatever they are.
        mask : Tensor, shape (batch, max_points) bool

        Returns
        -------
        mean : Tensor, shape (batch, 2)
            Of normalised (log kn, log delta).
        log_var : Tensor, shape (batch, 2)
            Within :data:`LOGVAR_RANGE`.
        """
        if x.ndim != 3 or x.shape[-1] != self.n_features or mask.shape != x.shape[:2]:
            raise ValueError(
                f"`x` must have shape (batch, max_points, {self.n_features}) and `mask` "
                f"(batch, max_points), got {tuple(x.shape)} and {tuple(mask.shape)}"
            )
        m = mask.to(torch.bool).unsqueeze(-1)
        h = self.phi(torch.where(m, x, 0.0))  # padding zeroed first: NaN/inf there stays out
        n = m.sum(dim=1).to(h.dtype)  # (batch, 1)
        mean = torch.where(m, h, 0.0).sum(dim=1) / n.clamp(min=1.0)
        mx = torch.where(m, h, -torch.inf).amax(dim=1)
        mx = torch.where(n > 0, mx, 0.0)  # an empty set pools to zeros, not -inf
        g = torch.cat([mean, mx, torch.log(n.clamp(min=1.0))], dim=-1)
        out = self.rho(g)
        log_var = self._lo + self._span * torch.sigmoid(out[:, 2:] + self._bias)
        return out[:, :2], log_var

"""The fit's model function f_BC(X; kn, delta): backbone frequency at a point's amplitude.

Scale invariance makes it cheap: the curve of (kn, delta) is the curve of (kn, 1) with amplitudes
times delta, so f_BC(X; kn, delta) = f_BC(X / delta; kn, 1) and a change of delta needs no new
eigen-solutions. Curves are computed once per kn (cached) and interpolated in ln X. Points whose
amplitude lies outside the curve's range take the end value (the open-hinge or the closed-hinge
frequency), which keeps the objective continuous for any start.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..backbone import amplitude_grid, backbone_curve, backbone_method
from ..model import FreeplaySystem

__all__ = ["BackboneModel", "gap_ratios", "MIN_GAP_RATIO"]

# [-] the lowest point's largest hinge amplitude over delta that the backbone can be trusted at:
# nearer contact the describing function is off by more than 7 % (the exact SDOF backbone,
# docs/backbone.md); the multi-start's plausibility and the verdict's contact margin use it
MIN_GAP_RATIO = 1.5


class BackboneModel:
    """Backbone frequencies f_BC(X; kn, delta) of one system, with per-kn curve caching.

    Parameters
    ----------
    system : FreeplaySystem
    channels : sequence of str
        DOF names the points are measured at.
    backbone : str
        A key of :data:`freeplayid.backbone.BACKBONE_METHODS` ("dfa", "hb").
    s : ndarray, optional
        Grid of largest hinge amplitude / delta (default: 400 points from 1.0002 to 2000).
    mode : int
        Mode of the backbone (0: lowest).
    **options
        Passed to the backbone method: e.g. ``equal_hinges=True`` for "dfa" (every hinge at the
        largest hinge's kappa, one eigen-batch per curve instead of a Newton solve: the cheap
        model of the multi-start phase), ``n_harmonics`` for "hb" (odd harmonics, default 5).
    """

    def __init__(
        self,
        system: FreeplaySystem,
        channels: Sequence[str],
        *,
        backbone: str = "dfa",
        s: np.ndarray | None = None,
        mode: int = 0,
        **options,
    ) -> None:
        backbone_method(backbone, argument="backbone")
        missing = sorted(set(channels) - set(system.dof_names))
        if missing:
            raise ValueError(
                f"channels {missing} are not DOFs of the model (known: {list(system.dof_names)})"
            )
        self.system = system
        self.channels = tuple(dict.fromkeys(channels))
        self.index = [system.dof_names.index(c) for c in self.channels]
        self.backbone = backbone
        self.s = amplitude_grid(400, s_min=1.0002, s_max=2000.0) if s is None else np.asarray(s)
        self.mode = mode
        self.options = dict(options)
        self._cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        self.n_curves = 0

    def curve(self, kn: float) -> tuple[np.ndarray, np.ndarray]:
        """(frequency (m,) [Hz], ln amplitude (m, c) at delta = 1) of the backbone for ``kn``."""
        key = float(kn)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        bc = backbone_curve(
            self.system,
            method=self.backbone,
            kn=key,
            delta=1.0,
            mode=self.mode,
            s=self.s,
            **self.options,
        )
        amp = bc.amplitude[0][:, self.index]
        with np.errstate(divide="ignore"):
            out = (bc.frequency_hz[0], np.log(amp))
        self.n_curves += 1
        if len(self._cache) > 512:
            self._cache.clear()
        self._cache[key] = out
        return out

    def frequency(self, amplitude, channel_index, kn: float, delta: float) -> np.ndarray:
        """Backbone frequency [Hz] at each point's amplitude [m]; shape (p,).

        Parameters
        ----------
        amplitude : array_like, shape (p,) [m]
        channel_index : ndarray, shape (p,) of int
            Index of each point's DOF in :attr:`channels`.
        kn : float [N m/rad]
        delta : float [rad]
        """
        freq, log_amp = self.curve(kn)
        with np.errstate(divide="ignore", over="ignore"):  # delta -> 0 (a start running off)
            x = np.log(np.asarray(amplitude, dtype=float) / delta)
        out = np.empty(x.shape)
        for c in range(len(self.channels)):
            sel = channel_index == c
            if np.any(sel):
                la = log_amp[:, c]
                ok = np.isfinite(la)
                if np.count_nonzero(ok) < 2:  # channel does not move in this mode at this kn
                    out[sel] = 0.0
                    continue
                order = np.argsort(la[ok])
                out[sel] = np.interp(x[sel], la[ok][order], freq[ok][order])
        return out


def gap_ratios(points, system, kn: float, delta: float, mode: int, model=None):
    """Theta_max / delta of each point on the fitted backbone, and the grid's largest ratio.

    ``model``: a :class:`BackboneModel` of ``system`` holding the points' channels to reuse (its
    per-kn curve cache); default a new DFA one."""
    bm = model or BackboneModel(system, sorted(set(points.channel)), mode=mode)
    _, log_amp = bm.curve(kn)
    out = np.empty(len(points.channel))
    for i, (c, a) in enumerate(zip(points.channel, points.amplitude_m, strict=True)):
        la = log_amp[:, bm.channels.index(c)]
        ok = np.isfinite(la)
        if np.count_nonzero(ok) < 2:
            out[i] = np.nan
            continue
        order = np.argsort(la[ok])
        out[i] = np.interp(np.log(a / delta), la[ok][order], bm.s[ok][order])
    return out, float(bm.s[-1])

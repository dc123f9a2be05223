"""The fit's model function f_BC(X; kn, delta): backbone frequency at a point's amplitude.

Scale invariance makes it cheap: the curve of (kn, delta) is the curve of (kn, 1) with amplitudes
times delta, so f_BC(X; kn, delta) = f_BC(X / delta; kn, 1) and a change of delta needs no new
eigen-solutions. The curve of a kn between nodes ``10^(i / KN_NODES_PER_DECADE)`` is interpolated
in log kn from the four nodes around it (Catmull-Rom: a cubic, continuous with its slope, whose
error is third order in the node spacing), each node's curve computed once, when a fit first
comes near it: a fit that moves kn by a few % computes a handful of curves instead of one per
evaluation. Against the curve computed at that kn: frequencies within 1.3e-6 and ln amplitudes
within 1e-8 on the default fin, kn 1e2-1e6 (``tests/test_fit.py``); where the nodes are not
smooth in kn (a mode veering near contact, :data:`KINK`) the curve is computed at kn itself.
Curves are interpolated in ln X. Points whose amplitude lies outside the curve's range take the
end value (the open-hinge or the closed-hinge frequency), which keeps the objective continuous
for any start.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..backbone import amplitude_grid, backbone_curve, backbone_method
from ..model import FreeplaySystem

__all__ = ["BackboneModel", "gap_ratios", "MIN_GAP_RATIO"]

# curve nodes per decade of kn (module docstring); 0: every curve computed at its own kn
KN_NODES_PER_DECADE = 128
# [-] the nodes' third difference of a frequency, over it, above which the curve is not smooth
# in kn there and is computed at kn itself (smooth: below 1e-5 on the default fin; at a
# mode's veering near contact: 0.5)
KINK = 1e-4

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
    kn_nodes : int
        Curve nodes per decade of kn (module docstring; 0: every curve computed at its kn).
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
        kn_nodes: int = KN_NODES_PER_DECADE,
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
        self.kn_nodes = int(kn_nodes)
        self.options = dict(options)
        self._cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        self._nodes = _shared_nodes(self)
        self.n_curves = 0

    def curve(self, kn: float) -> tuple[np.ndarray, np.ndarray]:
        """(frequency (m,) [Hz], ln amplitude (m, c) at delta = 1) of the backbone for ``kn``:
        interpolated in log kn between the curves of the nodes around it (module docstring)."""
        key = float(kn)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        n = self.kn_nodes
        if not (n and math.isfinite(key) and key > 0):
            return self.curve_at(key)  # (an invalid kn raises there)
        x = math.log10(key) * n
        i = math.floor(x)
        t = x - i
        p = [self._node(k) for k in range(i - 1, i + 3)]
        f = np.stack([q[0] for q in p])
        third = np.abs(f[0] - 3 * f[1] + 3 * f[2] - f[3])
        if np.any(third > KINK * np.abs(f[1])):
            # the curve is not smooth in kn there (a mode veering near contact, seen on the
            # default fin above kn 3e4): computed at kn itself
            return self.curve_at(key)
        w = _catmull_rom(t)
        with np.errstate(invalid="ignore"):  # -inf (a channel at rest) stays non-finite
            out = (sum(wk * q[0] for wk, q in zip(w, p)), sum(wk * q[1] for wk, q in zip(w, p)))
        if len(self._cache) > 512:
            self._cache.clear()
        self._cache[key] = out
        return out

    def _node(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """The curve of node ``i``: kn = 10^(i / kn_nodes), computed once."""
        hit = self._nodes.get(i)
        if hit is None:
            hit = self._nodes[i] = self.curve_at(10.0 ** (i / self.kn_nodes), keep=False)
        return hit

    def curve_at(self, kn: float, keep: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """The curve computed at ``kn`` itself (no interpolation); kept with ``keep``."""
        key = float(kn)
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
        if keep:
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


# the node curves of the last few models, shared by the models of one system that compute the
# same curves (the fits of a test and of its replays): (system, nodes) by the model's key
_NODES: dict = {}
_NODES_KEPT = 8


def _shared_nodes(model: BackboneModel) -> dict:
    """The node curves of the models like ``model`` (the same system object, channels, method,
    mode, grid, node spacing and options): one dict, filled by whichever computes a node first."""
    key = (id(model.system), model.channels, model.backbone, model.mode, model.kn_nodes,
           model.s.tobytes(), tuple(sorted(model.options.items())))
    try:
        hit = _NODES.get(key)
    except TypeError:  # an option that cannot be a key (an array): its own nodes
        return {}
    if hit is not None and hit[0] is model.system:
        return hit[1]
    if len(_NODES) >= _NODES_KEPT:
        _NODES.pop(next(iter(_NODES)))
    _NODES[key] = (model.system, {})
    return _NODES[key][1]


def _catmull_rom(t: float) -> tuple[float, float, float, float]:
    """Weights of the four nodes p(-1), p(0), p(1), p(2) for the value at 0 <= t < 1 between
    p(0) and p(1): the cubic Hermite with central-difference slopes."""
    t2, t3 = t * t, t * t * t
    return (0.5 * (-t + 2 * t2 - t3), 0.5 * (2 - 5 * t2 + 3 * t3),
            0.5 * (t + 4 * t2 - 3 * t3), 0.5 * (-t2 + t3))


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

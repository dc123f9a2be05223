"""The linear model's error in the answer: the update to sealed modes and kn's interval.

kn is conditional on the model (:class:`freeplayid.model.ModelOptions`). With the sealed fin's
modes the model is updated to them before the identification
(:func:`freeplayid.model.update_to_sealed_modes`); without, or for what the update could not
explain (with two sealed modes, which the update fits exactly: the option's uncertainty), kn's
interval takes in the move of kn that the model's frequency uncertainty makes:
the plain fit's points refitted against the model with that mode's frequency moved by ``u``
give kn's relative move ``m``, and the interval's log half-width becomes sqrt(h^2 + m^2). The
mode's frequency is moved by scaling the structure's stiffness (not the hinges'): its share of
the closed mode's stiffness at the estimate, phi^T K phi / w^2 (0.35 on the default fin: the
hinge springs carry the rest), sets the scale, 1 + ((1 + u)^2 - 1) / share, that moves the
closed mode's frequency by ``u`` (:func:`frequency_scale`).

One delta stands for every hinge. Where the hinges' gaps differ, what the points show of it is
measured (:func:`gap_split`): hinge j's half-gap (1 + a) delta and the others' (1 - a / (h - 1))
delta (their mean delta), the DFA backbone at the answer moves each point's frequency by v_i
(log); the common fit absorbs the part of v along its two directions (d log f / d log kn,
d log delta), and what is left, the part the points could show, is compared with their scatter
about the fit (the plain fit's RMS relative residual). The largest a it stays within that
scatter at every point, over the hinges, is the split these data cannot see; the common fit's
delta then differs from the hinges' mean by the move it absorbs (on the bundled example: a split
up to +-0.57 cannot be seen; at +-0.1 delta is the mean within 0.6 %; the realtests fin with
half-gaps 2.7 and 3.3 mrad gave the mean +0.33 %, the model +0.37 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..backbone import dfa_backbone
from ..estimate import PlainEstimate, refit
from ..fit import FitOptions, gap_ratios
from ..model import ModelOptions, SealedUpdate, modal_analysis, update_to_sealed_modes

__all__ = ["ModelError", "GapSplit", "update_model", "model_error", "hinge_ratio",
           "frequency_scale", "gap_split"]

# [-] hinge rotation ratio in the identified mode above which the hinges count as turning together
HINGES_TOGETHER = 0.9

# [-] the gap splits a tried (hinge j's half-gap (1 + a) delta); the split the points cannot see
# is interpolated between them, and reported as at least the last where even that is not seen
GAP_SPLITS = (0.05, 0.1, 0.2, 0.4, 0.8)


@dataclass(frozen=True)
class GapSplit:
    """How unequal the hinges' gaps could be without the points showing it (:func:`gap_split`).

    Attributes
    ----------
    split : float [-]
        The largest a such that a hinge's half-gap (1 + a) delta (the others' smaller, their
        mean delta) moves no point's frequency, beyond what the common fit absorbs, by more than
        the points' scatter; ``GAP_SPLITS[-1]`` when even that split is not seen (``beyond``).
    beyond : bool
        Whether ``split`` is only a lower bound (no split tried was seen).
    scatter : float [-]
        The points' RMS relative frequency residual about the plain fit.
    delta_bias : float [-]
        The largest |common delta / the hinges' mean - 1| over the splits up to ``split``.
    """

    split: float
    beyond: bool
    scatter: float
    delta_bias: float

    def describe(self) -> str:
        up = f"{'more than ' if self.beyond else 'up to '}±{100 * self.split:.2g} %"
        return (f"gaps split by {up} between the hinges move no point by more than the points' "
                f"scatter about the fit ({100 * self.scatter:.2g} %) once the common fit absorbs "
                "what it can, so these data cannot tell such gaps apart: a hinge's own half-gap "
                f"may be that much over delta, and delta is then their mean within "
                f"{100 * self.delta_bias:.2g} %")

    def to_dict(self) -> dict:
        return {"split": self.split, "beyond": self.beyond, "scatter": self.scatter,
                "delta_bias": self.delta_bias}


@dataclass(frozen=True)
class ModelError:
    """What the answer's kn owes to the linear model.

    Attributes
    ----------
    update : SealedUpdate or None
        The model's update to the sealed modes, when there was one.
    frequency_uncertainty : float [-]
        The relative uncertainty (95 %) of the identified mode's frequency taken into kn's
        interval (the option's, or the update's residual).
    kn_shift : float [-]
        kn's relative move for that frequency error.
    hinge_ratio : float or None [-]
        With two or more hinges: the smallest over the largest hinge rotation in the identified
        mode of the closed model (1: the hinges turn together, and one mode's backbone cannot
        tell their gaps apart; delta is then one half-gap for all, the hinges' mean when they
        differ).
    gaps : GapSplit or None
        With two or more hinges: how unequal their gaps could be without the points showing it.
    """

    update: SealedUpdate | None
    frequency_uncertainty: float
    kn_shift: float
    hinge_ratio: float | None = None
    gaps: GapSplit | None = None

    def describe(self) -> str:
        if self.update is not None:
            head = "the model was updated: " + self.update.describe()
        else:
            head = "kn is conditional on the linear model (no sealed-fin modes to update it to)"
        return (head + f"; a {100 * self.frequency_uncertainty:.2g} % error of the identified "
                f"mode's frequency moves kn by {100 * self.kn_shift:.2g} %, included in kn's "
                "interval" + self.hinges())

    def hinges(self) -> str:
        """What the data can tell of each hinge's gap ('' with one hinge)."""
        r = self.hinge_ratio
        if r is None:
            return ""
        split = "" if self.gaps is None else "; " + self.gaps.describe()
        if r >= HINGES_TOGETHER:
            return (f"; the hinges turn together in the identified mode (rotation ratio "
                    f"{r:.2f}): delta is one half-gap for all of them, their mean if they "
                    "differ" + split)
        return (f"; the hinges turn unequally in the identified mode (rotation ratio {r:.2f}): "
                "delta is one half-gap for all of them, weighted towards the hinge that turns "
                "most if they differ" + split)

    def to_dict(self) -> dict:
        return {"update": None if self.update is None else self.update.to_dict(),
                "frequency_uncertainty": self.frequency_uncertainty, "kn_shift": self.kn_shift,
                "hinge_ratio": self.hinge_ratio,
                "gaps": None if self.gaps is None else self.gaps.to_dict()}


def update_model(dataset, system, est: PlainEstimate, fit: FitOptions,
                 options: ModelOptions) -> tuple[object, PlainEstimate, SealedUpdate | None]:
    """The model updated to the data set's sealed modes (two or more) and the plain estimate
    refitted against it; unchanged without them or with ``options.update`` False."""
    ref = getattr(dataset, "reference_modes", None)
    if not (options.update and ref):
        return system, est, None
    upd = update_to_sealed_modes(system, est.kn, ref["frequencies_hz"], ref["shapes"],
                                 ref["dofs"], mode=fit.mode)
    if upd is None:
        return system, est, None
    return upd.system, refit(est, upd.system, fit), upd


def model_error(system, est: PlainEstimate, fit: FitOptions, options: ModelOptions,
                update: SealedUpdate | None) -> ModelError:
    """kn's relative move for the model's frequency uncertainty (module docstring)."""
    u = options.frequency_uncertainty if update is None or not update.residual_measured else \
        max(update.residual, 1e-3)
    ratio = hinge_ratio(system, est.kn, fit.mode)
    gaps = gap_split(system, est, fit.mode)
    if u == 0:
        return ModelError(update, 0.0, 0.0, ratio, gaps)
    moved = system.replace(K=system.K * frequency_scale(system, est.kn, u, fit.mode))
    kn_moved = refit(est, moved, fit).kn
    return ModelError(update, float(u), abs(math.log(kn_moved / est.kn)), ratio, gaps)


def gap_split(system, est: PlainEstimate, mode: int = 0) -> GapSplit | None:
    """How unequal the hinges' gaps could be without the fitted points showing it (module
    docstring); None with one hinge or where the backbone does not reach a point."""
    if system.n_hinges < 2:
        return None
    pts = est.fitting_points()
    kn, delta = float(est.kn), float(est.delta)
    ratios, _ = gap_ratios(pts, system, kn, delta, mode)
    if not np.all(np.isfinite(ratios)):
        return None
    # the curves over the points' range only (the largest hinge amplitude over delta), where a
    # split moves them by up to 0.8 x
    grid = np.geomspace(max(1.0005, 0.5 * ratios.min()), 2.0 * ratios.max(), 128)

    def logf(kn_, delta_, gaps=None):  # (members, points) for one or more (kn, delta)
        curve = dfa_backbone(system, kn=kn_, delta=delta_, mode=mode, gaps=gaps, s=grid)
        return np.log(np.stack([curve.frequency_at(x, ch)[:, 0] for x, ch in
                                zip(pts.amplitude_m, pts.channel, strict=True)], axis=1))

    eps = 1e-3  # the answer and a step in each of (kn, delta), one batch
    base, *steps = logf([kn, kn * (1 + eps), kn], [delta, delta, delta * (1 + eps)])
    J = np.stack([(f - base) / eps for f in steps], axis=1)
    if not (np.all(np.isfinite(base)) and np.all(np.isfinite(J))):
        return None
    h = system.n_hinges
    seen, bias = [], []
    for a in GAP_SPLITS:
        worst = moved = 0.0
        for j in range(h):
            gaps = np.full(h, 1.0 - a / (h - 1))
            gaps[j] = 1.0 + a
            v = logf(kn, delta, gaps)[0] - base
            if not np.all(np.isfinite(v)):
                return None
            step = np.linalg.lstsq(J, v, rcond=None)[0]  # what the common fit absorbs
            worst = max(worst, float(np.max(np.abs(v - J @ step))))
            moved = max(moved, abs(float(np.expm1(step[1]))))
        seen.append(worst)
        bias.append(moved)
    scatter = float(est.fit.residual_rms)
    splits = np.array((0.0, *GAP_SPLITS))
    shown = np.array((0.0, *seen))
    beyond = bool(shown[-1] <= scatter)
    k = int(np.argmax(shown > scatter)) if not beyond else len(splits) - 1
    split = float(splits[-1]) if beyond else float(
        np.interp(scatter, shown[k - 1: k + 1], splits[k - 1: k + 1]))
    within = [b for a, b in zip(GAP_SPLITS, bias, strict=True) if a <= split] or bias[:1]
    return GapSplit(split, beyond, scatter, float(max(within)))


def frequency_scale(system, kn: float, u: float, mode: int = 0) -> float:
    """The factor on the structure's stiffness K (the hinges' kn kept) that moves the closed
    mode ``mode`` at ``kn`` by the relative frequency ``u`` to first order: 1 + ((1 + u)^2 - 1)
    / share, share = phi^T K phi / w^2 of that mode (mass-normalised phi)."""
    modes = modal_analysis(system.M, system.closed_stiffness(kn))
    phi = modes.shapes[:, mode]
    share = float(phi @ (system.K @ phi)) / float(modes.omega[mode]) ** 2
    return 1.0 + ((1.0 + u) ** 2 - 1.0) / max(share, 1e-3)


def hinge_ratio(system, kn: float, mode: int) -> float | None:
    """The smallest over the largest hinge rotation |b_j^T phi| in mode ``mode`` of the closed
    model at ``kn`` (None with one hinge)."""
    if system.n_hinges < 2:
        return None
    phi = modal_analysis(system.M, system.closed_stiffness(kn)).shapes[:, mode]
    theta = np.abs(system.hinge_matrix().T @ phi)
    return float(theta.min() / theta.max()) if theta.max() > 0 else None


def widen(ci: tuple, value: float, shift: float) -> tuple:
    """``ci`` of ``value`` with ``shift`` (a relative 95 % half-width) added in quadrature to its
    own log half-widths."""
    lo, hi = ci
    h_lo = math.hypot(math.log(value / lo), shift) if lo > 0 else math.inf
    h_hi = math.hypot(math.log(hi / value), shift)
    return (value * math.exp(-h_lo), value * math.exp(h_hi))

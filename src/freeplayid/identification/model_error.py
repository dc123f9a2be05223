"""The linear model's error in the answer: the update to sealed modes and kn's interval.

kn is conditional on the model (:class:`freeplayid.model.ModelOptions`). With the sealed fin's
modes the model is updated to them before the identification
(:func:`freeplayid.model.update_to_sealed_modes`); without, or for what the update could not
explain, kn's interval takes in the move of kn that the model's frequency uncertainty makes:
the plain fit's points refitted against the model with that mode's frequency moved by ``u``
(the structure's stiffness times (1 + u)^2) give kn's relative move ``m``, and the interval's
log half-width becomes sqrt(h^2 + m^2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..estimate import PlainEstimate, refit
from ..fit import FitOptions
from ..model import ModelOptions, SealedUpdate, update_to_sealed_modes

__all__ = ["ModelError", "update_model", "model_error"]


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
    """

    update: SealedUpdate | None
    frequency_uncertainty: float
    kn_shift: float

    def describe(self) -> str:
        if self.update is not None:
            head = "the model was updated: " + self.update.describe()
        else:
            head = "kn is conditional on the linear model (no sealed-fin modes to update it to)"
        return (head + f"; a {100 * self.frequency_uncertainty:.2g} % error of the identified "
                f"mode's frequency moves kn by {100 * self.kn_shift:.2g} %, included in kn's "
                "interval")

    def to_dict(self) -> dict:
        return {"update": None if self.update is None else self.update.to_dict(),
                "frequency_uncertainty": self.frequency_uncertainty, "kn_shift": self.kn_shift}


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
    u = options.frequency_uncertainty if update is None else \
        max(update.residual, 1e-3)
    if u == 0:
        return ModelError(update, 0.0, 0.0)
    moved = system.replace(K=system.K * (1 + u) ** 2)
    kn_moved = refit(est, moved, fit).kn
    return ModelError(update, float(u), abs(math.log(kn_moved / est.kn)))


def widen(ci: tuple, value: float, shift: float) -> tuple:
    """``ci`` of ``value`` with ``shift`` (a relative 95 % half-width) added in quadrature to its
    own log half-widths."""
    lo, hi = ci
    h_lo = math.hypot(math.log(value / lo), shift) if lo > 0 else math.inf
    h_hi = math.hypot(math.log(hi / value), shift)
    return (value * math.exp(-h_lo), value * math.exp(h_hi))

"""What the identification assumes of the linear model: :class:`ModelOptions`."""

from __future__ import annotations

from dataclasses import dataclass

from ..arguments import check_bool, check_number

__all__ = ["ModelOptions"]


@dataclass(frozen=True)
class ModelOptions:
    """How far the identification trusts the linear model, and whether it updates it.

    kn is conditional on the model: the backbone's closed-hinge limit is the identified mode's
    frequency, so a model a relative ``e`` off in that frequency moves kn by about three times
    ``e`` (the default fin: +0.5 % -> kn +1.5 %). Validated on construction.

    Attributes
    ----------
    update : bool
        With the sealed fin's modes (the data set's ``reference_modes``, two or more): update
        the model to them before the identification
        (:func:`freeplayid.model.update_to_sealed_modes`: a stiffness scale of the structure
        with kn, the other modes along their shapes) and report what was updated.
    frequency_uncertainty : float [-]
        The model's relative uncertainty (95 %) in the identified mode's frequency, when it is
        not updated to sealed modes: kn's interval includes the move of kn it makes (0: kn's
        interval is conditional on an exact model). With an update, what the update could not
        explain (the sealed modes' residual after a uniform stiffness scale) takes its place.
    hinge_gaps : bool
        With two or more hinges: report each hinge's half-gap with its interval, from the plain
        estimate's points fitted again with one half-gap per hinge
        (:func:`freeplayid.identification.model_error.fit_hinge_gaps`, a few seconds); where
        the test shows the gaps split against its replay, the answer is that of the test
        replayed with the split (delta the hinges' mean). Off: one delta for all; where the
        hinges turn unequally that fit still runs, to test whether one delta explains the
        points (the verdict's ``hinge_gaps``), and a split the test shows is replayed to
        measure how far the hinges' mean lies from the reported one-gap delta.
    """

    update: bool = True
    frequency_uncertainty: float = 0.005
    hinge_gaps: bool = False

    def __post_init__(self):
        check_bool("update", self.update)
        check_number("frequency_uncertainty", self.frequency_uncertainty, 0.0, 0.2)
        check_bool("hinge_gaps", self.hinge_gaps)

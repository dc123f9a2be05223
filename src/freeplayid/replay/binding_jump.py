"""Where the binding function jumps: two replays of the loop whose fits differ by far more
than their parameters do, and the run that makes the jump.

A replayed run near the threshold of its jump changes branch between two nearby (kn, delta):
its point moves across the curve and the replay's fit with it (the default fin at 0.47 g, its
lowest run jumping near contact: delta's fit -25 % for a 1.4 % move of delta). The verdict's
``replay_binding`` check fails there, since the answer may lie anywhere across that jump,
unless the answer does not rest on that run. :func:`worst_jump` finds the largest jump of a
loop's history (the check's rule); :func:`jump_run` names the run whose points, left out of
both replays' fits, take the jump away (:class:`BindingJump`), and the answer's move were that
run left out of the statistic (the same move as :attr:`.misfit.RunMisfit.without`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import IdentificationError
from .damping_estimate import ZETA_RTOL

__all__ = ["BindingJump", "JUMP", "JUMP_SLOPE", "ZETA_MOVE", "form_moved", "worst_jump",
           "jump_run"]

JUMP = 0.01  # [-] a replayed fit's move (log) that counts as a jump ...
JUMP_SLOPE = 5.0  # [-] ... when it is this many times its parameters' move

# [-] two replays whose damping form's parameter (p or q, :data:`.corrected.FORM_PARAMETERS`)
# differs by more than twice its convergence tolerance are not compared; nor two replays of the
# loop with a form estimated (both carry p or q) whose estimated zeta differs by more than this
# (log): there zeta and the form move together, and zeta alone moves the replayed fit (a beam's
# step after q's probe: zeta 2.57 -> 2.11 %, the fit's delta 1.2 % for a 0.2 % move of delta)
ZETA_MOVE = 2 * ZETA_RTOL


@dataclass(frozen=True)
class BindingJump:
    """The largest jump of the loop's replayed fits, and the run that makes it.

    Attributes
    ----------
    after : int
        The index (in the loop's history) of the second replay of the pair.
    parameter : str
        "kn" or "delta": the replayed fit's parameter that jumped.
    move, cause : float [-]
        Its move between the two replays (log), and the replayed parameter's own.
    run : str or None
        The one run whose points, left out of both replays' fits, leave them within the jump's
        rule; None where no run does, or more than one.
    runs : int
        The runs of the test's statistic.
    without : (float, float) or None
        The answer's relative move (kn, delta) were ``run`` left out of the statistic; None
        where not measured.
    """

    after: int
    parameter: str
    move: float
    cause: float
    run: str | None = None
    runs: int = 0
    without: tuple | None = None

    def to_dict(self) -> dict:
        return {"after": self.after, "parameter": self.parameter, "move": self.move,
                "cause": self.cause, "run": self.run, "runs": self.runs,
                "without": None if self.without is None else list(self.without)}


def form_moved(a, b, atol: dict) -> bool:
    """Whether the damping's form, or its zeta within the form's loop, moved between replays
    ``a`` and ``b`` (:class:`.corrected.ReplayIteration`; they are then not compared);
    ``atol``: each form parameter's attribute and the tolerance within which two replays hold
    the same form (:data:`.corrected.FORM_ATOL`)."""
    if any(abs((getattr(a, attr, None) or 0.0) - (getattr(b, attr, None) or 0.0)) > 2 * tol
           for attr, tol in atol.items()):
        return True
    in_loop = all(any(getattr(it, attr, None) is not None for attr in atol) for it in (a, b))
    za, zb = getattr(a, "zeta", None), getattr(b, "zeta", None)
    return bool(in_loop and za and zb and abs(math.log(zb / za)) > ZETA_MOVE)


def _jumps(move: float, cause: float) -> bool:
    return move > JUMP and move > JUMP_SLOPE * cause


def worst_jump(history: Sequence, atol: dict) -> BindingJump | None:
    """The largest jump between consecutive replays of ``history`` (each with kn, delta,
    kn_rep, delta_rep): a replayed fit's move beyond ``JUMP`` and ``JUMP_SLOPE`` times its
    parameter's, where the damping's form did not move between them (:func:`form_moved` with
    ``atol``); None where there is none."""
    worst = None
    for i in range(1, len(history)):
        a, b = history[i - 1], history[i]
        if form_moved(a, b, atol):
            continue
        for name in ("kn", "delta"):
            move = abs(math.log(getattr(b, f"{name}_rep") / getattr(a, f"{name}_rep")))
            cause = abs(math.log(getattr(b, name) / getattr(a, name)))
            if _jumps(move, cause) and (worst is None or move > worst.move):
                worst = BindingJump(after=i, parameter=name, move=move, cause=cause)
    return worst


def jump_run(jump: BindingJump, fits: Callable[[int, frozenset], tuple | None],
             runs: Sequence[str]) -> str | None:
    """The one run of ``runs`` (those both replays of ``jump`` and the test have points in)
    without which the pair's fits no longer jump: ``fits(i, keep)`` is replay ``i``'s fit
    (kn, delta) on the runs ``keep`` (None where it cannot be made). None where no run, or
    more than one, takes the jump away, or with fewer than three runs (two left cannot tell
    a jump from the fit's own freedom)."""
    if len(runs) < 3:
        return None
    k = 0 if jump.parameter == "kn" else 1
    found = []
    for run in runs:
        keep = frozenset(runs) - {run}
        try:
            a, b = fits(jump.after - 1, keep), fits(jump.after, keep)
        except (IdentificationError, ValueError, np.linalg.LinAlgError):
            continue
        if a is None or b is None:
            continue
        if not _jumps(abs(math.log(b[k] / a[k])), jump.cause):
            found.append(run)
    return found[0] if len(found) == 1 else None

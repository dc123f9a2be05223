"""The replay's options as one record: :class:`Replay`."""

from __future__ import annotations

from dataclasses import dataclass

from ..arguments import check_bool, check_int, check_number, is_number
from ..signal import JUMP_POINTS

__all__ = ["Replay", "DAMPING_FORMS"]

# the replay's damping by name (a number is a modal damping ratio)
DAMPING_FORMS = ("model", "estimate")


@dataclass(frozen=True)
class Replay:
    """How the test is replayed to correct the fit's bias (:func:`corrected_fit`).

    Validated on construction; a bad value raises ``ValueError`` naming the field.

    Attributes
    ----------
    damping : None, "model", "estimate" or float
        None: the model file's C when it has one, else one modal damping ratio estimated from
        the peak amplitudes; "model" / "estimate" force either; a float in (0, 1) fixes the
        modal damping ratio of every closed-hinge mode.
    n_bootstrap : int
        Noisy copies of the final replay for bootstrap intervals that see the bias (0: none;
        the intervals are then the Jacobian ones, moved with the estimate).
    seed : int
        Seed of those copies' noise.
    jump_point : str or None
        Jump-point rule of the points the replays match (:data:`freeplayid.signal.JUMP_POINTS`):
        "drop" (default; the frequency where each curve drops, far less noisy than the
        maximum's on a flat top), or None for the extraction's own rule.
    weighted : bool
        Weight the matched points by their amplitude noise, measured against the first replay.
    rtol : float [-]
        Convergence: (kn, delta) move by less than this between replays.
    max_iter : int
        Most replays.
    engine : str or None
        Simulator engine of the replays (:data:`freeplayid.simulate.engines.ENGINES` or
        "auto"); None: the exponential engine when available, else "auto".
    """

    damping: float | str | None = None
    n_bootstrap: int = 0
    seed: int = 0
    jump_point: str | None = "drop"
    weighted: bool = True
    rtol: float = 5e-4
    max_iter: int = 8
    engine: str | None = None

    def __post_init__(self):
        d = self.damping
        ok = d is None or (isinstance(d, str) and d in DAMPING_FORMS) or \
            (is_number(d) and 0 < d < 1)
        if not ok:
            raise ValueError(f"`damping` must be None, 'model', 'estimate' or a ratio in (0, 1), "
                             f"got {d!r}")
        check_int("n_bootstrap", self.n_bootstrap, 0)
        check_int("seed", self.seed, 0)
        if self.jump_point is not None and self.jump_point not in JUMP_POINTS:
            raise ValueError(f"`jump_point` must be one of {sorted(JUMP_POINTS)} or None, "
                             f"got {self.jump_point!r}")
        check_bool("weighted", self.weighted)
        check_number("rtol", self.rtol, 0.0, 1.0, open_lo=True, open_hi=True)
        check_int("max_iter", self.max_iter, 1)
        if self.engine is not None:
            # the engines' registry imports torch: only when an engine is named
            from ..simulate.engines import ENGINES

            if self.engine not in ("auto", *ENGINES):
                raise ValueError(f"`engine` must be None or one of {['auto', *ENGINES]}, "
                                 f"got {self.engine!r}")

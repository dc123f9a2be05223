"""Broyden's quasi-Newton solve of the binding function F(u) = 0 (package docstring)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["BindingSolve", "solve_binding", "MAX_STEP_FACTOR", "MAX_HALVINGS"]

MAX_STEP_FACTOR = 1.5  # [-] the unknowns move by at most this factor per replay
MAX_CONDITION = 1e4  # [-] a Broyden update that makes J worse conditioned than this is dropped
MAX_HALVINGS = 2  # a step whose evaluation failed is halved at most this many times
# a loop that converges having stepped along one direction of (log kn, log delta) only knows the
# binding's slope along it (Broyden learns the directions stepped along, from the identity): a
# binding flat across it (a run near the threshold of its jump makes it so: the statistic moves
# by 4 % of a step that raises kn and delta together on a two-hinge beam) stops the loop where
# the identity says it has converged, up to its tolerance over that slope away (1.1 % in delta
# on that beam, noise-free, with the model's own damping). Before it stops, the loop replays one
# probe across the directions it has stepped along, PROBE times its tolerances away, and goes on
# where the slope it measures says the answer is not reached
PROBE = 10.0  # [-] the probe's step in units of the unknowns' tolerances
EXPLORED = 0.3  # [-] a direction the unit steps cover by less than this singular value: probed


@dataclass(frozen=True)
class BindingSolve:
    """The outcome of :func:`solve_binding`.

    Attributes
    ----------
    u : ndarray
        The answer: the last replayed unknowns' next iterate when converged, else the replayed
        unknowns whose residual came closest to zero.
    converged : bool
    jacobian : ndarray
        The binding function's Jacobian as learnt by the last update.
    closest : int or None
        Without convergence, the index of the closest replay in the residual's history.
    n : int
        Residual evaluations (replays) made, failed ones included.
    """

    u: np.ndarray
    converged: bool
    jacobian: np.ndarray
    closest: int | None
    n: int


def broyden_update(J: np.ndarray, du: np.ndarray, dF: np.ndarray) -> np.ndarray:
    """Broyden's rank-one update of the Jacobian ``J`` after a step ``du`` that moved the
    residual by ``dF``, kept while it stays finite and well conditioned."""
    if float(du @ du) <= 1e-12:
        return J
    J_new = J + np.outer(dF - J @ du, du) / float(du @ du)
    if np.all(np.isfinite(J_new)) and np.linalg.cond(J_new) < MAX_CONDITION:
        return J_new
    return J


def solve_binding(residual: Callable[[np.ndarray], np.ndarray | None], u0, J0, *, max_iter: int,
                  tolerances, first: np.ndarray | None = None,
                  bounds: tuple | None = None, probe: int = 0) -> BindingSolve:
    """Solve ``residual(u) = 0`` by Broyden's method from ``u0`` with the Jacobian ``J0``.

    Each step is ``-J^-1 F`` clipped to a factor :data:`MAX_STEP_FACTOR` per unknown (the
    unknowns are logarithms); the loop stops when every step is below its tolerance
    (``tolerances``, one per unknown, in log units) or after ``max_iter`` evaluations. An
    evaluation that fails (``residual`` returns None: a replay that could not be fitted, as where
    a step takes a run of the replay out of jumping) halves the step that led there, up to
    :data:`MAX_HALVINGS` times; the first evaluation failing, or a step failing after that, ends
    the loop. Without convergence the answer is the evaluated ``u`` whose residual came closest
    to zero (its index counts the successful evaluations).
    Near the gap the binding can even fall as delta rises (a larger gap at the same levels moves
    the lowest points towards it), which the identity start does not know: the updates learn it.

    ``first``: the residual at ``u0`` where it was evaluated already (it is not evaluated again
    and does not count in ``n``). ``bounds``: (lower, upper) arrays for the unknowns (+-inf:
    none); an unknown on its bound that the step would push beyond it is held there, and the
    step solves the other unknowns' equations alone (its own residual then need not vanish).
    ``probe``: in the space of the first ``probe`` unknowns, a loop about to stop that has not
    stepped along every direction there (:func:`unexplored`) first replays a probe along the
    least explored one (:data:`PROBE`), learns the slope there, and stops only if the step that
    slope gives is still below the tolerances (else it goes on from that step; a failed probe
    ends the probing and the step is evaluated, which clears its failure). Where the probe
    confirms the stop, ``residual.unprobe()`` (where it has one) makes the evaluation before the
    probe its last again and the loop stops; else the step is evaluated first. At most
    ``probe`` probes, within ``max_iter`` evaluations: with none left the loop stops unprobed,
    and a probe that takes the last one leaves it unconverged unless it confirms the stop.
    0: no probe.
    """
    u, J = np.asarray(u0, dtype=float).copy(), np.asarray(J0, dtype=float).copy()
    lo, hi = (np.full(u.size, -np.inf), np.full(u.size, np.inf)) if bounds is None else \
        (np.asarray(bounds[0], dtype=float), np.asarray(bounds[1], dtype=float))
    tol = np.asarray(tolerances, dtype=float)
    prev, best, n, good, halvings = None, None, 0, 0, 0
    steps = []  # the steps between evaluated unknowns, in units of the tolerances
    probes, probing = 0, probe > 0  # at most one probe per direction (``probe``)
    for k in range(max_iter + (first is not None)):
        if n >= max_iter:
            break
        if k == 0 and first is not None:
            F = np.asarray(first, dtype=float)
        else:
            F = residual(u)
            n += 1
        if F is None:
            if prev is None or halvings >= MAX_HALVINGS:
                break
            halvings += 1
            u = prev[0] + 0.5 * (u - prev[0])
            continue
        halvings, good = 0, good + 1
        # an unknown held on its bound leaves its own equation (the same index) unsolved
        miss = float(np.abs(F[(u > lo) & (u < hi)] if np.any((u > lo) & (u < hi)) else F).max())
        if best is None or miss < best[1]:
            best = (u.copy(), miss, good - 1)
        if prev is not None:
            J = broyden_update(J, u - prev[0], F - prev[1])
            steps.append((u - prev[0]) / tol)
        step = _bounded_step(J, F, u, lo, hi)
        prev = (u.copy(), F.copy())
        u = np.clip(u + step, lo, hi)
        step = u - prev[0]
        if not bool(np.all(np.abs(step) < tol)):
            continue
        e = None
        if probing and probes < probe and n < max_iter:
            # stopped at the start, no slope was measured: the first axis
            e = unexplored(steps, probe) if steps else np.eye(u.size)[0]
        if e is None:
            return BindingSolve(u, True, J, None, n)
        # the probe: learn the slope across the steps taken, then stop or go on
        du = np.clip(prev[0] + PROBE * tol * e, lo, hi) - prev[0]
        Fp = residual(prev[0] + du)
        n, probes = n + 1, probes + 1
        if Fp is None:  # not measured: no more probes; the step is replayed, which clears it
            probing = False
        else:
            steps.append(du / tol)
            J = broyden_update(J, du, np.asarray(Fp, dtype=float) - prev[1])
            stop = u  # the answer the loop was about to give
            u = np.clip(prev[0] + _bounded_step(J, prev[1], prev[0], lo, hi), lo, hi)
            unprobe = getattr(residual, "unprobe", None)
            if unprobe is not None and bool(np.all(np.abs(u - prev[0]) < tol)):
                unprobe()  # that answer stands, and the replay before the probe is its replay
                return BindingSolve(stop, True, J, None, n)
        # else the step is replayed: the loop's last replay is then the answer's
    if best is None:
        return BindingSolve(u, False, J, None, n)
    return BindingSolve(best[0], False, J, best[2], n)


def unexplored(steps, dims: int) -> np.ndarray | None:
    """The unit direction of the first ``dims`` unknowns (zero in the others) that ``steps``
    (the loop's steps, in units of the tolerances) cover least, where their unit directions'
    smallest singular value there is below :data:`EXPLORED` (or they are fewer than ``dims``);
    None where every direction was stepped along."""
    S = np.array([s[:dims] for s in steps], dtype=float)
    norms = np.linalg.norm(S, axis=1)
    S = S[norms > 0] / norms[norms > 0, None]
    if S.shape[0] == 0:
        return None
    _, sv, vt = np.linalg.svd(S, full_matrices=True)
    if S.shape[0] >= dims and sv[-1] >= EXPLORED:
        return None
    e = np.zeros(len(steps[0]))
    e[:dims] = vt[-1]
    return e


def _bounded_step(J: np.ndarray, F: np.ndarray, u: np.ndarray, lo: np.ndarray,
                  hi: np.ndarray) -> np.ndarray:
    """The Newton step ``-J^-1 F`` clipped to :data:`MAX_STEP_FACTOR`; an unknown on a bound
    that it would cross is held there and the others solve their own equations without it."""
    step = -np.linalg.solve(J, F)
    held = ((u <= lo) & (step < 0)) | ((u >= hi) & (step > 0))
    if np.any(held):
        free = ~held
        step = np.zeros_like(step)
        step[free] = -np.linalg.solve(J[np.ix_(free, free)], F[free])
    return np.clip(step, -np.log(MAX_STEP_FACTOR), np.log(MAX_STEP_FACTOR))

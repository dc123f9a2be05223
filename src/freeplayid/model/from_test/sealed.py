"""The linear model updated to the modes of the fin with its clearance sealed.

A model a little off (a plate 2 % too soft moves mode 1 by 1 %) biases kn by about three times
its frequency error: the backbone's closed-hinge limit is mode 1's frequency, and the fit puts
the model's error into kn. The sealed fin's modes (hammer test with the gap closed: the hinges
at kn, delta = 0) carry what is needed to take it out:

1. the structure's stiffness (the hinge springs apart) and the contact stiffness ``kn`` from
   the sealed modes' frequencies together, by least squares of ``log f_k(K' + kn B B^T) -
   log f_k,ref`` over the paired modes. With three or more: ``K' = s K + (s1 - s) w1^2 M v1
   v1^T M``, the open-hinge model's lowest elastic mode ``v1`` (mass-normalised, ``w1``) scaled
   by ``s1`` and the rest of the structure by ``s``; with two, one scale (``s1 = s``, ``K' =
   s K``). Mode 1 moves with kn and the stiffness, the higher modes only with the stiffness,
   so they separate. One scale is right when the whole structure is off alike; a part off
   alone (one plate) moves the lowest elastic mode more than the others, and one scale then
   puts the difference into kn: on the default fin with one plate's Young's modulus moving
   mode 1 by -2 ... +2 %, the fit of its exact DFA backbone points against the update is off
   in kn by 0.2-0.4 % with two scales, 0.8-1.8 % with one (docs/identify.md);
2. the other modes (not the identified one) moved onto their reference frequencies by a
   stiffness along their own shapes, ``M phi_k (w_ref^2 - w_k^2) phi_k^T M`` (mass-normalised
   closed-hinge shapes at that kn), which leaves every other closed mode where it was.

The identified mode is left to (s, kn): correcting it along its shape too would make every kn
match it, and the fit could no longer tell. ``kn`` here is the sealed modes' own estimate; the
identification still takes kn from the sweeps, against the updated model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize

from ..modal import modal_analysis, pair_modes
from ..system import FreeplaySystem

__all__ = ["SealedUpdate", "update_to_sealed_modes"]

# [-] an open-hinge mode with w^2 below this fraction of the largest is a mechanism (w = 0)
ELASTIC = 1e-9
# the two-scale update's Jacobian above this condition number: the modes cannot tell the lowest
# elastic mode's scale from the rest's, and one scale is kept
MAX_CONDITION = 1e6


@dataclass(frozen=True)
class SealedUpdate:
    """The model updated to the sealed fin's modes (module docstring).

    Attributes
    ----------
    system : FreeplaySystem
        The updated model (its stiffness; mass, damping, DOFs and hinges as given).
    scale : float [-]
        The structure's stiffness scale ``s``.
    kn : float [N m/rad]
        The contact stiffness the sealed modes alone give (with ``s``).
    mode_factors : dict of int -> float
        Per other reference mode (0-based model mode): its frequency factor after the scale.
    reference_hz, before_hz, after_hz : ndarray, shape (m,) [Hz]
        The reference frequencies and the paired model modes at ``kn`` before (s = 1) and after.
    residual : float [-]
        RMS of log(f_model / f_ref) over the modes after one uniform scale of the stiffness
        (what one scale could not explain: how far the error is from a uniform stiffness error;
        kn's interval takes it in, :mod:`freeplayid.identification.model_error`).
    first_scale : float [-]
        The scale ``s1`` of the open-hinge model's lowest elastic mode's stiffness (of mode
        ``own_scale_mode``'s; ``s`` with fewer than three modes or where the modes cannot tell
        the two apart).
    parameters : int
        The update's free parameters, kn among them: 2 (one scale) or 3 (two scales).
    own_scale_mode : int
        The open-hinge elastic mode that took the second scale (0: the lowest).
    """

    system: FreeplaySystem
    scale: float
    kn: float
    mode_factors: dict
    reference_hz: np.ndarray
    before_hz: np.ndarray
    after_hz: np.ndarray
    residual: float
    first_scale: float | None = None
    parameters: int = 2
    own_scale_mode: int = 0

    def __post_init__(self):
        if self.first_scale is None:
            object.__setattr__(self, "first_scale", self.scale)

    @property
    def residual_measured(self) -> bool:
        """Whether the update's own fit measures the model's error: not where it has as many
        parameters as modes and fits them exactly whatever the error (two modes with one scale,
        three with two: a plate off alone on a fin whose sealed mode 1 the hinges dominate moved
        kn by 2 % there, with every mode matched)."""
        return self.reference_hz.size > self.parameters

    def describe(self) -> str:
        others = ", ".join(f"mode {k + 1} x{v:.4f}" for k, v in self.mode_factors.items())
        which = ("lowest elastic open-hinge mode" if self.own_scale_mode == 0 else
                 f"open-hinge elastic mode {self.own_scale_mode + 1}")
        first = ("" if f"{self.first_scale:.4f}" == f"{self.scale:.4f}" else
                 f" (its {which} x{self.first_scale:.4f})")
        return (f"stiffness x{self.scale:.4f}{first}"
                + (f", {others} (frequency)" if others else "")
                + f" to the sealed fin's {self.reference_hz.size} modes (their own kn "
                f"{self.kn:.4g} N·m/rad; uniform-stiffness residual {100 * self.residual:.2g} %)")

    def to_dict(self) -> dict:
        return {"scale": self.scale, "first_scale": self.first_scale, "kn_sealed": self.kn,
                "mode_factors": {str(k + 1): v for k, v in self.mode_factors.items()},
                "reference_hz": self.reference_hz.tolist(), "before_hz": self.before_hz.tolist(),
                "after_hz": self.after_hz.tolist(), "residual": self.residual,
                "parameters": self.parameters}


def _closed(system: FreeplaySystem, K: np.ndarray, kn: float) -> np.ndarray:
    return K + (system.closed_stiffness(kn) - system.K)


def update_to_sealed_modes(system: FreeplaySystem, kn_start: float, reference_hz,
                           reference_shapes, shape_dofs, *, mode: int = 0,
                           own_scale_mode: int = 0) -> SealedUpdate | None:
    """The model updated to the sealed modes (module docstring), or None with fewer than two
    paired modes (one frequency cannot separate s from kn).

    Parameters
    ----------
    system : FreeplaySystem
    kn_start : float [N m/rad]
        A first kn (the plain fit's).
    reference_hz : array_like, shape (m,) [Hz]
    reference_shapes : array_like, shape (len(shape_dofs), m)
    shape_dofs : sequence of str
    mode : int
        The identified mode (0: the lowest).
    own_scale_mode : int
        Which elastic mode of the open-hinge model takes the second scale ``s1`` (0: the lowest,
        the default form). Another fits three modes exactly too, with another kn: the two
        forms' kn apart is what three sealed frequencies leave to the form
        (``benchmarks/sealed_forms.py``).
    """
    ref = np.asarray(reference_hz, dtype=float).reshape(-1)
    idx = system.dof_index(list(shape_dofs))
    modes = modal_analysis(system.M, system.closed_stiffness(kn_start))
    pairing, _ = pair_modes(np.asarray(reference_shapes, float), modes.shapes[idx, :],
                            frequencies=(ref, modes.frequencies_hz))
    ok = pairing >= 0
    if np.count_nonzero(ok) < 2 or mode not in pairing[ok]:
        return None
    pair, ref = pairing[ok], ref[ok]
    first = _elastic_stiffness(system, own_scale_mode)

    def stiffness(s, s1):
        return s * system.K + (s1 - s) * first if s1 != s else s * system.K

    def freqs(x):
        kn, s = np.exp(x[:2])
        s1 = float(np.exp(x[2])) if x.size == 3 else s
        return modal_analysis(system.M, _closed(system, stiffness(s, s1), kn)).frequencies_hz[pair]

    def solve(x0):
        return scipy.optimize.least_squares(lambda x: np.log(freqs(x) / ref), x0, x_scale=1.0)

    uniform = solve(np.array([np.log(kn_start), 0.0]))
    kn, s = (float(v) for v in np.exp(uniform.x))
    s1, parameters = s, 2
    if pair.size >= 3 and first is not None:
        two = solve(np.append(uniform.x, uniform.x[1]))
        if two.success and np.linalg.cond(two.jac) < MAX_CONDITION:
            kn, s, s1 = (float(v) for v in np.exp(two.x))
            parameters = 3
    K = stiffness(s, s1)
    closed = modal_analysis(system.M, _closed(system, K, kn))
    factors = {}
    for k, f_ref in zip(pair, ref, strict=True):
        if k == mode:
            continue
        phi = closed.shapes[:, k]  # mass-normalised
        w2, w2_ref = (2 * np.pi * closed.frequencies_hz[k]) ** 2, (2 * np.pi * f_ref) ** 2
        K = K + (w2_ref - w2) * np.outer(system.M @ phi, system.M @ phi)
        factors[int(k)] = float(f_ref / closed.frequencies_hz[k])
    updated = system.replace(K=0.5 * (K + K.T))
    after = modal_analysis(updated.M, updated.closed_stiffness(kn)).frequencies_hz[pair]
    return SealedUpdate(system=updated, scale=s, kn=kn, mode_factors=factors, reference_hz=ref,
                        before_hz=modes.frequencies_hz[pair],
                        after_hz=after, residual=float(np.sqrt(np.mean(uniform.fun ** 2))),
                        first_scale=s1, parameters=parameters, own_scale_mode=own_scale_mode)


def _elastic_stiffness(system: FreeplaySystem, k: int = 0) -> np.ndarray | None:
    """``wk^2 M vk vk^T M``: the stiffness of the open-hinge model's elastic mode ``k`` (0: the
    lowest; the mechanisms about the hinges, w = 0, apart); None without it."""
    modes = modal_analysis(system.M, system.K)
    w2 = modes.omega ** 2
    elastic = np.flatnonzero(w2 > ELASTIC * max(float(w2.max()), 0.0))
    if elastic.size <= k:
        return None
    k = int(elastic[k])
    m_phi = system.M @ modes.shapes[:, k]
    return w2[k] * np.outer(m_phi, m_phi)

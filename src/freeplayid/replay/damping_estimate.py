"""The replay's damping: the model's C, a given modal ratio, or one estimated in the loop."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import modal_analysis, modal_damping
from ..quantity import G

__all__ = ["ReplayDamping", "damped_system", "hinge_damper", "contact_dampers", "damping_mode",
           "initial_zeta", "ZETA_START", "ZETA_RTOL"]

ZETA_START = 0.02  # [-] first guess of an estimated damping ratio (the loop moves it)

ZETA_RTOL = 0.01  # [-] an estimated zeta has converged when it moves by less than 1 %

TREND_SE = 3.0  # [-] replayed peaks drifting with the level by more standard errors: reported


@dataclass(frozen=True)
class ReplayDamping:
    """The damping the replay used.

    Attributes
    ----------
    source : {"model", "given", "estimated"}
        The model file's C, a ratio given by the user, or one estimated from the amplitudes.
    zeta : float or None [-]
        Modal damping ratio of every closed-hinge mode (None with the model's C).
    zeta_ci95 : (float, float) or None
        95 % interval of an estimated zeta (from the per-point amplitude ratios).
    note : str
        Why it was estimated although the model file has C (its replay missed the test's
        amplitudes), or "".
    kn_shift, delta_shift : float or None [-]
        |log| move of the answer for an estimated zeta at its 95 % bound (the amplitude
        statistic 1.96 standard errors off, through the replay loop's Jacobian); added to the
        intervals' log half-widths in quadrature. None when zeta was not estimated.
    exponent : float [-]
        ``Replay.damping_exponent``: mode i had ``zeta (w_i / w_1)^exponent`` (0: ``zeta`` in
        every closed-hinge mode); estimated where that option is "estimate".
    exponent_estimated : bool
        Whether the exponent was estimated (with ``zeta``, so that the replayed amplitudes at
        the points have no trend with the level).
    exponent_ci95 : (float, float) or None
        95 % interval of an estimated exponent (from the trend's standard error, within its
        bounds); its move of the answer is in ``kn_shift`` and ``delta_shift``.
    exponent_note : str
        Why an exponent asked to be estimated was not (it stayed 0), or where it stopped.
    trend, trend_se : float or None [-]
        The slope of the runs' median log(X_replayed / X_measured) against their log level at
        the answer, and its standard error (:func:`.statistic.amplitude_trend`; with an
        estimated ratio and three levels or more); beyond :data:`TREND_SE` standard errors
        without an estimated exponent the description says the damping has another form.
    trend_single : float or None [-]
        That slope at the loop's answer with one ratio in every mode (p = 0), before the
        exponent was estimated.
    single_ratio_answer : (float, float) or None
        (kn, delta) of that answer.
    hinge : float [-]
        ``Replay.damping_hinge``: the share q of the lowest closed mode's ratio that a damper
        across each hinge carries (:func:`damped_system`; 0: modal damping alone); estimated
        where that option is "estimate".
    hinge_estimated : bool
        Whether that share was estimated (as the exponent is, from the trend).
    hinge_ci95 : (float, float) or None
        95 % interval of an estimated share (as ``exponent_ci95``).
    hinge_note : str
        Why a share asked to be estimated was not (it stayed 0), or where it stopped.
    contact : float [-]
        The share of the lowest closed mode's ratio that a damper across each hinge carries
        while it is in contact only (:func:`damped_system`'s ``contact``): 0 but where that form
        was taken from the measured curves (``Replay.damping_forms``).
    """

    source: str
    zeta: float | None = None
    zeta_ci95: tuple | None = None
    note: str = ""
    kn_shift: float | None = None
    delta_shift: float | None = None
    exponent: float = 0.0
    exponent_estimated: bool = False
    exponent_ci95: tuple | None = None
    exponent_note: str = ""
    trend: float | None = None
    trend_se: float | None = None
    trend_single: float | None = None
    single_ratio_answer: tuple | None = None
    hinge: float = 0.0
    hinge_estimated: bool = False
    hinge_ci95: tuple | None = None
    hinge_note: str = ""
    contact: float = 0.0

    def to_dict(self) -> dict:
        return {"source": self.source, "zeta": self.zeta,
                "zeta_ci95": None if self.zeta_ci95 is None else list(self.zeta_ci95),
                "note": self.note, "kn_shift": self.kn_shift, "delta_shift": self.delta_shift,
                "exponent": self.exponent, "exponent_estimated": self.exponent_estimated,
                "exponent_ci95": None if self.exponent_ci95 is None else
                list(self.exponent_ci95),
                "exponent_note": self.exponent_note, "trend": self.trend,
                "trend_se": self.trend_se, "trend_single": self.trend_single,
                "single_ratio_answer": None if self.single_ratio_answer is None else
                list(self.single_ratio_answer),
                "hinge": self.hinge, "hinge_estimated": self.hinge_estimated,
                "hinge_ci95": None if self.hinge_ci95 is None else list(self.hinge_ci95),
                "hinge_note": self.hinge_note, "contact": self.contact}

    @property
    def form_estimated(self) -> str | None:
        """Which form of the damping was estimated with zeta: "exponent", "hinge" or None."""
        return "exponent" if self.exponent_estimated else \
            "hinge" if self.hinge_estimated else None

    def describe(self) -> str:
        if self.source == "model":
            return "the model file's C"
        text = f"zeta = {self.zeta:.4g} in every closed-hinge mode" if not self.exponent else \
            (f"zeta = {self.zeta:.4g} in the lowest closed-hinge mode, zeta (w_i / w_1)^"
             f"{self.exponent:g} in mode i")
        if self.hinge:
            text = (f"zeta = {self.zeta:.4g} in the lowest closed-hinge mode: "
                    f"{100 * self.hinge:.2g} % of it from a damper across each hinge, the rest "
                    f"({self.zeta * (1 - self.hinge):.4g}) a modal ratio of every mode")
        if self.contact:
            text = (f"zeta = {self.zeta:.4g} in the lowest closed-hinge mode: "
                    f"{100 * self.contact:.2g} % of it from a damper across each hinge acting "
                    f"only in contact, the rest ({self.zeta * (1 - self.contact):.4g}) a modal "
                    "ratio of every mode")
        if self.source == "given":
            return text + " (given)"
        ci = "" if self.zeta_ci95 is None else \
            f", 95 % CI [{self.zeta_ci95[0]:.4g}, {self.zeta_ci95[1]:.4g}]"
        if self.kn_shift is not None:
            ci += (f", which moves the answer by kn {100 * self.kn_shift:.2g} %, delta "
                   f"{100 * self.delta_shift:.2g} % (in the intervals)")
        note = f"; {self.note}" if self.note else ""
        text += f" (estimated from the peak amplitudes{ci}{note})"
        form = self.form_estimated
        if form is not None:
            ci = self.exponent_ci95 if form == "exponent" else self.hinge_ci95
            eci = "" if ci is None else f", 95 % CI [{ci[0]:.2g}, {ci[1]:.2g}]"
            what = (f"the exponent {self.exponent:.2g}" if form == "exponent" else
                    f"the hinge damper's share {self.hinge:.2g}")
            text += f"; {what} estimated from how the peaks change with the level{eci}"
            if self.trend_single is not None and self.single_ratio_answer is not None:
                kn, delta = self.single_ratio_answer
                text += (f" (with one ratio in every mode the replayed peaks drifted by "
                         f"{100 * self.trend_single:+.2g} % per e-fold of level and the answer "
                         f"was kn = {kn:.5g} N·m/rad, delta = {delta:.5g} rad)")
        notes = "; ".join(n for n in (self.exponent_note, self.hinge_note) if n)
        if notes:
            text += f"; {notes}"
        elif form is None and self.drifts():
            text += (f"; the replayed peaks drift with the level by {100 * self.trend:+.2g} % "
                     f"per e-fold (standard error {100 * self.trend_se:.2g} %): the "
                     "structure's damping has another form than this one ("
                     + ("damping that rises with the mode, as Rayleigh damping does, or a "
                        "damper at the hinge; without a base channel a level that drifts during "
                        "the runs does the same; `replay.damping_hinge=estimate` or "
                        "`replay.damping_exponent=estimate` fits the first two where a base "
                        "channel is replayed" if self.trend < 0 else
                        "more damping in contact, or a level that sags during the runs?") + ")")
        return text

    def drifts(self) -> bool:
        """Whether the answer's replayed peaks drift with the level beyond
        :data:`TREND_SE` standard errors of that trend (a form of damping the replay lacks)."""
        return self.trend is not None and self.trend_se is not None and \
            np.isfinite(self.trend_se) and abs(self.trend) > TREND_SE * self.trend_se


def damped_system(system, zeta: float, kn: float, exponent: float = 0.0, hinge: float = 0.0,
                  contact: float = 0.0):
    """``system`` with modal damping ratio ``zeta`` in every mode of its closed-hinge stiffness
    at ``kn`` (``model.modal_damping``), replacing its C; with ``exponent`` p, the ratio
    ``zeta (w_i / w_1)^p`` in mode i (w_1 the lowest closed mode's circular frequency).

    With ``hinge`` q (in [0, 1)): a viscous damper across each hinge, ``c B B^T``, carries the
    share q of the lowest closed mode's ratio and the modes keep ``(1 - q)`` of theirs: ``c =
    2 q zeta w_1 / sum_j (b_j^T phi_1)^2`` (phi_1 mass-normalised). The lowest closed mode's
    modal ratio (the diagonal of ``Phi^T C Phi``) stays ``zeta``; the damper damps each mode by
    how far it turns the hinges, and acts with the hinges open too.

    With ``contact`` (a share in [0, 1) as q's): the modes keep ``(1 - contact)`` of their ratio
    and the rest is a damper across each hinge that acts only while it is in contact
    (:func:`contact_dampers`, which the replay passes to the simulator): the lowest closed
    mode's ratio is ``zeta`` with the hinges closed, ``(1 - contact) zeta`` in the gap."""
    Kc = system.closed_stiffness(kn)
    C = modal_damping(system.M, Kc, zeta * (1.0 - hinge - contact), exponent=exponent)
    if not hinge:
        return system.replace(C=C)
    B = system.hinge_matrix()
    C = C + hinge_damper(system, zeta, kn, hinge) * (B @ B.T)
    return system.replace(C=0.5 * (C + C.T))


def hinge_damper(system, zeta: float, kn: float, share: float) -> float:
    """The damper across each hinge [N m s/rad] that carries the share ``share`` of the lowest
    closed mode's ratio ``zeta`` at ``kn``: ``2 share zeta w_1 / sum_j (b_j^T phi_1)^2``
    (:func:`damped_system`)."""
    modes = modal_analysis(system.M, system.closed_stiffness(kn))
    w = 2 * np.pi * modes.frequencies_hz
    first = int(np.flatnonzero(w ** 2 > 1e-9 * float(np.max(w ** 2)))[0])  # mechanisms apart
    turn = float(np.sum((system.hinge_matrix().T @ modes.shapes[:, first]) ** 2))
    return 2 * share * zeta * w[first] / turn


def contact_dampers(system, zeta: float, kn: float, contact: float):
    """Each hinge's damper acting only in contact [N m s/rad] (``simulate_sweeps``'s
    ``contact_damping``) of :func:`damped_system`'s ``contact`` share; None at 0."""
    if not contact:
        return None
    return np.full(system.n_hinges, hinge_damper(system, zeta, kn, contact))


def damping_mode(system, damping) -> tuple[str, float | None]:
    """("model" | "given" | "estimated", zeta) from the ``damping`` argument."""
    if damping is None:
        has_c = system.C is not None and bool(np.any(system.C))
        return ("model", None) if has_c else ("estimated", ZETA_START)
    if isinstance(damping, str):
        if damping == "model":
            if system.C is None or not np.any(system.C):
                raise ValueError("`damping`='model' but the model file has no damping matrix C; "
                                 "use damping='estimate' or a ratio such as 0.02")
            return "model", None
        if damping == "estimate":
            return "estimated", ZETA_START
        raise ValueError(f"`damping` must be None, 'model', 'estimate' or a ratio in (0, 1), "
                         f"got {damping!r}")
    z = float(damping)
    if not (0 < z < 1):
        raise ValueError(f"`damping` must be None, 'model', 'estimate' or a ratio in (0, 1), "
                         f"got {damping!r}")
    return "given", z


def initial_zeta(system, points, levels: dict, kn: float, dofs: dict, mode: int = 0) -> float:
    """First guess of the modal damping ratio from the points: at the top of a resonance the
    damping force balances the excitation, 2 zeta w_c w q = gamma a_g, so with the closed-hinge
    mode (w_c, mass-normalised shape phi, modal load gamma per g) and a point of displacement
    amplitude X at the DOF of its channel, excitation w and level a_g::

        zeta = |phi_dof gamma| a_g / (2 w_c w X)

    (median over the points, kept in [0.002, 0.3]). A swept jump falls before the phase
    resonance and the absolute frame adds the base motion, so this is only the loop's start.
    """
    modes = modal_analysis(system.M, system.closed_stiffness(kn))
    phi = modes.shapes[:, mode]
    wc = 2 * np.pi * float(modes.frequencies_hz[mode])
    gamma = float(phi @ (system.M @ system.influence)) * G
    guesses = []
    for p in points:
        if p.run not in levels or p.channel not in dofs or not p.amplitude_m > 0:
            continue
        pd = float(phi[system.dof_index(dofs[p.channel])])
        w = 2 * np.pi * p.f_hz
        guesses.append(abs(pd * gamma) * levels[p.run][0] / (2 * wc * w * p.amplitude_m))
    if not guesses or wc <= 0:
        return ZETA_START
    return float(np.clip(np.median(guesses), 0.002, 0.3))

"""Plausibility checks of an identification: a verdict ``ok`` / ``suspect`` with its reasons.

A fit always returns numbers; these checks say when the numbers cannot be trusted. Each check
compares the result or the data with a physical limit, never with a value tuned to one data set:

- ``delta_bound``: a half-gap above :data:`LIMITS` ``delta_max_rad`` (0.05 rad, 2.9°) is no hinge
  freeplay; units or quantity errors give 0.07-17 rad.
- ``contact_margin``: the lowest point's hinge amplitude must be ``min_gap_ratio`` (1.5) × delta
  or more: nearer contact the describing function is off by more than 7 % (the exact SDOF
  backbone, docs/backbone.md), and a fit driven there (e.g. channels mapped to the wrong DOFs)
  puts every point at Theta = delta.
- ``backbone_range``: the highest point must lie inside the backbone's amplitude range; beyond
  it the fit sees only the closed-hinge frequency (a quantity error).
- ``interval_width``: a 95 % interval wider than the estimate itself says the points do not fix
  the parameter.
- ``residual``: the relative frequency residual against the frequency scatter between the
  channels of one run (the measurement's own noise level) and an absolute floor.
- ``channel_agreement``: the channels of one run see one resonance; a spread above 1 % means
  another mode or a channel problem.
- ``replay_misfit`` / ``replay_converged`` (with the replay): every run's measured and replayed
  amplitude-frequency curves within 5 % of the peak (median difference), and the corrected fit
  converged: its steps fell below 0.05 %, or its closest replay matches the test's statistics
  within a quarter of their standard error (the replayed fit then jitters by more than the steps
  but by far less than the noise; seen at 5 % damping and on noisy tests).
- ``replay_binding`` (with the replay): the replayed fit moves with (kn, delta) without jumps. When
  two replays whose delta (or kn) differ by less than a fifth of the move of their fits' delta
  (kn) and that move exceeds 1 %, a replayed point changed branch between them (a run whose
  jump appears or vanishes near the estimate): the statistics have no solution across that jump,
  and the estimate can lie anywhere within it, whatever the intervals say.
- ``sweep_law`` (with the replay): where each replayed run's sweep law came from. A law
  estimated from the response channels (no hint, no base channel) is a reason for caution, not
  for suspicion by itself: the check fails only when such a run's replayed curves miss the
  measured ones (its ``replay_misfit`` above the limit), which a wrong law shows.
- ``base_level``: the base channel's amplitude against each run's ``level_g``: a factor 9.81,
  1/9.81 or 1000 is a units error, a ratio that varies as a power of the frequency is a quantity
  error (acceleration declared as displacement...).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..fit import MIN_GAP_RATIO, gap_ratios
from ..quantity import G, check_quantity
from ..signal import window_amplitudes
from ..sweep import Sweep

__all__ = ["Check", "Verdict", "LIMITS", "base_level_checks", "fit_checks", "interval_check",
           "make_verdict", "replay_checks"]

LIMITS = {
    "delta_max_rad": 0.05,  # [rad] largest plausible half-gap
    "min_gap_ratio": MIN_GAP_RATIO,  # [-] lowest point's Theta / delta (DFA error -7 % at 1.5)
    "residual_floor": 5e-3,  # [-] relative frequency residual RMS that is always acceptable...
    "residual_vs_scatter": 5.0,  # [-] ... or this many times the channels' frequency scatter
    "channel_spread": 0.01,  # [-] relative spread of one run's channel frequencies
    "level_tolerance": 0.25,  # [-] base amplitude / level_g accepted within 1 -+ this
    "replay_misfit": 0.05,  # [-] measured vs replayed curves, median difference / peak
    "zeta_ci_ratio": 2.0,  # [-] an estimated damping ratio's 95 % interval, upper / lower
    "binding_jump": 0.01,  # [-] a replayed fit's move (log) that counts as a jump ...
    "binding_slope": 5.0,  # [-] ... when it is this many times its parameters' move
    # [-] an unconverged replay loop whose closest replay misses the test's statistics by at
    # most this many of their standard errors is as good as converged: the answer then lies
    # that far from the solution, which lowers a 95 % interval's coverage to 94.3 % at most
    "binding_noise": 0.25,
}


@dataclass(frozen=True)
class Check:
    """One plausibility check.

    Attributes
    ----------
    name : str
    passed : bool
    message : str
        What was found (for a failed check: the reason of the ``suspect`` verdict).
    value : float or None
        The checked number (e.g. the lowest Theta / delta).
    """

    name: str
    passed: bool
    message: str
    value: float | None = None

    def to_dict(self) -> dict:
        v = None if self.value is None or not math.isfinite(self.value) else float(self.value)
        return {"name": self.name, "passed": self.passed, "message": self.message, "value": v}


@dataclass(frozen=True)
class Verdict:
    """``ok`` when every check passed, else ``suspect`` with the failed checks' messages."""

    status: str
    checks: tuple[Check, ...]

    @property
    def reasons(self) -> tuple[str, ...]:
        return tuple(c.message for c in self.checks if not c.passed)

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def make_verdict(checks) -> Verdict:
    checks = tuple(checks)
    return Verdict("ok" if all(c.passed for c in checks) else "suspect", checks)


def _level_reason(ratio: float, slope: float, quantity: str) -> str | None:
    """Why a base amplitude / expected amplitude ``ratio`` (varying as f^slope) is wrong."""
    tol = LIMITS["level_tolerance"]
    if abs(slope) < 0.5 and abs(math.log(ratio)) < math.log(1 + tol):
        return None
    order = check_quantity(quantity).order
    k = int(round(slope))
    if abs(slope - k) < 0.4 and k != 0 and 0 <= order + k <= 2:
        names = {0: "displacement", 1: "velocity", 2: "acceleration"}
        return (f"the base channel varies as f^{k} against `level_g` in the declared "
                f"quantity: the data look like {names[order + k]}, the manifest says {quantity} "
                "(`quantity`)")
    for factor, meaning in ((G, "m/s^2 declared as g"), (1 / G, "g declared as m/s^2"),
                            (1000.0, "mg (or mm) declared as g (or m)"),
                            (1e-3, "g (or m) declared as mg (or mm)")):
        if abs(math.log(ratio / factor)) < math.log(1 + tol):
            return (f"the base channel is {factor:.4g} x `level_g`: a units error "
                    f"(data in {meaning}? check `units`)")
    return (f"the base channel's amplitude is {ratio:.2g} x `level_g`; check "
            "`units`, `quantity`, `base_channel` and the run's level")


def base_level_checks(dataset) -> list[Check]:
    """The base channel against each run's ``level_g`` (runs with both; none: no check)."""
    if dataset.base_channel is None:
        return []
    order = check_quantity(dataset.quantity).order
    reasons: dict[str, list[str]] = {}
    ratios = []
    for run in dataset.runs:
        if run.reason or run.base is None or not run.level_g:
            continue
        sweep = Sweep(**run.sweep) if run.sweep else None
        f, a = window_amplitudes(dataset.to_si(run.base), dataset.sample_rate, sweep)
        ok = (f > 0) & (a > 0) & np.isfinite(a)
        if np.count_nonzero(ok) < 4:
            continue
        # the base moves as level_g * G sin(phase): its amplitude in the declared quantity
        expected = run.level_g * G / (2 * np.pi * f[ok]) ** (2 - order)
        r = a[ok] / expected
        slope = float(np.polyfit(np.log(f[ok]), np.log(r), 1)[0]) if np.ptp(f[ok]) > 0 else 0.0
        ratio = float(np.median(r))
        ratios.append(ratio)
        why = _level_reason(ratio, slope, dataset.quantity)
        if why:
            reasons.setdefault(why, []).append(run.file)
    if not ratios:
        return []
    if reasons:
        text = "; ".join(f"run(s) {', '.join(runs)}: {why}" for why, runs in reasons.items())
        return [Check("base_level", False, text, float(np.median(ratios)))]
    return [Check("base_level", True, f"base channel matches `level_g` in every run "
                  f"(median ratio {np.median(ratios):.3f})", float(np.median(ratios)))]


def fit_checks(points, fit, system, extraction, *, mode: int = 0) -> list[Check]:
    """Checks of a fit: bounds, contact margin, backbone range, intervals, residual, channels.

    Parameters
    ----------
    points : FittingPoints
        The points fitted (model DOF names).
    fit : FitResult
    system : FreeplaySystem
    extraction : BackbonePoints
        Every run's points (their run names group the channels of one run).
    """
    checks = []
    kn, delta = fit.kn, fit.delta
    dmax = LIMITS["delta_max_rad"]
    checks.append(Check("delta_bound", bool(0 < delta <= dmax),
                        f"delta = {delta:.4g} rad" + ("" if delta <= dmax else
                        f" exceeds {dmax} rad: no hinge freeplay is that large (units, "
                        "quantity or channel mapping?)"), delta))
    ratios, s_max = gap_ratios(points, system, kn, delta, mode)
    lo, hi = float(np.nanmin(ratios)), float(np.nanmax(ratios))
    need = LIMITS["min_gap_ratio"]
    checks.append(Check("contact_margin", bool(lo >= need),
                        f"lowest point at Theta/delta = {lo:.3g}" + ("" if lo >= need else
                        f" < {need}: too close to contact for the backbone (channel mapping? "
                        "add higher levels)"), lo))
    checks.append(Check("backbone_range", bool(hi < 0.99 * s_max),
                        f"highest point at Theta/delta = {hi:.3g}" + ("" if hi < 0.99 * s_max
                        else ": beyond the backbone's range, the fit sees only the closed-hinge "
                        "frequency (quantity or units?)"), hi))
    checks.append(interval_check(kn, delta, fit.kn_ci95, fit.delta_ci95))
    by_run: dict[str, list[float]] = {}
    for p in extraction.used():
        by_run.setdefault(p.run, []).append(p.f_hz)
    spreads = {r: (max(f) - min(f)) / np.mean(f) for r, f in by_run.items() if len(f) > 1}
    bad = {r: s for r, s in spreads.items() if s > LIMITS["channel_spread"]}
    checks.append(Check("channel_agreement", not bad,
                        "the channels of each run agree on the resonance frequency" if not bad
                        else "channels of one run disagree on the resonance frequency: " +
                        ", ".join(f"{r} ({100 * s:.2g} %)" for r, s in bad.items()),
                        max(spreads.values(), default=None)))
    dev = [(fi - np.mean(f)) / np.mean(f) for f in by_run.values() if len(f) > 1 for fi in f]
    scatter = float(np.sqrt(np.mean(np.square(dev)))) if dev else 0.0
    limit = max(LIMITS["residual_floor"], LIMITS["residual_vs_scatter"] * scatter)
    checks.append(Check("residual", bool(fit.residual_rms <= limit),
                        f"residual RMS {fit.residual_rms:.2e}" + (
                            f" <= {limit:.2e}" if fit.residual_rms <= limit else
                            f" > {limit:.2e} (channel scatter {scatter:.1e}): the points do not "
                            "lie on one backbone of this model"), fit.residual_rms))
    return checks


def interval_check(kn: float, delta: float, kn_ci95, delta_ci95) -> Check:
    """``interval_width``: each 95 % interval no wider than its estimate (and finite)."""
    wide = [f"{name} [{ci[0]:.4g}, {ci[1]:.4g}]" for name, ci, v in
            (("kn", kn_ci95, kn), ("delta", delta_ci95, delta))
            if not (np.isfinite(ci[1]) and ci[1] - ci[0] <= v)]
    return Check("interval_width", not wide,
                 "95 % intervals narrower than the estimates" if not wide else
                 "95 % interval wider than the estimate: " + ", ".join(wide))


def validation_checks(validation) -> list[Check]:
    """The zero-clearance check (``reference_modes``) as a verdict check: a model whose sealed
    modes miss the hammer test's is not the structure that was swept, whatever the fit says
    (none without reference modes)."""
    if validation is None:
        return []
    err = np.abs(np.asarray(validation.error_hz, float))
    rel = err / np.maximum(np.abs(np.asarray(validation.reference_hz, float)), 1e-12)
    k = int(np.argmax(rel)) if rel.size else 0
    worst = (f"mode {k + 1}: {validation.model_hz[k]:.4g} Hz against "
             f"{validation.reference_hz[k]:.4g} Hz, MAC {validation.mac[k]:.3f}"
             if rel.size else "no mode")
    msg = (f"the model closed at the estimate matches the sealed fin's modes (worst {worst})"
           if validation.passed else
           f"the model closed at the estimate does not match the sealed fin's modes ({worst}): "
           "the linear model is not the tested structure")
    return [Check("zero_clearance", bool(validation.passed), msg,
                  float(rel[k]) if rel.size else None)]


def replay_checks(replay) -> list[Check]:
    """The replay's self-check: the replay could be fitted, measured vs replayed curves per run,
    convergence, and an estimated damping ratio that the amplitudes pin down."""
    if getattr(replay, "failure", ""):
        return [Check("replay_failed", False, replay.failure)]
    limit = LIMITS["replay_misfit"]
    misfit = {r: m for r, m in (replay.misfit or {}).items() if math.isfinite(m)}
    bad = {r: m for r, m in misfit.items() if m > limit}
    worst = max(misfit.values(), default=None)
    checks = [Check("replay_misfit", not bad,
                    ("measured and replayed curves agree (worst run "
                     f"{100 * worst:.2g} % of the peak)" if worst is not None else
                     "no replayed curve to compare") if not bad else
                    "the replay does not reproduce the test: " + ", ".join(
                        f"{r} ({100 * m:.2g} % of the peak)" for r, m in bad.items())
                    + " (model, damping, levels or sweep law?)", worst)]
    checks.append(_sweep_law_check(replay, misfit, limit))
    checks.append(_binding_check(replay.iterations))
    checks.append(_converged_check(replay))
    damping = getattr(replay, "damping", None)
    if damping is not None and damping.source == "estimated":
        ci = damping.zeta_ci95
        ratio = None if ci is None else ci[1] / ci[0]
        ok = ratio is not None and ratio <= LIMITS["zeta_ci_ratio"]
        checks.append(Check(
            "damping_estimate", ok,
            f"damping estimated from the peak amplitudes: zeta = {damping.zeta:.3g}"
            + ("" if ci is None else f" (95 % CI {ci[0]:.3g} to {ci[1]:.3g})")
            + ("" if ok else "; the amplitudes do not pin it down (give `damping=` or C in "
               "the model file)"), ratio))
    return checks


def _converged_check(replay) -> Check:
    """``replay_converged``: converged, or the closest replay within the statistics' noise."""
    n = len(replay.iterations)
    if replay.converged:
        return Check("replay_converged", True, f"the corrected fit converged in {n} replays")
    close = getattr(replay, "closest_misfit_se", None)
    if close is not None and close <= LIMITS["binding_noise"]:
        return Check("replay_converged", True,
                     f"the corrected fit did not converge in {n} replays, but its closest replay "
                     f"matches the test's statistics within {close:.2g} of their standard error",
                     close)
    return Check("replay_converged", False,
                 f"the corrected fit did not converge in {n} replays"
                 + ("" if close is None else
                    f" (its closest replay misses the test's statistics by {close:.2g} of their "
                    "standard error)"), close)


def _binding_check(iterations) -> Check:
    """``replay_binding``: no two replays whose fits differ by a jump (module docstring)."""
    worst = None  # (move of the fit, move of the parameter, name)
    for a, b in zip(iterations, iterations[1:]):
        for name in ("kn", "delta"):
            move = abs(math.log(getattr(b, f"{name}_rep") / getattr(a, f"{name}_rep")))
            cause = abs(math.log(getattr(b, name) / getattr(a, name)))
            if (move > LIMITS["binding_jump"] and move > LIMITS["binding_slope"] * cause
                    and (worst is None or move > worst[0])):
                worst = (move, cause, name)
    if worst is None:
        return Check("replay_binding", True, "the replayed fits move smoothly with (kn, delta)")
    move, cause, name = worst
    return Check("replay_binding", False,
                 f"the replayed fit's {name} jumped by {100 * move:.2g} % when the replayed "
                 f"{name} moved by {100 * cause:.2g} %: a replayed point changes branch near "
                 "the estimate (a run at the edge of jumping?), which can lie anywhere across "
                 "that jump", move)


def _sweep_law_check(replay, misfit: dict, limit: float) -> Check:
    """Where the replayed sweep laws came from; a law guessed from the responses passes only
    when the replay reproduces that run (module docstring)."""
    sweeps = replay.sweeps or {}
    by_source: dict[str, list[str]] = {}
    for run, sw in sweeps.items():
        by_source.setdefault(sw["source"], []).append(run)
    where = "; ".join(f"{src}: {', '.join(runs)}" for src, runs in by_source.items())
    guessed = by_source.get("response", [])
    if not guessed:
        return Check("sweep_law", True, f"sweep laws from {where or 'no run'}")
    worst = max((sweeps[r].get("residual_hz", 0.0) for r in guessed), default=0.0)
    bad = [r for r in guessed if not misfit.get(r, math.inf) <= limit]
    text = (f"sweep law of run(s) {', '.join(guessed)} estimated from the response channels "
            f"(no hint, no base channel; fit residual up to {worst:.2g} Hz)")
    if bad:
        return Check("sweep_law", False, text + f"; the replay does not reproduce {', '.join(bad)}"
                     ": the estimated law may be wrong (give the runs' `sweep` hints)", worst)
    return Check("sweep_law", True, text + "; the replay reproduces them (caution: no hint)",
                 worst)

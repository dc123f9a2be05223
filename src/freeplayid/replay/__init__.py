"""Replay the measured test with the simulator, and the bias-corrected fit (indirect inference).

The swept, damped resonance peaks are not points of the undamped backbone, and the extraction
adds its own offsets at the jump; a backbone fit turns both into a biased (kn, delta). The
replay simulates the test as it was run -- each run's level and sweep law, the measured sample
rate, quantity and frame, the model's damping -- at given (kn, delta), and passes the records
through the SAME extraction and fit as the measured data. With theta_hat = fit(measured) and
theta_rep(theta) = fit(replay(theta)), the corrected estimate solves

    theta_rep(theta) = theta_hat                                     (binding function)

in log parameters (every bias a factor) by Broyden's quasi-Newton method: it starts from the
fixed point theta_{k+1} = theta_k * theta_hat / theta_rep(theta_k) (an identity Jacobian) and
learns the binding function's Jacobian from the replays, so a binding that couples kn and delta,
or moves less than one to one, still converges; each step is at most a factor 1.5, and the loop
stops when both parameters move by less than ``Replay.rtol`` (0.05 %). Without convergence in
``max_iter`` replays the answer is the replayed parameters whose fit came closest to the test's,
and the verdict says that it did not converge. Whatever the bias comes
from (damping, sweep rate, the describing function, the extraction), the replay has it too, so it
cancels; what is left is the measurement noise and the model's own error.

The statistic (``jump_point``). theta_hat and theta_rep may be any statistic of the test, biased
or not, as long as both go through the same steps; what matters is its noise. The plain fit's
points sit at the maximum of each run's curve, which lies on a flat top 0.1-0.5 Hz of sweep long,
so its frequency wanders with the noise (0.03-0.17 Hz between noise draws at 0.2 g on the fin).
By default the replays therefore match the points taken with ``jump_point="drop"``
(:mod:`freeplayid.signal.peak`): the excitation frequency where the curve drops through half its
maximum (0.0001-0.0008 Hz between the same draws) and the amplitude one filter time ahead of
the drop, both from windows that stop at the drop: the grazing transient after it changes with
any 1e-9 change of the parameters, and a statistic that saw it made the binding function
jitter by 0.1-0.2 % (benchmarks/binding_jitter.py). The measured data are extracted once
more with that rule; the plain fit stays what it was (``kn_fit``, ``delta_fit``). The Jacobian
intervals moved with the estimate are the statistic fit's, with each run's points counted as
one observation (the channels of a run share its jump); where a run with points sweeps down,
from the residuals that the answer's replay does not reproduce (:func:`replayed_intervals`,
``ReplayResult.replayed_ci95``: its jump-ups lie off the backbone by what the replay does).

Weights (``weighted``): the statistic's fit weights each point by the inverse of the frequency
residual its amplitude noise makes (:func:`point_weights`): the noise level measured against the
first replay over the point's amplitude, times the backbone's slope d ln f / d ln X there. The
first replay is made at the unweighted fit; the measured points and that replay are refitted
with the weights, which stay fixed for every later fit (one fixed statistic).

Damping (``damping=``): the model file's ``C`` when it has one; else (or with
``damping="estimate"``) one modal damping ratio zeta for every mode of the closed-hinge stiffness
at the plain fit's kn, estimated in the same loop from the points' amplitudes: the jump peak of a
hardening resonance is held down by damping (its amplitude goes roughly as 1/zeta), so the
statistic r = median over the points of log(X_rep / X) joins the two fit statistics as a third
equation r(zeta) = 0 of the same Broyden solve (slope -1 to start); its first guess is
:func:`initial_zeta`. Its interval comes from the spread of the per-point log ratios. A number
(``damping=0.02``) fixes zeta.

Intervals that see the bias (``n_bootstrap``): B copies of the last replay (the test as the model
at the corrected estimate runs it), each with fresh white noise of each channel's measured noise
level (robust standard deviation of the measured minus the replayed record), pass through the
whole plain pipeline (extraction and fit); each copy's fit theta_b maps to a corrected estimate
by the binding function's local factor, theta * theta_b / theta_rep, and the 2.5/97.5 %
percentiles of those are the interval. The bootstrap reuses the last replay's correction factor
instead of re-running the fixed point per copy (the factor varies much less than the noise).
The answer's precision (``precision_copies``, by default): a few such copies, each run cut to
the stretch around its statistic point, give how far the noise alone moves the statistic;
carried through the binding's slope (the inverse of the loop's Jacobian: the answer moves as
far as the replayed statistic must to follow the test's), how far it moves the answer
(:class:`ReplayPrecision`), which the verdict holds against the accuracy bounds. The bootstrap
carries its copies through the same slope.

Each run's sweep law (linear or logarithmic) is its ``sweep`` hint; a run without one gets the
law estimated from the base channel when the data set has one, else from its response channels
(:func:`freeplayid.signal.estimate_sweep`), and the result says which (``sweeps``).

Parts: ``options`` (:class:`Replay`), ``runs`` (the test replayed: sweep laws, levels, the
simulated runs), ``damping`` (the replay's damping and its first guess), ``weights`` (noise
levels, point weights), ``statistic`` (the statistic's standard errors), ``broyden`` (the
solve), ``bootstrap`` (the bootstrap by replay), ``misfit`` (the self-check's curve misfit),
``base_timing`` (the base channel's delay against the responses, read against the replay),
``corrected`` (:func:`corrected_fit`, :class:`ReplayResult`).
"""

from .base_timing import BaseTiming, base_timing
from .binding_jump import BindingJump
from .bootstrap import (
    MeasuredRecords,
    ReplayBootstrap,
    ReplayPrecision,
    precision_by_replay,
    windowed,
)
from .corrected import (
    FORM_FIT_NOISE,
    FORM_PROBES,
    AcquisitionFilter,
    BaseReading,
    CrossCheck,
    DampingSensitivity,
    ExcitationNoise,
    FormAlternative,
    FormSensitivity,
    LevelSensitivity,
    PointOffset,
    ReplayIteration,
    ReplayResult,
    corrected_fit,
)
from .damping_estimate import ZETA_RTOL, ZETA_START, ReplayDamping, damped_system, initial_zeta
from .misfit import curve_misfit
from .options import Replay
from .runs import replay_dataset, replay_levels, replay_sweeps
from .statistic import replayed_intervals
from .weights import WEIGHT_FLOOR, PointWeight, noise_levels, point_weights

__all__ = ["Replay", "ReplayResult", "ReplayIteration", "PointOffset", "PointWeight",
           "ReplayBootstrap", "ReplayPrecision", "MeasuredRecords", "precision_by_replay",
           "windowed",
           "ReplayDamping", "CrossCheck", "LevelSensitivity", "ExcitationNoise", "BaseReading",
           "DampingSensitivity", "FormSensitivity", "FormAlternative", "FORM_FIT_NOISE",
           "FORM_PROBES",
           "AcquisitionFilter", "BaseTiming", "base_timing", "replay_sweeps",
           "replay_levels", "BindingJump",
           "replay_dataset", "corrected_fit", "curve_misfit", "damped_system", "noise_levels",
           "initial_zeta", "point_weights", "replayed_intervals", "WEIGHT_FLOOR", "ZETA_START",
           "ZETA_RTOL"]

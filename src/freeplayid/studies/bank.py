"""Simulated sweep banks: records at a reference gap, cached on disk.

Scale invariance (docs/inverse.md) makes the response depend on kn and on the level-to-gap ratio
``s = level / delta`` only: ``y(kn, c delta, c level) = c y(kn, delta, level)``. So a *bank*
simulates, for each of ``n_kn`` contact stiffnesses, ``n_ratios`` sweeps at ratios ``s`` once,
at the reference gap ``DELTA_REF``; any clearance delta is then the same record scaled by
``delta / DELTA_REF`` at the levels ``s delta`` (:mod:`freeplayid.studies.cases`).

A bank is cached under ``cache_dir`` in a folder named by a hash of everything that defines it
(the linear model's fingerprint, the sweep, the sampling, the seed), written chunk by chunk, so
an interrupted build resumes where it stopped.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..model.system import FreeplaySystem
from ..progress import progress_bar
from ..sweep import Sweep

__all__ = ["BankSpec", "SweepBank", "DELTA_REF", "simulate_bank", "ramped_excitation",
           "rayleigh_like_model"]

log = logging.getLogger(__name__)

DELTA_REF = 1e-3  # [rad] gap of the stored bank records (levels s * DELTA_REF)
# bump when the cached layout, the meaning of a spec field or the simulated numbers change
# (2: 2026-11-21, the numba kernels fuse their multiply-adds and the quasi-static model takes the
# derivative of its fast part inside the decimating FIR)
CACHE_FORMAT = 2
# a Rayleigh-damped kn's second frequency over its closed mode 1's: log-uniform in this range
RAYLEIGH_SECOND = (1.3, 4.0)
# [Hz] the rate at which a level ramp's excitation (phase and envelope) is sampled
RAMP_SAMPLES_HZ = 64.0


def digest(obj) -> str:
    text = json.dumps(obj, sort_keys=True, default=float)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def check_pair(name, v, *, positive=True) -> tuple[float, float]:
    try:
        lo, hi = (float(x) for x in v)
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be a pair [low, high], got {v!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi and (lo > 0 or not positive)):
        raise ValueError(f"`{name}` must be finite with 0 < low <= high, got {v!r}")
    return lo, hi


@dataclass(frozen=True)
class BankSpec:
    """What a sweep bank simulates.

    Attributes
    ----------
    sweep : Sweep
        The sweep of every record (start the sweep where the tests start it: which runs catch
        the resonance branch depends on it).
    sample_rate : float [Hz]
    channels : tuple of str
        DOF names recorded (relative acceleration).
    kn_range : (float, float) [N m/rad]
        kn is drawn log-uniform in it, ``n_kn`` values.
    ratio_range : (float, float) [g/rad]
        Level-to-gap ratios ``s``, ``n_ratios`` per kn, log-uniform.
    n_kn, n_ratios : int
    seed : int
    dtype : {"float32", "float64"}
    chunk_sweeps : int
        Sweeps per simulation call and per cached file (large batches run fastest).
    quasi_static_hz : float or None [Hz]
        Simulate with the quasi-static condensation of the modes above it
        (``simulate_sweeps(quasi_static_hz=)``: 6-7x faster on the default fin at 1000 Hz,
        peak-amplitude error <= 2.1e-3; docs/simulate.md). None: the full model.
    damping_range : (float, float) or None [-]
        A factor on the model's damping matrix C per kn, drawn log-uniform in it (after kn and
        the ratios, so those draws are the same with or without it): the training data then
        span a damping the test may not share (a real test's damping is never the model's
        exactly). None: the model's C for every sweep.
    rate_range : (float, float) or None [-]
        A factor on the sweep's rate (``rate_hz_per_s``, or ``octaves_per_min`` of a log sweep)
        per kn, drawn log-uniform in it after the damping (so the earlier draws are the same
        with or without it): the drop points of a faster sweep lie later and higher on the
        upper branch, which a bank at one rate never shows. The records then differ in length:
        each kn's are ``SweepBank.n_samples[k]`` long, zero after. None: ``sweep`` for every kn.
    rayleigh_fraction : float in [0, 1] or None
        The share of kn whose damping has another form than the model's: Rayleigh, ``a M + b
        K_closed(kn)``, with the ratio that the model's C (times the kn's damping factor) gives
        the closed mode 1 at that mode and at a second frequency drawn log-uniform in
        :data:`RAYLEIGH_SECOND` times it (higher modes then more or less damped than the
        model's). Drawn after the rate. None: the model's C (times its factor) for every kn.
    ramp_range : (float, float) or None [-]
        A level ramp per kn, ``r`` drawn uniform in it (|r| < 1): each sweep's level moves
        linearly from (1 - r) to (1 + r) times its ``level_g`` (the mean), as a shaker's level
        drifts over a sweep; simulated through :class:`freeplayid.sweep.MeasuredSweep`
        (``SweepBank.excitation``). Drawn after the damping form. None: constant levels.
    """

    sweep: Sweep
    sample_rate: float
    channels: tuple
    kn_range: tuple
    ratio_range: tuple
    n_kn: int
    n_ratios: int
    seed: int = 0
    dtype: str = "float32"
    chunk_sweeps: int = 512
    quasi_static_hz: float | None = None
    damping_range: tuple | None = None
    rate_range: tuple | None = None
    rayleigh_fraction: float | None = None
    ramp_range: tuple | None = None

    def __post_init__(self):
        object.__setattr__(self, "kn_range", check_pair("kn_range", self.kn_range))
        object.__setattr__(self, "ratio_range", check_pair("ratio_range", self.ratio_range))
        object.__setattr__(self, "channels", tuple(str(c) for c in self.channels))
        if not self.channels:
            raise ValueError("`channels` must name at least one DOF")
        for name in ("n_kn", "n_ratios", "chunk_sweeps"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"`{name}` must be >= 1, got {getattr(self, name)!r}")
        if self.dtype not in ("float32", "float64"):
            raise ValueError(f"`dtype` must be one of ('float32', 'float64'), got {self.dtype!r}")
        if not self.sample_rate > 0:
            raise ValueError(f"`sample_rate` must be > 0, got {self.sample_rate!r}")
        if self.quasi_static_hz is not None:
            if not float(self.quasi_static_hz) > 0:
                raise ValueError("`quasi_static_hz` must be > 0 or null, got "
                                 f"{self.quasi_static_hz!r}")
            object.__setattr__(self, "quasi_static_hz", float(self.quasi_static_hz))
        if self.damping_range is not None:
            object.__setattr__(self, "damping_range",
                               check_pair("damping_range", self.damping_range))
        if self.rate_range is not None:
            object.__setattr__(self, "rate_range", check_pair("rate_range", self.rate_range))
        if self.rayleigh_fraction is not None:
            f = float(self.rayleigh_fraction)
            if not 0.0 <= f <= 1.0:
                raise ValueError(f"`rayleigh_fraction` must be in [0, 1] or null, got "
                                 f"{self.rayleigh_fraction!r}")
            object.__setattr__(self, "rayleigh_fraction", f)
        if self.ramp_range is not None:
            lo, hi = check_pair("ramp_range", self.ramp_range, positive=False)
            if not (-1.0 < lo and hi < 1.0):
                raise ValueError(f"`ramp_range` must lie within (-1, 1), got {self.ramp_range!r}")
            object.__setattr__(self, "ramp_range", (lo, hi))

    @property
    def per_kn(self) -> bool:
        """Whether each kn has its own damping, sweep or level profile (simulated a kn at a
        time)."""
        return any(v is not None for v in (self.damping_range, self.rate_range,
                                            self.rayleigh_fraction, self.ramp_range))

    def key(self, system: FreeplaySystem) -> str:
        """Cache key: this spec, the model fingerprint and the cache format."""
        d = asdict(self)
        d.pop("chunk_sweeps")  # how the work is cut does not change the data
        if d["quasi_static_hz"] is None:  # the full model: keys of banks built before the option
            d.pop("quasi_static_hz")
        if d["sweep"].get("octaves_per_min") is None:  # linear: keys of banks before log sweeps
            d["sweep"].pop("octaves_per_min", None)
        for name in ("damping_range", "rate_range", "rayleigh_fraction", "ramp_range"):
            # off: the keys of banks before them
            if d[name] is None:
                d.pop(name)
        return digest({"bank": d, "model": system.fingerprint(), "format": CACHE_FORMAT})

    def draw(self) -> tuple[np.ndarray, np.ndarray]:
        """kn (n_kn,) [N m/rad] and ratios (n_kn, n_ratios) [g/rad], from ``seed``."""
        return self._draw()[:2]

    def _draw(self):
        """kn, ratios, the factor on the model's C and the factor on the sweep's rate of each
        kn (ones without ``damping_range`` / ``rate_range``), from ``seed``."""
        return self._draw_all()[:4]

    def _draw_all(self):
        """:meth:`_draw`'s four, then each kn's damping form (True: Rayleigh), its Rayleigh
        second frequency over mode 1's, and its level ramp r (False, 1 and 0 without
        ``rayleigh_fraction`` / ``ramp_range``)."""
        rng = np.random.default_rng(self.seed)
        lk = np.log(self.kn_range)
        lr = np.log(self.ratio_range)
        kn = np.exp(rng.uniform(lk[0], lk[1], self.n_kn))
        ratio = np.sort(np.exp(rng.uniform(lr[0], lr[1], (self.n_kn, self.n_ratios))), axis=1)
        factors = []
        for span in (self.damping_range, self.rate_range):  # in this order: earlier draws stay
            if span is None:
                factors.append(np.ones(self.n_kn))
            else:
                ld = np.log(span)
                factors.append(np.exp(rng.uniform(ld[0], ld[1], self.n_kn)))
        rayleigh, second = np.zeros(self.n_kn, bool), np.ones(self.n_kn)
        if self.rayleigh_fraction is not None:  # in this order, after the rate
            rayleigh = rng.uniform(size=self.n_kn) < self.rayleigh_fraction
            second = np.exp(rng.uniform(*np.log(RAYLEIGH_SECOND), self.n_kn))
        ramp = (np.zeros(self.n_kn) if self.ramp_range is None else
                rng.uniform(self.ramp_range[0], self.ramp_range[1], self.n_kn))
        return kn, ratio, *factors, rayleigh, second, ramp

    def sweep_of(self, rate: float) -> Sweep:
        """``sweep`` with its rate (Hz/s, or octaves/min of a log sweep) times ``rate`` (a
        factor of :meth:`_draw`)."""
        if rate == 1.0:
            return self.sweep
        key = "rate_hz_per_s" if self.sweep.law == "linear" else "octaves_per_min"
        return Sweep(**{**self.sweep.to_dict(), key: float(getattr(self.sweep, key)) * rate})


@dataclass(frozen=True)
class SweepBank:
    """Simulated records at the reference gap.

    Attributes
    ----------
    spec : BankSpec
    key : str
    kn : ndarray, shape (K,) [N m/rad]
    ratio : ndarray, shape (K, R) [g/rad]
    time : ndarray, shape (T,) [s]
    signals : ndarray, shape (K, R, C, T) [m/s^2]
        Relative acceleration at ``DELTA_REF`` and level ``ratio * DELTA_REF`` [g].
    diverged : ndarray, shape (K, R) bool
    damping : ndarray, shape (K,) [-]
        The factor on the model's C of each kn's sweeps (ones: the model's damping).
    rate : ndarray, shape (K,) [-]
        The factor on the sweep's rate of each kn's sweeps (ones: ``spec.sweep``).
    n_samples : ndarray, shape (K,) of int
        Samples of each kn's records (``T`` for all without ``spec.rate_range``; the rest of
        ``signals`` is zero).
    rayleigh : ndarray, shape (K,) bool, optional
        Whether each kn's damping is Rayleigh (``spec.rayleigh_fraction``); all False if None.
    ramp : ndarray, shape (K,) [-], optional
        Each kn's level ramp r (``spec.ramp_range``); all 0 if None.
    """

    spec: BankSpec
    key: str
    kn: np.ndarray
    ratio: np.ndarray
    time: np.ndarray
    signals: np.ndarray
    diverged: np.ndarray
    damping: np.ndarray
    rate: np.ndarray
    n_samples: np.ndarray
    rayleigh: np.ndarray | None = None
    ramp: np.ndarray | None = None

    def __post_init__(self):
        n = self.kn.size
        if self.rayleigh is None:
            object.__setattr__(self, "rayleigh", np.zeros(n, bool))
        if self.ramp is None:
            object.__setattr__(self, "ramp", np.zeros(n))

    def sweep(self, k: int) -> Sweep:
        """The sweep law of kn ``k``'s records (what a test's sweep hint says)."""
        return self.spec.sweep_of(float(self.rate[k]))

    def excitation(self, k: int):
        """What drove kn ``k``'s records: :meth:`sweep`, or with a level ramp the same law
        with the envelope (1 - r) -> (1 + r) (:func:`ramped_excitation`)."""
        return ramped_excitation(self.sweep(k), float(self.ramp[k]))

    def records(self, k: int, runs) -> np.ndarray:
        """kn ``k``'s records of the sweeps ``runs`` (runs, C, n_samples[k]) [m/s^2]."""
        return self.signals[k, runs, :, :int(self.n_samples[k])]


def ramped_excitation(sweep: Sweep, ramp: float):
    """``sweep`` with its level moving linearly from (1 - ramp) to (1 + ramp) of the mean over
    its duration (a :class:`freeplayid.sweep.MeasuredSweep` sampled at
    :data:`RAMP_SAMPLES_HZ`; its envelope's median is 1); ``sweep`` itself for ramp 0."""
    from ..sweep import MeasuredSweep

    if ramp == 0.0:
        return sweep
    n = int(math.ceil(sweep.duration * RAMP_SAMPLES_HZ)) + 1
    t = np.linspace(0.0, sweep.duration, n)
    return MeasuredSweep(sample_rate=(n - 1) / sweep.duration, phase_samples=sweep.phase(t),
                         envelope_samples=1.0 + ramp * (2.0 * t / sweep.duration - 1.0))


def rayleigh_like_model(system: FreeplaySystem, kn: float, factor: float,
                        second: float) -> np.ndarray:
    """The Rayleigh damping ``a M + b K_closed(kn)`` with the ratio that ``factor`` times the
    model's C gives the closed mode 1 at kn, at mode 1 and at ``second`` times its frequency."""
    from ..model.damping import rayleigh_damping
    from ..model.modal import closed_mode_damping

    f, zeta = closed_mode_damping(system, kn)
    f1 = float(f[0])
    return rayleigh_damping(system.M, system.closed_stiffness(kn), f1=f1, f2=second * f1,
                            zeta=factor * float(zeta[0]))


def simulate_bank(
    system: FreeplaySystem,
    spec: BankSpec,
    *,
    cache_dir: str | Path = "outputs/datasets",
    progress: bool = True,
    device=None,
) -> SweepBank:
    """Simulate (or load from the cache) the sweep bank ``spec`` of ``system``.

    The bank is written to ``cache_dir/bank-<key>/`` one chunk of ``spec.chunk_sweeps`` sweeps
    at a time; a later call with the same spec and model loads the finished chunks and
    simulates only the missing ones. ``progress``: a bar over the sweeps to simulate (with two
    chunks or more) and each chunk's simulation bar; False: none.
    """
    import torch

    from ..simulate import simulate_sweeps
    from ..simulate.plan import output_samples

    missing = [c for c in spec.channels if c not in system.dof_names]
    if missing:
        raise ValueError(f"bank `channels` {missing} are not DOFs of the model; "
                         f"allowed: {list(system.dof_names)}")
    if spec.damping_range is not None and system.C is None:
        raise ValueError("`damping_range` scales the model's damping matrix C, and this model "
                         "has none; give the model a C or set damping_range to null")
    if spec.rayleigh_fraction is not None and system.C is None:
        raise ValueError("`rayleigh_fraction` takes its mode-1 damping ratio from the model's "
                         "damping matrix C, and this model has none; give the model a C or set "
                         "rayleigh_fraction to null")
    key = spec.key(system)
    folder = Path(cache_dir) / f"bank-{key}"
    folder.mkdir(parents=True, exist_ok=True)
    spec_json = {"spec": asdict(spec), "model": system.fingerprint(), "delta_ref": DELTA_REF}
    (folder / "spec.json").write_text(json.dumps(spec_json, indent=2, default=float))
    kn, ratio, damping, rate, rayleigh, second, ramp = spec._draw_all()
    lengths = np.array([output_samples(spec.sweep_of(float(r)), spec.sample_rate) for r in rate])
    flat_kn = np.repeat(kn, spec.n_ratios)
    flat_s = ratio.reshape(-1)
    n = flat_kn.size
    cuts = list(range(0, n, spec.chunk_sweeps))
    todo = [i for i, _ in enumerate(cuts) if not (folder / f"chunk-{i:04d}.npz").is_file()]
    dtype = torch.float32 if spec.dtype == "float32" else torch.float64
    if todo:
        log.info("bank %s: simulating %d of %d chunks of %d sweeps -> %s", key, len(todo),
                 len(cuts), spec.chunk_sweeps, folder)
    sizes = [min(cuts[i] + spec.chunk_sweeps, n) - cuts[i] for i in todo]
    bar = progress_bar(total=sum(sizes), desc=f"bank {key}", unit="sweep",
                       show=progress and len(todo) > 1)
    for i, size in zip(todo, sizes):
        sl = slice(cuts[i], cuts[i] + size)
        kw = dict(delta=DELTA_REF, sweep=spec.sweep, channels=list(spec.channels),
                  quantity="acceleration", frame="relative", sample_rate=spec.sample_rate,
                  dtype=dtype, device=device, progress=progress,
                  quasi_static_hz=spec.quasi_static_hz)
        if not spec.per_kn:
            res = simulate_sweeps(system, kn=flat_kn[sl], level_g=flat_s[sl] * DELTA_REF, **kw)
            sig, div = res.signals, res.diverged
        else:  # one damping, sweep and level profile per kn: a call per kn of the chunk
            sig = np.zeros((size, len(spec.channels), lengths.max()), np.float32)
            div = np.zeros(size, bool)
            for k in np.unique(np.arange(n)[sl] // spec.n_ratios):
                js = np.arange(max(sl.start, k * spec.n_ratios),
                               min(sl.stop, (k + 1) * spec.n_ratios))
                if rayleigh[k]:
                    system_k = system.replace(C=rayleigh_like_model(
                        system, float(kn[k]), float(damping[k]), float(second[k])))
                elif spec.damping_range is not None:
                    system_k = system.replace(C=damping[k] * np.asarray(system.C))
                else:
                    system_k = system
                drive = ramped_excitation(spec.sweep_of(float(rate[k])), float(ramp[k]))
                res = simulate_sweeps(system_k, kn=flat_kn[js], level_g=flat_s[js] * DELTA_REF,
                                      **{**kw, "sweep": drive})
                m = min(res.signals.shape[-1], sig.shape[-1])  # a ramp's samples: to rounding
                sig[js - sl.start, :, :m] = res.signals[..., :m]
                div[js - sl.start] = res.diverged
        # a per-process temporary name: parallel jobs (a joblib multirun) may build one chunk
        with atomic_path(folder / f"chunk-{i:04d}.npz") as tmp:
            np.savez(tmp, signals=sig.astype(np.float32), diverged=div)
        bar.update(size)
    bar.close()
    parts = [np.load(folder / f"chunk-{i:04d}.npz") for i in range(len(cuts))]
    signals = np.concatenate([p["signals"] for p in parts])
    diverged = np.concatenate([p["diverged"] for p in parts])
    time = np.arange(signals.shape[-1]) / spec.sample_rate
    k, r = spec.n_kn, spec.n_ratios
    return SweepBank(spec=spec, key=key, kn=kn, ratio=ratio, time=time,
                     signals=signals.reshape(k, r, *signals.shape[1:]),
                     diverged=diverged.reshape(k, r), damping=damping, rate=rate,
                     n_samples=lengths, rayleigh=rayleigh, ramp=ramp)

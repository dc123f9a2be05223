"""Simulated training and study data: sweep banks and identification cases, cached on disk.

Scale invariance (DESIGN.md §1) makes the response depend on kn and on the level-to-gap ratio
``s = level / delta`` only: ``y(kn, c delta, c level) = c y(kn, delta, level)``. So a *bank*
simulates, for each of ``n_kn`` contact stiffnesses, ``n_ratios`` sweeps at ratios ``s`` once,
at the reference gap ``DELTA_REF``; any clearance delta is then the same record scaled by
``delta / DELTA_REF`` at the levels ``s delta``. A *case* (one identification) takes a kn of the
bank, a clearance, a noise level and a random subset of that kn's sweeps (runs), scales them,
adds white acceleration noise and passes every run through the same point extraction as
measured data (:func:`freeplayid.signal.extract_backbone_points`). Noise-free cases reuse one
extraction per sweep, scaled (the extraction is scale-equivariant to 1e-8).

Both stages are cached under ``cache_dir`` in folders named by a hash of everything that
defines them (the linear model's fingerprint, the sweep, the sampling, the seeds, the
extraction options), written chunk by chunk, so an interrupted build resumes where it stopped.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..model.system import FreeplaySystem
from ..quantity import G
from ..sweep import Sweep
from .points import PointSets

__all__ = [
    "BankSpec",
    "CaseSpec",
    "SweepBank",
    "DELTA_REF",
    "AXES",
    "simulate_bank",
    "build_cases",
    "split_by_kn",
]

DELTA_REF = 1e-3  # [rad] gap of the stored bank records (levels s * DELTA_REF)
AXES = ("noise_g", "delta")  # ablation axes of a case set
# bump when the cached layout, the meaning of a spec field or the simulated numbers change
# (2: 2026-11-21, the numba kernels fuse their multiply-adds and the quasi-static model takes the
# derivative of its fast part inside the decimating FIR)
_FORMAT = 2


def _digest(obj) -> str:
    text = json.dumps(obj, sort_keys=True, default=float)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _pair(name, v, *, positive=True) -> tuple[float, float]:
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

    def __post_init__(self):
        object.__setattr__(self, "kn_range", _pair("kn_range", self.kn_range))
        object.__setattr__(self, "ratio_range", _pair("ratio_range", self.ratio_range))
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

    def key(self, system: FreeplaySystem) -> str:
        """Cache key: this spec, the model fingerprint and the cache format."""
        d = asdict(self)
        d.pop("chunk_sweeps")  # how the work is cut does not change the data
        if d["quasi_static_hz"] is None:  # the full model: keys of banks built before the option
            d.pop("quasi_static_hz")
        return _digest({"bank": d, "model": system.fingerprint(), "format": _FORMAT})

    def draw(self) -> tuple[np.ndarray, np.ndarray]:
        """kn (n_kn,) [N m/rad] and ratios (n_kn, n_ratios) [g/rad], from ``seed``."""
        rng = np.random.default_rng(self.seed)
        lk = np.log(self.kn_range)
        lr = np.log(self.ratio_range)
        kn = np.exp(rng.uniform(lk[0], lk[1], self.n_kn))
        ratio = np.sort(np.exp(rng.uniform(lr[0], lr[1], (self.n_kn, self.n_ratios))), axis=1)
        return kn, ratio


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
    """

    spec: BankSpec
    key: str
    kn: np.ndarray
    ratio: np.ndarray
    time: np.ndarray
    signals: np.ndarray
    diverged: np.ndarray


def _atomic_savez(path: Path, **arrays) -> None:
    # a per-process temporary name: parallel jobs (a joblib multirun) may build the same chunk
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp.npz")
    np.savez(tmp, **arrays)
    tmp.replace(path)


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
    simulates only the missing ones.
    """
    import torch

    from ..simulate import simulate_sweeps

    missing = [c for c in spec.channels if c not in system.dof_names]
    if missing:
        raise ValueError(f"bank `channels` {missing} are not DOFs of the model; "
                         f"allowed: {list(system.dof_names)}")
    key = spec.key(system)
    folder = Path(cache_dir) / f"bank-{key}"
    folder.mkdir(parents=True, exist_ok=True)
    spec_json = {"spec": asdict(spec), "model": system.fingerprint(), "delta_ref": DELTA_REF}
    (folder / "spec.json").write_text(json.dumps(spec_json, indent=2, default=float))
    kn, ratio = spec.draw()
    flat_kn = np.repeat(kn, spec.n_ratios)
    flat_s = ratio.reshape(-1)
    n = flat_kn.size
    cuts = list(range(0, n, spec.chunk_sweeps))
    todo = [i for i, _ in enumerate(cuts) if not (folder / f"chunk-{i:04d}.npz").is_file()]
    dtype = torch.float32 if spec.dtype == "float32" else torch.float64
    if todo and progress:
        print(f"bank {key}: simulating {len(todo)} of {len(cuts)} chunks of "
              f"{spec.chunk_sweeps} sweeps -> {folder}")
    for i in todo:
        sl = slice(cuts[i], min(cuts[i] + spec.chunk_sweeps, n))
        res = simulate_sweeps(
            system, kn=flat_kn[sl], delta=DELTA_REF, level_g=flat_s[sl] * DELTA_REF,
            sweep=spec.sweep, channels=list(spec.channels), quantity="acceleration",
            frame="relative", sample_rate=spec.sample_rate, dtype=dtype, device=device,
            progress=progress, quasi_static_hz=spec.quasi_static_hz,
        )
        _atomic_savez(folder / f"chunk-{i:04d}.npz", time=res.time,
                      signals=res.signals.astype(np.float32), diverged=res.diverged)
    parts = [np.load(folder / f"chunk-{i:04d}.npz") for i in range(len(cuts))]
    signals = np.concatenate([p["signals"] for p in parts])
    diverged = np.concatenate([p["diverged"] for p in parts])
    time = parts[0]["time"]
    k, r = spec.n_kn, spec.n_ratios
    return SweepBank(spec=spec, key=key, kn=kn, ratio=ratio, time=time,
                     signals=signals.reshape(k, r, *signals.shape[1:]),
                     diverged=diverged.reshape(k, r))


@dataclass(frozen=True)
class CaseSpec:
    """How identification cases are drawn from a bank.

    Attributes
    ----------
    axis : {"noise_g", "delta"}
        The ablation axis; every kn of the bank gets ``cases_per_value`` cases per value.
    values : tuple of float
        Noise std [g] (axis "noise_g") or clearance delta [rad] (axis "delta"; each case draws
        its delta log-uniform in the bin around its value, :meth:`delta_bins`).
    noise_g : float [g]
        Noise std when the axis is "delta".
    delta_range : (float, float) [rad]
        delta drawn log-uniform in it when the axis is "noise_g".
    cases_per_value : int
    runs : (int, int)
        Runs per case, drawn uniformly in [low, high] (at most the bank's ``n_ratios``).
    extraction : dict
        Options of :func:`freeplayid.signal.extract_backbone_points` (``method`` etc.).
    seed : int
    n_jobs : int
        Worker processes for the noisy extractions (-1: all cores).
    """

    axis: str
    values: tuple
    noise_g: float = 0.0
    delta_range: tuple = (1e-3, 5e-3)
    cases_per_value: int = 2
    runs: tuple = (3, 6)
    extraction: dict = field(default_factory=lambda: {"method": "lockin"})
    seed: int = 0
    n_jobs: int = -1

    def __post_init__(self):
        if self.axis not in AXES:
            raise ValueError(f"`axis` must be one of {AXES}, got {self.axis!r}")
        vals = tuple(float(v) for v in self.values)
        if not vals or any(not math.isfinite(v) or v < 0 for v in vals):
            raise ValueError(f"`values` must be a non-empty list of finite values >= 0, "
                             f"got {self.values!r}")
        if self.axis == "delta" and min(vals) <= 0:
            raise ValueError(f"clearance `values` must be > 0 [rad], got {self.values!r}")
        object.__setattr__(self, "values", vals)
        object.__setattr__(self, "delta_range", _pair("delta_range", self.delta_range))
        lo, hi = (int(v) for v in self.runs)
        if not 1 <= lo <= hi:
            raise ValueError(f"`runs` must be [low, high] with 1 <= low <= high, got {self.runs!r}")
        object.__setattr__(self, "runs", (lo, hi))
        object.__setattr__(self, "extraction", dict(self.extraction))
        if not self.noise_g >= 0:
            raise ValueError(f"`noise_g` must be >= 0 [g], got {self.noise_g!r}")
        if int(self.cases_per_value) < 1:
            raise ValueError(f"`cases_per_value` must be >= 1, got {self.cases_per_value!r}")

    def key(self, bank: SweepBank) -> str:
        d = asdict(self)
        d.pop("n_jobs")
        if self.axis == "delta":  # clearances are drawn in a bin around each value (format 2)
            d["delta_sampling"] = "bin"
        return _digest({"cases": d, "bank": bank.key, "format": _FORMAT})

    def delta_bins(self) -> np.ndarray:
        """Edges [rad], shape (len(values) + 1,), of the clearance bins (axis "delta").

        Sorted values, edges at the geometric midpoints, the outer edges mirrored: a case of
        value v draws its delta log-uniform in v's bin, so the network never sees a prior made
        of a few point masses (it would learn to snap to them).
        """
        v = np.log(np.sort(np.asarray(self.values, dtype=float)))
        if v.size == 1:
            return np.exp(v[0] + np.array([-0.1, 0.1]))
        mid = 0.5 * (v[1:] + v[:-1])
        return np.exp(np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]]))


def _extract(signals, fs, sweep, channels, extraction, names) -> list[tuple[int, float, float]]:
    """Used points (channel index, amplitude [m], f [Hz]) of records (runs, C, T) [m/s^2]."""
    from ..signal import extract_backbone_points

    res = extract_backbone_points(list(signals), fs, quantity="acceleration",
                                  channel_names=list(channels), run_names=names, sweep=sweep,
                                  **extraction)
    return [(channels.index(p.channel), p.amplitude_m, p.f_hz) for p in res.points if p.used]


def _noisy_case(bank_signals, scale, noise_ms2, seed, fs, sweep, channels, extraction):
    rng = np.random.default_rng(seed)
    x = bank_signals.astype(np.float64) * scale
    x += rng.normal(0.0, noise_ms2, x.shape)
    return _extract(x, fs, sweep, channels, extraction, [f"run{i}" for i in range(len(x))])


def build_cases(
    bank: SweepBank,
    spec: CaseSpec,
    *,
    cache_dir: str | Path = "outputs/datasets",
    progress: bool = True,
) -> PointSets:
    """Identification cases of ``bank`` drawn as ``spec`` says (cached, resumable).

    Cases are planned kn-major (every kn of the bank, every axis value, ``cases_per_value``
    draws), extracted in chunks of 256 cases written to ``cache_dir/cases-<key>/`` and kept
    when they have at least two used points. ``spec.json`` there records how many were planned
    and dropped.

    Returns
    -------
    PointSets
        The kept cases; ``meta`` holds per case ``kn_index`` (index into ``bank.kn``),
        ``axis_value``, ``noise_g`` [g], ``n_runs`` and ``level_max_g`` [g].
    """
    from joblib import Parallel, delayed
    from tqdm import tqdm

    key = spec.key(bank)
    folder = Path(cache_dir) / f"cases-{key}"
    final = folder / "cases.npz"
    if final.is_file():
        return PointSets.load(final)
    folder.mkdir(parents=True, exist_ok=True)
    chans = bank.spec.channels
    fs, sweep = bank.spec.sample_rate, bank.spec.sweep
    k_n, r_n = bank.ratio.shape
    lo, hi = spec.runs[0], min(spec.runs[1], r_n)
    if lo > r_n:
        raise ValueError(f"`runs` low {lo} exceeds the bank's {r_n} sweeps per kn")
    rng = np.random.default_rng(spec.seed)
    if spec.axis == "delta":
        edges = np.log(spec.delta_bins())
        order = np.argsort(spec.values)
        bin_of = {spec.values[j]: (edges[i], edges[i + 1]) for i, j in enumerate(order)}
    plan = []  # (kn index, axis value, delta, noise_g, run indices, case seed)
    for k in range(k_n):
        for v in spec.values:
            for _ in range(int(spec.cases_per_value)):
                if spec.axis == "delta":
                    delta, noise = float(np.exp(rng.uniform(*bin_of[v]))), spec.noise_g
                else:
                    delta = float(np.exp(rng.uniform(*np.log(spec.delta_range))))
                    noise = v
                ok = np.flatnonzero(~bank.diverged[k])
                m = min(int(rng.integers(lo, hi + 1)), ok.size)
                runs = np.sort(rng.choice(ok, m, replace=False))
                plan.append((k, v, delta, noise, runs, int(rng.integers(2**63))))

    # Noise-free extraction: once per sweep (at DELTA_REF), scaled per case.
    clean_path = folder / "clean.npz"
    if clean_path.is_file():
        with np.load(clean_path) as z:
            clean = {(int(a), int(b)): z[f"p{a}_{b}"] for a, b in z["keys"]}
    else:
        need = sorted({(k, int(r)) for k, _, _, n, runs, _ in plan if n == 0 for r in runs})
        out = Parallel(n_jobs=spec.n_jobs, batch_size=16)(
            delayed(_extract)(bank.signals[k, r][None], fs, sweep, chans, spec.extraction,
                              [f"k{k}s{r}"])
            for k, r in tqdm(need, desc="clean points", unit="sweep",
                             disable=not progress or not need)
        )
        clean = {kr: np.array(p, float).reshape(-1, 3) for kr, p in zip(need, out, strict=True)}
        _atomic_savez(clean_path, keys=np.array(need, int).reshape(-1, 2),
                      **{f"p{a}_{b}": v for (a, b), v in clean.items()})

    chunk = 256
    parts = []
    bar = tqdm(total=len(plan), desc=f"cases {key}", unit="case", disable=not progress)
    for c0 in range(0, len(plan), chunk):
        path = folder / f"part-{c0 // chunk:04d}.npz"
        block = plan[c0:c0 + chunk]
        if not path.is_file():
            noisy = [i for i, p in enumerate(block) if p[3] > 0]
            got = Parallel(n_jobs=spec.n_jobs, batch_size=4)(
                delayed(_noisy_case)(bank.signals[block[i][0], block[i][4]],
                                     block[i][2] / DELTA_REF, block[i][3] * G, block[i][5],
                                     fs, sweep, chans, spec.extraction)
                for i in noisy
            )
            pts = dict(zip(noisy, got, strict=True))
            rows = []
            for i, (k, _v, delta, noise, runs, _) in enumerate(block):
                if noise > 0:
                    p = np.array(pts[i], float).reshape(-1, 3)
                else:
                    p = np.concatenate([clean[(k, int(r))] for r in runs]).reshape(-1, 3)
                    p = p * [1.0, delta / DELTA_REF, 1.0]
                rows.append(p)
            _atomic_savez(path, n=np.array([len(r) for r in rows]),
                          pts=np.concatenate(rows) if rows else np.zeros((0, 3)))
        with np.load(path) as z:
            parts.append((z["n"], z["pts"]))
        bar.update(len(block))
    bar.close()
    n_pts = np.concatenate([n for n, _ in parts])
    pts = np.concatenate([p for _, p in parts])
    keep = n_pts >= 2
    case = np.repeat(np.arange(len(plan)), n_pts)
    sel = keep[case]
    new_index = np.cumsum(keep) - 1
    meta = {
        "kn_index": np.array([p[0] for p in plan]),
        "axis_value": np.array([p[1] for p in plan], float),
        "noise_g": np.array([p[3] for p in plan], float),
        "n_runs": np.array([len(p[4]) for p in plan]),
        "level_max_g": np.array([bank.ratio[p[0], p[4]].max() * p[2] for p in plan]),
    }
    ps = PointSets(
        channels=chans, case=new_index[case[sel]].astype(np.int64),
        channel=pts[sel, 0].astype(np.int64), amplitude=pts[sel, 1], frequency=pts[sel, 2],
        kn=bank.kn[meta["kn_index"][keep]], delta=np.array([p[2] for p in plan])[keep],
        meta={k: v[keep] for k, v in meta.items()},
    )
    info = {"spec": asdict(spec), "bank": bank.key, "n_planned": len(plan),
            "n_cases": ps.n_cases, "n_dropped": int((~keep).sum())}
    (folder / "spec.json").write_text(json.dumps(info, indent=2, default=float))
    ps.save(final)
    return ps


def split_by_kn(ps: PointSets, n_kn: int, fractions: tuple[float, ...]) -> list[PointSets]:
    """Split cases into parts by the bank's kn index (no kn shared between parts).

    ``fractions`` of the ``n_kn`` bank stiffnesses, in index order (the kn are random draws),
    e.g. (0.7, 0.1, 0.2) for train, validation and test.
    """
    f = np.asarray(fractions, float)
    if np.any(f < 0) or not np.isclose(f.sum(), 1.0):
        raise ValueError(f"`fractions` must be >= 0 and sum to 1, got {fractions!r}")
    edges = np.round(np.concatenate([[0.0], np.cumsum(f)]) * n_kn).astype(int)
    ki = ps.meta["kn_index"]
    return [ps.subset((ki >= a) & (ki < b)) for a, b in zip(edges[:-1], edges[1:], strict=True)]

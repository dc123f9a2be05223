"""Identification cases drawn from a sweep bank, cached on disk, and their split by kn.

A *case* (one identification) takes a kn of the bank (:mod:`freeplayid.studies.bank`), a
clearance, a noise level and a random subset of that kn's sweeps (runs), scales them by
``delta / DELTA_REF`` (scale invariance, docs/inverse.md), adds white acceleration noise and passes
every run through the same point extraction as measured data
(:func:`freeplayid.signal.extract_backbone_points`). Noise-free cases reuse one extraction per
sweep, scaled (the extraction is scale-equivariant to 1e-8).

Cases are cached under ``cache_dir`` in a folder named by a hash of everything that defines
them (the bank's key, the draws, the seeds, the extraction options), written chunk by chunk, so
an interrupted build resumes where it stopped.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..inverse.points import PointSets
from ..quantity import G
from .bank import _FORMAT, DELTA_REF, SweepBank, _atomic_savez, _digest, _pair

__all__ = ["CaseSpec", "AXES", "build_cases", "split_by_kn"]

AXES = ("noise_g", "delta")  # ablation axes of a case set


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

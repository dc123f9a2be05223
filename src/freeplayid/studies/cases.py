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

The cache keeps only the extracted points. The draws are a deterministic function of the spec's
seed (:func:`plan_cases`), and each stored case records its entry of that plan
(``meta["plan_index"]``), so :func:`rebuild_case` makes a stored case's records again, noise
included, as an in-memory :class:`~freeplayid.io.Dataset` (what the bias-corrected fit,
which replays the test, needs).
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..atomic import atomic_path
from ..inverse.pointsets import PointSets
from ..progress import progress_bar
from ..quantity import G
from ..simulate.records import BASE_COLUMN
from ..sweep import rate_at
from .bank import CACHE_FORMAT, DELTA_REF, SweepBank, check_pair, digest

__all__ = ["CaseSpec", "AXES", "PlannedCase", "plan_cases", "build_cases", "rebuild_case",
           "require_plan_index", "split_by_kn"]

AXES = ("noise_g", "delta")  # ablation axes of a case set
# what the cache stores per point (a case set cached with other columns has another key)
POINT_COLUMNS = ("channel", "amplitude_m", "f_hz", "noise_db")
_NCOL = len(POINT_COLUMNS)


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
        object.__setattr__(self, "delta_range", check_pair("delta_range", self.delta_range))
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
        d["point_columns"] = list(POINT_COLUMNS)
        return digest({"cases": d, "bank": bank.key, "format": CACHE_FORMAT})

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


def _extract(signals, fs, sweep, channels, extraction, names) -> list[tuple]:
    """Used points (channel index, amplitude [m], f [Hz], noise [dB]) of records (runs, C, T)
    [m/s^2] (:data:`POINT_COLUMNS`)."""
    from ..signal import extract_backbone_points

    res = extract_backbone_points(list(signals), fs, quantity="acceleration",
                                  channel_names=list(channels), run_names=names, sweep=sweep,
                                  **extraction)
    return [(channels.index(p.channel), p.amplitude_m, p.f_hz, p.noise_db)
            for p in res.points if p.used]


def _case_records(bank_signals, scale, noise_ms2, seed) -> np.ndarray:
    """Records (runs, C, T) [m/s^2] of one case: the bank's sweeps scaled, plus white noise of
    std ``noise_ms2`` [m/s^2] drawn from ``seed`` (none when it is 0)."""
    x = bank_signals.astype(np.float64) * scale
    if noise_ms2 > 0:
        x += np.random.default_rng(seed).normal(0.0, noise_ms2, x.shape)
    return x


def _noisy_case(bank_signals, scale, noise_ms2, seed, fs, sweep, channels, extraction):
    x = _case_records(bank_signals, scale, noise_ms2, seed)
    return _extract(x, fs, sweep, channels, extraction, [f"run{i}" for i in range(len(x))])


class PlannedCase(NamedTuple):
    """One case of :func:`plan_cases`.

    Attributes
    ----------
    kn_index : int
        Index into the bank's ``kn``.
    axis_value : float
        The axis value the case was drawn for (noise std [g] or clearance [rad]).
    delta : float [rad]
        The case's clearance.
    noise_g : float [g]
        White-noise std added to every channel (0: noise-free).
    runs : ndarray of int
        The bank's sweeps (indices into its ``n_ratios``) of the case, sorted.
    seed : int
        Seed of the case's noise draw.
    """

    kn_index: int
    axis_value: float
    delta: float
    noise_g: float
    runs: np.ndarray
    seed: int


def plan_cases(bank: SweepBank, spec: CaseSpec) -> list[PlannedCase]:
    """Every case ``spec`` draws from ``bank``, before extraction (deterministic in ``spec.seed``).

    kn-major: every kn of the bank, every axis value, ``cases_per_value`` draws, each with its
    clearance, its runs among the kn's sweeps that did not diverge, and its noise seed.

    Raises
    ------
    ValueError
        ``spec.runs`` asks for more sweeps than the bank has per kn.
    """
    k_n, r_n = bank.ratio.shape
    lo, hi = spec.runs[0], min(spec.runs[1], r_n)
    if lo > r_n:
        raise ValueError(f"`runs` low {lo} exceeds the bank's {r_n} sweeps per kn")
    rng = np.random.default_rng(spec.seed)
    if spec.axis == "delta":
        edges = np.log(spec.delta_bins())
        order = np.argsort(spec.values)
        bin_of = {spec.values[j]: (edges[i], edges[i + 1]) for i, j in enumerate(order)}
    plan = []
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
                plan.append(PlannedCase(k, v, delta, noise, runs, int(rng.integers(2**63))))
    return plan


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
        ``axis_value``, ``noise_g`` [g], ``n_runs``, ``level_max_g`` [g], ``damping`` (the
        bank's factor on the model's C), ``rate`` (its factor on the sweep's rate; cases
        cached before it was stored lack it) and ``plan_index``
        (its entry of :func:`plan_cases`, for :func:`rebuild_case`; cases cached before it
        was stored lack it); ``noise_db`` each point's noise floor relative to it [dB]; ``rate``
        each point's sweep rate there [Hz/s].
    """
    from joblib import Parallel, delayed

    key = spec.key(bank)
    folder = Path(cache_dir) / f"cases-{key}"
    final = folder / "cases.npz"
    if final.is_file():
        return _with_rates(PointSets.load(final), bank)
    folder.mkdir(parents=True, exist_ok=True)
    chans = bank.spec.channels
    fs = bank.spec.sample_rate
    plan = plan_cases(bank, spec)

    # Noise-free extraction: once per sweep (at DELTA_REF), scaled per case.
    clean_path = folder / "clean.npz"
    if clean_path.is_file():
        with np.load(clean_path) as z:
            clean = {(int(a), int(b)): z[f"p{a}_{b}"] for a, b in z["keys"]}
    else:
        need = sorted({(c.kn_index, int(r)) for c in plan if c.noise_g == 0 for r in c.runs})
        out = Parallel(n_jobs=spec.n_jobs, batch_size=16)(
            delayed(_extract)(bank.records(k, [r]), fs, bank.sweep(k), chans,
                              spec.extraction, [f"k{k}s{r}"])
            for k, r in progress_bar(need, desc="clean points", unit="sweep",
                                     show=progress and bool(need))
        )
        clean = {kr: np.array(p, float).reshape(-1, _NCOL)
                 for kr, p in zip(need, out, strict=True)}
        with atomic_path(clean_path) as tmp:
            np.savez(tmp, keys=np.array(need, int).reshape(-1, 2),
                     **{f"p{a}_{b}": v for (a, b), v in clean.items()})

    chunk = 256
    parts = []
    bar = progress_bar(total=len(plan), desc=f"cases {key}", unit="case", show=progress)
    for c0 in range(0, len(plan), chunk):
        path = folder / f"part-{c0 // chunk:04d}.npz"
        block = plan[c0:c0 + chunk]
        if not path.is_file():
            noisy = [i for i, c in enumerate(block) if c.noise_g > 0]
            got = Parallel(n_jobs=spec.n_jobs, batch_size=4)(
                delayed(_noisy_case)(bank.records(block[i].kn_index, block[i].runs),
                                     block[i].delta / DELTA_REF, block[i].noise_g * G,
                                     block[i].seed, fs, bank.sweep(block[i].kn_index), chans,
                                     spec.extraction)
                for i in noisy
            )
            pts = dict(zip(noisy, got, strict=True))
            rows = []
            for i, (k, _v, delta, noise, runs, _) in enumerate(block):
                if noise > 0:
                    p = np.array(pts[i], float).reshape(-1, _NCOL)
                else:
                    p = np.concatenate([clean[(k, int(r))] for r in runs]).reshape(-1, _NCOL)
                    # the extraction is scale-equivariant: amplitudes scale, the noise floor
                    # relative to the point does not (a noise-free record's is NOISE_DB_MIN)
                    p = p * [1.0, delta / DELTA_REF, 1.0, 1.0]
                rows.append(p)
            with atomic_path(path) as tmp:
                np.savez(tmp, n=np.array([len(r) for r in rows]),
                         pts=np.concatenate(rows) if rows else np.zeros((0, _NCOL)))
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
        "kn_index": np.array([c.kn_index for c in plan]),
        "axis_value": np.array([c.axis_value for c in plan], float),
        "noise_g": np.array([c.noise_g for c in plan], float),
        "n_runs": np.array([len(c.runs) for c in plan]),
        "level_max_g": np.array([bank.ratio[c.kn_index, c.runs].max() * c.delta for c in plan]),
        "damping": np.array([bank.damping[c.kn_index] for c in plan]),
        "rate": np.array([bank.rate[c.kn_index] for c in plan]),
        "rayleigh": np.array([bank.rayleigh[c.kn_index] for c in plan], bool),
        "ramp": np.array([bank.ramp[c.kn_index] for c in plan], float),
        "plan_index": np.arange(len(plan)),
    }
    ps = PointSets(
        channels=chans, case=new_index[case[sel]].astype(np.int64),
        channel=pts[sel, 0].astype(np.int64), amplitude=pts[sel, 1], frequency=pts[sel, 2],
        kn=bank.kn[meta["kn_index"][keep]], delta=np.array([c.delta for c in plan])[keep],
        meta={k: v[keep] for k, v in meta.items()}, noise_db=pts[sel, 3],
    )
    info = {"spec": asdict(spec), "bank": bank.key, "n_planned": len(plan),
            "n_cases": ps.n_cases, "n_dropped": int((~keep).sum())}
    (folder / "spec.json").write_text(json.dumps(info, indent=2, default=float))
    ps.save(final)
    return _with_rates(ps, bank)


def _with_rates(ps: PointSets, bank: SweepBank) -> PointSets:
    """``ps`` with each point's sweep rate (its case's kn's sweep at the point's frequency),
    from the bank, not the cache (cases cached before it was recorded get it too)."""
    kn_index = np.asarray(ps.meta["kn_index"])[ps.case]
    rate = np.empty(ps.case.size)
    for k in np.unique(kn_index):
        sel = kn_index == k
        rate[sel] = rate_at(bank.sweep(int(k)), ps.frequency[sel])
    return ps.with_rate(rate)


def require_plan_index(bank: SweepBank, spec: CaseSpec, ps: PointSets) -> None:
    """ValueError unless ``ps`` records each case's plan entry (``meta["plan_index"]``), as
    cases cached before it was stored do not; the message names their cache folder."""
    if "plan_index" not in ps.meta:
        raise ValueError(f"the cases have no meta['plan_index'] (cached before it was stored); "
                         f"delete their cache folder cases-{spec.key(bank)} to rebuild them")


def rebuild_case(bank: SweepBank, spec: CaseSpec, ps: PointSets, i: int, *,
                 plan: list[PlannedCase] | None = None, base_influence=None):
    """Case ``i`` of ``ps`` as the records :func:`build_cases` extracted its points from.

    The same bank sweeps, scaled by ``delta / DELTA_REF``, with the same noise draw (the case's
    seed); extracting them with ``spec.extraction`` gives the stored points again (to rounding
    for a noisy case; to 1e-6 for a noise-free one, whose stored points are scaled extractions
    of the reference records).

    Parameters
    ----------
    bank : SweepBank
        The bank the cases were drawn from.
    spec : CaseSpec
        The spec that drew them.
    ps : PointSets
        ``build_cases(bank, spec)`` or a subset of it (:meth:`PointSets.subset` keeps ``meta``).
    i : int
        Case index in ``ps``.
    plan : list of PlannedCase, optional
        ``plan_cases(bank, spec)``, computed when not given (pass it when rebuilding many).
    base_influence : array_like, shape (channels,), optional
        The model's rigid-body influence (``FreeplaySystem.base_influence``) at the bank's
        channels: the records are then absolute accelerations, as accelerometers on a shaker
        give them, with the base (control) channel ``acc_base``: the excitation that drove the
        bank's sweeps (:meth:`SweepBank.excitation`) at the run's level, plus white noise of the
        case's std from its own draw. None (default): relative accelerations and no base channel.

    Returns
    -------
    freeplayid.io.Dataset
        In memory (``path`` and ``model`` None): relative acceleration [m/s^2] of the bank's
        channels (column = DOF name; absolute with ``base_influence``), one run per sweep named
        ``k<kn index>s<sweep index>`` with its ``level_g`` [g] and the bank's sweep law as its
        ``sweep`` hint; ``truth`` is the case's kn [N m/rad] and delta [rad].

    Raises
    ------
    ValueError
        ``ps`` has no ``meta["plan_index"]`` (cases cached before it was stored: delete their
        ``cases-<key>`` folder to rebuild them), or case ``i`` is not the plan's entry (``ps``
        comes from another bank or spec).
    """
    from ..dataset import Dataset, Run

    require_plan_index(bank, spec, ps)
    plan = plan_cases(bank, spec) if plan is None else plan
    j = int(ps.meta["plan_index"][i])
    if not 0 <= j < len(plan):
        raise ValueError(f"case {i}: plan_index {j} outside the plan's {len(plan)} cases; the "
                         "cases come from another bank or spec")
    case = plan[j]
    if case.kn_index != int(ps.meta["kn_index"][i]) or case.delta != float(ps.delta[i]):
        raise ValueError(f"case {i}: the plan's entry {j} has another kn or delta than the "
                         "stored case; the cases come from another bank or spec")
    k = case.kn_index
    x = _case_records(bank.records(k, case.runs), case.delta / DELTA_REF, case.noise_g * G,
                      case.seed)
    hint = bank.sweep(k).to_dict()
    time = np.asarray(bank.time[:x.shape[-1]], dtype=float)
    levels = [float(bank.ratio[k, r] * case.delta) for r in case.runs]
    base = [None] * len(levels)
    absolute = base_influence is not None
    if absolute:
        r = np.asarray(base_influence, dtype=float).reshape(-1)
        if r.shape != (x.shape[1],):
            raise ValueError(f"`base_influence` must have one value per bank channel "
                             f"({x.shape[1]}), got shape {r.shape}")
        drive = np.stack([bank.excitation(k).acceleration(time, lv) for lv in levels])
        x = x + r[None, :, None] * drive[:, None, :]
        base = drive
        if case.noise_g > 0:  # a draw of its own, not the channels'
            base = drive + np.random.default_rng([case.seed, 1]).normal(
                0.0, case.noise_g * G, drive.shape)
    runs = tuple(
        Run(file=f"k{k}s{int(rr)}", time=time, data=x[m], level_g=levels[m], base=base[m],
            sweep=dict(hint))
        for m, rr in enumerate(case.runs)
    )
    return Dataset(name=f"planned case {j} (kn index {k}, delta {case.delta:.4g} rad, noise "
                        f"{case.noise_g:g} g)", model=None, quantity="acceleration",
                   units="m/s^2", sample_rate=float(bank.spec.sample_rate),
                   channels={c: c for c in bank.spec.channels}, runs=runs,
                   truth={"kn": float(bank.kn[k]), "delta": float(case.delta)},
                   base_channel=BASE_COLUMN if absolute else None,
                   frame="absolute" if absolute else "relative")


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

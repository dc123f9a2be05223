"""Write docs/results.md: the paper's Sec. 3 numerical experiments (Tables 1-6) on the default fin.

    cd <repo> && PYTHONPATH=src nice python docs/make_results.py   # FREEPLAYID_JOBS=2 workers

Every number in docs/results.md and the figures under docs/figures/results_*.png come from this
script. Simulation: the package's batched RK4 (numba kernel on the CPU), every level of one
experiment in one call; identification: the records as a data set (``sweep_dataset``) through
``freeplayid.identify`` with its defaults, as measured data (ACMP with the sweep hint, DFA fit,
multi-start; harmonic balance for one comparison row): each call gives the plain fit (the
paper's method) and the answer ``identify`` reports, corrected by replaying the test.
"""

from __future__ import annotations

import datetime
import os
import pickle
import platform
import subprocess
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from freeplayid import IdentificationError, identify  # noqa: E402
from freeplayid.backbone import dfa_backbone  # noqa: E402
from freeplayid.model import default_fin, default_fin_parameters  # noqa: E402
from freeplayid.plots import plot_backbone_points, plot_identification_errors  # noqa: E402
from freeplayid.signal import white_noise  # noqa: E402
from freeplayid.simulate import Sweep, simulate_sweeps, sweep_dataset  # noqa: E402

DOCS = Path(__file__).resolve().parent
FIGS = DOCS / "figures"
CHECKPOINT = Path(os.environ.get("TMPDIR", "/tmp")) / "freeplayid_results.pkl"

SWEEP = Sweep(30.0, 50.0, 0.1)  # the paper's numerical sweep [Hz, Hz, Hz/s]
FS = 2048.0  # output sample rate [Hz]
CHANNELS = ("uz_top_left", "uz_lower_right")  # the two measure points
SHORT = {"uz_top_left": "tl", "uz_lower_right": "lr"}
LEVELS = (0.4, 0.6, 0.8, 1.0, 1.2, 1.4)  # base levels [g]; 0.4 g stays in the gap (rejected)
NOISE_G = (0.1, 0.2, 0.3)  # white-noise std on the acceleration [g] (paper Sec. 3.2)
SEEDS = (0, 1, 2, 3, 4)
CLEARANCES = (1e-3, 2e-3, 3e-3, 4e-3, 5e-3)  # half-gaps [rad] (paper Sec. 3.3)
CLEAR_LEVELS = (0.6, 0.8, 1.0, 1.2, 1.4)  # [g] at delta = 3 mrad; scaled by delta / 3 mrad
# paper's bounds [%]: Table 2 (noise-free) and Table 4 (noise); the issue's kn bound with noise
BOUND_FREE = {"delta": 1.0, "kn": 2.0}
BOUND_NOISE_PAPER = {"delta": 1.2, "kn": 0.5}
BOUND_NOISE_ISSUE = {"delta": 1.2, "kn": 2.0}
N_JOBS = int(os.environ.get("FREEPLAYID_JOBS", "2"))  # worker processes of the identifications


def git_commit() -> str:
    def run(*args):
        return subprocess.run(args, cwd=DOCS, capture_output=True, text=True).stdout.strip()

    sha = run("git", "rev-parse", "--short", "HEAD")
    # the outputs this script writes do not count as uncommitted changes of its inputs
    dirty = run("git", "status", "--porcelain", "--untracked-files=no", "--", ".",
                ":!docs/results.md", ":!docs/figures/results_*.png")
    return sha + (" (+ uncommitted changes)" if dirty else "")


def simulate(fin, *, delta, levels, quantity, frame):
    """One batched call of every level; returns the SweepResult."""
    r = simulate_sweeps(fin, kn=KN, delta=delta, level_g=levels, sweep=SWEEP, channels=CHANNELS,
                        quantity=quantity, frame=frame, sample_rate=FS, progress=False)
    if r.diverged.any():
        raise RuntimeError(f"diverged members: {np.flatnonzero(r.diverged)}")
    return r


# [N m/rad] the multi-start grid these tables were measured with (the library's default is now
# [1e2, 1e7]; both give the same fits, benchmarks/multistart_range.py)
KN_GRID = (1e3, 1e8)


def identify_sweeps(fin, result, run_names, *, members=None, noise=None, backbone="dfa"):
    """The simulated records as a data set (absolute accelerations with the base channel), run
    through the library pipeline a measured data set goes through: (points, plain fit, corrected
    answer). One call of ``identify`` with its default replay gives both: the plain backbone
    fit of the points (the paper's method) and the bias-corrected answer that ``identify``
    reports (a dict: :func:`corrected_record`)."""
    ds = sweep_dataset(result, columns={c: c for c in CHANNELS}, members=members,
                       run_names=run_names, noise=noise)
    res = identify(ds, system=fin, progress=False,
                   fit={"backbone": backbone, "multistart": {"kn_range": KN_GRID}})
    return res.points, res.plain_fit, corrected_record(res)


def corrected_record(res) -> dict:
    """What the tables show of the reported (corrected) answer; a plain dict, so that the
    checkpoint does not pickle the records."""
    rp = res.replay
    return dict(kn=res.kn, delta=res.delta, kn_ci95=tuple(res.kn_ci95),
                delta_ci95=tuple(res.delta_ci95), status=res.verdict.status,
                reasons=tuple(res.verdict.reasons), n_points=len(res.used_points),
                n_replays=len(rp.iterations) if rp is not None else 0,
                converged=bool(rp is not None and rp.converged),
                failure=rp.failure if rp is not None else "no replay",
                runtime_s=res.runtime_s)


def identify_backbone(fin, result, run_names, backbone):
    """``identify_sweeps`` of every member with the ``backbone`` method."""
    return identify_sweeps(fin, result, run_names, backbone=backbone)


def identify_noisy(fin, result, run_names, members, std, seed):
    """``identify_sweeps`` of ``members`` with white noise of ``std`` [g] and ``seed``."""
    n = np.zeros(result.signals.shape)
    n[members] = white_noise(n[members].shape, std_g=std, seed=seed)
    return identify_sweeps(fin, result, run_names, members=members, noise=n)


def identify_or_refuse(fin, result, run_names, members):
    """``identify_sweeps``, or (points, the refusal, None) when there are too few points."""
    try:
        return identify_sweeps(fin, result, run_names, members=members)
    except IdentificationError as e:
        return e.points, e, None


def parallel(fn, args_list):
    """``fn(*args)`` for each of ``args_list`` in ``N_JOBS`` worker processes, in order."""
    from joblib import Parallel, delayed

    return Parallel(n_jobs=N_JOBS, batch_size=1)(delayed(fn)(*a) for a in args_list)


def err(est, true):
    return 100.0 * (est / true - 1.0)


def fmt_ci(ci, scale):
    return f"[{ci[0] * scale:.4g}, {ci[1] * scale:.4g}]"


def ok(e, bound):
    return "yes" if abs(e) < bound else "**no**"


def true_bc_frequency(fin, delta, channel, amplitude):
    """Frequency [Hz] of the true DFA backbone at a displacement amplitude [m] of a channel."""
    bc = dfa_backbone(fin, kn=KN, delta=delta)
    j = bc.dof_names.index(channel)
    return float(np.interp(amplitude, bc.amplitude[0, :, j], bc.frequency_hz[0]))


def points_table(fin, sets, delta_of=None):
    """Markdown rows: one per (run, channel); columns f, X and the deviation from the true BC
    for each named point set. ``sets``: {label: BackbonePoints}."""
    labels = list(sets)
    head = "| run | channel | " + " | ".join(
        f"{lb}: f* [Hz] | {lb}: X* [mm] | {lb}: f*/f_BC − 1 [%]" for lb in labels) + " |"
    rows = [head, "|" + "---|" * (2 + 3 * len(labels))]
    first = sets[labels[0]].points
    for i, p0 in enumerate(first):
        cells = [p0.run, SHORT[p0.channel]]
        for lb in labels:
            p = sets[lb].points[i]
            if p.used:
                d = delta_of(p.run) if delta_of else DELTA
                dev = 100.0 * (p.f_hz / true_bc_frequency(fin, d, p.channel, p.amplitude_m) - 1)
                cells += [f"{p.f_hz:.3f}", f"{1e3 * p.amplitude_m:.4f}", f"{dev:+.3f}"]
            else:
                cells += ["–", "–", f"rejected: {p.reason}"]
        rows.append("| " + " | ".join(cells) + " |")
    return rows


def fit_row(label, fit, delta_true, bound, n_points):
    ed, ek = err(fit.delta, delta_true), err(fit.kn, KN)
    return (f"| {label} | {n_points} | {1e3 * fit.delta:.5f} | {ed:+.3f} | "
            f"{fmt_ci(fit.delta_ci95, 1e3)} | {ok(ed, bound['delta'])} | {fit.kn:.2f} | "
            f"{ek:+.3f} | "
            f"{fmt_ci(fit.kn_ci95, 1)} | {ok(ek, bound['kn'])} | {100 * fit.residual_rms:.3f} |")


FIT_HEAD = [
    "| data | points | δ [mrad] | δ error [%] | δ 95 % CI [mrad] | δ within bound | kn [N·m/rad] "
    "| kn error [%] | kn 95 % CI [N·m/rad] | kn within bound | residual rms [%] |",
    "|---|---|---|---|---|---|---|---|---|---|---|",
]

CORR_HEAD = [
    "| data | points | δ [mrad] | δ error [%] | δ 95 % CI [mrad] | δ within bound | kn [N·m/rad] "
    "| kn error [%] | kn 95 % CI [N·m/rad] | kn within bound | replays | verdict |",
    "|---|---|---|---|---|---|---|---|---|---|---|---|",
]


def corrected_row(label, c, delta_true, bound):
    """A row of the corrected answer (:func:`corrected_record`), CORR_HEAD's columns."""
    ed, ek = err(c["delta"], delta_true), err(c["kn"], KN)
    conv = "" if c["converged"] else ", not converged"
    why = f": {'; '.join(c['reasons'])}" if c["reasons"] else ""
    return (f"| {label} | {c['n_points']} | {1e3 * c['delta']:.5f} | {ed:+.3f} | "
            f"{fmt_ci(c['delta_ci95'], 1e3)} | {ok(ed, bound['delta'])} | {c['kn']:.2f} | "
            f"{ek:+.3f} | {fmt_ci(c['kn_ci95'], 1)} | {ok(ek, bound['kn'])} | "
            f"{c['n_replays']}{conv} | {c['status']}{why} |")


def errors_and_worst(estimates):
    """δ and kn errors [%] of (delta, kn) pairs against the truth, and the largest |error| of
    each (signed): (δ errors, kn errors, worst δ, worst kn)."""
    ed = np.array([err(d, DELTA) for d, _ in estimates])
    ek = np.array([err(k, KN) for _, k in estimates])
    return ed, ek, ed[np.argmax(abs(ed))], ek[np.argmax(abs(ek))]


def covers(ci, true):
    return ci[0] <= true <= ci[1]


def main() -> None:
    t_start = time.perf_counter()
    global KN, DELTA
    par = default_fin_parameters()
    KN, DELTA = float(par["kn"]), float(par["delta"])
    fin = default_fin()
    FIGS.mkdir(exist_ok=True)
    names = [f"{lv:.1f} g" for lv in LEVELS]
    timing = {}

    # ---- Tables 1-2: displacement, velocity, acceleration (noise-free) -------------------------
    t0 = time.perf_counter()
    sim = {}
    sim["displacement"] = simulate(fin, delta=DELTA, levels=LEVELS, quantity="displacement",
                                   frame="relative")
    sim["velocity"] = simulate(fin, delta=DELTA, levels=LEVELS, quantity="velocity",
                               frame="relative")
    # absolute, as accelerometers measure; the data set carries the control accelerometer
    sim["acceleration"] = simulate(fin, delta=DELTA, levels=LEVELS, quantity="acceleration",
                                   frame="absolute")
    timing["simulate (3 × 6 sweeps)"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    out = parallel(identify_backbone, [(fin, r, names, "dfa") for r in sim.values()]
                   + [(fin, sim["acceleration"], names, "hb")])
    pts, fits, corr = ({q: o[k] for q, o in zip(sim, out, strict=False)} for k in range(3))
    _, fit_hb, corr_hb = out[-1]
    timing["identify (3 × 12 curves DFA, 1 × 12 harmonic balance; fits and replays)"] = (
        time.perf_counter() - t0)
    print("tables 1-2 done", {q: (err(f.delta, DELTA), err(f.kn, KN)) for q, f in fits.items()},
          {q: (err(c["delta"], DELTA), err(c["kn"], KN)) for q, c in corr.items()}, flush=True)

    # ---- Tables 3-4: acceleration + white noise -------------------------------------------------
    t0 = time.perf_counter()
    acc = sim["acceleration"]
    keep = list(range(1, len(LEVELS)))  # 0.4 g is rejected anyway: not re-run
    jobs = [(std, seed) for std in NOISE_G for seed in SEEDS]
    out = parallel(identify_noisy, [(fin, acc, names[1:], keep, std, seed)
                                    for std, seed in jobs])
    noisy = dict(zip(jobs, out, strict=True))
    timing[f"noise ({len(NOISE_G)} × {len(SEEDS)} seeds: extract + fit + replays)"] = (
        time.perf_counter() - t0)
    print("tables 3-4 done", flush=True)

    # ---- Tables 5-6: clearance values ----------------------------------------------------------
    # (a) levels scaled with delta (level / delta fixed: the same resonance range); (b) the same
    # absolute levels for every delta. delta = 3 mrad at 0.6-1.4 g is the Table 1 run (reused).
    t0 = time.perf_counter()
    other = [d for d in CLEARANCES if d != DELTA]
    d_b, l_b = [], []
    for d in other:
        for lv in CLEAR_LEVELS:
            d_b += [d, d]
            l_b += [lv * d / DELTA, lv]
    sim_c = simulate(fin, delta=np.array(d_b), levels=np.array(l_b), quantity="acceleration",
                     frame="absolute")
    timing[f"simulate clearances ({len(d_b)} sweeps, one call)"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    jobs = {}
    for kind, off in (("scaled", 0), ("fixed", 1)):
        for d in CLEARANCES:
            if d == DELTA:
                if kind == "fixed":  # the same records as (a) at 3 mrad
                    continue
                r, idx = sim["acceleration"], list(range(1, len(LEVELS)))
            else:
                r, idx = sim_c, [i for i in range(off, len(d_b), 2) if d_b[i] == d]
            jobs[kind, d] = (r, idx)
    out = parallel(identify_or_refuse, [(fin, r, [f"{v:.2f} g" for v in r.level_g[idx]], idx)
                                        for r, idx in jobs.values()])
    clear = {key: (r.level_g[idx], *o) for (key, (r, idx)), o in zip(jobs.items(), out,
                                                                      strict=True)}
    clear["fixed", DELTA] = clear["scaled", DELTA]
    timing["clearances: identify (9 cases)"] = time.perf_counter() - t0
    print("tables 5-6 done", flush=True)

    runtime = time.perf_counter() - t_start
    state = dict(pts=pts, fits=fits, fit_hb=fit_hb, noisy=noisy, clear=clear, timing=timing,
                 runtime=runtime, names=names, corr=corr, corr_hb=corr_hb)
    with open(CHECKPOINT, "wb") as fh:  # lets a failed report be rewritten without re-running
        pickle.dump(state, fh)
    report(fin, state)


def report(fin, state) -> None:
    """Draw the figures and write docs/results.md from the computed ``state``."""
    keys = ("pts", "fits", "fit_hb", "noisy", "clear", "corr", "corr_hb")
    pts, fits, fit_hb, noisy, clear, corr, corr_hb = (state[k] for k in keys)
    timing, runtime, names = state["timing"], state["runtime"], state["names"]
    out = []
    # ---- figures ---------------------------------------------------------------------------------
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    fa = fits["acceleration"]
    bc = dfa_backbone(fin, kn=fa.kn, delta=fa.delta)
    for ax, ch in zip(axes, CHANNELS, strict=True):
        j = bc.dof_names.index(ch)
        plot_backbone_points(ax, pts["acceleration"], channel=ch,
                             backbone=(bc.frequency_hz[0], bc.amplitude[0, :, j]),
                             legend=False)
        ax.set_xlim(SWEEP.start_hz, SWEEP.stop_hz)
        ax.set_ylim(0, 1.15e3 * max(p.amplitude_m for p in pts["acceleration"].used(ch)))
        ax.set_title(f"{ch}: identified DFA backbone (dashed)", fontsize=9)
    axes[1].legend(*axes[0].get_legend_handles_labels(), fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(FIGS / "results_backbone.png", dpi=90)
    plt.close(fig)

    fig, axes = plt.subplots(2, 2, figsize=(9, 6.6), sharey="col")
    for row, which in enumerate(("plain fit", "corrected")):
        for ax, key, true in ((axes[row, 0], "delta", DELTA), (axes[row, 1], "kn", KN)):
            if which == "plain fit":
                e = [[err(getattr(noisy[s, k][1], key), true) for k in SEEDS] for s in NOISE_G]
                e0 = err(getattr(fits["acceleration"], key), true)
            else:
                e = [[err(noisy[s, k][2][key], true) for k in SEEDS] for s in NOISE_G]
                e0 = err(corr["acceleration"][key], true)
            plot_identification_errors(
                ax, np.r_[0.0, NOISE_G], [np.array([e0]), *np.array(e)],
                bounds={"paper, noise-free": BOUND_FREE[key],
                        "paper, noise": BOUND_NOISE_PAPER[key]},
                xlabel="noise std [g]",
                title=f"{which}: {'δ' if key == 'delta' else 'kn'} error",
            )
    fig.tight_layout()
    fig.savefig(FIGS / "results_noise.png", dpi=90)
    plt.close(fig)

    # ---- docs/results.md -------------------------------------------------------------------------
    import numba
    import torch

    out += [
        "# Results: the paper's numerical experiments (Sec. 3, Tables 1–6) on the default fin",
        "",
        "Generated by `docs/make_results.py` (the last section by `benchmarks/replay_study.py "
        "--doc`); do not edit by hand.",
        "",
        "- command: `PYTHONPATH=src nice python docs/make_results.py`",
        f"- date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC; "
        f"git commit: `{git_commit()}`",
        f"- runtime: {runtime:.0f} s on {platform.machine()}, {os.cpu_count()} CPU cores (shared "
        f"with other jobs, `nice`), Python {platform.python_version()}, torch {torch.__version__},"
        f" numba {numba.__version__}",
        *(["- text and figures rewritten with `--report-only` from the run's checkpoint (all "
            "numbers from that run; the date and commit above are the rewrite's)"]
          if state.get("rewritten") else []),
        "- stages [s]: " + "; ".join(f"{k} {v:.0f}" for k, v in timing.items()),
        "",
        "## Setup",
        "",
        f"- Model: `default_fin()` (12 DOFs, docs/model.md): truth **kn = {KN:g} N·m/rad** per "
        f"spring, **δ = {1e3 * DELTA:g} mrad**, modal damping ζ = 3 %, zero-clearance f1 = 50 Hz. "
        "The paper's kn = 2.35e6 N·m/rad makes the hinge rigid on a realistic fin "
        "(docs/model.md), so the fin's kn is smaller; the experiments are the paper's otherwise.",
        f"- Sweep: {SWEEP.start_hz:g} → {SWEEP.stop_hz:g} Hz at {SWEEP.rate_hz_per_s:g} Hz/s "
        f"({SWEEP.duration:g} s), from rest, RK4 in relative coordinates (step set by the "
        f"model's 9 kHz top mode), output decimated to {FS:g} Hz, float32.",
        f"- Levels: {', '.join(names)} base acceleration; channels: the two measure points "
        "`uz_top_left` (tl) and `uz_lower_right` (lr).",
        "- Data: displacement and velocity relative to the base (frame `relative`); acceleration "
        "**absolute**, as accelerometers measure, with the base (control) acceleration "
        "A_g sin φ(t) subtracted in `extract_backbone_points(base=...)`.",
        "- Fitting points: first-harmonic amplitude by ACMP (sweep hint, default bandwidth), "
        "peak at the jump, converted to displacement by Eq. 9 (X = V/ω = A/ω²). "
        "Fit: DFA backbone, relative frequency residual, multi-start over kn ∈ [1e3, 1e8], "
        "δ ∈ [1e-4, 1e-2]; 95 % CIs from the Jacobian.",
        "- f*/f_BC − 1: frequency of the point relative to the **true** DFA backbone at the "
        "point's amplitude (the damped, swept peak lies slightly below the undamped backbone).",
        "",
        "## Tables 1–2: displacement, velocity and acceleration data (noise-free)",
        "",
        "Table 1 analogue: fitting points.",
        "",
    ]
    out += points_table(fin, {q[:4] + ".": pts[q] for q in pts})
    out += ["", "Table 2 analogue: identified δ and kn. Paper's bounds (Table 2): "
            f"|δ error| < {BOUND_FREE['delta']:g} %, |kn error| < {BOUND_FREE['kn']:g} %.", ""]
    out += FIT_HEAD
    for q, f in fits.items():
        out.append(fit_row(f"{q} (DFA)", f, DELTA, BOUND_FREE, f.n_points))
    out.append(fit_row("acceleration (harmonic balance)", fit_hb, DELTA, BOUND_FREE,
                       fit_hb.n_points))
    out += ["", "The same identifications' reported answer: the bias-corrected fit (`identify`'s "
            "default replay of the test, docs/identify.md §3b; its own intervals and verdict). "
            "One call gives both rows: the plain fit above is its first step.", ""]
    out += CORR_HEAD
    for q, c in corr.items():
        out.append(corrected_row(f"{q} (DFA), corrected", c, DELTA, BOUND_FREE))
    out.append(corrected_row("acceleration (harmonic balance), corrected", corr_hb, DELTA,
                             BOUND_FREE))
    out += [
        "",
        f"DFA fits took {np.mean([f.runtime_s for f in fits.values()]):.1f} s each "
        f"(multi-start, {np.mean([f.n_evaluations for f in fits.values()]):.0f} evaluations), "
        f"the harmonic-balance fit {fit_hb.runtime_s:.1f} s; the whole identification with "
        f"its replays {np.mean([c['runtime_s'] for c in corr.values()]):.0f} s each "
        "(`identify`'s wall time, shared host).",
        "",
        "![amplitude-frequency curves](figures/results_backbone.png)",
        "",
        "First-harmonic displacement curves from the absolute acceleration (base subtracted), "
        "fitting points (circles), the rejected 0.4 g run (cross) and the identified DFA backbone.",
        "",
        "## Tables 3–4: acceleration with white noise",
        "",
        f"White Gaussian noise of std {', '.join(f'{s:g}' for s in NOISE_G)} g added to both "
        f"absolute-acceleration channels of the 0.6–1.4 g runs, seeds {SEEDS[0]}–{SEEDS[-1]} "
        "(`white_noise(shape, std_g=..., seed=...)`); same extraction and fit.",
        "",
        "Table 3 analogue: fitting points of seed 0.",
        "",
    ]
    out += points_table(fin, {f"{s:g} g": noisy[s, 0][0] for s in NOISE_G})
    out += [
        "",
        "Table 4 analogue: identified δ and kn over the seeds (mean, worst = largest |error|). "
        f"Paper's bounds (Table 4): |δ| < {BOUND_NOISE_PAPER['delta']:g} %, "
        f"|kn| < {BOUND_NOISE_PAPER['kn']:g} %; the issue's acceptance: "
        f"|δ| < {BOUND_NOISE_ISSUE['delta']:g} %, |kn| < {BOUND_NOISE_ISSUE['kn']:g} %.",
        "",
        "| noise std [g] | seeds | points per seed | δ error mean [%] | δ error worst [%] "
        "| δ CI half-width mean [%] | kn error mean [%] | kn error worst [%] "
        "| kn CI half-width mean [%] | δ < paper | kn < paper | kn < issue |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    summary = {}
    for s in NOISE_G:
        fs_ = [noisy[s, k][1] for k in SEEDS]
        ed, ek, wd, wk = errors_and_worst([(f.delta, f.kn) for f in fs_])
        hd = np.mean([50 * (f.delta_ci95[1] - f.delta_ci95[0]) / DELTA for f in fs_])
        hk = np.mean([50 * (f.kn_ci95[1] - f.kn_ci95[0]) / KN for f in fs_])
        npts = sorted({f.n_points for f in fs_})
        summary[s] = (ed.mean(), wd, ek.mean(), wk)
        out.append(
            f"| {s:g} | {len(SEEDS)} | {'/'.join(map(str, npts))} | {ed.mean():+.3f} | {wd:+.3f} | "
            f"{hd:.2f} | {ek.mean():+.3f} | {wk:+.3f} | {hk:.2f} | "
            f"{ok(wd, BOUND_NOISE_PAPER['delta'])} | {ok(wk, BOUND_NOISE_PAPER['kn'])} | "
            f"{ok(wk, BOUND_NOISE_ISSUE['kn'])} |")
    out += [
        "",
        "The same identifications' reported answer, corrected by the replay (its own intervals; "
        "the interval columns: the share of seeds whose 95 % interval holds the truth):",
        "",
        "| noise std [g] | seeds | δ error mean [%] | δ error worst [%] | δ CI holds "
        "| kn error mean [%] | kn error worst [%] | kn CI holds | δ < paper | kn < paper "
        "| verdict ok |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    csummary = {}
    for s in NOISE_G:
        cs = [noisy[s, k][2] for k in SEEDS]
        ed, ek, wd, wk = errors_and_worst([(c["delta"], c["kn"]) for c in cs])
        csummary[s] = (ed.mean(), wd, ek.mean(), wk)
        out.append(
            f"| {s:g} | {len(SEEDS)} | {ed.mean():+.3f} | {wd:+.3f} | "
            f"{sum(covers(c['delta_ci95'], DELTA) for c in cs)}/{len(cs)} | {ek.mean():+.3f} | "
            f"{wk:+.3f} | {sum(covers(c['kn_ci95'], KN) for c in cs)}/{len(cs)} | "
            f"{ok(wd, BOUND_NOISE_PAPER['delta'])} | {ok(wk, BOUND_NOISE_PAPER['kn'])} | "
            f"{sum(c['status'] == 'ok' for c in cs)}/{len(cs)} |")
    out += ["", "![errors vs noise](figures/results_noise.png)", "",
            "Identification error of every seed vs the noise std (0 = the noise-free "
            "acceleration fit), with the paper's bounds: the plain fit (top) and the corrected "
            "answer (bottom).", ""]

    out += [
        "## Tables 5–6: clearance values (acceleration data, noise-free)",
        "",
        "By scale invariance (DESIGN §1), y(kn, cδ, c·A_g) = c·y(kn, δ, A_g): the response leaves "
        "the gap only if level/δ is large enough. (a) Levels scaled with δ "
        f"({', '.join(f'{v:g}' for v in CLEAR_LEVELS)} g × δ / {1e3 * DELTA:g} mrad): the same "
        "experiment in scaled units, so the errors must repeat the δ = 3 mrad case; every case was "
        "simulated (one batched call), not scaled, so this checks the whole pipeline's scale "
        "equivariance. (b) The same absolute levels "
        f"{', '.join(f'{v:g}' for v in CLEAR_LEVELS)} g for every δ, as a test engineer would run "
        "them: small gaps resonate close to f1 = 50 Hz, large ones may stay in the gap.",
        "",
        "Table 5 analogue: fitting points (top-left channel; f* [Hz] / X* [mm]).",
        "",
    ]
    head = "| case | δ [mrad] | levels [g] | " + " | ".join(
        f"run {i + 1}" for i in range(len(CLEAR_LEVELS))) + " |"
    out += [head, "|" + "---|" * (3 + len(CLEAR_LEVELS))]
    for kind in ("scaled", "fixed"):
        for d in CLEARANCES:
            lv, p, *_ = clear[kind, d]
            cells = []
            for q in p.points:
                if q.channel != CHANNELS[0]:
                    continue
                cells.append(f"{q.f_hz:.3f} / {1e3 * q.amplitude_m:.4f}" if q.used
                             else f"rejected ({q.reason})")
            out.append(f"| ({'a' if kind == 'scaled' else 'b'}) {kind} | {1e3 * d:g} | "
                       f"{', '.join(f'{v:.2f}' for v in lv)} | " + " | ".join(cells) + " |")
    out += ["", "Table 6 analogue: identified δ and kn per clearance (paper's noise-free bounds "
            f"δ < {BOUND_FREE['delta']:g} %, kn < {BOUND_FREE['kn']:g} %).", ""]
    out += [FIT_HEAD[0].replace("| data |", "| case, δ true |"), FIT_HEAD[1]]
    for kind in ("scaled", "fixed"):
        for d in CLEARANCES:
            lv, p, f, _ = clear[kind, d]
            lab = f"({'a' if kind == 'scaled' else 'b'}) {kind}, δ = {1e3 * d:g} mrad"
            if isinstance(f, Exception):
                out.append(f"| {lab} | {len(p.used())} | fit failed: {f} |" + " |" * 9)
            else:
                out.append(fit_row(lab, f, d, BOUND_FREE, f.n_points))
    out += ["", "The same identifications' reported answer, corrected by the replay:", ""]
    out += [CORR_HEAD[0].replace("| data |", "| case, δ true |"), CORR_HEAD[1]]
    for kind in ("scaled", "fixed"):
        for d in CLEARANCES:
            lv, p, f, c = clear[kind, d]
            lab = f"({'a' if kind == 'scaled' else 'b'}) {kind}, δ = {1e3 * d:g} mrad"
            if c is None:
                out.append(f"| {lab} | {len(p.used())} | identification refused: {f} |"
                           + " |" * 10)
            else:
                out.append(corrected_row(lab, c, d, BOUND_FREE))

    # ---- headline table (README) ---------------------------------------------------------------
    out += ["", "## Headline (README table)", "",
            "| data | plain fit: δ error [%] | plain fit: kn error [%] | corrected: δ error [%] "
            "| corrected: kn error [%] | paper's bound δ / kn [%] |",
            "|---|---|---|---|---|---|"]
    for q, f in fits.items():
        c = corr[q]
        out.append(f"| {q}, noise-free | {err(f.delta, DELTA):+.2f} | {err(f.kn, KN):+.2f} | "
                   f"{err(c['delta'], DELTA):+.2f} | {err(c['kn'], KN):+.2f} | "
                   f"{BOUND_FREE['delta']:g} / {BOUND_FREE['kn']:g} |")
    for s in NOISE_G:
        md, wd, mk, wk = summary[s]
        cmd, cwd, cmk, cwk = csummary[s]
        out.append(f"| acceleration + {s:g} g noise (mean / worst of {len(SEEDS)}) | "
                   f"{md:+.2f} / {wd:+.2f} | {mk:+.2f} / {wk:+.2f} | "
                   f"{cmd:+.2f} / {cwd:+.2f} | {cmk:+.2f} / {cwk:+.2f} | "
                   f"{BOUND_NOISE_PAPER['delta']:g} / {BOUND_NOISE_PAPER['kn']:g} |")
    ws = [clear["scaled", d][2] for d in CLEARANCES]
    wd = max((err(f.delta, d) for f, d in zip(ws, CLEARANCES, strict=True)), key=abs)
    wk = max((err(f.kn, KN) for f in ws), key=abs)
    cs = [clear["scaled", d][3] for d in CLEARANCES]
    cwd = max((err(c["delta"], d) for c, d in zip(cs, CLEARANCES, strict=True)), key=abs)
    cwk = max((err(c["kn"], KN) for c in cs), key=abs)
    out.append(f"| acceleration, δ = 1–5 mrad (levels ∝ δ), worst | {wd:+.2f} | {wk:+.2f} | "
               f"{cwd:+.2f} | {cwk:+.2f} | {BOUND_FREE['delta']:g} / {BOUND_FREE['kn']:g} |")
    # ---- findings (numbers from the state) ------------------------------------------------------
    acc_dev = [100.0 * (q.f_hz / true_bc_frequency(fin, DELTA, q.channel, q.amplitude_m) - 1)
               for q in pts["acceleration"].used()]
    p08 = {q.channel: q for q in pts["acceleration"].points if q.run == "0.8 g"}
    f5, c5 = clear["fixed", CLEARANCES[-1]][2:]
    e5 = np.nan if isinstance(f5, Exception) else err(f5.delta, CLEARANCES[-1])
    low5 = min((q.f_hz for q in clear["fixed", CLEARANCES[-1]][1].used()), default=np.nan)
    out += [
        "",
        "## Findings",
        "",
        f"- **Systematic offset.** The noise-free acceleration points lie {min(acc_dev):+.2f} to "
        f"{max(acc_dev):+.2f} % (mean {np.mean(acc_dev):+.2f} %) in frequency from the true DFA "
        "backbone: the damped, swept peak sits below the undamped backbone (ζ = 3 %). The fit "
        f"absorbs it mostly in kn ({err(fits['acceleration'].kn, KN):+.2f} %). This bias, not "
        "the noise, is why the worst kn error with 0.2–0.3 g noise "
        f"({summary[0.2][3]:+.2f} / {summary[0.3][3]:+.2f} %) exceeds the paper's 0.5 % while "
        "meeting the issue's 2 %.",
        f"- **The corrected answer.** The replay of each test (docs/identify.md §3b) measures "
        "that bias and removes it: noise-free acceleration δ "
        f"{err(corr['acceleration']['delta'], DELTA):+.2f} %, kn "
        f"{err(corr['acceleration']['kn'], KN):+.2f} % (plain "
        f"{err(fits['acceleration'].delta, DELTA):+.2f} / "
        f"{err(fits['acceleration'].kn, KN):+.2f} %); "
        f"worst of the {len(SEEDS)} seeds at "
        + " / ".join(f"{s:g}" for s in NOISE_G) + " g: δ "
        + " / ".join(f"{csummary[s][1]:+.2f}" for s in NOISE_G) + " %, kn "
        + " / ".join(f"{csummary[s][3]:+.2f}" for s in NOISE_G) + " %; at δ = "
        f"{1e3 * CLEARANCES[-1]:g} mrad with fixed levels δ "
        + (f"{err(c5['delta'], CLEARANCES[-1]):+.2f} %, kn {err(c5['kn'], KN):+.2f} % "
           f"(`{c5['status']}`)." if c5 is not None else "refused."),
        f"- **Flat top at 0.8 g.** The 0.8 g curve has two maxima of equal height within 0.05 %: "
        f"the smooth top and a spike just before the jump. The tl channel picks "
        f"{p08['uz_top_left'].f_hz:.3f} Hz, the lr channel {p08['uz_lower_right'].f_hz:.3f} Hz "
        "(f*/f_BC − 1 of opposite sign, ±0.2 %). Either is a valid 'peak'; small noise flips the "
        "choice, which is the main source of the seed-to-seed scatter.",
        f"- **DFA vs harmonic balance.** The harmonic-balance backbone is closer to the exact "
        "backbone near contact, so the damping offset above is no longer partly cancelled by the "
        f"DFA's own low bias: δ {err(fit_hb.delta, DELTA):+.2f} %, kn {err(fit_hb.kn, KN):+.2f} % "
        f"(DFA: {err(fits['acceleration'].delta, DELTA):+.2f} %, "
        f"{err(fits['acceleration'].kn, KN):+.2f} %). Both meet the bounds.",
        f"- **Large gap, fixed levels.** At δ = {1e3 * CLEARANCES[-1]:g} mrad with 0.6–1.4 g "
        f"(level/δ equivalent to {0.6 * DELTA / CLEARANCES[-1]:.2f}–"
        f"{1.4 * DELTA / CLEARANCES[-1]:.2f} g at 3 mrad) the lowest level stays in the gap and "
        f"the lowest used point is at {low5:.2f} Hz, close to contact (Θ/δ ≈ 2), where the DFA "
        f"frequency error grows (−1.2 % at Θ = 2δ for the SDOF oscillator): δ error "
        f"{e5:+.2f} %. With levels scaled to δ (case a) the same gap "
        "meets the bound. Keep level/δ ≳ 0.2 g/mrad (peaks ≥ 40 Hz on this fin).",
        "- **Library issue met** (reported): the 0.4 g displacement run is rejected as 'too "
        "noisy' instead of 'no jump in band'.",
        "",
    ]
    # the held-out study of the corrected fit is written by benchmarks/replay_study.py --doc
    # after this marker; a regeneration of the tables keeps it
    marker = "<!-- replay study: benchmarks/replay_study.py -->"
    old = (DOCS / "results.md").read_text(encoding="utf-8") if (DOCS / "results.md").exists() \
        else ""
    kept = old[old.index(marker):] if marker in old else ""
    (DOCS / "results.md").write_text("\n".join(out) + ("\n" + kept if kept else ""),
                                     encoding="utf-8")
    print(f"wrote {DOCS / 'results.md'} in {runtime:.0f} s", file=sys.stderr)


if __name__ == "__main__":
    if "--report-only" in sys.argv:  # rewrite the report from the last run's checkpoint
        with open(CHECKPOINT, "rb") as fh:
            saved = pickle.load(fh)
        saved["rewritten"] = True
        par = default_fin_parameters()
        KN, DELTA = float(par["kn"]), float(par["delta"])
        report(default_fin(), saved)
    else:
        main()

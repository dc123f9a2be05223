"""Sweep-simulation throughput: scipy RK45 vs the torch engine vs the compiled numba kernel vs the
exponential engine (``expo``; small batches of a replay and large ones, same run).

    python benchmarks/simulate.py            # full table (a few minutes on 2 cores)
    python benchmarks/simulate.py --quick    # smoke run (short segments, noisier numbers)
    python benchmarks/simulate.py --only-small   # the replay's small batches and the beam only
    python benchmarks/simulate.py --device cuda  # the torch engine on the GPU, batch 1e3 - 1e5,
                                                 # beside numba on that machine's CPU

Model: ``freeplayid.model.default_fin()`` if this checkout has it, else the 12-DOF stand-in of
``tests/conftest.py`` (printed). Sweep: the paper's 30 -> 50 Hz at 0.1 Hz/s (200 s), kn = 2.35e6
N m/rad for the stand-in, the configured kn (480 N m/rad) and delta for the default fin, two
acceleration channels at 2048 Hz, automatic step. Every row times
a segment of the sweep and scales to the full 200 s (the cost per step does not depend on the
sweep frequency); the segment lengths are printed. The arithmetic limit is
flops per member-step x steps per sweep / the measured dense-matmul flop rate.

Two summaries close the table: a 5-run replay (5 members of a 200 s sweep, float64) by RK4 and
by the exponential engine, and a 200 s sweep x 5 levels of a Rayleigh-damped 15-DOF beam fin
whose top mode is above 40 kHz (``benchmarks/expo_models.py``; RK4's stability step there is
sub-microsecond, so its row is timed on a few milliseconds and scaled).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
import torch

from freeplayid.simulate import G, Sweep, build_modal_form, simulate_sweeps
from freeplayid.simulate.resample import design_decimator

KN, DELTA, FULL = 2.35e6, 3e-3, 200.0  # N m/rad, rad, s (stand-in model)
CH = ("uz_top_left", "uz_lower_right")


def load_model():
    global KN, DELTA
    try:
        from freeplayid.model import default_fin, default_fin_parameters

        hinge = default_fin_parameters()
        KN, DELTA = hinge["kn"], hinge["delta"]
        return default_fin(), f"default_fin() at kn = {KN:g} N·m/rad, delta = {DELTA:g} rad"
    except ImportError:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
        from conftest import standin_fin

        return standin_fin(), "12-DOF stand-in (tests/conftest.py; default_fin not in checkout)"


def segment(seconds: float) -> Sweep:
    return Sweep(40.0, 40.0 + 0.1 * seconds, 0.1)  # the paper's rate, around the resonance


def timed(system, sweep, level_g, *, kn, delta, channels=CH, **kw) -> tuple[float, object]:
    """(wall seconds, result) of ``simulate_sweeps`` over ``sweep``, after a 0.01 s warm-up with
    the same options (numba compile, allocator)."""
    rate = float(sweep.rate(0.0))
    warm = Sweep(sweep.start_hz, sweep.start_hz + 0.01 * rate, rate)
    simulate_sweeps(system, kn=kn, delta=delta, level_g=level_g[: min(len(level_g), 4)],
                    sweep=warm, channels=channels, progress=False, **kw)
    t0 = time.perf_counter()
    r = simulate_sweeps(system, kn=kn, delta=delta, level_g=level_g, sweep=sweep,
                        channels=channels, progress=False, **kw)
    return time.perf_counter() - t0, r


def time_sim(system, batch, seconds, **kw) -> tuple[float, object]:
    """Full sweeps per second from a ``seconds`` segment around the resonance."""
    sw = segment(seconds)
    el, r = timed(system, sw, np.linspace(0.3, 1.0, batch), kn=KN, delta=DELTA, **kw)
    return batch * sw.duration / (el * FULL), r


def time_whole(system, batch, quick, **kw) -> tuple[float, object, Sweep]:
    """Full sweeps per second of a whole sweep (the paper's 30 -> 50 Hz at 0.1 Hz/s; quick:
    38 -> 42 Hz)."""
    sw = Sweep(38.0, 42.0, 0.1) if quick else Sweep(30.0, 50.0, 0.1)
    el, r = timed(system, sw, np.linspace(0.3, 1.0, batch), kn=KN, delta=DELTA, **kw)
    return batch * sw.duration / (el * FULL), r, sw


def time_scipy(system, seconds) -> float:
    from scipy.integrate import solve_ivp

    from freeplayid.model import freeplay_force

    M, C, K, B, r = system.M, system.damping, system.K, system.hinge_matrix(), system.influence
    n = system.n_dof
    Mi = np.linalg.inv(M)
    MiK, MiC, MiB = Mi @ K, Mi @ C, Mi @ B
    sw = segment(seconds)

    def rhs(t, x):
        y, v = x[:n], x[n:]
        f = freeplay_force(B.T @ y, KN, DELTA)
        return np.concatenate([v, -MiK @ y - MiC @ v - MiB @ f - r * 0.6 * G * math.sin(
            sw.phase(t))])

    t_eval = np.arange(0, sw.duration, 1 / 2048)
    t0 = time.perf_counter()
    solve_ivp(rhs, (0, sw.duration), np.zeros(2 * n), method="RK45", rtol=1e-6, atol=1e-12,
              t_eval=t_eval)
    return sw.duration / ((time.perf_counter() - t0) * FULL)


def beam_rows(quick: bool) -> list[tuple[str, float, float]]:
    """(engine, step [us], seconds for a 200 s sweep x 5 levels) of the Rayleigh-damped beam
    fin (``benchmarks/expo_models.py``), float64, relative acceleration at 256 Hz; each engine
    timed on the whole 30 -> 50 Hz sweep (expo: its cost follows the hinge switches) or on a
    segment at 48 Hz and scaled (RK4: a constant cost per step)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from expo_models import beam_fin

    system, ch, kn, delta = beam_fin()
    out = []
    whole = Sweep(45.0, 47.0, 0.1) if quick else Sweep(30.0, 50.0, 0.1)
    rk4 = Sweep(48.0, 48.0 + 0.1 * (0.002 if quick else 0.01), 0.1)
    for engine, sw in (("expo", whole), ("numba", rk4)):
        el, r = timed(system, sw, [0.4, 0.6, 0.8, 1.0, 1.2], kn=kn, delta=delta,
                      channels=list(ch), quantity="acceleration", frame="relative",
                      sample_rate=256.0, dtype=torch.float64, engine=engine)
        name = "exponential engine" if engine == "expo" else "RK4 (numba)"
        out.append((f"{name}, timed on {sw.start_hz:g}->{sw.stop_hz:g} Hz ({sw.duration:g} s)",
                    r.dt * 1e6, el * FULL / sw.duration))
    return out


def cuda_table(system, quick: bool) -> None:
    """``--device cuda``: full sweeps per second of the torch engine on the GPU at batch 1e3, 1e4
    and 1e5 (CUDA graphs; float32 and float64), with CUDA eager at 1e4 and the numba kernel on
    this machine's CPU (batch 1024) timed in the same run for comparison."""
    name = torch.cuda.get_device_name()
    print(f"GPU: {name}, torch {torch.__version__}, CUDA {torch.version.cuda}")
    seg = 0.02 if quick else 0.2
    rows = [("scipy solve_ivp RK45 (rtol 1e-6), 1 sweep", "float64", 1, seg / 4,
             time_scipy(system, seg / 4), None)]
    for dt in (torch.float32, torch.float64):
        for b in (1_000, 10_000, 100_000):
            rate, r = time_sim(system, b, seg, engine="torch", dtype=dt, device="cuda")
            rows.append((f"torch CUDA graphs, batch {b}", str(dt)[6:], b, seg, rate, r))
    rate, r = time_sim(system, 10_000, seg, engine="torch", dtype=torch.float32, device="cuda",
                       cuda_graphs=False)
    rows.append(("torch CUDA eager (no graphs), batch 10000", "float32", 10_000, seg, rate, r))
    try:  # the CPU reference: a failure here (numba missing or broken) keeps the GPU rows
        for dt in (torch.float32, torch.float64):
            rate, r = time_sim(system, 1024, seg, engine="numba", dtype=dt, device="cpu")
            rows.append((f"numba kernel on the CPU ({os.cpu_count()} cores), batch 1024",
                         str(dt)[6:], 1024, seg, rate, r))
    except Exception as e:  # noqa: BLE001
        print(f"no numba CPU reference row: {type(e).__name__}: {e}")
    scipy_rate = rows[0][4]
    head = (f"{'engine':<52} {'dtype':<8} {'dt [us]':>8} {'seg [s]':>7} {'sweeps/s':>10} "
            f"{'x scipy':>9} {'us/step':>8}")
    print(f"\nsweep: the paper's 200 s (30 -> 50 Hz at 0.1 Hz/s), each row timed on a segment "
          f"at 40 Hz and scaled\n{head}\n{'-' * len(head)}")
    for label, dt, b, sg, rate, r in rows:
        step = "" if r is None else f"{1e6 * b * r.dt / (rate * FULL):.1f}"  # wall per step
        print(f"{label:<52} {dt:<8} {'adaptive' if r is None else f'{r.dt * 1e6:.2f}':>8} "
              f"{sg:>7.3g} {rate:>10.4g} {rate / scipy_rate:>9.3g} {step:>8}")


def flops_per_step(form, n_channels, m) -> float:
    N, h = form.D.shape
    stage = 2 * N * h + 4 * h + 2 * N + (2 * N if form.c_diagonal else 2 * N * N) + 2 * N * h
    stage += 2 * N + 8 * N  # forcing, stage combinations
    taps = len(design_decimator(m))
    return 4 * stage + 4 * N + 2 * n_channels * N + 2 * n_channels * taps / m


def matmul_rate(dtype) -> float:
    a = torch.randn(1024, 1024, dtype=dtype)
    a @ a
    t0 = time.perf_counter()
    k = 0
    while time.perf_counter() - t0 < 0.5:
        a @ a
        k += 1
    return 2 * 1024**3 * k / (time.perf_counter() - t0)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="short segments: a smoke run")
    p.add_argument("--cutoff-hz", type=float, default=600.0,
                   help="modal truncation row (numba, float32) [Hz]")
    p.add_argument("--quasi-static-hz", type=float, nargs="*", default=[1500.0, 1000.0],
                   help="quasi-static condensation rows (numba, batch 1024) [Hz]")
    p.add_argument("--only-numba", action="store_true",
                   help="numba rows only (full model and its quasi-static/truncation variants)")
    p.add_argument("--only-small", action="store_true",
                   help="only the small-batch (replay) rows and the beam model")
    p.add_argument("--device", choices=("cpu", "cuda"), default="cpu",
                   help="cuda: the GPU table (torch engine, batch 1e3 - 1e5) instead")
    args = p.parse_args()
    if args.device == "cuda" and not torch.cuda.is_available():
        p.error("--device cuda: torch sees no CUDA device on this machine")
    q = args.quick
    torch.set_num_threads(os.cpu_count() or 1)
    system, what = load_model()
    form = build_modal_form(system, channels=CH, quantity="acceleration", frame="absolute",
                            kn_max=KN)
    print(f"model: {what}; top closed-hinge |eig| {form.omega_max / 2 / np.pi:.0f} Hz; "
          f"damping {'diagonal' if form.c_diagonal else 'dense'} in the modal basis")
    print(f"threads: torch {torch.get_num_threads()}, cpu_count {os.cpu_count()}; "
          f"{'QUICK run: short segments' if q else 'full run'}")
    if args.device == "cuda":
        cuda_table(system, q)
        return
    rows = []
    seg = 0.05 if q else 0.5
    rows.append(("scipy solve_ivp RK45 (rtol 1e-6), 1 sweep", "float64", 1, seg,
                 time_scipy(system, seg), None))
    big = not args.only_small
    for dt in (() if args.only_numba or not big else (torch.float32, torch.float64)):
        for b in (1, 256, 1024):
            seg = (0.005 if q else 0.05) * (4 if b == 1 else 1)
            rate, r = time_sim(system, b, seg, engine="torch", dtype=dt)
            rows.append((f"torch eager, batch {b}", str(dt)[6:], b, seg, rate, r))
    if torch.cuda.is_available() and big:
        for dt in (torch.float32, torch.float64):
            for b in (1024, 16384):
                seg = 0.05 if q else 1.0
                rate, r = time_sim(system, b, seg, engine="torch", dtype=dt, device="cuda")
                rows.append((f"torch CUDA graphs, batch {b} ({torch.cuda.get_device_name()})",
                             str(dt)[6:], b, seg, rate, r))
    try:
        import numba  # noqa: F401

        for dt in ((torch.float32, torch.float64) if big else ()):
            for b in ((1024,) if args.only_numba else (256, 1024, 4096)):
                seg = max((0.1 if q else 2.0) * 1024 / b, 0.05)
                rate, r = time_sim(system, b, seg, engine="numba", dtype=dt)
                rows.append((f"numba kernel, batch {b}", str(dt)[6:], b, seg, rate, r))
                # quasi-static condensation, same run (A/B under the same load)
                for fq in args.quasi_static_hz:
                    rate, r = time_sim(system, b, seg, engine="numba", dtype=dt,
                                       quasi_static_hz=fq)
                    qs = r.quasi_static
                    rows.append((f"numba kernel, batch {b}, quasi-static above {fq:g} Hz "
                                 f"({qs.slow}/{qs.total} integrated)", str(dt)[6:], b, seg,
                                 rate, r))
        # small batches (one identification's replay: 5 runs) and the exponential engine
        # (step set by accuracy, exact between hinge switches; docs/simulate.md), same run. Its
        # cost per step grows with the hinge switches (a step holding one is halved until the
        # switch is located), so it is timed on whole sweeps, not on a segment at resonance
        for dt in (torch.float32, torch.float64):
            for b in (5, 64) if big else (5,):
                seg = max((0.1 if q else 2.0) * 64 / b, 0.05)
                rate, r = time_sim(system, b, seg, engine="numba", dtype=dt)
                rows.append((f"numba kernel, batch {b}", str(dt)[6:], b, seg, rate, r))
            for b in (5, 16) if big else (5,):
                rate, r, sw = time_whole(system, b, q, engine="expo", dtype=dt)
                rows.append((f"expo (exponential, per contact state), batch {b}, whole "
                             f"{sw.start_hz:g}->{sw.stop_hz:g} Hz sweep", str(dt)[6:], b,
                             sw.duration, rate, r))
        b = 1024
        if big:
            rate, r = time_sim(system, b, 0.1 if q else 2.0, engine="numba", dtype=torch.float32,
                               cutoff_hz=args.cutoff_hz)
            tr = r.truncation
            rows.append((f"numba kernel, batch {b}, modes <= {args.cutoff_hz:g} Hz "
                         f"({tr.kept}/{tr.total}, static err {tr.static_error:.1e})", "float32",
                         b, 0.1 if q else 2.0, rate, r))
        beam = beam_rows(q)
    except ImportError:
        beam = []
        print("numba not installed: no compiled-kernel rows")
    scipy_rate = rows[0][4]
    mm = {"float32": matmul_rate(torch.float32), "float64": matmul_rate(torch.float64)}
    print(f"\nmatmul 1024^3: float32 {mm['float32'] / 1e9:.1f} GFLOP/s, "
          f"float64 {mm['float64'] / 1e9:.1f} GFLOP/s\n")
    head = f"{'engine':<72} {'dtype':<8} {'dt [us]':>8} {'seg [s]':>7} {'sweeps/s':>10} " \
           f"{'x scipy':>9} {'% limit':>8}"
    print(head)
    print("-" * len(head))
    for name, dt, _b, seg, rate, r in rows:
        if r is None or r.quasi_static is not None or r.engine == "expo":
            print(f"{name:<72} {dt:<8} "
                  f"{'adaptive' if r is None else f'{r.dt * 1e6:.2f}':>8} {seg:>7.3g} "
                  f"{rate:>10.4g} {rate / scipy_rate:>9.3g} {'':>8}")
            continue
        f = build_modal_form(system, channels=CH, quantity="acceleration", frame="absolute",
                             kn_max=KN, cutoff_hz=r.truncation.cutoff_hz if r.truncation else None)
        steps = FULL / r.dt
        limit = mm[dt] / (flops_per_step(f, len(CH), r.steps_per_sample) * steps)
        print(f"{name:<72} {dt:<8} {r.dt * 1e6:>8.2f} {seg:>7.3g} {rate:>10.4g} "
              f"{rate / scipy_rate:>9.3g} {100 * rate / limit:>7.1f}%")
    small = {(r[5].engine, r[1]): r for r in rows[1:] if r[2] == 5 and r[5] is not None}
    if small:
        print("\n5-run replay (5 members, one 200 s sweep each; the replay's batch; RK4 "
              "scaled from its segment, expo timed on the whole sweep):")
        for (eng, dt), row in sorted(small.items()):
            print(f"  {eng:<6} {dt:<8} step {row[5].dt * 1e6:6.1f} us: {5 / row[4]:8.1f} s")
    for label, dt_us, seconds in beam:
        print(f"beam fin (Rayleigh, top mode > 40 kHz), 200 s sweep x 5 levels, {label}: "
              f"step {dt_us:.3g} us, {seconds:.3g} s ({seconds / 3600:.3g} h)")
    if args.only_small:
        return
    best = max((row for row in rows[1:] if "CUDA" not in row[0]),
               key=lambda row: row[4] if row[5].truncation is None
               and row[5].quasi_static is None and row[5].engine != "expo" else 0)
    f = build_modal_form(system, channels=CH, quantity="acceleration", frame="absolute",
                         kn_max=KN)
    limit = mm[best[1]] / (flops_per_step(f, len(CH), best[5].steps_per_sample) * FULL
                           / best[5].dt)
    print(f"\nbest full-model CPU engine: {best[0]} {best[1]}: {best[4]:.3g} sweeps/s = "
          f"{best[4] / scipy_rate:.0f}x scipy RK45, {best[4] / limit:.2f} of the arithmetic limit "
          f"({limit:.3g} sweeps/s at {flops_per_step(f, len(CH), best[5].steps_per_sample):.0f} "
          f"flop/step x {FULL / best[5].dt:.3g} steps)")
    # the targets, for the full model and for the (opt-in, approximate) quasi-static
    # condensation; its accuracy per threshold is in docs/simulate.md
    print("\ntargets (CPU, 2 cores, default fin): float32 >= 40 sweeps/s and >= 800x scipy RK45, "
          "float64 >= 15 sweeps/s")
    kinds = (("full model", lambda r: r.quasi_static is None and r.truncation is None),
             ("quasi-static option", lambda r: r.quasi_static is not None))
    for dt, target in (("float32", 40.0), ("float64", 15.0)):
        for label, keep in kinds:
            cand = [row for row in rows[1:] if row[1] == dt and "CUDA" not in row[0]
                    and row[5] is not None and keep(row[5])]
            if cand:
                top = max(cand, key=lambda row: row[4])
                verdict = "met" if top[4] >= target else "NOT met"
                print(f"  {dt:<8} {label:<20} best {top[4]:7.3g} sweeps/s "
                      f"({top[4] / scipy_rate:.0f}x scipy): {verdict}  [{top[0]}]")


if __name__ == "__main__":
    main()

"""Step convergence of the exponential engine against RK4 at a small step (float64).

    python benchmarks/expo_convergence.py                  # default fin, both rates and rates
    python benchmarks/expo_convergence.py --model beam     # the Rayleigh-damped 15-DOF beam fin
    python benchmarks/expo_convergence.py --quick          # 0.5 Hz/s at 256 Hz only

For each sweep rate (0.1, 0.5 Hz/s, 30 -> 46.5 Hz) and output rate (256, 2048 Hz), levels
0.4-1.2 g, relative acceleration of two channels: the reference is the RK4 kernel at
``omega_dt=0.5`` (RK4 is 4th order: ~1e-5 of its default step's error), then the exponential
engine at steps of 1/(fs m). Printed per step: the largest relative difference over the runs
and channels of (i) the raw record peak max|y| and its sweep frequency, (ii) the first-harmonic
jump points of ``extract_backbone_points`` (amplitude, frequency). The step the engine picks by
itself (``exponential.expo_step_limit``) is marked.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch

from freeplayid.signal import extract_backbone_points
from freeplayid.simulate import Sweep, simulate_sweeps

sys.path.insert(0, str(Path(__file__).resolve().parent))
from expo_models import beam_fin  # noqa: E402

LEVELS = [0.4, 0.6, 0.8, 1.0, 1.2]


def model(name):
    if name == "beam":
        return beam_fin()
    from freeplayid.model import default_fin

    return default_fin(), ("uz_top_left", "uz_lower_right"), 480.0, 3e-3


def metrics(res):
    """(raw peak amplitude, raw peak frequency, H1 amplitude, H1 frequency), each (runs, ch)."""
    y = res.signals.astype(float)
    fs = res.sample_rate
    i0 = int(fs)  # skip the first second (start transient)
    k = np.argmax(np.abs(y[..., i0:]), axis=-1) + i0
    amp = np.take_along_axis(np.abs(y), k[..., None], -1)[..., 0]
    f = res.sweep.frequency(k / fs)
    pts = extract_backbone_points(y, fs, quantity=res.quantity, sweep=res.sweep)
    ha = np.full(amp.shape, np.nan)
    hf = np.full(amp.shape, np.nan)
    for p in pts.points:
        if p.used:
            r, c = int(p.run[3:]), int(p.channel[2:])
            ha[r, c], hf[r, c] = p.amplitude_m, p.f_hz
    return np.stack([amp, f, ha, hf])


def rel(a, b):
    return np.nanmax(np.abs(a / b - 1), axis=(1, 2))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--model", default="fin", choices=("fin", "beam"))
    p.add_argument("--quick", action="store_true")
    p.add_argument("--rates", type=float, nargs="*", default=None)
    p.add_argument("--fs", type=float, nargs="*", default=None)
    p.add_argument("--ref-omega-dt", type=float, default=0.5)
    p.add_argument("--ref", default="rk4", choices=("rk4", "expo"),
                   help="reference: RK4 at --ref-omega-dt, or expo at 16x the rule's steps "
                        "(the beam: its RK4 step is ~0.1 us)")
    p.add_argument("--m", type=int, nargs="*", default=None, help="steps per sample to try")
    p.add_argument("--cache", default="/tmp/expo_ref")
    p.add_argument("--timing", action="store_true",
                   help="only time a 5-member batch of the fin's 165 s sweep (30 -> 46.5 Hz at "
                        "0.1 Hz/s, 256 Hz, levels 0.6-1.4 g): expo at its rule's step vs RK4 "
                        "(engine='numba', default step), in the same run")
    args = p.parse_args()
    system, ch, kn, delta = model(args.model)
    if args.timing:
        kw = dict(kn=kn, delta=delta, level_g=[0.6, 0.8, 1.0, 1.2, 1.4],
                  sweep=Sweep(30.0, 46.5, 0.1), channels=ch, quantity="acceleration",
                  frame="relative", sample_rate=256.0, dtype=torch.float64, progress=False)
        for eng in ("expo", "numba", "expo"):  # expo twice: the first may compile
            t0 = time.perf_counter()
            r = simulate_sweeps(system, engine=eng, **kw)
            print(f"{eng:6s} dt {r.dt * 1e6:6.2f} us: {time.perf_counter() - t0:6.1f} s",
                  flush=True)
        return
    rates = args.rates or ([0.5] if args.quick else [0.5, 0.1])
    rates_fs = args.fs or ([256.0] if args.quick else [256.0, 2048.0])
    Path(args.cache).mkdir(parents=True, exist_ok=True)
    what = (f"RK4 omega_dt={args.ref_omega_dt}" if args.ref == "rk4"
            else "expo at 16x the rule's steps")
    print(f"model {args.model}: kn {kn:g}, delta {delta:g}, channels {ch}; reference {what}, "
          f"float64; relative acceleration")
    print(f"{'rate':>5} {'fs':>5} {'m':>4} {'dt [us]':>8} {'raw amp':>9} {'raw f':>9} "
          f"{'H1 amp':>9} {'H1 f':>9} {'s':>6}")
    for rate in rates:
        sw = Sweep(30.0, 46.5, rate)
        for fs in rates_fs:
            kw = dict(kn=kn, delta=delta, level_g=LEVELS, sweep=sw, channels=ch,
                      quantity="acceleration", frame="relative", sample_rate=fs,
                      dtype=torch.float64, progress=False)
            auto = simulate_sweeps(system, engine="expo", **{**kw, "sweep": Sweep(30.0, 46.5, 1e3)})
            m_auto = auto.steps_per_sample
            tag = args.ref_omega_dt if args.ref == "rk4" else "expo16"
            cf = Path(args.cache) / f"{args.model}_{rate}_{fs}_{tag}.npy"
            if cf.exists():
                ref = np.load(cf)
            else:
                t0 = time.perf_counter()
                if args.ref == "rk4":
                    r = simulate_sweeps(system, engine="numba", omega_dt=args.ref_omega_dt, **kw)
                else:
                    r = simulate_sweeps(system, engine="expo", steps_per_sample=16 * m_auto, **kw)
                ref = metrics(r)
                np.save(cf, ref)
                print(f"  reference: dt {r.dt * 1e6:.2f} us, {time.perf_counter() - t0:.0f} s",
                      flush=True)
            ms = args.m or sorted({max(1, m_auto // 4), max(1, m_auto // 2), m_auto, 2 * m_auto,
                         4 * m_auto})
            for m in ms:
                t0 = time.perf_counter()
                r = simulate_sweeps(system, engine="expo", steps_per_sample=m, **kw)
                el = time.perf_counter() - t0
                e = rel(metrics(r), ref)
                mark = " <- rule" if m == m_auto else ""
                print(f"{rate:5.2g} {fs:5.0f} {m:4d} {r.dt * 1e6:8.2f} {e[0]:9.2e} {e[1]:9.2e} "
                      f"{e[2]:9.2e} {e[3]:9.2e} {el:6.1f}{mark}", flush=True)


if __name__ == "__main__":
    main()

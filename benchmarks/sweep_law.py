"""Accuracy of :func:`freeplayid.signal.estimate_sweep` on simulated sweep tests.

    python benchmarks/sweep_law.py             # SDOF freeplay oscillator, the whole grid
    python benchmarks/sweep_law.py --fin       # + the default fin (two slow sweeps skipped)

Each case simulates one run (``simulate_sweeps``, SDOF f_n = 50 Hz in contact, zeta = 4 %,
delta = 1.2e-4 m at 0.8 g: it jumps in the band) over 30 <-> 50 Hz, adds white noise of std
``p`` x the record's RMS (1 % and 5 %) to every recorded channel, and estimates the law from:

- ``base``: the base channel (absolute accelerations);
- ``response abs``: the response channel(s) of the absolute frame (no base channel);
- ``response rel``: the response channel(s) relative to the base.

Laws: linear 0.1, 0.5, 2 Hz/s and log 1, 2 octaves/min, up and down. The table gives the errors
of start and stop [Hz] and of the rate [%] against the simulated law, and whether the law
(linear / log) was recognised. Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

LAWS = [("linear", 0.1), ("linear", 0.5), ("linear", 2.0), ("log", 1.0), ("log", 2.0)]
NOISE = (0.01, 0.05)
FS = 512.0  # [Hz]
LEVEL = 0.8  # [g]


def _cases(system, kn, delta, channels, *, skip_slow: bool):
    import torch

    from freeplayid.signal import estimate_sweep
    from freeplayid.simulate import Sweep, simulate_sweeps

    rng = np.random.default_rng(0)
    rows = []
    for law, r in LAWS:
        if skip_slow and law == "linear" and r < 0.5:
            continue
        for f0, f1 in ((30.0, 50.0), (50.0, 30.0)):
            sw = Sweep(f0, f1, rate_hz_per_s=r) if law == "linear" else \
                Sweep(f0, f1, octaves_per_min=r)
            recs = {}
            for frame in ("absolute", "relative"):
                res = simulate_sweeps(system, kn=kn, delta=delta, level_g=[LEVEL], sweep=sw,
                                      channels=channels, quantity="acceleration", frame=frame,
                                      sample_rate=FS, dtype=torch.float64, progress=False)
                recs[frame] = res.signals[0]
                if frame == "absolute":
                    recs["base"] = sw.acceleration(res.time, LEVEL)[None, :]
            for p in NOISE:
                for source, key in (("base", "base"), ("response abs", "absolute"),
                                    ("response rel", "relative")):
                    x = recs[key]
                    x = x + p * np.sqrt(np.mean(x**2, axis=1, keepdims=True)) * \
                        rng.normal(size=x.shape)
                    est = estimate_sweep(x, FS).sweep
                    rate_err = (est.rate_hz_per_s / r - 1 if est.law == law == "linear" else
                                est.octaves_per_min / r - 1 if est.law == law == "log" else
                                np.nan)
                    rows.append({"law": sw.describe(), "noise": p, "source": source,
                                 "start": est.start_hz - f0, "stop": est.stop_hz - f1,
                                 "rate": rate_err, "law_ok": est.law == law})
    return rows


def _table(title, rows):
    print(f"\n### {title}\n")
    print("| sweep | noise | source | start err [Hz] | stop err [Hz] | rate err [%] | law |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['law']} | {100 * r['noise']:.0f} % | {r['source']} | {r['start']:+.4f} | "
              f"{r['stop']:+.4f} | {100 * r['rate']:+.3f} | {'ok' if r['law_ok'] else 'WRONG'} |")
    for source in ("base", "response abs", "response rel"):
        sel = [r for r in rows if r["source"] == source]
        print(f"\n{source}: max |start err| {max(abs(r['start']) for r in sel):.3g} Hz, "
              f"max |stop err| {max(abs(r['stop']) for r in sel):.3g} Hz, max |rate err| "
              f"{100 * np.nanmax([abs(r['rate']) for r in sel]):.3g} %, law recognised "
              f"{sum(r['law_ok'] for r in sel)}/{len(sel)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fin", action="store_true", help="also the default fin")
    args = ap.parse_args()
    from freeplayid.model import sdof_system

    t0 = time.perf_counter()
    _table("SDOF (f_n = 50 Hz, zeta = 4 %, 0.8 g)",
           _cases(sdof_system(mass=23.8, damping=598.0), 2.35e6, 1.2e-4, ["x"],
                  skip_slow=False))
    if args.fin:
        from freeplayid.model import default_fin, default_fin_parameters

        fin = default_fin()
        par = default_fin_parameters()
        chans = [d for d in fin.dof_names if d.startswith("uz_")][:2]
        _table("default fin (kn, delta of the model, 0.8 g, two uz channels)",
               _cases(fin, par["kn"], par["delta"], chans, skip_slow=True))
    print(f"\n({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()

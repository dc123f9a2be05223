"""Cold-compile CPU time of the numba kernels: what a fresh environment pays once.

    python benchmarks/compile.py                 # the kernels the default commands compile
    python benchmarks/compile.py --all           # every kernel and dtype
    python benchmarks/compile.py --commands      # + the default commands' simulations, end to end
    python benchmarks/compile.py --baseline REV  # before/after: REV's src/ (git archive), same run

Every row runs in a subprocess with an empty ``NUMBA_CACHE_DIR`` (a cold compile) and reports the
CPU time (``time.process_time`` of the subprocess: every thread, not the wall clock, so a loaded
machine does not inflate it) of the kernel's first call on the default fin (batch 64, a 0.01 s
segment: the run itself is a few ms), then the same in a second subprocess that loads the cache
it left. With ``--baseline REV`` every row is measured for REV's ``src/`` too, alternating with
this checkout's. The ``--commands`` rows time ``simulate_sweeps`` with the arguments of
``scripts/simulate.py`` (default, ``quasi_static_hz=1000``) and of the bank of ``scripts/train.py
debug=fast`` on a short segment, cold and from the cache, and list what was compiled.

Which kernels the commands compile (``scripts/identify.py`` simulates nothing):

- ``scripts/simulate.py`` (float32, acceleration, absolute): the full-model kernel and the
  base-term pass (``assemble._add``), float32;
- ``scripts/simulate.py quasi_static_hz=1000``: the quasi-static kernel and ``assemble._add``;
- ``scripts/train.py`` and ``debug=fast`` (bank: float32, acceleration, relative, fast modes
  condensed, ``dataset.bank.quasi_static_hz: 1000``): the quasi-static kernel, float32 (the
  relative frame has no base terms: no ``assemble._add``);
- ``scripts/compare.py`` (its bank: the full model, ``dataset/exact.yaml``): the full-model
  kernel, float32;
- ``simulate_sweeps(engine="expo")`` (float64): the exponential kernel (``engines/expo/kernel.py``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = textwrap.dedent("""
    import json, sys, time
    import numpy as np
    case = json.loads(sys.argv[1])
    from freeplayid.model import default_fin
    t0 = time.process_time()
    if case["what"] == "command":
        import torch
        from freeplayid.simulate import Sweep, simulate_sweeps
        kw = dict(case["kw"])
        kw["dtype"] = getattr(torch, kw["dtype"])
        system = default_fin()
        t0 = time.process_time()
        simulate_sweeps(system, kn=480.0, delta=3e-3, level_g=[0.6, 1.0],
                        sweep=Sweep(40.0, 40.1, 10.0), progress=False, engine="numba", **kw)
    elif case["what"] == "assemble":
        from freeplayid.simulate.assemble import add_base_terms
        y = np.zeros((2, 2, 100), dtype=case["dtype"])
        t0 = time.process_time()
        add_base_terms(y, base_coef=[1.0, 2.0], static_coef=[0.5, 0.1],
                       base=np.ones((2, 100)), level_g=[1.0, 2.0])
    else:
        from freeplayid.simulate import build_modal_form
        from freeplayid.simulate.quasistatic import condense_modal_form
        from freeplayid.simulate.resample import derivative_taps, design_decimator
        from freeplayid.simulate.engines import MODES
        try:
            from freeplayid.simulate.engines.expo.kernel import NumbaExpo
            from freeplayid.simulate.engines.numba.rk4 import NumbaRK4
            from freeplayid.simulate.engines.numba.rk4_qs import NumbaQSRK4
        except ImportError:  # a --baseline revision before the engines' folders
            from freeplayid.simulate.kernel import NumbaRK4
            from freeplayid.simulate.kernel_expo import NumbaExpo
            from freeplayid.simulate.kernel_qs import NumbaQSRK4
        q = case["quantity"]
        form = build_modal_form(default_fin(), channels=("uz_top_left", "uz_lower_right"),
                                quantity=q, frame="absolute", kn_max=480.0)
        m, h, B = 4, 1e-4, 64
        z = np.zeros((B, form.n_modes))
        kw = dict(h=h, quantity=q, dtype=getattr(np, case["dtype"]), taps=design_decimator(m),
                  factor=m)
        if case["what"] == "expo":
            eng = NumbaExpo(form, np.full(B, 480.0), np.full(B, 3e-3), np.ones(B), z, z, **kw)
        elif case["what"] == "qs":
            qf = condense_modal_form(form, threshold_hz=1000.0, quantity=q, kn_max=480.0)
            z = np.zeros((B, qf.slow.n_modes))
            if q != "displacement":
                kw["taps"], kw["taps_d"] = derivative_taps(kw["taps"], m, h, MODES[q])
            eng = NumbaQSRK4(qf, np.full(B, 480.0), np.full(B, 3e-3), np.ones(B), z, z, **kw)
        else:
            eng = NumbaRK4(form, np.full(B, 480.0), np.full(B, 3e-3), np.ones(B), z, z, **kw)
        s = np.sin(np.linspace(0.0, 1.0, 201))
        t0 = time.process_time()
        if case["what"] == "expo":  # decimates into a given signal array
            eng.run(s, np.empty((B, 2, eng.emitted(100)), dtype=case["dtype"]))
        else:
            eng.run(s)
    cpu = time.process_time() - t0
    from numba.core.registry import CPUDispatcher
    import gc
    sigs = {}
    for o in gc.get_objects():
        if isinstance(o, CPUDispatcher) and o.signatures and o.__module__.startswith("freeplayid"):
            sigs[o.__module__.split(".")[-1] + "." + o.__name__] = len(o.signatures)
    print(json.dumps({"cpu": cpu, "sigs": sigs}))
""")


def run_case(case: dict, cache: str, src: Path) -> dict:
    path = os.pathsep.join([str(src), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "NUMBA_CACHE_DIR": cache, "PYTHONPATH": path}
    p = subprocess.run([sys.executable, "-c", CHILD, json.dumps(case)], env=env, cwd=ROOT,
                       capture_output=True, text=True)
    if p.returncode:
        raise RuntimeError(p.stderr)
    return json.loads(p.stdout.strip().splitlines()[-1])


def measure(case: dict, src: Path) -> tuple[float, float, dict]:
    """(cold CPU s, cached CPU s, compiled signatures) of one case, the package from ``src``."""
    with tempfile.TemporaryDirectory() as cache:
        cold = run_case(case, cache, src)
        warm = run_case(case, cache, src)
    return cold["cpu"], warm["cpu"], cold["sigs"]


def export_src(rev: str, dest: str) -> Path:
    """``src/`` of git revision ``rev`` of this checkout, extracted under ``dest``."""
    tar = subprocess.run(["git", "archive", rev, "src"], cwd=ROOT, capture_output=True,
                         check=True).stdout
    subprocess.run(["tar", "-x", "-C", dest], input=tar, check=True)
    return Path(dest) / "src"


KERNELS = {  # name -> case
    "full model, float32": dict(what="full", dtype="float32", quantity="acceleration"),
    "quasi-static, float32": dict(what="qs", dtype="float32", quantity="acceleration"),
    "base terms (assemble), float32": dict(what="assemble", dtype="float32"),
    "full model, float64": dict(what="full", dtype="float64", quantity="acceleration"),
    "quasi-static, float64": dict(what="qs", dtype="float64", quantity="acceleration"),
    "base terms (assemble), float64": dict(what="assemble", dtype="float64"),
    "exponential (expo), float64": dict(what="expo", dtype="float64", quantity="acceleration"),
    "exponential (expo), float32": dict(what="expo", dtype="float32", quantity="acceleration"),
}
# the defaults: what the default commands compile, and the float64 exponential kernel (the
# engine of the replay's small batches when chosen, engine="expo")
DEFAULT = list(KERNELS)[:3] + ["exponential (expo), float64"]
# what the default commands compile with their default options: scripts/simulate.py (full model
# + base terms, float32), the bank of scripts/train.py (quasi-static, float32), that of
# scripts/compare.py (full model, float32) and the replay of scripts/identify.py (expo, float64)
DEFAULT_COMMANDS = ["full model, float32", "quasi-static, float32",
                    "base terms (assemble), float32", "exponential (expo), float64"]
CH = ["uz_top_left", "uz_lower_right"]
COMMANDS = {
    "scripts/simulate.py": dict(what="command", kw=dict(
        dtype="float32", quantity="acceleration", frame="absolute", channels=CH,
        sample_rate=512.0)),
    "scripts/simulate.py quasi_static_hz=1000": dict(what="command", kw=dict(
        dtype="float32", quantity="acceleration", frame="absolute", channels=CH,
        sample_rate=512.0, quasi_static_hz=1000.0)),
    "scripts/train.py debug=fast (bank)": dict(what="command", kw=dict(
        dtype="float32", quantity="acceleration", frame="relative", channels=CH,
        sample_rate=256.0, quasi_static_hz=1000.0)),
    "scripts/compare.py debug=fast (bank)": dict(what="command", kw=dict(
        dtype="float32", quantity="acceleration", frame="relative", channels=CH,
        sample_rate=256.0)),
}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--all", action="store_true", help="float64 and every kernel too")
    p.add_argument("--commands", action="store_true", help="also the commands, end to end")
    p.add_argument("--only", nargs="*", default=None, help="row names (substrings) to run")
    p.add_argument("--baseline", default=None, metavar="REV",
                   help="also measure git revision REV's src/ (before/after, alternating)")
    args = p.parse_args()
    cases = {k: KERNELS[k] for k in (KERNELS if args.all else DEFAULT)}
    if args.commands:
        cases.update(COMMANDS)
    if args.only is not None:
        cases = {k: v for k, v in cases.items() if any(s in k for s in args.only)}
    with tempfile.TemporaryDirectory() as tmp:
        srcs = {"": ROOT / "src"}
        if args.baseline:
            srcs = {args.baseline: export_src(args.baseline, tmp), "this checkout": ROOT / "src"}
        print(f"python {sys.version.split()[0]}, numba {__import__('numba').__version__}, "
              f"{os.cpu_count()} CPUs ({cpu_name()}); CPU seconds of the first call in a fresh "
              f"process, empty cache (cold) and the cache it left (cached)")
        w = max(len(k) for k in srcs)
        print(f"{'kernel / command':40s} {'':{w}s} {'cold [s]':>9s} {'cached [s]':>10s}  "
              f"compiled (signatures)")
        total = dict.fromkeys(srcs, 0.0)
        default = dict.fromkeys(srcs, 0.0)
        for name, case in cases.items():
            for rev, src in srcs.items():
                cold, warm, sigs = measure(case, src)
                if case["what"] != "command":
                    total[rev] += cold - warm
                if name in DEFAULT_COMMANDS:
                    default[rev] += cold - warm
                what = ", ".join(f"{k} x{v}" for k, v in sorted(sigs.items()))
                print(f"{name:40s} {rev:{w}s} {cold:9.1f} {warm:10.2f}  {what}", flush=True)
        for rev in srcs:
            print(f"{'total of the kernel rows (cold - cached)':40s} {rev:{w}s} "
                  f"{total[rev]:9.1f}")
        if all(k in cases for k in DEFAULT_COMMANDS):
            for rev in srcs:
                print(f"{'default commands':40s} {rev:{w}s} "
                      f"{default[rev]:9.1f}")


def cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown CPU"

if __name__ == "__main__":
    main()

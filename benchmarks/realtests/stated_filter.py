"""A realtests draw identified with its acquisition stated in several ways; prints a table.

    python benchmarks/realtests/stated_filter.py --data outputs/realtests/variants \\
        --cases var6_finC_nominal --draws d_none,d0,d1 --jobs 2

exact_sim.py decimates its records through its own zero-phase Kaiser filter, flat only to
0.3 of the sample rate; fin C's points lie at 0.31-0.34 of it. Each draw is copied to
``--work`` with its manifest stating the filter as:

- ``unknown``: nothing stated (the package's default: replays flat, the move were the filter the
  simulator's own measured and checked);
- ``replay``: "as the simulator's own" (a similar Kaiser design, 0.15 % apart at 86 Hz of 256);
- ``response``: exact_sim's response, ``{response: filter.csv}``, computed here with scipy's
  ``freqz`` of exact_sim's taps times its 5-point derivative's response (nothing of the
  package), which ``identify`` divides out of the records.
- ``base_delay``: the filter not stated, the base channel's delay against the responses stated
  (``base_delay_s``, from the draw's ``truth.json``: ``params.base_delay_samples`` over the
  sample rate; 0 where the case has none), which ``identify`` shifts out of the base records.

Each copy is identified with the library's defaults. Columns: delta and kn errors [%] (unequal
gaps: against the hinges' mean, the manifest's truth), whether each 95 % interval holds the
truth, the verdict (``ok OUT``: ``ok`` outside the bounds, |delta| < 1 %, |kn| < 2 %) and its
failed checks, the base channel's delay as shifted (stated, or estimated by ``identify``, with
its 95 % uncertainty) and what the answer's replay still reads (docs/identify.md §3c, "The
base channel's timing"), the wall time; then a tally per statement.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import shutil
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import scipy.signal
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
import exact_sim  # noqa: E402  (this folder's simulator)

STATEMENTS = ("unknown", "replay", "response", "base_delay")
BOUNDS = {"delta": 0.01, "kn": 0.02}  # the success bounds (relative)


def exact_sim_response(sample_rate: float, knots_per_sample: int = 64, n: int = 513):
    """(frequency [Hz], gain) of exact_sim's decimation: its Kaiser FIR (applied centred by
    ``resample_poly``: zero phase) and its 5-point central difference at the knot rate."""
    taps = exact_sim.decimator(knots_per_sample, sample_rate)
    f = np.linspace(0.0, sample_rate / 2, n)
    _, h = scipy.signal.freqz(taps, worN=f, fs=sample_rate * knots_per_sample)
    step = 1.0 / (sample_rate * knots_per_sample)
    w = 2 * np.pi * f
    d = np.ones_like(f)
    d[1:] = (8 * np.sin(w[1:] * step) - np.sin(2 * w[1:] * step)) / (6 * step * w[1:])
    return f, np.abs(h) * d


def stated_copy(src: Path, dst: Path, statement: str) -> Path:
    """``src`` (a draw's folder) copied to ``dst`` with its manifest stating ``statement``."""
    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(src, dst)
    path = dst / "manifest.yaml"
    m = yaml.safe_load(path.read_text())
    if statement == "response":
        f, g = exact_sim_response(float(m["sample_rate"]))
        np.savetxt(dst / "filter.csv", np.column_stack([f, g]), delimiter=",",
                   header="frequency_hz,gain", comments="", fmt="%.12g")
        m["antialias"] = {"response": "filter.csv"}
    elif statement == "base_delay":
        params = json.loads((dst / "truth.json").read_text()).get("params", {})
        m["base_delay_s"] = float(params.get("base_delay_samples", 0.0)) / float(
            m["sample_rate"])
    elif statement != "unknown":
        m["antialias"] = statement
    path.write_text(yaml.safe_dump(m, sort_keys=False))
    return dst


def one(job) -> dict:
    case, draw, statement, folder = job
    import freeplayid

    t0 = time.perf_counter()
    try:
        with contextlib.redirect_stderr(io.StringIO()):
            res = freeplayid.identify(folder, progress=False)
    except freeplayid.InputError as exc:
        return {"case": case, "draw": draw, "statement": statement,
                "refused": " ".join(str(exc).split()), "wall_s": time.perf_counter() - t0}
    truth = res.truth
    return {"case": case, "draw": draw, "statement": statement,
            "delta": 100 * res.truth_error["delta"], "kn": 100 * res.truth_error["kn"],
            "delta_holds": res.delta_ci95[0] <= truth["delta"] <= res.delta_ci95[1],
            "kn_holds": res.kn_ci95[0] <= truth["kn"] <= res.kn_ci95[1],
            "delta_ci": [100 * (v / truth["delta"] - 1) for v in res.delta_ci95],
            "kn_ci": [100 * (v / truth["kn"] - 1) for v in res.kn_ci95],
            "status": str(res.verdict.status),
            "failed": [c.name for c in res.verdict.checks if not c.passed],
            "base": _base_said(res), "wall_s": time.perf_counter() - t0}


def _base_said(res) -> str:
    """The base channel's delay as shifted (stated or estimated) [sample] and what the answer's
    replay still reads [degrees at the points]."""
    fs = float(res.dataset["sample_rate"])
    shifted = res.dataset.get("base_delay_s") or 0.0
    source = res.dataset.get("base_delay_source", "stated") if shifted else ""
    timing = None if res.replay is None else getattr(res.replay, "base_timing", None)
    left = "" if timing is None else f"; remains {abs(timing.turn_deg):.2f}°"
    known = res.dataset.get("base_delay_uncertainty_s")
    known = f" ± {known * fs:.3f}" if known is not None and np.isfinite(known) else ""
    return (f"{source} {shifted * fs:+.3f}{known}" if shifted else "none") + left


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True, help="cases.py --out")
    ap.add_argument("--cases", default="var6_finC_nominal")
    ap.add_argument("--draws", default="d_none,d0,d1")
    ap.add_argument("--statements", default="unknown,replay,response")
    ap.add_argument("--work", default="outputs/realtests/stated_filter")
    ap.add_argument("--jobs", type=int, default=1)
    args = ap.parse_args()
    jobs = []
    for case in args.cases.split(","):
        for draw in args.draws.split(","):
            src = Path(args.data) / case / draw
            if not (src / "manifest.yaml").is_file():
                sys.exit(f"{src}: no manifest.yaml (redraw.py --noise none makes d_none)")
            for st in args.statements.split(","):
                if st not in STATEMENTS:
                    sys.exit(f"--statements: {st!r} is not one of {list(STATEMENTS)}")
                jobs.append((case, draw, st,
                             str(stated_copy(src, Path(args.work) / case / f"{draw}_{st}", st))))
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(one, jobs))
    print("| case | draw | stated | δ [%] | kn [%] | intervals hold δ / kn | verdict "
          "| failed checks | base shifted [sample] | wall [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if "refused" in r:
            print(f"| {r['case']} | {r['draw']} | {r['statement']} | refused: {r['refused']} "
                  "| | | | | | |")
            continue
        within = abs(r["delta"]) < 100 * BOUNDS["delta"] and abs(r["kn"]) < 100 * BOUNDS["kn"]
        status = "**ok OUT**" if r["status"] == "ok" and not within else r["status"]
        print(f"| {r['case']} | {r['draw']} | {r['statement']} | {r['delta']:+.3f} | "
              f"{r['kn']:+.3f} | {'yes' if r['delta_holds'] else 'no'} / "
              f"{'yes' if r['kn_holds'] else 'no'} | {status} | "
              f"{', '.join(r['failed']) or '-'} | {r['base']} | {r['wall_s']:.0f} |")
    print()
    print("| stated | answers | within δ 1 % / kn 2 % | `ok` within | **`ok` outside** | "
          "`suspect` within | `suspect` outside | both intervals hold | refused |")
    print("|---|---|---|---|---|---|---|---|---|")
    for st in dict.fromkeys(r["statement"] for r in rows):
        mine = [r for r in rows if r["statement"] == st]
        done = [r for r in mine if "refused" not in r]
        inside = [abs(r["delta"]) < 100 * BOUNDS["delta"] and abs(r["kn"]) < 100 * BOUNDS["kn"]
                  for r in done]
        ok = [r["status"] == "ok" for r in done]
        print(f"| {st} | {len(mine)} | {sum(inside)} | {sum(i and o for i, o in zip(inside, ok))}"
              f" | {sum(o and not i for i, o in zip(inside, ok))} | "
              f"{sum(i and not o for i, o in zip(inside, ok))} | "
              f"{sum(not i and not o for i, o in zip(inside, ok))} | "
              f"{sum(r['delta_holds'] and r['kn_holds'] for r in done)} | "
              f"{len(mine) - len(done)} |")
    out = Path(args.work) / "results.jsonl"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("".join(json.dumps(r) + "\n" for r in rows))


if __name__ == "__main__":
    main()

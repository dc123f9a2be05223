"""Identify every realtests case (cases.py) with freeplayid and print the results table.

    python benchmarks/realtests/run.py                  # all cases in outputs/realtests/data
    python benchmarks/realtests/run.py --cases 'fin_level_*' --jobs 2
    python benchmarks/realtests/run.py --report outputs/realtests/results   # table from saved JSONL
    python benchmarks/realtests/run.py --replay damping_exponent=estimate    # a replay option set

For each case and noise draw, two identifications: the plain backbone fit and the default,
corrected answer (the replay). The table gives each one's errors against the truth (for unequal
gaps: against the mean of the hinges' gaps, marked "mean"), whether each 95 % interval holds the
truth, whether the answer is within the issue's bounds (|delta| < 1 %, |kn| < 2 %), the verdict
with its reasons (shortened), and the wall time. A refusal (freeplayid.InputError) is a row with
its message; any other exception is a row marked ``error``. ``ok OUT`` marks an ``ok`` verdict
outside the bounds: the failures the issue is about.

The library is called in one function, :func:`identify_case`, with its defaults (as a user
would). Results go to ``--out`` as one JSONL file per case (one line per draw and fit).
"""

from __future__ import annotations

import argparse
import contextlib
import fnmatch
import io
import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

DEFAULT_DATA = "outputs/realtests/data"  # cases.py --out
DEFAULT_OUT = "outputs/realtests/results"
BOUNDS = {"delta": 0.01, "kn": 0.02}  # the success bounds (relative)
FITS = ("plain", "corrected")


def identify_case(path: str, corrected: bool, replay: dict | None = None,
                  acmp: dict | None = None) -> dict:
    """The one call into freeplayid: the default corrected answer (with the ``replay`` options
    given, if any) or the plain fit of a data set, as a plain dict (kn, delta, intervals,
    verdict and reasons) or {"refused": message}. ``acmp``: options of the default extraction's
    pursuit (``Extraction(options=acmp)``), if any."""
    import freeplayid
    from freeplayid.signal import Extraction

    kw = {"extraction": Extraction(options=acmp)} if acmp else {}
    try:
        with contextlib.redirect_stderr(io.StringIO()):  # the progress bars
            res = (freeplayid.identify(path, **kw, **({"replay": replay} if replay else {}))
                   if corrected else freeplayid.identify(path, replay=None, **kw))
    except freeplayid.InputError as exc:
        return {"refused": " ".join(str(exc).split())}
    rep = res.replay
    return {"kn": float(res.kn), "delta": float(res.delta),
            "kn_ci95": [float(v) for v in res.kn_ci95],
            "delta_ci95": [float(v) for v in res.delta_ci95],
            "status": str(res.verdict.status), "reasons": [str(r) for r in res.verdict.reasons],
            # what the verdict measured: each check's value, and the replay loop's end
            "checks": {c.name: [bool(c.passed), c.to_dict()["value"]]
                       for c in res.verdict.checks},
            "replay": None if rep is None else {
                "replays": len(rep.iterations), "converged": bool(rep.converged),
                "failure": rep.failure or None, "stopped": getattr(rep, "stopped", "") or None,
                "peak_offset": {run: float(m.peak_offset)
                                for run, m in (rep.resonance or {}).items()},
                "backbone_offset": {run: float(m.backbone_offset)
                                    for run, m in (rep.resonance or {}).items()},
                # the offsets' noise (noisy copies) and the answer's move without each run,
                # where measured
                "offset_se": {run: float(m.offset_se) for run, m in (rep.resonance or {}).items()
                              if getattr(m, "offset_se_samples", 0)},
                "without": {run: list(m.without) for run, m in (rep.resonance or {}).items()
                            if getattr(m, "without", None) is not None},
                # the noise's move of the answer (noisy copies, through the binding's slope)
                "precision": None if getattr(rep, "precision", None) is None
                else rep.precision.to_dict(),
                # the base's reading noise, read as the replays' excitation (its copies' move)
                "excitation_noise": None if getattr(rep, "excitation_noise", None) is None
                else rep.excitation_noise.to_dict(),
                # the answer's move for a damping the down-sweeps do not measure
                "damping_sensitivity": None if getattr(rep, "damping_sensitivity", None) is None
                else rep.damping_sensitivity.to_dict(),
                # the answer's moves under other damping forms (no base channel)
                "form_sensitivity": None if getattr(rep, "form_sensitivity", None) is None
                else rep.form_sensitivity.to_dict(),
                # the answer's move for levels taken from level_g, and the levels the upper
                # branches imply
                "level": None if getattr(rep, "level", None) is None else rep.level.to_dict(),
                # the base's narrowed reading against the wide one around the points, and the
                # runs driven by the wide reading
                "base_reading": None if getattr(rep, "base_reading", None) is None
                else rep.base_reading.to_dict(),
                "wide_base": list(getattr(rep, "wide_base", ())),
                # the replay's damping: its ratio, the form estimated (or why not), the one
                # ratio's answer
                "damping": None if rep.damping is None else rep.damping.to_dict(),
                "branch": {run: float(m.branch) for run, m in (rep.resonance or {}).items()},
                # the loop's largest jump of the replayed fits, the run that makes it and the
                # answer's move without that run
                "binding_jump": None if getattr(rep, "binding_jump", None) is None
                else rep.binding_jump.to_dict()},
            # the hinges' split read against the replay, and the one-gap answer where the test
            # was replayed with the split it showed
            "split": None if getattr(res.model_error, "split", None) is None
            else res.model_error.split.to_dict(),
            "checks_text": {c.name: str(c.message) for c in res.verdict.checks
                            if c.name in ("replay_misfit", "hinge_gaps", "base_reading",
                                          "drop_window", "replay_binding",
                                          "damping_form")}}


def _task(case: str, draw: str, folder: str, fit: str, replay: dict | None = None,
          acmp: dict | None = None) -> dict:
    t0 = time.perf_counter()
    try:
        out = identify_case(folder, fit == "corrected", replay, acmp)
    except Exception as exc:  # a crash is a result of the benchmark too
        out = {"error": f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}"}
    truth = json.loads((Path(folder) / "truth.json").read_text())
    out.update(case=case, draw=draw, fit=fit, wall_s=time.perf_counter() - t0,
               condition=truth["condition"], truth={"kn": truth["kn"], "delta": truth["delta"],
                                                    "deltas": truth.get("deltas")})
    return out


def find_cases(data: Path, patterns: list[str]) -> list[tuple[str, str, Path]]:
    """(case, draw, folder) of every data set under ``data``, in cases.py's order."""
    try:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from cases import ALL_CASES

        order = {n: i for i, n in enumerate(ALL_CASES)}
    except Exception:  # the table does not need the generator
        order = {}
    found = []
    for manifest in sorted(data.glob("*/d*/manifest.yaml")):
        folder = manifest.parent
        case, draw = folder.parent.name, folder.name
        if patterns and not any(fnmatch.fnmatch(case, p) for p in patterns):
            continue
        found.append((case, draw, folder))
    return sorted(found, key=lambda x: (order.get(x[0], len(order)), x[0], x[1]))


# --------------------------------------------------------------------------- the table
def _pct(x: float) -> str:
    return f"{100 * x:+.2f}"


def row_cells(r: dict) -> list[str]:
    t = r["truth"]
    unequal = t.get("deltas") and len(set(t["deltas"])) > 1
    base = [r["case"], r["condition"] + (" (delta vs the hinges' mean)" if unequal else ""),
            r["draw"], r["fit"]]
    if "refused" in r or "error" in r:
        msg = r.get("refused") or r.get("error")
        kind = "refused" if "refused" in r else "error"
        return base + ["-", "-", "-", "-", "-", kind, _short([msg]), f"{r['wall_s']:.0f}"]
    ed, ek = r["delta"] / t["delta"] - 1, r["kn"] / t["kn"] - 1
    inside = abs(ed) < BOUNDS["delta"] and abs(ek) < BOUNDS["kn"]
    hold_d = r["delta_ci95"][0] <= t["delta"] <= r["delta_ci95"][1]
    hold_k = r["kn_ci95"][0] <= t["kn"] <= r["kn_ci95"][1]
    status = r["status"]
    flag = f"**{status} OUT**" if (status == "ok" and not inside) else status
    return base + [_pct(ed), _pct(ek), "yes" if hold_d else "no", "yes" if hold_k else "no",
                   "in" if inside else "OUT", flag, _short(r["reasons"]), f"{r['wall_s']:.0f}"]


def _short(reasons: list[str], each: int = 70, total: int = 220) -> str:
    parts = [(s[:each - 1] + "…") if len(s) > each else s for s in reasons]
    text = " · ".join(parts)
    text = (text[:total - 1] + "…") if len(text) > total else text
    return text.replace("|", "/") or "-"


def table(results: list[dict]) -> str:
    head = ["case", "condition", "draw", "fit", "δ err %", "kn err %", "δ CI holds",
            "kn CI holds", "bounds", "verdict", "reasons", "wall s"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(row_cells(r)) + " |" for r in results]
    lines += ["", summary(results)]
    return "\n".join(lines)


def summary(results: list[dict]) -> str:
    out = []
    for fit in FITS:
        rs = [r for r in results if r["fit"] == fit]
        if not rs:
            continue
        cells = [row_cells(r) for r in rs]
        n_in = sum(c[8] == "in" for c in cells)
        ok_out = sum("OUT**" in c[9] for c in cells)
        ok = sum(c[9] == "ok" for c in cells)
        sus = sum(c[9] == "suspect" for c in cells)
        ref = sum(c[9] in ("refused", "error") for c in cells)
        both = sum(c[6] == "yes" and c[7] == "yes" for c in cells)
        out.append(f"- {fit}: {len(rs)} answers; within the bounds {n_in}; `ok` within the "
                   f"bounds {ok}, **`ok` outside the bounds {ok_out}**, `suspect` {sus}, "
                   f"refused/error {ref}; both intervals hold the truth {both}")
    return "\n".join(out)


def _log_sd(r: dict, par: str, replay_alone: bool = False) -> float | None:
    """The standard deviation of log ``par`` that the answer's precision (its noisy copies)
    gives: its 95 % half-width over 1.96 (an upper bound where the copies stopped early);
    with ``replay_alone``, that of the replay's copies alone where the records' copies were
    pooled with them (``replay_halfwidths``; None where they were not)."""
    p = (r.get("replay") or {}).get("precision") or {}
    if replay_alone:
        alone = p.get("replay_halfwidths")
        hw = None if not alone else alone[0 if par == "kn" else 1]
    else:
        hw = p.get(f"{par}_halfwidth")
    return None if hw is None else math.log1p(hw) / 1.96


def _stopped_early(r: dict) -> bool:
    """Whether the answer's precision copies stopped early (records written before the
    ``settled`` field: fewer copies made than the default eight)."""
    from freeplayid.replay import Replay

    p = r["replay"]["precision"]
    return bool(p.get("settled", p["n"] < Replay().precision_copies))


def draw_pairs(results: list[dict]) -> str:
    """The precision checked on the two noise draws of each condition: their corrected answers
    differ by the noise alone (the same records but for the noise), so the difference of their
    logs over the two precisions combined is a standard normal where the precision is right
    (RMS 1, |z| > 2 in 4.6 %). Split by whether either answer's copies stopped early (their
    half-widths then 95 % upper bounds: RMS below 1). Down-sweeps apart (their answers move
    with the loop's path, not only the noise). Pairs whose answers pooled copies of the records
    with the replay's (``Replay.precision_record_copies``) are read again with the replay's
    copies alone, in a row of their own."""
    by = {}
    for r in results:
        if r["fit"] == "corrected" and "kn" in r and _log_sd(r, "delta") is not None:
            by.setdefault(r["case"], {})[r["draw"]] = r
    groups: dict = {}
    for case, draws in by.items():
        if len(draws) < 2:
            continue
        a, b = (draws[d] for d in sorted(draws)[:2])
        early = _stopped_early(a) or _stopped_early(b)
        kind = "down-sweeps" if "down" in case else (
            "up-sweeps, a copy set stopped early" if early else "up-sweeps, all copies")
        alone = all(_log_sd(r, "delta", True) is not None for r in (a, b))
        for par in ("delta", "kn"):
            z = math.log(a[par] / b[par]) / math.hypot(_log_sd(a, par), _log_sd(b, par))
            groups.setdefault((kind, par), []).append((z, case))
            if alone:
                z = math.log(a[par] / b[par]) / math.hypot(_log_sd(a, par, True),
                                                           _log_sd(b, par, True))
                groups.setdefault((kind + ", the replay's copies alone", par), []).append(
                    (z, case))
    head = ["pairs", "parameter", "conditions", "RMS z", "abs z > 2", "largest"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for (kind, par), zs in sorted(groups.items()):
        rms = math.sqrt(sum(z * z for z, _ in zs) / len(zs))
        far = sum(abs(z) > 2 for z, _ in zs)
        z_max, case_max = max(zs, key=lambda x: abs(x[0]))
        lines.append(f"| {kind} | {par} | {len(zs)} | {rms:.2f} | {far} ({100 * far / len(zs):.1f} "
                     f"%) | {z_max:+.1f} ({case_max}) |")
    return "\n".join(lines)


def draw_spread(results: list[dict], least: int = 3) -> str:
    """The precision checked on many noise draws of one condition (``redraw.py``): per
    condition with at least ``least`` corrected answers, the mean and the standard deviation of
    their delta errors (in log, %) beside the standard deviation their noisy copies predicted
    (the median over the draws), and how many answers are ``ok`` outside the bounds. Where the
    copies are right, the ratio of the two spreads is near 1 (with eight draws its 95 % range
    is about 0.6-1.5); the mean is the bias that no copy of the answer's own replay can show."""
    by: dict = {}
    for r in results:
        if r["fit"] == "corrected" and "kn" in r and _log_sd(r, "delta") is not None:
            by.setdefault(r["case"], []).append(r)
    head = ["condition", "draws", "delta error mean [%]", "sd over the draws [%]",
            "sd the copies predicted [%]", "ratio", "`ok` outside"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for case, rows in sorted(by.items()):
        if len(rows) < least:
            continue
        err = [math.log(r["delta"] / r["truth"]["delta"]) for r in rows]
        mean = sum(err) / len(err)
        sd = math.sqrt(sum((e - mean) ** 2 for e in err) / (len(err) - 1))
        pred = sorted(_log_sd(r, "delta") for r in rows)[len(rows) // 2]
        outside = sum(row_cells(r)[9].endswith("OUT**") for r in rows)
        lines.append(f"| {case} | {len(rows)} | {100 * mean:+.2f} | {100 * sd:.2f} | "
                     f"{100 * pred:.2f} | {sd / pred:.2f} | {outside} |")
    return "\n".join(lines)


def key_values(pairs: list[str], flag: str, check) -> dict:
    """``KEY=VALUE`` pairs of ``flag``, each value read as YAML (0.6, true, estimate), checked
    by ``check(options)`` (a TypeError or ValueError ends the run before any long work)."""
    import yaml

    out = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or not key:
            raise SystemExit(f"{flag} takes KEY=VALUE, got {pair!r}")
        out[key.strip()] = yaml.safe_load(value)
    if out:
        try:
            check(out)
        except (TypeError, ValueError) as err:
            raise SystemExit(f"{flag}: {err}") from None
    return out


def _check_replay(options: dict) -> None:
    from freeplayid.replay import Replay

    Replay(**options)


def replay_options(pairs: list[str]) -> dict:
    """``--replay``'s pairs as replay options."""
    return key_values(pairs, "--replay", _check_replay)


def _check_acmp(options: dict) -> None:
    """The pursuit's keyword options: known names (its signature), values as ``acmp`` checks
    them, on a short chirp."""
    import inspect

    import numpy as np

    from freeplayid.signal import acmp

    names = [p.name for p in inspect.signature(acmp).parameters.values()
             if p.kind is p.KEYWORD_ONLY and p.name not in ("sweep", "bandwidth_hz")]
    unknown = sorted(set(options) - set(names))
    if unknown:
        raise TypeError(f"unknown option(s) {unknown}; valid: {names}")
    t = np.arange(512) / 256.0
    acmp(np.sin(2 * np.pi * (20 * t + t * t)), 256.0, **options)


def acmp_options(pairs: list[str]) -> dict:
    """``--acmp``'s pairs as the extraction's pursuit options (``Extraction(options=...)``)."""
    return key_values(pairs, "--acmp", _check_acmp)


def sort_key(order: dict):
    return lambda r: (order.get(r["case"], 1e9), r["case"], r["draw"], FITS.index(r["fit"]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=DEFAULT_DATA, help="folder of the cases (cases.py --out)")
    ap.add_argument("--cases", default="", help="comma-separated names or shell patterns")
    ap.add_argument("--draws", default="", help="comma-separated draws (default: all; e.g. d0)")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", default=DEFAULT_OUT, help="folder for one JSONL per case")
    ap.add_argument("--fits", default="plain,corrected", help="plain, corrected or both")
    ap.add_argument("--report", default=None, help="print the table of the JSONL in this folder")
    ap.add_argument("--replay", action="append", default=[], metavar="KEY=VALUE",
                    help="a replay option for the corrected fits (repeatable), e.g. "
                    "damping_exponent=estimate")
    ap.add_argument("--acmp", action="append", default=[], metavar="KEY=VALUE",
                    help="an option of the extraction's pursuit (repeatable), e.g. "
                    "if_weighting=none")
    args = ap.parse_args()
    replay = replay_options(args.replay)
    acmp = acmp_options(args.acmp)
    patterns = [p for p in args.cases.split(",") if p]
    cases = find_cases(Path(args.data), patterns)
    draws = [d for d in args.draws.split(",") if d]
    cases = [c for c in cases if not draws or c[1] in draws]
    order = {c: i for i, c in enumerate(dict.fromkeys(c for c, _, _ in cases))}
    if args.report:
        results = [json.loads(line) for f in sorted(Path(args.report).glob("*.jsonl"))
                   for line in f.read_text().splitlines() if line.strip()]
        results = [r for r in results
                   if not patterns or any(fnmatch.fnmatch(r["case"], p) for p in patterns)]
        print(table(sorted(results, key=sort_key(order))))
        print("\nThe precision on the two draws of each condition (draw_pairs):\n")
        print(draw_pairs(results))
        print("\nThe precision on many draws of one condition (draw_spread):\n")
        print(draw_spread(results))
        return
    if not cases:
        raise SystemExit(f"no data sets under {args.data} matching {patterns or 'anything'}")
    fits = [f for f in args.fits.split(",") if f]
    tasks = [(c, d, str(f), fit, replay, acmp) for c, d, f in cases for fit in fits]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for case in order:  # fresh files for the cases this run covers
        (out / f"{case}.jsonl").unlink(missing_ok=True)
    t0, results = time.perf_counter(), []

    def keep(r):
        results.append(r)
        with open(out / f"{r['case']}.jsonl", "a") as fh:
            fh.write(json.dumps(r) + "\n")
        print(f"[{time.perf_counter() - t0:6.0f} s] {r['case']} {r['draw']} {r['fit']}: "
              f"{' '.join(row_cells(r)[4:10])}", file=sys.stderr, flush=True)

    if args.jobs > 1:
        with ProcessPoolExecutor(args.jobs) as pool:
            for r in pool.map(_task, *zip(*tasks)):
                keep(r)
    else:
        for t in tasks:
            keep(_task(*t))
    print(table(sorted(results, key=sort_key(order))))
    print(f"\n{len(tasks)} identifications in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()

"""Wall time of ``identify`` on the bundled example: the corrected fit beside the plain fit.

    python benchmarks/identify_time.py              # after pip install -e . (or PYTHONPATH=src)
    python benchmarks/identify_time.py --repeat 2   # best of 2 per row

One process, warm: a first identify (not timed) loads the compiled replay kernel and the modules,
as a notebook's second call or ``scripts/identify.py`` after its first run would find them. Then,
in the same run, per row:

- ``plain fit``: ``replay=None`` (the points and the backbone fit, no bias correction);
- ``corrected``: the default (the plain fit, then the replays of the test, then the noisy copies
  of the answer's replay that measure its precision);
- ``corrected, no precision copies``: ``replay.precision_copies=0`` (the default before the
  verdict's ``noise_precision``);
- ``corrected, eight copies of the records pooled``: ``replay.precision_record_copies=8`` (an
  option, not the default: noisy copies of the test's own records pooled with the replay's;
  none are made where the replay's copies stop early, as on the bundled example);
- ``corrected, no excitation copies``: ``replay.excitation_copies=0`` (the default before the
  base channel's noise entered the intervals, 2026-11-30);
- ``…, one thread``: the same with a replay's runs simulated one after another (the code
  before they ran at once, one per core: ``freeplayid.threads``);
- ``corrected, nothing kept``: the default with every extraction solved afresh, as before the
  extraction kept its results: no pursuit reused (ACMP's iterations on a record it has already
  run on with the same inputs) and the smoothing's Cholesky factor computed at every iteration;
- ``corrected, the BLAS on its own threads``: numpy's and scipy's BLAS free to use its own
  threads beside freeplayid's (the code before 2026-12-01: ``freeplayid.threads.BLAS_THREADS``);
- ``corrected, the base's noise read by the whole pursuit``: each excitation copy's reading noise
  read by the pursuit's full iterations, not one step (the code before 2026-12-01:
  ``freeplayid.replay.excitation.READ_AGAIN_STEPS``); its column ``the base's noise`` shows
  what the copies give the intervals either way.

Kept results are dropped before each row, so each row is a first identify of the data. The
stages: the plain estimate (the test's points and their fit), the replays' simulation, and the
extraction and fit of the replays (with the test's points for the replays' statistic), the
precision's noisy copies (their extraction and fit), the excitation copies (their replays,
extraction and fit). Prints a
Markdown table: wall time (best of ``--repeat``), stages, the answer and the verdict, which do not
depend on what is kept (checked: the table says if they differ).
"""

from __future__ import annotations

import argparse
import functools
import importlib
import logging
import time
from contextlib import contextmanager

from freeplayid import identify
from freeplayid.io import bundled_example, read_dataset

STAGES = {  # (module, function) -> stage name; a call's time counts once (outermost)
    ("freeplayid.identification.pipeline", "plain_estimate"): "plain estimate",
    ("freeplayid.replay.corrected", "replay_dataset"): "replays: simulate",
    ("freeplayid.replay.corrected", "plain_estimate"): "replays: extract + fit",
    ("freeplayid.replay.corrected", "precision_by_replay"): "precision copies",
    ("freeplayid.replay.corrected", "_excitation_noise"): "excitation copies",
}


@contextmanager
def timed_stages(totals: dict):
    """Adds each stage's wall time to ``totals`` while the block runs."""
    saved, active = [], []
    for (mod_name, fn_name), stage in STAGES.items():
        mod = importlib.import_module(mod_name)
        fn = getattr(mod, fn_name)
        saved.append((mod, fn_name, fn))

        def wrapper(*a, _fn=fn, _stage=stage, **k):
            if active:  # inside another stage (the excitation copies' replays): its time
                return _fn(*a, **k)
            active.append(_stage)
            t0 = time.perf_counter()
            try:
                return _fn(*a, **k)
            finally:
                active.pop()
                totals[_stage] = totals.get(_stage, 0.0) + time.perf_counter() - t0

        setattr(mod, fn_name, wrapper)
    try:
        yield
    finally:
        for mod, fn_name, fn in saved:
            setattr(mod, fn_name, fn)


@contextmanager
def nothing_kept():
    """Every pursuit run afresh and the smoothing factor computed per solve (the code before)."""
    acmp = importlib.import_module("freeplayid.signal.acmp")
    banded = importlib.import_module("freeplayid.signal.banded")
    kept, factor = acmp._PURSUITS, banded._smoothing_factor
    fresh = acmp._Pursuits()
    run = fresh.get_or_run

    def afresh(*args, **options):  # the kept results dropped before every call
        fresh.entries.clear()
        return run(*args, **options)

    fresh.get_or_run = afresh
    acmp._PURSUITS = fresh
    banded._smoothing_factor = functools.lru_cache(maxsize=0)(factor.__wrapped__)
    try:
        yield
    finally:
        acmp._PURSUITS, banded._smoothing_factor = kept, factor


@contextmanager
def one_thread():
    """A replay's runs simulated one at a time (``freeplayid.threads.cores`` -> 1)."""
    threads = importlib.import_module("freeplayid.threads")
    saved = threads.cores
    threads.cores = lambda: 1
    try:
        yield
    finally:
        threads.cores = saved


@contextmanager
def drop_kept() -> None:
    acmp = importlib.import_module("freeplayid.signal.acmp")
    acmp._PURSUITS.entries.clear()
    importlib.import_module("freeplayid.signal.banded")._smoothing_factor.cache_clear()


@contextmanager
def patched(module: str, name: str, value):
    """``module.name`` set to ``value`` while the block runs."""
    mod = importlib.import_module(module)
    saved = getattr(mod, name)
    setattr(mod, name, value)
    try:
        yield
    finally:
        setattr(mod, name, saved)


def blas_own_threads():
    """The BLAS library on its own threads (``freeplayid.threads.BLAS_THREADS`` None: the
    code before 2026-12-01)."""
    return patched("freeplayid.threads", "BLAS_THREADS", None)


def whole_pursuit():
    """The base's noise read by the whole pursuit in the excitation copies (its default
    ``max_iter``, 100: the code before 2026-12-01) instead of one step."""
    return patched("freeplayid.replay.excitation", "READ_AGAIN_STEPS", 100)


def run_row(dataset, replay: bool, repeat: int, afresh: bool = False,
            single: bool = False, options: dict | None = None, patch=None) -> dict:
    best = None
    for _ in range(repeat):
        drop_kept()
        totals: dict = {}
        with timed_stages(totals), (nothing_kept() if afresh else _no_op()), \
                (one_thread() if single else _no_op()), (patch() if patch else _no_op()):
            t0 = time.perf_counter()
            res = identify(dataset, progress=False,
                           replay=(options or {}) if replay else None)
            wall = time.perf_counter() - t0
        if best is None or wall < best["wall"]:
            exc = None if res.replay is None else res.replay.excitation_noise
            best = {"wall": wall, "stages": totals, "kn": res.kn, "delta": res.delta,
                    "verdict": res.verdict.status,
                    "base_noise": None if exc is None else exc.delta_halfwidth}
    return best


@contextmanager
def _no_op():
    yield


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=1, help="best of this many per row")
    args = ap.parse_args()
    logging.getLogger("freeplayid").setLevel(logging.WARNING)
    dataset = read_dataset(bundled_example())
    t0 = time.perf_counter()
    identify(dataset, progress=False)  # warm-up: the replay kernel loads (compiles if cold)
    print(f"warm-up identify (not timed in the table): {time.perf_counter() - t0:.1f} s\n")
    rows = [("plain fit (replay=None)", run_row(dataset, False, args.repeat)),
            ("plain fit, one thread", run_row(dataset, False, args.repeat, single=True)),
            ("corrected (default)", run_row(dataset, True, args.repeat)),
            ("corrected, no precision copies",
             run_row(dataset, True, args.repeat, options={"precision_copies": 0})),
            ("corrected, eight copies of the records pooled",
             run_row(dataset, True, args.repeat, options={"precision_record_copies": 8})),
            ("corrected, no excitation copies",
             run_row(dataset, True, args.repeat, options={"excitation_copies": 0})),
            ("corrected, one thread", run_row(dataset, True, args.repeat, single=True)),
            ("corrected, the BLAS on its own threads",
             run_row(dataset, True, args.repeat, patch=blas_own_threads)),
            ("corrected, the base's noise read by the whole pursuit",
             run_row(dataset, True, args.repeat, patch=whole_pursuit)),
            ("corrected, nothing kept", run_row(dataset, True, args.repeat, afresh=True))]
    row = {label: r for label, r in rows}
    names = list(dict.fromkeys(STAGES.values()))
    print("| identify | wall [s] | " + " | ".join(f"{n} [s]" for n in names)
          + " | kn [N·m/rad] | delta [mrad] | the base's noise in delta [±%] | verdict |")
    print("|---" * (len(names) + 6) + "|")
    for label, r in rows:
        stages = " | ".join(f"{r['stages'].get(n, 0.0):.1f}" for n in names)
        base = "–" if r["base_noise"] is None else f"{100 * r['base_noise']:.3g}"
        print(f"| {label} | {r['wall']:.1f} | {stages} | {r['kn']:.5g} | "
              f"{1e3 * r['delta']:.5g} | {base} | {r['verdict']} |")
    def same(a, b, keys=("kn", "delta", "verdict")):
        return all(row[a][k] == row[b][k] for k in keys)

    c = "corrected (default)"
    print(f"\nthreads: {threads_cores()}; the same answers on one thread: plain "
          f"{same('plain fit (replay=None)', 'plain fit, one thread')}, corrected "
          f"{same(c, 'corrected, one thread')}; corrected with and without kept results: "
          f"{same(c, 'corrected, nothing kept')}, with the BLAS on its own threads: "
          f"{same(c, 'corrected, the BLAS on its own threads')}; kn, delta with and without the "
          f"precision copies: {same(c, 'corrected, no precision copies', ('kn', 'delta'))}")


def threads_cores() -> int:
    return importlib.import_module("freeplayid.threads").cores()


if __name__ == "__main__":
    main()

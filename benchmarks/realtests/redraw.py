"""More noise draws of a realtests case, with the noise on all channels, the responses only, the
base only, or none: to tell what an answer's error owes to the noise from what it owes to the
method.

    python benchmarks/realtests/redraw.py var14_finB_damper_strong --data D --out OUT --noise none
    python benchmarks/realtests/redraw.py var14_finB_damper_strong --data D --out OUT \\
        --noise responses --draws 0-15
    python benchmarks/realtests/redraw.py var13_finC_fast_dip --data D --out OUT --noise-g 0.02

Each draw is written as ``OUT/<case>/d<k>`` (noise on all channels), ``d<k>_responses`` or
``d<k>_base`` from the case's clean records (``D/<case>/clean.npz``, or its source's where it
reuses another case's records; written by cases.py), as cases.py writes its draws. Draws 0
and 1 use cases.py's seeds (``--noise all --draws 0-1`` writes its ``d0`` and ``d1`` again, to
the bit, truth.json included), the others seed ``1000 + k``. ``--noise none`` writes one
noise-free data set, ``d_none``. Identify them as any realtests draw:
``run.py --data OUT --cases CASE --draws d_none,d2_responses,...``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import cases  # noqa: E402

NOISE = ("all", "responses", "base", "none")


def seed_of(k: int) -> int:
    """Draw k's seed: cases.py's for draws 0 and 1, else 1000 + k."""
    return cases.SEEDS[k] if k < len(cases.SEEDS) else 1000 + k


def draws(text: str) -> list[int]:
    """'0-3,7' -> [0, 1, 2, 3, 7]."""
    out = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out.extend(range(int(lo), int(hi or lo) + 1))
    return out


def redraw(name: str, data: Path, out: Path, noise: str, ks: list[int],
           noise_g: float | None = None) -> list[Path]:
    """Write draws ``ks`` of case ``name`` with ``noise`` on the channels it names (module
    docstring), at ``noise_g`` [g] instead of the case's own level where given (the folders
    then end in ``_<noise_g>g``); return their folders."""
    if noise not in NOISE:
        raise ValueError(f"--noise must be one of {NOISE}, got {noise!r}")
    if noise_g is not None and not noise_g > 0:
        raise ValueError(f"--noise-g must be > 0 [g], got {noise_g!r}")
    spec = cases.ALL_CASES[name]()
    if noise_g is not None:
        spec.noise_g = float(noise_g)
    needed = [spec.clean_from or name]
    if spec.profile_of_run is not None:
        needed.append(spec.params["profile_from"])
    for src in needed:
        if not (data / src / "clean.npz").is_file():
            raise FileNotFoundError(f"{data / src / 'clean.npz'}: no clean records (run "
                                    f"cases.py --cases {name} --out {data} first)")
    if spec.profile_of_run is not None:
        cases.set_profiles(spec, data)
    clean = cases.load_clean(data / needed[0])
    jumps = cases.clean_jumps(spec, clean)

    def keep_clean(runs):
        for i, run in enumerate(runs):
            if noise in ("base", "none"):
                run["data"] = clean["accel"][i] / cases.es.G0
            if noise in ("responses", "none"):
                run["base"] = clean["base"][i] / cases.es.G0
        return runs

    folders = []
    for k in ([0] if noise == "none" else ks):
        folder = out / name / ({"all": f"d{k}", "none": "d_none"}.get(noise, f"d{k}_{noise}")
                               + ("" if noise_g is None or noise == "none" else f"_{noise_g:g}g"))
        folder.mkdir(parents=True, exist_ok=True)
        cases.write_draw(folder, spec, clean, seed_of(k), jumps,
                         transform=None if noise == "all" else keep_clean)
        folders.append(folder)
    return folders


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case", metavar="CASE", help="a case name (cases.py --list)")
    ap.add_argument("--data", type=Path, default=Path(cases.DEFAULT_OUT),
                    help="where cases.py wrote the case (its clean.npz)")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--noise", choices=NOISE, default="all")
    ap.add_argument("--draws", default="0-1", help="draw numbers, e.g. 0-15 or 2,5")
    ap.add_argument("--noise-g", type=float, default=None,
                    help="the noise's standard deviation [g] instead of the case's own")
    args = ap.parse_args(argv)
    if args.case not in cases.ALL_CASES:
        ap.error(f"unknown case {args.case!r} (cases.py --list names them)")
    try:
        ks = draws(args.draws)
    except ValueError:
        ap.error(f"--draws: {args.draws!r} is not a list of numbers and ranges (e.g. 0-15 or 2,5)")
    try:
        folders = redraw(args.case, args.data, args.out, args.noise, ks, args.noise_g)
    except (FileNotFoundError, ValueError) as err:
        raise SystemExit(f"redraw.py: {err}") from None
    for folder in folders:
        print(folder)


if __name__ == "__main__":
    main()

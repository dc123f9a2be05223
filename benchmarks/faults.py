"""Record faults made one at a time on a clean data set, and what the record checks say.

    PYTHONPATH=src python benchmarks/faults.py                   # the bundled example (~1 min)
    PYTHONPATH=src python benchmarks/faults.py PATH/manifest.yaml --identify --markdown

Each fault of issue 28 is applied alone to a copy of a clean data set (default
``examples/fin_sweeps``), written to a temporary folder with ``write_dataset`` and read back
with ``read_dataset``, and ``freeplayid.quality.check_records`` runs on it:

- ``clip80_all`` / ``clip70_all``: every response channel clipped at 80 % / 70 % of its peak
  in every run; ``clip70_two``: at 70 % in the two highest-level runs;
- ``zeros_at_jump``: 0.5 s of zeros in every channel (base too) centred on each run's jump
  (the strongest channel's first-harmonic maximum);
- ``rate_2000``: the sample rate declared 2000/2048 of the true one (time column too);
- ``swapped``: two channels swapped in the manifest's ``channels``;
- ``no_base_ms2``: no base channel, and the data in g declared as ``m/s^2``;
- ``drift``: a DC offset of 5 % and a linear drift of 10 % of each channel's peak;
- ``hum50``: a 50 Hz line of 1 % of each channel's peak;
- ``spikes``: ten +-50 g samples in every channel of every run, at random times;
- ``foreign``: the middle run replaced by another test's record: the same structure swept over
  the band above the hint's (same rate and length), simulated at the manifest's ``truth`` with
  white noise of the base channel's level (time-reversed, i.e. a down-sweep, when the data set
  has no model or truth).

The table lists, per fault, each finding: check, run, channel, size and action. With
``--identify`` each faulty set also goes through ``freeplayid.identify`` with the record checks
off (``records=None``: the records as they are) and the table gains the delta / kn errors
against ``truth`` and the verdict (or the one-line error), and ``identify_checked`` the same
with the checks on (``identify``'s default: the repaired records, the rejected runs left out
with their reasons, ``suspect`` with the checks' reasons; the first reason shown)
(``--identify as_is`` or ``checked`` for one of them).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import yaml

from freeplayid.io import read_dataset, write_dataset
from freeplayid.model import load_system
from freeplayid.quality import check_records
from freeplayid.quantity import G

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "fin_sweeps"
SEED = 28


# ---------------------------------------------------------------------------- faults
def _peaks(run):
    return np.max(np.abs(run.data - np.median(run.data, axis=1, keepdims=True)), axis=1)


def clip(ds, share: float, runs=None):
    """Clip each response channel at ``share`` of its peak, in ``runs`` (indices) or all."""
    keep = range(len(ds.runs)) if runs is None else runs
    new = []
    for i, r in enumerate(ds.runs):
        if i in keep:
            c = share * _peaks(r)[:, None]
            r = replace(r, data=np.clip(r.data, -c, c))
        new.append(r)
    return replace(ds, runs=tuple(new))


def _jump_index(ds, run) -> int:
    """Sample of the strongest channel's largest 2-s RMS (the resonance, just before the drop)."""
    x = run.data - (run.base if run.base is not None else 0.0)
    k = max(1, int(2 * ds.sample_rate))
    power = np.array([np.convolve(row * row, np.ones(k) / k, mode="same") for row in x])
    return int(np.argmax(power.max(axis=0)))


def zeros_at_jump(ds, seconds: float = 0.5):
    new = []
    for r in ds.runs:
        k = _jump_index(ds, r) + int(0.5 * ds.sample_rate)  # the drop follows the peak
        h = int(round(0.5 * seconds * ds.sample_rate))
        data = r.data.copy()
        data[:, k - h:k + h] = 0.0
        base = None if r.base is None else r.base.copy()
        if base is not None:
            base[k - h:k + h] = 0.0
        new.append(replace(r, data=data, base=base))
    return replace(ds, runs=tuple(new))


def declared_rate(ds, factor: float = 2000 / 2048):
    fs = ds.sample_rate * factor
    runs = tuple(replace(r, time=np.arange(r.time.size) / fs) for r in ds.runs)
    return replace(ds, sample_rate=fs, runs=runs)


def swapped(ds):
    cols = list(ds.channels)
    dofs = [ds.channels[c] for c in cols]
    dofs[0], dofs[1] = dofs[1], dofs[0]
    return replace(ds, channels=dict(zip(cols, dofs, strict=True)))


def no_base_ms2(ds):
    """No base channel, and the values in g declared as m/s^2."""
    to_g = ds.si_scale / G
    runs = tuple(replace(r, data=r.data * to_g, base=None) for r in ds.runs)
    return replace(ds, runs=runs, base_channel=None, units="m/s^2")


def _each_signal(ds, fn):
    """Apply ``fn(x, t, peak, rng)`` to every channel and the base of every run."""
    rng = np.random.default_rng(SEED)
    new = []
    for r in ds.runs:
        t = np.arange(r.time.size) / ds.sample_rate
        data = np.array([fn(x, t, p, rng) for x, p in zip(r.data, _peaks(r), strict=True)])
        base = r.base
        if base is not None:
            base = fn(base, t, float(np.max(np.abs(base))), rng)
        new.append(replace(r, data=data, base=base))
    return replace(ds, runs=tuple(new))


def drift(ds):
    return _each_signal(ds, lambda x, t, p, rng: x + p * (0.05 + 0.10 * t / t[-1]))


def hum(ds, f_hz: float = 50.0):
    return _each_signal(ds, lambda x, t, p, rng: x + 0.01 * p * np.sin(2 * np.pi * f_hz * t + 1))


def spikes(ds, count: int = 10, size_g: float = 50.0):
    size = size_g * G / ds.si_scale  # in the data's units

    def add(x, t, p, rng):
        y = x.copy()
        k = rng.choice(np.arange(50, x.size - 50), count, replace=False)
        y[k] += size * rng.choice([-1.0, 1.0], count)
        return y
    return _each_signal(ds, add)


def foreign(ds):
    """The middle run replaced by another test's record (module docstring)."""
    i = len(ds.runs) // 2
    r = ds.runs[i]
    if ds.model is None or not ds.truth or not r.sweep or "rate_hz_per_s" not in r.sweep:
        other = replace(r, data=r.data[:, ::-1].copy(),
                        base=None if r.base is None else r.base[::-1].copy())
    else:
        other = _simulated_other(ds, r)
    runs = list(ds.runs)
    runs[i] = other
    return replace(ds, runs=tuple(runs))


def _simulated_other(ds, run):
    from freeplayid.quality.context import Records
    from freeplayid.quality.options import RecordCheckOptions
    from freeplayid.simulate import Sweep, simulate_sweeps

    h = run.sweep
    width = abs(h["stop_hz"] - h["start_hz"])
    sweep = Sweep(max(h["start_hz"], h["stop_hz"]), max(h["start_hz"], h["stop_hz"]) + width,
                  h["rate_hz_per_s"])
    res = simulate_sweeps(load_system(ds.model), kn=ds.truth["kn"], delta=ds.truth["delta"],
                          level_g=[run.level_g or 1.0], sweep=sweep,
                          channels=list(ds.channels.values()), quantity=ds.quantity,
                          frame="absolute", sample_rate=ds.sample_rate, engine="expo",
                          progress=False)
    rec = Records(ds, None, RecordCheckOptions(checks=()))
    noise = rec.noise(rec.runs[0], -1 if run.base is not None else 0)
    rng = np.random.default_rng(SEED)
    n = min(res.time.size, run.time.size)
    data = res.signals[0][:, :n] / ds.si_scale + rng.normal(0, noise, (len(ds.channels), n))
    base = None
    if run.base is not None:
        base = sweep.acceleration(res.time[:n], run.level_g or 1.0) / ds.si_scale
        base = base + rng.normal(0, noise, n)
    return replace(run, time=run.time[:n], data=data, base=base)


FAULTS = {
    "clip80_all": lambda ds: clip(ds, 0.8),
    "clip70_all": lambda ds: clip(ds, 0.7),
    "clip70_two": lambda ds: clip(ds, 0.7, runs=(len(ds.runs) - 2, len(ds.runs) - 1)),
    "zeros_at_jump": zeros_at_jump,
    "rate_2000": declared_rate,
    "swapped": swapped,
    "no_base_ms2": no_base_ms2,
    "drift": drift,
    "hum50": hum,
    "spikes": spikes,
    "foreign": foreign,
}


# ---------------------------------------------------------------------------- running
def write_faulty(ds, folder: Path, source: Path) -> Path:
    """Write ``ds`` as a data set folder (model and reference modes copied from ``source``)."""
    system = load_system(ds.model) if ds.model else None
    manifest = write_dataset(folder, name=f"{ds.name} (faulty)", quantity=ds.quantity,
                             units=ds.units, sample_rate=ds.sample_rate, channels=ds.channels,
                             runs=ds.runs, system=system, base_channel=ds.base_channel,
                             truth=ds.truth, float_format="%.6g", time_format="%.7f")
    original = yaml.safe_load(source.read_text())
    if "reference_modes" in original:
        m = yaml.safe_load(manifest.read_text())
        m["reference_modes"] = original["reference_modes"]
        manifest.write_text(yaml.safe_dump(m, sort_keys=False))
    return manifest


def identify_errors(data, truth, *, checked: bool = False) -> dict:
    """delta / kn errors [%] against ``truth`` and the verdict, or the one-line error, for a
    data set (its manifest's path, or a Dataset read from one), with the record checks on
    (``checked``) or off; the only call of the identification API here."""
    from freeplayid import InputError, identify
    from freeplayid.quality import RecordCheckOptions

    try:
        res = identify(data, progress=False,
                       records=RecordCheckOptions() if checked else None)
    except InputError as exc:
        return {"error": str(exc).splitlines()[0]}
    verdict = getattr(res, "verdict", None)
    out = {"verdict": getattr(verdict, "status", str(verdict)),
           "reasons": "; ".join(getattr(verdict, "reasons", ()))}
    if truth:
        out["delta_err_%"] = 100 * (res.delta / truth["delta"] - 1)
        out["kn_err_%"] = 100 * (res.kn / truth["kn"] - 1)
    return out


def run_fault(name: str, ds, source: Path, tmp: Path, *, with_identify: str | None) -> dict:
    faulty = FAULTS[name](ds) if name != "clean" else ds
    manifest = write_faulty(faulty, tmp / name, source)
    back = read_dataset(manifest)
    system = load_system(back.model) if back.model else None
    t0 = time.perf_counter()
    report = check_records(back, system)
    out = {"fault": name, "report": report, "seconds": time.perf_counter() - t0}
    if with_identify in ("both", "as_is"):
        out["identify"] = identify_errors(manifest, ds.truth)
    if with_identify in ("both", "checked"):
        out["identify_checked"] = identify_checked(manifest, ds.truth)
    return out


def identify_checked(manifest, truth) -> dict:
    """What the identification gives with the record checks wired in (``identify``'s default):
    the repaired records, the rejected runs left out, ``suspect`` with the checks' reasons
    first (they lead the verdict's checks)."""
    return identify_errors(manifest, truth, checked=True)


def _table(results, markdown: bool) -> str:
    head = ["fault", "check", "run", "channel", "size", "action"]
    rows = []
    for r in results:
        fs = r["report"].findings or [None]
        for f in fs:
            rows.append([r["fault"], *(("(nothing)", "", "", "", "") if f is None else
                                       (f.check, f.run or "all", f.channel or "all",
                                        f.size_text(), f.action))])
        for key in ("identify", "identify_checked"):
            if key in r:
                rows.append([r["fault"], key, "", "", "", _identify_text(r[key])])
    if markdown:
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])
    widths = [max(len(str(x)) for x in col) for col in zip(head, *rows, strict=True)]
    fmt = "  ".join(f"{{:{w}}}" for w in widths)
    return "\n".join([fmt.format(*head)] + [fmt.format(*row) for row in rows])


def _merged(results) -> str:
    """Markdown: one row per (fault, check, action), its runs, channels and size range."""
    rows = []
    for r in results:
        groups: dict = {}
        for f in r["report"].findings:
            groups.setdefault((f.check, f.action), []).append(f)
        if not groups:
            rows.append([r["fault"], "(nothing)", "", "", "", ""])
        for (check, action), fs in groups.items():
            runs = sorted({f.run or "all" for f in fs})
            chans = sorted({f.channel or "all" for f in fs})
            sizes = [f.size for f in fs if np.isfinite(f.size)]
            unit = fs[0].unit
            size = ("-" if not sizes else f"{min(sizes):.3g} {unit}" if min(sizes) == max(sizes)
                    else f"{min(sizes):.3g} to {max(sizes):.3g} {unit}")
            rows.append([r["fault"], check, action,
                         f"{len(runs)} runs" if len(runs) > 2 else ", ".join(runs),
                         ", ".join(chans), size.strip()])
        for key in ("identify", "identify_checked"):
            if key in r:
                rows.append([r["fault"], key, _identify_text(r[key]), "", "", ""])
    head = ["fault", "check", "action", "runs", "channels", "size"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def _identify_text(d: dict) -> str:
    if "error" in d:
        return f"error: {d['error'][:120]}"
    errs = (f"delta {d['delta_err_%']:+.2f} %, kn {d['kn_err_%']:+.2f} %, "
            if "kn_err_%" in d else "")
    why = f" ({d['reasons'][:100]})" if d.get("reasons") else ""
    return f"{errs}{d['verdict']}{why}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="?", default=str(EXAMPLE), help="clean data set (folder or "
                    "manifest.yaml)")
    ap.add_argument("--faults", nargs="+", default=["clean", *FAULTS],
                    choices=["clean", *FAULTS], help="faults to apply (default all, and clean)")
    ap.add_argument("--identify", nargs="?", const="both", default=None,
                    choices=["both", "as_is", "checked"],
                    help="also identify each faulty set: as it is, with the checks' actions "
                    "taken, or both (default)")
    ap.add_argument("--markdown", action="store_true", help="print a Markdown table")
    ap.add_argument("--merged", action="store_true", help="print one Markdown row per fault, "
                    "check and action")
    args = ap.parse_args()
    path = Path(args.data)
    source = path if path.suffix in (".yaml", ".yml") else path / "manifest.yaml"
    ds = read_dataset(source)
    results = []
    with tempfile.TemporaryDirectory(prefix="faults-") as tmp:
        for name in args.faults:
            results.append(run_fault(name, ds, source, Path(tmp), with_identify=args.identify))
    print(_merged(results) if args.merged else _table(results, args.markdown))
    slowest = max(results, key=lambda r: r["seconds"])
    print(f"\ncheck_records: {sum(r['seconds'] for r in results):.1f} s in all, slowest "
          f"{slowest['seconds']:.1f} s ({slowest['fault']})")


if __name__ == "__main__":
    main()

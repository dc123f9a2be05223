"""Regenerate the controller-export samples ``examples/exports/`` (a second; tiny files).

    PYTHONPATH=src python examples/exports/make_exports.py [--out examples/exports]

One short sweep run (512 samples: 2 s at 256 Hz, 30 -> 46 Hz at 8 Hz/s, base 0.6 g), the same
numbers written in each layout a vibration controller exports, one data-set folder per layout
(docs/identify.md, "Exporting from your controller"):

    reference/     plain CSV: ',' delimited, '.' decimal, one header row (the default layout)
    csv_semicolon/ ';' delimited, decimal comma, a preamble and a units row   (csv: block)
    mat_v5/        MATLAB v5: TimeData (time x channels), ChanName, Unit, hDelta   (mat: block)
    mat_v73/       MATLAB v7.3 (HDF5): the same variables, channels x time
    uff/           UFF 58 (ASCII), one "Time Response" record per channel, chosen by node:direction
    uff_58b/       UFF 58b (binary), the same records
    tdms/          NI TDMS, waveform channels with unit_string

Every file states its units (g; time in s), which the reader checks against the manifest. The
files are written here with scipy.io, h5py, pyuff and npTDMS in each format's own layout, not by
freeplayid, so the tests that read them (tests/test_io_exports.py) check the readers against
files they did not write. The v7.3 file is laid out as MATLAB lays one out (variables as HDF5
datasets transposed, cell arrays as references into ``#refs#``, chars as UTF-16 codes, the
512-byte MATLAB header).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import yaml

FS = 256.0  # sample rate [Hz]
N = 512  # samples: 2 s
SWEEP = {"start_hz": 30.0, "stop_hz": 46.0, "rate_hz_per_s": 8.0}  # [Hz], [Hz], [Hz/s]
LEVEL_G = 0.6  # base amplitude [g]
F_N, ZETA = 42.0, 0.03  # a resonance in the band [Hz], its damping ratio [-]
CHANNELS = {"acc_tl": "uz_top_left", "acc_lr": "uz_lower_right"}  # column -> model DOF
BASE = "acc_base"
MODEL = "../../fin_sweeps/model.npz"  # the bundled example's fin, relative to each manifest
# UFF: the records as a controller numbers them (node, direction +Z = 3)
NODES = {"acc_tl": (101, 3), "acc_lr": (102, 3), BASE: (1, 3)}


def signals() -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The run: time [s] and each column [g] (base; two responses with a resonance at 42 Hz,
    the steady-state transmissibility of a damped oscillator along the sweep)."""
    t = np.arange(N) / FS
    f = SWEEP["start_hz"] + SWEEP["rate_hz_per_s"] * t
    phase = 2 * np.pi * (SWEEP["start_hz"] * t + 0.5 * SWEEP["rate_hz_per_s"] * t**2)
    r = f / F_N
    h = (1 + 2j * ZETA * r) / (1 - r**2 + 2j * ZETA * r)  # base -> absolute acceleration
    base = LEVEL_G * np.sin(phase)
    return t, {"acc_tl": LEVEL_G * np.abs(h) * np.sin(phase + np.angle(h)),
               "acc_lr": 0.4 * LEVEL_G * np.abs(h) * np.sin(phase + np.angle(h) + 0.2),
               BASE: base}


def manifest(folder: Path, run: str, *, channels=None, base=BASE, **blocks) -> None:
    m = {"name": f"controller export sample: {folder.name} (examples/exports/make_exports.py)",
         "model": MODEL, "quantity": "acceleration", "units": "g", "sample_rate": FS,
         "channels": channels or dict(CHANNELS), "base_channel": base, **blocks,
         "runs": [{"file": run, "level_g": LEVEL_G, "sweep": dict(SWEEP)}]}
    (folder / "manifest.yaml").write_text(yaml.safe_dump(m, sort_keys=False, width=100))


def write_reference(folder: Path, t, cols) -> None:
    names = ["time", *cols]
    np.savetxt(folder / "sweep.csv", np.column_stack([t, *cols.values()]), delimiter=",",
               header=",".join(names), comments="", fmt=["%.9g"] * len(names))
    manifest(folder, "sweep.csv")


def write_csv_semicolon(folder: Path, t, cols) -> None:
    """A German-locale export: preamble, ';', decimal comma, a units row, CRLF."""
    names = ["time", *cols]
    lines = ["Controller export;sine sweep", f"Level;{LEVEL_G:g} g".replace(".", ","),
             ";".join(names), ";".join(["[s]"] + ["[g]"] * len(cols))]
    for k in range(t.size):
        row = [f"{t[k]:.9g}"] + [f"{cols[c][k]:.9g}" for c in cols]
        lines.append(";".join(v.replace(".", ",") for v in row))
    (folder / "sweep.csv").write_bytes(("\r\n".join(lines) + "\r\n").encode("latin-1"))
    manifest(folder, "sweep.csv",
             csv={"delimiter": ";", "decimal": ",", "units_row": True, "skip_rows": 2})


def _matlab_cell(strings) -> np.ndarray:
    out = np.empty((1, len(strings)), dtype=object)
    out[0, :] = [np.array([s]) for s in strings]
    return out


MAT_BLOCK = {"data": "TimeData", "names": "ChanName", "units": "Unit", "increment": "hDelta"}


def write_mat_v5(folder: Path, t, cols) -> None:
    import scipy.io

    names = list(cols)
    scipy.io.savemat(folder / "sweep.mat", {
        "TimeData": np.column_stack([cols[c] for c in names]),  # time x channels
        "ChanName": _matlab_cell(names), "Unit": _matlab_cell(["g"] * len(names)),
        "hDelta": np.array([[1 / FS]]), "Comment": "freeplayid sample export"}, format="5")
    manifest(folder, "sweep.mat", mat=dict(MAT_BLOCK))


def write_mat_v73(folder: Path, t, cols) -> None:
    import h5py

    names = list(cols)
    path = folder / "sweep.mat"
    with h5py.File(path, "w", userblock_size=512) as f:
        refs = f.create_group("#refs#")

        def chars(group, name, text):
            d = group.create_dataset(name, data=np.array([ord(c) for c in text],
                                                         dtype=np.uint16)[:, None])
            d.attrs["MATLAB_class"] = np.bytes_("char")
            d.attrs["MATLAB_int_decode"] = np.int32(2)
            return d

        def cell(name, strings):
            items = [chars(refs, f"{name}_{k}", s).ref for k, s in enumerate(strings)]
            d = f.create_dataset(name, data=np.array(items, dtype=h5py.ref_dtype)[:, None])
            d.attrs["MATLAB_class"] = np.bytes_("cell")

        def double(name, value):  # MATLAB's column-major array: HDF5 holds its transpose
            d = f.create_dataset(name, data=np.atleast_2d(np.asarray(value, dtype=float)).T)
            d.attrs["MATLAB_class"] = np.bytes_("double")

        double("TimeData", np.vstack([cols[c] for c in names]))  # channels x time
        cell("ChanName", names)
        cell("Unit", ["g"] * len(names))
        double("hDelta", 1 / FS)
    text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created by: examples/exports HDF5 schema 1.00"
    with open(path, "r+b") as fh:  # MATLAB's header: text, subsystem offset, version, endian
        fh.write(text.ljust(116) + bytes(8) + b"\x00\x02IM")
    manifest(folder, "sweep.mat", mat=dict(MAT_BLOCK))


def write_uff(folder: Path, t, cols, *, binary: bool) -> None:
    import pyuff

    path = folder / "sweep.uff"
    path.unlink(missing_ok=True)  # pyuff adds to an existing file
    uff = pyuff.UFF(str(path))
    for c, x in cols.items():
        node, direction = NODES[c]
        uff.write_sets(pyuff.prepare_58(
            binary=int(binary), id1="Time Response", id2=c, id3="", id4="", id5="",
            func_type=1, ver_num=0, load_case_id=0, rsp_ent_name="fin", rsp_node=node,
            rsp_dir=direction, ref_ent_name="none", ref_node=0, ref_dir=0, data=x, x=t,
            abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=1 / FS,
            abscissa_spec_data_type=17, abscissa_axis_units_lab="s",
            ordinate_spec_data_type=12, ordinate_axis_units_lab="g",
            orddenom_spec_data_type=0, z_axis_spec_data_type=0), mode="add")
    by_node = {f"{NODES[c][0]}:+Z": dof for c, dof in CHANNELS.items()}
    manifest(folder, "sweep.uff", channels=by_node, base=f"{NODES[BASE][0]}:+Z")


def write_tdms(folder: Path, t, cols) -> None:
    from nptdms import ChannelObject, TdmsWriter

    props = {"wf_increment": 1 / FS, "wf_start_offset": 0.0, "wf_xunit_string": "s",
             "unit_string": "g"}
    with TdmsWriter(str(folder / "sweep.tdms")) as w:
        w.write_segment([ChannelObject("Acceleration", c, x, properties=props)
                         for c, x in cols.items()])
    manifest(folder, "sweep.tdms")


WRITERS = {
    "reference": write_reference,
    "csv_semicolon": write_csv_semicolon,
    "mat_v5": write_mat_v5,
    "mat_v73": write_mat_v73,
    "uff": lambda folder, t, cols: write_uff(folder, t, cols, binary=False),
    "uff_58b": lambda folder, t, cols: write_uff(folder, t, cols, binary=True),
    "tdms": write_tdms,
}


def main(out: Path | None = None) -> None:
    if out is None:
        ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
        ap.add_argument("--out", default=str(Path(__file__).parent))
        out = Path(ap.parse_args().out)
    t, cols = signals()
    for name, write in WRITERS.items():
        folder = Path(out) / name
        folder.mkdir(parents=True, exist_ok=True)
        write(folder, t, cols)
    print(f"wrote {len(WRITERS)} sample data sets under {out}")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Instrument files read by femto and by the field's own readers (issue 44).

`check(femto, workdir)` returns a list of failure messages (empty: every check passed):

(a) PicoQuant PTU: the real scan of ../shared/data/real/ptu and T3 image scans written here
    with `ptufile.imwrite` as PicoHarp and generic (MultiHarp; the HydraHarp 2 and
    TimeHarp 260 layout) records, 3 frames and 2 channels, a pixel time in the header: `femto ingest` must equal `ptufile`'s `decode_image(frame=-1,
    channel=-1)` count for count (and its peak bin); `--select frame=K` and `channel=C`
    must equal `decode_image(frame=K)` and `decode_image(channel=C)`.
(b) Delmic SPARC HDF5 (../shared/data/real/delmic): `femto ingest` must equal rosettasciio's
    `delmic.file_reader` (the time-resolved acquisition, wavelength summed or selected),
    its time axis within 1e-6 of a bin.
(c) Time-first arrays: the real MATLAB v7.3 scans of ../shared/data/real/cdt read with
    h5py, a v5 `.mat` written with `scipy.io.savemat` (time first), an HDF5 dataset whose
    `DIMENSION_LABELS` (h5py `dims[i].label`) say (T, Y, X), and an `.npz`: femto refuses
    the unlabelled time-first ones naming `--time-axis` and reads them with it exactly as
    the reference reader indexes them; the labelled one is read without it.

Without ../shared (FEMTO_SHARED), (a)'s real file, (b) and (c)'s real files print
`skipped: <why>`; under CI=true that is a failure. Run alone:
`python3 tools/interop/instruments.py target/debug/femto` (needs numpy, h5py, scipy,
ptufile, rosettasciio).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np
import ptufile
import scipy.io
from rsciio import delmic

HERE = os.path.dirname(os.path.abspath(__file__))


def _shared() -> str:
    return os.environ.get("FEMTO_SHARED") or os.path.join(HERE, "..", "..", "..", "shared")


def _real(rel: str, failures: list[str]) -> str | None:
    path = os.path.join(_shared(), rel)
    if os.path.isfile(path):
        return path
    why = f"{path} not found (set FEMTO_SHARED)"
    if os.environ.get("CI") == "true":
        failures.append(f"CI=true and {why}")
    else:
        print(f"skipped: {why}")
    return None


def _run(femto: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([femto, *args], capture_output=True, text=True, timeout=600)


def _cube(path: str) -> tuple[np.ndarray, float, float]:
    """A femto cube as [y][x][t] counts, with t0_ps and dt_ps."""
    with h5py.File(path, "r") as f:
        d = f["cube"]
        return np.asarray(d[()], dtype=np.float64), float(d.attrs["t0_ps"]), float(d.attrs["dt_ps"])


def _ingest(femto: str, src: str, out: str, *args: str) -> tuple[np.ndarray, float, float] | str:
    r = _run(femto, "ingest", src, "-o", out, "--force", *args)
    if r.returncode != 0:
        return f"femto ingest {os.path.basename(src)} {' '.join(args)}: exit {r.returncode}: {r.stderr.strip()}"
    return _cube(out)


def _same(name: str, got, want: np.ndarray) -> list[str]:
    if isinstance(got, str):
        return [got]
    cube = got[0]
    if cube.shape != want.shape:
        return [f"{name}: shape {cube.shape}, the reference {want.shape}"]
    diff = int(np.count_nonzero(cube != want))
    peak_f, peak_r = int(cube.sum(axis=(0, 1)).argmax()), int(want.sum(axis=(0, 1)).argmax())
    print(f"{name}: {want.shape}, sum {cube.sum():.0f} (reference {want.sum():.0f}), "
          f"peak bin {peak_f} ({peak_r}), {diff} voxels differ")
    out = []
    if diff:
        out.append(f"{name}: {diff} voxels differ from the reference")
    if peak_f != peak_r:
        out.append(f"{name}: peak bin {peak_f}, the reference {peak_r}")
    return out


def _ptu_reference(path: str, **sel) -> tuple[np.ndarray, float]:
    """ptufile's histogram as [y][x][t], frames and channels summed unless selected."""
    with ptufile.PtuFile(path) as f:
        frame, channel = sel.get("frame", -1), sel.get("channel", -1)
        im = f.decode_image(frame=frame, channel=channel, dtype="uint32")
        return np.asarray(im[0, :, :, 0, :], dtype=np.float64), f.tcspc_resolution * 1e12


def check_ptu(femto: str, workdir: str) -> list[str]:
    failures: list[str] = []
    files = []
    real = _real("data/real/ptu/ptu_stack_FLIM_z1.ptu", failures)
    if real:
        files.append(("real FLIM scan", real, [("frame", 0), ("frame", 4)]))
    rng = np.random.default_rng(44)
    data = rng.poisson(0.6, size=(3, 16, 12, 2, 40)).astype(np.uint16)
    data[:, :, :, :, 7] += rng.poisson(4.0, size=(3, 16, 12, 2)).astype(np.uint16)
    # ptufile 2026.2.6 writes PicoHarp T3 and generic (MultiHarp) T3 records; asked for
    # HydraHarp2T3 it writes generic ones, which share the layout.
    for rt in ("PicoHarpT3", "GenericT3"):
        path = os.path.join(workdir, f"{rt}.ptu")
        try:
            ptufile.imwrite(path, data, 12.5e-9, 32e-12, record_type=getattr(ptufile.PtuRecordType, rt))
        except Exception as e:  # a record type this ptufile cannot write
            failures.append(f"ptufile.imwrite {rt}: {e}")
            continue
        files.append((rt, path, [("frame", 1), ("channel", 1)]))
    for name, path, selections in files:
        out = os.path.join(workdir, "ptu.h5")
        want, dt_ps = _ptu_reference(path)
        got = _ingest(femto, path, out)
        failures += _same(f"ptu {name}", got, want)
        if not isinstance(got, str) and abs(got[2] - dt_ps) > 1e-9 * dt_ps:
            failures.append(f"ptu {name}: bin width {got[2]} ps, ptufile {dt_ps}")
        for axis, k in selections:
            want_k, _ = _ptu_reference(path, **{axis: k})
            failures += _same(f"ptu {name} --select {axis}={k}",
                              _ingest(femto, path, out, "--select", f"{axis}={k}"), want_k)
    return failures


def check_delmic(femto: str, workdir: str) -> list[str]:
    failures: list[str] = []
    out = os.path.join(workdir, "delmic.h5")
    for rel in ("data/real/delmic/sparc-time-correlator-spot.h5",
                "data/real/delmic/sparc-streak-camera-spot.h5"):
        path = _real(rel, failures)
        if not path:
            continue
        sig = delmic.file_reader(path)[0]
        names = [a["name"] for a in sig["axes"]]
        data = np.asarray(sig["data"], dtype=np.float64)
        t_axis = sig["axes"][names.index("Time")]["axis"] * {"ns": 1e3, "ps": 1.0, "µs": 1e6}[
            sig["axes"][names.index("Time")]["units"]]
        # rosettasciio squeezes singletons and puts Time before Wavelength: one pixel.
        if "Wavelength" in names:
            summed = data.sum(axis=names.index("Wavelength"))
            one = np.take(data, 100, axis=names.index("Wavelength"))
            failures += _same(f"delmic {os.path.basename(path)} --select C=100",
                              _ingest(femto, path, out, "--select", "C=100"), one.reshape(1, 1, -1))
        else:
            summed = data
        got = _ingest(femto, path, out)
        failures += _same(f"delmic {os.path.basename(path)}", got, summed.reshape(1, 1, -1))
        if not isinstance(got, str):
            dt = (t_axis[-1] - t_axis[0]) / (len(t_axis) - 1)
            if abs(got[1] - t_axis[0]) > 1e-6 * dt or abs(got[2] - dt) > 1e-6 * dt:
                failures.append(f"delmic {os.path.basename(path)}: axis {got[1]} + {got[2]} ps, "
                                f"rosettasciio {t_axis[0]} + {dt} ps")
    return failures


def _refused(femto: str, src: str, out: str, *args: str, names=("--time-axis",)) -> list[str]:
    r = _run(femto, "ingest", src, "-o", out, *args)
    err = r.stderr.strip()
    bad = []
    if r.returncode != 2 or len(err.splitlines()) != 1 or not all(n in err for n in names):
        bad.append(f"{os.path.basename(src)} {' '.join(args)}: expected one line naming {names} "
                   f"and exit 2, got exit {r.returncode}: {err}")
    if os.path.exists(out):
        bad.append(f"{os.path.basename(src)}: {out} written by a refused ingest")
    return bad


def check_time_first(femto: str, workdir: str) -> list[str]:
    failures: list[str] = []
    out = os.path.join(workdir, "tf.h5")
    never = os.path.join(workdir, "never.h5")
    real = _real("data/real/cdt/letter_s.mat", failures)
    if real:
        with h5py.File(real, "r") as f:
            m = np.asarray(f["meas"][()], dtype=np.float64)  # h5py (x, y, t) of MATLAB (t, y, x)
        want = np.transpose(m, (1, 0, 2))  # MATLAB meas(t, i, j) -> cube[i][j][t]
        failures += _refused(femto, real, never, "--dt-ps", "16")
        failures += _same("cdt letter_s.mat --time-axis 0",
                          _ingest(femto, real, out, "--dt-ps", "16", "--time-axis", "0"), want)
    # scipy's v5 .mat, time first: MATLAB (t, y, x) = (64, 5, 7).
    rng = np.random.default_rng(7)
    a = rng.integers(0, 1000, size=(64, 5, 7)).astype(np.float64)
    mat = os.path.join(workdir, "tfirst.mat")
    scipy.io.savemat(mat, {"meas": a})
    failures += _refused(femto, mat, never, "--dt-ps", "4")
    failures += _same("scipy savemat (64, 5, 7) --time-axis 0",
                      _ingest(femto, mat, out, "--dt-ps", "4", "--time-axis", "0"),
                      np.transpose(a, (1, 2, 0)))
    # An HDF5 dataset labelled (T, Y, X) with h5py: read without --time-axis.
    h5 = os.path.join(workdir, "labelled.h5")
    with h5py.File(h5, "w") as f:
        d = f.create_dataset("counts", data=a.astype(np.uint32))
        for i, label in enumerate("TYX"):
            d.dims[i].label = label
        f["dt_ps"] = 4.0
    failures += _same("h5py DIMENSION_LABELS (T, Y, X)", _ingest(femto, h5, out),
                      np.transpose(a, (1, 2, 0)))
    # numpy.savez_compressed: two arrays, the data named with --dataset.
    npz = os.path.join(workdir, "scan.npz")
    np.savez_compressed(npz, data=a.transpose(1, 2, 0).astype(np.float32), t_ps=np.arange(64.0))
    failures += _refused(femto, npz, never, "--dt-ps", "4", names=("--dataset",))
    failures += _same("numpy savez_compressed --dataset data",
                      _ingest(femto, npz, out, "--dataset", "data", "--dt-ps", "4"),
                      np.transpose(a, (1, 2, 0)))
    return failures


def check(femto: str, workdir: str) -> list[str]:
    return check_ptu(femto, workdir) + check_delmic(femto, workdir) + check_time_first(femto, workdir)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        sys.exit(2)
    with tempfile.TemporaryDirectory() as tmp:
        found = check(os.path.abspath(sys.argv[1]), sys.argv[2] if len(sys.argv) > 2 else tmp)
    for m in found:
        print(f"FAIL {m}")
    sys.exit(1 if found else 0)

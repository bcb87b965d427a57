#!/usr/bin/env python3
"""Sparse-jitter check of `femto ingest` on a real capture (a development check, by hand).

The real confocal capture `data/real/lct/data_s_u.mat` (shared data; `rect_data`, 64 x 64 x
2048 uint16 counts, 4 ps bins; see data/real/FACTS.md) is written as 64 PNG16 scanline files,
scanline y = rect_data[y] (64 columns by 2048 time rows), with two scanlines shifted later by
a whole number of bins (np.roll along time, the bins rolled in set to zero): scanline 20 by 3
bins and scanline 41 by 2. They are ingested with the default flags

    femto ingest 'DIR/scan_*.png' --dt-ps 4 --t0-ps 0 -o DIR/cube.h5

and the cube's provenance notes are read back (h5py): `ingest.jitter_shifts_ps` (the shift
removed from each scanline, ps) and `ingest.jitter_std_errors_ps` (its standard error; null
where a row was not estimated). The check passes when the two shifts come back within 0.25
bin (1 ps) of 12 and 8 ps and no other scanline is moved by more than its standard error.

Usage: tools/sparse_jitter_check.py [FEMTO] [MAT] [DIR]
  FEMTO  the femto binary (default target/debug/femto)
  MAT    the capture (default ../shared/data/real/lct/data_s_u.mat)
  DIR    where to write the scanlines and the cube (default: a temporary folder)
Needs numpy, scipy, h5py and Pillow (e.g. /tmp/venv/bin/python). Exit status 0 = pass.
"""
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np
import scipy.io
from PIL import Image

SHIFTS_BINS = {20: 3, 41: 2}
DT_PS = 4.0
TOLERANCE_BINS = 0.25


def write_scanlines(mat: Path, out: Path) -> int:
    data = scipy.io.loadmat(mat)["rect_data"]  # (64, 64, 2048): y, x, t
    ny = data.shape[0]
    for y in range(ny):
        streak = np.ascontiguousarray(data[y].T.astype(np.uint16))  # [t][x]
        k = SHIFTS_BINS.get(y, 0)
        if k:
            streak = np.roll(streak, k, axis=0)
            streak[:k] = 0
        Image.fromarray(streak.astype(np.uint16)).save(out / f"scan_{y:03d}.png")
    return ny


def main() -> int:
    femto = sys.argv[1] if len(sys.argv) > 1 else "target/debug/femto"
    mat = Path(sys.argv[2] if len(sys.argv) > 2 else "../shared/data/real/lct/data_s_u.mat")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(sys.argv[3]) if len(sys.argv) > 3 else Path(tmp)
        out.mkdir(parents=True, exist_ok=True)
        ny = write_scanlines(mat, out)
        cube = out / "cube.h5"
        cmd = [femto, "ingest", str(out / "scan_*.png"), "--dt-ps", str(DT_PS), "--t0-ps", "0",
               "-o", str(cube)]
        run = subprocess.run(cmd, capture_output=True, text=True)
        print(run.stdout + run.stderr, end="")
        if run.returncode != 0:
            print(f"FAIL: femto ingest exited {run.returncode}")
            return 1
        with h5py.File(cube) as f:
            attrs = f["cube"].attrs
            shifts = json.loads(attrs["ingest.jitter_shifts_ps"])
            errors = json.loads(attrs["ingest.jitter_std_errors_ps"])
    ok = True
    for y in range(ny):
        s, e = shifts[y], errors[y]
        want = SHIFTS_BINS.get(y, 0) * DT_PS
        if y in SHIFTS_BINS:
            good = abs(s - want) <= TOLERANCE_BINS * DT_PS
            print(f"scanline {y}: shifted {want:.1f} ps, removed {s:.2f} +- "
                  f"{e if e is None else round(e, 2)} ps: {'ok' if good else 'WRONG'}")
        else:
            good = s == 0.0 or (e is not None and abs(s) <= e)
            if s != 0.0:
                print(f"scanline {y}: not shifted, moved {s:.2f} +- {e} ps: "
                      f"{'ok' if good else 'WRONG'}")
        ok &= good
    moved = sum(1 for y in range(ny) if y not in SHIFTS_BINS and shifts[y] != 0.0)
    print(f"{moved} unshifted scanlines moved; {'PASS' if ok else 'FAIL'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

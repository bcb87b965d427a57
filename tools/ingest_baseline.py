#!/usr/bin/env python3
"""Baseline for the ingest benchmark: the assembly femto ingest does, as a plain script.

Reads N streak images (16-bit PNG, [t][x]) with imageio, stacks them, scales to float32,
transposes to the cube layout [y][x][t] and writes an HDF5 cube with h5py, chunked and
compressed as femto writes it (docs/cube-format.md: chunks (1, cx, nt) of about 256 KiB,
shuffle + gzip level 4) with the required attributes. No corrections: this is the work
`femto ingest` does without correction flags.

Usage: ingest_baseline.py PATTERN N OUT.h5 [DT_PS] [T0_PS] [VALUE_PER_COUNT]
  PATTERN is a printf pattern, e.g. caps/scan_%04d.png
"""
import sys

import h5py
import imageio.v3 as iio
import numpy as np


def main():
    pattern, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    dt_ps = float(sys.argv[4]) if len(sys.argv) > 4 else 1.9
    t0_ps = float(sys.argv[5]) if len(sys.argv) > 5 else 0.0
    scale = float(sys.argv[6]) if len(sys.argv) > 6 else 1.0
    images = [iio.imread(pattern % y) for y in range(n)]
    stack = np.stack(images).astype(np.float32) * np.float32(scale)  # (ny, nt, nx)
    cube = np.ascontiguousarray(stack.transpose(0, 2, 1))  # (ny, nx, nt)
    ny, nx, nt = cube.shape
    # femto's chunk width: at most 256 KiB per chunk, balanced over the row.
    most = max(1, min(nx, 262144 // (4 * nt)))
    cx = -(-nx // -(-nx // most))
    with h5py.File(out, "w") as f:
        d = f.create_dataset(
            "cube", data=cube, chunks=(1, cx, nt), shuffle=True, compression="gzip",
            compression_opts=4,
        )
        d.attrs["t0_ps"] = t0_ps
        d.attrs["dt_ps"] = dt_ps
        d.attrs["time_frame"] = "camera"
        d.attrs["units"] = "arbitrary"
    print(f"wrote {out}: {ny} x {nx} x {nt}")


if __name__ == "__main__":
    main()

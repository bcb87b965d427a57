#!/usr/bin/env python3
"""Write the h5py fixtures of tests/container.rs (tests/data/h5py/), with h5py and numpy.

    python3 tools/make_h5py_fixtures.py target/debug/femto

- `annotated.h5`: a small cube written by femto (`femto simulate` at 8 x 6 pixels and
  `femto ingest`), then annotated by h5py as `tools/interop/h5.py` annotates (a group
  `/notes` with an attribute of every type h5py writes by default, a dataset with an
  attribute in it, root attributes). A femto file (superblock version 2 or 3) to which
  libhdf5 added old-style (symbol table) groups with version 1 object headers.
- `h5py_cube.h5`: a cube written by h5py alone following docs/cube-format.md (superblock
  version 0, every group a symbol table), annotated the same way.

The Rust tests copy them, add groups in place and check that no byte of the old file but
the superblock's changed; they need no Python.
"""

import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from interop.h5 import annotate  # noqa: E402


def main(argv):
    if len(argv) != 2:
        raise SystemExit(__doc__)
    femto = os.path.abspath(argv[1])
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    out = os.path.join(root, "tests", "data", "h5py")
    os.makedirs(out, exist_ok=True)
    with tempfile.TemporaryDirectory() as d:
        cap = os.path.join(d, "cap")
        subprocess.run([femto, "simulate", "--scene", "cube", "--size", "8x6", "--spp", "1",
                        "--out", cap], check=True, capture_output=True)
        annotated = os.path.join(out, "annotated.h5")
        subprocess.run([femto, "ingest", cap, "-o", annotated], check=True,
                       capture_output=True)
    annotate(annotated)
    ny, nx, nt = 3, 4, 16
    cube = (np.arange(ny * nx * nt, dtype=np.float32).reshape(ny, nx, nt) * 0.25 - 2.0)
    h5py_cube = os.path.join(out, "h5py_cube.h5")
    with h5py.File(h5py_cube, "w") as f:
        c = f.create_dataset("cube", data=cube, chunks=(1, nx, nt), shuffle=True,
                             compression="gzip")
        c.attrs["t0_ps"] = -10.0
        c.attrs["dt_ps"] = 2.0
        c.attrs["time_frame"] = "camera"
        c.attrs["units"] = "counts"
        f.create_dataset("mask", data=np.ones((ny, nx), dtype=np.uint8))
    annotate(h5py_cube)
    for p in (annotated, h5py_cube):
        print(f"{p}: {os.path.getsize(p)} bytes")


if __name__ == "__main__":
    main(sys.argv)

#!/usr/bin/env python3
"""Check by hand that femto cubes and h5py agree on docs/cube-format.md (not part of CI).

Needs h5py and numpy (pip install h5py numpy) and a built femto binary.

    python3 tools/h5py_roundtrip.py target/debug/femto [FEMTO_CUBE.h5 ...]

1. Writes cubes with h5py exactly as the documentation tells a Python user to (chunked and
   compressed, and plain contiguous), runs `femto info --json` on them and checks that femto
   reports the shape, time axis, frame, units, value range and mask that numpy computes.
2. For each FEMTO_CUBE.h5 given (written by femto), reads it with h5py following the
   documentation, checks the schema (types, shapes, attributes, group attribute index) and
   that numpy's value range and valid-pixel count equal what `femto info --json` reports.
"""

import json
import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np


def femto_info(femto, path):
    out = subprocess.run([femto, "info", path, "--json"], capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"femto info {path} failed: {out.stderr.strip()}")
    return json.loads(out.stdout)


def expect(cond, what):
    if not cond:
        raise SystemExit(f"FAIL: {what}")
    print(f"ok   {what}")


def h5py_to_femto(femto, folder):
    ny, nx, nt = 5, 7, 9
    y, x, t = np.meshgrid(np.arange(ny), np.arange(nx), np.arange(nt), indexing="ij")
    cube = ((y * 1000 + x * 10 + t) * 0.5 - 3.0).astype(np.float32)
    mask = (np.arange(ny * nx).reshape(ny, nx) % 3 != 0).astype(np.uint8)
    for name, kwargs in [
        ("documented.h5", dict(chunks=(1, nx, nt), shuffle=True, compression="gzip")),
        ("contiguous.h5", {}),
    ]:
        path = os.path.join(folder, name)
        with h5py.File(path, "w") as f:
            d = f.create_dataset("cube", data=cube, **kwargs)
            d.attrs["t0_ps"] = -12.5
            d.attrs["dt_ps"] = 0.75
            d.attrs["time_frame"] = "world"
            d.attrs["units"] = "photons"
            d.attrs["operator"] = "h5py"
            f.create_dataset("mask", data=mask)
        j = femto_info(femto, path)
        expect(j["shape"] == {"ny": ny, "nx": nx, "nt": nt}, f"{name}: shape")
        expect(j["time_axis"]["t0_ps"] == -12.5 and j["time_axis"]["dt_ps"] == 0.75,
               f"{name}: time axis")
        expect(j["time_frame"] == "world" and j["units"] == "photons", f"{name}: frame, units")
        expect(j["value_range"] == {"min": float(cube.min()), "max": float(cube.max())},
               f"{name}: value range {j['value_range']}")
        expect(j["mask"] == {"valid_pixels": int(mask.sum()), "pixels": ny * nx},
               f"{name}: mask {j['mask']}")
        expect(j["femto_version"] is None and j["notes"] == {"operator": "h5py"},
               f"{name}: provenance")


def femto_to_h5py(femto, path):
    j = femto_info(femto, path)
    with h5py.File(path, "r") as f:
        d = f["cube"]
        expect(d.dtype == np.float32 and d.ndim == 3, f"{path}: /cube is float32, 3-D")
        ny, nx, nt = d.shape
        expect(j["shape"] == {"ny": ny, "nx": nx, "nt": nt}, f"{path}: shape {d.shape}")
        expect(d.chunks is not None and d.chunks[0] == 1 and d.chunks[2] == nt,
               f"{path}: chunks {d.chunks}")
        if d.attrs.get("ingest.compression") == "none":  # `femto ingest --compression none`
            expect(not d.shuffle and d.compression is None, f"{path}: no filter")
        else:
            expect(d.shuffle and d.compression == "gzip", f"{path}: shuffle + gzip")
        a = d.attrs
        for k in ["t0_ps", "dt_ps", "time_frame", "units", "femto_version", "command_line"]:
            expect(k in a, f"{path}: attribute {k} = {a[k]!r}")
        expect(isinstance(a["time_frame"], str) and a["time_frame"] in ("camera", "world"),
               f"{path}: time_frame is a str")
        expect(a["t0_ps"] == j["time_axis"]["t0_ps"] and a["dt_ps"] == j["time_axis"]["dt_ps"],
               f"{path}: time axis agrees with femto")
        cube = d[...]
        finite = cube[np.isfinite(cube)]
        expect(j["value_range"] == {"min": float(finite.min()), "max": float(finite.max())},
               f"{path}: numpy value range equals femto's {j['value_range']}")
        if "mask" in f:
            m = f["mask"]
            expect(m.dtype == np.uint8 and m.shape == (ny, nx), f"{path}: /mask u8 (ny, nx)")
            expect(j["mask"]["valid_pixels"] == int(np.count_nonzero(m[...])),
                   f"{path}: valid pixels agree")
        for g in j["groups"]:
            grp = f[g]
            index = json.loads(grp.attrs["_femto_attrs"])
            for name, typed in index:
                (kind, value), = typed.items()
                got = grp.attrs[name]
                if kind == "f64_array":
                    ok = np.allclose(got, [float(v) for v in value], equal_nan=True)
                elif kind == "f64":
                    ok = float(got) == float(value) or (np.isnan(got) and value == "NaN")
                else:
                    ok = got == value
                expect(ok, f"{path}: /{g} attribute {name} = {got!r} matches the index")
            for name, ds in grp.items():
                expect(ds.dtype in (np.float32, np.float64, np.uint8, np.uint32, np.int32),
                       f"{path}: /{g}/{name} {ds.dtype} {ds.shape}")
    return cube


def main():
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    femto = sys.argv[1]
    with tempfile.TemporaryDirectory() as folder:
        h5py_to_femto(femto, folder)
    for path in sys.argv[2:]:
        femto_to_h5py(femto, path)
    print("all checks passed")


if __name__ == "__main__":
    main()

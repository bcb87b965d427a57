#!/usr/bin/env python3
"""femto and h5py: a cube that h5py annotated keeps its annotations through femto's chain.

Needs h5py and numpy and a built femto binary. `check(femto, workdir)` returns failure
messages (empty: pass); `tools/interop_check.py` imports it, and it runs alone too:

    python3 tools/interop/h5.py target/debug/femto [WORKDIR]

What it does, with h5py's numbers as the reference:

1. simulates a small capture and ingests it (`femto simulate`, `femto ingest`);
2. annotates the cube with h5py as a user would: a group `/notes` with an attribute of
   every type h5py writes by default (str, int, float, numpy int and float arrays, bool,
   bytes, a list of str), a dataset in it with an attribute of its own, and a root
   attribute;
3. runs `femto info`, `calibrate`, `unwarp`, `pyramid` (on the camera cube and on the
   world cube) and `render`, each of which must succeed;
4. after every command that writes a cube or adds a group to one, reads the file with h5py
   and checks that every annotation is unchanged (value, type and shape), that the cube's
   values and attributes are unchanged (bit for bit; for `unwarp`'s new cube, its
   annotations), and that femto's own groups read with h5py give the numbers
   `femto info --json` reports.
"""

import json
import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np

try:
    import tomllib
except ImportError:  # Python < 3.11
    tomllib = None

NOTES = "notes"


def annotate(path):
    """Annotate the cube at `path` with h5py's defaults, as a user would."""
    with h5py.File(path, "a") as f:
        g = f.create_group(NOTES)
        g.attrs["operator"] = "Ada Lovelace, λ=795 nm"  # str: variable-length UTF-8
        g.attrs["run"] = 42  # int: int64
        g.attrs["exposure_s"] = 1.25e-3  # float: float64
        g.attrs["rois"] = np.array([[1, 2], [3, 4], [5, 6]], dtype=np.int64)
        g.attrs["gains"] = np.array([0.5, 1.0, np.pi])
        g.attrs["reviewed"] = True  # bool: an HDF5 enum of int8
        g.attrs["raw_header"] = b"HPD-TA 9.5"  # bytes: fixed-length ASCII
        g.attrs["tags"] = ["wall", "box", "laser"]  # list of str: variable-length array
        d = g.create_dataset("trace", data=np.linspace(-1.0, 1.0, 17))
        d.attrs["units"] = "volts"
        f.attrs["lab"] = "femto-lab"  # a root attribute
        f.attrs["version"] = np.int32(3)


def snapshot_attrs(obj):
    """Each attribute's type (numpy's, and for strings HDF5's character set and whether
    the length is variable), shape and value."""
    out = {}
    for k in obj.attrs:
        v = obj.attrs[k]
        aid = obj.attrs.get_id(k)
        htype = aid.get_type()
        kind = str(aid.dtype)
        if htype.get_class() == h5py.h5t.STRING:
            kind += f" cset {htype.get_cset()} vlen {htype.is_variable_str()}"
        if isinstance(v, np.ndarray):
            out[k] = (kind, v.shape, v.tolist())
        else:
            out[k] = (kind, (), v.item() if hasattr(v, "item") else v)
    return out


def snapshot(path, skip=()):
    """Every object of the file but `skip` (names of femto's own objects): its attributes,
    and a dataset's type, shape and values."""
    snap = {}
    with h5py.File(path, "r") as f:
        snap["/"] = ("group", snapshot_attrs(f))

        def visit(name, obj):
            if name.split("/")[0] in skip:
                return
            if isinstance(obj, h5py.Dataset):
                snap[name] = ("dataset", str(obj.dtype), obj.shape, obj[()].tolist(),
                              snapshot_attrs(obj))
            else:
                snap[name] = ("group", snapshot_attrs(obj))

        f.visititems(visit)
    return snap


def cube_arrays(path):
    with h5py.File(path, "r") as f:
        cube = f["cube"][()]
        mask = f["mask"][()] if "mask" in f else None
        attrs = snapshot_attrs(f["cube"])
    return cube, mask, attrs


def femto_run(femto, args, failures, what):
    out = subprocess.run([femto, *args], capture_output=True, text=True)
    if out.returncode != 0:
        failures.append(f"{what}: `femto {' '.join(args)}` exited {out.returncode}: "
                        f"{out.stderr.strip()}")
        return None
    return out.stdout


def compare_snapshots(before, after, what, failures):
    for key, val in before.items():
        if key not in after:
            failures.append(f"{what}: {key} is gone")
        elif after[key] != val:
            failures.append(f"{what}: {key} changed: {val!r} became {after[key]!r}")


def check_groups_against_info(femto, path, what, failures):
    """femto's groups of `path`, read with h5py, agree with `femto info --json`."""
    text = femto_run(femto, ["info", path, "--json"], failures, what)
    if text is None:
        return
    info = json.loads(text)
    cube = info.get("cube", info)
    with h5py.File(path, "r") as f:
        groups = sorted(k for k in f.keys() if isinstance(f[k], h5py.Group))
        if sorted(cube.get("groups", [])) != groups:
            failures.append(f"{what}: femto info lists groups {cube.get('groups')}, "
                            f"h5py {groups}")
        c = f["cube"]
        ny, nx, nt = c.shape
        shape = cube.get("shape", {})
        if (shape.get("ny"), shape.get("nx"), shape.get("nt")) != (ny, nx, nt):
            failures.append(f"{what}: femto info shape {shape}, h5py {(ny, nx, nt)}")
        data = c[()]
        vr = cube.get("value_range") or {}
        if vr and (np.float32(vr.get("min")) != data.min()
                   or np.float32(vr.get("max")) != data.max()):
            failures.append(f"{what}: femto info value range {vr}, h5py "
                            f"{data.min()}..{data.max()}")
        if "registration" in f:
            reg = f["registration"]
            summary = cube.get("registration") or {}
            if not summary:
                failures.append(f"{what}: femto info reports no registration")
            for name, ds in reg.items():
                v = ds[()]
                if not np.all(np.isfinite(v[np.isfinite(v)])):
                    failures.append(f"{what}: /registration/{name} unreadable")
            if "valid_pixels" in summary and "mask" in reg:
                n = int(np.count_nonzero(reg["mask"][()]))
                if n != summary["valid_pixels"]:
                    failures.append(f"{what}: /registration/mask has {n} valid pixels, "
                                    f"femto info says {summary['valid_pixels']}")
        if "pyramid" in f:
            pyr = f["pyramid"]
            summary = cube.get("pyramid") or {}
            if not summary:
                failures.append(f"{what}: femto info reports no pyramid")
            if "prefix" in pyr:
                # The prefix sums along time end, for each pixel, at the sum of its bins.
                prefix = pyr["prefix"][()]
                want = data.astype(np.float64).sum(axis=2)
                got = prefix.reshape(ny, nx, -1)[:, :, -1].astype(np.float64)
                err = np.max(np.abs(got - want) / np.maximum(1.0, np.abs(want)))
                if not err < 1e-4:
                    failures.append(f"{what}: /pyramid/prefix ends {err:.2e} away from "
                                    "the cube's sums over time")
            levels = summary.get("levels")
            if levels is not None:
                mips = [k for k in pyr.keys() if k.startswith("level")]
                if mips and len(mips) != levels:
                    failures.append(f"{what}: {len(mips)} mip datasets, femto info "
                                    f"says {levels} levels")


def laser_flag(cap):
    """`--laser=x,y,z` from the capture's true calibration (`[laser] position_m`), as
    tests/common/cli.rs `chain_after_capture` gives it."""
    text = open(os.path.join(cap, "calibration.toml"), "rb").read().decode()
    if tomllib is not None:
        laser = tomllib.loads(text)["laser"]["position_m"]
    else:  # the numbers of the array after `[laser]`, one a line
        block = text.split("[laser]", 1)[1].split("]", 1)[0].split("[", 1)[1]
        laser = [float(v) for v in block.replace("\n", " ").split(",") if v.strip()]
    return "--laser=" + ",".join(repr(float(v)) for v in laser)


def check(femto: str, workdir: str) -> list[str]:
    """Build an h5py-annotated cube in `workdir`, run femto's chain on it, compare with
    h5py. Returns failure messages; empty means pass."""
    failures = []
    femto = os.path.abspath(femto)
    cap = os.path.join(workdir, "cap")
    cube = os.path.join(workdir, "cube.h5")
    world = os.path.join(workdir, "world.h5")
    if femto_run(femto, ["simulate", "--scene", "cube", "--size", "32x24", "--spp", "4",
                         "--out", cap], failures, "simulate") is None:
        return failures
    if femto_run(femto, ["ingest", cap, "-o", cube], failures, "ingest") is None:
        return failures
    annotate(cube)
    own = ("cube", "mask", "registration", "pyramid")
    notes = snapshot(cube, skip=own)
    data0, mask0, attrs0 = cube_arrays(cube)

    def cube_unchanged(what):
        data, mask, attrs = cube_arrays(cube)
        if data.tobytes() != data0.tobytes():
            failures.append(f"{what}: the cube's values changed")
        if (mask is None) != (mask0 is None) or (
                mask is not None and mask.tobytes() != mask0.tobytes()):
            failures.append(f"{what}: the cube's mask changed")
        if attrs != attrs0:
            failures.append(f"{what}: the cube's attributes changed: {attrs0} -> {attrs}")

    if femto_run(femto, ["info", cube], failures, "info") is None:
        return failures
    steps = [
        ("calibrate", cube, ["calibrate", cube, "--mesh", os.path.join(cap, "scene.glb"),
                             "--points", os.path.join(cap, "fiducials.toml"),
                             laser_flag(cap)]),
        ("unwarp", world, ["unwarp", cube, "--out", world]),
        ("pyramid", cube, ["pyramid", cube]),
        ("pyramid of the world cube", world, ["pyramid", world]),
        ("pyramid again (replacing the group)", cube, ["pyramid", cube, "--levels", "2"]),
    ]
    for what, out, args in steps:
        if femto_run(femto, args, failures, what) is None:
            continue
        compare_snapshots(notes, snapshot(out, skip=own), what, failures)
        if out == cube:
            cube_unchanged(what)
        check_groups_against_info(femto, out, what, failures)
    frames = os.path.join(workdir, "frames")
    femto_run(femto, ["render", "--cube", world, "--calibration",
                      os.path.join(workdir, "cube.calibration.toml"), "--mesh",
                      os.path.join(cap, "scene.glb"), "--capture-view", "--frame-count", "2",
                      "--out", frames], failures, "render")
    compare_snapshots(notes, snapshot(cube, skip=own), "after render", failures)
    return failures


def main(argv):
    if len(argv) < 2:
        raise SystemExit(__doc__)
    femto = argv[1]
    if len(argv) > 2:
        os.makedirs(argv[2], exist_ok=True)
        failures = check(femto, argv[2])
    else:
        with tempfile.TemporaryDirectory() as d:
            failures = check(femto, d)
    for f in failures:
        print(f"FAIL: {f}")
    print("h5py interop: " + ("pass" if not failures else f"{len(failures)} failures"))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

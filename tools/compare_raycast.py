#!/usr/bin/env python3
"""Ray casting alone: femto's BVH against Embree (the ray caster inside Mitsuba 3's LLVM
variants) on the very same rays, 1 and 2 threads.

Usage:
    python3 tools/compare_raycast.py [../shared/data/stanford-bunny.obj]

The cornell meshes are femto's built-in scene as OBJ files, tools/scenes/tuned_cornell/.

Ray sets (640 x 480 rays each, seed 7):
* cornell, interior: uniform origins in the box shrunk by 10 % about its centre, uniform
  directions: the incoherent bounce rays of a path tracer inside a closed room;
* bunny, random (when the OBJ is given): from uniform points of the bounding sphere towards
  uniform points of the bounding box, as in benches/bvh.rs.

The rays are written to a file that `target/release/examples/raycast` reads, so both casters
trace identical rays; hit counts are printed to show they agree. Embree is timed through
`scene.ray_intersect_preliminary` on the whole wavefront (Mitsuba's own per-call overhead
included, as in a Mitsuba render). Needs `pip install mitsuba` and, for drjit's LLVM backend,
DRJIT_LIBLLVM_PATH pointing at libLLVM >= 16.
"""

import glob
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

N = 640 * 480


def unit(v):
    return v / np.linalg.norm(v, axis=1)[:, None]


def sphere_dirs(rng, n):
    out = []
    while sum(len(o) for o in out) < n:
        v = rng.uniform(-1, 1, (2 * n, 3))
        r = np.linalg.norm(v, axis=1)
        out.append(unit(v[(r > 0.1) & (r <= 1)]))
    return np.concatenate(out)[:n]


def bounds(files):
    pts = []
    for f in files:
        for line in open(f):
            if line.startswith("v "):
                pts.append([float(x) for x in line.split()[1:4]])
    p = np.array(pts)
    return p.min(axis=0), p.max(axis=0)


def interior_rays(lo, hi, rng):
    c, h = 0.5 * (lo + hi), 0.45 * (hi - lo)
    return rng.uniform(c - h, c + h, (N, 3)), sphere_dirs(rng, N)


def sphere_to_box_rays(lo, hi, rng):
    c, rad = 0.5 * (lo + hi), 0.5 * np.linalg.norm(hi - lo)
    o = c + sphere_dirs(rng, N) * rad
    return o, unit(rng.uniform(lo, hi, (N, 3)) - o)


def embree(files, o, d, threads, mi, dr):
    dr.set_thread_count(threads)
    scene = mi.load_dict({"type": "scene", **{f"m{i}": {"type": "obj", "filename": f, "face_normals": True}
                                              for i, f in enumerate(files)}})
    ray = mi.Ray3f(mi.Point3f(*(o[:, k].astype(np.float32) for k in range(3))),
                   mi.Vector3f(*(d[:, k].astype(np.float32) for k in range(3))))
    dr.eval(ray)
    best, cpu_total, hits = float("inf"), 0.0, 0
    for k in range(9):
        t0, c0 = time.perf_counter(), time.process_time()
        count = dr.count(scene.ray_intersect_preliminary(ray).is_valid())
        dr.eval(count)
        dr.sync_thread()
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        if k > 0:  # the first pass compiles the kernel
            best, cpu_total = min(best, wall), cpu_total + cpu
        hits = int(np.array(count).ravel()[0])
    print(f"embree {threads} thr: {len(o)} rays, {hits} hits, best {best:.4f} s, {len(o) / best / 1e6:.2f} Mrays/s wall, "
          f"{8 * len(o) / cpu_total / 1e6:.2f} Mrays per CPU s")


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    cornell = sorted(glob.glob(os.path.join(here, "scenes", "tuned_cornell", "*.obj")))
    sets = [("cornell, interior rays", cornell, interior_rays)]
    if len(sys.argv) > 1:
        sets.append(("bunny, sphere-to-box rays", [sys.argv[1]], sphere_to_box_rays))
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    subprocess.run(["cargo", "build", "--quiet", "--release", "--example", "raycast"], cwd=root, check=True)
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_mono")
    print(f"Mitsuba {mi.__version__} (Embree {'3' if glob.glob(os.path.join(os.path.dirname(mi.__file__), 'libembree3*')) else '?'}), "
          f"load {os.getloadavg()[0]:.1f}")
    for name, files, make in sets:
        o, d = make(*bounds(files), np.random.default_rng(7))
        print(f"--- {name}")
        with tempfile.NamedTemporaryFile(suffix=".f32") as f:
            np.concatenate([o, d], axis=1).astype("<f4").tofile(f.name)
            subprocess.run([os.path.join(root, "target/release/examples/raycast"), f.name, *files], check=True)
        for threads in (1, 2):
            embree(files, o, d, threads, mi, dr)


if __name__ == "__main__":
    main()

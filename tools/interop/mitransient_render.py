"""mitransient (Mitsuba 3's transient renderer) into femto, numbers compared.

A tiny scene is rendered with mitransient's transient_path integrator (llvm_ad_rgb): a
diffuse 2 x 2 m plane at z = 0, seen from 2 m by a 16 x 16 perspective camera with a point
light at the camera centre, 32 bins of 0.05 m of optical path from 3.5 m, 4 spp. The array
(H, W, T, C) is saved with np.save and ingested with
`femto ingest render.npy --start-opl-m 3.5 --bin-width-opl-m 0.05 --channels mean|r`. h5py
reads the cube: values equal to the channels' mean (or R), t0_ps = 3.5 m / c, dt_ps =
0.05 m / c, camera clock; and the physics: the first lit bin of the image holds the first
arrival, light out to the plane's nearest point and back, 4.0 m / c = 13342.7 ps.

Needs LLVM >= 16 for Dr.Jit's LLVM backend: DRJIT_LIBLLVM_PATH names it (.ci/run installs
libllvm19 and sets it).
"""

import os
import subprocess

import h5py
import numpy as np

C_M_PER_PS = 2.99792458e-4
START_OPL_M, BIN_OPL_M, NT, SIZE = 3.5, 0.05, 32, 16


def render(path):
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    import mitransient  # noqa: F401  (registers the transient plugins)

    t = mi.ScalarTransform4f
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "transient_path", "max_depth": 2},
        "sensor": {
            "type": "perspective",
            "fov": 40,
            # mitransient counts optical path from the near plane: keep it at the centre.
            "near_clip": 1e-6,
            "to_world": t().look_at(origin=[0, 0, 2], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "transient_hdr_film", "width": SIZE, "height": SIZE,
                     "temporal_bins": NT, "start_opl": START_OPL_M, "bin_width_opl": BIN_OPL_M,
                     "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": 4},
        },
        "light": {"type": "point", "position": [0, 0, 2], "intensity": {"type": "uniform", "value": 1.0}},
        "plane": {"type": "rectangle", "bsdf": {"type": "diffuse"}},
    })
    _, transient = mi.render(scene, spp=4, seed=3)
    a = np.array(transient, dtype=np.float32)
    np.save(path, a)
    return a


def check(femto, workdir):
    failures = []
    npy = os.path.join(workdir, "render.npy")
    a = render(npy)
    if a.shape != (SIZE, SIZE, NT, 3):
        return [f"mitransient wrote {a.shape}, expected ({SIZE}, {SIZE}, {NT}, 3)"]
    for channels, want in (("mean", a.mean(axis=-1)), ("r", a[..., 0])):
        out = os.path.join(workdir, f"cube_{channels}.h5")
        p = subprocess.run([femto, "ingest", npy, "--start-opl-m", str(START_OPL_M), "--bin-width-opl-m",
                            str(BIN_OPL_M), "--channels", channels, "-o", out], capture_output=True, text=True)
        if p.returncode != 0:
            failures.append(f"femto ingest --channels {channels}: exit {p.returncode}: {p.stderr.strip()}")
            continue
        with h5py.File(out, "r") as f:
            cube = f["cube"][...]
            at = f["cube"].attrs
            t0, dt = float(at["t0_ps"]), float(at["dt_ps"])
            frame = at["time_frame"]
            frame = frame.decode() if isinstance(frame, bytes) else str(frame)
        err = float(np.abs(cube - want).max() / max(float(np.abs(want).max()), 1e-30)) if cube.shape == want.shape else None
        want_t0, want_dt = START_OPL_M / C_M_PER_PS, BIN_OPL_M / C_M_PER_PS
        lit = np.nonzero(cube.sum(axis=(0, 1)) > 0)[0]
        first = int(lit[0]) if lit.size else None
        arrival_ps = 4.0 / C_M_PER_PS
        in_first = first is not None and t0 + first * dt <= arrival_ps < t0 + (first + 1) * dt
        print(f"mitransient: render {a.shape} -> femto ingest --channels {channels}: cube {cube.shape}, max rel "
              f"diff {err}, t0 {t0:.4f} ps (want {want_t0:.4f}), dt {dt:.6f} ps (want {want_dt:.6f}), clock {frame}, "
              f"first lit bin {first} = [{t0 + (first or 0) * dt:.1f}, {t0 + ((first or 0) + 1) * dt:.1f}) ps holds "
              f"the first arrival {arrival_ps:.1f} ps: {in_first}")
        if err is None or err > 1e-6:
            failures.append(f"--channels {channels}: cube {cube.shape} differs from the render by {err}")
        if abs(t0 - want_t0) > 1e-6 * want_t0 or abs(dt - want_dt) > 1e-9 * want_dt:
            failures.append(f"--channels {channels}: axis t0 {t0} dt {dt}, want {want_t0} {want_dt}")
        if frame != "camera":
            failures.append(f"--channels {channels}: clock {frame}, want camera")
        if not in_first:
            failures.append(f"--channels {channels}: first lit bin {first} does not hold the first arrival")
    return failures

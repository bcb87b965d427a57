"""A femto scene file as a Mitsuba 3 + mitransient scene, and femto's time filter applied to
Mitsuba's histogram: the one place where tools/compare_mitsuba.py and tools/make_golden.py
turn femto's conventions into Mitsuba's.

Scene. The scene file's meshes must all be `file` meshes (OBJ, flat triangles); each becomes
an `obj` shape with face normals and a two-sided diffuse BSDF of the entry's albedo. The laser
must be isotropic; it becomes a `point` emitter of intensity energy / (4 pi). The camera is a
`perspective` sensor with a box pixel filter and a near clip of 1e-6 m (mitransient counts
optical path from the near plane, so its default 1 cm would make all light 33 ps early).
femto's `--bounces N` is Mitsuba's `max_depth = N + 1`.

Time. femto splats each path sample into the two time bins whose centres bracket its arrival
(a tent one bin wide on each side; the scene's pulse width is 0, so there is no Gaussian),
Mitsuba's `transient_hdr_film` adds it to the one bin it falls in (a box). The two are
different quantities: femto's bin i is the integral of the transient against the tent centred
on bin i's centre. To compare like with like, Mitsuba renders `FINE` times finer bins over the
window widened by half a bin on each side (the tent's reach), and `tent_filter` weighs each
fine bin by the tent at its centre. With `FINE` even, every fine bin lies inside one linear
piece of every tent, so the filtered histogram estimates femto's quantity up to the variation
of the light's mean time within a fine bin (second order in the fine bin's width).
"""

import math
import os
import tomllib

import numpy as np

C_M_PER_PS = 2.99792458e-4
# Fine bins per femto bin (even: see the module doc).
FINE = 4


def load(path):
    """The scene file at `path`, parsed, with the folder its mesh files are relative to."""
    with open(path, "rb") as f:
        scene = tomllib.load(f)
    for m in scene.get("mesh", []):
        if "file" not in m:
            raise SystemExit(f"{path}: mesh {m.get('name', '?')}: only file meshes can be given to Mitsuba")
    if scene["laser"].get("emission") != "isotropic":
        raise SystemExit(f"{path}: laser.emission must be \"isotropic\" (Mitsuba's point light)")
    if scene["laser"].get("pulse_width_fs", 0.0) != 0.0:
        raise SystemExit(f"{path}: laser.pulse_width_fs must be 0 (no Gaussian in the comparison)")
    if scene.get("eta", 1.0) != 1.0:
        raise SystemExit(f"{path}: eta must be 1")
    scene["_dir"] = os.path.dirname(os.path.abspath(path))
    return scene


def fine_window(scene):
    """(start_opl_m, bin_width_opl_m, bins) of the fine Mitsuba film: the scene's window widened
    by half a bin on each side, in FINE times finer bins."""
    cam = scene["camera"]
    dt_m = cam["dt_ps"] * C_M_PER_PS
    start = cam["t0_ps"] * C_M_PER_PS - 0.5 * dt_m
    return start, dt_m / FINE, FINE * (cam["nt"] + 1)


def mitsuba_dict(scene, mi, max_bounces, sampler="independent", spp=4, fine=True):
    """The Mitsuba scene dict. With `fine` False the film has the scene's own bins (for timing
    the cost of the finer film)."""
    cam = scene["camera"]
    t = mi.ScalarTransform4f
    if fine:
        start, width, bins = fine_window(scene)
    else:
        start, width, bins = cam["t0_ps"] * C_M_PER_PS, cam["dt_ps"] * C_M_PER_PS, cam["nt"]
    d = {
        "type": "scene",
        "integrator": {"type": "transient_path", "max_depth": max_bounces + 1, "camera_unwarp": False},
        "sensor": {
            "type": "perspective",
            "fov": cam["vfov_deg"],
            "fov_axis": "y",
            "near_clip": 1e-6,
            "to_world": t().look_at(origin=cam["position_m"], target=cam["look_at_m"], up=cam.get("up", [0, 1, 0])),
            "film": {
                "type": "transient_hdr_film",
                "width": cam["nx"],
                "height": cam["ny"],
                "temporal_bins": bins,
                "start_opl": start,
                "bin_width_opl": width,
                "rfilter": {"type": "box"},
            },
            "sampler": {"type": sampler, "sample_count": spp},
        },
        "laser": {
            "type": "point",
            "position": scene["laser"]["position_m"],
            "intensity": {"type": "uniform", "value": scene["laser"]["energy"] / (4.0 * math.pi)},
        },
    }
    for k, m in enumerate(scene["mesh"]):
        d[f"mesh_{k}"] = {
            "type": "obj",
            "filename": os.path.join(scene["_dir"], m["file"]),
            "face_normals": True,
            "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "uniform", "value": m["albedo"]}}},
        }
    return d


def tent_filter(fine_cube, nt):
    """femto's time bins from a fine histogram `(..., FINE * (nt + 1))` of `fine_window`: bin i
    is the sum of the fine bins weighted by the tent centred on bin i's centre."""
    j = np.arange(FINE * (nt + 1))
    # Fine bin centres in units of coarse bins, from the first coarse bin's centre.
    centre = (j + 0.5) / FINE - 0.5 - 0.5
    w = np.maximum(0.0, 1.0 - np.abs(centre[:, None] - np.arange(nt)[None, :]))
    return fine_cube @ w


def render(mi_scene, mi, dr, spp, seed):
    """One render: (cube (ny, nx, bins) float64, wall seconds)."""
    import time

    t0 = time.perf_counter()
    _, transient = mi.render(mi_scene, spp=spp, seed=seed)
    cube = np.array(transient, dtype=np.float64)
    dr.sync_thread()
    seconds = time.perf_counter() - t0
    return (cube[..., 0] if cube.ndim == 4 else cube), seconds

"""A femto scene file as a Mitsuba 3 + mitransient scene: the one place where
tools/compare_mitsuba.py and tools/make_golden.py turn femto's conventions into Mitsuba's.

Scene. The scene file's meshes must all be `file` meshes (OBJ, flat triangles); each becomes
an `obj` shape with face normals and a two-sided diffuse BSDF of the entry's albedo. The laser
must be isotropic; it becomes a `point` emitter of intensity energy / (4 pi). The camera is a
`perspective` sensor with a box pixel filter and a near clip of 1e-6 m (mitransient counts
optical path from the near plane, so its default 1 cm would make all light 33 ps early).
femto's `--bounces N` is Mitsuba's `max_depth = N + 1`.

Time. femto's cubes splat each sample into the two bins whose centres bracket its arrival
(the sensor's tent); Mitsuba's `transient_hdr_film` adds it to the one bin it falls in (a box
histogram). The two are different quantities, so both sides of a comparison render the
histogram: femto with `--time-filter box` (`TimeFilter::Box`), Mitsuba with the scene's own
bins (`start_opl = t0 c`, `bin_width_opl = dt c`). Both then estimate the same number per bin.
"""

import math
import os
import tomllib

import numpy as np

C_M_PER_PS = 2.99792458e-4


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


def mitsuba_dict(scene, mi, max_bounces, sampler="independent", spp=4, rr_depth=None):
    """The Mitsuba scene dict of `scene` (from `load`), for paths of at most `max_bounces`
    surface interactions; `rr_depth`: the integrator's Russian roulette depth (None: Mitsuba's
    default, 5; femto's `--rr-start-bounce B` is `rr_depth = B - 1`, see
    tools/compare_mitsuba.py)."""
    cam = scene["camera"]
    t = mi.ScalarTransform4f
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
    if rr_depth is not None:
        d["integrator"]["rr_depth"] = rr_depth
    for k, m in enumerate(scene["mesh"]):
        d[f"mesh_{k}"] = {
            "type": "obj",
            "filename": os.path.join(scene["_dir"], m["file"]),
            "face_normals": True,
            "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "uniform", "value": m["albedo"]}}},
        }
    return d


def render(mi_scene, mi, dr, spp, seed):
    """One render: (cube (ny, nx, nt) float64, wall seconds of `mi.render` and the read-back)."""
    import time

    t0 = time.perf_counter()
    _, transient = mi.render(mi_scene, spp=spp, seed=seed)
    cube = np.array(transient, dtype=np.float64)
    dr.sync_thread()
    seconds = time.perf_counter() - t0
    return (cube[..., 0] if cube.ndim == 4 else cube), seconds

#!/usr/bin/env python3
"""Compare femto's transient path tracer with Mitsuba 3 + mitransient on the same scene.

Usage:
    FEMTO_BENCH_DUMP=/tmp/femto_cmp cargo bench --bench tracer
    pip install mitsuba mitransient          # LLVM variant, CPU only
    # drjit 1.x needs LLVM >= 16 (Debian 12: apt-get install libllvm19, then
    # export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so)
    python3 tools/compare_mitsuba.py /tmp/femto_cmp [threads] [--sampler independent,multijitter,...]

The bench writes the built-in `cornell` scene (64 x 64 pixels, 300 bins of 4 ps) as one OBJ
per material plus `scene.json`, and femto renders with isotropic emission (Mitsuba's point
light is isotropic; the spot is lowered to 3 cm under the ceiling) at 4, 16 and 256 spp, each
from its own seed. This script renders the same scene with
`transient_path` (llvm_ad_mono, box pixel filter, flat-shaded OBJ triangles, a point light of
intensity energy / 4 pi, the same time window given as optical path length) and reports:

* agreement: femto 256 spp vs Mitsuba 256 spp, image sums and per-pixel differences of the
  steady (time-integrated) image against their combined noise, and the scene's time
  histogram (all pixels summed, rebinned by 4 to even out the different splatting);
* noise: RMSE of the 4 and 16 spp renders against the renderer's own 256 spp render, per
  bin of the transient and per pixel of the steady image, and the efficiency
  1 / (MSE * seconds), so the two can be compared at equal noise.

With `--sampler` (a comma-separated list of Mitsuba sampler plugins: independent, stratified,
multijitter, ldsampler, orthogonal) Mitsuba's renders are repeated with each sampler, so femto
can be compared with Mitsuba's best configuration; the agreement lines use the first one. The
sample count Mitsuba actually used is printed (some samplers round it).

Numbers depend on the machine and on how busy it is; record them with the date.
"""

import argparse
import json
import math
import os
import sys
import time

import numpy as np

C_M_PER_PS = 2.99792458e-4


def load_femto(folder, meta):
    out = {}
    for r in meta["renders"]:
        a = np.fromfile(os.path.join(folder, f"cube_spp{r['spp']}.f32"), dtype="<f4")
        cube = a.reshape(meta["ny"], meta["nx"], meta["nt"]).astype(np.float64)
        out[r["spp"]] = (cube, r["seconds"], r.get("cpu_seconds", float("nan")), r["spp"])
    return out


def mitsuba_scene(folder, meta, mi, sampler="independent"):
    t = mi.ScalarTransform4f
    d = {
        "type": "scene",
        "integrator": {
            "type": "transient_path",
            "max_depth": meta["max_bounces"] + 1,
            "rr_depth": 3,
        },
        "sensor": {
            "type": "perspective",
            "fov": meta["vfov_deg"],
            "fov_axis": "y",
            # Mitsuba starts camera rays on the near plane; mitransient counts optical path
            # from there, so a default 1 cm near clip would make all light ~33 ps early.
            "near_clip": 1e-6,
            "to_world": t().look_at(origin=meta["camera_m"], target=meta["target_m"], up=meta["up"]),
            "film": {
                "type": "transient_hdr_film",
                "width": meta["nx"],
                "height": meta["ny"],
                "temporal_bins": meta["nt"],
                "start_opl": meta["t0_ps"] * C_M_PER_PS / meta["eta"],
                "bin_width_opl": meta["dt_ps"] * C_M_PER_PS / meta["eta"],
                "rfilter": {"type": "box"},
            },
            "sampler": {"type": sampler, "sample_count": 4},
        },
        "laser": {
            "type": "point",
            "position": meta["laser_m"],
            "intensity": {"type": "uniform", "value": meta["energy"] / (4.0 * math.pi)},
        },
    }
    for m, albedo in enumerate(meta["albedo"]):
        d[f"mesh_{m}"] = {
            "type": "obj",
            "filename": os.path.join(folder, f"mesh_{m}.obj"),
            "face_normals": True,
            "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "uniform", "value": albedo}}},
        }
    return mi.load_dict(d)


def render_mitsuba(scene, meta, spp, mi, dr, seed):
    t0 = time.perf_counter()
    c0 = time.process_time()
    steady, transient = mi.render(scene, spp=spp, seed=seed)
    tr = np.array(transient, dtype=np.float64)
    dr.sync_thread()
    seconds = time.perf_counter() - t0
    cpu_seconds = time.process_time() - c0
    tr = tr[..., 0] if tr.ndim == 4 else tr
    # mitransient stores (height, width, time) for a width x height film.
    assert tr.shape == (meta["ny"], meta["nx"], meta["nt"]), tr.shape
    return tr, seconds, cpu_seconds


def main():
    ap = argparse.ArgumentParser(description="Compare femto's transient renders with Mitsuba 3 + mitransient.")
    ap.add_argument("folder", help="folder written by FEMTO_BENCH_DUMP=<folder> cargo bench --bench tracer")
    ap.add_argument("threads", nargs="?", type=int, default=2, help="Dr.Jit threads (default 2)")
    ap.add_argument("--sampler", default="independent",
                    help="comma-separated Mitsuba samplers to compare with (default independent)")
    args = ap.parse_args()
    folder, threads = args.folder, args.threads
    samplers = [s for s in args.sampler.split(",") if s]
    meta = json.load(open(os.path.join(folder, "scene.json")))
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("llvm_ad_mono")
    import mitransient  # noqa: F401  (registers the transient plugins)

    dr.set_thread_count(threads)
    femto = load_femto(folder, meta)
    print(f"scene cornell {meta['nx']}x{meta['ny']} px, {meta['nt']} bins of {meta['dt_ps']} ps, "
          f"max bounces {meta['max_bounces']}, isotropic point light; Mitsuba {mi.__version__} llvm_ad_mono, "
          f"{threads} threads")
    for k, sampler in enumerate(samplers):
        scene = mitsuba_scene(folder, meta, mi, sampler)
        mits = {}
        for spp, seed in ((4, 11), (16, 12), (256, 13)):
            # JIT warm-up at the same sample count (some samplers bake it into the kernel), so
            # the timed render reuses the compiled kernel.
            render_mitsuba(scene, meta, spp, mi, dr, seed + 100)
            mits[spp] = render_mitsuba(scene, meta, spp, mi, dr, seed)
        used = {spp: mi.load_dict({"type": sampler, "sample_count": spp}).sample_count() for spp in mits}
        if len(samplers) > 1:
            print(f"--- Mitsuba sampler: {sampler}")
        if any(used[spp] != spp for spp in used):
            print(f"note: {sampler} rounds the sample counts 4, 16, 256 to {used[4]}, {used[16]}, {used[256]}")
        mits = {spp: (cube, seconds, cpu, used[spp]) for spp, (cube, seconds, cpu) in mits.items()}
        if k == 0:
            agreement(femto, mits)
        compare(femto, mits)


def agreement(femto, mits):
    """Agreement of the two renderers at 256 spp."""
    f_ref, m_ref = femto[256][0], mits[256][0]
    fs, ms = f_ref.sum(axis=2), m_ref.sum(axis=2)
    # Noise of one 256-spp steady pixel, from the 16-spp renders (variance scales as 1/spp).
    var16 = 0.5 * (((femto[16][0].sum(axis=2) - fs) ** 2) + ((mits[16][0].sum(axis=2) - ms) ** 2))
    var256 = var16 * 16.0 / 256.0
    z = (fs - ms) / np.sqrt(2.0 * var256 + 1e-30)
    lit = fs > 0
    print(f"steady image sum: femto {fs.sum():.6g}, mitsuba {ms.sum():.6g}, ratio {fs.sum() / ms.sum():.4f}")
    # The variance comes from two squared 16-spp deviations per pixel, so z follows a Student
    # t with 2 degrees of freedom if the renderers agree: median |z| = 0.816 (rms undefined).
    print(f"steady per-pixel difference / combined noise: median |z| {np.median(np.abs(z[lit])):.3f} "
          f"(0.816 = agreement within noise), rms {np.sqrt(np.mean(z[lit] ** 2)):.2f}, lit pixels {lit.sum()}")
    hf = f_ref.sum(axis=(0, 1)).reshape(-1, 4).sum(axis=1)
    hm = m_ref.sum(axis=(0, 1)).reshape(-1, 4).sum(axis=1)
    top = hf.argmax()
    print(f"time histogram (16 ps bins): peak bin femto {hf.argmax()} mitsuba {hm.argmax()}, "
          f"max |difference| / peak {np.abs(hf - hm).max() / hf[top]:.3f}, "
          f"total in window femto/mitsuba {hf.sum() / hm.sum():.4f}")


def compare(femto, mits):
    """Noise at equal spp, efficiency (1 / (MSE * seconds), wall and CPU) and speed at equal noise."""
    print("renderer  spp   wall s    CPU s  RMSE(transient bin)  RMSE(steady px)  eff_transient(wall, CPU)  eff_steady(wall, CPU)")
    mse16 = {}
    for name, runs in (("femto", femto), ("mitsuba", mits)):
        ref = runs[256][0]
        for spp in (4, 16):
            cube, seconds, cpu, _ = runs[spp]
            mt = np.mean((cube - ref) ** 2)
            ms_ = np.mean((cube.sum(axis=2) - ref.sum(axis=2)) ** 2)
            if spp == 16:
                mse16[name] = (mt, ms_)
            print(f"{name:8s} {spp:4d} {seconds:8.3f} {cpu:8.2f} {math.sqrt(mt):20.4e} {math.sqrt(ms_):16.4e} "
                  f"{1 / (mt * seconds):12.4e} {1 / (mt * cpu):11.4e} {1 / (ms_ * seconds):10.4e} {1 / (ms_ * cpu):10.4e}")
    f256, m256 = femto[256], mits[256]
    print(f"256 spp: femto {f256[1]:.2f} s wall, {f256[2]:.2f} CPU s; mitsuba {m256[1]:.2f} s wall, {m256[2]:.2f} CPU s")
    # Equal noise: the time to reach a given MSE is proportional to (MSE at the "16 spp" render)
    # x (its sample count) x (time per sample), the latter taken from the "256 spp" render
    # where fixed costs matter least (sample counts as the sampler actually used them). The
    # reference noise inflates both renderers' 16-spp MSE by about the same factor
    # 1 + 16/256, so it nearly cancels (for independent samples; a stratified sampler's
    # reference is less noisy than that, which slightly favours it).
    f16, m16 = femto[16][3], mits[16][3]
    for k, what in ((0, "transient bin"), (1, "steady pixel")):
        for j, clock in ((1, "wall"), (2, "CPU")):
            cost_f = mse16["femto"][k] * f16 * f256[j] / f256[3]
            cost_m = mse16["mitsuba"][k] * m16 * m256[j] / m256[3]
            print(f"equal {what} noise, {clock} time: femto is {cost_m / cost_f:.2f}x as fast as mitsuba")


if __name__ == "__main__":
    main()

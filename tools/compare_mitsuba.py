#!/usr/bin/env python3
"""femto's transient path tracer against Mitsuba 3 + mitransient, like for like.

One command, from a release build:

    cargo build --release
    python3 tools/compare_mitsuba.py                      # needs mitsuba, mitransient, h5py, numpy
    # drjit 1.x needs LLVM >= 16 (Debian 12: apt-get install libllvm19, then
    # export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so)

What is the same on both sides:

* Scene: the same files. Each scene is a femto scene file whose meshes are OBJ files;
  tools/mitsuba_scene.py turns it into Mitsuba's scene (obj shapes, two-sided diffuse of the
  same albedo, an isotropic point light of intensity energy / 4 pi, box pixel filter).
  `peer_cornell` (primary) is mitransient's own Cornell box with a point light at (0, 0.5, 0),
  7 bounces (max_depth 8), 300 bins of 100 ps; `tuned_cornell` is femto's built-in scene,
  the one its tracer was tuned on, 4 bounces, 300 bins of 4 ps.
* Quantity: a histogram of arrival times on the same bins. femto renders with
  `--time-filter box` (each path sample whole in the bin it falls in), Mitsuba's
  `transient_hdr_film` bins the same way. (femto's own cubes use the sensor's tent response, a
  different and smoother quantity, which is not what is compared here.) The steady image is
  the sum over the same window on both sides.
* Truth: a common converged reference, the mean of a femto and a Mitsuba render at
  `--ref-spp` (neither renderer's own). The reference's own noise is removed from every MSE:
  with F, M the two reference renders, the reference's per-bin variance is estimated as
  mean((F - M)^2) / 4 (both unbiased and independent), and MSE(test) = mean((X - R)^2) - that.
  The script prints how large that correction is, and the agreement of F and M.
* Threads: femto `--threads T`, Dr.Jit `set_thread_count(T)`; wall and CPU seconds of the
  render alone on both sides (femto: the tracer's own timer in render.json, BVH built before;
  Mitsuba: `mi.render` and the read-back, scene loaded and the kernel compiled before by a
  warm-up render at the same sample count).

Speed at equal noise: the time to reach a given per-bin MSE is MSE(N spp) x N x (seconds per
sample), both measured; femto's advantage is the ratio of Mitsuba's to femto's. MSE(N spp) is
the mean over `--seeds` renders at N spp (each its own seed); seconds per sample from the
median of `--timing-runs` renders at `--timing-spp`, where fixed costs matter least; the
renderers take turns, so that a change of the machine's load reaches all of them alike.

Window: femto ends a path as soon as everything it could still deliver would arrive after the
window; Mitsuba traces such paths to max_depth. That is an algorithmic advantage of femto for a
transient render, counted in its time; the script prints the share of paths it ended that way.

Numbers depend on the machine and how busy it is: record them with the date and the load.
"""

import argparse
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mitsuba_scene  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
# Scene name -> most bounces (femto --bounces; Mitsuba max_depth = bounces + 1).
SCENES = {"peer_cornell": 7, "tuned_cornell": 4}


def femto_render(femto, scene_file, bounces, spp, seed, threads, workdir):
    """One femto render: (cube (ny, nx, nt) float64, counters from render.json)."""
    import h5py

    out = os.path.join(workdir, f"femto_{spp}_{seed}")
    cmd = [femto, "simulate", "--scene", scene_file, "--transient-only", "--time-filter", "box",
           "--bounces", str(bounces), "--spp", str(spp), "--seed", str(seed), "--threads", str(threads),
           "--out", out, "--force"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr}")
    with h5py.File(os.path.join(out, "truth_camera.h5"), "r") as f:
        cube = np.array(f["cube"], dtype=np.float64)
    with open(os.path.join(out, "render.json")) as f:
        counters = json.load(f)
    return cube, counters


class Mitsuba:
    """Mitsuba renders of one scene with one sampler, timed as femto's are."""

    def __init__(self, scene, bounces, sampler, threads):
        import drjit as dr
        import mitsuba as mi

        mi.set_variant("llvm_ad_mono")
        import mitransient  # noqa: F401  (registers the transient plugins)

        dr.set_thread_count(threads)
        self.mi, self.dr = mi, dr
        self.scene = mi.load_dict(mitsuba_scene.mitsuba_dict(scene, mi, bounces, sampler))
        self.sampler = sampler
        self.warm = set()

    def render(self, spp, seed):
        """(cube, wall seconds, CPU seconds); a first render at `spp` compiles the kernel."""
        if spp not in self.warm:
            mitsuba_scene.render(self.scene, self.mi, self.dr, spp, seed + 7919)
            self.warm.add(spp)
        c0 = time.process_time()
        cube, seconds = mitsuba_scene.render(self.scene, self.mi, self.dr, spp, seed)
        return cube, seconds, time.process_time() - c0

    def used_spp(self, spp):
        """The sample count the sampler really uses (some round it)."""
        return self.mi.load_dict({"type": self.sampler, "sample_count": spp}).sample_count()


def mse(cubes, ref, ref_var):
    """Mean over `cubes` of the per-bin and per-steady-pixel MSE against `ref`, less the
    reference's own variance (`ref_var`: per bin, per steady pixel)."""
    t = [np.mean((c - ref) ** 2) for c in cubes]
    s = [np.mean((c.sum(axis=2) - ref.sum(axis=2)) ** 2) for c in cubes]
    return np.mean(t) - ref_var[0], np.mean(s) - ref_var[1]


def compare_scene(name, args, workdir):
    """Compare on scene `name`; prints the figures and returns (ratios, agreement): a list of
    dicts, one per comparison, and the two reference renders' totals and histogram bins."""
    bounces = SCENES[name]
    scene_file = os.path.join(HERE, "scenes", name, "scene.toml")
    scene = mitsuba_scene.load(scene_file)
    cam = scene["camera"]
    print(f"\n=== {name}: {cam['nx']} x {cam['ny']} px, {cam['nt']} bins of {cam['dt_ps']} ps "
          f"({cam['dt_ps'] * mitsuba_scene.C_M_PER_PS:.4f} m) from {cam['t0_ps']} ps, {bounces} bounces "
          f"(Mitsuba max_depth {bounces + 1}), box time bins, {args.threads} threads")
    femto = lambda spp, seed: femto_render(args.femto, scene_file, bounces, spp, seed, args.threads, workdir)  # noqa: E731

    # Common reference.
    f_ref, f_ref_counters = femto(args.ref_spp, 1000)
    m_ind = Mitsuba(scene, bounces, "independent", args.threads)
    m_ref, _, _ = m_ind.render(args.ref_spp, 1000)
    ref = 0.5 * (f_ref + m_ref)
    ref_var = (np.mean((f_ref - m_ref) ** 2) / 4.0, np.mean((f_ref.sum(axis=2) - m_ref.sum(axis=2)) ** 2) / 4.0)
    fs, ms = f_ref.sum(), m_ref.sum()
    hf, hm = f_ref.sum(axis=(0, 1)), m_ref.sum(axis=(0, 1))
    print(f"reference: femto + Mitsuba (independent) at {args.ref_spp} spp each; "
          f"totals femto {fs:.6g}, Mitsuba {ms:.6g}, ratio {fs / ms:.5f}; whole-image histogram: "
          f"first lit bin {np.nonzero(hf)[0][0]} / {np.nonzero(hm)[0][0]}, peak bin {hf.argmax()} / {hm.argmax()}")
    ended = f_ref_counters["paths_ended_late"] / f_ref_counters["paths"]
    print(f"femto ended {100 * ended:.1f} % of its paths early (all they could still deliver lay past the window)")

    agreement = {"total_femto": fs, "total_mitsuba": ms,
                 "first_lit_bin": (int(np.nonzero(hf)[0][0]), int(np.nonzero(hm)[0][0])),
                 "peak_bin": (int(hf.argmax()), int(hm.argmax()))}
    results = []
    rows = []
    mitsubas = [m_ind if sampler == "independent" else Mitsuba(scene, bounces, sampler, args.threads)
                for sampler in args.sampler]
    # Seconds per sample: the renderers take turns, so that a change of the machine's load
    # during the run reaches all of them alike; the median of each one's runs is kept.
    f_times, m_times = [], [[] for _ in mitsubas]
    for k in range(args.timing_runs):
        c = femto(args.timing_spp, 2000 + k)[1]
        f_times.append((c["render_seconds"], c["render_cpu_seconds"]))
        for m, times in zip(mitsubas, m_times):
            _, wall, cpu = m.render(args.timing_spp, 2000 + k)
            times.append((wall, cpu))
    per_sample = lambda times, used: (statistics.median(t[0] for t in times) / used,  # noqa: E731
                                      statistics.median(t[1] for t in times) / used)
    f_wall, f_cpu = per_sample(f_times, args.timing_spp)
    f_mse = {n: mse([femto(n, 1 + k)[0] for k in range(args.seeds)], ref, ref_var) for n in args.spp}
    rows.append(("femto", f_wall, f_cpu, f_mse, {n: n for n in args.spp}))
    for m, times in zip(mitsubas, m_times):
        m_wall, m_cpu = per_sample(times, m.used_spp(args.timing_spp))
        m_mse = {n: mse([m.render(n, 1 + k)[0] for k in range(args.seeds)], ref, ref_var) for n in args.spp}
        rows.append((f"mitsuba {m.sampler}", m_wall, m_cpu, m_mse, {n: m.used_spp(n) for n in args.spp}))

    print(f"reference noise removed from each MSE: {ref_var[0]:.3e} per bin, {ref_var[1]:.3e} per steady pixel")
    print(f"{'renderer':22s} {'ms/spp wall':>11s} {'ms/spp CPU':>10s} " +
          " ".join(f"{'RMSE bin @' + str(n):>14s} {'RMSE px @' + str(n):>13s}" for n in args.spp))
    for label, wall, cpu, m_, used in rows:
        print(f"{label:22s} {1e3 * wall:11.3f} {1e3 * cpu:10.3f} " +
              " ".join(f"{math.sqrt(max(m_[n][0], 0)):14.4e} {math.sqrt(max(m_[n][1], 0)):13.4e}" for n in args.spp))
    _, fw, fc, fm, fu = rows[0]
    for label, wall, cpu, m_, used in rows[1:]:
        for n in args.spp:
            for k, what in ((0, "transient bin"), (1, "steady pixel")):
                # Seconds to reach a given MSE: MSE(N) x (samples used) x (seconds per sample).
                cost_f = fm[n][k] * fu[n] * np.array([fw, fc])
                cost_m = m_[n][k] * used[n] * np.array([wall, cpu])
                ratio = cost_m / cost_f
                print(f"{name}, vs {label}, N = {n} spp, equal {what} noise: femto is {ratio[0]:.2f}x "
                      f"(wall) / {ratio[1]:.2f}x (CPU) as fast")
                results.append({"scene": name, "against": label, "spp": n, "quantity": what,
                                "ratio_wall": ratio[0], "ratio_cpu": ratio[1]})
    return results, agreement


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--femto", default=os.path.join(HERE, "..", "target", "release", "femto"),
                    help="the femto binary (default: target/release/femto)")
    ap.add_argument("--threads", type=int, default=2, help="threads of both renderers (default 2)")
    ap.add_argument("--scenes", default="peer_cornell,tuned_cornell",
                    help=f"comma-separated, of {', '.join(SCENES)} (default both)")
    ap.add_argument("--sampler", default="multijitter,independent",
                    help="comma-separated Mitsuba samplers (default multijitter,independent)")
    ap.add_argument("--spp", default="16,64", help="sample counts of the noise renders (default 16,64)")
    ap.add_argument("--seeds", type=int, default=4, help="noise renders per sample count (default 4)")
    ap.add_argument("--ref-spp", type=int, default=4096, help="spp of each reference render (default 4096)")
    ap.add_argument("--timing-spp", type=int, default=256, help="spp of the timing renders (default 256)")
    ap.add_argument("--timing-runs", type=int, default=5, help="timing renders of each renderer, taken in turns, median kept (default 5)")
    ap.add_argument("--json", help="also write the ratios and the references' agreement to this JSON file")
    args = ap.parse_args()
    args.spp = [int(s) for s in args.spp.split(",") if s]
    args.sampler = [s for s in args.sampler.split(",") if s]
    args.femto = os.path.abspath(args.femto)
    if not os.access(args.femto, os.X_OK):
        raise SystemExit(f"--femto: {args.femto} is not an executable (cargo build --release first)")
    scenes = [s for s in args.scenes.split(",") if s]
    for s in scenes:
        if s not in SCENES:
            raise SystemExit(f"--scenes: unknown scene {s!r} (known: {', '.join(SCENES)})")

    import mitsuba as mi

    mi.set_variant("llvm_ad_mono")
    version = subprocess.run([args.femto, "--version"], capture_output=True, text=True).stdout.strip()
    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo") if ln.startswith("model name")),
               platform.processor())
    import mitransient
    print(f"{version}; Mitsuba {mi.__version__} + mitransient {mitransient.__version__} (llvm_ad_mono); "
          f"{cpu}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at start; "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    results, agreement = [], {}
    with tempfile.TemporaryDirectory() as workdir:
        for s in scenes:
            ratios, agreement[s] = compare_scene(s, args, workdir)
            results += ratios
    print(f"load average {os.getloadavg()[0]:.2f} at the end")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"ratios": results, "agreement": agreement}, f, indent=1)


if __name__ == "__main__":
    main()

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
* Russian roulette: the same start on both sides (`--roulette matched`, the default). femto
  counts bounces from 1, the first surface the camera ray hits, and after shading the vertex
  of bounce b (its connections to the light made) plays roulette when b >=
  `--rr-start-bounce` (TraceOptions::rr_start_bounce, default 3), surviving with probability
  min(throughput, 0.95), the throughput including this vertex's albedo. mitransient's
  `transient_path` (mitransient/integrators/transientpath.py, the `rr_depth` of Mitsuba's
  ADIntegrator) counts `depth` from 0 at that same first surface and, after emitter sampling
  and BSDF sampling at the vertex, plays roulette when depth >= `rr_depth` (default 5), with
  probability min(max throughput * eta^2, 0.95), eta = 1 here and the throughput (from 1,
  times the diffuse BSDF's sampling weight, the albedo) the same. So femto's bounce b is
  Mitsuba's depth b - 1, and `--rr-start-bounce B` is `rr_depth = B - 1`: femto's default 3 is
  rr_depth 2, Mitsuba's default 5 is femto's bounce 6. `--roulette defaults` runs each at its
  own default instead (femto 3, Mitsuba 5), which favours femto: Mitsuba then traces longer
  paths, whose cost per sample grows faster than its noise falls (on peer_cornell femto's
  ratio is about a fifth higher so; benches/tracer_results.md). Unless `--no-other-roulette`, the script also renders Mitsuba at the
  other setting and prints both, each labelled with its setting.
* Truth: a common converged reference, the mean of a femto and a Mitsuba render at
  `--ref-spp` (neither renderer's own). The reference's own noise is removed from every MSE:
  with F, M the two reference renders, the reference's per-bin variance is estimated as
  mean((F - M)^2) / 4 (both unbiased and independent), and MSE(test) = mean((X - R)^2) - that.
  The script prints how large that correction is, and the agreement of F and M.
* Threads: femto `--threads T`, Dr.Jit `set_thread_count(T)`.
* Time per sample: the slope between two sample counts (`--timing-spp`, default 256,1024),
  (t(hi) - t(lo)) / (samples(hi) - samples(lo)), so that every fixed cost of a call drops out
  on both sides: femto's process start, scene loading, BVH build and file writing, Mitsuba's
  per-call overhead and read-back. femto is timed from outside, like Mitsuba: wall seconds of
  the whole `femto simulate` process and its CPU seconds (the children's rusage); Mitsuba:
  wall seconds of `mi.render` and the read-back, CPU seconds of this process (Dr.Jit's
  threads), the kernel compiled before by a warm-up render at each sample count. (femto's own
  timer's slope is printed too.) `--timing-runs` rounds (default 4), each timing every
  renderer at both counts; the renderers' order reverses between rounds (A B, B A, A B, ...),
  so that a drift of the machine's load reaches all alike. The median slope over the rounds
  gives the figure; each round's slopes give a ratio too, and their min-max is printed as the
  spread.

Speed at equal noise: the time to reach a given per-bin MSE is MSE(N spp) x N x (seconds per
sample), both measured; femto's advantage is the ratio of Mitsuba's to femto's. MSE(N spp) is
the mean over `--seeds` renders at N spp (each its own seed).

Window: femto ends a path as soon as everything it could still deliver would arrive after the
window; Mitsuba traces such paths to max_depth. That is an algorithmic advantage of femto for a
transient render, counted in its time; the script prints the share of paths it ended that way.

The machine: every figure is printed with the CPU model, the SIMD path femto takes on it (from
/proc/cpuinfo's flags, as femto's `auto` chooses, or FEMTO_SIMD if set; Dr.Jit's LLVM backend
compiles for the host CPU too), and the 1-minute load average before and after the timing
renders. The numbers depend on the machine and how busy it is: record them with all of that.
"""

import argparse
import json
import math
import os
import platform
import resource
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
# Russian roulette's defaults: femto's first bounce (TraceOptions::rr_start_bounce) and
# Mitsuba's rr_depth (its ADIntegrator's default).
FEMTO_RR_DEFAULT = 3
MITSUBA_RR_DEFAULT = 5


def roulette_modes(args):
    """{mode: (femto's --rr-start-bounce, Mitsuba's rr_depth)}, the headline mode first."""
    modes = {"matched": (args.rr_start_bounce, args.rr_start_bounce - 1),
             "defaults": (FEMTO_RR_DEFAULT, MITSUBA_RR_DEFAULT)}
    order = [args.roulette] + ([] if args.no_other_roulette else [m for m in modes if m != args.roulette])
    return {m: modes[m] for m in order}


def cpu_info():
    """(CPU model, femto's SIMD path on it, a note on how that was found), from /proc/cpuinfo."""
    model, flags = None, set()
    try:
        with open("/proc/cpuinfo") as f:
            for ln in f:
                if ln.startswith("model name") and model is None:
                    model = ln.split(":", 1)[1].strip()
                elif ln.startswith("flags") and not flags:
                    flags = set(ln.split(":", 1)[1].split())
    except OSError:
        pass
    model = model or platform.processor() or "unknown CPU"
    # As src/geometry/simd_level.rs's `auto`: the AVX2 row build needs avx avx2 bmi1 bmi2
    # lzcnt (cpuinfo's abm) popcnt, and takes its GFNI copy where cpuinfo has gfni; AVX-512
    # adds avx512f avx512vl.
    avx2 = {"avx", "avx2", "bmi1", "bmi2", "abm", "popcnt"} <= flags
    avx512 = avx2 and {"avx512f", "avx512vl"} <= flags
    forced = os.environ.get("FEMTO_SIMD", "auto") or "auto"
    if forced != "auto":
        return model, forced, "forced by FEMTO_SIMD"
    level = "avx512" if avx512 else "avx2" if avx2 else ("avx (BVH), baseline rows" if "avx" in flags else "sse")
    if avx2:
        level += " (rows with GFNI)" if "gfni" in flags else " (rows without GFNI)"
    has = [f for f in ("avx2", "avx512f", "avx512vl", "gfni") if f in flags]
    return model, level, f"auto; cpuinfo has {' '.join(has) or 'none of avx2 avx512f avx512vl gfni'}"


def load1():
    return os.getloadavg()[0]


def femto_render(femto, scene_file, bounces, rr, spp, seed, threads, workdir):
    """One femto render: (cube (ny, nx, nt) float64, counters from render.json, wall seconds
    and CPU seconds of the whole process)."""
    import h5py

    out = os.path.join(workdir, f"femto_{spp}_{seed}")
    cmd = [femto, "simulate", "--scene", scene_file, "--transient-only", "--time-filter", "box",
           "--bounces", str(bounces), "--rr-start-bounce", str(rr), "--spp", str(spp), "--seed", str(seed),
           "--threads", str(threads), "--out", out, "--force"]
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr}")
    with h5py.File(os.path.join(out, "truth_camera.h5"), "r") as f:
        cube = np.array(f["cube"], dtype=np.float64)
    with open(os.path.join(out, "render.json")) as f:
        counters = json.load(f)
    if counters.get("rr_start_bounce", rr) != rr:
        raise SystemExit(f"{femto} rendered with rr_start_bounce {counters['rr_start_bounce']}, not {rr}")
    cpu = (r1.ru_utime + r1.ru_stime) - (r0.ru_utime + r0.ru_stime)
    return cube, counters, wall, cpu


class Femto:
    """femto renders of one scene with one roulette start."""

    def __init__(self, args, scene_file, bounces, rr, workdir):
        self.args, self.scene_file, self.bounces, self.rr, self.workdir = args, scene_file, bounces, rr, workdir
        self.label = f"femto (roulette from bounce {rr})"

    def render(self, spp, seed):
        """(cube, wall seconds, CPU seconds, femto's own render seconds, counters)."""
        cube, c, wall, cpu = femto_render(self.args.femto, self.scene_file, self.bounces, self.rr, spp, seed,
                                          self.args.threads, self.workdir)
        return cube, wall, cpu, c["render_seconds"], c

    def used_spp(self, spp):
        return spp


class Mitsuba:
    """Mitsuba renders of one scene with one sampler and one roulette depth."""

    def __init__(self, scene, bounces, sampler, rr_depth, threads):
        import drjit as dr
        import mitsuba as mi

        mi.set_variant("llvm_ad_mono")
        import mitransient  # noqa: F401  (registers the transient plugins)

        dr.set_thread_count(threads)
        self.mi, self.dr = mi, dr
        self.scene = mi.load_dict(mitsuba_scene.mitsuba_dict(scene, mi, bounces, sampler, rr_depth=rr_depth))
        self.sampler, self.rr_depth = sampler, rr_depth
        self.label = f"mitsuba {sampler} (rr_depth {rr_depth} = from bounce {rr_depth + 1})"
        self.warm = set()

    def render(self, spp, seed):
        """(cube, wall seconds, CPU seconds, None, None); a first render at `spp` compiles the
        kernel."""
        if spp not in self.warm:
            mitsuba_scene.render(self.scene, self.mi, self.dr, spp, seed + 7919)
            self.warm.add(spp)
        c0 = time.process_time()
        cube, seconds = mitsuba_scene.render(self.scene, self.mi, self.dr, spp, seed)
        return cube, seconds, time.process_time() - c0, None, None

    def used_spp(self, spp):
        """The sample count the sampler really uses (some round it)."""
        return self.mi.load_dict({"type": self.sampler, "sample_count": spp}).sample_count()


def mse(cubes, ref, ref_var):
    """Mean over `cubes` of the per-bin and per-steady-pixel MSE against `ref`, less the
    reference's own variance (`ref_var`: per bin, per steady pixel)."""
    t = [np.mean((c - ref) ** 2) for c in cubes]
    s = [np.mean((c.sum(axis=2) - ref.sum(axis=2)) ** 2) for c in cubes]
    return np.mean(t) - ref_var[0], np.mean(s) - ref_var[1]


def timing(renderers, args):
    """Seconds per sample of each renderer, from the slope between the two `--timing-spp`
    counts: {renderer: [(wall, CPU, own timer or None) per round]}, and the 1-minute load
    before and after. The first renderer alternates between rounds."""
    lo, hi = args.timing_spp
    for r in renderers:  # warm-up: the binary in the page cache, Mitsuba's kernels compiled
        r.render(lo, 3000)
        if isinstance(r, Mitsuba):
            r.render(hi, 3001)
    slopes = {r: [] for r in renderers}
    load_before = load1()
    for k in range(args.timing_runs):
        order = renderers if k % 2 == 0 else renderers[::-1]
        for r in order:
            a = r.render(lo, 2000 + k)
            b = r.render(hi, 2000 + k)
            n = r.used_spp(hi) - r.used_spp(lo)
            own = (b[3] - a[3]) / n if a[3] is not None else None
            slopes[r].append(((b[1] - a[1]) / n, (b[2] - a[2]) / n, own))
    return slopes, (load_before, load1())


def compare_scene(name, args, workdir, machine):
    """Compare on scene `name`; prints the figures and returns (ratios, agreement): a list of
    dicts, one per comparison, and the two reference renders' totals and histogram bins."""
    bounces = SCENES[name]
    scene_file = os.path.join(HERE, "scenes", name, "scene.toml")
    scene = mitsuba_scene.load(scene_file)
    cam = scene["camera"]
    modes = roulette_modes(args)
    print(f"\n=== {name}: {cam['nx']} x {cam['ny']} px, {cam['nt']} bins of {cam['dt_ps']} ps "
          f"({cam['dt_ps'] * mitsuba_scene.C_M_PER_PS:.4f} m) from {cam['t0_ps']} ps, {bounces} bounces "
          f"(Mitsuba max_depth {bounces + 1}), box time bins, {args.threads} threads; roulette "
          + "; ".join(f"{m}: femto from bounce {f}, Mitsuba rr_depth {d}" for m, (f, d) in modes.items()))

    femtos = {}
    mitsubas = {}
    for f_rr, m_rr in modes.values():
        femtos.setdefault(f_rr, Femto(args, scene_file, bounces, f_rr, workdir))
        for sampler in args.sampler:
            if (sampler, m_rr) not in mitsubas:
                mitsubas[(sampler, m_rr)] = Mitsuba(scene, bounces, sampler, m_rr, args.threads)
    head_f, head_m = next(iter(modes.values()))
    if ("independent", head_m) not in mitsubas:
        mitsubas[("independent", head_m)] = Mitsuba(scene, bounces, "independent", head_m, args.threads)

    # Common reference (roulette does not bias either renderer: the headline settings).
    f_ref, _, _, _, f_ref_counters = femtos[head_f].render(args.ref_spp, 1000)
    m_ref = mitsubas[("independent", head_m)].render(args.ref_spp, 1000)[0]
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

    renderers = list(femtos.values()) + [mitsubas[(s, d)] for (s, d) in mitsubas if s in args.sampler]
    slopes, load = timing(renderers, args)
    noise = {r: {n: mse([r.render(n, 1 + k)[0] for k in range(args.seeds)], ref, ref_var) for n in args.spp}
             for r in renderers}
    lo, hi = args.timing_spp
    context = (f"{machine['cpu']}, femto SIMD {machine['simd']}, load {load[0]:.2f} -> {load[1]:.2f} "
               f"over the timing")
    print(f"reference noise removed from each MSE: {ref_var[0]:.3e} per bin, {ref_var[1]:.3e} per steady pixel")
    print(f"ms per sample: median over {args.timing_runs} rounds of the slope between {lo} and {hi} spp "
          f"(min-max in brackets); {context}")
    print(f"{'renderer':48s} {'wall':>22s} {'CPU':>22s} " +
          " ".join(f"{'RMSE bin @' + str(n):>14s} {'RMSE px @' + str(n):>13s}" for n in args.spp))
    med = {}
    for r in renderers:
        w, c = [t[0] for t in slopes[r]], [t[1] for t in slopes[r]]
        med[r] = (statistics.median(w), statistics.median(c))
        fmt = lambda v: f"{1e3 * statistics.median(v):7.3f} [{1e3 * min(v):.3f}-{1e3 * max(v):.3f}]"  # noqa: E731
        print(f"{r.label:48s} {fmt(w):>22s} {fmt(c):>22s} " +
              " ".join(f"{math.sqrt(max(noise[r][n][0], 0)):14.4e} {math.sqrt(max(noise[r][n][1], 0)):13.4e}"
                       for n in args.spp))
    for f in femtos.values():
        own = [t[2] for t in slopes[f]]
        print(f"{f.label}: its own timer's slope {1e3 * statistics.median(own):.3f} ms per sample wall "
              f"(the process's: {1e3 * med[f][0]:.3f})")
    results = []
    for mode, (f_rr, m_rr) in modes.items():
        f = femtos[f_rr]
        for sampler in args.sampler:
            m = mitsubas[(sampler, m_rr)]
            for n in args.spp:
                for k, what in ((0, "transient bin"), (1, "steady pixel")):
                    # Seconds to reach a given MSE: MSE(N) x (samples used) x (seconds per sample).
                    def ratio(fw, fc, mw, mc):
                        return (noise[m][n][k] * m.used_spp(n) * np.array([mw, mc])
                                / (noise[f][n][k] * f.used_spp(n) * np.array([fw, fc])))
                    mid = ratio(*med[f], *med[m])
                    rounds = [ratio(a[0], a[1], b[0], b[1]) for a, b in zip(slopes[f], slopes[m])]
                    rw, rc = [x[0] for x in rounds], [x[1] for x in rounds]
                    print(f"{name}, roulette {mode} ({f_rr} / rr_depth {m_rr}), vs mitsuba {sampler}, N = {n} spp, "
                          f"equal {what} noise: femto is {mid[1]:.2f}x (CPU; rounds {min(rc):.2f}-{max(rc):.2f}) / "
                          f"{mid[0]:.2f}x (wall; {min(rw):.2f}-{max(rw):.2f}) as fast; {context}")
                    results.append({"scene": name, "roulette": mode, "femto_rr_start_bounce": f_rr,
                                    "mitsuba_rr_depth": m_rr, "against": f"mitsuba {sampler}", "spp": n,
                                    "quantity": what, "ratio_wall": mid[0], "ratio_cpu": mid[1],
                                    "rounds_wall": rw, "rounds_cpu": rc, "load_before": load[0],
                                    "load_after": load[1]})
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
    ap.add_argument("--roulette", choices=("matched", "defaults"), default="matched",
                    help="matched: Russian roulette from the same bounce on both sides (femto "
                         "--rr-start-bounce B, Mitsuba rr_depth B - 1); defaults: each at its own default "
                         f"(femto {FEMTO_RR_DEFAULT}, Mitsuba rr_depth {MITSUBA_RR_DEFAULT}). Default matched")
    ap.add_argument("--rr-start-bounce", type=int, default=FEMTO_RR_DEFAULT,
                    help=f"the first roulette bounce of --roulette matched (default {FEMTO_RR_DEFAULT}, femto's own)")
    ap.add_argument("--no-other-roulette", action="store_true",
                    help="render only the --roulette setting (by default the other one is printed too)")
    ap.add_argument("--spp", default="16,64", help="sample counts of the noise renders (default 16,64)")
    ap.add_argument("--seeds", type=int, default=4, help="noise renders per sample count (default 4)")
    ap.add_argument("--ref-spp", type=int, default=4096, help="spp of each reference render (default 4096)")
    ap.add_argument("--timing-spp", default="256,1024",
                    help="the two sample counts whose time difference gives the time per sample (default 256,1024)")
    ap.add_argument("--timing-runs", type=int, default=4,
                    help="timing rounds, the first renderer alternating; median kept, min-max printed (default 4)")
    ap.add_argument("--json", help="also write the ratios and the references' agreement to this JSON file")
    args = ap.parse_args()
    args.spp = [int(s) for s in args.spp.split(",") if s]
    args.sampler = [s for s in args.sampler.split(",") if s]
    args.timing_spp = [int(s) for s in args.timing_spp.split(",") if s]
    if len(args.timing_spp) != 2 or not 0 < args.timing_spp[0] < args.timing_spp[1]:
        raise SystemExit(f"--timing-spp: expected two counts LO,HI with 0 < LO < HI, got {args.timing_spp}")
    if args.rr_start_bounce < 2:
        raise SystemExit("--rr-start-bounce: must be at least 2 (Mitsuba's rr_depth = B - 1 must be >= 1)")
    if args.timing_runs < 1:
        raise SystemExit("--timing-runs: must be at least 1")
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
    cpu, simd, how = cpu_info()
    machine = {"cpu": cpu, "simd": simd, "simd_how": how, "cores": os.cpu_count()}
    import mitransient
    print(f"{version}; Mitsuba {mi.__version__} + mitransient {mitransient.__version__} (llvm_ad_mono); "
          f"{cpu}, {os.cpu_count()} cores; femto's SIMD path {simd} ({how}); load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())} at start; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    print(f"roulette: {args.roulette} is the headline"
          + ("" if args.no_other_roulette else ", the other setting is printed too"))
    results, agreement = [], {}
    with tempfile.TemporaryDirectory() as workdir:
        for s in scenes:
            ratios, agreement[s] = compare_scene(s, args, workdir, machine)
            results += ratios
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} at the end, "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"machine": machine, "args": {k: v for k, v in vars(args).items()},
                       "ratios": results, "agreement": agreement}, f, indent=1)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Golden transient references of tools/scenes/peer_cornell/scene.toml rendered by Mitsuba 3 +
mitransient, for tests/golden.rs (docs/golden.md).

Usage (a Python with mitsuba 3.9.1, mitransient 1.3.1 and h5py; drjit needs LLVM >= 16):
    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so \\
        python tools/make_golden.py [--out tests/golden/peer_cornell_32x32x64.h5]
or, from the test suite, `FEMTO_BLESS=1 FEMTO_INTEROP_PYTHON=<python> cargo test --test golden`.

What it renders. The scene file becomes a Mitsuba scene through tools/mitsuba_scene.py (the
one place that maps femto's conventions to Mitsuba's), with the camera set to 32 x 32 pixels
and 64 box time bins (`transient_hdr_film`: each sample whole in the bin it falls in, the
quantity femto renders with `TimeFilter::Box`), variant `llvm_ad_mono`, `independent`
sampler. Two references:

* `direct`: one-bounce light only (femto `max_bounces = 1`, Mitsuba `max_depth = 2`);
* `all`: all light of at most 4 bounces (femto `max_bounces = 4`, Mitsuba `max_depth = 5`).

Each is the mean of B renders (`--batches`, default 32) with seeds of their own (direct:
0 .. B-1, all: 1000 .. 1000+B-1, so the two references are independent), stored with the
variance of that mean per bin estimated from the batches (sample variance, ddof 1, over B).
The test compares femto's multi-bounce light with `all - direct`, whose variance is the sum.

Time axis: t0 = 13,550 ps, dt = 250 ps (7.49 cm of optical path), 64 bins, to 29,550 ps. The
first light (camera -> box -> point light, measured with 10 ps bins at 1024 spp) arrives at
about 13,960 ps, so bin 0 is dark and bin 1 [13,800, 14,050) is the first lit bin with about
12 % of the peak bin's light: both renderers must agree on it, and its value is not decided by
a few samples near an edge. One-bounce
light ends at about 23,900 ps (bin 41); the window holds about 93 % of the light of 2 to 4
bounces (the rest is a tail to about 46 ns). The peak of the whole-image histogram (the back
wall, bin 25) is 1.18 times the next bin for direct light and 1.15 times for all light, so
the peak-bin check is not decided by noise; the multi-bounce histogram is flat at its top
(1.03) and is not used for a peak check.

Samples: 32 batches (enough for the variance estimate to be close to a normal one in the
test's z scores) of 8192 (direct) and 2048 (all) samples per pixel: 262,144 and 65,536 per
pixel, against femto's 32 x 64 = 2,048 in the test, so the reference's share of the compared
variance per bin is small (the test prints its median: about 0.07 for one-bounce light, whose
femto estimate is stratified, and 0.05 for multi-bounce light). One run takes about 1.5
minutes with 2 threads (`--spp-scale` scales both counts). The file holds four float32
(32, 32, 64) datasets, gzip-compressed, and two small float64 ones.

The file is written to a temporary path beside the destination and renamed onto it.
"""

import argparse
import hashlib
import os
import shlex
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import mitsuba_scene  # noqa: E402

REPO = os.path.dirname(HERE)
SCENE = os.path.join("tools", "scenes", "peer_cornell", "scene.toml")
NX, NY, NT = 32, 32, 64
T0_PS, DT_PS = 13550.0, 250.0
# (name, femto max_bounces, first seed, default samples per pixel per batch)
REFERENCES = (("direct", 1, 0, 8192), ("all", 4, 1000, 2048))


def main():
    ap = argparse.ArgumentParser(description="Render the golden references of tests/golden.rs with mitransient.")
    ap.add_argument("--out", default=os.path.join(REPO, "tests", "golden", f"peer_cornell_{NX}x{NY}x{NT}.h5"))
    ap.add_argument("--batches", type=int, default=32, help="independent batches per reference (default 32)")
    ap.add_argument("--spp-scale", type=float, default=1.0,
                    help="multiply each reference's samples per pixel per batch (default 1: direct 8192, all 2048)")
    ap.add_argument("--threads", type=int, default=2, help="Dr.Jit threads (default 2)")
    args = ap.parse_args()
    if args.batches < 2 or not args.spp_scale > 0:
        raise SystemExit("--batches must be at least 2 and --spp-scale positive")

    import drjit as dr
    import h5py
    import mitsuba as mi

    mi.set_variant("llvm_ad_mono")
    import mitransient

    dr.set_thread_count(args.threads)
    scene_path = os.path.join(REPO, SCENE)
    scene = mitsuba_scene.load(scene_path)
    # The scene file and its meshes, verbatim: the test refuses a golden file whose scene
    # differs from the one in the tree.
    sources = [SCENE] + [os.path.join(os.path.dirname(SCENE), m["file"]) for m in scene["mesh"]]
    texts = {}
    for rel in sources:
        with open(os.path.join(REPO, rel), "rb") as f:
            texts[rel] = f.read()
    scene["camera"].update(nx=NX, ny=NY, nt=NT, t0_ps=T0_PS, dt_ps=DT_PS)

    results = {}
    for name, bounces, seed0, default_spp in REFERENCES:
        spp = max(1, round(default_spp * args.spp_scale))
        mi_scene = mi.load_dict(mitsuba_scene.mitsuba_dict(scene, mi, bounces, spp=spp))
        started = time.perf_counter()
        batches = []
        for b in range(args.batches):
            cube, _ = mitsuba_scene.render(mi_scene, mi, dr, spp, seed0 + b)
            if cube.shape != (NY, NX, NT):
                raise SystemExit(f"mitransient returned a cube of shape {cube.shape}, expected {(NY, NX, NT)}")
            batches.append(cube)
        stack = np.stack(batches)
        mean = stack.mean(axis=0)
        var_of_mean = stack.var(axis=0, ddof=1) / args.batches
        # Whole-image histogram of each batch: the test's aggregate checks take the variance of
        # sums over bins from these (bins of one path's bounces are correlated).
        hist = stack.sum(axis=(1, 2))
        results[name] = (mean, var_of_mean, hist, bounces, spp)
        seconds = time.perf_counter() - started
        print(f"{name}: {args.batches} x {spp} spp in {seconds:.1f} s, image sum {mean.sum():.6f} "
              f"+- {np.sqrt(var_of_mean.sum()):.6f} (per-bin variances summed)")

    out = os.path.abspath(args.out)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    tmp = out + ".tmp"
    try:
        with h5py.File(tmp, "w") as f:
            a = f.attrs
            a["scene_file"] = SCENE
            a["scene_sha256"] = hashlib.sha256(texts[SCENE]).hexdigest()
            a["source_files"] = list(sources)
            for rel, data in texts.items():
                a[f"text:{rel}"] = data.decode("utf-8")
            a["nx"], a["ny"], a["nt"] = NX, NY, NT
            a["t0_ps"], a["dt_ps"] = T0_PS, DT_PS
            a["batches"] = args.batches
            a["variant"] = "llvm_ad_mono"
            a["sampler"] = "independent"
            a["mitsuba_version"] = mi.__version__
            a["mitransient_version"] = mitransient.__version__
            a["drjit_version"] = dr.__version__
            a["command"] = shlex.join([os.path.relpath(sys.argv[0], REPO)] + sys.argv[1:])
            a["layout"] = ("datasets <ref>_mean and <ref>_var (variance of the mean), float32 (ny, nx, nt); "
                           "<ref>_batch_hist, float64 (batches, nt): each batch's whole-image histogram")
            for name, (mean, var, hist, bounces, spp) in results.items():
                f.create_dataset(f"{name}_batch_hist", data=hist)
                for kind, data in (("mean", mean), ("var", var)):
                    ds = f.create_dataset(f"{name}_{kind}", data=data.astype(np.float32),
                                          chunks=(1, NX, NT), shuffle=True, compression="gzip", compression_opts=9)
                    ds.attrs["spp_per_batch"] = spp
                    ds.attrs["max_bounces"] = bounces
                    ds.attrs["mitsuba_max_depth"] = bounces + 1
                    ds.attrs["first_seed"] = next(r[2] for r in REFERENCES if r[0] == name)
        os.replace(tmp, out)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    print(f"wrote {out} ({os.path.getsize(out) / 1024:.0f} kB)")


if __name__ == "__main__":
    main()

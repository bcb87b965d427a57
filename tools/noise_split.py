#!/usr/bin/env python3
"""Where femto's transient noise comes from, next to Mitsuba's: one-bounce (direct) light and
the rest, per time bin, on the scenes of tools/compare_mitsuba.py (issue 32).

    cargo build --release
    python3 tools/noise_split.py          # needs mitsuba, mitransient, h5py, numpy

For each renderer, `--seeds` renders at `--spp` of the whole light (the scene's bounces) and,
with the same seeds, of the direct light alone (femto `--bounces 1`, Mitsuba `max_depth 2`).
femto's direct render with a seed is exactly the one-bounce part of its full render with that
seed (the first vertex's connection to the spot uses only the pixel's position sample), so
its variance splits without approximation into direct, rest and their covariance; Mitsuba's
direct render is a separate estimate of the same quantity. The noise of each is the mean over
bins of the per-bin variance over the seeds. Both run with matched Russian roulette (femto
from bounce 3, Mitsuba rr_depth 2) and box time bins, as compare_mitsuba.py does.

With `--by-bounce` it splits femto's variance further, without Mitsuba: renders at 1, 2, 3
and the scene's bounces with the same seeds give, by difference, the light of exactly one,
exactly two, exactly three and of more bounces (each render with a seed is the same paths cut
shorter: roulette starts at bounce 3 and draws nothing before it). For each part it prints its
per-bin variance and share, its total, and how concentrated its variance is in the brightest
pixels; then the bound on what spending the samples unevenly over the pixels could give for
this measure of noise: with the per-pixel variance V_p of uniform sampling and equal cost per
sample, the best split of the same samples lowers the mean variance by P sum V_p / (sum
sqrt(V_p))^2 (an oracle's bound, from the variances measured over the seeds).

What it prints: each renderer's per-bin variance of the direct light, of the whole light, and
femto's direct share; and the variance ratios Mitsuba / femto for direct and whole light at the
same spp. At equal time per sample, the equal-noise speed-up is that variance ratio; the
direct light caps femto's whole-light ratio at (Mitsuba whole / femto direct) however well the
rest is estimated.
"""

import argparse
import os
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import compare_mitsuba as cm  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def per_bin_variance(cubes):
    """Mean over bins of the variance over the renders (ddof 1)."""
    return float(np.mean(np.var(np.stack(cubes), axis=0, ddof=1)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--femto", default=os.path.join(HERE, "..", "target", "release", "femto"))
    ap.add_argument("--scenes", default="peer_cornell")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--by-bounce", action="store_true",
                    help="femto only: split its variance by the number of bounces, and bound per-pixel allocation")
    args = ap.parse_args()
    for name in args.scenes.split(","):
        if args.by_bounce:
            by_bounce(name, args)
            continue
        bounces = cm.SCENES[name]
        scene_file = os.path.join(HERE, "scenes", name, "scene.toml")
        scene = cm.mitsuba_scene.load(scene_file)
        with tempfile.TemporaryDirectory() as work:
            f_full = [cm.femto_render(args.femto, scene_file, bounces, 3, args.spp, s, args.threads, work)[0]
                      for s in range(1, args.seeds + 1)]
            f_dir = [cm.femto_render(args.femto, scene_file, 1, 3, args.spp, s, args.threads, work)[0]
                     for s in range(1, args.seeds + 1)]
        m_full_r = cm.Mitsuba(scene, bounces, "multijitter", 2, args.threads)
        m_dir_r = cm.Mitsuba(scene, 1, "multijitter", 2, args.threads)
        m_full = [m_full_r.render(args.spp, s)[0] for s in range(1, args.seeds + 1)]
        m_dir = [m_dir_r.render(args.spp, s)[0] for s in range(1, args.seeds + 1)]
        vf, vfd = per_bin_variance(f_full), per_bin_variance(f_dir)
        vfr = per_bin_variance([a - b for a, b in zip(f_full, f_dir)])
        vm, vmd = per_bin_variance(m_full), per_bin_variance(m_dir)
        print(f"{name}: {args.spp} spp, {args.seeds} seeds, {bounces} bounces, {args.threads} threads")
        print(f"  femto   per-bin variance: whole {vf:.4e}, direct {vfd:.4e} ({100 * vfd / vf:.1f} %), "
              f"rest {vfr:.4e} ({100 * vfr / vf:.1f} %), covariance term {100 * (vf - vfd - vfr) / vf:+.1f} %")
        print(f"  mitsuba per-bin variance: whole {vm:.4e}, direct {vmd:.4e} ({100 * vmd / vm:.1f} %)")
        print(f"  variance ratio mitsuba / femto at equal spp: whole {vm / vf:.2f}x, direct {vmd / vfd:.2f}x; "
              f"with femto's rest noiseless, whole at most {vm / vfd:.2f}x")
        print(f"  totals: femto {np.mean([c.sum() for c in f_full]):.6e}, "
              f"mitsuba {np.mean([c.sum() for c in m_full]):.6e}")


def by_bounce(name, args):
    """femto's per-bin variance split by bounce count (see the module's doc)."""
    bounces = cm.SCENES[name]
    scene_file = os.path.join(HERE, "scenes", name, "scene.toml")
    cuts = sorted({1, 2, 3, bounces})
    seeds = range(1, args.seeds + 1)
    with tempfile.TemporaryDirectory() as work:
        renders = {b: [cm.femto_render(args.femto, scene_file, b, 3, args.spp, s, args.threads, work)[0]
                       for s in seeds] for b in cuts}
    whole = renders[bounces]
    v_whole = per_bin_variance(whole)
    print(f"{name}: femto, {args.spp} spp, {args.seeds} seeds, {bounces} bounces, {args.threads} threads, box bins")
    print(f"  whole light: per-bin variance {v_whole:.4e}, total {np.mean([c.sum() for c in whole]):.4f}")
    shares = 0.0
    for lo, hi in zip([0] + cuts[:-1], cuts):
        part = [a - (b if lo else 0) for a, b in zip(renders[hi], renders[lo] if lo else renders[hi])]
        var = np.var(np.stack(part), axis=0, ddof=1)
        pixels = np.sort(var.sum(axis=2).ravel())[::-1]
        top = pixels[: max(1, pixels.size // 10)].sum() / pixels.sum()
        label = f"{hi} bounce{'s' if hi > 1 else ''}" if hi == lo + 1 else f"{lo + 1}-{hi} bounces"
        shares += var.mean()
        print(f"  {label:>13}: per-bin variance {var.mean():.4e} ({100 * var.mean() / v_whole:5.1f} %), "
              f"total {np.mean([c.sum() for c in part]):.4f}, brightest-variance tenth of the pixels "
              f"holds {100 * top:.0f} % of it")
    print(f"  the parts' variances add to {100 * shares / v_whole:.1f} % of the whole's (the rest: covariance)")
    v_pixel = np.var(np.stack(whole), axis=0, ddof=1).sum(axis=2).ravel()
    gain = v_pixel.size * v_pixel.sum() / np.sqrt(v_pixel).sum() ** 2
    print(f"  per-pixel variance: max / median {v_pixel.max() / np.median(v_pixel):.0f}; the best uneven split "
          f"of the same samples over the pixels would lower the mean per-bin variance at most {gain:.2f}x")


if __name__ == "__main__":
    main()

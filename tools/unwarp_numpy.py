#!/usr/bin/env python3
"""Plain numpy time unwarp, the performance baseline for `femto::unwarp` (not used by femto).

Same semantics as `femto::unwarp::unwarp_rows` for equal source and destination bin widths:
each pixel's profile (values = signal integrated over each bin) is shifted by
-eta * d / c (camera -> world, seed Eq. 2) or +eta * d / c (world -> camera), reconstructed as
constant within each bin and integrated over each destination bin. A shift of k + f bins gives
dst[j] = (1 - f) src[j - k] + f src[j - k - 1]. The output axis covers every shifted profile and
is aligned with the input bins. Pixels with a NaN/negative distance or mask 0 come out zero with
mask 0. The cube is processed row by row (streaming), vectorised over the row's pixels.

Usage: python3 tools/unwarp_numpy.py [--nx 672 --ny 600 --nt 512 --reps 1] [--selftest]
Prints the kernel time and GB/s (bytes read + written / time).
"""
import argparse
import time

import numpy as np

C_M_PER_PS = 2.99792458e-4
SNAP_BINS = 1e-9


def covering_axis(t0_ps, dt_ps, nt, dmin_m, dmax_m, eta, to_world=True):
    sign = -1.0 if to_world else 1.0
    a, b = sign * eta * dmin_m / C_M_PER_PS, sign * eta * dmax_m / C_M_PER_PS
    lo, hi = min(a, b), max(a, b)
    k_lo, k_hi = np.floor(lo / dt_ps), np.ceil(hi / dt_ps)
    return t0_ps + k_lo * dt_ps, dt_ps, int(nt + k_hi - k_lo)


def unwarp(cube, t0_ps, dt_ps, dist_m, eta, mask=None, to_world=True, axis=None, out=None):
    """cube: (ny, nx, nt) float32, dist_m: (ny, nx). Returns (out, out_mask, (t0, dt, nt)).
    `out` (ny, nx, nt_out) float32 may be given (the benchmark passes a pre-faulted one)."""
    ny, nx, nt = cube.shape
    valid = np.isfinite(dist_m) & (dist_m >= 0)
    if mask is not None:
        valid &= mask != 0
    if axis is None:
        d = dist_m[valid].astype(np.float64)
        axis = covering_axis(t0_ps, dt_ps, nt, d.min(), d.max(), eta, to_world) if d.size else (t0_ps, dt_ps, nt)
    d0, _, nt_out = axis
    if out is None:
        out = np.empty((ny, nx, nt_out), np.float32)
    sign = -1.0 if to_world else 1.0
    j = np.arange(nt_out)[None, :]
    for y in range(ny):
        shift_ps = sign * eta * np.where(valid[y], dist_m[y], 0).astype(np.float64) / C_M_PER_PS
        s = (t0_ps + shift_ps - d0) / dt_ps
        k = np.floor(s)
        f = s - k
        k = np.where(f > 1 - SNAP_BINS, k + 1, k).astype(np.int64)
        f = np.where((f < SNAP_BINS) | (f > 1 - SNAP_BINS), 0.0, f)
        w1 = f.astype(np.float32)[:, None]
        w0 = (1.0 - f).astype(np.float32)[:, None]
        i0 = j - k[:, None]
        i1 = i0 - 1
        row = cube[y]
        g0 = np.take_along_axis(row, np.clip(i0, 0, nt - 1), axis=1)
        g1 = np.take_along_axis(row, np.clip(i1, 0, nt - 1), axis=1)
        g0 = np.where((i0 >= 0) & (i0 < nt), g0, 0)
        g1 = np.where((i1 >= 0) & (i1 < nt), g1, 0)
        r = w0 * g0 + w1 * g1
        r[~valid[y]] = 0
        out[y] = r
    return out, valid.astype(np.uint8), axis


def selftest():
    """Against a per-bin overlap integral written with plain Python loops."""
    rng = np.random.default_rng(1)
    ny, nx, nt, dt, t0, eta = 2, 3, 12, 1.7, 100.0, 1.3
    cube = rng.random((ny, nx, nt)).astype(np.float32)
    dist = rng.uniform(0.0, 0.01, (ny, nx)).astype(np.float32)
    dist[1, 2] = np.nan
    out, m, (d0, ddt, dnt) = unwarp(cube, t0, dt, dist, eta)
    for y in range(ny):
        for x in range(nx):
            if not np.isfinite(dist[y, x]):
                assert m[y, x] == 0 and not out[y, x].any()
                continue
            sh = -eta * float(dist[y, x]) / C_M_PER_PS
            ref = np.zeros(dnt)
            for i in range(nt):
                a, b = t0 + i * dt + sh, t0 + (i + 1) * dt + sh
                for jj in range(dnt):
                    lo, hi = max(a, d0 + jj * ddt), min(b, d0 + (jj + 1) * ddt)
                    if hi > lo:
                        ref[jj] += cube[y, x, i] * (hi - lo) / dt
            assert np.allclose(out[y, x], ref, atol=1e-5), (out[y, x], ref)
            assert abs(out[y, x].sum() - cube[y, x].sum()) < 1e-4
    print("selftest ok")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--nx", type=int, default=672)
    ap.add_argument("--ny", type=int, default=600)
    ap.add_argument("--nt", type=int, default=512)
    ap.add_argument("--reps", type=int, default=1)
    ap.add_argument("--selftest", action="store_true")
    a = ap.parse_args()
    if a.selftest:
        selftest()
        return
    rng = np.random.default_rng(0)
    cube = rng.random((a.ny, a.nx, a.nt), dtype=np.float32)
    # Same distance map as the Rust benchmark: 1.0 to 1.1 m across the image.
    yy, xx = np.mgrid[0 : a.ny, 0 : a.nx]
    dist = (1.0 + 0.1 * ((xx * 7 + yy * 13) % 1000) / 999.0).astype(np.float32)
    # Output written once before timing, as the Rust benchmark does.
    axis = covering_axis(0.0, 2.0, a.nt, 1.0, 1.1, 1.0)
    out = np.ones((a.ny, a.nx, axis[2]), np.float32)
    best = None
    for _ in range(a.reps):
        t = time.perf_counter()
        out, m, axis = unwarp(cube, 0.0, 2.0, dist, 1.0, axis=axis, out=out)
        dt = time.perf_counter() - t
        best = dt if best is None else min(best, dt)
    nbytes = cube.nbytes + dist.nbytes + out.nbytes + m.nbytes
    print(f"numpy unwarp: {best:.3f} s, {nbytes / best / 1e9:.2f} GB/s "
          f"({cube.nbytes / 1e6:.0f} MB in, {out.nbytes / 1e6:.0f} MB out, nt_out {axis[2]})")


if __name__ == "__main__":
    main()

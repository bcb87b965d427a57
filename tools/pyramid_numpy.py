#!/usr/bin/env python3
"""Plain numpy temporal prefix sums and mip levels, the performance baseline for
`femto::pyramid` (not used by femto).

Same semantics as `femto::pyramid`: per pixel, P[0] = 0 and P[i + 1] = P[i] + v[i]; mip level
k + 1 sums pairs of level k (the last sample alone when the length is odd), float32. The
integral over [ta, tb] is P(tb) - P(ta) with linear interpolation. P comes two ways: one float64
array (`prefix`, timed as "prefix" and "pyramid"), and the two-level form femto stores
(`prefix_two_level`: float64 every 8th bin, float32 within blocks; "prefix2", "pyramid2").
The baseline for femto's pyramid is the faster of "pyramid" and "pyramid2".

Usage: python3 tools/pyramid_numpy.py [--nx 672 --ny 600 --nt 512 --reps 1] [--selftest]
Prints the prefix, mip and whole-pyramid times (best and median of --reps), GB/s (bytes read +
written / best time) and the mean CPU seconds per run (process time).
"""
import argparse
import time

import numpy as np


def prefix(cube, out=None):
    """P[..., 0] = 0, P[..., i + 1] = P[..., i] + cube[..., i] in float64. `out` (ny, nx, nt + 1)
    float64 may be given (the benchmark passes a pre-allocated, pre-faulted one)."""
    ny, nx, nt = cube.shape
    p = np.empty((ny, nx, nt + 1), np.float64) if out is None else out
    p[..., 0] = 0
    v = p[..., 1:]
    v[...] = cube  # widen to float64 (the fastest of the variants tried), then sum in place
    np.cumsum(v, axis=2, out=v)
    return p


def prefix_two_level(cube, coarse=None, fine=None):
    """The two-level prefix femto stores (src/pyramid.rs): coarse[..., k] = P[8 k] in float64
    (nt // 8 + 1 values), fine[..., i] = P[i] - P[8 (i // 8)] in float32 (nt + 1 values), so
    P[i] = coarse[..., i // 8] + fine[..., i]. `coarse` and `fine` may be given (pre-faulted)."""
    ny, nx, nt = cube.shape
    nb = nt // 8
    coarse = np.empty((ny, nx, nb + 1), np.float64) if coarse is None else coarse
    fine = np.empty((ny, nx, nt + 1), np.float32) if fine is None else fine
    full = 8 * nb
    blocks = cube[..., :full].reshape(ny, nx, nb, 8)
    # Exclusive sums within each block: a strided (ny, nx, nb, 8) view of `fine`.
    f = np.lib.stride_tricks.as_strided(
        fine, shape=(ny, nx, nb, 8),
        strides=fine.strides[:2] + (8 * fine.strides[2], fine.strides[2]))
    f[..., 0] = 0
    np.cumsum(blocks[..., :7], axis=3, out=f[..., 1:])
    fine[..., full] = 0
    if nt > full:
        np.cumsum(cube[..., full:], axis=2, out=fine[..., full + 1:])
    coarse[..., 0] = 0
    np.cumsum(blocks.sum(axis=3, dtype=np.float64), axis=2, out=coarse[..., 1:])
    return coarse, fine


def level_shapes(shape):
    ny, nx, n = shape
    out = []
    while n > 1:
        n = (n + 1) // 2
        out.append((ny, nx, n))
    return out


def mips(cube, out=None):
    """Level k + 1 sums pairs of level k (the last sample alone when the length is odd), float32.
    `out` (arrays shaped as `level_shapes`) may be given: the benchmark passes pre-allocated,
    pre-faulted ones, as the Rust benchmark does."""
    levels = [np.empty(s, np.float32) for s in level_shapes(cube.shape)] if out is None else out
    cur = cube
    for lv in levels:
        half = cur.shape[2] // 2
        np.add(cur[..., 0:2 * half:2], cur[..., 1:2 * half:2], out=lv[..., :half])
        if cur.shape[2] % 2:
            lv[..., half] = cur[..., -1]
        cur = lv
    return levels


def pyramid(cube, p_out=None, l_out=None):
    """The prefix sums (float64) and every mip level."""
    return prefix(cube, out=p_out), mips(cube, out=l_out)


def pyramid_two_level(cube, c_out=None, f_out=None, l_out=None):
    """What `femto pyramid` computes: the two-level prefix sums and every mip level."""
    return prefix_two_level(cube, coarse=c_out, fine=f_out), mips(cube, out=l_out)


def integral(p, t0, dt, ta, tb):
    nt = p.shape[-1] - 1

    def at(t):
        c = np.clip((t - t0) / dt, 0, nt)
        i = np.minimum(np.floor(c).astype(np.int64), nt - 1)
        return p[..., i] + (c - i) * (p[..., i + 1] - p[..., i])

    return at(tb) - at(ta)


def selftest():
    rng = np.random.default_rng(2)
    v = rng.random((1, 1, 37)).astype(np.float32)
    p = prefix(v)
    assert abs(integral(p, 0.0, 1.0, 2.5, 3.25)[0, 0] - (0.5 * v[0, 0, 2] + 0.25 * v[0, 0, 3])) < 1e-6
    for nt in (1, 7, 8, 9, 37):
        w = rng.random((2, 1, nt)).astype(np.float32)
        c, f = prefix_two_level(w)
        p2 = np.repeat(c, 8, axis=2)[..., : nt + 1] + f
        assert np.allclose(p2, prefix(w), rtol=1e-6, atol=1e-6), nt
    lv = mips(v)
    assert [l.shape[2] for l in lv] == [19, 10, 5, 3, 2, 1]
    assert len(lv) == 6 and lv[-1].shape[2] == 1
    assert abs(lv[-1][0, 0, 0] - v.sum()) < 1e-4
    assert abs(lv[1][0, 0, 9] - v[0, 0, 36]) < 1e-7
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
    cube = np.random.default_rng(0).random((a.ny, a.nx, a.nt), dtype=np.float32)
    # Outputs written once before timing, as the Rust benchmark does, so page faults are not
    # counted.
    p = np.ones((a.ny, a.nx, a.nt + 1), np.float64)
    lv = [np.ones(s, np.float32) for s in level_shapes(cube.shape)]
    nb = a.nt // 8
    c2 = np.ones((a.ny, a.nx, nb + 1), np.float64)
    f2 = np.ones((a.ny, a.nx, a.nt + 1), np.float32)
    pbytes = cube.nbytes + p.nbytes
    p2bytes = cube.nbytes + c2.nbytes + f2.nbytes
    mbytes = sum(l.nbytes for l in lv) * 3  # each level: read 2x its size, write 1x
    lbytes = sum(l.nbytes for l in lv)
    allbytes = cube.nbytes + p.nbytes + lbytes  # as femto's one pass counts
    all2bytes = p2bytes + lbytes
    runs = {"prefix": (lambda: prefix(cube, out=p), pbytes),
            "prefix2": (lambda: prefix_two_level(cube, coarse=c2, fine=f2), p2bytes),
            "mips": (lambda: mips(cube, out=lv), mbytes),
            "pyramid": (lambda: pyramid(cube, p_out=p, l_out=lv), allbytes),
            "pyramid2": (lambda: pyramid_two_level(cube, c2, f2, lv), all2bytes)}
    for name, (f, nbytes) in runs.items():
        walls, cpu = [], 0.0
        for _ in range(a.reps):
            t, c = time.perf_counter(), time.process_time()
            f()
            walls.append(time.perf_counter() - t)
            cpu += time.process_time() - c
        walls.sort()
        best, median = walls[0], walls[len(walls) // 2]
        print(f"numpy {name + ':':10s} {best:.3f} s (median {median:.3f} s, CPU {cpu / a.reps:.3f} s per run), "
              f"{nbytes / best / 1e9:.2f} GB/s")


if __name__ == "__main__":
    main()

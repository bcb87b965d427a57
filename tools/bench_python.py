#!/usr/bin/env python3
"""Benchmark of the femto Python package against h5py and the `femto` binary (not a timed
test): prints the figures benches/python_results.md records, with the machine's load.

1. `femto.open_cube(p).data` against h5py's `f["cube"][...]` of the same 672 x 600 x 512
   cube (shuffle + deflate 1, as `femto ingest` writes), best of 3 each.
2. `femto.render` of 640 x 480 frames against `femto render --format png` of the same
   frames (time per frame, best of 3), on a world cube, calibration and mesh (a demo's data
   folder: DEMO/data/world.h5 ...).

Usage: tools/bench_python.py FEMTO_BIN DEMO_DIR [--frames N]
Compare builds of the same profile (the extension from `maturin develop` with
target/debug/femto, or `maturin develop --release` / `pip install` with target/release/femto).
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

import femto


def best_of(n, f):
    times = []
    for _ in range(n):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return min(times)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("femto_bin")
    ap.add_argument("demo_dir")
    ap.add_argument("--frames", type=int, default=8)
    a = ap.parse_args()
    print(f"femto {femto.__version__}, python {sys.version.split()[0]}, "
          f"{os.cpu_count()} CPUs, load before {os.getloadavg()}")

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        ny, nx, nt = 600, 672, 512
        rng = np.random.default_rng(1)
        t = np.arange(nt, dtype=np.float32)
        pulse = np.exp(-0.5 * ((t - 200) / 6.0) ** 2).astype(np.float32)
        data = rng.normal(0.02, 0.01, size=(ny, nx, nt)).astype(np.float32)
        data += rng.random((ny, nx, 1), dtype=np.float32) * pulse
        p = tmp / "big.h5"
        femto.cube_from_array(data, 2.0, 0.0, p, compression=1)
        del data
        print(f"cube {ny} x {nx} x {nt} float32, deflate 1: {p.stat().st_size / 1e6:.0f} MB")

        def h5():
            with h5py.File(p, "r") as f:
                return f["cube"][...]

        t_h5 = best_of(3, h5)
        t_fe = best_of(3, lambda: femto.open_cube(p, progress=False).data)
        assert np.array_equal(h5(), femto.open_cube(p, progress=False).data)
        print(f"read: h5py {t_h5:.3f} s, femto.open_cube().data {t_fe:.3f} s, "
              f"ratio {t_fe / t_h5:.2f} (limit 1.5); load {os.getloadavg()}")

    data_dir = Path(a.demo_dir) / "data"
    world, cal, mesh = data_dir / "world.h5", data_dir / "calibration.toml", data_dir / "capture/scene.glb"
    n = a.frames
    flags = ["--dolly", "0.5", "--size", "640x480", "--frame-count", str(n)]

    def cli():
        with tempfile.TemporaryDirectory() as out:
            subprocess.run([a.femto_bin, "render", "--cube", world, "--calibration", cal,
                            "--mesh", mesh, "--out", out, *flags], check=True,
                           capture_output=True)

    def py():
        return femto.render(world, cal, mesh, dolly=0.5, size=(640, 480), frame_count=n,
                            progress=False)

    t_cli = best_of(3, cli) / n
    t_py = best_of(3, py) / n
    print(f"render 640x480, {n} frames: CLI {t_cli * 1e3:.1f} ms/frame (process start, "
          f"input reading and PNG writing included), femto.render {t_py * 1e3:.1f} ms/frame, "
          f"ratio {t_py / t_cli:.2f} (limit 1.2); load {os.getloadavg()}")


if __name__ == "__main__":
    main()

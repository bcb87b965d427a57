//! Throughput of the in-memory cube kernels (time unwarp, the pyramid's prefix sums and mip
//! levels) against a
//! plain copy of the same bytes. Run through `tools/bench_cubeops.sh`, which also times the
//! numpy baselines; release build only.
//!
//! Usage: bench_cubeops [--nx 672] [--ny 600] [--nt 512] [--threads 2] [--reps 3]
//!                      [--only copy|unwarp|pyramid]
//!
//! GB/s counts bytes read plus bytes written (1 GB = 1e9 bytes), from the best of `reps`
//! runs; the median and the mean CPU seconds per run (time on a CPU of all threads, which a
//! shared machine's load disturbs less than wall time) are printed beside it. Output buffers are written once before timing so
//! that page faults are not counted.

use femto::cube::TimeAxis;
use femto::pyramid::{level_nt, pyramid_rows, top_level, PrefixRead, PrefixSums};
use femto::unwarp::{covering_axis, unwarp_rows, Direction};
use rayon::prelude::*;
use std::time::Instant;

fn arg(args: &[String], name: &str, default: usize) -> usize {
    match args.iter().position(|a| a == name) {
        Some(i) => args
            .get(i + 1)
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{name} needs a whole number")),
        None => default,
    }
}

/// CPU seconds spent so far by all threads of this process: the sum over
/// `/proc/self/task/*/schedstat` of the time on a CPU (Linux, nanoseconds; the time a
/// thread waits for a core on a shared machine is not counted); 0 where it is missing.
fn cpu_seconds() -> f64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    let ns: u64 = tasks
        .filter_map(|t| std::fs::read_to_string(t.ok()?.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .sum();
    ns as f64 * 1e-9
}

/// Runs `f` `reps` times; returns (best, median, mean CPU) seconds.
fn time(reps: usize, mut f: impl FnMut()) -> (f64, f64, f64) {
    let cpu0 = cpu_seconds();
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64()
        })
        .collect();
    let cpu = (cpu_seconds() - cpu0) / reps as f64;
    t.sort_by(f64::total_cmp);
    (t[0], t[t.len() / 2], cpu)
}

fn report(name: &str, (best, median, cpu): (f64, f64, f64), bytes: usize) {
    println!(
        "{name:<22} {best:>8.3} s (median {median:.3} s, CPU {cpu:.3} s)  {:>6.2} GB/s  ({:.0} MB moved)",
        bytes as f64 / best / 1e9,
        bytes as f64 / 1e6
    );
}

/// Fill in parallel (also pre-faults the pages).
fn touch<T: Copy + Send + Sync>(v: &mut [T], x: T) {
    v.par_chunks_mut(1 << 16).for_each(|c| c.fill(x));
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let nx = arg(&args, "--nx", 672);
    let ny = arg(&args, "--ny", 600);
    let nt = arg(&args, "--nt", 512);
    let threads = arg(&args, "--threads", 2);
    let reps = arg(&args, "--reps", 3).max(1);
    let only = args.iter().position(|a| a == "--only").map(|i| {
        args.get(i + 1)
            .expect("--only needs copy, unwarp or pyramid")
            .as_str()
    });
    let run = |name: &str| only.is_none_or(|o| o == name);
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .expect("thread pool");
    let n_pix = nx * ny;
    println!(
        "cube {nx} x {ny} x {nt} f32 ({:.0} MB), {threads} threads, best of {reps}",
        (n_pix * nt * 4) as f64 / 1e6
    );

    // Random-ish data: a per-pixel xorshift stream in [0, 1).
    let mut src = vec![0.0f32; n_pix * nt];
    src.par_chunks_mut(nt).enumerate().for_each(|(p, prof)| {
        let mut s = (p as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        for v in prof {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            *v = (s >> 40) as f32 / (1u64 << 24) as f32;
        }
    });
    // Distances 1.0 to 1.1 m across the image (the numpy script uses the same map).
    let dist_m: Vec<f32> = (0..n_pix)
        .map(|p| {
            let (x, y) = (p % nx, p / nx);
            1.0 + 0.1 * ((x * 7 + y * 13) % 1000) as f32 / 999.0
        })
        .collect();
    let src_axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: 2.0,
        nt,
    };

    // Plain copies of the cube: one thread (copy_from_slice) and the pool.
    if run("copy") {
        let mut dst = vec![0.0f32; src.len()];
        touch(&mut dst, 1.0);
        let bytes = 2 * src.len() * 4;
        report(
            "copy (1 thread)",
            time(reps, || dst.copy_from_slice(&src)),
            bytes,
        );
        let t = time(reps, || {
            dst.par_chunks_mut(1 << 16)
                .zip(src.par_chunks(1 << 16))
                .for_each(|(d, s)| d.copy_from_slice(s))
        });
        report(&format!("copy (rayon, {threads} thr)"), t, bytes);
        assert_eq!(dst[dst.len() / 2], src[src.len() / 2]);
    }

    // Unwarp camera -> world onto the covering axis.
    if run("unwarp") {
        let dst_axis = covering_axis(&src_axis, 1.0, 1.1, 1.0, Direction::CameraToWorld)
            .expect("a 10 cm span of distances gives a small axis");
        let mut dst = vec![0.0f32; n_pix * dst_axis.nt];
        let mut mask = vec![0u8; n_pix];
        touch(&mut dst, 1.0);
        touch(&mut mask, 1);
        let t = time(reps, || {
            unwarp_rows(
                &src,
                nx,
                ny,
                &src_axis,
                &dist_m,
                &[],
                None,
                1.0,
                Direction::CameraToWorld,
                &dst_axis,
                &mut dst,
                &mut mask,
            )
        });
        let bytes = src.len() * 4 + n_pix * 4 + dst.len() * 4 + n_pix;
        report(&format!("unwarp (nt_out {})", dst_axis.nt), t, bytes);
        let (a, b) = (
            src.iter().map(|&v| v as f64).sum::<f64>(),
            dst.iter().map(|&v| v as f64).sum::<f64>(),
        );
        println!("  check: total {a:.6e} -> {b:.6e}");
    }

    // The pyramid: prefix sums (two-level, f64 + f32) alone, then prefix sums and every mip
    // level in the one pass `femto pyramid` makes.
    if run("pyramid") {
        let mut prefix = PrefixSums::zeros(n_pix, nt);
        touch(&mut prefix.coarse, 1.0);
        touch(&mut prefix.fine, 1.0);
        let prefix_bytes = prefix.coarse.len() * 8 + prefix.fine.len() * 4;
        let t = time(reps, || pyramid_rows(&src, nt, prefix.slices(), &mut []));
        report("prefix only (2-level)", t, src.len() * 4 + prefix_bytes);
        println!("  check: P_end(0) {:.6e}", prefix.pixel(0).total());
        let mut levels: Vec<Vec<f32>> = (1..=top_level(nt))
            .map(|k| vec![1.0f32; n_pix * level_nt(nt, k)])
            .collect();
        levels.iter_mut().for_each(|l| touch(l, 1.0));
        let bytes =
            src.len() * 4 + prefix_bytes + levels.iter().map(|l| l.len() * 4).sum::<usize>();
        let t = time(reps, || {
            let mut outs: Vec<&mut [f32]> = levels.iter_mut().map(|l| &mut l[..]).collect();
            pyramid_rows(&src, nt, prefix.slices(), &mut outs)
        });
        report(&format!("pyramid ({} levels)", levels.len()), t, bytes);
        let top = levels.last().map_or(0.0, |l| l[0] as f64);
        println!(
            "  check: top level(0) {top:.6e}, P_end(0) {:.6e}",
            prefix.pixel(0).total()
        );
    }
}

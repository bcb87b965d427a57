//! Transient path tracer throughput (pbrt-style counters): camera paths and rays per second
//! on the built-in `cornell` scene at 64 x 64 pixels and 300 time bins, with 1 and 2 rayon
//! threads. Run with `cargo bench --bench tracer`; `FEMTO_BENCH_SPP` sets the samples per
//! pixel (default 16), `FEMTO_BENCH_BOUNCES` the maximum bounces (default 4),
//! `FEMTO_BENCH_LIGHT_VERTEX` 0 or 1 for `TraceOptions::light_vertex` (default: the
//! library's).
//!
//! The comparison with Mitsuba runs from the release binary instead
//! (`tools/compare_mitsuba.py`, `femto simulate --transient-only`).

use femto::geometry::bvh::Bvh;
use femto::scene::Scene;
use femto::tracer::{trace, TraceOptions};
use std::time::Instant;

fn env_or(name: &str, default: u32) -> u32 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// `TraceOptions::light_vertex` from `FEMTO_BENCH_LIGHT_VERTEX` (0 or 1), else the default.
fn light_vertex() -> bool {
    env_or(
        "FEMTO_BENCH_LIGHT_VERTEX",
        TraceOptions::default().light_vertex as u32,
    ) != 0
}

fn main() {
    let scene = Scene::builtin("cornell", None)
        .expect("built-in scene")
        .with_resolution(64, 64, 300, 4.0);
    let built = Instant::now();
    let bvh = Bvh::new(scene.mesh.clone());
    let build_s = built.elapsed().as_secs_f64();
    let opts = TraceOptions {
        spp: env_or("FEMTO_BENCH_SPP", 16),
        max_bounces: env_or("FEMTO_BENCH_BOUNCES", 4),
        seed: 1,
        light_vertex: light_vertex(),
        ..TraceOptions::default()
    };
    println!(
        "tracer bench: scene cornell, {} triangles, 64x64 px, 300 bins, spp {}, max bounces {}, light vertex {}, BVH build {:.3} s",
        scene.mesh.triangle_count(),
        opts.spp,
        opts.max_bounces,
        opts.light_vertex,
        build_s
    );
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        // One warm-up render, then the measured one.
        pool.install(|| trace(&scene, &bvh, &TraceOptions { spp: 1, ..opts }, &|_| {}));
        let r = pool.install(|| trace(&scene, &bvh, &opts, &|_| {}));
        let s = r.stats;
        let cpu = s.cpu_seconds;
        println!(
            "threads {threads}: {:.3} s, {:.2} CPU s, {} paths, {:.0} paths/s, {:.0} paths per CPU s, {} rays, {:.0} rays/s, {} samples ({} outside the window), {} paths ended past the window",
            s.seconds,
            cpu,
            s.paths,
            s.paths_per_second(),
            s.paths as f64 / cpu,
            s.rays,
            s.rays as f64 / s.seconds,
            s.samples,
            s.samples_outside_window,
            s.paths_ended_late
        );
    }
}

//! Transient path tracer throughput (pbrt-style counters): camera paths and rays per second
//! on the built-in `cornell` scene at 64 x 64 pixels and 300 time bins, with 1 and 2 rayon
//! threads. Run with `cargo bench --bench tracer`; `FEMTO_BENCH_SPP` sets the samples per
//! pixel (default 16), `FEMTO_BENCH_BOUNCES` the maximum bounces (default 4),
//! `FEMTO_BENCH_LIGHT_VERTEX` 0 or 1 for `TraceOptions::light_vertex` (default: the
//! library's; the comparison dump too).
//!
//! With `FEMTO_BENCH_DUMP=<dir>` it instead writes what `tools/compare_mitsuba.py` needs to
//! compare against Mitsuba 3 transient: the scene (one OBJ per material, `scene.json`) and
//! isotropic-emission renders (spot lowered to 3 cm under the ceiling) at 4, 16 and 256 spp
//! on 2 threads, each from its own seed (`cube_spp<N>.f32`, raw
//! little-endian f32 `[y][x][t]`, with their timings in `scene.json`).

use femto::geometry::bvh::Bvh;
use femto::scene::{Emission, Scene};
use femto::tracer::{trace, TraceOptions};
use std::fmt::Write as _;
use std::path::Path;
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

/// CPU seconds (user + system, all threads) this process has used so far, from
/// `/proc/self/stat` (clock ticks of 1/100 s); `None` where that file is missing. On a shared
/// machine this is steadier than wall time.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: u64 = f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?;
    Some(ticks as f64 / 100.0)
}

fn main() {
    let scene = Scene::builtin("cornell", None)
        .expect("built-in scene")
        .with_resolution(64, 64, 300, 4.0);
    let built = Instant::now();
    let bvh = Bvh::new(scene.mesh.clone());
    let build_s = built.elapsed().as_secs_f64();
    if let Ok(dir) = std::env::var("FEMTO_BENCH_DUMP") {
        dump_for_comparison(&scene, &bvh, Path::new(&dir));
        return;
    }
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
        let cpu0 = cpu_seconds();
        let r = pool.install(|| trace(&scene, &bvh, &opts, &|_| {}));
        let cpu = cpu_seconds()
            .zip(cpu0)
            .map(|(b, a)| b - a)
            .unwrap_or(f64::NAN);
        let s = r.stats;
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

/// Write the scene and isotropic renders for `tools/compare_mitsuba.py`.
fn dump_for_comparison(scene: &Scene, bvh: &Bvh, dir: &Path) {
    std::fs::create_dir_all(dir).expect("dump folder");
    // An isotropic point 1 mm under the ceiling gives the ceiling an irradiance that grows as
    // 1 / r^3 near the spot (heavy-tailed noise in both renderers): lower it to 3 cm.
    let mut scene = scene.clone();
    scene.laser.position_m.y -= 0.029;
    let scene = &scene;
    let mesh = &scene.mesh;
    for (m, _) in scene.albedo.iter().enumerate() {
        let mut obj = String::new();
        let mut k = 0;
        for i in 0..mesh.triangle_count() {
            if mesh.material[i] as usize != m {
                continue;
            }
            for p in mesh.corners(i) {
                writeln!(obj, "v {:.9} {:.9} {:.9}", p.x, p.y, p.z).unwrap();
            }
            writeln!(obj, "f {} {} {}", k + 1, k + 2, k + 3).unwrap();
            k += 3;
        }
        std::fs::write(dir.join(format!("mesh_{m}.obj")), obj).expect("write obj");
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("thread pool");
    let mut renders = Vec::new();
    for (spp, seed) in [(4u32, 7u64), (16, 8), (256, 9)] {
        let opts = TraceOptions {
            spp,
            max_bounces: 4,
            seed,
            emission: Some(Emission::Isotropic),
            split_bounces: false,
            world_time: false,
            light_vertex: light_vertex(),
            ..TraceOptions::default()
        };
        let cpu0 = cpu_seconds();
        let r = pool.install(|| trace(scene, bvh, &opts, &|_| {}));
        let cpu = cpu_seconds()
            .zip(cpu0)
            .map(|(b, a)| b - a)
            .unwrap_or(f64::NAN);
        let bytes: Vec<u8> = r
            .camera_time
            .data
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        std::fs::write(dir.join(format!("cube_spp{spp}.f32")), bytes).expect("write cube");
        println!(
            "dumped spp {spp}: {:.3} s, {:.2} CPU s",
            r.stats.seconds, cpu
        );
        renders.push(format!(
            "{{\"spp\": {spp}, \"seconds\": {}, \"cpu_seconds\": {}}}",
            r.stats.seconds, cpu
        ));
    }
    let c = &scene.camera;
    let v3 = |p: &nalgebra::Point3<f64>| format!("[{}, {}, {}]", p.x, p.y, p.z);
    let target = c.pose.position_m + c.pose.forward();
    let up = -(c.pose.world_from_camera * nalgebra::Vector3::y());
    let json = format!(
        "{{\"albedo\": {:?}, \"laser_m\": {}, \"energy\": {}, \"eta\": {}, \"camera_m\": {}, \"target_m\": {}, \"up\": [{}, {}, {}], \"vfov_deg\": {}, \"nx\": {}, \"ny\": {}, \"t0_ps\": {}, \"dt_ps\": {}, \"nt\": {}, \"max_bounces\": 4, \"renders\": [{}]}}\n",
        scene.albedo,
        v3(&scene.laser.position_m),
        scene.laser.energy,
        scene.eta,
        v3(&c.pose.position_m),
        v3(&target),
        up.x,
        up.y,
        up.z,
        c.vfov_deg,
        c.intrinsics.width,
        c.intrinsics.height,
        c.axis.t0_ps,
        c.axis.dt_ps,
        c.axis.nt,
        renders.join(", ")
    );
    std::fs::write(dir.join("scene.json"), json).expect("write scene.json");
}

//! Frame rate of the relativistic renderer on the built-in cube scene (`Scene::builtin("cube")`:
//! a 7 cm box on a floor before a wall, `femto::scene`) at 640 x 480, on a
//! rayon pool of 2 threads:
//!
//! - `all_effects`: the full transient pipeline (aberration, Doppler colour, searchlight
//!   accumulation, time dilation, per-view unwarp, capture visibility lookup);
//! - `effects_none`: the same frame with every effect off (ray cast, capture lookup, prefix
//!   sums, colour);
//! - (summary only) `all effects, rays reused`: the full pipeline through
//!   `render_frame_reusing_rays`, as `render_sequence` renders the frames of a dolly after the
//!   first (the camera rays, aberration and Doppler factors of the frame before are reused):
//!   frames 49 and 50 in turn, so the rays are cast from a new place each time;
//! - (summary only) `all effects, time alone moves`: frame 50's camera (same place, same
//!   velocity) with its time moved by a frame interval in turn, as `femto view` plays a camera
//!   at rest (rays and hits reused: the ray cast is skipped);
//! - `ray_cast_all` / `ray_cast_none`: only the world rays of the same two frames (the
//!   aberrated rays of the full pipeline; the plain pinhole rays with every effect off), made
//!   beforehand and cast against the BVH (`Bvh::intersect`), hit distances written to a
//!   buffer. The difference to the full frames is the cost of the physics and the lookups.
//!
//! The world-time cube is synthetic (single-bounce light in flight from the scene's laser
//! spot, `tests/common`), on the scene's own 64 x 48 capture camera, 256 bins of 6 ps. The
//! camera dollies towards the box at beta 0.5 (`--dolly 0.5` of the command line); the frame
//! benchmarked is frame 50 of 100. A summary is printed at the end, from the four jobs run in
//! interleaved rounds (so that a change of load on a shared machine affects each alike):
//! wall time per frame, CPU time per frame (time on a CPU of all the process's threads,
//! `/proc/self/task/*/schedstat`; the steadier figure on a machine shared with other jobs),
//! and the frame rate two dedicated cores would give, `2 / CPU seconds per frame` (rows are
//! independent, so the two threads stay busy).
//!
//! Run: `cargo bench --bench render`.

#[path = "../tests/common/mod.rs"]
mod common;

use criterion::Criterion;
use femto::camera_path::FrameState;
use femto::cube::TimeAxis;
use femto::geometry::bvh::Bvh;
use femto::geometry::Ray;
use femto::pyramid::Pyramid;
use femto::render::paths::{shortcut_path, Shortcut};
use femto::render::{
    probe_pixel, render_frame, render_frame_reusing_rays, Effects, FrameRays, RenderScene,
    RenderSettings,
};
use femto::scene::Scene;
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use std::time::{Duration, Instant};

const WIDTH: usize = 640;
const HEIGHT: usize = 480;
const THREADS: usize = 2;

/// The world ray of every pixel of a frame, as the renderer casts it.
fn frame_rays(scene: &RenderScene, settings: &RenderSettings, state: &FrameState) -> Vec<Ray> {
    let o = state.position_m;
    let origin = Point3::new(o.x as f32, o.y as f32, o.z as f32);
    (0..HEIGHT)
        .flat_map(|j| (0..WIDTH).map(move |i| (i, j)))
        .map(|(i, j)| {
            let d = probe_pixel(scene, settings, state, i, j).d_world;
            Ray::new(origin, Vector3::new(d.x as f32, d.y as f32, d.z as f32))
        })
        .collect()
}

/// Cast `rays` against the mesh, one rayon task per image row.
fn ray_cast(bvh: &Bvh, rays: &[Ray], out: &mut [f32]) {
    out.par_chunks_mut(WIDTH)
        .zip(rays.par_chunks(WIDTH))
        .for_each(|(row, rays)| {
            for (t, ray) in row.iter_mut().zip(rays) {
                *t = bvh
                    .intersect(ray, 0.0, f32::INFINITY)
                    .map_or(f32::INFINITY, |h| h.t);
            }
        });
}

/// CPU seconds spent so far by all threads of this process: the sum over
/// `/proc/self/task/*/schedstat` of the time on a CPU (Linux, nanoseconds, unaffected by
/// the time a thread waits for a core on a shared machine), or `None` where it is missing.
fn cpu_seconds() -> Option<f64> {
    let mut ns = 0u64;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        ns += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(ns as f64 * 1e-9)
}

/// Wall and CPU seconds per call of each of `jobs`, run on `pool` in interleaved rounds (one
/// call of each job per round, after one warm-up round) for at least 12 s of wall time and
/// 10 rounds, so that a change of the machine's load affects every job alike.
fn seconds_per_frame(
    pool: &rayon::ThreadPool,
    jobs: &mut [&mut (dyn FnMut() + Send)],
) -> Vec<(f64, Option<f64>)> {
    pool.install(|| {
        jobs.iter_mut().for_each(|f| f());
        let mut wall = vec![0.0; jobs.len()];
        let mut cpu = vec![Some(0.0); jobs.len()];
        let start = Instant::now();
        let mut n = 0;
        while start.elapsed() < Duration::from_secs(12) || n < 10 {
            for (k, f) in jobs.iter_mut().enumerate() {
                let (c0, t0) = (cpu_seconds(), Instant::now());
                f();
                wall[k] += t0.elapsed().as_secs_f64();
                cpu[k] = cpu[k]
                    .zip(c0.zip(cpu_seconds()))
                    .map(|(s, (a, b))| s + b - a);
            }
            n += 1;
        }
        wall.iter()
            .zip(cpu)
            .map(|(w, c)| (w / n as f64, c.map(|c| c / n as f64)))
            .collect()
    })
}

fn main() {
    let cube_scene = Scene::builtin("cube", None).expect("built-in cube scene");
    let bvh = Bvh::new(cube_scene.mesh.clone());
    let cal = cube_scene.calibration();
    assert_eq!((cal.intrinsics.width, cal.intrinsics.height), (64, 48));
    let axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: 6.0,
        nt: 256,
    };
    let cube = common::world_cube(&cal, &bvh, axis, common::single_bounce_energy(&cal, 10.0));
    let pyramid = Pyramid::build(&cube);
    let scene =
        RenderScene::new(&bvh, cal, &pyramid, cube_scene.laser.wavelength_nm).expect("scene");
    let s = shortcut_path(
        &scene,
        Shortcut::Dolly { beta: 0.5 },
        WIDTH,
        HEIGHT,
        100,
        None,
    )
    .expect("dolly path");
    let state = s.path.frame(50);
    let dolly = [s.path.frame(49), state];
    let mut later = state;
    later.t_world_ps += s.path.spec().dtau_ps;
    later.tau_ps += s.path.spec().dtau_ps;
    let at_rest = [later, state];
    let mut all = RenderSettings::for_path(&s.path);
    all.time_offset_ps = s.time_offset_ps;
    let none = RenderSettings {
        effects: Effects::NONE,
        ..all
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(THREADS)
        .build()
        .expect("thread pool");
    let mut pixels = vec![[0.0f32; 3]; WIDTH * HEIGHT];
    let mut depth = vec![0.0f32; WIDTH * HEIGHT];
    let (mut pixels2, mut pixels3, mut depth2) = (pixels.clone(), pixels.clone(), depth.clone());
    let mut pixels4 = pixels.clone();
    let (mut reused, mut resting) = (FrameRays::default(), FrameRays::default());
    let (mut k_dolly, mut k_rest) = (0usize, 0usize);
    let rays_all = frame_rays(&scene, &all, &state);
    let rays_none = frame_rays(&scene, &none, &state);

    // The frame is not black (a benchmark of an empty frame would flatter the renderer).
    pool.install(|| render_frame(&scene, &all, &state, &mut pixels));
    let lit = pixels.iter().filter(|p| p[0] + p[1] + p[2] > 0.0).count();
    assert!(lit > WIDTH * HEIGHT / 20, "only {lit} lit pixels");
    let hits = |rays: &[Ray], depth: &mut [f32]| {
        pool.install(|| ray_cast(&bvh, rays, depth));
        depth.iter().filter(|t| t.is_finite()).count()
    };
    let hits_all = hits(&rays_all, &mut depth);
    let hits_none = hits(&rays_none, &mut depth);

    let mut c = Criterion::default().configure_from_args();
    let mut group = c.benchmark_group(format!("render_{WIDTH}x{HEIGHT}_{THREADS}_threads"));
    group.sample_size(20);
    group.bench_function("all_effects", |b| {
        b.iter(|| pool.install(|| render_frame(&scene, &all, &state, &mut pixels)))
    });
    group.bench_function("effects_none", |b| {
        b.iter(|| pool.install(|| render_frame(&scene, &none, &state, &mut pixels)))
    });
    group.bench_function("ray_cast_all", |b| {
        b.iter(|| pool.install(|| ray_cast(&bvh, &rays_all, &mut depth)))
    });
    group.bench_function("ray_cast_none", |b| {
        b.iter(|| pool.install(|| ray_cast(&bvh, &rays_none, &mut depth)))
    });
    group.finish();
    c.final_summary();

    let times = seconds_per_frame(
        &pool,
        &mut [
            &mut || render_frame(&scene, &all, &state, &mut pixels),
            &mut || render_frame(&scene, &none, &state, &mut pixels2),
            &mut || ray_cast(&bvh, &rays_all, &mut depth),
            &mut || ray_cast(&bvh, &rays_none, &mut depth2),
            &mut || {
                k_dolly += 1;
                let frame = &dolly[k_dolly % 2];
                render_frame_reusing_rays(&scene, &all, frame, &mut reused, &mut pixels3)
            },
            &mut || {
                k_rest += 1;
                let frame = &at_rest[k_rest % 2];
                render_frame_reusing_rays(&scene, &all, frame, &mut resting, &mut pixels4)
            },
        ],
    );
    let (t_all, t_none, t_cast_all, t_cast_none) = (times[0], times[1], times[2], times[3]);
    let (t_reused, t_rest) = (times[4], times[5]);
    println!(
        "render {WIDTH}x{HEIGHT}, {THREADS} threads, built-in cube scene, {} triangles; \
         frame 50 of a 100-frame dolly at beta 0.5: {lit} pixels lit, rays hitting the mesh: \
         {hits_all} (all effects), {hits_none} (effects none) of {}",
        bvh.mesh().triangle_count(),
        WIDTH * HEIGHT
    );
    println!(
        "  {:<30} {:>10} {:>9} {:>10} {:>16}",
        "", "wall ms", "wall fps", "CPU ms", "fps on 2 cores"
    );
    for (name, (wall, cpu)) in [
        ("all effects", t_all),
        ("all effects, rays reused", t_reused),
        ("all effects, time alone moves", t_rest),
        ("--effects none", t_none),
        ("ray cast (all-effects rays)", t_cast_all),
        ("ray cast (effects-none rays)", t_cast_none),
    ] {
        let (cpu_ms, fps2) = match cpu {
            Some(c) => (
                format!("{:.2}", c * 1e3),
                format!("{:.1}", THREADS as f64 / c),
            ),
            None => ("n/a".into(), "n/a".into()),
        };
        println!(
            "  {name:<30} {:>10.2} {:>9.1} {cpu_ms:>10} {fps2:>16}",
            wall * 1e3,
            1.0 / wall
        );
    }
    if let (Some(a), Some(c)) = (t_all.1, t_cast_all.1) {
        println!(
            "  physics and lookups, all effects: {:.2} CPU ms = {:.2} x the ray cast",
            (a - c) * 1e3,
            (a - c) / c
        );
    }
    if let (Some(a), Some(c)) = (t_reused.1, t_cast_all.1) {
        println!(
            "  physics and lookups, all effects, rays reused (a dolly's frames): {:.2} CPU ms = {:.2} x the ray cast",
            (a - c) * 1e3,
            (a - c) / c
        );
    }
    if let (Some(a), Some(c)) = (t_none.1, t_cast_none.1) {
        println!(
            "  lookups, effects none: {:.2} CPU ms = {:.2} x the ray cast",
            (a - c) * 1e3,
            (a - c) / c
        );
    }
}

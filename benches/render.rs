//! Frame rate of the relativistic renderer on the built-in cube scene (`Scene::builtin("cube")`:
//! a 7 cm box on a floor before a wall, `femto::scene`) at 640 x 480, on a
//! rayon pool of 2 threads:
//!
//! - `all_effects`: the full transient pipeline (aberration, Doppler colour, searchlight
//!   accumulation, time dilation, per-view unwarp, capture visibility lookup);
//! - `effects_none`: the same frame with every effect off (ray cast, capture lookup, prefix
//!   sums, colour);
//! - `bare_ray_cast`: only the camera rays of the same frame cast against the BVH
//!   (`Bvh::intersect`), hit distances written to a buffer.
//!
//! The world-time cube is synthetic (single-bounce light in flight from the scene's laser
//! spot, `tests/common`), on the scene's own 64 x 48 capture camera, 256 bins of 6 ps. The
//! camera dollies towards the box at beta 0.5 (`--dolly 0.5` of the command line); the frame
//! benchmarked is frame 50 of 100. A summary in frames per second is printed at the end.
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
use femto::render::{render_frame, Effects, RenderScene, RenderSettings};
use femto::scene::Scene;
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use std::time::{Duration, Instant};

const WIDTH: usize = 640;
const HEIGHT: usize = 480;
const THREADS: usize = 2;

/// Camera rays of the frame (pinhole, no aberration) cast against the mesh.
fn bare_ray_cast(bvh: &Bvh, state: &FrameState, out: &mut [f32]) {
    let f = 0.5 * HEIGHT as f64 / (0.5 * state.vfov_deg.to_radians()).tan();
    let r = *state.world_from_camera.matrix();
    let o = state.position_m;
    let origin = Point3::new(o.x as f32, o.y as f32, o.z as f32);
    out.par_chunks_mut(WIDTH).enumerate().for_each(|(j, row)| {
        for (i, t) in row.iter_mut().enumerate() {
            let local = Vector3::new(
                (i as f64 + 0.5 - 0.5 * WIDTH as f64) / f,
                (j as f64 + 0.5 - 0.5 * HEIGHT as f64) / f,
                1.0,
            );
            let d = (r * local).normalize();
            let ray = Ray::new(origin, Vector3::new(d.x as f32, d.y as f32, d.z as f32));
            *t = bvh
                .intersect(&ray, 0.0, f32::INFINITY)
                .map_or(f32::INFINITY, |h| h.t);
        }
    });
}

fn seconds_per_frame(pool: &rayon::ThreadPool, mut f: impl FnMut() + Send) -> f64 {
    pool.install(|| {
        f();
        let start = Instant::now();
        let mut n = 0;
        while start.elapsed() < Duration::from_secs(3) || n < 10 {
            f();
            n += 1;
        }
        start.elapsed().as_secs_f64() / n as f64
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

    // The frame is not black (a benchmark of an empty frame would flatter the renderer).
    pool.install(|| render_frame(&scene, &all, &state, &mut pixels));
    let lit = pixels.iter().filter(|p| p[0] + p[1] + p[2] > 0.0).count();
    assert!(lit > WIDTH * HEIGHT / 20, "only {lit} lit pixels");

    let mut c = Criterion::default().configure_from_args();
    let mut group = c.benchmark_group(format!("render_{WIDTH}x{HEIGHT}_{THREADS}_threads"));
    group.sample_size(20);
    group.bench_function("all_effects", |b| {
        b.iter(|| pool.install(|| render_frame(&scene, &all, &state, &mut pixels)))
    });
    group.bench_function("effects_none", |b| {
        b.iter(|| pool.install(|| render_frame(&scene, &none, &state, &mut pixels)))
    });
    group.bench_function("bare_ray_cast", |b| {
        b.iter(|| pool.install(|| bare_ray_cast(&bvh, &state, &mut depth)))
    });
    group.finish();
    c.final_summary();

    let t_all = seconds_per_frame(&pool, || render_frame(&scene, &all, &state, &mut pixels));
    let t_none = seconds_per_frame(&pool, || render_frame(&scene, &none, &state, &mut pixels));
    let t_cast = seconds_per_frame(&pool, || bare_ray_cast(&bvh, &state, &mut depth));
    println!(
        "render {WIDTH}x{HEIGHT}, {THREADS} threads, built-in cube scene, {} triangles ({lit} of {} pixels lit):",
        bvh.mesh().triangle_count(),
        WIDTH * HEIGHT
    );
    for (name, t) in [
        ("all effects", t_all),
        ("--effects none", t_none),
        ("bare ray cast", t_cast),
    ] {
        println!(
            "  {name:<15} {:8.2} ms/frame {:8.1} frames/s",
            t * 1e3,
            1.0 / t
        );
    }
    println!(
        "  physics cost (all effects - ray cast) / ray cast: {:.2}",
        (t_all - t_cast) / t_cast
    );
}

//! Ray casting throughput of femto's BVH on given meshes and rays, for
//! `tools/compare_raycast.py` (which times Embree, through Mitsuba, on the very same rays).
//!
//! Usage: `raycast RAYS.f32 MESH.obj [MESH.obj ...]`, where `RAYS.f32` holds little-endian
//! f32 rows `(ox, oy, oz, dx, dy, dz)` with unit directions. Prints one line per thread count
//! (1 and 2): rays, hits, the best wall time of the passes, Mrays/s wall and per CPU-second.

use femto::geometry::bvh::Bvh;
use femto::geometry::load::load_mesh;
use femto::geometry::{Ray, TriangleMesh};
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use std::time::Instant;

/// User plus system CPU seconds of this process (`/proc/self/stat`), if readable.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let f: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        eprintln!("usage: raycast RAYS.f32 MESH.obj [MESH.obj ...]");
        std::process::exit(2);
    }
    let bytes = std::fs::read(&args[0]).unwrap_or_else(|e| {
        eprintln!("{}: {e}", args[0]);
        std::process::exit(2)
    });
    let v: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let rays: Vec<Ray> = v
        .chunks_exact(6)
        .map(|r| {
            Ray::new(
                Point3::new(r[0], r[1], r[2]),
                Vector3::new(r[3], r[4], r[5]),
            )
        })
        .collect();
    let mut mesh = TriangleMesh::default();
    for path in &args[1..] {
        let m = load_mesh(std::path::Path::new(path)).unwrap_or_else(|e| {
            eprintln!("{path}: {e}");
            std::process::exit(2)
        });
        mesh.append(&m, 0);
    }
    let triangles = mesh.triangle_count();
    let bvh = Bvh::new(mesh);
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        let pass = || {
            pool.install(|| {
                rays.par_chunks(4096)
                    .map(|c| {
                        c.iter()
                            .filter(|r| bvh.intersect(r, 0.0, f32::INFINITY).is_some())
                            .count()
                    })
                    .sum::<usize>()
            })
        };
        let hits = pass();
        let (cpu0, mut best, passes) = (cpu_seconds(), f64::INFINITY, 8);
        for _ in 0..passes {
            let t = Instant::now();
            std::hint::black_box(pass());
            best = best.min(t.elapsed().as_secs_f64());
        }
        let per_cpu = cpu0.zip(cpu_seconds()).map_or(f64::NAN, |(a, b)| {
            (passes * rays.len()) as f64 / (b - a).max(1e-9) / 1e6
        });
        println!(
            "femto  {threads} thr: {triangles} triangles, {} rays, {hits} hits, best {best:.4} s, {:.2} Mrays/s wall, {per_cpu:.2} Mrays per CPU s",
            rays.len(),
            rays.len() as f64 / best / 1e6,
        );
    }
}

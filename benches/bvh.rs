//! Ray casting throughput on the Stanford bunny (69 451 triangles): femto's own SAH BVH
//! against `obvhs` 0.4 (compressed wide BVH8, SIMD traversal) given the same watertight
//! two-sided triangle test, on the same rays.
//!
//! Two ray sets of 640 x 480 rays each: coherent primary rays of a pinhole camera framing the
//! bunny, and incoherent rays from random points of the bounding sphere towards random points
//! of the bounding box. Each is traced on a rayon pool of 1 and of 2 threads. Criterion's
//! throughput (`elem/s`) is rays per second; a summary in rays/s (wall clock, and per
//! CPU-second of the process, the steadier figure on a shared machine) is printed at the end.
//!
//! Run: `cargo bench --bench bvh`. The bunny is read from `$FEMTO_SHARED/data` or
//! `../shared/data`; without it the benchmark prints that it skipped.

use criterion::{BenchmarkId, Criterion, Throughput};
use femto::geometry::bvh::Bvh;
use femto::geometry::load::load_mesh;
use femto::geometry::{Ray, TriangleMesh};
use nalgebra::{Point3, Vector3};
use obvhs::cwbvh::CwBvh;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::{Duration, Instant};

const WIDTH: usize = 640;
const HEIGHT: usize = 480;

fn bunny_path() -> PathBuf {
    let shared = match std::env::var_os("FEMTO_SHARED") {
        Some(d) => PathBuf::from(d),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared"),
    };
    shared.join("data/stanford-bunny.obj")
}

/// Pinhole camera 3 bounding radii from the box centre, looking at it, 30 degree vertical
/// field of view: the bunny fills most of the frame.
fn camera_rays(mesh: &TriangleMesh) -> Vec<Ray> {
    let b = mesh.bounds();
    let centre = nalgebra::center(&b.min, &b.max);
    let radius = 0.5 * (b.max - b.min).norm();
    let eye = centre + Vector3::new(0.3, 0.2, 1.0).normalize() * (3.0 * radius);
    let forward = (centre - eye).normalize();
    let right = forward.cross(&Vector3::y()).normalize();
    let down = forward.cross(&right);
    let focal_px = 0.5 * HEIGHT as f32 / (15f32.to_radians()).tan();
    let mut rays = Vec::with_capacity(WIDTH * HEIGHT);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let px = (x as f32 + 0.5 - 0.5 * WIDTH as f32) / focal_px;
            let py = (y as f32 + 0.5 - 0.5 * HEIGHT as f32) / focal_px;
            rays.push(Ray::new(
                eye,
                (forward + right * px + down * py).normalize(),
            ));
        }
    }
    rays
}

/// Rays from uniform points of the bounding sphere to uniform points of the bounding box.
fn random_rays(mesh: &TriangleMesh) -> Vec<Ray> {
    let b = mesh.bounds();
    let centre = nalgebra::center(&b.min, &b.max);
    let radius = 0.5 * (b.max - b.min).norm();
    let mut rng = Pcg64::seed_from_u64(7);
    (0..WIDTH * HEIGHT)
        .map(|_| {
            let dir_on_sphere = loop {
                let v = Vector3::from_fn(|_, _| rng.random_range(-1.0f32..1.0));
                let n = v.norm();
                if n > 0.1 && n <= 1.0 {
                    break v / n;
                }
            };
            let origin = centre + dir_on_sphere * radius;
            let target = Point3::from(Vector3::from_fn(|i, _| {
                rng.random_range(b.min[i]..=b.max[i])
            }));
            Ray::new(origin, (target - origin).normalize())
        })
        .collect()
}

/// The same watertight two-sided test as femto's BVH (Woop, Benthin, Wald 2013), written
/// again here for obvhs' per-primitive callback; per-ray constants are computed once.
struct Watertight {
    origin: [f32; 3],
    k: [usize; 3],
    shear: [f32; 3],
}

impl Watertight {
    fn new(ray: &Ray) -> Watertight {
        let d = [ray.dir.x, ray.dir.y, ray.dir.z];
        let kz = (0..3)
            .max_by(|&a, &b| d[a].abs().total_cmp(&d[b].abs()))
            .unwrap_or(2);
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Watertight {
            origin: [ray.origin.x, ray.origin.y, ray.origin.z],
            k: [kx, ky, kz],
            shear: [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]],
        }
    }

    /// Distance of the hit in `(t_min, t_max)`, or infinity.
    #[inline(always)]
    fn intersect(&self, tri: &[[f32; 3]; 3], t_min: f32, t_max: f32) -> f32 {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.shear;
        let o = &self.origin;
        let rel = |p: &[f32; 3]| [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
        let (a, b, c) = (rel(&tri[0]), rel(&tri[1]), rel(&tri[2]));
        let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
        let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let f =
                |p: f32, q: f32, s: f32, t: f32| (p as f64 * q as f64 - s as f64 * t as f64) as f32;
            u = f(cx, by, cy, bx);
            v = f(ax, cy, ay, cx);
            w = f(bx, ay, by, ax);
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return f32::INFINITY;
        }
        let det = u + v + w;
        if det == 0.0 {
            return f32::INFINITY;
        }
        let t = (u * sz * a[kz] + v * sz * b[kz] + w * sz * c[kz]) / det;
        if t > t_min && t < t_max {
            t
        } else {
            f32::INFINITY
        }
    }
}

/// obvhs' CWBVH over the mesh, with the triangles stored in the BVH's primitive order.
struct Obvhs {
    bvh: CwBvh,
    tris: Vec<[[f32; 3]; 3]>,
}

impl Obvhs {
    fn new(mesh: &TriangleMesh) -> Obvhs {
        let corners = |i: usize| mesh.corners(i).map(|p| [p.x, p.y, p.z]);
        let tris: Vec<obvhs::triangle::Triangle> = (0..mesh.triangle_count())
            .map(|i| {
                let [a, b, c] = corners(i);
                obvhs::triangle::Triangle {
                    v0: a.into(),
                    v1: b.into(),
                    v2: c.into(),
                }
            })
            .collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
            &tris,
            obvhs::BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| corners(i as usize))
            .collect();
        Obvhs { bvh, tris }
    }

    /// Distance of the nearest hit, or infinity.
    fn intersect(&self, ray: &Ray) -> f32 {
        let test = Watertight::new(ray);
        let r = obvhs::ray::Ray::new(
            [ray.origin.x, ray.origin.y, ray.origin.z].into(),
            [ray.dir.x, ray.dir.y, ray.dir.z].into(),
            0.0,
            f32::INFINITY,
        );
        let mut hit = obvhs::ray::RayHit::none();
        self.bvh.ray_traverse(r, &mut hit, |r, id| {
            test.intersect(&self.tris[id], r.tmin, r.tmax)
        });
        hit.t
    }
}

/// User plus system CPU time of this process so far, in seconds (Linux `/proc/self/stat`,
/// 100 ticks per second), or `None` where that file is missing.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are the 12th and 13th.
    let rest = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks: u64 = fields.get(11)?.parse::<u64>().ok()? + fields.get(12)?.parse::<u64>().ok()?;
    Some(ticks as f64 / 100.0)
}

/// Trace `rays` on `pool`, returning the number of hits (so the work cannot be optimised out).
fn trace_own(pool: &rayon::ThreadPool, bvh: &Bvh, rays: &[Ray]) -> usize {
    pool.install(|| {
        rays.par_chunks(1024)
            .map(|c| {
                c.iter()
                    .filter(|r| bvh.intersect(r, 0.0, f32::INFINITY).is_some())
                    .count()
            })
            .sum()
    })
}

fn trace_obvhs(pool: &rayon::ThreadPool, bvh: &Obvhs, rays: &[Ray]) -> usize {
    pool.install(|| {
        rays.par_chunks(1024)
            .map(|c| c.iter().filter(|r| bvh.intersect(r).is_finite()).count())
            .sum()
    })
}

fn main() {
    let path = bunny_path();
    if !path.is_file() {
        println!("skipped: {} not found (set FEMTO_SHARED)", path.display());
        return;
    }
    let mesh = load_mesh(&path).expect("bunny loads");

    let start = Instant::now();
    let own = Bvh::new(mesh.clone());
    let own_build = start.elapsed();
    let start = Instant::now();
    let other = Obvhs::new(&mesh);
    let other_build = start.elapsed();
    println!(
        "bunny: {} triangles; build: femto {:.1} ms, obvhs {:.1} ms (1 thread)",
        mesh.triangle_count(),
        own_build.as_secs_f64() * 1e3,
        other_build.as_secs_f64() * 1e3
    );

    let ray_sets = [
        ("coherent", camera_rays(&mesh)),
        ("random", random_rays(&mesh)),
    ];
    // Both structures must see the same hits before their speeds are compared.
    for (name, rays) in &ray_sets {
        let (mut hits, mut disagree, mut max_dt) = (0, 0, 0f32);
        for r in rays {
            let a = own
                .intersect(r, 0.0, f32::INFINITY)
                .map_or(f32::INFINITY, |h| h.t);
            let b = other.intersect(r);
            if a.is_finite() != b.is_finite() {
                disagree += 1;
            } else if a.is_finite() {
                hits += 1;
                max_dt = max_dt.max((a - b).abs());
            }
        }
        println!(
            "{name}: {hits} of {} rays hit in both, {disagree} hit in only one; \
             max |t_femto - t_obvhs| = {max_dt:e} m",
            rays.len()
        );
    }

    let mut c = Criterion::default()
        .configure_from_args()
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    let mut summary = Vec::new();
    for (name, rays) in &ray_sets {
        let mut group = c.benchmark_group(format!("bunny_{name}"));
        group.throughput(Throughput::Elements(rays.len() as u64));
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("thread pool");
            group.bench_with_input(BenchmarkId::new("femto", threads), rays, |b, rays| {
                b.iter(|| trace_own(&pool, &own, rays))
            });
            group.bench_with_input(BenchmarkId::new("obvhs", threads), rays, |b, rays| {
                b.iter(|| trace_obvhs(&pool, &other, rays))
            });
            // Plain timings for the summary: wall-clock rays/s (median of the passes) and rays
            // per CPU-second of the whole process over all passes, which on a machine shared
            // with other jobs is the steadier figure. Passes repeat until 1.5 s of CPU time.
            for (which, f) in [
                (
                    "femto",
                    &(|| trace_own(&pool, &own, rays)) as &dyn Fn() -> usize,
                ),
                ("obvhs", &|| trace_obvhs(&pool, &other, rays)),
            ] {
                let cpu_start = cpu_seconds();
                let wall_start = Instant::now();
                let mut secs = Vec::new();
                loop {
                    let t = Instant::now();
                    std::hint::black_box(f());
                    secs.push(t.elapsed().as_secs_f64());
                    let cpu = cpu_start.zip(cpu_seconds()).map(|(a, b)| b - a);
                    let enough_cpu = cpu.is_none_or(|c| c >= 1.5);
                    if secs.len() >= 3 && (enough_cpu || wall_start.elapsed().as_secs() > 20) {
                        break;
                    }
                }
                let cpu = cpu_start.zip(cpu_seconds()).map(|(a, b)| b - a);
                let passes = secs.len();
                secs.sort_by(f64::total_cmp);
                let per_cpu = match cpu {
                    Some(c) if c > 0.0 => {
                        format!("{:8.2}", (passes * rays.len()) as f64 / c / 1e6)
                    }
                    _ => "     n/a".to_string(),
                };
                summary.push(format!(
                    "{name:>8} {threads} thread(s) {which:>5}: {:8.2} Mrays/s wall, {per_cpu} \
                     Mrays per CPU-second ({passes} passes)",
                    rays.len() as f64 / secs[passes / 2] / 1e6
                ));
            }
        }
        group.finish();
    }
    println!("\nsummary ({} rays per pass):", WIDTH * HEIGHT);
    for line in summary {
        println!("{line}");
    }
}

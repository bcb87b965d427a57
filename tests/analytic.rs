//! The transient tracer against an analytic multi-bounce scene (in the spirit of pbrt's
//! analytic-scene tests; issue 20): an isotropic point source of energy `Phi` at the centre
//! of a closed Lambertian sphere of radius `R` and albedo `rho`, the camera at the centre.
//!
//! Theory (derived here, not from the tracer). The source gives every point of the wall the
//! irradiance `Phi / (4 pi R^2)`, so the one-bounce radiance is `rho Phi / (4 pi^2 R^2)`. Seen
//! from a point of the wall, the uniform radiance `L` of the rest of a closed sphere gives
//! the irradiance `pi L` (the whole inner hemisphere is wall), so each further bounce
//! multiplies the radiance by `rho`: `L_k = rho^k Phi / (4 pi^2 R^2)` in every direction.
//! Light of `k` bounces travels `R` out, `k - 1` chords, and `R` back: `2R + S_{k-1}`, where
//! the chords are independent with density `s / (2 R^2)` on `[0, 2R]` (a cosine-weighted
//! direction at angle `theta` to the inward normal gives the chord `2 R cos theta`, and
//! `P(cos theta < u) = u^2`). Their sum's distribution is computed here by numerical
//! convolution of that density.
//!
//! Measurement. The sphere is an icosphere (vertices on the sphere), rendered with
//! [`femto::tracer::trace`] at maximum depth `k = 1 ..= 4` with the same seed; since a path's
//! random numbers do not depend on the maximum depth, the difference of the depth-`k` and
//! depth-`k - 1` cubes is exactly the light of `k` bounces, bounce by bounce. Each pixel has
//! its own random stream, so the pixels are independent samples of the same radiance (the
//! sphere looks the same in every direction): means and standard errors are taken over the
//! pixels, and every check is in standard errors (sigma), not a fixed percentage.
//!
//! Tessellation. The inscribed polyhedron is not the sphere; its effect is bounded, not
//! fitted. With `d` a face plane's distance from the centre (`d >= d_min`) and `r <= R` the
//! distance to a wall point, the one-bounce radiance towards the centre is
//! `rho Phi / (4 pi^2) d / r^3`, within `[d_min / R^3, 1 / d_min^2]` times
//! `rho Phi / (4 pi^2)`; on a closed convex polyhedron each further bounce maps radiance
//! within `[a, b]` to within `rho [a, b]` (the irradiance of a point is `pi` times a mean of
//! the radiance it sees). So every `L_k` lies in `[d_min R^2 / R^3, R^2 / d_min^2]` times the
//! sphere's value (1 - 2.9e-4 to 1 + 5.7e-4 with these 20480 faces), and the energy check asks
//! the measured mean to lie within 4 sigma of that interval. Path lengths differ from the
//! sphere's by at most `2 (1 - d_min / R) R` per segment, which moves a window's share of
//! the arrival-time distribution by at most that times the largest chord density `1 / R`
//! at each of its two edges: an allowance of `4 (k + 1) (1 - d_min / R)` of the bounce's
//! energy per window (0.6 % of it at four bounces), added to the 4 sigma.
//!
//! Run time: 1.7-1.8 s in `cargo test` (debug profile) on the 2-core machine, under load.

use femto::camera::{Intrinsics, Pose};
use femto::cube::TimeAxis;
use femto::geometry::bvh::Bvh;
use femto::geometry::primitives::icosphere;
use femto::scene::{Emission, Scene};
use femto::tracer::{trace, TraceOptions};
use femto::units::flight_time_ps;
use nalgebra::{Point3, Vector3};
use std::f64::consts::PI;

/// Sphere radius, metres.
const R_M: f64 = 1.0;
/// Wall albedo.
const RHO: f32 = 0.7;
/// Source energy.
const PHI: f64 = 1.0;
/// Icosphere subdivisions: 20 * 4^5 = 20480 faces.
const SUBDIVISIONS: u32 = 5;
/// Bounces checked.
const K: usize = 4;
/// Image size and paths per pixel.
const NX: usize = 16;
const NY: usize = 16;
const SPP: u32 = 256;
/// Time bin width, as a path length in metres.
const BIN_M: f64 = 0.04;
/// Bins of margin before the first arrival `2R` and after the last `2 K R`.
const MARGIN: usize = 3;
/// Windows of the arrival-time distribution per bounce (from two bounces on).
const WINDOWS: usize = 6;
/// The checks' bound, in standard errors.
const SIGMAS: f64 = 4.0;

/// Path length at the start of the time axis.
fn l0_m() -> f64 {
    2.0 * R_M - MARGIN as f64 * BIN_M
}

/// The sphere scene: the built-in `cube` scene's laser and camera moved to the centre of an
/// icosphere that replaces its meshes.
fn sphere_scene() -> Scene {
    let mut s = Scene::builtin("cube", None).unwrap();
    s.mesh = icosphere(R_M as f32, SUBDIVISIONS);
    s.mesh.material = vec![0; s.mesh.triangle_count()];
    s.albedo = vec![RHO];
    s.labels = vec!["sphere".into()];
    s.eta = 1.0;
    s.laser.position_m = Point3::origin();
    s.laser.emission = Emission::Isotropic;
    s.laser.pulse_width_fs = 0.0;
    s.laser.energy = PHI;
    s.camera.pose = Pose::look_at(
        Point3::origin(),
        Point3::new(0.3, 0.2, 1.0),
        Vector3::new(0.0, 1.0, 0.0),
    )
    .unwrap();
    s.camera.vfov_deg = 40.0;
    s.camera.intrinsics = Intrinsics::from_vfov(NX, NY, 40.0);
    let span_m = 2.0 * K as f64 * R_M - 2.0 * R_M;
    s.camera.axis = TimeAxis {
        t0_ps: flight_time_ps(1.0, l0_m()),
        dt_ps: flight_time_ps(1.0, BIN_M),
        nt: (span_m / BIN_M).ceil() as usize + 2 * MARGIN,
    };
    s
}

/// `(d_min, r_max)`: the smallest distance of a face plane from the centre and the largest
/// distance of a vertex, in f64 from the mesh's f32 corners.
fn tessellation(scene: &Scene) -> (f64, f64) {
    let m = &scene.mesh;
    let mut d_min = f64::INFINITY;
    for i in 0..m.triangle_count() {
        let c = m
            .corners(i)
            .map(|p| Vector3::new(p.x as f64, p.y as f64, p.z as f64));
        let n = (c[1] - c[0]).cross(&(c[2] - c[0])).normalize();
        d_min = d_min.min(n.dot(&c[0]).abs());
    }
    let r_max = m
        .positions
        .iter()
        .map(|p| p.coords.cast::<f64>().norm())
        .fold(0.0, f64::max);
    (d_min, r_max)
}

/// Mean and standard error of the mean.
fn mean_se(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// Probability masses of the sum of `m` independent chords on a grid of cells of `h` metres
/// (cell `j` of the sum holds its mass at `(j + m / 2) h`: each chord's cell at its centre).
fn chord_sum_masses(m: usize, h: f64) -> Vec<f64> {
    let n = (2.0 * R_M / h).round() as usize;
    // P(jh <= s < (j+1)h) for the density s / (2 R^2): ((j+1)^2 - j^2) h^2 / (4 R^2).
    let one: Vec<f64> = (0..n)
        .map(|j| ((2 * j + 1) as f64) * h * h / (4.0 * R_M * R_M))
        .collect();
    let mut sum = vec![1.0];
    for _ in 0..m {
        let mut next = vec![0.0; sum.len() + n - 1];
        for (a, pa) in sum.iter().enumerate() {
            for (b, pb) in one.iter().enumerate() {
                next[a + b] += pa * pb;
            }
        }
        sum = next;
    }
    sum
}

/// Sum over bins `bins` of the tent weights (`max(0, 1 - |c_i - L| / BIN)`, `c_i` the bin
/// centres) of light arriving after the path length `l_m`: the share of it that lands in
/// those bins (the documented response of a delta pulse).
fn window_weight(bins: std::ops::Range<usize>, l_m: f64) -> f64 {
    bins.map(|i| {
        let c = l0_m() + (i as f64 + 0.5) * BIN_M;
        (1.0 - (c - l_m).abs() / BIN_M).max(0.0)
    })
    .sum()
}

#[test]
fn closed_sphere_lit_from_its_centre_matches_theory_bounce_by_bounce() {
    let scene = sphere_scene();
    let bvh = Bvh::new(scene.mesh.clone());
    let (d_min, r_max) = tessellation(&scene);
    let eps = 1.0 - d_min / R_M;
    assert!(
        eps > 0.0 && eps < 5e-4 && (r_max - R_M).abs() < 1e-6,
        "{d_min} {r_max}"
    );
    let (lo, hi) = (
        d_min * R_M * R_M / r_max.powi(3),
        R_M * R_M / (d_min * d_min),
    );
    let nt = scene.camera.axis.nt;
    let npix = NX * NY;

    // Cubes at maximum depth 0 (nothing) ..= K, pixel by pixel.
    let mut cubes = vec![vec![0.0f64; npix * nt]];
    for k in 1..=K as u32 {
        let opts = TraceOptions {
            spp: SPP,
            max_bounces: k,
            seed: 20,
            emission: Some(Emission::Isotropic),
            rr_start_bounce: u32::MAX,
            split_bounces: false,
            world_time: false,
            ..TraceOptions::default()
        };
        // Both of the tracer's estimators (camera paths and light vertices, weighted by
        // multiple importance sampling) are under test.
        assert!(opts.light_vertex);
        let r = trace(&scene, &bvh, &opts, &|_| {});
        let total: f64 = r.camera_time.data.iter().map(|&v| v as f64).sum();
        assert!(
            r.stats.energy_outside_window <= 1e-9 * total,
            "light outside the window: {}",
            r.stats.energy_outside_window
        );
        assert_eq!(r.stats.paths_ended_late, 0);
        cubes.push(r.camera_time.data.iter().map(|&v| v as f64).collect());
    }

    let mut failures = Vec::new();
    let h = 2.0 * R_M / 2000.0;
    for k in 1..=K {
        // The light of exactly k bounces, per pixel and bin.
        let d: Vec<f64> = cubes[k]
            .iter()
            .zip(&cubes[k - 1])
            .map(|(a, b)| a - b)
            .collect();
        let pixel = |p: usize| &d[p * nt..(p + 1) * nt];
        let energy: Vec<f64> = (0..npix).map(|p| pixel(p).iter().sum()).collect();
        let (mean, se) = mean_se(&energy);
        let theory = (RHO as f64).powi(k as i32) * PHI / (4.0 * PI * PI * R_M * R_M);
        let outside = (theory * lo - mean).max(mean - theory * hi).max(0.0);
        let sigmas = outside / se.max(1e-12 * theory);
        println!(
            "bounce {k}: radiance {mean:.6e}, theory {theory:.6e}, ratio {:.6} +- {:.6} \
             ({:+.2} sigma from theory, {sigmas:.2} sigma outside the tessellation interval \
             [{lo:.6}, {hi:.6}])",
            mean / theory,
            se / theory,
            (mean - theory) / se,
        );
        if sigmas > SIGMAS {
            failures.push(format!("bounce {k}: energy {sigmas:.1} sigma off"));
        }

        if k == 1 {
            // One bounce arrives after 2r, r in [d_min, R]; the tent keeps each sample's
            // mean time, so the energy-weighted mean path length over bin centres is it.
            let mean_l: Vec<f64> = (0..npix)
                .map(|p| {
                    let px = pixel(p);
                    let m: f64 = px
                        .iter()
                        .enumerate()
                        .map(|(i, v)| v * (l0_m() + (i as f64 + 0.5) * BIN_M))
                        .sum();
                    m / px.iter().sum::<f64>()
                })
                .collect();
            let (m, se) = mean_se(&mean_l);
            let off = (2.0 * d_min - m).max(m - 2.0 * R_M).max(0.0);
            println!("bounce 1: mean path {m:.6} m (2R = {:.6})", 2.0 * R_M);
            if off > SIGMAS * se + 1e-6 {
                failures.push(format!("bounce 1: mean path {m} m, not 2R"));
            }
            continue;
        }

        // Arrival-time distribution: the share of the bounce's energy in each of WINDOWS
        // windows of bins, against the chord sums' distribution seen through the tent.
        let masses = chord_sum_masses(k - 1, h);
        let offset = (k - 1) as f64 / 2.0;
        let edge = |w: usize| -> usize {
            if w == 0 {
                return 0;
            }
            if w == WINDOWS {
                return nt;
            }
            let s = w as f64 / WINDOWS as f64 * 2.0 * R_M * (k - 1) as f64;
            ((2.0 * R_M + s - l0_m()) / BIN_M).round() as usize
        };
        let allowance = 4.0 * (k + 1) as f64 * eps * mean;
        let mut worst: f64 = 0.0;
        let mut shares = Vec::new();
        for w in 0..WINDOWS {
            let bins = edge(w)..edge(w + 1);
            let expected: f64 = masses
                .iter()
                .enumerate()
                .map(|(j, pm)| {
                    pm * window_weight(bins.clone(), 2.0 * R_M + (j as f64 + offset) * h)
                })
                .sum();
            let y: Vec<f64> = (0..npix)
                .map(|p| pixel(p)[bins.clone()].iter().sum::<f64>() - expected * energy[p])
                .collect();
            let (my, sy) = mean_se(&y);
            let z = (my.abs() - allowance).max(0.0) / sy.max(1e-12 * theory);
            worst = worst.max(my.abs() / sy);
            shares.push(format!("{:.4}/{expected:.4}", expected + my / mean));
            if z > SIGMAS {
                failures.push(format!(
                    "bounce {k} window {w} (bins {bins:?}): share {:.5}, theory {expected:.5}, \
                     {z:.1} sigma beyond the allowance",
                    expected + my / mean
                ));
            }
        }
        println!(
            "bounce {k}: window shares measured/theory {}; worst {worst:.2} sigma",
            shares.join(" ")
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

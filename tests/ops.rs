//! End-to-end tests of `femto calibrate`, `femto unwarp`, `femto pyramid` and `femto info`,
//! run as a user would in a temporary folder.
//!
//! The scene (a floor, a back wall and a box), the true camera, the fiducials and the
//! camera-time cube are built here from closed forms: every pixel's ray is intersected with
//! the planes and the box analytically (slab method), and holds one Gaussian pulse at the
//! first-arrival time `t0 + eta (|laser - p| + |p - camera|) / c`, integrated over each bin with
//! erf. Expectations (world-time pulses at `t0 + eta |laser - p| / c`, prefix sums, box sums,
//! mesh bounds) are derived here, never read from the code under test.

use femto::camera::{Calibration, Intrinsics, Pose};
use femto::container::{self, Provenance};
use femto::cube::{Cube, TimeAxis, TimeFrame};
use femto::formats::StreakImage;
use femto::geometry::glb::write_glb;
use femto::geometry::TriangleMesh;
use femto::pyramid::PrefixRead;
use nalgebra::{DMatrix, Point3, Rotation3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use serde_json::Value;
use std::path::{Path, PathBuf};
#[path = "common/cli.rs"]
mod cli;
#[path = "common/shared.rs"]
mod shared;

const C_M_PER_PS: f64 = 2.997_924_58e-4;

// ---------------------------------------------------------------------------------------
// The scene, analytically.

/// Floor `y = 0`, `x` in [-0.8, 0.8], `z` in [-0.8, 0.6].
const FLOOR_X: f64 = 0.8;
const FLOOR_Z: (f64, f64) = (-0.8, 0.6);
/// Back wall `z = -0.8`, `x` in [-0.8, 0.8], `y` in [0, 0.9].
const WALL_Z: f64 = -0.8;
const WALL_H: f64 = 0.9;
/// A box standing on the floor.
const BOX_LO: [f64; 3] = [-0.05, 0.0, -0.4];
const BOX_HI: [f64; 3] = [0.25, 0.3, -0.1];
/// Refractive index of the medium (not 1, so that a lost `eta` shows).
const ETA: f64 = 1.2;
/// Time axis of the captures: 40 ps bins, a pulse of 80 ps standard deviation.
const DT_PS: f64 = 40.0;
const SIGMA_PS: f64 = 80.0;
/// Signal of one pixel's pulse (its time integral).
const AMPLITUDE: f64 = 100.0;
/// Image size.
const W: usize = 128;
const H: usize = 96;

fn p32(x: f64, y: f64, z: f64) -> Point3<f32> {
    Point3::new(x as f32, y as f32, z as f32)
}

/// Two triangles of the quad `a b c d` (corners in order around it).
fn quad(mesh: &mut TriangleMesh, c: [Point3<f32>; 4], material: u32) {
    let base = mesh.positions.len() as u32;
    mesh.positions.extend_from_slice(&c);
    mesh.triangles
        .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    mesh.material.extend([material, material]);
}

/// The scene as triangles: floor (material 0), wall (1), the box's top and four sides (2).
fn scene_mesh() -> TriangleMesh {
    let mut m = TriangleMesh::default();
    let (z0, z1) = FLOOR_Z;
    quad(
        &mut m,
        [
            p32(-FLOOR_X, 0.0, z1),
            p32(FLOOR_X, 0.0, z1),
            p32(FLOOR_X, 0.0, z0),
            p32(-FLOOR_X, 0.0, z0),
        ],
        0,
    );
    quad(
        &mut m,
        [
            p32(-FLOOR_X, 0.0, WALL_Z),
            p32(FLOOR_X, 0.0, WALL_Z),
            p32(FLOOR_X, WALL_H, WALL_Z),
            p32(-FLOOR_X, WALL_H, WALL_Z),
        ],
        1,
    );
    let [x0, y0, z0] = BOX_LO;
    let [x1, y1, z1] = BOX_HI;
    let faces = [
        [
            p32(x0, y1, z0),
            p32(x1, y1, z0),
            p32(x1, y1, z1),
            p32(x0, y1, z1),
        ],
        [
            p32(x0, y0, z1),
            p32(x1, y0, z1),
            p32(x1, y1, z1),
            p32(x0, y1, z1),
        ],
        [
            p32(x0, y0, z0),
            p32(x1, y0, z0),
            p32(x1, y1, z0),
            p32(x0, y1, z0),
        ],
        [
            p32(x0, y0, z0),
            p32(x0, y0, z1),
            p32(x0, y1, z1),
            p32(x0, y1, z0),
        ],
        [
            p32(x1, y0, z0),
            p32(x1, y0, z1),
            p32(x1, y1, z1),
            p32(x1, y1, z0),
        ],
    ];
    for f in faces {
        quad(&mut m, f, 2);
    }
    m
}

/// Nearest intersection of the ray `o + t d` (t > 0) with the scene: `(t, point)`.
fn trace(o: &Point3<f64>, d: &Vector3<f64>) -> Option<(f64, Point3<f64>)> {
    let mut best: Option<f64> = None;
    let mut keep = |t: f64| {
        if t > 1e-9 && best.is_none_or(|b| t < b) {
            best = Some(t);
        }
    };
    let t = -o.y / d.y;
    let p = o + d * t;
    if p.x.abs() <= FLOOR_X && p.z >= FLOOR_Z.0 && p.z <= FLOOR_Z.1 {
        keep(t);
    }
    let t = (WALL_Z - o.z) / d.z;
    let p = o + d * t;
    if p.x.abs() <= FLOOR_X && p.y >= 0.0 && p.y <= WALL_H {
        keep(t);
    }
    // Slab method on the box.
    let (mut t_near, mut t_far) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..3 {
        let (t1, t2) = ((BOX_LO[a] - o[a]) / d[a], (BOX_HI[a] - o[a]) / d[a]);
        t_near = t_near.max(t1.min(t2));
        t_far = t_far.min(t1.max(t2));
    }
    if t_near <= t_far {
        keep(t_near);
    }
    best.map(|t| (t, o + d * t))
}

/// The true capture: camera, time origin, laser spot on the floor, medium.
fn truth() -> Calibration {
    Calibration {
        intrinsics: Intrinsics::from_vfov(W, H, 40.0),
        pose: Pose::look_at(
            Point3::new(0.5, 0.9, 1.6),
            Point3::new(0.0, 0.3, -0.3),
            Vector3::y(),
        )
        .unwrap(),
        t0_ps: 1234.5,
        time_scale: 1.0,
        laser_m: Point3::new(-0.4, 0.0, 0.3),
        eta: ETA,
    }
}

/// Pinhole projection (no distortion), written out: `(u, v, depth)`.
fn project(k: &Intrinsics, pose: &Pose, p: &Point3<f64>) -> (f64, f64, f64) {
    let r = pose.world_from_camera.matrix();
    let d = p - pose.position_m;
    let (x, y, z) = (
        r.column(0).dot(&d),
        r.column(1).dot(&d),
        r.column(2).dot(&d),
    );
    (k.fx * x / z + k.cx, k.fy * y / z + k.cy, z)
}

/// Unit world ray through continuous pixel coordinates (no distortion).
fn pixel_ray(k: &Intrinsics, pose: &Pose, u: f64, v: f64) -> Vector3<f64> {
    let d_cam = Vector3::new((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
    (pose.world_from_camera.matrix() * d_cam).normalize()
}

/// The surface point each pixel centre sees, `[y][x]`.
fn seen_points(cal: &Calibration) -> Vec<Option<Point3<f64>>> {
    let k = &cal.intrinsics;
    (0..H)
        .flat_map(|j| (0..W).map(move |i| (i, j)))
        .map(|(i, j)| {
            let d = pixel_ray(k, &cal.pose, i as f64 + 0.5, j as f64 + 0.5);
            trace(&cal.pose.position_m, &d).map(|(_, p)| p)
        })
        .collect()
}

/// Camera-time arrival of the direct pulse at `p`.
fn camera_arrival_ps(cal: &Calibration, p: &Point3<f64>) -> f64 {
    let path_m = (cal.laser_m - p).norm() + (p - cal.pose.position_m).norm();
    cal.t0_ps + cal.eta * path_m / C_M_PER_PS
}

/// World-time arrival of the direct pulse at `p`.
fn world_arrival_ps(cal: &Calibration, p: &Point3<f64>) -> f64 {
    cal.t0_ps + cal.eta * (cal.laser_m - p).norm() / C_M_PER_PS
}

/// erf to ~1e-13: Taylor series below 3, continued fraction of erfc above.
fn erf(x: f64) -> f64 {
    let ax = x.abs();
    let r = if ax < 3.0 {
        let (mut term, mut sum, mut n) = (ax, ax, 0.0);
        while term.abs() > 1e-17 * sum.abs() {
            n += 1.0;
            term *= -ax * ax / n;
            sum += term / (2.0 * n + 1.0);
        }
        sum * 2.0 / std::f64::consts::PI.sqrt()
    } else {
        let mut frac = ax;
        for k in (1..80).rev() {
            frac = ax + (k as f64 / 2.0) / frac;
        }
        1.0 - (-ax * ax).exp() / std::f64::consts::PI.sqrt() / frac
    };
    r.copysign(x)
}

/// A Gaussian pulse of integral `AMPLITUDE` at `mu_ps`, integrated over each bin of `axis`.
fn binned_pulse(axis: &TimeAxis, mu_ps: f64, out: &mut [f32]) {
    let s = SIGMA_PS * std::f64::consts::SQRT_2;
    let cdf = |t: f64| 0.5 * AMPLITUDE * (1.0 + erf((t - mu_ps) / s));
    for (i, v) in out.iter_mut().enumerate() {
        *v = (cdf(axis.bin_start_ps(i + 1)) - cdf(axis.bin_start_ps(i))) as f32;
    }
}

/// `max |s''|` of the pulse, per ps^3: `AMPLITUDE / (sigma^3 sqrt(2 pi))` (at its centre).
fn max_second_derivative() -> f64 {
    AMPLITUDE / (SIGMA_PS.powi(3) * (2.0 * std::f64::consts::PI).sqrt())
}

/// A cube of `points` (one pulse per pixel that sees geometry) with arrivals `arrival`.
fn pulse_cube(
    points: &[Option<Point3<f64>>],
    axis: TimeAxis,
    frame: TimeFrame,
    arrival: impl Fn(&Point3<f64>) -> f64,
) -> Cube {
    let mut cube = Cube::zeros(W, H, axis, frame);
    for (idx, p) in points.iter().enumerate() {
        if let Some(p) = p {
            binned_pulse(&axis, arrival(p), cube.profile_mut(idx % W, idx / W));
        }
    }
    cube
}

/// The camera-time capture of the true scene, on an axis with 8 sigma of margin.
fn camera_cube(cal: &Calibration, points: &[Option<Point3<f64>>]) -> Cube {
    let times: Vec<f64> = points
        .iter()
        .flatten()
        .map(|p| camera_arrival_ps(cal, p))
        .collect();
    let lo = times.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = times.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let t0_ps = (lo - 8.0 * SIGMA_PS).floor();
    let axis = TimeAxis {
        t0_ps,
        dt_ps: DT_PS,
        nt: ((hi + 8.0 * SIGMA_PS - t0_ps) / DT_PS).ceil() as usize,
    };
    pulse_cube(points, axis, TimeFrame::Camera, |p| {
        camera_arrival_ps(cal, p)
    })
}

/// Fiducial markers every `step_m` on the floor and the wall, plus the box corners: those the
/// true camera sees unoccluded, 2 px inside the image.
fn markers(cal: &Calibration, step_m: f64) -> Vec<(String, Point3<f64>)> {
    let mut pts = Vec::new();
    let n = |a: f64, b: f64| ((b - a) / step_m).round() as i64;
    for ix in 0..=n(-FLOOR_X, FLOOR_X) {
        let x = -FLOOR_X + ix as f64 * step_m;
        for iz in 0..=n(FLOOR_Z.0, FLOOR_Z.1) {
            let z = FLOOR_Z.0 + iz as f64 * step_m;
            pts.push((format!("floor {ix} {iz}"), Point3::new(x, 0.0, z)));
        }
        for iy in 1..=n(0.0, WALL_H) {
            let y = iy as f64 * step_m;
            pts.push((format!("wall {ix} {iy}"), Point3::new(x, y, WALL_Z)));
        }
    }
    for c in 0..8 {
        let pick = |a: usize| {
            if c >> a & 1 == 1 {
                BOX_HI[a]
            } else {
                BOX_LO[a]
            }
        };
        pts.push((
            format!("box corner {c}"),
            Point3::new(pick(0), pick(1), pick(2)),
        ));
    }
    let o = cal.pose.position_m;
    pts.retain(|(_, p)| {
        let (u, v, z) = project(&cal.intrinsics, &cal.pose, p);
        let inside = z > 0.1 && u > 2.0 && u < W as f64 - 2.0 && v > 2.0 && v < H as f64 - 2.0;
        let d = (p - o).normalize();
        let visible = trace(&o, &d).is_some_and(|(t, _)| t >= (p - o).norm() - 1e-6);
        inside && visible
    });
    pts
}

/// Correspondences `(name, pixel, point)`.
type Observations = Vec<(String, (f64, f64), Point3<f64>)>;

/// Correspondences of `markers` seen by `cal` with seeded Gaussian noise of `noise_px` per
/// axis.
fn observe(
    cal: &Calibration,
    markers: &[(String, Point3<f64>)],
    noise_px: f64,
    seed: u64,
) -> Observations {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let noise = Normal::new(0.0, noise_px).unwrap();
    markers
        .iter()
        .map(|(name, p)| {
            let (u, v, _) = project(&cal.intrinsics, &cal.pose, p);
            (
                name.clone(),
                (u + noise.sample(&mut rng), v + noise.sample(&mut rng)),
                *p,
            )
        })
        .collect()
}

/// The correspondence TOML, written here.
fn write_points(path: &Path, pts: &[(String, (f64, f64), Point3<f64>)]) {
    let mut s = String::new();
    for (name, (u, v), p) in pts {
        s.push_str(&format!(
            "[[point]]\nname = \"{name}\"\npixel = [{u:.6}, {v:.6}]\nworld_m = [{}, {}, {}]\n\n",
            p.x, p.y, p.z
        ));
    }
    std::fs::write(path, s).unwrap();
}

/// A TOML file with the true intrinsics, the laser spot and the medium only (no pose, no t0).
fn write_known_intrinsics(path: &Path, cal: &Calibration) {
    let k = &cal.intrinsics;
    let l = &cal.laser_m;
    std::fs::write(
        path,
        format!(
            "[intrinsics]\nwidth = {}\nheight = {}\nfx = {}\nfy = {}\ncx = {}\ncy = {}\n\n\
             [laser]\nposition_m = [{}, {}, {}]\n\n[medium]\neta = {}\n",
            k.width, k.height, k.fx, k.fy, k.cx, k.cy, l.x, l.y, l.z, cal.eta
        ),
    )
    .unwrap();
}

fn info_json(path: &Path) -> Value {
    let text = cli::femto_ok(&["info", s(path), "--json"]).stdout;
    assert_eq!(text.trim().lines().count(), 1, "one JSON line: {text}");
    serde_json::from_str(&text).unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Everything a chain test starts from, in a temporary folder.
struct Fixture {
    dir: tempfile::TempDir,
    cal: Calibration,
    points: Vec<Option<Point3<f64>>>,
    cube: Cube,
    markers: Vec<(String, Point3<f64>)>,
}

impl Fixture {
    fn new() -> Fixture {
        let dir = tempfile::tempdir().unwrap();
        let cal = truth();
        let points = seen_points(&cal);
        let cube = camera_cube(&cal, &points);
        write_glb(&scene_mesh(), &dir.path().join("scene.glb")).unwrap();
        container::write_cube(
            &dir.path().join("cam.h5"),
            &cube,
            &Provenance::new("tests/ops.rs closed form"),
        )
        .unwrap();
        let markers = markers(&cal, 0.02);
        Fixture {
            dir,
            cal,
            points,
            cube,
            markers,
        }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }
}

/// (position error in mm per metre of distance to the markers' centroid, rotation error in
/// degrees, relative fx error in percent).
fn camera_errors(
    markers: &[(String, Point3<f64>)],
    truth: &Calibration,
    fit: &Calibration,
) -> (f64, f64, f64) {
    let centroid = markers
        .iter()
        .fold(Vector3::zeros(), |a, (_, p)| a + p.coords)
        / markers.len() as f64;
    let dist_m = (truth.pose.position_m.coords - centroid).norm();
    let pos = 1e3 * (fit.pose.position_m - truth.pose.position_m).norm() / dist_m;
    let rot = UnitQuaternion::from_rotation_matrix(
        &(fit.pose.world_from_camera * truth.pose.world_from_camera.inverse()),
    )
    .angle()
    .to_degrees();
    let fx = 100.0 * (fit.intrinsics.fx - truth.intrinsics.fx).abs() / truth.intrinsics.fx;
    (pos, rot, fx)
}

// ---------------------------------------------------------------------------------------
// Calibrate with known intrinsics, then unwarp, round trip, pyramid and info.

#[test]
fn calibrate_unwarp_pyramid_info_chain() {
    let fx = Fixture::new();
    let cal = &fx.cal;
    let hits = fx.points.iter().flatten().count();
    assert!(
        hits > W * H / 2 && hits < W * H,
        "{hits} pixels see the scene"
    );
    let (cam, glb, pts, known) = (
        fx.path("cam.h5"),
        fx.path("scene.glb"),
        fx.path("points.toml"),
        fx.path("known.toml"),
    );
    write_points(&pts, &observe(cal, &fx.markers, 0.5, 7));
    write_known_intrinsics(&known, cal);

    // --- calibrate: pose from the fiducials, t0 from the cube.
    let report = cli::femto_ok(&[
        "calibrate",
        s(&cam),
        "--mesh",
        s(&glb),
        "--points",
        s(&pts),
        "--intrinsics",
        s(&known),
    ])
    .stdout;
    println!(
        "{}",
        report.lines().rev().take(8).collect::<Vec<_>>().join("\n")
    );
    assert!(report.contains("reprojection: rms") && report.contains("time: t0"));
    let fitted = Calibration::load(&fx.path("cam.calibration.toml")).unwrap();
    let (pos, rot, _) = camera_errors(&fx.markers, cal, &fitted);
    let t0_err_bins = (fitted.t0_ps - cal.t0_ps) / DT_PS;
    println!(
        "known intrinsics, {} markers at 0.5 px: position {pos:.3} mm/m, rotation {rot:.4} deg, t0 {t0_err_bins:+.4} bins",
        fx.markers.len()
    );
    // The calibrate issue's tolerances (1 mm/m, 0.05 deg) and a tenth of a bin for t0.
    assert!(pos < 1.0, "position error {pos} mm/m");
    assert!(rot < 0.05, "rotation error {rot} deg");
    assert!(t0_err_bins.abs() < 0.1, "t0 off by {t0_err_bins} bins");
    assert_eq!(fitted.intrinsics, cal.intrinsics);
    assert_eq!(fitted.eta, ETA);
    assert_eq!(fitted.laser_m, cal.laser_m);

    // --- info shows the registration: fraction of pixels with geometry, distances, t0.
    let j = info_json(&cam);
    let r = &j["registration"];
    let true_dist: Vec<f64> = fx
        .points
        .iter()
        .flatten()
        .map(|p| (p - cal.pose.position_m).norm())
        .collect();
    let (dmin, dmax) = true_dist
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &d| {
            (a.min(d), b.max(d))
        });
    let hit_fraction = r["hit_fraction"].as_f64().unwrap();
    assert!(
        (hit_fraction - hits as f64 / (W * H) as f64).abs() < 0.01,
        "{hit_fraction} vs {hits}"
    );
    assert!((r["dist_m"]["min"].as_f64().unwrap() - dmin).abs() < 0.01);
    assert!((r["dist_m"]["max"].as_f64().unwrap() - dmax).abs() < 0.01);
    assert_eq!(r["calibration"]["t0_ps"].as_f64().unwrap(), fitted.t0_ps);
    assert_eq!(r["calibration"]["eta"].as_f64().unwrap(), ETA);
    assert_eq!(
        r["fit"]["points"].as_u64().unwrap(),
        fx.markers.len() as u64
    );
    assert_eq!(j["groups"], serde_json::json!(["registration"]));
    assert!(j["pyramid"].is_null());

    // --- unwarp with the fitted registration: world pulses at t0 + eta |laser - p| / c.
    let world = fx.path("world.h5");
    cli::femto_ok(&["unwarp", s(&cam), "--out", s(&world)]);
    let wc = container::read_cube(&world).unwrap();
    assert_eq!(wc.frame, TimeFrame::World);
    let wmask = wc.mask.clone().unwrap();
    // Pixels whose footprint spans more than 4 bins of path are masked as mixed (their
    // spread, from the registration the world cube carries).
    let reg = container::read_group(&world, femto::store::registration::GROUP).unwrap();
    let spread = femto::store::registration::footprint_spread(&world, &reg, W, H)
        .unwrap()
        .expect("calibrate records the footprint spreads");
    let eta = cal.eta;
    let mixed = |idx: usize| {
        femto::calibrate::mixed::spread_bins(spread[idx], DT_PS, eta)
            > femto::calibrate::mixed::MASK_SPREAD_BINS
    };
    let mut mixed_masked = 0;
    let mut errs = Vec::new();
    let mut mask_disagree = 0;
    for (idx, p) in fx.points.iter().enumerate() {
        let (x, y) = (idx % W, idx / W);
        match p {
            Some(p) if wmask[idx] == 1 => {
                let prof = wc.profile(x, y);
                let sum: f64 = prof.iter().map(|&v| v as f64).sum();
                let centroid_ps = prof
                    .iter()
                    .enumerate()
                    .map(|(i, &v)| v as f64 * wc.axis.bin_centre_ps(i))
                    .sum::<f64>()
                    / sum;
                errs.push(((centroid_ps - world_arrival_ps(cal, p)) / DT_PS).abs());
                assert!(
                    (sum - AMPLITUDE).abs() < 1e-3 * AMPLITUDE,
                    "energy of {x},{y}"
                );
            }
            _ => {
                if p.is_some() && wmask[idx] == 0 && mixed(idx) {
                    mixed_masked += 1;
                } else if (p.is_some()) != (wmask[idx] == 1) {
                    mask_disagree += 1;
                }
                if wmask[idx] == 0 {
                    assert!(wc.profile(x, y).iter().all(|&v| v == 0.0));
                }
            }
        }
    }
    errs.sort_by(f64::total_cmp);
    let pct = |q: f64| errs[((errs.len() - 1) as f64 * q) as usize];
    println!(
        "world pulse centre vs closed form (fitted registration): median {:.4}, 99 % {:.4}, max {:.4} bins; {mask_disagree} pixels masked differently, {mixed_masked} masked as mixed",
        pct(0.5),
        pct(0.99),
        pct(1.0)
    );
    assert!(
        mask_disagree < W * H / 200,
        "{mask_disagree} mask differences"
    );
    assert!(pct(0.99) < 0.1, "99th percentile {} bins", pct(0.99));

    // --- unwarp through the true calibration: bin by bin within the resampling bound.
    let true_toml = fx.path("true.toml");
    std::fs::write(&true_toml, cal.to_toml()).unwrap();
    let world_true = fx.path("world_true.h5");
    // Every pixel kept: this cube's pulses are those of each pixel's centre point alone (no
    // footprint), so its mixed pixels are exact too.
    cli::femto_ok(&[
        "unwarp",
        s(&cam),
        "--out",
        s(&world_true),
        "--calibration",
        s(&true_toml),
        "--mesh",
        s(&glb),
        "--mask-spread-bins",
        "inf",
    ]);
    let wt = container::read_cube(&world_true).unwrap();
    let expected = pulse_cube(&fx.points, wt.axis, TimeFrame::World, |p| {
        world_arrival_ps(cal, p)
    });
    // Box resampling of a shift: error per bin <= dt^3 / 8 max|s''| (src/unwarp.rs doc).
    let bound = DT_PS.powi(3) / 8.0 * max_second_derivative();
    let peak = expected.value_range().unwrap().1 as f64;
    let mut worst: f64 = 0.0;
    let wt_mask = wt.mask.clone().unwrap();
    for (idx, p) in fx.points.iter().enumerate() {
        let (x, y) = (idx % W, idx / W);
        assert_eq!(wt_mask[idx] == 1, p.is_some(), "mask of pixel {x},{y}");
        for (a, b) in wt.profile(x, y).iter().zip(expected.profile(x, y)) {
            worst = worst.max((a - b).abs() as f64);
        }
    }
    println!(
        "world cube through the true calibration: max error {:.4} % of the peak bin (bound {:.4} %)",
        100.0 * worst / peak,
        100.0 * bound / peak
    );
    assert!(worst <= bound * 1.001 + 1e-4 * peak, "{worst} > {bound}");
    // The covering axis keeps the input's bin width and starts a whole number of bins away.
    assert_eq!(wt.axis.dt_ps, DT_PS);
    let k = (wt.axis.t0_ps - fx.cube.axis.t0_ps) / DT_PS;
    assert!((k - k.round()).abs() < 1e-9, "axis offset {k} bins");

    // --- round trip camera -> world -> camera: within f (1 - f) dt^3 max|s''| <= dt^3 / 4.
    let back = fx.path("back.h5");
    cli::femto_ok(&[
        "unwarp",
        s(&world_true),
        "--to",
        "camera",
        "--out",
        s(&back),
        "--mask-spread-bins",
        "inf",
    ]);
    let bc = container::read_cube(&back).unwrap();
    assert_eq!(bc.frame, TimeFrame::Camera);
    let off = ((fx.cube.axis.t0_ps - bc.axis.t0_ps) / DT_PS).round() as i64;
    assert!(off >= 0);
    let bound_rt = DT_PS.powi(3) / 4.0 * max_second_derivative();
    let mut worst_rt: f64 = 0.0;
    for (idx, p) in fx.points.iter().enumerate() {
        let (x, y) = (idx % W, idx / W);
        let (orig, got) = (fx.cube.profile(x, y), bc.profile(x, y));
        for (i, &g) in got.iter().enumerate() {
            let j = i as i64 - off;
            let want = if j >= 0 && (j as usize) < orig.len() {
                orig[j as usize]
            } else {
                0.0
            };
            worst_rt = worst_rt.max((g - want).abs() as f64);
        }
        if p.is_none() {
            assert!(got.iter().all(|&v| v == 0.0));
        }
    }
    println!(
        "round trip camera -> world -> camera: max error {:.4} % of the peak bin (bound {:.4} %)",
        100.0 * worst_rt / peak,
        100.0 * bound_rt / peak
    );
    assert!(worst_rt <= bound_rt * 1.001 + 1e-4 * peak);
    // The world cube carries the registration, so info still shows it.
    assert!(!info_json(&world_true)["registration"]["calibration"].is_null());

    // --- pyramid in the cube (3 levels) and in a side file (all levels).
    cli::femto_ok(&["pyramid", s(&world_true), "--levels", "3"]);
    let side = fx.path("side.h5");
    cli::femto_ok(&["pyramid", s(&world_true), "--side-file", s(&side)]);
    let nt = wt.axis.nt;
    let top = (nt as f64).log2().ceil() as usize;
    let stored = femto::store::pyramid::read_pyramid(&world_true).unwrap();
    assert_eq!(stored.levels.len(), 3);
    assert_eq!(stored.axis, wt.axis);
    assert_eq!(stored.mask, wt.mask);
    for idx in (0..W * H).step_by(7) {
        let (x, y) = (idx % W, idx / W);
        let prof = wt.profile(x, y);
        let p = stored.pixel_prefix(x, y);
        let mut acc = 0.0f64;
        for i in 0..nt {
            acc += prof[i] as f64;
            // The f32 part of the prefix: within a few 2^-24 of the light of its block of 8.
            let block: f64 = prof[i / 8 * 8..=i].iter().map(|&v| v.abs() as f64).sum();
            assert!((p.get(i + 1) - acc).abs() <= 2e-7 * block + 1e-12 * (1.0 + acc.abs()));
        }
        for (k1, level) in stored.levels.iter().enumerate() {
            let w = 1usize << (k1 + 1);
            assert_eq!(level.nt, nt.div_ceil(w));
            for s in 0..level.nt {
                let want: f64 = prof[s * w..((s + 1) * w).min(nt)]
                    .iter()
                    .map(|&v| v as f64)
                    .sum();
                let got = level.data[idx * level.nt + s] as f64;
                assert!((got - want).abs() <= 1e-4 * (1.0 + want.abs()));
            }
        }
    }
    let side_pyr = femto::store::pyramid::read_pyramid(&side).unwrap();
    assert_eq!(side_pyr.levels.len(), top);
    assert_eq!(side_pyr.prefix, stored.prefix);
    assert_eq!(side_pyr.levels[..3], stored.levels[..]);
    let j = info_json(&world_true);
    assert_eq!(j["groups"], serde_json::json!(["pyramid", "registration"]));
    assert_eq!(j["pyramid"]["levels"], 3);
    assert_eq!(
        j["pyramid"]["level_nt"],
        serde_json::json!([nt.div_ceil(2), nt.div_ceil(4), nt.div_ceil(8)])
    );
    assert_eq!(j["pyramid"]["matches_cube"], true);
    let j = info_json(&side);
    assert_eq!(j["kind"], "pyramid");
    assert_eq!(j["pyramid"]["levels"], top);
    assert_eq!(
        j["pyramid"]["prefix"],
        serde_json::json!({
            "layout": "two-level",
            "coarse_shape": [H, W, nt / 8 + 1],
            "fine_shape": [H, W, nt + 1],
        })
    );
    let text = cli::femto_ok(&["info", s(&world_true)]).stdout;
    assert!(
        text.contains("pyramid") && text.contains("registration"),
        "{text}"
    );

    // --- refusals.
    let e = cli::femto_refused(&["pyramid", s(&world_true), "--levels", "40"]);
    assert!(e.contains("--levels 40") && e.contains("at most"), "{e}");
    let e = cli::femto_refused(&["unwarp", s(&world), "--out", s(&fx.path("x.h5"))]);
    assert!(e.contains("already in world time"), "{e}");
    let bare = fx.path("bare.h5");
    container::write_cube(&bare, &fx.cube, &Provenance::new("test")).unwrap();
    let e = cli::femto_refused(&["unwarp", s(&bare), "--out", s(&fx.path("x.h5"))]);
    assert!(e.contains("no /registration group"), "{e}");
    assert!(!fx.path("x.h5").exists());
}

// ---------------------------------------------------------------------------------------
// Calibrate with unknown intrinsics: Cramer-Rao-limited camera, flagged outlier.

/// RMS Cramer-Rao bound of the 10-parameter camera (rotation increment, centre, fx, fy, cx,
/// cy) for correspondences at `sigma_px` per axis, from a central-difference Jacobian of
/// [`project`]: (position mm/m as [`camera_errors`], rotation deg, fx %).
fn cramer_rao(
    markers: &[(String, Point3<f64>)],
    cal: &Calibration,
    sigma_px: f64,
) -> (f64, f64, f64) {
    let k = cal.intrinsics;
    let pose = cal.pose;
    let project_all = |q: &[f64; 10]| -> Vec<f64> {
        let mut kk = k;
        (kk.fx, kk.fy, kk.cx, kk.cy) = (q[6], q[7], q[8], q[9]);
        let p = Pose {
            world_from_camera: pose.world_from_camera
                * Rotation3::new(Vector3::new(q[0], q[1], q[2])),
            position_m: Point3::new(q[3], q[4], q[5]),
        };
        markers
            .iter()
            .flat_map(|(_, m)| {
                let (u, v, _) = project(&kk, &p, m);
                [u, v]
            })
            .collect()
    };
    let c = pose.position_m;
    let q0 = [0.0, 0.0, 0.0, c.x, c.y, c.z, k.fx, k.fy, k.cx, k.cy];
    let rows = 2 * markers.len();
    let mut jac = DMatrix::<f64>::zeros(rows, 10);
    for j in 0..10 {
        let h = 1e-6 * q0[j].abs().max(1.0);
        let (mut qp, mut qm) = (q0, q0);
        qp[j] += h;
        qm[j] -= h;
        let (rp, rm) = (project_all(&qp), project_all(&qm));
        for i in 0..rows {
            jac[(i, j)] = (rp[i] - rm[i]) / (2.0 * h);
        }
    }
    let cov = (jac.transpose() * &jac).try_inverse().unwrap() * (sigma_px * sigma_px);
    let centroid = markers
        .iter()
        .fold(Vector3::zeros(), |a, (_, p)| a + p.coords)
        / markers.len() as f64;
    let dist_m = (c.coords - centroid).norm();
    (
        1e3 * (cov[(3, 3)] + cov[(4, 4)] + cov[(5, 5)]).sqrt() / dist_m,
        (cov[(0, 0)] + cov[(1, 1)] + cov[(2, 2)])
            .sqrt()
            .to_degrees(),
        100.0 * cov[(6, 6)].sqrt() / k.fx,
    )
}

#[test]
fn calibrate_with_unknown_intrinsics_flags_the_outlier() {
    let fx = Fixture::new();
    let cal = &fx.cal;
    let (cam, glb, pts) = (
        fx.path("cam.h5"),
        fx.path("scene.glb"),
        fx.path("points.csv"),
    );
    let mut obs = observe(cal, &fx.markers, 0.5, 11);
    // One mis-picked marker: 8 px off.
    let bad = obs.len() / 2;
    obs[bad].1 .0 += 8.0;
    let bad_name = obs[bad].0.clone();
    // As CSV this time.
    let mut csv = String::from("name,x_px,y_px,X_m,Y_m,Z_m\n");
    for (name, (u, v), p) in &obs {
        csv.push_str(&format!("{name},{u:.6},{v:.6},{},{},{}\n", p.x, p.y, p.z));
    }
    std::fs::write(&pts, csv).unwrap();
    let l = cal.laser_m;
    let laser = format!("{},{},{}", l.x, l.y, l.z);
    let out_toml = fx.path("fitted.toml");
    let report = cli::femto_ok(&[
        "calibrate",
        s(&cam),
        "--mesh",
        s(&glb),
        "--points",
        s(&pts),
        "--laser",
        &laser,
        "--eta",
        &ETA.to_string(),
        "--out",
        s(&out_toml),
    ])
    .stdout;
    // The mis-picked marker is flagged; so are the few Gaussian-noise points beyond the
    // threshold of 3 median errors (about 0.2 % of them, src/calibrate/refine.rs).
    let flagged: Vec<&str> = report.lines().filter(|l| l.contains("OUTLIER")).collect();
    assert!(
        flagged.iter().any(|l| l.contains(&format!(" {bad_name} "))),
        "{bad_name} not flagged: {flagged:?}"
    );
    assert!(flagged.len() < obs.len() / 100, "{} flagged", flagged.len());
    let error_of = |l: &str| -> f64 { l.split_whitespace().rev().nth(1).unwrap().parse().unwrap() };
    let worst = flagged
        .iter()
        .max_by(|a, b| error_of(a).total_cmp(&error_of(b)))
        .unwrap();
    assert!(worst.contains(&format!(" {bad_name} ")), "{worst}");
    assert!(error_of(worst) > 6.0, "{worst}");
    let fitted = Calibration::load(&out_toml).unwrap();
    let (pos, rot, fxe) = camera_errors(&fx.markers, cal, &fitted);
    let (cr_pos, cr_rot, cr_fx) = cramer_rao(&fx.markers, cal, 0.5);
    let dpos_m = (fitted.pose.position_m - cal.pose.position_m).norm();
    let t0_err_bins = (fitted.t0_ps - cal.t0_ps) / DT_PS;
    println!(
        "unknown intrinsics, {} markers at 0.5 px: position {pos:.3} mm/m (CR {cr_pos:.3}), rotation {rot:.4} deg (CR {cr_rot:.4}), fx {fxe:.3} % (CR {cr_fx:.3}), t0 {t0_err_bins:+.4} bins ({:.2} mm camera offset = {:.4} bins)",
        fx.markers.len(),
        dpos_m * 1e3,
        dpos_m * ETA / C_M_PER_PS / DT_PS
    );
    // A single view with free intrinsics cannot beat the Cramer-Rao bound: require the errors
    // within three times it.
    assert!(pos < 3.0 * cr_pos, "position {pos} mm/m, bound {cr_pos}");
    assert!(rot < 3.0 * cr_rot, "rotation {rot} deg, bound {cr_rot}");
    assert!(fxe < 3.0 * cr_fx, "fx {fxe} %, bound {cr_fx}");
    // The fitted camera centre moves every path by up to its offset: t0 within a tenth of a
    // bin plus that offset's flight time (with 20 % for the shift of the registered points).
    let allowed = 0.1 + 1.2 * dpos_m * ETA / C_M_PER_PS / DT_PS;
    assert!(
        t0_err_bins.abs() < allowed,
        "t0 off by {t0_err_bins} bins, allowed {allowed}"
    );

    // Constraints are kept: square pixels and a centred principal point.
    let constrained = fx.path("constrained.toml");
    cli::femto_ok(&[
        "calibrate",
        s(&cam),
        "--mesh",
        s(&glb),
        "--points",
        s(&pts),
        "--laser",
        &laser,
        "--square-pixels",
        "--centred-principal-point",
        "--out",
        s(&constrained),
    ]);
    let c = Calibration::load(&constrained).unwrap();
    assert_eq!(c.intrinsics.fx, c.intrinsics.fy);
    assert_eq!(
        (c.intrinsics.cx, c.intrinsics.cy),
        (W as f64 / 2.0, H as f64 / 2.0)
    );
    assert_eq!(c.eta, 1.0, "eta defaults to 1 without --eta");
}

// ---------------------------------------------------------------------------------------
// Refusals of `femto calibrate`.

#[test]
fn degenerate_calibrations_exit_2_with_the_library_message() {
    let dir = tempfile::tempdir().unwrap();
    let cal = truth();
    let cam = dir.path().join("cam.h5");
    let axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: DT_PS,
        nt: 4,
    };
    container::write_cube(
        &cam,
        &Cube::zeros(W, H, axis, TimeFrame::Camera),
        &Provenance::new("test"),
    )
    .unwrap();
    let glb = dir.path().join("scene.glb");
    write_glb(&scene_mesh(), &glb).unwrap();
    let all = observe(&cal, &markers(&cal, 0.1), 0.0 + 1e-9, 3);
    let floor: Vec<_> = all
        .iter()
        .filter(|(n, _, _)| n.starts_with("floor"))
        .cloned()
        .collect();
    assert!(floor.len() >= 6);
    let mut repeated = all.clone();
    repeated[9].2 = repeated[2].2;
    let behind: Vec<_> = all
        .iter()
        .map(|(n, px, p)| {
            let mirrored = Point3::from(2.0 * cal.pose.position_m.coords - p.coords);
            (n.clone(), *px, mirrored)
        })
        .collect();
    let known = dir.path().join("known.toml");
    write_known_intrinsics(&known, &cal);
    let laser = "-0.4,0,0.3";
    let cases: Vec<(&str, Observations, bool, &str)> = vec![
        ("five", all[..5].to_vec(), false, "at least 6"),
        ("three_known", all[..3].to_vec(), true, "at least 4"),
        ("coplanar", floor, false, "lie on one plane"),
        ("repeated", repeated, false, "same 3-D position"),
        ("behind", behind.clone(), false, "behind the camera"),
        ("behind_known", behind, true, "behind the camera"),
    ];
    for (name, points, with_known, message) in cases {
        let p = dir.path().join(format!("{name}.toml"));
        write_points(&p, &points);
        let mut args = vec!["calibrate", s(&cam), "--mesh", s(&glb), "--points", s(&p)];
        if with_known {
            args.extend(["--intrinsics", s(&known)]);
        } else {
            args.extend(["--laser", laser]);
        }
        let e = cli::femto_refused(&args);
        assert!(e.contains(message), "{name}: {e}");
        assert!(e.contains(s(&p)), "{name}: the message names the file: {e}");
    }
    // No laser spot at all.
    let p = dir.path().join("good.toml");
    write_points(&p, &all);
    let e = cli::femto_refused(&["calibrate", s(&cam), "--mesh", s(&glb), "--points", s(&p)]);
    assert!(e.contains("--laser"), "{e}");
    // A world-time cube.
    let world = dir.path().join("world.h5");
    container::write_cube(
        &world,
        &Cube::zeros(W, H, axis, TimeFrame::World),
        &Provenance::new("test"),
    )
    .unwrap();
    let e = cli::femto_refused(&[
        "calibrate",
        s(&world),
        "--mesh",
        s(&glb),
        "--points",
        s(&p),
        "--laser",
        laser,
    ]);
    assert!(e.contains("world time"), "{e}");
    // Nothing was written: no calibration file, no registration group.
    assert!(!dir.path().join("cam.calibration.toml").exists());
    assert!(container::read_meta(&cam).unwrap().groups.is_empty());
}

// ---------------------------------------------------------------------------------------
// `femto info` on meshes and streak images.

#[test]
fn info_describes_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join("scene.glb");
    let mesh = scene_mesh();
    write_glb(&mesh, &glb).unwrap();
    let j = info_json(&glb);
    assert_eq!(j["kind"], "mesh");
    assert_eq!(j["format"], "glb");
    assert_eq!(j["triangles"], 14);
    let b = &j["bounds_m"];
    let want_min = [-FLOOR_X, 0.0, FLOOR_Z.0];
    let want_max = [FLOOR_X, WALL_H, FLOOR_Z.1];
    for a in 0..3 {
        assert!((b["min"][a].as_f64().unwrap() - want_min[a]).abs() < 1e-6);
        assert!((b["max"][a].as_f64().unwrap() - want_max[a]).abs() < 1e-6);
    }
    // Areas: floor 1.6 x 1.4, wall 1.6 x 0.9, box top 0.3 x 0.3 and sides 0.3 x 0.3 (x4).
    let box_area = 5.0 * 0.3 * 0.3;
    let want = [(0, 2, 1.6 * 1.4), (1, 2, 1.6 * 0.9), (2, 10, box_area)];
    let mats = j["materials"].as_array().unwrap();
    assert_eq!(mats.len(), 3);
    for (m, (index, tris, area)) in mats.iter().zip(want) {
        assert_eq!(m["index"], index);
        assert_eq!(m["triangles"], tris);
        assert!((m["area_m2"].as_f64().unwrap() - area).abs() < 1e-5, "{m}");
    }
    let text = cli::femto_ok(&["info", s(&glb)]).stdout;
    assert!(
        text.contains("14 (") && text.contains("triangle mesh"),
        "{text}"
    );
}

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn info_describes_the_bunny() {
    let Some(bunny) = shared::file("data/stanford-bunny.obj") else {
        return;
    };
    let j = info_json(&bunny);
    assert_eq!(j["kind"], "mesh");
    assert_eq!(j["format"], "obj");
    assert_eq!(j["triangles"], 69_451);
    let size = &j["bounds_m"]["size"];
    assert!((0..3).all(|a| size[a].as_f64().unwrap() > 0.0));
}

#[test]
fn info_describes_streak_images() {
    let dir = tempfile::tempdir().unwrap();
    let (nx, nt) = (20, 12);
    let data: Vec<f32> = (0..nx * nt).map(|i| (i % 97) as f32 * 10.0).collect();
    let img = StreakImage::new(nx, nt, data);

    let png = dir.path().join("line.png");
    femto::formats::raster::write_png16(&png, &img, 2.0).unwrap();
    let j = info_json(&png);
    assert_eq!(j["kind"], "streak_image");
    assert_eq!(j["format"], "png");
    assert_eq!((j["nx"].as_u64(), j["nt"].as_u64()), (Some(20), Some(12)));
    assert_eq!(j["pixel_type"], "u16");
    // Stored counts are value / 2: the largest is 96 * 10 / 2.
    assert_eq!(j["value_range"]["max"], 480.0);
    assert!(j["time_axis"].is_null());

    let img_path = dir.path().join("line.img");
    let times: Vec<f64> = (0..nt).map(|i| 100.0 + 2.5 * i as f64).collect();
    femto::formats::hamamatsu::write_img(&img_path, &img, 16, &times).unwrap();
    let j = info_json(&img_path);
    assert_eq!(j["format"], "img");
    assert_eq!(j["pixel_type"], "u16");
    assert_eq!(j["time_axis"]["first_ps"], 100.0);
    assert_eq!(j["time_axis"]["last_ps"], 100.0 + 2.5 * (nt - 1) as f64);
    assert!((j["time_axis"]["mean_dt_ps"].as_f64().unwrap() - 2.5).abs() < 1e-9);
    assert_eq!(j["img"]["width"], nx);
    assert_eq!(j["img"]["height"], nt);
    assert_eq!(j["img"]["mode"], "Operate");
    let text = cli::femto_ok(&["info", s(&img_path)]).stdout;
    assert!(
        text.contains("20 x 12") && text.contains("HPD-TA"),
        "{text}"
    );
}

// ---------------------------------------------------------------------------------------
// The whole chain on a simulated capture: simulate (clean) -> calibrate with the simulator's
// fiducials -> unwarp -> the simulator's world-time truth.

#[test]
fn simulated_capture_calibrates_and_unwarps_to_the_world_time_truth() {
    let tmp = tempfile::tempdir().unwrap();
    let cap = tmp.path().join("cap");
    // The built-in cube scene, small: 48 x 36 pixels, 128 bins of 16 ps, 16 paths per pixel.
    // The window holds most of the two-bounce light: a pixel whose light it clips has a world
    // truth with light that the camera cube lacks, and is not compared below (with 64 bins
    // and the tracer's light vertices, which give nearly every path some late two-bounce
    // light, only 36 pixels were left; 614 with 128).
    let (nx, ny) = (48usize, 36usize);
    cli::femto_ok(&[
        "simulate",
        "--out",
        s(&cap),
        "--size",
        "48x36",
        "--nt",
        "128",
        "--dt-ps",
        "16",
        "--spp",
        "16",
        "--bounces",
        "2",
    ]);
    let truth_cal = Calibration::load(&cap.join("calibration.toml")).unwrap();
    let camera = cap.join("truth_camera.h5");
    let l = truth_cal.laser_m;
    // The simulator lists some points twice (a scene grid point that is also a marker, a few
    // nanometres apart), which
    // `femto calibrate` refuses as repeated points: keep the first of each.
    let points = femto::calibrate::load_points(&cap.join("fiducials.toml")).unwrap();
    let mut unique: Vec<femto::calibrate::Correspondence> = Vec::new();
    for p in points.iter() {
        if !unique.iter().any(|q| (q.point_m - p.point_m).norm() < 1e-6) {
            unique.push(p.clone());
        }
    }
    println!(
        "simulated capture: {} fiducials, {} repeated",
        points.len(),
        points.len() - unique.len()
    );
    let fiducials = tmp.path().join("fiducials.toml");
    femto::calibrate::save_points_toml(&fiducials, &unique).unwrap();
    cli::femto_ok(&[
        "calibrate",
        s(&camera),
        "--mesh",
        s(&cap.join("scene.glb")),
        "--points",
        s(&fiducials),
        "--laser",
        &format!("{},{},{}", l.x, l.y, l.z),
        "--eta",
        &truth_cal.eta.to_string(),
    ]);
    let fitted = Calibration::load(&cap.join("truth_camera.calibration.toml")).unwrap();
    let dt_ps = container::read_meta(&camera).unwrap().axis.dt_ps;
    let dpos_mm = 1e3 * (fitted.pose.position_m - truth_cal.pose.position_m).norm();
    let rot_deg = UnitQuaternion::from_rotation_matrix(
        &(fitted.pose.world_from_camera * truth_cal.pose.world_from_camera.inverse()),
    )
    .angle()
    .to_degrees();
    let fx_pct = 100.0 * (fitted.intrinsics.fx / truth_cal.intrinsics.fx - 1.0);
    let t0_bins = (fitted.t0_ps - truth_cal.t0_ps) / dt_ps;
    println!(
        "simulated capture: camera off by {dpos_mm:.4} mm, {rot_deg:.5} deg, fx {fx_pct:+.4} %; t0 {t0_bins:+.3} bins"
    );
    // Noise-free fiducials: the camera is exact up to the fit's convergence.
    assert!(dpos_mm < 0.1 && rot_deg < 1e-3 && fx_pct.abs() < 0.01);
    // Sub-bin pulses spread over each pixel's footprint: first arrivals are coarser than
    // the closed-form pulses above; still within half a bin.
    assert!(t0_bins.abs() < 0.5, "t0 off by {t0_bins} bins");

    // Unwarp onto the truth's world axis and compare pixel by pixel.
    let truth_world = container::read_cube(&cap.join("truth_world.h5")).unwrap();
    let world = tmp.path().join("world.h5");
    cli::femto_ok(&[
        "unwarp",
        s(&camera),
        "--out",
        s(&world),
        "--t0-ps",
        &truth_world.axis.t0_ps.to_string(),
        "--nt",
        &truth_world.axis.nt.to_string(),
        "--dt-ps",
        &truth_world.axis.dt_ps.to_string(),
    ]);
    let got = container::read_cube(&world).unwrap();
    assert_eq!(got.axis, truth_world.axis);
    let cam_cube = container::read_cube(&camera).unwrap();
    // Pixels whose footprint lies on one surface: the distances at the four corners (rays
    // through the true camera, intersected with the scene mesh) within 2 mm of the centre's.
    let bvh = femto::geometry::bvh::Bvh::new(
        femto::geometry::load::load_mesh(&cap.join("scene.glb")).unwrap(),
    );
    let o = truth_cal.pose.position_m;
    let distance = |u: f64, v: f64| -> Option<f64> {
        let d = truth_cal.world_ray(u, v).into_inner();
        let ray = femto::geometry::Ray::new(o.cast::<f32>(), d.cast::<f32>());
        bvh.intersect(&ray, 0.0, f32::INFINITY).map(|h| h.t as f64)
    };
    let totals = cam_cube.time_integral();
    let max_total = totals.iter().cloned().fold(0.0, f64::max);
    let mean = |p: &[f32], a: &TimeAxis| {
        p.iter()
            .enumerate()
            .map(|(i, &v)| v as f64 * a.bin_centre_ps(i))
            .sum::<f64>()
            / p.iter().map(|&v| v as f64).sum::<f64>()
    };
    let cdf = |p: &[f32]| -> Vec<f64> {
        let mut acc = 0.0;
        p.iter()
            .map(|&v| {
                acc += v as f64;
                acc
            })
            .collect()
    };
    let (mut checked, mut worst_mean_ps) = (0, 0.0f64);
    for y in 0..ny {
        for x in 0..nx {
            let Some(d_m) = distance(x as f64 + 0.5, y as f64 + 0.5) else {
                continue;
            };
            let corners: Vec<f64> = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .iter()
                .filter_map(|(a, b)| distance(x as f64 + a, y as f64 + b))
                .collect();
            if corners.len() < 4 || corners.iter().any(|c| (c - d_m).abs() > 2e-3) {
                continue;
            }
            let total = totals[y * nx + x];
            let (g, w) = (got.profile(x, y), truth_world.profile(x, y));
            let total_w: f64 = w.iter().map(|&v| v as f64).sum();
            let total_g: f64 = g.iter().map(|&v| v as f64).sum();
            // Skip dim pixels and those whose light the truth's axis clips.
            if total < 1e-3 * max_total || (total_w / total - 1.0).abs() > 1e-4 {
                continue;
            }
            assert!(
                (total_g / total_w - 1.0).abs() < 1e-4,
                "pixel ({x}, {y}): total {total_g} vs {total_w}"
            );
            // Mean world time: the resampling keeps it; the tracer's paths go through random
            // points of the pixel, whose mean distance differs from the centre's by about
            // spread / sqrt(12 spp): 6 of those plus 0.2 ps, as in tests/simulate.rs.
            let spread_m = corners.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                - corners.iter().cloned().fold(f64::INFINITY, f64::min);
            let tol_ps =
                0.2 + 6.0 * truth_cal.eta * spread_m / C_M_PER_PS / (12.0f64 * 16.0).sqrt();
            let err_ps = mean(g, &got.axis) - mean(w, &truth_world.axis);
            worst_mean_ps = worst_mean_ps.max(err_ps.abs());
            assert!(
                err_ps.abs() < tol_ps,
                "pixel ({x}, {y}): mean off by {err_ps} ps"
            );
            // Profiles: the cumulative sums agree to within the resampling's two bins.
            let (cg, cw) = (cdf(g), cdf(w));
            let n = cw.len();
            for j in 0..n {
                let (lo, hi) = (cw[j.saturating_sub(2)], cw[(j + 2).min(n - 1)]);
                let eps = 1e-4 * total_w;
                assert!(
                    cg[j] >= lo - eps && cg[j] <= hi + eps,
                    "pixel ({x}, {y}) bin {j}: {} outside [{lo}, {hi}]",
                    cg[j]
                );
            }
            checked += 1;
        }
    }
    println!(
        "simulated capture: {checked} pixels compared with truth_world.h5, worst mean time error {worst_mean_ps:.3} ps ({:.4} bins)",
        worst_mean_ps / dt_ps
    );
    assert!(checked > 150, "only {checked} pixels compared");
}

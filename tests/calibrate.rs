//! Calibration against synthetic truth: a camera written here, fiducials projected through it
//! with the pinhole formula written here, seeded pixel noise; a simulated cube whose first
//! arrivals are computed here from analytic planes; a registration checked against
//! brute-force ray-plane intersections.

use femto::calibrate::{
    arrival_samples, calibrate_time, fit_camera, fit_time_offset, footprints, load_points,
    register, ArrivalOptions, CalibrateError, Correspondence, SpatialOptions,
};
use femto::camera::{Calibration, Intrinsics, Pose};
use femto::container::read_cube;
use femto::cube::{Cube, TimeAxis, TimeFrame};
use femto::geometry::bvh::Bvh;
use femto::geometry::load::load_mesh;
use femto::geometry::TriangleMesh;
use femto::scene::Scene;
use femto::simulate::{simulate_capture, SimulateOptions};
use nalgebra::{DMatrix, Point3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::path::Path;

const C_M_PER_PS: f64 = 2.997_924_58e-4;
const SPATIAL_NX: usize = 672;
const SPATIAL_NY: usize = 504;

/// The seed's sensor size (672 x 600), 40 degree vertical field of view, a few metres from a
/// scene with a floor (y = 0) and a back wall (z = -1.5).
fn true_camera() -> (Intrinsics, Pose) {
    let k = Intrinsics::from_vfov(672, 600, 40.0);
    let pose = Pose::look_at(
        Point3::new(1.2, 1.6, 3.0),
        Point3::new(0.0, 0.35, -0.4),
        Vector3::y(),
    )
    .unwrap();
    (k, pose)
}

/// Pinhole projection with radial distortion, written out (no z check: callers make sure).
fn pinhole(k: &Intrinsics, pose: &Pose, p: &Point3<f64>) -> (f64, f64, f64) {
    let r = pose.world_from_camera.matrix();
    let d = p - pose.position_m;
    // camera = R^T (p - o)
    let (x, y, z) = (
        r.column(0).dot(&d),
        r.column(1).dot(&d),
        r.column(2).dot(&d),
    );
    let (xn, yn) = (x / z, y / z);
    let r2 = xn * xn + yn * yn;
    let s = 1.0 + k.k1 * r2 + k.k2 * r2 * r2;
    (k.fx * s * xn + k.cx, k.fy * s * yn + k.cy, z)
}

/// 8 corners of a 0.3 m cube on the floor, 12 floor markers and 9 wall markers.
fn fiducial_points() -> Vec<(String, Point3<f64>)> {
    let mut pts = Vec::new();
    for (i, &x) in [-0.15, 0.15].iter().enumerate() {
        for (j, &y) in [0.0, 0.3].iter().enumerate() {
            for (l, &z) in [-0.15, 0.15].iter().enumerate() {
                pts.push((format!("cube {i}{j}{l}"), Point3::new(x, y, z)));
            }
        }
    }
    for &x in &[-0.9, -0.4, 0.4, 0.9] {
        for &z in &[-1.1, -0.5, 0.6] {
            pts.push((format!("floor {x} {z}"), Point3::new(x, 0.0, z)));
        }
    }
    for &x in &[-1.0, 0.0, 1.0] {
        for &y in &[0.4, 0.8, 1.2] {
            pts.push((format!("wall {x} {y}"), Point3::new(x, y, -1.5)));
        }
    }
    pts
}

/// A grid of markers every 8 cm on the floor and the back wall, those the true camera sees
/// (5 px from the border), plus the 8 cube corners.
fn dense_points(k: &Intrinsics, pose: &Pose) -> Vec<(String, Point3<f64>)> {
    let mut pts: Vec<(String, Point3<f64>)> = fiducial_points().into_iter().take(8).collect();
    let step = 0.08;
    for ix in -31..=31 {
        let x = ix as f64 * step;
        for iz in -18..=37 {
            let z = iz as f64 * step;
            if x.abs() > 0.3 || z.abs() > 0.3 {
                pts.push((format!("floor {ix} {iz}"), Point3::new(x, 0.0, z)));
            }
        }
        for iy in 1..=37 {
            pts.push((
                format!("wall {ix} {iy}"),
                Point3::new(x, iy as f64 * step, -1.5),
            ));
        }
    }
    pts.retain(|(_, p)| {
        let (u, v, z) = pinhole(k, pose, p);
        z > 0.5 && u > 5.0 && u < k.width as f64 - 5.0 && v > 5.0 && v < k.height as f64 - 5.0
    });
    pts
}

/// Project `points` through the camera and add seeded Gaussian noise of `noise_px` per axis.
fn observe(
    points: &[(String, Point3<f64>)],
    k: &Intrinsics,
    pose: &Pose,
    noise_px: f64,
    seed: u64,
) -> Vec<Correspondence> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let noise = Normal::new(0.0, noise_px.max(1e-300)).unwrap();
    points
        .iter()
        .map(|(name, p)| {
            let (u, v, z) = pinhole(k, pose, p);
            assert!(z > 0.5, "{name} is not in front of the camera");
            assert!(
                u > 5.0 && u < k.width as f64 - 5.0 && v > 5.0 && v < k.height as f64 - 5.0,
                "{name} is outside the image: {u}, {v}"
            );
            let (du, dv) = if noise_px > 0.0 {
                (noise.sample(&mut rng), noise.sample(&mut rng))
            } else {
                (0.0, 0.0)
            };
            Correspondence {
                name: Some(name.clone()),
                pixel: (u + du, v + dv),
                point_m: *p,
            }
        })
        .collect()
}

fn correspondences(k: &Intrinsics, pose: &Pose, noise_px: f64, seed: u64) -> Vec<Correspondence> {
    observe(&fiducial_points(), k, pose, noise_px, seed)
}

/// (position error per metre of distance to the points' centroid in mm/m, rotation error in
/// degrees, relative fx error in percent).
fn camera_errors(
    points: &[Correspondence],
    true_pose: &Pose,
    true_k: &Intrinsics,
    pose: &Pose,
    k: &Intrinsics,
) -> (f64, f64, f64) {
    let centroid = points
        .iter()
        .fold(Vector3::zeros(), |a, c| a + c.point_m.coords)
        / points.len() as f64;
    let dist_m = (true_pose.position_m.coords - centroid).norm();
    let pos_mm_per_m = 1e3 * (pose.position_m - true_pose.position_m).norm() / dist_m;
    // Quaternion angle (2 atan2(|v|, w)) stays accurate for tiny rotations, unlike acos.
    let rot_deg = UnitQuaternion::from_rotation_matrix(
        &(pose.world_from_camera * true_pose.world_from_camera.inverse()),
    )
    .angle()
    .to_degrees();
    let fx_pct = 100.0 * (k.fx - true_k.fx).abs() / true_k.fx;
    (pos_mm_per_m, rot_deg, fx_pct)
}

/// Cramer-Rao bound of the 10-parameter camera (rotation increment, centre, fx, fy, cx, cy)
/// for the given points and `sigma_px` noise per axis, from a central-difference Jacobian of
/// [`pinhole`]: RMS position error (mm/m, as [`camera_errors`]), RMS rotation angle (deg),
/// RMS relative fx error (%).
fn cramer_rao(
    points: &[Correspondence],
    k: &Intrinsics,
    pose: &Pose,
    sigma_px: f64,
) -> (f64, f64, f64) {
    let project_all = |q: &[f64; 10]| -> Vec<f64> {
        let mut kk = *k;
        kk.fx = q[6];
        kk.fy = q[7];
        kk.cx = q[8];
        kk.cy = q[9];
        let p = Pose {
            world_from_camera: pose.world_from_camera
                * nalgebra::Rotation3::new(Vector3::new(q[0], q[1], q[2])),
            position_m: Point3::new(q[3], q[4], q[5]),
        };
        points
            .iter()
            .flat_map(|c| {
                let (u, v, _) = pinhole(&kk, &p, &c.point_m);
                [u, v]
            })
            .collect()
    };
    let c = pose.position_m;
    let q0 = [0.0, 0.0, 0.0, c.x, c.y, c.z, k.fx, k.fy, k.cx, k.cy];
    let m = 2 * points.len();
    let mut jac = DMatrix::<f64>::zeros(m, 10);
    for j in 0..10 {
        let h = 1e-6 * q0[j].abs().max(1.0);
        let (mut qp, mut qm) = (q0, q0);
        qp[j] += h;
        qm[j] -= h;
        let (rp, rm) = (project_all(&qp), project_all(&qm));
        for i in 0..m {
            jac[(i, j)] = (rp[i] - rm[i]) / (2.0 * h);
        }
    }
    let cov = (jac.transpose() * &jac).try_inverse().unwrap() * (sigma_px * sigma_px);
    let centroid = points
        .iter()
        .fold(Vector3::zeros(), |a, p| a + p.point_m.coords)
        / points.len() as f64;
    let dist_m = (c.coords - centroid).norm();
    let pos = 1e3 * (cov[(3, 3)] + cov[(4, 4)] + cov[(5, 5)]).sqrt() / dist_m;
    let rot = (cov[(0, 0)] + cov[(1, 1)] + cov[(2, 2)])
        .sqrt()
        .to_degrees();
    let fx = 100.0 * cov[(6, 6)].sqrt() / k.fx;
    (pos, rot, fx)
}

#[test]
fn spatial_calibration_recovers_the_true_camera_within_tolerance() {
    // Tolerances: position 1 mm per metre, rotation 0.05 deg, fx 0.2 %, with 0.5 px noise.
    // With intrinsics free these are below the Cramer-Rao bound of a few dozen markers
    // (see the next test), so the markers form a dense grid (~2200 points).
    let (k, pose) = true_camera();
    let grid = dense_points(&k, &pose);
    let seeds = 1..=6u64;
    let n = seeds.clone().count() as f64;
    let (mut pos, mut rot, mut fx) = (0.0, 0.0, 0.0);
    for seed in seeds {
        let pts = observe(&grid, &k, &pose, 0.5, seed);
        let fit = fit_camera(&pts, &SpatialOptions::unknown_intrinsics(672, 600)).unwrap();
        let (p, r, f) = camera_errors(&pts, &pose, &k, &fit.pose, &fit.intrinsics);
        println!(
            "{} points, seed {seed}: position {p:.3} mm/m, rotation {r:.4} deg, fx {f:.3} %, rms {:.3} px, {} outliers, {} iterations",
            pts.len(), fit.rms_px, fit.outliers.len(), fit.iterations
        );
        // 2-D Gaussian residuals of 0.5 px per axis: RMS 0.5 sqrt(2) = 0.71 px.
        assert!((fit.rms_px - 0.707).abs() < 0.05, "rms {}", fit.rms_px);
        assert!(fit.outliers.len() < pts.len() / 100);
        assert!(fit.intrinsics_fitted && !fit.distortion_fitted);
        pos += p / n;
        rot += r / n;
        fx += f / n;
    }
    println!("mean over seeds: position {pos:.3} mm/m, rotation {rot:.4} deg, fx {fx:.3} %");
    assert!(pos < 1.0, "position error {pos} mm per metre");
    assert!(rot < 0.05, "rotation error {rot} deg");
    assert!(fx < 0.2, "focal length error {fx} %");
}

#[test]
fn spatial_calibration_of_sparse_fiducials_reaches_the_cramer_rao_bound() {
    // 8 cube corners and 21 markers: the errors over many noise draws must match the bound
    // computed here (an efficient estimator), neither worse nor implausibly better.
    let (k, pose) = true_camera();
    let (bound_pos, bound_rot, bound_fx) =
        cramer_rao(&correspondences(&k, &pose, 0.0, 0), &k, &pose, 0.5);
    let seeds = 100..132u64;
    let n = seeds.clone().count() as f64;
    let (mut pos, mut rot, mut fx) = (0.0, 0.0, 0.0);
    for seed in seeds {
        let pts = correspondences(&k, &pose, 0.5, seed);
        let mut opts = SpatialOptions::unknown_intrinsics(672, 600);
        opts.reject_outliers = false; // the bound is for plain least squares
        let fit = fit_camera(&pts, &opts).unwrap();
        let (p, r, f) = camera_errors(&pts, &pose, &k, &fit.pose, &fit.intrinsics);
        pos += p * p / n;
        rot += r * r / n;
        fx += f * f / n;
    }
    let (pos, rot, fx) = (pos.sqrt(), rot.sqrt(), fx.sqrt());
    println!(
        "29 fiducials, 0.5 px: RMS position {pos:.3} mm/m (bound {bound_pos:.3}), rotation {rot:.4} deg (bound {bound_rot:.4}), fx {fx:.3} % (bound {bound_fx:.3})"
    );
    for (name, got, bound) in [
        ("position", pos, bound_pos),
        ("rotation", rot, bound_rot),
        ("fx", fx, bound_fx),
    ] {
        assert!(
            got > 0.6 * bound && got < 1.4 * bound,
            "{name}: {got} vs bound {bound}"
        );
    }
}

#[test]
fn noise_free_fiducials_give_the_exact_camera_with_distortion() {
    let (mut k, pose) = true_camera();
    k.k1 = -0.12;
    k.k2 = 0.05;
    let pts = correspondences(&k, &pose, 0.0, 0);
    let mut opts = SpatialOptions::unknown_intrinsics(672, 600);
    opts.fit_distortion = true;
    let fit = fit_camera(&pts, &opts).unwrap();
    assert!(fit.distortion_fitted);
    let (p, r, f) = camera_errors(&pts, &pose, &k, &fit.pose, &fit.intrinsics);
    assert!(p < 1e-4 && r < 1e-5 && f < 1e-5, "{p} mm/m {r} deg {f} %");
    assert!(
        (fit.intrinsics.k1 - k.k1).abs() < 1e-5,
        "k1 {}",
        fit.intrinsics.k1
    );
    assert!(
        (fit.intrinsics.k2 - k.k2).abs() < 1e-4,
        "k2 {}",
        fit.intrinsics.k2
    );
    assert!((fit.intrinsics.cx - k.cx).abs() < 1e-4 && (fit.intrinsics.cy - k.cy).abs() < 1e-4);
    assert!(fit.rms_px < 1e-6 && fit.outliers.is_empty());

    // Too few points to fit distortion: it stays fixed at zero.
    let few: Vec<Correspondence> = pts[..8].to_vec();
    let fit = fit_camera(&few, &opts).unwrap();
    assert!(!fit.distortion_fitted);
    assert_eq!((fit.intrinsics.k1, fit.intrinsics.k2), (0.0, 0.0));
}

#[test]
fn square_pixels_and_centred_principal_point_are_kept() {
    let (k, pose) = true_camera();
    let pts = correspondences(&k, &pose, 0.0, 0);
    let mut opts = SpatialOptions::unknown_intrinsics(672, 600);
    opts.square_pixels = true;
    opts.principal_point_at_centre = true;
    let fit = fit_camera(&pts, &opts).unwrap();
    assert_eq!(fit.intrinsics.fx, fit.intrinsics.fy);
    assert_eq!((fit.intrinsics.cx, fit.intrinsics.cy), (336.0, 300.0));
    let (p, r, f) = camera_errors(&pts, &pose, &k, &fit.pose, &fit.intrinsics);
    assert!(p < 1e-4 && r < 1e-5 && f < 1e-5, "{p} mm/m {r} deg {f} %");
}

#[test]
fn a_mispicked_point_is_flagged_as_outlier() {
    let (k, pose) = true_camera();
    let mut pts = correspondences(&k, &pose, 0.3, 3);
    pts[13].pixel.0 += 12.0;
    let fit = fit_camera(&pts, &SpatialOptions::unknown_intrinsics(672, 600)).unwrap();
    assert_eq!(fit.outliers, vec![13], "errors {:?}", fit.per_point_px);
    assert!(fit.per_point_px[13] > 5.0);
    assert!((1.0..=3.0).contains(&fit.outlier_threshold_px));
}

#[test]
fn pose_with_known_intrinsics_from_six_points() {
    let (k, pose) = true_camera();
    let all = correspondences(&k, &pose, 0.0, 0);
    // Two cube corners, two floor markers, two wall markers: not coplanar.
    let six: Vec<Correspondence> = [0, 7, 8, 19, 20, 28]
        .iter()
        .map(|&i| all[i].clone())
        .collect();
    let fit = fit_camera(&six, &SpatialOptions::known_intrinsics(k)).unwrap();
    let (p, r, _) = camera_errors(&all, &pose, &k, &fit.pose, &fit.intrinsics);
    assert!(p < 1e-4 && r < 1e-5, "{p} mm/m {r} deg");
    assert_eq!(fit.intrinsics, k);
    assert!(!fit.intrinsics_fitted);

    // With 0.5 px noise the reprojection RMS is at the noise level.
    let noisy_all = correspondences(&k, &pose, 0.5, 9);
    let six: Vec<Correspondence> = [0, 7, 8, 19, 20, 28]
        .iter()
        .map(|&i| noisy_all[i].clone())
        .collect();
    let fit = fit_camera(&six, &SpatialOptions::known_intrinsics(k)).unwrap();
    assert!(fit.rms_px < 0.9, "{}", fit.rms_px);
    let (p, r, _) = camera_errors(&all, &pose, &k, &fit.pose, &fit.intrinsics);
    assert!(p < 20.0 && r < 0.5, "{p} mm/m {r} deg");
}

#[test]
fn pose_with_known_intrinsics_from_four_coplanar_floor_points() {
    let (k, pose) = true_camera();
    let all = correspondences(&k, &pose, 0.0, 0);
    let floor: Vec<Correspondence> = all
        .iter()
        .filter(|c| c.name.as_deref().unwrap().starts_with("floor"))
        .cloned()
        .collect();
    let four = vec![
        floor[0].clone(),
        floor[2].clone(),
        floor[9].clone(),
        floor[11].clone(),
    ];
    let fit = fit_camera(&four, &SpatialOptions::known_intrinsics(k)).unwrap();
    let (p, r, _) = camera_errors(&all, &pose, &k, &fit.pose, &fit.intrinsics);
    assert!(p < 1e-4 && r < 1e-5, "{p} mm/m {r} deg");
    // The same coplanar points cannot give the intrinsics.
    let e = fit_camera(&floor, &SpatialOptions::unknown_intrinsics(672, 600)).unwrap_err();
    assert!(matches!(e, CalibrateError::Coplanar { .. }), "{e}");
    assert!(e.to_string().contains("coplanar"), "{e}");
}

#[test]
fn degenerate_inputs_give_their_own_errors() {
    let (k, pose) = true_camera();
    let pts = correspondences(&k, &pose, 0.0, 0);
    let unknown = SpatialOptions::unknown_intrinsics(672, 600);

    let e = fit_camera(&pts[..5], &unknown).unwrap_err();
    assert!(
        matches!(
            e,
            CalibrateError::TooFewPoints {
                got: 5,
                need: 6,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("at least 6"), "{e}");
    let e = fit_camera(&pts[..3], &SpatialOptions::known_intrinsics(k)).unwrap_err();
    assert!(
        matches!(
            e,
            CalibrateError::TooFewPoints {
                got: 3,
                need: 4,
                ..
            }
        ),
        "{e}"
    );

    let mut repeated = pts.clone();
    repeated[20].point_m = repeated[4].point_m;
    let e = fit_camera(&repeated, &unknown).unwrap_err();
    assert!(matches!(e, CalibrateError::RepeatedPoint { .. }), "{e}");
    let msg = e.to_string();
    assert!(
        msg.contains("#5") && msg.contains("#21") && msg.contains("same 3-D position"),
        "{msg}"
    );

    let mut same_pixel = pts.clone();
    same_pixel[9].pixel = same_pixel[2].pixel;
    let e = fit_camera(&same_pixel, &unknown).unwrap_err();
    assert!(matches!(e, CalibrateError::RepeatedPixel { .. }), "{e}");

    let line: Vec<Correspondence> = (0..6)
        .map(|i| Correspondence {
            name: None,
            pixel: (100.0 + 10.0 * i as f64, 200.0 + 3.0 * i as f64),
            point_m: Point3::new(0.1 * i as f64, 0.0, 0.0),
        })
        .collect();
    let e = fit_camera(&line, &SpatialOptions::known_intrinsics(k)).unwrap_err();
    assert!(matches!(e, CalibrateError::Collinear { .. }), "{e}");
}

#[test]
fn points_behind_the_camera_are_refused() {
    // Mirror every fiducial through the camera centre: the pinhole formula x/z gives the same
    // pixels, but the points now lie behind the camera.
    let (k, pose) = true_camera();
    let pts: Vec<Correspondence> = correspondences(&k, &pose, 0.0, 0)
        .into_iter()
        .map(|mut c| {
            c.point_m = Point3::from(2.0 * pose.position_m.coords - c.point_m.coords);
            c
        })
        .collect();
    for opts in [
        SpatialOptions::unknown_intrinsics(672, 600),
        SpatialOptions::known_intrinsics(k),
    ] {
        let e = fit_camera(&pts, &opts).unwrap_err();
        assert!(matches!(e, CalibrateError::BehindCamera { .. }), "{e}");
        assert!(
            e.to_string()
                .contains("solution puts the mesh behind the camera"),
            "{e}"
        );
    }
}

// ---------------------------------------------------------------------------------------
// Registration and temporal calibration.

/// Axis-aligned quad as two triangles, split along the (min, min)-(max, max) diagonal.
fn quad(corners: [Point3<f32>; 4]) -> TriangleMesh {
    TriangleMesh {
        positions: corners.to_vec(),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        material: vec![0, 0],
    }
}

#[test]
fn registration_of_a_quad_matches_brute_force_ray_plane_distances() {
    let k = Intrinsics::from_vfov(40, 30, 40.0);
    let pose = Pose::look_at(Point3::origin(), Point3::new(0.0, 0.0, -1.0), Vector3::y()).unwrap();
    let cal = Calibration {
        intrinsics: k,
        pose,
        t0_ps: 0.0,
        time_scale: 1.0,
        laser_m: Point3::origin(),
        eta: 1.0,
    };
    // Quad at z = -2 m, smaller than the field of view (which is +-0.73 x +-0.55 m there).
    let (hx, hy, zq) = (0.503f32, 0.377f32, -2.0f32);
    let bvh = Bvh::new(quad([
        Point3::new(-hx, -hy, zq),
        Point3::new(hx, -hy, zq),
        Point3::new(hx, hy, zq),
        Point3::new(-hx, hy, zq),
    ]));
    let reg = register(&cal, &bvh, 40, 30).unwrap();
    let mut hits = 0;
    for j in 0..30 {
        for i in 0..40 {
            // Camera looks down -z with y up: camera x = world x, camera y = -world y.
            let dx = (i as f64 + 0.5 - k.cx) / k.fx;
            let dy = -(j as f64 + 0.5 - k.cy) / k.fy;
            let scale = -(zq as f64) / 1.0; // ray (dx, dy, -1) reaches z = zq at this parameter
            let (px, py) = (dx * scale, dy * scale);
            let expected_dist = scale * (dx * dx + dy * dy + 1.0).sqrt();
            let inside = px.abs() < hx as f64 && py.abs() < hy as f64;
            let idx = j * 40 + i;
            assert_eq!(reg.mask[idx] == 1, inside, "pixel {i},{j}");
            if inside {
                hits += 1;
                assert!((reg.dist_m[idx] as f64 - expected_dist).abs() < 1e-5);
                let p = reg.point_m[idx];
                assert!((p[0] as f64 - px).abs() < 1e-5 && (p[1] as f64 - py).abs() < 1e-5);
                assert!((p[2] - zq).abs() < 1e-5);
                assert_eq!(reg.normal[idx], [0.0, 0.0, 1.0]);
                // Triangle 0 holds the points below the diagonal y = x * hy / hx.
                let below = py < px * hy as f64 / hx as f64;
                assert_eq!(
                    reg.triangle[idx],
                    if below { 0 } else { 1 },
                    "pixel {i},{j}"
                );
            } else {
                assert!(reg.dist_m[idx].is_nan());
                assert_eq!(reg.triangle[idx], u32::MAX);
            }
        }
    }
    assert_eq!(reg.hit_count(), hits);
    assert!(hits > 200 && hits < 1200);

    let e = register(&cal, &bvh, 80, 60).unwrap_err();
    assert!(matches!(e, CalibrateError::SizeMismatch { .. }), "{e}");
    assert!(e.to_string().contains("80 x 60"), "{e}");
}

/// The scene of the temporal test: floor y = 0 (|x| < 1.5, -2 < z < 1) and back wall z = -2.
fn room() -> TriangleMesh {
    let mut mesh = quad([
        Point3::new(-1.5, 0.0, 1.0),
        Point3::new(1.5, 0.0, 1.0),
        Point3::new(1.5, 0.0, -2.0),
        Point3::new(-1.5, 0.0, -2.0),
    ]);
    mesh.append(
        &quad([
            Point3::new(-1.5, 0.0, -2.0),
            Point3::new(1.5, 0.0, -2.0),
            Point3::new(1.5, 2.0, -2.0),
            Point3::new(-1.5, 2.0, -2.0),
        ]),
        0,
    );
    mesh
}

/// The point a pixel centre sees in [`room`], by ray-plane intersection (independent of the
/// BVH): nearest of the floor and the wall within their bounds.
fn room_point(cal: &Calibration, i: usize, j: usize) -> Option<Point3<f64>> {
    let k = &cal.intrinsics;
    let d_cam = Vector3::new(
        (i as f64 + 0.5 - k.cx) / k.fx,
        (j as f64 + 0.5 - k.cy) / k.fy,
        1.0,
    );
    let d = cal.pose.world_from_camera * d_cam;
    let o = cal.pose.position_m;
    let mut best: Option<(f64, Point3<f64>)> = None;
    let t_floor = -o.y / d.y;
    let p = o + d * t_floor;
    if t_floor > 0.0 && p.x.abs() <= 1.5 && p.z <= 1.0 && p.z >= -2.0 {
        best = Some((t_floor, p));
    }
    let t_wall = (-2.0 - o.z) / d.z;
    let p = o + d * t_wall;
    if t_wall > 0.0
        && p.x.abs() <= 1.5
        && p.y >= 0.0
        && p.y <= 2.0
        && best.is_none_or(|b| t_wall < b.0)
    {
        best = Some((t_wall, p));
    }
    best.map(|b| b.1)
}

/// Bin-integrated Gaussian pulse (unit area, centre `mu_ps`, width `sigma_ps`) over
/// `[a_ps, b_ps)` by Simpson's rule.
fn pulse_in_bin(mu_ps: f64, sigma_ps: f64, a_ps: f64, b_ps: f64) -> f64 {
    let m = 64;
    let h = (b_ps - a_ps) / m as f64;
    let f = |t: f64| {
        (-(t - mu_ps).powi(2) / (2.0 * sigma_ps * sigma_ps)).exp()
            / (sigma_ps * (2.0 * std::f64::consts::PI).sqrt())
    };
    let mut s = f(a_ps) + f(b_ps);
    for i in 1..m {
        s += f(a_ps + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

/// A simulated camera-time cube of [`room`]: each pixel holds the direct pulse at
/// `t0 + scale * path / c` (Gaussian, `sigma_ps`, integrated over 4 ps bins) plus a
/// multi-bounce tail starting 2 ps later and decaying over 200 ps; 4 % of the pixels also hold a
/// spurious spike 300 ps earlier (the outliers).
fn simulated_cube(cal: &Calibration, sigma_ps: f64, seed: u64) -> Cube {
    let (nx, ny) = (cal.intrinsics.width, cal.intrinsics.height);
    let mut arrivals = vec![None; nx * ny];
    for j in 0..ny {
        for i in 0..nx {
            arrivals[j * nx + i] = room_point(cal, i, j).map(|p| {
                let path_m = (cal.laser_m - p).norm() + (p - cal.pose.position_m).norm();
                cal.t0_ps + cal.time_scale * cal.eta * path_m / C_M_PER_PS
            });
        }
    }
    let (lo, hi) = arrivals
        .iter()
        .flatten()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &t| {
            (a.min(t), b.max(t))
        });
    let dt_ps = 4.0;
    let axis = TimeAxis {
        t0_ps: (lo - 400.0).floor(),
        dt_ps,
        nt: ((hi - lo + 700.0) / dt_ps) as usize,
    };
    let mut cube = Cube::zeros(nx, ny, axis, TimeFrame::Camera);
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    for j in 0..ny {
        for i in 0..nx {
            let Some(t_true) = arrivals[j * nx + i] else {
                continue;
            };
            let amplitude = 0.5 + rng.random::<f64>();
            let spike = rng.random::<f64>() < 0.04;
            let profile = cube.profile_mut(i, j);
            for (b, v) in profile.iter_mut().enumerate() {
                let (a, e) = (axis.bin_start_ps(b), axis.bin_start_ps(b + 1));
                let mut value = 0.0;
                if (a - t_true).abs() < 10.0 * sigma_ps + dt_ps {
                    value += amplitude * pulse_in_bin(t_true, sigma_ps, a, e);
                }
                // Tail: 0.3 * amplitude * exp(-(t - t_true - 2) / 200) / 200 for t > t_true + 2.
                let start = t_true + 2.0;
                if e > start {
                    let (lo_t, hi_t) = (a.max(start), e);
                    value += 0.3
                        * amplitude
                        * ((-(lo_t - start) / 200.0).exp() - (-(hi_t - start) / 200.0).exp());
                }
                if spike && (a - (t_true - 300.0)).abs() < 12.0 {
                    value += amplitude * pulse_in_bin(t_true - 300.0, sigma_ps, a, e);
                }
                *v = value as f32;
            }
        }
    }
    cube
}

fn temporal_camera(t0_ps: f64, time_scale: f64) -> Calibration {
    Calibration {
        intrinsics: Intrinsics::from_vfov(48, 36, 40.0),
        pose: Pose::look_at(
            Point3::new(0.6, 1.3, 2.6),
            Point3::new(0.0, 0.4, -1.0),
            Vector3::y(),
        )
        .unwrap(),
        t0_ps,
        time_scale,
        laser_m: Point3::new(-0.7, 0.9, -1.9),
        eta: 1.0,
    }
}

#[test]
fn time_offset_of_a_simulated_cube_within_a_tenth_of_a_bin() {
    let cal = temporal_camera(-537.3, 1.0);
    let bvh = Bvh::new(room());
    let reg = register(&cal, &bvh, 48, 36).unwrap();
    let expected_hits = (0..36)
        .flat_map(|j| (0..48).map(move |i| (i, j)))
        .filter(|&(i, j)| room_point(&cal, i, j).is_some())
        .count();
    assert_eq!(reg.hit_count(), expected_hits);
    for (sigma_ps, seed) in [(0.5, 1), (1.5, 2), (5.0, 3)] {
        let cube = simulated_cube(&cal, sigma_ps, seed);
        let samples =
            arrival_samples(&cube, &reg, &cal.laser_m, &ArrivalOptions::default()).unwrap();
        assert_eq!(samples.len(), expected_hits);
        let pairs: Vec<(f64, f64)> = samples.iter().map(|s| (s.t_first_ps, s.path_m)).collect();
        let fit = fit_time_offset(&pairs, cal.eta, false).unwrap();
        let err_bins = (fit.t0_ps - cal.t0_ps).abs() / cube.axis.dt_ps;
        println!(
            "sigma {sigma_ps} ps: t0 error {err_bins:.4} bins, {} of {} inliers, rms {:.3} ps",
            fit.inlier_count(),
            pairs.len(),
            fit.rms_ps
        );
        assert!(err_bins < 0.1, "t0 off by {err_bins} bins");
        // The spikes 300 ps early are outliers; almost everything else is an inlier.
        let outliers = pairs.len() - fit.inlier_count();
        assert!(
            outliers >= expected_hits / 50 && outliers < expected_hits / 10,
            "{outliers}"
        );
    }
}

#[test]
fn time_offset_and_scale_of_a_simulated_cube() {
    let cal = temporal_camera(812.0, 1.015);
    let reg = register(&cal, &Bvh::new(room()), 48, 36).unwrap();
    let cube = simulated_cube(&cal, 1.5, 4);
    let samples = arrival_samples(&cube, &reg, &cal.laser_m, &ArrivalOptions::default()).unwrap();
    let pairs: Vec<(f64, f64)> = samples.iter().map(|s| (s.t_first_ps, s.path_m)).collect();
    let fit = fit_time_offset(&pairs, cal.eta, true).unwrap();
    let err_bins = (fit.t0_ps - cal.t0_ps).abs() / cube.axis.dt_ps;
    println!(
        "t0 error {err_bins:.4} bins, time scale {:.6} (true {})",
        fit.time_scale, cal.time_scale
    );
    assert!(err_bins < 0.1, "t0 off by {err_bins} bins");
    assert!(
        (fit.time_scale - cal.time_scale).abs() < 2e-4,
        "{}",
        fit.time_scale
    );

    // A world-time cube and a registration of another size are refused.
    let mut world = cube.clone();
    world.frame = TimeFrame::World;
    let e = arrival_samples(&world, &reg, &cal.laser_m, &ArrivalOptions::default()).unwrap_err();
    assert!(matches!(e, CalibrateError::WorldTimeCube), "{e}");
}

// ---------------------------------------------------------------------------------------
// On the simulator's own capture (`femto::simulate`): its fiducials file, its true
// calibration and its true camera-time cube.

/// A capture folder of the built-in `cube` scene written by [`simulate_capture`] at
/// `nx x ny` pixels, 256 bins of 4 ps, `spp` paths per pixel, 2 bounces, no flaws.
fn simulated_capture(nx: usize, ny: usize, nt: usize, spp: u32) -> tempfile::TempDir {
    let scene = Scene::builtin("cube", None)
        .unwrap()
        .with_resolution(nx, ny, nt, 4.0);
    let dir = tempfile::tempdir().unwrap();
    let opts = SimulateOptions {
        spp,
        seed: 7,
        max_bounces: 2,
        created_by: "tests/calibrate.rs".into(),
        ..SimulateOptions::default()
    };
    simulate_capture(&scene, &opts, &dir.path().join("cap"), &|_, _| {}).unwrap();
    dir
}

/// The simulator's fiducials (it writes no two within 1 mm of each other, which
/// `fit_camera` would refuse as repeated points).
fn simulator_fiducials(cap: &Path) -> Vec<Correspondence> {
    load_points(&cap.join("fiducials.toml")).unwrap()
}

/// `points` with seeded Gaussian noise of `sigma_px` added to each pixel coordinate.
fn with_pixel_noise(points: &[Correspondence], sigma_px: f64, seed: u64) -> Vec<Correspondence> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let noise = Normal::new(0.0, sigma_px).unwrap();
    points
        .iter()
        .map(|c| Correspondence {
            pixel: (
                c.pixel.0 + noise.sample(&mut rng),
                c.pixel.1 + noise.sample(&mut rng),
            ),
            ..c.clone()
        })
        .collect()
}

#[test]
fn simulator_fiducials_with_half_a_pixel_of_noise_give_the_true_camera() {
    // Sizes: SPATIAL_NX x SPATIAL_NY pixels, few bins: only the fiducials and the truth are
    // used here.
    let dir = simulated_capture(SPATIAL_NX, SPATIAL_NY, 8, 1);
    let cap = dir.path().join("cap");
    let truth = Calibration::load(&cap.join("calibration.toml")).unwrap();
    let points = simulator_fiducials(&cap);
    // The pixels are the true projections: through the pinhole formula of this file.
    for c in &points {
        let (u, v, _) = pinhole(&truth.intrinsics, &truth.pose, &c.point_m);
        assert!((u - c.pixel.0).abs() < 1e-6 && (v - c.pixel.1).abs() < 1e-6);
    }
    let (k, pose) = (truth.intrinsics, truth.pose);
    let (cr_p, cr_r, cr_f) = cramer_rao(&points, &k, &pose, 0.5);
    println!(
        "{} fiducials; Cramer-Rao RMS with free intrinsics: position {cr_p:.3} mm/m, rotation {cr_r:.4} deg, fx {cr_f:.4} %",
        points.len()
    );
    let mut constrained = SpatialOptions::unknown_intrinsics(k.width, k.height);
    constrained.square_pixels = true;
    constrained.principal_point_at_centre = true;
    for seed in 0..3 {
        let noisy = with_pixel_noise(&points, 0.5, 100 + seed);
        // Square pixels and the principal point at the centre, both true of the simulator's
        // camera: the tolerances hold.
        let fit = fit_camera(&noisy, &constrained).unwrap();
        let (p, r, f) = camera_errors(&points, &pose, &k, &fit.pose, &fit.intrinsics);
        println!(
            "seed {seed}, square pixels, centred principal point: position {p:.3} mm/m, rotation {r:.4} deg, fx {f:.4} %, rms {:.3} px",
            fit.rms_px
        );
        assert!(
            p < 1.0 && r < 0.05 && f < 0.2,
            "seed {seed}: {p} mm/m {r} deg {f} %"
        );
        // All four intrinsics free: the principal point trades off against the rotation,
        // whose Cramer-Rao bound for these points at this image size (0.063 degrees RMS)
        // exceeds the 0.05: the position and focal length still meet theirs, the
        // rotation is held to 3 bounds.
        let fit = fit_camera(
            &noisy,
            &SpatialOptions::unknown_intrinsics(k.width, k.height),
        )
        .unwrap();
        let (p, r, f) = camera_errors(&points, &pose, &k, &fit.pose, &fit.intrinsics);
        println!(
            "seed {seed}, free intrinsics: position {p:.3} mm/m, rotation {r:.4} deg, fx {f:.4} %"
        );
        assert!(p < 1.0 && f < 0.2, "seed {seed}: {p} mm/m {f} %");
        assert!(r < 3.0 * cr_r, "seed {seed}: {r} deg");
    }
}

#[test]
fn simulator_cube_gives_the_true_t0_within_a_tenth_of_a_bin() {
    let dir = simulated_capture(64, 48, 256, 8);
    let cap = dir.path().join("cap");
    let truth = Calibration::load(&cap.join("calibration.toml")).unwrap();
    let cube = read_cube(&cap.join("truth_camera.h5")).unwrap();
    let bvh = Bvh::new(load_mesh(&cap.join("scene.glb")).unwrap());
    let reg = register(&truth, &bvh, cube.nx, cube.ny).unwrap();
    let dt = cube.axis.dt_ps;
    let (fit, samples) = calibrate_time(
        &cube,
        &reg,
        &truth.laser_m,
        truth.eta,
        false,
        &ArrivalOptions::default(),
    )
    .unwrap();
    let err_bins = (fit.t0_ps - truth.t0_ps) / dt;
    println!(
        "t0 {:+.4} bins ({:+.3} ps) from {} pixels, {} inliers, residual rms {:.3} ps, sigma {:.3} ps",
        err_bins,
        fit.t0_ps - truth.t0_ps,
        samples.len(),
        fit.inlier_count(),
        fit.rms_ps,
        fit.sigma_ps
    );
    assert!(err_bins.abs() < 0.1, "t0 off by {err_bins} bins");
}

/// Direct path `|laser - q| + |q - o|` and irradiance weight `cos / r^2` at the floor point
/// (y = 0) seen through continuous pixel `(u, v)`, by ray-plane intersection.
fn floor_path(cal: &Calibration, u: f64, v: f64) -> Option<(f64, f64)> {
    let d = cal.world_ray(u, v).into_inner();
    let o = cal.pose.position_m;
    let s = -o.y / d.y;
    if s <= 0.0 {
        return None;
    }
    let q = o + d * s;
    if q.x.abs() > 20.0 || q.z.abs() > 20.0 {
        return None; // beyond the floor quad of the test
    }
    let to_laser = cal.laser_m - q;
    let r = to_laser.norm();
    Some(((q - o).norm() + r, (to_laser.y / r).max(0.0) / (r * r)))
}

#[test]
fn footprints_match_rays_through_the_whole_pixel() {
    let mut cal = temporal_camera(0.0, 1.0);
    cal.laser_m = Point3::new(-0.4, 0.3, 0.2);
    let mesh = quad([
        Point3::new(-20.0, 0.0, 20.0),
        Point3::new(20.0, 0.0, 20.0),
        Point3::new(20.0, 0.0, -20.0),
        Point3::new(-20.0, 0.0, -20.0),
    ]);
    let (nx, ny) = (48, 36);
    let reg = register(&cal, &Bvh::new(mesh), nx, ny).unwrap();
    let prints = footprints(&reg, &cal.laser_m);
    let (mut worst_range, mut worst_mean, mut checked) = (0.0f64, 0.0f64, 0);
    for y in 0..ny {
        for x in 0..nx {
            let got = prints.pixels[y * nx + x];
            // Brute force: 32 x 32 rays through the pixel, and its corners.
            let m = 32;
            let mut samples = Vec::new();
            for a in 0..=m {
                for b in 0..=m {
                    let (u, v) = (
                        x as f64 + a as f64 / m as f64,
                        y as f64 + b as f64 / m as f64,
                    );
                    samples.push((a, b, floor_path(&cal, u, v)));
                }
            }
            if samples.iter().any(|s| s.2.is_none()) {
                continue; // the pixel sees the horizon
            }
            let got = got.unwrap_or_else(|| panic!("pixel {x}, {y} sees the floor: no footprint"));
            let paths: Vec<(usize, usize, f64, f64)> = samples
                .iter()
                .map(|&(a, b, s)| (a, b, s.unwrap().0, s.unwrap().1))
                .collect();
            let lo = paths.iter().map(|p| p.2).fold(f64::INFINITY, f64::min);
            let hi = paths.iter().map(|p| p.2).fold(f64::NEG_INFINITY, f64::max);
            // Mean over the cell centres of the 32 x 32 grid: midpoints of the grid nodes.
            let (mut sw, mut swp) = (0.0, 0.0);
            for a in 0..m {
                for b in 0..m {
                    let (u, v) = (
                        x as f64 + (a as f64 + 0.5) / m as f64,
                        y as f64 + (b as f64 + 0.5) / m as f64,
                    );
                    let (p, w) = floor_path(&cal, u, v).unwrap();
                    sw += w;
                    swp += w * p;
                }
            }
            let mean = swp / sw;
            worst_range = worst_range
                .max((got.path_min_m - lo).abs() / (hi - lo))
                .max((got.path_max_m - hi).abs() / (hi - lo));
            worst_mean = worst_mean.max((got.path_mean_m - mean).abs() / (hi - lo));
            checked += 1;
        }
    }
    println!(
        "{checked} pixels: worst min/max path error {:.2e} of the spread, worst mean path error {worst_mean:.2e} of the spread",
        worst_range
    );
    assert!(checked > 500);
    // The rays through a pixel are interpolated linearly from the neighbours' rays, exact to
    // first order: the mean (what t0 rests on) within 1 % of the spread, the extremes (which
    // only place the window, widened by a bin) within 10 %, near the horizon included.
    assert!(worst_mean < 0.01 && worst_range < 0.1);
}

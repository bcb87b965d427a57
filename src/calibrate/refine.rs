//! Levenberg-Marquardt refinement of the camera on the reprojection error, and the spatial
//! calibration pipeline [`fit_camera`] (linear estimate from [`super::dlt`], then refinement,
//! then the report).
//!
//! Model: the projection of [`crate::camera`] (`p_cam = world_from_camera^T (p - o)`, radial
//! distortion `s = 1 + k1 r^2 + k2 r^4`, `u = fx s x + cx`, `v = fy s y + cy`). Residuals are
//! `(u - u_obs, v - v_obs)` for every correspondence, in pixels. Parameters: a rotation
//! increment (axis-angle, in the camera frame, folded into `world_from_camera` after every
//! step so that it never nears a singularity), the camera position `o` in metres, and, with
//! unknown intrinsics, `fx, fy, cx, cy` and optionally `k1, k2`. Distortion is fitted only
//! when asked and with at least [`MIN_POINTS_FOR_DISTORTION`] points; otherwise it stays at
//! zero (unknown intrinsics) or at the given values (known intrinsics, where nothing of the
//! intrinsics is refined).
//!
//! The Jacobian is numeric (central differences; the problems have at most 12 parameters and
//! a few hundred residuals), the damping is Marquardt's (`J^T J + lambda diag(J^T J)`) with
//! Nielsen's update of `lambda`.
//!
//! Outliers: a point is flagged when its reprojection error exceeds
//! `clamp(3 * median, 1 px, 3 px)` (median over the points used in the fit): three times the
//! typical error, but a sub-pixel error is never an outlier and an error above 3 px always is.
//! A least-squares fit spreads one mis-picked point's error over its neighbours, so with
//! `reject_outliers` (the default) the worst flagged point (with any other flagged point within a
//! factor two of it) is left out and the camera refitted, again while a used point is flagged
//! (keeping at least the minimum number of points plus two, and leaving out at most a third);
//! points left out that the final camera explains are taken back for one last fit. Errors are
//! reported for every point, the outliers listed. On pure Gaussian noise about 0.2 % of the
//! points exceed `3 * median` and are flagged.
//!
//! Accuracy: least squares on the reprojection error is the maximum-likelihood estimate for
//! Gaussian pixel noise, and the tests check that its errors match the Cramer-Rao bound. That
//! bound is what limits a single view: with 29 fiducials (cube corners and markers) at 0.5 px
//! and all four intrinsics free it is about 6 mm per metre in position, 0.4 degrees in rotation
//! (the principal point trades off against the rotation) and 0.6 % in focal length; the errors
//! fall as one over the square root of the number of points, and the constraints below remove
//! most of the rotation error.
//!
//! Constraints (unknown intrinsics): `square_pixels` ties `fx = fy`, and
//! `principal_point_at_centre` fixes `(cx, cy)` at the image centre. Both are common in
//! single-view calibration, where the principal point trades off against the rotation and is
//! poorly determined by a few dozen points.

use super::dlt::{self, raw_project, require_in_front};
use super::{CalibrateError, Correspondence};
use crate::camera::{Calibration, Intrinsics, Pose};
use crate::stats::median_of;
use nalgebra::{DMatrix, DVector, Point3, Rotation3, Vector3};

/// Fewest points with which `k1, k2` are fitted (otherwise they stay fixed).
pub const MIN_POINTS_FOR_DISTORTION: usize = 10;
/// Outlier threshold: `clamp(OUTLIER_MEDIAN_FACTOR * median, OUTLIER_MIN_PX, OUTLIER_MAX_PX)`.
pub const OUTLIER_MEDIAN_FACTOR: f64 = 3.0;
pub const OUTLIER_MIN_PX: f64 = 1.0;
pub const OUTLIER_MAX_PX: f64 = 3.0;

/// What is known of the intrinsics before the fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IntrinsicsPrior {
    /// Solve for `fx, fy, cx, cy` (and `k1, k2` if asked) of an image of this size.
    Unknown { width: usize, height: usize },
    /// Known intrinsics (distortion included): solve the pose only.
    Known(Intrinsics),
}

/// Options of [`fit_camera`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpatialOptions {
    pub intrinsics: IntrinsicsPrior,
    /// Fit `k1, k2` too (unknown intrinsics and at least [`MIN_POINTS_FOR_DISTORTION`] points).
    pub fit_distortion: bool,
    /// Unknown intrinsics: constrain `fx = fy` (square pixels).
    pub square_pixels: bool,
    /// Unknown intrinsics: fix the principal point at the image centre.
    pub principal_point_at_centre: bool,
    /// Refit without the worst outlier while there is one (module doc).
    pub reject_outliers: bool,
    /// Upper bound on Levenberg-Marquardt iterations per fit.
    pub max_iterations: usize,
}

impl SpatialOptions {
    /// Solve intrinsics (`fx, fy, cx, cy`, no distortion) and pose for an image of
    /// `width x height` pixels, rejecting outliers.
    pub fn unknown_intrinsics(width: usize, height: usize) -> SpatialOptions {
        SpatialOptions {
            intrinsics: IntrinsicsPrior::Unknown { width, height },
            fit_distortion: false,
            square_pixels: false,
            principal_point_at_centre: false,
            reject_outliers: true,
            max_iterations: 200,
        }
    }

    /// Solve the pose only, rejecting outliers.
    pub fn known_intrinsics(intrinsics: Intrinsics) -> SpatialOptions {
        SpatialOptions {
            intrinsics: IntrinsicsPrior::Known(intrinsics),
            ..SpatialOptions::unknown_intrinsics(intrinsics.width, intrinsics.height)
        }
    }
}

/// The result of a spatial calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct SpatialFit {
    pub intrinsics: Intrinsics,
    pub pose: Pose,
    /// Reprojection error of every correspondence under the final camera, pixels (input order,
    /// outliers included).
    pub per_point_px: Vec<f64>,
    /// Root mean square of `per_point_px` over the points used in the final fit.
    pub rms_px: f64,
    /// Median of `per_point_px` over the points used in the final fit.
    pub median_px: f64,
    /// Errors above this are outliers (module doc).
    pub outlier_threshold_px: f64,
    /// Indices (input order) of the points whose error exceeds the threshold. With
    /// `reject_outliers` they were left out of the final fit.
    pub outliers: Vec<usize>,
    /// Levenberg-Marquardt iterations taken, all fits together.
    pub iterations: usize,
    /// Whether `fx, fy, cx, cy` were fitted (false with known intrinsics).
    pub intrinsics_fitted: bool,
    /// Whether `k1, k2` were fitted.
    pub distortion_fitted: bool,
}

impl SpatialFit {
    /// A full calibration with this camera and the given time origin, laser spot and medium.
    pub fn calibration(
        &self,
        t0_ps: f64,
        time_scale: f64,
        laser_m: Point3<f64>,
        eta: f64,
    ) -> Calibration {
        Calibration {
            intrinsics: self.intrinsics,
            pose: self.pose,
            t0_ps,
            time_scale,
            laser_m,
            eta,
        }
    }
}

/// The points whose flag in `used` is set.
fn selected(points: &[Correspondence], used: &[bool]) -> Vec<Correspondence> {
    points
        .iter()
        .zip(used)
        .filter(|(_, &u)| u)
        .map(|(c, _)| c.clone())
        .collect()
}

/// Reprojection error of every point, pixels.
fn reprojection_errors(points: &[Correspondence], k: &Intrinsics, pose: &Pose) -> Vec<f64> {
    points
        .iter()
        .map(|c| {
            let (u, v) = raw_project(k, &pose.camera_from_world(&c.point_m));
            (u - c.pixel.0).hypot(v - c.pixel.1)
        })
        .collect()
}

/// `clamp(3 * median, 1 px, 3 px)` over the used points, and that median.
fn outlier_threshold(errors: &[f64], used: &[bool]) -> (f64, f64) {
    let e: Vec<f64> = errors
        .iter()
        .zip(used)
        .filter(|(_, &u)| u)
        .map(|(e, _)| *e)
        .collect();
    let m = median_of(&e);
    (
        (OUTLIER_MEDIAN_FACTOR * m).clamp(OUTLIER_MIN_PX, OUTLIER_MAX_PX),
        m,
    )
}

/// Spatial calibration from 2D-3D correspondences: checks, linear estimate (DLT or PnP),
/// Levenberg-Marquardt refinement (leaving out the worst outlier and refitting while one
/// remains, when asked), the check that every point is in front of the camera, and the
/// per-point report.
pub fn fit_camera(
    points: &[Correspondence],
    options: &SpatialOptions,
) -> Result<SpatialFit, CalibrateError> {
    let (mut init, known) = match options.intrinsics {
        IntrinsicsPrior::Unknown { width, height } => (dlt::dlt(points, width, height)?, false),
        IntrinsicsPrior::Known(k) => (dlt::pnp(points, &k)?, true),
    };
    let square = options.square_pixels && !known;
    let centred = options.principal_point_at_centre && !known;
    if square {
        let f = 0.5 * (init.intrinsics.fx + init.intrinsics.fy);
        init.intrinsics.fx = f;
        init.intrinsics.fy = f;
    }
    if centred {
        init.intrinsics.cx = 0.5 * init.intrinsics.width as f64;
        init.intrinsics.cy = 0.5 * init.intrinsics.height as f64;
    }
    let distortion = options.fit_distortion && !known && points.len() >= MIN_POINTS_FOR_DISTORTION;
    let active = active_parameters(known, square, centred, distortion);
    let need = if known {
        dlt::MIN_POINTS_KNOWN_INTRINSICS
    } else {
        dlt::MIN_POINTS_UNKNOWN_INTRINSICS
    };
    let mut cam = CameraParams {
        world_from_camera: init.pose.world_from_camera,
        centre: init.pose.position_m,
        k: init.intrinsics,
        square,
    };
    let n = points.len();
    let mut used = vec![true; n];
    let mut iterations = 0;
    let max_rejected = n / 3;
    loop {
        let (fitted, it) = levenberg_marquardt(
            &selected(points, &used),
            cam,
            &active,
            options.max_iterations,
        )?;
        cam = fitted;
        iterations += it;
        if !options.reject_outliers {
            break;
        }
        let errors = reprojection_errors(points, &cam.k, &cam.pose());
        let (threshold, _) = outlier_threshold(&errors, &used);
        let used_count = used.iter().filter(|&&u| u).count();
        let drop = worst_points(&errors, &used, threshold);
        let may_drop = !drop.is_empty()
            && used_count - drop.len() >= need + 2
            && n - used_count + drop.len() <= max_rejected;
        if may_drop {
            for i in drop {
                used[i] = false;
            }
        } else {
            // Points left out earlier that the final camera explains are taken back once.
            let back: Vec<usize> = (0..n)
                .filter(|&i| !used[i] && errors[i] <= threshold)
                .collect();
            if back.is_empty() {
                break;
            }
            for i in back {
                used[i] = true;
            }
            let (fitted, it) = levenberg_marquardt(
                &selected(points, &used),
                cam,
                &active,
                options.max_iterations,
            )?;
            cam = fitted;
            iterations += it;
            break;
        }
    }
    let k = cam.k;
    let sane = k.fx.is_finite() && k.fy.is_finite() && k.fx > 0.0 && k.fy > 0.0;
    if !sane || !cam.centre.coords.iter().all(|v| v.is_finite()) {
        return Err(CalibrateError::Degenerate(format!(
            "the refinement left an invalid camera (fx = {}, fy = {})",
            k.fx, k.fy
        )));
    }
    let pose = cam.pose();
    require_in_front(points, &pose)?;
    let per_point_px = reprojection_errors(points, &k, &pose);
    let (outlier_threshold_px, median_px) = outlier_threshold(&per_point_px, &used);
    let (sum_sq, count) = per_point_px
        .iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .fold((0.0, 0usize), |(s, c), (e, _)| (s + e * e, c + 1));
    let outliers = (0..n)
        .filter(|&i| per_point_px[i] > outlier_threshold_px)
        .collect();
    Ok(SpatialFit {
        intrinsics: k,
        pose,
        per_point_px,
        rms_px: (sum_sq / count as f64).sqrt(),
        median_px,
        outlier_threshold_px,
        outliers,
        iterations,
        intrinsics_fitted: !known,
        distortion_fitted: distortion,
    })
}

/// Indices of the [`CameraParams`] a fit refines: the pose always; with unknown intrinsics
/// `fx`, `fy` unless `square` (then `fx` alone), `cx, cy` unless `centred`; `k1, k2` with
/// `distortion`.
fn active_parameters(known: bool, square: bool, centred: bool, distortion: bool) -> Vec<usize> {
    let mut active: Vec<usize> = (0..6).collect();
    if !known {
        active.push(6);
        if !square {
            active.push(7);
        }
        if !centred {
            active.extend(8..10);
        }
    }
    if distortion {
        active.extend(10..12);
    }
    active
}

/// The points [`fit_camera`] leaves out next: the used point with the worst reprojection
/// error above `threshold`, with any other flagged point within a factor two of it (one
/// refit for a group of gross errors; their smeared neighbours stay). Empty when no used
/// point is above `threshold`.
fn worst_points(errors: &[f64], used: &[bool], threshold: f64) -> Vec<usize> {
    let n = errors.len();
    let worst = (0..n)
        .filter(|&i| used[i] && errors[i] > threshold)
        .map(|i| errors[i])
        .fold(None, |m: Option<f64>, e| Some(m.map_or(e, |m| m.max(e))));
    // The worst point, with any other flagged point within a factor two of it (one refit
    // for a group of gross errors; their smeared neighbours stay).
    worst.map_or(Vec::new(), |worst| {
        (0..n)
            .filter(|&i| used[i] && errors[i] > threshold && errors[i] >= 0.5 * worst)
            .collect()
    })
}

/// The state being refined. Parameter indices: 0..3 rotation increment (camera frame, rad),
/// 3..6 centre (m), 6 fx, 7 fy, 8 cx, 9 cy, 10 k1, 11 k2.
#[derive(Clone, Copy, Debug)]
struct CameraParams {
    world_from_camera: Rotation3<f64>,
    centre: Point3<f64>,
    k: Intrinsics,
    /// `fx = fy`: parameter 6 moves both, parameter 7 is unused.
    square: bool,
}

impl CameraParams {
    fn pose(&self) -> Pose {
        Pose {
            world_from_camera: self.world_from_camera,
            position_m: self.centre,
        }
    }

    /// The state moved by `delta[j]` along parameter `active[j]`.
    fn step(&self, active: &[usize], delta: &[f64]) -> CameraParams {
        let mut full = [0.0; 12];
        for (&j, &d) in active.iter().zip(delta) {
            full[j] = d;
        }
        let mut out = *self;
        let omega = Vector3::new(full[0], full[1], full[2]);
        out.world_from_camera = self.world_from_camera * Rotation3::new(omega);
        out.centre += Vector3::new(full[3], full[4], full[5]);
        out.k.fx += full[6];
        out.k.fy += if self.square { full[6] } else { full[7] };
        out.k.cx += full[8];
        out.k.cy += full[9];
        out.k.k1 += full[10];
        out.k.k2 += full[11];
        out
    }

    /// Reprojection residuals `(u - u_obs, v - v_obs)`, stacked.
    fn residuals(&self, points: &[Correspondence], out: &mut DVector<f64>) {
        for (i, c) in points.iter().enumerate() {
            let p_cam = self
                .world_from_camera
                .inverse_transform_vector(&(c.point_m - self.centre));
            let (u, v) = raw_project(&self.k, &p_cam);
            out[2 * i] = u - c.pixel.0;
            out[2 * i + 1] = v - c.pixel.1;
        }
    }

    /// Central-difference step of each parameter.
    fn steps(&self, points_scale_m: f64) -> [f64; 12] {
        let h_rot = 1e-7;
        let h_pos = 1e-7 * points_scale_m;
        let h_f = 1e-7 * self.k.fx.abs().max(1.0);
        [
            h_rot, h_rot, h_rot, h_pos, h_pos, h_pos, h_f, h_f, h_f, h_f, 1e-7, 1e-7,
        ]
    }
}

/// Minimise the squared reprojection error over the `active` parameters. Returns the state and
/// the number of iterations.
fn levenberg_marquardt(
    points: &[Correspondence],
    start: CameraParams,
    active: &[usize],
    max_iterations: usize,
) -> Result<(CameraParams, usize), CalibrateError> {
    let m = 2 * points.len();
    let np = active.len();
    let scale_m = points
        .iter()
        .map(|c| (c.point_m - start.centre).norm())
        .fold(0.0, f64::max)
        .max(1e-3);
    let mut cam = start;
    let mut r = DVector::zeros(m);
    cam.residuals(points, &mut r);
    let mut cost = r.norm_squared();
    if !cost.is_finite() {
        return Err(CalibrateError::Degenerate(
            "the initial camera does not project the points".into(),
        ));
    }
    let mut lambda = -1.0;
    let mut nu = 2.0;
    let mut r_plus = DVector::zeros(m);
    let mut r_minus = DVector::zeros(m);
    let mut r_new = DVector::zeros(m);
    let mut jac = DMatrix::zeros(m, np);
    let mut iterations = 0;
    while iterations < max_iterations {
        iterations += 1;
        let steps = cam.steps(scale_m);
        for (col, &j) in active.iter().enumerate() {
            let h = steps[j];
            let mut d = vec![0.0; np];
            d[col] = h;
            cam.step(active, &d).residuals(points, &mut r_plus);
            d[col] = -h;
            cam.step(active, &d).residuals(points, &mut r_minus);
            jac.set_column(col, &((&r_plus - &r_minus) / (2.0 * h)));
        }
        let a = jac.transpose() * &jac;
        let g = jac.transpose() * &r;
        if g.amax() <= 1e-15 * (1.0 + cost) {
            break;
        }
        let diag: Vec<f64> = {
            let max_d = (0..np).map(|i| a[(i, i)]).fold(0.0, f64::max);
            (0..np).map(|i| a[(i, i)].max(1e-12 * max_d)).collect()
        };
        if lambda < 0.0 {
            lambda = 1e-3;
        }
        let mut accepted = false;
        while lambda < 1e16 {
            let mut damped = a.clone();
            for (i, d) in diag.iter().enumerate() {
                damped[(i, i)] += lambda * d;
            }
            let Some(chol) = damped.cholesky() else {
                lambda *= nu;
                nu *= 2.0;
                continue;
            };
            let delta = chol.solve(&(-&g));
            let trial = cam.step(active, delta.as_slice());
            trial.residuals(points, &mut r_new);
            let new_cost = r_new.norm_squared();
            // Gain ratio: actual over predicted decrease.
            let predicted = -(delta.dot(&g) * 2.0 + delta.dot(&(&a * &delta)));
            if new_cost.is_finite() && new_cost < cost {
                let rho = (cost - new_cost) / predicted.max(f64::MIN_POSITIVE);
                lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                nu = 2.0;
                let small_step = delta
                    .iter()
                    .zip(active)
                    .all(|(d, &j)| d.abs() <= 1e-6 * steps[j]);
                let small_gain = cost - new_cost <= 1e-14 * cost;
                cam = trial;
                std::mem::swap(&mut r, &mut r_new);
                cost = new_cost;
                accepted = true;
                if small_step || small_gain {
                    return Ok((cam, iterations));
                }
                break;
            }
            lambda *= nu;
            nu *= 2.0;
        }
        if !accepted {
            break; // no decrease possible: at a minimum to machine precision
        }
    }
    Ok((cam, iterations))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_active_parameters_follow_the_constraints() {
        let pose: Vec<usize> = (0..6).collect();
        assert_eq!(
            active_parameters(true, true, true, true),
            [pose.clone(), vec![10, 11]].concat()
        );
        assert_eq!(active_parameters(true, false, false, false), pose);
        assert_eq!(
            active_parameters(false, false, false, false),
            [pose.clone(), vec![6, 7, 8, 9]].concat()
        );
        assert_eq!(
            active_parameters(false, true, true, false),
            [pose.clone(), vec![6]].concat()
        );
        assert_eq!(
            active_parameters(false, true, false, true),
            [pose, vec![6, 8, 9, 10, 11]].concat()
        );
    }

    #[test]
    fn the_worst_points_are_those_within_a_factor_two_of_the_worst() {
        let errors = [0.1, 9.0, 5.0, 4.0, 20.0, 0.2];
        // Point 4 is the worst but already left out: 9.0 is the worst used.
        let used = [true, true, true, true, false, true];
        assert_eq!(worst_points(&errors, &used, 1.0), [1, 2]);
        assert_eq!(worst_points(&errors, &used, 9.0), Vec::<usize>::new());
        assert_eq!(worst_points(&errors, &[true; 6], 1.0), [4]);
    }
}

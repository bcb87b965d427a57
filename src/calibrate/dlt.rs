//! Linear first estimates of the camera from 2D-3D correspondences, and the checks that refuse
//! inputs from which no camera can be recovered.
//!
//! - Unknown intrinsics ([`dlt`], >= 6 non-coplanar points): the Hartley-normalised Direct
//!   Linear Transform (Hartley & Zisserman, Alg. 7.1). Pixels are translated to their centroid
//!   and scaled to a mean distance of sqrt(2), 3-D points to their centroid and a mean distance
//!   of sqrt(3); the 3x4 projection `P` is the right singular vector of the smallest singular
//!   value of the stacked `2n x 12` system, de-normalised. `P = K [R | -R C]` is then split by
//!   an RQ decomposition of its left 3x3 block into an upper-triangular `K` with a positive
//!   diagonal and a rotation `R` (det +1); the sign of `P` is chosen so that `det(KR) > 0`,
//!   which makes the third row of `P X` the (positive-scaled) depth of `X`. The skew of `K` is
//!   dropped: the camera model ([`crate::camera::Intrinsics`]) has none, and the refinement
//!   ([`super::refine`]) absorbs the difference.
//! - Known intrinsics ([`pnp`], >= 4 points, coplanar or not): the orthogonal-iteration
//!   algorithm of Lu, Hager & Mjolsness (2000), which minimises the object-space collinearity
//!   error `sum |(I - V_i)(R p_i + t)|^2` (`V_i` projects onto the line of sight of pixel `i`)
//!   by alternating a closed-form translation with an SVD absolute-orientation step. It is
//!   globally convergent in most configurations and handles planar targets without a special
//!   case. Because the line of sight extends behind the camera, it can converge to a mirrored
//!   solution, and planar targets have a two-fold pose ambiguity; so it is started from the 24
//!   axis-aligned rotations (the rotation group of the cube, at most 60 degrees from any
//!   rotation up to symmetry), the solutions that put every point in front of the camera are
//!   kept, and the one with the smallest reprojection error wins. Distortion is removed from
//!   the pixels first with the known `k1, k2`.
//!
//! The checks ([`check_correspondences`]): the point count, repeated 3-D points, two different
//! points at one pixel, collinear points, and (unknown intrinsics only) coplanar points: the
//! smallest singular value of the centred 3-D points over the largest below
//! [`COPLANAR_RATIO`].

use super::{label, CalibrateError, Correspondence};
use crate::camera::{Intrinsics, Pose};
use nalgebra::{DMatrix, Matrix3, Matrix3x4, Matrix4, Point3, Rotation3, Vector3, Vector4};

/// Minimum number of correspondences with unknown intrinsics (11 unknowns of the DLT).
pub const MIN_POINTS_UNKNOWN_INTRINSICS: usize = 6;
/// Minimum number of correspondences for a pose with known intrinsics.
pub const MIN_POINTS_KNOWN_INTRINSICS: usize = 4;
/// Below this ratio (thickness / extent of the 3-D points) the points count as coplanar.
pub const COPLANAR_RATIO: f64 = 1e-2;
/// Below this ratio (width / extent) the points count as collinear.
pub const COLLINEAR_RATIO: f64 = 1e-3;
/// Two 3-D points closer than this fraction of the extent are the same point.
const SAME_POINT_RELATIVE: f64 = 1e-6;
/// Two pixels closer than this (pixels) are the same pixel.
const SAME_PIXEL_PX: f64 = 1e-6;

/// A camera estimate: intrinsics (skew dropped) and pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpatialInit {
    pub intrinsics: Intrinsics,
    pub pose: Pose,
}

/// Shape of the cloud of 3-D points, from the singular values of the centred points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extent {
    /// Centroid of the points, metres.
    pub centroid_m: Point3<f64>,
    /// Singular values of the centred `n x 3` point matrix, descending, divided by sqrt(n)
    /// (RMS spread along the principal axes, metres).
    pub spread_m: [f64; 3],
}

impl Extent {
    pub fn of(points: &[Correspondence]) -> Extent {
        let n = points.len().max(1) as f64;
        let centroid = points
            .iter()
            .fold(Vector3::zeros(), |a, p| a + p.point_m.coords)
            / n;
        let mut cov = Matrix3::zeros();
        for p in points {
            let d = p.point_m.coords - centroid;
            cov += d * d.transpose();
        }
        // Eigenvalues of the scatter matrix are the squared singular values of the centred points.
        let mut ev: Vec<f64> = cov
            .symmetric_eigenvalues()
            .iter()
            .map(|v| (v.max(0.0) / n).sqrt())
            .collect();
        ev.sort_by(|a, b| b.total_cmp(a));
        Extent {
            centroid_m: Point3::from(centroid),
            spread_m: [ev[0], ev[1], ev[2]],
        }
    }

    /// Thickness over extent: 0 for coplanar points.
    pub fn flatness(&self) -> f64 {
        self.spread_m[2] / self.spread_m[0].max(f64::MIN_POSITIVE)
    }

    /// Width over extent: 0 for collinear points.
    pub fn slenderness(&self) -> f64 {
        self.spread_m[1] / self.spread_m[0].max(f64::MIN_POSITIVE)
    }
}

/// Refuse inputs from which the camera cannot be recovered (module doc). Returns the shape of
/// the point cloud.
pub fn check_correspondences(
    points: &[Correspondence],
    known_intrinsics: bool,
) -> Result<Extent, CalibrateError> {
    let need = if known_intrinsics {
        MIN_POINTS_KNOWN_INTRINSICS
    } else {
        MIN_POINTS_UNKNOWN_INTRINSICS
    };
    for (i, p) in points.iter().enumerate() {
        let all_finite = p.pixel.0.is_finite()
            && p.pixel.1.is_finite()
            && p.point_m.coords.iter().all(|v| v.is_finite());
        if !all_finite {
            return Err(CalibrateError::NonFinite {
                point: label(points, i),
            });
        }
    }
    if points.len() < need {
        return Err(CalibrateError::TooFewPoints {
            got: points.len(),
            need,
            known_intrinsics,
        });
    }
    let extent = Extent::of(points);
    check_repeats(points, extent.spread_m[0])?;
    if extent.slenderness() < COLLINEAR_RATIO {
        return Err(CalibrateError::Collinear {
            ratio: extent.slenderness(),
        });
    }
    if !known_intrinsics && extent.flatness() < COPLANAR_RATIO {
        return Err(CalibrateError::Coplanar {
            ratio: extent.flatness(),
        });
    }
    Ok(extent)
}

/// Repeated 3-D points, and different 3-D points at one pixel (sort-and-sweep, O(n log n)).
fn check_repeats(points: &[Correspondence], extent_m: f64) -> Result<(), CalibrateError> {
    let same_m = SAME_POINT_RELATIVE * extent_m.max(1e-3);
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| points[a].point_m.x.total_cmp(&points[b].point_m.x));
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            if points[j].point_m.x - points[i].point_m.x > same_m {
                break;
            }
            if (points[j].point_m - points[i].point_m).norm() <= same_m {
                let (a, b) = (i.min(j), i.max(j));
                return Err(CalibrateError::RepeatedPoint {
                    first: label(points, a),
                    second: label(points, b),
                });
            }
        }
    }
    order.sort_by(|&a, &b| points[a].pixel.0.total_cmp(&points[b].pixel.0));
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            if points[j].pixel.0 - points[i].pixel.0 > SAME_PIXEL_PX {
                break;
            }
            let d = (points[j].pixel.0 - points[i].pixel.0)
                .hypot(points[j].pixel.1 - points[i].pixel.1);
            if d <= SAME_PIXEL_PX {
                let (a, b) = (i.min(j), i.max(j));
                return Err(CalibrateError::RepeatedPixel {
                    first: label(points, a),
                    second: label(points, b),
                });
            }
        }
    }
    Ok(())
}

/// Similarity that moves `pts` to their centroid and scales them to mean distance
/// `sqrt(dim)`: returns (scale, centroid).
fn normalisation<const D: usize>(pts: &[[f64; D]]) -> (f64, [f64; D]) {
    let n = pts.len() as f64;
    let mut c = [0.0; D];
    for p in pts {
        for k in 0..D {
            c[k] += p[k] / n;
        }
    }
    let mean_dist = pts
        .iter()
        .map(|p| (0..D).map(|k| (p[k] - c[k]).powi(2)).sum::<f64>().sqrt())
        .sum::<f64>()
        / n;
    ((D as f64).sqrt() / mean_dist.max(f64::MIN_POSITIVE), c)
}

/// Hartley-normalised DLT: the 3x4 projection matrix mapping homogeneous world points to
/// homogeneous pixels, with the sign chosen so that `det(P[:, :3]) > 0`.
pub fn projection_matrix(points: &[Correspondence]) -> Result<Matrix3x4<f64>, CalibrateError> {
    let n = points.len();
    if n < MIN_POINTS_UNKNOWN_INTRINSICS {
        return Err(CalibrateError::TooFewPoints {
            got: n,
            need: MIN_POINTS_UNKNOWN_INTRINSICS,
            known_intrinsics: false,
        });
    }
    let px: Vec<[f64; 2]> = points.iter().map(|p| [p.pixel.0, p.pixel.1]).collect();
    let wp: Vec<[f64; 3]> = points.iter().map(|p| p.point_m.coords.into()).collect();
    let (s2, c2) = normalisation(&px);
    let (s3, c3) = normalisation(&wp);
    let t2 = Matrix3::new(s2, 0.0, -s2 * c2[0], 0.0, s2, -s2 * c2[1], 0.0, 0.0, 1.0);
    let t3 = Matrix4::new(
        s3,
        0.0,
        0.0,
        -s3 * c3[0],
        0.0,
        s3,
        0.0,
        -s3 * c3[1],
        0.0,
        0.0,
        s3,
        -s3 * c3[2],
        0.0,
        0.0,
        0.0,
        1.0,
    );
    let mut a = DMatrix::<f64>::zeros(2 * n, 12);
    for i in 0..n {
        let x = Vector4::new(
            s3 * (wp[i][0] - c3[0]),
            s3 * (wp[i][1] - c3[1]),
            s3 * (wp[i][2] - c3[2]),
            1.0,
        );
        let u = s2 * (px[i][0] - c2[0]);
        let v = s2 * (px[i][1] - c2[1]);
        for k in 0..4 {
            a[(2 * i, k)] = x[k];
            a[(2 * i, 8 + k)] = -u * x[k];
            a[(2 * i + 1, 4 + k)] = x[k];
            a[(2 * i + 1, 8 + k)] = -v * x[k];
        }
    }
    let svd = a.svd(false, true);
    let v_t = svd
        .v_t
        .ok_or_else(|| CalibrateError::Degenerate("the DLT system has no SVD".into()))?;
    // Singular values are sorted descending: the last row of V^T spans the null space.
    let p = v_t.row(v_t.nrows() - 1);
    let pn = Matrix3x4::from_fn(|r, c| p[4 * r + c]);
    let t2_inv = t2
        .try_inverse()
        .ok_or_else(|| CalibrateError::Degenerate("pixel normalisation is singular".into()))?;
    let mut proj = t2_inv * pn * t3;
    let det = proj.fixed_view::<3, 3>(0, 0).determinant();
    if !det.is_finite() || det == 0.0 {
        return Err(CalibrateError::Degenerate(
            "the DLT projection matrix is singular".into(),
        ));
    }
    if det < 0.0 {
        proj = -proj;
    }
    Ok(proj)
}

/// RQ decomposition of a 3x3 matrix `m = k * r`, `k` upper triangular with a positive diagonal,
/// `r` orthogonal (a rotation when `det(m) > 0`).
pub fn rq_decomposition(m: &Matrix3<f64>) -> (Matrix3<f64>, Matrix3<f64>) {
    // Reverse the rows: with J the exchange matrix, (J m)^T = Q R  =>  m = (J R^T J)(J Q^T).
    let j = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0);
    let qr = (j * m).transpose().qr();
    let (q, r) = (qr.q(), qr.r());
    let mut k = j * r.transpose() * j;
    let mut rot = j * q.transpose();
    for i in 0..3 {
        if k[(i, i)] < 0.0 {
            // k * D * D * rot with D = diag(..., -1, ...): flips column i of k and row i of rot.
            k.column_mut(i).neg_mut();
            rot.row_mut(i).neg_mut();
        }
    }
    (k, rot)
}

/// Split a projection matrix with `det(P[:, :3]) > 0` into intrinsics and pose.
pub fn decompose_projection(
    proj: &Matrix3x4<f64>,
    width: usize,
    height: usize,
) -> Result<SpatialInit, CalibrateError> {
    let m: Matrix3<f64> = proj.fixed_view::<3, 3>(0, 0).into_owned();
    let (k, camera_from_world) = rq_decomposition(&m);
    let m_inv = m.try_inverse().ok_or_else(|| {
        CalibrateError::Degenerate("the DLT projection matrix is singular".into())
    })?;
    let centre = -(m_inv * proj.column(3));
    let k = k / k[(2, 2)];
    let intrinsics = Intrinsics {
        width,
        height,
        fx: k[(0, 0)],
        fy: k[(1, 1)],
        cx: k[(0, 2)],
        cy: k[(1, 2)],
        k1: 0.0,
        k2: 0.0,
    };
    let all_finite = [intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy]
        .iter()
        .chain(centre.iter())
        .all(|v| v.is_finite());
    if !all_finite || camera_from_world.determinant() <= 0.0 {
        return Err(CalibrateError::Degenerate(
            "the DLT projection matrix does not decompose into a camera".into(),
        ));
    }
    Ok(SpatialInit {
        intrinsics,
        pose: Pose {
            world_from_camera: Rotation3::from_matrix(&camera_from_world.transpose()),
            position_m: Point3::from(centre),
        },
    })
}

/// Indices of the points that lie behind (or in the plane of) the camera.
pub fn points_behind(points: &[Correspondence], pose: &Pose) -> Vec<usize> {
    (0..points.len())
        .filter(|&i| pose.camera_from_world(&points[i].point_m).z <= 0.0)
        .collect()
}

/// The error for points behind the camera, or Ok when there are none.
pub(crate) fn require_in_front(
    points: &[Correspondence],
    pose: &Pose,
) -> Result<(), CalibrateError> {
    let behind = points_behind(points, pose);
    match behind.first() {
        None => Ok(()),
        Some(&i) => Err(CalibrateError::BehindCamera {
            behind: behind.len(),
            total: points.len(),
            first: label(points, i),
        }),
    }
}

/// Intrinsics and pose from >= 6 non-coplanar points by the normalised DLT (module doc).
/// `width` and `height` are the image size in pixels. Runs [`check_correspondences`] first.
pub fn dlt(
    points: &[Correspondence],
    width: usize,
    height: usize,
) -> Result<SpatialInit, CalibrateError> {
    check_correspondences(points, false)?;
    let proj = projection_matrix(points)?;
    let init = decompose_projection(&proj, width, height)?;
    require_in_front(points, &init.pose)?;
    Ok(init)
}

/// Pose from >= 4 points with known intrinsics, by multi-start orthogonal iteration (module
/// doc). Runs [`check_correspondences`] first.
pub fn pnp(
    points: &[Correspondence],
    intrinsics: &Intrinsics,
) -> Result<SpatialInit, CalibrateError> {
    let extent = check_correspondences(points, true)?;
    let origin = extent.centroid_m.coords;
    // World points relative to their centroid (conditioning), lines of sight from the pixels.
    let p: Vec<Vector3<f64>> = points.iter().map(|c| c.point_m.coords - origin).collect();
    let v: Vec<Matrix3<f64>> = points
        .iter()
        .map(|c| {
            let d = intrinsics.camera_ray(c.pixel.0, c.pixel.1).into_inner();
            d * d.transpose()
        })
        .collect();
    let n = p.len() as f64;
    let v_mean = v.iter().fold(Matrix3::zeros(), |a, m| a + m) / n;
    let t_factor = (Matrix3::identity() - v_mean)
        .try_inverse()
        .ok_or_else(|| CalibrateError::Degenerate("all lines of sight are parallel".into()))?
        / n;
    let solver = OrthogonalIteration {
        p: &p,
        v: &v,
        t_factor,
    };
    // Reprojection error with the raw pinhole formula (x/z also for z < 0), so that a data set
    // that only fits with the points behind the camera can be recognised as such.
    let sq_err = |rot: &Rotation3<f64>, t: &Vector3<f64>| -> f64 {
        points
            .iter()
            .zip(&p)
            .map(|(c, pi)| {
                let (u, w) = raw_project(intrinsics, &(rot * pi + t));
                (u - c.pixel.0).powi(2) + (w - c.pixel.1).powi(2)
            })
            .sum::<f64>()
    };
    let mut best_front: Option<(f64, Rotation3<f64>, Vector3<f64>)> = None;
    let mut best_any: Option<(f64, Option<usize>, usize)> = None; // (error, first behind, count)
    for start in cube_rotations() {
        let Some((rot, t)) = solver.solve(start) else {
            continue;
        };
        let err = sq_err(&rot, &t);
        if !err.is_finite() {
            continue;
        }
        let behind: Vec<usize> = (0..p.len())
            .filter(|&i| (rot * p[i] + t).z <= 0.0)
            .collect();
        if best_any.is_none_or(|b| err < b.0) {
            best_any = Some((err, behind.first().copied(), behind.len()));
        }
        if behind.is_empty() && best_front.as_ref().is_none_or(|b| err < b.0) {
            best_front = Some((err, rot, t));
        }
    }
    let rms = |sq: f64| (sq / n).sqrt();
    if let Some((err_any, Some(first), behind)) = best_any {
        // Refuse when the data fit a camera with points behind it clearly better than any
        // camera that sees them all (for planar targets both fit equally: keep the front one).
        let front_rms = best_front.as_ref().map_or(f64::INFINITY, |b| rms(b.0));
        if front_rms > 2.0 * rms(err_any) + 0.5 {
            return Err(CalibrateError::BehindCamera {
                behind,
                total: points.len(),
                first: label(points, first),
            });
        }
    }
    let Some((_, camera_from_world, t)) = best_front else {
        return Err(CalibrateError::Degenerate(
            "orthogonal iteration did not converge".into(),
        ));
    };
    let world_from_camera = camera_from_world.inverse();
    let centre = Point3::from(origin - (world_from_camera * t));
    Ok(SpatialInit {
        intrinsics: *intrinsics,
        pose: Pose {
            world_from_camera,
            position_m: centre,
        },
    })
}

/// Pixel of a camera-frame point by the pinhole formula, also for `z <= 0`.
pub(crate) fn raw_project(k: &Intrinsics, p_cam: &Vector3<f64>) -> (f64, f64) {
    let (x, y) = (p_cam.x / p_cam.z, p_cam.y / p_cam.z);
    let r2 = x * x + y * y;
    let s = 1.0 + k.k1 * r2 + k.k2 * r2 * r2;
    (k.fx * s * x + k.cx, k.fy * s * y + k.cy)
}

/// The 24 rotations that map the coordinate axes onto signed coordinate axes.
fn cube_rotations() -> Vec<Rotation3<f64>> {
    let perms = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut out = Vec::with_capacity(24);
    for perm in perms {
        for signs in 0..8 {
            let mut m = Matrix3::zeros();
            for (row, &col) in perm.iter().enumerate() {
                m[(row, col)] = if signs & (1 << row) != 0 { -1.0 } else { 1.0 };
            }
            if m.determinant() > 0.0 {
                out.push(Rotation3::from_matrix_unchecked(m));
            }
        }
    }
    out
}

/// Lu-Hager-Mjolsness orthogonal iteration on centred world points `p` and line-of-sight
/// projectors `v` (module doc).
struct OrthogonalIteration<'a> {
    p: &'a [Vector3<f64>],
    v: &'a [Matrix3<f64>],
    /// `(I - mean(V))^-1 / n`.
    t_factor: Matrix3<f64>,
}

impl OrthogonalIteration<'_> {
    /// Optimal translation for a rotation.
    fn translation(&self, rot: &Rotation3<f64>) -> Vector3<f64> {
        let sum = self
            .p
            .iter()
            .zip(self.v)
            .fold(Vector3::zeros(), |a, (pi, vi)| {
                let rp = rot * pi;
                a + vi * rp - rp
            });
        self.t_factor * sum
    }

    /// Object-space error.
    fn error(&self, rot: &Rotation3<f64>, t: &Vector3<f64>) -> f64 {
        self.p
            .iter()
            .zip(self.v)
            .map(|(pi, vi)| {
                let q = rot * pi + t;
                (q - vi * q).norm_squared()
            })
            .sum()
    }

    /// Iterate from `rot` to convergence: (camera_from_world, translation).
    fn solve(&self, mut rot: Rotation3<f64>) -> Option<(Rotation3<f64>, Vector3<f64>)> {
        let mut t = self.translation(&rot);
        let mut err = self.error(&rot, &t);
        for _ in 0..500 {
            // Project the current points onto their lines of sight, then fit R by SVD
            // (absolute orientation; the p are centred).
            let q: Vec<Vector3<f64>> = self
                .p
                .iter()
                .zip(self.v)
                .map(|(pi, vi)| vi * (rot * pi + t))
                .collect();
            let q_mean = q.iter().fold(Vector3::zeros(), |a, x| a + x) / q.len() as f64;
            let mut m = Matrix3::zeros();
            for (qi, pi) in q.iter().zip(self.p) {
                m += (qi - q_mean) * pi.transpose();
            }
            let svd = m.svd(true, true);
            let (u, v_t) = (svd.u?, svd.v_t?);
            let d = (u * v_t).determinant().signum();
            let r = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
            rot = Rotation3::from_matrix_unchecked(r);
            t = self.translation(&rot);
            let new_err = self.error(&rot, &t);
            if !new_err.is_finite() {
                return None;
            }
            let done = (err - new_err).abs() <= 1e-14 * err.max(1e-300);
            err = new_err;
            if done {
                break;
            }
        }
        Some((rot, t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rq_recovers_upper_triangular_times_rotation() {
        let k = Matrix3::new(800.0, 3.0, 320.0, 0.0, 780.0, 250.0, 0.0, 0.0, 1.0);
        let r = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
        let (k2, r2) = rq_decomposition(&(k * r.matrix() * 2.5));
        let k2 = k2 / k2[(2, 2)];
        assert!((k2 - k).abs().max() < 1e-9, "{k2}");
        assert!((r2 - r.matrix()).abs().max() < 1e-12);
    }

    #[test]
    fn there_are_24_distinct_cube_rotations() {
        let r = cube_rotations();
        assert_eq!(r.len(), 24);
        for i in 0..24 {
            for j in 0..i {
                assert!(r[i].angle_to(&r[j]) > 1.0);
            }
        }
    }
}

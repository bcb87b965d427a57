//! Pinhole camera with radial distortion, and the calibration file that pins a capture to
//! its geometry (the seed's Sec. 3: the cube is projected onto the scene through the capture
//! camera, and camera time is tied to the laser pulse by a time offset).
//!
//! Frames: the camera frame is x right, y down, z forward (optical axis). `world_from_camera`
//! maps camera-frame vectors into the mesh's (world) frame; `position_m` is the centre of
//! projection in world metres. Pixel coordinates are continuous: pixel `(i, j)` covers
//! `[i, i+1) x [j, j+1)` and its centre is `(i + 0.5, j + 0.5)`.
//!
//! Projection: `p_cam = world_from_camera^T (p - o)`, `(x, y) = (X/Z, Y/Z)`,
//! `r2 = x^2 + y^2`, `s = 1 + k1 r2 + k2 r2^2`, `u = fx s x + cx`, `v = fy s y + cy`.

use crate::ranges;
use nalgebra::{Matrix3, Point3, Rotation3, Unit, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Errors of the camera model and its calibration file.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    /// The calibration file could not be read.
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// The calibration file is not valid TOML of the documented shape (names key and line).
    #[error("{path}: {message}")]
    Parse { path: String, message: String },
    /// A value is out of range (non-positive focal length, non-orthonormal rotation, ...).
    #[error("{path}: {message}")]
    Invalid { path: String, message: String },
}

/// Pinhole intrinsics in pixels, with two radial distortion coefficients.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Intrinsics {
    pub width: usize,
    pub height: usize,
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    #[serde(default)]
    pub k1: f64,
    #[serde(default)]
    pub k2: f64,
}

impl Intrinsics {
    /// Square pixels, principal point at the image centre, vertical field of view in degrees.
    pub fn from_vfov(width: usize, height: usize, vfov_deg: f64) -> Intrinsics {
        let f = 0.5 * height as f64 / (0.5 * vfov_deg.to_radians()).tan();
        Intrinsics {
            width,
            height,
            fx: f,
            fy: f,
            cx: 0.5 * width as f64,
            cy: 0.5 * height as f64,
            k1: 0.0,
            k2: 0.0,
        }
    }

    /// The 3x3 matrix K (distortion not included).
    pub fn k_matrix(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }

    /// Radial distortion scale at squared normalised radius `r2`.
    #[inline]
    fn distortion(&self, r2: f64) -> f64 {
        1.0 + self.k1 * r2 + self.k2 * r2 * r2
    }

    /// Pixel coordinates of a camera-frame point (None when it is not in front, z <= 0).
    pub fn project_camera_point(&self, p_cam: &Vector3<f64>) -> Option<(f64, f64)> {
        if p_cam.z <= 0.0 {
            return None;
        }
        let (x, y) = (p_cam.x / p_cam.z, p_cam.y / p_cam.z);
        let s = self.distortion(x * x + y * y);
        Some((self.fx * s * x + self.cx, self.fy * s * y + self.cy))
    }

    /// Unit camera-frame direction through continuous pixel coordinates `(u, v)`
    /// (distortion removed by fixed-point iteration).
    pub fn camera_ray(&self, u: f64, v: f64) -> Unit<Vector3<f64>> {
        let (xd, yd) = ((u - self.cx) / self.fx, (v - self.cy) / self.fy);
        let (mut x, mut y) = (xd, yd);
        if self.k1 != 0.0 || self.k2 != 0.0 {
            for _ in 0..20 {
                let s = self.distortion(x * x + y * y);
                x = xd / s;
                y = yd / s;
            }
        }
        Unit::new_normalize(Vector3::new(x, y, 1.0))
    }
}

/// Where the camera is and which way it looks, in the mesh's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub world_from_camera: Rotation3<f64>,
    pub position_m: Point3<f64>,
}

impl Pose {
    /// A camera at `position_m` looking at `target_m`, with `up` pointing up in the image.
    /// Returns None when the view direction is zero or parallel to `up`.
    pub fn look_at(
        position_m: Point3<f64>,
        target_m: Point3<f64>,
        up: Vector3<f64>,
    ) -> Option<Pose> {
        let z = (target_m - position_m).try_normalize(1e-12)?;
        // Image y points down (away from `up`); x = y x z = z x up completes a right-handed frame.
        let x = z.cross(&up).try_normalize(1e-9)?;
        let y = z.cross(&x);
        let m = Matrix3::from_columns(&[x, y, z]);
        Some(Pose {
            world_from_camera: Rotation3::from_matrix_unchecked(m),
            position_m,
        })
    }

    /// A world point expressed in the camera frame.
    #[inline]
    pub fn camera_from_world(&self, p_m: &Point3<f64>) -> Vector3<f64> {
        self.world_from_camera
            .inverse_transform_vector(&(p_m - self.position_m))
    }

    /// Optical axis (camera +z) in world coordinates.
    pub fn forward(&self) -> Vector3<f64> {
        self.world_from_camera * Vector3::z()
    }
}

/// A full capture calibration: camera, time origin, laser spot and medium.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calibration {
    pub intrinsics: Intrinsics,
    pub pose: Pose,
    /// Cube (camera) time at which the laser pulse leaves the diffuser spot, ps:
    /// `t_camera = t0_ps + time_scale * eta * (|laser - p| + |p - o|) / c`.
    pub t0_ps: f64,
    /// Ratio of the cube's time unit to true picoseconds (1 for a perfect sweep).
    pub time_scale: f64,
    pub laser_m: Point3<f64>,
    pub eta: f64,
}

impl Calibration {
    /// Continuous pixel coordinates of a world point (None behind the camera).
    pub fn project(&self, p_m: &Point3<f64>) -> Option<(f64, f64)> {
        self.intrinsics
            .project_camera_point(&self.pose.camera_from_world(p_m))
    }

    /// World-frame unit ray through continuous pixel coordinates `(u, v)`.
    pub fn world_ray(&self, u: f64, v: f64) -> Unit<Vector3<f64>> {
        Unit::new_unchecked(
            self.pose.world_from_camera * self.intrinsics.camera_ray(u, v).into_inner(),
        )
    }

    /// Camera time (cube time) at which direct light from the laser spot, scattered once at
    /// `p_m`, reaches the sensor.
    pub fn first_arrival_ps(&self, p_m: &Point3<f64>) -> f64 {
        let path_m = (self.laser_m - p_m).norm() + (p_m - self.pose.position_m).norm();
        self.t0_ps + self.time_scale * crate::units::flight_time_ps(self.eta, path_m)
    }

    /// Read a calibration TOML file (format in [`CalibrationFile`]).
    pub fn load(path: &Path) -> Result<Calibration, CameraError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| CameraError::Io {
            path: name.clone(),
            source,
        })?;
        Calibration::from_toml(&text, &name)
    }

    /// Parse calibration TOML; `origin` names the source in error messages.
    pub fn from_toml(text: &str, origin: &str) -> Result<Calibration, CameraError> {
        let file: CalibrationFile = toml::from_str(text).map_err(|e| CameraError::Parse {
            path: origin.to_string(),
            message: one_line_toml_error(&e, text),
        })?;
        file.resolve(origin)
    }

    /// The calibration as TOML text.
    pub fn to_toml(&self) -> String {
        let file = CalibrationFile::from(self);
        let body = toml::to_string_pretty(&file).expect("calibration serialises");
        format!(
            "# femto camera calibration (metres, picoseconds; camera frame x right, y down, z forward)\n{body}"
        )
    }
}

/// One-line message for a TOML error: "line L, column C: what" (names the key when known).
pub fn one_line_toml_error(e: &toml::de::Error, text: &str) -> String {
    let msg = e.message().replace('\n', " ");
    match e.span() {
        Some(span) => {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
            format!("line {line}, column {col}: {}", msg.trim())
        }
        None => msg.trim().to_string(),
    }
}

/// On-disk calibration TOML (see `calibration/README.md`).
///
/// ```toml
/// [intrinsics]            # pixels
/// width = 64
/// height = 48
/// fx = 57.9
/// fy = 57.9
/// cx = 32.0
/// cy = 24.0
/// k1 = 0.0                # optional radial distortion
/// k2 = 0.0
/// [extrinsics]            # mesh frame, metres
/// position_m = [0.0, 0.5, 2.0]
/// world_from_camera = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]   # rows; columns = camera axes
/// [time]
/// t0_ps = 0.0             # cube time when the pulse leaves the laser spot
/// time_scale = 1.0        # optional
/// [laser]
/// position_m = [0.5, 0.0, 0.0]
/// [medium]
/// eta = 1.0               # optional, default 1
/// ```
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationFile {
    pub intrinsics: Intrinsics,
    pub extrinsics: ExtrinsicsFile,
    pub time: TimeFile,
    pub laser: LaserFile,
    #[serde(default)]
    pub medium: MediumFile,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExtrinsicsFile {
    pub position_m: [f64; 3],
    /// Rotation matrix rows; its columns are the camera's x, y, z axes in the world frame.
    pub world_from_camera: [[f64; 3]; 3],
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeFile {
    pub t0_ps: f64,
    #[serde(default = "one")]
    pub time_scale: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaserFile {
    pub position_m: [f64; 3],
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumFile {
    #[serde(default = "one")]
    pub eta: f64,
}

impl Default for MediumFile {
    fn default() -> Self {
        MediumFile { eta: 1.0 }
    }
}

fn one() -> f64 {
    1.0
}

impl From<&Calibration> for CalibrationFile {
    fn from(c: &Calibration) -> Self {
        let m = c.pose.world_from_camera.matrix();
        CalibrationFile {
            intrinsics: c.intrinsics,
            extrinsics: ExtrinsicsFile {
                position_m: c.pose.position_m.coords.into(),
                world_from_camera: [
                    [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
                    [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
                    [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
                ],
            },
            time: TimeFile {
                t0_ps: c.t0_ps,
                time_scale: c.time_scale,
            },
            laser: LaserFile {
                position_m: c.laser_m.coords.into(),
            },
            medium: MediumFile { eta: c.eta },
        }
    }
}

impl CalibrationFile {
    /// Check ranges and build the typed calibration.
    pub fn resolve(&self, origin: &str) -> Result<Calibration, CameraError> {
        let bad = |message: String| CameraError::Invalid {
            path: origin.to_string(),
            message,
        };
        let k = &self.intrinsics;
        check_intrinsics(k).map_err(bad)?;
        check_finite("time.t0_ps", self.time.t0_ps).map_err(bad)?;
        check_finite3("extrinsics.position_m", &self.extrinsics.position_m).map_err(bad)?;
        check_finite3("laser.position_m", &self.laser.position_m).map_err(bad)?;
        let r = &self.extrinsics.world_from_camera;
        // Finite first: the orthogonality test below cannot see a NaN (`max` skips it).
        for (i, row) in r.iter().enumerate() {
            check_finite3(&format!("extrinsics.world_from_camera[{i}]"), row).map_err(bad)?;
        }
        let m = Matrix3::new(
            r[0][0], r[0][1], r[0][2], r[1][0], r[1][1], r[1][2], r[2][0], r[2][1], r[2][2],
        );
        let ortho_err = (m.transpose() * m - Matrix3::identity()).abs().max();
        if ortho_err.is_nan() || ortho_err >= 1e-6 || (m.determinant() - 1.0).abs() > 1e-6 {
            return Err(bad(format!(
                "extrinsics.world_from_camera is not a rotation (|R^T R - I| = {ortho_err:.2e}, det = {:.6})",
                m.determinant()
            )));
        }
        check_eta(self.medium.eta).map_err(bad)?;
        // Each number in its meaningful range ([`crate::ranges`]), before anything sized by
        // it is made (a render's profile of span / (dt_ps / time_scale) bins: `time_scale =
        // 1e9` asked 1.6 TB).
        let in_range = |key: &str, v: f64, range| {
            ranges::check(key, v, range)
                .map(|_| ())
                .map_err(|e| bad(e.to_string()))
        };
        in_range("time.time_scale", self.time.time_scale, ranges::TIME_SCALE)?;
        in_range("time.t0_ps", self.time.t0_ps, ranges::TIME_PS)?;
        for (key, p) in [
            ("extrinsics.position_m", &self.extrinsics.position_m),
            ("laser.position_m", &self.laser.position_m),
        ] {
            ranges::check_point(key, p, ranges::COORD_M).map_err(|e| bad(e.to_string()))?;
        }
        Ok(Calibration {
            intrinsics: *k,
            pose: Pose {
                world_from_camera: Rotation3::from_matrix_unchecked(m),
                position_m: Point3::from(self.extrinsics.position_m),
            },
            t0_ps: self.time.t0_ps,
            time_scale: self.time.time_scale,
            laser_m: Point3::from(self.laser.position_m),
            eta: self.medium.eta,
        })
    }
}

/// `key` must be finite: a NaN or an infinity would reach the ray casts.
fn check_finite(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{key} must be finite, got {v}"))
    }
}

/// Each component of `key` finite (named `key[i]`).
fn check_finite3(key: &str, v: &[f64; 3]) -> Result<(), String> {
    for (i, &x) in v.iter().enumerate() {
        check_finite(&format!("{key}[{i}]"), x)?;
    }
    Ok(())
}

/// The `[intrinsics]` table's ranges: positive size and focal lengths, finite principal point
/// and distortion. Shared by calibration files and `calibrate --intrinsics`.
fn check_intrinsics(k: &Intrinsics) -> Result<(), String> {
    if k.width == 0 || k.height == 0 {
        return Err("intrinsics.width and intrinsics.height must be positive".into());
    }
    for (key, v) in [("fx", k.fx), ("fy", k.fy)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(format!(
                "intrinsics.{key} must be a positive number, got {v}"
            ));
        }
    }
    for (key, v) in [
        ("intrinsics.cx", k.cx),
        ("intrinsics.cy", k.cy),
        ("intrinsics.k1", k.k1),
        ("intrinsics.k2", k.k2),
    ] {
        check_finite(key, v)?;
    }
    for (key, v, range) in [
        ("intrinsics.fx", k.fx, ranges::FOCAL_PX),
        ("intrinsics.fy", k.fy, ranges::FOCAL_PX),
        ("intrinsics.cx", k.cx, ranges::PIXEL),
        ("intrinsics.cy", k.cy, ranges::PIXEL),
        ("intrinsics.k1", k.k1, ranges::DISTORTION),
        ("intrinsics.k2", k.k2, ranges::DISTORTION),
    ] {
        ranges::check(key, v, range).map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// `[medium] eta`: a refractive index in [`ranges::ETA`].
fn check_eta(eta: f64) -> Result<(), String> {
    ranges::check("medium.eta", eta, ranges::ETA)
        .map(|_| ())
        .map_err(|e| e.to_string())
}

/// What `femto calibrate --intrinsics FILE` takes from a calibration TOML: its intrinsics,
/// and its laser spot and medium when it has them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KnownIntrinsics {
    pub intrinsics: Intrinsics,
    pub laser_m: Option<Point3<f64>>,
    pub eta: Option<f64>,
}

/// A calibration TOML read for its `[intrinsics]` (`calibrate --intrinsics`): the same tables
/// and keys as [`CalibrationFile`], any other refused as `render --calibration` refuses it;
/// only `[intrinsics]` is required, `[extrinsics]` and `[time]` are checked for their keys
/// and otherwise ignored (they are what calibrate fits).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct KnownIntrinsicsFile {
    intrinsics: Intrinsics,
    #[serde(default)]
    #[allow(dead_code)]
    extrinsics: Option<ExtrinsicsFile>,
    #[serde(default)]
    #[allow(dead_code)]
    time: Option<TimeFile>,
    #[serde(default)]
    laser: Option<LaserFile>,
    #[serde(default)]
    medium: Option<MediumFile>,
}

impl KnownIntrinsics {
    /// Read `path` (see [`KnownIntrinsics`]); errors name the file and the key.
    pub fn load(path: &Path) -> Result<KnownIntrinsics, CameraError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| CameraError::Io {
            path: name.clone(),
            source,
        })?;
        KnownIntrinsics::from_toml(&text, &name)
    }

    /// Parse calibration TOML for its intrinsics; `origin` names the source in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<KnownIntrinsics, CameraError> {
        let bad = |message: String| CameraError::Invalid {
            path: origin.to_string(),
            message,
        };
        let file: KnownIntrinsicsFile = toml::from_str(text).map_err(|e| CameraError::Parse {
            path: origin.to_string(),
            message: one_line_toml_error(&e, text),
        })?;
        check_intrinsics(&file.intrinsics).map_err(bad)?;
        if let Some(l) = &file.laser {
            check_finite3("laser.position_m", &l.position_m).map_err(bad)?;
        }
        if let Some(m) = &file.medium {
            check_eta(m.eta).map_err(bad)?;
        }
        Ok(KnownIntrinsics {
            intrinsics: file.intrinsics,
            laser_m: file.laser.map(|l| Point3::from(l.position_m)),
            eta: file.medium.map(|m| m.eta),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_numbers_are_refused_naming_the_key() {
        let text = example().to_toml();
        for (key, line_start) in [
            ("intrinsics.cy", "cy = "),
            ("intrinsics.k2", "k2 = "),
            ("time.t0_ps", "t0_ps = "),
        ] {
            for bad in ["inf", "nan", "-inf"] {
                let edited: String = text
                    .lines()
                    .map(|l| {
                        if l.starts_with(line_start) {
                            format!("{line_start}{bad}")
                        } else {
                            l.to_string()
                        }
                    })
                    .collect::<Vec<_>>()
                    .join("\n");
                let e = Calibration::from_toml(&edited, "c.toml")
                    .unwrap_err()
                    .to_string();
                assert!(e.contains("c.toml") && e.contains(key), "{e}");
            }
        }
    }

    /// `calibrate --intrinsics` reads the same tables and keys as `render --calibration`
    /// (issue 16: unknown tables and keys were ignored) and checks the same ranges.
    #[test]
    fn known_intrinsics_refuse_what_calibration_files_refuse() {
        let text = example().to_toml();
        let k = KnownIntrinsics::from_toml(&text, "k.toml").unwrap();
        assert_eq!(k.intrinsics, example().intrinsics);
        assert_eq!(k.laser_m, Some(example().laser_m));
        assert_eq!(k.eta, Some(1.0));
        let only = "[intrinsics]\nwidth = 4\nheight = 3\nfx = 2.0\nfy = 2.0\ncx = 2.0\ncy = 1.5\n";
        let k = KnownIntrinsics::from_toml(only, "k.toml").unwrap();
        assert_eq!((k.laser_m, k.eta), (None, None));
        for (edit, key, full) in [
            (
                text.replace("[laser]", "[lens]\nmodel = 1\n[laser]"),
                "lens",
                true,
            ),
            (
                text.replace("[laser]", "[laser]\ncolour = 3"),
                "colour",
                true,
            ),
            (
                text.replace("[medium]", "[medium]\nindex = 2"),
                "index",
                true,
            ),
            (format!("{only}skew = 0.1\n"), "skew", false),
        ] {
            let e = KnownIntrinsics::from_toml(&edit, "k.toml")
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("k.toml: ") && e.contains(key), "{e}");
            if full {
                let e = Calibration::from_toml(&edit, "k.toml")
                    .unwrap_err()
                    .to_string();
                assert!(e.contains(key), "{e}");
            }
        }
        for (from, to, key) in [
            ("cy = ", "cy = inf", "intrinsics.cy"),
            ("k2 = ", "k2 = nan", "intrinsics.k2"),
            ("eta = ", "eta = 0.5", "medium.eta"),
        ] {
            let edited: String = text
                .lines()
                .map(|l| {
                    if l.starts_with(from) {
                        to.to_string()
                    } else {
                        l.to_string()
                    }
                })
                .collect::<Vec<_>>()
                .join("\n");
            let e = KnownIntrinsics::from_toml(&edited, "k.toml")
                .unwrap_err()
                .to_string();
            assert!(e.contains(key), "{e}");
        }
        let e = KnownIntrinsics::from_toml(
            &format!("{only}[laser]\nposition_m = [0.0, nan, 0.0]\n"),
            "k.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("laser.position_m[1] must be finite, got NaN"),
            "{e}"
        );
    }

    /// A NaN in the rotation was accepted (nalgebra's `max` skips NaN, so the orthogonality
    /// error read 0) and reached the ray casts (issue 16).
    #[test]
    fn a_nan_in_the_rotation_is_refused_naming_its_entry() {
        let mut file = CalibrationFile::from(&example());
        file.extrinsics.world_from_camera[1][1] = f64::NAN;
        let e = file.resolve("c.toml").unwrap_err().to_string();
        assert_eq!(
            e,
            "c.toml: extrinsics.world_from_camera[1][1] must be finite, got NaN"
        );
        file.extrinsics.world_from_camera[1][1] = 1.0;
        file.extrinsics.world_from_camera[0] = [1.0, f64::NEG_INFINITY, 0.0];
        let e = file.resolve("c.toml").unwrap_err().to_string();
        assert!(
            e.contains("world_from_camera[0][1] must be finite, got -inf"),
            "{e}"
        );
    }

    fn example() -> Calibration {
        let mut k = Intrinsics::from_vfov(64, 48, 40.0);
        k.k1 = -0.05;
        k.k2 = 0.01;
        Calibration {
            intrinsics: k,
            pose: Pose::look_at(
                Point3::new(0.3, 0.8, 2.5),
                Point3::new(0.0, 0.3, 0.0),
                Vector3::y(),
            )
            .unwrap(),
            t0_ps: 123.0,
            time_scale: 1.0,
            laser_m: Point3::new(-0.5, 0.2, 0.4),
            eta: 1.0,
        }
    }

    #[test]
    fn look_at_puts_target_at_centre_and_up_at_top() {
        let c = example();
        let (u, v) = c.project(&Point3::new(0.0, 0.3, 0.0)).unwrap();
        assert!((u - 32.0).abs() < 1e-9 && (v - 24.0).abs() < 1e-9);
        // A point above the target appears higher in the image (smaller v).
        let (_, v_up) = c.project(&Point3::new(0.0, 0.4, 0.0)).unwrap();
        assert!(v_up < 24.0);
        assert!((c.pose.world_from_camera.matrix().determinant() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn ray_and_projection_are_inverse_with_distortion() {
        let c = example();
        for &(u, v) in &[(0.5, 0.5), (63.5, 47.5), (10.2, 30.7)] {
            let d = c.world_ray(u, v);
            let p = c.pose.position_m + d.into_inner() * 3.0;
            let (u2, v2) = c.project(&p).unwrap();
            assert!(
                (u - u2).abs() < 1e-6 && (v - v2).abs() < 1e-6,
                "{u},{v} -> {u2},{v2}"
            );
        }
    }

    #[test]
    fn toml_round_trip_and_errors_name_the_key() {
        let c = example();
        let back = Calibration::from_toml(&c.to_toml(), "x.toml").unwrap();
        assert!((back.pose.position_m - c.pose.position_m).norm() < 1e-12);
        assert_eq!(back.intrinsics, c.intrinsics);
        let broken = c.to_toml().replace("[laser]", "[laser]\ncolour = 3");
        let e = Calibration::from_toml(&broken, "x.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("x.toml") && e.contains("line") && e.contains("colour"),
            "{e}"
        );
    }
}

//! The camera path file format: the TOML schema ([`CameraPathFile`]), its conversion from a
//! [`CameraPath`] (what [`CameraPath::to_toml`] writes) and its resolution into one (the shape
//! of the file: keyframes or an orbit, orientations, rotation matrices), and the reading and
//! writing of the file ([`CameraPath::load`], [`CameraPath::from_toml`]). The path itself
//! ([`super::path`]) knows nothing of the format.

use super::keyframes::ordinal;
use super::{
    CameraPath, CameraPathError, Clock, FrameSpec, Interpolation, Keyframe, Motion, Orbit,
    Orientation,
};
use crate::camera::one_line_toml_error;
use crate::relativity::{RotationAxis, SensorRotation};
use nalgebra::{Matrix3, Point3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// On-disk camera path TOML. Either `[[keyframe]]` tables (with `clock`) or one `[orbit]`.
///
/// ```toml
/// width = 320                 # frame size, pixels
/// height = 240
/// frames = 100                # frame count
/// dtau_ps = 5.0               # proper time between frames, ps
/// tau0_ps = 0.0               # optional: proper time of frame 0 (default: first keyframe)
/// clock = "world"             # "world" or "proper": the clock of the keyframe times
/// interpolation = "cubic"     # optional: "cubic" (default) or "linear"
///
/// [rotation]                  # optional rotating sensor
/// axis = "roll"               # "roll", "yaw" or "pitch"
/// beta_edge = 0.5             # speed at the sensor's farthest point from the axis
///
/// [[keyframe]]
/// time_ps = 0.0
/// position_m = [0.0, 0.5, 3.0]
/// look_at_m = [0.0, 0.3, 0.0] # or world_from_camera = [[..], [..], [..]] (rows)
/// up = [0.0, 1.0, 0.0]        # optional, default +y
/// vfov_deg = 40.0
/// beta = [0.0, 0.0, -0.5]     # optional (cubic only): world velocity / c here
///
/// [[keyframe]]
/// time_ps = 5000.0
/// position_m = [0.0, 0.5, 2.5]
/// look_at_m = [0.0, 0.3, 0.0]
/// vfov_deg = 40.0
///
/// # instead of [[keyframe]]:
/// # [orbit]
/// # centre_m = [0.0, 0.3, 0.0]
/// # radius_m = 2.0
/// # beta = 0.5               # signed speed / c
/// # axis = [0.0, 1.0, 0.0]   # optional, default +y
/// # height_m = 0.0           # optional
/// # start_angle_deg = 0.0    # optional
/// # look_at_m = [0.0, 0.3, 0.0]  # optional, default centre_m
/// # vfov_deg = 40.0
/// ```
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraPathFile {
    pub width: usize,
    pub height: usize,
    pub frames: usize,
    pub dtau_ps: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tau0_ps: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clock: Option<Clock>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interpolation: Option<Interpolation>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<RotationFile>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub keyframe: Option<Vec<KeyframeFile>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orbit: Option<OrbitFile>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotationFile {
    pub axis: RotationAxis,
    pub beta_edge: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeyframeFile {
    pub time_ps: f64,
    pub position_m: [f64; 3],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub look_at_m: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<[f64; 3]>,
    /// Rotation rows; its columns are the camera's x, y, z axes in the world frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub world_from_camera: Option<[[f64; 3]; 3]>,
    pub vfov_deg: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub beta: Option<[f64; 3]>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrbitFile {
    pub centre_m: [f64; 3],
    pub radius_m: f64,
    pub beta: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_angle_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub look_at_m: Option<[f64; 3]>,
    pub vfov_deg: f64,
}

fn rows(r: &Rotation3<f64>) -> [[f64; 3]; 3] {
    // `+ 0.0` turns -0.0 into 0.0 for tidier files.
    let m = r.matrix();
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)] + 0.0))
}

impl From<&CameraPath> for CameraPathFile {
    fn from(p: &CameraPath) -> Self {
        let (clock, interpolation, keyframe, orbit) = match &p.motion {
            Motion::Keyframes {
                clock,
                interpolation,
                keyframes,
            } => {
                let kfs = keyframes
                    .iter()
                    .map(|k| {
                        let (look_at_m, up, world_from_camera) = match k.orientation {
                            Orientation::LookAt { target_m, up } => {
                                (Some(target_m.coords.into()), Some(up.into()), None)
                            }
                            Orientation::Fixed(r) => (None, None, Some(rows(&r))),
                        };
                        KeyframeFile {
                            time_ps: k.time_ps,
                            position_m: k.position_m.coords.into(),
                            look_at_m,
                            up,
                            world_from_camera,
                            vfov_deg: k.vfov_deg,
                            beta: k.beta.map(Into::into),
                        }
                    })
                    .collect();
                (Some(*clock), Some(*interpolation), Some(kfs), None)
            }
            Motion::Orbit(o) => (
                None,
                None,
                None,
                Some(OrbitFile {
                    centre_m: o.centre_m.coords.into(),
                    radius_m: o.radius_m,
                    beta: o.beta,
                    axis: Some(o.axis.into()),
                    height_m: Some(o.height_m),
                    start_angle_deg: Some(o.start_angle_deg),
                    look_at_m: Some(o.look_at_m.coords.into()),
                    vfov_deg: o.vfov_deg,
                }),
            ),
        };
        CameraPathFile {
            width: p.spec.width,
            height: p.spec.height,
            frames: p.spec.frames,
            dtau_ps: p.spec.dtau_ps,
            tau0_ps: Some(p.tau0_ps),
            clock,
            interpolation,
            rotation: p.rotation.map(|r| RotationFile {
                axis: r.axis,
                beta_edge: r.beta_edge,
            }),
            keyframe,
            orbit,
        }
    }
}

impl CameraPathFile {
    /// Check the file's shape and build the validated path.
    pub fn resolve(&self, origin: &str) -> Result<CameraPath, CameraPathError> {
        let bad = |message: String| CameraPathError::Invalid {
            path: origin.to_string(),
            message,
        };
        let spec = FrameSpec {
            width: self.width,
            height: self.height,
            frames: self.frames,
            dtau_ps: self.dtau_ps,
        };
        let motion = match (&self.keyframe, &self.orbit) {
            (Some(_), Some(_)) => {
                return Err(bad(
                    "give either [[keyframe]] tables or an [orbit] table, not both".into(),
                ))
            }
            (None, None) => {
                return Err(bad(
                    "no motion: give [[keyframe]] tables or an [orbit] table".into(),
                ))
            }
            (Some(kfs), None) => {
                let clock = self.clock.ok_or_else(|| {
                    bad("clock is missing: say clock = \"proper\" or clock = \"world\" (the clock of the keyframe times)".into())
                })?;
                let n = kfs.len();
                let mut keyframes = Vec::with_capacity(n);
                for (i, k) in kfs.iter().enumerate() {
                    let name = ordinal(i, n);
                    let orientation = match (k.look_at_m, k.world_from_camera) {
                        (Some(t), None) => Orientation::LookAt {
                            target_m: Point3::from(t),
                            up: Vector3::from(k.up.unwrap_or([0.0, 1.0, 0.0])),
                        },
                        (None, Some(r)) => {
                            if k.up.is_some() {
                                return Err(bad(format!(
                                    "{name}: up only goes with look_at_m, not with world_from_camera"
                                )));
                            }
                            Orientation::Fixed(
                                rotation_from_rows(&r)
                                    .map_err(|m| bad(format!("{name}: world_from_camera{m}")))?,
                            )
                        }
                        (Some(_), Some(_)) => {
                            return Err(bad(format!(
                                "{name}: give look_at_m or world_from_camera, not both"
                            )))
                        }
                        (None, None) => {
                            return Err(bad(format!(
                                "{name}: give look_at_m (with optional up) or world_from_camera"
                            )))
                        }
                    };
                    keyframes.push(Keyframe {
                        time_ps: k.time_ps,
                        position_m: Point3::from(k.position_m),
                        orientation,
                        vfov_deg: k.vfov_deg,
                        beta: k.beta.map(Vector3::from),
                    });
                }
                Motion::Keyframes {
                    clock,
                    interpolation: self.interpolation.unwrap_or_default(),
                    keyframes,
                }
            }
            (None, Some(o)) => {
                if self.clock.is_some() || self.interpolation.is_some() {
                    return Err(bad(
                        "clock and interpolation apply to [[keyframe]] paths, not to [orbit]"
                            .into(),
                    ));
                }
                let centre_m = Point3::from(o.centre_m);
                Motion::Orbit(Orbit {
                    centre_m,
                    axis: Vector3::from(o.axis.unwrap_or([0.0, 1.0, 0.0])),
                    radius_m: o.radius_m,
                    height_m: o.height_m.unwrap_or(0.0),
                    start_angle_deg: o.start_angle_deg.unwrap_or(0.0),
                    beta: o.beta,
                    look_at_m: o.look_at_m.map(Point3::from).unwrap_or(centre_m),
                    vfov_deg: o.vfov_deg,
                })
            }
        };
        let rotation = self.rotation.as_ref().map(|r| SensorRotation {
            axis: r.axis,
            beta_edge: r.beta_edge,
        });
        CameraPath::new(spec, self.tau0_ps, rotation, motion, origin)
    }
}

/// Reading and writing the file format.
impl CameraPath {
    /// Read a camera path TOML file (format in [`CameraPathFile`]).
    pub fn load(path: &Path) -> Result<CameraPath, CameraPathError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| CameraPathError::Io {
            path: name.clone(),
            source,
        })?;
        CameraPath::from_toml(&text, &name)
    }

    /// Parse camera path TOML; `origin` names the source in error messages.
    pub fn from_toml(text: &str, origin: &str) -> Result<CameraPath, CameraPathError> {
        let file: CameraPathFile = toml::from_str(text).map_err(|e| CameraPathError::Parse {
            path: origin.to_string(),
            message: one_line_toml_error(&e, text),
        })?;
        file.resolve(origin)
    }

    /// The path as TOML text (reads back to the same path).
    pub fn to_toml(&self) -> String {
        let file = CameraPathFile::from(self);
        let body = toml::to_string(&file).expect("camera path serialises");
        format!("# femto camera path (metres, picoseconds; frames at proper time tau0_ps + k * dtau_ps)\n{body}")
    }
}

fn rotation_from_rows(r: &[[f64; 3]; 3]) -> Result<Rotation3<f64>, String> {
    for (i, row) in r.iter().enumerate() {
        for (j, &x) in row.iter().enumerate() {
            if !x.is_finite() {
                return Err(format!("[{i}][{j}] must be finite, got {x}"));
            }
        }
    }
    let m = Matrix3::new(
        r[0][0], r[0][1], r[0][2], r[1][0], r[1][1], r[1][2], r[2][0], r[2][1], r[2][2],
    );
    let ortho_err = (m.transpose() * m - Matrix3::identity()).abs().max();
    if ortho_err.is_nan() || ortho_err >= 1e-6 || (m.determinant() - 1.0).abs() > 1e-6 {
        return Err(format!(
            " is not a rotation (|R^T R - I| = {ortho_err:.2e}, det = {:.6})",
            m.determinant()
        ));
    }
    Ok(Rotation3::from_matrix_unchecked(m))
}

//! Camera paths of the relativistic renderer: where the camera is, where it looks, how fast it
//! moves and which world time it sees, frame by frame (seed Sec. 4: the camera moves at a
//! sizeable fraction of c; Sec. 4.3: a rotating sensor).
//!
//! Clocks (physics.md, "Units and clocks"): frame `k` is taken at the camera's **proper time**
//! `tau_k = tau0_ps + k * dtau_ps`; the world time of reception `t_world_ps` follows from the
//! path by integrating `dt_world = gamma dtau`. `dtau_ps` is the frame interval in picoseconds
//! of proper time (the seed renders frames a few ps apart); the playback rate of a video is the
//! renderer's business, not the path's.
//!
//! A path is one of:
//! - **keyframes** with a time each, on the clock named by the top-level `clock`:
//!   - `clock = "world"`: keyframe times are world times `t`. The path's derivative is the
//!     ordinary velocity, `beta = (dx/dt) / c`, which must stay below 1 everywhere (positions
//!     too far apart for the time between two keyframes are an error naming them). Proper
//!     time follows from `dtau = dt / gamma`; it equals the world time at the first keyframe.
//!   - `clock = "proper"`: keyframe times are the camera's proper times `tau`. The path's
//!     derivative is then the *proper* velocity `u = dx/dtau = gamma beta c`, which has no
//!     upper bound; `beta = u / sqrt(c^2 + u^2)` is always below 1, and `dt = sqrt(1 + u^2/c^2)
//!     dtau`. World time equals proper time at the first keyframe.
//!
//!   Positions are interpolated linearly or with a cubic Hermite spline whose tangent at each
//!   keyframe is its given `beta` (converted to `dx/dtime` on the path's clock) or, when absent,
//!   the Catmull-Rom (three-point, non-uniform) estimate; orientations are slerped, the field
//!   of view interpolated linearly. At a keyframe's own time the camera is exactly in that
//!   keyframe's state (position, orientation, field of view and, when given, `beta`). A
//!   single keyframe is a camera at rest, or, with `beta`, one moving uniformly at that
//!   velocity (its world time runs `gamma` times as fast as its proper time).
//! - an **orbit**: a circle about an axis at constant speed (so `t_world = gamma * tau`
//!   exactly), looking at a point.
//!
//! An optional rotating sensor (`[rotation]`: axis roll, yaw or pitch, and `beta_edge`, the
//! speed at the sensor's farthest point from the axis) is passed to every frame; the renderer
//! gives each pixel its own velocity with [`crate::relativity::sensor_velocity`].
//!
//! Resolve, then compute: [`CameraPath::from_toml`] and the constructors validate everything
//! (speeds below c at every keyframe, along the path and at every frame; increasing keyframe
//! times; frames inside the keyframes' span; non-zero frame count and size) and precompute the
//! clock table, so [`CameraPath::frame`] cannot fail. Even frame sizes (for mp4) are the
//! renderer's check, not this module's.
//!
//! # Layout
//!
//! - `file`: the TOML file format ([`CameraPathFile`]) and its resolution;
//! - `path`: [`CameraPath`], its validation and the camera's state at each frame;
//! - `keyframes`: interpolation of keyframes and their checks;
//! - `clock`: the clock table (proper time to world time along a keyframe path);
//! - `orbit`: circular orbits;
//! - `checks`: number checks and caps shared by the others.

mod checks;
mod clock;
mod file;
mod keyframes;
mod orbit;
mod path;
#[cfg(test)]
mod tests;

pub use checks::{MAX_COORD_M, MAX_FRAMES};
pub use file::{CameraPathFile, KeyframeFile, OrbitFile, RotationFile};
pub use path::CameraPath;

use crate::camera::Pose;
use crate::relativity::SensorRotation;
use nalgebra::{Point3, Rotation3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// Errors of camera paths.
#[derive(Debug, thiserror::Error)]
pub enum CameraPathError {
    /// The path file could not be read.
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// The path file is not TOML of the documented shape (line, column and key in `message`).
    #[error("{path}: {message}")]
    Parse { path: String, message: String },
    /// A value is out of range or inconsistent (names the keyframe or field in `message`).
    #[error("{path}: {message}")]
    Invalid { path: String, message: String },
}

/// Which clock the keyframe times use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Clock {
    /// The camera's proper time.
    Proper,
    /// World (scene) time.
    World,
}

/// Interpolation of keyframe positions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Interpolation {
    /// Straight segments at constant velocity between keyframes (no per-keyframe `beta`).
    Linear,
    /// Cubic Hermite: tangents from the keyframes' `beta`, else Catmull-Rom.
    #[default]
    Cubic,
}

/// Which way a keyframe looks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Orientation {
    /// Look at a point, with `up` pointing up in the image.
    LookAt {
        target_m: Point3<f64>,
        up: Vector3<f64>,
    },
    /// A given camera-to-world rotation.
    Fixed(Rotation3<f64>),
}

/// One keyframe of a path.
#[derive(Clone, Debug, PartialEq)]
pub struct Keyframe {
    /// Time on the path's [`Clock`], ps.
    pub time_ps: f64,
    pub position_m: Point3<f64>,
    pub orientation: Orientation,
    /// Vertical field of view, degrees.
    pub vfov_deg: f64,
    /// World-frame velocity over c at this keyframe (cubic interpolation only); None: from the
    /// path's derivative.
    pub beta: Option<Vector3<f64>>,
}

/// A circular orbit at constant speed.
#[derive(Clone, Debug, PartialEq)]
pub struct Orbit {
    pub centre_m: Point3<f64>,
    /// Unit normal of the orbit's plane; also the camera's up direction.
    pub axis: Vector3<f64>,
    pub radius_m: f64,
    /// Offset of the orbit's plane from `centre_m` along `axis`.
    pub height_m: f64,
    /// Angle at proper (and world) time 0, from the reference direction `e1` (the part of world
    /// +z perpendicular to `axis`, or of +x when `axis` is along z) towards `e2 = axis x e1`.
    pub start_angle_deg: f64,
    /// Signed speed over c; positive turns from `e1` towards `e2` (counter-clockwise seen from
    /// the tip of `axis`).
    pub beta: f64,
    /// The point the camera looks at.
    pub look_at_m: Point3<f64>,
    pub vfov_deg: f64,
}

/// How the camera moves.
#[derive(Clone, Debug, PartialEq)]
pub enum Motion {
    Keyframes {
        clock: Clock,
        interpolation: Interpolation,
        keyframes: Vec<Keyframe>,
    },
    Orbit(Orbit),
}

/// Frame size, count and interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameSpec {
    pub width: usize,
    pub height: usize,
    pub frames: usize,
    /// Proper time between frames, ps.
    pub dtau_ps: f64,
}

/// The camera's state at one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameState {
    /// Frame index.
    pub index: usize,
    /// Camera proper time, ps.
    pub tau_ps: f64,
    /// World time at which the camera receives this frame's light, ps.
    pub t_world_ps: f64,
    pub position_m: Point3<f64>,
    pub world_from_camera: Rotation3<f64>,
    pub vfov_deg: f64,
    /// Camera velocity in the world frame over c (world axes), `|beta| < 1`.
    pub beta: Vector3<f64>,
    /// The rotating sensor, if any (see [`FrameState::pixel_beta`]).
    pub rotation: Option<SensorRotation>,
}

impl FrameState {
    /// The camera pose of this frame.
    pub fn pose(&self) -> Pose {
        Pose {
            world_from_camera: self.world_from_camera,
            position_m: self.position_m,
        }
    }

    /// Lorentz factor of the camera's speed.
    pub fn gamma(&self) -> f64 {
        crate::relativity::gamma(self.beta.norm())
    }

    /// World-frame velocity over c of the sensor area at `offset` from the sensor centre
    /// (image-plane units, x right, y down; `half_size` in the same units): the camera's
    /// `beta` without a rotating sensor, else the sensor area's rotation velocity
    /// ([`SensorRotation::velocity`], rotated into world axes) added relativistically to the
    /// camera's ([`crate::relativity::add_velocities`]). Below 1 in magnitude.
    pub fn pixel_beta(&self, offset: &Vector2<f64>, half_size: &Vector2<f64>) -> Vector3<f64> {
        match self.rotation {
            None => self.beta,
            Some(r) => {
                let spin_world = self.world_from_camera * r.velocity(offset, half_size);
                crate::relativity::add_velocities(&self.beta, &spin_world)
            }
        }
    }
}

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
//!   of view interpolated linearly. A single keyframe is a camera at rest.
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

use crate::camera::{one_line_toml_error, Pose};
use crate::relativity::{RotationAxis, SensorRotation};
use crate::units::C_M_PER_PS;
use nalgebra::{Matrix3, Point3, Quaternion, Rotation3, UnitQuaternion, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;

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

/// Sub-intervals per keyframe segment of the clock table (5-point Gauss-Legendre each).
const SUB: usize = 32;
/// Samples per segment when checking the speed along a cubic segment.
const SPEED_SAMPLES: usize = 256;

/// A validated camera path with its precomputed clock table.
#[derive(Clone, Debug)]
pub struct CameraPath {
    spec: FrameSpec,
    tau0_ps: f64,
    rotation: Option<SensorRotation>,
    motion: Motion,
    resolved: Resolved,
}

#[derive(Clone, Debug)]
enum Resolved {
    Keyframes(KeyTrack),
    Orbit(OrbitTrack),
}

#[derive(Clone, Debug)]
struct KeyTrack {
    clock: Clock,
    interpolation: Interpolation,
    knots: Vec<f64>,
    points: Vec<Vector3<f64>>,
    /// dx/ds at each keyframe (m per ps of the path's clock), cubic only.
    tangents: Vec<Vector3<f64>>,
    rotations: Vec<UnitQuaternion<f64>>,
    vfovs: Vec<f64>,
    /// The other clock (tau for clock = world, t for clock = proper) at the table's nodes
    /// `knots[i] + j / SUB * h_i`, index `i * SUB + j`.
    cum: Vec<f64>,
}

#[derive(Clone, Debug)]
struct OrbitTrack {
    orbit: Orbit,
    e1: Vector3<f64>,
    e2: Vector3<f64>,
    /// Angular speed, radians per ps of world time.
    omega: f64,
    gamma: f64,
}

const GL5_X: [f64; 5] = [
    -0.906_179_845_938_664,
    -0.538_469_310_105_683_1,
    0.0,
    0.538_469_310_105_683_1,
    0.906_179_845_938_664,
];
const GL5_W: [f64; 5] = [
    0.236_926_885_056_189_1,
    0.478_628_670_499_366_5,
    0.568_888_888_888_888_9,
    0.478_628_670_499_366_5,
    0.236_926_885_056_189_1,
];

fn gauss_legendre(a: f64, b: f64, f: impl Fn(f64) -> f64) -> f64 {
    let (m, r) = (0.5 * (a + b), 0.5 * (b - a));
    r * GL5_X
        .iter()
        .zip(GL5_W.iter())
        .map(|(x, w)| w * f(m + r * x))
        .sum::<f64>()
}

/// Slerp on the shorter arc; normalised lerp for nearly equal rotations.
fn slerp(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>, t: f64) -> UnitQuaternion<f64> {
    let qa = a.coords;
    let mut qb = b.coords;
    let mut dot = qa.dot(&qb);
    if dot < 0.0 {
        qb = -qb;
        dot = -dot;
    }
    let q = if dot > 0.9995 {
        qa + (qb - qa) * t
    } else {
        let theta = dot.min(1.0).acos();
        let s = theta.sin();
        qa * (((1.0 - t) * theta).sin() / s) + qb * ((t * theta).sin() / s)
    };
    UnitQuaternion::new_normalize(Quaternion::from(q))
}

fn ordinal(i: usize, n: usize) -> String {
    format!("keyframe {} of {n}", i + 1)
}

impl KeyTrack {
    fn n(&self) -> usize {
        self.knots.len()
    }

    /// Segment index and fraction of `s` (clamped to the span). Requires n >= 2.
    fn locate(&self, s: f64) -> (usize, f64) {
        let n = self.n();
        let s = s.clamp(self.knots[0], self.knots[n - 1]);
        let i = match self.knots.partition_point(|&k| k <= s) {
            0 => 0,
            p => (p - 1).min(n - 2),
        };
        let h = self.knots[i + 1] - self.knots[i];
        (i, ((s - self.knots[i]) / h).clamp(0.0, 1.0))
    }

    /// Position and derivative dx/ds (m per ps of the path clock) at `s`.
    fn position_velocity(&self, s: f64) -> (Vector3<f64>, Vector3<f64>) {
        if self.n() == 1 {
            return (self.points[0], Vector3::zeros());
        }
        let (i, u) = self.locate(s);
        let h = self.knots[i + 1] - self.knots[i];
        let (p0, p1) = (self.points[i], self.points[i + 1]);
        match self.interpolation {
            Interpolation::Linear => (p0 + (p1 - p0) * u, (p1 - p0) / h),
            Interpolation::Cubic => {
                let (m0, m1) = (self.tangents[i] * h, self.tangents[i + 1] * h);
                let (u2, u3) = (u * u, u * u * u);
                let pos = p0 * (2.0 * u3 - 3.0 * u2 + 1.0)
                    + m0 * (u3 - 2.0 * u2 + u)
                    + p1 * (-2.0 * u3 + 3.0 * u2)
                    + m1 * (u3 - u2);
                let vel = (p0 * (6.0 * u2 - 6.0 * u)
                    + m0 * (3.0 * u2 - 4.0 * u + 1.0)
                    + p1 * (-6.0 * u2 + 6.0 * u)
                    + m1 * (3.0 * u2 - 2.0 * u))
                    / h;
                (pos, vel)
            }
        }
    }

    /// World-frame beta from the path derivative.
    fn beta_from_derivative(&self, vel: &Vector3<f64>) -> Vector3<f64> {
        match self.clock {
            Clock::World => vel / C_M_PER_PS,
            Clock::Proper => {
                let u = vel / C_M_PER_PS;
                u / (1.0 + u.norm_squared()).sqrt()
            }
        }
    }

    /// Rate of the other clock per unit of the path clock at `s`.
    fn rate(&self, s: f64) -> f64 {
        let (_, vel) = self.position_velocity(s);
        let b2 = vel.norm_squared() / (C_M_PER_PS * C_M_PER_PS);
        match self.clock {
            Clock::World => (1.0 - b2).max(0.0).sqrt(),
            Clock::Proper => (1.0 + b2).sqrt(),
        }
    }

    fn node_s(&self, node: usize) -> f64 {
        let i = (node / SUB).min(self.n() - 2);
        let j = node - i * SUB;
        let h = self.knots[i + 1] - self.knots[i];
        self.knots[i] + h * j as f64 / SUB as f64
    }

    fn build_table(&mut self) {
        let n = self.n();
        if n == 1 {
            self.cum = vec![self.knots[0]];
            return;
        }
        let nodes = (n - 1) * SUB + 1;
        let mut cum = Vec::with_capacity(nodes);
        cum.push(self.knots[0]);
        for node in 0..nodes - 1 {
            let (a, b) = (self.node_s(node), self.node_s(node + 1));
            let (a, b) = if node % SUB == SUB - 1 {
                (a, self.knots[node / SUB + 1])
            } else {
                (a, b)
            };
            // Evaluate inside the segment of `node` (matters at the knots for linear paths).
            let last = cum[node];
            cum.push(last + gauss_legendre(a, b, |s| self.rate(s)));
        }
        self.cum = cum;
    }

    /// The other clock at path-clock time `s` (clamped to the span).
    fn other_at(&self, s: f64) -> f64 {
        if self.n() == 1 {
            return s;
        }
        let s = s.clamp(self.knots[0], self.knots[self.n() - 1]);
        let (i, _) = self.locate(s);
        let h = self.knots[i + 1] - self.knots[i];
        let j = (((s - self.knots[i]) / h * SUB as f64).floor() as usize).min(SUB - 1);
        let node = i * SUB + j;
        let a = self.node_s(node);
        self.cum[node] + gauss_legendre(a, s, |x| self.rate(x))
    }

    /// Path-clock time at which the other clock reads `other` (clamped to the span).
    fn s_at_other(&self, other: f64) -> f64 {
        if self.n() == 1 {
            return other;
        }
        let last = self.cum.len() - 1;
        if other <= self.cum[0] {
            return self.knots[0];
        }
        if other >= self.cum[last] {
            return self.knots[self.n() - 1];
        }
        let node = self.cum.partition_point(|&c| c <= other).saturating_sub(1);
        let i = (node / SUB).min(self.n() - 2);
        let (mut lo, mut hi) = (
            self.node_s(node),
            if node % SUB == SUB - 1 {
                self.knots[i + 1]
            } else {
                self.node_s(node + 1)
            },
        );
        let base = self.cum[node];
        let a = lo;
        let f = |s: f64| base + gauss_legendre(a, s, |x| self.rate(x)) - other;
        let mut s = lo + (hi - lo) * 0.5;
        for _ in 0..100 {
            let fs = f(s);
            if fs.abs() <= 1e-13 * (1.0 + other.abs()) {
                break;
            }
            if fs > 0.0 {
                hi = s;
            } else {
                lo = s;
            }
            if hi - lo <= 1e-13 * (1.0 + s.abs()) {
                s = 0.5 * (lo + hi);
                break;
            }
            let r = self.rate(s);
            let newton = s - fs / r;
            s = if r > 0.0 && newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
        }
        s
    }

    fn orientation_at(&self, s: f64) -> (Rotation3<f64>, f64) {
        if self.n() == 1 {
            return (self.rotations[0].to_rotation_matrix(), self.vfovs[0]);
        }
        let (i, u) = self.locate(s);
        let q = slerp(&self.rotations[i], &self.rotations[i + 1], u);
        let vfov = self.vfovs[i] + (self.vfovs[i + 1] - self.vfovs[i]) * u;
        (q.to_rotation_matrix(), vfov)
    }

    /// Proper time span `[tau_first, tau_last]` of the keyframes.
    fn tau_span(&self) -> (f64, f64) {
        let n = self.n();
        match self.clock {
            Clock::Proper => (self.knots[0], self.knots[n - 1]),
            Clock::World => (self.cum[0], self.cum[self.cum.len() - 1]),
        }
    }

    /// (path-clock time, world time) at proper time `tau`.
    fn times_at_tau(&self, tau: f64) -> (f64, f64) {
        if self.n() == 1 {
            return (tau, tau);
        }
        match self.clock {
            Clock::Proper => (tau, self.other_at(tau)),
            Clock::World => {
                let s = self.s_at_other(tau);
                (s, s)
            }
        }
    }
}

fn unit_basis(axis: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let reference = if axis.z.abs() > 0.999_999 {
        Vector3::x()
    } else {
        Vector3::z()
    };
    let e1 = (reference - axis * axis.dot(&reference)).normalize();
    let e2 = axis.cross(&e1);
    (e1, e2)
}

fn valid_vfov(v: f64) -> bool {
    v.is_finite() && v > 0.0 && v < 180.0
}

fn finite3(v: &Vector3<f64>) -> bool {
    v.iter().all(|c| c.is_finite())
}

/// The most frames a path may have: [`CameraPath::new`] walks every frame to check its speed,
/// so the count is capped before the walk (`frames = 18446744073709551615` would never end).
pub const MAX_FRAMES: usize = 1_000_000;

/// The largest distance from the origin, in metres, of any point of a path (positions, look-at
/// targets, an orbit's centre and radius). The renderer casts rays in `f32`, which turns a
/// coordinate above about 3.4e38 into an infinity and loses every millimetre beyond 1e4 m;
/// a thousand kilometres is far beyond any scene a streak camera records.
pub const MAX_COORD_M: f64 = 1e6;

/// `key` (a number of the path, named as in the file) must be finite.
fn check_finite(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{key} must be finite, got {v}"))
    }
}

/// Every component of `key` finite (named `key[i]`).
fn check_finite_all(key: &str, v: &[f64]) -> Result<(), String> {
    for (i, &x) in v.iter().enumerate() {
        check_finite(&format!("{key}[{i}]"), x)?;
    }
    Ok(())
}

/// A length or coordinate of the path: finite and at most [`MAX_COORD_M`] in magnitude.
fn check_length(key: &str, x: f64) -> Result<(), String> {
    check_finite(key, x)?;
    if x.abs() > MAX_COORD_M {
        return Err(format!(
            "{key} = {x:e} m is beyond the {MAX_COORD_M:e} m from the origin that a path may reach"
        ));
    }
    Ok(())
}

/// A point of the path: each coordinate (named `key[i]`) as [`check_length`].
fn check_point(key: &str, v: &[f64]) -> Result<(), String> {
    for (i, &x) in v.iter().enumerate() {
        check_length(&format!("{key}[{i}]"), x)?;
    }
    Ok(())
}

impl CameraPath {
    /// Validate a path and precompute its clock table. `origin` names the source (a file or a
    /// constructor) in error messages. `tau0_ps`: proper time of frame 0; None: the first
    /// keyframe's proper time (keyframes) or 0 (orbit).
    pub fn new(
        spec: FrameSpec,
        tau0_ps: Option<f64>,
        rotation: Option<SensorRotation>,
        motion: Motion,
        origin: &str,
    ) -> Result<CameraPath, CameraPathError> {
        let bad = |message: String| CameraPathError::Invalid {
            path: origin.to_string(),
            message,
        };
        if spec.width == 0 || spec.height == 0 {
            return Err(bad(format!(
                "frame size {}x{}: width and height must be positive",
                spec.width, spec.height
            )));
        }
        if spec.frames == 0 {
            return Err(bad("frames = 0: need at least one frame".into()));
        }
        // Capped before anything walks the frames (check_frames visits every one).
        crate::limits::bounded_count(
            spec.frames as f64,
            MAX_FRAMES as u64,
            "frames",
            "use fewer frames (split a longer sequence into several paths)",
        )
        .map_err(|e| bad(e.to_string()))?;
        if !(spec.dtau_ps.is_finite() && spec.dtau_ps > 0.0) {
            return Err(bad(format!(
                "dtau_ps = {}: the frame interval must be a positive number of picoseconds",
                spec.dtau_ps
            )));
        }
        if let Some(t) = tau0_ps {
            if !t.is_finite() {
                return Err(bad(format!("tau0_ps = {t} is not a finite number")));
            }
        }
        if let Some(r) = rotation {
            if !(r.beta_edge.is_finite() && r.beta_edge.abs() < 1.0) {
                return Err(bad(format!(
                    "rotation.beta_edge = {}: the sensor edge must move slower than light (|beta_edge| < 1)",
                    r.beta_edge
                )));
            }
        }
        let resolved = match &motion {
            Motion::Keyframes {
                clock,
                interpolation,
                keyframes,
            } => Resolved::Keyframes(resolve_keyframes(*clock, *interpolation, keyframes, &bad)?),
            Motion::Orbit(o) => Resolved::Orbit(resolve_orbit(o, &bad)?),
        };
        let tau0 = tau0_ps.unwrap_or(match &resolved {
            Resolved::Keyframes(k) => k.tau_span().0,
            Resolved::Orbit(_) => 0.0,
        });
        let path = CameraPath {
            spec,
            tau0_ps: tau0,
            rotation,
            motion,
            resolved,
        };
        path.check_frames(&bad)?;
        Ok(path)
    }

    fn check_frames(&self, bad: &dyn Fn(String) -> CameraPathError) -> Result<(), CameraPathError> {
        let tau_end = self.tau0_ps + (self.spec.frames - 1) as f64 * self.spec.dtau_ps;
        if let Resolved::Keyframes(k) = &self.resolved {
            if k.n() > 1 {
                let (first, last) = k.tau_span();
                let tol = 1e-9 * (1.0 + first.abs().max(last.abs()));
                if self.tau0_ps < first - tol || tau_end > last + tol {
                    let clock_note = match k.clock {
                        Clock::Proper => String::new(),
                        Clock::World => format!(
                            " (clock = \"world\": keyframe times {} .. {} ps are proper times {first} .. {last} ps)",
                            k.knots[0],
                            k.knots[k.n() - 1]
                        ),
                    };
                    return Err(bad(format!(
                        "the {} frames span proper time {} .. {tau_end} ps (tau0_ps + k * dtau_ps), outside the keyframes' span {first} .. {last} ps{clock_note}; use fewer frames, a smaller dtau_ps or more keyframes",
                        self.spec.frames, self.tau0_ps
                    )));
                }
            }
        }
        for k in 0..self.spec.frames {
            let f = self.frame(k);
            if !(f.t_world_ps.is_finite() && finite3(&f.position_m.coords)) {
                return Err(bad(format!(
                    "frame {k} (tau = {} ps): its world time or position is not finite; use a smaller tau0_ps or dtau_ps",
                    f.tau_ps
                )));
            }
            let speed = f.beta.norm();
            if speed.is_nan() || speed >= 1.0 {
                return Err(bad(format!(
                    "frame {k} (tau = {} ps): speed |beta| = {speed} is not below the speed of light",
                    f.tau_ps
                )));
            }
        }
        Ok(())
    }

    /// Straight towards `target_m` at constant speed `beta` (negative: backing away), looking
    /// at the target with `up` up. Frame 0 is at `start_m`, proper time 0. Fails if the camera
    /// would reach the target within the frames.
    pub fn dolly(
        start_m: Point3<f64>,
        target_m: Point3<f64>,
        up: Vector3<f64>,
        beta: f64,
        vfov_deg: f64,
        spec: FrameSpec,
    ) -> Result<CameraPath, CameraPathError> {
        let origin = "dolly";
        let bad = |message: String| CameraPathError::Invalid {
            path: origin.into(),
            message,
        };
        if !(beta.is_finite() && beta.abs() < 1.0) {
            return Err(bad(format!(
                "beta = {beta}: the camera must move slower than light (|beta| < 1)"
            )));
        }
        let pose = Pose::look_at(start_m, target_m, up).ok_or_else(|| {
            bad("the target coincides with the start or lies along the up direction".into())
        })?;
        let span_tau_ps = (spec.frames.max(2) - 1) as f64 * spec.dtau_ps;
        let g = crate::relativity::gamma(beta);
        let travel_m = g * beta * C_M_PER_PS * span_tau_ps;
        let dist_m = (target_m - start_m).norm();
        if travel_m >= dist_m {
            return Err(bad(format!(
                "at beta = {beta} the camera covers {travel_m:.4} m in {} frames of {} ps, but the target is {dist_m:.4} m away",
                spec.frames, spec.dtau_ps
            )));
        }
        let dir = (target_m - start_m) / dist_m;
        let kf = |time_ps: f64, position_m: Point3<f64>| Keyframe {
            time_ps,
            position_m,
            orientation: Orientation::Fixed(pose.world_from_camera),
            vfov_deg,
            beta: None,
        };
        let motion = Motion::Keyframes {
            clock: Clock::Proper,
            interpolation: Interpolation::Linear,
            keyframes: vec![kf(0.0, start_m), kf(span_tau_ps, start_m + dir * travel_m)],
        };
        CameraPath::new(spec, Some(0.0), None, motion, origin)
    }

    /// A circle of `radius_m` about `centre_m` in the plane perpendicular to `axis` (also the
    /// image's up), at signed speed `beta`, looking at the centre. Starts at angle 0 (see
    /// [`Orbit`]) at proper time 0.
    pub fn orbit(
        centre_m: Point3<f64>,
        radius_m: f64,
        beta: f64,
        axis: Vector3<f64>,
        vfov_deg: f64,
        spec: FrameSpec,
    ) -> Result<CameraPath, CameraPathError> {
        let motion = Motion::Orbit(Orbit {
            centre_m,
            axis,
            radius_m,
            height_m: 0.0,
            start_angle_deg: 0.0,
            beta,
            look_at_m: centre_m,
            vfov_deg,
        });
        CameraPath::new(spec, Some(0.0), None, motion, "orbit")
    }

    /// A camera at rest at `pose` (e.g. the capture camera's own view); frame 0 at proper time 0.
    pub fn static_view(
        pose: &Pose,
        vfov_deg: f64,
        spec: FrameSpec,
    ) -> Result<CameraPath, CameraPathError> {
        let motion = Motion::Keyframes {
            clock: Clock::Proper,
            interpolation: Interpolation::Linear,
            keyframes: vec![Keyframe {
                time_ps: 0.0,
                position_m: pose.position_m,
                orientation: Orientation::Fixed(pose.world_from_camera),
                vfov_deg,
                beta: None,
            }],
        };
        CameraPath::new(spec, Some(0.0), None, motion, "static view")
    }

    /// The same path with a rotating sensor (or none).
    pub fn with_rotation(
        self,
        rotation: Option<SensorRotation>,
    ) -> Result<CameraPath, CameraPathError> {
        CameraPath::new(
            self.spec,
            Some(self.tau0_ps),
            rotation,
            self.motion,
            "rotation",
        )
    }

    pub fn spec(&self) -> FrameSpec {
        self.spec
    }

    /// Proper time of frame 0, ps.
    pub fn tau0_ps(&self) -> f64 {
        self.tau0_ps
    }

    pub fn rotation(&self) -> Option<SensorRotation> {
        self.rotation
    }

    pub fn motion(&self) -> &Motion {
        &self.motion
    }

    /// Proper time of frame `k`: `tau0_ps + k * dtau_ps`.
    pub fn tau_ps(&self, k: usize) -> f64 {
        self.tau0_ps + k as f64 * self.spec.dtau_ps
    }

    /// The camera's state at frame `k` (any `k`; frames past the path's end see its last state).
    pub fn frame(&self, k: usize) -> FrameState {
        let mut f = self.at_proper_time(self.tau_ps(k));
        f.index = k;
        f
    }

    /// The camera's state at proper time `tau_ps` (`index` 0). Keyframe paths are clamped to
    /// the keyframes' span: outside it, the state at the nearer end is returned.
    pub fn at_proper_time(&self, tau_ps: f64) -> FrameState {
        match &self.resolved {
            Resolved::Keyframes(k) => {
                let (s, t_world) = k.times_at_tau(tau_ps);
                let (pos, vel) = k.position_velocity(s);
                let (world_from_camera, vfov_deg) = k.orientation_at(s);
                let (first, last) = k.tau_span();
                let tau = if k.n() > 1 {
                    tau_ps.clamp(first, last)
                } else {
                    tau_ps
                };
                FrameState {
                    index: 0,
                    tau_ps: tau,
                    t_world_ps: t_world,
                    position_m: Point3::from(pos),
                    world_from_camera,
                    vfov_deg,
                    beta: k.beta_from_derivative(&vel),
                    rotation: self.rotation,
                }
            }
            Resolved::Orbit(track) => {
                let o = &track.orbit;
                let t_world = track.gamma * tau_ps;
                let phi = o.start_angle_deg.to_radians() + track.omega * t_world;
                let (sin, cos) = phi.sin_cos();
                let radial = track.e1 * cos + track.e2 * sin;
                let tangent = -track.e1 * sin + track.e2 * cos;
                let position_m = o.centre_m + o.axis * o.height_m + radial * o.radius_m;
                let world_from_camera = Pose::look_at(position_m, o.look_at_m, o.axis)
                    .map(|p| p.world_from_camera)
                    .unwrap_or_else(Rotation3::identity);
                FrameState {
                    index: 0,
                    tau_ps,
                    t_world_ps: t_world,
                    position_m,
                    world_from_camera,
                    vfov_deg: o.vfov_deg,
                    beta: tangent * o.beta,
                    rotation: self.rotation,
                }
            }
        }
    }

    /// `n` camera positions evenly spaced in proper time from frame 0 to the last frame
    /// (both included), for checking that the path does not pass through geometry.
    pub fn sample_positions(&self, n: usize) -> Vec<Point3<f64>> {
        let t0 = self.tau0_ps;
        let t1 = self.tau_ps(self.spec.frames - 1);
        (0..n)
            .map(|i| {
                let f = if n > 1 {
                    i as f64 / (n - 1) as f64
                } else {
                    0.0
                };
                self.at_proper_time(t0 + (t1 - t0) * f).position_m
            })
            .collect()
    }

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

/// Every number of a keyframe finite, its points within [`MAX_COORD_M`] (messages name the
/// file's keys: `look_at_m[1] must be finite, got -inf`).
fn check_keyframe_numbers(kf: &Keyframe) -> Result<(), String> {
    check_finite("time_ps", kf.time_ps)?;
    check_point("position_m", kf.position_m.coords.as_slice())?;
    match &kf.orientation {
        Orientation::LookAt { target_m, up } => {
            check_point("look_at_m", target_m.coords.as_slice())?;
            check_finite_all("up", up.as_slice())?;
        }
        Orientation::Fixed(r) => {
            let m = r.matrix();
            for row in 0..3 {
                for col in 0..3 {
                    check_finite(&format!("world_from_camera[{row}][{col}]"), m[(row, col)])?;
                }
            }
        }
    }
    check_finite("vfov_deg", kf.vfov_deg)?;
    if let Some(b) = &kf.beta {
        check_finite_all("beta", b.as_slice())?;
    }
    Ok(())
}

fn resolve_keyframes(
    clock: Clock,
    interpolation: Interpolation,
    keyframes: &[Keyframe],
    bad: &dyn Fn(String) -> CameraPathError,
) -> Result<KeyTrack, CameraPathError> {
    let n = keyframes.len();
    if n == 0 {
        return Err(bad("no keyframes: give at least one [[keyframe]]".into()));
    }
    let mut rotations = Vec::with_capacity(n);
    for (i, kf) in keyframes.iter().enumerate() {
        let name = ordinal(i, n);
        check_keyframe_numbers(kf).map_err(|m| bad(format!("{name}: {m}")))?;
        if !valid_vfov(kf.vfov_deg) {
            return Err(bad(format!(
                "{name}: vfov_deg = {} must be between 0 and 180 degrees",
                kf.vfov_deg
            )));
        }
        if i > 0 && kf.time_ps <= keyframes[i - 1].time_ps {
            return Err(bad(format!(
                "{name}: time_ps = {} does not increase (the previous keyframe has time_ps = {})",
                kf.time_ps,
                keyframes[i - 1].time_ps
            )));
        }
        if let Some(b) = kf.beta {
            let speed = b.norm();
            if !(speed.is_finite() && speed < 1.0) {
                return Err(bad(format!(
                    "{name} (time_ps = {}): beta = [{}, {}, {}] has |beta| = {speed}, not below the speed of light",
                    kf.time_ps, b.x, b.y, b.z
                )));
            }
            if interpolation == Interpolation::Linear {
                return Err(bad(format!(
                    "{name}: beta is given, but interpolation = \"linear\" takes the velocity from the positions; use interpolation = \"cubic\""
                )));
            }
            if n == 1 && speed > 0.0 {
                return Err(bad(format!(
                    "{name}: a single keyframe is a camera at rest, but beta is not zero"
                )));
            }
        }
        let rot = match kf.orientation {
            Orientation::Fixed(r) => r,
            Orientation::LookAt { target_m, up } => {
                Pose::look_at(kf.position_m, target_m, up)
                    .ok_or_else(|| {
                        bad(format!(
                            "{name}: look_at_m coincides with position_m or lies along up"
                        ))
                    })?
                    .world_from_camera
            }
        };
        rotations.push(UnitQuaternion::from_rotation_matrix(&rot));
    }
    let knots: Vec<f64> = keyframes.iter().map(|k| k.time_ps).collect();
    let points: Vec<Vector3<f64>> = keyframes.iter().map(|k| k.position_m.coords).collect();
    // Tangents dx/ds on the path's clock.
    let mut tangents = vec![Vector3::zeros(); n];
    if n > 1 {
        let d = |i: usize| (points[i + 1] - points[i]) / (knots[i + 1] - knots[i]);
        for (i, kf) in keyframes.iter().enumerate() {
            tangents[i] = match kf.beta {
                Some(b) => match clock {
                    Clock::World => b * C_M_PER_PS,
                    Clock::Proper => b * (crate::relativity::gamma(b.norm()) * C_M_PER_PS),
                },
                None if i == 0 => d(0),
                None if i == n - 1 => d(n - 2),
                None => {
                    let (h0, h1) = (knots[i] - knots[i - 1], knots[i + 1] - knots[i]);
                    (d(i - 1) * h1 + d(i) * h0) / (h0 + h1)
                }
            };
        }
    }
    let mut track = KeyTrack {
        clock,
        interpolation,
        knots,
        points,
        tangents,
        rotations,
        vfovs: keyframes.iter().map(|k| k.vfov_deg).collect(),
        cum: Vec::new(),
    };
    // Speed along the path.
    for i in 0..n.saturating_sub(1) {
        let (a, b) = (track.knots[i], track.knots[i + 1]);
        let samples = match interpolation {
            Interpolation::Linear => 1,
            Interpolation::Cubic => SPEED_SAMPLES,
        };
        let mut worst = (0.0f64, a);
        for j in 0..=samples {
            // Stay inside segment i (locate() puts a knot in the next segment).
            let u = (j as f64 / samples as f64).min(1.0 - 1e-12);
            let s = a + (b - a) * u;
            let (_, vel) = track.position_velocity(s);
            let speed = track.beta_from_derivative(&vel).norm();
            if speed.is_nan() || speed > worst.0 {
                worst = (speed, s);
            }
        }
        if worst.0.is_nan() || worst.0 >= 1.0 {
            let dist_m = (track.points[i + 1] - track.points[i]).norm();
            let hint = match clock {
                Clock::World => format!(
                    "; positions {dist_m:.4} m apart need more than {:.1} ps of world time",
                    crate::units::flight_time_ps(1.0, dist_m)
                ),
                Clock::Proper => String::new(),
            };
            return Err(bad(format!(
                "between {} (time_ps = {a}) and {} (time_ps = {b}): the path moves at |beta| = {:.4} at time_ps = {:.3}, not below the speed of light{hint}",
                ordinal(i, n),
                ordinal(i + 1, n),
                worst.0,
                worst.1
            )));
        }
    }
    track.build_table();
    Ok(track)
}

/// Every number of an orbit finite, its points and lengths within [`MAX_COORD_M`] (messages
/// name the file's keys: `orbit.look_at_m[1] must be finite, got -inf`).
fn check_orbit_numbers(o: &Orbit) -> Result<(), String> {
    check_point("orbit.centre_m", o.centre_m.coords.as_slice())?;
    check_point("orbit.look_at_m", o.look_at_m.coords.as_slice())?;
    check_finite_all("orbit.axis", o.axis.as_slice())?;
    check_length("orbit.radius_m", o.radius_m)?;
    check_length("orbit.height_m", o.height_m)?;
    check_finite("orbit.start_angle_deg", o.start_angle_deg)?;
    check_finite("orbit.beta", o.beta)?;
    check_finite("orbit.vfov_deg", o.vfov_deg)?;
    Ok(())
}

fn resolve_orbit(
    o: &Orbit,
    bad: &dyn Fn(String) -> CameraPathError,
) -> Result<OrbitTrack, CameraPathError> {
    check_orbit_numbers(o).map_err(bad)?;
    if !(o.radius_m.is_finite() && o.radius_m > 0.0) {
        return Err(bad(format!(
            "orbit.radius_m = {} must be positive",
            o.radius_m
        )));
    }
    if !(o.beta.is_finite() && o.beta.abs() < 1.0) {
        return Err(bad(format!(
            "orbit.beta = {}: the camera must move slower than light (|beta| < 1)",
            o.beta
        )));
    }
    let axis_norm = o.axis.norm();
    if !(axis_norm.is_finite() && axis_norm > 0.0) || (axis_norm - 1.0).abs() > 1e-9 {
        return Err(bad(format!(
            "orbit.axis = [{}, {}, {}] must be a unit vector",
            o.axis.x, o.axis.y, o.axis.z
        )));
    }
    if !valid_vfov(o.vfov_deg) {
        return Err(bad(format!(
            "orbit.vfov_deg = {} must be between 0 and 180 degrees",
            o.vfov_deg
        )));
    }
    let (e1, e2) = unit_basis(&o.axis);
    // The view direction must never be along the axis: check the whole circle.
    for j in 0..720 {
        let phi = j as f64 * std::f64::consts::PI / 360.0;
        let p = o.centre_m + o.axis * o.height_m + (e1 * phi.cos() + e2 * phi.sin()) * o.radius_m;
        if Pose::look_at(p, o.look_at_m, o.axis).is_none() {
            return Err(bad(
                "orbit: look_at_m lies on the orbit or straight along the axis from it".into(),
            ));
        }
    }
    Ok(OrbitTrack {
        orbit: o.clone(),
        e1,
        e2,
        omega: o.beta * C_M_PER_PS / o.radius_m,
        gamma: crate::relativity::gamma(o.beta),
    })
}

// ---------------------------------------------------------------------------------------------
// File format.

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::relativity::gamma;

    fn spec(frames: usize, dtau_ps: f64) -> FrameSpec {
        FrameSpec {
            width: 64,
            height: 48,
            frames,
            dtau_ps,
        }
    }

    fn kf(time_ps: f64, p: [f64; 3]) -> Keyframe {
        Keyframe {
            time_ps,
            position_m: Point3::from(p),
            orientation: Orientation::LookAt {
                target_m: Point3::new(0.0, 0.0, -10.0),
                up: Vector3::y(),
            },
            vfov_deg: 40.0,
            beta: None,
        }
    }

    fn keyframes(clock: Clock, interpolation: Interpolation, kfs: Vec<Keyframe>) -> Motion {
        Motion::Keyframes {
            clock,
            interpolation,
            keyframes: kfs,
        }
    }

    #[test]
    fn dolly_world_time_is_gamma_times_proper_time() {
        for beta in [0.1, 0.5, 0.8, 0.99] {
            let start = Point3::new(0.0, 0.5, 20.0);
            let target = Point3::new(0.0, 0.5, 0.0);
            let path =
                CameraPath::dolly(start, target, Vector3::y(), beta, 40.0, spec(50, 3.0)).unwrap();
            let g = 1.0 / (1.0 - beta * beta).sqrt();
            for k in [0, 1, 17, 49] {
                let f = path.frame(k);
                let tau = 3.0 * k as f64;
                assert!((f.tau_ps - tau).abs() < 1e-12);
                assert!(
                    (f.t_world_ps - g * tau).abs() < 1e-9 * (1.0 + g * tau),
                    "beta {beta} frame {k}: t_world {} vs gamma tau {}",
                    f.t_world_ps,
                    g * tau
                );
                // Position moves at beta c in world time, towards the target.
                let expect_z = 20.0 - beta * C_M_PER_PS * g * tau;
                assert!(
                    (f.position_m.z - expect_z).abs() < 1e-12,
                    "{}",
                    f.position_m
                );
                assert!((f.beta - Vector3::new(0.0, 0.0, -beta)).norm() < 1e-12);
                assert!((f.gamma() - g).abs() < 1e-9 * g);
                // Looks at the target.
                assert!((f.pose().forward() - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
            }
        }
        // Reaching the target within the frames is an error.
        let e = CameraPath::dolly(
            Point3::new(0.0, 0.0, 0.01),
            Point3::origin(),
            Vector3::y(),
            0.9,
            40.0,
            spec(100, 5.0),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("target"), "{e}");
    }

    #[test]
    fn world_clock_keyframes_at_constant_speed_dilate_time() {
        // Two keyframes 10 ns of world time apart, moving at 0.6 c along x.
        let beta = 0.6;
        let t1 = 10_000.0;
        let d = beta * C_M_PER_PS * t1;
        for interpolation in [Interpolation::Linear, Interpolation::Cubic] {
            let motion = keyframes(
                Clock::World,
                interpolation,
                vec![kf(0.0, [0.0, 0.0, 0.0]), kf(t1, [d, 0.0, 0.0])],
            );
            let g = gamma(beta);
            let path = CameraPath::new(spec(40, t1 / g / 40.0), None, None, motion, "t").unwrap();
            for k in 0..40 {
                let f = path.frame(k);
                assert!(
                    (f.t_world_ps - g * f.tau_ps).abs() < 1e-7,
                    "{interpolation:?} frame {k}: {} vs {}",
                    f.t_world_ps,
                    g * f.tau_ps
                );
                assert!((f.position_m.x - beta * C_M_PER_PS * f.t_world_ps).abs() < 1e-9);
                assert!((f.beta.x - beta).abs() < 1e-12);
            }
        }
    }

    /// Along a curved cubic path, the reported velocity is the derivative of the reported
    /// position with respect to the reported world time, and world time advances at gamma of
    /// the reported speed per unit of proper time.
    #[test]
    fn curved_paths_have_consistent_velocity_and_clocks() {
        let kfs = vec![
            kf(0.0, [0.0, 0.0, 0.0]),
            kf(4000.0, [0.5, 0.2, -0.3]),
            kf(7000.0, [0.9, 0.7, -0.2]),
            kf(12000.0, [1.2, 0.6, 0.6]),
        ];
        let mut with_beta = kfs.clone();
        with_beta[1].beta = Some(Vector3::new(0.45, 0.1, -0.2));
        for (clock, kfs) in [
            (Clock::World, kfs.clone()),
            (Clock::Proper, kfs.clone()),
            (Clock::World, with_beta.clone()),
            (Clock::Proper, with_beta),
        ] {
            let motion = keyframes(clock, Interpolation::Cubic, kfs);
            let probe = CameraPath::new(spec(1, 1.0), None, None, motion.clone(), "t").unwrap();
            let (tau_a, tau_b) = match &probe.resolved {
                Resolved::Keyframes(k) => k.tau_span(),
                Resolved::Orbit(_) => unreachable!(),
            };
            let n = 4000;
            let dtau = (tau_b - tau_a) / n as f64;
            let path = CameraPath::new(spec(n + 1, dtau), None, None, motion, "t").unwrap();
            let mut t_sum = path.frame(0).t_world_ps;
            let mut max_speed: f64 = 0.0;
            for k in 0..n {
                let (a, b) = (path.frame(k), path.frame(k + 1));
                // Trapezoid rule on dt = gamma dtau with the frames' own speeds.
                t_sum += 0.5 * (a.gamma() + b.gamma()) * dtau;
                let dt = b.t_world_ps - a.t_world_ps;
                let v = (b.position_m - a.position_m) / (C_M_PER_PS * dt);
                let mid = 0.5 * (a.beta + b.beta);
                // (Loose enough for steps across a keyframe, where the cubic's acceleration
                // jumps; a proper velocity mistaken for beta would be off by gamma ~ 1.1.)
                assert!(
                    (v - mid).norm() < 1e-3,
                    "{clock:?} frame {k}: dx/dt/c {v:?} vs beta {mid:?}"
                );
                max_speed = max_speed.max(a.beta.norm());
            }
            let t_end = path.frame(n).t_world_ps;
            assert!(
                (t_sum - t_end).abs() < 1e-5 * t_end,
                "{clock:?}: integrated {t_sum} vs reported {t_end}"
            );
            assert!(max_speed > 0.1 && max_speed < 1.0);
        }
    }

    #[test]
    fn derived_speed_at_0_99_passes_and_1_01_fails_naming_the_keyframes() {
        let t = 2000.0;
        let make = |beta: f64| {
            keyframes(
                Clock::World,
                Interpolation::Cubic,
                vec![
                    kf(0.0, [0.0, 0.0, 0.0]),
                    kf(t, [0.0, 0.0, 0.0]),
                    kf(2.0 * t, [beta * C_M_PER_PS * t, 0.0, 0.0]),
                ],
            )
        };
        let ok = CameraPath::new(spec(10, 10.0), None, None, make(0.99), "p.toml");
        // Catmull-Rom overshoots on the uneven middle keyframe: use linear for the 0.99 case.
        let linear = |beta: f64| {
            keyframes(
                Clock::World,
                Interpolation::Linear,
                vec![
                    kf(0.0, [0.0, 0.0, 0.0]),
                    kf(t, [0.0, 0.0, 0.0]),
                    kf(2.0 * t, [beta * C_M_PER_PS * t, 0.0, 0.0]),
                ],
            )
        };
        let passes = CameraPath::new(spec(10, 10.0), None, None, linear(0.99), "p.toml");
        assert!(passes.is_ok(), "{:?}", passes.err());
        let fails = CameraPath::new(spec(10, 10.0), None, None, linear(1.01), "p.toml")
            .unwrap_err()
            .to_string();
        assert!(
            fails.contains("p.toml")
                && fails.contains("keyframe 2 of 3")
                && fails.contains("keyframe 3 of 3")
                && fails.contains("1.01"),
            "{fails}"
        );
        // The cubic version of the 0.99 path exceeds c between keyframes 2 and 3 (the tangent
        // at keyframe 2 is the average, the spline speeds up past 0.99): caught too.
        let e = ok.unwrap_err().to_string();
        assert!(
            e.contains("keyframe 2 of 3") && e.contains("speed of light"),
            "{e}"
        );
        // A given keyframe beta above 1 names that keyframe.
        let mut kfs = vec![kf(0.0, [0.0; 3]), kf(t, [0.1, 0.0, 0.0])];
        kfs[1].beta = Some(Vector3::new(0.0, 1.2, 0.0));
        let e = CameraPath::new(
            spec(2, 1.0),
            None,
            None,
            keyframes(Clock::Proper, Interpolation::Cubic, kfs),
            "q",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("keyframe 2 of 2") && e.contains("1.2"), "{e}");
        // A proper-time path can cover any distance: beta = u / sqrt(1 + u^2) < 1.
        let far = keyframes(
            Clock::Proper,
            Interpolation::Linear,
            vec![kf(0.0, [0.0; 3]), kf(t, [3.0 * C_M_PER_PS * t, 0.0, 0.0])],
        );
        let p = CameraPath::new(spec(5, 100.0), None, None, far, "r").unwrap();
        let b = p.frame(2).beta.norm();
        assert!((b - 3.0 / 10f64.sqrt()).abs() < 1e-12, "{b}");
        assert!((p.frame(4).t_world_ps - 10f64.sqrt() * 400.0).abs() < 1e-9);
    }

    #[test]
    fn validation_errors_name_the_field() {
        let two = || vec![kf(0.0, [0.0; 3]), kf(1000.0, [0.01, 0.0, 0.0])];
        let new = |s: FrameSpec, kfs: Vec<Keyframe>| {
            CameraPath::new(
                s,
                None,
                None,
                keyframes(Clock::World, Interpolation::Cubic, kfs),
                "v.toml",
            )
            .map(|_| ())
            .unwrap_err()
            .to_string()
        };
        assert!(new(spec(0, 1.0), two()).contains("frames = 0"));
        let mut s = spec(3, 1.0);
        s.width = 0;
        assert!(new(s, two()).contains("width"));
        assert!(new(spec(3, -1.0), two()).contains("dtau_ps"));
        let mut kfs = two();
        kfs[1].time_ps = 0.0;
        let e = new(spec(3, 1.0), kfs);
        assert!(
            e.contains("keyframe 2 of 2") && e.contains("does not increase"),
            "{e}"
        );
        let mut kfs = two();
        kfs[0].vfov_deg = 180.0;
        assert!(new(spec(3, 1.0), kfs).contains("keyframe 1 of 2: vfov_deg"));
        // Frames must stay within the keyframes' span.
        let e = new(spec(2000, 1.0), two());
        assert!(e.contains("outside the keyframes' span"), "{e}");
        // Odd frame sizes are fine here (even sizes are the video encoder's concern).
        let mut odd = spec(3, 1.0);
        odd.width = 63;
        odd.height = 47;
        assert!(CameraPath::new(
            odd,
            None,
            None,
            keyframes(Clock::World, Interpolation::Cubic, two()),
            "v"
        )
        .is_ok());
        let rot = Some(SensorRotation {
            axis: RotationAxis::Roll,
            beta_edge: 1.0,
        });
        let e = CameraPath::new(
            spec(3, 1.0),
            None,
            rot,
            keyframes(Clock::World, Interpolation::Cubic, two()),
            "v",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("rotation.beta_edge"), "{e}");
    }

    #[test]
    fn orientation_is_slerped_and_fov_interpolated() {
        let mut a = kf(0.0, [0.0; 3]);
        a.orientation = Orientation::Fixed(Rotation3::identity());
        a.vfov_deg = 30.0;
        let mut b = kf(1000.0, [0.0; 3]);
        b.orientation = Orientation::Fixed(Rotation3::from_axis_angle(&Vector3::y_axis(), 1.2));
        b.vfov_deg = 50.0;
        let path = CameraPath::new(
            spec(3, 500.0),
            None,
            None,
            keyframes(Clock::Proper, Interpolation::Cubic, vec![a, b]),
            "o",
        )
        .unwrap();
        let mid = path.frame(1);
        let expect = Rotation3::from_axis_angle(&Vector3::y_axis(), 0.6);
        assert!(
            (mid.world_from_camera.matrix() - expect.matrix())
                .abs()
                .max()
                < 1e-12
        );
        assert!((mid.vfov_deg - 40.0).abs() < 1e-12);
        assert_eq!(mid.beta, Vector3::zeros());
        assert!((mid.t_world_ps - 500.0).abs() < 1e-9);
    }

    #[test]
    fn orbit_keeps_radius_and_speed_and_dilates_time() {
        let centre = Point3::new(0.1, 0.3, -0.2);
        let beta = 0.7;
        let path =
            CameraPath::orbit(centre, 2.0, beta, Vector3::y(), 35.0, spec(30, 200.0)).unwrap();
        let g = gamma(beta);
        for k in 0..30 {
            let f = path.frame(k);
            assert!((f.t_world_ps - g * f.tau_ps).abs() < 1e-9 * (1.0 + f.t_world_ps));
            let r = f.position_m - centre;
            assert!((r.norm() - 2.0).abs() < 1e-12 && r.y.abs() < 1e-12);
            assert!((f.beta.norm() - beta).abs() < 1e-12 && f.beta.dot(&r).abs() < 1e-12);
            assert!((f.pose().forward() + r / 2.0).norm() < 1e-12);
            if k + 1 < 30 {
                // Velocity is the derivative of position in world time (finite difference
                // over a short step).
                let h = 1e-3;
                let later = path.at_proper_time(f.tau_ps + h);
                let v = (later.position_m - f.position_m) / (C_M_PER_PS * g * h);
                assert!((v - f.beta).norm() < 1e-6, "{v:?} vs {:?}", f.beta);
            }
        }
        // Frame 0 starts on the +z side (e1 = +z for a y axis) and turns towards +x.
        let f0 = path.frame(0);
        assert!((f0.position_m - (centre + Vector3::new(0.0, 0.0, 2.0))).norm() < 1e-12);
        assert!(f0.beta.x > 0.0);
        assert!(CameraPath::orbit(centre, 2.0, 1.0, Vector3::y(), 35.0, spec(3, 1.0)).is_err());
    }

    #[test]
    fn static_view_and_sample_positions() {
        let pose =
            Pose::look_at(Point3::new(1.0, 2.0, 3.0), Point3::origin(), Vector3::y()).unwrap();
        let path = CameraPath::static_view(&pose, 45.0, spec(5, 2.0)).unwrap();
        for k in 0..5 {
            let f = path.frame(k);
            assert_eq!(f.position_m, pose.position_m);
            let diff = f.world_from_camera.matrix() - pose.world_from_camera.matrix();
            assert!(diff.abs().max() < 1e-12);
            assert_eq!(f.beta, Vector3::zeros());
            assert!((f.t_world_ps - 2.0 * k as f64).abs() < 1e-12);
        }
        let dolly = CameraPath::dolly(
            Point3::new(0.0, 0.0, 5.0),
            Point3::origin(),
            Vector3::y(),
            0.5,
            40.0,
            spec(11, 10.0),
        )
        .unwrap();
        let s = dolly.sample_positions(21);
        assert_eq!(s.len(), 21);
        assert!((s[0] - dolly.frame(0).position_m).norm() < 1e-12);
        assert!((s[20] - dolly.frame(10).position_m).norm() < 1e-12);
        assert!((s[10] - dolly.frame(5).position_m).norm() < 1e-12);
        assert!(dolly.sample_positions(0).is_empty());
    }

    #[test]
    fn pixel_velocity_combines_path_and_sensor_rotation() {
        let half = Vector2::new(32.0, 24.0);
        let corner = Vector2::new(32.0, 24.0);
        let dolly = CameraPath::dolly(
            Point3::new(0.0, 0.0, 5.0),
            Point3::origin(),
            Vector3::y(),
            0.6,
            40.0,
            spec(3, 10.0),
        )
        .unwrap();
        let f = dolly.frame(1);
        assert_eq!(f.pixel_beta(&corner, &half), f.beta);
        let spinning = dolly
            .with_rotation(Some(SensorRotation {
                axis: RotationAxis::Roll,
                beta_edge: 0.9,
            }))
            .unwrap();
        let f = spinning.frame(1);
        // On the axis the pixel moves with the camera.
        assert!((f.pixel_beta(&Vector2::zeros(), &half) - f.beta).norm() < 1e-15);
        // At the corner: the roll velocity is perpendicular to the dolly's (along the optical
        // axis), so the speeds combine as gamma_total = gamma_path * gamma_spin.
        let b = f.pixel_beta(&corner, &half);
        let expect = gamma(0.6) * gamma(0.9);
        assert!((gamma(b.norm()) - expect).abs() < 1e-9 * expect, "{b:?}");
        assert!(b.norm() < 1.0);
    }

    fn example_toml() -> String {
        r#"width = 65
height = 49
frames = 12
dtau_ps = 40.0
clock = "world"
interpolation = "cubic"

[rotation]
axis = "yaw"
beta_edge = 0.3

[[keyframe]]
time_ps = 0.0
position_m = [0.0, 0.5, 3.0]
look_at_m = [0.0, 0.3, 0.0]
vfov_deg = 40.0
beta = [0.0, 0.0, -0.4]

[[keyframe]]
time_ps = 300.0
position_m = [0.01, 0.5, 2.97]
world_from_camera = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]
vfov_deg = 45.0

[[keyframe]]
time_ps = 600.0
position_m = [0.03, 0.52, 2.94]
look_at_m = [0.0, 0.3, 0.0]
up = [0.0, 1.0, 0.1]
vfov_deg = 45.0
"#
        .to_string()
    }

    fn assert_same_frames(a: &CameraPath, b: &CameraPath) {
        assert_eq!(a.spec(), b.spec());
        assert_eq!(a.rotation(), b.rotation());
        for k in 0..a.spec().frames {
            let (fa, fb) = (a.frame(k), b.frame(k));
            assert!((fa.position_m - fb.position_m).norm() < 1e-12);
            assert!((fa.t_world_ps - fb.t_world_ps).abs() < 1e-9);
            assert!((fa.beta - fb.beta).norm() < 1e-12);
            assert!(
                (fa.world_from_camera.matrix() - fb.world_from_camera.matrix())
                    .abs()
                    .max()
                    < 1e-12
            );
            assert_eq!(fa.vfov_deg, fb.vfov_deg);
        }
    }

    #[test]
    fn toml_round_trip() {
        let path = CameraPath::from_toml(&example_toml(), "path.toml").unwrap();
        assert_eq!(path.spec().width, 65);
        assert_eq!(
            path.rotation(),
            Some(SensorRotation {
                axis: RotationAxis::Yaw,
                beta_edge: 0.3
            })
        );
        let back = CameraPath::from_toml(&path.to_toml(), "again.toml").unwrap();
        assert_same_frames(&path, &back);
        let orbit = CameraPath::orbit(
            Point3::origin(),
            1.5,
            -0.3,
            Vector3::z(),
            30.0,
            spec(7, 9.0),
        )
        .unwrap();
        let back = CameraPath::from_toml(&orbit.to_toml(), "orbit.toml").unwrap();
        assert_same_frames(&orbit, &back);
        let dolly = CameraPath::dolly(
            Point3::new(0.0, 0.0, 5.0),
            Point3::origin(),
            Vector3::y(),
            0.5,
            40.0,
            spec(11, 10.0),
        )
        .unwrap();
        let back = CameraPath::from_toml(&dolly.to_toml(), "dolly.toml").unwrap();
        assert_same_frames(&dolly, &back);
    }

    fn orbit_toml() -> String {
        r#"width = 32
height = 24
frames = 6
dtau_ps = 20.0
tau0_ps = 2000.0

[orbit]
centre_m = [0.0, 0.03, 0.0]
axis = [0.0, 1.0, 0.0]
height_m = 0.2
radius_m = 0.5
start_angle_deg = -41.8
beta = 0.3
look_at_m = [0.16, 0.05, 0.07]
vfov_deg = 40.0
"#
        .to_string()
    }

    /// Every number of both path kinds, made non-finite (or too far), is refused naming the
    /// keyframe and the key (issue 16: `look_at_m = [0, -inf, 0]` reached the BVH).
    #[test]
    fn every_number_must_be_finite_and_the_message_names_its_key() {
        let key = example_toml();
        let orbit = orbit_toml();
        assert!(CameraPath::from_toml(&orbit, "o.toml").is_ok());
        let cases: &[(&String, &str, &str, &str)] = &[
            (
                &key,
                "look_at_m = [0.0, 0.3, 0.0]",
                "look_at_m = [0.0, -inf, 0.0]",
                "keyframe 1 of 3: look_at_m[1] must be finite, got -inf",
            ),
            (
                &key,
                "position_m = [0.01, 0.5, 2.97]",
                "position_m = [0.01, nan, 2.97]",
                "keyframe 2 of 3: position_m[1] must be finite, got NaN",
            ),
            (
                &key,
                "position_m = [0.0, 0.5, 3.0]",
                "position_m = [1e39, 0.5, 3.0]",
                "keyframe 1 of 3: position_m[0] = 1e39 m is beyond",
            ),
            (
                &key,
                "up = [0.0, 1.0, 0.1]",
                "up = [0.0, inf, 0.1]",
                "keyframe 3 of 3: up[1] must be finite, got inf",
            ),
            (
                &key,
                "time_ps = 300.0",
                "time_ps = nan",
                "keyframe 2 of 3: time_ps must be finite, got NaN",
            ),
            (
                &key,
                "vfov_deg = 40.0",
                "vfov_deg = inf",
                "keyframe 1 of 3: vfov_deg must be finite, got inf",
            ),
            (
                &key,
                "beta = [0.0, 0.0, -0.4]",
                "beta = [0.0, 0.0, -inf]",
                "keyframe 1 of 3: beta[2] must be finite, got -inf",
            ),
            (
                &key,
                "[[1.0, 0.0, 0.0], [0.0, -1.0",
                "[[1.0, 0.0, 0.0], [0.0, nan",
                "keyframe 2 of 3: world_from_camera[1][1] must be finite, got NaN",
            ),
            (&key, "dtau_ps = 40.0", "dtau_ps = inf", "dtau_ps = inf"),
            (
                &key,
                "beta_edge = 0.3",
                "beta_edge = nan",
                "rotation.beta_edge = NaN",
            ),
            (
                &key,
                "dtau_ps = 40.0",
                "dtau_ps = 40.0\ntau0_ps = -inf",
                "tau0_ps = -inf",
            ),
            (
                &orbit,
                "centre_m = [0.0, 0.03, 0.0]",
                "centre_m = [0.0, 0.03, nan]",
                "orbit.centre_m[2] must be finite, got NaN",
            ),
            (
                &orbit,
                "look_at_m = [0.16, 0.05, 0.07]",
                "look_at_m = [0.0, -inf, 0.0]",
                "orbit.look_at_m[1] must be finite, got -inf",
            ),
            (
                &orbit,
                "axis = [0.0, 1.0, 0.0]",
                "axis = [0.0, inf, 0.0]",
                "orbit.axis[1] must be finite, got inf",
            ),
            (
                &orbit,
                "height_m = 0.2",
                "height_m = -inf",
                "orbit.height_m must be finite",
            ),
            (
                &orbit,
                "radius_m = 0.5",
                "radius_m = 1e300",
                "orbit.radius_m = 1e300 m is beyond",
            ),
            (
                &orbit,
                "start_angle_deg = -41.8",
                "start_angle_deg = nan",
                "orbit.start_angle_deg must be finite, got NaN",
            ),
            (
                &orbit,
                "beta = 0.3",
                "beta = inf",
                "orbit.beta must be finite, got inf",
            ),
            (
                &orbit,
                "vfov_deg = 40.0",
                "vfov_deg = -inf",
                "orbit.vfov_deg must be finite",
            ),
            (
                &orbit,
                "tau0_ps = 2000.0",
                "tau0_ps = nan",
                "tau0_ps = NaN is not a finite",
            ),
        ];
        for (text, from, to, want) in cases {
            assert!(text.contains(from), "{from}");
            let edited = text.replacen(from, to, 1);
            let e = CameraPath::from_toml(&edited, "p.toml")
                .map(|_| ())
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("p.toml: ") && e.contains(want), "{to}: {e}");
            assert_eq!(e.lines().count(), 1, "{e}");
        }
    }

    /// The frame count is capped before the frames are walked: a count of 2^64 - 1 is refused
    /// at once instead of checking frames for ever (issue 16).
    #[test]
    fn frame_counts_are_capped_before_the_walk() {
        let started = std::time::Instant::now();
        let text = orbit_toml().replace("frames = 6", "frames = 18446744073709551615");
        let e = CameraPath::from_toml(&text, "p.toml")
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(e.contains("frames") && e.contains("1000000"), "{e}");
        assert!(started.elapsed().as_secs_f64() < 1.0);
        let at_cap = CameraPath::orbit(
            Point3::origin(),
            1.0,
            0.1,
            Vector3::y(),
            40.0,
            spec(MAX_FRAMES + 1, 1.0),
        );
        assert!(at_cap.is_err());
    }

    #[test]
    fn toml_errors_give_line_and_key() {
        let text = example_toml().replace("vfov_deg = 45.0\n\n", "vfov_deg = 45.0\nzoom = 2\n\n");
        let line = text.lines().position(|l| l.starts_with("zoom")).unwrap() + 1;
        let e = CameraPath::from_toml(&text, "path.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("path.toml") && e.contains(&format!("line {line}")) && e.contains("zoom"),
            "{e}"
        );
        let e = CameraPath::from_toml(&example_toml().replace("clock = \"world\"\n", ""), "p")
            .unwrap_err()
            .to_string();
        assert!(e.contains("clock is missing"), "{e}");
        let e = CameraPath::from_toml(&example_toml().replace("\"yaw\"", "\"spin\""), "p")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 9"), "{e}");
        let e = CameraPath::from_toml(
            &example_toml().replace(
                "look_at_m = [0.0, 0.3, 0.0]\nvfov_deg = 40.0",
                "vfov_deg = 40.0",
            ),
            "p",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("keyframe 1 of 3") && e.contains("look_at_m"),
            "{e}"
        );
    }
}

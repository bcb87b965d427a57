//! Camera paths for the common cases, derived from the capture camera and the scene: a
//! straight dolly towards the scene at constant speed, an orbit about it, and the capture
//! camera's own view (the command line's `--dolly`, `--orbit` and `--capture-view`).
//!
//! Each starts at the capture camera's position and keeps the **target** in the centre of the
//! image: the first hit of the capture camera's optical axis with the mesh (the centre of the
//! mesh's bounds when the axis misses).
//! - The dolly moves along its line of sight, which aberration leaves in place.
//! - The orbit circles the target in the plane through the capture camera perpendicular to
//!   its up direction, at constant speed. The target lies at 90 degrees from the velocity in
//!   the world frame, so aberration shows it at `acos(beta)` from the velocity in the camera's
//!   frame (physics.md: `cos theta' = (cos theta_w + beta) / (1 + beta cos theta_w)`), that
//!   is `asin(beta)` ahead of where it lies. A camera looking at the target itself would see
//!   it leave the frame above `beta` of about 0.35 for a 40 degree field of view; the orbit
//!   camera therefore looks along the target's aberrated direction (at rest: the target). The
//!   path is a proper-time keyframe path with one keyframe per frame (position on the circle,
//!   world velocity, that orientation).
//!
//! Unless given, the frame interval is chosen so that the frames sweep the cube's world-time
//! span at the target, and the time offset so that frame 0 shows the target at the start of
//! the cube's span. The target's emission time advances at `1 / D` per unit proper time, `D`
//! the Doppler factor of the image centre (physics.md), so `dtau = D * span / (frames - 1)`:
//! - dolly at `beta` (positive towards the target): `D = gamma (1 - beta)`;
//! - orbit at `beta`: the target is perpendicular to the velocity in the world,
//!   `D = 1 / (gamma (1 + beta cos 90)) = 1 / gamma` (its distance stays constant and only
//!   time dilation remains);
//! - capture view (at rest): `D = 1`.
//!
//! The time offset is `t_start + eta r0 / c`, `r0` the distance from the capture camera to the
//! target: the world time at which light that left the target at the cube's first time
//! reaches the start position.

use super::{RenderError, RenderScene};
use crate::camera::Pose;
use crate::camera_path::{
    CameraPath, Clock, FrameSpec, Interpolation, Keyframe, Motion, Orientation,
};
use crate::geometry::Ray;
use crate::relativity::{gamma, Boost};
use crate::units::{flight_time_ps, C_M_PER_PS};
use nalgebra::{Point3, Vector3};

/// A command-line camera shortcut.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shortcut {
    /// Straight towards the target at constant `beta` (negative: backing away).
    Dolly { beta: f64 },
    /// A circle about the target, in the plane through the capture camera perpendicular to
    /// its up direction, at constant signed `beta` (positive: counter-clockwise seen from
    /// above), looking along the target's aberrated direction.
    Orbit { beta: f64 },
    /// The capture camera's own pose and field of view, at rest.
    CaptureView,
}

/// A shortcut's path and the time offset that goes with it
/// ([`super::RenderSettings::time_offset_ps`]).
#[derive(Clone, Debug)]
pub struct ShortcutPath {
    pub path: CameraPath,
    pub time_offset_ps: f64,
    /// The point the camera looks at, world metres.
    pub target_m: Point3<f64>,
}

/// The point the shortcuts look at: the capture camera's optical axis hit, else the centre of
/// the mesh's bounds.
pub fn scene_target(scene: &RenderScene) -> Point3<f64> {
    let k = &scene.capture.intrinsics;
    let o = scene.capture.pose.position_m;
    let d = scene.capture.world_ray(k.cx, k.cy);
    let ray = Ray::new(
        Point3::new(o.x as f32, o.y as f32, o.z as f32),
        Vector3::new(d.x as f32, d.y as f32, d.z as f32),
    );
    match scene.bvh.intersect(&ray, 0.0, f32::INFINITY) {
        Some(hit) => o + d.into_inner() * hit.t as f64,
        None => {
            let b = scene.bvh.bounds();
            Point3::new(
                0.5 * (b.min.x + b.max.x) as f64,
                0.5 * (b.min.y + b.max.y) as f64,
                0.5 * (b.min.z + b.max.z) as f64,
            )
        }
    }
}

/// The path of a shortcut with `frames` frames of `width x height`, frame interval
/// `dtau_ps` (None: chosen as in the module doc).
pub fn shortcut_path(
    scene: &RenderScene,
    shortcut: Shortcut,
    width: usize,
    height: usize,
    frames: usize,
    dtau_ps: Option<f64>,
) -> Result<ShortcutPath, RenderError> {
    let cal = &scene.capture;
    let start = cal.pose.position_m;
    let target = scene_target(scene);
    let r0_m = (target - start).norm();
    let up = cal.pose.world_from_camera * Vector3::new(0.0, -1.0, 0.0);
    let vfov_deg = 2.0
        * (0.5 * cal.intrinsics.height as f64 / cal.intrinsics.fy)
            .atan()
            .to_degrees();
    let (t_a, t_b) = scene.world_span_ps();
    let span_ps = t_b - t_a;
    let steps = frames.saturating_sub(1).max(1) as f64;
    let doppler_centre = match shortcut {
        Shortcut::Dolly { beta } => gamma(beta) * (1.0 - beta),
        Shortcut::Orbit { beta } => 1.0 / gamma(beta),
        Shortcut::CaptureView => 1.0,
    };
    let dtau_ps = dtau_ps.unwrap_or(doppler_centre * span_ps / steps);
    let spec = FrameSpec {
        width,
        height,
        frames,
        dtau_ps,
    };
    let path = match shortcut {
        Shortcut::Dolly { beta } => CameraPath::dolly(start, target, up, beta, vfov_deg, spec)?,
        Shortcut::CaptureView => CameraPath::static_view(&cal.pose, vfov_deg, spec)?,
        Shortcut::Orbit { beta } => orbit_path(target, start, up, beta, vfov_deg, spec)?,
    };
    Ok(ShortcutPath {
        path,
        time_offset_ps: t_a + flight_time_ps(cal.eta, r0_m),
        target_m: target,
    })
}

/// The orbit of [`Shortcut::Orbit`]: keyframes at proper times `k dtau` for frames
/// `0 ..= frames` on the circle about `target` through `start` (axis `up`), each with its
/// world velocity and an orientation looking along the target's aberrated direction.
fn orbit_path(
    target: Point3<f64>,
    start: Point3<f64>,
    up: Vector3<f64>,
    beta: f64,
    vfov_deg: f64,
    spec: FrameSpec,
) -> Result<CameraPath, RenderError> {
    if !(beta.is_finite() && beta.abs() < 1.0) {
        return Err(RenderError::Setting {
            name: "orbit",
            message: format!("beta = {beta}: the camera must move slower than light (|beta| < 1)"),
        });
    }
    let rel = start - target;
    let height_m = rel.dot(&up);
    let radial = rel - up * height_m;
    let radius_m = radial.norm();
    if radius_m <= 1e-9 {
        return Err(RenderError::Setting {
            name: "orbit",
            message: "the capture camera lies on the vertical axis through the target, so there is no circle to orbit on".into(),
        });
    }
    let e1 = radial / radius_m;
    let e2 = up.cross(&e1);
    let centre = target + up * height_m;
    // Angular speed in radians per ps of world time; world time = gamma * proper time.
    let omega = beta * C_M_PER_PS / radius_m;
    let g = gamma(beta);
    let mut keyframes = Vec::with_capacity(spec.frames + 1);
    for k in 0..=spec.frames {
        let tau_ps = k as f64 * spec.dtau_ps;
        let phi = omega * g * tau_ps;
        let (sin, cos) = phi.sin_cos();
        let position_m = centre + (e1 * cos + e2 * sin) * radius_m;
        let velocity = (e2 * cos - e1 * sin) * beta;
        let to_target = (target - position_m).normalize();
        let apparent = Boost::new(velocity)
            .map_err(|e| RenderError::Setting {
                name: "orbit",
                message: e.to_string(),
            })?
            .inverse()
            .aberrate(&to_target);
        let pose = Pose::look_at(position_m, position_m + apparent, up).ok_or_else(|| {
            RenderError::Setting {
                name: "orbit",
                message: "the view direction is along the up direction".into(),
            }
        })?;
        keyframes.push(Keyframe {
            time_ps: tau_ps,
            position_m,
            orientation: Orientation::Fixed(pose.world_from_camera),
            vfov_deg,
            beta: Some(velocity),
        });
    }
    Ok(CameraPath::new(
        spec,
        Some(0.0),
        None,
        Motion::Keyframes {
            clock: Clock::Proper,
            interpolation: Interpolation::Cubic,
            keyframes,
        },
        "orbit",
    )?)
}

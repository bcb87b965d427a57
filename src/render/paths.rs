//! Camera paths for the common cases, derived from the capture camera and the scene: a
//! straight dolly towards the scene at constant speed, an orbit about it, and the capture
//! camera's own view (the command line's `--dolly`, `--orbit` and `--capture-view`).
//!
//! Each starts at the capture camera's position and looks at the **target**: the first hit
//! of the capture camera's optical axis with the mesh (the centre of the mesh's bounds when
//! the axis misses). Unless given, the frame interval is chosen so that the frames sweep the
//! cube's world-time span at the target, and the time offset so that frame 0 shows the
//! target at the start of the cube's span:
//! - dolly at `beta` (positive towards the target): the target's emission time advances at
//!   `1 / D` per unit proper time with `D = gamma (1 - beta)` (physics.md), so
//!   `dtau = D * span / (frames - 1)`;
//! - orbit at `beta`: the optical axis is perpendicular to the velocity, `D = gamma`, so
//!   `dtau = span / (gamma (frames - 1))`;
//! - capture view (at rest): `dtau = span / (frames - 1)`.
//!
//! The time offset is `t_start + eta r0 / c`, `r0` the distance from the capture camera to the
//! target: the world time at which light that left the target at the cube's first time
//! reaches the start position.

use super::{RenderError, RenderScene};
use crate::camera_path::{CameraPath, FrameSpec, Motion, Orbit};
use crate::geometry::Ray;
use crate::relativity::gamma;
use crate::units::flight_time_ps;
use nalgebra::{Point3, Vector3};

/// A command-line camera shortcut.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shortcut {
    /// Straight towards the target at constant `beta` (negative: backing away).
    Dolly { beta: f64 },
    /// A circle about the target, in the plane through the capture camera perpendicular to
    /// its up direction, at constant signed `beta` (positive: counter-clockwise seen from
    /// above).
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
    let vfov_deg = 2.0 * (0.5 * cal.intrinsics.height as f64 / cal.intrinsics.fy).atan().to_degrees();
    let (t_a, t_b) = scene.world_span_ps();
    let span_ps = t_b - t_a;
    let steps = frames.saturating_sub(1).max(1) as f64;
    let doppler_centre = match shortcut {
        Shortcut::Dolly { beta } => gamma(beta) * (1.0 - beta),
        Shortcut::Orbit { beta } => gamma(beta),
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
        Shortcut::Orbit { beta } => {
            let rel = start - target;
            let along = rel.dot(&up);
            let radial = rel - up * along;
            let radius_m = radial.norm();
            if radius_m <= 1e-9 {
                return Err(RenderError::Setting {
                    name: "orbit",
                    message: "the capture camera lies on the vertical axis through the target, so there is no circle to orbit on".into(),
                });
            }
            let orbit = |start_angle_deg: f64| Orbit {
                centre_m: target,
                axis: up,
                radius_m,
                height_m: along,
                start_angle_deg,
                beta,
                look_at_m: target,
                vfov_deg,
            };
            // Angle 0 is the path's own reference direction: read it back and turn to the
            // capture camera's position.
            let probe = CameraPath::new(spec, Some(0.0), None, Motion::Orbit(orbit(0.0)), "orbit")?;
            let a = probe.frame(0).position_m - (target + up * along);
            let angle = up.dot(&a.cross(&radial)).atan2(a.dot(&radial));
            CameraPath::new(
                spec,
                Some(0.0),
                None,
                Motion::Orbit(orbit(angle.to_degrees())),
                "orbit",
            )?
        }
    };
    Ok(ShortcutPath {
        path,
        time_offset_ps: t_a + flight_time_ps(cal.eta, r0_m),
        target_m: target,
    })
}

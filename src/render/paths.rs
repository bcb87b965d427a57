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
//! # Times
//!
//! Unless given, the time offset and the frame interval are chosen so that every frame looks
//! at light (issue 15). The light a frame can show is [`LightProfile::in_frame`]: for each
//! of its pixels (probed with the renderer's own mapping) the signal of the cube pixel it
//! shows, delayed by the flight time from the point to the camera, summed: the reception
//! times at which light reaches the frame's camera from what it looks at. With `L` one
//! percent ([`LIGHT_FRACTION`]) of frame 0's peak per pixel:
//! - the time offset is the first reception time at which frame 0's light exceeds `L`
//!   (frame 0 is at the capture camera, at proper time 0);
//! - the `n` frames receive during `[offset, offset + gamma n dtau]` (world time advances at
//!   `gamma` per unit proper time, and each frame's exposure is `dtau`), and `dtau` is the
//!   largest found (to 0.1 %) for which that interval ends no later than the last time at
//!   which the **last** frame's light, from where that frame is, exceeds `L`;
//! - a dolly towards the target stops [`DOLLY_MAX_APPROACH`] (three quarters) of the way
//!   there: when the light lasts longer than that, the frames show its first part.
//!
//! For a dolly this is close to the rule it replaces, `dtau = D span / frames` with `D` the
//! Doppler factor of the image centre (`gamma (1 - beta)`; the orbit's `1 / gamma`; 1 at
//! rest), but `span` is now where light reaches the camera, not the cube's whole axis. The
//! whole axis, with the offset putting the target at its start, remains the rule for a cube
//! in which the first frame sees no light at all. The old rule's `span` was mostly empty: the
//! unwarp's covering axis spans the union of every pixel's recording window shifted by its
//! distance (see [`super::coverage`]), so with the built-in `cube` scene's realistic capture
//! at 160 x 120 (camera window 3200..4224 ps, world axis -108..2000 ps) the default `--dolly
//! 0.5` rendered 48 all-black frames of 100 (0..23 and 76..99), `--orbit 0.5` 39,
//! `--dolly -0.5` 47, `--capture-view` 50, `--dolly 0.9` 48, `--orbit -0.8` 30 (the same on
//! the demo's dark-subtracted cube). With this rule none of the 100 frames is black for any
//! of them, nor for `--dolly 0.99`, on either cube, at 160 x 120, 320 x 240 and 640 x 480;
//! choosing the times takes 16-160 ms (about 10 light profiles of the last frame).
//!
//! Frames between the first and the last can still be dark where the light the camera looks
//! at has a gap in time: single-bounce light alone, seen from far round an orbit (`--orbit
//! -0.8` over 11 ns of a 4 m scene), left 2 of 24 frames black in a test.

use super::coverage::{LightProfile, LIGHT_FRACTION};
use super::{RenderError, RenderScene, RenderSettings};
use crate::camera::Pose;
use crate::camera_path::{
    CameraPath, Clock, FrameSpec, Interpolation, Keyframe, Motion, Orientation,
};
use crate::geometry::Ray;
use crate::relativity::{gamma, Boost};
use crate::units::{flight_time_ps, C_M_PER_PS};
use nalgebra::{Point3, Vector3};

/// The largest part of its distance to the target that a dolly towards it covers when its
/// frame interval is chosen by [`shortcut_path`]: it stops a quarter of the way short.
pub const DOLLY_MAX_APPROACH: f64 = 0.75;

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
/// `dtau_ps` (None: chosen as in the module doc, "Times"), and its time offset (likewise).
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
    let beta = match shortcut {
        Shortcut::Dolly { beta } | Shortcut::Orbit { beta } => beta,
        Shortcut::CaptureView => 0.0,
    };
    if cal.eta != 1.0 {
        let name = match shortcut {
            Shortcut::Orbit { .. } => "orbit",
            _ => "dolly",
        };
        crate::relativity::medium::check_speed(beta.abs(), cal.eta).map_err(|message| {
            RenderError::Setting {
                name,
                message: format!("{message} (eta from the calibration)"),
            }
        })?;
    }
    let build = |dtau_ps: f64| -> Result<CameraPath, RenderError> {
        let spec = FrameSpec {
            width,
            height,
            frames,
            dtau_ps,
        };
        Ok(match shortcut {
            Shortcut::Dolly { beta } => CameraPath::dolly(start, target, up, beta, vfov_deg, spec)?,
            Shortcut::CaptureView => CameraPath::static_view(&cal.pose, vfov_deg, spec)?,
            Shortcut::Orbit { beta } => {
                orbit_path(target, start, up, beta, vfov_deg, cal.eta, spec)?
            }
        })
    };
    // The light a frame's pixels look at, as its camera receives it.
    let light_seen = |path: &CameraPath, k: usize| {
        let settings = RenderSettings::for_path(path);
        LightProfile::in_frame(scene, &settings, &path.frame(k))
    };
    // Frame 0 (at the capture camera, proper time 0) does not depend on the frame interval
    // (a tiny one keeps any number of frames short of the target); its peak sets the level
    // of light for every frame. Building the path first checks beta.
    let profile0 = light_seen(&build(1e-6)?, 0);
    let level = LIGHT_FRACTION * profile0.peak_per_pixel();
    let Some(first) = profile0.span_above(level) else {
        // No light in view: the cube's whole axis at the target, as received at the start.
        let (t_a, t_b) = scene.world_span_ps();
        let doppler_centre = match shortcut {
            Shortcut::Dolly { beta } => gamma(beta) * (1.0 - beta),
            Shortcut::Orbit { beta } => 1.0 / gamma(beta),
            Shortcut::CaptureView => 1.0,
        };
        let dtau_ps = dtau_ps.unwrap_or(doppler_centre * (t_b - t_a) / frames.max(1) as f64);
        return Ok(ShortcutPath {
            path: build(dtau_ps)?,
            time_offset_ps: t_a + flight_time_ps(cal.eta, r0_m),
            target_m: target,
        });
    };
    let dtau_ps = match dtau_ps {
        Some(d) => d,
        None => {
            // Reception times [t_a, t_a + gamma n dtau] against the light's end at the last
            // frame: zero at the interval wanted, increasing with dtau.
            let n = frames.max(1);
            let g = gamma(beta);
            let excess = |dtau_ps: f64| -> Result<f64, RenderError> {
                let end_ps = light_seen(&build(dtau_ps)?, n - 1)
                    .span_above(level)
                    .map_or(first.start_ps, |l| l.end_ps);
                Ok(g * n as f64 * dtau_ps - (end_ps - first.start_ps))
            };
            let reach_ps = match shortcut {
                // CameraPath::dolly moves over (frames - 1) intervals.
                Shortcut::Dolly { beta } if beta > 0.0 => {
                    DOLLY_MAX_APPROACH * r0_m / (g * beta * C_M_PER_PS * (frames.max(2) - 1) as f64)
                }
                _ => f64::INFINITY,
            };
            let at_rest_ps = first.len_ps() / (g * n as f64);
            solve_increasing(excess, at_rest_ps.min(reach_ps), reach_ps)?
        }
    };
    Ok(ShortcutPath {
        path: build(dtau_ps)?,
        time_offset_ps: first.start_ps,
        target_m: target,
    })
}

/// The largest `x` found with `f(x) < 0` within 0.1 % of where `f` (increasing on
/// `(0, cap]`, negative towards 0) changes sign: bracketing from `guess > 0` (doubling or
/// halving), then the Illinois variant of regula falsi. A jump of `f` across 0 (light
/// leaving the last frame's view) is approached from below. `cap` when `f(cap) <= 0`.
fn solve_increasing(
    f: impl Fn(f64) -> Result<f64, RenderError>,
    guess: f64,
    cap: f64,
) -> Result<f64, RenderError> {
    let mut hi = guess;
    let mut f_hi = f(hi)?;
    if f_hi == 0.0 {
        return Ok(hi);
    }
    let (mut lo, mut f_lo) = (hi, f_hi);
    while f_hi < 0.0 {
        if hi >= cap {
            return Ok(cap);
        }
        (lo, f_lo) = (hi, f_hi);
        hi = (2.0 * hi).min(cap);
        f_hi = f(hi)?;
    }
    for _ in 0..60 {
        if f_lo < 0.0 {
            break;
        }
        (hi, f_hi) = (lo, f_lo);
        lo *= 0.5;
        f_lo = f(lo)?;
    }
    let mut side = 0;
    for _ in 0..60 {
        if hi - lo <= 1e-3 * hi {
            break;
        }
        let x = if f_lo.is_finite() && f_hi > f_lo {
            (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        } else {
            0.5 * (lo + hi)
        };
        let x = x.clamp(lo + 1e-4 * (hi - lo), hi - 1e-4 * (hi - lo));
        let fx = f(x)?;
        if fx.abs() <= 1e-9 * hi {
            return Ok(x);
        }
        if fx < 0.0 {
            (lo, f_lo) = (x, fx);
            if side == -1 {
                f_hi *= 0.5;
            }
            side = -1;
        } else {
            (hi, f_hi) = (x, fx);
            if side == 1 {
                f_lo *= 0.5;
            }
            side = 1;
        }
    }
    Ok(lo)
}

/// The orbit of [`Shortcut::Orbit`]: keyframes at proper times `k dtau` for frames
/// `0 ..= frames` on the circle about `target` through `start` (axis `up`), each with its
/// world velocity and an orientation looking along the target's aberrated direction (in a
/// medium of index `eta`, [`crate::relativity::medium`]'s aberration).
fn orbit_path(
    target: Point3<f64>,
    start: Point3<f64>,
    up: Vector3<f64>,
    beta: f64,
    vfov_deg: f64,
    eta: f64,
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
        let boost = Boost::new(velocity).map_err(|e| RenderError::Setting {
            name: "orbit",
            message: e.to_string(),
        })?;
        let apparent = if eta == 1.0 {
            boost.inverse().aberrate(&to_target)
        } else {
            crate::relativity::medium::world_to_camera(&velocity, &to_target, eta).0
        };
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

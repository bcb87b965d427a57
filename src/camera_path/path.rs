//! The validated camera path: construction (every frame checked below the speed of light and
//! finite), the built-in paths (dolly, orbit, static view), and the camera's state at a frame
//! or a proper time. Reading and writing the file format is in [`super::file`].

use super::checks::{finite3, MAX_FRAMES};
use super::keyframes::{resolve_keyframes, KeyTrack};
use super::orbit::{resolve_orbit, OrbitTrack};
use super::{
    CameraPathError, Clock, FrameSpec, FrameState, Interpolation, Keyframe, Motion, Orbit,
    Orientation,
};
use crate::camera::Pose;
use crate::ranges;
use crate::relativity::SensorRotation;
use crate::units::C_M_PER_PS;
use nalgebra::{Point3, Rotation3, Vector3};

/// A validated camera path with its precomputed clock table.
#[derive(Clone, Debug)]
pub struct CameraPath {
    pub(super) spec: FrameSpec,
    pub(super) tau0_ps: f64,
    pub(super) rotation: Option<SensorRotation>,
    pub(super) motion: Motion,
    pub(super) resolved: Resolved,
}

#[derive(Clone, Debug)]
pub(super) enum Resolved {
    Keyframes(KeyTrack),
    Orbit(OrbitTrack),
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
        ranges::check("dtau_ps", spec.dtau_ps, ranges::INTERVAL_PS)
            .map_err(|e| bad(e.to_string()))?;
        if let Some(t) = tau0_ps {
            if !t.is_finite() {
                return Err(bad(format!("tau0_ps = {t} is not a finite number")));
            }
            ranges::check("tau0_ps", t, ranges::TIME_PS).map_err(|e| bad(e.to_string()))?;
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

    /// Proper times of the first and last keyframe, ps (None for an orbit).
    pub fn keyframe_tau_span_ps(&self) -> Option<(f64, f64)> {
        match &self.resolved {
            Resolved::Keyframes(k) => Some(k.tau_span()),
            Resolved::Orbit(_) => None,
        }
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
                    beta: k.beta_at(s, &vel),
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
}

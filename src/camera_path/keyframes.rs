//! Keyframe paths: positions interpolated linearly or with a cubic Hermite spline (tangents
//! from each keyframe's `beta`, else the non-uniform Catmull-Rom estimate), orientations
//! slerped, the field of view interpolated linearly; the checks of every keyframe and of the
//! speed along each segment. The clock table of the track is in [`super::clock`].

use super::checks::{check_finite, check_finite_all, check_point, check_time, valid_vfov};
use super::{CameraPathError, Clock, Interpolation, Keyframe, Orientation};
use crate::camera::Pose;
use crate::units::C_M_PER_PS;
use nalgebra::{Quaternion, Rotation3, UnitQuaternion, Vector3};

/// Samples per segment when checking the speed along a cubic segment.
const SPEED_SAMPLES: usize = 256;

#[derive(Clone, Debug)]
pub(super) struct KeyTrack {
    pub(super) clock: Clock,
    pub(super) interpolation: Interpolation,
    pub(super) knots: Vec<f64>,
    pub(super) points: Vec<Vector3<f64>>,
    /// dx/ds at each keyframe (m per ps of the path's clock), cubic only.
    pub(super) tangents: Vec<Vector3<f64>>,
    /// Each keyframe's given `beta`, returned as it is at the keyframe's own time.
    pub(super) betas: Vec<Option<Vector3<f64>>>,
    pub(super) rotations: Vec<UnitQuaternion<f64>>,
    pub(super) vfovs: Vec<f64>,
    /// The other clock (tau for clock = world, t for clock = proper) at the table's nodes
    /// `knots[i] + j / SUB * h_i`, index `i * SUB + j`.
    pub(super) cum: Vec<f64>,
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

pub(super) fn ordinal(i: usize, n: usize) -> String {
    format!("keyframe {} of {n}", i + 1)
}

impl KeyTrack {
    pub(super) fn n(&self) -> usize {
        self.knots.len()
    }

    /// Segment index and fraction of `s` (clamped to the span). Requires n >= 2.
    pub(super) fn locate(&self, s: f64) -> (usize, f64) {
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
    pub(super) fn position_velocity(&self, s: f64) -> (Vector3<f64>, Vector3<f64>) {
        if self.n() == 1 {
            // At rest, or moving uniformly at the keyframe's velocity.
            let v = self.tangents[0];
            if v == Vector3::zeros() {
                return (self.points[0], v);
            }
            return (self.points[0] + v * (s - self.knots[0]), v);
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

    /// World-frame beta at path-clock time `s` where the path's derivative is `vel`: a
    /// keyframe's given `beta` at that keyframe's own time (exactly as given), else from the
    /// derivative.
    pub(super) fn beta_at(&self, s: f64, vel: &Vector3<f64>) -> Vector3<f64> {
        match self.knots.iter().position(|&k| k == s) {
            Some(i) if self.betas[i].is_some() => self.betas[i].unwrap_or_default(),
            _ => self.beta_from_derivative(vel),
        }
    }

    /// World-frame beta from the path derivative.
    pub(super) fn beta_from_derivative(&self, vel: &Vector3<f64>) -> Vector3<f64> {
        match self.clock {
            Clock::World => vel / C_M_PER_PS,
            Clock::Proper => {
                let u = vel / C_M_PER_PS;
                u / (1.0 + u.norm_squared()).sqrt()
            }
        }
    }

    pub(super) fn orientation_at(&self, s: f64) -> (Rotation3<f64>, f64) {
        if self.n() == 1 {
            return (self.rotations[0].to_rotation_matrix(), self.vfovs[0]);
        }
        if let Some(i) = self.knots.iter().position(|&k| k == s) {
            // At a keyframe's own time: its orientation and field of view as given.
            return (self.rotations[i].to_rotation_matrix(), self.vfovs[i]);
        }
        let (i, u) = self.locate(s);
        let q = slerp(&self.rotations[i], &self.rotations[i + 1], u);
        let vfov = self.vfovs[i] + (self.vfovs[i + 1] - self.vfovs[i]) * u;
        (q.to_rotation_matrix(), vfov)
    }
}

/// Every number of a keyframe finite, its points within [`MAX_COORD_M`] (messages name the
/// file's keys: `look_at_m[1] must be finite, got -inf`).
fn check_keyframe_numbers(kf: &Keyframe) -> Result<(), String> {
    check_time("time_ps", kf.time_ps)?;
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

/// The keyframes checked ([`check_keyframe`], the speed along every segment) and made into a
/// track with its clock table.
pub(super) fn resolve_keyframes(
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
    for i in 0..n {
        let rot = check_keyframe(keyframes, i, interpolation, bad)?;
        rotations.push(UnitQuaternion::from_rotation_matrix(&rot));
    }
    let knots: Vec<f64> = keyframes.iter().map(|k| k.time_ps).collect();
    let points: Vec<Vector3<f64>> = keyframes.iter().map(|k| k.position_m.coords).collect();
    let tangents = tangents(clock, keyframes, &knots, &points);
    let mut track = KeyTrack {
        clock,
        interpolation,
        knots,
        points,
        tangents,
        betas: keyframes.iter().map(|k| k.beta).collect(),
        rotations,
        vfovs: keyframes.iter().map(|k| k.vfov_deg).collect(),
        cum: Vec::new(),
    };
    track.check_speed(bad)?;
    track.build_table();
    // The times are in range (check_time); a table that still overflows is refused here, not
    // met by `f64::clamp` when a frame is evaluated.
    if track.cum.iter().any(|t| !t.is_finite()) {
        return Err(bad(format!(
            "the keyframes' clock table is not finite (keyframe times {} .. {} ps)",
            track.knots[0],
            track.knots[n - 1]
        )));
    }
    Ok(track)
}

/// Keyframe `i` of `keyframes` checked (its numbers, field of view, increasing time, its
/// `beta` below c and allowed by the interpolation), and its camera-to-world rotation.
fn check_keyframe(
    keyframes: &[Keyframe],
    i: usize,
    interpolation: Interpolation,
    bad: &dyn Fn(String) -> CameraPathError,
) -> Result<Rotation3<f64>, CameraPathError> {
    let n = keyframes.len();
    let kf = &keyframes[i];
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
    Ok(rot)
}

/// Tangents dx/ds at each keyframe, on the path's clock (m per ps): the keyframe's `beta`
/// converted to the clock (`beta c` for world time, the proper velocity `gamma beta c` for
/// proper time), else the one-sided difference at the ends and the non-uniform Catmull-Rom
/// estimate inside. A single keyframe's tangent is its `beta` converted likewise (uniform
/// motion), zero without one (at rest).
pub(super) fn tangents(
    clock: Clock,
    keyframes: &[Keyframe],
    knots: &[f64],
    points: &[Vector3<f64>],
) -> Vec<Vector3<f64>> {
    let n = keyframes.len();
    let mut tangents = vec![Vector3::zeros(); n];
    let from_beta = |b: Vector3<f64>| match clock {
        Clock::World => b * C_M_PER_PS,
        Clock::Proper => b * (crate::relativity::gamma(b.norm()) * C_M_PER_PS),
    };
    if n == 1 {
        tangents[0] = keyframes[0].beta.map_or(Vector3::zeros(), from_beta);
    } else {
        let d = |i: usize| (points[i + 1] - points[i]) / (knots[i + 1] - knots[i]);
        for (i, kf) in keyframes.iter().enumerate() {
            tangents[i] = match kf.beta {
                Some(b) => from_beta(b),
                None if i == 0 => d(0),
                None if i == n - 1 => d(n - 2),
                None => {
                    let (h0, h1) = (knots[i] - knots[i - 1], knots[i + 1] - knots[i]);
                    (d(i - 1) * h1 + d(i) * h0) / (h0 + h1)
                }
            };
        }
    }
    tangents
}

impl KeyTrack {
    /// The speed along each segment below c (sampled: once for linear segments, at
    /// [`SPEED_SAMPLES`] points for cubic ones); the error names the two keyframes.
    fn check_speed(&self, bad: &dyn Fn(String) -> CameraPathError) -> Result<(), CameraPathError> {
        let (n, clock, interpolation) = (self.n(), self.clock, self.interpolation);
        let track = self;
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
        Ok(())
    }
}

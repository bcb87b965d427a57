//! Special-relativistic kernels of the novel-view renderer: Lorentz factor, aberration of camera
//! rays, Doppler factor, the time-resolved radiometry of the seed (Jarabo et al. 2013, Sec. 4)
//! and the velocity field of a rotating sensor (seed Sec. 4.3).
//!
//! Formulas and signs follow `physics.md` ("Aberration, Doppler factor, searchlight" and
//! "Time-resolved accumulation"), not the seed's Eq. 3 / Eq. 4 literally: the seed measures
//! angles from the photon's *propagation* direction, the opposite of the camera ray, and
//! feeding it a camera-ray angle aberrates the wrong way.
//!
//! Conventions:
//! - `beta` is the camera's velocity in the world frame divided by c (`|beta| < 1`).
//! - A camera ray `d_cam` is a unit vector in the camera's rest frame pointing **from the camera
//!   towards the source** (the direction you trace). [`Boost::aberrate`] gives the world-frame
//!   direction `d_world` of the same ray: the one to intersect with the scene.
//! - The velocity and both directions are expressed in one common set of axes (the boost is a
//!   pure boost, so the rest frame's axes are parallel to the world's). The renderer rotates the
//!   pixel ray into world axes with `world_from_camera` first, then aberrates.
//! - `D = gamma (1 - beta mu')` with `mu' = d_cam . beta_hat`, and `lambda' = D lambda`;
//!   approaching a source head-on gives `D < 1` (blue shift).
//! - In a medium of index `eta > 1` at rest in the world, light travels at `c / eta` and the
//!   aberration and Doppler factor are those of [`medium`] (velocity addition, the wave
//!   4-vector `(omega / c)(1, eta n)`); `eta = 1` is the vacuum, computed by [`Boost`].

use nalgebra::{Vector2, Vector3};
use serde::{Deserialize, Serialize};

pub mod medium;

/// Errors of the relativity kernels.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum RelativityError {
    /// A speed is not below the speed of light (or is not a finite number).
    #[error("speed |beta| = {beta} is not below the speed of light (need 0 <= |beta| < 1)")]
    NotSubluminal { beta: f64 },
}

/// Lorentz factor `gamma = 1 / sqrt(1 - beta^2)` of a speed `beta` (in units of c).
///
/// Not validated: `|beta| >= 1` gives infinity or NaN. Use [`Boost::new`] to validate.
#[inline]
pub fn gamma(beta: f64) -> f64 {
    1.0 / (1.0 - beta * beta).sqrt()
}

/// A pure Lorentz boost from the camera's rest frame to the world frame, for a camera moving
/// with velocity `beta * c` in the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Boost {
    beta: Vector3<f64>,
    gamma: f64,
}

impl Boost {
    /// The boost of a camera moving with velocity `beta_world * c` (world frame, world axes).
    /// Fails unless every component is finite and `|beta_world| < 1`.
    pub fn new(beta_world: Vector3<f64>) -> Result<Boost, RelativityError> {
        let speed = beta_world.norm();
        if !(speed.is_finite() && speed < 1.0) {
            return Err(RelativityError::NotSubluminal { beta: speed });
        }
        Ok(Boost {
            beta: beta_world,
            gamma: gamma(speed),
        })
    }

    /// The boost of a camera at rest (no aberration, `D = 1`).
    pub fn identity() -> Boost {
        Boost {
            beta: Vector3::zeros(),
            gamma: 1.0,
        }
    }

    /// Velocity over c in the world frame.
    pub fn beta_vector(&self) -> Vector3<f64> {
        self.beta
    }

    /// Speed over c, `|beta|`.
    pub fn beta(&self) -> f64 {
        self.beta.norm()
    }

    /// Lorentz factor of the speed.
    pub fn gamma(&self) -> f64 {
        self.gamma
    }

    /// The opposite boost (world frame seen from the camera): it maps world-frame rays back to
    /// camera-frame rays and has Doppler factor `1 / D`.
    pub fn inverse(&self) -> Boost {
        Boost {
            beta: -self.beta,
            gamma: self.gamma,
        }
    }

    /// World-frame direction of the camera ray `d_cam` (unit, camera rest frame, pointing from
    /// the camera towards the source):
    /// `d = (d'_perp / gamma + (mu' - beta) vhat) / (1 - beta mu')` (physics.md), written
    /// without `vhat` as `d = (d' / gamma + (gamma / (gamma + 1) (b . d') - 1) b) / (1 - b . d')`
    /// so that it holds at `b = 0`. The result is a unit vector when `d_cam` is.
    #[inline]
    pub fn aberrate(&self, d_cam: &Vector3<f64>) -> Vector3<f64> {
        let b_dot_d = self.beta.dot(d_cam);
        let g = self.gamma;
        (d_cam / g + self.beta * (g / (g + 1.0) * b_dot_d - 1.0)) / (1.0 - b_dot_d)
    }

    /// Doppler factor `D = gamma (1 - beta mu')` of light arriving along the camera ray `d_cam`:
    /// the received wavelength is `lambda' = D lambda` (physics.md).
    #[inline]
    pub fn doppler_factor(&self, d_cam: &Vector3<f64>) -> f64 {
        self.gamma * (1.0 - self.beta.dot(d_cam))
    }

    /// Both [`Boost::aberrate`] and [`Boost::doppler_factor`] with one dot product.
    #[inline]
    pub fn aberrate_with_doppler(&self, d_cam: &Vector3<f64>) -> (Vector3<f64>, f64) {
        let b_dot_d = self.beta.dot(d_cam);
        let g = self.gamma;
        let d_world = (d_cam / g + self.beta * (g / (g + 1.0) * b_dot_d - 1.0)) / (1.0 - b_dot_d);
        (d_world, g * (1.0 - b_dot_d))
    }
}

/// Relativistic velocity addition: the world-frame velocity (over c) of an object that moves
/// with `beta_in_frame` relative to a frame that itself moves with `beta_frame` in the world
/// (both in world axes):
/// `w = (v + u / gamma_v + gamma_v / (1 + gamma_v) (v . u) v) / (1 + v . u)`.
///
/// Used for a rotating sensor on a moving camera: `beta_frame` is the camera's path velocity,
/// `beta_in_frame` the sensor area's velocity ([`sensor_velocity`], rotated into world axes).
/// The result is below 1 whenever both inputs are. The renderer then uses the pure boost of the
/// combined velocity (the Thomas-Wigner rotation of the composed boosts is neglected, as in the
/// seed).
pub fn add_velocities(beta_frame: &Vector3<f64>, beta_in_frame: &Vector3<f64>) -> Vector3<f64> {
    let v = beta_frame;
    let u = beta_in_frame;
    let g = gamma(v.norm());
    let vu = v.dot(u);
    (v + u / g + v * (g / (1.0 + g) * vu)) / (1.0 + vu)
}

/// How the renderer turns the surface's temporal prefix sum into a pixel value.
///
/// Both modes integrate the world-time radiance over the emission window `[t_e, t_e + dtau/D]`
/// (the light received during one exposure of proper duration `dtau` left the surface during a
/// world-time interval of length `dtau / D`), and divide by `dtau`. They differ in the factor
/// applied to that average:
///
/// - [`Radiometry::Consistent`] (default, physics.md): `D^-3`. The displayed quantity of a
///   monochromatic laser is the wavelength-integrated radiance, which transforms as `D^-4`;
///   one of those four factors is the compression of the emission time (`dtau / D` of world
///   time is seen in `dtau`), and that factor is exactly what the accumulation window already
///   supplies. So the window carries `D^-1` and the remaining factor is `D^-3` (solid angle
///   `D^-2`, photon energy `D^-1`). Constant light gives `D^-4 L`, the classic result.
/// - [`Radiometry::Paper`]: `D^-5`, the seed's literal use of the spectral (per-wavelength)
///   radiance factor together with the same accumulation window. It counts the time
///   compression twice (once inside `D^-5`, once through the window), and it also applies the
///   per-wavelength bandwidth factor `D^-1`, which has no place for a line source whose
///   wavelength-integrated radiance is displayed. Constant light gives `D^-6 L`: two powers
///   of D more than the consistent value. Kept only to compare with the seed's pictures.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Radiometry {
    #[default]
    Consistent,
    Paper,
}

impl Radiometry {
    /// The factor multiplying the window average: `D^-3` (consistent) or `D^-5` (paper).
    #[inline]
    pub fn window_factor(self, doppler: f64) -> f64 {
        match self {
            Radiometry::Consistent => doppler.powi(-3),
            Radiometry::Paper => doppler.powi(-5),
        }
    }

    /// The value of one frame for one pixel, from the surface radiance's world-time prefix sum
    /// `P` read at the window's ends: `p_start = P(t_e)`, `p_end = P(t_e + dtau / D)`
    /// (see [`emission_window_ps`]). Consistent: `D^-3 (p_end - p_start) / dtau`;
    /// paper: `D^-5 (p_end - p_start) / dtau`.
    #[inline]
    pub fn frame_value(self, doppler: f64, p_start: f64, p_end: f64, dtau_ps: f64) -> f64 {
        self.window_factor(doppler) * (p_end - p_start) / dtau_ps
    }
}

/// Length in world time of the emission window of one exposure: `dtau / D` picoseconds.
#[inline]
pub fn emission_window_ps(doppler: f64, dtau_ps: f64) -> f64 {
    dtau_ps / doppler
}

/// What [`Radiometry::frame_value`] gives, per unit radiance, for light constant in time:
/// `D^-4` (consistent) or `D^-6` (paper).
#[inline]
pub fn constant_light_factor(doppler: f64, radiometry: Radiometry) -> f64 {
    match radiometry {
        Radiometry::Consistent => doppler.powi(-4),
        Radiometry::Paper => doppler.powi(-6),
    }
}

/// Transformation of wavelength-integrated radiance, `L' = D^-4 L`.
#[inline]
pub fn integrated_radiance_factor(doppler: f64) -> f64 {
    doppler.powi(-4)
}

/// Transformation of spectral radiance per unit wavelength, `L'_lambda(D lambda) =
/// D^-5 L_lambda(lambda)`.
#[inline]
pub fn spectral_radiance_factor(doppler: f64) -> f64 {
    doppler.powi(-5)
}

/// Transformation of photon-count radiance, `D^-3`.
#[inline]
pub fn photon_radiance_factor(doppler: f64) -> f64 {
    doppler.powi(-3)
}

/// Axis of a rotating sensor (seed Sec. 4.3), in the camera frame (x right, y down, z forward).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RotationAxis {
    /// About the optical axis (+z). Positive `beta_edge`: clockwise as seen from behind the
    /// camera looking forward (the seed's Fig. 8).
    Roll,
    /// About the camera's vertical axis (+y, pointing down): the sensor's left and right halves
    /// move along the optical axis in opposite directions.
    Yaw,
    /// About the camera's horizontal axis (+x): the top and bottom halves move along the
    /// optical axis in opposite directions.
    Pitch,
}

impl RotationAxis {
    /// Unit rotation axis in the camera frame (positive rotation by the right-hand rule).
    pub fn camera_axis(self) -> Vector3<f64> {
        match self {
            RotationAxis::Roll => Vector3::z(),
            RotationAxis::Yaw => Vector3::y(),
            RotationAxis::Pitch => Vector3::x(),
        }
    }

    /// Name as written in files and flags.
    pub fn name(self) -> &'static str {
        match self {
            RotationAxis::Roll => "roll",
            RotationAxis::Yaw => "yaw",
            RotationAxis::Pitch => "pitch",
        }
    }
}

/// A rotating sensor: its axis and the speed over c of its edge (its farthest point from the
/// axis; see [`sensor_velocity`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorRotation {
    pub axis: RotationAxis,
    pub beta_edge: f64,
}

impl SensorRotation {
    /// Camera-frame velocity over c of the sensor area at `offset` from the sensor centre
    /// ([`sensor_velocity`]).
    #[inline]
    pub fn velocity(&self, offset: &Vector2<f64>, half_size: &Vector2<f64>) -> Vector3<f64> {
        sensor_velocity(offset, self.axis, self.beta_edge, half_size)
    }
}

/// Distance from the rotation axis of the sensor's farthest point (its "edge"): the corner
/// `hypot(half_w, half_h)` for a roll, `half_w` for a yaw, `half_h` for a pitch.
pub fn sensor_edge_distance(axis: RotationAxis, half_size: &Vector2<f64>) -> f64 {
    match axis {
        RotationAxis::Roll => half_size.x.hypot(half_size.y),
        RotationAxis::Yaw => half_size.x,
        RotationAxis::Pitch => half_size.y,
    }
}

/// Velocity over c, in the camera frame, of the sensor area at `offset` under a rigid rotation
/// about `axis` (seed Sec. 4.3): `beta = omega x r` with `r = (offset.x, offset.y, 0)`.
///
/// - `offset`: the pixel's position on the image plane relative to the sensor centre, x right,
///   y down, as in the rendered picture (e.g. `(u - width/2, v - height/2)` in pixels); the
///   rotation axis passes through the sensor centre. (A physical sensor behind a lens sees the
///   image inverted; its own areas move the opposite way, which is `-beta_edge` here.)
/// - `half_size`: half the sensor's width and height, in the same unit as `offset`.
/// - `beta_edge`: the speed at the sensor's **edge, defined as its farthest point from the axis**
///   ([`sensor_edge_distance`]: the corner for a roll, the left/right border for a yaw, the
///   top/bottom border for a pitch). So `|beta| <= |beta_edge|` on the whole sensor, zero on
///   the axis. Its sign is the sense of rotation (right-hand rule about
///   [`RotationAxis::camera_axis`]).
///
/// A degenerate sensor (edge distance zero) gives zero velocity.
pub fn sensor_velocity(
    offset: &Vector2<f64>,
    axis: RotationAxis,
    beta_edge: f64,
    half_size: &Vector2<f64>,
) -> Vector3<f64> {
    let r_edge = sensor_edge_distance(axis, half_size);
    if r_edge <= 0.0 {
        return Vector3::zeros();
    }
    let omega = axis.camera_axis() * (beta_edge / r_edge);
    omega.cross(&Vector3::new(offset.x, offset.y, 0.0))
}

/// The tests' Lorentz oracle, written independently of this module.
#[cfg(test)]
#[path = "../../tests/common/lorentz.rs"]
mod lorentz_oracle;

#[cfg(test)]
mod tests {
    use super::lorentz_oracle::{lorentz_world_to_moving, photon_camera_to_world};
    use super::*;
    use nalgebra::Vector4;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    fn random_unit(rng: &mut Pcg64) -> Vector3<f64> {
        loop {
            let v = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let n = v.norm();
            if n > 0.1 && n <= 1.0 {
                return v / n;
            }
        }
    }

    #[test]
    fn aberration_and_doppler_match_a_general_lorentz_boost() {
        let mut rng = Pcg64::seed_from_u64(0x5eed_0001);
        for trial in 0..2000 {
            let speed = if trial % 10 == 0 {
                0.99
            } else {
                rng.random_range(0.0..0.99)
            };
            let v = random_unit(&mut rng) * speed;
            let d_cam = random_unit(&mut rng);
            let boost = Boost::new(v).unwrap();
            let (d_expect, dop_expect) = photon_camera_to_world(&v, &d_cam);
            let d_world = boost.aberrate(&d_cam);
            let dop = boost.doppler_factor(&d_cam);
            assert!(
                (d_world - d_expect).norm() < 1e-10,
                "trial {trial}: beta {v:?} d' {d_cam:?}: {d_world:?} vs {d_expect:?}"
            );
            assert!((d_world.norm() - 1.0).abs() < 1e-12);
            assert!(
                (dop - dop_expect).abs() < 1e-10 * dop_expect.max(1.0),
                "trial {trial}: D {dop} vs {dop_expect}"
            );
            let (d2, dop2) = boost.aberrate_with_doppler(&d_cam);
            assert!((d2 - d_world).norm() < 1e-15 && (dop2 - dop).abs() < 1e-15);
            // The inverse boost takes the world ray back, with the reciprocal Doppler factor.
            let back = boost.inverse();
            assert!((back.aberrate(&d_world) - d_cam).norm() < 1e-9);
            assert!((back.doppler_factor(&d_world) * dop - 1.0).abs() < 1e-9);
        }
    }

    #[test]
    fn physics_md_reference_table_at_half_c() {
        // (camera ray angle to velocity, world angle, D, D^-5, D^-4) from physics.md.
        let table = [
            (0.0, 0.0, 0.577350, 15.58846, 9.00000),
            (30.0, 49.7922, 0.654701, 8.31355, 5.44289),
            (60.0, 90.0000, 0.866025, 2.05280, 1.77778),
            (90.0, 120.0000, 1.154701, 0.48714, 0.56250),
            (120.0, 143.1301, 1.443376, 0.15963, 0.23040),
            (180.0, 180.0, 1.732051, 0.06415, 0.11111),
        ];
        let vhat = Vector3::new(0.0, 0.6, 0.8);
        let boost = Boost::new(vhat * 0.5).unwrap();
        assert!((boost.gamma() - 1.154701).abs() < 1e-6);
        let perp = Vector3::new(1.0, 0.0, 0.0);
        for (cam_deg, world_deg, d, d5, d4) in table {
            let a: f64 = f64::to_radians(cam_deg);
            let d_cam = vhat * a.cos() + perp * a.sin();
            let (d_world, dop) = boost.aberrate_with_doppler(&d_cam);
            let world = d_world.dot(&vhat).clamp(-1.0, 1.0).acos().to_degrees();
            assert!((world - world_deg).abs() < 1e-4, "{cam_deg}: {world}");
            // The ray stays in the plane of vhat and d_cam, on the same side.
            assert!(d_world.dot(&perp) >= -1e-12);
            assert!((dop - d).abs() < 1e-6, "{cam_deg}: D {dop}");
            assert!((spectral_radiance_factor(dop) - d5).abs() < 1e-5 * d5.max(1.0));
            assert!((integrated_radiance_factor(dop) - d4).abs() < 1e-5 * d4.max(1.0));
        }
    }

    #[test]
    fn rejects_superluminal_and_non_finite_speeds() {
        assert!(Boost::new(Vector3::new(0.0, 0.99, 0.0)).is_ok());
        for v in [
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.8, 0.7, 0.0),
            Vector3::new(f64::NAN, 0.0, 0.0),
            Vector3::new(f64::INFINITY, 0.0, 0.0),
        ] {
            let e = Boost::new(v).unwrap_err();
            assert!(e.to_string().contains("speed of light"), "{e}");
        }
        let id = Boost::identity();
        let d = Vector3::new(0.3, -0.4, 0.866).normalize();
        assert_eq!(id.aberrate(&d), d);
        assert_eq!(id.doppler_factor(&d), 1.0);
    }

    #[test]
    fn emission_window_is_the_derivative_of_emission_time_along_the_world_line() {
        // A camera on the world line x(t) = x0 + v t receives, at world time t_r, light that
        // left a fixed point source p at t_e = t_r - |p - x(t_r)| (c = 1 in m and m/c here).
        // Its proper time is tau = t_r / gamma. d t_e / d tau must be 1 / D.
        let mut rng = Pcg64::seed_from_u64(0x5eed_0002);
        for _ in 0..200 {
            let v = random_unit(&mut rng) * rng.random_range(0.05..0.95);
            let g = 1.0 / (1.0 - v.norm_squared()).sqrt();
            let x0 = Vector3::new(0.1, -0.2, 0.3);
            let p = x0 + random_unit(&mut rng) * rng.random_range(1.0..5.0);
            let t_emit = |tau: f64| {
                let t_r = g * tau;
                t_r - (p - (x0 + v * t_r)).norm()
            };
            let h = 1e-5;
            let rate = (t_emit(h) - t_emit(-h)) / (2.0 * h);
            // Camera-frame ray towards p at tau = 0: world ray n, boosted into the camera
            // frame with the test's own 4x4 matrix (world -> camera is the boost with v).
            let n = (p - x0).normalize();
            let k_world = Vector4::new(1.0, -n.x, -n.y, -n.z);
            let k_cam = lorentz_world_to_moving(&v) * k_world;
            let p_cam = Vector3::new(k_cam[1], k_cam[2], k_cam[3]);
            let d_cam = -p_cam / p_cam.norm();
            let boost = Boost::new(v).unwrap();
            let dop = boost.doppler_factor(&d_cam);
            assert!(
                (rate - 1.0 / dop).abs() < 1e-6 * rate,
                "rate {rate} vs 1/D {}",
                1.0 / dop
            );
            assert!((emission_window_ps(dop, 3.0) - 3.0 * rate).abs() < 1e-5 * rate);
        }
    }

    #[test]
    fn constant_light_through_the_accumulation_gives_d_to_the_minus_four() {
        // Surface radiance constant in world time: prefix sum P(t) = L t.
        let radiance = 2.5;
        let prefix = |t_ps: f64| radiance * t_ps;
        let mut rng = Pcg64::seed_from_u64(0x5eed_0003);
        for _ in 0..500 {
            let dop: f64 = rng.random_range(0.1..10.0);
            let t_e = rng.random_range(-500.0..500.0);
            let dtau = rng.random_range(0.1..20.0);
            let window = emission_window_ps(dop, dtau);
            for mode in [Radiometry::Consistent, Radiometry::Paper] {
                let value = mode.frame_value(dop, prefix(t_e), prefix(t_e + window), dtau);
                let factor = constant_light_factor(dop, mode);
                assert!((value - factor * radiance).abs() < 1e-9 * value.abs().max(1.0));
            }
            let consistent =
                Radiometry::Consistent.frame_value(dop, prefix(t_e), prefix(t_e + window), dtau);
            // The classic result for steady light, written out: L D^-4.
            assert!((consistent - radiance / dop.powi(4)).abs() < 1e-9 * consistent.max(1.0));
            // The paper mode double counts: two extra powers of D.
            let paper = Radiometry::Paper.frame_value(dop, prefix(t_e), prefix(t_e + window), dtau);
            assert!((paper * dop * dop - consistent).abs() < 1e-9 * consistent.max(1.0));
        }
        assert_eq!(Radiometry::default(), Radiometry::Consistent);
    }

    #[test]
    fn radiance_factors_follow_from_the_invariance_of_i_nu_over_nu_cubed() {
        // A spectral line I_nu(nu) (Gaussian, arbitrary units, frequency in units of the line
        // centre). Invariance of I_nu / nu^3 gives, at the observed frequency nu' = nu / D,
        // I'_nu'(nu') = (nu'/nu)^3 I_nu(nu) = D^-3 I_nu(D nu').
        let line = |nu: f64| (-(nu - 1.0).powi(2) / (2.0 * 0.02f64.powi(2))).exp();
        let integrate = |f: &dyn Fn(f64) -> f64, a: f64, b: f64| {
            let n = 200_000;
            let h = (b - a) / n as f64;
            (0..=n)
                .map(|i| {
                    let w = if i == 0 || i == n { 0.5 } else { 1.0 };
                    w * f(a + i as f64 * h)
                })
                .sum::<f64>()
                * h
        };
        for dop in [0.4f64, 0.577_350_269, 0.9, 1.0, 1.3, 2.2] {
            let observed = |nu_obs: f64| dop.powi(-3) * line(dop * nu_obs);
            let total_rest = integrate(&line, 0.5, 1.5);
            let total_obs = integrate(&observed, 0.5 / dop, 1.5 / dop);
            let ratio = total_obs / total_rest;
            assert!(
                (ratio - integrated_radiance_factor(dop)).abs() < 1e-6 * ratio,
                "D {dop}: integrated ratio {ratio}"
            );
            // Per unit wavelength, I_lambda = I_nu nu^2 / c: compare the peaks, at lambda = 1
            // (rest) and lambda' = D (observed).
            let peak_rest = line(1.0) * 1.0f64.powi(2);
            let peak_obs = observed(1.0 / dop) * (1.0 / dop).powi(2);
            assert!((peak_obs / peak_rest - spectral_radiance_factor(dop)).abs() < 1e-9);
            // Photon count radiance, integral of I_nu / (h nu): D^-3.
            let n_rest = integrate(&|nu| line(nu) / nu, 0.5, 1.5);
            let n_obs = integrate(&|nu| observed(nu) / nu, 0.5 / dop, 1.5 / dop);
            assert!((n_obs / n_rest - photon_radiance_factor(dop)).abs() < 1e-6 * n_obs / n_rest);
            // The consistent window factor is the integrated factor with one D (the time
            // compression) taken out.
            assert!((Radiometry::Consistent.window_factor(dop) / dop - ratio).abs() < 1e-6 * ratio);
        }
    }

    #[test]
    fn sensor_velocity_is_omega_cross_r_with_beta_edge_at_the_farthest_point() {
        let half = Vector2::new(32.0, 24.0);
        for axis in [RotationAxis::Roll, RotationAxis::Yaw, RotationAxis::Pitch] {
            // Zero on the axis.
            assert_eq!(
                sensor_velocity(&Vector2::zeros(), axis, 0.7, &half).norm(),
                0.0
            );
            // Maximum over a grid of the sensor is beta_edge, reached at the farthest point.
            let mut max: f64 = 0.0;
            for i in 0..=64 {
                for j in 0..=48 {
                    let off = Vector2::new(i as f64 - 32.0, j as f64 - 24.0);
                    let b = sensor_velocity(&off, axis, 0.7, &half);
                    max = max.max(b.norm());
                    // Perpendicular to both the axis and the lever arm.
                    let r = Vector3::new(off.x, off.y, 0.0);
                    assert!(b.dot(&axis.camera_axis()).abs() < 1e-12);
                    assert!(b.dot(&r).abs() < 1e-9);
                }
            }
            assert!((max - 0.7).abs() < 1e-12, "{axis:?}: {max}");
        }
        // Roll, positive beta_edge: the right edge (x > 0) moves down (+y), the top edge
        // (y < 0) moves right: clockwise seen from behind the camera. Corner speed 0.5.
        let b = sensor_velocity(&Vector2::new(32.0, 0.0), RotationAxis::Roll, 0.5, &half);
        assert!((b - Vector3::new(0.0, 0.5 * 32.0 / 40.0, 0.0)).norm() < 1e-12);
        let b = sensor_velocity(&Vector2::new(0.0, -24.0), RotationAxis::Roll, 0.5, &half);
        assert!((b - Vector3::new(0.5 * 24.0 / 40.0, 0.0, 0.0)).norm() < 1e-12);
        // Yaw about +y (down): the right border moves backwards (-z) at beta_edge.
        let b = sensor_velocity(&Vector2::new(32.0, 10.0), RotationAxis::Yaw, 0.5, &half);
        assert!((b - Vector3::new(0.0, 0.0, -0.5)).norm() < 1e-12);
        // Pitch about +x: the bottom border (y > 0) moves forwards (+z).
        let b = sensor_velocity(&Vector2::new(-5.0, 24.0), RotationAxis::Pitch, 0.5, &half);
        assert!((b - Vector3::new(0.0, 0.0, 0.5)).norm() < 1e-12);
        assert_eq!(
            sensor_velocity(
                &Vector2::new(1.0, 1.0),
                RotationAxis::Roll,
                0.5,
                &Vector2::zeros()
            ),
            Vector3::zeros()
        );
    }

    #[test]
    fn velocity_addition_matches_boosting_a_four_velocity() {
        let mut rng = Pcg64::seed_from_u64(0x5eed_0004);
        for _ in 0..500 {
            let v = random_unit(&mut rng) * rng.random_range(0.0..0.99);
            let u = random_unit(&mut rng) * rng.random_range(0.0..0.99);
            // 4-velocity of the object in the moving frame, boosted to the world (velocity -v).
            let gu = 1.0 / (1.0 - u.norm_squared()).sqrt();
            let four = Vector4::new(gu, gu * u.x, gu * u.y, gu * u.z);
            let w4 = lorentz_world_to_moving(&(-v)) * four;
            let expect = Vector3::new(w4[1], w4[2], w4[3]) / w4[0];
            let w = add_velocities(&v, &u);
            assert!((w - expect).norm() < 1e-10, "{w:?} vs {expect:?}");
            assert!(w.norm() < 1.0);
        }
    }
}

//! Aberration and Doppler factor of light in a medium at rest in the world (index `eta > 1`,
//! light at `c / eta`, no dispersion): physics.md, "In a medium". At `eta = 1` every function
//! here returns exactly what the vacuum formulas of [`super::Boost`] return (they are called).
//!
//! Derivation (c = 1; `v = beta vhat` the camera's world velocity, `gamma` its factor):
//!
//! - **World to camera.** Light propagates along `n = -d` (`d` points from the camera to the
//!   source) with velocity `u = n / eta`. The camera sees the velocity `u'` given by the
//!   relativistic addition of `u` and `-v`:
//!   `u'_par = (u_par - beta) / (1 - beta u_par)`,
//!   `u'_perp = u_perp / (gamma (1 - beta u_par))`; the camera ray is `d' = -u' / |u'|`.
//! - **Camera to world** (what the renderer traces). The camera ray `d'` fixes the direction
//!   `m = -d'` of `u' = s m`, not its speed `s`, which in the camera frame is not `1 / eta`.
//!   Adding `v` back, `u = (s m_par + beta) / (1 + beta s m_par)` along `vhat` and
//!   `s m_perp / (gamma (1 + beta s m_par))` across, and asking `|u| = 1 / eta` gives, with
//!   `k = 1 - 1 / eta^2`, the quadratic
//!   `[(1 - beta^2) + beta^2 m_par^2 k] s^2 + [2 beta m_par k] s + [beta^2 - 1 / eta^2] = 0`.
//!   Its constant term is negative while `beta < 1 / eta` and its leading term positive, so
//!   exactly one root is positive: that `s`. Then `d = -u / |u|`. (At `eta = 1`, `k = 0` and
//!   `s = 1`: the vacuum formula.)
//! - **Doppler.** The wave 4-vector in the world is `omega (1, eta n)`; its time component in
//!   the camera frame is `gamma omega (1 - eta beta . n) = gamma omega (1 + eta beta . d)`, so
//!   `D = lambda' / lambda = 1 / (gamma (1 + eta beta (d . vhat)))`.
//! - **`beta >= 1 / eta`**: light going the camera's way at `c / eta` never reaches a camera
//!   that is as fast; the constant term above is then not negative and the ray has no
//!   solution. [`check_speed`] refuses such a camera.
//! - **Searchlight.** The renderer keeps the vacuum factors (`D^-3` with the accumulation
//!   window, `D^-4` for constant light) with the medium's `D`. Radiance in a moving medium
//!   also changes with the refraction of solid angle (`L / eta^2` is the invariant at rest),
//!   which this does not model: an approximation, stated in docs/physics.md.

use nalgebra::Vector3;

/// The fastest camera speed (over c) light in a medium of index `eta` can reach from every
/// direction: `1 / eta`.
pub fn speed_limit(eta: f64) -> f64 {
    1.0 / eta
}

/// Refuse a camera speed `beta` (over c) at or above `1 / eta`: the message says why.
pub fn check_speed(beta: f64, eta: f64) -> Result<(), String> {
    if beta < speed_limit(eta) {
        Ok(())
    } else {
        Err(format!(
            "|beta| = {beta} is not below 1 / eta = {:.6} (eta {eta}): light in the medium \
             travels at c / eta and cannot reach a camera that fast from behind",
            speed_limit(eta)
        ))
    }
}

/// World ray `d` (camera to source, unit) and Doppler factor `D` of the camera ray `d_cam`
/// (camera rest frame, world axes, unit) for a camera moving with `beta` (world, over c) in a
/// medium of index `eta > 1` (module doc). `|beta| < 1 / eta` is the caller's to check.
pub fn camera_to_world(beta: &Vector3<f64>, d_cam: &Vector3<f64>, eta: f64) -> (Vector3<f64>, f64) {
    let b = beta.norm();
    if b == 0.0 {
        return (*d_cam, 1.0);
    }
    let vhat = beta / b;
    let g = super::gamma(b);
    let m = -d_cam;
    let m_par = m.dot(&vhat);
    let m_perp = m - vhat * m_par;
    let k = 1.0 - 1.0 / (eta * eta);
    let qa = (1.0 - b * b) + b * b * m_par * m_par * k;
    let qb = 2.0 * b * m_par * k;
    let qc = b * b - 1.0 / (eta * eta);
    let s = (-qb + (qb * qb - 4.0 * qa * qc).sqrt()) / (2.0 * qa);
    let denom = 1.0 + b * s * m_par;
    let u = vhat * ((s * m_par + b) / denom) + m_perp * (s / (g * denom));
    let d = -u / u.norm();
    (d, doppler_of_world_ray(beta, &d, eta))
}

/// Camera ray `d'` (camera rest frame, world axes, unit) and Doppler factor of the light that
/// arrives from the world direction `d_world` (camera to source, unit): the inverse of
/// [`camera_to_world`] (module doc).
pub fn world_to_camera(
    beta: &Vector3<f64>,
    d_world: &Vector3<f64>,
    eta: f64,
) -> (Vector3<f64>, f64) {
    let b = beta.norm();
    if b == 0.0 {
        return (*d_world, 1.0);
    }
    let vhat = beta / b;
    let g = super::gamma(b);
    let u = -d_world / eta;
    let u_par = u.dot(&vhat);
    let u_perp = u - vhat * u_par;
    let denom = 1.0 - b * u_par;
    let u_cam = vhat * ((u_par - b) / denom) + u_perp / (g * denom);
    (
        -u_cam / u_cam.norm(),
        doppler_of_world_ray(beta, d_world, eta),
    )
}

/// `D = 1 / (gamma (1 + eta beta . d))` of light arriving from the world direction `d`
/// (camera to source) at a camera moving with `beta` in a medium of index `eta`.
pub fn doppler_of_world_ray(beta: &Vector3<f64>, d_world: &Vector3<f64>, eta: f64) -> f64 {
    1.0 / (super::gamma(beta.norm()) * (1.0 + eta * beta.dot(d_world)))
}

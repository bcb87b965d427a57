//! Orbits: a circle about an axis at constant speed, looking at a point, so that world time
//! is exactly `gamma` times proper time; the checks of an orbit's numbers and of its view
//! along the whole circle.

use super::checks::{check_finite, check_finite_all, check_length, check_point, valid_vfov};
use super::{CameraPathError, Orbit};
use crate::camera::Pose;
use crate::units::C_M_PER_PS;
use nalgebra::Vector3;

#[derive(Clone, Debug)]
pub(super) struct OrbitTrack {
    pub(super) orbit: Orbit,
    pub(super) e1: Vector3<f64>,
    pub(super) e2: Vector3<f64>,
    /// Angular speed, radians per ps of world time.
    pub(super) omega: f64,
    pub(super) gamma: f64,
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

pub(super) fn resolve_orbit(
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

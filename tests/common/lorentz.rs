//! The tests' Lorentz oracle: boosts of 4-vectors and photon 4-momenta, built independently
//! of `src/relativity.rs` (which uses the closed forms of physics.md, Eqs. 3-7 of the seed).
//!
//! The boost along +x by speed `b` is Einstein's 1905 form, `t' = g (t - b x)`,
//! `x' = g (x - b t)`, `y' = y`, `z' = z`; a boost along any direction is that one
//! conjugated by the rotation that takes +x onto the direction of motion (no general
//! boost matrix is written out, so a slip in one would not be repeated in the other).
//! Included by `tests/common/mod.rs` and, for the library's unit tests, by `#[path]` from
//! `src/relativity.rs`.
#![allow(dead_code)]

use nalgebra::{Matrix3, Matrix4, Rotation3, Unit, Vector3, Vector4};

/// The boost (contravariant components, c = 1) from the world frame to a frame moving with
/// velocity `v` (over c) in the world: `x' = L x`.
pub fn lorentz_world_to_moving(v: &Vector3<f64>) -> Matrix4<f64> {
    let b = v.norm();
    if b == 0.0 {
        return Matrix4::identity();
    }
    let g = 1.0 / (1.0 - b * b).sqrt();
    #[rustfmt::skip]
    let along_x = Matrix4::new(
        g,      -g * b, 0.0, 0.0,
        -g * b, g,      0.0, 0.0,
        0.0,    0.0,    1.0, 0.0,
        0.0,    0.0,    0.0, 1.0,
    );
    // Columns of `r`: the direction of motion and two directions across it.
    let r: Matrix3<f64> = Rotation3::rotation_between(&Vector3::x(), &(v / b))
        .unwrap_or_else(|| {
            Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::z()), std::f64::consts::PI)
        })
        .into_inner();
    let mut rotate = Matrix4::identity();
    rotate.fixed_view_mut::<3, 3>(1, 1).copy_from(&r);
    // World components -> components along (v, across, across) -> boost -> back.
    rotate * along_x * rotate.transpose()
}

/// A photon arriving at a camera moving with `v`, from world direction `n_world` (unit, from
/// the camera towards the source): its direction towards the source in the camera frame and
/// `D = nu_world / nu_camera = lambda_camera / lambda_world`.
pub fn photon_world_to_camera(v: &Vector3<f64>, n_world: &Vector3<f64>) -> (Vector3<f64>, f64) {
    let k_world = Vector4::new(1.0, -n_world.x, -n_world.y, -n_world.z);
    let k_cam = lorentz_world_to_moving(v) * k_world;
    let p = Vector3::new(k_cam[1], k_cam[2], k_cam[3]);
    (-p / p.norm(), k_world[0] / k_cam[0])
}

/// The same photon the other way: camera-frame direction `d_cam` (towards the source) to the
/// world-frame direction and `D`. Camera to world is the boost with velocity `-v`.
pub fn photon_camera_to_world(v: &Vector3<f64>, d_cam: &Vector3<f64>) -> (Vector3<f64>, f64) {
    let k_cam = Vector4::new(1.0, -d_cam.x, -d_cam.y, -d_cam.z);
    let k_world = lorentz_world_to_moving(&(-v)) * k_cam;
    let p = Vector3::new(k_world[1], k_world[2], k_world[3]);
    (-p / p.norm(), k_world[0] / k_cam[0])
}

/// Light in a medium of index `eta` at rest in the world, arriving at a camera moving with `v`
/// from world direction `n_world` (unit, camera towards source): the camera-frame direction
/// towards the source and `D = lambda_camera / lambda_world`. The light's world line
/// `(1, -n_world / eta)` (c = 1) and its wave 4-vector `(1, -eta n_world)` are boosted with
/// the same matrix as [`photon_world_to_camera`]; nothing of the velocity-addition formula
/// is used.
pub fn medium_world_to_camera(
    v: &Vector3<f64>,
    n_world: &Vector3<f64>,
    eta: f64,
) -> (Vector3<f64>, f64) {
    let l = lorentz_world_to_moving(v);
    let x_world = Vector4::new(1.0, -n_world.x / eta, -n_world.y / eta, -n_world.z / eta);
    let x_cam = l * x_world;
    let p = Vector3::new(x_cam[1], x_cam[2], x_cam[3]);
    let k_world = Vector4::new(1.0, -eta * n_world.x, -eta * n_world.y, -eta * n_world.z);
    let k_cam = l * k_world;
    (-p / p.norm(), k_world[0] / k_cam[0])
}

#[cfg(test)]
mod oracle_checks {
    /// The oracle's own sanity: it preserves the Minkowski norm, a boost along +x is the
    /// 1905 form, and boosting by v then by -v is the identity.
    #[test]
    fn the_oracle_is_a_lorentz_transformation() {
        use super::lorentz_world_to_moving;
        use nalgebra::{Matrix4, Vector3, Vector4};
        let eta = Matrix4::from_diagonal(&Vector4::new(1.0, -1.0, -1.0, -1.0));
        for v in [
            Vector3::new(0.3, 0.0, 0.0),
            Vector3::new(-0.5, 0.2, 0.7),
            Vector3::new(-0.9, 0.0, 0.0),
            Vector3::new(0.0, 0.0, -0.999),
        ] {
            let l = lorentz_world_to_moving(&v);
            assert!((l.transpose() * eta * l - eta).norm() < 1e-9, "{v:?}");
            assert!((lorentz_world_to_moving(&-v) * l - Matrix4::identity()).norm() < 1e-9);
        }
        let l = lorentz_world_to_moving(&Vector3::new(0.6, 0.0, 0.0));
        let x = l * Vector4::new(1.0, 0.0, 0.0, 0.0);
        assert!(
            (x - Vector4::new(1.25, -0.75, 0.0, 0.0)).norm() < 1e-12,
            "{x:?}"
        );
    }
}

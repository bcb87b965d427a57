//! Number checks shared by the path's parts: finite values, coordinates within
//! [`MAX_COORD_M`], fields of view, and the frame-count cap [`MAX_FRAMES`]. Messages name the
//! file's keys (`look_at_m[1] must be finite, got -inf`).

use crate::ranges;
use nalgebra::Vector3;

pub(super) fn valid_vfov(v: f64) -> bool {
    v.is_finite() && v > 0.0 && v < 180.0
}

pub(super) fn finite3(v: &Vector3<f64>) -> bool {
    v.iter().all(|c| c.is_finite())
}

/// The most frames a path may have: [`CameraPath::new`](super::CameraPath::new) walks every frame to check its speed,
/// so the count is capped before the walk (`frames = 18446744073709551615` would never end).
pub const MAX_FRAMES: usize = 1_000_000;

/// The largest distance from the origin, in metres, of any point of a path (positions, look-at
/// targets, an orbit's centre and radius). The renderer casts rays in `f32`, which turns a
/// coordinate above about 3.4e38 into an infinity and loses every millimetre beyond 1e4 m;
/// a thousand kilometres is far beyond any scene a streak camera records.
pub const MAX_COORD_M: f64 = 1e6;

/// `key` (a number of the path, named as in the file) must be finite.
pub(super) fn check_finite(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{key} must be finite, got {v}"))
    }
}

/// Every component of `key` finite (named `key[i]`).
pub(super) fn check_finite_all(key: &str, v: &[f64]) -> Result<(), String> {
    for (i, &x) in v.iter().enumerate() {
        check_finite(&format!("{key}[{i}]"), x)?;
    }
    Ok(())
}

/// A time of the path (a keyframe's `time_ps`, `tau0_ps`): finite, then in
/// [`ranges::TIME_PS`] (a keyframe at `1e308` ps made the clock table NaN, and `f64::clamp`
/// panicked on it).
pub(super) fn check_time(key: &str, t_ps: f64) -> Result<(), String> {
    check_finite(key, t_ps)?;
    ranges::check(key, t_ps, ranges::TIME_PS)
        .map(|_| ())
        .map_err(|e| e.to_string())
}

/// A length or coordinate of the path: finite and at most [`MAX_COORD_M`] in magnitude.
pub(super) fn check_length(key: &str, x: f64) -> Result<(), String> {
    check_finite(key, x)?;
    if x.abs() > MAX_COORD_M {
        return Err(format!(
            "{key} = {x:e} m is beyond the {MAX_COORD_M:e} m from the origin that a path may reach"
        ));
    }
    Ok(())
}

/// A point of the path: each coordinate (named `key[i]`) as [`check_length`].
pub(super) fn check_point(key: &str, v: &[f64]) -> Result<(), String> {
    for (i, &x) in v.iter().enumerate() {
        check_length(&format!("{key}[{i}]"), x)?;
    }
    Ok(())
}

//! The limits of a scene file's values and the checks that apply them: what a scene file is
//! resolved against ([`Resolver`]: its name, its text for line numbers, the folder of its
//! mesh files), and each check of one value (positive, within a range, a point within
//! [`MAX_EXTENT_M`] of the origin, a direction), whose error names the key and its line.
//! [`super::resolve`] (the camera, the laser, the scene) and [`super::entry`] (one mesh
//! entry) both use them.

use super::SceneError;
use crate::limits::short_number;
use nalgebra::{Unit, Vector3};
use std::ops::Range;
use std::path::Path;
use toml::Spanned;

/// Most subdivisions an icosphere may ask for (20 * 4^7 = 327 680 triangles).
pub(super) const MAX_SUBDIVISIONS: u32 = 7;
/// The range of `eta`: from vacuum to well beyond any transparent medium (water 1.33,
/// diamond 2.42, germanium about 4 in the infrared). A larger index multiplies every flight
/// time and the world-time axis with it (`eta = 1e19` asked for an impossible allocation).
pub const ETA_RANGE: (f64, f64) = (crate::ranges::ETA.lo, crate::ranges::ETA.hi);
/// The largest pulse width, fs (1 ns): far beyond femtosecond lasers, small enough that the
/// pulse's time response stays a bounded number of bins (4294967296 fs hung the tracer).
/// The pulse must also be shorter than the camera's time window.
pub const MAX_PULSE_WIDTH_FS: f64 = 1e6;
/// How far from the origin, in metres, any point of a scene may lie (camera, laser, look-at
/// target, every vertex after its entry's transform): the tracer casts rays in `f32`, which
/// loses millimetres beyond about 1e4 m and turns coordinates above 3.4e38 into infinities.
pub const MAX_EXTENT_M: f64 = 1e4;
/// The range of `camera.dt_ps`: a femtosecond to a microsecond per bin
/// ([`crate::ranges::BIN_WIDTH_PS`], the range of every bin width femto reads).
pub const DT_PS_RANGE: (f64, f64) = (
    crate::ranges::BIN_WIDTH_PS.lo,
    crate::ranges::BIN_WIDTH_PS.hi,
);
/// The range of `laser.wavelength_nm`: soft X-rays to far infrared (the Doppler-shifted
/// colour and the CIE tables need a positive, finite wavelength).
pub const WAVELENGTH_NM_RANGE: (f64, f64) = (1.0, 1e6);
/// The largest `laser.energy` (cube values are `f32` and scale with it).
pub const MAX_ENERGY: f64 = 1e12;
/// The largest `camera.nx` and `camera.ny`.
pub const MAX_SIDE: u64 = 16384;
/// The largest `camera.nt`.
pub const MAX_NT: u64 = 1 << 20;
/// Closest a camera may be to a surface, metres.
pub(super) const CAMERA_CLEARANCE_M: f64 = 1e-3;

/// What a scene file is resolved against: its name in errors, its text (for line numbers)
/// and the folder of its mesh files.
pub(super) struct Resolver<'a> {
    pub origin: &'a str,
    pub text: &'a str,
    pub base_dir: &'a Path,
}

impl Resolver<'_> {
    /// "line L, column C" of a byte offset.
    pub(super) fn at(&self, span: &Range<usize>) -> String {
        let before = &self.text[..span.start.min(self.text.len())];
        let line = before.matches('\n').count() + 1;
        let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
        format!("line {line}, column {col}")
    }

    pub(super) fn bad(
        &self,
        span: &Range<usize>,
        key: &str,
        what: impl std::fmt::Display,
    ) -> SceneError {
        SceneError::Invalid {
            origin: self.origin.to_string(),
            message: format!("{}: {key}: {what}", self.at(span)),
        }
    }

    pub(super) fn positive(&self, v: &Spanned<f64>, key: &str) -> Result<f64, SceneError> {
        let x = *v.get_ref();
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(self.bad(&v.span(), key, format!("must be positive, got {x}")))
        }
    }

    /// A number within `[lo, hi]` (`unit` follows the numbers in the message).
    pub(super) fn in_range(
        &self,
        v: &Spanned<f64>,
        key: &str,
        (lo, hi): (f64, f64),
        unit: &str,
    ) -> Result<f64, SceneError> {
        let x = *v.get_ref();
        if x.is_finite() && x >= lo && x <= hi {
            Ok(x)
        } else {
            Err(self.bad(
                &v.span(),
                key,
                format!(
                    "must lie in [{}, {}]{unit}, got {}",
                    short_number(lo),
                    short_number(hi),
                    short_number(x)
                ),
            ))
        }
    }

    /// A point within [`MAX_EXTENT_M`] of the origin.
    pub(super) fn point(
        &self,
        v: &Spanned<[f64; 3]>,
        key: &str,
    ) -> Result<Vector3<f64>, SceneError> {
        let p = self.finite3(v, key)?;
        match p.iter().position(|x| x.abs() > MAX_EXTENT_M) {
            None => Ok(p),
            Some(i) => Err(self.bad(
                &v.span(),
                key,
                format!(
                    "[{i}] = {:e} m lies beyond the {MAX_EXTENT_M:e} m from the origin that a scene may reach",
                    p[i]
                ),
            )),
        }
    }

    pub(super) fn finite3(
        &self,
        v: &Spanned<[f64; 3]>,
        key: &str,
    ) -> Result<Vector3<f64>, SceneError> {
        let a = *v.get_ref();
        if a.iter().all(|x| x.is_finite()) {
            Ok(Vector3::from(a))
        } else {
            Err(self.bad(&v.span(), key, format!("must be finite, got {a:?}")))
        }
    }

    pub(super) fn direction(
        &self,
        v: &Spanned<[f64; 3]>,
        key: &str,
    ) -> Result<Unit<Vector3<f64>>, SceneError> {
        let d = self.finite3(v, key)?;
        Unit::try_new(d, 1e-12)
            .ok_or_else(|| self.bad(&v.span(), key, "must be a non-zero direction"))
    }
}

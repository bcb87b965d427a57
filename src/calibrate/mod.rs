//! Calibration of a capture against its geometry: where the camera is (spatial), when the
//! pulse left the laser spot (temporal), and what every pixel sees (registration).
//!
//! The seed (Sec. 3) projects the cube onto the scene through the capture camera and ties
//! camera time to the laser pulse. This module recovers the [`Calibration`] that does that:
//!
//! - [`points`]: 2D-3D correspondences (pixel, mesh point) read from TOML or CSV.
//! - [`dlt`]: a linear first estimate. Unknown intrinsics: Hartley-normalised DLT and an RQ
//!   decomposition into K, R and the camera centre. Known intrinsics: pose only (PnP) by
//!   orthogonal iteration from several starts.
//! - [`refine`]: Levenberg-Marquardt on the reprojection error, per-point residuals, outliers,
//!   and the refusal of fits that put the mesh behind the camera. [`fit_camera`] runs the
//!   whole spatial pipeline.
//! - [`temporal`]: sub-bin first-arrival detection on a pixel's time profile and a robust fit of
//!   `t_first = t0 + time_scale * eta * (|laser - p| + |p - o|) / c` (physics.md, "Transient
//!   path tracing"; [`Calibration::first_arrival_ps`]).
//! - [`mod@register`]: one ray per pixel centre through the calibrated camera into the mesh.
//!
//! [`Calibration`]: crate::camera::Calibration
//! [`Calibration::first_arrival_ps`]: crate::camera::Calibration::first_arrival_ps

pub mod dlt;
pub mod mixed;
pub mod points;
pub mod refine;
pub mod register;
pub mod scanline_time;
pub mod temporal;

pub use dlt::{Extent, SpatialInit};
pub use points::{load_points, save_points_toml, Correspondence};
pub use refine::{fit_camera, IntrinsicsPrior, SpatialFit, SpatialOptions};
pub use register::{register, Registration};
pub use temporal::{
    arrival_samples, calibrate_time, direct_arrival_samples, first_arrival_bin, fit_direct_time,
    fit_time_offset, footprints, window_centroid_bin, ArrivalOptions, ArrivalSample, Footprint,
    Footprints, TimeFit,
};

/// Errors of the calibration algorithms and of the correspondence files.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    /// A correspondence file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// A correspondence file is malformed; `line` is 1-based.
    #[error("{path}: line {line}: {message}")]
    Parse {
        path: String,
        line: usize,
        message: String,
    },
    /// A correspondence file has an unsupported shape (extension, no points).
    #[error("{path}: {message}")]
    Format { path: String, message: String },
    /// A correspondence holds a non-finite coordinate.
    #[error("{point}: coordinates must be finite numbers")]
    NonFinite { point: String },
    /// Not enough correspondences for the requested fit.
    #[error(
        "{got} point correspondences, at least {need} are needed {}",
        if *.known_intrinsics { "to solve the pose with known intrinsics" } else { "to solve intrinsics and pose (give the intrinsics to need only 4)" }
    )]
    TooFewPoints {
        got: usize,
        need: usize,
        known_intrinsics: bool,
    },
    /// Two correspondences name the same 3-D point.
    #[error("{first} and {second} have the same 3-D position; remove the repeated point")]
    RepeatedPoint { first: String, second: String },
    /// Two different 3-D points are given at the same pixel.
    #[error("{first} and {second} are different 3-D points at the same pixel; one of them is mis-picked")]
    RepeatedPixel { first: String, second: String },
    /// All 3-D points lie (nearly) on one plane, which leaves the intrinsics undetermined.
    #[error(
        "all 3-D points lie on one plane (thickness / extent = {ratio:.1e}); with unknown \
         intrinsics the points must not be coplanar: add points off the plane, or give the intrinsics"
    )]
    Coplanar { ratio: f64 },
    /// All 3-D points lie (nearly) on one line: no pose can be recovered.
    #[error(
        "all 3-D points lie on one line (width / extent = {ratio:.1e}); the pose is undetermined"
    )]
    Collinear { ratio: f64 },
    /// The fitted camera sees (some of) the points from behind.
    #[error(
        "solution puts the mesh behind the camera ({behind} of {total} points, first: {first}); \
         check that pixel and 3-D coordinates belong together and use the same axes"
    )]
    BehindCamera {
        behind: usize,
        total: usize,
        first: String,
    },
    /// The linear or iterative solve broke down (singular system, non-finite result).
    #[error("camera fit failed: {0}")]
    Degenerate(String),
    /// Too few usable samples for the time-offset fit.
    #[error("{got} pixels with a first arrival on the mesh, at least {need} are needed for the time fit")]
    TooFewSamples { got: usize, need: usize },
    /// The temporal samples cannot determine the requested parameters.
    #[error("time fit failed: {0}")]
    TimeDegenerate(String),
    /// The cube's pixel grid differs from the calibration's image size.
    #[error(
        "the cube is {cube_nx} x {cube_ny} pixels but the calibration is for {width} x {height}; \
         calibrate at the cube's resolution"
    )]
    SizeMismatch {
        cube_nx: usize,
        cube_ny: usize,
        width: usize,
        height: usize,
    },
    /// The cube's time axis is in world time; first arrivals need camera time.
    #[error(
        "the cube's time axis is in world time; temporal calibration needs a camera-time cube"
    )]
    WorldTimeCube,
    /// A registration does not match the cube it is used with.
    #[error(
        "the registration is {reg_nx} x {reg_ny} pixels but the cube is {cube_nx} x {cube_ny}"
    )]
    RegistrationMismatch {
        reg_nx: usize,
        reg_ny: usize,
        cube_nx: usize,
        cube_ny: usize,
    },
}

/// How a correspondence is named in messages: its name, else "point #k" (1-based).
pub(crate) fn label(points: &[Correspondence], i: usize) -> String {
    match &points[i].name {
        Some(n) if !n.is_empty() => format!("point '{n}' (#{})", i + 1),
        _ => format!("point #{}", i + 1),
    }
}

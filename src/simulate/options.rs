//! The settings of a simulated capture ([`SimulateOptions`], with their check), its errors
//! ([`SimulateError`]), the stages it reports progress of ([`Stage`]) and the names of the
//! files of a capture folder: what [`super::capture`] (the streak capture),
//! [`super::transient`] (the transient-only render) and [`super::band`] (a band of rows,
//! merged later) share. The check of the sizes against the machine is [`super::budget`]'s.

use super::fiducials::DEFAULT_MARKER_SPACING_M;
use super::flaws::{FlawError, Flaws};
use crate::calibrate::CalibrateError;
use crate::container::ContainerError;
use crate::formats::FormatError;
use crate::geometry::glb::GlbError;
use crate::manifest::{ManifestError, StreakFormat};
use crate::scene::Scene;
use crate::tracer::TimeFilter;
use std::path::PathBuf;

/// Errors of [`simulate_capture`](super::capture::simulate_capture). Messages name the file, folder or option at fault.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    /// An option is out of range.
    #[error("{option}: {message}")]
    InvalidOption {
        option: SimulateOption,
        message: String,
    },
    /// An imperfection parameter is out of range.
    #[error(transparent)]
    Flaw(#[from] FlawError),
    /// The capture is larger than the machine can hold or a loop may walk
    /// ([`super::budget`]).
    #[error(transparent)]
    Limit(#[from] crate::limits::LimitError),
    /// The destination exists and is not an empty folder (and `force` was not given), or
    /// it is not a folder at all.
    #[error("{}: {message}", path.display())]
    OutputExists { path: PathBuf, message: String },
    /// A folder could not be created, renamed or removed, or a small file written.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A streak image could not be written.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// A truth cube could not be written.
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// The manifest could not be written.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// The geometry could not be written.
    #[error(transparent)]
    Glb(#[from] GlbError),
    /// The fiducials could not be written.
    #[error(transparent)]
    Points(#[from] CalibrateError),
    /// Bands that cannot be merged, or a band that cannot be made ([`super::band`]).
    #[error("{message}")]
    Band { message: String },
    /// Any of the above while the capture was written into its temporary folder, with the
    /// temporary folder's name replaced by the destination's.
    #[error("{message}")]
    Staged { message: String },
}

/// A field of [`SimulateOptions`] that [`SimulateOptions::validate`] can refuse; displayed as
/// the field's name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimulateOption {
    /// [`SimulateOptions::spp`].
    Spp,
    /// [`SimulateOptions::max_bounces`].
    MaxBounces,
    /// [`SimulateOptions::seed`].
    Seed,
    /// [`SimulateOptions::formats`].
    Formats,
    /// [`SimulateOptions::marker_spacing_m`].
    MarkerSpacingM,
    /// [`SimulateOptions::time_filter`].
    TimeFilter,
    /// [`SimulateOptions::rr_start_bounce`].
    RrStartBounce,
}

impl SimulateOption {
    /// The name of its field of [`SimulateOptions`].
    pub fn field(self) -> &'static str {
        match self {
            SimulateOption::Spp => "spp",
            SimulateOption::MaxBounces => "max_bounces",
            SimulateOption::Seed => "seed",
            SimulateOption::Formats => "formats",
            SimulateOption::MarkerSpacingM => "marker_spacing_m",
            SimulateOption::TimeFilter => "time_filter",
            SimulateOption::RrStartBounce => "rr_start_bounce",
        }
    }
}

impl std::fmt::Display for SimulateOption {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.field())
    }
}

/// Settings of a simulated capture.
#[derive(Clone, Debug, PartialEq)]
pub struct SimulateOptions {
    /// Camera paths per pixel (>= 1).
    pub spp: u32,
    /// Seed of the render and of every imperfection (at most `i64::MAX`, TOML's range).
    pub seed: u64,
    /// Most surface interactions per path (>= 1).
    pub max_bounces: u32,
    /// Formats of each scanline, the first being the manifest's `file` (at least one, no
    /// repeats, not both `img16` and `img32`).
    pub formats: Vec<StreakFormat>,
    /// Imperfections of the capture.
    pub flaws: Flaws,
    /// Spacing of the fiducial marker grid on planar surfaces, metres.
    pub marker_spacing_m: f64,
    /// Replace a non-empty destination folder.
    pub force: bool,
    /// Provenance: the command line (or tool) that asked for the capture.
    pub created_by: String,
    /// Write only the true transient cube in camera time and the render's counters
    /// ([`super::transient`]): no streak images, imperfections or side files.
    pub transient_only: bool,
    /// How the tracer bins arrival times; [`TimeFilter::Box`] only with `transient_only`
    /// (a streak capture is the sensor's response).
    pub time_filter: TimeFilter,
    /// First bounce at which Russian roulette may end a path, at least 1
    /// ([`TraceOptions::rr_start_bounce`](crate::tracer::TraceOptions::rr_start_bounce));
    /// `None`: the tracer's default. Only with `transient_only`, to render with another
    /// renderer's setting in a comparison.
    pub rr_start_bounce: Option<u32>,
}

impl Default for SimulateOptions {
    fn default() -> Self {
        SimulateOptions {
            spp: 64,
            seed: 0,
            max_bounces: 4,
            formats: vec![StreakFormat::Png16],
            flaws: Flaws::default(),
            marker_spacing_m: DEFAULT_MARKER_SPACING_M,
            force: false,
            created_by: "femto::simulate".into(),
            transient_only: false,
            time_filter: TimeFilter::Sensor,
            rr_start_bounce: None,
        }
    }
}

impl SimulateOptions {
    /// Check every option and imperfection, and the capture's sizes against their caps and
    /// the memory available ([`super::budget`]); the error names the one at fault.
    pub fn validate(&self, scene: &Scene) -> Result<(), SimulateError> {
        let bad = |option: SimulateOption, message: String| {
            Err(SimulateError::InvalidOption { option, message })
        };
        if self.spp == 0 {
            return bad(SimulateOption::Spp, "must be at least 1".into());
        }
        if self.max_bounces == 0 {
            return bad(SimulateOption::MaxBounces, "must be at least 1".into());
        }
        if self.seed > i64::MAX as u64 {
            return bad(
                SimulateOption::Seed,
                format!("{} exceeds {} (TOML's integer range)", self.seed, i64::MAX),
            );
        }
        if self.formats.is_empty() {
            return bad(
                SimulateOption::Formats,
                "at least one format is needed".into(),
            );
        }
        for (i, f) in self.formats.iter().enumerate() {
            if self.formats[..i].contains(f) {
                return bad(SimulateOption::Formats, format!("{f:?} is listed twice"));
            }
        }
        let has = |f| self.formats.contains(&f);
        if has(StreakFormat::Img16) && has(StreakFormat::Img32) {
            return bad(
                SimulateOption::Formats,
                "img16 and img32 both write scanline_NNNN.img; choose one".into(),
            );
        }
        let (nx, nt) = (scene.camera.intrinsics.width, scene.camera.axis.nt);
        let max_img = i16::MAX as usize;
        if (has(StreakFormat::Img16) || has(StreakFormat::Img32)) && (nx > max_img || nt > max_img)
        {
            return bad(
                SimulateOption::Formats,
                format!("HPD-TA .img holds at most {max_img} x {max_img} pixels, not {nx} x {nt}"),
            );
        }
        if !(self.marker_spacing_m.is_finite() && self.marker_spacing_m > 0.0) {
            return bad(
                SimulateOption::MarkerSpacingM,
                format!("{} must be finite and > 0", self.marker_spacing_m),
            );
        }
        if self.time_filter == TimeFilter::Box && !self.transient_only {
            return bad(
                SimulateOption::TimeFilter,
                "a box time filter applies only to a transient-only render (a streak capture \
                 is the sensor's response)"
                    .into(),
            );
        }
        if let Some(b) = self.rr_start_bounce {
            if b == 0 {
                return bad(SimulateOption::RrStartBounce, "must be at least 1".into());
            }
            if !self.transient_only {
                return bad(
                    SimulateOption::RrStartBounce,
                    "applies only to a transient-only render".into(),
                );
            }
        }
        self.flaws.validate()?;
        super::budget::check(scene, self.spp, self.marker_spacing_m)?;
        Ok(())
    }
}

/// What [`simulate_capture`](super::capture::simulate_capture) is busy with when it reports progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Rendering the true cubes: one call per finished image row (`ny` in all).
    Render,
    /// Writing the streak images: one call per finished scanline (`ny` in all).
    Write,
    /// Rendering the truth frames of a moving camera (`--truth-path`): one call per frame.
    Truth,
}

/// File names inside the capture folder.
pub const MANIFEST_FILE: &str = "manifest.toml";
pub const GEOMETRY_FILE: &str = "scene.glb";
pub const CALIBRATION_FILE: &str = "calibration.toml";
pub const FIDUCIALS_FILE: &str = "fiducials.toml";
pub const TRUTH_CAMERA_FILE: &str = "truth_camera.h5";
pub const TRUTH_WORLD_FILE: &str = "truth_world.h5";
pub const TRUTH_DIRECT_FILE: &str = "truth_direct.h5";
pub const FLAT_FILE: &str = "flat.exr";
pub const DARK_FILE: &str = "dark.exr";

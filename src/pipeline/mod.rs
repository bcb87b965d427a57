//! The stages a user runs, as library functions: one pipeline, many front ends.
//!
//! `femto calibrate`, `femto unwarp`, `femto pyramid` and `femto render` map their flags onto
//! the options of these functions and print what they return; `femto demo` calls the same
//! functions with the same defaults, so the chain the tests and the demo exercise is the chain
//! users run. Each stage takes typed options whose `Default` is what a user gets, reads and
//! writes files, reports progress through [`Progress`], and returns a typed outcome (figures
//! and warnings) without printing anything.
//!
//! - [`calibrate`]: camera, registration and `t0` (seed Sec. 3), written as a calibration TOML
//!   and the cube's `registration` group, both or neither.
//! - [`describe`]: what a cube, pyramid side file, mesh or streak image holds (`femto info`).
//! - [`unwarp`]: camera time to world time and back (seed Eq. 2), streamed by row slabs.
//! - [`pyramid`]: the temporal prefix sums and mip levels of a cube (seed Sec. 5).
//! - [`render`]: a world-time cube, its calibration and mesh opened into a render scene, and
//!   a camera path rendered into frames or a video (seed Sec. 4).
//! - [`simulate`]: `femto simulate`'s flags as a request, planned into a scene and
//!   [`crate::simulate::SimulateOptions`] and run into a capture or band folder.
//!
//! Ingest is [`crate::ingest::plan::IngestPlan`] with [`crate::ingest::assemble::ingest`].

pub mod calibrate;
pub mod describe;
pub mod overwrite;
pub mod pyramid;
pub mod render;
pub mod simulate;
pub mod truth;
pub mod unwarp;

use crate::atomic::output_holds;
use crate::container::CubeCompression;
use std::path::Path;

/// How `femto ingest` (and the demo's ingest) stores the cubes it makes from captures:
/// shuffle + deflate level 1, the fastest level (real Hamamatsu streak data 2.1-3.5x smaller);
/// later stages keep a cube's compression.
pub const INGEST_COMPRESSION: CubeCompression = CubeCompression::Deflate(1);

/// Where a long stage reports how far it is (the CLI draws a progress bar; tests and the demo
/// pass [`Quiet`]).
pub trait Progress: Sync {
    /// A pass named `what` of `len` steps begins.
    fn start(&self, what: &str, len: u64) {
        let _ = (what, len);
    }
    /// `done` steps of the current pass are done.
    fn set(&self, done: u64) {
        let _ = done;
    }
    /// The current pass is over.
    fn finish(&self) {}
    /// Called between the steps of a stage's phases that report nothing (opening inputs,
    /// building a scene, reading a slab before writing it), so that a caller may unwind
    /// from here to stop the stage promptly (the Python package on Ctrl-C). Reports nothing.
    fn poll(&self) {}
}

/// Reports nothing.
pub struct Quiet;

impl Progress for Quiet {}

/// Errors of the stages; each names the file or the option that is wrong.
#[derive(Debug, thiserror::Error)]
pub enum StageError {
    /// A cube, pyramid or group file could not be read or written.
    #[error(transparent)]
    Container(#[from] crate::container::ContainerError),
    /// An array file (`.npy`, `.mat`, `.hspy`, HDF5 dataset) could not be read.
    #[error(transparent)]
    Reader(#[from] crate::readers::ReaderError),
    /// Another tool's file (a y-tal capture) could not be read (the message names it).
    #[error(transparent)]
    Interop(#[from] crate::interop::InteropError),
    /// A stored group (registration, pyramid) is malformed.
    #[error(transparent)]
    Store(#[from] crate::store::StoreError),
    /// A calibration file could not be read.
    #[error(transparent)]
    Camera(#[from] crate::camera::CameraError),
    /// A mesh could not be read.
    #[error(transparent)]
    Mesh(#[from] crate::geometry::load::LoadError),
    /// A camera path could not be read or built.
    #[error(transparent)]
    Path(#[from] crate::camera_path::CameraPathError),
    /// The renderer refused its inputs.
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// A video or frame sequence could not be written.
    #[error(transparent)]
    Video(#[from] crate::video::VideoError),
    /// The unwarp kernel refused its inputs.
    #[error(transparent)]
    Unwarp(#[from] crate::unwarp::UnwarpError),
    /// The correspondences could not be fitted.
    #[error("points: {source}")]
    Points {
        #[source]
        source: crate::calibrate::CalibrateError,
    },
    /// A calibration step failed on a cube (`path` empty while the caller has not named it).
    #[error("{}{source}", if path.is_empty() { String::new() } else { format!("{path}: ") })]
    Calibrate {
        path: String,
        #[source]
        source: crate::calibrate::CalibrateError,
    },
    /// No pixel of the fitted camera sees the mesh.
    #[error(
        "no pixel of the fitted camera sees the mesh; check that the points and the mesh use \
         the same frame and units"
    )]
    NothingSeen,
    /// The time fit depends on the detection floor: `t0` is not determined by the data.
    #[error(
        "{path}: t0 is not determined by the direct light: {t0_ps:.2} ps with the detection \
         floor at {floor:.4}, {check_t0_ps:.2} ps with it at {check_floor:.4} (the cube's noise \
         sigma is {noise_sigma:.4}); weak or noisy pixels decide the fit: raise --min-peak, or \
         check the laser position, the mesh and the cube's time axis"
    )]
    UnstableTime {
        path: String,
        t0_ps: f64,
        floor: f32,
        check_t0_ps: f64,
        check_floor: f32,
        noise_sigma: f64,
    },
    /// An option is out of range; `name` is the option (displayed as its flag's name
    /// without dashes), `message` starts with the value given (`--levels 40: ...`) or says
    /// what is wrong (`--eta must be ...`).
    #[error("--{name} {message}")]
    Option { name: StageOption, message: String },
    /// An input does not fit the stage (a world-time cube given for calibration, ...).
    #[error("{path}: {message}")]
    Input { path: String, message: String },
    /// A required input is missing; the message says which flag gives it.
    #[error("{0}")]
    Missing(&'static str),
    /// An output is one of the inputs.
    #[error("--{flag} {path} is also an input of this command; choose another path")]
    OutputIsInput { flag: &'static str, path: String },
    /// An output exists and `--force` was not given ([`overwrite`]).
    #[error("--{flag} {path}: {what} exists; add --force to replace it")]
    OutputExists {
        flag: &'static str,
        path: String,
        what: String,
    },
    /// A request beyond what the machine can hold or a loop may walk ([`crate::limits`]).
    #[error(transparent)]
    Limit(#[from] crate::limits::LimitError),
    /// A file could not be written.
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
}

/// The option of a stage that a [`StageError::Option`] is about, so that a caller can tell
/// the cases apart; displayed as the name of its `femto` flag without the leading dashes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StageOption {
    /// `--levels`.
    Levels,
    /// `--laser-nm`.
    LaserNm,
    /// `--calibration`.
    Calibration,
    /// `--mesh`.
    Mesh,
    /// `--cube`.
    Cube,
    /// `--pyramid`.
    Pyramid,
    /// `--path`.
    Path,
    /// `--dolly`.
    Dolly,
    /// `--orbit`.
    Orbit,
    /// `--capture-view`.
    CaptureView,
    /// `--frame-count`.
    FrameCount,
    /// `--size`.
    Size,
    /// `--dtau-ps`.
    DtauPs,
    /// `--time-offset-ps`.
    TimeOffsetPs,
    /// `--exposure`.
    Exposure,
    /// `--fps`.
    Fps,
    /// `--contour-ps`.
    ContourPs,
    /// `--frames`.
    Frames,
    /// `--threshold`.
    Threshold,
    /// `--eta`.
    Eta,
    /// `--mask-spread-bins`.
    MaskSpreadBins,
    /// `--min-peak`.
    MinPeak,
    /// `--intrinsics`.
    Intrinsics,
    /// `femto unwarp --t0-ps/--dt-ps/--nt`: the output time axis.
    OutputAxis,
}

impl StageOption {
    /// The name of its `femto` flag without the leading dashes.
    pub fn flag_name(self) -> &'static str {
        match self {
            StageOption::Levels => "levels",
            StageOption::MaskSpreadBins => "mask-spread-bins",
            StageOption::LaserNm => "laser-nm",
            StageOption::Calibration => "calibration",
            StageOption::Mesh => "mesh",
            StageOption::Cube => "cube",
            StageOption::Pyramid => "pyramid",
            StageOption::Path => "path",
            StageOption::Dolly => "dolly",
            StageOption::Orbit => "orbit",
            StageOption::CaptureView => "capture-view",
            StageOption::FrameCount => "frame-count",
            StageOption::Size => "size",
            StageOption::DtauPs => "dtau-ps",
            StageOption::TimeOffsetPs => "time-offset-ps",
            StageOption::Exposure => "exposure",
            StageOption::Fps => "fps",
            StageOption::ContourPs => "contour-ps",
            StageOption::Frames => "frames",
            StageOption::Threshold => "threshold",
            StageOption::Eta => "eta",
            StageOption::MinPeak => "min-peak",
            StageOption::Intrinsics => "intrinsics",
            StageOption::OutputAxis => "t0-ps/--dt-ps/--nt",
        }
    }
}

impl std::fmt::Display for StageOption {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.flag_name())
    }
}

impl From<crate::calibrate::CalibrateError> for StageError {
    /// A calibration error whose file the caller names ([`StageError::Calibrate`]'s path is
    /// filled in where the cube is known).
    fn from(source: crate::calibrate::CalibrateError) -> Self {
        StageError::Calibrate {
            path: String::new(),
            source,
        }
    }
}

/// Refuse an output path (given with `--flag`) that names one of `inputs`: the same file
/// through any path (symbolic links, `..`, hard links: device and inode are compared where
/// both exist), or, for an output that is a folder (a frame sequence, a capture), a folder
/// that holds one of them, which replacing it would delete. Call it before anything is
/// written.
pub fn refuse_same_file(
    out: &Path,
    inputs: &[&Path],
    flag: &'static str,
) -> Result<(), StageError> {
    if inputs.iter().any(|input| output_holds(out, input)) {
        return Err(StageError::OutputIsInput {
            flag,
            path: out.display().to_string(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_that_reach_an_input_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let input = d.join("c.h5");
        std::fs::write(&input, "cube").unwrap();
        std::fs::create_dir(d.join("sub")).unwrap();
        let refused = |out: &Path| refuse_same_file(out, &[&input], "out").is_err();
        assert!(refused(&input));
        assert!(refused(&d.join("sub/../c.h5")));
        std::fs::hard_link(&input, d.join("hard.h5")).unwrap();
        assert!(refused(&d.join("hard.h5")));
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(&input, d.join("link.h5")).unwrap();
            assert!(refused(&d.join("link.h5")));
            std::os::unix::fs::symlink(d, d.join("sub/up")).unwrap();
            assert!(refused(&d.join("sub/up/c.h5")));
        }
        // A folder output holding the input, and the folder itself.
        assert!(refused(d));
        assert!(refused(&d.join("sub/..")));
        // Elsewhere: new files, a sibling, a folder that does not hold it.
        assert!(!refused(&d.join("new.toml")));
        assert!(!refused(&d.join("sub/c.h5")));
        assert!(!refused(&d.join("sub")));
        std::fs::write(d.join("other.h5"), "x").unwrap();
        assert!(!refused(&d.join("other.h5")));
    }
}

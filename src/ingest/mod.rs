//! Ingest of real streak-camera captures: from one streak image per scanline to a calibrated
//! x-y-t [`Cube`](crate::cube::Cube) in camera time.
//!
//! A capture is `ny` streak images, one per scanline `y` (physics.md, "Transient path
//! tracing": the seed's capture is 672 x by 512 time pixels per image, a mirror scanning the
//! rows). Ingest works in two steps, "resolve, then compute":
//!
//! - [`plan`] resolves what the user named (a capture folder with its manifest, a glob or
//!   printf pattern of files, a stack of images in one HDF5 dataset) into a typed
//!   [`plan::IngestPlan`]: the file of each scanline, the image size, the time axis, and each
//!   requested correction with its parameters (dark frame, flat field, sweep table, ...).
//! - [`assemble`] streams the scanlines through the corrections of [`corrections`] (with the
//!   per-scanline jitter and laser power of [`row_offsets`]) into the
//!   HDF5 cube (`docs/cube-format.md`), decoding rows in parallel with a bounded number in
//!   flight, so peak memory does not grow with the number of scanlines.
//!
//! [`kind`] decides what kind of input a file is (streak capture, y-tal, mitransient, or a
//! file of [`crate::readers`]); [`arrays`] ingests the last. [`flags`] names the `femto ingest` flag in an error's line (the CLI and the Python package).
//!
//! Errors of both steps are [`IngestError`]; each message names the file (and the row, the
//! pixel or the size) that is wrong.

pub mod arrays;
pub mod assemble;
pub mod corrections;
pub mod flags;
pub mod kind;
pub mod plan;
pub mod row_offsets;
pub mod time_axis;

use std::path::PathBuf;

use crate::container::ContainerError;
use crate::formats::FormatError;
use crate::manifest::ManifestError;
use corrections::CorrectionError;
use time_axis::AxisValue;

/// Everything that can go wrong resolving or assembling a capture.
#[derive(Debug, thiserror::Error)]
pub enum IngestError {
    /// The input is none of the accepted kinds (capture folder, manifest, scanline file,
    /// glob, printf pattern, HDF5 file with a dataset name).
    #[error(
        "{input}: not a capture folder (with manifest.toml), a manifest, a scanline file \
         (.png, .tif, .tiff, .exr, .hdr, .img), a glob or printf pattern of scanline files, \
         or an HDF5 file with a dataset name"
    )]
    NotAnInput { input: String },
    /// The input names no file or folder (and is no pattern).
    #[error("{input}: no such file or folder")]
    NoSuchInput { input: String },
    /// A folder without `manifest.toml`; `found` lists the scanline files it holds, by
    /// extension (`(extension, count)`, most first).
    #[error("{}: no manifest.toml in this folder ({})", dir.display(), found_words(found))]
    FolderWithoutManifest {
        dir: PathBuf,
        found: Vec<(String, usize)>,
    },
    /// A printf pattern was given without the number of scanlines.
    #[error("{pattern}: a printf pattern needs the number of scanlines (rows)")]
    PrintfNeedsRows { pattern: String },
    /// A printf pattern that is not exactly one `%d`, `%Nd` or `%0Nd` conversion.
    #[error("{pattern}: bad printf pattern: {message}")]
    BadPrintf { pattern: String, message: String },
    /// A glob pattern that does not parse.
    #[error("{pattern}: bad glob pattern: {message}")]
    BadGlob { pattern: String, message: String },
    /// A glob pattern that matches no file.
    #[error("{pattern}: no file matches")]
    NoMatches { pattern: String },
    /// Two files of a glob carry the same scanline number.
    #[error("{}: scanline number {number} is also carried by {}", second.display(), first.display())]
    DuplicateNumber {
        number: u64,
        first: PathBuf,
        second: PathBuf,
    },
    /// A scanline has no file (a gap in the numbering, or a file of a printf pattern that is
    /// not there).
    #[error("scanline {row} is missing: {expected}")]
    MissingScanline { row: usize, expected: String },
    /// The manifest names a scanline file that is not there.
    #[error("{}: scanline {row}: file {} is not there", manifest.display(), file.display())]
    ManifestFileMissing {
        manifest: PathBuf,
        row: usize,
        file: PathBuf,
    },
    /// Every scanline is missing: there is nothing to interpolate from.
    #[error("{input}: every scanline is missing")]
    AllMissing { input: String },
    /// The manifest could not be read or is invalid.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// A streak image (scanline, dark frame, flat field) could not be read.
    #[error(transparent)]
    Format(#[from] FormatError),
    /// The HDF5 input stack could not be read or the cube could not be written.
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// An HDF5 stack that is not `ny` streak images.
    #[error("{}: dataset /{dataset} has shape {shape:?}: {message}", path.display())]
    StackShape {
        path: PathBuf,
        dataset: String,
        shape: Vec<usize>,
        message: String,
    },
    /// A scanline (or dark frame, flat field) whose size differs from the capture's.
    #[error(
        "{}: {what} is {found_nx} x {found_nt} (x by t), but the capture's scanlines are \
         {nx} x {nt} (as in {})",
        path.display(), reference.display()
    )]
    SizeMismatch {
        path: PathBuf,
        what: String,
        found_nx: usize,
        found_nt: usize,
        nx: usize,
        nt: usize,
        reference: PathBuf,
    },
    /// A flat field that is neither one row per scanline nor a single row.
    #[error(
        "{}: flat field is {width} x {height}, expected {nx} wide and {ny} (one row per \
         scanline) or 1 high",
        path.display()
    )]
    FlatSize {
        path: PathBuf,
        width: usize,
        height: usize,
        nx: usize,
        ny: usize,
    },
    /// A NaN or infinite value in an input image.
    #[error("{}: non-finite value {value} at x {x}, t {t} (NaN and infinite values are refused)", path.display())]
    NonFinite {
        path: PathBuf,
        x: usize,
        t: usize,
        value: f32,
    },
    /// An HPD-TA scanline (`.img` or TIFF) whose time axis the file does not calibrate (`reason`: the
    /// header keys, e.g. a pixel axis or a bare sweep-range index with no table), and no bin
    /// width given.
    #[error("{}: not calibrated in time ({reason})", path.display())]
    ImgTimeUncalibrated { path: PathBuf, reason: String },
    /// No source gives the time axis (no manifest, no `.img` time table, no bin width given).
    #[error(
        "{input}: no time axis: no manifest and no .img time table, and no bin width and \
         start time (dt_ps, t0_ps) given"
    )]
    NoTimeAxis { input: String },
    /// A time axis value given explicitly contradicts the one the capture records (the
    /// manifest's axis, or the `.img` time table), and resampling was not asked for.
    #[error("{what} = {given} ps contradicts {source_name}, whose {} is {recorded} ps", what.quantity())]
    AxisConflict {
        what: AxisValue,
        given: f64,
        source_name: String,
        recorded: f64,
    },
    /// Resampling onto a start given explicitly that lies after the first recorded edge:
    /// the rows before it would be lost.
    #[error(
        "t0_ps = {t0_ps} ps is after the start of the recorded rows ({source_name}: \
         {first_edge_ps} ps): the signal before it would be lost"
    )]
    StartAfterRecording {
        t0_ps: f64,
        first_edge_ps: f64,
        source_name: String,
    },
    /// Resampling onto bins so fine that the cube would hold more than
    /// [`time_axis::MAX_BINS_PER_RECORDED_ROW`] bins per recorded row.
    #[error(
        "dt_ps = {dt_ps} ps: the recorded rows ({source_name}) span {first_edge_ps} to \
         {last_edge_ps} ps, {needed} bins of {dt_ps} ps (at most {max}, 16 per recorded row)"
    )]
    TooManyBins {
        dt_ps: f64,
        first_edge_ps: f64,
        last_edge_ps: f64,
        needed: u64,
        max: usize,
        source_name: String,
    },
    /// Resampling asked for, but the capture records no time axis to resample from.
    #[error(
        "{input}: resampling asked for, but there is no manifest and no .img time table: \
         the bin width and start given are the axis"
    )]
    NothingToResample { input: String },
    /// A laser wavelength given explicitly contradicts the manifest's.
    #[error("laser_nm = {given} nm contradicts {}, whose [capture] laser_wavelength_nm is {recorded} nm", manifest.display())]
    LaserConflict {
        given: f64,
        manifest: PathBuf,
        recorded: f64,
    },
    /// The scanline images do not have the size the manifest records.
    #[error("{}: capture.{what} = {manifest_value}, but {} has {found}", manifest.display(), file.display())]
    ManifestSize {
        manifest: PathBuf,
        what: String,
        manifest_value: usize,
        file: PathBuf,
        found: usize,
    },
    /// A `.img` time table that differs from the first scanline's.
    #[error("{}: the .img time table differs from that of {} at row {row} ({found_ps} ps vs {expected_ps} ps)", path.display(), reference.display())]
    TimeTableMismatch {
        path: PathBuf,
        reference: PathBuf,
        row: usize,
        found_ps: f64,
        expected_ps: f64,
    },
    /// A sweep calibration table that cannot be read or parsed.
    #[error("{}: line {line}: {message}", path.display())]
    SweepTable {
        path: PathBuf,
        line: usize,
        message: String,
    },
    /// A correction's parameters do not fit the capture (`what` names the file or option).
    #[error("{what}: {source}")]
    Correction {
        what: String,
        #[source]
        source: CorrectionError,
    },
    /// `auto` saturation asked of files with floating-point samples, which have no maximum.
    #[error("{}: automatic saturation level needs integer samples, this file has {pixel_type} (give a level)", path.display())]
    SaturationAuto { path: PathBuf, pixel_type: String },
    /// A count or a memory estimate beyond what the machine can hold ([`crate::limits`]).
    #[error(transparent)]
    Limit(#[from] crate::limits::LimitError),
    /// An option value out of its range (names the option and the value).
    #[error("{what} = {value}: {message}")]
    BadValue {
        what: IngestValue,
        value: String,
        message: String,
    },
    /// The output is one of the capture's files (or a folder holding one of them).
    #[error("--out {} is also an input of this ingest ({}); choose another path", out.display(), input.display())]
    OutputIsInput { out: PathBuf, input: PathBuf },
    /// The scratch file of a two-pass ingest (beside the output) could not be written or read.
    #[error("{}: scratch file: {source}", dir.display())]
    Scratch {
        dir: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// The option values of an ingest that [`IngestError::BadValue`] can refuse; displayed as
/// the library's messages name them (a caller maps each to its own flag).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IngestValue {
    ValueScale,
    DtPs,
    T0Ps,
    LaserNm,
    DarkLevel,
    SaturationLevel,
}

impl std::fmt::Display for IngestValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            IngestValue::ValueScale => "value scale",
            IngestValue::DtPs => "dt_ps",
            IngestValue::T0Ps => "t0_ps",
            IngestValue::LaserNm => "laser_nm",
            IngestValue::DarkLevel => "dark level",
            IngestValue::SaturationLevel => "saturation level",
        })
    }
}

/// `it holds 12 .png, 1 .exr files`, or `it holds no scanline files (.png, ...)`.
fn found_words(found: &[(String, usize)]) -> String {
    if found.is_empty() {
        return format!(
            "it holds no scanline files ({})",
            crate::formats::STREAK_EXTENSIONS
                .iter()
                .map(|e| format!(".{e}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let total: usize = found.iter().map(|(_, n)| n).sum();
    let list: Vec<String> = found.iter().map(|(e, n)| format!("{n} .{e}")).collect();
    format!(
        "it holds {} file{}",
        list.join(", "),
        if total == 1 { "" } else { "s" }
    )
}

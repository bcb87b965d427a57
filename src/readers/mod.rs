//! Time-resolved files as instruments and labs save them, read into one value, [`Capture`]:
//! NumPy `.npy` and `.npz`, MATLAB `.mat` (v5 and v7.3), HyperSpy `.hspy`, plain HDF5
//! datasets, Delmic SPARC HDF5 (Odemis) and PicoQuant PTU time-tagged records. `femto ingest`
//! writes a cube from it ([`crate::ingest::arrays`]) and `femto info` describes it. Which
//! kind a file is, is decided here ([`Format::sniff`]) and nowhere else.
//!
//! | module | what it reads |
//! |---|---|
//! | `dtype` | stored sample types and their decoding into f32 ([`Dtype`]) |
//! | `array` | an N-D array in C order, column-major reordering |
//! | [`layout`] | which axis is time, which are rows and columns, what the others become |
//! | [`npy`] | `.npy`, C and Fortran order, every integer and float type, both byte orders |
//! | `npz` | `.npz`: a zip of `.npy` arrays, each one a dataset |
//! | [`mat`] | MATLAB v5 (compressed elements too) and v7.3 (HDF5 behind a user block) |
//! | `hspy` | HyperSpy signals with their axes |
//! | `hdf5_array` | one plain HDF5 dataset, its dimension labels and the bin width its group records |
//! | `delmic` | Delmic SPARC acquisitions: `Image` (C, T, Z, Y, X) with its dimension scales |
//! | [`ptu`] | PicoQuant PTU: T3 records of image scans and point measurements, histogrammed |
//! | `datasets` | the candidate arrays of a file, pictures left out |
//! | `open` | [`open`]: a file of any of these formats into a [`Capture`] |
//! | `h5` | the HDF5 reading these share |
//!
//! Layout: the array's axes are numbered as the file stores them (the shape `femto info`
//! prints); time is the axis the file names, or `--time-axis N`, or the last one when that is
//! unambiguous ([`layout`]); the other axes become rows and columns in their order.

mod array;
mod datasets;
mod delmic;
mod dtype;
mod h5;
mod hdf5_array;
mod hspy;
pub mod layout;
pub mod mat;
pub mod npy;
mod npz;
mod open;
pub mod ptu;

pub use array::{column_major_to_c, permute, Array};
pub use datasets::{candidates, Candidate};
pub use dtype::{decode, Decoded, Dtype};
pub use hdf5_array::{ambiguous_3d_dataset, is_3d_dataset, is_streak_stack};
pub use hspy::ps_per_unit;
pub use layout::{AxisRef, LayoutOptions};
pub use open::open;

use std::path::{Path, PathBuf};

/// What can go wrong reading an array file; every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum ReaderError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Hdf5 { path: PathBuf, message: String },
    /// A value, key or flag that does not fit.
    #[error("{path}: {key}: {message}")]
    Invalid {
        path: PathBuf,
        key: String,
        message: String,
    },
    /// The file reads, but which of its arrays or axes are the data is for the user to say
    /// (`--dataset`, `--time-axis`, `--select`, `--sum`): `femto info` describes such a file,
    /// `femto ingest` refuses it.
    #[error("{path}: {key}: {message}")]
    Choice {
        path: PathBuf,
        key: String,
        message: String,
    },
    #[error("{path}: {source}")]
    Limit {
        path: PathBuf,
        source: crate::limits::LimitError,
    },
    /// Writing the cube failed (the message names the file).
    #[error(transparent)]
    Container(#[from] crate::container::ContainerError),
}

impl ReaderError {
    /// A value, key or flag that does not fit. Names and values read from the file (a
    /// variable's name, a dataset's) may hold control characters: they are escaped, so that
    /// the message stays one line.
    pub(crate) fn invalid(path: &Path, key: &str, message: impl Into<String>) -> ReaderError {
        ReaderError::Invalid {
            path: path.to_path_buf(),
            key: one_line(key),
            message: one_line(&message.into()),
        }
    }

    /// A choice the file leaves to the user ([`ReaderError::Choice`]), one line as
    /// [`ReaderError::invalid`].
    pub(crate) fn choice(path: &Path, key: &str, message: impl Into<String>) -> ReaderError {
        ReaderError::Choice {
            path: path.to_path_buf(),
            key: one_line(key),
            message: one_line(&message.into()),
        }
    }

    /// The same error with `more` after its message (an `Invalid` or `Choice` only), one
    /// line as [`ReaderError::invalid`] (`more` may name variables of the file).
    pub(crate) fn and_then_say(self, more: &str) -> ReaderError {
        let more = one_line(more);
        match self {
            ReaderError::Invalid { path, key, message } => ReaderError::Invalid {
                path,
                key,
                message: format!("{message}{more}"),
            },
            ReaderError::Choice { path, key, message } => ReaderError::Choice {
                path,
                key,
                message: format!("{message}{more}"),
            },
            e => e,
        }
    }
}

/// `text` with its control characters (a newline, a NUL) escaped as `\n`, `\0`.
fn one_line(text: &str) -> String {
    if text.chars().any(char::is_control) {
        text.chars()
            .map(|c| {
                if c.is_control() {
                    c.escape_default().to_string()
                } else {
                    c.to_string()
                }
            })
            .collect()
    } else {
        text.to_string()
    }
}

/// Float32 copies of an array's values that reading it and writing its cube hold at once:
/// the decoded values, their reorder (C order, x-y-t order, a resampled time axis), and the
/// cube writer's buffers.
pub const F32_COPIES: usize = 3;

/// The size check of every array reader, made from the header alone before any value is
/// read, inflated or allocated ([`crate::limits::check_decoded`]): the values of `dims`,
/// stored as `stored`, decoded to float32 with [`F32_COPIES`] held at once, plus the stored
/// bytes themselves when the reader holds them whole (`raw_held`: an HDF5 dataset is read
/// whole before it is decoded). `what` names the array in the file ("variable rect").
pub fn check_decode(
    path: &Path,
    what: &str,
    dims: &[usize],
    stored: Dtype,
    raw_held: bool,
) -> Result<(), ReaderError> {
    let copies = F32_COPIES
        + if raw_held {
            stored.size().div_ceil(4)
        } else {
            0
        };
    let shape: Vec<String> = dims.iter().map(|d| d.to_string()).collect();
    crate::limits::check_decoded(
        dims,
        4,
        copies,
        format_args!(
            "{what} of {} {} values (read as float32, {copies} copies held)",
            shape.join(" x "),
            stored.name()
        ),
        "crop or downsample it first",
    )
    .map(|_| ())
    .map_err(|source| ReaderError::Limit {
        path: path.to_path_buf(),
        source,
    })
}

/// Refuse before allocating `bytes` (a size a file declares or has, times what reading it
/// costs): checked against the memory this process may use ([`crate::limits::check_memory`]);
/// `None` (an overflow in the caller's checked product) is refused too.
pub(crate) fn check_bytes(path: &Path, bytes: Option<u128>, what: &str) -> Result<(), ReaderError> {
    let needed = bytes.map_or(f64::INFINITY, |b| b as f64);
    crate::limits::check_memory(needed, what, "crop or split it first").map_err(|source| {
        ReaderError::Limit {
            path: path.to_path_buf(),
            source,
        }
    })
}

/// The file formats femto reads as arrays; each owns its extensions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Npy,
    Npz,
    Mat,
    Hspy,
    Hdf5Array,
    Delmic,
    Ptu,
}

/// Formats femto knows and does not read, by extension, with the tool that converts them.
const CONVERT: [(&str, &str); 4] = [
    ("sdt", "a Becker & Hickl SPCImage .sdt file: export it as .npy or HDF5 (sdtfile in Python: sdtfile.SdtFile(f).data[0], then numpy.save), or to .ptu"),
    ("spc", "a Becker & Hickl .spc photon stream: histogram it first (tttrlib or sdtfile in Python) and save it as .npy"),
    ("pt3", "a PicoQuant .pt3 file (the PTU format's predecessor): convert it with ptufile or tttrlib in Python, or save the histogram as .npy"),
    ("phu", "a PicoQuant .phu histogram file: read it with ptufile (PhuFile) in Python and save the histograms as .npy"),
];

impl Format {
    /// Every format, in the order messages list them.
    pub const ALL: [Format; 7] = [
        Format::Npy,
        Format::Npz,
        Format::Mat,
        Format::Hspy,
        Format::Hdf5Array,
        Format::Delmic,
        Format::Ptu,
    ];

    /// Its name in messages and provenance.
    pub fn name(self) -> &'static str {
        match self {
            Format::Npy => "NumPy array",
            Format::Npz => "NumPy .npz archive",
            Format::Mat => "MATLAB file",
            Format::Hspy => "HyperSpy signal",
            Format::Hdf5Array => "HDF5 dataset",
            Format::Delmic => "Delmic SPARC acquisition",
            Format::Ptu => "PicoQuant PTU file",
        }
    }

    /// The extensions (lower case) that name it.
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            Format::Npy => &["npy"],
            Format::Npz => &["npz"],
            Format::Mat => &["mat"],
            Format::Hspy => &["hspy"],
            Format::Hdf5Array | Format::Delmic => &["h5", "hdf5", "he5"],
            Format::Ptu => &["ptu"],
        }
    }

    /// One line listing what femto reads, for the refusal of a file it does not.
    pub fn readable_list() -> String {
        "femto reads femto cubes (.h5), streak images (.png, .tif, .tiff, .exr, .hdr, .img), \
         capture folders and manifests, meshes (.obj, .gltf, .glb), y-tal captures, arrays \
         (.npy, .npz, .mat, .hspy, HDF5 datasets), Delmic SPARC HDF5 and PicoQuant .ptu"
            .to_string()
    }

    /// For a format femto knows and does not read (by extension): what to convert it with.
    pub fn convert_hint(path: &Path) -> Option<&'static str> {
        let ext = extension(path);
        CONVERT.iter().find(|(e, _)| *e == ext).map(|(_, h)| *h)
    }

    /// The format of `path` from its extension and contents: `.npy`, `.npz`; `.mat`, or an
    /// HDF5 file behind a MATLAB 7.3 header; `.hspy`, or an HDF5 file whose root says
    /// `file_format = HyperSpy`; `.ptu`, or a file starting `PQTTTR`; an HDF5 file with a
    /// Delmic acquisition (`AcquisitionN/ImageData/Image`); any other HDF5 file is
    /// [`Format::Hdf5Array`]. `None`: not an array file (an image, a folder, a missing file).
    pub fn sniff(path: &Path) -> Option<Format> {
        let ext = extension(path);
        let by_ext = [
            Format::Npy,
            Format::Npz,
            Format::Mat,
            Format::Hspy,
            Format::Ptu,
        ]
        .into_iter()
        .find(|f| f.extensions().contains(&ext.as_str()));
        if by_ext.is_some() {
            return by_ext;
        }
        if !path.is_file() {
            return None;
        }
        let mut head = [0u8; 20];
        let n = std::fs::File::open(path)
            .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
            .unwrap_or(0);
        if head[..n].starts_with(ptu::MAGIC) {
            return Some(Format::Ptu);
        }
        if !crate::container::is_hdf5(path).unwrap_or(false) {
            return None;
        }
        if mat::is_v73_header(&head[..n]) {
            return Some(Format::Mat);
        }
        match h5::open(path) {
            Ok(file) if hspy::is_hyperspy(&file) => Some(Format::Hspy),
            Ok(file) if !delmic::acquisitions(&file).is_empty() => Some(Format::Delmic),
            _ => Some(Format::Hdf5Array),
        }
    }
}

/// The extension of `path` in lower case ("" without one).
fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// A space axis of the file (or any axis other than time): its name, units, and either a
/// uniform `scale`/`offset` or explicit values.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    pub name: String,
    pub units: String,
    pub scale: Option<f64>,
    pub offset: Option<f64>,
    pub values: Option<Vec<f64>>,
}

/// The shortest bin width femto accepts, ps ([`crate::ranges::BIN_WIDTH_PS`]).
pub const MIN_DT_PS: f64 = crate::ranges::BIN_WIDTH_PS.lo;
/// The longest bin width, ps ([`crate::ranges::BIN_WIDTH_PS`]).
pub const MAX_DT_PS: f64 = crate::ranges::BIN_WIDTH_PS.hi;

/// The time axis a file records, in ps.
#[derive(Clone, Debug, PartialEq)]
pub enum TimeSpec {
    /// Bins of `dt_ps` from `t0_ps` (bin `i` starts at `t0_ps + i dt_ps`).
    Uniform { t0_ps: f64, dt_ps: f64 },
    /// The bin width is recorded, the start is not.
    Width { dt_ps: f64 },
    /// The start of each bin, increasing, not uniform within 1e-6 of a bin.
    Table(Vec<f64>),
    /// Nothing (or nothing usable) is recorded: why.
    Uncalibrated { reason: String },
}

impl TimeSpec {
    /// A uniform axis, checked: a finite start and a bin width in
    /// [`MIN_DT_PS`]..[`MAX_DT_PS`].
    pub fn uniform(
        path: &Path,
        key: &str,
        t0_ps: f64,
        dt_ps: f64,
    ) -> Result<TimeSpec, ReaderError> {
        check_dt(path, key, dt_ps)?;
        check_time(path, key, t0_ps)?;
        Ok(TimeSpec::Uniform { t0_ps, dt_ps })
    }

    /// A table of bin starts: uniform within 1e-6 of a bin becomes [`TimeSpec::Uniform`].
    pub fn from_table(
        path: &Path,
        key: &str,
        starts_ps: Vec<f64>,
    ) -> Result<TimeSpec, ReaderError> {
        let n = starts_ps.len();
        if n < 2 {
            return Err(ReaderError::invalid(
                path,
                key,
                format!("a time axis of {n} value(s) gives no bin width"),
            ));
        }
        if let Some(w) = starts_ps
            .windows(2)
            .find(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
        {
            return Err(ReaderError::invalid(
                path,
                key,
                format!("time values must increase ({} then {})", w[0], w[1]),
            ));
        }
        let dt = (starts_ps[n - 1] - starts_ps[0]) / (n - 1) as f64;
        check_dt(path, key, dt)?;
        let t0 = starts_ps[0];
        let uniform = starts_ps
            .iter()
            .enumerate()
            .all(|(i, t)| (t - (t0 + i as f64 * dt)).abs() <= 1e-6 * dt);
        if uniform {
            TimeSpec::uniform(path, key, t0, dt)
        } else {
            Ok(TimeSpec::Table(starts_ps))
        }
    }
}

/// A bin width in [`crate::ranges::BIN_WIDTH_PS`].
pub fn check_dt(path: &Path, key: &str, dt_ps: f64) -> Result<(), ReaderError> {
    crate::ranges::check("bin width", dt_ps, crate::ranges::BIN_WIDTH_PS)
        .map(|_| ())
        .map_err(|e| ReaderError::invalid(path, key, format!("bin width {}", e.detail())))
}

/// A time (an axis's start) in [`crate::ranges::TIME_PS`].
pub fn check_time(path: &Path, key: &str, t_ps: f64) -> Result<(), ReaderError> {
    crate::ranges::check("time", t_ps, crate::ranges::TIME_PS)
        .map(|_| ())
        .map_err(|e| ReaderError::invalid(path, key, format!("time offset {}", e.detail())))
}

/// How to read a file: which dataset or variable, and its layout.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReadOptions {
    /// The dataset (HDF5), variable (`.mat`), array (`.npz`), signal (`.hspy`) or
    /// acquisition (Delmic); `None`: the only candidate.
    pub dataset: Option<String>,
    /// Which axis is time, what becomes of the extra ones ([`layout`]).
    pub layout: LayoutOptions,
}

/// A file read: what it is, its x-y-t samples and its axes.
#[derive(Clone, Debug, PartialEq)]
pub struct Capture {
    pub path: PathBuf,
    pub format: Format,
    /// Which dataset, variable or signal, as the user would name it.
    pub source: String,
    pub stored_shape: Vec<usize>,
    pub dtype: Dtype,
    pub ny: usize,
    pub nx: usize,
    pub nt: usize,
    pub time: TimeSpec,
    /// Where the time axis came from (an axis, a key), for provenance.
    pub time_source: String,
    /// Which stored axis became time, rows and columns, and what became of the others.
    pub layout: String,
    /// The row and column axes, when the file records them.
    pub y: Option<Axis>,
    pub x: Option<Axis>,
    /// `[y][x][t]`.
    pub samples: Vec<f32>,
    /// Other values the file holds, kept as cube attributes (`mat.width`).
    pub attributes: Vec<(String, String)>,
    /// Integer samples f32 does not hold exactly, and the largest of them.
    pub inexact: usize,
    pub largest_inexact: f64,
}

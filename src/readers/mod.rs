//! Array files as labs save them, read into one value, [`Capture`]: NumPy `.npy`, MATLAB
//! `.mat` (v5 and v7.3), HyperSpy `.hspy`, and plain HDF5 datasets. `femto ingest` writes a
//! cube from it ([`crate::ingest::arrays`]) and `femto info` describes it.
//!
//! | module | what it reads |
//! |---|---|
//! | `dtype` | stored sample types and their decoding into f32 ([`Dtype`]) |
//! | `array` | an N-D array in C order, column-major reordering, the move of time last |
//! | [`npy`] | `.npy`, C and Fortran order, every integer and float type, both byte orders |
//! | [`mat`] | MATLAB v5 (compressed elements too) and v7.3 (HDF5 behind a user block) |
//! | `hspy` | HyperSpy signals with their axes |
//! | `hdf5_array` | one plain HDF5 dataset and the bin width its group records |
//! | `h5` | the HDF5 reading these share |
//!
//! Layout: an array's time dimension becomes the cube's bins, the others its rows and
//! columns in their order. A 3-D array `A[i, j, k]` is row `i`, column `j`, bin `k`; a 2-D
//! array `A[i, k]` is one scanline, pixel `i`, bin `k`; a 1-D array is one pixel. For
//! `.npy`, `.mat` and plain HDF5 the time dimension is the last one, or the one before it
//! with `transpose` (a 2-D `(t, x)` image, a 3-D `(y, t, x)` stack); a HyperSpy signal's is
//! the axis with time units, and a plain dataset's the one a sibling `n_timebins` names.

mod array;
mod dtype;
mod h5;
mod hdf5_array;
mod hspy;
pub mod mat;
pub mod npy;

pub use array::{column_major_to_c, permute, Array};
pub use dtype::{decode, Decoded, Dtype};
pub use hspy::ps_per_unit;

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

/// The array formats; each owns its extensions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Npy,
    Mat,
    Hspy,
    Hdf5Array,
}

impl Format {
    /// Its name in messages and provenance.
    pub fn name(self) -> &'static str {
        match self {
            Format::Npy => "NumPy array",
            Format::Mat => "MATLAB file",
            Format::Hspy => "HyperSpy signal",
            Format::Hdf5Array => "HDF5 dataset",
        }
    }

    /// The extensions (lower case) that name it.
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            Format::Npy => &["npy"],
            Format::Mat => &["mat"],
            Format::Hspy => &["hspy"],
            Format::Hdf5Array => &["h5", "hdf5", "he5"],
        }
    }

    /// The format of `path` from its extension and contents: `.npy`; `.mat`, or an HDF5
    /// file behind a MATLAB 7.3 header; `.hspy`, or an HDF5 file whose root says
    /// `file_format = HyperSpy`; any other HDF5 file is [`Format::Hdf5Array`]. `None`: not
    /// an array file (an image, a folder, a missing file).
    pub fn sniff(path: &Path) -> Option<Format> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        let by_ext = [Format::Npy, Format::Mat, Format::Hspy]
            .into_iter()
            .find(|f| f.extensions().contains(&ext.as_str()));
        if by_ext.is_some() {
            return by_ext;
        }
        if !path.is_file() || !crate::container::is_hdf5(path).unwrap_or(false) {
            return None;
        }
        let mut head = [0u8; 20];
        let n = std::fs::File::open(path)
            .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
            .unwrap_or(0);
        if mat::is_v73_header(&head[..n]) {
            return Some(Format::Mat);
        }
        match h5::open(path) {
            Ok(file) if hspy::is_hyperspy(&file) => Some(Format::Hspy),
            _ => Some(Format::Hdf5Array),
        }
    }
}

/// A time or space axis of the file other than time: its name, units, and either a
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

/// How to read a file: which dataset or variable, and whether time comes before x.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReadOptions {
    /// The dataset (HDF5), variable (`.mat`) or signal (`.hspy`); `None`: the only one.
    pub dataset: Option<String>,
    /// The array stores time before x (the last two dimensions swapped).
    pub transpose: bool,
}

/// An array file read: what it is, its x-y-t samples and its axes.
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

/// The time dimension of a rank-`rank` array: the last, or the one before it (`transpose`).
fn default_t_dim(rank: usize, transpose: bool) -> usize {
    if transpose && rank >= 2 {
        rank - 2
    } else {
        rank.saturating_sub(1)
    }
}

/// Open the array file at `path` as `format` (see [`Format::sniff`]).
pub fn open(path: &Path, format: Format, options: &ReadOptions) -> Result<Capture, ReaderError> {
    let dataset = options.dataset.as_deref();
    let no_axis = |what: &str| TimeSpec::Uncalibrated {
        reason: format!("{what} records no time axis"),
    };
    let (source, array, t_dim, time, time_source, axes, attributes) = match format {
        Format::Npy => {
            if dataset.is_some() {
                return Err(ReaderError::invalid(
                    path,
                    "--dataset",
                    "a .npy file holds one array",
                ));
            }
            let a = npy::read_npy(path)?;
            let t = default_t_dim(a.shape.len(), options.transpose);
            (
                String::new(),
                a,
                t,
                no_axis("a .npy array"),
                String::new(),
                vec![],
                vec![],
            )
        }
        Format::Mat => {
            let (name, a, attrs) = mat_variable(path, dataset)?;
            let t = default_t_dim(a.shape.len(), options.transpose);
            let src = format!("variable {name}");
            (
                src,
                a,
                t,
                no_axis("a MATLAB array"),
                String::new(),
                vec![],
                attrs,
            )
        }
        Format::Hspy => {
            let file = h5::open(path)?;
            let s = hspy::read_signal(&file, path, dataset)?;
            let t = match s.t_dim {
                Some(_) if options.transpose => {
                    return Err(ReaderError::invalid(
                        path,
                        "--transpose",
                        "a HyperSpy signal names its time axis; leave out --transpose",
                    ))
                }
                Some(d) => d,
                None => default_t_dim(s.array.shape.len(), options.transpose),
            };
            let ts = s.t_dim.map_or(String::new(), |d| format!("axis-{d}"));
            (
                format!("signal {}", s.name),
                s.array,
                t,
                s.time,
                ts,
                s.axes,
                vec![],
            )
        }
        Format::Hdf5Array => {
            let file = h5::open(path)?;
            let p = hdf5_array::read_plain(&file, path, dataset)?;
            let rank = p.array.shape.len();
            let (t, t_note) = match &p.t_dim {
                Some((d, key)) => (*d, format!("time dimension {d} from {key}")),
                None => (default_t_dim(rank, options.transpose), String::new()),
            };
            let (time, ts) = match (&p.dt_ps, &p.t0_ps) {
                (Some((dt, kd)), Some((t0, k0))) => (
                    TimeSpec::uniform(path, kd, *t0, *dt)?,
                    format!("bin width from {kd}, start from {k0}"),
                ),
                (Some((dt, kd)), None) => {
                    check_dt(path, kd, *dt)?;
                    (
                        TimeSpec::Width { dt_ps: *dt },
                        format!("bin width from {kd}"),
                    )
                }
                _ => (
                    no_axis(&format!("/{} (no sibling timebin_width_ps, dt_ps)", p.name)),
                    String::new(),
                ),
            };
            let ts = [ts, t_note]
                .into_iter()
                .filter(|s| !s.is_empty())
                .collect::<Vec<_>>()
                .join("; ");
            (
                format!("dataset /{}", p.name),
                p.array,
                t,
                time,
                ts,
                vec![],
                vec![],
            )
        }
    };
    let stored_shape = array.shape.clone();
    let rank = stored_shape.len();
    let (ny, nx, nt, samples) = array::to_xyt(&array, t_dim).ok_or_else(|| {
        let hint = if format == Format::Npy && rank == 4 {
            " (a 4-D (H, W, T, C) array is a mitransient render: give --start-opl-m and \
             --bin-width-opl-m)"
        } else {
            ""
        };
        ReaderError::invalid(
            path,
            "shape",
            format!("{stored_shape:?}: 1 to 3 dimensions are read{hint}"),
        )
    })?;
    if ny * nx * nt == 0 {
        return Err(ReaderError::invalid(
            path,
            "shape",
            format!("{stored_shape:?} is empty"),
        ));
    }
    if let TimeSpec::Table(t) = &time {
        if t.len() != nt {
            return Err(ReaderError::invalid(
                path,
                "time axis",
                "length differs from the data",
            ));
        }
    }
    let (y, x) = match axes.len() {
        2 => (Some(axes[0].clone()), Some(axes[1].clone())),
        1 => (None, Some(axes[0].clone())),
        _ => (None, None),
    };
    Ok(Capture {
        path: path.to_path_buf(),
        format,
        source,
        stored_shape,
        dtype: array.dtype,
        ny,
        nx,
        nt,
        time,
        time_source,
        y,
        x,
        samples,
        attributes,
        inexact: array.inexact,
        largest_inexact: array.largest_inexact,
    })
}

/// A variable picked: its name, its array, the scalars kept as attributes.
type MatPick = (String, Array, Vec<(String, String)>);

/// The variable of a `.mat` file: the one named, else the only 3-D numeric array (else the
/// only 2-D one); numeric scalars become attributes `mat.NAME`.
fn mat_variable(path: &Path, want: Option<&str>) -> Result<MatPick, ReaderError> {
    // A first pass lists the variables without decoding the large ones.
    let listed = mat::read_mat(path, &|_| false)?;
    let numeric = |v: &&mat::MatVar| v.dtype.is_some();
    let pick = match want {
        Some(w) => match listed.iter().find(|v| v.name == w) {
            Some(v) if v.dtype.is_some() => v.name.clone(),
            Some(v) => {
                return Err(ReaderError::invalid(
                    path,
                    "--dataset",
                    format!("variable {w} is a {} array, not a numeric one", v.class),
                ))
            }
            None => {
                let names: Vec<&str> = listed.iter().map(|v| v.name.as_str()).collect();
                return Err(ReaderError::invalid(
                    path,
                    "--dataset",
                    format!("no variable {w}; the file holds: {}", names.join(", ")),
                ));
            }
        },
        None => {
            let rank = |r: usize| -> Vec<&mat::MatVar> {
                listed
                    .iter()
                    .filter(numeric)
                    .filter(|v| v.dims.iter().filter(|&&d| d > 1).count() == r)
                    .collect()
            };
            let three = rank(3);
            let c = if three.is_empty() { rank(2) } else { three };
            match c.as_slice() {
                [one] => one.name.clone(),
                [] => {
                    return Err(ReaderError::invalid(
                        path,
                        "--dataset",
                        "no numeric array of 2 or 3 dimensions",
                    ))
                }
                many => {
                    let list: Vec<String> = many
                        .iter()
                        .map(|v| format!("{} {:?}", v.name, v.dims))
                        .collect();
                    return Err(ReaderError::invalid(
                        path,
                        "--dataset",
                        format!(
                            "several arrays could be the data; name one of: {}",
                            list.join(", ")
                        ),
                    ));
                }
            }
        }
    };
    let vars = mat::read_mat(path, &|n| n == pick)?;
    let mut attrs = Vec::new();
    let mut chosen = None;
    for v in vars {
        if v.name == pick {
            chosen = v.array;
        } else if let Some(x) = v.scalar {
            attrs.push((format!("mat.{}", v.name), x.to_string()));
        }
    }
    let mut array = chosen.ok_or_else(|| ReaderError::invalid(path, &pick, "not read"))?;
    // MATLAB arrays have at least 2 dimensions; trailing singleton ones are dropped (a
    // column vector (n, 1) stays 2-D).
    while array.shape.len() > 2 && array.shape.last() == Some(&1) {
        array.shape.pop();
    }
    Ok((pick, array, attrs))
}

/// The plain HDF5 file's only candidate dataset when it is a 3-D one that records no time
/// axis: either a stack of streak images `(ny, nt, nx)` (`--dataset NAME`, the scanline route)
/// or an x-y-t cube `(ny, nx, nt)` (`--from array`). Nothing in the file tells them apart,
/// so `femto ingest` asks which rather than guess.
pub fn ambiguous_3d_dataset(path: &Path) -> Option<String> {
    let file = h5::open(path).ok()?;
    match hdf5_array::candidates(&file).as_slice() {
        [(name, shape)] if shape.len() == 3 && is_streak_stack(path, name) => Some(name.clone()),
        _ => None,
    }
}

/// Whether `dataset` of the HDF5 file `path` is 3-D: named with `--dataset`, such a dataset
/// is a stack of streak images `(ny, nt, nx)` for the scanline route of `femto ingest`.
pub fn is_3d_dataset(path: &Path, dataset: &str) -> bool {
    let Ok(file) = h5::open(path) else {
        return false;
    };
    matches!(
        hdf5_array::read_keys(&file, dataset.trim_start_matches('/')),
        Some((3, _))
    )
}

/// Whether `dataset` of the plain HDF5 file `path` is a stack of streak images for the
/// scanline route of `femto ingest` (`(ny, nt, nx)`, streak corrections apply): a 3-D
/// dataset whose group records no bin width or bin count. Any other dataset is an
/// assembled array read by [`open`].
pub fn is_streak_stack(path: &Path, dataset: &str) -> bool {
    let Ok(file) = h5::open(path) else {
        return false;
    };
    match hdf5_array::read_keys(&file, dataset.trim_start_matches('/')) {
        Some((rank, recorded)) => rank == 3 && !recorded,
        None => false,
    }
}

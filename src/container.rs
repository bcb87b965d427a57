//! The on-disk cube container: HDF5 files holding a [`Cube`] plus optional extra groups.
//!
//! This is the only module of femto that talks to HDF5 (through the pure-Rust `rust_hdf5`
//! crate), so the choice of library can change here alone. The schema is documented for
//! users of other tools in `docs/cube-format.md`; in short:
//!
//! - `/cube`: f32, shape `(ny, nx, nt)`, i.e. the in-memory layout `[y][x][t]` of
//!   [`Cube`], chunked `(1, cx, nt)` and compressed with shuffle + deflate. Bin `i` covers
//!   `[t0_ps + i dt_ps, t0_ps + (i + 1) dt_ps)` and holds the signal integrated over it.
//!   Attributes: `t0_ps` (f64), `dt_ps` (f64), `time_frame` (`"camera"` or `"world"`,
//!   physics.md "two clocks"), `units` (string), `femto_version`, `command_line` and any
//!   provenance notes (strings).
//! - `/mask`: optional u8, shape `(ny, nx)`, 1 where a pixel holds valid data.
//! - `/<group>`: optional extra groups (e.g. `registration`, `pyramid`) holding datasets and
//!   attributes, read and written generically as [`GroupData`].
//!
//! Cubes can be streamed by row slabs ([`CubeWriter`], [`CubeReader`]) so that commands can
//! process cubes larger than memory. Every write is atomic: it goes to a temporary file in
//! the destination folder which is renamed onto the destination only on success.

use crate::atomic::write_atomically;
use crate::cube::{self, Cube, TimeAxis, TimeFrame};
use rayon::prelude::*;
use rust_hdf5::format::messages::filter::{
    apply_filters, reverse_filters_masked_bounded, FILTER_DEFLATE, FILTER_SHUFFLE,
};
use rust_hdf5::{
    DatatypeMessage, FilterPipeline, H5Dataset, H5File, H5Group, H5Type, Hdf5Error, VarLenUnicode,
};
use serde_json::{json, Value};
use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// Name of the cube dataset at the file root.
pub const CUBE_DATASET: &str = "cube";
/// Name of the optional validity-mask dataset at the file root.
pub const MASK_DATASET: &str = "mask";
/// Units written by [`write_cube`] when the caller names none: the cube holds relative
/// signal per bin with no absolute calibration.
pub const DEFAULT_UNITS: &str = "arbitrary";
/// String attribute on each extra group holding all its attributes, typed, as JSON.
///
/// `rust_hdf5` 0.7 can read numeric attributes of datasets but only string attributes of
/// groups, so a group's attributes are written twice from the same values: as ordinary
/// HDF5 attributes (what h5py users read) and in this one JSON index (what femto reads).
pub const GROUP_ATTRS_INDEX: &str = "_femto_attrs";

/// Attribute names of `/cube` that are not provenance notes.
const RESERVED_ATTRS: [&str; 6] = [
    "t0_ps",
    "dt_ps",
    "time_frame",
    "units",
    "femto_version",
    "command_line",
];

/// Deflate level: 4 is h5py's default for gzip, a good speed/size trade for f32 signal.
const DEFLATE_LEVEL: u32 = 4;

/// Target size of one chunk, bytes.
///
/// The cube is chunked `(1, cx, nt)` with `cx` the width of `n = ceil(nx / cx_max)` equal
/// chunks, `cx = ceil(nx / n)`, where `cx_max = clamp(CHUNK_TARGET_BYTES / (4 nt), 1, nx)`
/// (so a 672-pixel row of 512 bins is 6 chunks of 112 pixels, not 5 of 128 and a sixth
/// padded from 32 to 128, which stored and compressed 14 % more bytes):
/// one chunk never spans two rows, so writing or reading a slab of whole rows touches only
/// whole chunks (no read-modify-write, and a streaming writer keeps nothing but the slab it
/// is given); every chunk holds whole time profiles, so reading one pixel's profile (the
/// most common access from h5py, `f["cube"][y, x, :]`) decompresses at most one chunk; and
/// 256 KiB fits h5py's default 1 MiB chunk cache, so a loop over neighbouring pixels does
/// not decompress the same chunk again and again.
const CHUNK_TARGET_BYTES: usize = 256 * 1024;

/// Largest slab of rows moved at once when copying or scanning a cube, bytes.
const SLAB_TARGET_BYTES: usize = 32 << 20;

/// Errors of the cube container. Every message names the file, and the dataset or
/// attribute where one is involved.
#[derive(Debug, thiserror::Error)]
pub enum ContainerError {
    /// A dataset larger than the memory this machine has available ([`crate::limits`]).
    #[error("{}: {source}", path.display())]
    Limit {
        path: PathBuf,
        #[source]
        source: crate::limits::LimitError,
    },
    /// The file or its folder could not be opened, created, read or renamed (a missing file
    /// or folder, no permission, a full disk).
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    /// The file exists but is not an HDF5 file (no HDF5 signature).
    #[error("{}: not an HDF5 file", path.display())]
    NotHdf5 { path: PathBuf },
    /// The HDF5 file holds no `/cube` dataset.
    #[error("{}: no /cube dataset, so not a femto cube", path.display())]
    NoCube { path: PathBuf },
    /// A dataset has a number of dimensions other than the schema's.
    #[error("{}: dataset /{dataset} has {found} dimensions, expected {expected}", path.display())]
    WrongRank {
        path: PathBuf,
        dataset: String,
        found: usize,
        expected: usize,
    },
    /// A dataset holds elements of a type the schema does not allow.
    #[error("{}: dataset /{dataset} holds {found}, expected {expected}", path.display())]
    WrongType {
        path: PathBuf,
        dataset: String,
        found: String,
        expected: String,
    },
    /// A dataset's shape disagrees with the cube it belongs to.
    #[error("{}: dataset /{dataset} has shape {found:?}, expected {expected:?}", path.display())]
    WrongShape {
        path: PathBuf,
        dataset: String,
        found: Vec<usize>,
        expected: Vec<usize>,
    },
    /// A required attribute is absent.
    #[error("{}: /{object} has no attribute '{attr}'", path.display())]
    MissingAttribute {
        path: PathBuf,
        object: String,
        attr: String,
    },
    /// An attribute is present but its type or value cannot be used (a `time_frame` other
    /// than "camera" or "world", a non-positive `dt_ps`, a numeric attribute where a string
    /// is expected).
    #[error("{}: attribute '{attr}' of /{object}: {reason}", path.display())]
    BadAttribute {
        path: PathBuf,
        object: String,
        attr: String,
        reason: String,
    },
    /// A named group is absent.
    #[error("{}: no group /{group}", path.display())]
    NoGroup { path: PathBuf, group: String },
    /// A named dataset is absent.
    #[error("{}: no dataset /{dataset}", path.display())]
    NoDataset { path: PathBuf, dataset: String },
    /// What the caller asked for does not fit the schema or the file: an empty or
    /// non-finite time axis, a buffer whose length is not a whole number of rows, a row
    /// range past the end, a reserved or duplicate name, rows never written.
    #[error("{}: {reason}", path.display())]
    Invalid { path: PathBuf, reason: String },
    /// A dataset read for computation holds a NaN or an infinity (a cube or pyramid written by
    /// another tool, or damaged): named with its first pixel and bin, before any stage uses it.
    #[error("{}: {dataset} has {} at x {}, y {}, bin {}", path.display(), at.kind(), at.x, at.y, at.bin)]
    NonFinite {
        path: PathBuf,
        /// The dataset, e.g. `cube` or `pyramid/level_2`.
        dataset: String,
        at: cube::NonFiniteAt,
    },
    /// Any other failure reported by the HDF5 library (a corrupt or unsupported file).
    #[error("{}: HDF5: {message}", path.display())]
    Hdf5 { path: PathBuf, message: String },
}

impl From<io::Error> for ContainerError {
    /// An I/O error without a path yet; `ContainerError::at` fills it in.
    fn from(source: io::Error) -> Self {
        ContainerError::Io {
            path: PathBuf::new(),
            source,
        }
    }
}

impl ContainerError {
    /// Name `path` in an I/O error that was raised without one.
    fn at(self, path: &Path) -> Self {
        match self {
            ContainerError::Io { path: p, source } if p.as_os_str().is_empty() => {
                ContainerError::Io {
                    path: path.to_path_buf(),
                    source,
                }
            }
            other => other,
        }
    }
}

type Result<T> = std::result::Result<T, ContainerError>;

/// Map an error of the HDF5 layer to a [`ContainerError`] naming `path`.
fn h5(path: &Path) -> impl Fn(Hdf5Error) -> ContainerError + '_ {
    move |e| match e {
        Hdf5Error::Io(source) => ContainerError::Io {
            path: path.to_path_buf(),
            source,
        },
        other => ContainerError::Hdf5 {
            path: path.to_path_buf(),
            message: other.to_string(),
        },
    }
}

fn invalid(path: &Path, reason: impl Into<String>) -> ContainerError {
    ContainerError::Invalid {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

/// How the `/cube` dataset of a streamed cube is stored (the chunk shape is the same).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CubeCompression {
    /// Shuffle + deflate at this level (0-9); level 4 is femto's default, as h5py's gzip.
    Deflate(u32),
    /// No filter: chunks stored as they are (fastest to write, about three times larger for
    /// camera data).
    None,
}

impl Default for CubeCompression {
    fn default() -> Self {
        CubeCompression::Deflate(DEFLATE_LEVEL)
    }
}

/// Who made a cube: stored as string attributes of `/cube`. The femto version is added
/// automatically.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Provenance {
    /// The command line that made the file.
    pub command_line: String,
    /// Free-form `(key, value)` notes, e.g. `("ingest.dark_frame", "dark.png")`; each becomes
    /// a string attribute of `/cube` named `key`.
    pub notes: Vec<(String, String)>,
}

impl Provenance {
    /// Provenance with a command line and no notes.
    pub fn new(command_line: impl Into<String>) -> Provenance {
        Provenance {
            command_line: command_line.into(),
            notes: Vec::new(),
        }
    }

    /// Add a note.
    pub fn with_note(mut self, key: impl Into<String>, value: impl Into<String>) -> Provenance {
        self.notes.push((key.into(), value.into()));
        self
    }
}

/// Everything about a cube file but its values.
#[derive(Clone, Debug, PartialEq)]
pub struct CubeMeta {
    pub nx: usize,
    pub ny: usize,
    pub axis: TimeAxis,
    pub frame: TimeFrame,
    /// Units of the cube values (each value is the signal integrated over one bin).
    pub units: String,
    /// The femto version that wrote the file (None for a file written by another tool).
    pub femto_version: Option<String>,
    /// The command line that made the file (None for a file written by another tool).
    pub command_line: Option<String>,
    /// Provenance notes: every other attribute of `/cube`, in file order.
    pub notes: Vec<(String, String)>,
    /// Names of the extra groups at the file root, sorted.
    pub groups: Vec<String>,
    /// Whether the file holds a `/mask` dataset.
    pub has_mask: bool,
}

impl CubeMeta {
    /// Size of the cube in memory once loaded (f32 values plus the mask), bytes.
    pub fn size_bytes(&self) -> usize {
        let pixels = self.nx * self.ny;
        pixels * self.axis.nt * std::mem::size_of::<f32>() + if self.has_mask { pixels } else { 0 }
    }

    /// Number of f32 values in one row (`nx * nt`).
    pub fn row_len(&self) -> usize {
        self.nx * self.axis.nt
    }
}

/// The values of one dataset of an extra group, flattened in row-major (C) order.
#[derive(Clone, Debug, PartialEq)]
pub enum DataBuf {
    F32(Vec<f32>),
    F64(Vec<f64>),
    U8(Vec<u8>),
    U32(Vec<u32>),
    I32(Vec<i32>),
}

impl DataBuf {
    /// Number of elements.
    pub fn len(&self) -> usize {
        match self {
            DataBuf::F32(v) => v.len(),
            DataBuf::F64(v) => v.len(),
            DataBuf::U8(v) => v.len(),
            DataBuf::U32(v) => v.len(),
            DataBuf::I32(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The element type's name as documented in docs/cube-format.md ("f32", "u8", ...).
    pub fn type_name(&self) -> &'static str {
        self.elem().name()
    }

    fn elem(&self) -> Elem {
        match self {
            DataBuf::F32(_) => Elem::F32,
            DataBuf::F64(_) => Elem::F64,
            DataBuf::U8(_) => Elem::U8,
            DataBuf::U32(_) => Elem::U32,
            DataBuf::I32(_) => Elem::I32,
        }
    }
}

/// The value of one attribute of an extra group.
#[derive(Clone, Debug, PartialEq)]
pub enum AttrValue {
    F64(f64),
    I64(i64),
    Str(String),
    F64Array(Vec<f64>),
}

/// The contents of one extra group: attributes and datasets (no nested groups).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GroupData {
    /// Attributes in the order they were written.
    pub attrs: Vec<(String, AttrValue)>,
    /// Datasets as `(name, shape, values)`; read back sorted by name.
    pub datasets: Vec<(String, Vec<usize>, DataBuf)>,
}

impl GroupData {
    /// The attribute called `name`.
    pub fn attr(&self, name: &str) -> Option<&AttrValue> {
        self.attrs.iter().find(|(n, _)| n == name).map(|(_, v)| v)
    }

    /// The shape and values of the dataset called `name`.
    pub fn dataset(&self, name: &str) -> Option<(&[usize], &DataBuf)> {
        self.datasets
            .iter()
            .find(|(n, _, _)| n == name)
            .map(|(_, s, d)| (s.as_slice(), d))
    }
}

// ---------------------------------------------------------------------------------------
// Element types

/// Element types the container recognises on disk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Elem {
    U8,
    U16,
    U32,
    U64,
    I8,
    I16,
    I32,
    I64,
    F32,
    F64,
}

impl Elem {
    fn of(dt: &DatatypeMessage) -> Option<Elem> {
        match *dt {
            DatatypeMessage::FixedPoint {
                size,
                signed,
                bit_offset: 0,
                bit_precision,
                ..
            } if u32::from(bit_precision) == size * 8 => Some(match (size, signed) {
                (1, false) => Elem::U8,
                (2, false) => Elem::U16,
                (4, false) => Elem::U32,
                (8, false) => Elem::U64,
                (1, true) => Elem::I8,
                (2, true) => Elem::I16,
                (4, true) => Elem::I32,
                (8, true) => Elem::I64,
                _ => return None,
            }),
            DatatypeMessage::FloatingPoint { size, .. } if dt.ieee_format().is_some() => match size
            {
                4 => Some(Elem::F32),
                8 => Some(Elem::F64),
                _ => None,
            },
            _ => None,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Elem::U8 => "u8",
            Elem::U16 => "u16",
            Elem::U32 => "u32",
            Elem::U64 => "u64",
            Elem::I8 => "i8",
            Elem::I16 => "i16",
            Elem::I32 => "i32",
            Elem::I64 => "i64",
            Elem::F32 => "f32",
            Elem::F64 => "f64",
        }
    }

    fn size(self) -> usize {
        match self {
            Elem::U8 | Elem::I8 => 1,
            Elem::U16 | Elem::I16 => 2,
            Elem::U32 | Elem::I32 | Elem::F32 => 4,
            Elem::U64 | Elem::I64 | Elem::F64 => 8,
        }
    }
}

/// A readable name for a datatype, for error messages.
fn type_description(dt: &DatatypeMessage) -> String {
    Elem::of(dt).map_or_else(|| dt.to_string(), |e| e.name().to_string())
}

// ---------------------------------------------------------------------------------------
// Opening files

/// The 8-byte signature at the start of every HDF5 superblock.
const HDF5_SIGNATURE: [u8; 8] = [0x89, b'H', b'D', b'F', b'\r', b'\n', 0x1a, b'\n'];

/// Whether the file at `path` is an HDF5 file: its signature sits at offset 0, or at 512,
/// 1024, 2048, ... when the file starts with a user block.
pub fn is_hdf5(path: &Path) -> io::Result<bool> {
    let mut f = File::open(path)?;
    let len = f.metadata()?.len();
    let mut offset = 0u64;
    let mut sig = [0u8; 8];
    while offset + 8 <= len {
        f.seek(SeekFrom::Start(offset))?;
        f.read_exact(&mut sig)?;
        if sig == HDF5_SIGNATURE {
            return Ok(true);
        }
        offset = if offset == 0 { 512 } else { offset * 2 };
    }
    Ok(false)
}

/// Open an existing HDF5 file for reading, telling a missing file and a non-HDF5 file
/// apart from a corrupt one.
fn open_h5(path: &Path) -> Result<H5File> {
    match is_hdf5(path) {
        Err(source) => {
            return Err(ContainerError::Io {
                path: path.to_path_buf(),
                source,
            })
        }
        Ok(false) => {
            return Err(ContainerError::NotHdf5 {
                path: path.to_path_buf(),
            })
        }
        Ok(true) => {}
    }
    H5File::options()
        .best_effort_locking()
        .open(path)
        .map_err(h5(path))
}

/// Open the dataset at `name`, mapping "not found" to [`ContainerError::NoDataset`].
fn open_dataset(file: &H5File, path: &Path, name: &str) -> Result<H5Dataset> {
    file.dataset(name).map_err(|e| match e {
        Hdf5Error::NotFound(_) => ContainerError::NoDataset {
            path: path.to_path_buf(),
            dataset: name.to_string(),
        },
        other => h5(path)(other),
    })
}

/// The element type of a reader-mode dataset.
fn dataset_elem(ds: &H5Dataset, path: &Path) -> Result<(Option<Elem>, String)> {
    let dt = ds.datatype().map_err(h5(path))?;
    Ok((Elem::of(&dt), type_description(&dt)))
}

// ---------------------------------------------------------------------------------------
// Writing

/// An open HDF5 file being written with a `/cube` dataset, not yet atomic: the callers put
/// it on a temporary path. `path` is the destination named in error messages.
struct CubeSink {
    cube: H5Dataset,
    file: QuietFile,
    compression: CubeCompression,
    path: PathBuf,
    nx: usize,
    ny: usize,
    nt: usize,
    rows_written: Vec<bool>,
    mask_written: bool,
}

/// What goes into the attributes of `/cube`.
struct CubeAttrs<'a> {
    axis: TimeAxis,
    frame: TimeFrame,
    units: &'a str,
    femto_version: Option<&'a str>,
    command_line: Option<&'a str>,
    notes: &'a [(String, String)],
}

fn check_name(path: &Path, what: &str, name: &str) -> Result<()> {
    if name.is_empty() || name.contains('/') || name == "." {
        return Err(invalid(
            path,
            format!("{what} name '{name}' must be non-empty and contain no '/'"),
        ));
    }
    Ok(())
}

fn check_axis(path: &Path, axis: &TimeAxis) -> Result<()> {
    if axis.nt == 0 {
        return Err(invalid(path, "a cube needs at least one time bin"));
    }
    if !axis.t0_ps.is_finite() {
        return Err(invalid(path, format!("t0_ps is {}", axis.t0_ps)));
    }
    if !(axis.dt_ps.is_finite() && axis.dt_ps > 0.0) {
        return Err(invalid(
            path,
            format!("dt_ps must be positive and finite, not {}", axis.dt_ps),
        ));
    }
    Ok(())
}

/// Rows of `row_bytes` per chunk of a dataset of `rows` rows: at most
/// [`CHUNK_TARGET_BYTES`], balanced so the last chunk is about as full as the others.
fn chunk_rows(row_bytes: usize, rows: usize) -> usize {
    let most = (CHUNK_TARGET_BYTES / row_bytes.max(1)).clamp(1, rows.max(1));
    rows.max(1).div_ceil(rows.max(1).div_ceil(most))
}

impl CubeSink {
    fn create(tmp: &Path, path: &Path, nx: usize, ny: usize, attrs: &CubeAttrs) -> Result<Self> {
        Self::create_with(tmp, path, nx, ny, attrs, CubeCompression::default())
    }

    fn create_with(
        tmp: &Path,
        path: &Path,
        nx: usize,
        ny: usize,
        attrs: &CubeAttrs,
        compression: CubeCompression,
    ) -> Result<Self> {
        if let CubeCompression::Deflate(level) = compression {
            if level > 9 {
                return Err(invalid(
                    path,
                    format!("deflate level {level} (levels are 0 to 9)"),
                ));
            }
        }
        check_axis(path, &attrs.axis)?;
        if nx == 0 || ny == 0 {
            return Err(invalid(
                path,
                format!("a cube needs pixels, not {nx} x {ny}"),
            ));
        }
        for (i, (k, _)) in attrs.notes.iter().enumerate() {
            check_name(path, "note", k)?;
            if RESERVED_ATTRS.contains(&k.as_str()) {
                return Err(invalid(
                    path,
                    format!("note '{k}' uses a reserved attribute name"),
                ));
            }
            if attrs.notes[..i].iter().any(|(o, _)| o == k) {
                return Err(invalid(path, format!("note '{k}' given twice")));
            }
        }
        let nt = attrs.axis.nt;
        let e = h5(path);
        let file = QuietFile(Some(
            H5File::options()
                .best_effort_locking()
                .create(tmp)
                .map_err(&e)?,
        ));
        let cx = chunk_rows(nt * 4, nx);
        let builder = file
            .new_dataset::<f32>()
            .shape([ny, nx, nt])
            .chunk(&[1, cx, nt]);
        let builder = match compression {
            CubeCompression::Deflate(level) => builder.shuffle_deflate(level),
            CubeCompression::None => builder,
        };
        let cube = builder.create(CUBE_DATASET).map_err(&e)?;
        set_attr(&cube, "t0_ps", &AttrValue::F64(attrs.axis.t0_ps)).map_err(&e)?;
        set_attr(&cube, "dt_ps", &AttrValue::F64(attrs.axis.dt_ps)).map_err(&e)?;
        let frame = AttrValue::Str(attrs.frame.as_str().to_string());
        set_attr(&cube, "time_frame", &frame).map_err(&e)?;
        set_attr(&cube, "units", &AttrValue::Str(attrs.units.to_string())).map_err(&e)?;
        if let Some(v) = attrs.femto_version {
            set_attr(&cube, "femto_version", &AttrValue::Str(v.to_string())).map_err(&e)?;
        }
        if let Some(c) = attrs.command_line {
            set_attr(&cube, "command_line", &AttrValue::Str(c.to_string())).map_err(&e)?;
        }
        for (k, v) in attrs.notes {
            set_attr(&cube, k, &AttrValue::Str(v.clone())).map_err(&e)?;
        }
        Ok(CubeSink {
            cube,
            file,
            compression,
            path: path.to_path_buf(),
            nx,
            ny,
            nt,
            rows_written: vec![false; ny],
            mask_written: false,
        })
    }

    /// Number of whole rows in `rows`, to be written from row `y0`; an error when they are
    /// not whole rows or run past the cube.
    fn check_rows(&self, y0: usize, rows: &[f32]) -> Result<usize> {
        let row_len = self.nx * self.nt;
        if rows.is_empty() || !rows.len().is_multiple_of(row_len) {
            return Err(invalid(
                &self.path,
                format!(
                    "{} values are not a whole number of rows of {} x {} values",
                    rows.len(),
                    self.nx,
                    self.nt
                ),
            ));
        }
        let n = rows.len() / row_len;
        if y0 + n > self.ny {
            return Err(invalid(
                &self.path,
                format!("rows {y0}..{} past the cube's {} rows", y0 + n, self.ny),
            ));
        }
        Ok(n)
    }

    /// Write whole rows from row `y0`, compressed in parallel on rayon's threads (see
    /// [`RowCompressor`]) and appended as they are.
    fn write_rows(&mut self, y0: usize, rows: &[f32]) -> Result<()> {
        self.check_rows(y0, rows)?;
        let compressor = self.row_compressor();
        let compressed: Vec<CompressedRow> = rows
            .par_chunks(compressor.row_len())
            .map(|row| compressor.compress(row))
            .collect();
        for (i, row) in compressed.iter().enumerate() {
            self.write_compressed_row(y0 + i, row)?;
        }
        Ok(())
    }

    /// A compressor for this cube's rows (see [`RowCompressor`]).
    fn row_compressor(&self) -> RowCompressor {
        RowCompressor {
            nx: self.nx,
            nt: self.nt,
            cx: chunk_rows(self.nt * 4, self.nx),
            compression: self.compression,
        }
    }

    /// Write row `y` from chunks made by this sink's [`RowCompressor`], as they are (an
    /// uncompressed row from its own buffer, without a copy).
    fn write_compressed_row(&mut self, y: usize, row: &CompressedRow) -> Result<()> {
        let s = self;
        let cx = chunk_rows(s.nt * 4, s.nx);
        let chunks = s.nx.div_ceil(cx);
        let fits = match &row.storage {
            RowStorage::Filtered { chunks: c, .. } => c.len() == chunks,
            RowStorage::Plain(values) => values.len() == s.nx * s.nt,
        };
        if y >= s.ny || row.nx != s.nx || row.nt != s.nt || !fits {
            return Err(invalid(
                &s.path,
                format!(
                    "compressed row {y} ({} x {} values) does not fit the cube's {} rows of \
                     {} x {} in {chunks} chunks",
                    row.nx, row.nt, s.ny, s.nx, s.nt
                ),
            ));
        }
        if matches!(row.storage, RowStorage::Filtered { .. })
            != matches!(s.compression, CubeCompression::Deflate(_))
        {
            return Err(invalid(
                &s.path,
                "compressed row made by another writer's compressor",
            ));
        }
        let e = h5(&s.path);
        match &row.storage {
            RowStorage::Filtered { chunks, .. } => {
                for (c, bytes) in chunks.iter().enumerate() {
                    s.cube
                        .write_chunk_raw_at(&[y, c, 0], bytes, 0)
                        .map_err(&e)?;
                }
            }
            RowStorage::Plain(values) => {
                let chunk_values = cx * s.nt;
                for (c, part) in values.chunks(chunk_values).enumerate() {
                    if part.len() == chunk_values {
                        s.cube
                            .write_chunk_at(&[y, c, 0], &le_bytes(part))
                            .map_err(&e)?;
                    } else {
                        // The edge chunk, padded with zeros as HDF5 stores it.
                        let mut padded = vec![0.0f32; chunk_values];
                        padded[..part.len()].copy_from_slice(part);
                        s.cube
                            .write_chunk_at(&[y, c, 0], &le_bytes(&padded))
                            .map_err(&e)?;
                    }
                }
            }
        }
        s.rows_written[y] = true;
        Ok(())
    }

    /// Store row `y` from chunks already filtered by this sink's pipeline (bytes and filter
    /// mask of each, as [`CubeReader::read_raw_row`] gives them).
    fn write_raw_row(&mut self, y: usize, chunks: &[(Vec<u8>, u32)]) -> Result<()> {
        for (c, (bytes, mask)) in chunks.iter().enumerate() {
            self.cube
                .write_chunk_raw_at(&[y, c, 0], bytes, *mask)
                .map_err(h5(&self.path))?;
        }
        self.rows_written[y] = true;
        Ok(())
    }

    fn write_mask(&mut self, mask: &[u8]) -> Result<()> {
        if mask.len() != self.nx * self.ny {
            return Err(invalid(
                &self.path,
                format!(
                    "mask has {} values, expected {} x {}",
                    mask.len(),
                    self.ny,
                    self.nx
                ),
            ));
        }
        if self.mask_written {
            return Err(invalid(&self.path, "mask written twice"));
        }
        let e = h5(&self.path);
        let rows = chunk_rows(self.nx, self.ny);
        let ds = self
            .file
            .new_dataset::<u8>()
            .shape([self.ny, self.nx])
            .chunk(&[rows, self.nx])
            .deflate(DEFLATE_LEVEL)
            .create(MASK_DATASET)
            .map_err(&e)?;
        ds.write_raw(mask).map_err(&e)?;
        self.mask_written = true;
        Ok(())
    }

    /// Check every row was written and close the file.
    fn close(self) -> Result<()> {
        if let Some(y) = self.rows_written.iter().position(|w| !w) {
            let n = self.rows_written.iter().filter(|w| !**w).count();
            return Err(invalid(
                &self.path,
                format!("{n} rows of the cube were never written (first: row {y})"),
            ));
        }
        let CubeSink {
            cube, file, path, ..
        } = self;
        drop(cube);
        // No fsync, as for every other output of femto (`atomic::write_atomically`) and as
        // the HDF5 library and h5py close files: the file is complete and renamed atomically
        // for other processes, and the operating system writes it to disk in its own time.
        // The fsync of `close` made the caller wait for the disk: 0.5 s or more of wall time
        // for a 825 MB cube on the benchmark machine (tools/bench_ingest_results.md).
        file.into_inner().close_no_sync().map_err(h5(&path))
    }
}

/// An HDF5 file being written that, dropped unclosed (a write failed: a full disk), is closed
/// without a word: the library would print a second error line on stderr, and the file is a
/// temporary one about to be deleted.
struct QuietFile(Option<H5File>);

impl QuietFile {
    fn into_inner(mut self) -> H5File {
        self.0
            .take()
            .expect("a QuietFile holds its file until into_inner")
    }
}

impl std::ops::Deref for QuietFile {
    type Target = H5File;
    fn deref(&self) -> &H5File {
        self.0
            .as_ref()
            .expect("a QuietFile holds its file until into_inner")
    }
}

impl Drop for QuietFile {
    fn drop(&mut self) {
        if let Some(f) = self.0.take() {
            let _ = f.close_no_sync();
        }
    }
}

fn write_sink_cube(sink: &mut CubeSink, cube: &Cube) -> Result<()> {
    let row_len = cube.nx * cube.nt();
    let rows = slab_rows(row_len * 4, cube.ny);
    for y0 in (0..cube.ny).step_by(rows) {
        let y1 = (y0 + rows).min(cube.ny);
        sink.write_rows(y0, &cube.data[y0 * row_len..y1 * row_len])?;
    }
    if let Some(m) = &cube.mask {
        sink.write_mask(m)?;
    }
    Ok(())
}

fn slab_rows(row_bytes: usize, rows: usize) -> usize {
    (SLAB_TARGET_BYTES / row_bytes.max(1)).clamp(1, rows.max(1))
}

/// Write `cube` to `path` atomically, with units [`DEFAULT_UNITS`].
pub fn write_cube(path: &Path, cube: &Cube, provenance: &Provenance) -> Result<()> {
    write_cube_with_units(path, cube, DEFAULT_UNITS, provenance)
}

/// Write `cube` to `path` atomically, recording `units` for its values.
///
/// On failure any earlier file at `path` is left untouched and no temporary file remains.
pub fn write_cube_with_units(
    path: &Path,
    cube: &Cube,
    units: &str,
    provenance: &Provenance,
) -> Result<()> {
    if cube.data.len() != cube.nx * cube.ny * cube.nt() {
        return Err(invalid(
            path,
            format!(
                "cube data has {} values, expected {} x {} x {}",
                cube.data.len(),
                cube.ny,
                cube.nx,
                cube.nt()
            ),
        ));
    }
    let attrs = CubeAttrs {
        axis: cube.axis,
        frame: cube.frame,
        units,
        femto_version: Some(env!("CARGO_PKG_VERSION")),
        command_line: Some(&provenance.command_line),
        notes: &provenance.notes,
    };
    write_atomically(path, |tmp| {
        let mut sink = CubeSink::create(tmp, path, cube.nx, cube.ny, &attrs)?;
        write_sink_cube(&mut sink, cube)?;
        sink.close()
    })
    .map_err(|e| e.at(path))
}

/// Streaming writer of a cube file: rows are written in any order as slabs, so peak memory
/// is one slab whatever the cube's size.
///
/// The file is written to a temporary path beside the destination and renamed onto it by
/// [`CubeWriter::finish`]; dropping an unfinished writer deletes the temporary file and
/// leaves any earlier file at the destination untouched.
pub struct CubeWriter {
    // Field order matters: the HDF5 file is closed before the temporary path is deleted.
    groups: GroupSinks,
    sink: CubeSink,
    tmp: crate::atomic::TempFile,
    dest: PathBuf,
}

impl CubeWriter {
    /// Start writing a cube of `nx` by `ny` pixels on `axis` to `path`.
    pub fn create(
        path: &Path,
        nx: usize,
        ny: usize,
        axis: TimeAxis,
        frame: TimeFrame,
        units: &str,
        provenance: &Provenance,
    ) -> Result<CubeWriter> {
        Self::create_with(
            path,
            nx,
            ny,
            axis,
            frame,
            units,
            provenance,
            CubeCompression::default(),
        )
    }

    /// [`CubeWriter::create`] with a choice of compression for `/cube`.
    #[allow(clippy::too_many_arguments)]
    pub fn create_with(
        path: &Path,
        nx: usize,
        ny: usize,
        axis: TimeAxis,
        frame: TimeFrame,
        units: &str,
        provenance: &Provenance,
        compression: CubeCompression,
    ) -> Result<CubeWriter> {
        let tmp = temp_beside(path)?;
        let attrs = CubeAttrs {
            axis,
            frame,
            units,
            femto_version: Some(env!("CARGO_PKG_VERSION")),
            command_line: Some(&provenance.command_line),
            notes: &provenance.notes,
        };
        let sink = CubeSink::create_with(&tmp, path, nx, ny, &attrs, compression)?;
        Ok(CubeWriter {
            groups: GroupSinks::default(),
            sink,
            tmp,
            dest: path.to_path_buf(),
        })
    }

    /// Write rows `y0 .. y0 + n` from `rows` (`n * nx * nt` values, layout `[y][x][t]`).
    ///
    /// The rows are compressed in parallel on rayon's threads (see [`RowCompressor`]) and
    /// appended as they are.
    pub fn write_rows(&mut self, y0: usize, rows: &[f32]) -> Result<()> {
        self.sink.write_rows(y0, rows)
    }

    /// Write the validity mask (`ny * nx` bytes, `[y][x]`, 1 = valid). At most once.
    pub fn write_mask(&mut self, mask: &[u8]) -> Result<()> {
        self.sink.write_mask(mask)
    }

    /// Create extra group `name` with its attributes and empty datasets, to be filled by
    /// [`CubeWriter::write_group_rows`].
    pub fn begin_group(
        &mut self,
        name: &str,
        attrs: &[(String, AttrValue)],
        datasets: &[DatasetSpec],
    ) -> Result<()> {
        self.groups
            .begin(&self.sink.file, &self.dest, name, attrs, datasets)
    }

    /// Write rows `r0 ..` of dataset `dataset` of group `group` (begun before).
    pub fn write_group_rows(
        &mut self,
        group: &str,
        dataset: &str,
        r0: usize,
        rows: &DataBuf,
    ) -> Result<()> {
        self.groups.write_rows(&self.dest, group, dataset, r0, rows)
    }

    /// Write a whole extra group at once.
    pub fn write_group(&mut self, name: &str, data: &GroupData) -> Result<()> {
        self.groups
            .write_whole(&self.sink.file, &self.dest, name, data)
    }

    /// A compressor for this cube's rows, to run on worker threads (see [`RowCompressor`]).
    pub fn row_compressor(&self) -> RowCompressor {
        self.sink.row_compressor()
    }

    /// Write row `y` from chunks made by this writer's [`RowCompressor`]: the bytes are
    /// stored as they are, so the writer's thread does no compression (and, for an
    /// uncompressed cube, no copy: the row's values go to the file from where they are).
    pub fn write_compressed_row(&mut self, y: usize, row: &CompressedRow) -> Result<()> {
        self.sink.write_compressed_row(y, row)
    }

    /// Check every row (of the cube and of every group) was written, close the file and
    /// rename it onto the destination.
    pub fn finish(self) -> Result<()> {
        let CubeWriter {
            groups,
            sink,
            tmp,
            dest,
        } = self;
        groups.close(&dest)?;
        sink.close()?;
        persist(tmp, &dest)
    }
}

/// The little-endian bytes of `values` (every on-disk type of femto's files is
/// little-endian): a view of the same memory on little-endian machines, a converted copy
/// elsewhere.
fn le_bytes<T: bytemuck::Pod>(values: &[T]) -> std::borrow::Cow<'_, [u8]> {
    let bytes: &[u8] = bytemuck::cast_slice(values);
    if cfg!(target_endian = "little") {
        std::borrow::Cow::Borrowed(bytes)
    } else {
        std::borrow::Cow::Owned(
            bytes
                .chunks_exact(std::mem::size_of::<T>())
                .flat_map(|v| v.iter().rev().copied())
                .collect(),
        )
    }
}

/// Compresses one row of a cube into the chunks of its `/cube` dataset (the writer's filters,
/// shuffle + deflate by default, and the chunk shape of the schema), without touching the
/// file.
///
/// Compression is the slow part of writing a cube and the writer runs it on one thread;
/// a `RowCompressor` (from [`CubeWriter::row_compressor`]) is `Send + Sync`, so streaming
/// commands compress rows on their worker threads and hand the bytes to
/// [`CubeWriter::write_compressed_row`], which only appends them to the file.
///
/// The chunks are standard HDF5 shuffle + deflate (zlib streams), which any HDF5 reader
/// decodes with its built-in filters. The deflate encoder depends on the level, each the
/// faster of the two measured on camera data (`examples/bench_chunk_compression.rs`,
/// `tools/bench_ingest_results.md`): miniz_oxide at level 1 (its fast greedy mode beat
/// libdeflate's level 1 by 1.5x in CPU for 5 % more bytes), libdeflate at every other level
/// (at level 4, 2.2x faster than miniz_oxide and 5 % smaller).
#[derive(Clone, Debug)]
pub struct RowCompressor {
    nx: usize,
    nt: usize,
    cx: usize,
    compression: CubeCompression,
}

/// One row of a cube as stored chunks, from [`RowCompressor::compress`].
#[derive(Clone, Debug)]
pub struct CompressedRow {
    nx: usize,
    nt: usize,
    storage: RowStorage,
}

#[derive(Clone, Debug)]
enum RowStorage {
    /// The chunks after shuffle + deflate; `row` is the buffer the values came in (kept only
    /// so the caller can reuse it, see [`CompressedRow::into_buffer`]).
    Filtered { chunks: Vec<Vec<u8>>, row: Vec<f32> },
    /// The values themselves (an unfiltered cube stores them as they are).
    Plain(Vec<f32>),
}

impl CompressedRow {
    /// Stored size, bytes (an unfiltered edge chunk counts its padding).
    pub fn stored_bytes(&self) -> usize {
        match &self.storage {
            RowStorage::Filtered { chunks, .. } => chunks.iter().map(Vec::len).sum(),
            RowStorage::Plain(values) => {
                let cx = chunk_rows(self.nt * 4, self.nx);
                values.len().div_ceil(cx * self.nt) * cx * self.nt * 4
            }
        }
    }

    /// The row buffer given to [`RowCompressor::compress_owned`], for reuse once the row is
    /// written (its contents are unspecified; empty when the row came from
    /// [`RowCompressor::compress`] of a filtered cube).
    pub fn into_buffer(self) -> Vec<f32> {
        match self.storage {
            RowStorage::Filtered { row, .. } => row,
            RowStorage::Plain(values) => values,
        }
    }
}

impl RowCompressor {
    /// Values in one row (`nx * nt`, layout `[x][t]`).
    pub fn row_len(&self) -> usize {
        self.nx * self.nt
    }

    /// Compress one row (`nx * nt` values, layout `[x][t]`). The last chunk along x is padded
    /// with zeros when `nx` is not a multiple of the chunk width, as HDF5 stores edge chunks.
    ///
    /// # Panics
    /// If `row.len() != self.row_len()` (a programming error, not bad input).
    pub fn compress(&self, row: &[f32]) -> CompressedRow {
        match self.compression {
            CubeCompression::None => self.compress_owned(row.to_vec()),
            CubeCompression::Deflate(_) => CompressedRow {
                nx: self.nx,
                nt: self.nt,
                storage: RowStorage::Filtered {
                    chunks: self.deflate_chunks(row),
                    row: Vec::new(),
                },
            },
        }
    }

    /// [`RowCompressor::compress`] of a row the caller gives away: an uncompressed cube
    /// keeps the values where they are (no copy), and [`CompressedRow::into_buffer`] hands
    /// the buffer back for the next row.
    ///
    /// # Panics
    /// If `row.len() != self.row_len()`.
    pub fn compress_owned(&self, row: Vec<f32>) -> CompressedRow {
        assert_eq!(row.len(), self.row_len(), "RowCompressor: row length");
        let storage = match self.compression {
            CubeCompression::None => RowStorage::Plain(row),
            CubeCompression::Deflate(_) => RowStorage::Filtered {
                chunks: self.deflate_chunks(&row),
                row,
            },
        };
        CompressedRow {
            nx: self.nx,
            nt: self.nt,
            storage,
        }
    }

    fn deflate_chunks(&self, row: &[f32]) -> Vec<Vec<u8>> {
        assert_eq!(row.len(), self.row_len(), "RowCompressor: row length");
        let CubeCompression::Deflate(level) = self.compression else {
            unreachable!("deflate_chunks of an unfiltered cube")
        };
        let chunk_values = self.cx * self.nt;
        DEFLATE_SCRATCH.with_borrow_mut(|scratch| {
            row.chunks(chunk_values)
                .map(|values| scratch.shuffle_deflate(values, chunk_values, level))
                .collect()
        })
    }
}

thread_local! {
    /// Per-thread buffers and encoder of [`RowCompressor`].
    static DEFLATE_SCRATCH: std::cell::RefCell<DeflateScratch> =
        std::cell::RefCell::new(DeflateScratch::default());
}

/// The shuffled bytes of the chunk being compressed, and a libdeflate encoder of the last
/// level used (allocating one costs more than compressing a small chunk).
#[derive(Default)]
struct DeflateScratch {
    shuffled: Vec<u8>,
    encoder: Option<(u32, libdeflater::Compressor)>,
}

impl DeflateScratch {
    /// HDF5 shuffle (element size 4) then deflate (zlib stream) of one chunk: `values`
    /// padded with zeros to `chunk_values`.
    fn shuffle_deflate(&mut self, values: &[f32], chunk_values: usize, level: u32) -> Vec<u8> {
        // Shuffle: byte k of every value, for k = 0..4 (little-endian, the stored order).
        self.shuffled.clear();
        self.shuffled.resize(chunk_values * 4, 0);
        let (b0, rest) = self.shuffled.split_at_mut(chunk_values);
        let (b1, rest) = rest.split_at_mut(chunk_values);
        let (b2, b3) = rest.split_at_mut(chunk_values);
        for (i, v) in values.iter().enumerate() {
            [b0[i], b1[i], b2[i], b3[i]] = v.to_le_bytes();
        }
        if level == 1 {
            return apply_filters(&FilterPipeline::deflate(1), &self.shuffled)
                .expect("deflate cannot fail on a whole chunk");
        }
        let encoder = match &mut self.encoder {
            Some((l, e)) if *l == level => e,
            slot => {
                let lvl = libdeflater::CompressionLvl::new(level as i32)
                    .expect("levels 0-9 are libdeflate levels");
                &mut slot.insert((level, libdeflater::Compressor::new(lvl))).1
            }
        };
        let mut out = vec![0u8; encoder.zlib_compress_bound(self.shuffled.len())];
        let n = encoder
            .zlib_compress(&self.shuffled, &mut out)
            .expect("the output holds the compress bound");
        out.truncate(n);
        out
    }
}

// ---------------------------------------------------------------------------------------
// Reading

/// Streaming reader of a cube file: metadata at once, values by row slabs.
pub struct CubeReader {
    file: H5File,
    cube: H5Dataset,
    path: PathBuf,
    meta: CubeMeta,
    /// Chunk width `cx` and filters of a cube chunked `(1, cx, nt)` through a filter
    /// pipeline: its rows are decoded chunk by chunk on rayon's threads.
    row_chunks: Option<(usize, FilterPipeline)>,
}

fn read_f64_attr(ds: &H5Dataset, path: &Path, object: &str, name: &str) -> Result<f64> {
    let attr = ds
        .attr(name)
        .map_err(|_| ContainerError::MissingAttribute {
            path: path.to_path_buf(),
            object: object.to_string(),
            attr: name.to_string(),
        })?;
    let bad = |reason: String| ContainerError::BadAttribute {
        path: path.to_path_buf(),
        object: object.to_string(),
        attr: name.to_string(),
        reason,
    };
    // Integers are accepted too (h5py writes `attrs["t0_ps"] = 0` as int64).
    let values: Vec<f64> = match attr.read_numeric_as::<f64>() {
        Ok(v) => v,
        Err(_) => attr
            .read_numeric_as::<i64>()
            .map_err(|e| bad(format!("not a number ({e})")))?
            .into_iter()
            .map(|v| v as f64)
            .collect(),
    };
    match values.as_slice() {
        [v] => Ok(*v),
        _ => Err(bad(format!("expected one number, found {}", values.len()))),
    }
}

/// Read a string attribute; `Ok(None)` when it is absent.
fn read_str_attr(ds: &H5Dataset, path: &Path, object: &str, name: &str) -> Result<Option<String>> {
    if !ds.attr_names().map_err(h5(path))?.iter().any(|n| n == name) {
        return Ok(None);
    }
    let attr = ds.attr(name).map_err(h5(path))?;
    let dt = attr.datatype().map_err(h5(path))?;
    if !matches!(
        dt,
        DatatypeMessage::VarLenString { .. } | DatatypeMessage::FixedString { .. }
    ) {
        return Err(ContainerError::BadAttribute {
            path: path.to_path_buf(),
            object: object.to_string(),
            attr: name.to_string(),
            reason: format!("expected a string, found {}", type_description(&dt)),
        });
    }
    attr.read_string().map(Some).map_err(h5(path))
}

fn required_str_attr(ds: &H5Dataset, path: &Path, object: &str, name: &str) -> Result<String> {
    read_str_attr(ds, path, object, name)?.ok_or_else(|| ContainerError::MissingAttribute {
        path: path.to_path_buf(),
        object: object.to_string(),
        attr: name.to_string(),
    })
}

impl CubeReader {
    /// Open the cube file at `path` and read its metadata.
    pub fn open(path: &Path) -> Result<CubeReader> {
        let file = open_h5(path)?;
        let cube = file.dataset(CUBE_DATASET).map_err(|e| match e {
            Hdf5Error::NotFound(_) => ContainerError::NoCube {
                path: path.to_path_buf(),
            },
            other => h5(path)(other),
        })?;
        let shape = cube.shape();
        if shape.len() != 3 {
            return Err(ContainerError::WrongRank {
                path: path.to_path_buf(),
                dataset: CUBE_DATASET.into(),
                found: shape.len(),
                expected: 3,
            });
        }
        let (elem, found) = dataset_elem(&cube, path)?;
        if elem != Some(Elem::F32) {
            return Err(ContainerError::WrongType {
                path: path.to_path_buf(),
                dataset: CUBE_DATASET.into(),
                found,
                expected: "f32".into(),
            });
        }
        let (ny, nx, nt) = (shape[0], shape[1], shape[2]);
        if nx == 0 || ny == 0 || nt == 0 {
            return Err(invalid(path, format!("/cube is empty, shape {shape:?}")));
        }
        let object = CUBE_DATASET;
        let t0_ps = read_f64_attr(&cube, path, object, "t0_ps")?;
        let dt_ps = read_f64_attr(&cube, path, object, "dt_ps")?;
        let axis = TimeAxis { t0_ps, dt_ps, nt };
        check_axis(path, &axis).map_err(|e| ContainerError::BadAttribute {
            path: path.to_path_buf(),
            object: object.into(),
            attr: if t0_ps.is_finite() { "dt_ps" } else { "t0_ps" }.into(),
            reason: e.to_string(),
        })?;
        let frame_s = required_str_attr(&cube, path, object, "time_frame")?;
        let frame = TimeFrame::parse(&frame_s).ok_or_else(|| ContainerError::BadAttribute {
            path: path.to_path_buf(),
            object: object.into(),
            attr: "time_frame".into(),
            reason: format!("{frame_s:?} is neither \"camera\" nor \"world\""),
        })?;
        let units = required_str_attr(&cube, path, object, "units")?;
        let femto_version = read_str_attr(&cube, path, object, "femto_version")?;
        let command_line = read_str_attr(&cube, path, object, "command_line")?;
        let mut notes = Vec::new();
        for name in cube.attr_names().map_err(h5(path))? {
            if RESERVED_ATTRS.contains(&name.as_str()) {
                continue;
            }
            // A note written by another tool may be numeric: keep it, as text.
            let value = match read_str_attr(&cube, path, object, &name) {
                Ok(v) => v.unwrap_or_default(),
                Err(_) => cube
                    .attr(&name)
                    .and_then(|a| a.read_numeric_as::<f64>())
                    .map(|v| {
                        v.iter()
                            .map(|x| x.to_string())
                            .collect::<Vec<_>>()
                            .join(" ")
                    })
                    .unwrap_or_default(),
            };
            notes.push((name, value));
        }
        let root = file.root_group();
        let has_mask = root
            .dataset_names()
            .map_err(h5(path))?
            .iter()
            .any(|n| n == MASK_DATASET);
        let mut groups = root.group_names().map_err(h5(path))?;
        groups.sort();
        let meta = CubeMeta {
            nx,
            ny,
            axis,
            frame,
            units,
            femto_version,
            command_line,
            notes,
            groups,
            has_mask,
        };
        let row_chunks = match (cube.chunk_dims(), cube.filters()) {
            (Some(d), Ok(filters))
                if d.len() == 3 && d[0] == 1 && d[2] == meta.axis.nt && !filters.is_empty() =>
            {
                Some((d[1], FilterPipeline { filters }))
            }
            _ => None,
        };
        Ok(CubeReader {
            file,
            cube,
            path: path.to_path_buf(),
            meta,
            row_chunks,
        })
    }

    /// Rows `y0 ..` into `out` (whole rows) from the stored chunks of a cube chunked
    /// `(1, cx, nt)`: read one by one, decoded in parallel. `None` when a chunk cannot be
    /// read or decoded this way (the caller then reads through the HDF5 library, which
    /// reports the fault).
    fn read_rows_by_chunks(&self, y0: usize, out: &mut [f32]) -> Option<()> {
        let (cx, pipeline) = self.row_chunks.as_ref()?;
        let (nx, nt) = (self.meta.nx, self.meta.axis.nt);
        let row_len = nx * nt;
        let n_chunks = nx.div_ceil(*cx);
        let stored: Vec<(Vec<u8>, u32)> = (0..out.len() / row_len)
            .flat_map(|r| (0..n_chunks).map(move |c| (y0 + r, c)))
            .map(|(y, c)| self.cube.read_chunk_raw_at(&[y, c, 0]).ok())
            .collect::<Option<_>>()?;
        let chunk_values = cx * nt;
        let ok = out
            .par_chunks_mut(row_len)
            .zip(stored.par_chunks(n_chunks))
            .all(|(row, chunks)| {
                row.chunks_mut(chunk_values)
                    .zip(chunks)
                    .all(|(dst, (bytes, mask))| {
                        match reverse_filters_masked_bounded(
                            pipeline,
                            bytes,
                            *mask,
                            chunk_values * 4,
                        ) {
                            Ok(raw) if raw.len() == chunk_values * 4 => {
                                for (v, b) in dst.iter_mut().zip(raw.chunks_exact(4)) {
                                    *v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                                }
                                true
                            }
                            _ => false,
                        }
                    })
            });
        ok.then_some(())
    }

    /// The cube's metadata.
    pub fn meta(&self) -> &CubeMeta {
        &self.meta
    }

    fn check_rows(&self, y0: usize, n: usize) -> Result<()> {
        if y0 + n > self.meta.ny {
            return Err(invalid(
                &self.path,
                format!(
                    "rows {y0}..{} past the cube's {} rows",
                    y0 + n,
                    self.meta.ny
                ),
            ));
        }
        Ok(())
    }

    /// Read rows `y0 .. y0 + n` (`n * nx * nt` values, layout `[y][x][t]`).
    pub fn read_rows(&self, y0: usize, n: usize) -> Result<Vec<f32>> {
        let mut out = vec![0.0; n * self.meta.row_len()];
        self.read_rows_into(y0, &mut out)?;
        Ok(out)
    }

    /// Read rows starting at `y0` into `out`, whose length must be a whole number of rows.
    /// A NaN or infinite value is refused ([`ContainerError::NonFinite`], naming its pixel
    /// and bin): every stage reads the cube through here, so none of them sees one.
    pub fn read_rows_into(&self, y0: usize, out: &mut [f32]) -> Result<()> {
        self.read_rows_as_stored(y0, out)?;
        let (nx, nt) = (self.meta.nx, self.meta.axis.nt);
        match cube::first_non_finite(out, nx, nt) {
            None => Ok(()),
            Some(mut at) => {
                at.y += y0;
                Err(ContainerError::NonFinite {
                    path: self.path.clone(),
                    dataset: CUBE_DATASET.into(),
                    at,
                })
            }
        }
    }

    /// [`Self::read_rows_into`] without the check of the values (for [`Self::value_scan`],
    /// which describes a cube whatever it holds).
    fn read_rows_as_stored(&self, y0: usize, out: &mut [f32]) -> Result<()> {
        let row_len = self.meta.row_len();
        if !out.len().is_multiple_of(row_len) {
            return Err(invalid(
                &self.path,
                format!(
                    "buffer of {} values is not whole rows of {row_len}",
                    out.len()
                ),
            ));
        }
        let n = out.len() / row_len;
        self.check_rows(y0, n)?;
        if n == 0 || self.read_rows_by_chunks(y0, out).is_some() {
            return Ok(());
        }
        self.cube
            .read_slice_into(out, &[y0, 0, 0], &[n, self.meta.nx, self.meta.axis.nt])
            .map_err(h5(&self.path))
    }

    /// Whether `/cube` is stored as femto's writer stores it (chunks `(1, cx, nt)`, shuffle
    /// of 4-byte values then deflate at any level), so that its chunks can be copied as
    /// they are into a new cube of chunk width `cx` ([`GroupUpdate::open`]).
    /// How `/cube` is stored: shuffle + deflate at its level when its filters hold deflate
    /// (a cube of another tool's with deflate alone is re-stored with shuffle too), else
    /// [`CubeCompression::None`]. Stages that rewrite a cube keep this unless told otherwise.
    pub fn stored_compression(&self) -> CubeCompression {
        match self.cube.filters() {
            Ok(filters) => {
                filters
                    .iter()
                    .find(|f| f.id == FILTER_DEFLATE)
                    .map_or(CubeCompression::None, |f| {
                        CubeCompression::Deflate(
                            f.cd_values.first().copied().unwrap_or(DEFLATE_LEVEL).min(9),
                        )
                    })
            }
            Err(_) => CubeCompression::None,
        }
    }

    fn stored_as_written(&self, cx: usize) -> bool {
        match &self.row_chunks {
            Some((c, p)) => {
                let f = &p.filters;
                *c == cx
                    && f.len() == 2
                    && f[0].id == FILTER_SHUFFLE
                    && matches!(f[0].cd_values.first(), None | Some(4))
                    && f[1].id == FILTER_DEFLATE
            }
            None => false,
        }
    }

    /// The stored (filtered) bytes and filter mask of the `n_chunks` chunks of row `y`, or
    /// `None` if one of them cannot be read raw (never written, for example).
    fn read_raw_row(&self, y: usize, n_chunks: usize) -> Option<Vec<(Vec<u8>, u32)>> {
        (0..n_chunks)
            .map(|c| self.cube.read_chunk_raw_at(&[y, c, 0]).ok())
            .collect()
    }

    /// The validity mask (`ny * nx` bytes, `[y][x]`), if the file has one.
    pub fn read_mask(&self) -> Result<Option<Vec<u8>>> {
        if !self.meta.has_mask {
            return Ok(None);
        }
        let ds = open_dataset(&self.file, &self.path, MASK_DATASET)?;
        let expected = vec![self.meta.ny, self.meta.nx];
        if ds.shape() != expected {
            return Err(ContainerError::WrongShape {
                path: self.path.clone(),
                dataset: MASK_DATASET.into(),
                found: ds.shape(),
                expected,
            });
        }
        let (elem, found) = dataset_elem(&ds, &self.path)?;
        if elem != Some(Elem::U8) {
            return Err(ContainerError::WrongType {
                path: self.path.clone(),
                dataset: MASK_DATASET.into(),
                found,
                expected: "u8".into(),
            });
        }
        ds.read_raw::<u8>().map(Some).map_err(h5(&self.path))
    }

    /// The whole cube in memory.
    pub fn read_cube(&self) -> Result<Cube> {
        let data = self.read_rows(0, self.meta.ny)?;
        Ok(Cube {
            nx: self.meta.nx,
            ny: self.meta.ny,
            axis: self.meta.axis,
            frame: self.meta.frame,
            data,
            mask: self.read_mask()?,
        })
    }

    /// Smallest and largest finite values (None when there are none), streaming the cube
    /// by slabs; `on_rows` is called with the number of rows scanned so far. NaN and
    /// infinite values are skipped, not refused ([`Self::value_scan`] counts them).
    pub fn value_range(&self, on_rows: &dyn Fn(usize)) -> Result<Option<(f32, f32)>> {
        Ok(self.value_scan(on_rows)?.range)
    }

    /// The finite values' range and the NaN and infinite values (how many, the first),
    /// streaming the cube by slabs: what `femto info` reports of a cube that the stages
    /// refuse. `on_rows` is called with the number of rows scanned so far.
    pub fn value_scan(&self, on_rows: &dyn Fn(usize)) -> Result<ValueScan> {
        let row_len = self.meta.row_len();
        let (nx, nt) = (self.meta.nx, self.meta.axis.nt);
        let rows = slab_rows(row_len * 4, self.meta.ny);
        let mut buf = vec![0.0f32; rows * row_len];
        let mut scan = ValueScan::default();
        for y0 in (0..self.meta.ny).step_by(rows) {
            let n = rows.min(self.meta.ny - y0);
            let slab = &mut buf[..n * row_len];
            self.read_rows_as_stored(y0, slab)?;
            if let Some((lo, hi)) = cube::value_range(slab) {
                scan.range = Some(scan.range.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
            }
            if let Some(mut at) = cube::first_non_finite(slab, nx, nt) {
                at.y += y0;
                scan.first_non_finite.get_or_insert(at);
                scan.non_finite += slab.iter().filter(|v| !v.is_finite()).count();
            }
            on_rows(y0 + n);
        }
        Ok(scan)
    }

    /// Read one extra group whole.
    pub fn read_group(&self, name: &str) -> Result<GroupData> {
        read_group_in(&self.file, &self.path, name)
    }

    /// The attributes of extra group `name`, without reading its datasets.
    pub fn read_group_attrs(&self, name: &str) -> Result<Vec<(String, AttrValue)>> {
        let group = open_group(&self.file, &self.path, name)?;
        read_group_attrs(&group, &self.path, name)
    }

    /// Names of the datasets of extra group `name`, sorted.
    pub fn group_dataset_names(&self, name: &str) -> Result<Vec<String>> {
        let group = open_group(&self.file, &self.path, name)?;
        dataset_names_in(&group, &self.path, name)
    }

    /// Shape and element type name ("f32", "f64", "u8", "u32" or "i32") of dataset
    /// `dataset` of group `group`.
    pub fn group_dataset_shape(
        &self,
        group: &str,
        dataset: &str,
    ) -> Result<(Vec<usize>, &'static str)> {
        group_dataset_shape_in(&self.file, &self.path, group, dataset)
    }

    /// Read rows `r0 .. r0 + n` (along the first axis) of dataset `dataset` of group
    /// `group`, in row-major order.
    pub fn read_group_rows(
        &self,
        group: &str,
        dataset: &str,
        r0: usize,
        n: usize,
    ) -> Result<DataBuf> {
        read_group_rows_in(&self.file, &self.path, group, dataset, r0, n)
    }
}

/// What [`CubeReader::value_scan`] finds in a cube's values.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ValueScan {
    /// Smallest and largest finite value (None when there are none).
    pub range: Option<(f32, f32)>,
    /// How many values are NaN or infinite.
    pub non_finite: usize,
    /// The first of them in storage order.
    pub first_non_finite: Option<cube::NonFiniteAt>,
}

/// Reader of the extra groups of any HDF5 file: a cube file, or a side file that holds
/// groups only (e.g. `femto pyramid --side-file`), which [`CubeReader`] refuses for lack
/// of a `/cube`.
pub struct GroupReader {
    file: H5File,
    path: PathBuf,
    groups: Vec<String>,
    has_cube: bool,
}

impl GroupReader {
    /// Open the HDF5 file at `path` and list its groups.
    pub fn open(path: &Path) -> Result<GroupReader> {
        let file = open_h5(path)?;
        let root = file.root_group();
        let mut groups = root.group_names().map_err(h5(path))?;
        groups.sort();
        let has_cube = root
            .dataset_names()
            .map_err(h5(path))?
            .iter()
            .any(|n| n == CUBE_DATASET);
        Ok(GroupReader {
            file,
            path: path.to_path_buf(),
            groups,
            has_cube,
        })
    }

    /// Names of the groups at the file root, sorted.
    pub fn groups(&self) -> &[String] {
        &self.groups
    }

    /// Whether the file also holds a `/cube` dataset.
    pub fn has_cube(&self) -> bool {
        self.has_cube
    }

    /// Read one group whole.
    pub fn read_group(&self, name: &str) -> Result<GroupData> {
        read_group_in(&self.file, &self.path, name)
    }

    /// The attributes of group `name`, without reading its datasets.
    pub fn read_group_attrs(&self, name: &str) -> Result<Vec<(String, AttrValue)>> {
        let group = open_group(&self.file, &self.path, name)?;
        read_group_attrs(&group, &self.path, name)
    }

    /// Names of the datasets of group `name`, sorted.
    pub fn group_dataset_names(&self, name: &str) -> Result<Vec<String>> {
        let group = open_group(&self.file, &self.path, name)?;
        dataset_names_in(&group, &self.path, name)
    }

    /// Shape and element type name of dataset `dataset` of group `group`.
    pub fn group_dataset_shape(
        &self,
        group: &str,
        dataset: &str,
    ) -> Result<(Vec<usize>, &'static str)> {
        group_dataset_shape_in(&self.file, &self.path, group, dataset)
    }

    /// Read rows `r0 .. r0 + n` (along the first axis) of dataset `dataset` of group
    /// `group`, in row-major order.
    pub fn read_group_rows(
        &self,
        group: &str,
        dataset: &str,
        r0: usize,
        n: usize,
    ) -> Result<DataBuf> {
        read_group_rows_in(&self.file, &self.path, group, dataset, r0, n)
    }
}

fn read_group_in(file: &H5File, path: &Path, name: &str) -> Result<GroupData> {
    let group = open_group(file, path, name)?;
    let attrs = read_group_attrs(&group, path, name)?;
    let mut datasets = Vec::new();
    for ds_name in dataset_names_in(&group, path, name)? {
        let (shape, _) = group_dataset_shape_in(file, path, name, &ds_name)?;
        let rows = shape[0];
        let data = read_group_rows_in(file, path, name, &ds_name, 0, rows)?;
        datasets.push((ds_name, shape, data));
    }
    Ok(GroupData { attrs, datasets })
}

fn open_group(file: &H5File, path: &Path, name: &str) -> Result<H5Group> {
    file.root_group().group(name).map_err(|e| match e {
        Hdf5Error::NotFound(_) => ContainerError::NoGroup {
            path: path.to_path_buf(),
            group: name.to_string(),
        },
        other => h5(path)(other),
    })
}

fn dataset_names_in(group: &H5Group, path: &Path, name: &str) -> Result<Vec<String>> {
    let sub = group.group_names().map_err(h5(path))?;
    if let Some(s) = sub.first() {
        return Err(invalid(
            path,
            format!("group /{name} holds a nested group /{name}/{s}, which femto does not read"),
        ));
    }
    let mut names = group.dataset_names().map_err(h5(path))?;
    names.sort();
    Ok(names)
}

fn group_dataset_shape_in(
    file: &H5File,
    path: &Path,
    group: &str,
    dataset: &str,
) -> Result<(Vec<usize>, &'static str)> {
    let full = format!("{group}/{dataset}");
    open_group(file, path, group)?;
    let ds = open_dataset(file, path, &full)?;
    let elem = group_elem(&ds, path, &full)?;
    let shape = ds.shape();
    if shape.is_empty() {
        return Err(ContainerError::WrongRank {
            path: path.to_path_buf(),
            dataset: full,
            found: 0,
            expected: 1,
        });
    }
    Ok((shape, elem.name()))
}

fn read_group_rows_in(
    file: &H5File,
    path: &Path,
    group: &str,
    dataset: &str,
    r0: usize,
    n: usize,
) -> Result<DataBuf> {
    let (shape, _) = group_dataset_shape_in(file, path, group, dataset)?;
    let full = format!("{group}/{dataset}");
    if r0 + n > shape[0] {
        return Err(invalid(
            path,
            format!(
                "rows {r0}..{} past the {} rows of /{full}",
                r0 + n,
                shape[0]
            ),
        ));
    }
    let ds = open_dataset(file, path, &full)?;
    let elem = group_elem(&ds, path, &full)?;
    let mut starts = vec![0; shape.len()];
    starts[0] = r0;
    let mut counts = shape.clone();
    counts[0] = n;
    if n == 0 {
        return Ok(empty_buf(elem));
    }
    let e = h5(path);
    Ok(match elem {
        Elem::F32 => DataBuf::F32(ds.read_slice(&starts, &counts).map_err(e)?),
        Elem::F64 => DataBuf::F64(ds.read_slice(&starts, &counts).map_err(e)?),
        Elem::U8 => DataBuf::U8(ds.read_slice(&starts, &counts).map_err(e)?),
        Elem::U32 => DataBuf::U32(ds.read_slice(&starts, &counts).map_err(e)?),
        Elem::I32 => DataBuf::I32(ds.read_slice(&starts, &counts).map_err(e)?),
        _ => unreachable!("group_elem admits the DataBuf types only"),
    })
}

fn empty_buf(elem: Elem) -> DataBuf {
    match elem {
        Elem::F64 => DataBuf::F64(Vec::new()),
        Elem::U8 => DataBuf::U8(Vec::new()),
        Elem::U32 => DataBuf::U32(Vec::new()),
        Elem::I32 => DataBuf::I32(Vec::new()),
        _ => DataBuf::F32(Vec::new()),
    }
}

/// The element type of a group dataset, which must be one [`DataBuf`] can hold.
fn group_elem(ds: &H5Dataset, path: &Path, full: &str) -> Result<Elem> {
    let (elem, found) = dataset_elem(ds, path)?;
    match elem {
        Some(e @ (Elem::F32 | Elem::F64 | Elem::U8 | Elem::U32 | Elem::I32)) => Ok(e),
        _ => Err(ContainerError::WrongType {
            path: path.to_path_buf(),
            dataset: full.to_string(),
            found,
            expected: "f32, f64, u8, u32 or i32".into(),
        }),
    }
}

/// Read the whole cube at `path`.
pub fn read_cube(path: &Path) -> Result<Cube> {
    CubeReader::open(path)?.read_cube()
}

/// Read the metadata of the cube at `path`.
pub fn read_meta(path: &Path) -> Result<CubeMeta> {
    Ok(CubeReader::open(path)?.meta)
}

/// Names of the extra groups of the cube at `path`, sorted.
pub fn list_groups(path: &Path) -> Result<Vec<String>> {
    Ok(CubeReader::open(path)?.meta.groups)
}

/// Read extra group `name` of the cube at `path` whole.
pub fn read_group(path: &Path, name: &str) -> Result<GroupData> {
    CubeReader::open(path)?.read_group(name)
}

// ---------------------------------------------------------------------------------------
// Attributes

/// Something that can carry attributes while a file is being written.
trait AttrTarget {
    fn put(&self, name: &str, value: &AttrValue) -> rust_hdf5::Result<()>;
}

impl AttrTarget for H5Dataset {
    fn put(&self, name: &str, value: &AttrValue) -> rust_hdf5::Result<()> {
        match value {
            AttrValue::F64(v) => self
                .new_attr::<f64>()
                .shape(())
                .create(name)?
                .write_numeric(v),
            AttrValue::I64(v) => self
                .new_attr::<i64>()
                .shape(())
                .create(name)?
                .write_numeric(v),
            AttrValue::Str(s) => self
                .new_attr::<VarLenUnicode>()
                .shape(())
                .create(name)?
                .write_string(s),
            AttrValue::F64Array(v) => self
                .new_attr::<f64>()
                .shape([v.len()])
                .create(name)?
                .write_array(v),
        }
    }
}

impl AttrTarget for H5Group {
    fn put(&self, name: &str, value: &AttrValue) -> rust_hdf5::Result<()> {
        match value {
            AttrValue::F64(v) => self.set_attr_numeric(name, v),
            AttrValue::I64(v) => self.set_attr_numeric(name, v),
            AttrValue::Str(s) => self.set_attr_string(name, s),
            AttrValue::F64Array(v) => self.set_attr_array_numeric(name, v),
        }
    }
}

fn set_attr(target: &impl AttrTarget, name: &str, value: &AttrValue) -> rust_hdf5::Result<()> {
    target.put(name, value)
}

/// JSON for an f64 that survives non-finite values (JSON has no NaN or infinity).
fn f64_json(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        json!(v.to_string())
    }
}

fn f64_from_json(v: &Value) -> Option<f64> {
    match v {
        Value::String(s) => s.parse().ok(),
        other => other.as_f64(),
    }
}

/// The [`GROUP_ATTRS_INDEX`] JSON of a group's attributes: `[[name, {type: value}], ...]`.
fn attrs_to_json(attrs: &[(String, AttrValue)]) -> String {
    let list: Vec<Value> = attrs
        .iter()
        .map(|(name, v)| {
            let typed = match v {
                AttrValue::F64(x) => json!({ "f64": f64_json(*x) }),
                AttrValue::I64(x) => json!({ "i64": x }),
                AttrValue::Str(s) => json!({ "str": s }),
                AttrValue::F64Array(xs) => {
                    json!({ "f64_array": xs.iter().map(|x| f64_json(*x)).collect::<Vec<_>>() })
                }
            };
            json!([name, typed])
        })
        .collect();
    Value::Array(list).to_string()
}

fn attrs_from_json(text: &str) -> Option<Vec<(String, AttrValue)>> {
    let list: Vec<Value> = serde_json::from_str(text).ok()?;
    list.iter()
        .map(|item| {
            let name = item.get(0)?.as_str()?.to_string();
            let typed = item.get(1)?.as_object()?;
            let (kind, v) = typed.iter().next()?;
            let value = match kind.as_str() {
                "f64" => AttrValue::F64(f64_from_json(v)?),
                "i64" => AttrValue::I64(v.as_i64()?),
                "str" => AttrValue::Str(v.as_str()?.to_string()),
                "f64_array" => AttrValue::F64Array(
                    v.as_array()?
                        .iter()
                        .map(f64_from_json)
                        .collect::<Option<Vec<_>>>()?,
                ),
                _ => return None,
            };
            Some((name, value))
        })
        .collect()
}

fn read_group_attrs(group: &H5Group, path: &Path, name: &str) -> Result<Vec<(String, AttrValue)>> {
    let names = group.attr_names().map_err(h5(path))?;
    if !names.iter().any(|n| n == GROUP_ATTRS_INDEX) {
        if let Some(first) = names.first() {
            return Err(ContainerError::BadAttribute {
                path: path.to_path_buf(),
                object: name.to_string(),
                attr: first.clone(),
                reason: format!(
                    "group attributes without the {GROUP_ATTRS_INDEX} index cannot be read \
                     (see docs/cube-format.md)"
                ),
            });
        }
        return Ok(Vec::new());
    }
    let text = group.attr_string(GROUP_ATTRS_INDEX).map_err(h5(path))?;
    attrs_from_json(&text).ok_or_else(|| ContainerError::BadAttribute {
        path: path.to_path_buf(),
        object: name.to_string(),
        attr: GROUP_ATTRS_INDEX.to_string(),
        reason: "not a valid attribute index".into(),
    })
}

// ---------------------------------------------------------------------------------------
// Extra groups

fn check_group(path: &Path, name: &str, data: &GroupData) -> Result<()> {
    let layout: Vec<(&str, &[usize])> = data
        .datasets
        .iter()
        .map(|(d, shape, _)| (d.as_str(), shape.as_slice()))
        .collect();
    check_group_layout(path, name, &data.attrs, &layout)?;
    for (d, shape, buf) in &data.datasets {
        let n: usize = shape.iter().product();
        if n != buf.len() {
            return Err(invalid(
                path,
                format!(
                    "dataset /{name}/{d} has shape {shape:?} ({n} values) but {} values",
                    buf.len()
                ),
            ));
        }
    }
    Ok(())
}

/// Check the names of a group, its attributes and datasets, and the datasets' shapes.
fn check_group_layout(
    path: &Path,
    name: &str,
    attrs: &[(String, AttrValue)],
    datasets: &[(&str, &[usize])],
) -> Result<()> {
    check_name(path, "group", name)?;
    if name == CUBE_DATASET || name == MASK_DATASET {
        return Err(invalid(path, format!("group name '{name}' is reserved")));
    }
    for (i, (a, _)) in attrs.iter().enumerate() {
        check_name(path, "attribute", a)?;
        if a == GROUP_ATTRS_INDEX || attrs[..i].iter().any(|(o, _)| o == a) {
            return Err(invalid(
                path,
                format!("attribute '{a}' of group /{name} is reserved or given twice"),
            ));
        }
    }
    for (i, (d, shape)) in datasets.iter().enumerate() {
        check_name(path, "dataset", d)?;
        if datasets[..i].iter().any(|(o, _)| o == d) {
            return Err(invalid(path, format!("dataset /{name}/{d} given twice")));
        }
        if shape.is_empty() || shape.contains(&0) {
            return Err(invalid(
                path,
                format!("dataset /{name}/{d} has shape {shape:?}: every axis needs length > 0"),
            ));
        }
    }
    Ok(())
}

/// Deflate level of the datasets of extra groups unless their [`DatasetSpec`] says
/// otherwise: derived data (the pyramid, the registration), rebuilt by a command in seconds,
/// so written at the fastest level.
const GROUP_DEFLATE_LEVEL: u32 = 1;

/// The filters of a group dataset of `elem`: shuffle (for values wider than a byte), then
/// deflate; `None` for an uncompressed one.
fn group_pipeline(elem: Elem, compression: CubeCompression) -> Option<FilterPipeline> {
    match compression {
        CubeCompression::Deflate(level) if elem.size() > 1 => {
            Some(FilterPipeline::shuffle_deflate(elem.size() as u32, level))
        }
        CubeCompression::Deflate(level) => Some(FilterPipeline::deflate(level)),
        CubeCompression::None => None,
    }
}

/// Create a chunked dataset of `elem` in `group`, one row (index of the first axis) per
/// chunk, so that rows are compressed independently, in parallel ([`write_group_rows`]).
fn create_group_dataset(
    group: &H5Group,
    name: &str,
    elem: Elem,
    shape: &[usize],
    compression: CubeCompression,
) -> rust_hdf5::Result<H5Dataset> {
    fn make<T: H5Type>(
        group: &H5Group,
        name: &str,
        shape: &[usize],
        chunk: &[usize],
        compression: CubeCompression,
    ) -> rust_hdf5::Result<H5Dataset> {
        let b = group.new_dataset::<T>().shape(shape).chunk(chunk);
        match compression {
            CubeCompression::Deflate(level) if T::element_size() > 1 => {
                b.shuffle_deflate(level).create(name)
            }
            CubeCompression::Deflate(level) => b.deflate(level).create(name),
            CubeCompression::None => b.create(name),
        }
    }
    let mut chunk = shape.to_vec();
    chunk[0] = 1;
    match elem {
        Elem::F64 => make::<f64>(group, name, shape, &chunk, compression),
        Elem::U8 => make::<u8>(group, name, shape, &chunk, compression),
        Elem::U32 => make::<u32>(group, name, shape, &chunk, compression),
        Elem::I32 => make::<i32>(group, name, shape, &chunk, compression),
        _ => make::<f32>(group, name, shape, &chunk, compression),
    }
}

/// Little-endian bytes of elements `range` of `buf` ([`le_bytes`]).
fn buf_le_bytes(buf: &DataBuf, range: std::ops::Range<usize>) -> std::borrow::Cow<'_, [u8]> {
    match buf {
        DataBuf::F32(v) => le_bytes(&v[range]),
        DataBuf::F64(v) => le_bytes(&v[range]),
        DataBuf::U8(v) => le_bytes(&v[range]),
        DataBuf::U32(v) => le_bytes(&v[range]),
        DataBuf::I32(v) => le_bytes(&v[range]),
    }
}

/// Write `buf` as rows `r0 ..` of a group dataset of shape `shape` (made by
/// [`create_group_dataset`]): each row is one chunk, compressed on rayon's threads and
/// stored as it is.
fn write_group_rows(
    ds: &H5Dataset,
    shape: &[usize],
    compression: CubeCompression,
    r0: usize,
    buf: &DataBuf,
) -> rust_hdf5::Result<()> {
    let row_elems: usize = shape[1..].iter().product();
    let pipeline = group_pipeline(buf.elem(), compression);
    // Uncompressed rows are stored from `buf` itself (on little-endian machines).
    let chunks: Vec<std::borrow::Cow<[u8]>> = (0..buf.len() / row_elems)
        .into_par_iter()
        .map(|i| {
            let raw = buf_le_bytes(buf, i * row_elems..(i + 1) * row_elems);
            match &pipeline {
                Some(p) => apply_filters(p, &raw)
                    .expect("shuffle and deflate cannot fail on a whole chunk")
                    .into(),
                None => raw,
            }
        })
        .collect();
    let mut coords = vec![0; shape.len()];
    for (i, bytes) in chunks.iter().enumerate() {
        coords[0] = r0 + i;
        if pipeline.is_some() {
            ds.write_chunk_raw_at(&coords, bytes, 0)?;
        } else {
            ds.write_chunk_at(&coords, bytes)?;
        }
    }
    Ok(())
}

fn write_group_attrs(group: &H5Group, attrs: &[(String, AttrValue)]) -> rust_hdf5::Result<()> {
    for (k, v) in attrs {
        set_attr(group, k, v)?;
    }
    group.set_attr_string(GROUP_ATTRS_INDEX, &attrs_to_json(attrs))
}

/// Add the given extra groups to the cube at `cube_path`, replacing groups of the same
/// names, atomically.
///
/// A complete new file is written beside the old one (the cube copied slab by slab, other
/// groups copied row slab by row slab) and renamed onto it, so on failure the old file is
/// left as it was. [`GroupUpdate`] does the same with groups streamed by rows.
pub fn write_groups(cube_path: &Path, groups: &[(&str, GroupData)]) -> Result<()> {
    for (i, (name, data)) in groups.iter().enumerate() {
        check_group(cube_path, name, data)?;
        if groups[..i].iter().any(|(o, _)| o == name) {
            return Err(invalid(cube_path, format!("group /{name} given twice")));
        }
    }
    let mut update = GroupUpdate::open(cube_path)?;
    for (name, data) in groups {
        update.write_group(name, data)?;
    }
    update.finish()
}

/// Copy every row of group `name` of `reader` into a new group of `file`.
fn copy_group(reader: &CubeReader, file: &H5File, name: &str) -> Result<()> {
    let path = &reader.path;
    let e = h5(path);
    let src = open_group(&reader.file, path, name)?;
    let dst = file.create_group(name).map_err(&e)?;
    write_group_attrs(&dst, &read_group_attrs(&src, path, name)?).map_err(&e)?;
    for ds_name in dataset_names_in(&src, path, name)? {
        let (shape, _) = reader.group_dataset_shape(name, &ds_name)?;
        let full = format!("{name}/{ds_name}");
        let src_ds = open_dataset(&reader.file, path, &full)?;
        let elem = group_elem(&src_ds, path, &full)?;
        // Stored as it was: uncompressed, or deflated at its level.
        let compression = match src_ds
            .filters()
            .map_err(&e)?
            .iter()
            .find(|f| f.id == FILTER_DEFLATE)
        {
            Some(f) => CubeCompression::Deflate(
                f.cd_values
                    .first()
                    .copied()
                    .unwrap_or(GROUP_DEFLATE_LEVEL)
                    .min(9),
            ),
            None => CubeCompression::None,
        };
        let ds = create_group_dataset(&dst, &ds_name, elem, &shape, compression).map_err(&e)?;
        let row_bytes = shape[1..].iter().product::<usize>() * elem.size();
        let step = slab_rows(row_bytes, shape[0]);
        for r0 in (0..shape[0]).step_by(step) {
            let n = step.min(shape[0] - r0);
            let slab = reader.read_group_rows(name, &ds_name, r0, n)?;
            write_group_rows(&ds, &shape, compression, r0, &slab).map_err(&e)?;
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Extra groups streamed by rows

/// Element type of a dataset of an extra group: the types a [`DataBuf`] holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GroupElem {
    F32,
    F64,
    U8,
    U32,
    I32,
}

impl GroupElem {
    fn elem(self) -> Elem {
        match self {
            GroupElem::F32 => Elem::F32,
            GroupElem::F64 => Elem::F64,
            GroupElem::U8 => Elem::U8,
            GroupElem::U32 => Elem::U32,
            GroupElem::I32 => Elem::I32,
        }
    }

    /// The type's name as documented in docs/cube-format.md ("f32", "u8", ...).
    pub fn name(self) -> &'static str {
        self.elem().name()
    }
}

impl DataBuf {
    /// The element type of the values.
    pub fn group_elem(&self) -> GroupElem {
        match self {
            DataBuf::F32(_) => GroupElem::F32,
            DataBuf::F64(_) => GroupElem::F64,
            DataBuf::U8(_) => GroupElem::U8,
            DataBuf::U32(_) => GroupElem::U32,
            DataBuf::I32(_) => GroupElem::I32,
        }
    }
}

/// A dataset of an extra group that is written by row slabs ([`GroupUpdate::begin_group`],
/// [`CubeWriter::begin_group`]).
#[derive(Clone, Debug, PartialEq)]
pub struct DatasetSpec {
    /// Name inside the group.
    pub name: String,
    /// Shape, C order; slabs are cut along the first axis.
    pub shape: Vec<usize>,
    pub elem: GroupElem,
    /// Filters of the stored rows: shuffle (for values wider than a byte) + deflate at the
    /// given level, or none. Default: deflate level 1.
    pub compression: CubeCompression,
}

impl DatasetSpec {
    pub fn new(name: impl Into<String>, shape: &[usize], elem: GroupElem) -> DatasetSpec {
        DatasetSpec {
            name: name.into(),
            shape: shape.to_vec(),
            elem,
            compression: CubeCompression::Deflate(GROUP_DEFLATE_LEVEL),
        }
    }

    /// The same dataset stored with `compression`.
    pub fn with_compression(mut self, compression: CubeCompression) -> DatasetSpec {
        self.compression = compression;
        self
    }
}

/// One dataset of a group being written, and which of its rows have been.
struct OpenGroupDataset {
    group: String,
    name: String,
    ds: H5Dataset,
    shape: Vec<usize>,
    elem: Elem,
    compression: CubeCompression,
    rows_written: Vec<bool>,
}

/// The extra groups of a file being written, their datasets filled by row slabs.
#[derive(Default)]
struct GroupSinks {
    /// Names of the groups created so far.
    written: Vec<String>,
    datasets: Vec<OpenGroupDataset>,
}

impl GroupSinks {
    fn begin(
        &mut self,
        file: &H5File,
        path: &Path,
        name: &str,
        attrs: &[(String, AttrValue)],
        specs: &[DatasetSpec],
    ) -> Result<()> {
        let layout: Vec<(&str, &[usize])> = specs
            .iter()
            .map(|d| (d.name.as_str(), d.shape.as_slice()))
            .collect();
        check_group_layout(path, name, attrs, &layout)?;
        if self.written.iter().any(|g| g == name) {
            return Err(invalid(path, format!("group /{name} given twice")));
        }
        let e = h5(path);
        let group = file.create_group(name).map_err(&e)?;
        write_group_attrs(&group, attrs).map_err(&e)?;
        for d in specs {
            let ds = create_group_dataset(&group, &d.name, d.elem.elem(), &d.shape, d.compression)
                .map_err(&e)?;
            self.datasets.push(OpenGroupDataset {
                group: name.to_string(),
                name: d.name.clone(),
                ds,
                shape: d.shape.clone(),
                elem: d.elem.elem(),
                compression: d.compression,
                rows_written: vec![false; d.shape[0]],
            });
        }
        self.written.push(name.to_string());
        Ok(())
    }

    fn write_rows(
        &mut self,
        path: &Path,
        group: &str,
        dataset: &str,
        r0: usize,
        rows: &DataBuf,
    ) -> Result<()> {
        let d = self
            .datasets
            .iter_mut()
            .find(|d| d.group == group && d.name == dataset)
            .ok_or_else(|| {
                invalid(
                    path,
                    format!("dataset /{group}/{dataset} was not declared by begin_group"),
                )
            })?;
        if rows.elem() != d.elem {
            return Err(invalid(
                path,
                format!(
                    "dataset /{group}/{dataset} holds {}, not {}",
                    d.elem.name(),
                    rows.type_name()
                ),
            ));
        }
        let row_elems: usize = d.shape[1..].iter().product();
        if rows.is_empty() || !rows.len().is_multiple_of(row_elems) {
            return Err(invalid(
                path,
                format!(
                    "{} values are not whole rows of {row_elems} of /{group}/{dataset}",
                    rows.len()
                ),
            ));
        }
        let n = rows.len() / row_elems;
        if r0 + n > d.shape[0] {
            return Err(invalid(
                path,
                format!(
                    "rows {r0}..{} past the {} rows of /{group}/{dataset}",
                    r0 + n,
                    d.shape[0]
                ),
            ));
        }
        write_group_rows(&d.ds, &d.shape, d.compression, r0, rows).map_err(h5(path))?;
        d.rows_written[r0..r0 + n].fill(true);
        Ok(())
    }

    fn write_whole(
        &mut self,
        file: &H5File,
        path: &Path,
        name: &str,
        data: &GroupData,
    ) -> Result<()> {
        check_group(path, name, data)?;
        let specs: Vec<DatasetSpec> = data
            .datasets
            .iter()
            .map(|(n, shape, buf)| DatasetSpec::new(n.clone(), shape, buf.group_elem()))
            .collect();
        self.begin(file, path, name, &data.attrs, &specs)?;
        for (n, _, buf) in &data.datasets {
            self.write_rows(path, name, n, 0, buf)?;
        }
        Ok(())
    }

    /// Check that every row of every dataset was written, then release the datasets.
    fn close(self, path: &Path) -> Result<()> {
        for d in &self.datasets {
            if let Some(r) = d.rows_written.iter().position(|w| !w) {
                let n = d.rows_written.iter().filter(|w| !**w).count();
                return Err(invalid(
                    path,
                    format!(
                        "{n} rows of /{}/{} were never written (first: row {r})",
                        d.group, d.name
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// A temporary file beside `dest`, for a writer that renames it onto `dest` when done (the
/// scheme of `atomic::write_atomically`, held open across calls).
fn temp_beside(dest: &Path) -> Result<crate::atomic::TempFile> {
    crate::atomic::temp_beside(dest).map_err(|e| ContainerError::from(e).at(dest))
}

/// Rename a finished temporary file onto `dest`.
fn persist(tmp: crate::atomic::TempFile, dest: &Path) -> Result<()> {
    crate::atomic::persist(tmp, dest).map_err(|source| ContainerError::Io {
        path: dest.to_path_buf(),
        source,
    })
}

/// What a [`GroupUpdate`] writes into.
enum UpdateTarget {
    /// A copy of a cube file; its groups not rewritten are copied at the end.
    Cube {
        sink: Box<CubeSink>,
        reader: Box<CubeReader>,
    },
    /// A file holding groups only.
    SideFile { file: QuietFile },
}

/// Adds or replaces extra groups of an existing cube file, or writes a side file that holds
/// groups only, with datasets streamed by row slabs so that peak memory is one slab.
///
/// Like [`CubeWriter`], everything goes to a temporary file beside the destination, renamed
/// onto it by [`GroupUpdate::finish`]; dropping an unfinished update deletes the temporary file
/// and leaves the old file as it was. For a cube, the cube and mask are copied when the update
/// is opened, and the groups that were not rewritten when it is finished.
pub struct GroupUpdate {
    // Field order matters: the HDF5 file is closed before the temporary path is deleted.
    groups: GroupSinks,
    target: UpdateTarget,
    tmp: crate::atomic::TempFile,
    dest: PathBuf,
}

impl GroupUpdate {
    /// Start an update of the cube file at `cube_path` (copying its cube and mask).
    pub fn open(cube_path: &Path) -> Result<GroupUpdate> {
        let reader = CubeReader::open(cube_path)?;
        let tmp = temp_beside(cube_path)?;
        let meta = reader.meta.clone();
        let attrs = CubeAttrs {
            axis: meta.axis,
            frame: meta.frame,
            units: &meta.units,
            femto_version: meta.femto_version.as_deref(),
            command_line: meta.command_line.as_deref(),
            notes: &meta.notes,
        };
        // The cube keeps its compression (level included).
        let compression = reader.stored_compression();
        let mut sink =
            CubeSink::create_with(&tmp, cube_path, meta.nx, meta.ny, &attrs, compression)?;
        let row_len = meta.row_len();
        // Chunks stored as this sink stores them are copied as they are (no decompression
        // and recompression); other rows are decoded and written.
        let cx = chunk_rows(meta.axis.nt * 4, meta.nx);
        let raw =
            matches!(sink.compression, CubeCompression::Deflate(_)) && reader.stored_as_written(cx);
        let rows = slab_rows(row_len * 4, meta.ny);
        let mut buf = vec![0.0f32; rows * row_len];
        for y0 in (0..meta.ny).step_by(rows) {
            let n = rows.min(meta.ny - y0);
            let copied = raw
                .then(|| {
                    (y0..y0 + n)
                        .map(|y| reader.read_raw_row(y, meta.nx.div_ceil(cx)))
                        .collect::<Option<Vec<_>>>()
                })
                .flatten();
            match copied {
                Some(slab) => {
                    for (y, chunks) in (y0..).zip(&slab) {
                        sink.write_raw_row(y, chunks)?;
                    }
                }
                None => {
                    reader.read_rows_into(y0, &mut buf[..n * row_len])?;
                    sink.write_rows(y0, &buf[..n * row_len])?;
                }
            }
        }
        drop(buf);
        if let Some(mask) = reader.read_mask()? {
            sink.write_mask(&mask)?;
        }
        Ok(GroupUpdate {
            groups: GroupSinks::default(),
            target: UpdateTarget::Cube {
                sink: Box::new(sink),
                reader: Box::new(reader),
            },
            tmp,
            dest: cube_path.to_path_buf(),
        })
    }

    /// Start a new side file at `path` that will hold groups only (no `/cube`); read it back
    /// with [`GroupReader`].
    pub fn side_file(path: &Path) -> Result<GroupUpdate> {
        let tmp = temp_beside(path)?;
        let file = H5File::options()
            .best_effort_locking()
            .create(&tmp)
            .map_err(h5(path))?;
        Ok(GroupUpdate {
            groups: GroupSinks::default(),
            target: UpdateTarget::SideFile {
                file: QuietFile(Some(file)),
            },
            tmp,
            dest: path.to_path_buf(),
        })
    }

    /// Create group `name` with its attributes and empty datasets, to be filled by
    /// [`GroupUpdate::write_group_rows`]. A group of that name in the old file is replaced.
    pub fn begin_group(
        &mut self,
        name: &str,
        attrs: &[(String, AttrValue)],
        datasets: &[DatasetSpec],
    ) -> Result<()> {
        let file = match &self.target {
            UpdateTarget::Cube { sink, .. } => &sink.file,
            UpdateTarget::SideFile { file } => file,
        };
        self.groups.begin(file, &self.dest, name, attrs, datasets)
    }

    /// Write rows `r0 ..` of dataset `dataset` of group `group` (begun before).
    pub fn write_group_rows(
        &mut self,
        group: &str,
        dataset: &str,
        r0: usize,
        rows: &DataBuf,
    ) -> Result<()> {
        self.groups.write_rows(&self.dest, group, dataset, r0, rows)
    }

    /// Write a whole group at once.
    pub fn write_group(&mut self, name: &str, data: &GroupData) -> Result<()> {
        let file = match &self.target {
            UpdateTarget::Cube { sink, .. } => &sink.file,
            UpdateTarget::SideFile { file } => file,
        };
        self.groups.write_whole(file, &self.dest, name, data)
    }

    /// Check that every row was written, copy the untouched groups of the old cube file,
    /// close the file and rename it onto the destination.
    pub fn finish(self) -> Result<()> {
        self.finish_staged()?.persist()
    }

    /// [`GroupUpdate::finish`] but the rename: the closed file stays beside the destination
    /// until [`StagedFile::persist`], for a command that commits several outputs together.
    pub fn finish_staged(self) -> Result<StagedFile> {
        let GroupUpdate {
            groups,
            target,
            tmp,
            dest,
        } = self;
        let written = groups.written.clone();
        groups.close(&dest)?;
        match target {
            UpdateTarget::Cube { sink, reader } => {
                for old in &reader.meta.groups {
                    if !written.contains(old) {
                        copy_group(&reader, &sink.file, old)?;
                    }
                }
                drop(reader);
                sink.close()?;
            }
            UpdateTarget::SideFile { file } => file.into_inner().close().map_err(h5(&dest))?,
        }
        Ok(StagedFile { tmp, dest })
    }
}

/// A finished file still under its temporary name beside its destination (dropping it
/// deletes it).
pub struct StagedFile {
    tmp: crate::atomic::TempFile,
    dest: PathBuf,
}

impl StagedFile {
    /// Rename the file onto its destination.
    pub fn persist(self) -> Result<()> {
        persist(self.tmp, &self.dest)
    }
}

// ---------------------------------------------------------------------------------------
// Image stacks (HDF5 input to `femto ingest`)

/// Read a 3-D stack of streak images stored in one dataset, converting u8, u16, u32, i32,
/// f32 or f64 values to f32. Returns the dataset's shape and its values in row-major order.
pub fn read_image_stack(path: &Path, dataset: &str) -> Result<(Vec<usize>, Vec<f32>)> {
    let file = open_h5(path)?;
    let name = dataset.trim_start_matches('/');
    let ds = open_dataset(&file, path, name)?;
    let shape = ds.shape();
    if shape.len() != 3 {
        return Err(ContainerError::WrongRank {
            path: path.to_path_buf(),
            dataset: name.to_string(),
            found: shape.len(),
            expected: 3,
        });
    }
    let (elem, found) = dataset_elem(&ds, path)?;
    // The raw values and their f32 copy are held together: at most 8 + 4 bytes a value.
    let values_count = shape.iter().map(|&n| n as f64).product::<f64>();
    crate::limits::check_memory(
        12.0 * values_count,
        format!("the image stack /{name} of {shape:?} values"),
        "split the stack into several datasets, or ingest its images as files",
    )
    .map_err(|source| ContainerError::Limit {
        path: path.to_path_buf(),
        source,
    })?;
    let e = h5(path);
    let values: Vec<f32> = match elem {
        Some(Elem::U8) => convert(ds.read_raw::<u8>().map_err(e)?, f32::from),
        Some(Elem::U16) => convert(ds.read_raw::<u16>().map_err(e)?, f32::from),
        Some(Elem::U32) => convert(ds.read_raw::<u32>().map_err(e)?, |v| v as f32),
        Some(Elem::I32) => convert(ds.read_raw::<i32>().map_err(e)?, |v| v as f32),
        Some(Elem::F32) => ds.read_raw::<f32>().map_err(e)?,
        Some(Elem::F64) => convert(ds.read_raw::<f64>().map_err(e)?, |v| v as f32),
        _ => {
            return Err(ContainerError::WrongType {
                path: path.to_path_buf(),
                dataset: name.to_string(),
                found,
                expected: "u8, u16, u32, i32, f32 or f64".into(),
            })
        }
    };
    Ok((shape, values))
}

fn convert<T: Copy>(v: Vec<T>, f: impl Fn(T) -> f32) -> Vec<f32> {
    v.into_iter().map(f).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunk_holds_whole_profiles_of_one_row() {
        // 256 KiB / (4 bytes * 1024 bins) = at most 64 pixels per chunk; 1000 pixels need 16
        // chunks, balanced to 63 pixels (16 * 63 = 1008: 8 padded, not 24).
        assert_eq!(chunk_rows(4 * 1024, 1000), 63);
        // The seed's capture: 672 pixels of 512 bins, at most 128 per chunk: 6 chunks of 112.
        assert_eq!(chunk_rows(4 * 512, 672), 112);
        assert_eq!(chunk_rows(4 * 1024, 128), 64);
        // Never wider than the row, never empty.
        assert_eq!(chunk_rows(4 * 16, 10), 10);
        assert_eq!(chunk_rows(4 << 20, 10), 1);
    }

    #[test]
    fn attr_index_round_trips_every_kind() {
        let attrs = vec![
            ("a".to_string(), AttrValue::F64(0.1)),
            ("b".to_string(), AttrValue::F64(f64::NAN)),
            ("c".to_string(), AttrValue::I64(-3)),
            ("d".to_string(), AttrValue::Str("x \"y\"".into())),
            (
                "e".to_string(),
                AttrValue::F64Array(vec![1e-300, f64::INFINITY, -2.5]),
            ),
        ];
        let back = attrs_from_json(&attrs_to_json(&attrs)).unwrap();
        assert_eq!(back.len(), attrs.len());
        for ((n0, v0), (n1, v1)) in attrs.iter().zip(&back) {
            assert_eq!(n0, n1);
            match (v0, v1) {
                (AttrValue::F64(a), AttrValue::F64(b)) if a.is_nan() => assert!(b.is_nan()),
                _ => assert_eq!(v0, v1),
            }
        }
    }

    #[test]
    fn compressed_rows_read_back_like_plain_rows() {
        // nx = 69 with nt = 1024 gives two 35-pixel chunks (at most 64 per chunk): one full
        // chunk and an edge chunk padded by one pixel.
        let (nx, ny, nt) = (69usize, 3usize, 1024usize);
        let axis = TimeAxis {
            t0_ps: -3.0,
            dt_ps: 0.5,
            nt,
        };
        let value = |y: usize, i: usize| ((y * 7919 + i * 104_729) % 10_007) as f32 * 0.25 - 9.0;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.h5");
        let mut w = camera_writer(&path, nx, ny, axis, CubeCompression::default()).unwrap();
        let compressor = w.row_compressor();
        assert_eq!(compressor.row_len(), nx * nt);
        for y in [2, 0] {
            let row: Vec<f32> = (0..nx * nt).map(|i| value(y, i)).collect();
            let c = compressor.compress(&row);
            assert!(c.stored_bytes() > 0);
            w.write_compressed_row(y, &c).unwrap();
        }
        let plain: Vec<f32> = (0..nx * nt).map(|i| value(1, i)).collect();
        w.write_rows(1, &plain).unwrap();
        let bad = RowCompressor {
            nx: nx - 1,
            ..compressor.clone()
        };
        assert!(w
            .write_compressed_row(0, &bad.compress(&plain[..(nx - 1) * nt]))
            .is_err());
        w.finish().unwrap();
        let back = read_cube(&path).unwrap();
        for y in 0..ny {
            for i in 0..nx * nt {
                assert_eq!(back.data[y * nx * nt + i], value(y, i), "y {y} i {i}");
            }
        }

        // Uncompressed cubes and every deflate level (miniz_oxide at 1, libdeflate at the
        // others) read back the same, from borrowed and from owned rows.
        let levels = (0..=9).map(CubeCompression::Deflate);
        for compression in std::iter::once(CubeCompression::None).chain(levels) {
            let p = dir.path().join("d.h5");
            let mut w = camera_writer(&p, nx, ny, axis, compression).unwrap();
            let row0: Vec<f32> = (0..nx * nt).map(|i| value(0, i)).collect();
            // Deflated chunks decode whatever their level; raw ones only fit an unfiltered cube.
            let foreign = w.write_compressed_row(0, &compressor.compress(&row0));
            assert_eq!(foreign.is_err(), compression == CubeCompression::None);
            let c = w.row_compressor();
            for y in 0..ny {
                let row: Vec<f32> = (0..nx * nt).map(|i| value(y, i)).collect();
                let packed = if y == 1 {
                    c.compress(&row)
                } else {
                    c.compress_owned(row.clone())
                };
                w.write_compressed_row(y, &packed).unwrap();
                if y != 1 || compression == CubeCompression::None {
                    // The buffer comes back for the next row.
                    assert_eq!(packed.into_buffer().len(), nx * nt);
                }
            }
            w.finish().unwrap();
            assert_eq!(read_cube(&p).unwrap().data, back.data, "{compression:?}");
        }
        assert!(camera_writer(
            &dir.path().join("e.h5"),
            nx,
            ny,
            axis,
            CubeCompression::Deflate(10)
        )
        .is_err());
    }

    /// A writer of a camera-time test cube at `p`.
    fn camera_writer(
        p: &Path,
        nx: usize,
        ny: usize,
        axis: TimeAxis,
        compression: CubeCompression,
    ) -> Result<CubeWriter> {
        CubeWriter::create_with(
            p,
            nx,
            ny,
            axis,
            TimeFrame::Camera,
            DEFAULT_UNITS,
            &Provenance::new("test"),
            compression,
        )
    }

    /// Adding a group in place copies the cube: chunk by chunk as stored when femto's writer
    /// made it (deflate at any level), decoded and written again otherwise (an uncompressed
    /// cube); the cube, its mask and its compression come back unchanged either way.
    #[test]
    fn group_update_copies_the_cube_raw_or_decoded() {
        let dir = tempfile::tempdir().unwrap();
        let (nx, ny, nt) = (300, 3, 512);
        let axis = TimeAxis {
            t0_ps: 1.0,
            dt_ps: 2.0,
            nt,
        };
        let data: Vec<f32> = (0..nx * ny * nt).map(|i| (i % 97) as f32 - 3.5).collect();
        let mask: Vec<u8> = (0..nx * ny).map(|i| u8::from(i % 4 != 0)).collect();
        for (compression, raw) in [
            (CubeCompression::Deflate(6), true),
            (CubeCompression::None, false),
        ] {
            let p = dir.path().join(format!("{compression:?}.h5"));
            let mut w = camera_writer(&p, nx, ny, axis, compression).unwrap();
            w.write_rows(0, &data).unwrap();
            w.write_mask(&mask).unwrap();
            w.finish().unwrap();
            let cx = chunk_rows(nt * 4, nx);
            assert!(cx < nx, "the test needs several chunks per row");
            assert_eq!(CubeReader::open(&p).unwrap().stored_as_written(cx), raw);
            let mut u = GroupUpdate::open(&p).unwrap();
            u.begin_group("g", &[], &[DatasetSpec::new("d", &[2, 3], GroupElem::F64)])
                .unwrap();
            u.write_group_rows("g", "d", 0, &DataBuf::F64(vec![1.0; 6]))
                .unwrap();
            u.finish().unwrap();
            let back = read_cube(&p).unwrap();
            assert_eq!(back.data, data, "{compression:?}");
            assert_eq!(back.mask.as_deref(), Some(&mask[..]));
            // The cube keeps its compression: an uncompressed cube stays uncompressed.
            let reader = CubeReader::open(&p).unwrap();
            assert_eq!(reader.stored_compression(), compression);
            assert_eq!(reader.stored_as_written(cx), raw);
        }
    }

    #[test]
    fn streamed_groups_must_be_complete_and_leave_nothing_on_failure() {
        let dir = tempfile::tempdir().unwrap();
        let side = dir.path().join("side.h5");
        let spec = [DatasetSpec::new("d", &[3, 2], GroupElem::F64)];
        let attrs = vec![("n".to_string(), AttrValue::I64(3))];
        // Row 2 never written: refused, and neither the file nor a temporary file remains.
        let mut up = GroupUpdate::side_file(&side).unwrap();
        up.begin_group("g", &attrs, &spec).unwrap();
        up.write_group_rows("g", "d", 0, &DataBuf::F64(vec![1.0, 2.0, 3.0, 4.0]))
            .unwrap();
        let e = up.finish().unwrap_err().to_string();
        assert!(e.contains("/g/d") && e.contains("row 2"), "{e}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        // Wrong type, past the end, undeclared dataset, then a complete file read back.
        let mut up = GroupUpdate::side_file(&side).unwrap();
        up.begin_group("g", &attrs, &spec).unwrap();
        assert!(up
            .write_group_rows("g", "d", 0, &DataBuf::F32(vec![0.0; 2]))
            .is_err());
        assert!(up
            .write_group_rows("g", "d", 2, &DataBuf::F64(vec![0.0; 4]))
            .is_err());
        assert!(up
            .write_group_rows("g", "e", 0, &DataBuf::F64(vec![0.0; 2]))
            .is_err());
        assert!(up.begin_group("g", &[], &[]).is_err());
        for r in [2, 0, 1] {
            let v = vec![r as f64, -(r as f64)];
            up.write_group_rows("g", "d", r, &DataBuf::F64(v)).unwrap();
        }
        up.finish().unwrap();
        let reader = GroupReader::open(&side).unwrap();
        assert!(!reader.has_cube());
        assert_eq!(reader.groups(), ["g"]);
        let g = reader.read_group("g").unwrap();
        assert_eq!(g.attrs, attrs);
        assert_eq!(
            g.dataset("d").unwrap(),
            (
                &[3usize, 2][..],
                &DataBuf::F64(vec![0.0, -0.0, 1.0, -1.0, 2.0, -2.0])
            )
        );
        assert!(matches!(
            CubeReader::open(&side),
            Err(ContainerError::NoCube { .. })
        ));
    }

    #[test]
    fn signature_found_after_user_block() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x");
        let mut bytes = vec![0u8; 512];
        bytes.extend_from_slice(&HDF5_SIGNATURE);
        std::fs::write(&p, &bytes).unwrap();
        assert!(is_hdf5(&p).unwrap());
        std::fs::write(&p, b"\x89PNG\r\n\x1a\n").unwrap();
        assert!(!is_hdf5(&p).unwrap());
    }
}

//! The container's schema in types: dataset and attribute names, the chunk and slab sizes,
//! the values read and written ([`CubeMeta`], [`DataBuf`], [`GroupData`], [`DatasetSpec`]) and
//! the element types recognised on disk. See `docs/cube-format.md` for the schema itself.

use super::error::{invalid, Result};
use crate::cube::TimeAxis;
use crate::cube::TimeFrame;
use crate::ranges;
use rust_hdf5::DatatypeMessage;
use std::path::Path;

/// Name of the cube dataset at the file root.
pub const CUBE_DATASET: &str = "cube";
/// Name of the optional validity-mask dataset at the file root.
pub const MASK_DATASET: &str = "mask";
/// Units written by [`write_cube`] when the caller names none: the cube holds relative
/// signal per bin with no absolute calibration.
///
/// [`write_cube`]: super::write_cube
pub const DEFAULT_UNITS: &str = "arbitrary";
/// String attribute on each extra group holding all its attributes, typed, as JSON.
///
/// `rust_hdf5` 0.7 can read numeric attributes of datasets but only string attributes of
/// groups, so a group's attributes are written twice from the same values: as ordinary
/// HDF5 attributes (what h5py users read) and in this one JSON index (what femto reads).
pub const GROUP_ATTRS_INDEX: &str = "_femto_attrs";

/// Attribute names of `/cube` that are not provenance notes.
pub(super) const RESERVED_ATTRS: [&str; 6] = [
    "t0_ps",
    "dt_ps",
    "time_frame",
    "units",
    "femto_version",
    "command_line",
];

/// Deflate level: 4 is h5py's default for gzip, a good speed/size trade for f32 signal.
pub(super) const DEFLATE_LEVEL: u32 = 4;

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
pub(super) const CHUNK_TARGET_BYTES: usize = 256 * 1024;

/// Largest slab of rows moved at once when copying or scanning a cube, bytes.
pub(super) const SLAB_TARGET_BYTES: usize = 32 << 20;

/// How the `/cube` dataset of a streamed cube is stored (the chunk shape is the same).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CubeCompression {
    /// Shuffle + deflate at this level (0-9); level 4 is femto's default, as h5py's gzip.
    Deflate(u32),
    /// No filter: chunks stored as they are (fastest to write, about three times larger for
    /// camera data).
    None,
}

impl CubeCompression {
    /// Parse `none` or a deflate level 0-9 (with shuffle): the value of the `--compression`
    /// flags; the message says what was expected.
    pub fn parse(s: &str) -> std::result::Result<CubeCompression, String> {
        if s == "none" {
            return Ok(CubeCompression::None);
        }
        match s.parse::<u32>() {
            Ok(level) if level <= 9 => Ok(CubeCompression::Deflate(level)),
            _ => Err(format!("'{s}' is not 'none' or a deflate level 0-9")),
        }
    }
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

    pub(super) fn elem(&self) -> Elem {
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

/// Element types the container recognises on disk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Elem {
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
    pub(super) fn of(dt: &DatatypeMessage) -> Option<Elem> {
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

    pub(super) fn name(self) -> &'static str {
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

    pub(super) fn size(self) -> usize {
        match self {
            Elem::U8 | Elem::I8 => 1,
            Elem::U16 | Elem::I16 => 2,
            Elem::U32 | Elem::I32 | Elem::F32 => 4,
            Elem::U64 | Elem::I64 | Elem::F64 => 8,
        }
    }
}

/// A readable name for a datatype, for error messages.
pub(super) fn type_description(dt: &DatatypeMessage) -> String {
    Elem::of(dt).map_or_else(|| dt.to_string(), |e| e.name().to_string())
}

pub(super) fn check_name(path: &Path, what: &str, name: &str) -> Result<()> {
    if name.is_empty() || name.contains('/') || name == "." {
        return Err(invalid(
            path,
            format!("{what} name '{name}' must be non-empty and contain no '/'"),
        ));
    }
    Ok(())
}

/// The axis attributes of `/cube` with their meaningful ranges ([`crate::ranges`]).
pub(super) fn axis_ranges(axis: &TimeAxis) -> [(&'static str, f64, ranges::Range); 2] {
    [
        ("t0_ps", axis.t0_ps, ranges::TIME_PS),
        ("dt_ps", axis.dt_ps, ranges::BIN_WIDTH_PS),
    ]
}

pub(super) fn check_axis(path: &Path, axis: &TimeAxis) -> Result<()> {
    if axis.nt == 0 {
        return Err(invalid(path, "a cube needs at least one time bin"));
    }
    for (key, value, range) in axis_ranges(axis) {
        ranges::check(key, value, range).map_err(|e| invalid(path, e.to_string()))?;
    }
    Ok(())
}

/// Rows of `row_bytes` per chunk of a dataset of `rows` rows: at most
/// [`CHUNK_TARGET_BYTES`], balanced so the last chunk is about as full as the others.
pub(super) fn chunk_rows(row_bytes: usize, rows: usize) -> usize {
    let most = (CHUNK_TARGET_BYTES / row_bytes.max(1)).clamp(1, rows.max(1));
    rows.max(1).div_ceil(rows.max(1).div_ceil(most))
}

pub(super) fn slab_rows(row_bytes: usize, rows: usize) -> usize {
    (SLAB_TARGET_BYTES / row_bytes.max(1)).clamp(1, rows.max(1))
}

/// Deflate level of the datasets of extra groups unless their [`DatasetSpec`] says
/// otherwise: derived data (the pyramid, the registration), rebuilt by a command in seconds,
/// so written at the fastest level.
pub(super) const GROUP_DEFLATE_LEVEL: u32 = 1;

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
    pub(super) fn elem(self) -> Elem {
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
///
/// [`GroupUpdate::begin_group`]: super::GroupUpdate::begin_group
/// [`CubeWriter::begin_group`]: super::CubeWriter::begin_group
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

/// The little-endian bytes of `values` (every on-disk type of femto's files is
/// little-endian): a view of the same memory on little-endian machines, a converted copy
/// elsewhere.
pub(super) fn le_bytes<T: bytemuck::Pod>(values: &[T]) -> std::borrow::Cow<'_, [u8]> {
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
}

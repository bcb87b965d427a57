//! The describe stage (`femto info`): what a file femto reads or writes holds, as a typed
//! [`Description`] that prints as text ([`std::fmt::Display`]) or as the JSON object that
//! docs/cube-format.md documents ([`Description::to_json`]).
//!
//! The kind of file is decided from its contents where the format allows (an HDF5 signature
//! means a cube, or a pyramid side file when there is no `/cube`), meshes and streak images
//! by their extension. One module per kind: [`cube`], with its [`registration`] and
//! [`pyramid`] groups (a pyramid side file too), [`mesh`], [`streak`].

pub mod array;
pub mod brief;
pub mod cube;
pub mod mesh;
pub mod pyramid;
pub mod registration;
pub mod streak;

pub use array::ArrayDescription;
pub use cube::CubeDescription;
pub use mesh::{MaterialArea, MeshDescription};
pub use pyramid::{PrefixLayout, PyramidSummary, SideFileDescription};
pub use registration::{FitFigures, RegistrationSummary, StoredNumber};
pub use streak::{StreakAxis, StreakDescription, StreakTimeAxis};

use super::{Progress, StageError};
use crate::container::GroupReader;
use crate::store::pyramid as stored_pyramid;
use serde::{Serialize, Serializer};
use std::fmt;
use std::path::Path;

/// How [`describe_file`] reads a file; `Default` is what `femto info` does.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DescribeOptions {
    /// Read a streak image as storing time across and x down, as `femto ingest --transpose`
    /// reads it (the HPD-TA axis roles swap too); cubes and meshes are unaffected.
    pub transpose: bool,
    /// For array files: which dataset and layout, as `femto ingest` takes them
    /// (`--dataset`, `--time-axis`, `--select`, `--sum`).
    pub array: crate::readers::ReadOptions,
}

/// What a file is and holds; `kind` in the JSON tells which.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind")]
// One description per call, never stored in bulk: its variants are not boxed.
#[allow(clippy::large_enum_variant)]
pub enum Description {
    /// A femto cube (HDF5 with `/cube`).
    #[serde(rename = "cube")]
    Cube(CubeDescription),
    /// An HDF5 file with a `pyramid` group and no `/cube` (`femto pyramid --side-file`).
    #[serde(rename = "pyramid")]
    PyramidSideFile(SideFileDescription),
    /// A triangle mesh (.obj, .gltf, .glb).
    #[serde(rename = "mesh")]
    Mesh(MeshDescription),
    /// A streak image (.png, .tif, .tiff, .exr, .hdr, .img).
    #[serde(rename = "streak_image")]
    StreakImage(StreakDescription),
    /// An array file `femto ingest` reads (.npy, .mat, .hspy, an HDF5 dataset).
    #[serde(rename = "array")]
    Array(ArrayDescription),
}

impl Description {
    /// The JSON object of `femto info --json` (docs/cube-format.md), keys sorted.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("a description serialises to JSON")
    }
}

impl fmt::Display for Description {
    /// The text of `femto info`: one `key  value` line per fact, rounded and with long
    /// lists summarised ([`brief`]); the alternate form (`{:#}`, `femto info --full`) prints
    /// every stored value whole.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Description::Cube(d) => d.fmt(f),
            Description::PyramidSideFile(d) => d.fmt(f),
            Description::Mesh(d) => d.fmt(f),
            Description::StreakImage(d) => d.fmt(f),
            Description::Array(d) => d.fmt(f),
        }
    }
}

/// Mesh extensions (lower case), decided by name.
const MESH_EXTENSIONS: [&str; 3] = ["obj", "gltf", "glb"];

/// Describe the file at `path`; the cube's values are streamed once for their range
/// (reported to `progress` as the pass "scanning", one step per row).
pub fn describe_file(
    path: &Path,
    options: &DescribeOptions,
    progress: &dyn Progress,
) -> Result<Description, StageError> {
    let is_hdf5 = crate::container::is_hdf5(path).map_err(|source| StageError::Io {
        path: path.display().to_string(),
        source,
    })?;
    if is_hdf5 {
        let groups = GroupReader::open(path)?;
        if !groups.has_cube() && groups.groups().iter().any(|g| g == stored_pyramid::GROUP) {
            return Ok(Description::PyramidSideFile(pyramid::describe_side_file(
                path, &groups,
            )?));
        }
        let has_cube = groups.has_cube();
        drop(groups);
        if !has_cube && crate::interop::is_tal_capture(path) {
            return Ok(Description::Array(array::describe_tal(path)?));
        }
        if !has_cube {
            if let Some(format) = crate::readers::Format::sniff(path) {
                return Ok(Description::Array(array::describe_array(
                    path,
                    format,
                    &options.array,
                )?));
            }
        }
        // A cube, or not ours: then the cube reader says why.
        return Ok(Description::Cube(cube::describe_cube(path, progress)?));
    }
    let ext = extension(path);
    if MESH_EXTENSIONS.contains(&ext.as_str()) {
        return Ok(Description::Mesh(mesh::describe_mesh(path)?));
    }
    if let Some(format) = crate::readers::Format::sniff(path) {
        return Ok(Description::Array(array::describe_array(
            path,
            format,
            &options.array,
        )?));
    }
    if crate::formats::streak_extension(path).is_some() {
        return Ok(Description::StreakImage(streak::describe_streak(
            path,
            options.transpose,
        )?));
    }
    let message = match crate::readers::Format::convert_hint(path) {
        Some(hint) => hint.to_string(),
        None => format!(
            "not a file femto reads; {}",
            crate::readers::Format::readable_list()
        ),
    };
    Err(StageError::Input {
        path: path.display().to_string(),
        message,
    })
}

/// Smallest and largest finite value (of a cube, an image, or distances in metres).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ValueRange {
    pub min: f32,
    pub max: f32,
}

impl ValueRange {
    /// From `(min, max)` as [`crate::cube::value_range`] returns it.
    pub fn from_pair((min, max): (f32, f32)) -> ValueRange {
        ValueRange { min, max }
    }
}

/// The extension of `path` in lower case ("" without one).
fn extension(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// One line of the text form: the key padded to 14 columns, then the value.
fn line(f: &mut fmt::Formatter<'_>, key: &str, value: impl fmt::Display) -> fmt::Result {
    writeln!(f, "{key:<14}{value}")
}

/// A value as the JSON object writes it (`2.0`, `[4,5,8]`, `null` for None or a non-finite
/// number): the text form shows some figures this way.
fn json_text<T: Serialize>(value: &T) -> String {
    serde_json::to_string(value).expect("a figure serialises to JSON")
}

/// A path as the JSON's `file` keys write it (lossy where it is not UTF-8).
fn serialize_path<P: AsRef<Path>, S: Serializer>(path: &P, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(&path.as_ref().display())
}

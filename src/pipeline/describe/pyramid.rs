//! Summarising a `pyramid` group, stored with a cube or in a side file of its own (the
//! `pyramid` objects of docs/cube-format.md).

use super::{json_text, line, serialize_path};
use crate::container::{AttrValue, CubeMeta, GroupReader};
use crate::cube::TimeAxis;
use crate::pipeline::StageError;
use crate::pyramid::coarse_len;
use crate::store::pyramid::{self as stored_pyramid, PyramidInfo};
use serde::{Serialize, Serializer};
use std::fmt;
use std::path::{Path, PathBuf};

/// The `pyramid` group, from its attributes and dataset names.
#[derive(Clone, Debug, PartialEq)]
pub enum PyramidSummary {
    Readable {
        /// The group's attributes: shape, time axis and frame, levels, source.
        info: PyramidInfo,
        /// The layout of its prefix sums, from its dataset names.
        prefix: PrefixLayout,
        /// Whether it still fits the cube's shape and time axis (None for a side file).
        matches_cube: Option<bool>,
    },
    /// The attributes cannot be read: why.
    Unreadable { error: String },
}

/// How a pyramid stores its prefix sums; shapes `(ny, nx, n)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "layout")]
pub enum PrefixLayout {
    /// `prefix_coarse` (f64 at every 8th bin) and `prefix_fine` (f32 within the blocks).
    #[serde(rename = "two-level")]
    TwoLevel {
        coarse_shape: [usize; 3],
        fine_shape: [usize; 3],
    },
    /// One f64 `prefix` dataset, as an older femto wrote it.
    #[serde(rename = "f64")]
    F64 { shape: [usize; 3] },
}

/// A pyramid side file: an HDF5 file holding groups and no `/cube`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SideFileDescription {
    #[serde(serialize_with = "serialize_path")]
    pub file: PathBuf,
    /// The groups at the file's root.
    pub groups: Vec<String>,
    pub pyramid: PyramidSummary,
}

/// Describe the pyramid side file at `path`, opened as `groups`.
pub(super) fn describe_side_file(
    path: &Path,
    groups: &GroupReader,
) -> Result<SideFileDescription, StageError> {
    let attrs = groups.read_group_attrs(stored_pyramid::GROUP)?;
    let names = groups.group_dataset_names(stored_pyramid::GROUP)?;
    Ok(SideFileDescription {
        file: path.to_path_buf(),
        groups: groups.groups().to_vec(),
        pyramid: summarise_pyramid(path, attrs, &names, None),
    })
}

/// The pyramid group from its attributes and dataset names; `meta` is the cube it is checked
/// against.
pub(super) fn summarise_pyramid(
    path: &Path,
    attrs: Vec<(String, AttrValue)>,
    datasets: &[String],
    meta: Option<&CubeMeta>,
) -> PyramidSummary {
    let has = |name: &str| datasets.iter().any(|d| d == name);
    match stored_pyramid::info_from_attrs(path, attrs) {
        Ok(info) => {
            let (ny, nx, nt) = (info.ny, info.nx, info.axis.nt);
            let prefix = if has(stored_pyramid::COARSE) || !has("prefix") {
                PrefixLayout::TwoLevel {
                    coarse_shape: [ny, nx, coarse_len(nt)],
                    fine_shape: [ny, nx, nt + 1],
                }
            } else {
                PrefixLayout::F64 {
                    shape: [ny, nx, nt + 1],
                }
            };
            PyramidSummary::Readable {
                matches_cube: meta.map(|m| info.check_matches(path, m).is_ok()),
                info,
                prefix,
            }
        }
        Err(e) => PyramidSummary::Unreadable {
            error: e.to_string(),
        },
    }
}

/// The `pyramid` object: the figures with `error` null, or `error` alone.
impl Serialize for PyramidSummary {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Axis {
            t0_ps: f64,
            dt_ps: f64,
            nt: usize,
        }
        #[derive(Serialize)]
        struct Readable<'a> {
            levels: usize,
            level_nt: Vec<usize>,
            prefix: &'a PrefixLayout,
            time_axis: Axis,
            time_frame: &'static str,
            source: &'a str,
            matches_cube: Option<bool>,
            error: Option<&'a str>,
        }
        #[derive(Serialize)]
        struct Unreadable<'a> {
            error: &'a str,
        }
        match self {
            PyramidSummary::Readable {
                info,
                prefix,
                matches_cube,
            } => {
                let TimeAxis { t0_ps, dt_ps, nt } = info.axis;
                Readable {
                    levels: info.levels,
                    level_nt: info.level_nts(),
                    prefix,
                    time_axis: Axis { t0_ps, dt_ps, nt },
                    time_frame: info.frame.as_str(),
                    source: &info.source,
                    matches_cube: *matches_cube,
                    error: None,
                }
                .serialize(s)
            }
            PyramidSummary::Unreadable { error } => Unreadable { error }.serialize(s),
        }
    }
}

/// The `pyramid` line's value.
impl fmt::Display for PyramidSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (info, prefix, matches_cube) = match self {
            PyramidSummary::Unreadable { error } => return write!(f, "unreadable: {error}"),
            PyramidSummary::Readable {
                info,
                prefix,
                matches_cube,
            } => (info, prefix, matches_cube),
        };
        let prefix = match prefix {
            PrefixLayout::F64 { shape } => {
                format!("{} (f64, an older femto's layout)", json_text(shape))
            }
            PrefixLayout::TwoLevel {
                coarse_shape,
                fine_shape,
            } => format!(
                "{} (f32 within blocks of 8 bins, f64 {} at their starts)",
                json_text(fine_shape),
                json_text(coarse_shape)
            ),
        };
        write!(
            f,
            "prefix sums {prefix}, {} mip level(s) with {} samples per pixel; built from {}",
            info.levels,
            json_text(&info.level_nts()),
            info.source
        )?;
        if *matches_cube == Some(false) {
            write!(f, " (STALE: the cube's shape or time axis has changed)")?;
        }
        Ok(())
    }
}

impl fmt::Display for SideFileDescription {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        line(f, "file", self.file.display())?;
        line(f, "kind", "femto pyramid side file (HDF5, no cube)")?;
        line(f, "pyramid", &self.pyramid)
    }
}

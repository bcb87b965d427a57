//! The `[Scaling]` section of an HPD-TA header: how each file axis is calibrated
//! ([`AxisScaling`]), the float32 tables it points at inside the file, cropped to the rows or
//! columns the image holds (`[Acquisition] areSource`), and the reversal that makes every
//! calibrated axis increase with the index.
//!
//! `Scaling?ScalingFile="#offset,count"` names `count` float32 little-endian values at byte
//! `offset` of the file (of the `.img` file, or of the TIFF whose ImageDescription holds the
//! header). The table covers the grabbed area; when it is longer than the image, `areSource
//! ="x,y,width,height"` says which part the image holds: the X table is cropped to
//! `x..x + width`, the Y table to `y..y + height` (an HPD-TA TIFF of 1008 rows holds rows
//! 4..1011 of a 1016-entry table). A `ScalingFile` that names another file (or none) leaves
//! the axis without a table in this file ([`AxisScaling::External`]).

use super::FormatError;
use crate::formats::FileRegions;
use std::collections::BTreeMap;
use std::path::Path;

/// The keys of `[Scaling]`, per axis (`Scaling{X,Y}` + suffix).
pub(super) const SCALING_KEYS: [&str; 4] = ["Type", "Scale", "Unit", "ScalingFile"];

/// How one file axis is scaled (`[Scaling]`, as stored, before any reversal).
#[derive(Clone, Debug, PartialEq)]
pub enum AxisScaling {
    /// No calibration: sensor pixels (no `[Scaling]` entry, or type 1 without a unit).
    Pixels,
    /// Type 1 with a unit: value of pixel `i` is `scale * i` (HPD-TA records no offset).
    Linear { scale: f64, unit: String },
    /// Type 2: one float32 value per pixel, in file order and file unit: entries
    /// `first_entry..first_entry + values.len()` of the `table_len` at `byte_offset`.
    Table {
        unit: String,
        byte_offset: u64,
        table_len: usize,
        first_entry: usize,
        values: Vec<f64>,
    },
    /// Type 2 whose `ScalingFile` is not a table inside this file: the name of another file
    /// (`file`), or no `ScalingFile` at all (`None`). The axis is not calibrated here.
    External { unit: String, file: Option<String> },
}

/// Picoseconds per unit for the time units HPD-TA writes (`None` if unknown).
pub fn time_unit_to_ps(unit: &str) -> Option<f64> {
    match unit.trim() {
        "fs" => Some(1e-3),
        "ps" => Some(1.0),
        "ns" => Some(1e3),
        "us" | "\u{b5}s" | "\u{3bc}s" => Some(1e6),
        "ms" => Some(1e9),
        "s" => Some(1e12),
        _ => None,
    }
}

/// Whether `unit` is one HPD-TA writes for an axis that is not time: none, sensor pixels or a
/// length (a spectrograph's wavelength, a position). Such a time axis is not calibrated; any
/// other unknown unit is an error.
pub fn is_non_time_unit(unit: &str) -> bool {
    matches!(
        unit.trim().to_lowercase().as_str(),
        "" | "px"
            | "pixel"
            | "pixels"
            | "pm"
            | "nm"
            | "um"
            | "\u{b5}m"
            | "\u{3bc}m"
            | "mm"
            | "cm"
            | "m"
    )
}

/// `[Acquisition] areSource="x,y,width,height"`: the part of the grabbed area the image
/// holds, or `None` without the key.
fn area_source(
    path: &Path,
    sections: &BTreeMap<String, BTreeMap<String, String>>,
) -> Result<Option<[usize; 4]>, FormatError> {
    let Some(raw) = sections.get("Acquisition").and_then(|s| s.get("areSource")) else {
        return Ok(None);
    };
    let numbers: Vec<usize> = raw
        .split(',')
        .map(|v| v.trim().parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad_area(path, raw))?;
    let area: [usize; 4] = numbers.try_into().map_err(|_| bad_area(path, raw))?;
    Ok(Some(area))
}

fn bad_area(path: &Path, raw: &str) -> FormatError {
    FormatError::BadValue {
        path: path.to_path_buf(),
        section: "Acquisition".into(),
        key: "areSource".into(),
        value: raw.to_string(),
        expected: "four non-negative integers \"x,y,width,height\"".into(),
    }
}

/// Read the scaling of one axis (`axis` is 'X' or 'Y', `len` its pixel count); tables are
/// read from `file` at the offset the header gives, once their extent is known to lie in it
/// (checked arithmetic: an offset or count near 2^64 is refused, never wrapped).
pub(super) fn parse_axis_scaling(
    path: &Path,
    sections: &BTreeMap<String, BTreeMap<String, String>>,
    axis: char,
    len: usize,
    file: &FileRegions,
) -> Result<AxisScaling, FormatError> {
    let Some(scaling) = sections.get("Scaling") else {
        return Ok(AxisScaling::Pixels);
    };
    let key = |suffix: &str| format!("Scaling{axis}{suffix}");
    let get = |suffix: &str| scaling.get(&key(suffix)).map(|v| v.trim());
    let bad = |suffix: &str, value: &str, expected: &str| FormatError::BadValue {
        path: path.to_path_buf(),
        section: "Scaling".into(),
        key: key(suffix),
        value: value.to_string(),
        expected: expected.to_string(),
    };
    let Some(kind) = get("Type") else {
        if ["Scale", "Unit", "ScalingFile"]
            .iter()
            .any(|s| get(s).is_some())
        {
            return Err(bad(
                "Type",
                "",
                "missing while other Scaling entries are present",
            ));
        }
        return Ok(AxisScaling::Pixels);
    };
    let unit = get("Unit").unwrap_or("").to_string();
    match kind {
        "1" => {
            if unit.is_empty() || ["px", "pixel", "pixels"].contains(&unit.to_lowercase().as_str())
            {
                return Ok(AxisScaling::Pixels);
            }
            let raw = get("Scale").ok_or_else(|| bad("Scale", "", "missing for linear scaling"))?;
            let scale: f64 = raw
                .parse()
                .ok()
                .filter(|s: &f64| s.is_finite() && *s != 0.0)
                .ok_or_else(|| bad("Scale", raw, "a finite non-zero number"))?;
            Ok(AxisScaling::Linear { scale, unit })
        }
        "2" => {
            let Some(raw) = get("ScalingFile") else {
                return Ok(AxisScaling::External { unit, file: None });
            };
            let Some(address) = raw.strip_prefix('#') else {
                return Ok(AxisScaling::External {
                    unit,
                    file: Some(raw.to_string()),
                });
            };
            let expected = "\"#offset,count\" (a table inside this file)";
            let (offset_s, count_s) = address
                .split_once(',')
                .ok_or_else(|| bad("ScalingFile", raw, expected))?;
            let byte_offset: u64 = offset_s
                .trim()
                .parse()
                .map_err(|_| bad("ScalingFile", raw, expected))?;
            let table_len: usize = count_s
                .trim()
                .parse()
                .map_err(|_| bad("ScalingFile", raw, expected))?;
            let first_entry = table_part(path, sections, axis, len, table_len)?;
            let table = TablePlace {
                axis,
                raw,
                byte_offset,
                table_len,
                first_entry,
            };
            let values = read_table(path, file, &table, len)?;
            Ok(AxisScaling::Table {
                unit,
                byte_offset,
                table_len,
                first_entry,
                values,
            })
        }
        other => Err(FormatError::UnknownScalingType {
            path: path.to_path_buf(),
            axis,
            value: other.to_string(),
        }),
    }
}

/// Where a `[Scaling]` table lies: the axis, the `ScalingFile` value as written, the byte
/// offset and length (entries) it gives, and the first entry the image holds.
struct TablePlace<'a> {
    axis: char,
    raw: &'a str,
    byte_offset: u64,
    table_len: usize,
    first_entry: usize,
}

/// The `len` entries of a table the image holds, read from `file` once the table's extent is
/// known to lie in it (in u128: no offset or count of the header can wrap), checked finite.
fn read_table(
    path: &Path,
    file: &FileRegions,
    t: &TablePlace,
    len: usize,
) -> Result<Vec<f64>, FormatError> {
    let key = format!("Scaling{}ScalingFile", t.axis);
    let bad = |expected: String| FormatError::BadValue {
        path: path.to_path_buf(),
        section: "Scaling".into(),
        key: key.clone(),
        value: t.raw.to_string(),
        expected,
    };
    let (byte_offset, table_len) = (t.byte_offset, t.table_len);
    let end = u128::from(byte_offset) + 4 * table_len as u128;
    if end > u128::from(u64::MAX) {
        return Err(bad(format!(
            "a table inside this file ({table_len} float32 at byte {byte_offset} would end at \
             byte {end}, past 2^64)"
        )));
    }
    if end > u128::from(file.len) {
        return Err(FormatError::Truncated {
            path: path.to_path_buf(),
            what: format!(
                "the {} axis table of [Scaling] {key}=\"{}\" ({table_len} float32 at byte \
                 {byte_offset})",
                t.axis, t.raw
            ),
            needed: end as u64,
            available: file.len,
        });
    }
    // Inside the file, so below 2^64: `first_entry + len <= table_len` (table_part).
    let start = byte_offset + 4 * t.first_entry as u64;
    let table_bytes = file
        .read(start, 4 * len)
        .map_err(|source| FormatError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    let values: Vec<f64> = table_bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")) as f64)
        .collect();
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(bad(format!(
            "a table of finite numbers (entry {} is {})",
            t.first_entry + i,
            values[i]
        )));
    }
    Ok(values)
}

/// The first table entry of an axis `len` pixels long whose table has `table_len` entries:
/// 0 when they agree, else the offset `areSource` gives when its size is `len` and the part
/// lies inside the table; anything else is a size mismatch naming the key.
fn table_part(
    path: &Path,
    sections: &BTreeMap<String, BTreeMap<String, String>>,
    axis: char,
    len: usize,
    table_len: usize,
) -> Result<usize, FormatError> {
    if table_len == len {
        return Ok(0);
    }
    let mismatch = |what: String| FormatError::SizeMismatch {
        path: path.to_path_buf(),
        what,
        expected: len,
        found: table_len,
    };
    let key = format!("[Scaling] Scaling{axis}ScalingFile");
    let Some(area) = area_source(path, sections)? else {
        return Err(mismatch(format!(
            "{axis} axis table length ({key}; no [Acquisition] areSource says which part the \
             image holds)"
        )));
    };
    let (offset, size) = if axis == 'X' {
        (area[0], area[2])
    } else {
        (area[1], area[3])
    };
    // In u128: an areSource offset of 2^64 - 1 must not wrap past the table's length.
    let part_end = offset as u128 + size as u128;
    if size != len || part_end > table_len as u128 {
        return Err(mismatch(format!(
            "{axis} axis table length ({key}; [Acquisition] areSource=\"{},{},{},{}\" gives \
             entries {offset}..{part_end} of it)",
            area[0], area[1], area[2], area[3],
        )));
    }
    Ok(offset)
}

/// Per-pixel values of an axis (file order), or `None` when uncalibrated.
pub(super) fn axis_values(scaling: &AxisScaling, len: usize) -> Option<(Vec<f64>, String)> {
    match scaling {
        AxisScaling::Pixels | AxisScaling::External { .. } => None,
        AxisScaling::Linear { scale, unit } => {
            Some(((0..len).map(|i| scale * i as f64).collect(), unit.clone()))
        }
        AxisScaling::Table { unit, values, .. } => Some((values.clone(), unit.clone())),
    }
}

/// +1 for strictly increasing, -1 for strictly decreasing; else the first offending index.
fn direction(values: &[f64]) -> Result<i8, usize> {
    if values.len() < 2 {
        return Ok(1);
    }
    let dir = if values[1] > values[0] {
        1
    } else if values[1] < values[0] {
        -1
    } else {
        return Err(1);
    };
    for i in 1..values.len() {
        let ok = if dir > 0 {
            values[i] > values[i - 1]
        } else {
            values[i] < values[i - 1]
        };
        if !ok {
            return Err(i);
        }
    }
    Ok(dir)
}

/// Reverse a decreasing X table (and the columns of `data`, `w` wide) or Y table (and its
/// rows) so that every calibrated axis increases with the index; returns whether the
/// columns and the rows were reversed. A table that is not monotonic is an error.
pub(super) fn make_axes_increase(
    path: &Path,
    data: &mut Vec<f32>,
    w: usize,
    x_vals: &mut Option<(Vec<f64>, String)>,
    y_vals: &mut Option<(Vec<f64>, String)>,
) -> Result<(bool, bool), FormatError> {
    let mut columns_reversed = false;
    let mut rows_reversed = false;
    if let Some((v, _)) = x_vals.as_mut() {
        match direction(v) {
            Ok(1) => {}
            Ok(_) => {
                v.reverse();
                data.chunks_exact_mut(w).for_each(|row| row.reverse());
                columns_reversed = true;
            }
            Err(index) => {
                return Err(FormatError::NonMonotonicAxis {
                    path: path.to_path_buf(),
                    axis: 'X',
                    index,
                })
            }
        }
    }
    if let Some((v, _)) = y_vals.as_mut() {
        match direction(v) {
            Ok(1) => {}
            Ok(_) => {
                v.reverse();
                let flipped: Vec<f32> = data.chunks_exact(w).rev().flatten().copied().collect();
                *data = flipped;
                rows_reversed = true;
            }
            Err(index) => {
                return Err(FormatError::NonMonotonicAxis {
                    path: path.to_path_buf(),
                    axis: 'Y',
                    index,
                })
            }
        }
    }
    Ok((columns_reversed, rows_reversed))
}

/// Refuse a key of the comment's `[Scaling]` section that is not one of [`SCALING_KEYS`] for
/// the X or Y axis.
pub(super) fn check_scaling_keys(
    path: &Path,
    sections: &BTreeMap<String, BTreeMap<String, String>>,
) -> Result<(), FormatError> {
    if let Some(scaling) = sections.get("Scaling") {
        for key in scaling.keys() {
            let known = ['X', 'Y'].iter().any(|a| {
                SCALING_KEYS
                    .iter()
                    .any(|s| *key == format!("Scaling{a}{s}"))
            });
            if !known {
                return Err(FormatError::UnknownKey {
                    path: path.to_path_buf(),
                    section: "Scaling".into(),
                    key: key.clone(),
                });
            }
        }
    }
    Ok(())
}

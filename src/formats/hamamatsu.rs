//! Hamamatsu HPD-TA `.img` streak images: reader with typed metadata, and a writer.
//!
//! Container (little-endian), as HPD-TA 9.x writes it:
//!
//! | offset | type     | field                                              |
//! |--------|----------|----------------------------------------------------|
//! | 0      | 2 bytes  | `"IM"`                                             |
//! | 2      | int16    | comment length in bytes                            |
//! | 4      | int16    | width (columns, x)                                 |
//! | 6      | int16    | height (rows, time)                                |
//! | 8, 10  | int16    | x and y offset of the region on the sensor         |
//! | 12     | int16    | file type: 0 = 8-bit, 1 = compressed, 2 = 16-bit, 3 = 32-bit |
//! | 14     | int32    | number of images                                   |
//! | 18     | int16    | number of additional channels                      |
//! | 20     | int16    | channel number                                     |
//! | 22     | float64  | time stamp                                         |
//! | 30     | 4 bytes  | marker                                             |
//! | 34     | 30 bytes | additional information                             |
//!
//! Then the comment, then `width x height` unsigned pixels row by row (row = one time line),
//! then optional float32 axis tables. The comment is `[Section],Key=Value,Key="quoted, with
//! commas"` text; sections follow one another on new lines or directly after a value. The
//! `[Scaling]` section gives each axis a type: 1 = linear (`Scaling?Scale` per pixel in
//! `Scaling?Unit`; with no unit, as in Focus mode where the sweep is off, the axis is
//! uncalibrated sensor pixels and the recorded scale is not applied), 2 = a table of float32
//! values at the byte offset and count given as `Scaling?ScalingFile="#offset,count"`.
//!
//! Axis conventions of the reader: every calibrated axis of the returned image increases
//! with the index. HPD-TA stores spectrograph images with the wavelength decreasing from left
//! to right; a strictly decreasing table is therefore reversed together with the image
//! columns (or rows), and [`ImgMeta::columns_reversed`] / [`ImgMeta::rows_reversed`] say so.
//! The time axis is converted to picoseconds (fs, ps, ns, us/µs, ms, s). A scaling type, a
//! `[Scaling]` key, a file type or a time unit that the reader does not know is an error,
//! never a guess.
//!
//! Writer ([`write_img`]): 16- or 32-bit unsigned, a comment with `[Application]`,
//! `[Acquisition]`, `[Streak camera]` (`Time Range`, `Mode="Operate"`) and `[Scaling]` with
//! an uncalibrated X axis and `ScalingYType=2`, the per-row times in ps stored as a float32
//! table after the pixels. Values are rounded to the nearest integer (half away from zero)
//! and clamped to `0..=2^bits - 1`; the number clamped at the top is returned.

use super::{write_file_atomically, AxisTable, FormatError, PixelType, StreakImage};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Length of the fixed header.
pub const HEADER_LEN: usize = 64;

/// Sample storage of an HPD-TA file (the header's file type; 1 = compressed is refused).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImgFileType {
    /// File type 0: 8-bit unsigned.
    U8,
    /// File type 2: 16-bit unsigned.
    U16,
    /// File type 3: 32-bit unsigned.
    U32,
}

impl ImgFileType {
    /// The header's type code.
    pub fn code(self) -> i16 {
        match self {
            ImgFileType::U8 => 0,
            ImgFileType::U16 => 2,
            ImgFileType::U32 => 3,
        }
    }

    /// Bytes per pixel.
    pub fn bytes(self) -> usize {
        match self {
            ImgFileType::U8 => 1,
            ImgFileType::U16 => 2,
            ImgFileType::U32 => 4,
        }
    }

    fn pixel_type(self) -> PixelType {
        match self {
            ImgFileType::U8 => PixelType::U8,
            ImgFileType::U16 => PixelType::U16,
            ImgFileType::U32 => PixelType::U32,
        }
    }
}

/// The 64-byte header, decoded.
#[derive(Clone, Debug, PartialEq)]
pub struct ImgHeader {
    /// Comment length in bytes.
    pub comment_len: usize,
    /// Columns stored in the file.
    pub width: usize,
    /// Rows stored in the file.
    pub height: usize,
    /// Horizontal offset of the region on the sensor, pixels.
    pub x_offset: i16,
    /// Vertical offset of the region on the sensor, pixels.
    pub y_offset: i16,
    /// Sample storage.
    pub file_type: ImgFileType,
    /// Number of images (0 or 1 in single-image files).
    pub num_images: i32,
    /// Number of additional channels (0 in single-image files).
    pub additional_channels: i16,
    /// Channel number.
    pub channel_number: i16,
    /// Time stamp as stored (HPD-TA writes 0).
    pub timestamp: f64,
}

/// How one file axis is scaled (`[Scaling]`, as stored, before any reversal).
#[derive(Clone, Debug, PartialEq)]
pub enum AxisScaling {
    /// No calibration: sensor pixels (no `[Scaling]` entry, or type 1 without a unit).
    Pixels,
    /// Type 1 with a unit: value of pixel `i` is `scale * i` (HPD-TA records no offset).
    Linear { scale: f64, unit: String },
    /// Type 2: one float32 value per pixel at `byte_offset`, in file order and file unit.
    Table {
        unit: String,
        byte_offset: u64,
        values: Vec<f64>,
    },
}

/// Everything an `.img` file says besides its pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct ImgMeta {
    /// The fixed header.
    pub header: ImgHeader,
    /// The comment text as stored (NUL padding removed).
    pub comment: String,
    /// The comment parsed: section name -> key -> value (quotes removed).
    pub sections: BTreeMap<String, BTreeMap<String, String>>,
    /// Scaling of the file's columns.
    pub scaling_x: AxisScaling,
    /// Scaling of the file's rows.
    pub scaling_y: AxisScaling,
    /// The columns were reversed so that the X table increases.
    pub columns_reversed: bool,
    /// The rows were reversed so that the Y table increases.
    pub rows_reversed: bool,
    /// `[Streak camera] Mode` (`Operate`, `Focus`).
    pub mode: Option<String>,
    /// `[Streak camera] Time Range` (the sweep window), picoseconds.
    pub time_range_ps: Option<f64>,
    /// `[Streak camera] MCP Gain`.
    pub mcp_gain: Option<f64>,
    /// `[Acquisition] NrExposure`: exposures summed into the image.
    pub n_exposures: Option<u32>,
    /// `[Acquisition] ExposureTime` of one exposure, seconds.
    pub exposure_time_s: Option<f64>,
    /// `n_exposures * exposure_time_s`: total integration time, seconds.
    pub total_exposure_s: Option<f64>,
}

impl ImgMeta {
    /// A comment value by section and key.
    pub fn get(&self, section: &str, key: &str) -> Option<&str> {
        self.sections
            .get(section)
            .and_then(|s| s.get(key))
            .map(String::as_str)
    }
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

/// Parse a `[Section],Key=Value,...` comment into section -> key -> value.
///
/// Values may be quoted (`Key="a, b"`: the quotes are removed, commas inside are kept) or
/// bare (ending at a comma, a line break or the next `[`). Errors give the byte offset.
pub fn parse_comment(
    text: &str,
) -> Result<BTreeMap<String, BTreeMap<String, String>>, (usize, String)> {
    let bytes = text.as_bytes();
    let n = bytes.len();
    let is_sep = |b: u8| matches!(b, b',' | b'\r' | b'\n' | b' ' | b'\t' | 0);
    let mut sections: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
    let mut current: Option<String> = None;
    let mut pos = 0;
    loop {
        while pos < n && is_sep(bytes[pos]) {
            pos += 1;
        }
        if pos >= n {
            break;
        }
        if bytes[pos] == b'[' {
            let close = text[pos..]
                .find(']')
                .map(|i| pos + i)
                .ok_or((pos, "section name without closing ']'".to_string()))?;
            let name = &text[pos + 1..close];
            if name.is_empty() || name.contains(['\r', '\n', '[']) {
                return Err((pos, format!("bad section name {name:?}")));
            }
            sections.entry(name.to_string()).or_default();
            current = Some(name.to_string());
            pos = close + 1;
            continue;
        }
        let Some(section) = current.as_ref() else {
            return Err((pos, "text before the first [Section]".to_string()));
        };
        // Key: up to '='; a separator or '[' first means the entry has no '='.
        let key_start = pos;
        while pos < n && bytes[pos] != b'=' {
            if matches!(bytes[pos], b',' | b'\r' | b'\n' | b'[' | b'"') {
                return Err((
                    key_start,
                    format!("entry {:?} has no '='", &text[key_start..pos]),
                ));
            }
            pos += 1;
        }
        if pos >= n {
            return Err((
                key_start,
                format!("entry {:?} has no '='", &text[key_start..]),
            ));
        }
        let key = text[key_start..pos].trim();
        if key.is_empty() {
            return Err((key_start, "empty key".to_string()));
        }
        pos += 1; // '='
        let value;
        if pos < n && bytes[pos] == b'"' {
            let close = text[pos + 1..]
                .find('"')
                .map(|i| pos + 1 + i)
                .ok_or((pos, format!("unterminated quoted value of {key:?}")))?;
            value = &text[pos + 1..close];
            pos = close + 1;
            if pos < n && !is_sep(bytes[pos]) && bytes[pos] != b'[' {
                return Err((pos, format!("text after the quoted value of {key:?}")));
            }
        } else {
            let start = pos;
            while pos < n && !matches!(bytes[pos], b',' | b'\r' | b'\n' | b'[' | 0) {
                pos += 1;
            }
            value = text[start..pos].trim_end();
        }
        let entries = sections.get_mut(section).expect("section was inserted");
        if entries.contains_key(key) {
            return Err((key_start, format!("duplicate key {key:?} in [{section}]")));
        }
        entries.insert(key.to_string(), value.to_string());
    }
    Ok(sections)
}

fn le_i16(b: &[u8], at: usize) -> i16 {
    i16::from_le_bytes([b[at], b[at + 1]])
}

fn le_i32(b: &[u8], at: usize) -> i32 {
    i32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}

/// Decode the 64-byte header (`bytes` is the whole file).
fn parse_header(path: &Path, bytes: &[u8]) -> Result<ImgHeader, FormatError> {
    let truncated = |what: &str, needed: usize| FormatError::Truncated {
        path: path.to_path_buf(),
        what: what.to_string(),
        needed: needed as u64,
        available: bytes.len() as u64,
    };
    if bytes.len() >= 2 && &bytes[0..2] != b"IM" {
        return Err(FormatError::BadMagic {
            path: path.to_path_buf(),
            message: format!(
                "not a Hamamatsu HPD-TA image (starts with {:02x?}, expected \"IM\")",
                &bytes[0..2]
            ),
        });
    }
    if bytes.len() < HEADER_LEN {
        return Err(truncated("the 64-byte header", HEADER_LEN));
    }
    let non_negative = |field: &str, v: i16| -> Result<usize, FormatError> {
        usize::try_from(v).map_err(|_| FormatError::BadValue {
            path: path.to_path_buf(),
            section: "header".into(),
            key: field.into(),
            value: v.to_string(),
            expected: "a non-negative int16".into(),
        })
    };
    let comment_len = non_negative("comment length", le_i16(bytes, 2))?;
    let width = non_negative("width", le_i16(bytes, 4))?;
    let height = non_negative("height", le_i16(bytes, 6))?;
    let file_type = match le_i16(bytes, 12) {
        0 => ImgFileType::U8,
        2 => ImgFileType::U16,
        3 => ImgFileType::U32,
        1 => {
            return Err(FormatError::CompressedImg {
                path: path.to_path_buf(),
            })
        }
        code => {
            return Err(FormatError::UnknownImgFileType {
                path: path.to_path_buf(),
                code,
            })
        }
    };
    let header = ImgHeader {
        comment_len,
        width,
        height,
        x_offset: le_i16(bytes, 8),
        y_offset: le_i16(bytes, 10),
        file_type,
        num_images: le_i32(bytes, 14),
        additional_channels: le_i16(bytes, 18),
        channel_number: le_i16(bytes, 20),
        timestamp: f64::from_le_bytes(bytes[22..30].try_into().expect("8 bytes")),
    };
    if header.num_images < 0 {
        return Err(FormatError::BadValue {
            path: path.to_path_buf(),
            section: "header".into(),
            key: "number of images".into(),
            value: header.num_images.to_string(),
            expected: "0 or 1 (a single image)".into(),
        });
    }
    if header.num_images > 1 {
        return Err(FormatError::Unsupported {
            path: path.to_path_buf(),
            what: format!(
                "{} images in one HPD-TA file (only single images are read)",
                header.num_images
            ),
        });
    }
    if header.additional_channels != 0 {
        return Err(FormatError::Unsupported {
            path: path.to_path_buf(),
            what: format!(
                "{} additional channels in an HPD-TA file (only single-channel files are read)",
                header.additional_channels
            ),
        });
    }
    if width == 0 || height == 0 {
        return Err(FormatError::BadValue {
            path: path.to_path_buf(),
            section: "header".into(),
            key: "width x height".into(),
            value: format!("{width} x {height}"),
            expected: "a non-empty image".into(),
        });
    }
    Ok(header)
}

/// Decode the comment bytes: UTF-8 when valid (HPD-TA 9 writes `Enconding=UTF-8`), else
/// Latin-1 (older files, where `µ` is the byte 0xB5). Trailing NUL padding is removed.
fn decode_comment(raw: &[u8]) -> String {
    let trimmed = match raw.iter().rposition(|&b| b != 0) {
        Some(last) => &raw[..=last],
        None => &[],
    };
    match std::str::from_utf8(trimmed) {
        Ok(s) => s.to_string(),
        Err(_) => trimmed.iter().map(|&b| b as char).collect(),
    }
}

/// Read the scaling of one axis (`axis` is 'X' or 'Y', `len` its pixel count).
fn parse_axis_scaling(
    path: &Path,
    sections: &BTreeMap<String, BTreeMap<String, String>>,
    axis: char,
    len: usize,
    bytes: &[u8],
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
            let raw = get("ScalingFile")
                .ok_or_else(|| bad("ScalingFile", "", "missing for table scaling"))?;
            let expected = "\"#offset,count\" (a table inside this file)";
            let (offset_s, count_s) = raw
                .strip_prefix('#')
                .and_then(|r| r.split_once(','))
                .ok_or_else(|| bad("ScalingFile", raw, expected))?;
            let byte_offset: u64 = offset_s
                .trim()
                .parse()
                .map_err(|_| bad("ScalingFile", raw, expected))?;
            let count: usize = count_s
                .trim()
                .parse()
                .map_err(|_| bad("ScalingFile", raw, expected))?;
            if count != len {
                return Err(FormatError::SizeMismatch {
                    path: path.to_path_buf(),
                    what: format!("{axis} axis table length (Scaling{axis}ScalingFile)"),
                    expected: len,
                    found: count,
                });
            }
            let end = byte_offset.saturating_add(4 * count as u64);
            if end > bytes.len() as u64 {
                return Err(FormatError::Truncated {
                    path: path.to_path_buf(),
                    what: format!("the {axis} axis table at byte {byte_offset}"),
                    needed: end,
                    available: bytes.len() as u64,
                });
            }
            let start = byte_offset as usize;
            let values: Vec<f64> = bytes[start..start + 4 * count]
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")) as f64)
                .collect();
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                return Err(bad(
                    "ScalingFile",
                    raw,
                    &format!("a table of finite numbers (value {i} is {})", values[i]),
                ));
            }
            Ok(AxisScaling::Table {
                unit,
                byte_offset,
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

/// Per-pixel values of an axis (file order), or `None` when uncalibrated.
fn axis_values(scaling: &AxisScaling, len: usize) -> Option<(Vec<f64>, String)> {
    match scaling {
        AxisScaling::Pixels => None,
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

fn parse_time_value(
    path: &Path,
    section: &str,
    key: &str,
    value: &str,
) -> Result<f64, FormatError> {
    let bad = || FormatError::BadValue {
        path: path.to_path_buf(),
        section: section.into(),
        key: key.into(),
        value: value.into(),
        expected: "a finite number and a time unit, e.g. \"20 us\"".into(),
    };
    let mut parts = value.split_whitespace();
    let (Some(number), Some(unit), None) = (parts.next(), parts.next(), parts.next()) else {
        return Err(bad());
    };
    let number: f64 = number.parse().map_err(|_| bad())?;
    let per = time_unit_to_ps(unit).ok_or_else(|| FormatError::UnknownUnit {
        path: path.to_path_buf(),
        what: format!("[{section}] {key}"),
        unit: unit.to_string(),
    })?;
    let ps = number * per;
    if !ps.is_finite() {
        return Err(bad());
    }
    Ok(ps)
}

fn parse_number<T: std::str::FromStr>(
    path: &Path,
    section: &str,
    key: &str,
    value: &str,
    expected: &str,
) -> Result<T, FormatError> {
    value.trim().parse().map_err(|_| FormatError::BadValue {
        path: path.to_path_buf(),
        section: section.into(),
        key: key.into(),
        value: value.into(),
        expected: expected.into(),
    })
}

const SCALING_KEYS: [&str; 4] = ["Type", "Scale", "Unit", "ScalingFile"];

/// Read an HPD-TA `.img` file (see the module doc for the layout and the axis rules).
pub fn read_img(path: &Path, transpose: bool) -> Result<StreakImage, FormatError> {
    let bytes = std::fs::read(path).map_err(|source| FormatError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let header = parse_header(path, &bytes)?;
    let comment_end = HEADER_LEN + header.comment_len;
    if bytes.len() < comment_end {
        return Err(FormatError::Truncated {
            path: path.to_path_buf(),
            what: format!("the {}-byte comment", header.comment_len),
            needed: comment_end as u64,
            available: bytes.len() as u64,
        });
    }
    let (w, h) = (header.width, header.height);
    let data_end = comment_end + w * h * header.file_type.bytes();
    if bytes.len() < data_end {
        return Err(FormatError::Truncated {
            path: path.to_path_buf(),
            what: format!(
                "{w} x {h} pixels of {} bytes after the comment",
                header.file_type.bytes()
            ),
            needed: data_end as u64,
            available: bytes.len() as u64,
        });
    }
    let comment = decode_comment(&bytes[HEADER_LEN..comment_end]);
    let sections =
        parse_comment(&comment).map_err(|(offset, message)| FormatError::BadComment {
            path: path.to_path_buf(),
            offset,
            message,
        })?;
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
    let scaling_x = parse_axis_scaling(path, &sections, 'X', w, &bytes)?;
    let scaling_y = parse_axis_scaling(path, &sections, 'Y', h, &bytes)?;

    let pixels = &bytes[comment_end..data_end];
    let mut data: Vec<f32> = match header.file_type {
        ImgFileType::U8 => pixels.iter().map(|&v| v as f32).collect(),
        ImgFileType::U16 => pixels
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]) as f32)
            .collect(),
        ImgFileType::U32 => pixels
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")) as f32)
            .collect(),
    };

    // Make every calibrated axis increase with the index.
    let mut x_vals = axis_values(&scaling_x, w);
    let mut y_vals = axis_values(&scaling_y, h);
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
                data = flipped;
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

    // Assign roles: rows are time unless transposed.
    let (time_vals, time_axis_name, space_vals, nx, nt) = if transpose {
        data = super::transpose_rows(&data, w, h);
        (x_vals, 'X', y_vals, h, w)
    } else {
        (y_vals, 'Y', x_vals, w, h)
    };
    let time_axis_ps = match time_vals {
        None => None,
        Some((values, unit)) => {
            let per = time_unit_to_ps(&unit).ok_or_else(|| FormatError::UnknownUnit {
                path: path.to_path_buf(),
                what: format!("the time axis (Scaling{time_axis_name}Unit)"),
                unit: unit.clone(),
            })?;
            Some(values.iter().map(|v| v * per).collect())
        }
    };
    let x_axis = space_vals.map(|(values, unit)| AxisTable { values, unit });

    let streak = sections.get("Streak camera");
    let acquisition = sections.get("Acquisition");
    let mode = streak.and_then(|s| s.get("Mode")).cloned();
    let time_range_ps = streak
        .and_then(|s| s.get("Time Range"))
        .map(|v| parse_time_value(path, "Streak camera", "Time Range", v))
        .transpose()?;
    let mcp_gain = streak
        .and_then(|s| s.get("MCP Gain"))
        .map(|v| parse_number::<f64>(path, "Streak camera", "MCP Gain", v, "a finite number"))
        .transpose()?
        .map(|g| {
            g.is_finite()
                .then_some(g)
                .ok_or_else(|| FormatError::BadValue {
                    path: path.to_path_buf(),
                    section: "Streak camera".into(),
                    key: "MCP Gain".into(),
                    value: g.to_string(),
                    expected: "a finite number".into(),
                })
        })
        .transpose()?;
    let n_exposures = acquisition
        .and_then(|s| s.get("NrExposure"))
        .map(|v| {
            parse_number::<u32>(
                path,
                "Acquisition",
                "NrExposure",
                v,
                "a non-negative integer",
            )
        })
        .transpose()?;
    let exposure_time_s = acquisition
        .and_then(|s| s.get("ExposureTime"))
        .map(|v| parse_time_value(path, "Acquisition", "ExposureTime", v).map(|ps| ps * 1e-12))
        .transpose()?;
    let total_exposure_s = match (n_exposures, exposure_time_s) {
        (Some(n), Some(t)) => Some(n as f64 * t),
        _ => None,
    };

    Ok(StreakImage {
        nx,
        nt,
        data,
        pixel_type: header.file_type.pixel_type(),
        time_axis_ps,
        x_axis,
        img_meta: Some(ImgMeta {
            header,
            comment,
            sections,
            scaling_x,
            scaling_y,
            columns_reversed,
            rows_reversed,
            mode,
            time_range_ps,
            mcp_gain,
            n_exposures,
            exposure_time_s,
            total_exposure_s,
        }),
    })
}

/// A duration in the largest of ps, ns, us that keeps the number at least 1, with six
/// significant digits (`"1.9 ns"`, `"640 ps"`).
fn format_time_range(span_ps: f64) -> String {
    let (value, unit) = if span_ps.abs() >= 1e6 {
        (span_ps / 1e6, "us")
    } else if span_ps.abs() >= 1e3 {
        (span_ps / 1e3, "ns")
    } else {
        (span_ps, "ps")
    };
    let rounded: f64 = format!("{value:.5e}")
        .parse()
        .expect("formatted float parses");
    format!("{rounded} {unit}")
}

/// The comment [`write_img`] stores, for a table at `table_offset`.
fn writer_comment(
    bytes_per_pixel: usize,
    nt: usize,
    time_range: &str,
    table_offset: usize,
) -> String {
    format!(
        "[Application],Software=\"femto\",SoftwareVersion=\"{version}\",\
         ApplicationTitle=\"femto streak-camera simulator\"\r\n\
         [Acquisition],BytesPerPixel={bytes_per_pixel},IsLineData=0,ZAxisLabel=Intensity,ZAxisUnit=Count\r\n\
         [Streak camera],Time Range=\"{time_range}\",Mode=\"Operate\"\r\n\
         [Scaling],ScalingXType=1,ScalingXScale=1,ScalingXUnit=\"\",ScalingXScalingFile=\"\",\
         ScalingYType=2,ScalingYScale=1,ScalingYUnit=\"ps\",ScalingYScalingFile=\"#{table_offset},{nt:04}\"\r\n\
         [Comment],UserComment=\"\"",
        version = env!("CARGO_PKG_VERSION"),
    )
}

/// Write `img` as an HPD-TA `.img` file with `bits` = 16 or 32 per pixel and the per-row
/// times `time_axis_ps` (one per row, strictly increasing) as a float32 table in ps. The
/// reader hands the table back unchanged; femto's simulator passes the start of each row's
/// bin, `t0_ps + i * dt_ps` (the [`crate::cube::TimeAxis`] convention), and the
/// `[Streak camera] Time Range` it records is `nt` times the mean row spacing.
///
/// Values are rounded to the nearest integer (half away from zero) and clamped to
/// `0..=2^bits - 1`; returns how many were clamped at the top (saturated). Negative values
/// become 0 (a real sensor cannot report less than zero counts). Non-finite values are an
/// error. The file is written atomically.
pub fn write_img(
    path: &Path,
    img: &StreakImage,
    bits: u32,
    time_axis_ps: &[f64],
) -> Result<usize, FormatError> {
    let invalid = |message: String| FormatError::InvalidArgument {
        path: path.to_path_buf(),
        message,
    };
    let file_type = match bits {
        16 => ImgFileType::U16,
        32 => ImgFileType::U32,
        _ => {
            return Err(invalid(format!(
                "HPD-TA bit depth {bits} (the writer supports 16 and 32)"
            )))
        }
    };
    let (nx, nt) = (img.nx, img.nt);
    if img.data.len() != nx * nt {
        return Err(FormatError::SizeMismatch {
            path: path.to_path_buf(),
            what: "image data length (nx * nt)".into(),
            expected: nx * nt,
            found: img.data.len(),
        });
    }
    let max_dim = i16::MAX as usize;
    if nx == 0 || nt == 0 || nx > max_dim || nt > max_dim {
        return Err(invalid(format!(
            "HPD-TA image size {nx} x {nt} (each side must be 1..={max_dim})"
        )));
    }
    if time_axis_ps.len() != nt {
        return Err(FormatError::SizeMismatch {
            path: path.to_path_buf(),
            what: "time axis length (one time per row)".into(),
            expected: nt,
            found: time_axis_ps.len(),
        });
    }
    if let Some(i) = time_axis_ps.iter().position(|t| !t.is_finite()) {
        return Err(invalid(format!(
            "time axis value {} at row {i} is not finite",
            time_axis_ps[i]
        )));
    }
    if let Some(i) = time_axis_ps.windows(2).position(|w| w[1] <= w[0]) {
        return Err(invalid(format!(
            "time axis is not strictly increasing at row {}",
            i + 1
        )));
    }
    if let Some(i) = img.data.iter().position(|v| !v.is_finite()) {
        return Err(FormatError::NonFinite {
            path: path.to_path_buf(),
            x: i % nx,
            t: i / nx,
            value: img.data[i],
        });
    }

    let span_ps = if nt > 1 {
        (time_axis_ps[nt - 1] - time_axis_ps[0]) * nt as f64 / (nt - 1) as f64
    } else {
        0.0
    };
    let time_range = format_time_range(span_ps);
    let bpp = file_type.bytes();
    let pixel_bytes = nx * nt * bpp;
    // The table offset is written inside the comment, whose length moves the offset: iterate
    // to the fixed point (at most a couple of rounds, as the offset only grows in digits).
    let mut comment = writer_comment(bpp, nt, &time_range, 0);
    loop {
        let offset = HEADER_LEN + comment.len() + pixel_bytes;
        let next = writer_comment(bpp, nt, &time_range, offset);
        if next.len() == comment.len() {
            comment = next;
            break;
        }
        comment = next;
    }
    if comment.len() > i16::MAX as usize {
        return Err(invalid("HPD-TA comment longer than 32767 bytes".into()));
    }

    let mut out = Vec::with_capacity(HEADER_LEN + comment.len() + pixel_bytes + 4 * nt);
    out.extend_from_slice(b"IM");
    out.extend_from_slice(&(comment.len() as i16).to_le_bytes());
    out.extend_from_slice(&(nx as i16).to_le_bytes());
    out.extend_from_slice(&(nt as i16).to_le_bytes());
    out.extend_from_slice(&0i16.to_le_bytes()); // x offset
    out.extend_from_slice(&0i16.to_le_bytes()); // y offset
    out.extend_from_slice(&file_type.code().to_le_bytes());
    out.extend_from_slice(&0i32.to_le_bytes()); // number of images, as HPD-TA writes it
    out.extend_from_slice(&0i16.to_le_bytes()); // additional channels
    out.extend_from_slice(&0i16.to_le_bytes()); // channel number
    out.extend_from_slice(&0f64.to_le_bytes()); // time stamp
    out.resize(HEADER_LEN, 0); // marker and additional information
    out.extend_from_slice(comment.as_bytes());
    let max = if bits == 16 {
        u16::MAX as f64
    } else {
        u32::MAX as f64
    };
    let mut saturated = 0;
    for &v in &img.data {
        let r = (v as f64).round();
        if r > max {
            saturated += 1;
        }
        let stored = r.clamp(0.0, max);
        if bits == 16 {
            out.extend_from_slice(&(stored as u16).to_le_bytes());
        } else {
            out.extend_from_slice(&(stored as u32).to_le_bytes());
        }
    }
    debug_assert_eq!(out.len(), HEADER_LEN + comment.len() + pixel_bytes);
    for &t in time_axis_ps {
        out.extend_from_slice(&(t as f32).to_le_bytes());
    }
    write_file_atomically(path, |tmp| {
        std::fs::write(tmp, &out).map_err(|source| FormatError::Io {
            path: PathBuf::from(path),
            source,
        })
    })?;
    Ok(saturated)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comment_sections_follow_values_directly() {
        let s =
            parse_comment("[A],k=1,q=\"x, y\"\r\n[B],Type=5,SubType=0[C],ExposureTime=5 s,E=\"\"")
                .unwrap();
        assert_eq!(s["A"]["k"], "1");
        assert_eq!(s["A"]["q"], "x, y");
        assert_eq!(s["B"]["SubType"], "0");
        assert_eq!(s["C"]["ExposureTime"], "5 s");
        assert_eq!(s["C"]["E"], "");
    }

    #[test]
    fn comment_errors_give_offsets() {
        assert_eq!(parse_comment("k=1").unwrap_err().0, 0);
        assert_eq!(parse_comment("[A],k=1,lonely").unwrap_err().0, 8);
        assert!(parse_comment("[A],k=\"open").is_err());
        assert!(parse_comment("[A],k=1,k=2")
            .unwrap_err()
            .1
            .contains("duplicate"));
    }

    #[test]
    fn time_values_must_be_finite_in_ps() {
        let p = Path::new("x.img");
        let t = |v: &str| parse_time_value(p, "Streak camera", "Time Range", v);
        assert_eq!(t("20 us").unwrap(), 2e7);
        for v in ["inf ps", "nan ns", "1e300 s", "-inf fs"] {
            let e = t(v).unwrap_err().to_string();
            assert!(e.contains("finite") && e.contains("Time Range"), "{v}: {e}");
        }
    }

    #[test]
    fn time_units() {
        assert_eq!(time_unit_to_ps("us"), Some(1e6));
        assert_eq!(time_unit_to_ps("\u{b5}s"), Some(1e6));
        assert_eq!(time_unit_to_ps("fs"), Some(1e-3));
        assert_eq!(time_unit_to_ps("s"), Some(1e12));
        assert_eq!(time_unit_to_ps("nm"), None);
        assert_eq!(format_time_range(1900.0), "1.9 ns");
        assert_eq!(format_time_range(640.0), "640 ps");
        assert_eq!(format_time_range(2.0e7), "20 us");
    }
}

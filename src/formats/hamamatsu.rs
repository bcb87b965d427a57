//! Hamamatsu HPD-TA streak images: the `.img` reader with typed metadata and its writer, and
//! the HPD-TA header shared with HPD-TA TIFF files (`hamamatsu/tiff.rs`).
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
//! A time axis that is not calibrated leaves [`StreakImage::time_axis_ps`] empty (never a
//! guessed scale) and [`ImgMeta::time_uncalibrated`] names the header keys that say so:
//! `[Streak camera] Mode="Focus"` (the sweep is off, whatever `[Scaling]` says), a pixel or
//! length unit (`""`, `px`, `nm`, ...; another unknown unit is an error), or a table that is
//! not in the file (`ScalingYScalingFile` names another file, or is absent). `[Streak camera]
//! Time Range` may be a duration (`"20 us"`) or a bare sweep-range index (`"4"`), kept as
//! [`ImgMeta::time_range_index`] (see `hamamatsu/settings.rs`).
//!
//! One image per file: a header announcing several images or additional channels is refused
//! in one line (rosettasciio's reader reads the first `width x height` pixels whatever the
//! count says; femto does not silently drop the rest).
//!
//! The same header in a TIFF's ImageDescription ([`read_hpd_tiff`]) goes through the same
//! [`parse_comment`] and `build_image`: its tables are at byte offsets of the TIFF file.
//!
//! Writer ([`write_img`]): 16- or 32-bit unsigned, a comment with `[Application]`,
//! `[Acquisition]` (`AcqMode=2`, one exposure, no corrections: every key rosettasciio's
//! reader needs), `[Streak camera]` (`Time Range`, `Mode="Operate"`) and `[Scaling]` with
//! an uncalibrated X axis and `ScalingYType=2`, the per-row times in ps stored as a float32
//! table after the pixels. Values are rounded to the nearest integer (half away from zero)
//! and clamped to `0..=2^bits - 1`; the number clamped at the top is returned.
//!
//! The reader is here; the `[Scaling]` axes in `hamamatsu/scaling.rs`, the comment's settings
//! in `hamamatsu/settings.rs`, the TIFF container in `hamamatsu/tiff.rs`, the writer in
//! `hamamatsu/write.rs`, the unit tests in `hamamatsu/tests.rs`.

use super::{AxisTable, FileRegions, FormatError, PixelType, StreakImage};
use std::collections::BTreeMap;
use std::path::Path;

mod scaling;
mod settings;
mod tiff;
mod write;
use scaling::{axis_values, check_scaling_keys, make_axes_increase, parse_axis_scaling};
pub use scaling::{is_non_time_unit, time_unit_to_ps, AxisScaling};
use settings::comment_meta;
#[cfg(test)]
use settings::{parse_time_range, parse_time_value, TimeRange};
pub use tiff::{hpd_tiff_header, read_hpd_tiff, TiffImage};
pub use write::write_img;

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

/// The container an HPD-TA image came in.
#[derive(Clone, Debug, PartialEq)]
pub enum HpdContainer {
    /// An `.img` file, with its fixed header.
    Img(ImgHeader),
    /// A TIFF whose ImageDescription holds the HPD-TA header: the image's columns and rows.
    Tiff { width: usize, height: usize },
}

/// Everything an HPD-TA file (`.img`, or a TIFF with the HPD-TA header) says besides its
/// pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct ImgMeta {
    /// The container and, for `.img` files, the fixed header.
    pub container: HpdContainer,
    /// The comment text as stored (NUL padding removed): the `.img` comment or the TIFF's
    /// ImageDescription.
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
    /// `[Streak camera] Time Range` (the sweep window), picoseconds, when it is written as a
    /// duration (`"20 us"`).
    pub time_range_ps: Option<f64>,
    /// `[Streak camera] Time Range` when it is written as a bare number (`"4"`): the index
    /// of the sweep range, which gives no duration.
    pub time_range_index: Option<u32>,
    /// Which axis of the file holds time: `'Y'` (rows), or `'X'` when read transposed.
    pub time_file_axis: char,
    /// When the file does not calibrate its time axis: the header keys that say so
    /// ([`ImgMeta::uncalibrated_time`]); `None` when it has a time axis.
    pub time_uncalibrated: Option<String>,
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

    /// The `.img` header, for `.img` files.
    pub fn img_header(&self) -> Option<&ImgHeader> {
        match &self.container {
            HpdContainer::Img(h) => Some(h),
            HpdContainer::Tiff { .. } => None,
        }
    }

    /// Columns and rows as the file stores them.
    pub fn stored_size(&self) -> (usize, usize) {
        match &self.container {
            HpdContainer::Img(h) => (h.width, h.height),
            HpdContainer::Tiff { width, height } => (*width, *height),
        }
    }

    /// Whether `[Streak camera] Mode` is `Focus`: the sweep is off, so the rows are not time.
    pub fn focus_mode(&self) -> bool {
        self.mode
            .as_deref()
            .is_some_and(|m| m.trim().eq_ignore_ascii_case("focus"))
    }

    /// The header keys that leave the time axis uncalibrated, in words, for messages: e.g.
    /// `[Streak camera] Mode="Focus" (no sweep)`, `[Scaling] ScalingYType=1 with
    /// ScalingYUnit="nm" (not a time unit)`, `[Scaling] ScalingYType=2 with
    /// ScalingYScalingFile="t.dat" (a table outside this file)` and, when the time range is
    /// a sweep-range index, `[Streak camera] Time Range="4" (a sweep-range index, not a
    /// duration)`. Meant for an image read without a time axis.
    pub fn uncalibrated_time(&self) -> String {
        let axis = self.time_file_axis;
        let key = |suffix: &str| format!("Scaling{axis}{suffix}");
        let scaling = if axis == 'Y' {
            &self.scaling_y
        } else {
            &self.scaling_x
        };
        let with_unit = |kind: &str, unit: &str, what: &str| {
            format!(
                "[Scaling] {}={kind} with {}={unit:?} ({what})",
                key("Type"),
                key("Unit")
            )
        };
        let mut parts = Vec::new();
        if self.focus_mode() {
            parts.push(format!(
                "[Streak camera] Mode={:?} (no sweep: the {} are not time)",
                self.mode.as_deref().unwrap_or(""),
                if axis == 'Y' { "rows" } else { "columns" }
            ));
        }
        let sensor = if axis == 'Y' {
            "sensor rows"
        } else {
            "sensor columns"
        };
        let scaling_part = match (self.sections.get("Scaling"), scaling) {
            (None, _) => Some("no [Scaling] section".to_string()),
            (Some(_), AxisScaling::Pixels) => Some(match self.get("Scaling", &key("Type")) {
                None => format!("no [Scaling] {}", key("Type")),
                Some(kind) => with_unit(
                    kind,
                    self.get("Scaling", &key("Unit")).unwrap_or(""),
                    sensor,
                ),
            }),
            (Some(_), AxisScaling::External { file: None, .. }) => Some(format!(
                "[Scaling] {}=2 with no {} (no table)",
                key("Type"),
                key("ScalingFile")
            )),
            (Some(_), AxisScaling::External { file: Some(f), .. }) => Some(format!(
                "[Scaling] {}=2 with {}={f:?} (a table outside this file)",
                key("Type"),
                key("ScalingFile")
            )),
            (Some(_), AxisScaling::Linear { unit, .. }) if time_unit_to_ps(unit).is_none() => {
                Some(with_unit("1", unit, "not a time unit"))
            }
            (Some(_), AxisScaling::Table { unit, .. }) if time_unit_to_ps(unit).is_none() => {
                Some(with_unit("2", unit, "not a time unit"))
            }
            // A time calibration that Focus mode overrides.
            (Some(_), _) => None,
        };
        parts.extend(scaling_part);
        if let Some(i) = self.time_range_index {
            parts.push(format!(
                "[Streak camera] Time Range=\"{i}\" (a sweep-range index, not a duration)"
            ));
        }
        parts.join("; ")
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

/// Decode the 64-byte header (`bytes`: the start of a file of `file_bytes`).
fn parse_header(path: &Path, bytes: &[u8], file_bytes: u64) -> Result<ImgHeader, FormatError> {
    let truncated = |what: &str, needed: usize| FormatError::Truncated {
        path: path.to_path_buf(),
        what: what.to_string(),
        needed: needed as u64,
        available: file_bytes,
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
pub(crate) fn decode_comment(raw: &[u8]) -> String {
    let trimmed = match raw.iter().rposition(|&b| b != 0) {
        Some(last) => &raw[..=last],
        None => &[],
    };
    match std::str::from_utf8(trimmed) {
        Ok(s) => s.to_string(),
        Err(_) => trimmed.iter().map(|&b| b as char).collect(),
    }
}

/// Read an HPD-TA `.img` file (see the module doc for the layout and the axis rules). The
/// file is read by parts, never whole: the header and comment, then (once the image is
/// known to lie in the file and to fit in memory, [`super::check_image_size`]) the pixels,
/// then the axis tables where the comment says they are.
pub fn read_img(path: &Path, transpose: bool) -> Result<StreakImage, FormatError> {
    let io = |source| FormatError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let regions = FileRegions::new(&file).map_err(io)?;
    let head = regions
        .read(0, HEADER_LEN.min(regions.len as usize))
        .map_err(io)?;
    let header = parse_header(path, &head, regions.len)?;
    let comment_end = (HEADER_LEN + header.comment_len) as u64;
    if regions.len < comment_end {
        return Err(FormatError::Truncated {
            path: path.to_path_buf(),
            what: format!("the {}-byte comment", header.comment_len),
            needed: comment_end,
            available: regions.len,
        });
    }
    // Width and height are int16: the image is below 2^32 pixels, and u64 holds its bytes.
    let (w, h) = (header.width, header.height);
    let pixel_bytes = header.file_type.bytes();
    let data_end = comment_end + (w * h * pixel_bytes) as u64;
    if regions.len < data_end {
        return Err(FormatError::Truncated {
            path: path.to_path_buf(),
            what: format!("{w} x {h} pixels of {pixel_bytes} bytes after the comment"),
            needed: data_end,
            available: regions.len,
        });
    }
    super::check_image_size(path, w, h, pixel_bytes)?;
    let comment = decode_comment(
        &regions
            .read(HEADER_LEN as u64, header.comment_len)
            .map_err(io)?,
    );
    let sections =
        parse_comment(&comment).map_err(|(offset, message)| FormatError::BadComment {
            path: path.to_path_buf(),
            offset,
            message,
        })?;
    let data = read_pixels(&file, comment_end, header.file_type, w * h).map_err(io)?;
    let pixel_type = header.file_type.pixel_type();
    build_image(
        path,
        HpdPixels {
            container: HpdContainer::Img(header),
            width: w,
            height: h,
            data,
            pixel_type,
        },
        (comment, sections),
        &regions,
        transpose,
    )
}

/// `count` pixels of `file_type` at byte `offset` of `file`, decoded a megabyte at a time.
fn read_pixels(
    file: &std::fs::File,
    offset: u64,
    file_type: ImgFileType,
    count: usize,
) -> std::io::Result<Vec<f32>> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = file;
    f.seek(SeekFrom::Start(offset))?;
    let mut reader = std::io::BufReader::new(f);
    let size = file_type.bytes();
    let mut data = Vec::with_capacity(count);
    let mut chunk = vec![0u8; (1 << 20).min(count * size)];
    let mut left = count;
    while left > 0 {
        let n = left.min((1 << 20) / size);
        reader.read_exact(&mut chunk[..n * size])?;
        data.extend(decode_pixels(file_type, &chunk[..n * size]));
        left -= n;
    }
    Ok(data)
}

/// The pixels of an HPD-TA image as its container stores them: `height` rows of `width`.
pub(crate) struct HpdPixels {
    pub container: HpdContainer,
    pub width: usize,
    pub height: usize,
    pub data: Vec<f32>,
    pub pixel_type: PixelType,
}

/// The image of an HPD-TA file, whatever its container: the `[Scaling]` axes read (tables
/// from `file` at the offsets the comment gives) and made to increase, the roles assigned (rows are time
/// unless `transpose`), the time axis converted to ps or left uncalibrated (Focus mode, a
/// pixel or length unit, a table outside the file), and the settings of the header.
pub(crate) fn build_image(
    path: &Path,
    pixels: HpdPixels,
    (comment, sections): (String, BTreeMap<String, BTreeMap<String, String>>),
    file: &FileRegions,
    transpose: bool,
) -> Result<StreakImage, FormatError> {
    let HpdPixels {
        container,
        width: w,
        height: h,
        mut data,
        pixel_type,
    } = pixels;
    check_scaling_keys(path, &sections)?;
    let scaling_x = parse_axis_scaling(path, &sections, 'X', w, file)?;
    let scaling_y = parse_axis_scaling(path, &sections, 'Y', h, file)?;

    // Make every calibrated axis increase with the index.
    let mut x_vals = axis_values(&scaling_x, w);
    let mut y_vals = axis_values(&scaling_y, h);
    let (columns_reversed, rows_reversed) =
        make_axes_increase(path, &mut data, w, &mut x_vals, &mut y_vals)?;

    // Assign roles: rows are time unless transposed.
    let (time_vals, time_axis_name, space_vals, nx, nt) = if transpose {
        data = super::transpose_rows(&data, w, h);
        (x_vals, 'X', y_vals, h, w)
    } else {
        (y_vals, 'Y', x_vals, w, h)
    };
    let settings = comment_meta(path, &sections)?;
    let mut meta = ImgMeta {
        container,
        comment,
        sections,
        scaling_x,
        scaling_y,
        columns_reversed,
        rows_reversed,
        mode: settings.mode,
        time_range_ps: settings.time_range_ps,
        time_range_index: settings.time_range_index,
        time_file_axis: time_axis_name,
        time_uncalibrated: None,
        mcp_gain: settings.mcp_gain,
        n_exposures: settings.n_exposures,
        exposure_time_s: settings.exposure_time_s,
        total_exposure_s: settings.total_exposure_s,
    };
    let time_axis_ps = match time_vals {
        _ if meta.focus_mode() => None,
        None => None,
        Some((_, unit)) if is_non_time_unit(&unit) => None,
        Some((values, unit)) => {
            let per = time_unit_to_ps(&unit).ok_or_else(|| FormatError::UnknownUnit {
                path: path.to_path_buf(),
                what: format!("the time axis ([Scaling] Scaling{time_axis_name}Unit)"),
                unit: unit.clone(),
            })?;
            Some(values.iter().map(|v| v * per).collect())
        }
    };
    if time_axis_ps.is_none() {
        meta.time_uncalibrated = Some(meta.uncalibrated_time());
    }
    Ok(StreakImage {
        nx,
        nt,
        data,
        pixel_type,
        time_axis_ps,
        x_axis: space_vals.map(|(values, unit)| AxisTable { values, unit }),
        img_meta: Some(meta),
    })
}

/// The pixels of an image stored as `file_type` (little-endian), as floats.
fn decode_pixels(file_type: ImgFileType, pixels: &[u8]) -> Vec<f32> {
    match file_type {
        ImgFileType::U8 => pixels.iter().map(|&v| v as f32).collect(),
        ImgFileType::U16 => pixels
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]) as f32)
            .collect(),
        ImgFileType::U32 => pixels
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")) as f32)
            .collect(),
    }
}

#[cfg(test)]
mod tests;

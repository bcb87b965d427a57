//! Describing a streak image (.png, .tif, .tiff, .exr, .hdr, .img) as
//! [`crate::formats::read_streak`] reads it: size, sample type, value range, saturation, the
//! axes the file calibrates and an HPD-TA file's header. The JSON form is the `streak_image`
//! object of docs/cube-format.md.

use super::{brief, extension, line, serialize_path, ValueRange};
use crate::formats::hamamatsu::{HpdContainer, ImgMeta};
use crate::formats::{read_streak, PixelType};
use crate::pipeline::StageError;
use serde::{Serialize, Serializer};
use std::fmt;
use std::path::{Path, PathBuf};

/// A streak image: `nx` columns (x along the slit) by `nt` rows (time bins).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StreakDescription {
    #[serde(serialize_with = "serialize_path")]
    pub file: PathBuf,
    /// The extension, lower case.
    pub format: String,
    pub nx: usize,
    pub nt: usize,
    /// How the file stores its samples.
    #[serde(serialize_with = "serialize_pixel_type")]
    pub pixel_type: PixelType,
    /// Smallest and largest finite value (None when there are none).
    pub value_range: Option<ValueRange>,
    /// Samples at the file's largest storable value (None for floating-point files).
    pub saturated_pixels: Option<usize>,
    /// The per-row times the file calibrates, summarised (None without a time calibration).
    pub time_axis: Option<StreakTimeAxis>,
    /// The per-column positions the file calibrates, summarised.
    pub x_axis: Option<StreakAxis>,
    /// An HPD-TA file's header and comment.
    #[serde(serialize_with = "serialize_img")]
    pub img: Option<ImgMeta>,
    /// Read as storing time across and x down ([`super::DescribeOptions::transpose`]).
    #[serde(skip)]
    pub transposed: bool,
}

/// First and last of the per-row times, ps, and their mean step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StreakTimeAxis {
    pub first_ps: Option<f64>,
    pub last_ps: Option<f64>,
    /// `(last - first) / (nt - 1)`; NaN (null in the JSON) for fewer than two rows.
    pub mean_dt_ps: f64,
    pub nt: usize,
}

/// First and last of the per-column positions, in the file's unit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StreakAxis {
    pub first: Option<f64>,
    pub last: Option<f64>,
    pub unit: String,
}

/// Read and describe the streak image at `path` (`transpose`: stored time across).
pub(super) fn describe_streak(
    path: &Path,
    transpose: bool,
) -> Result<StreakDescription, StageError> {
    let img = read_streak(path, transpose).map_err(|e| {
        // The reader's message starts with the path; the stage's error adds it again.
        let message = e.to_string();
        let prefix = format!("{}: ", path.display());
        StageError::Input {
            path: path.display().to_string(),
            message: message
                .strip_prefix(&prefix)
                .unwrap_or(&message)
                .to_string(),
        }
    })?;
    let saturated_pixels = img
        .pixel_type
        .max_stored_value()
        .map(|top| img.data.iter().filter(|&&v| v as f64 >= top).count());
    let time_axis = img.time_axis_ps.as_ref().map(|t| {
        let n = t.len();
        StreakTimeAxis {
            first_ps: t.first().copied(),
            last_ps: t.last().copied(),
            mean_dt_ps: if n > 1 {
                (t[n - 1] - t[0]) / (n - 1) as f64
            } else {
                f64::NAN
            },
            nt: n,
        }
    });
    Ok(StreakDescription {
        file: path.to_path_buf(),
        format: extension(path),
        nx: img.nx,
        nt: img.nt,
        pixel_type: img.pixel_type,
        value_range: crate::cube::value_range(&img.data).map(ValueRange::from_pair),
        saturated_pixels,
        time_axis,
        x_axis: img.x_axis.map(|a| StreakAxis {
            first: a.values.first().copied(),
            last: a.values.last().copied(),
            unit: a.unit,
        }),
        img: img.img_meta,
        transposed: transpose,
    })
}

/// The documented name of a pixel type.
fn pixel_type_name(t: PixelType) -> &'static str {
    match t {
        PixelType::U8 => "u8",
        PixelType::U16 => "u16",
        PixelType::U32 => "u32",
        PixelType::I16 => "i16",
        PixelType::I32 => "i32",
        PixelType::F16 => "f16",
        PixelType::F32 => "f32",
        PixelType::F64 => "f64",
        PixelType::RgbU8 => "rgb_u8",
        PixelType::RgbU16 => "rgb_u16",
        PixelType::RgbF16 => "rgb_f16",
        PixelType::RgbF32 => "rgb_f32",
        PixelType::Rgbe => "rgbe",
    }
}

fn serialize_pixel_type<S: Serializer>(t: &PixelType, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(pixel_type_name(*t))
}

/// `img` for an `.img` file, `tiff` for an HPD-TA TIFF.
fn container_name(m: &ImgMeta) -> &'static str {
    match m.container {
        HpdContainer::Img(_) => "img",
        HpdContainer::Tiff { .. } => "tiff",
    }
}

/// The `img` object: the container, the stored size and the `.img` file type, the streak camera's and acquisition's
/// settings, the comment's section names.
fn serialize_img<S: Serializer>(img: &Option<ImgMeta>, s: S) -> Result<S::Ok, S::Error> {
    #[derive(Serialize)]
    struct Json<'a> {
        container: &'static str,
        width: usize,
        height: usize,
        file_type: Option<i16>,
        mode: &'a Option<String>,
        time_range_ps: Option<f64>,
        time_range_index: Option<u32>,
        time_uncalibrated: Option<String>,
        mcp_gain: Option<f64>,
        n_exposures: Option<u32>,
        exposure_time_s: Option<f64>,
        total_exposure_s: Option<f64>,
        sections: Vec<&'a String>,
        columns_reversed: bool,
        rows_reversed: bool,
    }
    img.as_ref()
        .map(|m| Json {
            container: container_name(m),
            width: m.stored_size().0,
            height: m.stored_size().1,
            file_type: m.img_header().map(|h| h.file_type.code()),
            mode: &m.mode,
            time_range_ps: m.time_range_ps,
            time_range_index: m.time_range_index,
            time_uncalibrated: m.time_uncalibrated.clone(),
            mcp_gain: m.mcp_gain,
            n_exposures: m.n_exposures,
            exposure_time_s: m.exposure_time_s,
            total_exposure_s: m.total_exposure_s,
            sections: m.sections.keys().collect(),
            columns_reversed: m.columns_reversed,
            rows_reversed: m.rows_reversed,
        })
        .serialize(s)
}

impl fmt::Display for StreakDescription {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        line(f, "file", self.file.display())?;
        line(f, "kind", format!("streak image ({})", self.format))?;
        let layout = if self.transposed {
            "time across, x down"
        } else {
            "x across, time down"
        };
        line(
            f,
            "size",
            format!("{} x {} (nx, nt): {layout}", self.nx, self.nt),
        )?;
        line(f, "pixels", pixel_type_name(self.pixel_type))?;
        match self.value_range {
            Some(r) => line(f, "values", format!("{} .. {}", r.min, r.max))?,
            None => line(f, "values", "no finite values")?,
        }
        if let Some(n) = self.saturated_pixels {
            line(
                f,
                "saturated",
                format!("{n} pixels at the file's largest value"),
            )?;
        }
        match &self.time_axis {
            Some(StreakTimeAxis {
                first_ps: Some(first),
                last_ps: Some(last),
                mean_dt_ps,
                nt,
            }) => line(
                f,
                "time axis",
                format!(
                    "{} .. {} ps over {nt} rows (mean {} ps per row)",
                    brief::significant(*first, 7),
                    brief::significant(*last, 7),
                    brief::significant(*mean_dt_ps, 6)
                ),
            )?,
            _ => match &self.img {
                Some(m) => line(
                    f,
                    "time axis",
                    format!(
                        "not calibrated in time: {} (femto ingest needs --dt-ps)",
                        m.time_uncalibrated
                            .as_deref()
                            .unwrap_or("no [Scaling] entry")
                    ),
                )?,
                None => line(f, "time axis", "none in the file")?,
            },
        }
        if let Some(a) = &self.x_axis {
            line(
                f,
                "x axis",
                format!(
                    "{} .. {} {}",
                    brief::significant(a.first.unwrap_or(f64::NAN), 7),
                    brief::significant(a.last.unwrap_or(f64::NAN), 7),
                    a.unit
                ),
            )?;
        }
        if let Some(m) = &self.img {
            let opt = |v: Option<f64>| v.map_or("-".to_string(), |x| brief::significant(x, 6));
            line(
                f,
                "HPD-TA",
                format!(
                    "{} x {} stored, {}, mode {}, time range {}, MCP gain {}",
                    m.stored_size().0,
                    m.stored_size().1,
                    match m.img_header() {
                        Some(h) => format!("file type {}", h.file_type.code()),
                        None => "header in the TIFF ImageDescription".to_string(),
                    },
                    m.mode.as_deref().unwrap_or("-"),
                    match (m.time_range_ps, m.time_range_index) {
                        (_, Some(i)) => format!("index {i} (no duration)"),
                        (ps, None) => format!("{} ps", opt(ps)),
                    },
                    opt(m.mcp_gain)
                ),
            )?;
            line(
                f,
                "exposure",
                exposure_text(m.n_exposures, m.exposure_time_s, m.total_exposure_s),
            )?;
            line(
                f,
                "sections",
                m.sections.keys().cloned().collect::<Vec<_>>().join(", "),
            )?;
        }
        Ok(())
    }
}

/// The HPD-TA exposure as `info` prints it: `5 x 0.2 s = 1 s`, or what the header lacks said
/// in words (`1 exposure, time not recorded`).
fn exposure_text(count: Option<u32>, each_s: Option<f64>, total_s: Option<f64>) -> String {
    let s = |x: f64| brief::significant(x, 6);
    match (count, each_s, total_s) {
        (Some(n), Some(t), Some(total)) => format!("{n} x {} s = {} s", s(t), s(total)),
        (Some(n), Some(t), None) => format!("{n} x {} s", s(t)),
        (Some(n), None, Some(total)) => format!("{n} exposure(s), {} s in all", s(total)),
        (Some(n), None, None) => format!("{n} exposure(s), time not recorded"),
        (None, Some(t), _) => format!("{} s each, count not recorded", s(t)),
        (None, None, Some(total)) => format!("{} s in all", s(total)),
        (None, None, None) => "not recorded".to_string(),
    }
}

#[cfg(test)]
mod exposure_tests {
    use super::exposure_text;

    #[test]
    fn exposure_says_what_the_header_lacks() {
        assert_eq!(
            exposure_text(Some(5), Some(0.19999999999999998), Some(1.0)),
            "5 x 0.2 s = 1 s"
        );
        assert_eq!(
            exposure_text(Some(1), None, None),
            "1 exposure(s), time not recorded"
        );
        assert_eq!(exposure_text(None, None, None), "not recorded");
    }
}

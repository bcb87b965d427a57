//! The acquisition settings of an HPD-TA comment ([`comment_meta`]): the `[Streak camera]`
//! mode, time range and MCP gain, the `[Acquisition]` exposures, and the values' parsers.
//!
//! HPD-TA writes `[Streak camera] Time Range` in two forms: a duration with its unit
//! (`Time Range="20 us"`, HPD-TA 9.x in Operate and Focus mode) or a bare number, the index
//! of the sweep range on the camera's range switch (`Time Range="4"`, some versions and
//! modes, e.g. shading files). The index says nothing about seconds without the camera's own
//! table of ranges, so it is kept as an index ([`super::ImgMeta::time_range_index`]) and
//! never turned into a duration; the time axis comes from `[Scaling]` alone.

use super::time_unit_to_ps;
use crate::formats::FormatError;
use std::collections::BTreeMap;
use std::path::Path;

/// `[Streak camera] Time Range` as HPD-TA writes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum TimeRange {
    /// A number and a time unit (`"20 us"`), in ps.
    Duration { ps: f64 },
    /// A bare integer: the index of the sweep range (`"4"`).
    Index(u32),
}

/// Parse `[Streak camera] Time Range`: a duration with a time unit, or a bare sweep-range
/// index (a non-negative integer). Anything else is an error naming the key.
pub(super) fn parse_time_range(path: &Path, value: &str) -> Result<TimeRange, FormatError> {
    let trimmed = value.trim();
    if !trimmed.is_empty() && trimmed.bytes().all(|b| b.is_ascii_digit()) {
        if let Ok(index) = trimmed.parse::<u32>() {
            return Ok(TimeRange::Index(index));
        }
    }
    if trimmed.split_whitespace().count() <= 1 {
        return Err(FormatError::BadValue {
            path: path.to_path_buf(),
            section: "Streak camera".into(),
            key: "Time Range".into(),
            value: value.into(),
            expected: "a number and a time unit (\"20 us\") or a sweep-range index (\"4\")".into(),
        });
    }
    parse_time_value(path, "Streak camera", "Time Range", value)
        .map(|ps| TimeRange::Duration { ps })
}

pub(super) fn parse_time_value(
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

/// The acquisition settings read from the comment (see [`super::ImgMeta`]).
pub(super) struct CommentMeta {
    pub mode: Option<String>,
    pub time_range_ps: Option<f64>,
    pub time_range_index: Option<u32>,
    pub mcp_gain: Option<f64>,
    pub n_exposures: Option<u32>,
    pub exposure_time_s: Option<f64>,
    pub total_exposure_s: Option<f64>,
}

/// The `[Streak camera]` and `[Acquisition]` settings of the comment's `sections`; a value
/// that does not parse (or a gain that is not finite) is an error naming its key.
pub(super) fn comment_meta(
    path: &Path,
    sections: &BTreeMap<String, BTreeMap<String, String>>,
) -> Result<CommentMeta, FormatError> {
    let streak = sections.get("Streak camera");
    let acquisition = sections.get("Acquisition");
    let mode = streak.and_then(|s| s.get("Mode")).cloned();
    let time_range = streak
        .and_then(|s| s.get("Time Range"))
        .map(|v| parse_time_range(path, v))
        .transpose()?;
    let (time_range_ps, time_range_index) = match time_range {
        Some(TimeRange::Duration { ps }) => (Some(ps), None),
        Some(TimeRange::Index(i)) => (None, Some(i)),
        None => (None, None),
    };
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
    Ok(CommentMeta {
        mode,
        time_range_ps,
        time_range_index,
        mcp_gain,
        n_exposures,
        exposure_time_s,
        total_exposure_s,
    })
}

//! Describing a cube: shape, time axis, values, mask, provenance, with summaries of its
//! `registration` ([`super::registration`]) and `pyramid` ([`super::pyramid`]) groups. The
//! JSON form is the `cube` object of docs/cube-format.md.

use super::pyramid::{summarise_pyramid, PyramidSummary};
use super::registration::{summarise_registration, RegistrationSummary};
use super::{brief, line, serialize_path, ValueRange};
use crate::container::{CubeMeta, CubeReader};
use crate::cube::NonFiniteAt;
use crate::pipeline::{Progress, StageError};
use crate::store::pyramid as stored_pyramid;
use crate::store::registration as stored_registration;
use serde::{Serialize, Serializer};
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// A femto cube: its metadata, its values' range and its groups, summarised.
#[derive(Clone, Debug, PartialEq)]
pub struct CubeDescription {
    /// The path as given.
    pub file: PathBuf,
    /// Shape, time axis and frame, units, provenance, group names.
    pub meta: CubeMeta,
    /// Smallest and largest finite value (None when there are none).
    pub value_range: Option<ValueRange>,
    /// How many values are NaN or infinite and the first of them (None when all are
    /// finite): the stages refuse such a cube, `info` describes it.
    pub non_finite: Option<(usize, NonFiniteAt)>,
    /// `(valid, total)` pixels when the cube has a mask.
    pub mask: Option<(usize, usize)>,
    /// The `registration` group, summarised (None without one).
    pub registration: Option<RegistrationSummary>,
    /// The `pyramid` group, summarised (None without one).
    pub pyramid: Option<PyramidSummary>,
}

/// Describe the cube at `path`, streaming its values once for their range.
pub(super) fn describe_cube(
    path: &Path,
    progress: &dyn Progress,
) -> Result<CubeDescription, StageError> {
    let reader = CubeReader::open(path)?;
    let meta = reader.meta().clone();
    progress.start("scanning", meta.ny as u64);
    let scan = reader.value_scan(&|rows| progress.set(rows as u64))?;
    progress.finish();
    let mask = reader
        .read_mask()?
        .map(|m| (m.iter().filter(|&&v| v != 0).count(), m.len()));
    let has = |g: &str| meta.groups.iter().any(|n| n == g);
    let registration = if has(stored_registration::GROUP) {
        Some(summarise_registration(path, &reader, &meta)?)
    } else {
        None
    };
    let pyramid = if has(stored_pyramid::GROUP) {
        let attrs = reader.read_group_attrs(stored_pyramid::GROUP)?;
        let names = reader.group_dataset_names(stored_pyramid::GROUP)?;
        Some(summarise_pyramid(path, attrs, &names, Some(&meta)))
    } else {
        None
    };
    Ok(CubeDescription {
        file: path.to_path_buf(),
        meta,
        value_range: scan.range.map(ValueRange::from_pair),
        non_finite: scan.first_non_finite.map(|at| (scan.non_finite, at)),
        mask,
        registration,
        pyramid,
    })
}

/// The `cube` object of docs/cube-format.md.
impl Serialize for CubeDescription {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Shape {
            ny: usize,
            nx: usize,
            nt: usize,
        }
        #[derive(Serialize)]
        struct Axis {
            t0_ps: f64,
            dt_ps: f64,
            nt: usize,
            end_ps: f64,
            unit: &'static str,
        }
        #[derive(Serialize)]
        struct Mask {
            valid_pixels: usize,
            pixels: usize,
        }
        #[derive(Serialize)]
        struct NonFinite {
            count: usize,
            first: First,
        }
        #[derive(Serialize)]
        struct First {
            x: usize,
            y: usize,
            bin: usize,
            value: &'static str,
        }
        #[derive(Serialize)]
        struct Json<'a> {
            #[serde(serialize_with = "serialize_path")]
            file: &'a PathBuf,
            shape: Shape,
            time_axis: Axis,
            time_frame: &'static str,
            units: &'a str,
            value_range: Option<ValueRange>,
            non_finite_values: Option<NonFinite>,
            mask: Option<Mask>,
            size_bytes: usize,
            groups: &'a [String],
            registration: &'a Option<RegistrationSummary>,
            pyramid: &'a Option<PyramidSummary>,
            femto_version: &'a Option<String>,
            command_line: &'a Option<String>,
            notes: BTreeMap<&'a str, &'a str>,
        }
        let m = &self.meta;
        Json {
            file: &self.file,
            shape: Shape {
                ny: m.ny,
                nx: m.nx,
                nt: m.axis.nt,
            },
            time_axis: Axis {
                t0_ps: m.axis.t0_ps,
                dt_ps: m.axis.dt_ps,
                nt: m.axis.nt,
                end_ps: m.axis.end_ps(),
                unit: "ps",
            },
            time_frame: m.frame.as_str(),
            units: &m.units,
            value_range: self.value_range,
            non_finite_values: self.non_finite.map(|(count, at)| NonFinite {
                count,
                first: First {
                    x: at.x,
                    y: at.y,
                    bin: at.bin,
                    value: at.kind(),
                },
            }),
            mask: self.mask.map(|(valid_pixels, pixels)| Mask {
                valid_pixels,
                pixels,
            }),
            size_bytes: m.size_bytes(),
            groups: &m.groups,
            registration: &self.registration,
            pyramid: &self.pyramid,
            femto_version: &m.femto_version,
            command_line: &m.command_line,
            // A note given twice keeps its last value.
            notes: m
                .notes
                .iter()
                .map(|(k, v)| (k.as_str(), v.as_str()))
                .collect(),
        }
        .serialize(s)
    }
}

impl fmt::Display for CubeDescription {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = &self.meta;
        line(f, "file", self.file.display())?;
        line(f, "kind", "femto cube (HDF5)")?;
        line(
            f,
            "shape",
            format!("{} x {} x {} (ny, nx, nt)", m.ny, m.nx, m.axis.nt),
        )?;
        line(
            f,
            "time axis",
            format!(
                "t0 {} ps, dt {} ps, {} bins, ends at {} ps",
                brief::significant(m.axis.t0_ps, 7),
                brief::significant(m.axis.dt_ps, 7),
                m.axis.nt,
                brief::significant(m.axis.end_ps(), 7)
            ),
        )?;
        line(f, "time frame", m.frame.as_str())?;
        line(f, "units", &m.units)?;
        match self.value_range {
            Some(r) => line(f, "values", format!("{} .. {}", r.min, r.max))?,
            None => line(f, "values", "no finite values")?,
        }
        if let Some((count, at)) = self.non_finite {
            line(
                f,
                "non-finite",
                format!(
                    "{count} values NaN or infinite, first {} at x {}, y {}, bin {} \
                     (the stages refuse this cube)",
                    at.kind(),
                    at.x,
                    at.y,
                    at.bin
                ),
            )?;
        }
        match self.mask {
            Some((valid, total)) => line(f, "mask", format!("{valid} of {total} pixels valid"))?,
            None => line(f, "mask", "none")?,
        }
        line(
            f,
            "size",
            format!("{} in memory", human_bytes(m.size_bytes() as u64)),
        )?;
        if m.groups.is_empty() {
            line(f, "groups", "none")?;
        } else {
            line(f, "groups", m.groups.join(", "))?;
        }
        if let Some(r) = &self.registration {
            r.fmt(f)?;
        }
        if let Some(p) = &self.pyramid {
            line(f, "pyramid", p)?;
        }
        if let Some(v) = &m.femto_version {
            line(f, "femto", v)?;
        }
        if let Some(c) = &m.command_line {
            line(f, "made by", c)?;
        }
        let full = f.alternate();
        for (k, v) in &m.notes {
            let shown = if full {
                v.to_string()
            } else {
                brief::note_value(v)
            };
            line(f, "note", format!("{k} = {shown}"))?;
        }
        Ok(())
    }
}

/// Bytes in binary units, e.g. "1.5 MiB (1572864 bytes)".
fn human_bytes(n: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = n as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{n} B")
    } else {
        format!("{v:.1} {} ({n} bytes)", UNITS[u])
    }
}

#[cfg(test)]
mod tests {
    use super::human_bytes;

    #[test]
    fn human_bytes_uses_binary_units() {
        assert_eq!(human_bytes(1000), "1000 B");
        assert_eq!(human_bytes(3 * 1024 * 1024 / 2), "1.5 MiB (1572864 bytes)");
    }
}

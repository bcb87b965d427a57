//! Summarising a cube's `registration` group: the stored calibration, the pixels that see
//! geometry, the distances and the fit's figures (the `registration` object of
//! docs/cube-format.md).

use super::{json_text, line, ValueRange};
use crate::camera::Calibration;
use crate::container::{AttrValue, CubeMeta, CubeReader, DataBuf, GroupData};
use crate::pipeline::StageError;
use crate::store::registration as stored_registration;
use serde::{Serialize, Serializer};
use std::fmt;
use std::path::Path;

/// The `registration` group: the stored calibration, the pixels that see geometry, the
/// distances and the fit's figures.
#[derive(Clone, Debug, PartialEq)]
pub struct RegistrationSummary {
    /// The `calibration` attribute, or why it is missing or does not parse.
    pub calibration: Result<Calibration, String>,
    /// The `mesh` attribute.
    pub mesh: Option<String>,
    /// Pixels of the cube (`nx * ny`).
    pub pixels: usize,
    /// Non-zero entries of the `mask` dataset (None without a `(ny, nx)` u8 mask).
    pub hit_pixels: Option<usize>,
    /// Range of the `dist_m` dataset over the pixels that see geometry, metres.
    pub dist_m: Option<ValueRange>,
    /// The fit's figures, when `femto calibrate` fitted the calibration (`points` stored).
    pub fit: Option<FitFigures>,
    /// Names of the group's datasets.
    pub datasets: Vec<String>,
}

impl RegistrationSummary {
    /// Fraction of the pixels that see geometry (NaN for a cube of no pixels).
    pub fn hit_fraction(&self) -> Option<f64> {
        self.hit_pixels.map(|h| h as f64 / self.pixels as f64)
    }
}

/// A number stored as an attribute, integer or float as the file holds it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum StoredNumber {
    Int(i64),
    Float(f64),
}

impl StoredNumber {
    fn of(attr: Option<&AttrValue>) -> Option<StoredNumber> {
        match attr {
            Some(AttrValue::F64(v)) => Some(StoredNumber::Float(*v)),
            Some(AttrValue::I64(v)) => Some(StoredNumber::Int(*v)),
            _ => None,
        }
    }
}

/// The figures `femto calibrate` stores with a fitted calibration; None where an attribute
/// is missing or not a number.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FitFigures {
    pub points: Option<StoredNumber>,
    pub outliers: Option<StoredNumber>,
    pub reprojection_rms_px: Option<StoredNumber>,
    pub time_samples: Option<StoredNumber>,
    pub time_inliers: Option<StoredNumber>,
    pub time_residual_rms_ps: Option<StoredNumber>,
}

/// The registration group: the calibration (when its `calibration` attribute parses), the
/// pixels that see geometry (from `mask`) and the distance range (from `dist_m`).
pub(super) fn summarise_registration(
    path: &Path,
    reader: &CubeReader,
    meta: &CubeMeta,
) -> Result<RegistrationSummary, StageError> {
    let g = stored_registration::GROUP;
    let data = GroupData {
        attrs: reader.read_group_attrs(g)?,
        datasets: Vec::new(),
    };
    let names = reader.group_dataset_names(g)?;
    // A `(ny, nx)` dataset of the group, None when absent or of another shape.
    let plane = |name: &str| -> Result<Option<DataBuf>, StageError> {
        if !names.iter().any(|n| n == name) {
            return Ok(None);
        }
        let (shape, _) = reader.group_dataset_shape(g, name)?;
        if shape != [meta.ny, meta.nx] {
            return Ok(None);
        }
        Ok(Some(reader.read_group_rows(g, name, 0, meta.ny)?))
    };
    let mask = match plane("mask")? {
        Some(DataBuf::U8(m)) => Some(m),
        _ => None,
    };
    let dist_m = match plane("dist_m")? {
        Some(DataBuf::F32(d)) => d
            .iter()
            .enumerate()
            .filter(|&(p, v)| v.is_finite() && mask.as_ref().is_none_or(|m| m[p] != 0))
            .map(|(_, &v)| v)
            .fold(None, |r: Option<(f32, f32)>, v| {
                Some(r.map_or((v, v), |(a, b)| (a.min(v), b.max(v))))
            })
            .map(ValueRange::from_pair),
        _ => None,
    };
    let number = |name: &str| StoredNumber::of(data.attr(name));
    let fit = data.attr("points").map(|_| FitFigures {
        points: number("points"),
        outliers: number("outliers"),
        reprojection_rms_px: number("reprojection_rms_px"),
        time_samples: number("time_samples"),
        time_inliers: number("time_inliers"),
        time_residual_rms_ps: number("time_residual_rms_ps"),
    });
    Ok(RegistrationSummary {
        calibration: stored_registration::stored_calibration(path, &data)
            .map_err(|e| e.to_string()),
        mesh: match data.attr("mesh") {
            Some(AttrValue::Str(s)) => Some(s.clone()),
            _ => None,
        },
        pixels: meta.nx * meta.ny,
        hit_pixels: mask.map(|m| m.iter().filter(|&&v| v != 0).count()),
        dist_m,
        fit,
        datasets: names,
    })
}

/// The calibration's numbers as the JSON lists them (`forward`: the optical axis).
#[derive(Serialize)]
struct CalibrationJson {
    width: usize,
    height: usize,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    k1: f64,
    k2: f64,
    camera_m: [f64; 3],
    forward: [f64; 3],
    t0_ps: f64,
    time_scale: f64,
    laser_m: [f64; 3],
    eta: f64,
}

impl CalibrationJson {
    fn of(c: &Calibration) -> CalibrationJson {
        let k = c.intrinsics;
        let (o, f, l) = (c.pose.position_m, c.pose.forward(), c.laser_m);
        CalibrationJson {
            width: k.width,
            height: k.height,
            fx: k.fx,
            fy: k.fy,
            cx: k.cx,
            cy: k.cy,
            k1: k.k1,
            k2: k.k2,
            camera_m: [o.x, o.y, o.z],
            forward: [f.x, f.y, f.z],
            t0_ps: c.t0_ps,
            time_scale: c.time_scale,
            laser_m: [l.x, l.y, l.z],
            eta: c.eta,
        }
    }
}

impl Serialize for RegistrationSummary {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Json<'a> {
            calibration: Option<CalibrationJson>,
            calibration_error: Option<&'a str>,
            mesh: &'a Option<String>,
            pixels: usize,
            hit_pixels: Option<usize>,
            hit_fraction: Option<f64>,
            dist_m: Option<ValueRange>,
            fit: &'a Option<FitFigures>,
            datasets: &'a [String],
        }
        Json {
            calibration: self.calibration.as_ref().ok().map(CalibrationJson::of),
            calibration_error: self.calibration.as_ref().err().map(String::as_str),
            mesh: &self.mesh,
            pixels: self.pixels,
            hit_pixels: self.hit_pixels,
            hit_fraction: self.hit_fraction(),
            dist_m: self.dist_m,
            fit: &self.fit,
            datasets: &self.datasets,
        }
        .serialize(s)
    }
}

/// The `registration` lines of a cube's text.
impl fmt::Display for RegistrationSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let key = "registration";
        match &self.calibration {
            Err(e) => line(f, key, format!("calibration unreadable: {e}"))?,
            Ok(c) => {
                let v3 = |x: f64, y: f64, z: f64| format!("({x:.4}, {y:.4}, {z:.4})");
                let k = &c.intrinsics;
                let (o, d, l) = (c.pose.position_m, c.pose.forward(), c.laser_m);
                line(
                    f,
                    key,
                    format!(
                        "camera at {} m looking along {}, fx {:.2} fy {:.2} cx {:.2} cy {:.2} px",
                        v3(o.x, o.y, o.z),
                        v3(d.x, d.y, d.z),
                        k.fx,
                        k.fy,
                        k.cx,
                        k.cy
                    ),
                )?;
                line(
                    f,
                    key,
                    format!(
                        "t0 {:.3} ps, time scale {}, laser at {} m, eta {}",
                        c.t0_ps,
                        c.time_scale,
                        v3(l.x, l.y, l.z),
                        c.eta
                    ),
                )?;
            }
        }
        if let (Some(h), Some(fr)) = (self.hit_pixels, self.hit_fraction()) {
            if fr.is_finite() {
                line(
                    f,
                    key,
                    format!(
                        "{h} of {} pixels see geometry ({:.1} %)",
                        self.pixels,
                        100.0 * fr
                    ),
                )?;
            }
        }
        if let Some(d) = self.dist_m {
            line(
                f,
                key,
                format!("distance to the camera {:.4} .. {:.4} m", d.min, d.max),
            )?;
        }
        if let Some(fit) = &self.fit {
            // Missing figures read `null` and NaN, as the JSON has them.
            let float = |n: Option<StoredNumber>| match n {
                Some(StoredNumber::Int(i)) => i as f64,
                Some(StoredNumber::Float(x)) if x.is_finite() => x,
                _ => f64::NAN,
            };
            line(
                f,
                key,
                format!(
                    "fit: {} points, {} outlier(s), reprojection rms {:.3} px; time residual \
                     rms {:.3} ps over {} of {} pixels",
                    json_text(&fit.points),
                    json_text(&fit.outliers),
                    float(fit.reprojection_rms_px),
                    float(fit.time_residual_rms_ps),
                    json_text(&fit.time_inliers),
                    json_text(&fit.time_samples)
                ),
            )?;
        }
        Ok(())
    }
}

//! The options of an ingest as typed values ([`IngestOptions`], what the command line's flags
//! map onto) and the check of the numbers given, before any file is read.

use std::path::PathBuf;

use super::super::corrections::RefRegion;
use crate::ingest::{IngestError, IngestValue};
use crate::ranges;
pub use crate::saturation::SaturationInput;

/// The dark signal asked for.
#[derive(Clone, Debug, PartialEq)]
pub enum DarkInput {
    /// A constant level (scaled value units).
    Level(f64),
    /// A dark frame: a streak image of the scanlines' size (read like them; integer samples
    /// are scaled by the value scale, float samples taken as they are).
    File(PathBuf),
}

/// The laser power normalisation asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PowerRef {
    /// A block of every scanline that sees a fixed part of the scene (the laser spot, a
    /// reference fibre): rows are scaled to the median of its integral.
    Region(RefRegion),
    /// No reference in view: each row's pixel integrals against the same pixels in the
    /// neighbouring rows ([`crate::ingest::row_offsets`]).
    Auto,
}

impl PowerRef {
    /// Parse `auto` or a reference region `x0:x1,t0:t1` (the value of `--power-ref`).
    pub fn parse(s: &str) -> Result<PowerRef, String> {
        if s == "auto" {
            return Ok(PowerRef::Auto);
        }
        let (xs, ts) = s
            .split_once(',')
            .ok_or_else(|| format!("'{s}' is not x0:x1,t0:t1"))?;
        let (x0, x1) = range(xs, "x range")?;
        let (t0_bin, t1_bin) = range(ts, "bin range")?;
        Ok(PowerRef::Region(RefRegion {
            x0,
            x1,
            t0_bin,
            t1_bin,
        }))
    }
}

/// `A:B`, two non-negative integers.
fn range(s: &str, what: &str) -> Result<(usize, usize), String> {
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| format!("{what} '{s}' is not A:B"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<usize>()
            .map_err(|_| format!("{what} '{s}': '{v}' is not a non-negative integer"))
    };
    Ok((parse(a)?, parse(b)?))
}

/// The options of an ingest, as typed values (the command line maps its flags onto these);
/// `Default` is what `femto ingest` does without flags: the manifest's corrections and jitter
/// removal.
#[derive(Clone, Debug, PartialEq)]
pub struct IngestOptions {
    /// Width of a time bin, ps, when the capture records none.
    pub dt_ps: Option<f64>,
    /// Start of bin 0, ps, when the capture records none.
    pub t0_ps: Option<f64>,
    /// The files store time across and x down.
    pub transpose: bool,
    /// Dark subtraction.
    pub dark: Option<DarkInput>,
    /// Flat-field division by the per-pixel gains of this image (`nx` wide, `ny` or 1 high).
    pub flat: Option<PathBuf>,
    /// Sweep calibration table (`nt + 1` true bin-edge times, ps).
    pub sweep_table: Option<PathBuf>,
    /// Estimate and remove per-scanline trigger jitter (on by default).
    pub jitter: bool,
    /// Laser power normalisation (a reference region in recorded bins, or automatic).
    pub power_ref: Option<PowerRef>,
    /// Mask saturated pixels.
    pub saturation: Option<SaturationInput>,
    /// Fill missing scanlines by interpolation (and mask them) instead of refusing.
    pub allow_missing: bool,
    /// Multiply the samples read by this (for 16-bit PNG: the signal per count).
    pub value_scale: Option<f64>,
    /// Where `dt_ps` or `t0_ps` contradict the axis the capture records (manifest, `.img`
    /// time table), resample the recorded rows onto them (conserving each pixel's
    /// integral) instead of refusing them.
    pub resample_time: bool,
    /// Laser wavelength, nm, for captures without a manifest (must agree with a
    /// manifest's).
    pub laser_nm: Option<f64>,
    /// Do not apply the corrections a manifest records (module doc, "Manifest
    /// corrections"): its dark frame, flat field and sweep bin times.
    pub ignore_manifest_corrections: bool,
}

impl Default for IngestOptions {
    fn default() -> Self {
        IngestOptions {
            dt_ps: None,
            t0_ps: None,
            transpose: false,
            dark: None,
            flat: None,
            sweep_table: None,
            jitter: true,
            power_ref: None,
            saturation: None,
            allow_missing: false,
            value_scale: None,
            resample_time: false,
            laser_nm: None,
            ignore_manifest_corrections: false,
        }
    }
}

impl IngestOptions {
    /// Refuse a value scale, bin width, start or laser wavelength that is not a usable
    /// number (the first such one, in that order), before any file is read.
    pub fn check_values(&self) -> Result<(), IngestError> {
        if let Some(v) = self.value_scale {
            if !(v.is_finite() && v > 0.0) {
                return Err(IngestError::BadValue {
                    what: IngestValue::ValueScale,
                    value: v.to_string(),
                    message: "must be finite and > 0".into(),
                });
            }
        }
        for (what, v, range) in [
            (IngestValue::DtPs, self.dt_ps, ranges::BIN_WIDTH_PS),
            (IngestValue::T0Ps, self.t0_ps, ranges::TIME_PS),
        ] {
            if let Some(v) = v {
                if let Err(e) = ranges::check("", v, range) {
                    return Err(IngestError::BadValue {
                        what,
                        value: crate::limits::short_number(v),
                        message: e.requirement(),
                    });
                }
            }
        }
        if let Some(v) = self.laser_nm {
            if !(v.is_finite() && v > 0.0) {
                return Err(IngestError::BadValue {
                    what: IngestValue::LaserNm,
                    value: v.to_string(),
                    message: "must be a positive wavelength in nm".into(),
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(options: IngestOptions) -> String {
        options.check_values().unwrap_err().to_string()
    }

    #[test]
    fn usable_numbers_pass_and_a_negative_start_is_one() {
        let options = IngestOptions {
            value_scale: Some(0.5),
            dt_ps: Some(2.0),
            t0_ps: Some(-40.0),
            laser_nm: Some(670.0),
            ..IngestOptions::default()
        };
        options.check_values().unwrap();
        IngestOptions::default().check_values().unwrap();
    }

    #[test]
    fn each_unusable_number_is_refused_by_name() {
        let base = IngestOptions::default();
        for (options, what) in [
            (
                IngestOptions {
                    value_scale: Some(0.0),
                    ..base.clone()
                },
                "value scale",
            ),
            (
                IngestOptions {
                    value_scale: Some(f64::NAN),
                    ..base.clone()
                },
                "value scale",
            ),
            (
                IngestOptions {
                    dt_ps: Some(0.0),
                    ..base.clone()
                },
                "dt_ps",
            ),
            (
                IngestOptions {
                    dt_ps: Some(f64::INFINITY),
                    ..base.clone()
                },
                "dt_ps",
            ),
            (
                IngestOptions {
                    t0_ps: Some(f64::NAN),
                    ..base.clone()
                },
                "t0_ps",
            ),
            (
                IngestOptions {
                    laser_nm: Some(-1.0),
                    ..base.clone()
                },
                "laser_nm",
            ),
        ] {
            let e = refused(options);
            assert!(e.contains(what), "{what}: {e}");
        }
        // The value scale is checked first.
        let e = refused(IngestOptions {
            value_scale: Some(-1.0),
            dt_ps: Some(-1.0),
            ..base
        });
        assert!(
            e.contains("value scale") && e.contains("must be finite and > 0"),
            "{e}"
        );
    }
}

//! Ingest errors as the `femto ingest` flags name them: the library's messages say what is
//! wrong with a value or a file; here the flag that gives or fixes it is named, and a hint
//! is added where a value is missing. The CLI and the Python package raise these lines.

use super::time_axis::AxisValue;
use super::{IngestError, IngestValue};

/// `x` rounded up to three significant digits (a bin width to suggest).
fn round_up_3_digits(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return x;
    }
    let unit = 10f64.powf(x.log10().floor() - 2.0);
    (x / unit).ceil() * unit
}

/// The flag of a time-axis value.
fn axis_flag(what: AxisValue) -> &'static str {
    match what {
        AxisValue::BinWidth => "--dt-ps",
        AxisValue::Start => "--t0-ps",
    }
}

/// The flag that gives each value the library can refuse ([`IngestError::BadValue`]).
fn value_flag(what: IngestValue) -> &'static str {
    match what {
        IngestValue::ValueScale => "--value-scale",
        IngestValue::DtPs => "--dt-ps",
        IngestValue::T0Ps => "--t0-ps",
        IngestValue::LaserNm => "--laser-nm",
        IngestValue::DarkLevel => "--dark",
        IngestValue::SaturationLevel => "--saturation",
    }
}

/// `e`'s line naming the flag where the library's message names an option, with the flag
/// to use where it names a missing value; None where the error's own message (and its
/// causes) say it.
pub fn flag_message(e: &IngestError) -> Option<String> {
    match e {
        IngestError::AxisConflict {
            what,
            given,
            source_name,
            recorded,
        } => {
            return Some(format!(
                "{} {given}: contradicts {source_name}, whose {} is {recorded} ps (leave the \
                 flag out to keep the recorded axis, or add --resample-time to resample the \
                 recorded rows onto the axis asked for)",
                axis_flag(*what),
                what.quantity()
            ))
        }
        IngestError::StartAfterRecording {
            t0_ps,
            first_edge_ps,
            source_name,
        } => {
            return Some(format!(
                "--t0-ps {t0_ps}: after the start of the recorded rows ({source_name}: \
                 {first_edge_ps} ps); resampling from there would lose the signal before \
                 it (give --t0-ps {first_edge_ps} or earlier)"
            ))
        }
        IngestError::TooManyBins {
            dt_ps,
            first_edge_ps,
            last_edge_ps,
            needed,
            max,
            source_name,
        } => {
            let span = last_edge_ps - first_edge_ps;
            return Some(format!(
                "--dt-ps {dt_ps}: the recorded rows ({source_name}) span {first_edge_ps} to \
                 {last_edge_ps} ps, which would take {needed} bins of {dt_ps} ps (at most \
                 {max}, 16 per recorded row; give --dt-ps {} or more)",
                round_up_3_digits(span / *max as f64)
            ));
        }
        IngestError::LaserConflict {
            given,
            manifest,
            recorded,
        } => {
            return Some(format!(
                "--laser-nm {given}: contradicts {}, whose [capture] laser_wavelength_nm is \
                 {recorded} nm (leave the flag out)",
                manifest.display()
            ))
        }
        IngestError::BadValue {
            what,
            value,
            message,
        } => return Some(format!("{} {value}: {message}", value_flag(*what))),
        IngestError::Correction { what, source } if what == "power reference region" => {
            return Some(format!("--power-ref: {source}"));
        }
        IngestError::FolderWithoutManifest { dir, found } => {
            let ext = found.first().map_or("png", |(e, _)| e.as_str());
            let axis = if ext == "img" {
                ""
            } else {
                " --dt-ps PS --t0-ps PS"
            };
            return Some(format!(
                "{e}; give its scanlines as a quoted glob: femto ingest '{}/*.{ext}'{axis} -o \
                 CUBE.h5",
                dir.display().to_string().trim_end_matches('/')
            ));
        }
        _ => {}
    }
    let hint = match e {
        IngestError::PrintfNeedsRows { .. } => Some("give --rows N"),
        IngestError::NoTimeAxis { .. } => Some("give --dt-ps and --t0-ps"),
        IngestError::ImgTimeUncalibrated { .. } => {
            Some("give --dt-ps PS, the time per row; --t0-ps defaults to 0")
        }
        IngestError::NothingToResample { .. } => Some("leave out --resample-time"),
        IngestError::SaturationAuto { .. } => Some("use --saturation LEVEL"),
        IngestError::MissingScanline { .. } | IngestError::ManifestFileMissing { .. } => {
            Some("--allow-missing fills missing scanlines by interpolation")
        }
        _ => None,
    };
    hint.map(|h| format!("{e} ({h})"))
}

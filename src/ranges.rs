//! The meaningful range of each kind of number femto reads from a file or a flag (a bin
//! width, a time, a time scale, a coordinate, a refractive index), and the one check that
//! holds a number to its range where it enters ([`check`], [`check_point`]), before anything
//! sized by it is allocated or walked.
//!
//! A range is wide enough for every real capture and narrow enough that the arithmetic built
//! on it stays finite and bounded: a bin width of `1e-300` ps made `femto render` index past a
//! profile and `1e-6` ps ask 6.4 GB; a camera path keyframe at `1e308` ps turned the clock
//! table into NaN; a calibration `time_scale` of `1e9` asked 1.6 TB. Counts derived from
//! these numbers (a span divided by a bin width) are still bounded where they are used
//! ([`crate::limits`]). The ranges are listed in `docs/faults.md` ("Ranges").
//!
//! [`OutOfRange`] prints as one line naming the key and the value: `dt_ps = 1e-300: must lie
//! in [0.001, 1000000000] ps`; the caller adds the file or the flag.

use crate::limits::short_number;
use std::fmt;

/// A closed interval of meaningful values and its unit (as printed after the numbers).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub lo: f64,
    pub hi: f64,
    /// Printed after the interval: `" ps"`, `" m"`, or `""` for a ratio.
    pub unit: &'static str,
}

impl Range {
    /// Whether `v` lies in the range (never for NaN).
    pub fn contains(&self, v: f64) -> bool {
        v >= self.lo && v <= self.hi
    }

    /// The same range in another unit: both ends times `factor` (> 0), e.g. a bin width in
    /// ps as metres of optical path.
    pub fn scaled(&self, factor: f64, unit: &'static str) -> Range {
        Range {
            lo: self.lo * factor,
            hi: self.hi * factor,
            unit,
        }
    }
}

/// A time bin's width, ps: a femtosecond to a millisecond. Femto-photography bins are
/// femtoseconds (a simulated capture) to nanoseconds (a slow SPAD histogram); a streak
/// camera's slow sweep unit spans up to 10 ms over about 1000 rows, 10 us a row; every real
/// file of `shared/data/real` has bins of 0.75 ps to 31 ns.
pub const BIN_WIDTH_PS: Range = Range {
    lo: 1e-3,
    hi: 1e9,
    unit: " ps",
};

/// A time (the start of an axis, a keyframe, a path's first frame, a calibration's `t0`),
/// ps: within a second either side of time zero. Light crosses 3e8 m in a second, far
/// beyond any scene; at 1e12 ps an f64 still resolves 1e-4 ps.
pub const TIME_PS: Range = Range {
    lo: -1e12,
    hi: 1e12,
    unit: " ps",
};

/// A frame interval or exposure window, ps: positive, at most a second.
pub const INTERVAL_PS: Range = Range {
    lo: 1e-6,
    hi: 1e12,
    unit: " ps",
};

/// A calibration's `time_scale` (cube time units per true picosecond, 1 for a perfect sweep):
/// a thousandth to a thousand, which covers a sweep miscalibrated by any real amount and a
/// cube recorded in fs or ns where ps were meant; `65536` took 24 s to render 16 x 12 pixels.
pub const TIME_SCALE: Range = Range {
    lo: 1e-3,
    hi: 1e3,
    unit: "",
};

/// A coordinate or length, metres: a thousand kilometres either side of the origin (the
/// camera path's [`crate::camera_path::MAX_COORD_M`]). The renderer casts rays in `f32`.
pub const COORD_M: Range = Range {
    lo: -1e6,
    hi: 1e6,
    unit: " m",
};

/// A distance, metres: from nothing to [`COORD_M`]'s bound (a registration's `dist_m`, the
/// distance from the camera centre to the surface a pixel sees).
pub const DISTANCE_M: Range = Range {
    lo: 0.0,
    hi: 1e6,
    unit: " m",
};

/// A component of a direction or a normal (not necessarily unit), bounded as [`COORD_M`].
pub const DIRECTION: Range = Range {
    lo: -1e6,
    hi: 1e6,
    unit: "",
};

/// A refractive index: vacuum to well beyond any transparent medium (the scene's
/// [`crate::scene::ETA_RANGE`]).
pub const ETA: Range = Range {
    lo: 1.0,
    hi: 10.0,
    unit: "",
};

/// A focal length in pixels: a thousandth of a pixel to ten million.
pub const FOCAL_PX: Range = Range {
    lo: 1e-3,
    hi: 1e7,
    unit: " px",
};

/// A principal point coordinate in pixels: within ten million pixels of the image's corner.
pub const PIXEL: Range = Range {
    lo: -1e7,
    hi: 1e7,
    unit: " px",
};

/// A radial distortion coefficient (Brown's `k1`, `k2`, on normalised coordinates, where
/// real lenses have |k| below 10).
pub const DISTORTION: Range = Range {
    lo: -1e6,
    hi: 1e6,
    unit: "",
};

/// A number outside its [`Range`], named by its key (`dt_ps`, `keyframe 2 of 3: time_ps`,
/// `--dt-ps`).
#[derive(Clone, Debug, PartialEq)]
pub struct OutOfRange {
    pub key: String,
    pub value: f64,
    pub range: Range,
}

impl OutOfRange {
    /// What the value must be, without the key and the value: `must lie in [0.001, 1000000000]
    /// ps` (for messages that name the flag and the value their own way).
    pub fn requirement(&self) -> String {
        let r = &self.range;
        format!(
            "must lie in [{}, {}]{}",
            short_number(r.lo),
            short_number(r.hi),
            r.unit
        )
    }
}

impl OutOfRange {
    /// The value and what it must be, without the key: `1e-300: must lie in [0.001,
    /// 1000000000] ps` (for messages that name the key their own way).
    pub fn detail(&self) -> String {
        format!("{}: {}", short_number(self.value), self.requirement())
    }
}

impl fmt::Display for OutOfRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} = {}", self.key, self.detail())
    }
}

impl std::error::Error for OutOfRange {}

/// `value` when it lies in `range` (never a NaN or an infinity), else [`OutOfRange`] naming
/// `key`.
pub fn check(key: impl fmt::Display, value: f64, range: Range) -> Result<f64, OutOfRange> {
    if range.contains(value) {
        Ok(value)
    } else {
        Err(OutOfRange {
            key: key.to_string(),
            value,
            range,
        })
    }
}

/// Each component of `v` in `range`, the first outside named `key[i]`.
pub fn check_point(key: impl fmt::Display, v: &[f64], range: Range) -> Result<(), OutOfRange> {
    for (i, &x) in v.iter().enumerate() {
        if !range.contains(x) {
            return Err(OutOfRange {
                key: format!("{key}[{i}]"),
                value: x,
                range,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_at_the_ends_pass_and_beyond_them_are_named() {
        assert_eq!(check("dt_ps", 1e-3, BIN_WIDTH_PS), Ok(1e-3));
        assert_eq!(check("dt_ps", 1e9, BIN_WIDTH_PS), Ok(1e9));
        let e = check("dt_ps", 1e-300, BIN_WIDTH_PS).unwrap_err();
        assert_eq!(
            e.to_string(),
            "dt_ps = 1e-300: must lie in [0.001, 1000000000] ps"
        );
        for v in [f64::NAN, f64::INFINITY, -1e308, 0.0, 5e-324, 1e308] {
            assert!(check("t", v, BIN_WIDTH_PS).is_err(), "{v}");
        }
        assert!(check("t0_ps", f64::NAN, TIME_PS)
            .unwrap_err()
            .to_string()
            .starts_with("t0_ps = NaN: must lie in ["));
    }

    #[test]
    fn a_point_names_its_component() {
        let e = check_point("sensor_xyz", &[0.0, 1e308, 0.0], COORD_M).unwrap_err();
        assert_eq!(e.key, "sensor_xyz[1]");
        assert!(check_point("p", &[1.0, -2.0, 3.0], COORD_M).is_ok());
    }

    #[test]
    fn a_scaled_range_is_the_same_interval_in_another_unit() {
        let m = BIN_WIDTH_PS.scaled(crate::units::C_M_PER_PS, " m");
        assert!(m.contains(4.0 * crate::units::C_M_PER_PS));
        assert!(!m.contains(1e-300));
        assert_eq!(m.unit, " m");
    }
}

//! One scanline's offset (trigger jitter in ps, or the log of the laser power), as estimated
//! and as removed, and the significance gate that decides between them.
//!
//! Two estimators produce it: ingest from the data alone ([`crate::ingest::row_offsets`],
//! each row against its neighbours) and calibration from the geometry
//! ([`crate::calibrate::scanline_time`], each row against the calibrated scene's direct
//! light); the cube file stores what was applied (`crate::store::registration`). It lives
//! here, below all three, so that none of them reaches up into another for it.

/// An offset is applied when it exceeds this many standard errors.
pub const SIGNIFICANCE: f64 = 4.0;

/// One row's offset: what the data give, its standard error, and what is removed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowOffset {
    /// The row's offset as solved for.
    pub estimate: f64,
    /// Standard error of `estimate` with the neighbouring rows' offsets at theirs: from the
    /// pixels' spread and the disagreement of the row's prediction windows (the scene model's
    /// error there); the slow offsets that no row tells from the scene are not in it.
    pub std_error: f64,
    /// The offset to remove: `estimate` where it exceeds [`SIGNIFICANCE`] standard errors,
    /// else 0.
    pub applied: f64,
}

impl RowOffset {
    /// The offset `estimate` with standard error `std_error`, applied where
    /// `|estimate| > SIGNIFICANCE * std_error` (else 0 is removed).
    pub fn gated(estimate: f64, std_error: f64) -> RowOffset {
        RowOffset {
            estimate,
            std_error,
            applied: if estimate.abs() > SIGNIFICANCE * std_error {
                estimate
            } else {
                0.0
            },
        }
    }
}

/// The applied offsets of `offsets` as the cube file stores them (`NaN`: not estimated).
pub fn applied_ps(offsets: &[Option<RowOffset>]) -> Vec<f64> {
    offsets
        .iter()
        .map(|o| o.map_or(f64::NAN, |o| o.applied))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_offset_is_applied_only_beyond_the_significance() {
        assert_eq!(RowOffset::gated(4.1, 1.0).applied, 4.1);
        assert_eq!(RowOffset::gated(-4.1, 1.0).applied, -4.1);
        assert_eq!(RowOffset::gated(4.0, 1.0).applied, 0.0);
        assert_eq!(RowOffset::gated(3.0, 1.0).applied, 0.0);
        // An infinite standard error never applies; a NaN estimate is not applied either.
        assert_eq!(RowOffset::gated(1e9, f64::INFINITY).applied, 0.0);
        assert_eq!(RowOffset::gated(f64::NAN, 1.0).applied, 0.0);
        let o = RowOffset::gated(12.0, 0.5);
        assert_eq!((o.estimate, o.std_error, o.applied), (12.0, 0.5, 12.0));
    }
}

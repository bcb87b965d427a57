//! Saturated samples: the level a user asks for ([`SaturationInput`], the value of
//! `--saturation`) and the validity mask of a raw scanline whose profile reaches it
//! ([`saturation_mask`]).
//!
//! A clipped profile is not a measurement of the light: the stages mark its pixel invalid in
//! the cube's `valid` mask instead of keeping a wrong number. The streak ingest
//! ([`crate::ingest::corrections`]), the array ingest and the y-tal ingest
//! ([`crate::interop`]) all apply it; it lives here, below them, so that none reaches up
//! into another for it.

/// The saturation level asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SaturationInput {
    /// A level in scaled value units.
    Level(f64),
    /// The largest value the files' integer sample type can store, times the value scale.
    Auto,
}

impl SaturationInput {
    /// Parse `auto` or a level in value units (the value of `--saturation`; the range is
    /// checked with the other values).
    pub fn parse(s: &str) -> Result<SaturationInput, String> {
        if s == "auto" {
            return Ok(SaturationInput::Auto);
        }
        s.parse()
            .map(SaturationInput::Level)
            .map_err(|e| format!("expected a level or 'auto': {e}"))
    }
}

/// Validity mask of a raw scanline (before any correction): 1 for a valid pixel, 0 for a pixel
/// with any bin at or above `level` (or not finite), whose profile is clipped.
pub fn saturation_mask(row_raw: &[f32], nx: usize, nt: usize, level: f32) -> Vec<u8> {
    debug_assert_eq!(row_raw.len(), nx * nt);
    if nt == 0 {
        return vec![1; nx];
    }
    row_raw
        .chunks_exact(nt)
        .map(|p| u8::from(p.iter().all(|v| v.is_finite() && *v < level)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saturation_mask_flags_exactly_the_clipped_pixels() {
        let (nx, nt, level) = (10usize, 8usize, 4095.0f32);
        let mut row: Vec<f32> = (0..nx * nt).map(|i| (i % 50) as f32 * 10.0).collect();
        row[2 * nt + 3] = 4095.0; // reaches the level
        row[5 * nt + 7] = 5000.0; // above
        row[7 * nt] = 4094.9; // just below: valid
        row[9 * nt + 1] = f32::NAN; // unreadable
        let mask = saturation_mask(&row, nx, nt, level);
        let want: Vec<u8> = (0..nx).map(|x| u8::from(![2, 5, 9].contains(&x))).collect();
        assert_eq!(mask, want);
    }

    #[test]
    fn levels_and_auto_parse() {
        assert_eq!(SaturationInput::parse("auto"), Ok(SaturationInput::Auto));
        assert_eq!(
            SaturationInput::parse("4095"),
            Ok(SaturationInput::Level(4095.0))
        );
        assert!(SaturationInput::parse("lots")
            .unwrap_err()
            .contains("expected a level or 'auto'"));
    }
}

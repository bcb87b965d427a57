//! Scanline times against the geometry: the trigger offset of each scanline, measured from
//! where the calibrated scene puts its direct light.
//!
//! A scanning streak capture triggers every scanline on its own, so each scanline's times
//! carry an offset `o(y)` (trigger jitter). `femto ingest` estimates it from the data alone
//! ([`crate::ingest::row_offsets`]): it compares each row with its neighbours and cannot tell
//! the slow part of the offsets (runs of rows late together) from the scene's own shape, so
//! that part stays, and a row whose own offset is small but whose neighbours' are large is
//! moved the wrong way.
//!
//! Once the camera, the mesh and `t0` are calibrated, the geometry predicts every pixel's
//! direct light absolutely (seed Eq. 1, [`super::temporal`]):
//! `t = t0 + time_scale * eta * path / c`. A row's direct-light samples then differ from the
//! prediction by its offset plus noise and model error, whatever the neighbouring rows do, so
//! [`scanline_offsets`] takes, per row, the median residual of its pixels and its standard
//! error (`1.2533 * 1.4826 MAD / sqrt(n)`), and keeps it where it exceeds
//! [`SIGNIFICANCE`] standard errors (the same gate as ingest's), over at least
//! [`MIN_PIXELS`] pixels. Each pixel's direct light is measured as the centroid of its profile
//! in a window the model places ([`super::temporal::direct_arrival_samples`]); a row several ps
//! late has part of its pulse outside that window, which pulls its centroid back, so
//! [`fit_scanline_offsets`] moves each row's windows by its current estimate and measures
//! again until the estimates settle.
//!
//! `femto unwarp` removes the offsets with the distances (`t_world = t_camera - o(y) -
//! eta |p - o| / c`). Measured on simulated `--realistic` captures of the `cube` scene at
//! 320 x 240 (2 ps rms jitter) against the manifest's truth: after ingest alone 1.17 ps rms,
//! 4.70 ps at most, 11 of 240 scanlines made worse by more than 1 ps; with these offsets too
//! 0.19 ps rms, 0.76 ps at most, none made worse (docs/ingest.md has the table).
//!
//! Rows with fewer than [`MIN_PIXELS`] pixels of direct light above the time fit's floor are
//! measured again at [`DIM_ROW_FLOOR`] of it; rows without direct light even then (the
//! laser's shadow) get no estimate and keep ingest's.

use super::temporal::ArrivalSample;
use crate::row_offset::RowOffset;
#[cfg(doc)]
use crate::row_offset::SIGNIFICANCE;
use crate::stats::{mad, median, MAD_TO_SIGMA, MEDIAN_SE_PER_SIGMA};
use crate::units::flight_time_ps;

/// Fewest direct-light pixels for a row to get an estimate.
pub const MIN_PIXELS: usize = 5;

/// Most measuring passes of [`fit_scanline_offsets`].
pub const MAX_PASSES: usize = 4;

/// [`fit_scanline_offsets`] stops once no row's estimate moves by more than this, ps.
pub const CONVERGED_PS: f64 = 0.01;

/// The time model the residuals are taken against: `t = t0_ps + time_scale * eta * path / c`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectTime {
    pub t0_ps: f64,
    pub time_scale: f64,
    pub eta: f64,
}

impl DirectTime {
    /// Cube time of the direct light over a path of `path_m` metres, ps.
    pub fn at_ps(&self, path_m: f64) -> f64 {
        self.t0_ps + self.time_scale * flight_time_ps(self.eta, path_m)
    }
}

/// Each of `ny` rows' offset from `samples` (module doc): the median of its samples' residuals
/// against `model`, with its standard error, applied where significant; `None` for a row with
/// fewer than [`MIN_PIXELS`] samples.
pub fn scanline_offsets(
    samples: &[ArrivalSample],
    model: &DirectTime,
    ny: usize,
) -> Vec<Option<RowOffset>> {
    let mut per_row: Vec<Vec<f64>> = vec![Vec::new(); ny];
    for s in samples.iter().filter(|s| s.y < ny) {
        let r = s.t_first_ps - model.at_ps(s.path_m);
        if r.is_finite() {
            per_row[s.y].push(r);
        }
    }
    per_row
        .into_iter()
        .map(|mut r| {
            if r.len() < MIN_PIXELS {
                return None;
            }
            let estimate = median(&mut r);
            // Standard error of a median of normal samples: 1.2533 sigma / sqrt(n), with sigma
            // from the MAD.
            let std_error =
                MEDIAN_SE_PER_SIGMA * MAD_TO_SIGMA * mad(&r, estimate) / (r.len() as f64).sqrt();
            Some(RowOffset::gated(estimate, std_error))
        })
        .collect()
}

/// [`scanline_offsets`] with each row's direct-light windows moved by its current estimate,
/// measured again until no estimate moves by [`CONVERGED_PS`] (at most [`MAX_PASSES`]).
/// `samples(shift_ps)` measures the direct light of every pixel with row `y`'s windows moved
/// by `shift_ps[y]` (ps; the caller reads the cube).
pub fn fit_scanline_offsets<E, F>(
    model: &DirectTime,
    ny: usize,
    mut samples: F,
) -> Result<Vec<Option<RowOffset>>, E>
where
    F: FnMut(&[f64]) -> Result<Vec<ArrivalSample>, E>,
{
    let mut shift_ps = vec![0.0; ny];
    let mut offsets = scanline_offsets(&samples(&shift_ps)?, model, ny);
    for _ in 1..MAX_PASSES {
        let next: Vec<f64> = offsets
            .iter()
            .map(|o| o.map_or(0.0, |o| o.estimate))
            .collect();
        let moved = next
            .iter()
            .zip(&shift_ps)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if moved < CONVERGED_PS {
            break;
        }
        shift_ps = next;
        offsets = scanline_offsets(&samples(&shift_ps)?, model, ny);
    }
    Ok(offsets)
}

/// Fraction of the time fit's detection floor at which the rows it leaves without an
/// estimate (too few pixels with direct light above the floor: dim rows) are measured again
/// ([`fill_missing`]). Only those rows: at this floor the pixels straddling an edge of the
/// scene enter too, and on a capture without jitter one such row (of 48) came out 1.5 ps
/// "late" beyond 4 standard errors, where at the full floor none did.
pub const DIM_ROW_FLOOR: f32 = 0.25;

/// Fill the rows of `offsets` without an estimate from `dim` (the same rows measured with a
/// lower floor, [`DIM_ROW_FLOOR`]).
pub fn fill_missing(offsets: &mut [Option<RowOffset>], dim: &[Option<RowOffset>]) {
    for (o, d) in offsets.iter_mut().zip(dim) {
        if o.is_none() {
            *o = *d;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::row_offset::applied_ps;

    const MODEL: DirectTime = DirectTime {
        t0_ps: 10.0,
        time_scale: 1.0,
        eta: 1.0,
    };

    /// Samples of `ny` rows, `per_row` pixels each, with row `y` late by `offset(y)` and a
    /// deterministic spread of +-0.5 ps.
    fn samples(ny: usize, per_row: usize, offset: impl Fn(usize) -> f64) -> Vec<ArrivalSample> {
        let mut out = Vec::new();
        for y in 0..ny {
            for x in 0..per_row {
                let path_m = 0.5 + 0.01 * x as f64;
                let spread = ((x * 7 + y * 3) % 11) as f64 / 10.0 - 0.5;
                out.push(ArrivalSample {
                    x,
                    y,
                    t_first_ps: MODEL.at_ps(path_m) + offset(y) + spread,
                    path_m,
                });
            }
        }
        out
    }

    #[test]
    fn each_row_gets_its_own_offset_whatever_its_neighbours_do() {
        // A slow drift that a row-to-row estimate cannot see, plus one glitched row.
        let offset = |y: usize| 0.5 * y as f64 + if y == 3 { -4.0 } else { 0.0 };
        let found = scanline_offsets(&samples(8, 40, offset), &MODEL, 8);
        for (y, o) in found.iter().enumerate() {
            let o = o.expect("estimated");
            assert!((o.estimate - offset(y)).abs() < 0.1, "row {y}: {o:?}");
            assert!(o.std_error > 0.0 && o.std_error < 0.1, "row {y}: {o:?}");
        }
        // Row 0 is on time: not significant, nothing applied.
        assert_eq!(found[0].unwrap().applied, 0.0);
        assert!((found[3].unwrap().applied + 2.5).abs() < 0.1);
    }

    #[test]
    fn rows_with_too_few_pixels_are_not_estimated() {
        let mut s = samples(3, 40, |_| 1.0);
        s.retain(|a| a.y != 1 || a.x < MIN_PIXELS - 1);
        let found = scanline_offsets(&s, &MODEL, 4);
        assert!(found[0].is_some() && found[2].is_some());
        assert!(found[1].is_none() && found[3].is_none());
        assert!(applied_ps(&found)[1].is_nan());
    }

    #[test]
    fn dim_rows_fill_only_the_rows_left_without_an_estimate() {
        let o = |e: f64| {
            Some(RowOffset {
                estimate: e,
                std_error: 0.1,
                applied: e,
            })
        };
        let mut first = vec![o(1.0), None, o(2.0)];
        fill_missing(&mut first, &[o(9.0), o(3.0), None]);
        assert_eq!(first, vec![o(1.0), o(3.0), o(2.0)]);
    }

    #[test]
    fn windows_follow_the_estimates_until_they_settle() {
        // A measurement that sees only half of a row's true offset unless its window is
        // moved by it: the passes converge on the truth.
        let truth = [3.0, -2.0, 0.0];
        let mut passes = 0;
        let found = fit_scanline_offsets::<(), _>(&MODEL, 3, |shift| {
            passes += 1;
            Ok(samples(3, 40, |y| shift[y] + 0.5 * (truth[y] - shift[y])))
        })
        .unwrap();
        for (y, t) in truth.iter().enumerate() {
            assert!((found[y].unwrap().estimate - t).abs() < 0.2, "row {y}");
        }
        assert!(passes <= MAX_PASSES);
    }
}

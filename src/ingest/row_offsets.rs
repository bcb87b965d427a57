//! Per-scanline offsets that the scene cannot explain: trigger jitter (a time shift of the
//! whole scanline) and laser power (a gain of the whole scanline), estimated from per-pixel
//! measurements of every scanline.
//!
//! A scanning streak capture records scanline `y` at its own trigger and laser pulse, so a
//! per-pixel measurement `v(x, y)` (the leading-edge time of the pixel's pulse, or the log of
//! its time integral) is the scene's value `g(x, y)` plus an offset `o(y)` common to the row:
//! the jitter in ps, or the log of the laser power. Neighbouring scanlines see neighbouring
//! points of the scene, so `g` changes little from one row to the next except across the edge
//! of an object. [`estimate_row_offsets`] predicts each pixel from the same pixel in the rows
//! next to it and takes, for each row, the median over its pixels of the measured minus the
//! predicted value:
//!
//! - three predictions per pixel: from the two rows around it (`(v(y-1) + v(y+1)) / 2`), and
//!   by linear extrapolation from the two rows on either side (`2 v(y-1) - v(y-2)`,
//!   `2 v(y+1) - v(y+2)`). Where the two extrapolations agree (within 5 times their median
//!   disagreement over the capture) the scene is smooth through the pixel and the two-sided
//!   prediction is used; where they do not, an edge of the scene runs next to the pixel, and
//!   the extrapolation closer to the measured value (the side the pixel belongs to) is used;
//! - the median over the row's pixels ignores the pixels that no prediction explains (the
//!   edge runs through them, or their pulse is too weak to measure);
//! - the neighbours' own offsets spoil the predictions, so the estimate is repeated with the
//!   neighbours corrected by the previous estimate (a fixed number of times).
//!
//! What cannot be recovered: an offset that changes linearly over a few rows looks exactly
//! like a tilted scene, so the estimates lose the slow part of the fluctuations (they are
//! reported relative to their median row). A row-level estimate that fits the rows' mean
//! fronts or totals to a smooth curve (`corrections::estimate_jitter`) fails on scenes with a
//! horizontal edge, where every pixel of the row jumps at once; this per-pixel estimate does
//! not, as long as the edge leaves a side to predict from.

use crate::cube::TimeAxis;

/// Fraction of the row's reference (90th-percentile) pulse height, or integral, below which a
/// pixel is not measured.
const MIN_RELATIVE_SIGNAL: f64 = 0.2;

/// Disagreement between a pixel's two one-sided predictions, in units of its median over the
/// capture, above which an edge of the scene is taken to run between them.
const EDGE_DISAGREEMENT: f64 = 5.0;

/// How [`estimate_row_offsets`] runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowOffsetFit {
    /// Estimates, each with the neighbours corrected by the previous one.
    pub iterations: usize,
    /// Fewest measured pixels for a row to get an estimate (others get 0 / `None`).
    pub min_pixels: usize,
}

impl Default for RowOffsetFit {
    /// 6 iterations, at least 3 pixels.
    fn default() -> Self {
        RowOffsetFit {
            iterations: 6,
            min_pixels: 3,
        }
    }
}

/// The value at `q` (0..=1) of `values` (reordered), nearest rank.
fn quantile(values: &mut [f64], q: f64) -> f64 {
    let k = ((values.len() - 1) as f64 * q).round() as usize;
    let (_, v, _) = values.select_nth_unstable_by(k, f64::total_cmp);
    *v
}

fn median(values: &mut [f64]) -> f64 {
    let n = values.len();
    values.sort_by(f64::total_cmp);
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// Leading-edge time (ps) of each pixel's pulse in a scanline (`[x][t]` on `axis`):
/// where the rise before the highest bin crosses half of the peak height above the profile's
/// median, interpolated between bin centres. `None` for pixels whose pulse height is below a
/// fifth of the row's 90th-percentile height, or whose rise cannot be measured.
pub fn pixel_leading_edges(row: &[f32], nx: usize, axis: &TimeAxis) -> Vec<Option<f64>> {
    let nt = axis.nt;
    debug_assert_eq!(row.len(), nx * nt);
    if nx == 0 || nt < 2 {
        return vec![None; nx];
    }
    let mut scratch: Vec<f32> = Vec::with_capacity(nt);
    let stats: Vec<(f64, f64, usize)> = row
        .chunks_exact(nt)
        .map(|p| {
            scratch.clear();
            scratch.extend(p.iter().copied().filter(|v| v.is_finite()));
            if scratch.is_empty() {
                return (0.0, 0.0, 0);
            }
            let mid = scratch.len() / 2;
            let (_, &mut base, _) = scratch.select_nth_unstable_by(mid, f32::total_cmp);
            let (k, &peak) = p
                .iter()
                .enumerate()
                .filter(|(_, v)| v.is_finite())
                .max_by(|a, b| a.1.total_cmp(b.1))
                .expect("a finite value");
            (base as f64, (peak - base) as f64, k)
        })
        .collect();
    let mut heights: Vec<f64> = stats.iter().map(|s| s.1).collect();
    let reference = quantile(&mut heights, 0.9);
    if !(reference > 0.0) {
        return vec![None; nx];
    }
    row.chunks_exact(nt)
        .zip(&stats)
        .map(|(p, &(base, height, peak))| {
            if height < MIN_RELATIVE_SIGNAL * reference {
                return None;
            }
            let half = base + 0.5 * height;
            let below = (0..peak).rev().find(|&i| (p[i] as f64) < half)?;
            let (a, b) = (p[below] as f64, p[below + 1] as f64);
            let frac = (half - a) / (b - a);
            frac.is_finite()
                .then(|| axis.bin_centre_ps(below) + frac * axis.dt_ps)
        })
        .collect()
}

/// Natural log of each pixel's time integral in a scanline (`[x][t]`, `nt` bins); `None`
/// for pixels whose integral is below a fifth of the row's 90th-percentile integral (or not
/// positive).
pub fn pixel_log_integrals(row: &[f32], nx: usize, nt: usize) -> Vec<Option<f64>> {
    debug_assert_eq!(row.len(), nx * nt);
    if nx == 0 || nt == 0 {
        return vec![None; nx];
    }
    let sums: Vec<f64> = row
        .chunks_exact(nt)
        .map(|p| p.iter().filter(|v| v.is_finite()).map(|&v| v as f64).sum())
        .collect();
    let mut sorted = sums.clone();
    let reference = quantile(&mut sorted, 0.9);
    if !(reference > 0.0) {
        return vec![None; nx];
    }
    sums.iter()
        .map(|&s| (s >= MIN_RELATIVE_SIGNAL * reference && s > 0.0).then(|| s.ln()))
        .collect()
}

/// The offset common to each row of per-pixel measurements `values` (`ny x nx`, `[y][x]`,
/// `None` = not measured), relative to the median row (module doc). Rows with fewer than
/// `fit.min_pixels` predicted pixels get `None`.
pub fn estimate_row_offsets(
    values: &[Option<f64>],
    nx: usize,
    fit: &RowOffsetFit,
) -> Vec<Option<f64>> {
    let ny = if nx == 0 { 0 } else { values.len() / nx };
    let mut offsets = vec![0.0f64; ny];
    let mut known = vec![false; ny];
    // Per pixel: (measured, between, from above, from below).
    type Predictions = (f64, Option<f64>, Option<f64>, Option<f64>);
    let mut preds: Vec<Predictions> = Vec::with_capacity(nx);
    let mut residuals = Vec::with_capacity(nx);
    for _ in 0..fit.iterations.max(1) {
        let at = |y: isize, x: usize, offsets: &[f64]| -> Option<f64> {
            if y < 0 || y as usize >= ny {
                return None;
            }
            let y = y as usize;
            values[y * nx + x].map(|v| v - offsets[y])
        };
        // How much the two one-sided extrapolations disagree where the scene is smooth (from
        // the neighbours' offsets and noise): a robust scale over every pixel that has both.
        let mut disagreement: Vec<f64> = Vec::new();
        let mut all_preds: Vec<Vec<Predictions>> = Vec::with_capacity(ny);
        for y in 0..ny {
            preds.clear();
            let yi = y as isize;
            for x in 0..nx {
                let Some(v) = values[y * nx + x] else {
                    continue;
                };
                let (m2, m1, p1, p2) = (
                    at(yi - 2, x, &offsets),
                    at(yi - 1, x, &offsets),
                    at(yi + 1, x, &offsets),
                    at(yi + 2, x, &offsets),
                );
                let between = m1.zip(p1).map(|(a, b)| 0.5 * (a + b));
                let above = m1.zip(m2).map(|(a, b)| 2.0 * a - b);
                let below = p1.zip(p2).map(|(a, b)| 2.0 * a - b);
                if let (Some(a), Some(b)) = (above, below) {
                    disagreement.push((a - b).abs());
                }
                preds.push((v, between, above, below));
            }
            all_preds.push(preds.clone());
        }
        // Disagreement beyond this is an edge of the scene between the two sides.
        let edge = if disagreement.is_empty() {
            f64::INFINITY
        } else {
            EDGE_DISAGREEMENT * median(&mut disagreement)
        };
        let mut next = vec![0.0f64; ny];
        for (y, row_preds) in all_preds.iter().enumerate() {
            residuals.clear();
            for &(v, between, above, below) in row_preds {
                let prediction = match (between, above, below) {
                    // Smooth through the pixel: the two-sided prediction, the most precise.
                    (Some(m), Some(a), Some(b)) if (a - b).abs() <= edge => Some(m),
                    // An edge: the side the pixel belongs to, the one that explains it best.
                    (_, Some(a), Some(b)) => {
                        Some(if (v - a).abs() <= (v - b).abs() { a } else { b })
                    }
                    (Some(m), _, _) => Some(m),
                    (None, a, b) => a.or(b),
                };
                if let Some(p) = prediction {
                    residuals.push(v - p);
                }
            }
            known[y] = residuals.len() >= fit.min_pixels.max(1);
            if known[y] {
                next[y] = median(&mut residuals);
            }
        }
        offsets = next;
    }
    let mut present: Vec<f64> = (0..ny).filter(|&y| known[y]).map(|y| offsets[y]).collect();
    if present.is_empty() {
        return vec![None; ny];
    }
    let centre = median(&mut present);
    (0..ny)
        .map(|y| known[y].then(|| offsets[y] - centre))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use rand_pcg::Pcg64;

    fn rms(v: &[f64]) -> f64 {
        (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt()
    }

    /// Offsets relative to their median, as the estimate reports them.
    fn centred(v: &[f64]) -> Vec<f64> {
        let mut s = v.to_vec();
        let m = median(&mut s);
        v.iter().map(|x| x - m).collect()
    }

    /// A scene of per-pixel values: a smooth wall (curving in x and y), a horizontal edge
    /// where every pixel jumps (wall to floor), and an object covering a block of pixels.
    fn scene(x: usize, y: usize) -> f64 {
        let (xf, yf) = (x as f64, y as f64);
        let mut g = 100.0 + 0.8 * xf + 0.02 * (xf - 20.0).powi(2) + 0.015 * (yf - 30.0).powi(2);
        if y >= 40 {
            g -= 45.0 - 0.5 * (yf - 40.0); // the floor: much earlier, rising again
        }
        if (10..18).contains(&x) && (20..34).contains(&y) {
            g = 30.0 + 0.3 * yf; // an object in front
        }
        g
    }

    #[test]
    fn offsets_are_recovered_across_edges_of_the_scene() {
        let (nx, ny) = (32usize, 64usize);
        let mut rng = Pcg64::seed_from_u64(9);
        let jitter = Normal::new(0.0, 2.0).unwrap();
        let noise = Normal::new(0.0, 0.3).unwrap();
        let mut truth: Vec<f64> = (0..ny).map(|_| jitter.sample(&mut rng)).collect();
        truth[25] = 9.0; // a glitch inside the object's rows
        let mut values: Vec<Option<f64>> = Vec::with_capacity(nx * ny);
        for (y, o) in truth.iter().enumerate() {
            for x in 0..nx {
                // A few pixels with no pulse.
                let dead = (x * 7 + y * 3) % 23 == 0;
                values.push((!dead).then(|| scene(x, y) + o + noise.sample(&mut rng)));
            }
        }
        let est = estimate_row_offsets(&values, nx, &RowOffsetFit::default());
        let est: Vec<f64> = est.iter().map(|e| e.expect("every row measured")).collect();
        let want = centred(&truth);
        let err: Vec<f64> = (0..ny).map(|y| est[y] - want[y]).collect();
        eprintln!(
            "row offsets: true {:.2} rms, error {:.2} rms, {:.2} worst",
            rms(&want),
            rms(&err),
            err.iter().fold(0.0f64, |m, e| m.max(e.abs()))
        );
        // Tolerance: a third of the fluctuation's spread (the slow part is not observable).
        assert!(
            rms(&err) < 0.35 * rms(&want),
            "{} vs {}",
            rms(&err),
            rms(&want)
        );
        assert!((est[25] - want[25]).abs() < 1.5, "glitch {}", est[25]);

        // The same scene with no offsets: the edges are not mistaken for offsets.
        let clean: Vec<Option<f64>> = (0..ny * nx).map(|i| Some(scene(i % nx, i / nx))).collect();
        let est = estimate_row_offsets(&clean, nx, &RowOffsetFit::default());
        let worst = est.iter().fold(0.0f64, |m, e| m.max(e.unwrap().abs()));
        eprintln!("row offsets of a clean scene: worst {worst:.3}");
        assert!(worst < 0.05, "{worst}");
    }

    #[test]
    fn leading_edges_and_log_integrals_follow_shifts_and_gains() {
        let axis = TimeAxis {
            t0_ps: 0.0,
            dt_ps: 2.0,
            nt: 64,
        };
        let (nx, nt) = (6usize, 64usize);
        // A triangle pulse starting at bin 20 + x / 2, peak 10 + x, on a baseline of 1.
        let row = |shift_bins: usize, gain: f32| -> Vec<f32> {
            let mut r = vec![1.0f32; nx * nt];
            for x in 0..nx {
                let start = 20 + x / 2 + shift_bins;
                for k in 0..8 {
                    let h = if k < 4 { k + 1 } else { 8 - k } as f32;
                    r[x * nt + start + k] += gain * h * (10.0 + x as f32) / 4.0;
                }
            }
            if gain < 1.0 {
                r[..nt].iter_mut().for_each(|v| *v = 0.0); // pixel 0 dark
            }
            r
        };
        let e0 = pixel_leading_edges(&row(0, 1.0), nx, &axis);
        let e3 = pixel_leading_edges(&row(3, 1.0), nx, &axis);
        for x in 0..nx {
            // The half-height crossing: between the rise's bins, a whole-bin shift moves it
            // by exactly 3 bins.
            let (a, b) = (e0[x].unwrap(), e3[x].unwrap());
            assert!((b - a - 6.0).abs() < 1e-9, "pixel {x}: {a} -> {b}");
            // The rise is 1/4, 2/4, 3/4, 1 of the peak: half height is reached exactly at the
            // centre of bin start + 1.
            let start = 20 + x / 2;
            assert!(
                (a - axis.bin_centre_ps(start + 1)).abs() < 1e-9,
                "pixel {x}: {a}"
            );
        }
        let l1 = pixel_log_integrals(&row(0, 1.0), nx, nt);
        let l2 = pixel_log_integrals(&row(0, 0.5), nx, nt);
        assert_eq!(l2[0], None);
        for x in 1..nx {
            // The gain scales the pulse, not the baseline of 1 per bin.
            let pulse = 20.0 * (10.0 + x as f64) / 4.0;
            let want = ((nt as f64 + 0.5 * pulse) / (nt as f64 + pulse)).ln();
            assert!((l2[x].unwrap() - l1[x].unwrap() - want).abs() < 1e-6);
        }
    }
}

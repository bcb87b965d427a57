//! What the row-offset corrections did, in words: how many scanlines were corrected, by how
//! much and how surely, which ones could not be estimated, and (for a simulated capture whose
//! manifest records the true jitter or laser power) how far the result is from the truth.
//! `femto ingest` prints these lines and the cube keeps them as provenance notes.

use crate::row_offset::{RowOffset, SIGNIFICANCE};
use crate::stats::median;

/// Most scanlines named one per line as not estimated; the rest are counted.
const MOST_NAMED: usize = 8;

/// The truth a simulated capture's manifest records for the row offsets.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RowTruth {
    /// True trigger delay of each scanline, ps.
    pub jitter_shifts_ps: Option<Vec<f64>>,
    /// True laser power factor of each scanline.
    pub power_factors: Option<Vec<f64>>,
}

/// The report of one correction: a summary, a comparison with the truth, and one line per
/// scanline not estimated.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OffsetReport {
    pub summary: String,
    pub truth: Option<String>,
    pub not_estimated: Vec<String>,
}

impl OffsetReport {
    /// Every line, summary first.
    pub fn lines(&self) -> Vec<String> {
        let mut v = vec![self.summary.clone()];
        v.extend(self.truth.clone());
        v.extend(self.not_estimated.iter().cloned());
        v
    }
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|e| e * e).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, e| m.max(e.abs()))
}

/// `v` less its median.
fn centred(v: &[f64]) -> Vec<f64> {
    let m = median(&mut v.to_vec());
    v.iter().map(|e| e - m).collect()
}

/// Scanline-to-scanline error: the rms of the differences of consecutive rows over sqrt 2
/// (the rms itself for independent rows; blind to a slow drift).
fn row_to_row(v: &[f64]) -> f64 {
    let d: Vec<f64> = v.windows(2).map(|p| p[1] - p[0]).collect();
    rms(&d) / std::f64::consts::SQRT_2
}

/// Width (standard deviation, rows) of the Gaussian smoothing that takes the slow part out of
/// a residual: offsets slower than this the stencil barely sees ([`super`]).
const SLOW_ROWS: f64 = 3.0;

/// `v` less its Gaussian smoothing over [`SLOW_ROWS`] rows (weights renormalised at the
/// ends): the row-to-row part, what shows as a ragged front in the cube.
fn fast_part(v: &[f64]) -> Vec<f64> {
    let reach = (3.0 * SLOW_ROWS).ceil() as usize;
    if v.is_empty() {
        return vec![];
    }
    (0..v.len())
        .map(|y| {
            let (lo, hi) = (y.saturating_sub(reach), (y + reach).min(v.len() - 1));
            let (mut sum, mut norm) = (0.0, 0.0);
            for (k, vk) in v.iter().enumerate().take(hi + 1).skip(lo) {
                let w = (-0.5 * ((k as f64 - y as f64) / SLOW_ROWS).powi(2)).exp();
                sum += w * vk;
                norm += w;
            }
            v[y] - sum / norm
        })
        .collect()
}

/// Pearson correlation of `a` and `b` (`None` when either is constant).
fn correlation(a: &[f64], b: &[f64]) -> Option<f64> {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    (saa > 0.0 && sbb > 0.0).then(|| sab / (saa * sbb).sqrt())
}

/// The lines naming the scanlines not estimated.
fn not_estimated(offsets: &[Option<RowOffset>]) -> Vec<String> {
    let missing: Vec<usize> = (0..offsets.len())
        .filter(|&y| offsets[y].is_none())
        .collect();
    if missing.len() == offsets.len() && !offsets.is_empty() {
        return vec![];
    }
    let mut lines: Vec<String> = missing
        .iter()
        .take(MOST_NAMED)
        .map(|y| format!("scanline {y}: not estimated, too little signal"))
        .collect();
    if missing.len() > MOST_NAMED {
        lines.push(format!(
            "... and {} more scanlines not estimated (too little signal)",
            missing.len() - MOST_NAMED
        ));
    }
    lines
}

/// How many rows were applied, estimated, and the applied row with the largest offset.
fn counts(offsets: &[Option<RowOffset>]) -> (usize, usize, Option<RowOffset>, f64) {
    let estimated: Vec<RowOffset> = offsets.iter().flatten().copied().collect();
    let applied: Vec<&RowOffset> = estimated.iter().filter(|o| o.applied != 0.0).collect();
    let largest = applied
        .iter()
        .max_by(|a, b| a.applied.abs().total_cmp(&b.applied.abs()))
        .map(|o| **o);
    let mut se: Vec<f64> = estimated.iter().map(|o| o.std_error).collect();
    let median_se = if se.is_empty() {
        f64::NAN
    } else {
        median(&mut se)
    };
    (applied.len(), estimated.len(), largest, median_se)
}

/// The report of trigger-jitter removal (`offsets` in ps); `truth`: the true delays.
pub fn jitter_report(offsets: &[Option<RowOffset>], truth: Option<&[f64]>) -> OffsetReport {
    let ny = offsets.len();
    let (applied, estimated, largest, se) = counts(offsets);
    let summary = if estimated == 0 {
        format!("jitter: not estimated, too little signal (no scanline of {ny} has a pulse in enough pixels)")
    } else {
        let largest = largest.map_or(String::new(), |o| {
            format!(" (largest {:.2} +- {:.2} ps)", o.applied, o.std_error)
        });
        format!(
            "jitter: {applied} of {ny} scanlines shifted{largest}; {estimated} estimated, median \
             standard error {se:.2} ps; a shift is applied above {} standard errors",
            SIGNIFICANCE
        )
    };
    let truth = truth.filter(|t| t.len() == ny).map(|t| {
        let removed: Vec<f64> = offsets
            .iter()
            .map(|o| o.map_or(0.0, |o| o.applied))
            .collect();
        jitter_truth_line("jitter against the manifest's truth", t, &removed)
    });
    OffsetReport {
        summary,
        truth,
        not_estimated: not_estimated(offsets),
    }
}

/// `prefix: rms .. before; .. after (..)`: the true scanline delays `truth` against what is
/// left of them once `removed` is taken off, each less its median (a common delay is `t0`'s).
fn jitter_truth_line(prefix: &str, t: &[f64], removed: &[f64]) -> String {
    {
        let before = centred(t);
        let after = centred(
            &t.iter()
                .zip(removed)
                .map(|(t, r)| t - r)
                .collect::<Vec<_>>(),
        );
        let over = after.iter().filter(|e| e.abs() > 2.0).count();
        let worse = before
            .iter()
            .zip(&after)
            .filter(|(b, a)| a.abs() > b.abs() + 1.0)
            .count();
        let (fb, fa) = (fast_part(&before), fast_part(&after));
        format!(
            "{prefix}: rms {:.2} ps, max {:.2} ps before; rms {:.2} \
             ps, max {:.2} ps after ({over} scanlines more than 2 ps off, {worse} made worse by \
             more than 1 ps); row-to-row part (less a {SLOW_ROWS}-row smoothing): rms {:.2} ps, \
             max {:.2} ps before; rms {:.2} ps, max {:.2} ps after",
            rms(&before),
            max_abs(&before),
            rms(&after),
            max_abs(&after),
            rms(&fb),
            max_abs(&fb),
            rms(&fa),
            max_abs(&fa)
        )
    }
}

/// The report of the scanline times `femto calibrate` measures against the geometry
/// ([`crate::calibrate::scanline_time`]; `offsets` in ps). `truth`: a simulated capture's true
/// delays and the shifts ingest already removed, both per scanline.
pub fn scanline_report(
    offsets: &[Option<RowOffset>],
    truth: Option<(&[f64], &[f64])>,
) -> OffsetReport {
    let ny = offsets.len();
    let (applied, estimated, largest, se) = counts(offsets);
    let summary = if estimated == 0 {
        format!(
            "scanline times: not estimated (no scanline of {ny} has direct light in enough pixels)"
        )
    } else {
        let largest = largest.map_or(String::new(), |o| {
            format!(" (largest {:.2} +- {:.2} ps)", o.applied, o.std_error)
        });
        format!(
            "scanline times against the geometry: {applied} of {ny} scanlines late or early \
             beyond {} standard errors{largest}; {estimated} estimated, median standard error \
             {se:.2} ps; femto unwarp removes them",
            SIGNIFICANCE
        )
    };
    let truth = truth
        .filter(|(t, i)| t.len() == ny && i.len() == ny)
        .map(|(t, ingest)| {
            let removed: Vec<f64> = offsets
                .iter()
                .zip(ingest)
                .map(|(o, i)| i + o.map_or(0.0, |o| o.applied))
                .collect();
            jitter_truth_line(
                "jitter against the manifest's truth, ingest's shifts and these together",
                t,
                &removed,
            )
        });
    OffsetReport {
        summary,
        truth,
        not_estimated: vec![],
    }
}

/// The report of automatic laser power normalisation (`offsets`: log gains); `truth`: the
/// true power factors.
pub fn power_report(offsets: &[Option<RowOffset>], truth: Option<&[f64]>) -> OffsetReport {
    let ny = offsets.len();
    let (applied, estimated, largest, se) = counts(offsets);
    let summary = if estimated == 0 {
        format!("power: not estimated, too little signal (no scanline of {ny} has enough lit pixels); scanlines masked")
    } else {
        let largest = largest.map_or(String::new(), |o| {
            format!(
                " (largest {:+.2} +- {:.2} %)",
                100.0 * o.applied.exp_m1(),
                100.0 * o.std_error
            )
        });
        format!(
            "power: {applied} of {ny} scanlines normalised{largest}; {estimated} estimated, \
             median standard error {:.2} %; a gain is applied above {} standard errors",
            100.0 * se,
            SIGNIFICANCE
        )
    };
    let truth = truth
        .filter(|t| t.len() == ny && t.iter().all(|f| *f > 0.0))
        .map(|t| {
            let log_t: Vec<f64> = t.iter().map(|f| f.ln()).collect();
            let removed: Vec<f64> = offsets
                .iter()
                .map(|o| o.map_or(0.0, |o| o.applied))
                .collect();
            let before = centred(&log_t);
            let after = centred(
                &log_t
                    .iter()
                    .zip(&removed)
                    .map(|(t, r)| t - r)
                    .collect::<Vec<_>>(),
            );
            let corr = correlation(&removed, &log_t)
                .map_or("none (nothing applied)".to_string(), |c| format!("{c:.2}"));
            format!(
                "power against the manifest's truth: correlation of the gains with it {corr}; \
             scanline-to-scanline error {:.2} % before, {:.2} % after (rms {:.2} % -> {:.2} %)",
                100.0 * row_to_row(&before),
                100.0 * row_to_row(&after),
                100.0 * rms(&before),
                100.0 * rms(&after)
            )
        });
    OffsetReport {
        summary,
        truth,
        not_estimated: not_estimated(offsets),
    }
}

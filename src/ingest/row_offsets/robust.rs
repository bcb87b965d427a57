//! Step 3 of [`super`]: the offsets that explain the rows' residuals, under a heavy-tailed
//! prior, so that white jitter on every row and a few large glitches on otherwise quiet rows
//! are both found, and a significance test per row.
//!
//! Each row `i` has one equation, `r_i = sum_y c_iy o_y + noise`, of variance `s2_i` (the
//! standard error of its median residual) plus `model_s2_i` (the scene model's error there:
//! how far the row's other prediction windows miss). The offsets minimise
//! `sum_i rho(r_i - (A o)_i) / var_i + sum_y alpha_y o_y^2`, with Huber's `rho` (threshold
//! `huber_k` standard errors) and a Student-t prior of `prior_dof` degrees of freedom (2 for jitter; infinite, a
//! Gaussian, for laser power, which drifts but does not jump) and scale
//! `sigma` on each offset, by iterative re-weighting: `alpha_y = (nu + 1) / (nu sigma^2 +
//! o_y^2)`. A Gaussian prior (Tikhonov) of the spread `sigma` shrinks a lone 12 ps glitch to
//! nothing when most rows are quiet (`sigma`, estimated by moments, is then near 0); the
//! t-prior's precision falls as `1 / o^2`, so a large offset that the data call for keeps
//! its size, while offsets of the size of the noise are pulled to zero. `sigma^2` is the
//! moment estimate `E r^2 = gain sigma^2 + var` (a median over rows, robust to glitches),
//! at least the median squared standard error. The iteration starts from a weak prior (the
//! largest `r^2`), so that the data, not the start, decide which rows carry offsets.
//!
//! Each row's standard error is that of its offset with its neighbours' at their estimates:
//! `1 / sqrt(H_yy)`, `H = A^T W A` (it leaves out the slow offsets no row tells from the
//! scene, see [`super`]). An offset is applied only where it exceeds [`SIGNIFICANCE`](crate::row_offset::SIGNIFICANCE) of
//! them. The normal equations are banded and solved in `O(ny)` ([`super::solve_banded`]).

use super::{solve_banded, RowOffsetFit, BAND};
use crate::stats::median;

/// Median of `|z|` for a standard normal `z`, squared: the median of a chi-square with one
/// degree of freedom (0.4549), for the moment estimate of `sigma`.
const MEDIAN_CHI2_1: f64 = 0.454_936_4;

/// One row's equation: `r = sum coeffs.1 * o[coeffs.0]`, variance `s2 + model_s2`.
#[derive(Clone, Copy, Debug)]
pub struct Equation {
    pub coeffs: [(usize, f64); 5],
    pub r: f64,
    /// Squared standard error of `r` from the pixels' spread.
    pub s2: f64,
    /// Variance of the scene model at this row (0 until known).
    pub model_s2: f64,
}

impl Equation {
    fn variance(&self) -> f64 {
        self.s2 + self.model_s2
    }

    /// `r - sum c o`.
    fn misfit(&self, offsets: &[f64]) -> f64 {
        self.r
            - self
                .coeffs
                .iter()
                .map(|&(i, c)| c * offsets[i])
                .sum::<f64>()
    }
}

/// Each row's offset and its standard error (`INFINITY` for a row no equation involves).
pub struct Solution {
    pub offsets: Vec<f64>,
    pub std_errors: Vec<f64>,
}

/// Banded least squares for the offsets: equations `eqs` with weights `weights`, prior
/// precision `prior[y]` on each row.
fn solve(eqs: &[Equation], weights: &[f64], prior: &[f64]) -> Vec<f64> {
    let ny = prior.len();
    let mut band = vec![0.0f64; ny * (BAND + 1)];
    let mut rhs = vec![0.0f64; ny];
    for (y, &p) in prior.iter().enumerate() {
        band[y * (BAND + 1) + BAND] = p;
    }
    for (e, &wt) in eqs.iter().zip(weights) {
        for &(i, ci) in &e.coeffs {
            rhs[i] += wt * ci * e.r;
            for &(j, cj) in e.coeffs.iter().filter(|(j, _)| *j <= i) {
                band[i * (BAND + 1) + (j + BAND - i)] += wt * ci * cj;
            }
        }
    }
    solve_banded(&mut band, &rhs)
}

/// `1 / sqrt(H_yy)` for each row under equation weights `weights`.
fn std_errors(eqs: &[Equation], weights: &[f64], ny: usize) -> Vec<f64> {
    let mut h = vec![0.0f64; ny];
    for (e, &w) in eqs.iter().zip(weights) {
        for &(i, c) in &e.coeffs {
            h[i] += w * c * c;
        }
    }
    h.iter()
        .map(|&h| {
            if h > 0.0 {
                h.sqrt().recip()
            } else {
                f64::INFINITY
            }
        })
        .collect()
}

/// The offsets of `ny` rows (module doc).
pub fn solve_robust(eqs: &[Equation], ny: usize, fit: &RowOffsetFit) -> Solution {
    let mut weights: Vec<f64> = eqs.iter().map(|e| 1.0 / e.variance()).collect();
    let se0 = std_errors(eqs, &weights, ny);
    let mut finite: Vec<f64> = se0.iter().copied().filter(|s| s.is_finite()).collect();
    let median_se2 = if finite.is_empty() {
        0.0
    } else {
        median(&mut finite).powi(2)
    };
    let mut moments: Vec<f64> = eqs
        .iter()
        .map(|e| {
            let gain: f64 = e.coeffs.iter().map(|(_, c)| c * c).sum();
            (e.r * e.r - e.variance()) / gain
        })
        .collect();
    let sigma2 = (median(&mut moments) / MEDIAN_CHI2_1)
        .max(median_se2)
        .max(f64::MIN_POSITIVE);
    let largest = eqs.iter().fold(sigma2, |m, e| m.max(e.r * e.r));
    let mut prior = vec![1.0 / largest; ny];
    let mut offsets = vec![0.0f64; ny];
    for _ in 0..fit.iterations.max(1) {
        offsets = solve(eqs, &weights, &prior);
        let nu = fit.prior_dof;
        for (p, o) in prior.iter_mut().zip(&offsets) {
            *p = if nu.is_finite() {
                (nu + 1.0) / (nu * sigma2 + o * o)
            } else {
                1.0 / sigma2
            };
        }
        for (e, w) in eqs.iter().zip(weights.iter_mut()) {
            let z = e.misfit(&offsets).abs() / e.variance().sqrt();
            *w = if z > fit.huber_k {
                fit.huber_k / z
            } else {
                1.0
            } / e.variance();
        }
    }
    Solution {
        std_errors: std_errors(eqs, &weights, ny),
        offsets,
    }
}

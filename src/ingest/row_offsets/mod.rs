//! Per-scanline offsets that the scene cannot explain: trigger jitter (a time shift of the
//! whole scanline) and laser power (a gain of the whole scanline), estimated from per-pixel
//! measurements of every scanline.
//!
//! A scanning streak capture records scanline `y` at its own trigger and laser pulse, so a
//! per-pixel measurement `v(x, y)` (the median arrival time of the pixel's pulse,
//! [`pixel_pulse_times`], or the log of its time integral, [`pixel_log_integrals`]) is the
//! scene's value `g(x, y)` plus an offset `o(y)` common to the row: the jitter in ps, or the
//! log of the laser power. Neighbouring scanlines see neighbouring points of the scene, so
//! `g` is smooth in `y` except across the edge of an object. [`estimate_row_offsets`]:
//!
//! 1. predicts each pixel from the same pixel in four other rows by the quadratic through
//!    them, evaluated at the row: `p(y) = sum_k w_k v(y + d_k)`, exact for a scene that
//!    curves quadratically with `y` (a plane seen in perspective, lit by a point: its arrival
//!    times nearly do), so the scene's curvature does not leak into the estimates. The four
//!    rows are those of a 5-row window holding the row: the centred one (two rows on each
//!    side) where it can be used. A pixel's window holds an edge of the scene when its four
//!    other rows are far from a quadratic (their third divided difference over 5 times its
//!    median over the capture); such pixels are left out. Where the centred window is clean
//!    for fewer than half of the row's pixels (a horizontal edge next to the row, where every
//!    pixel jumps at once), the row is predicted from the clean window whose residual is
//!    smallest: the side of the edge that the row belongs to;
//! 2. takes, for each row, the median `r(y)` over those pixels of `v - p` and its standard
//!    error `s(y)` (from the median absolute deviation). By linearity
//!    `r(y) = o(y) - sum_k w_k o(y + d_k) + noise`: a known linear operator `A` of the offsets;
//! 3. solves for the offsets that explain every `r` (`robust`): robust least squares with
//!    a heavy-tailed (Student-t) prior on each offset, so that white offsets on every row
//!    and a few large glitches on quiet rows are both found; a row whose prediction windows
//!    disagree given the solution (the scene is not quadratic there) gets that disagreement
//!    added to its variance and the offsets are solved for again. Each offset has a standard
//!    error (with its neighbours' at their estimates) and is applied only where it exceeds
//!    [`SIGNIFICANCE`] of them; rows with too few measured pixels are not estimated (`None`),
//!    and `report` says so.
//!
//! What cannot be recovered: `A` vanishes on offsets that are quadratic in `y`, and nearly
//! vanishes on slow ones, which look exactly like a curved scene. The estimates follow the
//! row-to-row (fast) part of the fluctuations and lose their slow part. Measured on the
//! simulator's `cube` scene (320 x 240 x 256 bins of 4 ps, 64 paths per pixel,
//! `--realistic`: 2 ps jitter, 3 % power), against the manifest's truth: jitter rms 2.07 ->
//! 1.14 ps, max 6.34 -> 2.97 ps (the slow part); its row-to-row part (less a 3-row
//! smoothing) 1.76 -> 0.49 ps rms, max 5.05 -> 1.88 ps; 211 of 240 rows shifted, none made
//! worse by more than 2 ps. Two glitches of 3 and 2 bins (4 ps) in the real confocal capture
//! `data/real/lct/data_s_u.mat`: 12.36 +- 0.38 and 7.86 +- 0.34 ps, no other row moved. With
//! no jitter: no row moved. Laser power (log integrals over each pixel's pulse, not over every
//! bin, whose noise swamped 3 % of power): the scene's pulse integrals still vary from row to
//! row about half as much as 3 % power does, so on the capture above 44 of the 240 rows are
//! significant (Gaussian prior, [`RowOffsetFit::gaussian`]): gains correlating 0.46 with the
//! truth, scanline-to-scanline error 3.09 % -> 2.42 % (over every bin: 0 rows, 3.09 % left);
//! a reference region (`PowerRef::Region`) is what normalises such a capture.
//!
//! The jitter left after the correction is its slow part, not an error that accumulates:
//! on the capture above, the 20 rows left more than 2 ps off and the 11 made worse by more
//! than 1 ps lie in runs of neighbouring rows whose true delays share a sign (rows 138-142,
//! 164-169, 210-211: a local mean of 1.5-2.5 ps, which the stencil takes for the scene), next
//! to the horizontal edge at rows 140-146, or at the dim bottom rows 233-239, whose pulses
//! barely clear the dark noise (standard errors 0.4-1.2 ps, not applied). The error after
//! correlates 0.79 with the truth smoothed over 3 rows; with the true scene known (pixels
//! chosen where its stencil residual is under 0.3 ps) the same stencil still leaves 23 rows
//! over 2 ps and 12 made worse, wider stencils (9 rows) 11 and 6 but 29 and 22 without that
//! knowledge (the edges), and no gate or clipping of the shifts by their posterior
//! uncertainty (0.8-0.9 ps) brings the rows made worse under 10.

mod report;
mod robust;

use crate::cube::TimeAxis;
pub use crate::row_offset::{RowOffset, SIGNIFICANCE};
use crate::stats::{median, median_and_variance, quantile};
pub use report::{jitter_report, power_report, scanline_report, OffsetReport, RowTruth};
use robust::{solve_robust, Equation};

/// Each row's centred window fit over every pixel, `None` with too few pixels.
type CentredFits = Vec<Option<WindowFit>>;
/// Fraction of the row's reference (90th-percentile) pulse height, or integral, below which a
/// pixel is not measured.
const MIN_RELATIVE_SIGNAL: f64 = 0.2;

/// A pixel's pulse extends, around its highest bin, while the profile stays above this
/// fraction of the pulse height (plus one bin on each side).
pub const PULSE_EXTENT: f64 = 0.1;

/// Bins added on each side of a pixel's pulse for its integral: the tails under
/// [`PULSE_EXTENT`] of the height, which a pulse moving across the bins from row to row would
/// otherwise cut by varying amounts.
pub const INTEGRAL_MARGIN: usize = 2;

/// A pixel's window is taken to hold an edge of the scene where its misfit, or the spread
/// of its windows' predictions, exceeds this many times the median over the capture.
const EDGE_FACTOR: f64 = 5.0;

/// Smallest standard error of a row's residual, as a fraction of the median residual.
const MODEL_FLOOR: f64 = 0.02;

/// Half-bandwidth of the normal equations: each row's stencil spans 5 consecutive rows, so
/// `A^T W A` couples rows at most 4 apart.
pub(crate) const BAND: usize = 4;

/// How [`estimate_row_offsets`] runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowOffsetFit {
    /// Re-weighted solutions (Huber weights of the equations, Student-t weights of the
    /// offsets).
    pub iterations: usize,
    /// Huber threshold: a row whose residual exceeds this many standard errors is
    /// down-weighted.
    pub huber_k: f64,
    /// Fewest measured pixels for a row to get an estimate (others get `None`).
    pub min_pixels: usize,
    /// Degrees of freedom of the Student-t prior on each offset: small for offsets that
    /// come as rare large glitches as well as white noise (trigger jitter), infinite for a
    /// Gaussian prior (laser power, which drifts but does not jump).
    pub prior_dof: f64,
}

impl RowOffsetFit {
    /// The fit for laser power: a Gaussian prior ([`RowOffsetFit::prior_dof`] infinite).
    pub fn gaussian() -> Self {
        RowOffsetFit {
            prior_dof: f64::INFINITY,
            ..RowOffsetFit::default()
        }
    }
}

impl Default for RowOffsetFit {
    /// 30 re-weightings, Huber threshold 2.5, at least 3 pixels, a Student-t prior of 2
    /// degrees of freedom.
    fn default() -> Self {
        RowOffsetFit {
            iterations: 30,
            huber_k: 2.5,
            min_pixels: 3,
            prior_dof: 2.0,
        }
    }
}

/// Each pixel's baseline (the median of its profile), pulse height above it and highest bin,
/// in a scanline (`[x][t]`, `nt` bins); `(0, 0, 0)` for a pixel with no finite value.
fn pulse_peaks(row: &[f32], nt: usize) -> Vec<(f64, f64, usize)> {
    let mut scratch: Vec<f32> = Vec::with_capacity(nt);
    row.chunks_exact(nt)
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
        .collect()
}

/// A measured pulse: the baseline, and the first and last bins of the pulse.
type Pulse = (f64, usize, usize);

/// The pixels of a scanline whose pulse is measured, each with its profile: `Some((base,
/// first, last))` (the baseline and the pulse's bins, [`pulse_extent`]) where the height is at
/// least [`MIN_RELATIVE_SIGNAL`] of the row's 90th-percentile height; all `None` when that
/// reference is not positive.
fn measured_pulses(row: &[f32], nx: usize, nt: usize) -> Vec<(&[f32], Option<Pulse>)> {
    let stats = pulse_peaks(row, nt);
    let mut heights: Vec<f64> = stats.iter().map(|s| s.1).collect();
    let reference = quantile(&mut heights, 0.9);
    let measured = !reference.is_nan() && reference > 0.0;
    row.chunks_exact(nt)
        .zip(stats)
        .map(|(p, (base, height, peak))| {
            let pulse = (measured && height >= MIN_RELATIVE_SIGNAL * reference).then(|| {
                let (lo, hi) = pulse_extent(p, base, height, peak);
                (base, lo, hi)
            });
            (p, pulse)
        })
        .take(nx)
        .collect()
}

/// The bins of a pixel's pulse (`p`, baseline `base`, height `height` at bin `peak`): the run
/// around the highest bin that stays above [`PULSE_EXTENT`] of the height over the baseline,
/// plus one bin on each side, as `(first, last)`.
fn pulse_extent(p: &[f32], base: f64, height: f64, peak: usize) -> (usize, usize) {
    let above = |i: usize| p[i] as f64 - base > PULSE_EXTENT * height;
    let mut lo = peak;
    while lo > 0 && above(lo - 1) {
        lo -= 1;
    }
    let mut hi = peak;
    while hi + 1 < p.len() && above(hi + 1) {
        hi += 1;
    }
    (lo.saturating_sub(1), (hi + 1).min(p.len() - 1))
}

/// Median arrival time (ps) of each pixel's pulse in a scanline (`[x][t]` on `axis`): the
/// pulse is the run of bins around the highest one that stay above a tenth of its height
/// over the profile's median (the baseline), plus one bin on each side; the time is where
/// the cumulative signal above the baseline over those bins reaches half its total, the
/// signal taken as uniform within each bin. A shift of the profile moves it by the shift.
/// `None` for pixels whose pulse height is below a fifth of the row's 90th-percentile
/// height, or with a non-finite value in the pulse.
pub fn pixel_pulse_times(row: &[f32], nx: usize, axis: &TimeAxis) -> Vec<Option<f64>> {
    let nt = axis.nt;
    debug_assert_eq!(row.len(), nx * nt);
    if nx == 0 || nt < 2 {
        return vec![None; nx];
    }
    measured_pulses(row, nx, nt)
        .into_iter()
        .map(|(p, pulse)| {
            let (base, lo, hi) = pulse?;
            let bins = &p[lo..=hi];
            if bins.iter().any(|v| !v.is_finite()) {
                return None;
            }
            let weight = |v: f32| (v as f64 - base).max(0.0);
            let total: f64 = bins.iter().map(|&v| weight(v)).sum();
            let half = 0.5 * total;
            let mut before = 0.0;
            for (i, &v) in bins.iter().enumerate() {
                let w = weight(v);
                if w > 0.0 && before + w >= half {
                    return Some(axis.bin_start_ps(lo + i) + (half - before) / w * axis.dt_ps);
                }
                before += w;
            }
            None
        })
        .collect()
}

/// Natural log of each pixel's pulse integral in a scanline (`[x][t]`, `nt` bins): the signal
/// above the baseline summed over the pulse's bins (those of [`pixel_pulse_times`], and
/// [`INTEGRAL_MARGIN`] more on each side), which a
/// laser power scales and a time shift keeps. Not the integral over every bin: that adds the
/// noise of all of them (on the simulator's realistic capture, 320 x 240 x 256 bins, the
/// pixels' log integrals scatter by 19 % about the truth over all bins, 6 % over the pulse).
/// `None` for pixels whose pulse height is below a fifth of the row's 90th-percentile
/// height, with a non-finite value in the pulse, or whose pulse integral is not positive.
pub fn pixel_log_integrals(row: &[f32], nx: usize, nt: usize) -> Vec<Option<f64>> {
    debug_assert_eq!(row.len(), nx * nt);
    if nx == 0 || nt < 2 {
        return vec![None; nx];
    }
    measured_pulses(row, nx, nt)
        .into_iter()
        .map(|(p, pulse)| {
            let (base, lo, hi) = pulse?;
            let (lo, hi) = (
                lo.saturating_sub(INTEGRAL_MARGIN),
                (hi + INTEGRAL_MARGIN).min(nt - 1),
            );
            let sum: f64 = p[lo..=hi].iter().map(|&v| v as f64 - base).sum();
            (sum.is_finite() && sum > 0.0).then(|| sum.ln())
        })
        .collect()
}

/// The first row of the centred prediction window of row `y` of `ny` (>= 5): two rows on
/// each side where there are.
fn centred_window(y: usize, ny: usize) -> usize {
    y.saturating_sub(2).min(ny - 5)
}

/// The prediction stencil of row `y` from the 5-row window starting at `first` (which holds
/// `y`): the four other rows and the weights of the least-squares quadratic through them,
/// evaluated at `y`.
fn stencil(y: usize, first: usize) -> ([usize; 4], [f64; 4]) {
    let mut rows = [0usize; 4];
    let mut n = 0;
    for r in first..first + 5 {
        if r != y {
            rows[n] = r;
            n += 1;
        }
    }
    debug_assert_eq!(n, 4);
    // w = e0^T (X^T X)^-1 X^T with X rows (1, d, d^2): the fitted value at d = 0.
    let d: [f64; 4] = rows.map(|r| r as f64 - y as f64);
    let mut m = [[0.0f64; 3]; 3];
    for &di in &d {
        let x = [1.0, di, di * di];
        for a in 0..3 {
            for b in 0..3 {
                m[a][b] += x[a] * x[b];
            }
        }
    }
    let inv = invert3(&m);
    let weights = d.map(|di| inv[0][0] + inv[0][1] * di + inv[0][2] * di * di);
    (rows, weights)
}

/// Inverse of a symmetric positive-definite 3x3 matrix (cofactors).
fn invert3(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let c =
        |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let cof = [
        [c(1, 2, 1, 2), -c(1, 2, 0, 2), c(1, 2, 0, 1)],
        [-c(0, 2, 1, 2), c(0, 2, 0, 2), -c(0, 2, 0, 1)],
        [c(0, 1, 1, 2), -c(0, 1, 0, 2), c(0, 1, 0, 1)],
    ];
    let det = m[0][0] * cof[0][0] + m[0][1] * cof[0][1] + m[0][2] * cof[0][2];
    let mut inv = [[0.0; 3]; 3];
    for (a, row) in inv.iter_mut().enumerate() {
        for (b, v) in row.iter_mut().enumerate() {
            *v = cof[b][a] / det;
        }
    }
    inv
}

/// Solve `M x = b` for a symmetric positive-definite `M` of half-bandwidth [`BAND`], stored
/// by rows as `band[i * (BAND + 1) + (j + BAND - i)]` for `i - BAND <= j <= i` (banded
/// Cholesky, `M = L L^T`). `band` is overwritten by `L`.
pub(crate) fn solve_banded(band: &mut [f64], b: &[f64]) -> Vec<f64> {
    let n = b.len();
    let w = BAND + 1;
    let at = |i: usize, j: usize| i * w + (j + BAND - i);
    for i in 0..n {
        let j0 = i.saturating_sub(BAND);
        for j in j0..=i {
            let mut sum = band[at(i, j)];
            for k in j0.max(j.saturating_sub(BAND))..j {
                sum -= band[at(i, k)] * band[at(j, k)];
            }
            band[at(i, j)] = if i == j {
                sum.max(f64::MIN_POSITIVE).sqrt()
            } else {
                sum / band[at(j, j)]
            };
        }
    }
    let mut x = b.to_vec();
    for i in 0..n {
        for k in i.saturating_sub(BAND)..i {
            x[i] -= band[at(i, k)] * x[k];
        }
        x[i] /= band[at(i, i)];
    }
    for i in (0..n).rev() {
        for k in i + 1..(i + BAND + 1).min(n) {
            x[i] -= band[at(k, i)] * x[k];
        }
        x[i] /= band[at(i, i)];
    }
    x
}

/// One row's prediction from one 5-row window: the stencil, the median residual `r` over the
/// row's pixels and its squared standard error `s2` (infinite when too few pixels).
#[derive(Clone, Copy, Debug)]
struct Window {
    rows: [usize; 4],
    weights: [f64; 4],
    r: f64,
    s2: f64,
}

impl Window {
    /// `(row, coefficient)` of the offsets in `r`: `o(y) - sum_k w_k o(rows_k)`.
    fn coeffs(&self, y: usize) -> [(usize, f64); 5] {
        let (rows, w) = (&self.rows, &self.weights);
        [
            (y, 1.0),
            (rows[0], -w[0]),
            (rows[1], -w[1]),
            (rows[2], -w[2]),
            (rows[3], -w[3]),
        ]
    }
}

/// Coefficients of the third divided difference at the offsets `d` (normalised to unit
/// length): zero on any quadratic, so `|c . v|` is how far four values are from lying on one.
fn cubic_misfit_coeffs(d: &[f64; 4]) -> [f64; 4] {
    let mut c = [0.0; 4];
    for k in 0..4 {
        c[k] = 1.0
            / (0..4)
                .filter(|&j| j != k)
                .map(|j| d[k] - d[j])
                .product::<f64>();
    }
    let norm = c.iter().map(|v| v * v).sum::<f64>().sqrt();
    c.map(|v| v / norm)
}

/// Every 5-row window holding each of `ny` rows, the centred one first, with the
/// coefficients of its four other rows' cubic misfit (steps 1 and 2 of the module doc).
fn candidate_windows(ny: usize) -> (Vec<Vec<Window>>, Vec<Vec<[f64; 4]>>) {
    let mut windows: Vec<Vec<Window>> = Vec::with_capacity(ny);
    let mut misfit_coeffs: Vec<Vec<[f64; 4]>> = Vec::with_capacity(ny);
    for y in 0..ny {
        let centred = centred_window(y, ny);
        let firsts = std::iter::once(centred)
            .chain((y.saturating_sub(4)..=y.min(ny - 5)).filter(|&f| f != centred));
        let (mut row_windows, mut row_coeffs) = (Vec::with_capacity(5), Vec::with_capacity(5));
        for first in firsts {
            let (rows, weights) = stencil(y, first);
            row_windows.push(Window {
                rows,
                weights,
                r: 0.0,
                s2: f64::INFINITY,
            });
            row_coeffs.push(cubic_misfit_coeffs(&rows.map(|r| r as f64 - y as f64)));
        }
        windows.push(row_windows);
        misfit_coeffs.push(row_coeffs);
    }
    (windows, misfit_coeffs)
}

/// Step 1 of the module doc over a capture: every row's candidate windows (the centred one
/// first) with their misfit coefficients, and the per-pixel measurements `values` (`ny x nx`,
/// `[y][x]`, `None` = not measured) they predict from.
struct Stencils<'a> {
    values: &'a [Option<f64>],
    nx: usize,
    windows: Vec<Vec<Window>>,
    misfit_coeffs: Vec<Vec<[f64; 4]>>,
}

/// Step 2 for one candidate window of one row: the median residual `r` over the pixels for
/// which the window is clean (for the centred window over every pixel: all of them), its
/// squared standard error `s2`, and how many pixels (`0`, with `s2` infinite, when fewer than
/// the fit's minimum).
#[derive(Clone, Copy, Debug)]
struct WindowFit {
    r: f64,
    s2: f64,
    pixels: usize,
}

/// The window chosen for a row (step 2): its index among the row's candidates, its median
/// residual and squared standard error.
type Chosen = Option<(usize, f64, f64)>;

impl<'a> Stencils<'a> {
    fn new(values: &'a [Option<f64>], nx: usize, ny: usize) -> Self {
        let (windows, misfit_coeffs) = candidate_windows(ny);
        Stencils {
            values,
            nx,
            windows,
            misfit_coeffs,
        }
    }

    fn ny(&self) -> usize {
        self.windows.len()
    }

    /// Pixel `(y, x)` against window `k` of its row: its residual and the signed third divided
    /// difference of the window's four other rows; NaN where a row is not measured.
    #[inline]
    fn pixel(&self, y: usize, x: usize, k: usize) -> (f64, f64) {
        let (values, nx) = (self.values, self.nx);
        let w = &self.windows[y][k];
        let Some(v) = values[y * nx + x] else {
            return (f64::NAN, f64::NAN);
        };
        let (mut p, mut m) = (0.0, 0.0);
        for ((&ry, &wk), &ck) in w.rows.iter().zip(&w.weights).zip(&self.misfit_coeffs[y][k]) {
            let Some(u) = values[ry * nx + x] else {
                return (f64::NAN, f64::NAN);
            };
            p += wk * u;
            m += ck * u;
        }
        (v - p, m)
    }

    /// [`Stencils::pixel`] with the misfit's magnitude.
    #[inline]
    fn misfit(&self, y: usize, x: usize, k: usize) -> (f64, f64) {
        let (e, m) = self.pixel(y, x, k);
        (e, m.abs())
    }

    /// Step 1's edge test: a pixel's window holds an edge of the scene where its misfit exceeds
    /// [`EDGE_FACTOR`] times the median over every pixel and window. `None` when no pixel has
    /// a finite misfit.
    fn misfit_limit(&self) -> Option<f64> {
        let (ny, nx) = (self.ny(), self.nx);
        let mut misfits: Vec<f64> = (0..ny)
            .flat_map(|y| (0..nx).map(move |x| (y, x)))
            .flat_map(|(y, x)| (0..self.windows[y].len()).map(move |k| (y, x, k)))
            .map(|(y, x, k)| self.misfit(y, x, k).1)
            .filter(|m| m.is_finite())
            .collect();
        (!misfits.is_empty()).then(|| EDGE_FACTOR * median(&mut misfits))
    }

    /// Step 2 for every candidate window of every row: its median residual over the pixels for
    /// which it is clean (misfit within `misfit_limit`), with at least `min` of them; and the
    /// centred window's over every pixel (`None` with fewer than `min`).
    fn fit_windows(&self, min: usize, misfit_limit: f64) -> (Vec<Vec<WindowFit>>, CentredFits) {
        let (ny, nx) = (self.ny(), self.nx);
        let mut residuals: Vec<f64> = Vec::with_capacity(nx);
        let mut fitted: Vec<Vec<WindowFit>> = Vec::with_capacity(ny);
        let mut centred_all: Vec<Option<WindowFit>> = Vec::with_capacity(ny);
        for (y, row_windows) in self.windows.iter().enumerate() {
            let mut row = Vec::with_capacity(5);
            for k in 0..row_windows.len() {
                residuals.clear();
                residuals.extend(
                    (0..nx)
                        .map(|x| self.misfit(y, x, k))
                        .filter(|&(_, m)| m <= misfit_limit)
                        .map(|(e, _)| e),
                );
                row.push(if residuals.len() >= min {
                    let (r, s2) = median_and_variance(&mut residuals);
                    WindowFit {
                        r,
                        s2,
                        pixels: residuals.len(),
                    }
                } else {
                    WindowFit {
                        r: 0.0,
                        s2: f64::INFINITY,
                        pixels: 0,
                    }
                });
            }
            fitted.push(row);
            residuals.clear();
            residuals.extend(
                (0..nx)
                    .map(|x| self.pixel(y, x, 0).0)
                    .filter(|e| e.is_finite()),
            );
            centred_all.push((residuals.len() >= min).then(|| {
                let (r, s2) = median_and_variance(&mut residuals);
                WindowFit {
                    r,
                    s2,
                    pixels: residuals.len(),
                }
            }));
        }
        (fitted, centred_all)
    }

    /// Step 2's choice of one window per row: the centred one where it is clean for at least
    /// half of the row's measured pixels; else (a horizontal edge next to the row, where every
    /// pixel jumps at once) the clean window whose residual is smallest: the side of the edge
    /// that the row belongs to, off by the offsets only, not by the edge; with no clean
    /// window, the centred one over every pixel.
    fn choose(
        &self,
        fitted: &[Vec<WindowFit>],
        centred_all: &[Option<WindowFit>],
        min: usize,
    ) -> Vec<Chosen> {
        let nx = self.nx;
        (0..self.ny())
            .map(|y| {
                let measured = (0..nx)
                    .filter(|&x| self.values[y * nx + x].is_some())
                    .count();
                let f = &fitted[y];
                let centred_clean = f[0].pixels >= min && 2 * f[0].pixels >= measured;
                if centred_clean {
                    Some((0, f[0].r, f[0].s2))
                } else {
                    (0..f.len())
                        .filter(|&k| f[k].pixels >= min)
                        .min_by(|&a, &b| f[a].r.abs().total_cmp(&f[b].r.abs()))
                        .map(|k| (k, f[k].r, f[k].s2))
                        .or_else(|| centred_all[y].map(|c| (0, c.r, c.s2)))
                }
            })
            .collect()
    }

    /// Step 3's equations: one per row with a chosen window, its variance at least `floor`;
    /// with the row of each.
    fn equations(&self, chosen: &[Chosen], floor: f64) -> (Vec<Equation>, Vec<usize>) {
        let ny = self.ny();
        let mut eqs: Vec<Equation> = Vec::with_capacity(ny);
        let mut eq_row: Vec<usize> = Vec::with_capacity(ny);
        for (y, c) in chosen.iter().enumerate() {
            if let Some((k, r, s2)) = *c {
                eqs.push(Equation {
                    coeffs: Window {
                        r,
                        s2,
                        ..self.windows[y][k]
                    }
                    .coeffs(y),
                    r,
                    s2: s2.max(floor),
                    model_s2: 0.0,
                });
                eq_row.push(y);
            }
        }
        (eqs, eq_row)
    }

    /// Step 3's model error: each equation's `model_s2`, how far its row's clean windows other
    /// than the chosen one miss their residuals given `offsets` (an edge of the scene that the
    /// windows see differently). Whether any is positive.
    fn add_model_error(
        &self,
        eqs: &mut [Equation],
        eq_row: &[usize],
        fitted: &[Vec<WindowFit>],
        min: usize,
        floor: f64,
        offsets: &[f64],
    ) -> bool {
        for (e, &y) in eqs.iter_mut().zip(eq_row) {
            let mut excess: Vec<f64> = (0..self.windows[y].len())
                .filter(|&k| fitted[y][k].pixels >= min)
                .map(|k| {
                    let w = Window {
                        r: fitted[y][k].r,
                        s2: fitted[y][k].s2,
                        ..self.windows[y][k]
                    };
                    let m = w.r
                        - w.coeffs(y)
                            .iter()
                            .map(|&(i, c)| c * offsets[i])
                            .sum::<f64>();
                    (m * m - w.s2.max(floor)).max(0.0)
                })
                .collect();
            e.model_s2 = if excess.is_empty() {
                0.0
            } else {
                median(&mut excess)
            };
        }
        eqs.iter().any(|e| e.model_s2 > 0.0)
    }
}

/// The smallest variance of a row's residual (step 3): [`MODEL_FLOOR`] of the median chosen
/// residual, squared; `None` when no row has a chosen window.
fn model_floor(chosen: &[Chosen]) -> Option<f64> {
    let mut typical: Vec<f64> = chosen.iter().flatten().map(|c| c.1.abs()).collect();
    if typical.is_empty() {
        return None;
    }
    Some((MODEL_FLOOR * median(&mut typical)).powi(2).max(1e-24))
}

/// The offset common to each row of per-pixel measurements `values` (`ny x nx`, `[y][x]`,
/// `None` = not measured), with its standard error and the part applied (module doc). Rows
/// with fewer than `fit.min_pixels` predicted pixels get `None`; with fewer than 5 rows,
/// every row does. A glitched row next to a horizontal edge of the scene is left alone
/// rather than corrected: the windows of its neighbours that hold it look like an edge, so
/// its prediction windows disagree and its standard error is large (module doc).
pub fn estimate_row_offsets(
    values: &[Option<f64>],
    nx: usize,
    fit: &RowOffsetFit,
) -> Vec<Option<RowOffset>> {
    let ny = values.len().checked_div(nx).unwrap_or(0);
    if ny < 5 {
        return vec![None; ny];
    }
    let min = fit.min_pixels.max(3);
    // Step 1: every 5-row window holding each row, the centred one first; per pixel, a window
    // is left out where its four other rows do not lie on a quadratic.
    let stencils = Stencils::new(values, nx, ny);
    let Some(misfit_limit) = stencils.misfit_limit() else {
        return vec![None; ny];
    };
    // Step 2: each window's median residual and its error; one window per row.
    let (fitted, centred_all) = stencils.fit_windows(min, misfit_limit);
    let chosen = stencils.choose(&fitted, &centred_all, min);
    // Step 3: the robust solve, then again with the scene model's error where the row's
    // windows disagree given the offsets (0 on the first solve).
    let Some(floor) = model_floor(&chosen) else {
        return vec![None; ny];
    };
    let (mut eqs, eq_row) = stencils.equations(&chosen, floor);
    let mut solution = solve_robust(&eqs, ny, fit);
    if stencils.add_model_error(&mut eqs, &eq_row, &fitted, min, floor, &solution.offsets) {
        solution = solve_robust(&eqs, ny, fit);
    }
    // A row is estimated when it has an equation of its own.
    (0..ny)
        .map(|y| {
            let (o, se) = (solution.offsets[y], solution.std_errors[y]);
            (chosen[y].is_some() && se.is_finite()).then(|| RowOffset::gated(o, se))
        })
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

    /// `v` minus its least-squares straight line in the index (what no estimate can see).
    fn detrended(v: &[f64]) -> Vec<f64> {
        let n = v.len() as f64;
        let mx = (n - 1.0) / 2.0;
        let my = v.iter().sum::<f64>() / n;
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for (i, y) in v.iter().enumerate() {
            sxy += (i as f64 - mx) * (y - my);
            sxx += (i as f64 - mx).powi(2);
        }
        let b = sxy / sxx;
        v.iter()
            .enumerate()
            .map(|(i, y)| y - my - b * (i as f64 - mx))
            .collect()
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
    fn stencils_reproduce_quadratics_and_the_banded_solve_inverts() {
        // The prediction of a quadratic in y is exact at every row, ends included.
        let q = |y: f64| 3.0 - 0.7 * y + 0.05 * y * y;
        for ny in [5usize, 6, 11] {
            for y in 0..ny {
                for first in y.saturating_sub(4)..=y.min(ny - 5) {
                    let (rows, w) = stencil(y, first);
                    assert!(!rows.contains(&y) && rows.iter().all(|&r| r < ny));
                    let p: f64 = rows.iter().zip(&w).map(|(&r, &wk)| wk * q(r as f64)).sum();
                    assert!((p - q(y as f64)).abs() < 1e-9, "ny {ny}, y {y}: {p}");
                }
            }
        }
        // A random symmetric positive-definite banded matrix: M x = b is met.
        let n = 40;
        let mut rng = Pcg64::seed_from_u64(4);
        let normal = Normal::new(0.0, 1.0).unwrap();
        let mut dense = vec![vec![0.0f64; n]; n];
        #[allow(clippy::needless_range_loop)] // (i, j) and (j, i) of a symmetric matrix
        for i in 0..n {
            for j in i.saturating_sub(BAND)..i {
                let v = normal.sample(&mut rng);
                dense[i][j] = v;
                dense[j][i] = v;
            }
            dense[i][i] = 2.0 * BAND as f64 + 1.0; // diagonally dominant
        }
        let mut band = vec![0.0; n * (BAND + 1)];
        for i in 0..n {
            for j in i.saturating_sub(BAND)..=i {
                band[i * (BAND + 1) + (j + BAND - i)] = dense[i][j];
            }
        }
        let b: Vec<f64> = (0..n).map(|_| normal.sample(&mut rng)).collect();
        let x = solve_banded(&mut band, &b);
        for i in 0..n {
            let mx: f64 = (0..n).map(|j| dense[i][j] * x[j]).sum();
            assert!((mx - b[i]).abs() < 1e-10, "row {i}: {mx} vs {}", b[i]);
        }
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
        let est: Vec<f64> = est
            .iter()
            .map(|e| e.expect("every row measured").applied)
            .collect();
        // Compared after removing the straight line through the differences: an offset
        // linear in y is a tilted scene, invisible to any estimate.
        let err = detrended(&(0..ny).map(|y| est[y] - truth[y]).collect::<Vec<_>>());
        let want = detrended(&truth);
        // Row-to-row jumps (what shows as a ragged front in the cube): the fast part.
        let jumps = |v: &[f64]| -> Vec<f64> { v.windows(2).map(|p| p[1] - p[0]).collect() };
        let jump_err = jumps(&err);
        eprintln!(
            "row offsets: true {:.2} rms, error {:.2} rms, {:.2} worst; row-to-row jumps {:.2} \
             rms, error {:.2} rms; glitch off by {:.2}",
            rms(&want),
            rms(&err),
            err.iter().fold(0.0f64, |m, e| m.max(e.abs())),
            rms(&jumps(&truth)),
            rms(&jump_err),
            err[25]
        );
        // Tolerances: the stencil is exact on quadratics, so it barely sees offsets slower
        // than about 10 rows, and the prior leaves them out: for white offsets about a fifth
        // of the modes, so up to half of the rms (module doc), and a little more for the
        // offsets below `SIGNIFICANCE` standard errors left in place: 0.55. The row-to-row jumps carry
        // little of the slow part: within a quarter of theirs, plus the offsets below
        // `SIGNIFICANCE` standard errors that are left in place: three tenths. The glitch (9
        // against a spread of 2) stands out of its neighbours by what it should within 1.
        assert!(
            rms(&err) < 0.55 * rms(&want),
            "{} vs {}",
            rms(&err),
            rms(&want)
        );
        assert!(rms(&jump_err) < 0.3 * rms(&jumps(&truth)));
        let local = err[25] - 0.5 * (err[24] + err[26]);
        assert!(local.abs() < 1.0, "glitch off its neighbours by {local}");

        // The same scene with no offsets: the edges are not mistaken for offsets.
        let clean: Vec<Option<f64>> = (0..ny * nx).map(|i| Some(scene(i % nx, i / nx))).collect();
        let est = estimate_row_offsets(&clean, nx, &RowOffsetFit::default());
        let worst = est
            .iter()
            .fold(0.0f64, |m, e| m.max(e.unwrap().applied.abs()));
        eprintln!("row offsets of a clean scene: worst {worst:.3}");
        assert!(worst < 0.05, "{worst}");
        // Too few rows for a quadratic stencil: nothing is estimated.
        assert_eq!(
            estimate_row_offsets(&clean[..4 * nx], nx, &RowOffsetFit::default()),
            vec![None; 4]
        );
    }

    #[test]
    fn small_gains_on_a_smooth_scene_are_recovered() {
        // Log integrals of a scene smooth in x and y times a laser power fluctuating by 5 %
        // from row to row, with a tiny measurement noise.
        let (nx, ny) = (32usize, 64usize);
        let mut rng = Pcg64::seed_from_u64(15);
        let power = Normal::new(0.0, 0.05).unwrap();
        let noise = Normal::new(0.0, 1e-4).unwrap();
        let truth: Vec<f64> = (0..ny).map(|_| power.sample(&mut rng)).collect();
        let values: Vec<Option<f64>> = (0..ny * nx)
            .map(|i| {
                let (x, y) = ((i % nx) as f64, (i / nx) as f64);
                let scene =
                    (400.0 * (1.0 + 0.3 * (x / 5.0).sin()) * (1.0 + 0.2 * (y / 12.0).cos())).ln();
                Some(scene + truth[i / nx] + noise.sample(&mut rng))
            })
            .collect();
        let est = estimate_row_offsets(&values, nx, &RowOffsetFit::default());
        let est: Vec<f64> = est
            .iter()
            .map(|e| e.expect("every row measured").applied)
            .collect();
        let err = detrended(&(0..ny).map(|y| est[y] - truth[y]).collect::<Vec<_>>());
        let want = detrended(&truth);
        eprintln!(
            "small gains: true {:.4} rms, error {:.4} rms",
            rms(&want),
            rms(&err)
        );
        // Tolerance: the slow part is lost (offsets slower than a few rows; and residuals
        // are not trusted below a fiftieth of the typical one, so a little more: just over
        // two fifths of the spread here): under a half.
        assert!(
            rms(&err) < 0.5 * rms(&want),
            "{} vs {}",
            rms(&err),
            rms(&want)
        );
    }

    #[test]
    fn pulse_times_and_log_integrals_follow_shifts_and_gains() {
        let axis = TimeAxis {
            t0_ps: 0.0,
            dt_ps: 2.0,
            nt: 64,
        };
        let (nx, nt) = (6usize, 64usize);
        // A symmetric pulse over 8 bins from bin 20 + x / 2 (heights 1 2 3 4 4 3 2 1 times
        // (10 + x) / 4), on a baseline of 1.
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
        let e0 = pixel_pulse_times(&row(0, 1.0), nx, &axis);
        let e3 = pixel_pulse_times(&row(3, 1.0), nx, &axis);
        for x in 0..nx {
            // A symmetric pulse: half its signal lies before the end of its fourth bin.
            let start = 20 + x / 2;
            let (a, b) = (e0[x].unwrap(), e3[x].unwrap());
            assert!(
                (a - axis.bin_start_ps(start + 4)).abs() < 1e-9,
                "pixel {x}: {a}"
            );
            assert!((b - a - 6.0).abs() < 1e-9, "pixel {x}: {a} -> {b}");
        }
        let l1 = pixel_log_integrals(&row(0, 1.0), nx, nt);
        let l2 = pixel_log_integrals(&row(0, 0.5), nx, nt);
        assert_eq!(l2[0], None);
        let l3 = pixel_log_integrals(&row(3, 1.0), nx, nt);
        for x in 1..nx {
            // The gain scales the pulse above the baseline of 1 per bin, which is left out;
            // the integral is the pulse's own (its 20 units times (10 + x) / 4), whatever
            // its time.
            let pulse = 20.0 * (10.0 + x as f64) / 4.0;
            assert!((l1[x].unwrap() - pulse.ln()).abs() < 1e-6, "pixel {x}");
            assert!((l2[x].unwrap() - l1[x].unwrap() - 0.5f64.ln()).abs() < 1e-6);
            assert!((l3[x].unwrap() - l1[x].unwrap()).abs() < 1e-6);
        }
    }

    #[test]
    fn sparse_glitches_come_back_whole_and_quiet_rows_stay_put() {
        // The scene of `scene` with pixel noise 0.3: no offsets at all, then two glitched
        // rows (12 and 8) among 64 quiet ones, away from the horizontal edge at row 40 (a
        // glitch next to it is left alone, see `estimate_row_offsets`).
        let (nx, ny) = (32usize, 64usize);
        let mut rng = Pcg64::seed_from_u64(21);
        let noise = Normal::new(0.0, 0.3).unwrap();
        let capture = |truth: &[f64], rng: &mut Pcg64| -> Vec<Option<f64>> {
            (0..ny * nx)
                .map(|i| Some(scene(i % nx, i / nx) + truth[i / nx] + noise.sample(rng)))
                .collect()
        };
        let quiet = vec![0.0; ny];
        let est = estimate_row_offsets(&capture(&quiet, &mut rng), nx, &RowOffsetFit::default());
        for (y, e) in est.iter().enumerate() {
            let e = e.expect("every row measured");
            // Nothing is applied, and no estimate exceeds its standard error by far.
            assert_eq!(e.applied, 0.0, "row {y}: {e:?}");
            assert!(
                e.estimate.abs() < SIGNIFICANCE * e.std_error,
                "row {y}: {e:?}"
            );
        }
        let mut glitched = quiet.clone();
        glitched[20] = 12.0;
        glitched[50] = 8.0;
        let est = estimate_row_offsets(&capture(&glitched, &mut rng), nx, &RowOffsetFit::default());
        for (y, e) in est.iter().enumerate() {
            let e = e.expect("every row measured");
            if glitched[y] != 0.0 {
                eprintln!(
                    "glitch of row {y}: {} -> {:.3} +- {:.3}",
                    glitched[y], e.applied, e.std_error
                );
                // Within 3 standard errors, which are under a third of the pixels' noise.
                assert!(e.std_error < 0.1, "row {y}: {e:?}");
                assert!(
                    (e.applied - glitched[y]).abs() < 3.0 * e.std_error,
                    "row {y}: {e:?}"
                );
            } else {
                assert!(e.applied.abs() <= e.std_error, "row {y} moved: {e:?}");
            }
        }
    }
}

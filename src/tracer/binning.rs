//! Time binning of path samples: each sample's energy is spread over the time bins with the
//! sensor's time response, so that binning conserves energy and does not alias.
//!
//! Response model (physics.md, "Transient path tracing": the pulse width and the sensor's
//! resolution both blur the arrival histogram): the laser pulse is a Gaussian in time with
//! standard deviation `sigma = FWHM / (2 sqrt(2 ln 2))`, and the streak sensor integrates
//! over a box one bin (`dt`) wide. A sample arriving at `t` therefore adds to bin `i` the
//! fraction
//!
//! `w_i = E_g[ tent((c_i - t - g) / dt) ]`, `g ~ N(0, sigma^2)`, `tent(x) = max(0, 1 - |x|)`,
//!
//! where `c_i` is the bin centre (the box response integrated over a bin is the tent). In
//! closed form, with `s = sigma / dt`, `x = (c_i - t) / dt`, `F(z) = z Phi(z) + phi(z)`:
//!
//! `w_i = s [F((x + 1) / s) - 2 F(x / s) + F((x - 1) / s)]`.
//!
//! For `sigma -> 0` this is exactly linear (tent) splatting between the two nearest bin
//! centres; for `sigma >> dt` it is the Gaussian integrated over each bin. The weights sum to
//! one over all bins and keep the sample's mean time; the Gaussian is truncated at +-6 sigma
//! (mass 2e-9 beyond, small enough that the cut keeps the mean time) and the kept weights
//! renormalised so each sample's energy is conserved exactly. Weight
//! that falls on bins outside the axis is lost and reported to the caller.

use crate::cube::TimeAxis;

/// Where the Gaussian pulse is cut, in standard deviations.
pub const TRUNCATE_SIGMAS: f64 = 6.0;

/// The time response of one sample on a given axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeResponse {
    axis: TimeAxis,
    /// Pulse standard deviation in units of bins.
    sigma_bins: f64,
}

impl TimeResponse {
    /// Response on `axis` for a Gaussian pulse of standard deviation `sigma_ps` (0: a delta
    /// pulse, plain tent splatting).
    pub fn new(axis: TimeAxis, sigma_ps: f64) -> TimeResponse {
        TimeResponse {
            axis,
            sigma_bins: (sigma_ps / axis.dt_ps).max(0.0),
        }
    }

    pub fn axis(&self) -> &TimeAxis {
        &self.axis
    }

    /// Normalised weights of a sample arriving at `t_ps`: fills `weights` (cleared first) with
    /// the weights of consecutive bins starting at the returned bin index, which may lie
    /// outside `0..nt`. The weights sum to 1.
    pub fn weights(&self, t_ps: f64, weights: &mut Vec<f64>) -> isize {
        // Continuous coordinate in units of bins where bin i's centre sits at i.
        self.weights_at_centre_coord(self.axis.bin_coord(t_ps) - 0.5, weights)
    }

    /// [`TimeResponse::weights`] of a sample at centre coordinate `tc` (bin i's centre at i).
    fn weights_at_centre_coord(&self, tc: f64, weights: &mut Vec<f64>) -> isize {
        weights.clear();
        let s = self.sigma_bins;
        let reach = 1.0 + TRUNCATE_SIGMAS * s;
        let first = (tc - reach).ceil() as isize;
        let last = (tc + reach).floor() as isize;
        if s == 0.0 {
            // Exact tent: the two bins whose centres bracket t.
            let i0 = tc.floor();
            let f = tc - i0;
            weights.extend_from_slice(&[1.0 - f, f]);
            return i0 as isize;
        }
        let mut sum = 0.0;
        for i in first..=last {
            let x = (i as f64 - tc) / s;
            let inv = 1.0 / s;
            let w = s * (ramp_gauss(x + inv) - 2.0 * ramp_gauss(x) + ramp_gauss(x - inv));
            let w = w.max(0.0);
            weights.push(w);
            sum += w;
        }
        if sum > 0.0 {
            weights.iter_mut().for_each(|w| *w /= sum);
        } else {
            // Unreachable for finite t: the centre bin always has weight; keep energy anyway.
            weights.clear();
            weights.push(1.0);
            return tc.round() as isize;
        }
        first
    }

    /// Add `value` arriving at `t_ps` into `profile` (one value per bin of the axis);
    /// returns the part of `value` that fell outside the axis.
    pub fn splat(&self, profile: &mut [f64], t_ps: f64, value: f64, scratch: &mut Vec<f64>) -> f64 {
        let first = self.weights(t_ps, scratch);
        add_weighted(profile, first, scratch, value)
    }
}

/// Finest and coarsest table spacing of [`ResponseTable`], in rows per bin.
const TABLE_ROWS_MAX: usize = 4096;
const TABLE_ROWS_MIN: usize = 16;

/// [`TimeResponse`] tabulated for the tracer's inner loop: the weights depend only on where
/// the sample falls within a bin, so they are computed exactly at `rows + 1` evenly spaced
/// positions across one bin and interpolated linearly between them. Interpolation keeps the
/// two properties binning relies on exactly (up to rounding): every sample's weights sum to
/// one (each row does) and their centroid is the arrival time (each row's is, and the
/// centroid is linear in the position). The remaining difference from the exact weights is
/// below 1e-5 of the sample per bin (linear interpolation errs by at most `h^2 max|w''| / 8`,
/// with `max|w''| ~ 0.8 / s` for a pulse of `s` bins: a spacing `h = sqrt(s) / 128`, at most
/// 4096 rows per bin, keeps it below 1e-5); for a delta pulse the table is the tent itself.
#[derive(Clone, Debug)]
pub struct ResponseTable {
    axis: TimeAxis,
    /// `1 / axis.dt_ps`.
    inv_dt: f64,
    /// Bin of a row's first weight, relative to the bin whose centre precedes the sample.
    lo: isize,
    /// Weights per row.
    len: usize,
    /// Rows per bin (the table holds `rows + 1` rows, the last one a bin later than the first).
    rows: usize,
    /// Row-major weights, `(rows + 1) * len`.
    table: Vec<f64>,
    /// Half-width of the sub-bin positions near a bin centre where the pulse matters: a
    /// sample whose position `f` within the bin has `tent_from <= f <= 1 - tent_from` keeps
    /// its whole (truncated, symmetric) pulse between two bin centres, where the tent is
    /// linear, so its exact weights are the tent's and the table is not read (keeping the
    /// table's hot part small enough for the cache). 0 for a delta pulse, whose table is the
    /// tent; 0.5 or more: always the table.
    tent_from: f64,
    /// Where a sample sits relative to its placement bin: 0.5 for the sensor's response
    /// (bin `floor(b - 0.5)`, the last centre at or before the sample), 0 for a histogram
    /// (bin `floor(b)`, the bin the sample falls in).
    place_shift: f64,
    /// Factor of the sample's distance past its placement bin: 1 for the sensor's response,
    /// 0 for a histogram (all of the sample in the placement bin: tent weights `1, 0`).
    f_scale: f64,
}

impl ResponseTable {
    /// Rows per bin of the table for a pulse of `sigma_bins` bins (1 for a delta pulse).
    fn rows_for(sigma_bins: f64) -> usize {
        if sigma_bins == 0.0 {
            1
        } else {
            ((128.0 / sigma_bins.sqrt())
                .ceil()
                .min(TABLE_ROWS_MAX as f64) as usize)
                .max(TABLE_ROWS_MIN)
        }
    }

    /// Bins one sample weighs before trimming, for a pulse of `sigma_ps` on bins of `dt_ps`:
    /// the work of every splat and the table's width. A float, so that a pulse of 1e300 bins
    /// can be refused ([`crate::limits::bounded_count`]) before anything is computed.
    pub fn weights_per_sample(dt_ps: f64, sigma_ps: f64) -> f64 {
        let s = (sigma_ps / dt_ps).max(0.0);
        2.0 * (1.0 + TRUNCATE_SIGMAS * s) + 2.0
    }

    /// Bytes [`ResponseTable::new`] holds at its peak (the exact rows and the table, f64),
    /// for a pulse of `sigma_ps` on bins of `dt_ps`.
    pub fn bytes_estimate(dt_ps: f64, sigma_ps: f64) -> f64 {
        let s = (sigma_ps / dt_ps).max(0.0);
        let rows = if s.is_finite() { Self::rows_for(s) } else { 1 };
        2.0 * (rows + 1) as f64 * Self::weights_per_sample(dt_ps, sigma_ps) * 8.0
    }

    pub fn new(response: &TimeResponse) -> ResponseTable {
        let s = response.sigma_bins;
        let rows = Self::rows_for(s);
        let mut scratch = Vec::new();
        let exact: Vec<(isize, Vec<f64>)> = (0..=rows)
            .map(|j| {
                let first = response.weights_at_centre_coord(j as f64 / rows as f64, &mut scratch);
                (first, scratch.clone())
            })
            .collect();
        // Columns that some row reaches, with its all-zero edges trimmed.
        let lo = exact.iter().map(|(f, _)| *f).min().unwrap_or(0);
        let hi = exact
            .iter()
            .map(|(f, w)| *f + w.len() as isize)
            .max()
            .unwrap_or(1);
        let width = (hi - lo) as usize;
        let mut table = vec![0.0; (rows + 1) * width];
        for (j, (first, w)) in exact.iter().enumerate() {
            let at = j * width + (first - lo) as usize;
            table[at..at + w.len()].copy_from_slice(w);
        }
        let nonzero = |c: usize| (0..=rows).any(|j| table[j * width + c] != 0.0);
        let c0 = (0..width).find(|&c| nonzero(c)).unwrap_or(0);
        let c1 = (0..width).rev().find(|&c| nonzero(c)).unwrap_or(0) + 1;
        let len = c1 - c0;
        let table = (0..=rows)
            .flat_map(|j| table[j * width + c0..j * width + c1].to_vec())
            .collect();
        let lo = lo + c0 as isize;
        // The tent's two bins must be columns of the table (they always are: every row's
        // centre bins have weight).
        let tent_from = if lo <= 0 && 1 - lo < len as isize {
            TRUNCATE_SIGMAS * s
        } else {
            1.0
        };
        ResponseTable {
            axis: response.axis,
            inv_dt: 1.0 / response.axis.dt_ps,
            lo,
            len,
            rows,
            table,
            tent_from,
            place_shift: 0.5,
            f_scale: 1.0,
        }
    }

    /// The table of a histogram of arrival times (no pulse, no sensor blur): each sample adds
    /// its whole value to the one bin its arrival time falls in, `[t0 + i dt, t0 + (i + 1) dt)`.
    /// This is what a renderer with box time bins estimates (mitransient's
    /// `transient_hdr_film`); femto's own cubes use [`ResponseTable::new`], the sensor's
    /// response. Implemented as the delta pulse's tent placed at the bin's start with weights
    /// `1, 0`, so it shares every code path (and the path window's reach) with the tent.
    pub fn histogram(axis: TimeAxis) -> ResponseTable {
        ResponseTable {
            place_shift: 0.0,
            f_scale: 0.0,
            ..ResponseTable::new(&TimeResponse::new(axis, 0.0))
        }
    }

    pub fn axis(&self) -> &TimeAxis {
        &self.axis
    }

    /// Arrival times, ps, outside of which a sample has no weight in any bin `0..nt`: one
    /// bin of margin beyond the exact reach of the table's columns.
    pub fn reach_ps(&self) -> (f64, f64) {
        // A sample at bin coordinate `b` weighs bins `floor(b - 0.5) + lo ..` (`len` of them).
        let (lo, len, nt) = (self.lo as f64, self.len as f64, self.axis.nt as f64);
        let dt = self.axis.dt_ps;
        (
            self.axis.t0_ps + (0.5 - lo - len) * dt,
            self.axis.t0_ps + (nt - lo + 1.5) * dt,
        )
    }

    /// Number of weights of every sample.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether a sample has no weights (never: a table holds at least one bin).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Weights of a sample arriving at `t_ps` into `weights[..self.len()]` (which must be at
    /// least that long), for consecutive bins from the returned index (possibly outside
    /// `0..nt`). Returns `None` for a non-finite time.
    #[inline]
    pub fn weights(&self, t_ps: f64, weights: &mut [f64]) -> Option<isize> {
        self.weights_at(self.bin_coord(t_ps), weights)
    }

    /// Continuous bin coordinate of `t_ps` on the table's axis (bin `i` covers `[i, i + 1)`):
    /// [`TimeAxis::bin_coord`] with the division by the bin width replaced by a product.
    #[inline]
    pub fn bin_coord(&self, t_ps: f64) -> f64 {
        (t_ps - self.axis.t0_ps) * self.inv_dt
    }

    /// [`ResponseTable::weights`] of a sample at bin coordinate `b` (from
    /// [`ResponseTable::bin_coord`]).
    #[inline]
    pub fn weights_at(&self, b: f64, weights: &mut [f64]) -> Option<isize> {
        let p = self.place(b)?;
        Some(self.fill(&p, weights))
    }

    /// Where a sample at bin coordinate `b` (from [`ResponseTable::bin_coord`]) falls, for
    /// [`ResponseTable::add`]; `None` for a non-finite coordinate.
    #[inline(always)]
    pub fn place(&self, b: f64) -> Option<Placement> {
        let tc = b - self.place_shift;
        if !tc.is_finite() || tc.abs() > 1e15 {
            return None;
        }
        // floor(tc) without a libm call (SSE2 has no rounding instruction): truncation is
        // exact for |tc| <= 1e15 < 2^53.
        let trunc = tc as i64;
        let floor = (trunc - ((trunc as f64) > tc) as i64) as f64;
        let f = (tc - floor) * self.f_scale;
        Some(Placement {
            floor: floor as isize,
            f,
            tent: f >= self.tent_from && f <= 1.0 - self.tent_from,
        })
    }

    /// The weights of placement `p` into `weights[..self.len()]`; returns the bin of the
    /// first.
    #[inline]
    fn fill(&self, p: &Placement, weights: &mut [f64]) -> isize {
        let len = self.len;
        if p.tent {
            let w = &mut weights[..len];
            w.fill(0.0);
            w[(-self.lo) as usize] = 1.0 - p.f;
            w[(1 - self.lo) as usize] = p.f;
            return p.floor + self.lo;
        }
        let x = p.f * self.rows as f64;
        let j = (x as usize).min(self.rows - 1);
        let a = x - j as f64;
        let r0 = &self.table[j * len..(j + 1) * len];
        let r1 = &self.table[(j + 1) * len..(j + 2) * len];
        for ((w, &w0), &w1) in weights[..len].iter_mut().zip(r0).zip(r1) {
            *w = w0 + a * (w1 - w0);
        }
        p.floor + self.lo
    }

    /// Add `value` placed at `p` into `profile` (one value per bin of the axis); returns the
    /// part of `value` that fell outside it. The same sums, in the same order, as
    /// [`ResponseTable::weights_at`] followed by [`add_weighted`] (the table's other columns
    /// add exact zeros), but a tent sample inside the axis adds its two weights directly,
    /// without filling `scratch` (at least [`ResponseTable::len`] long).
    #[inline(always)]
    pub fn add(&self, p: &Placement, profile: &mut [f64], value: f64, scratch: &mut [f64]) -> f64 {
        if p.tent && p.floor >= 0 && (p.floor as usize) + 1 < profile.len() {
            let i = p.floor as usize;
            profile[i] += value * (1.0 - p.f);
            profile[i + 1] += value * p.f;
            return 0.0;
        }
        self.add_general(p, profile, value, scratch)
    }

    /// [`ResponseTable::add`] through the weights (kept out of line: the tracer's common
    /// case is the tent).
    #[inline(never)]
    fn add_general(
        &self,
        p: &Placement,
        profile: &mut [f64],
        value: f64,
        scratch: &mut [f64],
    ) -> f64 {
        let first = self.fill(p, scratch);
        add_weighted(profile, first, &scratch[..self.len], value)
    }

    /// The bins placement `p` may add to: `(first, count)`, possibly outside `0..nt`.
    #[inline]
    pub fn span(&self, p: &Placement) -> (isize, usize) {
        if p.tent {
            (p.floor, 2)
        } else {
            (p.floor + self.lo, self.len)
        }
    }
}

/// Where a sample falls on a [`ResponseTable`]'s axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Bin whose centre is the last at or before the sample (`floor(b - 0.5)`; for a
    /// [`ResponseTable::histogram`], the bin the sample falls in, `floor(b)`).
    floor: isize,
    /// Distance of the sample past that centre, bins, in `[0, 1)` (0 for a histogram).
    f: f64,
    /// Whether the weights are the plain tent: `1 - f` on bin `floor`, `f` on the next.
    tent: bool,
}

/// Add `value * weights[k]` to `profile[first + k]`; returns the part that fell outside.
#[inline]
pub fn add_weighted(profile: &mut [f64], first: isize, weights: &[f64], value: f64) -> f64 {
    if first >= 0 && first as usize + weights.len() <= profile.len() {
        let dst = &mut profile[first as usize..first as usize + weights.len()];
        for (d, &w) in dst.iter_mut().zip(weights) {
            *d += value * w;
        }
        return 0.0;
    }
    let mut lost = 0.0;
    for (k, &w) in weights.iter().enumerate() {
        let i = first + k as isize;
        if i >= 0 && (i as usize) < profile.len() {
            profile[i as usize] += value * w;
        } else {
            lost += value * w;
        }
    }
    lost
}

/// The cumulative sensor response of one sample: the fraction of a sample arriving at time 0
/// that the sensor records before time `x_ps`, for a pulse of standard deviation `sigma_ps`
/// and the one-bin box `dt_ps` wide. Its density, the Gaussian convolved with the box, is the
/// one whose integral over each bin is [`TimeResponse`]'s weight (module doc), so that
/// integrating it over any window gives what a cube binned with that response holds there:
/// `(sigma / dt) [F((x + dt/2) / sigma) - F((x - dt/2) / sigma)]`, the box's ramp
/// `clamp((x + dt/2) / dt, 0, 1)` for a delta pulse.
pub fn response_cdf(x_ps: f64, dt_ps: f64, sigma_ps: f64) -> f64 {
    let half = 0.5 * dt_ps;
    if sigma_ps <= 1e-9 * dt_ps {
        return ((x_ps + half) / dt_ps).clamp(0.0, 1.0);
    }
    let lo = (x_ps - half) / sigma_ps;
    if lo > TRUNCATE_SIGMAS {
        return 1.0;
    }
    let hi = (x_ps + half) / sigma_ps;
    if hi < -TRUNCATE_SIGMAS {
        return 0.0;
    }
    (sigma_ps / dt_ps * (ramp_gauss(hi) - ramp_gauss(lo))).clamp(0.0, 1.0)
}

/// `F(z) = E[(z - g)_+]` for a standard normal `g`: `z Phi(z) + phi(z)`.
#[inline]
fn ramp_gauss(z: f64) -> f64 {
    const INV_SQRT_2PI: f64 = 0.398_942_280_401_432_7;
    z * std_normal_cdf(z) + INV_SQRT_2PI * (-0.5 * z * z).exp()
}

/// Standard normal CDF `Phi(z) = erfc(-z / sqrt 2) / 2`.
#[inline]
pub fn std_normal_cdf(z: f64) -> f64 {
    0.5 * erfc(-z * std::f64::consts::FRAC_1_SQRT_2)
}

/// Complementary error function, relative error below 1.2e-7 everywhere (Chebyshev fit of
/// Numerical Recipes, `erfcc`).
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis() -> TimeAxis {
        TimeAxis {
            t0_ps: 100.0,
            dt_ps: 2.0,
            nt: 64,
        }
    }

    #[test]
    fn table_size_estimates_bound_the_built_tables() {
        // Pulses of 0, 0.1, 1, 5 and 40 bins of 2 ps.
        for sigma_ps in [0.0, 0.2, 2.0, 10.0, 80.0] {
            let table = ResponseTable::new(&TimeResponse::new(axis(), sigma_ps));
            let per_sample = ResponseTable::weights_per_sample(2.0, sigma_ps);
            assert!(table.len as f64 <= per_sample, "{sigma_ps}: {}", table.len);
            // The peak holds the exact rows and the table: twice the table, at most.
            let held = 8.0 * table.table.len() as f64;
            let est = ResponseTable::bytes_estimate(2.0, sigma_ps);
            assert!(
                est >= held && est <= 2.0 * 2.0 * held,
                "{sigma_ps}: {est} vs {held}"
            );
        }
        // A bin of 1e-300 ps: refused by its count before any table exists.
        assert!(ResponseTable::weights_per_sample(1e-300, 0.02) > 1e290);
    }

    #[test]
    fn nothing_lands_in_the_axis_from_beyond_the_reach() {
        // Samples past either end of `reach_ps` weigh no bin of the axis; samples a bin and a
        // half inside it do, for a delta pulse and for pulses of a fraction of a bin to many.
        for sigma_ps in [0.0, 0.02, 1.0, 7.0, 40.0] {
            let table = ResponseTable::new(&TimeResponse::new(axis(), sigma_ps));
            let (early, late) = table.reach_ps();
            let nt = axis().nt as isize;
            let mut w = vec![0.0; table.len()];
            let weight_inside = |t: f64, w: &mut Vec<f64>| {
                let first = table.weights(t, w).unwrap();
                (0..table.len())
                    .filter(|&k| (0..nt).contains(&(first + k as isize)))
                    .map(|k| w[k])
                    .sum::<f64>()
            };
            for k in 0..200 {
                let d = k as f64 * 0.37;
                assert_eq!(weight_inside(early - d, &mut w), 0.0, "sigma {sigma_ps}");
                assert_eq!(weight_inside(late + d, &mut w), 0.0, "sigma {sigma_ps}");
            }
            let dt = axis().dt_ps;
            assert!(weight_inside(early + 2.5 * dt + 6.0 * sigma_ps, &mut w) > 0.0);
            assert!(weight_inside(late - 2.5 * dt - 6.0 * sigma_ps, &mut w) > 0.0);
        }
    }

    #[test]
    fn a_histogram_puts_each_sample_in_the_bin_it_falls_in() {
        let table = ResponseTable::histogram(axis());
        let (t0, dt, nt) = (axis().t0_ps, axis().dt_ps, axis().nt);
        let mut scratch = vec![0.0; table.len()];
        // Starts, middles and ends of bins; every sample lands whole in bin floor((t - t0) / dt).
        for k in 0..(4 * nt) {
            let t = t0 + k as f64 * 0.25 * dt + [0.0, 0.1, 0.5, 0.999][k % 4] * 0.25 * dt;
            let mut profile = vec![0.0; nt];
            let p = table.place(table.bin_coord(t)).unwrap();
            let lost = table.add(&p, &mut profile, 3.0, &mut scratch);
            let bin = ((t - t0) / dt).floor() as usize;
            assert_eq!(lost, 0.0, "t {t}");
            assert_eq!(profile[bin], 3.0, "t {t}");
            assert_eq!(profile.iter().sum::<f64>(), 3.0, "t {t}");
        }
        // Before the first bin and at the end of the last: all lost, nothing added.
        for t in [
            t0 - 1e-9,
            t0 - 0.5 * dt,
            t0 + nt as f64 * dt,
            t0 + (nt as f64 + 0.5) * dt,
        ] {
            let mut profile = vec![0.0; nt];
            let p = table.place(table.bin_coord(t)).unwrap();
            assert_eq!(table.add(&p, &mut profile, 3.0, &mut scratch), 3.0, "t {t}");
            assert!(profile.iter().all(|&v| v == 0.0), "t {t}");
        }
        // The histogram's bins lie inside the tent's reach, which the path window uses.
        let (early, late) = table.reach_ps();
        assert!(early <= t0 && late >= t0 + nt as f64 * dt);
    }

    #[test]
    fn erfc_matches_reference_values() {
        // Values from Abramowitz & Stegun, table 7.1 (erf), as 1 - erf.
        for &(x, erf) in &[
            (0.0, 0.0),
            (0.5, 0.520_499_877_8),
            (1.0, 0.842_700_792_9),
            (2.0, 0.995_322_265_0),
        ] {
            assert!((erfc(x) - (1.0 - erf)).abs() < 2e-7, "{x}");
            assert!((erfc(-x) - (1.0 + erf)).abs() < 2e-7, "{x}");
        }
    }

    #[test]
    fn zero_width_pulse_is_linear_splatting_between_bin_centres() {
        let r = TimeResponse::new(axis(), 0.0);
        let mut p = vec![0.0; 64];
        let mut scratch = Vec::new();
        // t = 100 + 2 * 10.25: bin coordinate 10.25, between the centres of bins 9 (9.5) and
        // 10 (10.5), three quarters of the way: weights 0.25 and 0.75.
        let lost = r.splat(&mut p, 120.5, 8.0, &mut scratch);
        assert_eq!(lost, 0.0);
        assert!((p[9] - 2.0).abs() < 1e-12 && (p[10] - 6.0).abs() < 1e-12);
        assert!((p.iter().sum::<f64>() - 8.0).abs() < 1e-12);
    }

    #[test]
    fn weights_conserve_energy_and_mean_time_for_any_width() {
        let mut scratch = Vec::new();
        for &sigma_ps in &[0.0, 0.01, 0.3, 1.0, 2.0, 7.5] {
            let r = TimeResponse::new(axis(), sigma_ps);
            for k in 0..17 {
                let t = 150.0 + 0.37 * k as f64;
                let first = r.weights(t, &mut scratch);
                let sum: f64 = scratch.iter().sum();
                let mean: f64 = scratch
                    .iter()
                    .enumerate()
                    .map(|(j, w)| w * axis().bin_centre_ps((first + j as isize) as usize))
                    .sum();
                assert!((sum - 1.0).abs() < 1e-12, "sigma {sigma_ps} t {t}");
                // Symmetric response: the centroid of the weights is the arrival time, up to
                // the Gaussian's tails cut at +-6 sigma on bin boundaries (mass 2e-9).
                assert!(
                    (mean - t).abs() < 1e-6 * axis().dt_ps,
                    "sigma {sigma_ps} t {t}: {mean}"
                );
            }
        }
    }

    #[test]
    fn wide_pulse_matches_numerical_integration_of_gaussian_times_box() {
        // Independent: integrate the Gaussian pulse convolved with a box of one bin over each
        // bin by brute-force quadrature.
        let ax = axis();
        let sigma = 3.0;
        let t = 163.3;
        let r = TimeResponse::new(ax, sigma);
        let mut scratch = Vec::new();
        let first = r.weights(t, &mut scratch);
        let gauss = |tau: f64| {
            (-(tau - t).powi(2) / (2.0 * sigma * sigma)).exp()
                / (sigma * (2.0 * std::f64::consts::PI).sqrt())
        };
        // (g * box)(tau) = (1/dt) * integral of g over [tau - dt/2, tau + dt/2].
        let n = 400;
        let conv = |tau: f64| {
            let h = ax.dt_ps / n as f64;
            (0..n)
                .map(|k| gauss(tau - 0.5 * ax.dt_ps + (k as f64 + 0.5) * h) * h)
                .sum::<f64>()
                / ax.dt_ps
        };
        for (j, &w) in scratch.iter().enumerate() {
            let i = (first + j as isize) as usize;
            let h = ax.dt_ps / n as f64;
            let exact: f64 = (0..n)
                .map(|k| conv(ax.bin_start_ps(i) + (k as f64 + 0.5) * h) * h)
                .sum();
            assert!((w - exact).abs() < 2e-4, "bin {i}: {w} vs {exact}");
        }
    }

    #[test]
    fn energy_beyond_the_axis_is_reported_lost() {
        let r = TimeResponse::new(axis(), 0.5);
        let mut p = vec![0.0; 64];
        let mut scratch = Vec::new();
        let lost = r.splat(&mut p, 50.0, 3.0, &mut scratch);
        assert_eq!(lost, 3.0);
        assert!(p.iter().all(|&v| v == 0.0));
        // At the very start of the axis part of the tent reaches bin -1.
        let lost = r.splat(&mut p, 100.2, 1.0, &mut scratch);
        assert!(lost > 0.0 && lost < 1.0);
        assert!((p.iter().sum::<f64>() + lost - 1.0).abs() < 1e-12);
    }

    #[test]
    fn direct_tent_add_equals_weights_then_add_weighted() {
        // `ResponseTable::add` (a tent sample's two weights added directly) leaves exactly
        // the profile and lost energy of the general route, `weights_at` + `add_weighted`,
        // for delta, short and wide pulses, at every sub-bin position, inside the axis and
        // across both of its ends; and `span` covers every bin it changed.
        let ax = axis();
        let nt = ax.nt;
        for sigma_ps in [0.0, 0.0212, 0.1, 0.6, 7.5] {
            let table = ResponseTable::new(&TimeResponse::new(ax, sigma_ps));
            let mut w = vec![0.0; table.len()];
            let mut scratch = vec![0.0; table.len()];
            let (mut tents, mut rows) = (0, 0);
            for k in 0..4001 {
                let b = -3.0 + (nt as f64 + 6.0) * k as f64 / 4000.0 + 1e-7 * (k % 7) as f64;
                let value = 0.3 + 0.001 * k as f64;
                // A profile already holding values, as mid-pixel.
                let start: Vec<f64> = (0..nt).map(|i| 0.01 * ((i * 7919) % 13) as f64).collect();
                let mut general = start.clone();
                let first = table.weights_at(b, &mut w).unwrap();
                let lost_general = add_weighted(&mut general, first, &w, value);
                let mut direct = start.clone();
                let p = table.place(b).unwrap();
                let lost_direct = table.add(&p, &mut direct, value, &mut scratch);
                assert_eq!(direct, general, "sigma {sigma_ps} b {b}");
                assert_eq!(lost_direct.to_bits(), lost_general.to_bits(), "b {b}");
                let (f, len) = table.span(&p);
                for i in 0..nt {
                    if direct[i] != start[i] {
                        assert!(
                            (f..f + len as isize).contains(&(i as isize)),
                            "b {b} bin {i}"
                        );
                    }
                }
                if p.tent {
                    tents += 1;
                } else {
                    rows += 1;
                }
            }
            // Both routes are exercised where they exist: a delta pulse is all tent, pulses
            // whose 6 sigma reach stays under half a bin partly, wider ones never.
            let s = sigma_ps / ax.dt_ps;
            if s == 0.0 {
                assert_eq!(rows, 0);
            } else if 6.0 * s < 0.5 {
                assert!(tents > 0 && rows > 0, "sigma {sigma_ps}: {tents} {rows}");
            } else {
                assert_eq!(tents, 0);
            }
            assert!(table.place(f64::INFINITY).is_none());
        }
    }

    #[test]
    fn table_matches_exact_weights_and_keeps_energy_and_centroid() {
        let ax = axis();
        let mut exact = Vec::new();
        for &sigma_ps in &[0.0, 0.0212, 0.1, 0.6, 2.0, 7.5] {
            let r = TimeResponse::new(ax, sigma_ps);
            let table = ResponseTable::new(&r);
            let mut w = vec![0.0; table.len()];
            for k in 0..997 {
                // Arrival times spread over many sub-bin positions, including bin edges.
                let t = 140.0 + 0.0317 * k as f64;
                let first = table.weights(t, &mut w).unwrap();
                let first_exact = r.weights(t, &mut exact);
                // Compare bin by bin over the union of both supports.
                let lo = first.min(first_exact);
                let hi = (first + w.len() as isize).max(first_exact + exact.len() as isize);
                let at = |f: isize, ws: &[f64], i: isize| {
                    ws.get((i - f) as usize)
                        .copied()
                        .filter(|_| i >= f)
                        .unwrap_or(0.0)
                };
                for i in lo..hi {
                    let (a, b) = (at(first, &w, i), at(first_exact, &exact, i));
                    assert!(
                        (a - b).abs() < 1e-5,
                        "sigma {sigma_ps} t {t} bin {i}: {a} vs {b}"
                    );
                }
                let sum: f64 = w.iter().sum();
                assert!(
                    (sum - 1.0).abs() < 1e-12,
                    "sigma {sigma_ps} t {t}: sum {sum}"
                );
                let mean: f64 = w
                    .iter()
                    .enumerate()
                    .map(|(j, w)| w * (ax.t0_ps + ((first + j as isize) as f64 + 0.5) * ax.dt_ps))
                    .sum();
                assert!(
                    (mean - t).abs() < 1e-6 * ax.dt_ps,
                    "sigma {sigma_ps} t {t}: {mean}"
                );
            }
            assert!(table.weights(f64::NAN, &mut w).is_none());
        }
    }
}

//! Robust statistics shared by calibration and ingest: one median, a nearest-rank quantile,
//! the median absolute deviation (MAD) and the standard error of a median.
//!
//! Every median in the crate is [`median`] (or [`median_of`], which leaves its input as it
//! is). For an even count it is the mean of the two middle values; the empty slice has median
//! 0 rather than a panic, so a caller that forgot to check for no data gets a defined value.
//! The values are ordered with [`f64::total_cmp`] and are expected to be finite (callers
//! filter NaN first).
//!
//! For samples of a normal distribution of spread `sigma`, `MAD = sigma / 1.4826`
//! ([`MAD_TO_SIGMA`]) and the median of `n` samples has the standard error
//! `1.2533 sigma / sqrt(n)` ([`MEDIAN_SE_PER_SIGMA`], `sqrt(pi / 2)`).

/// A normal distribution's standard deviation per median absolute deviation (`1 / Phi^-1(3/4)`).
pub const MAD_TO_SIGMA: f64 = 1.4826;

/// Standard error of the median of `n` normal samples, in units of `sigma / sqrt(n)`
/// (`sqrt(pi / 2)`).
pub const MEDIAN_SE_PER_SIGMA: f64 = 1.2533;

/// Median of `values` (reordered in place); the mean of the middle two for an even count,
/// 0 for an empty slice.
pub fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let n = values.len();
    let (lower, m, _) = values.select_nth_unstable_by(n / 2, f64::total_cmp);
    let m = *m;
    if n % 2 == 1 {
        m
    } else {
        // `lower` holds the values ordered before the middle one: its largest is the other
        // middle value.
        let below = lower.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (below + m)
    }
}

/// [`median`] of a copy of `values`, which stay as they are.
pub fn median_of(values: &[f64]) -> f64 {
    median(&mut values.to_vec())
}

/// The value at `q` (0..=1) of `values` (reordered in place), nearest rank: the element of
/// rank `round((n - 1) q)`. At `q = 0.5` it is the upper of the two middle values for an even
/// count. 0 for an empty slice.
pub fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let k = ((values.len() - 1) as f64 * q).round() as usize;
    let (_, v, _) = values.select_nth_unstable_by(k, f64::total_cmp);
    *v
}

/// Median absolute deviation of `values` from `centre`: the [`median`] of `|v - centre|`
/// (0 for an empty slice). Times [`MAD_TO_SIGMA`] it estimates a normal spread.
pub fn mad(values: &[f64], centre: f64) -> f64 {
    let mut dev: Vec<f64> = values.iter().map(|v| (v - centre).abs()).collect();
    median(&mut dev)
}

/// Median of `values` (reordered in place) and its squared standard error,
/// `(1.2533 sigma)^2 / n` with `sigma = 1.4826 MAD` (module doc). An empty slice gives
/// `(0, NaN)`.
pub fn median_and_variance(values: &mut [f64]) -> (f64, f64) {
    let m = median(values);
    let sigma = MAD_TO_SIGMA * mad(values, m);
    (
        m,
        (MEDIAN_SE_PER_SIGMA * sigma).powi(2) / values.len() as f64,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    /// The textbook median: sort a copy, take the middle one or the mean of the middle two.
    fn naive_median(values: &[f64]) -> f64 {
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        }
    }

    #[test]
    fn small_medians() {
        assert_eq!(median(&mut [3.0]), 3.0);
        assert_eq!(median(&mut [5.0, 1.0, 3.0]), 3.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&mut [-1.0, -1.0, 7.0, -1.0]), -1.0);
        assert_eq!(median_of(&[10.0, -2.0]), 4.0);
    }

    /// The slice the sort-based median of ingest indexed at `n / 2 - 1` (an underflow when
    /// empty) now has a defined median, as calibration's had.
    #[test]
    fn an_empty_slice_has_median_zero_and_no_panic() {
        assert_eq!(median(&mut []), 0.0);
        assert_eq!(median_of(&[]), 0.0);
        assert_eq!(quantile(&mut [], 0.9), 0.0);
        assert_eq!(mad(&[], 1.0), 0.0);
        let (m, s2) = median_and_variance(&mut []);
        assert_eq!(m, 0.0);
        assert!(s2.is_nan());
    }

    /// Bit for bit the textbook median, over random counts, values, repeats and signed zeros.
    #[test]
    fn the_median_is_the_sorted_middle_bit_for_bit() {
        let mut rng = Pcg64::seed_from_u64(46);
        for trial in 0..2000 {
            let n = rng.random_range(1..60);
            let v: Vec<f64> = (0..n)
                .map(|_| match trial % 4 {
                    0 => rng.random_range(-1e3..1e3),
                    1 => rng.random_range(-3i32..3) as f64,
                    2 => [0.0, -0.0, 1e-300, -2.5][rng.random_range(0..4)],
                    _ => rng.random::<f64>() * 10f64.powi(rng.random_range(-20..20)),
                })
                .collect();
            let want = naive_median(&v);
            let got = median_of(&v);
            assert_eq!(got.to_bits(), want.to_bits(), "{v:?}");
        }
    }

    #[test]
    fn median_of_leaves_its_input_alone() {
        let v = vec![3.0, 1.0, 2.0, 0.0];
        assert_eq!(median_of(&v), 1.5);
        assert_eq!(v, [3.0, 1.0, 2.0, 0.0]);
    }

    #[test]
    fn quantiles_are_nearest_rank() {
        let v: Vec<f64> = (0..11).rev().map(f64::from).collect();
        for (q, want) in [
            (0.0, 0.0),
            (0.5, 5.0),
            (0.9, 9.0),
            (0.94, 9.0),
            (0.96, 10.0),
            (1.0, 10.0),
        ] {
            assert_eq!(quantile(&mut v.clone(), q), want, "q {q}");
        }
        // Even count: the upper middle value.
        assert_eq!(quantile(&mut [4.0, 1.0, 3.0, 2.0], 0.5), 3.0);
    }

    #[test]
    fn mad_is_the_median_distance_from_the_centre() {
        // |v - 2| = 1, 1, 0, 3, 8: median 1.
        assert_eq!(mad(&[1.0, 3.0, 2.0, 5.0, 10.0], 2.0), 1.0);
        assert_eq!(mad(&[-4.0, 4.0], 0.0), 4.0);
    }

    /// For normal samples the error of the median, measured over many draws, matches the
    /// squared standard error [`median_and_variance`] states, and its sigma the true one.
    #[test]
    fn the_median_error_matches_its_spread_over_draws() {
        use rand_distr::{Distribution, Normal};
        let mut rng = Pcg64::seed_from_u64(7);
        let (n, draws, sigma) = (201, 2000, 3.0);
        let normal = Normal::new(10.0, sigma).unwrap();
        let mut sq_err = 0.0;
        let mut stated = 0.0;
        for _ in 0..draws {
            let mut v: Vec<f64> = (0..n).map(|_| normal.sample(&mut rng)).collect();
            let (m, s2) = median_and_variance(&mut v);
            sq_err += (m - 10.0) * (m - 10.0);
            stated += s2;
        }
        let (measured, stated) = (sq_err / draws as f64, stated / draws as f64);
        // Asymptotic: pi/2 sigma^2 / n.
        let theory = std::f64::consts::FRAC_PI_2 * sigma * sigma / n as f64;
        assert!(
            (measured / theory - 1.0).abs() < 0.1,
            "{measured} vs {theory}"
        );
        assert!((stated / theory - 1.0).abs() < 0.1, "{stated} vs {theory}");
    }
}

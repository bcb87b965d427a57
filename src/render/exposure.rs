//! The renderer's automatic exposure: one number per cube (and view), so that every part of
//! a split render, and every frame of `femto view`, is exposed alike.
//!
//! # Transient and naive views: the key of the lit space-time
//!
//! A capture's brightest light is its direct bounce; the light that arrives later (echoes of
//! hidden objects, multi-bounce light) is often 100-1000 times weaker. An exposure that puts
//! the brightest bins at mid-grey leaves the late light at a few 8-bit levels (on the real
//! confocal NLOS capture of `data/real/lct`, its echoes needed `--exposure` 6 to 20). The
//! exposure is therefore keyed, as in photographic tone reproduction (Reinhard et al. 2002,
//! "Photographic tone reproduction for digital images", Sec. 3.1), on the **log-average** of
//! the **lit** bins:
//!
//! 1. The signal densities (value / bin width) of a deterministic subsample of at most about
//!    2^20 bins; bins that are exactly zero (outside a pixel's recording window) are left out.
//! 2. The noise floor: the median `m` of those bins and their robust standard deviation
//!    `sigma = 1.4826 MAD`. Most bins of a capture hold no light, so these are the noise's.
//! 3. The lit bins: those above `m + 5 sigma` ([`LIT_SIGMAS`]).
//! 4. The exposure `KEY / L` with `L = exp(mean ln v)` over the lit bins and `KEY = 0.18`
//!    ([`KEY`], mid-grey): the typical lit bin shows at luminance 0.18 (0.15 after tone
//!    mapping), the direct pulse above it, the weak late light below it but visible.
//! 5. Clamped so that the 99.9th percentile `p` of the lit bins lands between luminance 1
//!    (the old exposure, which keyed on the brightest light; 0.5 after tone mapping) and
//!    [`MAX_PEAK_LUMINANCE`] (16: 0.94 after tone mapping, so the direct pulse keeps some
//!    gradation): `1 / p <= exposure <= 16 / p`.
//!
//! Fewer than [`MIN_LIT_BINS`] lit bins: the 99.9th percentile of the positive bins is brought
//! to 1, as before ([`exposure_for`]).
//!
//! # Integrated view and isochrones
//!
//! Integrated: the 99.9th percentile of the pixels' time integrals at luminance 1 (a
//! steady-state photograph has no late light to bring out). Isochrones: 1 (display colours).

use super::{RenderScene, View};
use crate::pyramid::PrefixRead;

/// The luminance at which the log-average of the lit bins is shown (photographic mid-grey).
pub const KEY: f64 = 0.18;

/// Robust standard deviations above the median of the non-zero bins from which a bin counts
/// as lit.
pub const LIT_SIGMAS: f64 = 5.0;

/// The largest luminance at which the 99.9th percentile of the lit bins is shown.
pub const MAX_PEAK_LUMINANCE: f64 = 16.0;

/// Fewer lit bins than this and the exposure falls back to [`exposure_for`].
pub const MIN_LIT_BINS: usize = 16;

/// Most bins sampled for the exposure of the transient and naive views.
pub const MAX_SAMPLED_BINS: usize = 1 << 20;

/// The automatic exposure for `view` (see the module doc). Depends on the cube only and is
/// computed once per scene and view; 1 for an all-zero cube.
pub fn auto_exposure(scene: &RenderScene, view: &View) -> f64 {
    let slot = match view {
        View::Isochrones(_) => return 1.0,
        View::Integrated => &scene.auto_exposures[1],
        View::Transient | View::Naive => &scene.auto_exposures[0],
    };
    *slot.get_or_init(|| auto_exposure_uncached(scene, view))
}

fn auto_exposure_uncached(scene: &RenderScene, view: &View) -> f64 {
    let w = scene.world;
    let nt = w.axis.nt;
    match view {
        View::Isochrones(_) => 1.0,
        View::Integrated => exposure_for(
            (0..w.nx * w.ny)
                .map(|p| w.prefix.pixel(p).total())
                .collect(),
        )
        .unwrap_or(1.0),
        View::Transient | View::Naive => {
            let bins = w.nx * w.ny * nt;
            let step = (bins / MAX_SAMPLED_BINS).max(1);
            let values = (0..bins)
                .step_by(step)
                .map(|b| {
                    let (pix, i) = (b / nt, b % nt);
                    w.prefix.pixel(pix).bin(i) / w.axis.dt_ps
                })
                .collect();
            lit_exposure(values).map_or(1.0, |l| l.exposure)
        }
    }
}

/// The exposure that brings the 99.9th percentile of `values` (their positive, finite ones)
/// to 1: its reciprocal. None when no value is positive and finite.
pub fn exposure_for(mut values: Vec<f64>) -> Option<f64> {
    values.retain(|&v| v > 0.0 && v.is_finite());
    if values.is_empty() {
        return None;
    }
    let q = quantile(&mut values, 0.999);
    Some(1.0 / q)
}

/// What [`lit_exposure`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LitExposure {
    /// The exposure.
    pub exposure: f64,
    /// Median of the non-zero values (the noise floor's level).
    pub noise_median: f64,
    /// `1.4826 MAD` of the non-zero values.
    pub noise_sigma: f64,
    /// Values above `noise_median + LIT_SIGMAS * noise_sigma`.
    pub lit: usize,
    /// Log-average of the lit values (0 when fewer than [`MIN_LIT_BINS`]).
    pub log_average: f64,
}

/// The exposure of the module doc for signal densities `values` (non-finite and zero values
/// are left out). None when no value is positive and finite.
pub fn lit_exposure(mut values: Vec<f64>) -> Option<LitExposure> {
    values.retain(|&v| v != 0.0 && v.is_finite());
    let noise_median = quantile(&mut values, 0.5);
    let mut deviations: Vec<f64> = values.iter().map(|v| (v - noise_median).abs()).collect();
    let noise_sigma = 1.4826 * quantile(&mut deviations, 0.5);
    let floor = noise_median + LIT_SIGMAS * noise_sigma;
    let mut lit: Vec<f64> = values
        .iter()
        .copied()
        .filter(|&v| v > floor && v > 0.0)
        .collect();
    if lit.len() < MIN_LIT_BINS {
        return exposure_for(values).map(|exposure| LitExposure {
            exposure,
            noise_median,
            noise_sigma,
            lit: lit.len(),
            log_average: 0.0,
        });
    }
    let log_average = (lit.iter().map(|v| v.ln()).sum::<f64>() / lit.len() as f64).exp();
    let peak = quantile(&mut lit, 0.999);
    let exposure = (KEY / log_average).clamp(1.0 / peak, MAX_PEAK_LUMINANCE / peak);
    Some(LitExposure {
        exposure,
        noise_median,
        noise_sigma,
        lit: lit.len(),
        log_average,
    })
}

/// The `q`-quantile of `values` (the element of rank `floor(q n)`, the last at most), NaN for
/// no values. Reorders `values`.
fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let k = ((values.len() as f64 * q) as usize).min(values.len() - 1);
    *values.select_nth_unstable_by(k, f64::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic noise sample: a sum of three uniform values, centred, width about 1.
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed;
        let mut u = move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n).map(|_| u() + u() + u() - 1.5).collect()
    }

    #[test]
    fn weak_late_light_is_shown_and_the_direct_pulse_keeps_gradation() {
        // 200 000 noise bins of sigma 0.5, 1 000 direct-pulse bins at 1000 and 20 000 bins of
        // echoes 200 times weaker, at 5.
        let mut v: Vec<f64> = noise(200_000, 7).iter().map(|n| 0.5 * n).collect();
        v.extend(std::iter::repeat_n(1000.0, 1_000));
        v.extend(std::iter::repeat_n(5.0, 20_000));
        let l = lit_exposure(v.clone()).unwrap();
        assert_eq!(l.lit, 21_000);
        let old = exposure_for(v).unwrap();
        assert!((old - 1e-3).abs() < 1e-12, "{old}");
        // Echoes at luminance >= 0.05 (12 % grey in sRGB: visible), the pulse at most 16.
        assert!(5.0 * l.exposure >= 0.05, "{l:?}");
        assert!(
            1000.0 * l.exposure <= MAX_PEAK_LUMINANCE * (1.0 + 1e-12),
            "{l:?}"
        );
        // The old exposure left the echoes at 0.005.
        assert!(5.0 * old < 0.006);
    }

    #[test]
    fn noise_alone_does_not_set_the_key() {
        // Echo bins only 1 sigma above the noise are not lit: the light is the pulse alone.
        let mut v: Vec<f64> = noise(100_000, 3).iter().map(|n| 0.5 * n).collect();
        v.extend(std::iter::repeat_n(0.25, 5_000));
        v.extend(std::iter::repeat_n(40.0, 500));
        let l = lit_exposure(v).unwrap();
        assert_eq!(l.lit, 500);
        assert!((l.log_average - 40.0).abs() < 1e-9);
        // KEY / 40 is below 1 / p: the floor applies and the pulse sits at luminance 1.
        assert!((l.exposure - 1.0 / 40.0).abs() < 1e-12, "{l:?}");
    }

    #[test]
    fn few_lit_bins_fall_back_and_empty_input_has_none() {
        assert_eq!(lit_exposure(vec![0.0, f64::NAN, -0.0]), None);
        let l = lit_exposure(vec![2.0; 10]).unwrap();
        assert_eq!(l.lit, 0);
        assert!((l.exposure - 0.5).abs() < 1e-12);
        assert_eq!(exposure_for(vec![-1.0, 0.0]), None);
    }
}

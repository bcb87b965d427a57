//! Per-scanline correction kernels for streak-camera captures.
//!
//! A streak camera records one horizontal scanline of the scene per exposure: an image of `nx`
//! pixels by `nt` time bins (physics.md, "Transient path tracing": 672 x 512 in the seed's
//! capture), and a mirror scans the rows. Each kernel here works on one such scanline in the
//! cube's row layout `[x][t]` (`row[x * nt + t]`, see [`crate::cube`]), and each corrects one
//! flaw of the instrument:
//!
//! - dark signal: [`subtract_dark`] (a constant or a dark frame of the same shape);
//! - pixel gain: [`divide_flat`] (a flat-field gain per pixel; unusable gains mask the pixel);
//! - sweep non-linearity: [`resample_sweep`] moves the recorded bins, whose true time edges
//!   are non-uniform (a calibration table, or the `.img` scaling table via
//!   [`edges_from_centres`]), onto a uniform [`TimeAxis`], conserving each pixel's integral
//!   ([`crate::resample::rebin_add`]);
//! - trigger jitter between scanlines: the per-row shifts are estimated from every pixel by
//!   [`super::row_offsets`] (a row-level front fitted through the neighbours' fronts fails
//!   where the scene's front jumps between rows, at a horizontal edge), and [`remove_shift`]
//!   moves each row back ([`crate::resample::shift_into`]);
//! - laser power drift between scanlines: [`power_factor`] integrates a reference region of
//!   the row and [`power_gains`] normalises the rows to their median (without a reference in
//!   view, see [`super::row_offsets`]);
//! - saturation: [`saturation_mask`] flags pixels whose raw profile reaches the saturation
//!   level (it lives in [`crate::saturation`], which the interop ingests share).
//!
//! Kernels take validated values and cannot fail; the `check_*` functions and
//! [`RefRegion::check`] validate the inputs once, with messages that name what is wrong.

use thiserror::Error;

use crate::cube::TimeAxis;
use crate::formats::PixelType;
use crate::resample::{rebin_add, shift_into};
pub use crate::saturation::saturation_mask;
use crate::stats::median;
use std::path::{Path, PathBuf};

/// Invalid correction inputs.
#[derive(Debug, Error, PartialEq)]
pub enum CorrectionError {
    /// The dark frame does not have one value per pixel and bin of the scanline.
    #[error("dark frame has {got} values, but a scanline has {expected} (nx x nt)")]
    DarkSize { expected: usize, got: usize },
    /// The flat field does not have one gain per pixel of the scanline.
    #[error("flat field has {got} gains, but a scanline has {expected} pixels")]
    FlatSize { expected: usize, got: usize },
    /// The sweep table does not have `nt + 1` bin edges.
    #[error("sweep table has {got} bin edges, but {expected} bins need {} edges", expected + 1)]
    SweepEdgeCount { expected: usize, got: usize },
    /// A sweep-table edge is not finite or not above the previous one.
    #[error(
        "sweep table edge {index} ({edge_ps} ps) is not finite or not above the previous edge"
    )]
    SweepNotIncreasing { index: usize, edge_ps: f64 },
    /// A time scaling table (bin centres) needs at least two entries.
    #[error("time scaling table has {got} entries, at least 2 are needed")]
    TooFewCentres { got: usize },
    /// A time scaling table entry is not finite or not above the previous one.
    #[error("time scaling table entry {index} ({centre_ps} ps) is not finite or not above the previous entry")]
    CentresNotIncreasing { index: usize, centre_ps: f64 },
    /// A scanline whose samples are stored at another depth or in another format than the
    /// capture's first scanline (`reference`).
    #[error(
        "{found} samples, but the capture's are {expected} ({}): every scanline must be \
         stored alike (convert this file to the capture's format)",
        reference.display()
    )]
    MixedSampleTypes {
        found: &'static str,
        expected: &'static str,
        reference: PathBuf,
    },
    /// The power reference region is empty or leaves the scanline.
    #[error(
        "reference region x {x0}..{x1}, bins {t0_bin}..{t1_bin} is empty or outside the \
         {nx} x {nt} scanline"
    )]
    BadRegion {
        x0: usize,
        x1: usize,
        t0_bin: usize,
        t1_bin: usize,
        nx: usize,
        nt: usize,
    },
}

// ---------------------------------------------------------------------------------------------
// Sample formats.

/// What a sample type means for the values read: its width and kind. Grey stored as colour
/// (equal R, G, B) reads like grey of the same depth, so the two are the same here.
fn sample_format(t: PixelType) -> &'static str {
    match t {
        PixelType::U8 | PixelType::RgbU8 => "8-bit integer",
        PixelType::U16 | PixelType::RgbU16 => "16-bit integer",
        PixelType::U32 => "32-bit integer",
        PixelType::I16 => "16-bit signed integer",
        PixelType::I32 => "32-bit signed integer",
        PixelType::F16 | PixelType::RgbF16 => "16-bit float",
        PixelType::F32 | PixelType::RgbF32 => "32-bit float",
        PixelType::F64 => "64-bit float",
        PixelType::Rgbe => "RGBE",
    }
}

/// Refuse scanline `path` when its samples are not stored like the capture's first
/// scanline (`reference`, of type `expected`). The value scale and the saturation level are
/// set once from the first scanline, so a scanline of another depth would be read wrong
/// without a word (an 8-bit PNG among 16-bit ones, 256 times too dim).
pub fn check_sample_type(
    path: &Path,
    found: PixelType,
    expected: PixelType,
    reference: &Path,
) -> Result<(), super::IngestError> {
    if sample_format(found) == sample_format(expected) {
        return Ok(());
    }
    Err(super::IngestError::Correction {
        what: path.display().to_string(),
        source: CorrectionError::MixedSampleTypes {
            found: sample_format(found),
            expected: sample_format(expected),
            reference: reference.to_path_buf(),
        },
    })
}

// ---------------------------------------------------------------------------------------------
// Dark and flat.

/// Dark signal to subtract from a scanline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Dark<'a> {
    /// The same level in every pixel and bin.
    Constant(f32),
    /// A dark frame with the scanline's shape (`nx * nt`, layout `[x][t]`).
    Frame(&'a [f32]),
}

impl Dark<'_> {
    /// Check that the dark frame (if any) matches a scanline of `row_len = nx * nt` values.
    pub fn check(&self, row_len: usize) -> Result<(), CorrectionError> {
        match self {
            Dark::Frame(d) if d.len() != row_len => Err(CorrectionError::DarkSize {
                expected: row_len,
                got: d.len(),
            }),
            _ => Ok(()),
        }
    }
}

/// Subtract the dark signal in place.
pub fn subtract_dark(row: &mut [f32], dark: Dark<'_>) {
    match dark {
        Dark::Constant(level) => row.iter_mut().for_each(|v| *v -= level),
        Dark::Frame(frame) => {
            debug_assert_eq!(frame.len(), row.len());
            row.iter_mut().zip(frame).for_each(|(v, d)| *v -= d);
        }
    }
}

/// Check a flat field against a scanline of `nx` pixels.
pub fn check_flat(flat_per_pixel: &[f32], nx: usize) -> Result<(), CorrectionError> {
    if flat_per_pixel.len() == nx {
        Ok(())
    } else {
        Err(CorrectionError::FlatSize {
            expected: nx,
            got: flat_per_pixel.len(),
        })
    }
}

/// Divide each pixel's profile by its flat-field gain (`nx = flat_per_pixel.len()`).
///
/// A pixel whose gain is not a positive finite number is masked: its profile is set to zero and
/// `mask_row[x]` to 0 (other mask entries are left as they are, 1 = valid).
pub fn divide_flat(row: &mut [f32], flat_per_pixel: &[f32], mask_row: &mut [u8]) {
    let nx = flat_per_pixel.len();
    debug_assert_eq!(mask_row.len(), nx);
    if nx == 0 {
        return;
    }
    let nt = row.len() / nx;
    for (x, (profile, &gain)) in row.chunks_exact_mut(nt).zip(flat_per_pixel).enumerate() {
        if gain.is_finite() && gain > 0.0 {
            profile.iter_mut().for_each(|v| *v /= gain);
        } else {
            profile.iter_mut().for_each(|v| *v = 0.0);
            mask_row[x] = 0;
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Sweep linearity.

/// Check a sweep table: `nt + 1` finite, strictly increasing bin edges in ps.
pub fn check_sweep_edges(src_edges_ps: &[f64], nt: usize) -> Result<(), CorrectionError> {
    if src_edges_ps.len() != nt + 1 {
        return Err(CorrectionError::SweepEdgeCount {
            expected: nt,
            got: src_edges_ps.len(),
        });
    }
    for (i, &e) in src_edges_ps.iter().enumerate() {
        if !e.is_finite() || (i > 0 && e <= src_edges_ps[i - 1]) {
            return Err(CorrectionError::SweepNotIncreasing {
                index: i,
                edge_ps: e,
            });
        }
    }
    Ok(())
}

/// Bin edges from bin-centre times (the `.img` scaling table gives one time per time pixel):
/// inner edges halfway between neighbouring centres, the two outer edges half a spacing beyond
/// the first and last centre. The centres must be at least two, finite and increasing.
pub fn edges_from_centres(centres_ps: &[f64]) -> Result<Vec<f64>, CorrectionError> {
    let n = centres_ps.len();
    if n < 2 {
        return Err(CorrectionError::TooFewCentres { got: n });
    }
    for (i, &c) in centres_ps.iter().enumerate() {
        if !c.is_finite() || (i > 0 && c <= centres_ps[i - 1]) {
            return Err(CorrectionError::CentresNotIncreasing {
                index: i,
                centre_ps: c,
            });
        }
    }
    let mut edges = Vec::with_capacity(n + 1);
    edges.push(centres_ps[0] - 0.5 * (centres_ps[1] - centres_ps[0]));
    edges.extend(centres_ps.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    edges.push(centres_ps[n - 1] + 0.5 * (centres_ps[n - 1] - centres_ps[n - 2]));
    Ok(edges)
}

/// Resample every pixel of a scanline from its recorded bins, whose true time edges are
/// `src_edges_ps` (`nt + 1` increasing values, see [`check_sweep_edges`]), onto the uniform
/// `dst_axis`. `out` (`nx * dst_axis.nt`, layout `[x][t]`) is overwritten. Each pixel's
/// integral is conserved where `dst_axis` covers the recorded interval.
pub fn resample_sweep(
    row: &[f32],
    nx: usize,
    src_edges_ps: &[f64],
    dst_axis: &TimeAxis,
    out: &mut [f32],
) {
    let nt = src_edges_ps.len() - 1;
    debug_assert_eq!(row.len(), nx * nt);
    debug_assert_eq!(out.len(), nx * dst_axis.nt);
    out.iter_mut().for_each(|v| *v = 0.0);
    if nt == 0 || dst_axis.nt == 0 {
        return;
    }
    for (src, dst) in row.chunks_exact(nt).zip(out.chunks_exact_mut(dst_axis.nt)) {
        rebin_add(src_edges_ps, src, dst_axis, dst);
    }
}

// ---------------------------------------------------------------------------------------------
// Jitter.

/// Move a scanline back by `shift_ps` (the row was recorded `shift_ps` late; positive = earlier
/// output), rebinning each pixel with [`shift_into`] onto the same axis. `out` has the row's
/// shape and is overwritten. Signal shifted past either end of the axis is lost.
pub fn remove_shift(row: &[f32], nx: usize, axis: &TimeAxis, shift_ps: f64, out: &mut [f32]) {
    let nt = axis.nt;
    debug_assert_eq!(row.len(), nx * nt);
    debug_assert_eq!(out.len(), nx * nt);
    if nt == 0 {
        return;
    }
    for (src, dst) in row.chunks_exact(nt).zip(out.chunks_exact_mut(nt)) {
        shift_into(axis, src, -shift_ps, axis, dst);
    }
}

// ---------------------------------------------------------------------------------------------
// Laser power.

/// A block of a scanline that sees a fixed part of the scene (for example the laser spot on
/// the diffuser), used as a laser-power reference: pixels `x0..x1`, bins `t0_bin..t1_bin`
/// (half-open).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RefRegion {
    pub x0: usize,
    pub x1: usize,
    pub t0_bin: usize,
    pub t1_bin: usize,
}

impl RefRegion {
    /// Check that the region is non-empty and inside an `nx` x `nt` scanline.
    pub fn check(&self, nx: usize, nt: usize) -> Result<(), CorrectionError> {
        if self.x0 < self.x1 && self.x1 <= nx && self.t0_bin < self.t1_bin && self.t1_bin <= nt {
            Ok(())
        } else {
            Err(CorrectionError::BadRegion {
                x0: self.x0,
                x1: self.x1,
                t0_bin: self.t0_bin,
                t1_bin: self.t1_bin,
                nx,
                nt,
            })
        }
    }
}

/// Integrated signal of the reference region of one scanline (proportional to the laser power
/// during that scanline's exposure). Non-finite values are skipped.
pub fn power_factor(row: &[f32], nx: usize, nt: usize, region: RefRegion) -> f64 {
    debug_assert_eq!(row.len(), nx * nt);
    debug_assert!(region.check(nx, nt).is_ok());
    (region.x0..region.x1)
        .flat_map(|x| &row[x * nt + region.t0_bin..x * nt + region.t1_bin])
        .filter(|v| v.is_finite())
        .map(|&v| v as f64)
        .sum()
}

/// Gain per row that brings each row's power factor to the median over the rows with a
/// positive finite factor: `median / factor_y`. `None` for rows whose factor is unusable
/// (zero, negative or not finite), and for all rows if none is usable.
pub fn power_gains(factors: &[f64]) -> Vec<Option<f64>> {
    let usable = |f: f64| f.is_finite() && f > 0.0;
    let mut good: Vec<f64> = factors.iter().copied().filter(|&f| usable(f)).collect();
    if good.is_empty() {
        return vec![None; factors.len()];
    }
    let median = median(&mut good);
    factors
        .iter()
        .map(|&f| usable(f).then(|| median / f))
        .collect()
}

/// Multiply a scanline by a gain (from [`power_gains`]).
pub fn apply_gain(row: &mut [f32], gain: f64) {
    row.iter_mut().for_each(|v| *v = (*v as f64 * gain) as f32);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use rand_pcg::Pcg64;

    /// erf, Abramowitz & Stegun 7.1.26 (absolute error below 1.5e-7).
    fn erf(x: f64) -> f64 {
        let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
        let poly = t
            * (0.254_829_592
                + t * (-0.284_496_736
                    + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
        let y = 1.0 - poly * (-x * x).exp();
        y.copysign(x)
    }

    /// Integral over [a, b] of a Gaussian pulse of area `area`, centre `mu`, width `sigma`.
    fn gauss_integral(area: f64, mu: f64, sigma: f64, a: f64, b: f64) -> f64 {
        let s = sigma * std::f64::consts::SQRT_2;
        0.5 * area * (erf((b - mu) / s) - erf((a - mu) / s))
    }

    fn axis(t0_ps: f64, dt_ps: f64, nt: usize) -> TimeAxis {
        TimeAxis { t0_ps, dt_ps, nt }
    }

    /// Centroid (ps) of a profile on `axis` over the bins whose centre lies in [lo, hi].
    fn centroid_ps(profile: &[f32], axis: &TimeAxis, lo: f64, hi: f64) -> f64 {
        let (mut m0, mut m1) = (0.0, 0.0);
        for (i, &v) in profile.iter().enumerate() {
            let t = axis.bin_centre_ps(i);
            if t >= lo && t <= hi {
                m0 += v as f64;
                m1 += v as f64 * t;
            }
        }
        m1 / m0
    }

    #[test]
    fn dark_subtraction_is_exact() {
        let (nx, nt) = (4, 6);
        let truth: Vec<f32> = (0..nx * nt).map(|i| ((i * 37) % 1000) as f32).collect();
        let dark_frame: Vec<f32> = (0..nx * nt).map(|i| 95.0 + (i % 11) as f32).collect();

        let mut row: Vec<f32> = truth.iter().map(|v| v + 100.0).collect();
        subtract_dark(&mut row, Dark::Constant(100.0));
        assert_eq!(row, truth);

        let mut row: Vec<f32> = truth.iter().zip(&dark_frame).map(|(v, d)| v + d).collect();
        let dark = Dark::Frame(&dark_frame);
        dark.check(nx * nt).unwrap();
        subtract_dark(&mut row, dark);
        assert_eq!(row, truth);

        assert_eq!(
            Dark::Frame(&dark_frame[1..]).check(nx * nt),
            Err(CorrectionError::DarkSize {
                expected: 24,
                got: 23
            })
        );
    }

    #[test]
    fn flat_division_is_exact_and_masks_unusable_gains() {
        let nt = 5;
        let flat = [
            0.5f32,
            2.0,
            1.0,
            4.0,
            0.0,
            -1.0,
            f32::NAN,
            f32::INFINITY,
            0.25,
            1.37,
        ];
        let nx = flat.len();
        check_flat(&flat, nx).unwrap();
        assert!(check_flat(&flat[1..], nx).is_err());
        let truth: Vec<f32> = (0..nx * nt).map(|i| (i * 13 % 97) as f32 + 1.0).collect();
        let mut row: Vec<f32> = truth
            .iter()
            .enumerate()
            .map(|(i, v)| v * flat[i / nt])
            .collect();
        let mut mask = vec![1u8; nx];
        divide_flat(&mut row, &flat, &mut mask);
        assert_eq!(mask, [1, 1, 1, 1, 0, 0, 0, 0, 1, 1]);
        for x in 0..nx {
            for t in 0..nt {
                let (got, want) = (row[x * nt + t], truth[x * nt + t]);
                match mask[x] {
                    0 => assert_eq!(got, 0.0),
                    // Power-of-two gains divide exactly; 1.37 within one rounding each way.
                    _ if x < 9 => assert_eq!(got, want),
                    _ => assert!((got - want).abs() <= 2.0 * f32::EPSILON * want),
                }
            }
        }
    }

    #[test]
    fn sweep_resampling_conserves_integrals_and_puts_peaks_in_place() {
        // The recorded bins widen from 2 ps to 3 ps across the sweep:
        // edge_i = 100 + 2 i + i^2 / (2 nt) ps, from 100 ps to 600 ps.
        let (nx, nt) = (3usize, 200usize);
        let edges: Vec<f64> = (0..=nt)
            .map(|i| 100.0 + 2.0 * i as f64 + (i * i) as f64 / (2.0 * nt as f64))
            .collect();
        check_sweep_edges(&edges, nt).unwrap();
        // Two pulses per pixel, at times that move with x.
        let pulses = |x: usize| {
            [
                (1000.0, 180.0 + 10.0 * x as f64, 5.0),
                (400.0, 450.0 + 7.0 * x as f64, 6.0),
            ]
        };
        let mut row = vec![0.0f32; nx * nt];
        for x in 0..nx {
            for i in 0..nt {
                row[x * nt + i] = pulses(x)
                    .iter()
                    .map(|&(a, mu, s)| gauss_integral(a, mu, s, edges[i], edges[i + 1]))
                    .sum::<f64>() as f32;
            }
        }
        let dst = axis(100.0, 2.5, 200);
        let mut out = vec![0.0f32; nx * dst.nt];
        resample_sweep(&row, nx, &edges, &dst, &mut out);

        let naive = axis(100.0, 2.5, nt); // reading the recorded bins as if uniform
        let (mut worst_total, mut worst_peak_bins) = (0.0f64, 0.0f64);
        for x in 0..nx {
            let src = &row[x * nt..(x + 1) * nt];
            let res = &out[x * dst.nt..(x + 1) * dst.nt];
            let total_src: f64 = src.iter().map(|&v| v as f64).sum();
            let total_dst: f64 = res.iter().map(|&v| v as f64).sum();
            let rel = ((total_dst - total_src) / total_src).abs();
            worst_total = worst_total.max(rel);
            assert!(rel < 1e-5, "pixel {x}: {total_src} -> {total_dst}");
            for (_, mu, s) in pulses(x) {
                let c = centroid_ps(res, &dst, mu - 5.0 * s, mu + 5.0 * s);
                worst_peak_bins = worst_peak_bins.max(((c - mu) / dst.dt_ps).abs());
                assert!(
                    ((c - mu) / dst.dt_ps).abs() < 0.1,
                    "pixel {x}: peak at {c} ps, true {mu} ps"
                );
            }
            // Read as if uniform, the first peak lands several bins late: the flaw is real.
            let (_, mu, _) = pulses(x)[0];
            let c_naive = centroid_ps(src, &naive, mu - 60.0, mu + 60.0);
            assert!((c_naive - mu) / dst.dt_ps > 3.0, "{c_naive}");
        }
        eprintln!(
            "sweep: integral conserved to {worst_total:.1e}, peaks within {worst_peak_bins:.3} bins"
        );
    }

    #[test]
    fn sweep_tables_are_validated_and_centres_become_edges() {
        assert_eq!(
            check_sweep_edges(&[0.0, 1.0], 2),
            Err(CorrectionError::SweepEdgeCount {
                expected: 2,
                got: 2
            })
        );
        assert_eq!(
            check_sweep_edges(&[0.0, 1.0, 1.0], 2),
            Err(CorrectionError::SweepNotIncreasing {
                index: 2,
                edge_ps: 1.0
            })
        );
        assert!(check_sweep_edges(&[0.0, f64::NAN, 2.0], 2).is_err());
        // A uniform table: the edges are exactly the bin boundaries.
        let centres: Vec<f64> = (0..5).map(|i| 10.0 + 2.0 * (i as f64 + 0.5)).collect();
        assert_eq!(
            edges_from_centres(&centres).unwrap(),
            [10.0, 12.0, 14.0, 16.0, 18.0, 20.0]
        );
        // Non-uniform: inner edges are midpoints.
        assert_eq!(
            edges_from_centres(&[0.0, 1.0, 3.0]).unwrap(),
            [-0.5, 0.5, 2.0, 4.0]
        );
        assert!(edges_from_centres(&[1.0]).is_err());
        assert!(edges_from_centres(&[1.0, 0.5]).is_err());
    }

    /// A synthetic scanning capture: every pixel sees a short direct pulse whose arrival
    /// (in bins) is `front_bins(x, y)` plus the row's jitter, followed by a broader, weaker
    /// indirect bump; constant ambient background and Gaussian read noise.
    struct Scene {
        nx: usize,
        ny: usize,
        axis: TimeAxis,
    }

    impl Scene {
        fn front_bins(&self, x: usize, y: usize) -> f64 {
            // A front that curves strongly with y (a hyperbola, as a plane seen at an angle).
            30.0 + 0.15 * x as f64 + 12.0 * (1.0 + ((y as f64 - 70.0) / 30.0).powi(2)).sqrt()
        }

        fn row(&self, y: usize, jitter_bins: f64, power: f64, rng: Option<&mut Pcg64>) -> Vec<f32> {
            let (nx, nt, dt) = (self.nx, self.axis.nt, self.axis.dt_ps);
            let mut row = vec![0.0f32; nx * nt];
            for x in 0..nx {
                let t_direct = self.axis.t0_ps + (self.front_bins(x, y) + jitter_bins) * dt;
                let area = power * 300.0 * (1.0 + 0.5 * (x as f64 / 4.0).sin());
                for i in 0..nt {
                    let (a, b) = (self.axis.bin_start_ps(i), self.axis.bin_start_ps(i + 1));
                    row[x * nt + i] = (gauss_integral(area, t_direct, 1.5 * dt, a, b)
                        + gauss_integral(0.4 * area, t_direct + 12.0 * dt, 4.0 * dt, a, b)
                        + 1.0) as f32;
                }
            }
            if let Some(rng) = rng {
                let noise = Normal::new(0.0, 0.3).unwrap();
                row.iter_mut().for_each(|v| *v += noise.sample(rng) as f32);
            }
            row
        }
    }

    #[test]
    fn remove_shift_moves_the_pulse_back_and_conserves_it() {
        let ax = axis(0.0, 2.0, 64);
        let (mu, sigma, jitter_ps) = (50.0, 4.0, 3.3);
        let profile = |shift: f64| -> Vec<f32> {
            (0..ax.nt)
                .map(|i| {
                    let (a, b) = (ax.bin_start_ps(i), ax.bin_start_ps(i + 1));
                    gauss_integral(100.0, mu + shift, sigma, a, b) as f32
                })
                .collect()
        };
        let late = profile(jitter_ps);
        let mut out = vec![0.0f32; ax.nt];
        remove_shift(&late, 1, &ax, jitter_ps, &mut out);
        let total: f64 = out.iter().map(|&v| v as f64).sum();
        assert!((total - 100.0).abs() < 1e-4);
        let c = centroid_ps(&out, &ax, 0.0, 128.0);
        assert!(((c - mu) / ax.dt_ps).abs() < 0.02, "centroid {c}");
    }

    #[test]
    fn power_normalisation_recovers_the_laser_drift() {
        let scene = Scene {
            nx: 16,
            ny: 40,
            axis: axis(0.0, 2.0, 96),
        };
        let (nx, nt) = (scene.nx, scene.axis.nt);
        let mut rng = Pcg64::seed_from_u64(7);
        let powers: Vec<f64> = (0..scene.ny)
            .map(|y| 1.0 + 0.25 * (1.3 * y as f64).sin() + 0.05 * (y % 3) as f64)
            .collect();
        // Pixels 0..3 see the laser spot on the diffuser, the brightest thing in the capture: a
        // fixed pulse at 20 ps, on a dark background, whatever the row.
        let region = RefRegion {
            x0: 0,
            x1: 3,
            t0_bin: 2,
            t1_bin: 20,
        };
        region.check(nx, nt).unwrap();
        let mut rows: Vec<Vec<f32>> = Vec::new();
        for (y, &p) in powers.iter().enumerate() {
            let mut row = scene.row(y, 0.0, p, Some(&mut rng));
            for x in region.x0..region.x1 {
                for i in 0..nt {
                    let (a, b) = (scene.axis.bin_start_ps(i), scene.axis.bin_start_ps(i + 1));
                    row[x * nt + i] = (gauss_integral(5000.0 * p, 20.0, 3.0, a, b)
                        + Normal::new(0.0, 0.3).unwrap().sample(&mut rng))
                        as f32;
                }
            }
            rows.push(row);
        }
        let factors: Vec<f64> = rows
            .iter()
            .map(|r| power_factor(r, nx, nt, region))
            .collect();
        let gains = power_gains(&factors);
        let mut sorted = powers.clone();
        sorted.sort_by(f64::total_cmp);
        let median_power = 0.5 * (sorted[19] + sorted[20]);
        let mut worst = 0.0f64;
        for (y, g) in gains.iter().enumerate() {
            let want = median_power / powers[y];
            let g = g.unwrap();
            worst = worst.max((g / want - 1.0).abs());
            assert!(
                (g / want - 1.0).abs() < 0.01,
                "row {y}: gain {g}, want {want}"
            );
        }
        eprintln!("power gains: worst relative error {worst:.1e}");
        // After the gain, a scene pixel's integral is that of the median power.
        let x = 8;
        for (y, &p) in powers.iter().enumerate() {
            let mut row = scene.row(y, 0.0, p, None);
            apply_gain(&mut row, gains[y].unwrap());
            let reference = scene.row(y, 0.0, median_power, None);
            let got: f64 = row[x * nt..(x + 1) * nt].iter().map(|&v| v as f64).sum();
            // The ambient background (1 per bin) is not laser light and gets scaled too.
            let want: f64 = reference[x * nt..(x + 1) * nt]
                .iter()
                .map(|&v| v as f64 - 1.0)
                .sum::<f64>()
                + gains[y].unwrap() * nt as f64;
            assert!((got / want - 1.0).abs() < 0.01, "row {y}: {got} vs {want}");
        }
    }

    #[test]
    fn power_gains_skip_unusable_rows_and_regions_are_checked() {
        let gains = power_gains(&[2.0, 0.0, 4.0, f64::NAN, 1.0, -3.0]);
        assert_eq!(gains, [Some(1.0), None, Some(0.5), None, Some(2.0), None]);
        assert_eq!(power_gains(&[0.0, f64::NAN]), [None, None]);
        let bad = RefRegion {
            x0: 3,
            x1: 3,
            t0_bin: 0,
            t1_bin: 4,
        };
        assert!(bad.check(8, 8).is_err());
        let outside = RefRegion {
            x0: 0,
            x1: 9,
            t0_bin: 0,
            t1_bin: 4,
        };
        assert!(outside
            .check(8, 8)
            .unwrap_err()
            .to_string()
            .contains("0..9"));
    }

    /// Grey stored as colour reads like grey of its depth; any other difference of depth or
    /// kind is refused, naming both formats and the reference scanline.
    #[test]
    fn sample_types_must_match_the_first_scanline() {
        use std::path::Path;
        let (p, r) = (Path::new("s_0003.png"), Path::new("s_0000.png"));
        let ok = [
            (PixelType::U16, PixelType::U16),
            (PixelType::RgbU16, PixelType::U16),
            (PixelType::U8, PixelType::RgbU8),
            (PixelType::RgbF32, PixelType::F32),
        ];
        for (found, expected) in ok {
            assert!(
                check_sample_type(p, found, expected, r).is_ok(),
                "{found:?}"
            );
        }
        let refused = [
            (PixelType::U8, PixelType::U16),
            (PixelType::U16, PixelType::U32),
            (PixelType::F16, PixelType::F32),
            (PixelType::I16, PixelType::U16),
            (PixelType::F32, PixelType::U16),
        ];
        for (found, expected) in refused {
            let e = check_sample_type(p, found, expected, r)
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with("s_0003.png: ") && e.contains("(s_0000.png)"),
                "{found:?}: {e}"
            );
            assert!(e.contains(sample_format(found)) && e.contains(sample_format(expected)));
        }
        assert_eq!(
            check_sample_type(p, PixelType::U8, PixelType::U16, r)
                .unwrap_err()
                .to_string(),
            "s_0003.png: 8-bit integer samples, but the capture's are 16-bit integer \
             (s_0000.png): every scanline must be stored alike (convert this file to the \
             capture's format)"
        );
    }
}

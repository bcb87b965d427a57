//! Time unwarp: camera time to world time per pixel, and back (seed Eq. 2).
//!
//! physics.md, "Units and clocks": light seen at camera time `t_camera` by a pixel whose
//! surface point lies `d` metres from the camera centre left that point at
//! `t_world = t_camera - eta * d / c` (Euclidean distance, not z-depth). Unwarping shifts each
//! pixel's profile by `-eta * d / c`; the inverse, [`Direction::WorldToCamera`], shifts by
//! `+eta * d / c` and, given the distances to *another* camera position, re-warps a world-time
//! cube for that view (what the renderer does for a new viewpoint).
//!
//! Shifts are fractions of a bin, so profiles are resampled with the energy-conserving scheme
//! of [`crate::resample`]: the signal is taken as constant within each source bin and
//! integrated over each destination bin. Each pixel's time integral is unchanged as long as
//! the destination axis covers the shifted data ([`covering_axis`] builds such an axis).
//!
//! # Resampling error
//!
//! Piecewise-constant reconstruction followed by box integration returns, for a shift of
//! `k + f` bins, `(1 - f) c[j - k] + f c[j - k - 1]`: the linear interpolation, between the two
//! neighbouring whole-bin shifts, of the exactly binned shifted signal. Equivalently, the exact
//! shifted bin values blurred by a two-point kernel one bin wide (weight `1 - f` at `-f` bins,
//! `f` at `1 - f` bins): its mean offset is zero, so pulses are widened, not moved, and sums
//! are kept. For a signal `s(t)` the
//! error per bin is at most `dt^3 / 8 * max|s''|` (interpolation error of the bin-integral
//! function `g(u) = integral of s over [u, u + dt]`, whose second derivative is at most
//! `dt * max|s''|`). For a Gaussian pulse of standard deviation `sigma` that is
//! `(dt / sigma)^2 / 8` of its peak density times `dt`, i.e. about `(dt / sigma)^2 / 8` of the
//! peak bin. Measured in this module's tests on erf-binned Gaussian pulses (worst over 32
//! fractional shifts, relative to the peak bin): 10.7 % for `sigma = 1 dt`, 3.0 % for
//! `sigma = 2 dt`, 0.77 % for `sigma = 4 dt`, against bounds of 13.2 %, 3.2 % and 0.78 %
//! (the bound is nearly reached at half-bin shifts). A camera -> world -> camera round
//! trip convolves with `[a, 1 - 2a, a]`, `a = f (1 - f) <= 1/4`, so its error is at most
//! `f (1 - f) dt^3 max|s''|`, twice the one-way bound: measured 3.6 % of the peak bin for
//! `sigma = 2.5 dt` (bound 4.1 %).
//!
//! Pixels without geometry (distance NaN, infinite or negative) or masked out in the input
//! come out as zeros with mask 0.

use crate::cube::{Cube, TimeAxis, TimeFrame};
use crate::limits::{bounded_count, check_memory, short_number, LimitError, MAX_COUNT};
use crate::resample;
use crate::units::flight_time_ps;
use rayon::prelude::*;

/// Which way to move a profile between the two clocks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// `t_world = t_camera - eta * d / c`: shift earlier by the flight time.
    CameraToWorld,
    /// `t_camera = t_world + eta * d / c`: shift later by the flight time.
    WorldToCamera,
}

impl Direction {
    /// The clock of the input cube.
    pub fn source_frame(self) -> TimeFrame {
        match self {
            Direction::CameraToWorld => TimeFrame::Camera,
            Direction::WorldToCamera => TimeFrame::World,
        }
    }

    /// The clock of the output cube.
    pub fn target_frame(self) -> TimeFrame {
        match self {
            Direction::CameraToWorld => TimeFrame::World,
            Direction::WorldToCamera => TimeFrame::Camera,
        }
    }

    /// Time shift in ps applied to a profile seen at `dist_m` metres in a medium of index `eta`.
    #[inline]
    pub fn shift_ps(self, eta: f64, dist_m: f64) -> f64 {
        self.toward_target(flight_time_ps(eta, dist_m))
    }

    /// A delay `delay_ps` of the camera clock behind the world's (a flight time, a scanline's
    /// trigger offset) as a shift of this direction: removed going to world time, added back
    /// going to camera time.
    #[inline]
    pub fn toward_target(self, delay_ps: f64) -> f64 {
        match self {
            Direction::CameraToWorld => -delay_ps,
            Direction::WorldToCamera => delay_ps,
        }
    }
}

/// Errors of [`unwarp_cube`].
#[derive(Debug, thiserror::Error)]
pub enum UnwarpError {
    /// The distance map does not have one value per pixel.
    #[error("distance map has {found} values, the cube has {expected} pixels ({nx} x {ny})")]
    DistanceMapSize {
        /// Pixels in the cube.
        expected: usize,
        /// Values in the distance map.
        found: usize,
        /// Cube width.
        nx: usize,
        /// Cube height.
        ny: usize,
    },
    /// The cube is in the wrong clock for the requested direction.
    #[error("cube is in {found} time, {direction:?} needs a {expected}-time cube")]
    WrongFrame {
        /// The requested direction.
        direction: Direction,
        /// The frame that direction reads.
        expected: TimeFrame,
        /// The frame of the cube.
        found: TimeFrame,
    },
    /// The refractive index is not a finite positive number.
    #[error("refractive index eta must be finite and positive, got {0}")]
    BadEta(f64),
    /// The output axis or the output cube is larger than a loop may walk or the machine
    /// can hold.
    #[error(transparent)]
    Limit(#[from] LimitError),
    /// The requested output axis has a non-positive or non-finite bin width or start.
    #[error("output time axis must have a finite start and a positive bin width, got t0 {t0_ps} ps, dt {dt_ps} ps")]
    BadAxis {
        /// Requested start, ps.
        t0_ps: f64,
        /// Requested bin width, ps.
        dt_ps: f64,
    },
}

/// Whether a distance means "there is geometry at this pixel".
#[inline]
fn has_geometry(dist_m: f32) -> bool {
    dist_m.is_finite() && dist_m >= 0.0
}

/// An axis with the bin width of `in_axis` that covers every profile of `in_axis` shifted
/// for distances in `[min_dist_m, max_dist_m]`. Its bins are aligned with those of `in_axis`
/// (its start differs by a whole number of bins), so a shift that is a whole number of bins
/// moves bins exactly. Distances must be finite; their order does not matter. Refused when
/// its bin count is not finite or beyond [`crate::limits::MAX_COUNT`] (a bin width of
/// 1e-300 ps, a distance of 1e12 m), before any buffer is sized by it.
pub fn covering_axis(
    in_axis: &TimeAxis,
    min_dist_m: f64,
    max_dist_m: f64,
    eta: f64,
    direction: Direction,
) -> Result<TimeAxis, LimitError> {
    let a = direction.shift_ps(eta, min_dist_m);
    let b = direction.shift_ps(eta, max_dist_m);
    let (lo_ps, hi_ps) = (a.min(b), a.max(b));
    // The data occupies [lo, nt + hi] in input-bin coordinates.
    let k_lo = (lo_ps / in_axis.dt_ps).floor();
    let k_hi = (hi_ps / in_axis.dt_ps).ceil();
    let nt = bounded_count(
        in_axis.nt as f64 + k_hi - k_lo,
        MAX_COUNT,
        format_args!(
            "the time axis covering distances of {} to {} m in bins of {} ps (bins)",
            short_number(min_dist_m),
            short_number(max_dist_m),
            short_number(in_axis.dt_ps)
        ),
        "check the cube's dt_ps and the registration's dist_m, or give the output axis \
         (--t0-ps, --nt)",
    )?;
    Ok(TimeAxis {
        t0_ps: in_axis.t0_ps + k_lo * in_axis.dt_ps,
        dt_ps: in_axis.dt_ps,
        nt,
    })
}

/// Shift `rows` full rows of `nx` pixels (`src_rows`: `[y][x][t]` on `src_axis`) into
/// `dst_rows` (`[y][x][t]` on `dst_axis`), one shift per pixel from `dist_m` (metres, one per
/// pixel of these rows; NaN, infinite or negative = no geometry) and, when `row_delay_ps` is
/// not empty, one delay of the camera clock per row (a scanline's trigger offset, ps; NaN:
/// none). A pixel with no geometry or with `mask` 0 is written as zeros with `dst_mask` 0;
/// every other pixel gets `dst_mask` 1. Runs in parallel over pixels.
///
/// Panics if a slice length does not match `nx`, `rows` and the axes.
#[allow(clippy::too_many_arguments)]
pub fn unwarp_rows(
    src_rows: &[f32],
    nx: usize,
    rows: usize,
    src_axis: &TimeAxis,
    dist_m: &[f32],
    row_delay_ps: &[f64],
    mask: Option<&[u8]>,
    eta: f64,
    direction: Direction,
    dst_axis: &TimeAxis,
    dst_rows: &mut [f32],
    dst_mask: &mut [u8],
) {
    let n_pix = nx * rows;
    let (nt_src, nt_dst) = (src_axis.nt, dst_axis.nt);
    assert_eq!(src_rows.len(), n_pix * nt_src, "source rows size");
    assert_eq!(dst_rows.len(), n_pix * nt_dst, "destination rows size");
    assert_eq!(dist_m.len(), n_pix, "distance map size");
    assert_eq!(dst_mask.len(), n_pix, "destination mask size");
    if let Some(m) = mask {
        assert_eq!(m.len(), n_pix, "source mask size");
    }
    assert!(
        row_delay_ps.is_empty() || row_delay_ps.len() == rows,
        "row delays size"
    );
    let row_delay = |p: usize| {
        let d = row_delay_ps.get(p / nx.max(1)).copied().unwrap_or(0.0);
        if d.is_finite() {
            d
        } else {
            0.0
        }
    };
    let valid = |p: usize| has_geometry(dist_m[p]) && mask.is_none_or(|m| m[p] != 0);
    dst_mask
        .par_iter_mut()
        .enumerate()
        .for_each(|(p, m)| *m = valid(p) as u8);
    if nt_dst == 0 {
        return;
    }
    dst_rows
        .par_chunks_mut(nt_dst)
        .enumerate()
        .with_min_len(64)
        .for_each(|(p, dst)| {
            if valid(p) {
                let src = &src_rows[p * nt_src..(p + 1) * nt_src];
                let shift_ps = direction.shift_ps(eta, dist_m[p] as f64)
                    + direction.toward_target(row_delay(p));
                resample::shift_into(src_axis, src, shift_ps, dst_axis, dst);
            } else {
                dst.fill(0.0);
            }
        });
}

/// Shift a whole cube between clocks (see [`unwarp_rows`]). `dist_m` holds one distance per
/// pixel, `[y][x]`. With `axis` `None` the output axis is [`covering_axis`] for the range of
/// distances of the valid pixels, so nothing is lost; a given axis may be coarser or finer
/// and clips what falls outside it. The output always carries a mask.
pub fn unwarp_cube(
    cube: &Cube,
    dist_m: &[f32],
    eta: f64,
    direction: Direction,
    axis: Option<TimeAxis>,
) -> Result<Cube, UnwarpError> {
    let n_pix = cube.nx * cube.ny;
    if dist_m.len() != n_pix {
        return Err(UnwarpError::DistanceMapSize {
            expected: n_pix,
            found: dist_m.len(),
            nx: cube.nx,
            ny: cube.ny,
        });
    }
    if cube.frame != direction.source_frame() {
        return Err(UnwarpError::WrongFrame {
            direction,
            expected: direction.source_frame(),
            found: cube.frame,
        });
    }
    if !(eta.is_finite() && eta > 0.0) {
        return Err(UnwarpError::BadEta(eta));
    }
    let mask = cube.mask.as_deref();
    let dst_axis = match axis {
        Some(a) => {
            if !(a.t0_ps.is_finite() && a.dt_ps.is_finite() && a.dt_ps > 0.0) {
                return Err(UnwarpError::BadAxis {
                    t0_ps: a.t0_ps,
                    dt_ps: a.dt_ps,
                });
            }
            a
        }
        None => {
            let (lo, hi) = dist_m
                .iter()
                .enumerate()
                .filter(|&(p, &d)| has_geometry(d) && mask.is_none_or(|m| m[p] != 0))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (_, &d)| {
                    (lo.min(d as f64), hi.max(d as f64))
                });
            if lo <= hi {
                covering_axis(&cube.axis, lo, hi, eta, direction)?
            } else {
                cube.axis
            }
        }
    };
    check_memory(
        4.0 * n_pix as f64 * dst_axis.nt as f64,
        format_args!(
            "the unwarped cube of {} x {} pixels x {} bins",
            cube.nx, cube.ny, dst_axis.nt
        ),
        "give a shorter output axis",
    )?;
    let mut out = Cube::zeros(cube.nx, cube.ny, dst_axis, direction.target_frame());
    let mut out_mask = vec![0u8; n_pix];
    unwarp_rows(
        &cube.data,
        cube.nx,
        cube.ny,
        &cube.axis,
        dist_m,
        &[],
        mask,
        eta,
        direction,
        &dst_axis,
        &mut out.data,
        &mut out_mask,
    );
    out.mask = Some(out_mask);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::C_M_PER_PS;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    /// erf to ~1e-13: Taylor series below 3, continued fraction of erfc above.
    fn erf(x: f64) -> f64 {
        let ax = x.abs();
        let r = if ax < 3.0 {
            // erf(x) = 2/sqrt(pi) * sum (-1)^n x^(2n+1) / (n! (2n+1))
            let mut term = ax;
            let mut sum = ax;
            let mut n = 0.0;
            while term.abs() > 1e-17 * sum.abs() {
                n += 1.0;
                term *= -ax * ax / n;
                sum += term / (2.0 * n + 1.0);
            }
            sum * 2.0 / std::f64::consts::PI.sqrt()
        } else {
            // erfc(x) = exp(-x^2)/sqrt(pi) / (x + (1/2)/(x + 1/(x + (3/2)/(x + ...))))
            let mut frac = ax;
            for k in (1..80).rev() {
                frac = ax + (k as f64 / 2.0) / frac;
            }
            1.0 - (-ax * ax).exp() / std::f64::consts::PI.sqrt() / frac
        };
        r.copysign(x)
    }

    #[test]
    fn erf_helper_matches_tabulated_values() {
        for (x, e) in [
            (0.5, 0.520_499_877_813_046_5),
            (1.0, 0.842_700_792_949_714_9),
            (2.0, 0.995_322_265_018_952_7),
            (3.5, 0.999_999_256_901_627_7),
            (-1.0, -0.842_700_792_949_714_9),
        ] {
            assert!((erf(x) - e).abs() < 1e-13, "erf({x}) = {}", erf(x));
        }
    }

    /// A Gaussian pulse of peak density `amp` (signal per ps), centre `mu_ps`, width
    /// `sigma_ps`, integrated exactly over each bin of `axis`.
    fn binned_gaussian(axis: &TimeAxis, amp: f64, mu_ps: f64, sigma_ps: f64) -> Vec<f32> {
        let s2 = sigma_ps * std::f64::consts::SQRT_2;
        let scale = amp * sigma_ps * (std::f64::consts::PI / 2.0).sqrt();
        (0..axis.nt)
            .map(|i| {
                let a = (axis.bin_start_ps(i) - mu_ps) / s2;
                let b = (axis.bin_start_ps(i + 1) - mu_ps) / s2;
                (scale * (erf(b) - erf(a))) as f32
            })
            .collect()
    }

    fn axis(t0_ps: f64, dt_ps: f64, nt: usize) -> TimeAxis {
        TimeAxis { t0_ps, dt_ps, nt }
    }

    #[test]
    fn shift_sign_follows_eq_2() {
        // 1 m in vacuum is 3335.64 ps; camera -> world moves profiles earlier.
        let s = Direction::CameraToWorld.shift_ps(1.0, 1.0);
        assert!((s + 1.0 / C_M_PER_PS).abs() < 1e-9);
        assert!((Direction::WorldToCamera.shift_ps(1.33, 1.0) - 1.33 / C_M_PER_PS).abs() < 1e-9);
    }

    #[test]
    fn covering_axis_is_aligned_and_covers() {
        let a = axis(100.0, 2.0, 50);
        let (d_lo, d_hi) = (0.2, 0.35);
        for dir in [Direction::CameraToWorld, Direction::WorldToCamera] {
            let c = covering_axis(&a, d_hi, d_lo, 1.0, dir).unwrap();
            assert_eq!(c.dt_ps, 2.0);
            let k = (c.t0_ps - a.t0_ps) / a.dt_ps;
            assert!((k - k.round()).abs() < 1e-9, "start not aligned: {k}");
            for d in [d_lo, d_hi] {
                let s = dir.shift_ps(1.0, d);
                assert!(c.t0_ps <= a.t0_ps + s + 1e-9);
                assert!(c.end_ps() >= a.end_ps() + s - 1e-9);
                // No more than one spare bin at each end.
            }
            let span = (0.35 - 0.2) / C_M_PER_PS;
            assert!(c.nt as f64 <= a.nt as f64 + span / 2.0 + 2.0);
        }
    }

    #[test]
    fn covering_axes_beyond_any_buffer_are_refused_before_use() {
        // "capacity overflow" (issue 16): bins of 1e-300 ps, or one distance of 1e12 m.
        let tiny = axis(0.0, 1e-300, 64);
        let e = covering_axis(&tiny, 0.5, 1.2, 1.0, Direction::CameraToWorld).unwrap_err();
        assert!(e.to_string().contains("dt_ps"), "{e}");
        let a = axis(0.0, 2.0, 64);
        let e = covering_axis(&a, 0.5, 1e12, 1.0, Direction::CameraToWorld).unwrap_err();
        assert!(e.to_string().contains("dist_m"), "{e}");
        assert!(covering_axis(&a, 0.5, f64::INFINITY, 1.0, Direction::CameraToWorld).is_err());
        // A realistic span stays as it was: 0.7 m at eta 1 is 2335 ps, 1168 bins of 2 ps.
        let c = covering_axis(&a, 0.5, 1.2, 1.0, Direction::CameraToWorld).unwrap();
        assert!((64 + 1168..=64 + 1170).contains(&c.nt), "{}", c.nt);
    }

    /// A pixel whose flight time is a whole number of bins moves bit for bit.
    #[test]
    fn whole_bin_distance_copies_bins() {
        let d = 0.3f32;
        let tof_ps = d as f64 / C_M_PER_PS;
        let a = axis(10.0, tof_ps / 3.0, 8); // flight time = 3 bins
        let src: Vec<f32> = (1..=8).map(|v| v as f32 * 0.1).collect();
        let dst_axis =
            covering_axis(&a, d as f64, d as f64, 1.0, Direction::CameraToWorld).unwrap();
        let mut dst = vec![f32::NAN; dst_axis.nt];
        let mut m = [0u8];
        unwarp_rows(
            &src,
            1,
            1,
            &a,
            &[d],
            &[],
            None,
            1.0,
            Direction::CameraToWorld,
            &dst_axis,
            &mut dst,
            &mut m,
        );
        assert_eq!(m[0], 1);
        // Bin 0 of the source now starts at t0 - tof: find it on the destination axis.
        let j0 = dst_axis.bin_coord(a.t0_ps - tof_ps);
        assert!((j0 - j0.round()).abs() < 1e-6, "not aligned: {j0}");
        let j0 = j0.round() as usize;
        assert_eq!(&dst[j0..j0 + 8], &src[..]);
        assert!(dst[..j0].iter().chain(&dst[j0 + 8..]).all(|&v| v == 0.0));
    }

    /// Worst error (relative to the peak bin) of unwarping erf-binned Gaussian pulses against
    /// the erf-binned world-time truth, over fractional shifts; with the analytic bound.
    fn gaussian_unwarp_error(sigma_bins: f64) -> (f64, f64) {
        let dt = 2.0;
        let cam = axis(1000.0, dt, 96);
        let eta = 1.0;
        let amp = 3.0;
        let sigma_ps = sigma_bins * dt;
        let d_base = 0.3;
        // The camera-time pulse lands near bin 48 of the camera window.
        let mu_world_ps = 1000.0 + 48.0 * dt - flight_time_ps(eta, d_base);
        let n = 32; // fractional shifts 0, 1/32, ... of a bin
        let dists: Vec<f32> = (0..n)
            .map(|i| (d_base + (i as f64 / n as f64) * dt * C_M_PER_PS / eta) as f32)
            .collect();
        let mut cube = Cube::zeros(n, 1, cam, TimeFrame::Camera);
        for (x, &d) in dists.iter().enumerate() {
            let mu_cam_ps = mu_world_ps + flight_time_ps(eta, d as f64);
            cube.profile_mut(x, 0)
                .copy_from_slice(&binned_gaussian(&cam, amp, mu_cam_ps, sigma_ps));
        }
        let out = unwarp_cube(&cube, &dists, eta, Direction::CameraToWorld, None).unwrap();
        let truth = binned_gaussian(&out.axis, amp, mu_world_ps, sigma_ps);
        let peak = truth.iter().fold(0.0f32, |m, &v| m.max(v)) as f64;
        let mut worst = 0.0f64;
        for x in 0..n {
            for (&o, &t) in out.profile(x, 0).iter().zip(&truth) {
                worst = worst.max((o as f64 - t as f64).abs());
            }
        }
        // dt^3 / 8 * max|s''|, max|s''| = amp / sigma^2 for a Gaussian.
        let bound = dt.powi(3) / 8.0 * amp / (sigma_ps * sigma_ps);
        (worst / peak, bound / peak)
    }

    #[test]
    fn unwarp_of_analytic_pulses_is_within_the_stated_error() {
        // The figures printed here are the ones stated in the module doc.
        for sigma_bins in [1.0, 2.0, 4.0] {
            let (err, bound) = gaussian_unwarp_error(sigma_bins);
            eprintln!(
                "sigma {sigma_bins} bins: max error {:.4} % of peak (bound {:.4} %)",
                err * 100.0,
                bound * 100.0
            );
            assert!(err <= bound, "error {err} above analytic bound {bound}");
        }
    }

    /// A synthetic camera-time cube of pulses at known distances (several pulses per pixel,
    /// mask and missing geometry) unwarps to the analytically binned world-time cube.
    #[test]
    fn synthetic_cube_unwarps_to_world_truth() {
        let mut rng = Pcg64::seed_from_u64(7);
        let (nx, ny) = (6, 4);
        let cam = axis(3000.0, 1.7, 160);
        let eta = 1.33;
        let sigma_ps = 3.0 * 1.7;
        let dist_m: Vec<f32> = (0..nx * ny)
            .map(|_| rng.random_range(0.9..1.0f32))
            .collect();
        // World-time pulses (centre, amplitude) per pixel, placed so that their camera-time
        // images lie well inside the camera window.
        let pulses: Vec<Vec<(f64, f64)>> = (0..nx * ny)
            .map(|p| {
                let tof_ps = eta * dist_m[p] as f64 / C_M_PER_PS;
                (0..3)
                    .map(|_| {
                        let mu_cam_ps = rng.random_range(3060.0..3210.0);
                        (mu_cam_ps - tof_ps, rng.random_range(0.5..2.0))
                    })
                    .collect()
            })
            .collect();
        let mut cube = Cube::zeros(nx, ny, cam, TimeFrame::Camera);
        let mut mask = vec![1u8; nx * ny];
        mask[5] = 0;
        let mut dist_in = dist_m.clone();
        dist_in[9] = f32::NAN;
        for p in 0..nx * ny {
            let tof_ps = eta * dist_m[p] as f64 / C_M_PER_PS;
            let prof = &mut cube.data[p * cam.nt..(p + 1) * cam.nt];
            for &(mu_w, a) in &pulses[p] {
                for (v, b) in prof
                    .iter_mut()
                    .zip(binned_gaussian(&cam, a, mu_w + tof_ps, sigma_ps))
                {
                    *v += b;
                }
            }
        }
        cube.mask = Some(mask);
        let out = unwarp_cube(&cube, &dist_in, eta, Direction::CameraToWorld, None).unwrap();
        assert_eq!(out.frame, TimeFrame::World);
        let out_mask = out.mask.as_ref().unwrap();
        let amp_max = 2.0;
        let bound = 1.7f64.powi(3) / 8.0 * amp_max / (sigma_ps * sigma_ps) * 3.0;
        for p in 0..nx * ny {
            let got = &out.data[p * out.axis.nt..(p + 1) * out.axis.nt];
            if p == 5 || p == 9 {
                assert_eq!(out_mask[p], 0);
                assert!(got.iter().all(|&v| v == 0.0));
                continue;
            }
            assert_eq!(out_mask[p], 1);
            let mut truth = vec![0.0f64; out.axis.nt];
            for &(mu_w, a) in &pulses[p] {
                for (t, b) in truth
                    .iter_mut()
                    .zip(binned_gaussian(&out.axis, a, mu_w, sigma_ps))
                {
                    *t += b as f64;
                }
            }
            for (j, (&g, &t)) in got.iter().zip(&truth).enumerate() {
                assert!(
                    (g as f64 - t).abs() <= bound,
                    "pixel {p} bin {j}: {g} vs truth {t} (bound {bound})"
                );
            }
        }
    }

    #[test]
    fn integrals_are_conserved_for_random_shifts() {
        let mut rng = Pcg64::seed_from_u64(11);
        let (nx, ny) = (9, 5);
        let cam = axis(-50.0, 1.9, 70);
        let mut cube = Cube::zeros(nx, ny, cam, TimeFrame::Camera);
        cube.data
            .iter_mut()
            .for_each(|v| *v = rng.random_range(0.0..1.0f32).powi(4) * 1e3);
        let dist: Vec<f32> = (0..nx * ny)
            .map(|_| rng.random_range(0.0..0.05f32))
            .collect();
        let before = cube.time_integral();
        // Covering axis with the same bin width, then a finer and a coarser covering axis.
        let cover = covering_axis(&cam, 0.0, 0.05, 1.5, Direction::CameraToWorld).unwrap();
        let finer = axis(
            cover.t0_ps - 0.3,
            0.7,
            (cover.nt as f64 * 1.9 / 0.7) as usize + 2,
        );
        let coarser = axis(
            cover.t0_ps - 1.1,
            5.3,
            (cover.nt as f64 * 1.9 / 5.3) as usize + 2,
        );
        for ax in [None, Some(finer), Some(coarser)] {
            let out = unwarp_cube(&cube, &dist, 1.5, Direction::CameraToWorld, ax).unwrap();
            for (p, (b, a)) in before.iter().zip(out.time_integral()).enumerate() {
                assert!(
                    (a - b).abs() <= 1e-5 * b.abs(),
                    "pixel {p}: {b} -> {a} on {:?}",
                    out.axis
                );
            }
        }
    }

    #[test]
    fn camera_world_camera_round_trip_is_within_twice_the_error() {
        let dt = 2.0;
        let cam = axis(500.0, dt, 100);
        let eta = 1.0;
        let (amp, sigma_ps) = (1.0, 2.5 * dt);
        let n = 16;
        let dists: Vec<f32> = (0..n).map(|i| 0.5 + 0.0007 * i as f32).collect();
        let mut cube = Cube::zeros(n, 1, cam, TimeFrame::Camera);
        for x in 0..n {
            cube.profile_mut(x, 0).copy_from_slice(&binned_gaussian(
                &cam,
                amp,
                500.0 + 50.0 * dt,
                sigma_ps,
            ));
        }
        let world = unwarp_cube(&cube, &dists, eta, Direction::CameraToWorld, None).unwrap();
        assert_eq!(world.frame, TimeFrame::World);
        let back = unwarp_cube(&world, &dists, eta, Direction::WorldToCamera, Some(cam)).unwrap();
        assert_eq!(back.frame, TimeFrame::Camera);
        let bound = dt.powi(3) / 4.0 * amp / (sigma_ps * sigma_ps);
        let mut worst = 0.0f64;
        for (x, &d) in dists.iter().enumerate() {
            // The composite kernel [a, 1 - 2a, a], a = f (1 - f), written out independently.
            let s = (cam.t0_ps - flight_time_ps(eta, d as f64) - world.axis.t0_ps) / dt;
            let f = s - s.floor();
            let a = f * (1.0 - f);
            let src = cube.profile(x, 0);
            for (j, &v) in back.profile(x, 0).iter().enumerate() {
                let at = |i: isize| src.get(i as usize).copied().unwrap_or(0.0) as f64;
                let j = j as isize;
                let expect = a * at(j - 1) + (1.0 - 2.0 * a) * at(j) + a * at(j + 1);
                assert!((v as f64 - expect).abs() < 2e-6, "x {x} bin {j}");
                worst = worst.max((v as f64 - src[j as usize] as f64).abs());
            }
        }
        let peak = cube.data.iter().fold(0.0f32, |m, &v| m.max(v)) as f64;
        eprintln!(
            "round trip: max error {:.3} % of peak (bound {:.3} %)",
            worst / peak * 100.0,
            bound / peak * 100.0
        );
        assert!(worst <= bound, "round trip error {worst} above {bound}");
        assert!(worst > 0.0);
    }

    #[test]
    fn bad_inputs_are_errors() {
        let cube = Cube::zeros(2, 2, axis(0.0, 1.0, 4), TimeFrame::Camera);
        assert!(matches!(
            unwarp_cube(&cube, &[1.0; 3], 1.0, Direction::CameraToWorld, None),
            Err(UnwarpError::DistanceMapSize { .. })
        ));
        assert!(matches!(
            unwarp_cube(&cube, &[1.0; 4], 1.0, Direction::WorldToCamera, None),
            Err(UnwarpError::WrongFrame { .. })
        ));
        assert!(matches!(
            unwarp_cube(&cube, &[1.0; 4], 0.0, Direction::CameraToWorld, None),
            Err(UnwarpError::BadEta(_))
        ));
        let bad = axis(0.0, -1.0, 4);
        assert!(matches!(
            unwarp_cube(&cube, &[1.0; 4], 1.0, Direction::CameraToWorld, Some(bad)),
            Err(UnwarpError::BadAxis { .. })
        ));
        // No valid pixel at all: output keeps the input axis and is all masked.
        let out = unwarp_cube(&cube, &[f32::NAN; 4], 1.0, Direction::CameraToWorld, None).unwrap();
        assert_eq!(out.axis, cube.axis);
        assert_eq!(out.mask, Some(vec![0; 4]));
    }
}

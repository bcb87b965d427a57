//! Temporal calibration: when did the pulse leave the laser spot, in cube time?
//!
//! Direct light from the laser spot `l`, scattered once at the surface point `p` a pixel sees,
//! reaches a camera centred at `o` at
//!
//! ```text
//! t_first = t0 + time_scale * eta * (|l - p| + |p - o|) / c
//! ```
//!
//! (physics.md, "Transient path tracing"; [`crate::camera::Calibration::first_arrival_ps`]).
//! Every multi-bounce path to `p` is longer (triangle inequality), so direct light is the first
//! light in the pixel's profile. [`first_arrival_bin`] finds it with sub-bin precision,
//! [`arrival_samples`] does that over the pixels that see the mesh, and [`fit_time_offset`] fits
//! `t0` (and optionally `time_scale`) robustly. [`calibrate_time`] (or [`fit_direct_time`] for
//! a cube read by slabs) then refines the fit with the direct-light centroid below.
//!
//! # Direct-light centroid
//!
//! A pixel integrates over its footprint, the patch of surface it sees, so its direct light
//! is not one pulse at the pixel-centre path but a spread of pulses from the shortest to the
//! longest direct path of the footprint. On the built-in `cube` scene at 64 x 48 pixels that
//! spread is 5 bins of 4 ps for a typical pixel and 10 or more where the floor is seen at a
//! grazing angle (measured with 8 x 8 rays per pixel), far wider than the 50 fs pulse. The
//! first peak of such a profile is one of the first path samples inside the spread, so first
//! arrivals are early: the fitted `t0` was -0.59 to -0.50 bins off at 4 and 8 spp and -0.37
//! to -0.31 at 64 spp (two seeds each, through the true camera), the more so the fewer the
//! samples.
//!
//! The tracer's time response (a one-bin sensor box over one-bin bins, and the Gaussian
//! pulse) keeps each sample's mean time, so the centroid of a pixel's direct light is the
//! mean arrival over its footprint. [`footprints`] computes, from the registration alone,
//! each pixel's shortest, longest and mean direct path: the pixel's patch is the plane of the
//! point its centre sees, its rays are interpolated between the rays to its neighbours'
//! points, and the mean is weighted by the laser's irradiance `cos / r^2` over 8 x 8
//! sub-pixels. Given a fit `(t0, time_scale)`, [`direct_arrival_samples`] takes the centroid
//! of each profile over the window where the fit puts its direct light (the footprint's
//! paths widened by [`ArrivalOptions::window_margin_bins`], 1 bin: the reach of the sensor
//! response) and pairs it with the footprint's mean path. Pixels without direct light (in the
//! laser's shadow) have an empty window and drop out. [`fit_direct_time`] starts from the
//! first-arrival fit and repeats centroid passes until `t0` moves by less than
//! [`T0_CONVERGED_PS`]; a window misplaced by the first fit's half bin loses little of the
//! pulse, so two or three passes settle. On the same cubes the fitted `t0` is -0.026 to -0.009
//! bins off (-0.10 to -0.04 ps) at 4, 8 and 64 spp, with or without the multi-bounce light;
//! with the time scale fitted too, `t0` (an extrapolation to a zero path) is within 0.3 bins.
//!
//! # First-arrival estimator
//!
//! The pulse is a Gaussian in time, and each bin holds the signal integrated over the bin.
//! 1. Find the first bin at or above `threshold_fraction` of the profile's maximum, and climb
//!    from there to the first local maximum: the peak bin `p` of the direct pulse. (A fraction
//!    of the maximum rather than the maximum itself, because inter-reflections that arrive
//!    later can be brighter than a grazing direct return.)
//! 2. With both neighbours of `p` above 1e-3 of it, take the vertex of the parabola through
//!    the logarithms of the three bins (exact for a Gaussian sampled at bin centres; the
//!    bin-integrated Gaussian is a Gaussian of variance `sigma^2 + 1/12` bin^2 to first order,
//!    so the vertex stays nearly unbiased). Otherwise (a pulse much narrower than a bin) take the
//!    centroid of the three bins.
//!
//! Only the peak bin and its two neighbours are used, so the multi-bounce tail that follows the
//! direct pulse enters mostly through the later neighbour. Bias measured on bin-integrated
//! Gaussian pulses at random sub-bin offsets (pinned by the tests of this module; sigma in
//! bins):
//!
//! - no tail: mean below 0.005 bin and worst below 0.03 bin for sigma >= 0.4; for a pulse much
//!   narrower than a bin (sigma = 0.15) the sub-bin position is mostly lost: errors up to
//!   +-0.2 bin per pixel, within 0.03 bin in the mean over random offsets.
//! - a strong tail (half the direct energy, starting 0.3 bin after the pulse, decaying over 20
//!   bins, blurred by the same pulse): late by 0.02-0.03 bin for sigma <= 0.8, 0.04 at 1.2, 0.1
//!   at 2. The blurred tail cannot be told apart from the pulse's own late half, so wide pulses
//!   with strong immediate inter-reflections make the fitted `t0` late by that much.
//!
//! # Robust fit
//!
//! `t_first = t0 + s * tau` with `tau = eta * path / c`. Start: with `s = 1` fixed, `t0` is the
//! median of `t_first - tau`; with `s` free, the least-median-of-squares line over
//! deterministic random pairs of samples. Then iteratively reweighted least squares with the
//! Huber weight (`k = 1.345 sigma`, `sigma = 1.4826 MAD` of the residuals), and a final
//! least-squares fit over the inliers, the samples within `3 sigma` (at least 0.5 ps).

use super::{CalibrateError, Registration};
use crate::cube::{Cube, TimeFrame};
use crate::stats::{mad, median, median_of, MAD_TO_SIGMA};
use crate::units::flight_time_ps;
use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;

/// Fewest samples for a fit of `t0` alone.
pub const MIN_SAMPLES_T0: usize = 5;
/// Fewest samples for a fit of `t0` and the time scale.
pub const MIN_SAMPLES_T0_SCALE: usize = 10;
/// Inliers lie within this many robust standard deviations of the fit.
pub const INLIER_SIGMAS: f64 = 3.0;
/// Inlier band never narrower than this, ps (so noiseless data keeps all its samples).
pub const MIN_INLIER_BAND_PS: f64 = 0.5;

/// Options of the first-arrival detector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArrivalOptions {
    /// The direct pulse is searched from the first bin at or above this fraction of the
    /// profile's maximum.
    pub threshold_fraction: f64,
    /// Pixels whose maximum is below this value are skipped (no reliable arrival).
    pub min_peak: f32,
    /// Reach of the time response (pulse and sensor) beyond a footprint's direct paths, in
    /// bins: the centroid window of [`direct_arrival_samples`] runs from this much before the
    /// shortest direct path of the pixel to this much after the longest. A sensor that
    /// integrates a one-bin box over one-bin bins spreads an arrival over +-1 bin.
    pub window_margin_bins: f64,
}

impl Default for ArrivalOptions {
    fn default() -> Self {
        ArrivalOptions {
            threshold_fraction: 0.3,
            min_peak: 0.0,
            window_margin_bins: 1.0,
        }
    }
}

/// Continuous bin coordinate (0.0 at the start of bin 0, `i + 0.5` at the centre of bin `i`)
/// of the direct-light pulse in one pixel's profile (module doc). None when the profile has no
/// positive finite value, or its maximum is below `options.min_peak`.
pub fn first_arrival_bin(profile: &[f32], options: &ArrivalOptions) -> Option<f64> {
    let max = profile
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(f32::NEG_INFINITY, f32::max);
    if max <= 0.0 || max < options.min_peak {
        return None;
    }
    let value = |i: isize| -> f64 {
        if i < 0 || i as usize >= profile.len() {
            0.0
        } else {
            let v = profile[i as usize] as f64;
            if v.is_finite() {
                v.max(0.0)
            } else {
                0.0
            }
        }
    };
    let threshold = options.threshold_fraction * max as f64;
    let mut p = (0..profile.len()).find(|&i| value(i as isize) >= threshold)? as isize;
    while value(p + 1) > value(p) {
        p += 1;
    }
    let (vm, v0, vp) = (value(p - 1), value(p), value(p + 1));
    let offset = if vm > 1e-3 * v0 && vp > 1e-3 * v0 {
        let (lm, l0, lp) = (vm.ln(), v0.ln(), vp.ln());
        let curvature = lm - 2.0 * l0 + lp;
        if curvature < 0.0 {
            (0.5 * (lm - lp) / curvature).clamp(-1.0, 1.0)
        } else {
            (vp - vm) / (vm + v0 + vp)
        }
    } else {
        (vp - vm) / (vm + v0 + vp)
    };
    Some(p as f64 + 0.5 + offset)
}

/// One pixel's first arrival and the length of its direct light path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArrivalSample {
    pub x: usize,
    pub y: usize,
    /// Cube (camera) time of the direct pulse, ps.
    pub t_first_ps: f64,
    /// `|laser - p| + |p - camera|`, metres.
    pub path_m: f64,
}

/// First arrivals of every pixel that sees the mesh (registration mask 1, cube mask valid),
/// with the length of its direct path from `laser_m` over the seen point to the camera centre.
pub fn arrival_samples(
    cube: &Cube,
    registration: &Registration,
    laser_m: &Point3<f64>,
    options: &ArrivalOptions,
) -> Result<Vec<ArrivalSample>, CalibrateError> {
    if cube.frame != TimeFrame::Camera {
        return Err(CalibrateError::WorldTimeCube);
    }
    if cube.nx != registration.nx || cube.ny != registration.ny {
        return Err(CalibrateError::RegistrationMismatch {
            reg_nx: registration.nx,
            reg_ny: registration.ny,
            cube_nx: cube.nx,
            cube_ny: cube.ny,
        });
    }
    let camera_m = registration.camera_m;
    let rows: Vec<Vec<ArrivalSample>> = (0..cube.ny)
        .into_par_iter()
        .map(|y| {
            (0..cube.nx)
                .filter_map(|x| {
                    let i = y * cube.nx + x;
                    if registration.mask[i] == 0 || !cube.is_valid(x, y) {
                        return None;
                    }
                    let bin = first_arrival_bin(cube.profile(x, y), options)?;
                    let p = Point3::from(registration.point_m[i]).cast::<f64>();
                    Some(ArrivalSample {
                        x,
                        y,
                        t_first_ps: cube.axis.t0_ps + bin * cube.axis.dt_ps,
                        path_m: (laser_m - p).norm() + (p - camera_m).norm(),
                    })
                })
                .collect()
        })
        .collect();
    Ok(rows.into_iter().flatten().collect())
}

/// The direct light one pixel can receive: the lengths of the direct paths
/// `|laser - q| + |q - o|` over the surface patch `q` the pixel sees (its footprint).
///
/// A pixel integrates over its footprint, so its direct light is not one pulse at the
/// pixel-centre path but a spread of pulses between the shortest and the longest path of the
/// footprint (5 bins of 4 ps for a typical pixel of the built-in `cube` scene at 64 x 48,
/// 10 or more where the floor is seen at a grazing angle).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    /// Shortest direct path over the footprint, metres.
    pub path_min_m: f64,
    /// Longest direct path over the footprint, metres.
    pub path_max_m: f64,
    /// Mean direct path over the footprint (uniform over the pixel, weighted by the laser's
    /// irradiance `cos / r^2` at each point), metres.
    pub path_mean_m: f64,
}

/// The [`Footprint`] of every pixel of a registration, `[y][x]` order; `None` where the pixel
/// sees no geometry, its patch faces away from the laser or is seen edge-on, or no
/// neighbour along a pixel axis is registered.
#[derive(Clone, Debug, PartialEq)]
pub struct Footprints {
    pub nx: usize,
    pub ny: usize,
    pub pixels: Vec<Option<Footprint>>,
}

impl Footprints {
    /// Rows `y0 .. y0 + n` (for a cube read by row slabs).
    pub fn rows(&self, y0: usize, n: usize) -> Footprints {
        Footprints {
            nx: self.nx,
            ny: n,
            pixels: self.pixels[y0 * self.nx..(y0 + n) * self.nx].to_vec(),
        }
    }
}

/// Sub-samples per pixel side over which a footprint's mean path is taken.
const FOOTPRINT_SUBSAMPLES: usize = 8;

/// The footprint of every registered pixel (module doc, "Direct-light centroid"). Each
/// pixel's patch is the plane of the surface its centre sees (point and normal of the
/// registration); the rays through the pixel are interpolated from the rays through its
/// centre and its neighbours' centres (the directions to their registered points), which is
/// exact for a pinhole camera up to second order in the pixel's angular size.
pub fn footprints(registration: &Registration, laser_m: &Point3<f64>) -> Footprints {
    let (nx, ny) = (registration.nx, registration.ny);
    let o = registration.camera_m;
    let dir = |i: usize| -> Option<Vector3<f64>> {
        if registration.mask[i] == 0 {
            return None;
        }
        let d = Point3::from(registration.point_m[i]).cast::<f64>() - o;
        let n = d.norm();
        (n > 0.0 && n.is_finite()).then(|| d / n)
    };
    // Direction change per pixel along one axis from the neighbours before and after.
    let step = |d0: &Vector3<f64>, before: Option<Vector3<f64>>, after: Option<Vector3<f64>>| match (
        before, after,
    ) {
        (Some(a), Some(b)) => Some((b - a) / 2.0),
        (Some(a), None) => Some(d0 - a),
        (None, Some(b)) => Some(b - d0),
        (None, None) => None,
    };
    let pixel = |x: usize, y: usize| -> Option<Footprint> {
        let i = y * nx + x;
        let d0 = dir(i)?;
        let gx = step(
            &d0,
            (x > 0).then(|| dir(i - 1)).flatten(),
            (x + 1 < nx).then(|| dir(i + 1)).flatten(),
        )?;
        let gy = step(
            &d0,
            (y > 0).then(|| dir(i - nx)).flatten(),
            (y + 1 < ny).then(|| dir(i + nx)).flatten(),
        )?;
        let p = Point3::from(registration.point_m[i]).cast::<f64>();
        let n = Vector3::from(registration.normal[i]).cast::<f64>();
        let plane = n.dot(&(p - o));
        // Path and irradiance weight through pixel offset (u, v) from the centre.
        let at = |u: f64, v: f64| -> Option<(f64, f64)> {
            let d = d0 + gx * u + gy * v;
            let nd = n.dot(&d);
            // The normal faces the camera: a ray that meets the plane has n . d < 0.
            if nd.is_nan() || nd >= -1e-6 * d.norm() {
                return None;
            }
            let q = o + d * (plane / nd);
            let to_laser = laser_m - q;
            let r = to_laser.norm();
            let cos = n.dot(&to_laser) / r;
            let w = if cos > 0.0 { cos / (r * r) } else { 0.0 };
            Some(((q - o).norm() + r, w))
        };
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (u, v) in [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)] {
            let (path, _) = at(u, v)?;
            lo = lo.min(path);
            hi = hi.max(path);
        }
        let m = FOOTPRINT_SUBSAMPLES;
        let (mut sum_w, mut sum_wp) = (0.0, 0.0);
        for a in 0..m {
            for b in 0..m {
                let u = (a as f64 + 0.5) / m as f64 - 0.5;
                let v = (b as f64 + 0.5) / m as f64 - 0.5;
                let (path, w) = at(u, v)?;
                lo = lo.min(path);
                hi = hi.max(path);
                sum_w += w;
                sum_wp += w * path;
            }
        }
        let mean = sum_wp / sum_w;
        (sum_w > 0.0 && mean.is_finite()).then_some(Footprint {
            path_min_m: lo,
            path_max_m: hi,
            path_mean_m: mean,
        })
    };
    let pixels = (0..ny)
        .into_par_iter()
        .flat_map_iter(|y| (0..nx).map(move |x| (x, y)).collect::<Vec<_>>())
        .map(|(x, y)| pixel(x, y))
        .collect();
    Footprints { nx, ny, pixels }
}

/// Centroid (continuous bin coordinate, as [`first_arrival_bin`]) of the profile over the
/// bins whose centre lies in `[lo_bin, hi_bin]` (bin `i`'s centre is `i + 0.5`), and the
/// window's sum. Non-finite values count as 0; negative values (noise about a subtracted
/// background) count as they are. None when the window holds no bin, its sum is not
/// positive or its maximum is below `min_peak`.
pub fn window_centroid_bin(
    profile: &[f32],
    lo_bin: f64,
    hi_bin: f64,
    min_peak: f32,
) -> Option<(f64, f64)> {
    if !(lo_bin.is_finite() && hi_bin.is_finite()) {
        return None;
    }
    let first = (lo_bin - 0.5).ceil().max(0.0) as usize;
    let last = ((hi_bin - 0.5).floor().min(profile.len() as f64 - 1.0)).max(-1.0);
    if last < first as f64 {
        return None;
    }
    let (mut sum, mut moment, mut max) = (0.0f64, 0.0f64, f32::NEG_INFINITY);
    for (b, &v) in profile
        .iter()
        .enumerate()
        .take(last as usize + 1)
        .skip(first)
    {
        let v = if v.is_finite() { v } else { 0.0 };
        max = max.max(v);
        sum += v as f64;
        moment += v as f64 * (b as f64 + 0.5);
    }
    if sum.is_nan() || sum <= 0.0 || max < min_peak {
        return None;
    }
    let c = moment / sum;
    (c.is_finite() && c >= first as f64 && c <= last + 1.0).then_some((c, sum))
}

/// The direct-light time of every pixel with a footprint, given the current time model
/// `t = t0_ps + time_scale * eta * path / c`: the centroid of the pixel's profile over the
/// window where the model puts its direct light (from `options.window_margin_bins` before the
/// footprint's shortest path to as much after its longest), paired with the footprint's mean
/// path (module doc). `footprints` must have the cube's size (use [`Footprints::rows`] for a
/// row slab). `row_shift_ps` moves row `y`'s windows later by `row_shift_ps[y]` (a scanline's
/// own offset, [`super::scanline_time`]; empty: none).
#[allow(clippy::too_many_arguments)]
pub fn direct_arrival_samples(
    cube: &Cube,
    footprints: &Footprints,
    eta: f64,
    t0_ps: f64,
    time_scale: f64,
    row_shift_ps: &[f64],
    options: &ArrivalOptions,
) -> Result<Vec<ArrivalSample>, CalibrateError> {
    if cube.frame != TimeFrame::Camera {
        return Err(CalibrateError::WorldTimeCube);
    }
    if cube.nx != footprints.nx || cube.ny != footprints.ny {
        return Err(CalibrateError::RegistrationMismatch {
            reg_nx: footprints.nx,
            reg_ny: footprints.ny,
            cube_nx: cube.nx,
            cube_ny: cube.ny,
        });
    }
    let axis = cube.axis;
    let margin = options.window_margin_bins.max(0.0);
    let rows: Vec<Vec<ArrivalSample>> = (0..cube.ny)
        .into_par_iter()
        .map(|y| {
            let row_t0_ps = t0_ps + row_shift_ps.get(y).copied().unwrap_or(0.0);
            (0..cube.nx)
                .filter_map(|x| {
                    let f = footprints.pixels[y * cube.nx + x]?;
                    if !cube.is_valid(x, y) {
                        return None;
                    }
                    let at = |path_m: f64| {
                        axis.bin_coord(row_t0_ps + time_scale * flight_time_ps(eta, path_m))
                    };
                    let (c, _) = window_centroid_bin(
                        cube.profile(x, y),
                        at(f.path_min_m) - margin,
                        at(f.path_max_m) + margin,
                        options.min_peak,
                    )?;
                    Some(ArrivalSample {
                        x,
                        y,
                        t_first_ps: axis.t0_ps + c * axis.dt_ps,
                        path_m: f.path_mean_m,
                    })
                })
                .collect()
        })
        .collect();
    Ok(rows.into_iter().flatten().collect())
}

/// Most centroid passes of [`fit_direct_time`].
pub const MAX_CENTROID_PASSES: usize = 4;
/// [`fit_direct_time`] stops once a pass moves `t0` by less than this, ps.
pub const T0_CONVERGED_PS: f64 = 1e-3;

/// The time fit of module doc, "Direct-light centroid": a first fit of the first arrivals,
/// then passes of direct-light centroids in the windows the current fit predicts, each
/// refitted, until `t0` settles (at most [`MAX_CENTROID_PASSES`]). `samples(None)` gives
/// the first arrivals ([`arrival_samples`]), `samples(Some((t0_ps, time_scale)))` the
/// centroids under that model ([`direct_arrival_samples`]); the caller reads the cube (whole
/// or by row slabs). Returns the last fit and its samples.
pub fn fit_direct_time<E: From<CalibrateError>>(
    eta: f64,
    fit_scale: bool,
    samples: &mut dyn FnMut(Option<(f64, f64)>) -> Result<Vec<ArrivalSample>, E>,
) -> Result<(TimeFit, Vec<ArrivalSample>), E> {
    let pairs = |s: &[ArrivalSample]| -> Vec<(f64, f64)> {
        s.iter().map(|a| (a.t_first_ps, a.path_m)).collect()
    };
    let mut found = samples(None)?;
    let mut fit = fit_time_offset(&pairs(&found), eta, fit_scale)?;
    for _ in 0..MAX_CENTROID_PASSES {
        found = samples(Some((fit.t0_ps, fit.time_scale)))?;
        let next = fit_time_offset(&pairs(&found), eta, fit_scale)?;
        let moved = (next.t0_ps - fit.t0_ps).abs();
        fit = next;
        if moved < T0_CONVERGED_PS {
            break;
        }
    }
    Ok((fit, found))
}

/// [`fit_direct_time`] on a cube in memory: first arrivals and footprints from
/// `registration`, laser spot `laser_m`.
pub fn calibrate_time(
    cube: &Cube,
    registration: &Registration,
    laser_m: &Point3<f64>,
    eta: f64,
    fit_scale: bool,
    options: &ArrivalOptions,
) -> Result<(TimeFit, Vec<ArrivalSample>), CalibrateError> {
    let prints = footprints(registration, laser_m);
    fit_direct_time(eta, fit_scale, &mut |model| match model {
        None => arrival_samples(cube, registration, laser_m, options),
        Some((t0_ps, scale)) => {
            direct_arrival_samples(cube, &prints, eta, t0_ps, scale, &[], options)
        }
    })
}

/// Result of [`fit_time_offset`].
#[derive(Clone, Debug, PartialEq)]
pub struct TimeFit {
    /// Cube time at which the pulse leaves the laser spot, ps.
    pub t0_ps: f64,
    /// Cube time units per true picosecond (1 when not fitted).
    pub time_scale: f64,
    /// `t_first - (t0 + time_scale * eta * path / c)` of every sample, ps (input order).
    pub residuals_ps: Vec<f64>,
    /// Whether each sample is an inlier (module doc).
    pub inliers: Vec<bool>,
    /// Root mean square residual over the inliers, ps.
    pub rms_ps: f64,
    /// Robust standard deviation of the residuals (1.4826 MAD), ps.
    pub sigma_ps: f64,
}

impl TimeFit {
    pub fn inlier_count(&self) -> usize {
        self.inliers.iter().filter(|&&b| b).count()
    }
}

/// Weighted least-squares line `t = t0 + s tau` (or `s = 1` fixed): (t0, s).
fn weighted_line(tau: &[f64], t: &[f64], w: &[f64], fit_scale: bool) -> Option<(f64, f64)> {
    let sw: f64 = w.iter().sum();
    if sw.is_nan() || sw <= 0.0 {
        return None;
    }
    let tau_mean = tau.iter().zip(w).map(|(a, b)| a * b).sum::<f64>() / sw;
    let t_mean = t.iter().zip(w).map(|(a, b)| a * b).sum::<f64>() / sw;
    if !fit_scale {
        return Some((t_mean - tau_mean, 1.0));
    }
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for i in 0..tau.len() {
        let dx = tau[i] - tau_mean;
        sxx += w[i] * dx * dx;
        sxy += w[i] * dx * (t[i] - t_mean);
    }
    if sxx.is_nan() || sxx <= 0.0 {
        return None;
    }
    let s = sxy / sxx;
    Some((t_mean - s * tau_mean, s))
}

/// Robust fit of `t_first = t0 + time_scale * eta * path / c` to `(t_first_ps, path_m)`
/// samples (module doc). `time_scale` is fixed at 1 unless `fit_scale`.
pub fn fit_time_offset(
    samples: &[(f64, f64)],
    eta: f64,
    fit_scale: bool,
) -> Result<TimeFit, CalibrateError> {
    let need = if fit_scale {
        MIN_SAMPLES_T0_SCALE
    } else {
        MIN_SAMPLES_T0
    };
    if samples.len() < need {
        return Err(CalibrateError::TooFewSamples {
            got: samples.len(),
            need,
        });
    }
    if let Some(k) = samples
        .iter()
        .position(|(t, l)| !(t.is_finite() && l.is_finite()))
    {
        return Err(CalibrateError::TimeDegenerate(format!(
            "sample {k} is not finite"
        )));
    }
    if !(eta.is_finite() && eta > 0.0) {
        return Err(CalibrateError::TimeDegenerate(format!(
            "the refractive index must be positive, got {eta}"
        )));
    }
    let t: Vec<f64> = samples.iter().map(|s| s.0).collect();
    let tau: Vec<f64> = samples.iter().map(|s| flight_time_ps(eta, s.1)).collect();
    let n = t.len();
    let residuals =
        |t0: f64, s: f64| -> Vec<f64> { (0..n).map(|i| t[i] - t0 - s * tau[i]).collect() };

    // Robust start.
    let diff: Vec<f64> = (0..n).map(|i| t[i] - tau[i]).collect();
    let mut t0 = median_of(&diff);
    let mut s = 1.0;
    if fit_scale {
        (t0, s) = least_median_start(&t, &tau, t0)?;
    }

    // Huber IRLS.
    let mut w = vec![1.0; n];
    for _ in 0..50 {
        let r = residuals(t0, s);
        let sigma = (MAD_TO_SIGMA * mad(&r, 0.0)).max(1e-9);
        let k = 1.345 * sigma;
        for i in 0..n {
            let a = r[i].abs();
            w[i] = if a <= k { 1.0 } else { k / a };
        }
        let Some((t0_new, s_new)) = weighted_line(&tau, &t, &w, fit_scale) else {
            break;
        };
        let change = (t0_new - t0).abs() + (s_new - s).abs() * 1e3;
        t0 = t0_new;
        s = s_new;
        if change < 1e-9 {
            break;
        }
    }

    // Final least squares over the inliers.
    let r = residuals(t0, s);
    let sigma = MAD_TO_SIGMA * mad(&r, 0.0);
    let band = (INLIER_SIGMAS * sigma).max(MIN_INLIER_BAND_PS);
    let inliers: Vec<bool> = r.iter().map(|v| v.abs() <= band).collect();
    let w: Vec<f64> = inliers.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
    let need_inliers = need.min(n);
    if inliers.iter().filter(|&&b| b).count() < need_inliers {
        return Err(CalibrateError::TimeDegenerate(
            "too few samples agree with any single time offset".into(),
        ));
    }
    let (t0, s) = weighted_line(&tau, &t, &w, fit_scale).ok_or_else(|| {
        CalibrateError::TimeDegenerate("the inlier paths all have the same length".into())
    })?;
    if !(s > 0.0 && s.is_finite() && t0.is_finite()) {
        return Err(CalibrateError::TimeDegenerate(format!(
            "the fitted time scale {s} is not positive"
        )));
    }
    let residuals_ps = residuals(t0, s);
    let sigma_ps = MAD_TO_SIGMA * mad(&residuals_ps, 0.0);
    let (sum_sq, count) = residuals_ps
        .iter()
        .zip(&inliers)
        .filter(|(_, &b)| b)
        .fold((0.0, 0usize), |(a, c), (r, _)| (a + r * r, c + 1));
    Ok(TimeFit {
        t0_ps: t0,
        time_scale: s,
        residuals_ps,
        inliers,
        rms_ps: (sum_sq / count as f64).sqrt(),
        sigma_ps,
    })
}

/// The robust start of [`fit_time_offset`]'s time scale: least median of squares over 500
/// seeded random pairs of samples (`t` arrival times and `tau` flight times, ps), the median
/// taken over a subsample of at most about 4000, starting from `t0` with scale 1. Refuses
/// flight times that span 1 ps or less.
fn least_median_start(t: &[f64], tau: &[f64], t0: f64) -> Result<(f64, f64), CalibrateError> {
    let n = t.len();
    let (mut t0, mut s) = (t0, 1.0);
    let (lo, hi) = tau
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let span = hi - lo;
    if span.is_nan() || span <= 1.0 {
        return Err(CalibrateError::TimeDegenerate(format!(
            "the direct paths differ by {span:.3} ps of flight time only; the time scale \
             cannot be fitted (fit t0 alone)"
        )));
    }
    // Least median of squares over random pairs; the median is taken over a subsample.
    let mut rng = rand_pcg::Pcg64::seed_from_u64(0x7e3f_0d11);
    let stride = (n / 4000).max(1);
    let subset: Vec<usize> = (0..n).step_by(stride).collect();
    let score = |t0: f64, s: f64| -> f64 {
        let mut r: Vec<f64> = subset
            .iter()
            .map(|&i| (t[i] - t0 - s * tau[i]).abs())
            .collect();
        median(&mut r)
    };
    let mut best = score(t0, s);
    for _ in 0..500 {
        let i = rng.random_range(0..n);
        let j = rng.random_range(0..n);
        let d_tau = tau[j] - tau[i];
        if d_tau.abs() < 0.05 * span {
            continue;
        }
        let s_c = (t[j] - t[i]) / d_tau;
        if s_c.is_nan() || s_c <= 0.0 {
            continue;
        }
        let t0_c = t[i] - s_c * tau[i];
        let sc = score(t0_c, s_c);
        if sc < best {
            best = sc;
            t0 = t0_c;
            s = s_c;
        }
    }
    Ok((t0, s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;
    use rand_distr::{Distribution, Normal};

    /// Integral of a unit-area Gaussian (centre `mu`, width `sigma`, bins) over `[a, b)`,
    /// by Simpson's rule on a fine grid (independent of the estimator).
    fn gaussian_bin(mu: f64, sigma: f64, a: f64, b: f64) -> f64 {
        let m = 64;
        let h = (b - a) / m as f64;
        let f = |x: f64| {
            (-(x - mu).powi(2) / (2.0 * sigma * sigma)).exp()
                / (sigma * (2.0 * std::f64::consts::PI).sqrt())
        };
        let mut s = f(a) + f(b);
        for i in 1..m {
            s += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    }

    /// Profile of `nt` bins: direct Gaussian pulse at `mu` (bin coordinates) plus, optionally,
    /// a multi-bounce tail starting `tail_delay` bins later (exponential, total weight
    /// `tail_weight` of the direct pulse, blurred by the same Gaussian through 8 sub-steps).
    fn profile(nt: usize, mu: f64, sigma: f64, tail_weight: f64, tail_delay: f64) -> Vec<f32> {
        let decay = 20.0; // bins
        (0..nt)
            .map(|i| {
                let (a, b) = (i as f64, i as f64 + 1.0);
                let mut v = gaussian_bin(mu, sigma, a, b);
                if tail_weight > 0.0 {
                    // Tail = sum of delayed pulses with exponential weights.
                    let steps = 160;
                    let dt = 8.0 * decay / steps as f64;
                    let mut tail = 0.0;
                    for k in 0..steps {
                        let delay = tail_delay + (k as f64 + 0.5) * dt;
                        let wk = (-delay / decay).exp() * dt / decay;
                        let lo = a - mu - delay;
                        if lo > 6.0 * sigma || b - mu - delay < -6.0 * sigma {
                            continue;
                        }
                        tail += wk * gaussian_bin(mu + delay, sigma, a, b);
                    }
                    v += tail_weight * tail;
                }
                v as f32
            })
            .collect()
    }

    #[test]
    fn first_arrival_bias_on_binned_gaussian_pulses() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        let opts = ArrivalOptions::default();
        // (sigma in bins, tail weight, allowed |mean bias|, allowed worst error) in bins: the
        // figures documented in the module doc.
        for &(sigma, tail, mean_tol, worst_tol) in &[
            (0.15, 0.0, 0.05, 0.3),
            (0.4, 0.0, 0.01, 0.03),
            (0.8, 0.0, 0.005, 0.01),
            (2.0, 0.0, 0.005, 0.01),
            (0.4, 0.5, 0.04, 0.05),
            (0.8, 0.5, 0.04, 0.05),
            (1.2, 0.5, 0.06, 0.07),
            (2.0, 0.5, 0.12, 0.12),
        ] {
            let mut sum = 0.0;
            let mut worst: f64 = 0.0;
            let trials = 100;
            for _ in 0..trials {
                let mu = 30.0 + rng.random::<f64>();
                let p = profile(64, mu, sigma, tail, 0.3);
                let est = first_arrival_bin(&p, &opts).unwrap();
                sum += est - mu;
                worst = worst.max((est - mu).abs());
            }
            let mean = sum / trials as f64;
            println!("sigma {sigma} tail {tail}: mean bias {mean:+.4} worst {worst:.4} bins");
            assert!(
                mean.abs() < mean_tol && worst < worst_tol,
                "sigma {sigma} tail {tail}: mean bias {mean:.4} worst {worst:.4} bins"
            );
        }
    }

    #[test]
    fn first_arrival_skips_empty_profiles_and_finds_the_first_peak() {
        let opts = ArrivalOptions::default();
        assert_eq!(first_arrival_bin(&[0.0; 8], &opts), None);
        assert_eq!(first_arrival_bin(&[f32::NAN; 8], &opts), None);
        // A direct pulse at 10.5 followed by a brighter inter-reflection at 20.5.
        let mut p = vec![0.0f32; 32];
        p[10] = 0.5;
        p[20] = 1.0;
        p[21] = 0.2;
        let b = first_arrival_bin(&p, &opts).unwrap();
        assert!((b - 10.5).abs() < 1e-9, "{b}");
        let strict = ArrivalOptions {
            min_peak: 2.0,
            ..opts
        };
        assert_eq!(first_arrival_bin(&p, &strict), None);
    }

    #[test]
    fn window_centroid_of_tent_splatted_arrivals_is_their_mean_time() {
        // Two arrivals at bin coordinates 10.2 (weight 1) and 12.9 (weight 3), each split
        // linearly between the two nearest bin centres (a one-bin sensor box over one-bin
        // bins); then a later arrival at 20.5 outside the window.
        let mut p = vec![0.0f32; 32];
        let mut splat = |t: f64, w: f32| {
            let c = t - 0.5;
            let i = c.floor();
            let f = (c - i) as f32;
            p[i as usize] += w * (1.0 - f);
            p[i as usize + 1] += w * f;
        };
        splat(10.2, 1.0);
        splat(12.9, 3.0);
        splat(20.5, 5.0);
        let expected = (10.2 + 3.0 * 12.9) / 4.0;
        let (c, sum) = window_centroid_bin(&p, 10.2 - 1.0, 12.9 + 1.0, 0.0).unwrap();
        assert!((c - expected).abs() < 1e-6, "{c} vs {expected}");
        assert!((sum - 4.0).abs() < 1e-6);
        // An empty window, a window before the profile, a peak below min_peak.
        assert_eq!(window_centroid_bin(&p, 2.0, 6.0, 0.0), None);
        assert_eq!(window_centroid_bin(&p, -9.0, -2.0, 0.0), None);
        assert_eq!(window_centroid_bin(&p, 9.0, 14.0, 10.0), None);
    }

    #[test]
    fn time_offset_with_outliers() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let noise = Normal::new(0.0, 0.6).unwrap();
        let (t0_true, eta) = (-1234.5, 1.0);
        let mut samples = Vec::new();
        for i in 0..400 {
            let path_m = 3.0 + 2.0 * rng.random::<f64>();
            let mut t = t0_true + flight_time_ps(eta, path_m) + noise.sample(&mut rng);
            if i % 10 == 0 {
                t += 50.0 + 300.0 * rng.random::<f64>(); // late (mixed pixels, noise spikes)
            }
            samples.push((t, path_m));
        }
        let fit = fit_time_offset(&samples, eta, false).unwrap();
        assert!((fit.t0_ps - t0_true).abs() < 0.2, "{}", fit.t0_ps);
        assert_eq!(fit.time_scale, 1.0);
        // Every late sample is an outlier; of the good ones (Gaussian noise, 3 sigma band) at
        // most a few fall outside.
        let mut good_rejected = 0;
        for (i, &inlier) in fit.inliers.iter().enumerate() {
            if i % 10 == 0 {
                assert!(!inlier, "sample {i}");
            } else if !inlier {
                good_rejected += 1;
            }
        }
        assert!(good_rejected <= 4, "{good_rejected}");
        assert!(fit.rms_ps > 0.4 && fit.rms_ps < 0.8, "{}", fit.rms_ps);
    }

    #[test]
    fn too_few_or_degenerate_samples_are_errors() {
        let e = fit_time_offset(&[(1.0, 1.0); 4], 1.0, false).unwrap_err();
        assert!(
            matches!(e, CalibrateError::TooFewSamples { got: 4, need: 5 }),
            "{e}"
        );
        let e = fit_time_offset(&[(1.0, 1.0); 12], 1.0, true).unwrap_err();
        assert!(e.to_string().contains("time scale"), "{e}");
    }

    #[test]
    fn the_least_median_start_finds_the_line_through_most_samples() {
        // 70 samples on t = 250 + 1.25 tau, 30 far off it.
        let tau: Vec<f64> = (0..100).map(|i| 10.0 * i as f64).collect();
        let t: Vec<f64> = tau
            .iter()
            .enumerate()
            .map(|(i, &x)| {
                250.0
                    + 1.25 * x
                    + if i % 10 < 3 {
                        400.0 + 7.0 * i as f64
                    } else {
                        0.0
                    }
            })
            .collect();
        let (t0, s) = least_median_start(&t, &tau, 0.0).unwrap();
        assert!((s - 1.25).abs() < 1e-9, "{s}");
        assert!((t0 - 250.0).abs() < 1e-6, "{t0}");
        // Flight times within 1 ps: no scale can be fitted.
        let e = least_median_start(&[1.0, 2.0, 3.0], &[5.0, 5.5, 5.9], 0.0).unwrap_err();
        assert!(e.to_string().contains("fit t0 alone"), "{e}");
    }
}

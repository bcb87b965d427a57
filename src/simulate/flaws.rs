//! Capture imperfections of a simulated streak camera, applied to the true camera-time cube
//! one scanline at a time.
//!
//! A scanline `y` of the cube (`[x][t]`, the layout of [`crate::cube`]) becomes one streak
//! image. [`CaptureModel::apply_row`] applies, in this fixed order (ingest undoes them in the
//! reverse order):
//!
//! 1. **sweep non-linearity** — recorded bin `j` integrates the true signal over
//!    `[e_j, e_{j+1})` with `e_j = t0 + dt (j + s nt sin(pi j / nt) / pi)`: the same for every
//!    scanline, `e_0` and `e_nt` are the ends of the nominal window, and the local bin width
//!    is `dt (1 + s cos(pi j / nt))`, so `s` (in `[0, 1)`) is the largest relative deviation
//!    of a bin's width from `dt` and the edges stay strictly increasing. The true signal is
//!    taken as constant within each of its bins and integrated exactly, so the row's total is
//!    conserved. The `nt + 1` true edges go to the manifest ([`crate::manifest::Sweep`]);
//! 2. **trigger jitter** — the recorded row shifted later by `j_y ~ N(0, sigma)` ps
//!    ([`crate::resample::shift_into`] on the nominal axis; signal shifted past either end is
//!    lost), positive = the scanline arrived late, the sign ingest removes;
//! 3. **laser power** — the row multiplied by `max(0, 1 + sigma N(0, 1))`;
//! 4. **vignetting** — pixel `(x, y)` multiplied by `g = 1 - s r^2`, `r` the distance of the
//!    pixel centre `(x + 0.5, y + 0.5)` from the sensor centre `(nx / 2, ny / 2)` divided by
//!    the half diagonal (so `r = 1` at the corners), `s` in `[0, 1)`; the gains are the flat
//!    field ([`CaptureModel::flat_field`]);
//! 5. **photon noise** — each bin becomes `Poisson(k v) / k`, with `k = N / full_scale`
//!    photons per signal unit for `N` photons at the full-scale value;
//! 6. **dark signal** — `offset + N(0, sigma)` added to each bin; a dark frame (a streak
//!    image with no light, [`CaptureModel::dark_frame_counts`]) is drawn the same way;
//! 7. **saturation** — values clipped at the level;
//! 8. **quantisation** — `counts = clamp(round(v / value_per_count), 0, 65535)`, always
//!    applied: the capture holds what a 16-bit sensor reports. `value_per_count` is chosen
//!    so that the brightest noiseless value reads 60000 counts, leaving headroom for the
//!    noise: the largest value after steps 1 to 4 plus the dark offset, divided by 60000
//!    (with no imperfection, the clean cube's maximum reads 60000); or `level / 65535` when
//!    saturation is on (the clip level is the top count).
//!
//! `full_scale` is the largest value of the clean camera-time cube (1 if the cube is black).
//! Dark offset, dark sigma and the saturation level are given as fractions of it, the photon
//! count at it; the manifest records the absolute values in signal units.
//!
//! Determinism: every random draw comes from a PCG stream seeded by (seed, purpose,
//! scanline), so the capture is bit-identical whatever the number of threads, and turning
//! one imperfection on or off does not change the random values of another.

use crate::cube::{Cube, TimeAxis};
use crate::manifest::{self, Imperfections};
use rand::Rng;
use rand_distr::{Distribution, Poisson, StandardNormal};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;

/// Top count of the 16-bit sensor.
pub const MAX_COUNT: f64 = 65535.0;
/// Counts that the brightest true value maps to when saturation is off.
pub const FULL_SCALE_COUNTS: f64 = 60000.0;

/// An imperfection parameter out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{flaw}: {message}")]
pub struct FlawError {
    /// The [`Flaws`] field at fault.
    pub flaw: Flaw,
    /// What is wrong with its value.
    pub message: String,
}

/// One imperfection of [`Flaws`]; displayed as the name of its field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flaw {
    /// [`Flaws::photon_noise`].
    PhotonNoise,
    /// [`Flaws::dark`].
    Dark,
    /// [`Flaws::vignetting`].
    Vignetting,
    /// [`Flaws::jitter_ps`].
    JitterPs,
    /// [`Flaws::power_sigma`].
    PowerSigma,
    /// [`Flaws::sweep`].
    Sweep,
    /// [`Flaws::saturation`].
    Saturation,
    /// [`Flaws::fiducial_photo_px`].
    FiducialPhotoPx,
}

impl Flaw {
    /// Every imperfection, in the order of the fields of [`Flaws`].
    pub const ALL: [Flaw; 8] = [
        Flaw::PhotonNoise,
        Flaw::Dark,
        Flaw::Vignetting,
        Flaw::JitterPs,
        Flaw::PowerSigma,
        Flaw::Sweep,
        Flaw::Saturation,
        Flaw::FiducialPhotoPx,
    ];

    /// The name of its field of [`Flaws`].
    pub fn field(self) -> &'static str {
        match self {
            Flaw::PhotonNoise => "photon_noise",
            Flaw::Dark => "dark",
            Flaw::Vignetting => "vignetting",
            Flaw::JitterPs => "jitter_ps",
            Flaw::PowerSigma => "power_sigma",
            Flaw::Sweep => "sweep",
            Flaw::Saturation => "saturation",
            Flaw::FiducialPhotoPx => "fiducial_photo_px",
        }
    }
}

impl std::fmt::Display for Flaw {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.field())
    }
}

/// Which imperfections to simulate, each off (`None`) by default. Levels relative to the
/// clean cube's maximum (`full_scale`, see the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Flaws {
    /// Poisson photon noise: expected photons for a signal equal to `full_scale` (> 0).
    pub photon_noise: Option<f64>,
    /// Dark signal `(offset, sigma)`, fractions of `full_scale` (offset finite, sigma >= 0).
    pub dark: Option<(f64, f64)>,
    /// Vignetting strength `s` in `[0, 1)`: gain `1 - s r^2`.
    pub vignetting: Option<f64>,
    /// Standard deviation of the per-scanline trigger jitter, ps (>= 0).
    pub jitter_ps: Option<f64>,
    /// Relative standard deviation of the per-scanline laser power (>= 0).
    pub power_sigma: Option<f64>,
    /// Sweep non-linearity strength `s` in `[0, 1)`.
    pub sweep: Option<f64>,
    /// Saturation level, fraction of `full_scale` (> 0).
    pub saturation: Option<f64>,
    /// Standard deviation of the fiducial markers' detected positions, in pixels of a photo
    /// of the scene [`FIDUCIAL_PHOTO_WIDTH_PX`] wide (>= 0), where a lab finds its markers:
    /// Gaussian noise of `sigma * nx / FIDUCIAL_PHOTO_WIDTH_PX` capture pixels added to each
    /// coordinate of `fiducials.toml` ([`add_fiducial_noise`]). Not a flaw of the streak
    /// images.
    pub fiducial_photo_px: Option<f64>,
}

impl Flaws {
    /// A capture like a real lab's, for demos: 3000 photons at full scale, a dark offset of
    /// 1 % with 0.3 % noise, vignetting 0.25, 2 ps trigger jitter, 3 % laser power
    /// fluctuation, a sweep non-linearity of 0.05, and fiducials detected to 0.5 px in a
    /// 4032-pixel-wide photo ([`REALISTIC_FIDUCIAL_PHOTO_PX`]). No saturation.
    pub fn realistic() -> Flaws {
        Flaws {
            photon_noise: Some(3000.0),
            dark: Some((0.01, 0.003)),
            vignetting: Some(0.25),
            jitter_ps: Some(2.0),
            power_sigma: Some(0.03),
            sweep: Some(0.05),
            saturation: None,
            fiducial_photo_px: Some(REALISTIC_FIDUCIAL_PHOTO_PX),
        }
    }

    /// True when no imperfection is on.
    pub fn is_none(&self) -> bool {
        *self == Flaws::default()
    }

    /// Check every parameter; the error names the field.
    pub fn validate(&self) -> Result<(), FlawError> {
        let bad = |flaw: Flaw, message: String| Err(FlawError { flaw, message });
        if let Some(n) = self.photon_noise {
            if !(n.is_finite() && n > 0.0) {
                return bad(
                    Flaw::PhotonNoise,
                    format!("{n} photons must be finite and > 0"),
                );
            }
        }
        if let Some((offset, sigma)) = self.dark {
            if !offset.is_finite() {
                return bad(Flaw::Dark, format!("offset {offset} must be finite"));
            }
            if !(sigma.is_finite() && sigma >= 0.0) {
                return bad(Flaw::Dark, format!("sigma {sigma} must be finite and >= 0"));
            }
        }
        for (flaw, v) in [
            (Flaw::Vignetting, self.vignetting),
            (Flaw::Sweep, self.sweep),
        ] {
            if let Some(s) = v {
                if !(s.is_finite() && (0.0..1.0).contains(&s)) {
                    return bad(flaw, format!("strength {s} must be in [0, 1)"));
                }
            }
        }
        for (flaw, v) in [
            (Flaw::JitterPs, self.jitter_ps),
            (Flaw::PowerSigma, self.power_sigma),
            (Flaw::FiducialPhotoPx, self.fiducial_photo_px),
        ] {
            if let Some(s) = v {
                if !(s.is_finite() && s >= 0.0) {
                    return bad(flaw, format!("sigma {s} must be finite and >= 0"));
                }
            }
        }
        if let Some(l) = self.saturation {
            if !(l.is_finite() && l > 0.0) {
                return bad(
                    Flaw::Saturation,
                    format!("level {l} must be finite and > 0"),
                );
            }
        }
        Ok(())
    }
}

/// Purposes of the random streams (independent of each other and of the tracer's).
#[derive(Clone, Copy, Debug)]
enum Purpose {
    Jitter = 101,
    Power = 102,
    Photon = 103,
    Dark = 104,
    DarkFrame = 105,
    Fiducial = 106,
}

fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random stream of one purpose and scanline.
fn stream(seed: u64, purpose: Purpose, row: usize) -> Pcg64Mcg {
    let a = splitmix64(seed ^ splitmix64(purpose as u64));
    let hi = splitmix64(a ^ splitmix64(row as u64));
    let lo = splitmix64(hi ^ 0xBB67_AE85_84CA_A73B);
    Pcg64Mcg::new(((hi as u128) << 64) | lo as u128)
}

fn normal(rng: &mut Pcg64Mcg) -> f64 {
    rng.sample::<f64, _>(StandardNormal)
}

/// Width of the photo of the scene in which fiducial markers are found, pixels (a 12
/// megapixel camera, 4032 x 3024, as the demo's fiducial image).
pub const FIDUCIAL_PHOTO_WIDTH_PX: f64 = 4032.0;

/// The fiducial noise of [`Flaws::realistic`], pixels of that photo: a marker centre found
/// to half a pixel, the demo's own figure. At 320 capture pixels across it is 0.04 capture
/// pixels; at 128, 0.016.
pub const REALISTIC_FIDUCIAL_PHOTO_PX: f64 = 0.5;

/// Capture-pixel standard deviation of fiducial noise `photo_px` (photo pixels, module
/// constants above) for a capture `nx` pixels wide.
pub fn fiducial_capture_px(photo_px: f64, nx: usize) -> f64 {
    photo_px * nx as f64 / FIDUCIAL_PHOTO_WIDTH_PX
}

/// `points` with Gaussian noise of `sigma_px` added to each pixel coordinate, point `k`'s
/// from the stream (seed, fiducial, `k`): the same whatever the threads, and independent
/// of the streak images' draws.
pub fn add_fiducial_noise(
    points: &[crate::calibrate::points::Correspondence],
    sigma_px: f64,
    seed: u64,
) -> Vec<crate::calibrate::points::Correspondence> {
    points
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let mut rng = stream(seed, Purpose::Fiducial, k);
            let (du, dv) = (normal(&mut rng), normal(&mut rng));
            crate::calibrate::points::Correspondence {
                pixel: (c.pixel.0 + sigma_px * du, c.pixel.1 + sigma_px * dv),
                ..c.clone()
            }
        })
        .collect()
}

/// Dark frames averaged into the dark frame a simulated capture comes with.
pub const DARK_FRAMES_AVERAGED: usize = 64;

/// The imperfections resolved for one capture: absolute levels, and the random per-scanline
/// values already drawn. Built once by [`CaptureModel::new`]; applying it cannot fail.
#[derive(Clone, Debug, PartialEq)]
pub struct CaptureModel {
    /// Nominal time axis of the streak images (the cube's camera axis).
    pub axis: TimeAxis,
    pub nx: usize,
    pub ny: usize,
    /// Largest value of the clean cube (1 when it has no positive finite value).
    pub full_scale: f64,
    /// Signal value of one count.
    pub value_per_count: f64,
    /// The flaws as asked for.
    pub flaws: Flaws,
    /// True time edges of the recorded bins (`nt + 1`), when the sweep is non-linear.
    pub sweep_edges_ps: Option<Vec<f64>>,
    /// Trigger shift of each scanline, ps (positive = late).
    pub jitter_shifts_ps: Option<Vec<f64>>,
    /// Laser power factor of each scanline.
    pub power_factors: Option<Vec<f64>>,
    /// Photons per signal unit.
    pub photons_per_unit: Option<f64>,
    /// Dark `(offset, sigma)` in signal units.
    pub dark: Option<(f64, f64)>,
    /// Saturation level in signal units.
    pub saturation_level: Option<f64>,
    seed: u64,
}

/// Peaks of a clean camera-time cube that set a capture's levels ([`CaptureModel::scaled`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Peaks {
    /// Largest finite clean value (`full_scale` when positive).
    pub clean_max: f32,
    /// Largest value after the deterministic steps 1 to 4 (sweep, jitter, laser power,
    /// vignetting).
    pub noiseless: f64,
}

impl Peaks {
    /// The peaks of two parts of a cube together.
    pub fn max(self, o: Peaks) -> Peaks {
        Peaks {
            clean_max: self.clean_max.max(o.clean_max),
            noiseless: self.noiseless.max(o.noiseless),
        }
    }
}

/// Text of the vignetting model recorded in the manifest.
pub const VIGNETTING_MODEL: &str = "gain = 1 - strength * r^2, r = distance of the pixel centre \
     (x + 0.5, y + 0.5) from the sensor centre (nx / 2, ny / 2) divided by the half diagonal; \
     the gains are in flat.exr (nx x ny)";

impl CaptureModel {
    /// Resolve `flaws` for the clean camera-time cube `clean` and draw the per-scanline random
    /// values from `seed`.
    pub fn new(flaws: &Flaws, clean: &Cube, seed: u64) -> Result<CaptureModel, FlawError> {
        let shape = CaptureModel::unscaled(flaws, clean.nx, clean.ny, clean.axis, seed)?;
        let peaks = (0..clean.ny)
            .into_par_iter()
            .map(|y| shape.row_peaks(y, clean.row(y)))
            .reduce(Peaks::default, Peaks::max);
        Ok(shape.scaled(&peaks))
    }

    /// The model of an `nx` x `ny` capture on `axis` before the clean cube's scale is known:
    /// the deterministic steps 1 to 4 and the per-scanline random values resolved, the levels
    /// (photon count, dark, saturation, count scale) not yet. Feed each clean row to
    /// [`CaptureModel::row_peaks`], combine with [`Peaks::max`] and finish with
    /// [`CaptureModel::scaled`]; this gives [`CaptureModel::new`]'s model without holding the
    /// cube whole.
    pub fn unscaled(
        flaws: &Flaws,
        nx: usize,
        ny: usize,
        axis: TimeAxis,
        seed: u64,
    ) -> Result<CaptureModel, FlawError> {
        flaws.validate()?;
        let sweep_edges_ps = flaws.sweep.map(|s| sweep_edges_ps(&axis, s));
        let per_row = |purpose: Purpose, f: &dyn Fn(f64) -> f64| -> Vec<f64> {
            (0..ny)
                .map(|y| f(normal(&mut stream(seed, purpose, y))))
                .collect()
        };
        let jitter_shifts_ps = flaws
            .jitter_ps
            .map(|sigma| per_row(Purpose::Jitter, &|n| sigma * n));
        let power_factors = flaws
            .power_sigma
            .map(|sigma| per_row(Purpose::Power, &|n| (1.0 + sigma * n).max(0.0)));
        Ok(CaptureModel {
            axis,
            nx,
            ny,
            full_scale: 1.0,
            value_per_count: 1.0,
            flaws: *flaws,
            sweep_edges_ps,
            jitter_shifts_ps,
            power_factors,
            photons_per_unit: None,
            dark: None,
            saturation_level: None,
            seed,
        })
    }

    /// The peaks of clean row `y` (`nx * nt` values, `[x][t]`) that scale the capture.
    pub fn row_peaks(&self, y: usize, row: &[f32]) -> Peaks {
        let nt = self.axis.nt;
        let clean_max = row
            .iter()
            .filter(|v| v.is_finite())
            .fold(0.0f32, |m, &v| m.max(v));
        let mut s = Scratch::new(nt);
        let noiseless = (0..self.nx)
            .map(|x| {
                let gain = self.shape_pixel(y, x, &row[x * nt..(x + 1) * nt], &mut s);
                s.a.iter()
                    .filter(|v| v.is_finite())
                    .fold(0.0f64, |m, &v| m.max(v as f64 * gain))
            })
            .fold(0.0f64, f64::max);
        Peaks {
            clean_max,
            noiseless,
        }
    }

    /// Finish an [`CaptureModel::unscaled`] model with the peaks of every clean row.
    pub fn scaled(mut self, peaks: &Peaks) -> CaptureModel {
        let flaws = self.flaws;
        let max = peaks.clean_max as f64;
        let full_scale = if max > 0.0 { max } else { 1.0 };
        let saturation_level = flaws.saturation.map(|f| f * full_scale);
        self.full_scale = full_scale;
        self.photons_per_unit = flaws.photon_noise.map(|n| n / full_scale);
        self.dark = flaws.dark.map(|(o, s)| (o * full_scale, s * full_scale));
        self.saturation_level = saturation_level;
        self.value_per_count = match saturation_level {
            Some(level) => level / MAX_COUNT,
            None => {
                let peak = peaks.noiseless + self.dark.map_or(0.0, |d| d.0);
                if peak > 0.0 && peak.is_finite() {
                    peak / FULL_SCALE_COUNTS
                } else {
                    full_scale / FULL_SCALE_COUNTS
                }
            }
        };
        self
    }

    /// Steps 1 and 2 (sweep, jitter) of pixel `(x, y)` into `s.a`; returns the gain of steps
    /// 3 and 4 (laser power, vignetting).
    fn shape_pixel(&self, y: usize, x: usize, profile: &[f32], s: &mut Scratch) -> f64 {
        match &self.sweep_edges_ps {
            Some(edges) => {
                integrate_over_edges(&self.axis, profile, edges, &mut s.prefix, &mut s.a)
            }
            None => s.a.copy_from_slice(profile),
        }
        if let Some(shifts) = &self.jitter_shifts_ps {
            crate::resample::shift_into(&self.axis, &s.a, shifts[y], &self.axis, &mut s.b);
            std::mem::swap(&mut s.a, &mut s.b);
        }
        let mut gain = self.vignetting_gain(x, y);
        if let Some(f) = &self.power_factors {
            gain *= f[y];
        }
        gain
    }

    /// Flat-field gain of pixel `(x, y)` (1 without vignetting).
    pub fn vignetting_gain(&self, x: usize, y: usize) -> f64 {
        let Some(s) = self.flaws.vignetting else {
            return 1.0;
        };
        let (cx, cy) = (self.nx as f64 / 2.0, self.ny as f64 / 2.0);
        let half_diag2 = cx * cx + cy * cy;
        let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
        1.0 - s * (dx * dx + dy * dy) / half_diag2
    }

    /// The flat field: gain of every pixel, `[y][x]` (`ny * nx`).
    pub fn flat_field(&self) -> Vec<f32> {
        (0..self.ny)
            .flat_map(|y| (0..self.nx).map(move |x| (y, x)))
            .map(|(y, x)| self.vignetting_gain(x, y) as f32)
            .collect()
    }

    /// A dark frame in counts, `[t][x]` (`nt * nx`): the dark signal with no light, as a lab
    /// records it, the average of [`DARK_FRAMES_AVERAGED`] frames (noise `sigma / 8`: a single
    /// frame's noise, subtracted from every scanline, would add to theirs), quantised like a
    /// scanline. `None` when the dark signal is off.
    pub fn dark_frame_counts(&self) -> Option<Vec<f32>> {
        let (offset, sigma) = self.dark?;
        let sigma = sigma / (DARK_FRAMES_AVERAGED as f64).sqrt();
        let mut rng = stream(self.seed, Purpose::DarkFrame, 0);
        Some(
            (0..self.axis.nt * self.nx)
                .map(|_| {
                    let v = offset + sigma * normal(&mut rng);
                    let v = match self.saturation_level {
                        Some(level) => v.min(level),
                        None => v,
                    };
                    self.to_counts(v)
                })
                .collect(),
        )
    }

    fn to_counts(&self, v: f64) -> f32 {
        (v / self.value_per_count).round().clamp(0.0, MAX_COUNT) as f32
    }

    /// Apply every imperfection (module doc, steps 1 to 8) to scanline `y`: `truth` is the
    /// clean row `[x][t]` (`nx * nt`), `counts` receives the quantised row in counts, same
    /// layout. Signal = counts x [`CaptureModel::value_per_count`].
    pub fn apply_row(&self, y: usize, truth: &[f32], counts: &mut [f32]) {
        let nt = self.axis.nt;
        assert_eq!(truth.len(), self.nx * nt, "apply_row: truth is not nx * nt");
        assert_eq!(
            counts.len(),
            self.nx * nt,
            "apply_row: counts is not nx * nt"
        );
        let mut photon_rng = stream(self.seed, Purpose::Photon, y);
        let mut dark_rng = stream(self.seed, Purpose::Dark, y);
        let mut s = Scratch::new(nt);
        for x in 0..self.nx {
            // 1 to 4: sweep non-linearity, jitter, laser power, vignetting.
            let gain = self.shape_pixel(y, x, &truth[x * nt..(x + 1) * nt], &mut s);
            let out = &mut counts[x * nt..(x + 1) * nt];
            for (o, &v) in out.iter_mut().zip(&s.a) {
                let mut v = v as f64 * gain;
                // 5. photon noise.
                if let Some(k) = self.photons_per_unit {
                    let lambda = v * k;
                    v = if lambda > 0.0 && lambda.is_finite() {
                        let n: f64 = Poisson::new(lambda)
                            .expect("positive finite rate")
                            .sample(&mut photon_rng);
                        n / k
                    } else {
                        0.0
                    };
                }
                // 6. dark signal.
                if let Some((offset, sigma)) = self.dark {
                    v += offset + sigma * normal(&mut dark_rng);
                }
                // 7. saturation.
                if let Some(level) = self.saturation_level {
                    v = v.min(level);
                }
                // 8. quantisation.
                *o = self.to_counts(v);
            }
        }
    }

    /// The `[imperfections]` table of the manifest: every imperfection that is on, with its
    /// true parameters in signal units.
    pub fn imperfections(&self) -> Imperfections {
        let f = &self.flaws;
        Imperfections {
            photon_noise: self.photons_per_unit.map(|k| manifest::PhotonNoise {
                photons_at_full_scale: None,
                photons_per_unit: Some(k),
            }),
            dark: self
                .dark
                .map(|(offset, sigma)| manifest::Dark { offset, sigma }),
            vignetting: f.vignetting.map(|strength| manifest::Vignetting {
                strength,
                model: VIGNETTING_MODEL.to_string(),
            }),
            jitter: f
                .jitter_ps
                .zip(self.jitter_shifts_ps.clone())
                .map(|(sigma_ps, shifts_ps)| manifest::Jitter {
                    sigma_ps,
                    shifts_ps,
                }),
            power: f
                .power_sigma
                .zip(self.power_factors.clone())
                .map(|(sigma, factors)| manifest::Power { sigma, factors }),
            sweep: f
                .sweep
                .zip(self.sweep_edges_ps.clone())
                .map(|(strength, bin_times_ps)| manifest::Sweep {
                    strength,
                    bin_times_ps,
                }),
            saturation: self
                .saturation_level
                .map(|level| manifest::Saturation { level }),
            fiducials: f.fiducial_photo_px.map(|photo_px| manifest::FiducialNoise {
                photo_px,
                photo_width_px: FIDUCIAL_PHOTO_WIDTH_PX,
                sigma_px: fiducial_capture_px(photo_px, self.nx),
            }),
        }
    }
}

/// Per-pixel work buffers.
struct Scratch {
    a: Vec<f32>,
    b: Vec<f32>,
    prefix: Vec<f64>,
}

impl Scratch {
    fn new(nt: usize) -> Scratch {
        Scratch {
            a: vec![0.0; nt],
            b: vec![0.0; nt],
            prefix: vec![0.0; nt + 1],
        }
    }
}

/// True time edges of the recorded bins for sweep strength `s` (module doc, step 1).
pub fn sweep_edges_ps(axis: &TimeAxis, s: f64) -> Vec<f64> {
    let nt = axis.nt as f64;
    (0..=axis.nt)
        .map(|j| {
            let j = j as f64;
            let g = (std::f64::consts::PI * j / nt).sin() / std::f64::consts::PI;
            axis.t0_ps + axis.dt_ps * (j + s * nt * g)
        })
        .collect()
}

/// `out[j]` = integral of `profile` (constant within each bin of `axis`) over
/// `[edges[j], edges[j + 1])`; `prefix` is scratch of `nt + 1` values.
fn integrate_over_edges(
    axis: &TimeAxis,
    profile: &[f32],
    edges: &[f64],
    prefix: &mut [f64],
    out: &mut [f32],
) {
    let nt = profile.len();
    prefix[0] = 0.0;
    for i in 0..nt {
        prefix[i + 1] = prefix[i] + profile[i] as f64;
    }
    // Cumulative signal up to time t.
    let cumulative = |t: f64| -> f64 {
        let c = axis.bin_coord(t).clamp(0.0, nt as f64);
        let i = (c.floor() as usize).min(nt - 1);
        prefix[i] + (c - i as f64) * profile[i] as f64
    };
    let mut lo = cumulative(edges[0]);
    for (j, o) in out.iter_mut().enumerate() {
        let hi = cumulative(edges[j + 1]);
        *o = (hi - lo) as f32;
        lo = hi;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cube::TimeFrame;

    fn axis() -> TimeAxis {
        TimeAxis {
            t0_ps: 100.0,
            dt_ps: 2.0,
            nt: 40,
        }
    }

    /// A cube with one smooth pulse per pixel, the brightest value 8.
    fn cube(nx: usize, ny: usize) -> Cube {
        let mut c = Cube::zeros(nx, ny, axis(), TimeFrame::Camera);
        for y in 0..ny {
            for x in 0..nx {
                let centre = 12.0 + x as f64 + 0.5 * y as f64;
                let p = c.profile_mut(x, y);
                for (t, v) in p.iter_mut().enumerate() {
                    let d = (t as f64 - centre) / 2.5;
                    *v = (8.0 * (-0.5 * d * d).exp()) as f32;
                }
            }
        }
        c
    }

    fn counts_of(model: &CaptureModel, c: &Cube, y: usize) -> Vec<f32> {
        let mut out = vec![0.0; c.nx * c.nt()];
        model.apply_row(y, c.row(y), &mut out);
        out
    }

    #[test]
    fn clean_capture_is_the_truth_quantised_at_60000_counts_for_the_max() {
        let c = cube(3, 2);
        let m = CaptureModel::new(&Flaws::default(), &c, 1).unwrap();
        let max = c.data.iter().cloned().fold(0.0f32, f32::max) as f64;
        assert_eq!(m.value_per_count, max / 60000.0);
        assert_eq!(m.imperfections(), Imperfections::default());
        for y in 0..2 {
            let out = counts_of(&m, &c, y);
            for (o, t) in out.iter().zip(c.row(y)) {
                assert_eq!(*o, (*t as f64 / m.value_per_count).round() as f32);
            }
        }
    }

    #[test]
    fn sweep_edges_are_monotone_keep_the_window_and_conserve_each_pixel() {
        let a = axis();
        let e = sweep_edges_ps(&a, 0.3);
        assert_eq!(e.len(), 41);
        assert_eq!(e[0], a.t0_ps);
        assert!((e[40] - a.end_ps()).abs() < 1e-9);
        // Bin widths dt (1 + s cos(pi j / nt)) to first order: the first is wider.
        assert!(e.windows(2).all(|w| w[1] > w[0]));
        assert!((e[1] - e[0]) / a.dt_ps > 1.25);
        assert!((e[40] - e[39]) / a.dt_ps < 0.75);

        let c = cube(2, 1);
        let flaws = Flaws {
            sweep: Some(0.3),
            ..Flaws::default()
        };
        let m = CaptureModel::new(&flaws, &c, 1).unwrap();
        let out = counts_of(&m, &c, 0);
        for x in 0..2 {
            let truth = c.profile(x, 0);
            // Independent integral: the overlap of [e_j, e_j+1) with every truth bin times
            // that bin's density.
            for j in 0..40 {
                let (lo, hi) = (e[j], e[j + 1]);
                let s: f64 = (0..40)
                    .map(|i| {
                        let (a0, a1) = (a.bin_start_ps(i), a.bin_start_ps(i + 1));
                        let overlap = (hi.min(a1) - lo.max(a0)).max(0.0);
                        truth[i] as f64 * overlap / a.dt_ps
                    })
                    .sum();
                let got = out[x * 40 + j] as f64 * m.value_per_count;
                assert!(
                    (got - s).abs() <= 0.5 * m.value_per_count + 1e-6 * s,
                    "bin {j}: {got} vs {s}"
                );
            }
            let total: f64 = out[x * 40..(x + 1) * 40].iter().map(|&v| v as f64).sum();
            let true_total: f64 = truth.iter().map(|&v| v as f64).sum();
            assert!((total * m.value_per_count - true_total).abs() < 20.0 * m.value_per_count);
        }
        // The scale leaves the widened bins room: the brightest reads 60000 counts.
        let peak = counts_of(&m, &c, 0).into_iter().fold(0.0f32, f32::max);
        assert_eq!(peak, 60000.0);
        let im = m.imperfections();
        assert_eq!(im.sweep.unwrap().bin_times_ps, e);
    }

    /// Mean time of a profile (bin centres), ps.
    fn mean_ps(p: &[f32], a: &TimeAxis) -> f64 {
        let s: f64 = p.iter().map(|&v| v as f64).sum();
        p.iter()
            .enumerate()
            .map(|(i, &v)| v as f64 * a.bin_centre_ps(i))
            .sum::<f64>()
            / s
    }

    #[test]
    fn jitter_moves_each_row_by_its_recorded_shift() {
        let c = cube(4, 6);
        let flaws = Flaws {
            jitter_ps: Some(3.0),
            ..Flaws::default()
        };
        let m = CaptureModel::new(&flaws, &c, 5).unwrap();
        let shifts = m.jitter_shifts_ps.clone().unwrap();
        assert_eq!(shifts.len(), 6);
        assert!(shifts.iter().any(|s| s.abs() > 0.5));
        assert_eq!(m.imperfections().jitter.unwrap().shifts_ps, shifts);
        for (y, &shift) in shifts.iter().enumerate() {
            let out = counts_of(&m, &c, y);
            for x in 0..4 {
                let got = mean_ps(&out[x * 40..(x + 1) * 40], &c.axis);
                let want = mean_ps(c.profile(x, y), &c.axis) + shift;
                assert!((got - want).abs() < 0.02, "row {y}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn power_scales_rows_and_vignetting_follows_its_formula() {
        let c = cube(5, 4);
        let flaws = Flaws {
            power_sigma: Some(0.2),
            vignetting: Some(0.4),
            ..Flaws::default()
        };
        let m = CaptureModel::new(&flaws, &c, 9).unwrap();
        let factors = m.power_factors.clone().unwrap();
        assert!(factors.iter().any(|f| (f - 1.0).abs() > 0.02));
        let flat = m.flat_field();
        // Corner pixel (0, 0): r^2 = (2.0^2 + 1.5^2) / (2.5^2 + 2^2).
        let r2: f64 = (2.0 * 2.0 + 1.5 * 1.5) / (2.5 * 2.5 + 2.0 * 2.0);
        assert!((flat[0] as f64 - (1.0 - 0.4 * r2)).abs() < 1e-6);
        for y in 0..4 {
            let out = counts_of(&m, &c, y);
            for x in 0..5 {
                let g = factors[y] * flat[y * 5 + x] as f64;
                for t in 0..40 {
                    let want = c.profile(x, y)[t] as f64 * g / m.value_per_count;
                    assert!((out[x * 40 + t] as f64 - want).abs() <= 0.5 + 1e-3);
                }
            }
        }
    }

    #[test]
    fn photon_noise_has_poisson_variance() {
        // A flat cube: every bin at full scale, 400 photons there.
        let mut c = Cube::zeros(50, 4, axis(), TimeFrame::Camera);
        c.data.fill(2.0);
        let flaws = Flaws {
            photon_noise: Some(400.0),
            ..Flaws::default()
        };
        let m = CaptureModel::new(&flaws, &c, 3).unwrap();
        assert_eq!(m.photons_per_unit, Some(200.0));
        let mut photons = Vec::new();
        for y in 0..4 {
            for v in counts_of(&m, &c, y) {
                photons.push(v as f64 * m.value_per_count * 200.0);
            }
        }
        let n = photons.len() as f64;
        let mean = photons.iter().sum::<f64>() / n;
        let var = photons.iter().map(|p| (p - mean).powi(2)).sum::<f64>() / (n - 1.0);
        // 8000 samples: the mean within 4 standard errors, the variance within 10 %.
        assert!((mean - 400.0).abs() < 4.0 * (400.0 / n).sqrt(), "{mean}");
        assert!((var / 400.0 - 1.0).abs() < 0.1, "{var}");
    }

    #[test]
    fn dark_adds_offset_and_noise_and_the_dark_frame_matches() {
        let mut c = Cube::zeros(50, 4, axis(), TimeFrame::Camera);
        c.data[0] = 1.0;
        let flaws = Flaws {
            dark: Some((0.05, 0.01)),
            ..Flaws::default()
        };
        let m = CaptureModel::new(&flaws, &c, 3).unwrap();
        assert_eq!(m.dark, Some((0.05, 0.01)));
        let stats = |v: &[f64]| {
            let n = v.len() as f64;
            let mean = v.iter().sum::<f64>() / n;
            let sd = (v.iter().map(|p| (p - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
            (mean, sd)
        };
        let vpc = m.value_per_count;
        let row: Vec<f64> = counts_of(&m, &c, 2)
            .iter()
            .map(|&v| v as f64 * vpc)
            .collect();
        let (mean, sd) = stats(&row);
        assert!((mean - 0.05).abs() < 0.001, "{mean}");
        assert!((sd / 0.01 - 1.0).abs() < 0.05, "{sd}");
        let frame: Vec<f64> = m
            .dark_frame_counts()
            .unwrap()
            .iter()
            .map(|&v| v as f64 * vpc)
            .collect();
        assert_eq!(frame.len(), 2000);
        let (mean, sd) = stats(&frame);
        assert!((mean - 0.05).abs() < 0.001, "{mean}");
        // The average of DARK_FRAMES_AVERAGED frames.
        let sd_frame = 0.01 / (DARK_FRAMES_AVERAGED as f64).sqrt();
        assert!((sd / sd_frame - 1.0).abs() < 0.05, "{sd}");
        let im = m.imperfections();
        assert_eq!(im.dark.unwrap().offset, 0.05);
    }

    #[test]
    fn saturation_clips_at_the_top_count() {
        let c = cube(3, 2);
        let flaws = Flaws {
            saturation: Some(0.5),
            ..Flaws::default()
        };
        let m = CaptureModel::new(&flaws, &c, 3).unwrap();
        assert_eq!(m.saturation_level, Some(4.0));
        assert_eq!(m.value_per_count, 4.0 / 65535.0);
        let out = counts_of(&m, &c, 1);
        let truth = c.row(1);
        let mut clipped = 0;
        for (o, &t) in out.iter().zip(truth) {
            if t as f64 >= 4.0 {
                assert_eq!(*o, 65535.0);
                clipped += 1;
            } else {
                assert!((*o as f64 - t as f64 / m.value_per_count).abs() <= 0.5 + 1e-3);
            }
        }
        assert!(clipped > 3);
        assert_eq!(m.imperfections().saturation.unwrap().level, 4.0);
    }

    #[test]
    fn streams_are_independent_of_other_flaws() {
        let c = cube(3, 3);
        let a = CaptureModel::new(
            &Flaws {
                jitter_ps: Some(1.0),
                ..Flaws::default()
            },
            &c,
            4,
        )
        .unwrap();
        let b = CaptureModel::new(&Flaws::realistic(), &c, 4).unwrap();
        let scaled: Vec<f64> = a
            .jitter_shifts_ps
            .unwrap()
            .iter()
            .map(|s| s * 2.0)
            .collect();
        assert_eq!(scaled, b.jitter_shifts_ps.unwrap());
        let other = CaptureModel::new(&Flaws::realistic(), &c, 5).unwrap();
        assert_ne!(other.power_factors, b.power_factors);
    }

    #[test]
    fn out_of_range_parameters_name_the_flaw() {
        let cases = [
            (
                Flaws {
                    sweep: Some(1.0),
                    ..Flaws::default()
                },
                "sweep",
            ),
            (
                Flaws {
                    photon_noise: Some(0.0),
                    ..Flaws::default()
                },
                "photon_noise",
            ),
            (
                Flaws {
                    dark: Some((0.0, -1.0)),
                    ..Flaws::default()
                },
                "dark",
            ),
            (
                Flaws {
                    jitter_ps: Some(f64::NAN),
                    ..Flaws::default()
                },
                "jitter_ps",
            ),
            (
                Flaws {
                    saturation: Some(-0.1),
                    ..Flaws::default()
                },
                "saturation",
            ),
        ];
        for (f, name) in cases {
            assert_eq!(f.validate().unwrap_err().flaw.field(), name);
        }
        assert!(Flaws::realistic().validate().is_ok());
    }
}

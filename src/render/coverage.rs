//! Where the world-time cube holds light, and which frames of a camera path look at it.
//!
//! A frame shows light only where the world emission time of a pixel (step 4 of the
//! [`crate::render`] pipeline, `t_e = t_receive - eta r / c`) falls where the pixel's cube
//! pixel recorded some. An unwarped capture holds light in a small part of its axis: the
//! unwarp's covering axis ([`crate::unwarp::covering_axis`]) spans the union of every pixel's
//! recording window shifted by its own distance, so each pixel is empty over most of it
//! (a 1024 ps streak window becomes a 2108 ps world axis for the built-in `cube` scene at
//! 160 x 120), and the light itself starts some time after the axis does. A path whose times
//! miss that renders black frames.
//!
//! - [`LightProfile`]: the cube's signal summed over pixels, each delayed by its own time,
//!   and the span where it exceeds a fraction of its peak: in world time ([`light_span`]), as
//!   received at a point, or as received by a frame's camera from the pixels it shows (from
//!   which the camera shortcuts choose their times, [`super::paths`]).
//! - [`predict_coverage`]: without rendering, for each frame of a path, the emission times
//!   that a coarse grid of its pixels ([`GRID`]) sees, through the renderer's own per-pixel
//!   mapping ([`super::probe_pixel`]), against the cube's light span; its [`Coverage`]
//!   summary names the frames that will be black and prints as a one-line warning.
//! - [`frame_is_black`]: whether a rendered frame holds no light at all.

use super::{check_frames, probe_pixel, RenderError, RenderScene, RenderSettings, View};
use crate::camera_path::{CameraPath, FrameState};
use crate::pyramid::PrefixRead;
use crate::units::flight_time_ps;
use nalgebra::Point3;
use rayon::prelude::*;
use std::fmt;
use std::ops::Range;

/// Fraction of the peak of the summed signal above which a time counts as holding light:
/// 1 %, above the residue of a dark subtraction summed over the image (0.1-0.3 % of the peak
/// before the first light in the demo's world cube), and far above the faintest light an
/// 8-bit frame shows (about 1.5e-4 of the exposure's white), so that the frames at either
/// end of a span still show theirs.
pub const LIGHT_FRACTION: f64 = 0.01;

/// Pixels sampled by [`predict_coverage`] (columns, rows), evenly spread over each frame and
/// again over its central quarter; the image's centre pixel is sampled too.
pub const GRID: (usize, usize) = (16, 12);

/// An interval of times at which the cube holds light, ps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSpan {
    pub start_ps: f64,
    pub end_ps: f64,
}

impl LightSpan {
    /// `end_ps - start_ps`.
    pub fn len_ps(&self) -> f64 {
        self.end_ps - self.start_ps
    }
}

/// The cube's signal summed over a set of its pixels (repeats allowed), each delayed by its
/// own time, in bins of the cube's width: the light as some observer receives it.
#[derive(Clone, Debug, PartialEq)]
pub struct LightProfile {
    /// Start of bin 0, ps.
    pub origin_ps: f64,
    /// Bin width, ps (the cube's, in world time).
    pub dt_ps: f64,
    /// Summed signal per bin.
    pub sums: Vec<f64>,
    /// Pixels summed.
    pub pixels: usize,
}

impl LightProfile {
    /// The signal in physical world time (0 = the pulse leaves the laser spot), summed over
    /// the capture pixels the renderer can look up (those whose ray hits the mesh and that
    /// the cube's mask keeps; a regular subset of at most about [`MAX_SUMMED_PIXELS`]).
    pub fn world(scene: &RenderScene) -> LightProfile {
        LightProfile::summed(scene, &capture_delays(scene, |_| 0.0))
    }

    /// [`LightProfile::world`] as the light arrives at `o_m`: each capture pixel's signal
    /// delayed by the flight time `eta |p - o| / c` from its point `p`. At the capture
    /// camera's position these are the capture's own camera times (shifted by the
    /// calibration's `t0_ps`), where a streak camera records: light exists there only inside
    /// the recording window.
    pub fn received_at(scene: &RenderScene, o_m: &Point3<f64>) -> LightProfile {
        let eta = scene.capture.eta;
        let delays = capture_delays(scene, |p| flight_time_ps(eta, (p - o_m).norm()));
        LightProfile::summed(scene, &delays)
    }

    /// The light the frame `state` looks at, as its camera receives it: for every pixel of a
    /// regular subset of the frame (at most about [`MAX_SUMMED_PIXELS`]) that shows a cube
    /// pixel, that pixel's signal delayed by the flight time from the hit point to the
    /// camera, both from [`probe_pixel`] (the renderer's own mapping; transient view, under
    /// `settings`' effects). Reception times are world times: the frame shows light when its
    /// `t_receive` falls where this profile holds some.
    pub fn in_frame(
        scene: &RenderScene,
        settings: &RenderSettings,
        state: &FrameState,
    ) -> LightProfile {
        let settings = RenderSettings {
            view: View::Transient,
            ..*settings
        };
        let (w, h) = (settings.width, settings.height);
        let stride = subset_stride(w * h);
        let eta = scene.capture.eta;
        let nx = scene.world.nx;
        let delays: Vec<(usize, f64)> = (0..h)
            .into_par_iter()
            .step_by(stride)
            .flat_map_iter(|j| {
                (0..w).step_by(stride).filter_map(move |i| {
                    let s = probe_pixel(scene, &settings, state, i, j);
                    let (x, y) = s.capture_pixel?;
                    let (_, dist_m) = s.hit_m?;
                    Some((y * nx + x, flight_time_ps(eta, dist_m)))
                })
            })
            .collect();
        LightProfile::summed(scene, &delays)
    }

    /// The signal of the cube pixels `delays` lists (flat index, delay in ps), each delayed
    /// and summed into bins of the cube's width, each bin split linearly between the two it
    /// overlaps. Entries with a non-finite delay are left out.
    fn summed(scene: &RenderScene, delays: &[(usize, f64)]) -> LightProfile {
        let w = scene.world;
        let nt = w.axis.nt;
        let dt_ps = w.axis.dt_ps / scene.capture.time_scale;
        let t0_ps = scene.world_time_ps(w.axis.t0_ps);
        let delays: Vec<(usize, f64)> = delays
            .iter()
            .copied()
            .filter(|(_, d)| d.is_finite())
            .collect();
        let (lo, hi) = delays
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &(_, d)| {
                (a.min(d), b.max(d))
            });
        if lo > hi {
            return LightProfile {
                origin_ps: t0_ps,
                dt_ps,
                sums: Vec::new(),
                pixels: 0,
            };
        }
        // Bins of the cube's width, widened where the delays span more than
        // MAX_PROFILE_BINS of them (a tiny dt_ps or a large time_scale: 1e-6 ps asked 6.4 GB
        // per thread, and a count never checked indexed past the profile).
        let span_ps = (hi - lo) + nt as f64 * dt_ps;
        let bin_ps = dt_ps.max(span_ps / (MAX_PROFILE_BINS - 2) as f64);
        let n = ((span_ps / bin_ps).ceil() as usize + 2).min(MAX_PROFILE_BINS);
        // Cube bins per profile bin: 1 unless widened.
        let step = dt_ps / bin_ps;
        let sums = delays
            .par_iter()
            .fold(
                || vec![0.0f64; n],
                |mut acc, &(pix, d)| {
                    let prefix = w.prefix.pixel(pix);
                    let u = (d - lo) / bin_ps;
                    let (j0, frac) = (u.floor() as usize, u - u.floor());
                    for i in 0..nt {
                        let v = prefix.bin(i);
                        let (j, f) = if step == 1.0 {
                            (j0 + i, frac)
                        } else {
                            let u = u + i as f64 * step;
                            (u.floor() as usize, u - u.floor())
                        };
                        if j + 1 < n {
                            acc[j] += v * (1.0 - f);
                            acc[j + 1] += v * f;
                        }
                    }
                    acc
                },
            )
            .reduce(
                || vec![0.0f64; n],
                |mut a, b| {
                    a.iter_mut().zip(&b).for_each(|(a, b)| *a += b);
                    a
                },
            );
        LightProfile {
            origin_ps: t0_ps + lo,
            dt_ps: bin_ps,
            sums,
            pixels: delays.len(),
        }
    }

    /// The largest bin's sum divided by the pixels summed (0 without pixels): the level of
    /// the brightest moment of an average pixel.
    pub fn peak_per_pixel(&self) -> f64 {
        let peak = self.sums.iter().cloned().fold(0.0f64, f64::max);
        if self.pixels == 0 || !peak.is_finite() {
            return 0.0;
        }
        peak / self.pixels as f64
    }

    /// From the start of the first to the end of the last bin whose sum per pixel exceeds
    /// `level_per_pixel`; None when none does or the level is not positive.
    pub fn span_above(&self, level_per_pixel: f64) -> Option<LightSpan> {
        if level_per_pixel.is_nan() || level_per_pixel <= 0.0 || self.pixels == 0 {
            return None;
        }
        let level = level_per_pixel * self.pixels as f64;
        let first = self.sums.iter().position(|&s| s > level)?;
        let last = self.sums.iter().rposition(|&s| s > level)?;
        Some(LightSpan {
            start_ps: self.origin_ps + first as f64 * self.dt_ps,
            end_ps: self.origin_ps + (last + 1) as f64 * self.dt_ps,
        })
    }

    /// [`LightProfile::span_above`] `fraction` of the peak.
    pub fn span(&self, fraction: f64) -> Option<LightSpan> {
        self.span_above(fraction * self.peak_per_pixel())
    }
}

/// Where the cube holds light in physical world time:
/// `LightProfile::world(scene).span(fraction)`.
pub fn light_span(scene: &RenderScene, fraction: f64) -> Option<LightSpan> {
    LightProfile::world(scene).span(fraction)
}

/// Most bins of a [`LightProfile`] (8 MB of sums per thread): delays spanning more bins of
/// the cube's width are summed into wider bins.
pub const MAX_PROFILE_BINS: usize = 1 << 20;

/// Most pixels summed by a [`LightProfile`]: larger images are read on a regular grid of
/// every `s`-th pixel in x and y, which keeps a profile to tens of milliseconds.
pub const MAX_SUMMED_PIXELS: usize = 1 << 16;

/// The grid step that keeps `pixels` to about [`MAX_SUMMED_PIXELS`].
fn subset_stride(pixels: usize) -> usize {
    ((pixels as f64 / MAX_SUMMED_PIXELS as f64).sqrt().ceil() as usize).max(1)
}

/// `(flat cube pixel, delay_ps(point))` for the capture pixels the renderer can look up (a
/// hit, kept by the mask), on the grid of [`subset_stride`].
fn capture_delays(
    scene: &RenderScene,
    delay_ps: impl Fn(&Point3<f64>) -> f64 + Sync,
) -> Vec<(usize, f64)> {
    let w = scene.world;
    let stride = subset_stride(w.nx * w.ny);
    let delay_ps = &delay_ps;
    (0..w.ny)
        .into_par_iter()
        .step_by(stride)
        .flat_map_iter(|y| {
            (0..w.nx).step_by(stride).filter_map(move |x| {
                let pix = y * w.nx + x;
                let kept = w.mask.as_ref().is_none_or(|m| m[pix] != 0);
                let p = scene.capture_hit_m(x, y).filter(|_| kept)?;
                Some((pix, delay_ps(&p)))
            })
        })
        .collect()
}

/// Whether a frame of scene-linear pixels holds no light: no component is positive. The
/// renderer writes exact zeros where the cube holds no signal (outside a pixel's recording
/// window, before the light, where a ray leaves the scene), so such a frame is black however
/// it is exposed.
pub fn frame_is_black(pixels: &[[f32; 3]]) -> bool {
    !pixels.iter().flatten().any(|&v| v > 0.0)
}

/// What the sampled pixels of one frame see.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameLight {
    /// Some sampled pixel shows light (a positive value).
    Lit,
    /// No sampled pixel shows light, and every sampled emission window ends at or before the
    /// start of the cube's light.
    Before,
    /// No sampled pixel shows light, and every sampled emission window starts at or after the
    /// end of the cube's light.
    After,
    /// No sampled pixel shows light, though the sampled windows are not all on one side of
    /// the cube's light (their own cube pixels hold none at those times).
    Dark,
    /// No sampled pixel shows light or has an emission time: the rays leave the scene, the
    /// capture camera does not see their points, or the view has no emission time
    /// (isochrones, integrated).
    Unseen,
}

/// One frame's prediction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameCoverage {
    pub frame: usize,
    /// Earliest emission time and latest end of an emission window (`t_e + dtau / D`) over
    /// the sampled pixels, world ps; None when none has an emission time.
    pub t_emit_ps: Option<(f64, f64)>,
    /// Sampled pixels showing light.
    pub lit_samples: usize,
    pub light: FrameLight,
}

/// [`predict_coverage`]'s summary of a frame range.
#[derive(Clone, Debug, PartialEq)]
pub struct Coverage {
    /// The path's number of frames.
    pub frame_count: usize,
    /// Pixels sampled per frame.
    pub samples_per_frame: usize,
    /// One entry per predicted frame, in order.
    pub frames: Vec<FrameCoverage>,
    /// Where the cube holds light, world time ([`light_span`] at [`LIGHT_FRACTION`]); None
    /// for a cube without signal.
    pub light_ps: Option<LightSpan>,
    /// The end of the cube's last non-zero bin, world time
    /// ([`RenderScene::last_signal_world_ps`]): the warning names it beside `light_ps`, whose
    /// threshold leaves out weak late light.
    pub last_signal_ps: Option<f64>,
    /// The time offset the frames were predicted with ([`RenderSettings::time_offset_ps`]).
    pub time_offset_ps: f64,
}

impl Coverage {
    /// The runs of consecutive frames classed `light`, as frame ranges.
    pub fn runs(&self, light: FrameLight) -> Vec<Range<usize>> {
        let mut out: Vec<Range<usize>> = Vec::new();
        for f in self.frames.iter().filter(|f| f.light == light) {
            match out.last_mut() {
                Some(r) if r.end == f.frame => r.end += 1,
                _ => out.push(f.frame..f.frame + 1),
            }
        }
        out
    }

    /// Frames predicted black (every class but [`FrameLight::Lit`]).
    pub fn black_count(&self) -> usize {
        self.frames
            .iter()
            .filter(|f| f.light != FrameLight::Lit)
            .count()
    }

    /// Emission times seen by the frames classed `light`: earliest start and latest end.
    pub fn seen_ps(&self, light: FrameLight) -> Option<(f64, f64)> {
        self.frames
            .iter()
            .filter(|f| f.light == light)
            .filter_map(|f| f.t_emit_ps)
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
    }

    /// When some frames see times entirely before or after the cube's light: the time offset
    /// that moves the earliest emission time the predicted frames see to the start of the
    /// light. None otherwise.
    pub fn suggested_time_offset_ps(&self) -> Option<f64> {
        let light = self.light_ps?;
        if self.runs(FrameLight::Before).is_empty() && self.runs(FrameLight::After).is_empty() {
            return None;
        }
        let seen = self
            .frames
            .iter()
            .filter_map(|f| f.t_emit_ps)
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))?;
        Some(self.time_offset_ps + light.start_ps - seen.0)
    }
}

/// Frame ranges as `0..49, 60..62` (end excluded).
fn ranges_text(runs: &[Range<usize>]) -> String {
    runs.iter()
        .map(|r| format!("{}..{}", r.start, r.end))
        .collect::<Vec<_>>()
        .join(", ")
}

impl fmt::Display for Coverage {
    /// One line per class of black frames, e.g. `frames 0..49 of 100 see world times 0..400
    /// ps, before the cube's light (light above 1 % of the peak of the signal summed over the
    /// image lies in 1650..2900 ps; the cube's last non-zero bin ends at 8192 ps): a time
    /// offset of about 1650 ps shows it`; nothing when every frame is predicted lit.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let threshold = format!(
            "light above {} % of the peak of the signal summed over the image",
            LIGHT_FRACTION * 100.0
        );
        let last = match self.last_signal_ps {
            Some(t) => format!("the cube's last non-zero bin ends at {t:.0} ps"),
            None => "the cube holds no non-zero bin".to_string(),
        };
        let light = match self.light_ps {
            Some(l) => format!(
                "{threshold} lies in {:.0}..{:.0} ps; {last}",
                l.start_ps, l.end_ps
            ),
            None => format!("no {threshold}; {last}"),
        };
        let suggestion = self
            .suggested_time_offset_ps()
            .map(|t| format!(": a time offset of about {t:.0} ps shows it"))
            .unwrap_or_default();
        let mut lines = Vec::new();
        for (class, what) in [
            (FrameLight::Before, "before the cube's light"),
            (FrameLight::After, "after the cube's light"),
            (FrameLight::Dark, "where their cube pixels hold no light"),
        ] {
            let runs = self.runs(class);
            if runs.is_empty() {
                continue;
            }
            let seen = self
                .seen_ps(class)
                .map(|(a, b)| format!("{a:.0}..{b:.0} ps"))
                .unwrap_or_default();
            let tail = if class == FrameLight::Dark {
                ""
            } else {
                &suggestion
            };
            lines.push(format!(
                "frames {} of {} see world times {seen}, {what} ({light}){tail}",
                ranges_text(&runs),
                self.frame_count
            ));
        }
        let unseen = self.runs(FrameLight::Unseen);
        if !unseen.is_empty() {
            lines.push(format!(
                "frames {} of {} show no point of the cube at any of {} sampled pixels",
                ranges_text(&unseen),
                self.frame_count,
                self.samples_per_frame
            ));
        }
        f.write_str(&lines.join("\n"))
    }
}

/// The sampled pixel positions along a side of `n` pixels: `min(n, g)` evenly spread centres.
fn grid_positions(n: usize, g: usize) -> Vec<usize> {
    let g = g.min(n).max(1);
    (0..g).map(|k| ((2 * k + 1) * n) / (2 * g)).collect()
}

/// The pixels [`predict_coverage`] samples in a `width x height` frame: the [`GRID`] over the
/// whole frame, the same grid over its central quarter (half the width and height: a fast
/// dolly's aberration gathers the scene there and sends the other rays out of it) and the
/// centre pixel (where the shortcuts keep their target); no pixel twice.
fn sample_pixels(width: usize, height: usize) -> Vec<(usize, usize)> {
    let grid = |x0: usize, y0: usize, w: usize, h: usize| {
        let cols = grid_positions(w, GRID.0);
        grid_positions(h, GRID.1)
            .into_iter()
            .flat_map(move |j| cols.clone().into_iter().map(move |i| (x0 + i, y0 + j)))
    };
    let (qw, qh) = ((width / 2).max(1), (height / 2).max(1));
    let mut pixels: Vec<(usize, usize)> = grid(0, 0, width, height)
        .chain(grid((width - qw) / 2, (height - qh) / 2, qw, qh))
        .chain([(width / 2, height / 2)])
        .collect();
    pixels.sort_unstable();
    pixels.dedup();
    pixels
}

/// Predict, without rendering, which of `frames` of `path` under `settings` show light: for a
/// [`GRID`] of pixels over each frame and over its central quarter and the centre pixel,
/// [`probe_pixel`] gives each one's emission time, Doppler factor and value; the emission window `[t_e, t_e + dtau / D]` (`D = 1` with the
/// searchlight off) is compared with the cube's [`light_span`]. A frame is
/// [`FrameLight::Lit`] when a sampled pixel shows a positive value, and otherwise classed by
/// where its windows lie (see [`FrameLight`]). A frame lit only between the sampled pixels
/// is predicted black. Checks the settings and the frame range first.
pub fn predict_coverage(
    scene: &RenderScene,
    settings: &RenderSettings,
    path: &CameraPath,
    frames: Range<usize>,
) -> Result<Coverage, RenderError> {
    settings.validate()?;
    check_frames(path, &frames)?;
    let light = light_span(scene, LIGHT_FRACTION);
    let pixels = sample_pixels(settings.width, settings.height);
    let searchlight = settings.effects.searchlight;
    let predicted: Vec<FrameCoverage> = frames
        .into_par_iter()
        .map(|k| {
            let state = path.frame(k);
            let mut seen: Option<(f64, f64)> = None;
            let mut lit = 0;
            for &(i, j) in &pixels {
                let s = probe_pixel(scene, settings, &state, i, j);
                if s.value > 0.0 {
                    lit += 1;
                }
                if let Some(t) = s.t_emit_ps {
                    let d = if searchlight { s.doppler } else { 1.0 };
                    let end = t + settings.dtau_ps / d;
                    seen = Some(match seen {
                        Some((a, b)) => (a.min(t), b.max(end)),
                        None => (t, end),
                    });
                }
            }
            let class = match (lit, seen, light) {
                (n, _, _) if n > 0 => FrameLight::Lit,
                (_, None, _) => FrameLight::Unseen,
                (_, Some((_, end)), Some(l)) if end <= l.start_ps => FrameLight::Before,
                (_, Some((start, _)), Some(l)) if start >= l.end_ps => FrameLight::After,
                _ => FrameLight::Dark,
            };
            FrameCoverage {
                frame: k,
                t_emit_ps: seen,
                lit_samples: lit,
                light: class,
            }
        })
        .collect();
    Ok(Coverage {
        frame_count: path.spec().frames,
        samples_per_frame: pixels.len(),
        frames: predicted,
        light_ps: light,
        last_signal_ps: scene.last_signal_world_ps(),
        time_offset_ps: settings.time_offset_ps,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_positions_are_pixel_centres_spread_over_the_side() {
        assert_eq!(
            grid_positions(160, 16),
            (0..16).map(|k| 5 + 10 * k).collect::<Vec<_>>()
        );
        assert_eq!(grid_positions(4, 16), vec![0, 1, 2, 3]);
        assert_eq!(grid_positions(1, 12), vec![0]);
        for n in [7, 12, 13, 121, 480] {
            let g = grid_positions(n, 12);
            assert!(g.windows(2).all(|w| w[0] < w[1]) && *g.last().unwrap() < n);
        }
    }

    #[test]
    fn samples_cover_the_frame_and_its_centre_once() {
        let p = sample_pixels(160, 120);
        // 16 x 12 over the frame, 16 x 12 over the middle 80 x 60 (none shared), the centre.
        assert_eq!(p.len(), 2 * 192 + 1);
        assert!(p.contains(&(80, 60)) && p.contains(&(5, 5)) && p.contains(&(42, 32)));
        assert!(p.iter().all(|&(i, j)| i < 160 && j < 120));
        let q = sample_pixels(3, 2);
        assert_eq!(q, vec![(0, 0), (0, 1), (1, 0), (1, 1), (2, 0), (2, 1)]);
        assert_eq!(sample_pixels(1, 1), vec![(0, 0)]);
    }

    #[test]
    fn black_frames_have_no_positive_component() {
        assert!(frame_is_black(&[[0.0; 3]; 4]));
        assert!(frame_is_black(&[[0.0, -1e-3, f32::NAN]]));
        assert!(frame_is_black(&[]));
        assert!(!frame_is_black(&[[0.0; 3], [0.0, 1e-30, 0.0]]));
    }

    #[test]
    fn runs_group_consecutive_frames() {
        let f = |frame, light| FrameCoverage {
            frame,
            t_emit_ps: Some((frame as f64, frame as f64 + 1.0)),
            lit_samples: 0,
            light,
        };
        use FrameLight::*;
        let c = Coverage {
            frame_count: 10,
            samples_per_frame: 4,
            frames: vec![
                f(2, Before),
                f(3, Before),
                f(4, Lit),
                f(5, After),
                f(6, Before),
            ],
            light_ps: Some(LightSpan {
                start_ps: 3.6,
                end_ps: 5.0,
            }),
            last_signal_ps: Some(8192.0),
            time_offset_ps: 100.0,
        };
        assert_eq!(c.runs(Before), vec![2..4, 6..7]);
        assert_eq!(c.runs(After), vec![5..6]);
        assert_eq!(c.black_count(), 4);
        assert_eq!(c.seen_ps(Before), Some((2.0, 7.0)));
        // The earliest time seen (2) moves to the light's start (3.6).
        assert!((c.suggested_time_offset_ps().unwrap() - 101.6).abs() < 1e-9);
        let text = c.to_string();
        assert!(text.starts_with(
            "frames 2..4, 6..7 of 10 see world times 2..7 ps, before the cube's light (light above 1 % of the peak of the signal summed over the image lies in 4..5 ps; the cube's last non-zero bin ends at 8192 ps): a time offset of about 102 ps"
        ), "{text}");
        assert_eq!(text.lines().count(), 2);
    }
}

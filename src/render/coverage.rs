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
//! - [`light_span`] and [`light_span_received_at`]: the first and last times at which the
//!   cube's summed signal exceeds a fraction of its peak, in world time or as received at a
//!   point (each pixel's signal delayed by its distance to that point). The camera shortcuts
//!   ([`super::paths`]) choose their times from the second.
//! - [`predict_coverage`]: without rendering, for each frame of a path, the emission times
//!   that a coarse grid of its pixels ([`GRID`]) sees, through the renderer's own per-pixel
//!   mapping ([`super::probe_pixel`]), against the cube's light span; its [`Coverage`]
//!   summary names the frames that will be black and prints as a one-line warning.
//! - [`frame_is_black`]: whether a rendered frame holds no light at all.

use super::{check_frames, probe_pixel, RenderError, RenderScene, RenderSettings};
use crate::camera_path::CameraPath;
use crate::pyramid::PrefixRead;
use crate::units::flight_time_ps;
use nalgebra::Point3;
use rayon::prelude::*;
use std::fmt;
use std::ops::Range;

/// Fraction of the peak of the summed signal above which a time counts as holding light:
/// 1 %, well above the residue of a dark subtraction summed over the image (0.3 % of the peak
/// before the first light in the demo's world cube) and well below what a frame needs to show
/// something (8-bit sRGB shows 1.5e-4 of the exposure's white).
pub const LIGHT_FRACTION: f64 = 0.01;

/// Pixels sampled per frame by [`predict_coverage`] (columns, rows), evenly spread; the
/// image's centre pixel is sampled too.
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

/// The first and last physical world times (0 = the pulse leaves the laser spot) at which
/// the cube's signal, summed over the capture pixels the renderer can look up (those whose
/// ray hits the mesh and that the cube's mask keeps), exceeds `fraction` of its peak. The sum
/// is taken over bins of the cube's width. None when no bin's sum is positive.
pub fn light_span(scene: &RenderScene, fraction: f64) -> Option<LightSpan> {
    summed_span(scene, fraction, |_| 0.0)
}

/// [`light_span`] for the light as it arrives at `o_m`: each capture pixel's signal delayed by
/// the flight time `eta |p - o| / c` from its point `p` to `o_m`. At the capture camera's
/// position these are the capture's own camera times (shifted by the calibration's `t0_ps`),
/// where a streak camera records: light exists there only inside the recording window.
pub fn light_span_received_at(
    scene: &RenderScene,
    o_m: &Point3<f64>,
    fraction: f64,
) -> Option<LightSpan> {
    let eta = scene.capture.eta;
    summed_span(scene, fraction, |p| flight_time_ps(eta, (p - o_m).norm()))
}

/// The span where the cube's signal, each pixel delayed by `delay_ps(point)` and summed into
/// bins of the cube's width (each bin split linearly between the two it overlaps), exceeds
/// `fraction` of its peak.
fn summed_span(
    scene: &RenderScene,
    fraction: f64,
    delay_ps: impl Fn(&Point3<f64>) -> f64 + Sync,
) -> Option<LightSpan> {
    let w = scene.world;
    let nt = w.axis.nt;
    let dt_ps = w.axis.dt_ps / scene.capture.time_scale;
    let t0_ps = scene.world_time_ps(w.axis.t0_ps);
    let delays: Vec<Option<f64>> = (0..w.nx * w.ny)
        .into_par_iter()
        .map(|pix| {
            let (x, y) = (pix % w.nx, pix / w.nx);
            let kept = w.mask.as_ref().is_none_or(|m| m[pix] != 0);
            let p = scene.capture_hit_m(x, y).filter(|_| kept)?;
            Some(delay_ps(&p)).filter(|d| d.is_finite())
        })
        .collect();
    let (lo, hi) = delays
        .iter()
        .flatten()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &d| {
            (a.min(d), b.max(d))
        });
    if lo > hi {
        return None;
    }
    let origin_ps = t0_ps + lo;
    let n = nt + ((hi - lo) / dt_ps).ceil() as usize + 2;
    let sums = delays
        .par_iter()
        .enumerate()
        .fold(
            || vec![0.0f64; n],
            |mut acc, (pix, d)| {
                if let Some(d) = d {
                    let prefix = w.prefix.pixel(pix);
                    let u = (d - lo) / dt_ps;
                    let (j0, frac) = (u.floor() as usize, u - u.floor());
                    for i in 0..nt {
                        let v = prefix.bin(i);
                        acc[j0 + i] += v * (1.0 - frac);
                        acc[j0 + i + 1] += v * frac;
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
    let peak = sums.iter().cloned().fold(0.0f64, f64::max);
    if !(peak > 0.0 && peak.is_finite()) {
        return None;
    }
    let level = fraction * peak;
    let first = sums.iter().position(|&s| s > level)?;
    let last = sums.iter().rposition(|&s| s > level)?;
    Some(LightSpan {
        start_ps: origin_ps + first as f64 * dt_ps,
        end_ps: origin_ps + (last + 1) as f64 * dt_ps,
    })
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
    /// ps, before the cube's light (1650..2900 ps): a time offset of about 1650 ps shows it`;
    /// nothing when every frame is predicted lit.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let light = match self.light_ps {
            Some(l) => format!("{:.0}..{:.0} ps", l.start_ps, l.end_ps),
            None => "none".to_string(),
        };
        let suggestion = self
            .suggested_time_offset_ps()
            .map(|t| format!(": a time offset of about {t:.0} ps shows it"))
            .unwrap_or_default();
        let mut lines = Vec::new();
        for (class, what) in [
            (FrameLight::Before, "before the cube's light"),
            (FrameLight::After, "after the cube's light"),
            (FrameLight::Dark, "where their cube pixels hold no light; the cube's light is"),
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

/// Predict, without rendering, which of `frames` of `path` under `settings` show light: for a
/// [`GRID`] of pixels per frame and the image's centre pixel, [`probe_pixel`] gives each one's emission time, Doppler
/// factor and value; the emission window `[t_e, t_e + dtau / D]` (`D = 1` with the
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
    let cols = grid_positions(settings.width, GRID.0);
    let rows = grid_positions(settings.height, GRID.1);
    // The grid and the image centre (where the shortcuts keep their target; at high speed
    // a dolly's rays away from it leave the scene).
    let centre = (settings.width / 2, settings.height / 2);
    let mut pixels: Vec<(usize, usize)> = rows
        .iter()
        .flat_map(|&j| cols.iter().map(move |&i| (i, j)))
        .collect();
    if !pixels.contains(&centre) {
        pixels.push(centre);
    }
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
        time_offset_ps: settings.time_offset_ps,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_positions_are_pixel_centres_spread_over_the_side() {
        assert_eq!(grid_positions(160, 16), (0..16).map(|k| 5 + 10 * k).collect::<Vec<_>>());
        assert_eq!(grid_positions(4, 16), vec![0, 1, 2, 3]);
        assert_eq!(grid_positions(1, 12), vec![0]);
        for n in [7, 12, 13, 121, 480] {
            let g = grid_positions(n, 12);
            assert!(g.windows(2).all(|w| w[0] < w[1]) && *g.last().unwrap() < n);
        }
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
            "frames 2..4, 6..7 of 10 see world times 2..7 ps, before the cube's light (4..5 ps): a time offset of about 102 ps"
        ), "{text}");
        assert_eq!(text.lines().count(), 2);
    }
}

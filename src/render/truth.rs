//! The direct truth of a moving camera: the frames [`super::render_frame`] approximates from
//! a capture, computed instead by tracing the moving camera's own rays through the scene with
//! the transient path tracer (seed Eq. 1 for the light, seed Sec. 4 for the camera). Their
//! difference is the image-based renderer's own error: disocclusion, pixel footprints and
//! time interpolation (docs/truth.md).
//!
//! # Per pixel and frame
//!
//! 1. `spp` points spread over the pixel (the tracer's scrambled Sobol points, dimension 0):
//!    a box filter over the pixel's footprint, where the renderer takes its centre.
//! 2. Each point's camera ray and its aberration into the world, with the Doppler factor
//!    `D` of the light arriving along it: [`super::frame`]'s steps 1-2, the same functions
//!    (rotating sensor, medium of index `eta` and every effect flag included).
//! 3. The ray is traced from the camera's position at the frame's reception time, as the
//!    renderer places it; the tracer's paths (next-event estimation, light vertices,
//!    Russian roulette: [`crate::tracer::ray_paths`]) give contributions of radiance `L_k`
//!    that arrive there at `t_k = eta l_k / c` after the pulse left the spot (`l_k`: the
//!    path's length from the spot to the camera).
//! 4. The light received during the exposure left the first surface `p` during
//!    `[t_e, t_e + dtau / D]`, `t_e = t_receive - eta r / c` (the renderer's step 4 and 6):
//!    at the camera, the arrivals `[t_receive, t_receive + dtau / D]`. Each contribution
//!    counts with the part of its time response inside that window,
//!    `H(t_receive + dtau/D - t_k) - H(t_receive - t_k)`, `H` being the cumulative response
//!    of the capture's bins ([`crate::tracer::binning::response_cdf`]: the pulse and the
//!    one-bin box), so that the truth and a capture of the same scene differ only in
//!    viewpoint. With the `unwarp` effect off the window applies to the emission time at `p`
//!    instead (`t_k - eta r / c`), as the renderer shows every point at `t_receive`.
//! 5. The pixel value is the mean over its points of `window_factor(D) E / dtau`
//!    ([`crate::relativity::Radiometry::window_factor`]) times the colour of `D lambda`
//!    ([`super::frame`]'s step 7), in the renderer's units: a cube's radiance per
//!    picosecond of proper time.
//!
//! # What it leaves to the renderer's approximation
//!
//! The camera's position is held at its value at the frame's reception time for the whole
//! exposure, as in the renderer, and the motion during the exposure is carried by the window
//! `dtau / D` alone (exact to first order in the distance moved during one frame). Only the
//! transient view has a truth; the others are the renderer's own constructions.
//!
//! # Determinism
//!
//! Pixel `(i, j)` of frame `k` draws from its own random stream and Sobol scramble
//! ([`crate::tracer::sampling::Stream::Truth`], index `k * width * height + j * width + i`),
//! so a frame depends only on its index and the seed: any split of a sequence gives the same
//! frames, bit for bit, for any number of threads.

use super::frame::FrameCtx;
use super::{RenderSettings, View};
use crate::camera_path::FrameState;
use crate::geometry::bvh::Bvh;
use crate::scene::Scene;
use crate::tracer::binning::{response_cdf, TRUNCATE_SIGMAS};
use crate::tracer::ray_paths::{RayPaths, WindowOn};
use crate::tracer::sampling::{pixel_rng, PixelSampler, Stream};
use crate::tracer::TraceOptions;
use crate::units::flight_time_ps;
use nalgebra::Vector3;
use rayon::prelude::*;
use std::ops::Range;

/// How the truth is traced: paths per pixel, bounces, seed (the tracer's other settings are
/// its defaults: roulette from bounce 3, light vertices).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthOptions {
    pub spp: u32,
    pub max_bounces: u32,
    pub seed: u64,
}

/// Counters of a truth frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TruthStats {
    /// Camera paths traced (pixels x spp).
    pub paths: u64,
    /// Rays cast.
    pub rays: u64,
}

impl TruthStats {
    fn add(&mut self, o: &TruthStats) {
        self.paths += o.paths;
        self.rays += o.rays;
    }
}

/// What a run of truth frames wrote (`crate::pipeline::truth::stage_truth`).
#[derive(Clone, Debug, PartialEq)]
pub struct TruthSummary {
    /// The frames rendered (global indices of the path's sequence).
    pub frames: Range<usize>,
    pub width: usize,
    pub height: usize,
    /// Paths per pixel.
    pub spp: u32,
    /// Counters over all frames.
    pub stats: TruthStats,
    /// Wall-clock seconds of the truth frames alone (not the capture).
    pub seconds: f64,
    /// The exposure multiplier of the PNG frames (the automatic one times `--exposure`).
    pub exposure: f64,
}

/// A scene prepared for truth frames: its tracer kernel and the capture's time response.
pub struct TruthScene<'a> {
    scene: &'a Scene,
    paths: RayPaths<'a>,
    opts: TruthOptions,
    /// Flight time per metre in the scene's medium, ps.
    ps_per_m: f64,
    /// The capture's bin width and pulse standard deviation, ps.
    dt_ps: f64,
    sigma_ps: f64,
}

impl<'a> TruthScene<'a> {
    /// Prepare `scene` (`bvh` built from its mesh): the time response of its camera's bins
    /// and pulse.
    pub fn new(scene: &'a Scene, bvh: &'a Bvh, opts: TruthOptions) -> TruthScene<'a> {
        let trace = TraceOptions {
            spp: opts.spp,
            max_bounces: opts.max_bounces,
            seed: opts.seed,
            ..TraceOptions::default()
        };
        TruthScene {
            scene,
            paths: RayPaths::new(scene, bvh, &trace),
            opts,
            ps_per_m: flight_time_ps(scene.eta, 1.0),
            dt_ps: scene.camera.axis.dt_ps,
            sigma_ps: scene.laser.pulse_sigma_ps(),
        }
    }

    /// The laser wavelength, nm.
    pub fn laser_nm(&self) -> f64 {
        self.scene.laser.wavelength_nm
    }

    /// How far the response reaches either side of an arrival, ps.
    fn reach_ps(&self) -> f64 {
        0.5 * self.dt_ps + TRUNCATE_SIGMAS * self.sigma_ps
    }
}

/// Render the truth of frame `state` (transient view, `settings`' effects, radiometry and
/// colour output) into `out` (row-major from the top row), parallel over rows. Panics if
/// `out.len() != width * height` or the view is not [`View::Transient`] (caller bugs).
pub fn render_truth_frame(
    truth: &TruthScene,
    settings: &RenderSettings,
    state: &FrameState,
    out: &mut [[f32; 3]],
) -> TruthStats {
    let (w, h) = (settings.width, settings.height);
    assert_eq!(out.len(), w * h, "render_truth_frame: output buffer size");
    assert_eq!(
        settings.view,
        View::Transient,
        "render_truth_frame: only the transient view has a truth"
    );
    let ctx = FrameCtx::in_medium(settings, state, truth.scene.eta, truth.laser_nm());
    let frame_base = (state.index * w * h) as u64;
    out.par_chunks_mut(w)
        .enumerate()
        .map(|(j, row)| {
            let mut stats = TruthStats::default();
            for (i, px) in row.iter_mut().enumerate() {
                let index = frame_base + (j * w + i) as u64;
                let rgb = truth_pixel(truth, settings, &ctx, (i, j), index, &mut stats);
                *px = [rgb[0] as f32, rgb[1] as f32, rgb[2] as f32];
            }
            stats
        })
        .reduce(TruthStats::default, |mut a, b| {
            a.add(&b);
            a
        })
}

/// One pixel's truth (module doc, steps 1-5).
fn truth_pixel(
    truth: &TruthScene,
    settings: &RenderSettings,
    ctx: &FrameCtx,
    (i, j): (usize, usize),
    stream_index: u64,
    stats: &mut TruthStats,
) -> [f64; 3] {
    let spp = truth.opts.spp.max(1);
    let mut rng = pixel_rng(truth.opts.seed, Stream::Truth, stream_index);
    let ld = PixelSampler::new(truth.opts.seed, Stream::Truth, stream_index, spp);
    let e = settings.effects;
    let (dt, sigma, reach) = (truth.dt_ps, truth.sigma_ps, truth.reach_ps());
    let t0 = ctx.t_receive_ps;
    let on = if e.unwarp {
        WindowOn::Arrival
    } else {
        WindowOn::Emission
    };
    let mut rgb = [0.0f64; 3];
    for s in 0..spp {
        let (du, dv) = ld.sample(s, 0);
        let ray = ctx.ray_at(settings, i as f64 + du as f64, j as f64 + dv as f64);
        let d_light = if e.searchlight { ray.doppler } else { 1.0 };
        let t1 = t0 + settings.dtau_ps / d_light;
        let window_m = ((t0 - reach) / truth.ps_per_m, (t1 + reach) / truth.ps_per_m);
        let d = &ray.d_world;
        let dir = Vector3::new(d.x as f32, d.y as f32, d.z as f32);
        let mut energy = 0.0f64;
        stats.paths += 1;
        stats.rays += truth.paths.trace(
            &mut rng,
            &ld,
            s,
            ctx.origin_f32,
            dir,
            window_m,
            on,
            &mut |c| {
                let len_m = match on {
                    WindowOn::Arrival => c.path_m,
                    WindowOn::Emission => c.path_m - c.first_m,
                };
                let t_ps = len_m * truth.ps_per_m;
                let part = response_cdf(t1 - t_ps, dt, sigma) - response_cdf(t0 - t_ps, dt, sigma);
                energy += c.value * part;
            },
        );
        if energy == 0.0 {
            continue;
        }
        let value = settings.radiometry.window_factor(d_light) * energy * ctx.inv_dtau_per_ps;
        let colour = ctx.colour(settings, ray.doppler * truth.laser_nm());
        for (o, c) in rgb.iter_mut().zip(colour) {
            *o += value * c;
        }
    }
    rgb.map(|v| v / spp as f64)
}

//! Transient path tracer: Monte Carlo estimation of the time-resolved rendering equation
//! (seed Eq. 1; physics.md "Transient path tracing").
//!
//! Light model. The laser pulse hits a diffuser spot, a point emitter that sends a spherical
//! wave at cube time 0 with radiant intensity `I(w) = energy cos(theta) / pi` about the spot
//! normal (zero behind it) or `energy / (4 pi)` (isotropic). Surfaces are two-sided
//! Lambertian with the entry's albedo `rho` (BRDF `rho / pi`).
//!
//! Estimator. For each pixel, `spp` camera rays leave the camera centre through uniformly
//! distributed points of the pixel (a box filter: the pixel value is the mean radiance over its
//! footprint); the points, and the first two bounce directions, are stratified across the
//! pixel's paths by scrambled Sobol points ([`sampling::PixelSampler`]: each point is still
//! uniform, so the estimate is unbiased, with less variance than independent points). At every path vertex `x_k` (k = 1 .. max_bounces) the spot is connected by a
//! shadow ray (next-event estimation; the spot is a delta light, so this is the only way to
//! reach it), contributing
//!
//! `beta_k * rho(x_k) / pi * I(x_k - spot) * cos(theta_k) / r_k^2`,
//!
//! where `beta_k` is the path throughput (cosine-weighted bounces make it the product of the
//! albedos so far, divided by Russian-roulette survival probabilities) and `r_k` the distance
//! to the spot. The contribution arrives at the sensor at camera time
//! `t_camera = eta * (|x_1 - o| + |x_2 - x_1| + ... + |x_k - x_{k-1}| + r_k) / c`, the
//! optical length from the spot back to the camera centre `o`. It is spread over the time
//! bins with the sensor response of [`binning`] (the pulse's Gaussian and a one-bin sensor
//! box), which conserves energy, so that summing a pixel's bins gives the steady-state
//! radiance of the same pixel (see [`render_steady`]). Cube values are radiance integrated
//! over each bin (`energy` units per m^2 per sr).
//!
//! Light vertices ([`TraceOptions::light_vertex`], on by default). Light of two or more
//! bounces is also sampled from the light's side: once per path, an emission ray from the
//! spot (direction density `I(w) / energy`) lands on a point `y`, which every vertex `x_k`
//! of the path but the last joins by a shadow ray, contributing
//! `beta_k * rho_k / pi * G(x_k, y) * rho_y / pi * energy` (the spot's intensity over the
//! emission density) as light of `k + 1` bounces. A bounce that lands next to the spot gives
//! the camera's strategy a `1 / r^2` spike; `y` next to `x_k` gives the light's a `1 / d^2`
//! one. Both estimates of each path are weighted by the balance heuristic of their densities
//! per unit area at its last surface vertex (camera: `cos_k / pi * cos' / d^2`; light:
//! `I(w) / energy * cos' / r^2`), which sum to one, so the sum stays unbiased (Veach 1997,
//! ch. 9; the camera's density includes Russian roulette's survival probability). Both
//! arrive at the same time.
//!
//! Outputs: the total transient (camera time), optionally its split into one-bounce (`direct`)
//! and two-or-more-bounce (`multi`) light, and optionally the same samples binned at world
//! time `t_world = t_camera - eta |x_1 - o| / c` (physics.md, "two clocks"), `x_1` being the
//! first surface the pixel ray hits, on the axis of [`world_axis`].
//!
//! Determinism: each pixel draws from its own random stream ([`sampling::pixel_rng`]) and its
//! own scrambled points, and accumulates its samples in a fixed order in f64; rows are rendered in parallel but the
//! output is bit-identical for any number of rayon threads, and a cube assembled from bands
//! of rows ([`Tracer::render_rows`], for writing large cubes without holding them whole) is
//! bit-identical to the whole render.
//!
//! Speed: geometry and path vertices are single precision, ray casting uses the wide BVH of
//! [`crate::geometry::bvh`]; the sensor response is read from a table ([`binning::ResponseTable`]) rather than
//! evaluated per sample (a sample whose pulse fits between two bin centres adds its two tent
//! weights directly), and each pixel stores and clears only the bins it touched; where the CPU
//! has AVX2 and BMI the row loop runs a copy compiled for them, and another with GFNI where it
//! has that too (bit-identical: no fused multiply-adds; it follows the BVH's SIMD level, so
//! `FEMTO_SIMD=scalar` or `sse` forces the baseline rows, see
//! [`crate::geometry::simd_level`]); the rest of the time is ray casting (figures in `benches/tracer_results.md`). Light that lands
//! in no bin is not traced: a connection to the spot that would arrive before every window
//! is not made, and a path ends as soon as its length so far plus the straight line to the
//! spot puts everything it could still deliver after every window (the camera window, and
//! the world window shifted by the path's first segment); this removes only terms that
//! would fall outside the cubes.

pub mod binning;
mod path;
pub mod ray_paths;
pub mod sampling;

use crate::cpu_time::process_cpu_seconds;
use crate::cube::{Cube, TimeAxis, TimeFrame};
use crate::geometry::bvh::Bvh;
#[cfg(target_arch = "x86_64")]
use crate::geometry::simd_level::SimdLevel;
use crate::geometry::Ray;
use crate::scene::{Emission, Scene};
use crate::units::flight_time_ps;
use binning::{ResponseTable, TimeResponse};
use path::{kernel, Contribution, PathKernel, PathWindow};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use sampling::{pixel_rng, PixelSampler, Stream};
use std::ops::Range;
use std::time::Instant;

/// Settings of a transient render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceOptions {
    /// Camera paths per pixel.
    pub spp: u32,
    /// Most surface interactions per path (1 = direct light only).
    pub max_bounces: u32,
    /// Seed of the per-pixel random streams.
    pub seed: u64,
    /// Emission profile of the spot; `None` keeps the scene's.
    pub emission: Option<Emission>,
    /// First bounce at which Russian roulette may end a path (survival probability
    /// `min(throughput, 0.95)`).
    pub rr_start_bounce: u32,
    /// Also produce the one-bounce and multi-bounce cubes.
    pub split_bounces: bool,
    /// Also produce the world-time cube.
    pub world_time: bool,
    /// Also estimate light of two or more bounces from the light's side: each path's
    /// vertices (all but the last) are joined to a point lit by the spot (where one emission
    /// ray from the spot lands), weighted against the path's own connections by multiple
    /// importance sampling (balance heuristic). Unbiased either way; it removes the spikes of
    /// bounces that land next to the spot, for one emission ray and a shadow ray per vertex.
    pub light_vertex: bool,
    /// How a sample's arrival time is binned.
    pub time_filter: TimeFilter,
}

/// How the tracer bins a sample's arrival time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TimeFilter {
    /// The capture's response (physics.md, "Transient path tracing"): the laser's Gaussian
    /// pulse and the streak sensor's one-bin box, a tent for a short pulse
    /// ([`binning::TimeResponse`]). femto's cubes.
    #[default]
    Sensor,
    /// A histogram of arrival times: each sample in the one bin it falls in, no pulse. The
    /// quantity renderers with box time bins estimate (mitransient), for comparisons.
    Box,
}

impl Default for TraceOptions {
    fn default() -> Self {
        TraceOptions {
            spp: 64,
            max_bounces: 4,
            seed: 0,
            emission: None,
            rr_start_bounce: 3,
            split_bounces: true,
            world_time: true,
            light_vertex: true,
            time_filter: TimeFilter::Sensor,
        }
    }
}

/// Counters of a render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraceStats {
    /// Camera paths traced (pixels x spp).
    pub paths: u64,
    /// Rays cast: camera and bounce rays plus shadow rays.
    pub rays: u64,
    /// Contributions that reached the sensor (unoccluded connections to the spot).
    pub samples: u64,
    /// Contributions whose camera arrival time lies outside the cube's time window: those
    /// binned with part of their weight outside, and connections to the spot not made
    /// because they would arrive before every window.
    pub samples_outside_window: u64,
    /// Paths ended because anything they could still deliver would arrive after every
    /// window (their length so far plus the straight line to the spot is already too long).
    pub paths_ended_late: u64,
    /// Energy that fell outside the camera-time window, summed over pixels in cube units
    /// (what the cube's sum misses compared with a steady-state render).
    pub energy_outside_window: f64,
    /// Wall-clock time of the render, seconds.
    pub seconds: f64,
    /// CPU time of this process during the render (all threads, user + system), seconds.
    pub cpu_seconds: f64,
}

impl TraceStats {
    /// Camera paths per second of wall-clock time.
    pub fn paths_per_second(&self) -> f64 {
        self.paths as f64 / self.seconds.max(1e-12)
    }

    /// Add the counters of `o` (not its times).
    pub fn add(&mut self, o: &TraceStats) {
        self.paths += o.paths;
        self.rays += o.rays;
        self.samples += o.samples;
        self.samples_outside_window += o.samples_outside_window;
        self.paths_ended_late += o.paths_ended_late;
        self.energy_outside_window += o.energy_outside_window;
    }
}

/// The cubes of a transient render.
#[derive(Clone, Debug)]
pub struct TransientRender {
    /// All light, camera time, on the scene's camera axis.
    pub camera_time: Cube,
    /// One-bounce light, camera time (when [`TraceOptions::split_bounces`]).
    pub direct: Option<Cube>,
    /// Light of two or more bounces, camera time (when [`TraceOptions::split_bounces`]).
    pub multi: Option<Cube>,
    /// All light at world time on [`world_axis`] (when [`TraceOptions::world_time`]).
    pub world_time: Option<Cube>,
    pub stats: TraceStats,
}

/// The world-time axis of a render: the same bin width as the camera axis, covering the
/// world times `t_camera - eta d / c` of the camera window for every distance `d` from the
/// camera to the first surface seen through the pixel corners and centres.
pub fn world_axis(scene: &Scene, bvh: &Bvh) -> TimeAxis {
    let cam = &scene.camera;
    let k = &cam.intrinsics;
    let (mut d_min, mut d_max) = (f64::INFINITY, 0.0f64);
    let mut probe = |u: f64, v: f64| {
        let dir = cam.pose.world_from_camera * k.camera_ray(u, v).into_inner();
        let ray = Ray::new(cam.pose.position_m.cast::<f32>(), dir.cast::<f32>());
        if let Some(h) = bvh.intersect(&ray, 0.0, f32::INFINITY) {
            d_min = d_min.min(h.t as f64);
            d_max = d_max.max(h.t as f64);
        }
    };
    for j in 0..=k.height {
        for i in 0..=k.width {
            probe(i as f64, j as f64);
            if i < k.width && j < k.height {
                probe(i as f64 + 0.5, j as f64 + 0.5);
            }
        }
    }
    let axis = cam.axis;
    if d_min > d_max {
        return axis;
    }
    let start = axis.t0_ps - flight_time_ps(scene.eta, d_max);
    let end = axis.end_ps() - flight_time_ps(scene.eta, d_min);
    TimeAxis {
        t0_ps: start,
        dt_ps: axis.dt_ps,
        nt: ((end - start) / axis.dt_ps).ceil().max(1.0) as usize,
    }
}

/// Per-row output slices of the transient render.
struct RowOut<'a> {
    camera: &'a mut [f32],
    direct: Option<&'a mut [f32]>,
    multi: Option<&'a mut [f32]>,
    world: Option<&'a mut [f32]>,
}

/// Pixel `(x, y)`'s random stream and low-discrepancy sampler in `stream`, for an image `nx`
/// pixels wide rendered with `spp` paths per pixel.
fn pixel_streams(
    seed: u64,
    stream: Stream,
    nx: usize,
    (x, y): (usize, usize),
    spp: u32,
) -> (Pcg64Mcg, PixelSampler) {
    let pixel = (y * nx + x) as u64;
    (
        pixel_rng(seed, stream, pixel),
        PixelSampler::new(seed, stream, pixel, spp),
    )
}

fn row_slices(cube: &mut Option<Cube>, ny: usize) -> Vec<Option<&mut [f32]>> {
    match cube {
        Some(c) => {
            let n = c.nx * c.axis.nt;
            c.data.chunks_mut(n.max(1)).map(Some).collect()
        }
        None => (0..ny).map(|_| None).collect(),
    }
}

/// Paths of a pixel between two polls of a render's progress ([`Tracer::render_rows`]):
/// about a millisecond of paths in a release build.
pub const POLL_PATHS: u32 = 1024;

/// Render the transient cubes of `scene`. `bvh` must be built from `scene.mesh`.
/// `progress` is called with 1 after each finished image row.
pub fn trace(
    scene: &Scene,
    bvh: &Bvh,
    opts: &TraceOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> TransientRender {
    let started = Instant::now();
    let cpu_started = process_cpu_seconds();
    let tracer = Tracer::new(scene, bvh, opts);
    let mut r = tracer.render_rows(0..scene.camera.intrinsics.height, progress);
    r.stats.seconds = started.elapsed().as_secs_f64();
    r.stats.cpu_seconds = process_cpu_seconds() - cpu_started;
    r
}

/// A transient render prepared once (kernel, time responses, world-time axis) that renders
/// any band of image rows, so that a caller can write a large cube band by band without
/// holding it whole. Each pixel's samples depend only on its own random stream, so a cube
/// assembled from bands is bit-identical to [`trace`]'s.
pub struct Tracer<'a> {
    kernel: PathKernel<'a>,
    opts: TraceOptions,
    cam_resp: ResponseTable,
    /// `None` unless [`TraceOptions::world_time`].
    world_resp: Option<ResponseTable>,
    /// Which build of the row loop runs: the widest the CPU has, where the BVH's SIMD level
    /// ([`Bvh::simd`]: `FEMTO_SIMD` or [`Bvh::with_simd`]) allows it (`avx2` and wider, or
    /// `auto`).
    #[cfg(target_arch = "x86_64")]
    row_isa: RowIsa,
}

/// The builds of the row loop (bit-identical: the same operations in the same order, no
/// fused multiply-adds).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RowIsa {
    /// Baseline x86-64 (SSE2).
    Baseline,
    /// AVX2, BMI1/2, LZCNT, POPCNT: [`Tracer::render_row_v3`].
    V3,
    /// Those and GFNI, whose affine byte transform makes the samplers' bit reversals single
    /// instructions: [`Tracer::render_row_v3_gfni`].
    V3Gfni,
}

#[cfg(target_arch = "x86_64")]
impl RowIsa {
    /// The widest build this CPU runs, if `allowed`.
    fn detect(allowed: bool) -> RowIsa {
        let v3 = allowed
            && is_x86_feature_detected!("avx")
            && is_x86_feature_detected!("avx2")
            && is_x86_feature_detected!("bmi1")
            && is_x86_feature_detected!("bmi2")
            && is_x86_feature_detected!("lzcnt")
            && is_x86_feature_detected!("popcnt");
        match (v3, is_x86_feature_detected!("gfni")) {
            (false, _) => RowIsa::Baseline,
            (true, false) => RowIsa::V3,
            (true, true) => RowIsa::V3Gfni,
        }
    }
}

impl<'a> Tracer<'a> {
    /// Prepare a render of `scene`; `bvh` must be built from `scene.mesh`. With
    /// [`TraceOptions::world_time`] this probes the whole image for [`world_axis`].
    pub fn new(scene: &'a Scene, bvh: &'a Bvh, opts: &TraceOptions) -> Tracer<'a> {
        let sigma_ps = scene.laser.pulse_sigma_ps();
        let table = |axis| match opts.time_filter {
            TimeFilter::Sensor => ResponseTable::new(&TimeResponse::new(axis, sigma_ps)),
            TimeFilter::Box => ResponseTable::histogram(axis),
        };
        Tracer {
            kernel: kernel(scene, bvh, opts),
            opts: *opts,
            cam_resp: table(scene.camera.axis),
            world_resp: opts.world_time.then(|| table(world_axis(scene, bvh))),
            #[cfg(target_arch = "x86_64")]
            row_isa: RowIsa::detect(bvh.simd().is_none_or(|l| l >= SimdLevel::Avx2)),
        }
    }

    /// The world-time axis of the render (when [`TraceOptions::world_time`]).
    pub fn world_axis(&self) -> Option<TimeAxis> {
        self.world_resp.as_ref().map(|r| *r.axis())
    }

    /// Render image rows `rows` (clamped to the image): cubes of `rows.len()` rows holding
    /// rows `rows.start ..` of the full image. `progress` is called with 1 after each row,
    /// and with 0 after each pixel and every [`POLL_PATHS`] paths of a pixel: points at which
    /// a caller may unwind the render to stop it (the Python package on Ctrl-C), a few
    /// milliseconds of paths rather than a row's after the request.
    pub fn render_rows(
        &self,
        rows: Range<usize>,
        progress: &(dyn Fn(usize) + Sync),
    ) -> TransientRender {
        let started = Instant::now();
        let cpu_started = process_cpu_seconds();
        let scene = self.kernel.scene;
        let opts = &self.opts;
        let (nx, ny_image) = (
            scene.camera.intrinsics.width,
            scene.camera.intrinsics.height,
        );
        let rows = rows.start.min(ny_image)..rows.end.min(ny_image);
        let y0 = rows.start;
        let ny = rows.len();
        let cam_axis = scene.camera.axis;
        let cam_resp = &self.cam_resp;
        let mut camera = Cube::zeros(nx, ny, cam_axis, TimeFrame::Camera);
        let mut direct = opts
            .split_bounces
            .then(|| Cube::zeros(nx, ny, cam_axis, TimeFrame::Camera));
        let mut multi = opts
            .split_bounces
            .then(|| Cube::zeros(nx, ny, cam_axis, TimeFrame::Camera));
        let mut world = self
            .world_resp
            .as_ref()
            .map(|r| Cube::zeros(nx, ny, *r.axis(), TimeFrame::World));

        let row_outs: Vec<RowOut> = camera
            .data
            .chunks_mut((nx * cam_axis.nt).max(1))
            .zip(row_slices(&mut direct, ny))
            .zip(row_slices(&mut multi, ny))
            .zip(row_slices(&mut world, ny))
            .map(|(((camera, direct), multi), world)| RowOut {
                camera,
                direct,
                multi,
                world,
            })
            .collect();

        let ps_per_m = flight_time_ps(scene.eta, 1.0);
        let window = PathWindow::new(cam_resp, self.world_resp.as_ref(), ps_per_m);
        let row_stats: Vec<TraceStats> = row_outs
            .into_par_iter()
            .enumerate()
            .map(|(dy, out)| {
                let stats = self.render_row_dispatch(y0 + dy, out, &window, ps_per_m, progress);
                progress(1);
                stats
            })
            .collect();

        let mut stats = TraceStats::default();
        for s in &row_stats {
            stats.add(s);
        }
        stats.seconds = started.elapsed().as_secs_f64();
        stats.cpu_seconds = process_cpu_seconds() - cpu_started;
        TransientRender {
            camera_time: camera,
            direct,
            multi,
            world_time: world,
            stats,
        }
    }

    /// Render image row `y` into `out`: [`Tracer::render_row`] compiled for the x86-64-v3
    /// instruction set (AVX2, BMI), with GFNI for the samplers' bit reversals where the CPU
    /// has it ([`RowIsa`]). No fused multiply-adds are enabled and Rust never contracts
    /// arithmetic, so every version computes the same operations in the same order:
    /// bit-identical output.
    fn render_row_dispatch(
        &self,
        y: usize,
        out: RowOut,
        window: &PathWindow,
        ps_per_m: f64,
        poll: &(dyn Fn(usize) + Sync),
    ) -> TraceStats {
        #[cfg(target_arch = "x86_64")]
        match self.row_isa {
            // SAFETY: `RowIsa::detect` found every feature each build enables on this CPU.
            RowIsa::V3 => return unsafe { self.render_row_v3(y, out, window, ps_per_m, poll) },
            RowIsa::V3Gfni => {
                return unsafe { self.render_row_v3_gfni(y, out, window, ps_per_m, poll) }
            }
            RowIsa::Baseline => {}
        }
        self.render_row::<0>(y, out, window, ps_per_m, poll)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2,bmi1,bmi2,lzcnt,popcnt")]
    fn render_row_v3(
        &self,
        y: usize,
        out: RowOut,
        window: &PathWindow,
        ps_per_m: f64,
        poll: &(dyn Fn(usize) + Sync),
    ) -> TraceStats {
        self.render_row::<1>(y, out, window, ps_per_m, poll)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2,bmi1,bmi2,lzcnt,popcnt,gfni")]
    fn render_row_v3_gfni(
        &self,
        y: usize,
        out: RowOut,
        window: &PathWindow,
        ps_per_m: f64,
        poll: &(dyn Fn(usize) + Sync),
    ) -> TraceStats {
        self.render_row::<2>(y, out, window, ps_per_m, poll)
    }

    /// Render image row `y` (of the full image) into its output slices, calling `poll(0)`
    /// after each pixel ([`Tracer::render_rows`]). `_BUILD` only tells the compiled versions
    /// apart, so that each has its own copy of the per-sample closure (one caller each, which
    /// the compiler then inlines).
    #[inline(always)]
    fn render_row<const _BUILD: u8>(
        &self,
        y: usize,
        mut out: RowOut,
        window: &PathWindow,
        ps_per_m: f64,
        poll: &(dyn Fn(usize) + Sync),
    ) -> TraceStats {
        let scene = self.kernel.scene;
        let opts = &self.opts;
        let k = &self.kernel;
        let nx = scene.camera.intrinsics.width;
        let cam_axis = scene.camera.axis;
        let cam_resp = &self.cam_resp;
        let ntw = self.world_resp.as_ref().map_or(0, |r| r.axis().nt);
        let spp = opts.spp.max(1);
        let inv_spp = 1.0 / spp as f64;
        let mut stats = TraceStats::default();
        let nt = cam_axis.nt;
        let mut acc = vec![0.0f64; nt];
        let mut acc_direct = vec![0.0f64; nt];
        let mut acc_multi = vec![0.0f64; nt];
        let mut acc_world = vec![0.0f64; ntw];
        let mut weights = vec![0.0f64; cam_resp.len()];
        let mut weights_world = vec![0.0f64; self.world_resp.as_ref().map_or(0, |r| r.len())];
        // The accumulators are all zero between pixels; only the bins a pixel touched
        // (`touched`, `touched_world`) are stored and cleared again.
        let mut touched = (nt, 0usize);
        let mut touched_world = (ntw, 0usize);
        let grow = |t: &mut (usize, usize), first: isize, len: usize, n: usize| {
            let lo = first.clamp(0, n as isize) as usize;
            let hi = (first + len as isize).clamp(0, n as isize) as usize;
            if lo < hi {
                *t = (t.0.min(lo), t.1.max(hi));
            }
        };
        for x in 0..nx {
            let (mut rng, ld) = pixel_streams(opts.seed, Stream::Transient, nx, (x, y), spp);
            let mut lost = 0.0;
            for i in 0..spp {
                let uv = ld.image_position(i, x, y);
                stats.paths += 1;
                let tally = k.trace_path(&mut rng, &ld, i, uv, window, &mut |c: Contribution| {
                    let value = c.value * inv_spp;
                    let t_camera_ps = c.path_m * ps_per_m;
                    stats.samples += 1;
                    let b = cam_resp.bin_coord(t_camera_ps);
                    if !(b >= 0.0 && b < nt as f64) {
                        stats.samples_outside_window += 1;
                    }
                    let Some(at) = cam_resp.place(b) else {
                        lost += value;
                        return;
                    };
                    lost += cam_resp.add(&at, &mut acc, value, &mut weights);
                    let (first, len) = cam_resp.span(&at);
                    grow(&mut touched, first, len, nt);
                    if out.direct.is_some() {
                        let split = if c.bounce == 1 {
                            &mut acc_direct
                        } else {
                            &mut acc_multi
                        };
                        cam_resp.add(&at, split, value, &mut weights);
                    }
                    if let Some(world_resp) = &self.world_resp {
                        let t_world_ps = t_camera_ps - c.first_m * ps_per_m;
                        if let Some(at) = world_resp.place(world_resp.bin_coord(t_world_ps)) {
                            world_resp.add(&at, &mut acc_world, value, &mut weights_world);
                            let (first, len) = world_resp.span(&at);
                            grow(&mut touched_world, first, len, ntw);
                        }
                    }
                });
                stats.rays += tally.rays;
                stats.samples_outside_window += tally.skipped_early;
                stats.paths_ended_late += tally.ended_late as u64;
                if i % POLL_PATHS == POLL_PATHS - 1 {
                    poll(0);
                }
            }
            stats.energy_outside_window += lost;
            let store = |dst: &mut [f32], src: &mut [f64], (lo, hi): (usize, usize)| {
                if lo < hi {
                    for (d, s) in dst[lo..hi].iter_mut().zip(&mut src[lo..hi]) {
                        *d = *s as f32;
                        *s = 0.0;
                    }
                }
            };
            store(&mut out.camera[x * nt..(x + 1) * nt], &mut acc, touched);
            if let Some(d) = out.direct.as_deref_mut() {
                store(&mut d[x * nt..(x + 1) * nt], &mut acc_direct, touched);
            }
            if let Some(m) = out.multi.as_deref_mut() {
                store(&mut m[x * nt..(x + 1) * nt], &mut acc_multi, touched);
            }
            if let Some(w) = out.world.as_deref_mut() {
                store(
                    &mut w[x * ntw..(x + 1) * ntw],
                    &mut acc_world,
                    touched_world,
                );
            }
            touched = (nt, 0);
            touched_world = (ntw, 0);
            poll(0);
        }
        stats
    }
}

/// Steady-state render of `scene` with the same estimator, no time: the radiance of each
/// pixel (`[y][x]`), from random streams independent of [`trace`]'s. For a time window that
/// holds all the light, it equals the time integral of the transient cube within noise.
pub fn render_steady(
    scene: &Scene,
    bvh: &Bvh,
    opts: &TraceOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Vec<f64> {
    let k = kernel(scene, bvh, opts);
    let (nx, ny) = (
        scene.camera.intrinsics.width,
        scene.camera.intrinsics.height,
    );
    let spp = opts.spp.max(1);
    let mut image = vec![0.0f64; nx * ny];
    image
        .par_chunks_mut(nx.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, px) in row.iter_mut().enumerate() {
                let (mut rng, ld) = pixel_streams(opts.seed, Stream::Steady, nx, (x, y), spp);
                let mut sum = 0.0;
                for i in 0..spp {
                    k.trace_path(
                        &mut rng,
                        &ld,
                        i,
                        ld.image_position(i, x, y),
                        &PathWindow::UNBOUNDED,
                        &mut |c: Contribution| sum += c.value,
                    );
                }
                *px = sum / spp as f64;
            }
            progress(1);
        });
    image
}

#[cfg(test)]
mod tests;

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
//! has AVX2, BMI and GFNI the row loop runs a copy compiled for them (bit-identical: no fused
//! multiply-adds); the
//! rest of the time is ray casting (figures in `benches/tracer_results.md`). Light that lands
//! in no bin is not traced: a connection to the spot that would arrive before every window
//! is not made, and a path ends as soon as its length so far plus the straight line to the
//! spot puts everything it could still deliver after every window (the camera window, and
//! the world window shifted by the path's first segment); this removes only terms that
//! would fall outside the cubes.

pub mod binning;
pub mod sampling;

use crate::cube::{Cube, TimeAxis, TimeFrame};
use crate::geometry::bvh::Bvh;
use crate::geometry::Ray;
use crate::scene::{Emission, Scene};
use crate::units::flight_time_ps;
use binning::{ResponseTable, TimeResponse};
use nalgebra::{Matrix3, Point3, Vector3};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use sampling::{
    cosine_hemisphere_in, cosine_local, orthonormal_basis, pixel_rng, uniform, uniform_pair,
    uniform_sphere, PixelSampler, Stream,
};
use std::ops::Range;
use std::time::Instant;

/// Offset of secondary ray origins along the surface normal, metres (0.1 mm).
const RAY_OFFSET_M: f32 = 1e-4;
/// Shadow rays stop this short of the laser spot, metres (a spot on a surface must not be
/// shadowed by that surface).
const SHADOW_END_M: f32 = 1e-4;
/// Bounces whose directions come from the pixel's low-discrepancy points (2D dimensions 1 and
/// 2; dimension 0 is the position in the pixel).
const LD_BOUNCES: u32 = 2;
/// The pixel's low-discrepancy dimension of the light vertex's emission direction
/// ([`TraceOptions::light_vertex`]).
const LIGHT_DIM: u32 = 3;
/// `1 / pi` in single precision.
const FRAC_1_PI: f32 = std::f32::consts::FRAC_1_PI;

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
}

impl TraceStats {
    /// Camera paths per second of wall-clock time.
    pub fn paths_per_second(&self) -> f64 {
        self.paths as f64 / self.seconds.max(1e-12)
    }

    /// Add the counters of `o` (not its time).
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

/// One contribution of a path: a connection to the laser spot from vertex `bounce`.
#[derive(Clone, Copy, Debug)]
struct Contribution {
    /// Index of the vertex that connected to the spot (1 = the first surface seen).
    bounce: u32,
    /// Optical path length from the spot to the camera centre, metres (times eta later).
    path_m: f64,
    /// Distance from the camera centre to the first surface of the path, metres.
    first_m: f64,
    /// Radiance along the camera ray carried by this path.
    value: f64,
}

/// The per-path kernel shared by the transient and steady renders. Path vertices and
/// directions are single precision, like the geometry (positions to ~1e-7 relative: 0.1 um
/// in a metre-sized scene, 3e-4 ps of flight); path lengths and contributions are summed in
/// double precision.
struct PathKernel<'a> {
    scene: &'a Scene,
    bvh: &'a Bvh,
    /// Camera centre.
    camera_m: Point3<f32>,
    /// Without lens distortion, the world direction of the ray through pixel coordinates
    /// `(u, v)` is `world_from_pixel * (u, v, 1)` normalised (`R K^-1`); `None` with
    /// distortion, which `Intrinsics::camera_ray` removes by iteration.
    world_from_pixel: Option<Matrix3<f32>>,
    /// Laser spot and its unit normal.
    laser_m: Point3<f32>,
    laser_normal: Vector3<f32>,
    /// Radiant intensity towards `w` (unit, away from the spot): `intensity_scale`, times
    /// `max(0, laser_normal . w)` for cosine emission (scene.rs `Laser::intensity`).
    intensity_scale: f32,
    cosine_emission: bool,
    /// Albedo and normal's basis of each triangle of the mesh (one load per hit).
    shading: Vec<TriangleShading>,
    max_bounces: u32,
    rr_start_bounce: u32,
    /// [`TraceOptions::light_vertex`].
    light_vertex: bool,
    /// The spot's energy (its radiant intensity over the emission's direction density, for
    /// both profiles).
    energy: f32,
    /// [`orthonormal_basis`] of `laser_normal`.
    laser_tangent: Vector3<f32>,
    laser_bitangent: Vector3<f32>,
}

impl PathKernel<'_> {
    /// Trace path `index` of a pixel through continuous pixel coordinates `(u, v)`; calls
    /// `sink` for each contribution that can land in `window`; returns the rays cast and what
    /// the window let it skip.
    #[inline(always)]
    fn trace_path(
        &self,
        rng: &mut Pcg64Mcg,
        ld: &PixelSampler,
        index: u32,
        (u, v): (f64, f64),
        window: &PathWindow,
        sink: &mut impl FnMut(Contribution),
    ) -> PathTally {
        let mut dir: Vector3<f32> = match &self.world_from_pixel {
            Some(m) => (m * Vector3::new(u as f32, v as f32, 1.0)).normalize(),
            None => {
                let cam = &self.scene.camera;
                (cam.pose.world_from_camera * cam.intrinsics.camera_ray(u, v).into_inner())
                    .cast::<f32>()
            }
        };
        let mut origin = self.camera_m;
        let mut path_m = 0.0f64;
        let mut first_m = 0.0f64;
        let mut beta = 1.0f32;
        let mut tally = PathTally::default();
        let (mut early_m, mut late_m) = (f64::NEG_INFINITY, f64::INFINITY);
        // With light vertices: the path's light point, and the solid-angle density of the
        // last bounce's direction, for the connection's weight against the light's strategy.
        let mut light = None;
        let mut bounce_pdf = 0.0f32;
        for bounce in 1..=self.max_bounces {
            tally.rays += 1;
            let ray = Ray::new(origin, dir);
            let Some(hit) = self.bvh.intersect(&ray, 0.0, f32::INFINITY) else {
                break;
            };
            let p = origin + dir * hit.t;
            path_m += hit.t as f64;
            if bounce == 1 {
                first_m = hit.t as f64;
                (early_m, late_m) = window.bounds_m(first_m);
            }
            // Two-sided surfaces: shade the side the ray arrives from.
            let shading = &self.shading[hit.triangle as usize];
            let mut n = hit.normal;
            let back = n.dot(&dir) > 0.0;
            if back {
                n = -n;
            }
            let rho = shading.albedo;
            if rho <= 0.0 {
                break;
            }
            // The continuation of a low-discrepancy bounce depends on nothing of this vertex
            // but its frame: drawn now, its latency overlaps the connection to the spot.
            let ld_local = (bounce <= LD_BOUNCES && bounce < self.max_bounces).then(|| {
                let (u1, u2) = ld.sample(index, bounce);
                cosine_local(u1, u2)
            });
            let p_off = p + n * RAY_OFFSET_M;
            // Next-event estimation towards the spot.
            let to_spot = self.laser_m - p_off;
            let r2 = to_spot.norm_squared();
            let r = r2.sqrt();
            // This connection arrives after `path_m + r`, and so does every later one (the
            // rest of a longer path to the spot is at least the straight line): past the
            // window, the path has nothing left to give.
            let arrival_m = path_m + r as f64;
            if arrival_m > late_m {
                tally.ended_late = true;
                break;
            }
            if arrival_m < early_m {
                tally.skipped_early += 1;
            } else if r2 > SHADOW_END_M * SHADOW_END_M {
                let inv_r = 1.0 / r;
                let w = to_spot * inv_r;
                let cos_p = n.dot(&w);
                let intensity = if self.cosine_emission {
                    self.intensity_scale * (-self.laser_normal.dot(&w)).max(0.0)
                } else {
                    self.intensity_scale
                };
                if cos_p > 0.0 && intensity > 0.0 {
                    tally.rays += 1;
                    let shadow = Ray::new(p_off, w);
                    if !self.bvh.occluded(&shadow, 0.0, r - SHADOW_END_M) {
                        let mut value = beta * rho * FRAC_1_PI * intensity * cos_p * inv_r * inv_r;
                        if bounce >= 2 && self.light_vertex {
                            let pdf_camera = bounce_pdf * -n.dot(&dir) / (hit.t * hit.t);
                            let pdf_light = self.emission_area_pdf(&p, &n);
                            // A direction tangent to the surface (cosine 0) that the light
                            // cannot reach either keeps its whole weight.
                            if pdf_camera + pdf_light > 0.0 {
                                value *= pdf_camera / (pdf_camera + pdf_light);
                            }
                        }
                        sink(Contribution {
                            bounce,
                            path_m: arrival_m,
                            first_m,
                            value: value as f64,
                        });
                    }
                }
            }
            if bounce == self.max_bounces {
                break;
            }
            if self.light_vertex {
                if bounce == 1 {
                    light = self.light_point(ld, index, &mut tally);
                }
                if let Some(y) = &light {
                    self.connect_light_point(
                        y,
                        (p, p_off, n, rho),
                        (bounce, beta, path_m, first_m),
                        (early_m, late_m),
                        &mut tally,
                        sink,
                    );
                }
            }
            // Cosine-weighted continuation: BRDF * cos / pdf = rho.
            beta *= rho;
            let mut survive = 1.0;
            if bounce >= self.rr_start_bounce {
                survive = beta.min(0.95);
                if uniform(rng) >= survive {
                    break;
                }
                beta /= survive;
            }
            // The first two bounces from the pixel's low-discrepancy points, later ones from
            // its random stream (drawn after Russian roulette's, in this order).
            let l = ld_local.unwrap_or_else(|| {
                let (u1, u2) = uniform_pair(rng);
                cosine_local(u1, u2)
            });
            bounce_pdf = survive * l.z * FRAC_1_PI;
            // The basis of the flipped normal is (t, -b) (sampling::cosine_hemisphere_in).
            let b = if back {
                -shading.bitangent
            } else {
                shading.bitangent
            };
            dir = shading.tangent * l.x + b * l.y + n * l.z;
            origin = p_off;
        }
        tally
    }

    /// Density, per unit area at the surface point `p` (unit normal `n`, either side), of
    /// the spot's emission ray landing there: the emission's direction density times the
    /// cosine at `p` over the squared distance. The direction density is the radiant
    /// intensity over the energy for both emission profiles (`cos / pi`, `1 / (4 pi)`).
    #[inline(always)]
    fn emission_area_pdf(&self, p: &Point3<f32>, n: &Vector3<f32>) -> f32 {
        let to_spot = self.laser_m - p;
        let inv_r = 1.0 / to_spot.norm_squared().sqrt();
        let w = to_spot * inv_r;
        let per_sr = if self.cosine_emission {
            (-self.laser_normal.dot(&w)).max(0.0) * FRAC_1_PI
        } else {
            0.25 * FRAC_1_PI
        };
        per_sr * n.dot(&w).abs() * inv_r * inv_r
    }

    /// The light point of path `index` ([`TraceOptions::light_vertex`]): where an emission
    /// ray from the spot lands (its direction from the pixel's low-discrepancy dimension
    /// [`LIGHT_DIM`]), on a surface that reflects; `None` if it lands nowhere.
    #[inline(always)]
    fn light_point(
        &self,
        ld: &PixelSampler,
        index: u32,
        tally: &mut PathTally,
    ) -> Option<LightPoint> {
        let (u1, u2) = ld.sample(index, LIGHT_DIM);
        let dir = if self.cosine_emission {
            cosine_hemisphere_in(
                &self.laser_tangent,
                &self.laser_bitangent,
                &self.laser_normal,
                u1,
                u2,
            )
        } else {
            uniform_sphere(u1, u2)
        };
        tally.rays += 1;
        let hit = self
            .bvh
            .intersect(&Ray::new(self.laser_m, dir), SHADOW_END_M, f32::INFINITY)?;
        let albedo = self.shading[hit.triangle as usize].albedo;
        if albedo <= 0.0 {
            return None;
        }
        let p = self.laser_m + dir * hit.t;
        // The lit side faces the spot.
        let normal = if hit.normal.dot(&dir) > 0.0 {
            -hit.normal
        } else {
            hit.normal
        };
        Some(LightPoint {
            p,
            p_off: p + normal * RAY_OFFSET_M,
            normal,
            albedo,
            spot_m: hit.t,
            pdf_area: self.emission_area_pdf(&p, &normal),
        })
    }

    /// The light's strategy for the light of `bounce + 1` bounces: vertex `bounce` of a path
    /// (point `x_m`, moved off the surface `x_off`, unit normal `n_x` of the side seen,
    /// albedo `rho_x`, throughput `beta`, path length `path_m` so far) joined to the light
    /// point `y` by a shadow ray. Its contribution, and the camera's own (a bounce from `x`
    /// that lands on `y`, connected to the spot), are weighted by the balance heuristic of
    /// their densities per unit area at `y`, so that together they count that light once,
    /// without the camera strategy's spikes where a bounce lands next to the spot (its
    /// `1 / r^2`) nor the light strategy's where `y` is next to `x` (`1 / d^2`).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn connect_light_point(
        &self,
        y: &LightPoint,
        (x_m, x_off, n_x, rho_x): (Point3<f32>, Point3<f32>, Vector3<f32>, f32),
        (bounce, beta, path_m, first_m): (u32, f32, f64, f64),
        (early_m, late_m): (f64, f64),
        tally: &mut PathTally,
        sink: &mut impl FnMut(Contribution),
    ) {
        let to_y = y.p - x_m;
        let d2 = to_y.norm_squared();
        let inv_d = 1.0 / d2.sqrt();
        let w = to_y * inv_d;
        let (cos_x, cos_y) = (n_x.dot(&w), -y.normal.dot(&w));
        // A surface does not light its own plane (grazing connections carry nothing); `y`
        // at `x` itself (a NaN direction) is not joined either.
        if !(cos_x > 1e-5 && cos_y > 1e-5) {
            return;
        }
        let arrival_m = path_m + (d2 * inv_d) as f64 + y.spot_m as f64;
        if arrival_m < early_m || arrival_m > late_m {
            tally.skipped_early += (arrival_m < early_m) as u64;
            return;
        }
        let span = y.p_off - x_off;
        let span_m = span.norm();
        tally.rays += 1;
        if self
            .bvh
            .occluded(&Ray::new(x_off, span / span_m), 0.0, span_m - SHADOW_END_M)
        {
            return;
        }
        let g = cos_x * cos_y * inv_d * inv_d;
        // The camera's density of the same path: its bounce from `x`, times the chance that
        // Russian roulette lets it bounce (the same expression as in `trace_path`).
        let survive = if bounce >= self.rr_start_bounce {
            (beta * rho_x).min(0.95)
        } else {
            1.0
        };
        let pdf_camera = survive * FRAC_1_PI * g;
        // beta rho_x / pi G(x, y) rho_y / pi times the spot's intensity over the emission
        // density (its energy, for both profiles), and the strategy's weight.
        let value = beta
            * rho_x
            * FRAC_1_PI
            * g
            * y.albedo
            * FRAC_1_PI
            * self.energy
            * (y.pdf_area / (y.pdf_area + pdf_camera));
        sink(Contribution {
            bounce: bounce + 1,
            path_m: arrival_m,
            first_m,
            value: value as f64,
        });
    }
}

/// Where an emission ray from the spot lands ([`PathKernel::light_point`]).
#[derive(Clone, Copy, Debug)]
struct LightPoint {
    p: Point3<f32>,
    /// `p` moved off the surface along `normal`.
    p_off: Point3<f32>,
    /// Unit normal of the side facing the spot.
    normal: Vector3<f32>,
    albedo: f32,
    /// Distance from the spot, metres.
    spot_m: f32,
    /// Density of the emission ray landing here, per unit area.
    pdf_area: f32,
}

/// What a path needs of the triangle it hits.
#[derive(Clone, Copy, Debug)]
struct TriangleShading {
    albedo: f32,
    /// [`orthonormal_basis`] of the triangle's unit normal.
    tangent: Vector3<f32>,
    bitangent: Vector3<f32>,
}

/// What one path cost and skipped (see [`PathKernel::trace_path`]).
#[derive(Clone, Copy, Debug, Default)]
struct PathTally {
    /// Rays cast: the camera and bounce rays plus the shadow rays.
    rays: u64,
    /// Connections to the spot not made because they would arrive before every window.
    skipped_early: u64,
    /// Whether the path ended because everything it could still deliver arrives after
    /// every window.
    ended_late: bool,
}

/// The optical path lengths, metres, outside of which a contribution falls in no bin of
/// the cubes being rendered (the time responses' reach, [`ResponseTable::reach_ps`]).
#[derive(Clone, Copy, Debug)]
struct PathWindow {
    /// Camera-time window as path lengths.
    camera_m: (f64, f64),
    /// World-time window as path lengths less the first segment (world time is camera time
    /// less the first segment's flight), when a world-time cube is rendered.
    world_m: Option<(f64, f64)>,
}

impl PathWindow {
    /// No window: every contribution counts (steady-state renders).
    const UNBOUNDED: PathWindow = PathWindow {
        camera_m: (f64::NEG_INFINITY, f64::INFINITY),
        world_m: None,
    };

    fn new(camera: &ResponseTable, world: Option<&ResponseTable>, ps_per_m: f64) -> PathWindow {
        let to_m = |(a, b): (f64, f64)| (a / ps_per_m, b / ps_per_m);
        PathWindow {
            camera_m: to_m(camera.reach_ps()),
            world_m: world.map(|w| to_m(w.reach_ps())),
        }
    }

    /// Shortest and longest useful path lengths of a path whose first segment is `first_m`.
    fn bounds_m(&self, first_m: f64) -> (f64, f64) {
        let (a, b) = self.camera_m;
        match self.world_m {
            None => (a, b),
            Some((wa, wb)) => (a.min(wa + first_m), b.max(wb + first_m)),
        }
    }
}

fn kernel<'a>(scene: &'a Scene, bvh: &'a Bvh, opts: &TraceOptions) -> PathKernel<'a> {
    let mesh = bvh.mesh();
    assert!(
        mesh.material
            .iter()
            .all(|&m| (m as usize) < scene.albedo.len()),
        "the BVH's mesh has materials the scene has no albedo for (build it from scene.mesh)"
    );
    let emission = opts.emission.unwrap_or(scene.laser.emission);
    let laser = &scene.laser;
    let laser_basis = orthonormal_basis(&laser.normal.into_inner().cast::<f32>());
    let (intensity_scale, cosine_emission) = match emission {
        Emission::Cosine => (laser.energy * FRAC_1_PI as f64, true),
        Emission::Isotropic => (laser.energy / (4.0 * std::f64::consts::PI), false),
    };
    PathKernel {
        scene,
        bvh,
        camera_m: scene.camera.pose.position_m.cast::<f32>(),
        world_from_pixel: world_from_pixel(&scene.camera),
        laser_m: laser.position_m.cast::<f32>(),
        laser_normal: laser.normal.into_inner().cast::<f32>(),
        intensity_scale: intensity_scale as f32,
        cosine_emission,
        shading: bvh
            .mesh()
            .material
            .iter()
            .enumerate()
            .map(|(i, &m)| {
                let normal = bvh.normal(i as u32);
                let (tangent, bitangent) = orthonormal_basis(&normal);
                TriangleShading {
                    albedo: scene.albedo[m as usize],
                    tangent,
                    bitangent,
                }
            })
            .collect(),
        max_bounces: opts.max_bounces,
        rr_start_bounce: opts.rr_start_bounce.max(1),
        light_vertex: opts.light_vertex,
        energy: laser.energy as f32,
        laser_tangent: laser_basis.0,
        laser_bitangent: laser_basis.1,
    }
}

/// `R K^-1` of an undistorted camera (see `PathKernel::world_from_pixel`).
fn world_from_pixel(cam: &crate::scene::StreakCamera) -> Option<Matrix3<f32>> {
    let k = &cam.intrinsics;
    if k.k1 != 0.0 || k.k2 != 0.0 {
        return None;
    }
    let camera_from_pixel = k.k_matrix().try_inverse()?;
    Some((cam.pose.world_from_camera.matrix() * camera_from_pixel).cast::<f32>())
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

/// Render the transient cubes of `scene`. `bvh` must be built from `scene.mesh`.
/// `progress` is called with 1 after each finished image row.
pub fn trace(
    scene: &Scene,
    bvh: &Bvh,
    opts: &TraceOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> TransientRender {
    let started = Instant::now();
    let tracer = Tracer::new(scene, bvh, opts);
    let mut r = tracer.render_rows(0..scene.camera.intrinsics.height, progress);
    r.stats.seconds = started.elapsed().as_secs_f64();
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
    /// Whether the CPU runs [`Tracer::render_row_wide`].
    #[cfg(target_arch = "x86_64")]
    wide_isa: bool,
}

impl<'a> Tracer<'a> {
    /// Prepare a render of `scene`; `bvh` must be built from `scene.mesh`. With
    /// [`TraceOptions::world_time`] this probes the whole image for [`world_axis`].
    pub fn new(scene: &'a Scene, bvh: &'a Bvh, opts: &TraceOptions) -> Tracer<'a> {
        let sigma_ps = scene.laser.pulse_sigma_ps();
        Tracer {
            kernel: kernel(scene, bvh, opts),
            opts: *opts,
            cam_resp: ResponseTable::new(&TimeResponse::new(scene.camera.axis, sigma_ps)),
            world_resp: opts
                .world_time
                .then(|| ResponseTable::new(&TimeResponse::new(world_axis(scene, bvh), sigma_ps))),
            #[cfg(target_arch = "x86_64")]
            wide_isa: is_x86_feature_detected!("avx")
                && is_x86_feature_detected!("avx2")
                && is_x86_feature_detected!("bmi1")
                && is_x86_feature_detected!("bmi2")
                && is_x86_feature_detected!("lzcnt")
                && is_x86_feature_detected!("popcnt")
                && is_x86_feature_detected!("gfni"),
        }
    }

    /// The world-time axis of the render (when [`TraceOptions::world_time`]).
    pub fn world_axis(&self) -> Option<TimeAxis> {
        self.world_resp.as_ref().map(|r| *r.axis())
    }

    /// Render image rows `rows` (clamped to the image): cubes of `rows.len()` rows holding
    /// rows `rows.start ..` of the full image. `progress` is called with 1 after each row.
    pub fn render_rows(
        &self,
        rows: Range<usize>,
        progress: &(dyn Fn(usize) + Sync),
    ) -> TransientRender {
        let started = Instant::now();
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
                let stats = self.render_row_dispatch(y0 + dy, out, &window, ps_per_m);
                progress(1);
                stats
            })
            .collect();

        let mut stats = TraceStats::default();
        for s in &row_stats {
            stats.add(s);
        }
        stats.seconds = started.elapsed().as_secs_f64();
        TransientRender {
            camera_time: camera,
            direct,
            multi,
            world_time: world,
            stats,
        }
    }

    /// Render image row `y` into `out`: [`Tracer::render_row`] compiled for the x86-64-v3
    /// instruction set (AVX2, BMI, and GFNI for the samplers' bit reversals) where the CPU
    /// has it. No fused multiply-adds are enabled and Rust never contracts arithmetic, so
    /// both versions compute the same operations in the same order: bit-identical output.
    fn render_row_dispatch(
        &self,
        y: usize,
        out: RowOut,
        window: &PathWindow,
        ps_per_m: f64,
    ) -> TraceStats {
        #[cfg(target_arch = "x86_64")]
        if self.wide_isa {
            // SAFETY: `wide_isa` says the CPU has every feature `render_row_wide` enables.
            return unsafe { self.render_row_wide(y, out, window, ps_per_m) };
        }
        self.render_row::<false>(y, out, window, ps_per_m)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2,bmi1,bmi2,lzcnt,popcnt,gfni")]
    fn render_row_wide(
        &self,
        y: usize,
        out: RowOut,
        window: &PathWindow,
        ps_per_m: f64,
    ) -> TraceStats {
        self.render_row::<true>(y, out, window, ps_per_m)
    }

    /// Render image row `y` (of the full image) into its output slices. `_WIDE` only tells
    /// the two compiled versions apart, so that each has its own copy of the per-sample
    /// closure (one caller each, which the compiler then inlines).
    #[inline(always)]
    fn render_row<const _WIDE: bool>(
        &self,
        y: usize,
        mut out: RowOut,
        window: &PathWindow,
        ps_per_m: f64,
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
mod tests {
    use super::*;

    #[test]
    fn pixel_matrix_gives_the_camera_rays() {
        // The undistorted fast path agrees with Intrinsics::camera_ray rotated to the world,
        // at corners, centre and interior points of the image.
        let scene = Scene::builtin("cornell", None).unwrap();
        let cam = &scene.camera;
        let m = world_from_pixel(cam).expect("the built-in camera has no distortion");
        let (w, h) = (cam.intrinsics.width as f64, cam.intrinsics.height as f64);
        for (u, v) in [
            (0.0, 0.0),
            (w, h),
            (0.5 * w, 0.5 * h),
            (3.25, 40.5),
            (w, 0.0),
        ] {
            let expected =
                cam.pose.world_from_camera * cam.intrinsics.camera_ray(u, v).into_inner();
            let got = (m * Vector3::new(u as f32, v as f32, 1.0)).normalize();
            assert!((got.cast::<f64>() - expected).norm() < 1e-6, "({u}, {v})");
        }
        let mut distorted = *cam;
        distorted.intrinsics.k1 = 0.1;
        assert!(world_from_pixel(&distorted).is_none());
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn wide_isa_rows_are_bit_identical_to_baseline_rows() {
        // The x86-64-v3 build of the row renderer computes the same operations in the same
        // order as the baseline one: every cube (camera, split, world time) agrees bit for
        // bit, and the counters agree.
        let scene = Scene::builtin("cornell", None)
            .unwrap()
            .with_resolution(8, 6, 120, 4.0);
        let bvh = Bvh::new(scene.mesh.clone());
        let opts = TraceOptions {
            spp: 16,
            ..TraceOptions::default()
        };
        let mut tracer = Tracer::new(&scene, &bvh, &opts);
        if !tracer.wide_isa {
            eprintln!("skipped: this CPU lacks AVX2/BMI/GFNI");
            return;
        }
        let wide = tracer.render_rows(0..6, &|_| {});
        tracer.wide_isa = false;
        let base = tracer.render_rows(0..6, &|_| {});
        let bits = |c: &Cube| c.data.iter().map(|v| v.to_bits()).collect::<Vec<u32>>();
        let cubes = |r: &TransientRender| {
            [
                Some(r.camera_time.clone()),
                r.direct.clone(),
                r.multi.clone(),
                r.world_time.clone(),
            ]
        };
        for (a, b) in cubes(&wide).iter().zip(cubes(&base).iter()) {
            let (a, b) = (a.as_ref().unwrap(), b.as_ref().unwrap());
            assert!(a.data.iter().any(|&v| v > 0.0));
            assert_eq!(bits(a), bits(b));
        }
        let (mut sw, mut sb) = (wide.stats, base.stats);
        (sw.seconds, sb.seconds) = (0.0, 0.0);
        assert_eq!(sw, sb);
    }

    #[test]
    fn triangle_bases_are_those_of_the_hit_normals() {
        // The per-triangle basis the kernel precomputes is, bit for bit, the basis of the
        // normal the BVH reports for hits on that triangle (so shading with it is the same
        // as computing it per hit), for rays in all directions from inside the room.
        let scene = Scene::builtin("cornell", None).unwrap();
        let bvh = Bvh::new(scene.mesh.clone());
        let k = kernel(&scene, &bvh, &TraceOptions::default());
        let mut rng = pixel_rng(3, Stream::Steady, 0);
        let mut seen = std::collections::HashSet::new();
        for _ in 0..4000 {
            let (u1, u2) = uniform_pair(&mut rng);
            let z = 1.0 - 2.0 * u1;
            let phi = 2.0 * std::f32::consts::PI * u2;
            let rxy = (1.0 - z * z).max(0.0).sqrt();
            let dir = Vector3::new(rxy * phi.cos(), rxy * phi.sin(), z);
            let Some(hit) = bvh.intersect(&Ray::new(k.laser_m, dir), 0.0, f32::INFINITY) else {
                continue;
            };
            let s = &k.shading[hit.triangle as usize];
            let (t, b) = orthonormal_basis(&hit.normal);
            assert_eq!(
                (s.tangent, s.bitangent),
                (t, b),
                "triangle {}",
                hit.triangle
            );
            seen.insert(hit.triangle);
        }
        assert!(seen.len() > 20, "{}", seen.len());
    }

    /// Every contribution of 256 paths of one pixel, each path's random stream started
    /// afresh: `(path, bounce, first_m, path_m, value)`.
    fn contributions(k: &PathKernel, window: &PathWindow) -> Vec<(u32, u32, f64, f64, f64)> {
        let mut out = Vec::new();
        let ld = PixelSampler::new(1, Stream::Transient, 7, 256);
        for i in 0..256 {
            let mut rng = pixel_rng(1, Stream::Transient, 1000 + i as u64);
            let (du, dv) = ld.sample(i, 0);
            let (u, v) = (20.0 + du as f64, 30.0 + dv as f64);
            k.trace_path(&mut rng, &ld, i, (u, v), window, &mut |c: Contribution| {
                out.push((i, c.bounce, c.first_m, c.path_m, c.value))
            });
        }
        out
    }

    #[test]
    fn a_window_drops_exactly_the_contributions_outside_it() {
        // The same paths traced without a window and with one (camera time, and camera plus
        // world time) give exactly the unwindowed contributions that land inside it: ending
        // a path whose length plus the straight line to the spot is already past the window
        // loses nothing that could land in it.
        let scene = Scene::builtin("cornell", None).unwrap();
        let bvh = Bvh::new(scene.mesh.clone());
        let opts = TraceOptions {
            max_bounces: 8,
            rr_start_bounce: 8,
            ..TraceOptions::default()
        };
        let k = kernel(&scene, &bvh, &opts);
        let all = contributions(&k, &PathWindow::UNBOUNDED);
        assert!(all.iter().any(|c| c.1 >= 5), "long paths are sampled");
        let lo = all.iter().map(|c| c.3).fold(f64::INFINITY, f64::min);
        let hi = all.iter().map(|c| c.3).fold(0.0, f64::max);
        let narrow = (lo + 0.2 * (hi - lo), lo + 0.4 * (hi - lo));
        for window in [
            PathWindow {
                camera_m: narrow,
                world_m: None,
            },
            PathWindow {
                camera_m: narrow,
                world_m: Some((narrow.0 - 0.5, narrow.1 - 0.3)),
            },
        ] {
            let kept = contributions(&k, &window);
            let expected: Vec<_> = all
                .iter()
                .filter(|c| {
                    let (a, b) = window.bounds_m(c.2);
                    a <= c.3 && c.3 <= b
                })
                .cloned()
                .collect();
            assert_eq!(kept, expected);
            assert!(
                kept.len() > 50 && kept.len() + 50 < all.len(),
                "{}",
                kept.len()
            );
        }
    }
}

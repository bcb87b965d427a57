//! The per-pixel pipeline of the renderer (steps 1-7 of the [`crate::render`] module doc):
//! camera ray, aberration, hit, emission time, capture lookup, searchlight accumulation,
//! Doppler colour. [`render_frame`] runs it over a frame in parallel (rayon, one task per
//! row, each stage over the whole row before the next); [`render_frame_reusing_rays`] keeps
//! the rays of steps 1-2 from frame to frame while they stay the same (a dolly);
//! [`probe_pixel`] returns every intermediate quantity of one pixel.
//!
//! A row's rays are made four at a time (`rays`), cast with the batch caster that skips rays
//! missing the scene's box ([`crate::geometry::bvh::Bvh::intersect_distances`]), and shaded
//! in the transient view by the row pipeline of `transient`; other views shade pixel by
//! pixel (`FrameCtx::shade`). Each computes what [`probe_pixel`] does, bit for bit.

mod colour;
mod rays;
mod transient;

use super::views;
use super::{ColourOutput, RenderScene, RenderSettings, View, FALSE_COLOUR_LASER_NM};
use crate::camera_path::FrameState;
use crate::color;
use crate::geometry::Ray;
use crate::relativity::{constant_light_factor, medium, Boost};
use crate::units::flight_time_ps;
use nalgebra::{Matrix3, Point3, Vector2, Vector3};
use rayon::prelude::*;

/// Everything the pipeline computed for one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelSample {
    /// Camera-frame ray in world axes (`world_from_camera * d'`), unit.
    pub d_camera: Vector3<f64>,
    /// The traced world-frame ray, unit (aberrated unless aberration is off).
    pub d_world: Vector3<f64>,
    /// Velocity over c used for this pixel (world frame).
    pub beta: Vector3<f64>,
    /// Doppler factor of the light received along this ray, `1 / (gamma (1 + eta beta . d))`
    /// (eta: the capture's refractive index, 1 in vacuum).
    pub doppler: f64,
    /// World time of reception, ps (0 = the pulse leaves the laser spot).
    pub t_receive_ps: f64,
    /// The hit point and its distance from the camera; None when the ray leaves the scene.
    pub hit_m: Option<(Point3<f64>, f64)>,
    /// World emission time of the light shown (transient and naive views), ps.
    pub t_emit_ps: Option<f64>,
    /// Time of first arrival of the direct light at the camera (see [`View::Isochrones`]).
    pub t_arrival_ps: Option<f64>,
    /// The cube pixel nearest to the hit point's projection (the value interpolates it with
    /// the neighbours that see the point, [`super::RenderScene::capture_taps`]); None when
    /// the capture camera does not see it.
    pub capture_pixel: Option<(usize, usize)>,
    /// Received wavelength shown, nm (`D lambda_laser`, or the laser's with Doppler off).
    pub lambda_nm: f64,
    /// Pixel luminance before exposure (scene-linear; display value for isochrones).
    pub value: f64,
    /// The pixel written by [`render_frame`], in the settings' [`ColourOutput`].
    pub rgb: [f64; 3],
}

/// A boost with the constants of its aberration formula precomputed, so that a ray costs one
/// division ([`Boost::aberrate_with_doppler`] written with `1 / gamma`,
/// `gamma / (gamma + 1)` and one reciprocal of `1 - b . d'`).
#[derive(Clone, Copy)]
struct PixelBoost {
    beta: Vector3<f64>,
    gamma: f64,
    inv_gamma: f64,
    /// `gamma / (gamma + 1)`.
    k: f64,
}

impl PixelBoost {
    #[inline]
    fn new(b: &Boost) -> PixelBoost {
        let g = b.gamma();
        PixelBoost {
            beta: b.beta_vector(),
            gamma: g,
            inv_gamma: 1.0 / g,
            k: g / (g + 1.0),
        }
    }

    /// World-frame ray and Doppler factor of the camera ray `d_cam` (physics.md; the same
    /// formula as [`Boost::aberrate_with_doppler`]).
    #[inline(always)]
    fn aberrate_with_doppler(&self, d_cam: &Vector3<f64>) -> (Vector3<f64>, f64) {
        let b_dot_d = self.beta.dot(d_cam);
        let inv = 1.0 / (1.0 - b_dot_d);
        let d_world = (d_cam * self.inv_gamma + self.beta * (self.k * b_dot_d - 1.0)) * inv;
        (d_world, self.gamma * (1.0 - b_dot_d))
    }

    /// Doppler factor of light arriving from the world direction `d`, `1 / (gamma (1 + b . d))`
    /// (aberration off).
    #[inline(always)]
    fn doppler_of_world_ray(&self, d: &Vector3<f64>) -> f64 {
        1.0 / (self.gamma * (1.0 + self.beta.dot(d)))
    }

    /// The same two in a medium of index `eta`: the vacuum formulas above at `eta == 1`
    /// (bit-identical), else [`medium`]'s.
    #[inline(always)]
    fn in_medium(&self, d_cam: &Vector3<f64>, eta: f64, aberration: bool) -> (Vector3<f64>, f64) {
        match (eta == 1.0, aberration) {
            (true, true) => self.aberrate_with_doppler(d_cam),
            (true, false) => (*d_cam, self.doppler_of_world_ray(d_cam)),
            (false, true) => medium::camera_to_world(&self.beta, d_cam, eta),
            (false, false) => (*d_cam, medium::doppler_of_world_ray(&self.beta, d_cam, eta)),
        }
    }
}

/// Per-frame constants of the pipeline (shared with the traced truth, [`super::truth`]).
pub(super) struct FrameCtx<'s> {
    state: &'s FrameState,
    world_from_camera: Matrix3<f64>,
    origin: Point3<f64>,
    pub(super) origin_f32: Point3<f32>,
    inv_focal_px: f64,
    half: Vector2<f64>,
    /// One boost for the whole frame; None when it varies per pixel (rotating sensor).
    boost: Option<PixelBoost>,
    pub(super) t_receive_ps: f64,
    eta: f64,
    /// `eta / c`: flight time per metre, ps.
    eta_over_c_ps_per_m: f64,
    pub(super) inv_dtau_per_ps: f64,
    /// The colour of every pixel when the Doppler shift is off (the laser's own).
    fixed_colour: Option<[f64; 3]>,
    /// Wavelength drawn per nm received: 1, or for [`ColourOutput::FalseColour`]
    /// `FALSE_COLOUR_LASER_NM / laser_nm`.
    drawn_per_received: f64,
}

/// A boost for `beta`, its speed pulled just below 1 if rounding took it to 1 (paths and
/// rotations are validated to stay below 1, so this only guards the last bit).
#[inline]
fn boost_of(beta: &Vector3<f64>) -> Boost {
    match Boost::new(*beta) {
        Ok(b) => b,
        Err(_) => {
            let s = beta.norm();
            if s.is_finite() && s > 0.0 {
                Boost::new(beta * ((1.0 - 1e-12) / s)).unwrap_or_else(|_| Boost::identity())
            } else {
                Boost::identity()
            }
        }
    }
}

/// Colour of light received at `lambda_nm` in the output's colour space, luminance 1.
#[inline]
pub(super) fn colour_of(colour: ColourOutput, lambda_nm: f64) -> [f64; 3] {
    match colour {
        ColourOutput::LinearSrgb | ColourOutput::FalseColour => color::laser_colour(lambda_nm),
        ColourOutput::Xyz => match color::monochromatic_linear_srgb(lambda_nm) {
            Some(_) => {
                let [cx, cy, cz] = color::cmf_xyz(lambda_nm).unwrap_or([1.0; 3]);
                [cx / cy, 1.0, cz / cy]
            }
            None => color::linear_srgb_to_xyz([1.0; 3]),
        },
    }
}

impl<'s> FrameCtx<'s> {
    fn new(scene: &RenderScene, settings: &RenderSettings, state: &'s FrameState) -> Self {
        Self::in_medium(settings, state, scene.capture.eta, scene.laser_nm)
    }

    /// The constants of frame `state` in a medium of index `eta`, for a laser of
    /// `laser_nm` (what [`FrameCtx::new`] takes from a [`RenderScene`]).
    pub(super) fn in_medium(
        settings: &RenderSettings,
        state: &'s FrameState,
        eta: f64,
        laser_nm: f64,
    ) -> Self {
        let e = settings.effects;
        let (w, h) = (settings.width as f64, settings.height as f64);
        let focal_px = 0.5 * h / (0.5 * state.vfov_deg.to_radians()).tan();
        let per_pixel = e.rotation && state.rotation.is_some();
        let boost = if !e.needs_boost() {
            Some(PixelBoost::new(&Boost::identity()))
        } else if per_pixel {
            None
        } else {
            Some(PixelBoost::new(&boost_of(&state.beta)))
        };
        let t_path_ps = if e.dilation {
            state.t_world_ps
        } else {
            state.tau_ps
        };
        let o = state.position_m;
        FrameCtx {
            state,
            world_from_camera: *state.world_from_camera.matrix(),
            origin: o,
            origin_f32: Point3::new(o.x as f32, o.y as f32, o.z as f32),
            inv_focal_px: 1.0 / focal_px,
            half: Vector2::new(0.5 * w, 0.5 * h),
            boost,
            t_receive_ps: t_path_ps + settings.time_offset_ps,
            eta,
            eta_over_c_ps_per_m: flight_time_ps(eta, 1.0),
            inv_dtau_per_ps: 1.0 / settings.dtau_ps,
            fixed_colour: (!e.doppler).then(|| match settings.colour {
                ColourOutput::FalseColour => colour_of(settings.colour, FALSE_COLOUR_LASER_NM),
                _ => colour_of(settings.colour, color::nearest_visible_nm(laser_nm)),
            }),
            drawn_per_received: match settings.colour {
                ColourOutput::FalseColour => FALSE_COLOUR_LASER_NM / laser_nm,
                _ => 1.0,
            },
        }
    }

    /// Step 1-2 of the pipeline for pixel `(i, j)`: the camera ray `d'` (world axes), the
    /// world ray and the Doppler factor of the light arriving along it, and the velocity used.
    #[inline(always)]
    fn ray(&self, settings: &RenderSettings, i: usize, j: usize) -> PixelRay {
        self.ray_at(settings, i as f64 + 0.5, j as f64 + 0.5)
    }

    /// [`FrameCtx::ray`] through the continuous pixel coordinates `(u, v)` (pixel `(i, j)`
    /// spans `[i, i + 1) x [j, j + 1)`).
    #[inline(always)]
    pub(super) fn ray_at(&self, settings: &RenderSettings, u: f64, v: f64) -> PixelRay {
        let offset = Vector2::new(u - self.half.x, v - self.half.y);
        let local = Vector3::new(
            offset.x * self.inv_focal_px,
            offset.y * self.inv_focal_px,
            1.0,
        );
        let d = self.world_from_camera * local;
        let d_camera = d * (1.0 / d.norm());
        let boost = match self.boost {
            Some(b) => b,
            None => PixelBoost::new(&boost_of(&self.state.pixel_beta(&offset, &self.half))),
        };
        let (d_world, doppler) = boost.in_medium(&d_camera, self.eta, settings.effects.aberration);
        PixelRay {
            d_camera,
            d_world,
            beta: boost.beta,
            doppler,
        }
    }

    /// Step 3: distance to the nearest hit of the world ray `d_world` (from the frame's
    /// camera position), or None when it leaves the scene.
    #[inline(always)]
    fn cast(&self, scene: &RenderScene, d_world: &Vector3<f64>) -> Option<f32> {
        let ray = Ray::new(
            self.origin_f32,
            Vector3::new(d_world.x as f32, d_world.y as f32, d_world.z as f32),
        );
        scene.bvh.intersect(&ray, 0.0, f32::INFINITY).map(|h| h.t)
    }

    /// Steps 4-7 for the world ray `d_world` with Doppler factor `doppler` whose nearest hit
    /// is at `hit_t` metres.
    #[inline(always)]
    fn shade(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
        d_world: &Vector3<f64>,
        doppler: f64,
        hit_t: Option<f32>,
    ) -> Shaded {
        let e = settings.effects;
        let lambda_nm = if e.doppler {
            doppler * scene.laser_nm
        } else {
            scene.laser_nm
        };
        let mut out = Shaded {
            lambda_nm,
            hit_m: None,
            t_emit_ps: None,
            t_arrival_ps: None,
            capture_pixel: None,
            value: 0.0,
            colour: Colour::Black,
        };
        let Some(t) = hit_t else {
            return out;
        };
        let dist_m = t as f64;
        let p = self.origin + d_world * dist_m;
        out.hit_m = Some((p, dist_m));
        if let View::Isochrones(iso) = settings.view {
            let t = views::first_arrival_world_ps(scene, &p)
                + if e.unwarp {
                    flight_time_ps(self.eta, dist_m)
                } else {
                    0.0
                };
            out.t_arrival_ps = Some(t);
            let lit = views::laser_sees(scene, &p);
            let rgb = views::isochrone_colour(&iso, t, lit);
            out.value = color::luminance(rgb);
            out.colour = Colour::Display(rgb);
            return out;
        }
        let Some(taps) = scene.capture_taps(&p, d_world) else {
            return out;
        };
        out.capture_pixel = Some(taps.nearest);
        let d_light = if e.searchlight { doppler } else { 1.0 };
        let value = match settings.view {
            View::Integrated => {
                let total: f64 = taps
                    .iter()
                    .map(|((x, y), w)| w * scene.pixel_total(x, y))
                    .sum();
                let factor = if e.searchlight {
                    constant_light_factor(d_light, settings.radiometry)
                } else {
                    1.0
                };
                factor * total
            }
            _ => {
                let t_e = match settings.view {
                    View::Naive => views::naive_emission_ps(scene, &p, self.t_receive_ps),
                    _ if e.unwarp => self.t_receive_ps - self.eta_over_c_ps_per_m * dist_m,
                    _ => self.t_receive_ps,
                };
                out.t_emit_ps = Some(t_e);
                let window_ps = settings.dtau_ps / d_light;
                let energy = scene.emitted_energy_of(&taps, t_e, t_e + window_ps);
                // Radiometry::frame_value, with the division by dtau done once per frame.
                settings.radiometry.window_factor(d_light) * energy * self.inv_dtau_per_ps
            }
        };
        out.value = value;
        out.colour = Colour::Radiance(value);
        out
    }

    /// The colour, luminance 1, of light received at `lambda_nm` (the laser's own with the
    /// Doppler shift off): step 7 without the value.
    #[inline(always)]
    pub(super) fn colour(&self, settings: &RenderSettings, lambda_nm: f64) -> [f64; 3] {
        match self.fixed_colour {
            Some(c) => c,
            None => colour_of(settings.colour, lambda_nm * self.drawn_per_received),
        }
    }

    /// Step 7, the pixel's colour: `value` times the colour of the received wavelength
    /// `lambda_nm`, black, or the display colour of an isochrone.
    #[inline(always)]
    fn rgb(&self, settings: &RenderSettings, lambda_nm: f64, colour: Colour) -> [f64; 3] {
        match colour {
            Colour::Black => [0.0; 3],
            Colour::Display(rgb) => rgb,
            Colour::Radiance(value) => {
                let c = self.colour(settings, lambda_nm);
                [value * c[0], value * c[1], value * c[2]]
            }
        }
    }

    /// Steps 3-7 for one row whose world rays and Doppler factors are given, one stage at a
    /// time (all casts, then all lookups, then all colours): the same arithmetic as
    /// [`FrameCtx::trace`], with each stage's loop kept tight.
    #[inline(always)]
    fn render_row(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
        d_world: &[Vector3<f64>],
        doppler: &[f64],
        scratch: &mut RowScratch,
        row: &mut [[f32; 3]],
    ) {
        let mut hit_t = std::mem::take(&mut scratch.hit_t);
        hit_t.resize(d_world.len(), None);
        self.cast_row(scene, d_world, scratch, &mut hit_t);
        self.shade_row(scene, settings, d_world, doppler, &hit_t, scratch, row);
        scratch.hit_t = hit_t;
    }

    /// Step 3 for a row: the distance to the nearest hit of each world ray in `d_world`, or
    /// None, into `hit_t`.
    #[inline(always)]
    fn cast_row(
        &self,
        scene: &RenderScene,
        d_world: &[Vector3<f64>],
        scratch: &mut RowScratch,
        hit_t: &mut [Option<f32>],
    ) {
        scratch.dirs.clear();
        scratch.dirs.extend(
            d_world
                .iter()
                .map(|d| Vector3::new(d.x as f32, d.y as f32, d.z as f32)),
        );
        scene
            .bvh
            .intersect_distances(self.origin_f32, &scratch.dirs, 0.0, f32::INFINITY, hit_t);
    }

    /// Steps 4-7 for a row whose world rays, Doppler factors and hit distances are known.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn shade_row(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
        d_world: &[Vector3<f64>],
        doppler: &[f64],
        hit_t: &[Option<f32>],
        scratch: &mut RowScratch,
        row: &mut [[f32; 3]],
    ) {
        if settings.view == View::Transient {
            return self
                .shade_transient_row(scene, settings, d_world, doppler, hit_t, scratch, row);
        }
        scratch.lambda_nm.clear();
        scratch.colour.clear();
        for ((d, &doppler), &hit_t) in d_world.iter().zip(doppler).zip(hit_t) {
            let s = self.shade(scene, settings, d, doppler, hit_t);
            scratch.lambda_nm.push(s.lambda_nm);
            scratch.colour.push(s.colour);
        }
        for ((px, &lambda_nm), &colour) in
            row.iter_mut().zip(&scratch.lambda_nm).zip(&scratch.colour)
        {
            let rgb = self.rgb(settings, lambda_nm, colour);
            *px = [rgb[0] as f32, rgb[1] as f32, rgb[2] as f32];
        }
    }

    /// The whole pipeline for one pixel.
    fn trace(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
        i: usize,
        j: usize,
    ) -> PixelSample {
        let r = self.ray(settings, i, j);
        let hit_t = self.cast(scene, &r.d_world);
        let s = self.shade(scene, settings, &r.d_world, r.doppler, hit_t);
        let rgb = self.rgb(settings, s.lambda_nm, s.colour);
        PixelSample {
            d_camera: r.d_camera,
            d_world: r.d_world,
            beta: r.beta,
            doppler: r.doppler,
            t_receive_ps: self.t_receive_ps,
            hit_m: s.hit_m,
            t_emit_ps: s.t_emit_ps,
            t_arrival_ps: s.t_arrival_ps,
            capture_pixel: s.capture_pixel,
            lambda_nm: s.lambda_nm,
            value: s.value,
            rgb,
        }
    }
}

/// Steps 1-2 of one pixel.
pub(super) struct PixelRay {
    pub(super) d_camera: Vector3<f64>,
    pub(super) d_world: Vector3<f64>,
    pub(super) beta: Vector3<f64>,
    pub(super) doppler: f64,
}

/// Steps 4-7 of one pixel.
struct Shaded {
    lambda_nm: f64,
    hit_m: Option<(Point3<f64>, f64)>,
    t_emit_ps: Option<f64>,
    t_arrival_ps: Option<f64>,
    capture_pixel: Option<(usize, usize)>,
    value: f64,
    colour: Colour,
}

/// What step 7 makes of a pixel.
#[derive(Clone, Copy)]
enum Colour {
    /// The ray leaves the scene or the capture camera does not see its point.
    Black,
    /// Isochrones: a display colour.
    Display([f64; 3]),
    /// Scene-linear luminance, to be coloured by the received wavelength.
    Radiance(f64),
}

/// One row's ray directions, hit distances, projections, wavelengths and colours, filled
/// one stage at a time.
#[derive(Default)]
struct RowScratch {
    dirs: Vec<Vector3<f32>>,
    hit_t: Vec<Option<f32>>,
    /// The pixels whose ray hits the mesh: index in the row, distance.
    hit_pixels: Vec<(usize, f32)>,
    projected: Vec<transient::Projected>,
    /// The lit pixels of the transient view whose colours are made four at a time: index
    /// in the row, value, received wavelength (nm).
    lit: Vec<(usize, f64, f64)>,
    lambda_nm: Vec<f64>,
    colour: Vec<Colour>,
}

/// Render one frame of `settings.width x settings.height` pixels for the camera state
/// `state` into `out` (row-major from the top row): scene-linear colours in the settings'
/// [`ColourOutput`] (display colours for isochrones). Pixels whose ray leaves the scene or
/// whose point the capture camera does not see are black. Parallel over rows; the result
/// does not depend on the number of threads.
///
/// Panics if `out.len() != width * height` (a caller bug).
pub fn render_frame(
    scene: &RenderScene,
    settings: &RenderSettings,
    state: &FrameState,
    out: &mut [[f32; 3]],
) {
    assert_eq!(
        out.len(),
        settings.width * settings.height,
        "render_frame: output buffer size"
    );
    let ctx = FrameCtx::new(scene, settings, state);
    out.par_chunks_mut(settings.width)
        .enumerate()
        .for_each_init(
            || (Vec::new(), Vec::new(), RowScratch::default()),
            |(d_world, doppler, scratch), (j, row)| {
                d_world.resize(row.len(), Vector3::zeros());
                doppler.resize(row.len(), 0.0);
                ctx.row_rays(settings, j, d_world, doppler);
                ctx.render_row(scene, settings, d_world, doppler, scratch, row);
            },
        );
}

/// The world rays and Doppler factors of every pixel of a frame, kept from one frame to the
/// next by [`render_frame_reusing_rays`]: they depend only on the camera's orientation,
/// velocity and field of view, which stay the same over a straight path at constant speed
/// (a dolly), so such frames skip steps 1-2 of the pipeline.
///
/// They also keep each pixel's hit distance (step 3), which depends on the camera's position
/// as well: the frames of a camera at rest whose time alone moves (`femto view`'s Play after
/// Reset) skip the ray cast too.
#[derive(Default)]
pub struct FrameRays {
    key: Option<RayKey>,
    d_world: Vec<Vector3<f64>>,
    doppler: Vec<f64>,
    /// The geometry and camera position `hit_t` was cast for (with `key`).
    hits_key: Option<HitsKey>,
    hit_t: Vec<Option<f32>>,
}

/// What step 3 depends on besides the rays: the mesh (by address: a [`FrameRays`] kept
/// by one caller for one scene) and the camera position, bit for bit.
#[derive(Clone, Copy, PartialEq)]
struct HitsKey {
    bvh_address: usize,
    origin_bits: [u32; 3],
}

/// Everything [`FrameCtx::ray`] depends on for a frame with one boost.
#[derive(Clone, Copy, PartialEq)]
struct RayKey {
    world_from_camera: Matrix3<f64>,
    beta: Vector3<f64>,
    gamma: f64,
    inv_focal_px: f64,
    half: Vector2<f64>,
    aberration: bool,
    width: usize,
    height: usize,
}

/// [`render_frame`], with steps 1-2 (camera rays, aberration, Doppler factors) taken from
/// `rays` when they were made for the same ray geometry (see [`FrameRays`]), and left in
/// `rays` for the next frame otherwise. The pixels are the same, bit for bit. A rotating
/// sensor (a boost per pixel) is rendered as by [`render_frame`].
pub fn render_frame_reusing_rays(
    scene: &RenderScene,
    settings: &RenderSettings,
    state: &FrameState,
    rays: &mut FrameRays,
    out: &mut [[f32; 3]],
) {
    let ctx = FrameCtx::new(scene, settings, state);
    let Some(boost) = ctx.boost else {
        rays.key = None;
        return render_frame(scene, settings, state, out);
    };
    assert_eq!(
        out.len(),
        settings.width * settings.height,
        "render_frame_reusing_rays: output buffer size"
    );
    let (key, hits_key) = frame_keys(scene, settings, &ctx, &boost);
    let w = settings.width;
    if rays.key == Some(key) {
        // The same rays: from the same place, the same hits too.
        let cast = rays.hits_key != Some(hits_key);
        rays.hits_key = None;
        out.par_chunks_mut(w)
            .zip(rays.d_world.par_chunks(w))
            .zip(rays.doppler.par_chunks(w))
            .zip(rays.hit_t.par_chunks_mut(w))
            .for_each_init(
                RowScratch::default,
                |scratch, (((row, d_world), doppler), hit_t)| {
                    if cast {
                        ctx.cast_row(scene, d_world, scratch, hit_t);
                    }
                    ctx.shade_row(scene, settings, d_world, doppler, hit_t, scratch, row);
                },
            );
        rays.hits_key = Some(hits_key);
        return;
    }
    // New rays: each row's are made in the task that renders the row, and used while they
    // are in its cache (a pass of their own wrote 5 MB and read them back after a barrier:
    // 1.5 CPU ms of the render bench's 23.3).
    rays.key = None;
    rays.hits_key = None;
    rays.d_world.resize(out.len(), Vector3::zeros());
    rays.doppler.resize(out.len(), 0.0);
    rays.hit_t.resize(out.len(), None);
    out.par_chunks_mut(w)
        .zip(rays.d_world.par_chunks_mut(w))
        .zip(rays.doppler.par_chunks_mut(w))
        .zip(rays.hit_t.par_chunks_mut(w))
        .enumerate()
        .for_each_init(
            RowScratch::default,
            |scratch, (j, (((row, d_world), doppler), hit_t))| {
                ctx.row_rays(settings, j, d_world, doppler);
                ctx.cast_row(scene, d_world, scratch, hit_t);
                ctx.shade_row(scene, settings, d_world, doppler, hit_t, scratch, row);
            },
        );
    rays.key = Some(key);
    rays.hits_key = Some(hits_key);
}

/// What the rays of the frame `ctx` (one boost for the whole frame) and their hits
/// depend on.
fn frame_keys(
    scene: &RenderScene,
    settings: &RenderSettings,
    ctx: &FrameCtx,
    boost: &PixelBoost,
) -> (RayKey, HitsKey) {
    let key = RayKey {
        world_from_camera: ctx.world_from_camera,
        beta: boost.beta,
        gamma: boost.gamma,
        inv_focal_px: ctx.inv_focal_px,
        half: ctx.half,
        aberration: settings.effects.aberration,
        width: settings.width,
        height: settings.height,
    };
    let hits_key = HitsKey {
        bvh_address: std::ptr::from_ref(scene.bvh) as usize,
        origin_bits: [0, 1, 2].map(|k| ctx.origin_f32[k].to_bits()),
    };
    (key, hits_key)
}

/// [`probe_pixel`] for many pixels of one frame: the frame's constants computed once, and
/// the frame's rays and hits read from a [`FrameRays`] that holds them.
pub(super) struct FrameProbe<'s> {
    ctx: FrameCtx<'s>,
    /// The rays and hits of this frame (as [`render_frame_reusing_rays`] left them after
    /// rendering it), when the caller has them.
    kept: Option<&'s FrameRays>,
}

impl<'s> FrameProbe<'s> {
    /// The probe of the frame `state`; `rays`: the rays and hits of a frame rendered just
    /// before ([`render_frame_reusing_rays`]), used where they are this frame's.
    pub(super) fn new(
        scene: &RenderScene,
        settings: &RenderSettings,
        state: &'s FrameState,
        rays: Option<&'s FrameRays>,
    ) -> FrameProbe<'s> {
        let ctx = FrameCtx::new(scene, settings, state);
        let kept = rays.filter(|rays| {
            ctx.boost.is_some_and(|boost| {
                let (key, hits_key) = frame_keys(scene, settings, &ctx, &boost);
                rays.key == Some(key) && rays.hits_key == Some(hits_key)
            })
        });
        FrameProbe { ctx, kept }
    }

    /// [`probe_pixel`] of pixel `(i, j)`.
    pub(super) fn sample(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
        i: usize,
        j: usize,
    ) -> PixelSample {
        self.ctx.trace(scene, settings, i, j)
    }

    /// What [`super::dark::DarkKind`] pixel `(i, j)` is depends on: from the kept ray and
    /// hit when the probe has them (steps 4-7 alone; the render's batch cast gives the single
    /// ray's hit, bit for bit), else from [`FrameProbe::sample`].
    pub(super) fn seen_hit(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
        i: usize,
        j: usize,
    ) -> SeenHit {
        let Some(rays) = self.kept else {
            return SeenHit::from(&self.sample(scene, settings, i, j));
        };
        let k = j * settings.width + i;
        let d_world = rays.d_world[k];
        let s = self
            .ctx
            .shade(scene, settings, &d_world, rays.doppler[k], rays.hit_t[k]);
        SeenHit {
            hit_m: s.hit_m.map(|(p, _)| p),
            capture_pixel: s.capture_pixel,
            d_world,
        }
    }
}

/// A pixel's ray, its hit and the capture pixel that sees the hit ([`PixelSample`]'s
/// `d_world`, `hit_m` point and `capture_pixel`).
pub(super) struct SeenHit {
    pub(super) hit_m: Option<Point3<f64>>,
    pub(super) capture_pixel: Option<(usize, usize)>,
    pub(super) d_world: Vector3<f64>,
}

impl From<&PixelSample> for SeenHit {
    fn from(s: &PixelSample) -> SeenHit {
        SeenHit {
            hit_m: s.hit_m.map(|(p, _)| p),
            capture_pixel: s.capture_pixel,
            d_world: s.d_world,
        }
    }
}

/// Every intermediate quantity of pixel `(i, j)` of the frame `state` (for tests, tools and
/// the isochrone range).
pub fn probe_pixel(
    scene: &RenderScene,
    settings: &RenderSettings,
    state: &FrameState,
    i: usize,
    j: usize,
) -> PixelSample {
    FrameCtx::new(scene, settings, state).trace(scene, settings, i, j)
}

//! The per-pixel pipeline of the renderer (steps 1-7 of the [`crate::render`] module doc):
//! camera ray, aberration, hit, emission time, capture lookup, searchlight accumulation,
//! Doppler colour. [`render_frame`] runs it over a frame in parallel (rayon, one task per
//! row); [`probe_pixel`] returns every intermediate quantity of one pixel.

use super::views;
use super::{ColourOutput, RenderScene, RenderSettings, View};
use crate::camera_path::FrameState;
use crate::color;
use crate::geometry::Ray;
use crate::relativity::{constant_light_factor, Boost};
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
    /// Doppler factor of the light received along this ray, `1 / (gamma (1 + beta . d))`.
    pub doppler: f64,
    /// World time of reception, ps (0 = the pulse leaves the laser spot).
    pub t_receive_ps: f64,
    /// The hit point and its distance from the camera; None when the ray leaves the scene.
    pub hit_m: Option<(Point3<f64>, f64)>,
    /// World emission time of the light shown (transient and naive views), ps.
    pub t_emit_ps: Option<f64>,
    /// Time of first arrival of the direct light at the camera (see [`View::Isochrones`]).
    pub t_arrival_ps: Option<f64>,
    /// The cube pixel that recorded the hit point; None when the capture camera does not see
    /// it.
    pub capture_pixel: Option<(usize, usize)>,
    /// Received wavelength shown, nm (`D lambda_laser`, or the laser's with Doppler off).
    pub lambda_nm: f64,
    /// Pixel luminance before exposure (scene-linear; display value for isochrones).
    pub value: f64,
    /// The pixel written by [`render_frame`], in the settings' [`ColourOutput`].
    pub rgb: [f64; 3],
}

/// Per-frame constants of the pipeline.
struct FrameCtx<'s> {
    state: &'s FrameState,
    world_from_camera: Matrix3<f64>,
    origin: Point3<f64>,
    origin_f32: Point3<f32>,
    focal_px: f64,
    half: Vector2<f64>,
    /// One boost for the whole frame; None when it varies per pixel (rotating sensor).
    boost: Option<Boost>,
    t_receive_ps: f64,
    eta: f64,
    /// `eta / c`: flight time per metre, ps.
    eta_over_c_ps_per_m: f64,
    inv_dtau_per_ps: f64,
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

impl<'s> FrameCtx<'s> {
    fn new(scene: &RenderScene, settings: &RenderSettings, state: &'s FrameState) -> Self {
        let e = settings.effects;
        let (w, h) = (settings.width as f64, settings.height as f64);
        let focal_px = 0.5 * h / (0.5 * state.vfov_deg.to_radians()).tan();
        let per_pixel = e.rotation && state.rotation.is_some();
        let boost = if !e.needs_boost() {
            Some(Boost::identity())
        } else if per_pixel {
            None
        } else {
            Some(boost_of(&state.beta))
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
            focal_px,
            half: Vector2::new(0.5 * w, 0.5 * h),
            boost,
            t_receive_ps: t_path_ps + settings.time_offset_ps,
            eta: scene.capture.eta,
            eta_over_c_ps_per_m: flight_time_ps(scene.capture.eta, 1.0),
            inv_dtau_per_ps: 1.0 / settings.dtau_ps,
        }
    }

    #[inline(always)]
    fn trace(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
        i: usize,
        j: usize,
    ) -> PixelSample {
        let e = settings.effects;
        let (u, v) = (i as f64 + 0.5, j as f64 + 0.5);
        let offset = Vector2::new(u - self.half.x, v - self.half.y);
        let local = Vector3::new(offset.x / self.focal_px, offset.y / self.focal_px, 1.0);
        let d = self.world_from_camera * local;
        let d_camera = d * (1.0 / d.norm());
        let (boost, beta) = match self.boost {
            Some(b) => (b, b.beta_vector()),
            None => {
                let beta = self.state.pixel_beta(&offset, &self.half);
                (boost_of(&beta), beta)
            }
        };
        let (d_world, doppler) = if e.aberration {
            boost.aberrate_with_doppler(&d_camera)
        } else {
            // D of the light arriving from the world direction d: 1 / (gamma (1 + beta . d)).
            (d_camera, 1.0 / boost.inverse().doppler_factor(&d_camera))
        };
        let lambda_nm = if e.doppler {
            doppler * scene.laser_nm
        } else {
            scene.laser_nm
        };
        let mut sample = PixelSample {
            d_camera,
            d_world,
            beta,
            doppler,
            t_receive_ps: self.t_receive_ps,
            hit_m: None,
            t_emit_ps: None,
            t_arrival_ps: None,
            capture_pixel: None,
            lambda_nm,
            value: 0.0,
            rgb: [0.0; 3],
        };
        let ray = Ray::new(
            self.origin_f32,
            Vector3::new(d_world.x as f32, d_world.y as f32, d_world.z as f32),
        );
        let Some(hit) = scene.bvh.intersect(&ray, 0.0, f32::INFINITY) else {
            return sample;
        };
        let dist_m = hit.t as f64;
        let p = self.origin + d_world * dist_m;
        sample.hit_m = Some((p, dist_m));
        if let View::Isochrones(iso) = settings.view {
            let t = views::first_arrival_world_ps(scene, &p)
                + if e.unwarp {
                    flight_time_ps(self.eta, dist_m)
                } else {
                    0.0
                };
            sample.t_arrival_ps = Some(t);
            let lit = views::laser_sees(scene, &p);
            sample.rgb = views::isochrone_colour(&iso, t, lit);
            sample.value = color::luminance(sample.rgb);
            return sample;
        }
        let Some((x, y)) = scene.capture_pixel(&p, &d_world) else {
            return sample;
        };
        sample.capture_pixel = Some((x, y));
        let d_light = if e.searchlight { doppler } else { 1.0 };
        let value = match settings.view {
            View::Integrated => {
                let nt = scene.world.axis.nt;
                let total = scene.world.pixel_prefix(x, y)[nt];
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
                sample.t_emit_ps = Some(t_e);
                let window_ps = settings.dtau_ps / d_light;
                let energy = scene.emitted_energy(x, y, t_e, t_e + window_ps);
                // Radiometry::frame_value, with the division by dtau done once per frame.
                settings.radiometry.window_factor(d_light) * energy * self.inv_dtau_per_ps
            }
        };
        sample.value = value;
        let colour = match settings.colour {
            ColourOutput::LinearSrgb => color::laser_colour(lambda_nm),
            ColourOutput::Xyz => match color::monochromatic_linear_srgb(lambda_nm) {
                Some(_) => {
                    let [cx, cy, cz] = color::cmf_xyz(lambda_nm).unwrap_or([1.0; 3]);
                    [cx / cy, 1.0, cz / cy]
                }
                None => color::linear_srgb_to_xyz([1.0; 3]),
            },
        };
        sample.rgb = [value * colour[0], value * colour[1], value * colour[2]];
        sample
    }
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
        .for_each(|(j, row)| {
            for (i, px) in row.iter_mut().enumerate() {
                let s = ctx.trace(scene, settings, i, j);
                *px = [s.rgb[0] as f32, s.rgb[1] as f32, s.rgb[2] as f32];
            }
        });
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

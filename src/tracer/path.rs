//! The per-path kernel of the transient tracer (seed Eq. 1, see the parent module's doc):
//! one camera path with next-event estimation to the laser spot at each vertex, the light
//! vertex joined by the balance heuristic, Russian roulette, and the path-length window
//! outside of which a contribution lands in no bin. Shared by the transient and the steady
//! renders.

use super::binning::ResponseTable;
use super::sampling::{
    cosine_hemisphere_in, cosine_local, orthonormal_basis, uniform, uniform_pair, uniform_sphere,
    PixelSampler,
};
use super::TraceOptions;
use crate::geometry::bvh::Bvh;
use crate::geometry::Ray;
use crate::scene::{Emission, Scene};
use nalgebra::{Matrix3, Point3, Vector3};
use rand_pcg::Pcg64Mcg;

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

/// One contribution of a path: a connection to the laser spot from vertex `bounce`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Contribution {
    /// Index of the vertex that connected to the spot (1 = the first surface seen).
    pub(super) bounce: u32,
    /// Optical path length from the spot to the camera centre, metres (times eta later).
    pub(super) path_m: f64,
    /// Distance from the camera centre to the first surface of the path, metres.
    pub(super) first_m: f64,
    /// Radiance along the camera ray carried by this path.
    pub(super) value: f64,
}

/// The per-path kernel shared by the transient and steady renders. Path vertices and
/// directions are single precision, like the geometry (positions to ~1e-7 relative: 0.1 um
/// in a metre-sized scene, 3e-4 ps of flight); path lengths and contributions are summed in
/// double precision.
pub(super) struct PathKernel<'a> {
    pub(super) scene: &'a Scene,
    pub(super) bvh: &'a Bvh,
    /// Camera centre.
    pub(super) camera_m: Point3<f32>,
    /// Without lens distortion, the world direction of the ray through pixel coordinates
    /// `(u, v)` is `world_from_pixel * (u, v, 1)` normalised (`R K^-1`); `None` with
    /// distortion, which `Intrinsics::camera_ray` removes by iteration.
    pub(super) world_from_pixel: Option<Matrix3<f32>>,
    /// Laser spot and its unit normal.
    pub(super) laser_m: Point3<f32>,
    pub(super) laser_normal: Vector3<f32>,
    /// Radiant intensity towards `w` (unit, away from the spot): `intensity_scale`, times
    /// `max(0, laser_normal . w)` for cosine emission (`scene::Laser::intensity`).
    pub(super) intensity_scale: f32,
    pub(super) cosine_emission: bool,
    /// Albedo and normal's basis of each triangle of the mesh (one load per hit).
    pub(super) shading: Vec<TriangleShading>,
    pub(super) max_bounces: u32,
    pub(super) rr_start_bounce: u32,
    /// [`TraceOptions::light_vertex`].
    pub(super) light_vertex: bool,
    /// The spot's energy (its radiant intensity over the emission's direction density, for
    /// both profiles).
    pub(super) energy: f32,
    /// [`orthonormal_basis`] of `laser_normal`.
    pub(super) laser_tangent: Vector3<f32>,
    pub(super) laser_bitangent: Vector3<f32>,
}

impl PathKernel<'_> {
    /// Trace path `index` of a pixel through continuous pixel coordinates `(u, v)`; calls
    /// `sink` for each contribution that can land in `window`; returns the rays cast and what
    /// the window let it skip ([`PathKernel::trace_from`] from the scene's camera).
    #[inline(always)]
    pub(super) fn trace_path(
        &self,
        rng: &mut Pcg64Mcg,
        ld: &PixelSampler,
        index: u32,
        (u, v): (f64, f64),
        window: &PathWindow,
        sink: &mut impl FnMut(Contribution),
    ) -> PathTally {
        let dir: Vector3<f32> = match &self.world_from_pixel {
            Some(m) => (m * Vector3::new(u as f32, v as f32, 1.0)).normalize(),
            None => {
                let cam = &self.scene.camera;
                (cam.pose.world_from_camera * cam.intrinsics.camera_ray(u, v).into_inner())
                    .cast::<f32>()
            }
        };
        self.trace_from(rng, ld, index, self.camera_m, dir, window, sink)
    }

    /// Trace path `index` of a pixel from the camera centre `camera_m` along the unit world
    /// direction `dir` (what [`PathKernel::trace_path`] does for the scene's own camera; a
    /// moving camera's truth, `crate::render::truth`, starts from wherever that camera is).
    /// Contributions' path lengths end at `camera_m`. Per vertex: the hit, the connection to
    /// the spot ([`PathKernel::connect_spot`]), the light point's
    /// ([`PathKernel::connect_light_point`]), then the bounce ([`PathKernel::scatter`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn trace_from(
        &self,
        rng: &mut Pcg64Mcg,
        ld: &PixelSampler,
        index: u32,
        camera_m: Point3<f32>,
        mut dir: Vector3<f32>,
        window: &PathWindow,
        sink: &mut impl FnMut(Contribution),
    ) -> PathTally {
        let mut origin = camera_m;
        let mut path = PathState {
            bounce: 0,
            beta: 1.0,
            path_m: 0.0,
            first_m: 0.0,
        };
        let mut tally = PathTally::default();
        let (mut early_m, mut late_m) = (f64::NEG_INFINITY, f64::INFINITY);
        // With light vertices: the path's light point, and the solid-angle density of the
        // last bounce's direction, for the connection's weight against the light's strategy.
        let mut light = None;
        let mut bounce_pdf = 0.0f32;
        // How far the ray's origin lies ahead of the last vertex along the ray: bounce rays
        // start off the surface ([`RAY_OFFSET_M`] along the normal), but the path's length
        // runs from the vertex itself.
        let mut origin_ahead_m = 0.0f32;
        for bounce in 1..=self.max_bounces {
            path.bounce = bounce;
            tally.rays += 1;
            let ray = Ray::new(origin, dir);
            let Some(hit) = self.bvh.intersect(&ray, 0.0, f32::INFINITY) else {
                break;
            };
            let p = origin + dir * hit.t;
            let segment_m = hit.t + origin_ahead_m;
            path.path_m += segment_m as f64;
            if bounce == 1 {
                path.first_m = hit.t as f64;
                (early_m, late_m) = window.bounds_m(path.first_m);
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
            let v = Vertex {
                p,
                p_off: p + n * RAY_OFFSET_M,
                n,
                rho,
            };
            // Next-event estimation towards the spot, from the vertex itself.
            let to_spot = self.laser_m - p;
            let r2 = to_spot.norm_squared();
            let r = r2.sqrt();
            // This connection arrives after `path_m + r`, and so does every later one (the
            // rest of a longer path to the spot is at least the straight line): past the
            // window, the path has nothing left to give.
            let spot = ToSpot {
                to_spot,
                r2,
                r,
                arrival_m: path.path_m + r as f64,
            };
            if spot.arrival_m > late_m {
                tally.ended_late = true;
                break;
            }
            if spot.arrival_m < early_m {
                tally.skipped_early += 1;
            } else if let Some(c) =
                self.connect_spot(&v, &path, &spot, (dir, segment_m, bounce_pdf), &mut tally)
            {
                sink(c);
            }
            if bounce == self.max_bounces {
                break;
            }
            if self.light_vertex {
                if bounce == 1 {
                    light = self.light_point(ld, index, &mut tally);
                }
                if let Some(y) = &light {
                    self.connect_light_point(y, &v, &path, (early_m, late_m), &mut tally, sink);
                }
            }
            let Some(next) = self.scatter(rng, ld_local, shading, back, &v, &mut path) else {
                break;
            };
            (dir, bounce_pdf, origin_ahead_m) = next;
            origin = v.p_off;
        }
        tally
    }

    /// Next-event estimation from vertex `v` of `path` to the laser spot along `spot`: the
    /// contribution, or `None` where the spot lies within [`SHADOW_END_M`] of `v` (a spot on
    /// a surface is not lit by that surface), behind the surface, unlit in that direction, or
    /// shadowed (the shadow ray starts off the surface, parallel to the connection). With
    /// light vertices, a vertex after the first is weighted against the light's strategy by
    /// the balance heuristic: `incoming` is the last bounce's direction, the segment's length
    /// to `v` and the direction's solid-angle density.
    #[inline(always)]
    pub(super) fn connect_spot(
        &self,
        v: &Vertex,
        path: &PathState,
        spot: &ToSpot,
        (dir, segment_m, bounce_pdf): (Vector3<f32>, f32, f32),
        tally: &mut PathTally,
    ) -> Option<Contribution> {
        let far = spot.r2 > SHADOW_END_M * SHADOW_END_M;
        if !far {
            return None;
        }
        let inv_r = 1.0 / spot.r;
        let w = spot.to_spot * inv_r;
        let cos_p = v.n.dot(&w);
        let intensity = if self.cosine_emission {
            self.intensity_scale * (-self.laser_normal.dot(&w)).max(0.0)
        } else {
            self.intensity_scale
        };
        let lit = cos_p > 0.0 && intensity > 0.0;
        if !lit {
            return None;
        }
        tally.rays += 1;
        let shadow = Ray::new(v.p_off, w);
        if self.bvh.occluded(&shadow, 0.0, spot.r - SHADOW_END_M) {
            return None;
        }
        let mut value = path.beta * v.rho * FRAC_1_PI * intensity * cos_p * inv_r * inv_r;
        if path.bounce >= 2 && self.light_vertex {
            let pdf_camera = bounce_pdf * -v.n.dot(&dir) / (segment_m * segment_m);
            let pdf_light = self.emission_area_pdf(&v.p, &v.n);
            // A direction tangent to the surface (cosine 0) that the light cannot reach
            // either keeps its whole weight.
            if pdf_camera + pdf_light > 0.0 {
                value *= pdf_camera / (pdf_camera + pdf_light);
            }
        }
        Some(Contribution {
            bounce: path.bounce,
            path_m: spot.arrival_m,
            first_m: path.first_m,
            value: value as f64,
        })
    }

    /// The bounce from vertex `v` (on the back of `shading`'s triangle when `back`): the
    /// cosine-weighted continuation (BRDF * cos / pdf = rho, which `path.beta` takes), after
    /// Russian roulette from `rr_start_bounce` on; `None` where roulette ends the path. The
    /// direction comes from `ld_local` (the first two bounces' low-discrepancy points), else
    /// from the pixel's random stream (drawn after Russian roulette's, in this order).
    /// Returns the new direction, its solid-angle density and how far the next ray's origin
    /// lies ahead of `v` along it.
    #[inline(always)]
    pub(super) fn scatter(
        &self,
        rng: &mut Pcg64Mcg,
        ld_local: Option<Vector3<f32>>,
        shading: &TriangleShading,
        back: bool,
        v: &Vertex,
        path: &mut PathState,
    ) -> Option<(Vector3<f32>, f32, f32)> {
        path.beta *= v.rho;
        let mut survive = 1.0;
        if path.bounce >= self.rr_start_bounce {
            survive = path.beta.min(0.95);
            if uniform(rng) >= survive {
                return None;
            }
            path.beta /= survive;
        }
        let l = ld_local.unwrap_or_else(|| {
            let (u1, u2) = uniform_pair(rng);
            cosine_local(u1, u2)
        });
        let bounce_pdf = survive * l.z * FRAC_1_PI;
        // The basis of the flipped normal is (t, -b) (sampling::cosine_hemisphere_in).
        let b = if back {
            -shading.bitangent
        } else {
            shading.bitangent
        };
        let dir = shading.tangent * l.x + b * l.y + v.n * l.z;
        Some((dir, bounce_pdf, RAY_OFFSET_M * l.z))
    }

    /// Density, per unit area at the surface point `p` (unit normal `n`, either side), of
    /// the spot's emission ray landing there: the emission's direction density times the
    /// cosine at `p` over the squared distance. The direction density is the radiant
    /// intensity over the energy for both emission profiles (`cos / pi`, `1 / (4 pi)`).
    #[inline(always)]
    pub(super) fn emission_area_pdf(&self, p: &Point3<f32>, n: &Vector3<f32>) -> f32 {
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
    pub(super) fn light_point(
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

    /// The light's strategy for the light of `bounce + 1` bounces: vertex `v` of `path`
    /// (point `x_m`, moved off the surface `x_off`, unit normal `n_x` of the side seen,
    /// albedo `rho_x`; the path's throughput `beta` and length `path_m` so far) joined to the
    /// light point `y` by a shadow ray. Its contribution, and the camera's own (a bounce from `x`
    /// that lands on `y`, connected to the spot), are weighted by the balance heuristic of
    /// their densities per unit area at `y`, so that together they count that light once,
    /// without the camera strategy's spikes where a bounce lands next to the spot (its
    /// `1 / r^2`) nor the light strategy's where `y` is next to `x` (`1 / d^2`).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn connect_light_point(
        &self,
        y: &LightPoint,
        v: &Vertex,
        path: &PathState,
        (early_m, late_m): (f64, f64),
        tally: &mut PathTally,
        sink: &mut impl FnMut(Contribution),
    ) {
        let (x_m, x_off, n_x, rho_x) = (v.p, v.p_off, v.n, v.rho);
        let (bounce, beta, path_m, first_m) = (path.bounce, path.beta, path.path_m, path.first_m);
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

/// A vertex of a camera path: the surface point `p`, the point `p_off` moved off the surface
/// along the normal (where the next rays leave from), the unit normal `n` of the side the
/// path arrives from, and the surface's albedo `rho`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Vertex {
    pub(super) p: Point3<f32>,
    pub(super) p_off: Point3<f32>,
    pub(super) n: Vector3<f32>,
    pub(super) rho: f32,
}

/// A camera path at its current vertex: the vertex's index (1 = the first surface seen), the
/// throughput so far, the optical path length from the camera to the vertex and to the
/// path's first surface, metres.
#[derive(Clone, Copy, Debug)]
pub(super) struct PathState {
    pub(super) bounce: u32,
    pub(super) beta: f32,
    pub(super) path_m: f64,
    pub(super) first_m: f64,
}

/// The straight line from a vertex to the laser spot: the vector, its squared length and its
/// length (metres), and the path length of the light that takes it, metres.
#[derive(Clone, Copy, Debug)]
pub(super) struct ToSpot {
    pub(super) to_spot: Vector3<f32>,
    pub(super) r2: f32,
    pub(super) r: f32,
    pub(super) arrival_m: f64,
}

/// Where an emission ray from the spot lands ([`PathKernel::light_point`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct LightPoint {
    pub(super) p: Point3<f32>,
    /// `p` moved off the surface along `normal`.
    pub(super) p_off: Point3<f32>,
    /// Unit normal of the side facing the spot.
    pub(super) normal: Vector3<f32>,
    pub(super) albedo: f32,
    /// Distance from the spot, metres.
    pub(super) spot_m: f32,
    /// Density of the emission ray landing here, per unit area.
    pub(super) pdf_area: f32,
}

/// What a path needs of the triangle it hits.
#[derive(Clone, Copy, Debug)]
pub(super) struct TriangleShading {
    pub(super) albedo: f32,
    /// [`orthonormal_basis`] of the triangle's unit normal.
    pub(super) tangent: Vector3<f32>,
    pub(super) bitangent: Vector3<f32>,
}

/// What one path cost and skipped (see [`PathKernel::trace_path`]).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct PathTally {
    /// Rays cast: the camera and bounce rays plus the shadow rays.
    pub(super) rays: u64,
    /// Connections to the spot not made because they would arrive before every window.
    pub(super) skipped_early: u64,
    /// Whether the path ended because everything it could still deliver arrives after
    /// every window.
    pub(super) ended_late: bool,
}

/// The optical path lengths, metres, outside of which a contribution falls in no bin of
/// the cubes being rendered (the time responses' reach, [`ResponseTable::reach_ps`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct PathWindow {
    /// Camera-time window as path lengths.
    pub(super) camera_m: (f64, f64),
    /// World-time window as path lengths less the first segment (world time is camera time
    /// less the first segment's flight), when a world-time cube is rendered.
    pub(super) world_m: Option<(f64, f64)>,
}

impl PathWindow {
    /// No window: every contribution counts (steady-state renders).
    pub(super) const UNBOUNDED: PathWindow = PathWindow {
        camera_m: (f64::NEG_INFINITY, f64::INFINITY),
        world_m: None,
    };

    pub(super) fn new(
        camera: &ResponseTable,
        world: Option<&ResponseTable>,
        ps_per_m: f64,
    ) -> PathWindow {
        let to_m = |(a, b): (f64, f64)| (a / ps_per_m, b / ps_per_m);
        PathWindow {
            camera_m: to_m(camera.reach_ps()),
            world_m: world.map(|w| to_m(w.reach_ps())),
        }
    }

    /// Shortest and longest useful path lengths of a path whose first segment is `first_m`.
    pub(super) fn bounds_m(&self, first_m: f64) -> (f64, f64) {
        let (a, b) = self.camera_m;
        match self.world_m {
            None => (a, b),
            Some((wa, wb)) => (a.min(wa + first_m), b.max(wb + first_m)),
        }
    }
}

pub(super) fn kernel<'a>(scene: &'a Scene, bvh: &'a Bvh, opts: &TraceOptions) -> PathKernel<'a> {
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
pub(super) fn world_from_pixel(cam: &crate::scene::StreakCamera) -> Option<Matrix3<f32>> {
    let k = &cam.intrinsics;
    if k.k1 != 0.0 || k.k2 != 0.0 {
        return None;
    }
    let camera_from_pixel = k.k_matrix().try_inverse()?;
    Some((cam.pose.world_from_camera.matrix() * camera_from_pixel).cast::<f32>())
}

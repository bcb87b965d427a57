//! The tracer's paths from any camera position and direction: the kernel of [`super::trace`]
//! (seed Eq. 1, next-event estimation and light vertices alike) for a camera that is not the
//! scene's own, such as the moving camera whose direct truth `crate::render::truth` traces.
//! The caller picks the first ray and bins the contributions; this module only runs paths.

use super::path::{kernel, Contribution, PathKernel, PathWindow};
use super::sampling::PixelSampler;
use super::TraceOptions;
use crate::geometry::bvh::Bvh;
use crate::scene::Scene;
use nalgebra::{Point3, Vector3};
use rand_pcg::Pcg64Mcg;

/// One contribution of a path started by [`RayPaths::trace`]: the connection of vertex
/// `bounce` to the laser spot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RaySample {
    /// Index of the vertex that connected to the spot (1 = the first surface hit).
    pub bounce: u32,
    /// Geometric length from the spot to the path's start, metres (times `eta / c`: the
    /// light's arrival there after the pulse left the spot).
    pub path_m: f64,
    /// Distance from the path's start to its first surface, metres.
    pub first_m: f64,
    /// Radiance along the first ray carried by this path (the tracer's cube units per path).
    pub value: f64,
}

/// Which length of a path the window of [`RayPaths::trace`] bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WindowOn {
    /// The whole length `path_m`: arrival at the path's start.
    Arrival,
    /// The length up to the first surface, `path_m - first_m`: emission from that surface.
    Emission,
}

/// The tracer's path kernel, prepared once for a scene.
pub struct RayPaths<'a> {
    kernel: PathKernel<'a>,
}

impl<'a> RayPaths<'a> {
    /// Prepare paths in `scene` (`bvh` built from `scene.mesh`) with `opts`' bounces,
    /// roulette, emission and light vertices (its spp, seed, filter and outputs do not apply).
    pub fn new(scene: &'a Scene, bvh: &'a Bvh, opts: &TraceOptions) -> RayPaths<'a> {
        RayPaths {
            kernel: kernel(scene, bvh, opts),
        }
    }

    /// Trace path `index` of a pixel from `origin_m` along the unit world direction `dir`,
    /// drawing from the pixel's random stream `rng` and low-discrepancy points `ld`
    /// (dimension 0, the position in the pixel, is the caller's). `sink` gets every
    /// contribution whose length (`on`) lies in `lengths_m`; paths end once nothing they could
    /// still deliver can fall in it. Returns the rays cast.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn trace(
        &self,
        rng: &mut Pcg64Mcg,
        ld: &PixelSampler,
        index: u32,
        origin_m: Point3<f32>,
        dir: Vector3<f32>,
        (lo_m, hi_m): (f64, f64),
        on: WindowOn,
        sink: &mut impl FnMut(RaySample),
    ) -> u64 {
        // PathWindow::bounds_m: the camera window bounds `path_m`; the world window bounds
        // `path_m - first_m` (with the camera window empty, only it counts).
        let window = match on {
            WindowOn::Arrival => PathWindow {
                camera_m: (lo_m, hi_m),
                world_m: None,
            },
            WindowOn::Emission => PathWindow {
                camera_m: (f64::INFINITY, f64::NEG_INFINITY),
                world_m: Some((lo_m, hi_m)),
            },
        };
        let tally = self.kernel.trace_from(
            rng,
            ld,
            index,
            origin_m,
            dir,
            &window,
            &mut |c: Contribution| {
                sink(RaySample {
                    bounce: c.bounce,
                    path_m: c.path_m,
                    first_m: c.first_m,
                    value: c.value,
                })
            },
        );
        tally.rays
    }
}

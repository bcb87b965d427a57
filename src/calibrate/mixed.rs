//! Mixed pixels: pixels whose footprint spans many bins of path, so that the one distance
//! `femto unwarp` moves their light by (seed Eq. 2) is wrong for much of it.
//!
//! `femto unwarp` shifts each pixel's profile by `eta |p - o| / c` for the point `p` its
//! centre sees ([`super::register()`]). A pixel integrates over its footprint, and the
//! distances over it spread: across a depth edge (the top of the box in front of the wall) by
//! the depth step, on a surface seen at a grazing angle (the floor far from the camera) by
//! `r alpha tan(theta)` for a pixel of `alpha` radians at distance `r` and incidence `theta`,
//! on the built-in scene at 64 x 48 pixels tens of bins of 4 ps. The light of such a
//! pixel is smeared over those bins in camera time, and the centre's shift leaves it smeared,
//! and off centre where the footprint is lit unevenly.
//!
//! [`footprint_spread_m`] measures the spread: the largest less the smallest distance along
//! [`FOOTPRINT_RAYS`] x [`FOOTPRINT_RAYS`] rays spanning the pixel, corners included (infinite
//! where one misses the mesh: a pixel on the scene's silhouette). `femto calibrate` stores it
//! in the registration (`footprint_spread_m`); `femto unwarp` counts the pixels whose spread is
//! more than one bin of path (`c dt / eta`), and masks those whose spread exceeds
//! [`MASK_SPREAD_BINS`] bins (the renderer and the viewer leave masked pixels out).
//!
//! Why [`MASK_SPREAD_BINS`] = 4: where a footprint is lit unevenly (a shadow's edge, light
//! that grazes one side of a box), the centre of its light in time can lie anywhere in its
//! spread, up to half of it from where the centre's distance puts it; 4 bins keep that within
//! 2. Measured on the walkthrough's practice capture (the cube scene at 64 x 48 pixels, 256
//! bins of 4 ps, every realistic flaw): with the pixels spanning more than 4 bins masked
//! (1279 of 3072: the floor far from the camera, the box's sides and every silhouette), every
//! bright direct pulse of the unwarped cube has its centre at half maximum within 2.5 ps of
//! `truth_world.h5`'s (`tests/chain.rs`); at 6 or 8 bins, a column of the box's side face
//! spanning 4.2 to 4.5 bins came out 6.5 to 8.5 ps off. The footprint shrinks with the pixel:
//! at 320 x 240 a pixel spans 5 times fewer bins.

use super::Registration;
use crate::camera::Calibration;
use crate::geometry::bvh::Bvh;
use crate::geometry::Ray;
use rayon::prelude::*;

/// Rays per pixel side in [`footprint_spread_m`], spanning the pixel from edge to edge.
pub const FOOTPRINT_RAYS: usize = 5;

/// Pixels whose footprint spans more bins of path than this are masked by `femto unwarp`
/// (module doc).
pub const MASK_SPREAD_BINS: f64 = 4.0;

/// For every pixel of `reg` (cast through `cal` into `bvh`), the spread of the distances from
/// the camera centre over its footprint, metres (module doc): infinite where a ray of the
/// footprint misses the mesh, NaN for pixels that see nothing.
pub fn footprint_spread_m(cal: &Calibration, bvh: &Bvh, reg: &Registration) -> Vec<f32> {
    let o32 = cal.pose.position_m.cast::<f32>();
    let step = 1.0 / (FOOTPRINT_RAYS - 1) as f64;
    (0..reg.nx * reg.ny)
        .into_par_iter()
        .map(|i| {
            if reg.mask[i] == 0 {
                return f32::NAN;
            }
            let (x, y) = (i % reg.nx, i / reg.nx);
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for j in 0..FOOTPRINT_RAYS * FOOTPRINT_RAYS {
                let u = x as f64 + (j % FOOTPRINT_RAYS) as f64 * step;
                let v = y as f64 + (j / FOOTPRINT_RAYS) as f64 * step;
                let d = cal.world_ray(u, v).into_inner();
                let Some(hit) = bvh.intersect(&Ray::new(o32, d.cast::<f32>()), 0.0, f32::INFINITY)
                else {
                    return f32::INFINITY;
                };
                lo = lo.min(hit.t);
                hi = hi.max(hit.t);
            }
            hi - lo
        })
        .collect()
}

/// How many bins of `dt_ps` a footprint spread of `spread_m` metres spans in a medium of index
/// `eta` (infinite for an infinite spread).
pub fn spread_bins(spread_m: f32, dt_ps: f64, eta: f64) -> f64 {
    crate::units::flight_time_ps(eta, spread_m as f64) / dt_ps
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::register;
    use crate::camera::{Intrinsics, Pose};
    use crate::geometry::TriangleMesh;
    use nalgebra::{Point3, Vector3};

    /// Two axis-aligned rectangles facing +z: a wall at z = 0 filling the view (x, y in
    /// -9..9) and a step in front of it at z = `step_m` covering x in 0..9.
    fn wall_and_step(step_m: f32) -> Bvh {
        let quad = |x0: f32, x1: f32, z: f32| -> Vec<Point3<f32>> {
            [[x0, -9.0], [x1, -9.0], [x1, 9.0], [x0, 9.0]]
                .iter()
                .map(|[x, y]| Point3::new(*x, *y, z))
                .collect()
        };
        let mut positions = quad(-9.0, 9.0, 0.0);
        positions.extend(quad(0.0, 9.0, step_m));
        let triangles = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
        Bvh::new(TriangleMesh {
            positions,
            material: vec![0; triangles.len()],
            triangles,
        })
    }

    fn camera(nx: usize, ny: usize, from: Point3<f64>) -> Calibration {
        Calibration {
            intrinsics: Intrinsics::from_vfov(nx, ny, 40.0),
            pose: Pose::look_at(from, Point3::new(0.0, 0.0, 0.0), Vector3::y()).unwrap(),
            t0_ps: 0.0,
            time_scale: 1.0,
            laser_m: Point3::new(0.0, 0.5, 1.0),
            eta: 1.0,
        }
    }

    /// Where each of pixel `(x, y)`'s footprint rays meets the plane `z = z_m`: distance and
    /// the point's x, computed here independently of the BVH (ray-plane intersection).
    fn rays_to_plane(cal: &Calibration, x: usize, y: usize, z_m: f64) -> Vec<(f64, f64)> {
        let o = cal.pose.position_m;
        (0..FOOTPRINT_RAYS * FOOTPRINT_RAYS)
            .map(|j| {
                let u = x as f64 + (j % FOOTPRINT_RAYS) as f64 / 4.0;
                let v = y as f64 + (j / FOOTPRINT_RAYS) as f64 / 4.0;
                let d = cal.world_ray(u, v).into_inner();
                let t = (z_m - o.z) / d.z;
                (t, o.x + t * d.x)
            })
            .collect()
    }

    fn range(ts: impl Iterator<Item = f64> + Clone) -> f64 {
        ts.clone().fold(f64::MIN, f64::max) - ts.fold(f64::MAX, f64::min)
    }

    #[test]
    fn a_step_spans_its_depth_and_a_plane_its_obliquity() {
        let (nx, ny) = (21, 15);
        let cal = camera(nx, ny, Point3::new(0.3, 0.9, 1.6));
        let step_m = 0.2;
        let bvh = wall_and_step(step_m as f32);
        let reg = register(&cal, &bvh, nx, ny).unwrap();
        let spread = footprint_spread_m(&cal, &bvh, &reg);
        let (mut edge, mut plane) = (0, 0);
        for (i, &got) in spread.iter().enumerate() {
            let (x, y) = (i % nx, i / nx);
            // A ray meets the step's front face (nearer the camera) where that plane's point
            // has x > 0, else the wall.
            let front = rays_to_plane(&cal, x, y, step_m);
            let wall = rays_to_plane(&cal, x, y, 0.0);
            let on_front: Vec<bool> = front.iter().map(|&(_, px)| px > 0.0).collect();
            let margin = front.iter().all(|&(_, px)| px.abs() > 1e-3);
            if on_front.iter().all(|f| *f) && margin {
                let want = range(front.iter().map(|d| d.0));
                assert!(
                    (got as f64 - want).abs() < 1e-5,
                    "front {x},{y}: {got} vs {want}"
                );
                plane += 1;
            } else if on_front.iter().all(|f| !*f) && margin {
                let want = range(wall.iter().map(|d| d.0));
                assert!(
                    (got as f64 - want).abs() < 1e-5,
                    "wall {x},{y}: {got} vs {want}"
                );
                plane += 1;
            } else if margin {
                // Across the step's edge: rays on both, at least the depth between them.
                let want =
                    range(
                        front
                            .iter()
                            .zip(&wall)
                            .zip(&on_front)
                            .map(|((f, w), on)| if *on { f.0 } else { w.0 }),
                    );
                assert!(
                    (got as f64 - want).abs() < 1e-5,
                    "edge {x},{y}: {got} vs {want}"
                );
                assert!(got > 0.05, "edge {x},{y}: {got}");
                edge += 1;
            }
        }
        assert!(
            plane > nx * ny / 2 && edge >= ny / 2,
            "{plane} plane, {edge} edge pixels"
        );
        // 0.2 m of path is 667 ps: 167 bins of 4 ps.
        assert!((spread_bins(step_m as f32, 4.0, 1.0) - 166.78).abs() < 0.01);
    }

    #[test]
    fn a_pixel_partly_off_the_mesh_is_infinite_and_one_seeing_nothing_nan() {
        let (nx, ny) = (8, 6);
        let cal = camera(nx, ny, Point3::new(0.0, 0.0, 1.6));
        // Only a half-plane, x > 0: its edge x = 0 runs down the middle of the view.
        let bvh = {
            let positions: Vec<Point3<f32>> = [[0.0, -9.0], [9.0, -9.0], [9.0, 9.0], [0.0, 9.0]]
                .iter()
                .map(|[x, y]| Point3::new(*x, *y, 0.0))
                .collect();
            Bvh::new(TriangleMesh {
                positions,
                material: vec![0; 2],
                triangles: vec![[0, 1, 2], [0, 2, 3]],
            })
        };
        let reg = register(&cal, &bvh, nx, ny).unwrap();
        let spread = footprint_spread_m(&cal, &bvh, &reg);
        let (mut nan, mut infinite, mut finite) = (0, 0, 0);
        for (i, &got) in spread.iter().enumerate() {
            let (x, y) = (i % nx, i / nx);
            let rays = rays_to_plane(&cal, x, y, 0.0);
            if reg.mask[i] == 0 {
                assert!(got.is_nan(), "{x},{y}: {got}");
                nan += 1;
            } else if rays.iter().all(|&(_, px)| px > 1e-3) {
                let want = range(rays.iter().map(|d| d.0));
                assert!((got as f64 - want).abs() < 1e-5, "{x},{y}: {got} vs {want}");
                finite += 1;
            } else if rays.iter().any(|&(_, px)| px < -1e-3) {
                assert!(got.is_infinite(), "{x},{y}: {got}");
                infinite += 1;
            }
        }
        assert!(
            nan > 0 && finite > 0,
            "{nan} NaN, {infinite} infinite, {finite} finite"
        );
    }
}

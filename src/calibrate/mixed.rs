//! Mixed pixels: pixels whose footprint straddles a depth edge, so that no single distance
//! moves all of their light between the clocks (seed Eq. 2).
//!
//! `femto unwarp` shifts each pixel's profile by `eta |p - o| / c` for the point `p` its
//! centre sees ([`super::register()`]). A pixel integrates over its footprint: where that
//! footprint lies on one surface, the distances over it spread around the centre's (on a
//! plane seen at a grazing angle, by several bins at low resolution) and the centre's shift is
//! right for the footprint's light on average. Where the footprint crosses a depth edge (the
//! top of an object in front of a wall) part of the light comes from a surface at another
//! distance, and the centre's shift puts it in the wrong place: on the built-in scene at
//! 64 x 48, by up to 300 ps.
//!
//! [`off_surface_m`] measures this from the registration and the mesh: it casts
//! [`SUBPIXELS`] x [`SUBPIXELS`] rays over each pixel and takes the largest difference
//! between where a ray meets the mesh and where it would meet the plane of the centre's
//! point (its tangent plane): zero for a footprint on one flat surface however oblique, the
//! depth step for one that crosses an edge, infinite where a ray misses the mesh. `femto
//! calibrate` stores it in the registration (`footprint_off_surface_m`); `femto unwarp` masks
//! the pixels whose value exceeds one bin of path (`c dt / eta`) and counts them, and the
//! renderer and the viewer, which draw only the world cube's unmasked pixels, leave them out.

use super::Registration;
use crate::camera::Calibration;
use crate::geometry::bvh::Bvh;
use crate::geometry::Ray;
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

/// Rays per pixel side in [`off_surface_m`].
pub const SUBPIXELS: usize = 4;

/// For every pixel of `reg` (cast through `cal` into `bvh`), the largest distance along a
/// sub-pixel ray between the mesh and the tangent plane of the centre's point, metres (module
/// doc): 0 on one flat surface, infinite where a sub-pixel ray misses the mesh or runs along
/// the plane, NaN for pixels that see nothing.
pub fn off_surface_m(cal: &Calibration, bvh: &Bvh, reg: &Registration) -> Vec<f32> {
    let origin = cal.pose.position_m;
    let o32 = origin.cast::<f32>();
    (0..reg.nx * reg.ny)
        .into_par_iter()
        .map(|i| {
            if reg.mask[i] == 0 {
                return f32::NAN;
            }
            let (x, y) = (i % reg.nx, i / reg.nx);
            let p = Point3::from(reg.point_m[i]).cast::<f64>();
            let n = Vector3::from(reg.normal[i]).cast::<f64>();
            let plane = (p - origin).dot(&n);
            let mut worst = 0.0f64;
            for j in 0..SUBPIXELS * SUBPIXELS {
                let u = x as f64 + ((j % SUBPIXELS) as f64 + 0.5) / SUBPIXELS as f64;
                let v = y as f64 + ((j / SUBPIXELS) as f64 + 0.5) / SUBPIXELS as f64;
                let d = cal.world_ray(u, v).into_inner();
                let along = d.dot(&n);
                let Some(hit) = bvh.intersect(&Ray::new(o32, d.cast::<f32>()), 0.0, f32::INFINITY)
                else {
                    return f32::INFINITY;
                };
                if along.abs() < 1e-9 {
                    return f32::INFINITY;
                }
                worst = worst.max((hit.t as f64 - plane / along).abs());
            }
            worst as f32
        })
        .collect()
}

/// Whether a pixel whose footprint leaves the centre's surface by `off_m` metres straddles
/// more than one bin of `dt_ps` in a medium of index `eta`: its light would be moved to the
/// wrong bin by the centre's distance.
pub fn is_mixed(off_m: f32, dt_ps: f64, eta: f64) -> bool {
    off_m.is_infinite() || crate::units::flight_time_ps(eta, off_m as f64) > dt_ps
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::register;
    use crate::camera::{Intrinsics, Pose};
    use crate::geometry::TriangleMesh;

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

    #[test]
    fn only_pixels_across_the_step_are_off_their_surface() {
        let (nx, ny) = (21, 15);
        // Seen obliquely, so that the flat parts spread in distance over each pixel.
        let cal = camera(nx, ny, Point3::new(0.3, 0.9, 1.6));
        let bvh = wall_and_step(0.2);
        let reg = register(&cal, &bvh, nx, ny).unwrap();
        let off = off_surface_m(&cal, &bvh, &reg);
        let dt_ps = 4.0;
        let mixed: Vec<usize> = (0..nx * ny)
            .filter(|&i| is_mixed(off[i], dt_ps, 1.0))
            .collect();
        assert!(!mixed.is_empty());
        for &i in &mixed {
            // A mixed pixel has sub-pixel rays on both surfaces: its neighbours in the row
            // are on either side of the step's edge x = 0 or its front face.
            let (x, y) = (i % nx, i / nx);
            let near_edge = (x.saturating_sub(1)..=(x + 1).min(nx - 1)).any(|xx| {
                let j = y * nx + xx;
                reg.triangle[j] != reg.triangle[i] || reg.mask[j] == 0
            }) || (y.saturating_sub(1)..=(y + 1).min(ny - 1)).any(|yy| {
                let j = yy * nx + x;
                reg.triangle[j] / 2 != reg.triangle[i] / 2 || reg.mask[j] == 0
            });
            assert!(
                near_edge,
                "pixel ({x}, {y}) mixed away from an edge: {}",
                off[i]
            );
        }
        // Pixels inside one face are on their surface to float precision.
        let flat = (0..nx * ny)
            .filter(|&i| off[i].is_finite() && off[i] < 1e-4)
            .count();
        assert!(flat > nx * ny / 2, "{flat} flat pixels");
    }

    #[test]
    fn a_plane_at_a_grazing_angle_is_not_mixed() {
        let (nx, ny) = (16, 12);
        let cal = camera(nx, ny, Point3::new(0.0, 0.15, 1.5));
        let bvh = wall_and_step(0.0);
        let reg = register(&cal, &bvh, nx, ny).unwrap();
        let off = off_surface_m(&cal, &bvh, &reg);
        for i in 0..nx * ny {
            if reg.mask[i] != 0 && off[i].is_finite() {
                assert!(off[i] < 1e-4, "pixel {i}: {}", off[i]);
            }
        }
    }
}

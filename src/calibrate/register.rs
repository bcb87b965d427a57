//! Registration of a cube to its mesh: one ray per pixel centre through the calibrated camera,
//! giving for every pixel the surface point it sees, its distance to the camera centre (the
//! `|p - o|` of physics.md's `t_world = t_camera - eta |p - o| / c`), the surface normal, the
//! triangle, and a mask of the pixels that see geometry.
//!
//! Rays start at the camera centre and follow [`Calibration::world_ray`] through
//! `(i + 0.5, j + 0.5)`, distortion included. Normals are the triangle's geometric normal
//! turned to face the camera (the side the pixel sees). Pixels that see nothing have mask 0,
//! triangle `u32::MAX`, and NaN point, distance and normal.

use super::CalibrateError;
use crate::camera::Calibration;
use crate::geometry::bvh::Bvh;
use crate::geometry::Ray;
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

/// What every pixel of a cube sees, `[y][x]` order (`index = y * nx + x`).
#[derive(Clone, Debug, PartialEq)]
pub struct Registration {
    pub nx: usize,
    pub ny: usize,
    /// Camera centre the rays were cast from, mesh frame, metres.
    pub camera_m: Point3<f64>,
    /// Surface point seen by each pixel, mesh frame, metres (NaN where mask = 0).
    pub point_m: Vec<[f32; 3]>,
    /// Distance from the camera centre to that point, metres (NaN where mask = 0).
    pub dist_m: Vec<f32>,
    /// Unit geometric normal facing the camera (NaN where mask = 0).
    pub normal: Vec<[f32; 3]>,
    /// Index of the triangle seen (`u32::MAX` where mask = 0).
    pub triangle: Vec<u32>,
    /// 1 where the pixel sees geometry, 0 elsewhere.
    pub mask: Vec<u8>,
}

impl Registration {
    /// Number of pixels that see geometry.
    pub fn hit_count(&self) -> usize {
        self.mask.iter().filter(|&&m| m != 0).count()
    }

    /// Rows `y0 .. y0 + n` of this registration (a slab of a streamed cube).
    pub fn rows(&self, y0: usize, n: usize) -> Registration {
        let (a, b) = (y0 * self.nx, (y0 + n) * self.nx);
        Registration {
            nx: self.nx,
            ny: n,
            camera_m: self.camera_m,
            point_m: self.point_m[a..b].to_vec(),
            dist_m: self.dist_m[a..b].to_vec(),
            normal: self.normal[a..b].to_vec(),
            triangle: self.triangle[a..b].to_vec(),
            mask: self.mask[a..b].to_vec(),
        }
    }
}

/// One pixel's result: (point, distance, normal, triangle) or none.
type PixelHit = Option<([f32; 3], f32, [f32; 3], u32)>;

/// Cast one ray per pixel centre of an `nx x ny` cube into `bvh` through `cal`. The cube must
/// have the calibration's image size.
pub fn register(
    cal: &Calibration,
    bvh: &Bvh,
    nx: usize,
    ny: usize,
) -> Result<Registration, CalibrateError> {
    if nx != cal.intrinsics.width || ny != cal.intrinsics.height {
        return Err(CalibrateError::SizeMismatch {
            cube_nx: nx,
            cube_ny: ny,
            width: cal.intrinsics.width,
            height: cal.intrinsics.height,
        });
    }
    let origin = cal.pose.position_m.cast::<f32>();
    let rows: Vec<Vec<PixelHit>> = (0..ny)
        .into_par_iter()
        .map(|y| {
            (0..nx)
                .map(|x| {
                    let dir = cal.world_ray(x as f64 + 0.5, y as f64 + 0.5).into_inner();
                    let ray = Ray::new(origin, dir.cast::<f32>());
                    let hit = bvh.intersect(&ray, 0.0, f32::INFINITY)?;
                    let p = ray.at(hit.t);
                    let n: Vector3<f32> = if hit.normal.dot(&ray.dir) > 0.0 {
                        -hit.normal
                    } else {
                        hit.normal
                    };
                    Some(([p.x, p.y, p.z], hit.t, [n.x, n.y, n.z], hit.triangle))
                })
                .collect()
        })
        .collect();
    let count = nx * ny;
    let mut reg = Registration {
        nx,
        ny,
        camera_m: cal.pose.position_m,
        point_m: Vec::with_capacity(count),
        dist_m: Vec::with_capacity(count),
        normal: Vec::with_capacity(count),
        triangle: Vec::with_capacity(count),
        mask: Vec::with_capacity(count),
    };
    for hit in rows.into_iter().flatten() {
        match hit {
            Some((p, d, n, tri)) => {
                reg.point_m.push(p);
                reg.dist_m.push(d);
                reg.normal.push(n);
                reg.triangle.push(tri);
                reg.mask.push(1);
            }
            None => {
                reg.point_m.push([f32::NAN; 3]);
                reg.dist_m.push(f32::NAN);
                reg.normal.push([f32::NAN; 3]);
                reg.triangle.push(u32::MAX);
                reg.mask.push(0);
            }
        }
    }
    Ok(reg)
}

//! A capture camera and a mesh for a cube that knows only the wall point each pixel sees (a
//! y-tal capture, a confocal scan of a relay wall): what `femto render` and `femto view` use
//! when they are given no calibration and no mesh.
//!
//! The renderer projects a surface point into the capture camera to find the pixel whose light
//! it shows (the seed's Sec. 3). A regular planar grid of wall points, `p(x, y) = a + x e_x +
//! y e_y` for pixel `(x, y)`, is exactly the image of a pinhole camera looking straight at the
//! plane: placed on the plane's normal through the grid's centre, at the distance `D` of the
//! grid's larger side (a field of view near 53 degrees), with focal lengths `D / |e_x|` and
//! `D / |e_y|` pixels and its principal point at the image centre, it maps every grid point to
//! its own pixel centre. The mesh is the rectangle the pixels cover (one pixel's margin of half
//! a step around the grid points). Its side of the plane is the one where `e_x x e_y` points
//! away from the camera (camera x along `e_x`, y along `e_y`, z forward): a wall seen from
//! behind holds the same diffuse light.
//!
//! Grids that are not regular and planar (a step that varies by more than a quarter of
//! itself, axes more than 1 % from orthogonal, a pixel missing) are refused: such a capture
//! needs its own calibration and mesh.

use super::tal::{LaserSpot, TalGeometry};
use crate::camera::{Calibration, Intrinsics, Pose};
use crate::geometry::TriangleMesh;
use nalgebra::{Matrix3, Point3, Rotation3, Vector3};

/// Largest distance of a grid point from the fitted grid, as a fraction of the smaller step.
const MAX_OFF_GRID: f64 = 0.25;

/// Largest cosine between the two grid axes.
const MAX_AXIS_COSINE: f64 = 0.01;

/// The capture camera and the wall rectangle of `geo`'s sensor grid (`nx` x `ny` pixels,
/// `[y][x]`); `Err` says in words why the grid cannot be seen by one pinhole camera.
pub fn wall_view(
    geo: &TalGeometry,
    nx: usize,
    ny: usize,
) -> Result<(Calibration, TriangleMesh), String> {
    if nx < 2 || ny < 2 {
        return Err(format!(
            "a grid of {nx} x {ny} wall points spans no plane (2 x 2 at least)"
        ));
    }
    let point = |x: usize, y: usize| Vector3::from(geo.sensor_grid_m[y * nx + x]);
    if let Some(p) = geo
        .sensor_grid_m
        .iter()
        .position(|p| p.iter().any(|c| !c.is_finite()))
    {
        return Err(format!(
            "wall point of pixel ({}, {}) is not a number",
            p % nx,
            p / nx
        ));
    }
    // Mean steps along x and y, and the grid's origin a = mean(p) - mean(x) e_x - mean(y) e_y.
    let mut ex = Vector3::zeros();
    let mut ey = Vector3::zeros();
    let mut mean = Vector3::zeros();
    for y in 0..ny {
        for x in 0..nx {
            mean += point(x, y);
            if x + 1 < nx {
                ex += point(x + 1, y) - point(x, y);
            }
            if y + 1 < ny {
                ey += point(x, y + 1) - point(x, y);
            }
        }
    }
    let ex = ex / ((nx - 1) * ny) as f64;
    let ey = ey / (nx * (ny - 1)) as f64;
    let mean = mean / (nx * ny) as f64;
    let (sx, sy) = (ex.norm(), ey.norm());
    if !(sx > 0.0 && sy > 0.0) {
        return Err("the wall points do not step along both axes".into());
    }
    let cosine = ex.dot(&ey) / (sx * sy);
    if cosine.abs() > MAX_AXIS_COSINE {
        return Err(format!(
            "the grid's axes are {:.2} degrees from orthogonal",
            90.0 - cosine.acos().to_degrees()
        ));
    }
    let (xc, yc) = ((nx - 1) as f64 / 2.0, (ny - 1) as f64 / 2.0);
    let centre = mean;
    let on_grid = |x: usize, y: usize| centre + (x as f64 - xc) * ex + (y as f64 - yc) * ey;
    let tolerance = MAX_OFF_GRID * sx.min(sy);
    for y in 0..ny {
        for x in 0..nx {
            let off = (point(x, y) - on_grid(x, y)).norm();
            if off > tolerance {
                return Err(format!(
                    "wall point of pixel ({x}, {y}) is {off:.3e} m off the regular planar grid \
                     (steps {sx:.3e} and {sy:.3e} m)"
                ));
            }
        }
    }
    let cam_x = ex / sx;
    let cam_y = (ey - cam_x * ey.dot(&cam_x)).normalize();
    let cam_z = cam_x.cross(&cam_y);
    let distance_m = (nx as f64 * sx).max(ny as f64 * sy);
    let position = Point3::from(centre - distance_m * cam_z);
    let pose = Pose {
        world_from_camera: Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[
            cam_x, cam_y, cam_z,
        ])),
        position_m: position,
    };
    let intrinsics = Intrinsics {
        width: nx,
        height: ny,
        fx: distance_m / sx,
        fy: distance_m / sy,
        cx: nx as f64 / 2.0,
        cy: ny as f64 / 2.0,
        k1: 0.0,
        k2: 0.0,
    };
    let laser = match geo.laser_spot_m {
        LaserSpot::Single(spot) => Point3::from(spot),
        LaserSpot::Confocal => Point3::from(centre),
    };
    let calibration = Calibration {
        intrinsics,
        pose,
        t0_ps: geo.t_spot_ps,
        time_scale: geo.time_scale,
        laser_m: laser,
        eta: 1.0,
    };
    let corner = |u: f64, v: f64| {
        let p = centre + (u - xc) * ex + (v - yc) * ey;
        Point3::new(p.x as f32, p.y as f32, p.z as f32)
    };
    let (u1, v1) = (nx as f64 - 0.5, ny as f64 - 0.5);
    let mesh = TriangleMesh {
        positions: vec![
            corner(-0.5, -0.5),
            corner(u1, -0.5),
            corner(u1, v1),
            corner(-0.5, v1),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        material: vec![0, 0],
    };
    Ok((calibration, mesh))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(nx: usize, ny: usize, step: impl Fn(usize, usize) -> [f64; 3]) -> TalGeometry {
        TalGeometry {
            sensor_grid_m: (0..nx * ny).map(|p| step(p % nx, p / nx)).collect(),
            sensor_normals: None,
            sensor_m: [0.0; 3],
            laser_origin_m: [0.0; 3],
            laser_spot_m: LaserSpot::Confocal,
            t_spot_ps: 5.0,
            time_scale: 1.0,
        }
    }

    /// A tilted, off-centre rectangular grid: every wall point projects to its pixel centre.
    #[test]
    fn every_wall_point_projects_to_its_pixel_centre() {
        let (nx, ny) = (7, 4);
        let r = Rotation3::from_euler_angles(0.3, -0.2, 0.7);
        let geo = grid(nx, ny, |x, y| {
            let p = r * Vector3::new(0.05 * x as f64, 0.08 * y as f64, 0.0)
                + Vector3::new(1.0, -2.0, 3.0);
            p.into()
        });
        let (cal, mesh) = wall_view(&geo, nx, ny).unwrap();
        for y in 0..ny {
            for x in 0..nx {
                let (u, v) = cal
                    .project(&Point3::from(geo.sensor_grid_m[y * nx + x]))
                    .unwrap();
                assert!((u - (x as f64 + 0.5)).abs() < 1e-9, "({x}, {y}): u {u}");
                assert!((v - (y as f64 + 0.5)).abs() < 1e-9, "({x}, {y}): v {v}");
            }
        }
        // The mesh's corners project to the image's corners.
        let (u, v) = cal.project(&mesh.positions[2].cast::<f64>()).unwrap();
        assert!((u - nx as f64).abs() < 1e-4 && (v - ny as f64).abs() < 1e-4);
        assert_eq!(cal.t0_ps, 5.0);
    }

    #[test]
    fn grids_one_camera_cannot_see_are_refused() {
        let flat = |x: usize, y: usize| [0.1 * x as f64, 0.1 * y as f64, 0.0];
        assert!(wall_view(&grid(1, 4, flat), 1, 4).is_err());
        let mut g = grid(3, 3, flat);
        g.sensor_grid_m[4][2] = 0.05;
        let e = wall_view(&g, 3, 3).unwrap_err();
        assert!(e.contains("pixel (1, 1)"), "{e}");
        g.sensor_grid_m[4][2] = f64::NAN;
        assert!(wall_view(&g, 3, 3).unwrap_err().contains("not a number"));
        let skewed = grid(3, 3, |x, y| {
            [0.1 * x as f64 + 0.05 * y as f64, 0.1 * y as f64, 0.0]
        });
        assert!(wall_view(&skewed, 3, 3)
            .unwrap_err()
            .contains("from orthogonal"));
    }
}

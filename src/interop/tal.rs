//! A y-tal capture (`tal.io.NLOSCaptureData`, `H_format = T_Sx_Sy`: one laser point, or a
//! confocal scan) in memory, and its conversion to and from a femto cube with the geometry
//! y-tal needs.
//!
//! Axes: y-tal's `H` is `(T, Sx, Sy)`, femto's cube `[y][x][t]`, so `H[t, x, y] =
//! cube[y, x, t]`; `sensor_grid_xyz[x, y] = point_m[y, x]`. Time: y-tal's `t_start` and
//! `delta_t` are optical path lengths in metres; bin `i` of both covers `[t_start + i delta_t,
//! t_start + (i + 1) delta_t)` (mitransient's film bins by `floor((opl - start) / width)`,
//! femto's bins are half-open the same way). With `t_accounts_first_and_last_bounces =
//! False` the path counts from the laser spot to the sensor point: femto's world time minus
//! the time the pulse leaves the spot. With `True` it adds the first bounce (laser origin to
//! spot) and the last (sensor point to the sensor origin): femto's camera time, for a camera
//! at the sensor origin, plus the first bounce.
//!
//! Confocal captures ([`LaserSpot::Confocal`]: the laser and the sensor look at the same wall
//! point, pixel by pixel, y-tal's `laser_grid_xyz` equal to `sensor_grid_xyz`): there is no
//! one spot whose first bounce could be a constant, so femto's camera time of a confocal cube
//! counts from the pulse leaving the laser's origin and holds both wall legs (laser origin to
//! the pixel's point, the point to the sensor); world time counts from the pulse at the pixel's
//! own wall point (`femto unwarp` removes both legs). Neither conversion adds a first bounce:
//! y-tal's `t_accounts_first_and_last_bounces = True` is the camera-time cube as it is.

use crate::cube::{Cube, TimeAxis, TimeFrame};
use crate::store::registration::StoredRegistration;
use crate::units::C_M_PER_PS;

/// Name of the cube group that keeps a y-tal capture's geometry (written by `femto ingest`,
/// read by `femto export --to tal` when the cube has no registration).
pub const GROUP: &str = "tal";

/// Where the laser points on the wall.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LaserSpot {
    /// One spot for every pixel, metres.
    Single([f64; 3]),
    /// Each pixel's own wall point (a confocal scan): y-tal's `laser_grid_xyz` is the sensor
    /// grid.
    Confocal,
}

impl LaserSpot {
    /// Whether this is a confocal scan.
    pub fn is_confocal(self) -> bool {
        self == LaserSpot::Confocal
    }
}

/// A capture as y-tal holds it: a grid of sensor points and one laser point, or a laser point
/// per sensor point (confocal).
#[derive(Clone, Debug, PartialEq)]
pub struct TalCapture {
    /// Time bins (`T`).
    pub nt: usize,
    /// Sensor grid size (`Sx`, `Sy`).
    pub sx: usize,
    pub sy: usize,
    /// `H`, shape `(T, Sx, Sy)`, C order.
    pub h: Vec<f32>,
    /// Bin width, metres of optical path.
    pub delta_t_m: f64,
    /// Start of bin 0, metres of optical path.
    pub t_start_m: f64,
    /// Whether the path lengths include laser origin to spot and sensor point to sensor origin.
    pub t_accounts_first_and_last_bounces: bool,
    /// The sensor's own origin, metres.
    pub sensor_xyz_m: [f64; 3],
    /// Sensor points on the relay wall, `(Sx, Sy)`, metres.
    pub sensor_grid_xyz_m: Vec<[f64; 3]>,
    /// Their normals, `(Sx, Sy)`, when known.
    pub sensor_grid_normals: Option<Vec<[f64; 3]>>,
    /// The laser's own origin (not the spot), metres.
    pub laser_xyz_m: [f64; 3],
    /// The laser spot on the wall, metres, or the sensor grid itself (confocal).
    pub laser_grid_xyz_m: LaserSpot,
}

/// What a cube needs besides its values to become a y-tal capture, per pixel `[y][x]`.
#[derive(Clone, Debug, PartialEq)]
pub struct TalGeometry {
    /// Surface point seen by each pixel, `[y][x]`, metres (NaN: none).
    pub sensor_grid_m: Vec<[f64; 3]>,
    /// Unit normals, `[y][x]`, when known.
    pub sensor_normals: Option<Vec<[f64; 3]>>,
    /// The sensor (camera) centre, metres.
    pub sensor_m: [f64; 3],
    /// The laser's own origin, metres.
    pub laser_origin_m: [f64; 3],
    /// The laser spot, metres, or each pixel's own point (confocal).
    pub laser_spot_m: LaserSpot,
    /// Cube time at which the pulse leaves the spot (confocal: the laser's origin), ps.
    pub t_spot_ps: f64,
    /// Cube time units per true picosecond.
    pub time_scale: f64,
}

fn dist_m(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

impl TalGeometry {
    /// The first bounce, laser origin to spot, metres, that y-tal's camera clock adds to
    /// femto's; 0 for a confocal scan, whose camera time holds its first bounce already.
    pub fn first_bounce_m(&self) -> f64 {
        match self.laser_spot_m {
            LaserSpot::Single(spot) => dist_m(self.laser_origin_m, spot),
            LaserSpot::Confocal => 0.0,
        }
    }

    /// The optical path, metres, that separates the camera clock from the world clock at
    /// pixel `p` (`[y][x]` index), for a sensor and a laser in a medium of index 1: the last
    /// bounce (wall point to sensor) and, for a confocal scan, the pixel's own first bounce
    /// (laser origin to wall point). NaN where the pixel sees nothing.
    pub fn clock_path_m(&self, p: usize) -> f64 {
        let point = self.sensor_grid_m[p];
        let last = dist_m(point, self.sensor_m);
        match self.laser_spot_m {
            LaserSpot::Single(_) => last,
            LaserSpot::Confocal => last + dist_m(self.laser_origin_m, point),
        }
    }

    /// The geometry of a cube's registration: the points and normals its pixels see, its
    /// camera centre as the sensor, its calibration's laser spot, `t0_ps` and `time_scale`,
    /// and `laser_origin_m`, which no calibration records.
    pub fn from_registration(stored: &StoredRegistration, laser_origin_m: [f64; 3]) -> TalGeometry {
        let reg = &stored.registration;
        let cal = &stored.calibration;
        let wide =
            |v: &[[f32; 3]]| -> Vec<[f64; 3]> { v.iter().map(|p| p.map(f64::from)).collect() };
        TalGeometry {
            sensor_grid_m: wide(&reg.point_m),
            sensor_normals: Some(wide(&reg.normal)),
            sensor_m: reg.camera_m.coords.into(),
            laser_origin_m,
            laser_spot_m: LaserSpot::Single(cal.laser_m.coords.into()),
            t_spot_ps: cal.t0_ps,
            time_scale: cal.time_scale,
        }
    }
}

impl TalCapture {
    /// The capture of `cube` seen with `geo` (one entry per pixel, `[y][x]`): a world-time
    /// cube gives `t_accounts_first_and_last_bounces = False`, a camera-time cube `True` with
    /// the first bounce added.
    pub fn from_cube(cube: &Cube, geo: &TalGeometry) -> TalCapture {
        let (nx, ny, nt) = (cube.nx, cube.ny, cube.axis.nt);
        assert_eq!(
            geo.sensor_grid_m.len(),
            nx * ny,
            "one sensor point per pixel"
        );
        let mut h = vec![0.0f32; nt * nx * ny];
        for y in 0..ny {
            for x in 0..nx {
                let profile = &cube.data[(y * nx + x) * nt..][..nt];
                for (t, &v) in profile.iter().enumerate() {
                    h[(t * nx + x) * ny + y] = v;
                }
            }
        }
        let to_xy = |v: &[[f64; 3]]| -> Vec<[f64; 3]> {
            let mut out = vec![[0.0; 3]; nx * ny];
            for y in 0..ny {
                for x in 0..nx {
                    out[x * ny + y] = v[y * nx + x];
                }
            }
            out
        };
        let camera = cube.frame == TimeFrame::Camera;
        let opl_m = |t_ps: f64| C_M_PER_PS * (t_ps - geo.t_spot_ps) / geo.time_scale;
        TalCapture {
            nt,
            sx: nx,
            sy: ny,
            h,
            delta_t_m: C_M_PER_PS * cube.axis.dt_ps / geo.time_scale,
            t_start_m: opl_m(cube.axis.t0_ps) + if camera { geo.first_bounce_m() } else { 0.0 },
            t_accounts_first_and_last_bounces: camera,
            sensor_xyz_m: geo.sensor_m,
            sensor_grid_xyz_m: to_xy(&geo.sensor_grid_m),
            sensor_grid_normals: geo.sensor_normals.as_deref().map(to_xy),
            laser_xyz_m: geo.laser_origin_m,
            laser_grid_xyz_m: geo.laser_spot_m,
        }
    }

    /// The cube of this capture (`Sx` columns, `Sy` rows) and its geometry; the inverse of
    /// [`TalCapture::from_cube`] for a geometry whose pulse leaves the spot at 0 ps.
    pub fn to_cube(&self) -> (Cube, TalGeometry) {
        let (nx, ny, nt) = (self.sx, self.sy, self.nt);
        let mut data = vec![0.0f32; nt * nx * ny];
        for t in 0..nt {
            for x in 0..nx {
                for y in 0..ny {
                    data[(y * nx + x) * nt + t] = self.h[(t * nx + x) * ny + y];
                }
            }
        }
        let to_yx = |v: &[[f64; 3]]| -> Vec<[f64; 3]> {
            let mut out = vec![[0.0; 3]; nx * ny];
            for x in 0..nx {
                for y in 0..ny {
                    out[y * nx + x] = v[x * ny + y];
                }
            }
            out
        };
        let geo = TalGeometry {
            sensor_grid_m: to_yx(&self.sensor_grid_xyz_m),
            sensor_normals: self.sensor_grid_normals.as_deref().map(to_yx),
            sensor_m: self.sensor_xyz_m,
            laser_origin_m: self.laser_xyz_m,
            laser_spot_m: self.laser_grid_xyz_m,
            t_spot_ps: 0.0,
            time_scale: 1.0,
        };
        let camera = self.t_accounts_first_and_last_bounces;
        let first_m = if camera { geo.first_bounce_m() } else { 0.0 };
        let axis = TimeAxis {
            t0_ps: (self.t_start_m - first_m) / C_M_PER_PS,
            dt_ps: self.delta_t_m / C_M_PER_PS,
            nt,
        };
        let frame = if camera {
            TimeFrame::Camera
        } else {
            TimeFrame::World
        };
        let cube = Cube {
            nx,
            ny,
            axis,
            frame,
            data,
            mask: None,
        };
        (cube, geo)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry(nx: usize, ny: usize) -> TalGeometry {
        TalGeometry {
            sensor_grid_m: (0..nx * ny)
                .map(|i| [(i % nx) as f64 * 0.1, (i / nx) as f64 * 0.2, 1.0])
                .collect(),
            sensor_normals: None,
            sensor_m: [0.0, 0.0, -1.0],
            laser_origin_m: [0.3, 0.4, 0.0],
            laser_spot_m: LaserSpot::Single([0.0, 0.0, 0.0]),
            t_spot_ps: 100.0,
            time_scale: 1.0,
        }
    }

    fn cube(frame: TimeFrame) -> Cube {
        let (nx, ny, nt) = (3, 2, 4);
        Cube {
            nx,
            ny,
            axis: TimeAxis {
                t0_ps: 110.0,
                dt_ps: 2.0,
                nt,
            },
            frame,
            data: (0..nx * ny * nt).map(|i| i as f32).collect(),
            mask: None,
        }
    }

    #[test]
    fn h_is_the_cube_as_t_sx_sy_and_the_clock_is_optical_path_from_the_spot() {
        let c = cube(TimeFrame::World);
        let cap = TalCapture::from_cube(&c, &geometry(3, 2));
        assert_eq!((cap.nt, cap.sx, cap.sy), (4, 3, 2));
        // H[t=1, x=2, y=1] = cube[y=1, x=2, t=1] = (1 * 3 + 2) * 4 + 1.
        assert_eq!(cap.h[(3 + 2) * 2 + 1], 21.0);
        // Sensor point of pixel (x=2, y=1).
        assert_eq!(cap.sensor_grid_xyz_m[2 * 2 + 1], [0.2, 0.2, 1.0]);
        // 10 ps after the pulse leaves the spot: 10 ps of light, 2.998 mm.
        assert!((cap.t_start_m - 10.0 * 2.99792458e-4).abs() < 1e-15);
        assert!((cap.delta_t_m - 2.0 * 2.99792458e-4).abs() < 1e-15);
        assert!(!cap.t_accounts_first_and_last_bounces);
        // Camera time: the first bounce (0.5 m, a 3-4-5 triangle) is added.
        let cap = TalCapture::from_cube(&cube(TimeFrame::Camera), &geometry(3, 2));
        assert!(cap.t_accounts_first_and_last_bounces);
        assert!((cap.t_start_m - (10.0 * 2.99792458e-4 + 0.5)).abs() < 1e-12);
    }

    #[test]
    fn capture_to_cube_inverts_cube_to_capture() {
        for frame in [TimeFrame::World, TimeFrame::Camera] {
            let mut geo = geometry(3, 2);
            geo.t_spot_ps = 0.0;
            let c = cube(frame);
            let (back, g) = TalCapture::from_cube(&c, &geo).to_cube();
            assert_eq!(back.data, c.data);
            assert_eq!(back.frame, frame);
            assert!((back.axis.t0_ps - c.axis.t0_ps).abs() < 1e-9);
            assert!((back.axis.dt_ps - c.axis.dt_ps).abs() < 1e-12);
            assert_eq!(g.sensor_grid_m, geo.sensor_grid_m);
            assert_eq!(g.laser_origin_m, geo.laser_origin_m);
        }
    }

    #[test]
    fn a_confocal_capture_adds_no_first_bounce_and_its_clock_path_holds_both_legs() {
        let mut geo = geometry(3, 2);
        geo.laser_spot_m = LaserSpot::Confocal;
        geo.t_spot_ps = 0.0;
        assert_eq!(geo.first_bounce_m(), 0.0);
        for frame in [TimeFrame::World, TimeFrame::Camera] {
            let c = cube(frame);
            let cap = TalCapture::from_cube(&c, &geo);
            assert_eq!(cap.laser_grid_xyz_m, LaserSpot::Confocal);
            // 110 ps of light from the laser's origin (camera) or the wall point (world).
            assert!((cap.t_start_m - 110.0 * C_M_PER_PS).abs() < 1e-15);
            let (back, g) = cap.to_cube();
            assert_eq!(back.data, c.data);
            assert_eq!(back.frame, frame);
            assert!((back.axis.t0_ps - c.axis.t0_ps).abs() < 1e-9);
            assert_eq!(g.laser_spot_m, LaserSpot::Confocal);
        }
        // Pixel (x 2, y 1) sees (0.2, 0.2, 1): to the sensor (0, 0, -1) and from the laser's
        // origin (0.3, 0.4, 0).
        let p = nalgebra::Vector3::<f64>::new(0.2, 0.2, 1.0);
        let want = (p - nalgebra::Vector3::new(0.0, 0.0, -1.0)).norm()
            + (p - nalgebra::Vector3::new(0.3, 0.4, 0.0)).norm();
        assert!((geo.clock_path_m(3 + 2) - want).abs() < 1e-12);
        geo.laser_spot_m = LaserSpot::Single([0.0; 3]);
        let last = (p - nalgebra::Vector3::new(0.0, 0.0, -1.0)).norm();
        assert!((geo.clock_path_m(3 + 2) - last).abs() < 1e-12);
    }
}

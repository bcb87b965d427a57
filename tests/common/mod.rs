//! Shared fixtures of the renderer's tests and benchmark: small meshes built from primitives,
//! synthetic world-time cubes made by casting the capture camera's pixel rays, and an
//! independent Lorentz boost of photon 4-momenta (`lorentz`).
#![allow(dead_code)]

pub mod lorentz;

use femto::camera::{Calibration, Intrinsics, Pose};
use femto::cube::{Cube, TimeAxis, TimeFrame};
use femto::geometry::bvh::Bvh;
use femto::geometry::{Ray, TriangleMesh};
use femto::units::C_M_PER_PS;
use nalgebra::{Point3, Vector3};

/// A quad as two triangles (corners in order around the quad).
pub fn quad(c: [[f32; 3]; 4]) -> TriangleMesh {
    TriangleMesh {
        positions: c.iter().map(|p| Point3::new(p[0], p[1], p[2])).collect(),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        material: vec![0, 0],
    }
}

/// The plane z = 0, `half` metres in each direction from the origin.
pub fn wall_z0(half: f32) -> TriangleMesh {
    quad([
        [-half, -half, 0.0],
        [half, -half, 0.0],
        [half, half, 0.0],
        [-half, half, 0.0],
    ])
}

/// An axis-aligned box (12 triangles).
pub fn box_mesh(min: [f32; 3], max: [f32; 3]) -> TriangleMesh {
    let p = |x: usize, y: usize, z: usize| {
        Point3::new(
            if x == 0 { min[0] } else { max[0] },
            if y == 0 { min[1] } else { max[1] },
            if z == 0 { min[2] } else { max[2] },
        )
    };
    let mut positions = Vec::new();
    for z in 0..2 {
        for y in 0..2 {
            for x in 0..2 {
                positions.push(p(x, y, z));
            }
        }
    }
    // Vertex index x + 2 y + 4 z.
    let faces = [
        [0, 2, 3, 1], // z = min
        [4, 5, 7, 6], // z = max
        [0, 1, 5, 4], // y = min
        [2, 6, 7, 3], // y = max
        [0, 4, 6, 2], // x = min
        [1, 3, 7, 5], // x = max
    ];
    let mut triangles = Vec::new();
    for f in faces {
        triangles.push([f[0], f[1], f[2]]);
        triangles.push([f[0], f[2], f[3]]);
    }
    let n = triangles.len();
    TriangleMesh {
        positions,
        triangles,
        material: vec![0; n],
    }
}

/// The cube scene: a 4 m x 2 m floor (y = 0), a back wall at z = -1, and a 0.4 m box on the
/// floor in front of the wall.
pub fn cube_scene_mesh() -> TriangleMesh {
    let mut mesh = quad([
        [-2.0, 0.0, -1.0],
        [-2.0, 0.0, 1.0],
        [2.0, 0.0, 1.0],
        [2.0, 0.0, -1.0],
    ]);
    mesh.append(
        &quad([
            [-2.0, 0.0, -1.0],
            [2.0, 0.0, -1.0],
            [2.0, 2.0, -1.0],
            [-2.0, 2.0, -1.0],
        ]),
        1,
    );
    mesh.append(&box_mesh([-0.2, 0.0, -0.3], [0.2, 0.4, 0.1]), 2);
    mesh
}

/// A capture camera of the cube scene: `width x height`, 40 degree vertical field of view,
/// 2.2 m in front of the box, laser spot up and to the left, cube time 100 ps when the pulse
/// leaves the spot.
pub fn cube_scene_calibration(width: usize, height: usize) -> Calibration {
    Calibration {
        intrinsics: Intrinsics::from_vfov(width, height, 40.0),
        pose: Pose::look_at(
            Point3::new(0.1, 0.7, 2.2),
            Point3::new(0.0, 0.35, -0.4),
            Vector3::y(),
        )
        .unwrap(),
        t0_ps: 100.0,
        time_scale: 1.0,
        laser_m: Point3::new(-0.6, 1.2, 0.6),
        eta: 1.0,
    }
}

/// A capture camera at `position` looking at `target` (up +y), square pixels.
pub fn calibration(
    width: usize,
    height: usize,
    vfov_deg: f64,
    position: Point3<f64>,
    target: Point3<f64>,
) -> Calibration {
    Calibration {
        intrinsics: Intrinsics::from_vfov(width, height, vfov_deg),
        pose: Pose::look_at(position, target, Vector3::y()).unwrap(),
        t0_ps: 0.0,
        time_scale: 1.0,
        laser_m: Point3::new(0.0, 0.0, 1.0),
        eta: 1.0,
    }
}

/// First hit of each capture pixel's centre ray: `[y][x]`, point and unit normal.
pub fn capture_hits(cal: &Calibration, bvh: &Bvh) -> Vec<Option<(Point3<f64>, Vector3<f64>)>> {
    let k = &cal.intrinsics;
    let o = cal.pose.position_m;
    let mut out = Vec::with_capacity(k.width * k.height);
    for y in 0..k.height {
        for x in 0..k.width {
            let d = cal.world_ray(x as f64 + 0.5, y as f64 + 0.5);
            let ray = Ray::new(
                Point3::new(o.x as f32, o.y as f32, o.z as f32),
                Vector3::new(d.x as f32, d.y as f32, d.z as f32),
            );
            out.push(bvh.intersect(&ray, 0.0, f32::INFINITY).map(|h| {
                let n = Vector3::new(h.normal.x as f64, h.normal.y as f64, h.normal.z as f64);
                (o + d.into_inner() * h.t as f64, n)
            }));
        }
    }
    out
}

/// A world-time cube of the capture camera `cal`: bin `i` of pixel `(x, y)` holds
/// `energy(point, normal, t_start, t_end)`, the signal integrated over the bin's **physical
/// world** times (cube time minus `cal.t0_ps`), for the point the pixel sees; zero where
/// it sees nothing.
pub fn world_cube(
    cal: &Calibration,
    bvh: &Bvh,
    axis: TimeAxis,
    energy: impl Fn(&Point3<f64>, &Vector3<f64>, f64, f64) -> f64,
) -> Cube {
    let k = &cal.intrinsics;
    let hits = capture_hits(cal, bvh);
    let mut cube = Cube::zeros(k.width, k.height, axis, TimeFrame::World);
    for y in 0..k.height {
        for x in 0..k.width {
            if let Some((p, n)) = hits[y * k.width + x] {
                let prof = cube.profile_mut(x, y);
                for (i, v) in prof.iter_mut().enumerate() {
                    let a = axis.bin_start_ps(i) - cal.t0_ps;
                    *v = energy(&p, &n, a, a + axis.dt_ps) as f32;
                }
            }
        }
    }
    cube
}

/// Single-bounce light in flight: a Gaussian pulse of `sigma_ps` leaves the laser spot at world
/// time 0 and reaches `p` at `|laser - p| / c`, with the irradiance of a point source on a
/// Lambertian surface (`cos / r^2`, shadows ignored). Energy per bin from the pulse density
/// at the bin centre.
pub fn single_bounce_energy(
    cal: &Calibration,
    sigma_ps: f64,
) -> impl Fn(&Point3<f64>, &Vector3<f64>, f64, f64) -> f64 {
    let laser = cal.laser_m;
    move |p, n, a, b| {
        let to_laser = laser - p;
        let r = to_laser.norm();
        let cos = (n.dot(&to_laser) / r).abs();
        let t_arrive = r / C_M_PER_PS;
        let t = 0.5 * (a + b) - t_arrive;
        let density = (-(t * t) / (2.0 * sigma_ps * sigma_ps)).exp()
            / (sigma_ps * (2.0 * std::f64::consts::PI).sqrt());
        cos / (r * r) * density * (b - a)
    }
}

/// A world-time cube as the unwarp of a streak capture leaves it. Capture pixel `(x, y)`,
/// whose point lies `r` from the capture camera, recorded only the physical camera times
/// `t_cam_ps.0 ..= t_cam_ps.1` (cube time minus `cal.t0_ps`), which are the world times
/// `t_cam_ps - eta r / c`; it holds zero elsewhere. The axis, of bins of `dt_ps`, covers every
/// pixel's window, as the unwarp's covering axis does, so each pixel is empty over most of it.
/// Inside its window a pixel holds `energy` plus a dark pedestal of `pedestal_per_ps` (a
/// capture whose dark signal was not subtracted).
pub fn windowed_world_cube(
    cal: &Calibration,
    bvh: &Bvh,
    dt_ps: f64,
    t_cam_ps: (f64, f64),
    pedestal_per_ps: f64,
    energy: impl Fn(&Point3<f64>, &Vector3<f64>, f64, f64) -> f64,
) -> Cube {
    let o = cal.pose.position_m;
    let flight = |p: &Point3<f64>| cal.eta * (p - o).norm() / C_M_PER_PS;
    let (near, far) = capture_hits(cal, bvh)
        .iter()
        .flatten()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (p, _)| {
            (a.min(flight(p)), b.max(flight(p)))
        });
    let start_ps = t_cam_ps.0 - far;
    let axis = TimeAxis {
        t0_ps: cal.t0_ps + start_ps,
        dt_ps,
        nt: ((t_cam_ps.1 - near - start_ps) / dt_ps).ceil() as usize,
    };
    world_cube(cal, bvh, axis, |p, n, a, b| {
        let (lo, hi) = (a.max(t_cam_ps.0 - flight(p)), b.min(t_cam_ps.1 - flight(p)));
        if lo < hi {
            energy(p, n, lo, hi) + pedestal_per_ps * (hi - lo)
        } else {
            0.0
        }
    })
}

/// [`single_bounce_energy`] plus a stand-in for the indirect light that follows it: a tail
/// decaying as `exp(-(t - t_arrive) / tail_ps)` after the direct light reaches `p`, holding
/// `tail_fraction` of the direct energy.
pub fn single_bounce_with_tail_energy(
    cal: &Calibration,
    sigma_ps: f64,
    tail_fraction: f64,
    tail_ps: f64,
) -> impl Fn(&Point3<f64>, &Vector3<f64>, f64, f64) -> f64 {
    let laser = cal.laser_m;
    let direct = single_bounce_energy(cal, sigma_ps);
    move |p, n, a, b| {
        let to_laser = laser - p;
        let r = to_laser.norm();
        let cos = (n.dot(&to_laser) / r).abs();
        let t_arrive = r / C_M_PER_PS;
        let decayed = |t: f64| (-(t - t_arrive).max(0.0) / tail_ps).exp();
        direct(p, n, a, b) + tail_fraction * cos / (r * r) * (decayed(a) - decayed(b))
    }
}

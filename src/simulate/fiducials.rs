//! Fiducial markers of a simulated capture: 3-D points on the scene with their true pixel
//! positions, the input of spatial calibration (`femto calibrate`).
//!
//! Two kinds of points: the scene's own candidates ([`Scene::fiducials`]: box corners, quad
//! corners and 3 x 3 grids), and a dense grid of markers on every planar mesh entry (the
//! floor, the walls), `spacing_m` apart, as a lab would tape a printed marker sheet there. A
//! handful of corners is not enough for the target accuracy of calibration (position
//! 1 mm/m, rotation 0.05 degrees, focal length 0.2 % at 0.5 px noise): about 2000 points are,
//! which an 8 mm grid gives on the built-in scenes.
//!
//! A point is kept when it projects inside the image (half a pixel from the border), nothing
//! lies between it and the camera centre, and no point kept before it lies within
//! [`MIN_SEPARATION_M`] (a grid marker that falls on one of the scene's corners is the same
//! physical point, and calibration refuses repeated points). Its pixel is the continuous
//! projection through the true calibration ([`crate::camera::Calibration::project`]).

use crate::calibrate::points::Correspondence;
use crate::geometry::bvh::Bvh;
use crate::geometry::Ray;
use crate::scene::Scene;
use nalgebra::{Point3, Vector3};

/// Grid spacing of the markers that gives about 2000 points on the built-in scenes, metres.
pub const DEFAULT_MARKER_SPACING_M: f64 = 0.008;

/// Visible points closer than this to a point listed before them are dropped, metres: a marker
/// sheet does not put two marks within a millimetre.
pub const MIN_SEPARATION_M: f64 = 1e-3;

/// A point counts as hidden when something lies on its line of sight closer than this to it,
/// metres: far above the precision of single-precision intersections at a metre (about a
/// micrometre), far below a pixel's footprint.
const OCCLUSION_MARGIN_M: f64 = 1e-5;

/// How far off the plane of its first triangle a vertex may be for an entry to count as
/// planar, metres.
const PLANARITY_TOLERANCE_M: f64 = 1e-5;

/// The fiducials of `scene` seen by its camera (module doc): the scene's candidates and a
/// marker grid of `spacing_m` on each planar entry. `bvh` must be built from `scene.mesh`.
pub fn fiducials(scene: &Scene, bvh: &Bvh, spacing_m: f64) -> Vec<Correspondence> {
    let calib = scene.calibration();
    let mut points: Vec<(String, Point3<f64>)> = scene.fiducials();
    for material in 0..scene.labels.len() {
        let label = &scene.labels[material];
        for (k, p) in planar_grid(scene, material as u32, spacing_m)
            .into_iter()
            .enumerate()
        {
            points.push((format!("{label}.marker{k}"), p));
        }
    }
    let (w, h) = (
        scene.camera.intrinsics.width as f64,
        scene.camera.intrinsics.height as f64,
    );
    let o = scene.camera.pose.position_m;
    let visible: Vec<Correspondence> = points
        .into_iter()
        .filter_map(|(name, p)| {
            let (u, v) = calib.project(&p)?;
            if !(u >= 0.5 && v >= 0.5 && u <= w - 0.5 && v <= h - 0.5) {
                return None;
            }
            let d = p - o;
            let dist = d.norm();
            let ray = Ray::new(o.cast::<f32>(), (d / dist).cast::<f32>());
            if bvh.occluded(&ray, 0.0, (dist - OCCLUSION_MARGIN_M) as f32) {
                return None;
            }
            Some(Correspondence {
                name: Some(name),
                pixel: (u, v),
                point_m: p,
            })
        })
        .collect();
    well_separated(visible, MIN_SEPARATION_M)
}

/// `points` without those closer than `min_m` to an earlier point (kept in order; a sweep over
/// the points sorted by x, so near-linear for evenly spread points).
fn well_separated(points: Vec<Correspondence>, min_m: f64) -> Vec<Correspondence> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| points[a].point_m.x.total_cmp(&points[b].point_m.x));
    let mut keep = vec![true; points.len()];
    // Visit points in list order; each is dropped if a kept earlier point lies within min_m.
    let mut rank = vec![0usize; points.len()];
    for (r, &i) in order.iter().enumerate() {
        rank[i] = r;
    }
    for i in 0..points.len() {
        let x = points[i].point_m.x;
        let near =
            |&j: &usize| j < i && keep[j] && (points[j].point_m - points[i].point_m).norm() < min_m;
        let r = rank[i];
        let before = order[..r]
            .iter()
            .rev()
            .take_while(|&&j| x - points[j].point_m.x < min_m);
        let after = order[r + 1..]
            .iter()
            .take_while(|&&j| points[j].point_m.x - x < min_m);
        if before.chain(after).any(near) {
            keep[i] = false;
        }
    }
    points
        .into_iter()
        .zip(keep)
        .filter_map(|(p, k)| k.then_some(p))
        .collect()
}

/// A planar mesh entry in its own 2-D frame: `origin + a u_axis + b v_axis`, the triangles'
/// coordinates and their extent `lo..hi` along `(a, b)`.
struct PlanarEntry {
    origin: Point3<f64>,
    u_axis: Vector3<f64>,
    v_axis: Vector3<f64>,
    tris_2d: Vec<[(f64, f64); 3]>,
    lo: (f64, f64),
    hi: (f64, f64),
}

impl PlanarEntry {
    /// The entry of material `material`, if all its triangles lie in one plane.
    fn of(scene: &Scene, material: u32) -> Option<PlanarEntry> {
        let mesh = &scene.mesh;
        let tris: Vec<[Point3<f64>; 3]> = (0..mesh.triangle_count())
            .filter(|&i| mesh.material[i] == material)
            .map(|i| mesh.corners(i).map(|p| p.cast::<f64>()))
            .collect();
        let first = tris.first()?;
        let e1 = first[1] - first[0];
        let n = e1.cross(&(first[2] - first[0]));
        if n.norm() < 1e-12 {
            return None;
        }
        let n = n.normalize();
        let origin = first[0];
        if tris
            .iter()
            .flatten()
            .any(|p| (p - origin).dot(&n).abs() > PLANARITY_TOLERANCE_M)
        {
            return None;
        }
        let u_axis = e1.normalize();
        let v_axis = n.cross(&u_axis);
        let coords = |p: &Point3<f64>| ((p - origin).dot(&u_axis), (p - origin).dot(&v_axis));
        let (mut lo, mut hi) = (
            (f64::INFINITY, f64::INFINITY),
            (f64::NEG_INFINITY, f64::NEG_INFINITY),
        );
        for p in tris.iter().flatten() {
            let (a, b) = coords(p);
            lo = (lo.0.min(a), lo.1.min(b));
            hi = (hi.0.max(a), hi.1.max(b));
        }
        let tris_2d = tris.iter().map(|t| t.map(|p| coords(&p))).collect();
        Some(PlanarEntry {
            origin,
            u_axis,
            v_axis,
            tris_2d,
            lo,
            hi,
        })
    }
}

/// Grid nodes along an extent `lo..hi` at `spacing_m`: `floor(extent / spacing)`, at least 1
/// (as a float: a tiny spacing gives a count no `usize` holds).
fn axis_node_count(lo: f64, hi: f64, spacing_m: f64) -> f64 {
    ((hi - lo) / spacing_m + 1e-6).floor().max(1.0)
}

/// How many grid nodes [`fiducials`] would test on the planar entries of `scene` at
/// `spacing_m` (before the triangle, image and occlusion tests drop some): the count that
/// sizes its work and memory, computed without walking them.
pub fn marker_candidates(scene: &Scene, spacing_m: f64) -> f64 {
    (0..scene.labels.len())
        .filter_map(|m| PlanarEntry::of(scene, m as u32))
        .map(|e| {
            axis_node_count(e.lo.0, e.hi.0, spacing_m) * axis_node_count(e.lo.1, e.hi.1, spacing_m)
        })
        .sum()
}

/// Grid points `spacing_m` apart on the entry of material `material`, if all its triangles
/// lie in one plane: `floor(extent / spacing)` nodes along each of two in-plane axes, centred
/// in the entry's extent (so half a spacing in from a rectangle's edges), kept where they fall
/// on one of its triangles. Empty for a non-planar entry. The caller bounds the node count
/// first ([`marker_candidates`]).
fn planar_grid(scene: &Scene, material: u32, spacing_m: f64) -> Vec<Point3<f64>> {
    if !(spacing_m.is_finite() && spacing_m > 0.0) {
        return Vec::new();
    }
    let Some(e) = PlanarEntry::of(scene, material) else {
        return Vec::new();
    };
    let axis_nodes = |lo: f64, hi: f64| -> Vec<f64> {
        let extent = hi - lo;
        let n = axis_node_count(lo, hi, spacing_m) as usize;
        let start = lo + (extent - (n - 1) as f64 * spacing_m) / 2.0;
        (0..n).map(|i| start + i as f64 * spacing_m).collect()
    };
    let mut out = Vec::new();
    for &b in &axis_nodes(e.lo.1, e.hi.1) {
        for &a in &axis_nodes(e.lo.0, e.hi.0) {
            if e.tris_2d.iter().any(|t| inside(t, (a, b))) {
                let p: Vector3<f64> = e.origin.coords + e.u_axis * a + e.v_axis * b;
                out.push(Point3::from(p));
            }
        }
    }
    out
}

/// Whether `p` lies inside triangle `t` or on its edges (within a nanometre), so that a
/// point on the diagonal shared by two triangles of a quad is kept.
fn inside(t: &[(f64, f64); 3], p: (f64, f64)) -> bool {
    let edge = |a: (f64, f64), b: (f64, f64)| {
        let (ex, ey) = (b.0 - a.0, b.1 - a.1);
        let len = (ex * ex + ey * ey).sqrt();
        (ex * (p.1 - a.1) - ey * (p.0 - a.0)) / len.max(1e-300)
    };
    let d = [edge(t[0], t[1]), edge(t[1], t[2]), edge(t[2], t[0])];
    const TOLERANCE_M: f64 = 1e-9;
    d.iter().all(|&v| v > -TOLERANCE_M) || d.iter().all(|&v| v < TOLERANCE_M)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_scene_has_about_two_thousand_visible_fiducials_on_the_surfaces() {
        let scene = Scene::builtin("cube", None).unwrap();
        let bvh = Bvh::new(scene.mesh.clone());
        let f = fiducials(&scene, &bvh, DEFAULT_MARKER_SPACING_M);
        assert!(f.len() > 1800, "{} fiducials", f.len());
        assert!(f
            .iter()
            .any(|c| c.name.as_deref().unwrap().starts_with("cube.corner")));
        let calib = scene.calibration();
        for c in &f {
            let dir = calib.world_ray(c.pixel.0, c.pixel.1);
            let o = calib.pose.position_m;
            let ray = Ray::new(o.cast::<f32>(), dir.into_inner().cast::<f32>());
            let hit = bvh.intersect(&ray, 0.0, f32::INFINITY).unwrap();
            let d = (c.point_m - o).norm();
            let name = c.name.as_deref().unwrap();
            // Nothing in front of the point; a marker (inside a face, not on a silhouette
            // edge where the ray may graze past) is where the ray stops.
            assert!(hit.t as f64 > d - 1e-3, "{name}: {} vs {d}", hit.t);
            if name.contains(".marker") {
                assert!((hit.t as f64 - d).abs() < 1e-4, "{name}: {} vs {d}", hit.t);
            }
        }
    }

    #[test]
    fn grid_covers_a_quad_at_the_spacing() {
        let scene = Scene::builtin("cube", None).unwrap();
        let floor = scene.labels.iter().position(|l| l == "floor").unwrap();
        // The floor is 0.40 x 0.35 m in the y = 0 plane, centred at x = 0, z = 0.075: a
        // 40 x 35 grid 1 cm apart, half a centimetre in from the edges.
        let g = planar_grid(&scene, floor as u32, 0.01);
        assert_eq!(g.len(), 40 * 35);
        for p in &g {
            assert!(p.y.abs() < 1e-6);
            for (v, lo) in [(p.x, -0.2), (p.z, 0.075 - 0.175)] {
                let k = (v - lo - 0.005) / 0.01;
                assert!((k - k.round()).abs() < 1e-4, "{v}");
            }
        }
        let box_entry = scene.labels.iter().position(|l| l == "cube").unwrap();
        assert!(planar_grid(&scene, box_entry as u32, 0.01).is_empty());
    }

    #[test]
    fn marker_candidates_count_the_grid_without_walking_it() {
        let scene = Scene::builtin("cube", None).unwrap();
        // Every planar entry of the cube scene is a rectangle: each node is a candidate.
        let walked: usize = (0..scene.labels.len())
            .map(|m| planar_grid(&scene, m as u32, 0.01).len())
            .sum();
        assert!(walked >= 40 * 35, "{walked}");
        assert_eq!(marker_candidates(&scene, 0.01), walked as f64);
        // A nanometre grid on the 0.40 x 0.35 m floor alone: 1.4e17 nodes, counted at once.
        let huge = marker_candidates(&scene, 1e-9);
        assert!(huge.is_finite() && huge > 1.4e17, "{huge}");
    }

    #[test]
    fn points_closer_than_the_separation_to_an_earlier_one_are_dropped() {
        let c = |name: &str, x: f64, y: f64| Correspondence {
            name: Some(name.to_string()),
            pixel: (0.0, 0.0),
            point_m: Point3::new(x, y, 0.0),
        };
        let pts = vec![
            c("corner", 0.0, 0.0),
            c("far", 0.5, 0.0),
            c("marker_on_corner", 3e-9, 0.0),
            c("close_in_y", 0.0, 9e-4),
            c("just_apart", -1.1e-3, 0.0),
            c("near_far", 0.5, 5e-4),
        ];
        let kept: Vec<String> = well_separated(pts, 1e-3)
            .into_iter()
            .map(|p| p.name.unwrap())
            .collect();
        assert_eq!(kept, ["corner", "far", "just_apart"]);
    }
}

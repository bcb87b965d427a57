//! Built-in primitive meshes for scene files: a quad, a box and an icosphere, in metres,
//! centred at the origin, every triangle with material 0.
//!
//! Winding: counter-clockwise seen from the front, so the geometric normal
//! `(v1 - v0) x (v2 - v0)` of every triangle points out of the closed shapes (box,
//! icosphere) and along +z for the quad. The shapes are closed 2-manifolds where stated: every
//! edge is shared by exactly two triangles that traverse it in opposite directions.

use super::TriangleMesh;
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;

/// A rectangle `size_x` by `size_y` in the z = 0 plane, centred at the origin, normal +z.
pub fn quad(size_x: f32, size_y: f32) -> TriangleMesh {
    let (hx, hy) = (0.5 * size_x, 0.5 * size_y);
    TriangleMesh {
        positions: vec![
            Point3::new(-hx, -hy, 0.0),
            Point3::new(hx, -hy, 0.0),
            Point3::new(hx, hy, 0.0),
            Point3::new(-hx, hy, 0.0),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        material: vec![0; 2],
    }
}

/// A closed axis-aligned box with edge lengths `size` (x, y, z), centred at the origin,
/// 8 shared corners and 12 triangles with outward normals.
pub fn cuboid(size: Vector3<f32>) -> TriangleMesh {
    let h = 0.5 * size;
    // Corner k has x = +h.x when bit 0 is set, y = +h.y for bit 1, z = +h.z for bit 2.
    let positions = (0..8)
        .map(|k| {
            Point3::new(
                if k & 1 != 0 { h.x } else { -h.x },
                if k & 2 != 0 { h.y } else { -h.y },
                if k & 4 != 0 { h.z } else { -h.z },
            )
        })
        .collect();
    // Each face as a quad listed counter-clockwise seen from outside.
    let faces: [[u32; 4]; 6] = [
        [1, 3, 7, 5], // +x
        [0, 4, 6, 2], // -x
        [2, 6, 7, 3], // +y
        [0, 1, 5, 4], // -y
        [4, 5, 7, 6], // +z
        [0, 2, 3, 1], // -z
    ];
    let triangles: Vec<[u32; 3]> = faces
        .iter()
        .flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]])
        .collect();
    TriangleMesh {
        positions,
        material: vec![0; triangles.len()],
        triangles,
    }
}

/// A closed sphere of `radius` approximated by an icosahedron whose faces are split in four
/// `subdivisions` times (20 * 4^subdivisions triangles), vertices on the sphere.
pub fn icosphere(radius: f32, subdivisions: u32) -> TriangleMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let base: [[f64; 3]; 12] = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut unit: Vec<Vector3<f64>> = base
        .iter()
        .map(|p| Vector3::new(p[0], p[1], p[2]).normalize())
        .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, unit: &mut Vec<Vector3<f64>>| -> u32 {
            let key = (a.min(b), a.max(b));
            *midpoint.entry(key).or_insert_with(|| {
                unit.push((unit[a as usize] + unit[b as usize]).normalize());
                (unit.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for &[a, b, c] in &faces {
            let ab = mid(a, b, &mut unit);
            let bc = mid(b, c, &mut unit);
            let ca = mid(c, a, &mut unit);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    // The sphere is convex and centred at the origin: a face is outward when its normal points
    // the same way as its centroid. Enforce it rather than trust the table.
    for f in &mut faces {
        let [a, b, c] = f.map(|i| unit[i as usize]);
        if (b - a).cross(&(c - a)).dot(&(a + b + c)) < 0.0 {
            f.swap(1, 2);
        }
    }
    let r = radius as f64;
    TriangleMesh {
        positions: unit
            .iter()
            .map(|u| Point3::new((r * u.x) as f32, (r * u.y) as f32, (r * u.z) as f32))
            .collect(),
        material: vec![0; faces.len()],
        triangles: faces,
    }
}

/// Whether every edge of `mesh` is shared by exactly two triangles traversing it in opposite
/// directions (a closed, consistently wound surface).
pub fn is_closed(mesh: &TriangleMesh) -> bool {
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    !directed.is_empty()
        && directed
            .iter()
            .all(|(&(a, b), &n)| n == 1 && directed.get(&(b, a)) == Some(&1))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Signed volume by the divergence theorem (positive for outward winding).
    fn signed_volume(m: &TriangleMesh) -> f64 {
        (0..m.triangle_count())
            .map(|i| {
                let [a, b, c] = m.corners(i).map(|p| p.coords.cast::<f64>());
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum()
    }

    fn total_area(m: &TriangleMesh) -> f64 {
        (0..m.triangle_count()).map(|i| m.area(i) as f64).sum()
    }

    #[test]
    fn quad_faces_plus_z_with_the_right_area() {
        let q = quad(0.8, 0.5);
        assert!((total_area(&q) - 0.4).abs() < 1e-6);
        for i in 0..q.triangle_count() {
            let [a, b, c] = q.corners(i);
            let n = (b - a).cross(&(c - a));
            assert!(n.z > 0.0 && n.x == 0.0 && n.y == 0.0);
        }
        assert!(!is_closed(&q));
        let b = q.bounds();
        assert_eq!((b.min.x, b.max.y), (-0.4, 0.25));
    }

    #[test]
    fn box_is_closed_outward_with_exact_volume() {
        let m = cuboid(Vector3::new(0.2, 0.3, 0.5));
        assert!(is_closed(&m));
        assert!((signed_volume(&m) - 0.03).abs() < 1e-7);
        assert!((total_area(&m) - 2.0 * (0.06 + 0.1 + 0.15)).abs() < 1e-6);
        // Each face normal points away from the centre.
        for i in 0..m.triangle_count() {
            let [a, b, c] = m.corners(i);
            let n = (b - a).cross(&(c - a));
            let centroid = (a.coords + b.coords + c.coords) / 3.0;
            assert!(n.dot(&centroid) > 0.0, "triangle {i}");
        }
    }

    #[test]
    fn icosphere_is_closed_outward_and_converges_to_the_sphere() {
        let r = 0.3f64;
        let mut prev_err = f64::INFINITY;
        for s in 0..4 {
            let m = icosphere(r as f32, s);
            assert_eq!(m.triangle_count(), 20 * 4usize.pow(s));
            assert!(is_closed(&m), "subdivisions {s}");
            for p in &m.positions {
                assert!((p.coords.norm() as f64 - r).abs() < 1e-6);
            }
            let v = signed_volume(&m);
            let exact = 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
            // Inscribed polyhedron: below the sphere and closer with each subdivision.
            assert!(v > 0.0 && v < exact);
            let err = exact - v;
            assert!(err < prev_err);
            prev_err = err;
        }
        assert!(prev_err / (4.0 / 3.0 * std::f64::consts::PI * r.powi(3)) < 0.02);
    }
}

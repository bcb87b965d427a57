//! Point queries against a triangle mesh, in f64: whether a point lies inside a closed mesh
//! (ray-crossing parity), its distance to the surface, and the closest point of a triangle.
//! Scenes use them to keep the camera and the laser spot out of solid objects.

use super::TriangleMesh;
use nalgebra::{Point3, Vector3};

/// Whether `p` lies inside a closed mesh: parity of the crossings of a ray from `p`.
pub fn inside_closed(mesh: &TriangleMesh, p: &Point3<f64>) -> bool {
    // A direction unlikely to graze an edge of an axis-aligned or primitive mesh.
    let dir = Vector3::new(0.5773, 0.6117, 0.5406).normalize();
    let mut crossings = 0usize;
    for i in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.corners(i).map(|q| q.cast::<f64>());
        let e1 = b - a;
        let e2 = c - a;
        let pv = dir.cross(&e2);
        let det = e1.dot(&pv);
        if det.abs() < 1e-18 {
            continue;
        }
        let s = p - a;
        let u = s.dot(&pv) / det;
        let q = s.cross(&e1);
        let v = dir.dot(&q) / det;
        let t = e2.dot(&q) / det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 {
            crossings += 1;
        }
    }
    crossings % 2 == 1
}

/// Distance from `p` to the nearest point of any triangle of `mesh`, metres.
pub fn distance_to_mesh(mesh: &TriangleMesh, p: &Point3<f64>) -> f64 {
    (0..mesh.triangle_count())
        .map(|i| {
            let [a, b, c] = mesh.corners(i).map(|q| q.cast::<f64>());
            (closest_point_on_triangle(p, &a, &b, &c) - p).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Closest point to `p` on triangle `abc` (Ericson, Real-Time Collision Detection, 5.1.5).
pub fn closest_point_on_triangle(
    p: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> Point3<f64> {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::primitives;

    #[test]
    fn points_inside_and_outside_a_box_and_a_sphere() {
        let cube = primitives::cuboid(Vector3::new(0.2, 0.2, 0.2));
        assert!(inside_closed(&cube, &Point3::new(0.0, 0.0, 0.0)));
        assert!(inside_closed(&cube, &Point3::new(0.09, -0.09, 0.05)));
        assert!(!inside_closed(&cube, &Point3::new(0.11, 0.0, 0.0)));
        assert!(!inside_closed(&cube, &Point3::new(0.0, 0.5, 0.0)));
        let ball = primitives::icosphere(0.1, 2);
        assert!(inside_closed(&ball, &Point3::new(0.02, 0.03, -0.01)));
        assert!(!inside_closed(&ball, &Point3::new(0.0, 0.0, 0.2)));
    }

    #[test]
    fn distance_to_a_box_is_the_euclidean_distance_to_its_nearest_feature() {
        let cube = primitives::cuboid(Vector3::new(0.2, 0.2, 0.2));
        // In front of a face, beyond an edge, beyond a corner, and inside.
        let cases = [
            (Point3::new(0.0, 0.0, 0.4), 0.3),
            (
                Point3::new(0.4, 0.5, 0.0),
                (0.3f64 * 0.3 + 0.4 * 0.4).sqrt(),
            ),
            (Point3::new(0.2, 0.2, 0.2), (3.0f64 * 0.01).sqrt()),
            (Point3::new(0.0, 0.05, 0.0), 0.05),
        ];
        for (p, want) in cases {
            let d = distance_to_mesh(&cube, &p);
            assert!((d - want).abs() < 1e-6, "{p}: {d} vs {want}");
        }
    }

    #[test]
    fn closest_point_on_a_triangle_in_each_region() {
        let (a, b, c) = (
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
        );
        let cases = [
            // Above the interior: the foot of the perpendicular.
            (Point3::new(0.2, 0.3, 2.0), Point3::new(0.2, 0.3, 0.0)),
            // Vertex regions.
            (Point3::new(-1.0, -1.0, 0.0), a),
            (Point3::new(2.0, -0.5, 0.0), b),
            (Point3::new(-0.5, 2.0, 1.0), c),
            // Edge regions: ab, ac and bc.
            (Point3::new(0.5, -1.0, 0.0), Point3::new(0.5, 0.0, 0.0)),
            (Point3::new(-1.0, 0.5, 0.0), Point3::new(0.0, 0.5, 0.0)),
            (Point3::new(1.0, 1.0, 0.0), Point3::new(0.5, 0.5, 0.0)),
        ];
        for (p, want) in cases {
            let q = closest_point_on_triangle(&p, &a, &b, &c);
            assert!((q - want).norm() < 1e-12, "{p}: {q} vs {want}");
        }
    }
}

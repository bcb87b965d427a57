//! Ray-mesh intersection: the public API every caster uses.
//!
//! PLACEHOLDER BODY FOR THE BOOTSTRAP COMMIT: brute force over all triangles with a
//! watertight test. The geometry work replaces the internals with an SAH BVH; the signatures
//! below are the contract and stay.

use super::{Aabb, Hit, Ray, TriangleMesh};

/// An acceleration structure that owns its mesh.
#[derive(Clone, Debug)]
pub struct Bvh {
    mesh: TriangleMesh,
    bounds: Aabb,
}

impl Bvh {
    /// Build over `mesh` (takes ownership; read it back with [`Bvh::mesh`]).
    pub fn new(mesh: TriangleMesh) -> Bvh {
        let bounds = mesh.bounds();
        Bvh { mesh, bounds }
    }

    pub fn mesh(&self) -> &TriangleMesh {
        &self.mesh
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Nearest hit with `t_min < t < t_max` (both sides of every triangle count).
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut t_best = t_max;
        for i in 0..self.mesh.triangle_count() {
            if let Some(h) = intersect_triangle(&self.mesh, i, ray, t_min, t_best) {
                t_best = h.t;
                best = Some(h);
            }
        }
        best
    }

    /// Whether anything lies on the ray with `t_min < t < t_max` (shadow rays).
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        (0..self.mesh.triangle_count())
            .any(|i| intersect_triangle(&self.mesh, i, ray, t_min, t_max).is_some())
    }
}

/// Möller-Trumbore (not watertight; replaced by the geometry work).
fn intersect_triangle(
    mesh: &TriangleMesh,
    i: usize,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<Hit> {
    let [a, b, c] = mesh.corners(i);
    let e1 = b - a;
    let e2 = c - a;
    let p = ray.dir.cross(&e2);
    let det = e1.dot(&p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = ray.origin - a;
    let u = s.dot(&p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(&e1);
    let v = ray.dir.dot(&q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(&q) * inv;
    (t > t_min && t < t_max).then(|| Hit {
        t,
        triangle: i as u32,
        normal: e1.cross(&e2).normalize(),
        u,
        v,
    })
}

//! Triangle geometry: meshes in metres, rays, and hits.
//!
//! Geometry is single precision (the tracer and renderer cast billions of rays); calibration
//! math converts to f64 where it needs to. The BVH lives in [`bvh`]; mesh loading (OBJ, glTF) in
//! [`load`]; writing binary glTF in [`glb`]; built-in primitive meshes in [`primitives`]; point
//! queries (inside a closed mesh, distance to the surface) in [`queries`]; welding and fitting
//! of mesh files in [`normalize`]; fiducial candidates of primitives in [`fiducials`]; the run-time choice of SIMD path
//! (`FEMTO_SIMD`) in [`simd_level`].

pub mod bvh;
pub mod fiducials;
pub mod glb;
pub mod load;
pub mod normalize;
pub mod primitives;
pub mod queries;
mod simd;
pub mod simd_level;

use nalgebra::{Point3, Vector3};

/// A ray `origin + t * dir`, `t` in metres when `dir` is a unit vector.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Point3<f32>,
    pub dir: Vector3<f32>,
}

impl Ray {
    pub fn new(origin: Point3<f32>, dir: Vector3<f32>) -> Ray {
        Ray { origin, dir }
    }

    #[inline]
    pub fn at(&self, t: f32) -> Point3<f32> {
        self.origin + self.dir * t
    }
}

/// The nearest intersection of a ray with a mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (metres along a unit ray).
    pub t: f32,
    /// Index of the triangle in the mesh.
    pub triangle: u32,
    /// Unit geometric normal `(v1 - v0) x (v2 - v0)`, not flipped towards the ray.
    pub normal: Vector3<f32>,
    /// Barycentric coordinates of the hit: `p = (1 - u - v) v0 + u v1 + v v2`.
    pub u: f32,
    pub v: f32,
}

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Point3<f32>,
    pub max: Point3<f32>,
}

impl Aabb {
    pub fn empty() -> Aabb {
        Aabb {
            min: Point3::new(f32::INFINITY, f32::INFINITY, f32::INFINITY),
            max: Point3::new(f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY),
        }
    }

    pub fn grow(&mut self, p: &Point3<f32>) {
        self.min = self.min.inf(p);
        self.max = self.max.sup(p);
    }

    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.inf(&o.min),
            max: self.max.sup(&o.max),
        }
    }

    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }

    /// Whether `p` lies inside (boundary included).
    pub fn contains(&self, p: &Point3<f32>) -> bool {
        (0..3).all(|i| p[i] >= self.min[i] && p[i] <= self.max[i])
    }
}

/// An indexed triangle mesh in metres, with one material index per triangle.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    pub positions: Vec<Point3<f32>>,
    pub triangles: Vec<[u32; 3]>,
    /// Material (albedo slot) of each triangle; same length as `triangles`.
    pub material: Vec<u32>,
}

impl TriangleMesh {
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The three corners of triangle `i`.
    #[inline]
    pub fn corners(&self, i: usize) -> [Point3<f32>; 3] {
        let [a, b, c] = self.triangles[i];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// Bounds of all vertices referenced by triangles.
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::empty();
        for t in &self.triangles {
            for &i in t {
                b.grow(&self.positions[i as usize]);
            }
        }
        b
    }

    /// Area of triangle `i`, square metres.
    pub fn area(&self, i: usize) -> f32 {
        let [a, b, c] = self.corners(i);
        0.5 * (b - a).cross(&(c - a)).norm()
    }

    /// Append another mesh, giving its triangles material `material`.
    pub fn append(&mut self, other: &TriangleMesh, material: u32) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.triangles.extend(
            other
                .triangles
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
        self.material
            .extend(std::iter::repeat_n(material, other.triangles.len()));
    }

    /// Apply an affine transform (a 4x4 matrix in metres) to every vertex.
    pub fn transform(&mut self, m: &nalgebra::Matrix4<f32>) {
        for p in &mut self.positions {
            *p = m.transform_point(p);
        }
    }
}

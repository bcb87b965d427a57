//! Ray-mesh intersection: the public API every caster uses.
//!
//! A bounding volume hierarchy built with the binned surface area heuristic (SAH; Wald 2007,
//! "On fast construction of SAH-based bounding volume hierarchies"), stored as a flat array of
//! 32-byte nodes whose two children share one 64-byte cache line. Traversal tests both children,
//! visits the nearer first and culls subtrees that start beyond the current closest hit. The
//! ray-box test is the slab test made conservative as in pbrt-v3 §3.9.2 (far distances scaled by
//! `1 + 2 gamma(3)`, NaNs from `0 * inf` on a slab boundary ignored), so no box that holds a hit
//! is ever skipped.
//!
//! femto keeps its own tree rather than a crate's after measuring against `obvhs` 0.4 (BVH8,
//! SIMD traversal) with the same triangle test: on the bunny this tree was about 20 % faster for
//! coherent camera rays and within about 5 % for random rays (`cargo bench --bench bvh`), and
//! its box test is provably conservative for axis-parallel rays.
//!
//! The ray-triangle test is the watertight algorithm of Woop, Benthin and Wald (2013,
//! "Watertight ray/triangle intersection", JCGT 2(1)): vertices are moved into a ray-aligned
//! sheared frame and the three 2D edge functions are evaluated there, falling back to double
//! precision when one of them is exactly zero. A ray that passes through a shared edge or vertex
//! of a closed mesh hits at least one of the triangles, whatever rounding does. Both faces of a
//! triangle are hit. Triangles of zero area are left out of the hierarchy, so they never report
//! a hit.

use super::{Aabb, Hit, Ray, TriangleMesh};
use nalgebra::{Point3, Vector3};
use std::mem::MaybeUninit;

/// Number of SAH bins per axis.
const BINS: usize = 16;
/// Leaves never hold more triangles than this (the SAH may still choose smaller leaves).
const MAX_LEAF: usize = 8;
/// Below this depth the SAH picks the split; deeper nodes split at the centroid median, which
/// halves the count at every level and so bounds the depth of any tree by `SAH_DEPTH + 32`.
const SAH_DEPTH: u32 = 64;
/// Traversal stack size: one entry per level, so it must exceed `SAH_DEPTH + 32`.
const STACK: usize = 128;
/// Relative cost of one node visit (two box tests) against one triangle test, for the SAH.
const COST_TRAVERSAL: f32 = 1.0;
/// `1 + 2 gamma(3)` with `gamma(n) = n u / (1 - n u)`, `u = 2^-24` (pbrt-v3, Eq. 3.9): scaling
/// the far slab distance by this makes the f32 slab test conservative.
const SLAB_FAR_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// One node of the flattened tree.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct Node {
    /// Box corners: `min` x, y, z then `max` x, y, z.
    bounds: [f32; 6],
    /// Leaf: first entry of `Bvh::tris`. Interior: index of its children in `Bvh::pairs`.
    first: u32,
    /// Number of triangles of a leaf; 0 for an interior node.
    count: u32,
}

/// The two children of an interior node, sharing one 64-byte cache line.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct NodePair([Node; 2]);

/// An acceleration structure that owns its mesh.
#[derive(Clone, Debug)]
pub struct Bvh {
    mesh: TriangleMesh,
    bounds: Aabb,
    /// Root node; `None` when the mesh has no triangle of non-zero area.
    root: Option<Node>,
    /// Children of interior nodes: an interior node's `first` indexes this array.
    pairs: Vec<NodePair>,
    /// Triangle corners in leaf order, copied from the mesh for locality.
    tris: Vec<[[f32; 3]; 3]>,
    /// Mesh triangle index of each entry of `tris`.
    ids: Vec<u32>,
}

impl Bvh {
    /// Build over `mesh` (takes ownership; read it back with [`Bvh::mesh`]).
    ///
    /// Every index in `mesh.triangles` must be a valid position index (the loaders check this).
    pub fn new(mesh: TriangleMesh) -> Bvh {
        let bounds = mesh.bounds();
        let (nodes, order) = build(&mesh);
        // `build` pushes children in pairs after the root: nodes 2k+1 and 2k+2 form pair k.
        let root = nodes.first().map(|&root| relink(root));
        let pairs = nodes
            .get(1..)
            .unwrap_or_default()
            .chunks_exact(2)
            .map(|c| NodePair([relink(c[0]), relink(c[1])]))
            .collect();
        let tris = order
            .iter()
            .map(|&i| mesh.corners(i as usize).map(|p| [p.x, p.y, p.z]))
            .collect();
        Bvh {
            mesh,
            bounds,
            root,
            pairs,
            tris,
            ids: order,
        }
    }

    pub fn mesh(&self) -> &TriangleMesh {
        &self.mesh
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Nearest hit with `t_min < t < t_max` (both sides of every triangle count).
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let mut best: Option<(usize, TriHit)> = None;
        let mut t_best = t_max;
        self.traverse(ray, t_min, t_max, |slot, pre, t_far| {
            if let Some(h) = intersect_triangle(&self.tris[slot], pre, t_min, t_far) {
                t_best = h.t;
                best = Some((slot, h));
            }
            (t_best, false)
        });
        best.map(|(slot, h)| Hit {
            t: h.t,
            triangle: self.ids[slot],
            normal: geometric_normal(&self.tris[slot]),
            u: h.u,
            v: h.v,
        })
    }

    /// Whether anything lies on the ray with `t_min < t < t_max` (shadow rays).
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        let mut hit = false;
        self.traverse(ray, t_min, t_max, |slot, pre, t_far| {
            hit = intersect_triangle(&self.tris[slot], pre, t_min, t_far).is_some();
            (t_far, hit)
        });
        hit
    }

    /// Walk the tree front to back, calling `visit(slot, ray, t_far)` for each triangle slot in
    /// a leaf whose box the ray enters before `t_far`. `visit` returns the new `t_far` and
    /// whether to stop.
    #[inline(always)]
    fn traverse<F>(&self, ray: &Ray, t_min: f32, t_max: f32, mut visit: F)
    where
        F: FnMut(usize, &PreparedRay, f32) -> (f32, bool),
    {
        let Some(root) = self.root else {
            return;
        };
        if t_min.is_nan() || t_max.is_nan() || t_min >= t_max {
            return;
        }
        let pre = PreparedRay::new(ray);
        let mut t_far = t_max;
        if slab(&root, &pre, t_min, t_far).is_none() {
            return;
        }
        // Entries: (2 * pair + child, entry distance). Left uninitialised: zeroing 1 KiB for
        // every ray cost a few per cent of a short ray's traversal.
        let mut stack = [const { MaybeUninit::<(u32, f32)>::uninit() }; STACK];
        let mut sp = 0usize;
        let mut n = root;
        loop {
            if n.count > 0 {
                let first = n.first as usize;
                for slot in first..first + n.count as usize {
                    let (t, stop) = visit(slot, &pre, t_far);
                    if stop {
                        return;
                    }
                    t_far = t;
                }
            } else {
                let pair = &self.pairs[n.first as usize].0;
                let ta = slab(&pair[0], &pre, t_min, t_far);
                let tb = slab(&pair[1], &pre, t_min, t_far);
                match (ta, tb) {
                    (Some(ta), Some(tb)) => {
                        let (near, far, t_enter_far) =
                            if ta <= tb { (0, 1, tb) } else { (1, 0, ta) };
                        stack[sp].write((2 * n.first + far, t_enter_far));
                        sp += 1;
                        n = pair[near as usize];
                        continue;
                    }
                    (Some(_), None) => {
                        n = pair[0];
                        continue;
                    }
                    (None, Some(_)) => {
                        n = pair[1];
                        continue;
                    }
                    (None, None) => {}
                }
            }
            // Pop the next subtree that still starts before the closest hit.
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                // SAFETY: entries are pushed by writing `stack[sp]` before `sp += 1`, and
                // popped by `sp -= 1` before this read, so every entry below the old `sp`
                // (this one included) was written by this traversal.
                let (next, t_enter) = unsafe { stack[sp].assume_init() };
                if t_enter < t_far {
                    n = self.pairs[next as usize / 2].0[next as usize % 2];
                    break;
                }
            }
        }
    }
}

/// Map an interior node's child index in the build array (2k+1) to its pair index (k).
fn relink(mut n: Node) -> Node {
    if n.count == 0 {
        n.first = (n.first - 1) / 2;
    }
    n
}

/// Per-ray constants of the slab and watertight triangle tests.
struct PreparedRay {
    origin: [f32; 3],
    inv_dir: [f32; 3],
    /// Index into `Node::bounds` of the near and far plane on each axis (the max plane is
    /// the near one when the direction component is negative, including -0).
    near: [usize; 3],
    far: [usize; 3],
    /// Axis of the largest direction component (`kz`) and the two others, ordered so that the
    /// sheared frame keeps the triangles' winding.
    kx: usize,
    ky: usize,
    kz: usize,
    /// Shear constants of Woop et al.: `S = (d_kx / d_kz, d_ky / d_kz, 1 / d_kz)`.
    sx: f32,
    sy: f32,
    sz: f32,
}

impl PreparedRay {
    #[inline(always)]
    fn new(ray: &Ray) -> PreparedRay {
        let d = [ray.dir.x, ray.dir.y, ray.dir.z];
        let inv_dir = d.map(|c| 1.0 / c);
        let kz = if d[0].abs() >= d[1].abs() {
            if d[0].abs() >= d[2].abs() {
                0
            } else {
                2
            }
        } else if d[1].abs() >= d[2].abs() {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let neg = inv_dir.map(|c| c.is_sign_negative() as usize);
        PreparedRay {
            origin: [ray.origin.x, ray.origin.y, ray.origin.z],
            inv_dir,
            near: [3 * neg[0], 1 + 3 * neg[1], 2 + 3 * neg[2]],
            far: [3 - 3 * neg[0], 4 - 3 * neg[1], 5 - 3 * neg[2]],
            kx,
            ky,
            kz,
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: 1.0 / d[kz],
        }
    }
}

/// Conservative slab test: the entry distance when the ray meets the box within
/// `(t_min, t_max)`, else `None`.
#[inline(always)]
fn slab(n: &Node, r: &PreparedRay, t_min: f32, t_max: f32) -> Option<f32> {
    let mut t0 = t_min;
    let mut t1 = t_max;
    for a in 0..3 {
        let near = (n.bounds[r.near[a]] - r.origin[a]) * r.inv_dir[a];
        let far = (n.bounds[r.far[a]] - r.origin[a]) * r.inv_dir[a] * SLAB_FAR_SCALE;
        // Written so that a NaN (0 * inf: the origin on the slab plane of a parallel ray)
        // leaves the interval unchanged.
        if near > t0 {
            t0 = near;
        }
        if far < t1 {
            t1 = far;
        }
    }
    (t0 <= t1).then_some(t0)
}

/// Distance and barycentrics of a triangle hit.
#[derive(Clone, Copy, Debug)]
struct TriHit {
    t: f32,
    u: f32,
    v: f32,
}

/// Watertight two-sided ray-triangle test (Woop, Benthin and Wald 2013), hits with
/// `t_min < t < t_max` only.
#[inline(always)]
fn intersect_triangle(
    tri: &[[f32; 3]; 3],
    r: &PreparedRay,
    t_min: f32,
    t_max: f32,
) -> Option<TriHit> {
    let rel = |p: &[f32; 3]| [p[0] - r.origin[0], p[1] - r.origin[1], p[2] - r.origin[2]];
    let (a, b, c) = (rel(&tri[0]), rel(&tri[1]), rel(&tri[2]));
    let (kx, ky, kz) = (r.kx, r.ky, r.kz);
    // Shear and scale the vertices into the ray's frame (the ray becomes the +z axis).
    let ax = a[kx] - r.sx * a[kz];
    let ay = a[ky] - r.sy * a[kz];
    let bx = b[kx] - r.sx * b[kz];
    let by = b[ky] - r.sy * b[kz];
    let cx = c[kx] - r.sx * c[kz];
    let cy = c[ky] - r.sy * c[kz];
    // Scaled barycentric coordinates (2D edge functions).
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    // Early out on the first two: a nonzero f32 edge function has the sign of the exact one
    // (rounding is monotonic), so this agrees with the full test below.
    if (u < 0.0 && v > 0.0) || (u > 0.0 && v < 0.0) {
        return None;
    }
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let f = |p: f32, q: f32, s: f32, t: f32| (p as f64 * q as f64 - s as f64 * t as f64) as f32;
        u = f(cx, by, cy, bx);
        v = f(ax, cy, ay, cx);
        w = f(bx, ay, by, ax);
    }
    // Two-sided: reject only when the signs differ.
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let t_scaled = u * (r.sz * a[kz]) + v * (r.sz * b[kz]) + w * (r.sz * c[kz]);
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    // A NaN `t` (degenerate ray) fails both comparisons.
    if t > t_min && t < t_max {
        Some(TriHit {
            t,
            u: v * inv_det,
            v: w * inv_det,
        })
    } else {
        None
    }
}

/// Unit `(v1 - v0) x (v2 - v0)`, computed in f64 so that thin (but non-degenerate) triangles
/// still give a finite unit vector.
fn geometric_normal(tri: &[[f32; 3]; 3]) -> Vector3<f32> {
    cross_f64(tri).normalize().cast::<f32>()
}

fn cross_f64(tri: &[[f32; 3]; 3]) -> Vector3<f64> {
    let p = tri.map(|c| Vector3::new(c[0] as f64, c[1] as f64, c[2] as f64));
    (p[1] - p[0]).cross(&(p[2] - p[0]))
}

/// Build record of one triangle.
struct Prim {
    lo: [f32; 3],
    hi: [f32; 3],
    centroid: [f32; 3],
}

#[derive(Clone, Copy)]
struct Bin {
    count: u32,
    lo: [f32; 3],
    hi: [f32; 3],
}

impl Bin {
    const EMPTY: Bin = Bin {
        count: 0,
        lo: [f32::INFINITY; 3],
        hi: [f32::NEG_INFINITY; 3],
    };

    fn add(&mut self, p: &Prim) {
        self.count += 1;
        self.grow(&p.lo, &p.hi);
    }

    fn grow(&mut self, lo: &[f32; 3], hi: &[f32; 3]) {
        for a in 0..3 {
            self.lo[a] = self.lo[a].min(lo[a]);
            self.hi[a] = self.hi[a].max(hi[a]);
        }
    }

    fn merge(&mut self, o: &Bin) {
        self.count += o.count;
        self.grow(&o.lo, &o.hi);
    }

    /// Half the surface area (0 for an empty bin).
    fn half_area(&self) -> f32 {
        if self.count == 0 {
            return 0.0;
        }
        let d = [0, 1, 2].map(|a| (self.hi[a] - self.lo[a]).max(0.0));
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
}

/// Build the flattened tree; returns the nodes and the mesh triangle index of each leaf slot.
fn build(mesh: &TriangleMesh) -> (Vec<Node>, Vec<u32>) {
    let mut prims = Vec::with_capacity(mesh.triangle_count());
    let mut order = Vec::with_capacity(mesh.triangle_count());
    for i in 0..mesh.triangle_count() {
        let c = mesh.corners(i).map(|p: Point3<f32>| [p.x, p.y, p.z]);
        // Zero area (coincident or collinear corners, or non-finite ones): never hit, so leave out.
        let n = cross_f64(&c);
        if !(n.norm_squared() > 0.0 && n.norm_squared().is_finite()) {
            continue;
        }
        let lo = [0, 1, 2].map(|a| c[0][a].min(c[1][a]).min(c[2][a]));
        let hi = [0, 1, 2].map(|a| c[0][a].max(c[1][a]).max(c[2][a]));
        let centroid = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]));
        prims.push(Prim { lo, hi, centroid });
        order.push(i as u32);
    }
    let mut nodes = Vec::new();
    if prims.is_empty() {
        return (nodes, order);
    }
    let mut idx: Vec<u32> = (0..prims.len() as u32).collect();
    nodes.reserve(2 * prims.len());
    nodes.push(Node {
        bounds: [0.0; 6],
        first: 0,
        count: 0,
    });
    // (node, start, end, depth)
    let mut work = vec![(0usize, 0usize, prims.len(), 0u32)];
    while let Some((ni, s, e, depth)) = work.pop() {
        let mut bounds = Bin::EMPTY;
        let mut cbounds = Bin::EMPTY;
        for &i in &idx[s..e] {
            let p = &prims[i as usize];
            bounds.add(p);
            cbounds.grow(&p.centroid, &p.centroid);
        }
        nodes[ni].bounds = [
            bounds.lo[0],
            bounds.lo[1],
            bounds.lo[2],
            bounds.hi[0],
            bounds.hi[1],
            bounds.hi[2],
        ];
        let count = e - s;
        let mid = if count <= 1 {
            None
        } else {
            split(&prims, &mut idx[s..e], &bounds, &cbounds, depth).map(|m| s + m)
        };
        match mid {
            None => {
                nodes[ni].first = s as u32;
                nodes[ni].count = count as u32;
            }
            Some(mid) => {
                let l = nodes.len();
                let child = Node {
                    bounds: [0.0; 6],
                    first: 0,
                    count: 0,
                };
                nodes.push(child);
                nodes.push(child);
                nodes[ni].first = l as u32;
                nodes[ni].count = 0;
                // Left popped first, so its subtree is laid out next to this node.
                work.push((l + 1, mid, e, depth + 1));
                work.push((l, s, mid, depth + 1));
            }
        }
    }
    let order = idx.iter().map(|&i| order[i as usize]).collect();
    (nodes, order)
}

/// Choose how to split `idx` (at least two triangles): partitions it in place and returns the
/// size of the left part, or `None` to make a leaf.
fn split(
    prims: &[Prim],
    idx: &mut [u32],
    bounds: &Bin,
    cbounds: &Bin,
    depth: u32,
) -> Option<usize> {
    let count = idx.len();
    let extent = [0, 1, 2].map(|a| cbounds.hi[a] - cbounds.lo[a]);
    let axis = (0..3)
        .max_by(|&a, &b| extent[a].total_cmp(&extent[b]))
        .unwrap_or(0);
    let median = |idx: &mut [u32]| {
        let m = idx.len() / 2;
        idx.select_nth_unstable_by(m, |&i, &j| {
            prims[i as usize].centroid[axis].total_cmp(&prims[j as usize].centroid[axis])
        });
        Some(m)
    };
    // Coincident centroids cannot be binned: any partition is as good as another. (Extents
    // are finite: triangles with non-finite corners were left out.)
    if extent[axis] <= 0.0 {
        return if count <= MAX_LEAF {
            None
        } else {
            Some(count / 2)
        };
    }
    if depth >= SAH_DEPTH {
        return median(idx);
    }

    // Binned SAH over every axis with non-zero centroid extent.
    let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, last left bin)
    for a in 0..3 {
        if extent[a] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / extent[a];
        let mut bins = [Bin::EMPTY; BINS];
        for &i in idx.iter() {
            let p = &prims[i as usize];
            bins[bin_of(p.centroid[a], cbounds.lo[a], scale)].add(p);
        }
        // Sweep from the right: area and count of bins (k+1)..BINS.
        let mut right_area = [0f32; BINS];
        let mut right_count = [0u32; BINS];
        let mut acc = Bin::EMPTY;
        for k in (1..BINS).rev() {
            acc.merge(&bins[k]);
            right_area[k - 1] = acc.half_area();
            right_count[k - 1] = acc.count;
        }
        let mut acc = Bin::EMPTY;
        for k in 0..BINS - 1 {
            acc.merge(&bins[k]);
            if acc.count == 0 || right_count[k] == 0 {
                continue;
            }
            let cost = acc.half_area() * acc.count as f32 + right_area[k] * right_count[k] as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, a, k));
            }
        }
    }
    let Some((cost, a, k)) = best else {
        return median(idx);
    };
    let parent_area = bounds.half_area();
    let split_cost = COST_TRAVERSAL + cost / parent_area;
    if split_cost >= count as f32 && count <= MAX_LEAF {
        return None;
    }
    let scale = BINS as f32 / extent[a];
    let lo = cbounds.lo[a];
    let mut left = 0;
    for j in 0..count {
        if bin_of(prims[idx[j] as usize].centroid[a], lo, scale) <= k {
            idx.swap(j, left);
            left += 1;
        }
    }
    if left == 0 || left == count {
        return median(idx);
    }
    Some(left)
}

#[inline]
fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    // `as usize` saturates (negative and NaN give 0).
    (((c - lo) * scale) as usize).min(BINS - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_send_sync<T: Send + Sync>() {}

    #[test]
    fn bvh_is_send_and_sync() {
        assert_send_sync::<Bvh>();
    }

    #[test]
    fn empty_and_degenerate_meshes_never_hit() {
        let ray = Ray::new(Point3::new(0.2, 0.2, -1.0), Vector3::new(0.0, 0.0, 1.0));
        let empty = Bvh::new(TriangleMesh::default());
        assert!(empty.intersect(&ray, 0.0, f32::INFINITY).is_none());
        assert!(!empty.occluded(&ray, 0.0, f32::INFINITY));
        // A point triangle, a collinear one and a repeated-vertex one, all crossing the ray.
        let mesh = TriangleMesh {
            positions: vec![
                Point3::new(0.2, 0.2, 0.0),
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 1.0, 0.0),
            ],
            triangles: vec![[0, 0, 0], [1, 0, 2], [1, 2, 2]],
            material: vec![0; 3],
        };
        let bvh = Bvh::new(mesh);
        assert!(bvh.intersect(&ray, 0.0, f32::INFINITY).is_none());
        assert!(!bvh.occluded(&ray, 0.0, f32::INFINITY));
    }

    #[test]
    fn many_identical_triangles_build_a_bounded_tree() {
        // Coincident centroids force the count split; the stack must hold the depth.
        let mut mesh = TriangleMesh {
            positions: vec![
                Point3::new(0.0, 0.0, 1.0),
                Point3::new(1.0, 0.0, 1.0),
                Point3::new(0.0, 1.0, 1.0),
            ],
            ..Default::default()
        };
        mesh.triangles = vec![[0, 1, 2]; 1000];
        mesh.material = vec![0; 1000];
        let bvh = Bvh::new(mesh);
        let ray = Ray::new(Point3::new(0.25, 0.25, 0.0), Vector3::new(0.0, 0.0, 1.0));
        let hit = bvh.intersect(&ray, 0.0, f32::INFINITY).unwrap();
        assert!((hit.t - 1.0).abs() < 1e-6);
        let nodes = bvh.pairs.iter().flat_map(|p| p.0);
        assert!(nodes.chain(bvh.root).all(|n| n.count as usize <= MAX_LEAF));
    }

    #[test]
    fn nan_and_zero_rays_do_not_hit_or_panic() {
        let mesh = TriangleMesh {
            positions: vec![
                Point3::new(-1.0, -1.0, 1.0),
                Point3::new(1.0, -1.0, 1.0),
                Point3::new(0.0, 1.0, 1.0),
            ],
            triangles: vec![[0, 1, 2]],
            material: vec![0],
        };
        let bvh = Bvh::new(mesh);
        let o = Point3::origin();
        for dir in [Vector3::zeros(), Vector3::new(f32::NAN, 0.0, 1.0)] {
            assert!(bvh
                .intersect(&Ray::new(o, dir), 0.0, f32::INFINITY)
                .is_none());
        }
        let ray = Ray::new(o, Vector3::z());
        assert!(bvh.intersect(&ray, f32::NAN, 10.0).is_none());
        assert!(
            bvh.intersect(&ray, 0.0, 1.0).is_none(),
            "t_max is exclusive"
        );
        assert!(
            bvh.intersect(&ray, 1.0, 2.0).is_none(),
            "t_min is exclusive"
        );
        assert!(bvh.intersect(&ray, 0.5, 2.0).is_some());
    }
}

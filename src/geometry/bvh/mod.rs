//! Ray-mesh intersection: the public API every caster uses.
//!
//! A wide bounding volume hierarchy (Wald, Benthin and Boulos 2008, "Getting rid of packets";
//! Embree's layouts): four children per node (BVH4) with SSE2 on x86_64 and on other
//! architectures, eight (BVH8) where the CPU has AVX (detected at run time with
//! `is_x86_feature_detected!`; where it also has AVX-512, the same eight-lane code is compiled
//! a second time for it, which gives it 32 vector registers instead of 16). It is built as a
//! binary tree with the binned surface area heuristic (SAH; Wald 2007, "On fast construction
//! of SAH-based bounding volume hierarchies"), whose leaf cost counts triangles in blocks of
//! four, with two rules for rays that start inside the scene (the SAH assumes they come from
//! outside): a node whose box is more than half the scene's is never a leaf and first puts its
//! large triangles (the walls of a room) apart from the others, so each wall ends up in a leaf
//! of its own near the root instead of sharing one whose box is the whole room. The binary
//! tree is then collapsed: each wide node takes the two children of a binary node and keeps
//! opening its largest interior child until it has four (or eight). A node stores its child
//! boxes lane by lane, so one slab test of vectors (the private `geometry::simd`: SSE2 or AVX
//! lanes, plain arrays elsewhere) tests all of them; the hit children are visited nearest
//! first and subtrees that start beyond the current closest hit are culled (with a relative
//! slack of 2^-16, so that rounding never culls a coplanar triangle hit a few ulps nearer,
//! such as a box's bottom face lying on the floor). Leaves hold one or
//! two packets of four triangles, also stored lane by lane and tested against the ray at
//! once; the eight-wide tree tests a leaf's two packets side by side in one eight-lane (AVX)
//! test, which halves the number of triangle tests on leaves of five to eight triangles
//! without making packets of small leaves larger in memory.
//!
//! The ray-box test is the slab test made conservative as in pbrt-v3 §3.9.2 (far distances
//! scaled by `1 + 2 gamma(3)`, NaNs from `0 * inf` on a slab boundary ignored), so no box that
//! holds a hit is ever skipped.
//!
//! The ray-triangle test is the watertight algorithm of Woop, Benthin and Wald (2013,
//! "Watertight ray/triangle intersection", JCGT 2(1)): vertices are moved into a ray-aligned
//! sheared frame and the three 2D edge functions are evaluated there, falling back to double
//! precision when one of them is exactly zero. A ray that passes through a shared edge or vertex
//! of a closed mesh hits at least one of the triangles, whatever rounding does. Both faces of a
//! triangle are hit. Each lane of the wide test performs exactly the scalar test's operations
//! (no fused multiply-add; the double-precision fallback per lane), so the wide test is bit for
//! bit the scalar one and keeps its watertightness; the four- and eight-wide trees therefore
//! return the same hits. Triangles of zero area are left out of the hierarchy, so they never
//! report a hit.
//!
//! femto keeps its own tree rather than a crate's: the binary version of this tree already
//! matched `obvhs` 0.4 (BVH8, SIMD traversal) with the same triangle test on the bunny
//! (`cargo bench --bench bvh`), and its box test is provably conservative for axis-parallel
//! rays; the wide version is what the transient tracer's speed needed
//! (`benches/tracer_results.md`).

#[cfg(target_arch = "x86_64")]
use super::simd::{Avx, Sse};
use super::simd::{Lanes, Native, Pairs, Portable};
use super::{Aabb, Hit, Ray, TriangleMesh};
use nalgebra::{Point3, Vector3};
use std::mem::MaybeUninit;

/// Number of SAH bins per axis.
const BINS: usize = 16;
/// Leaves never hold more triangles than this (the SAH may still choose smaller leaves).
const MAX_LEAF: usize = 8;
/// Triangles per leaf packet (the SIMD width of the triangle test).
const PACKET: usize = 4;
/// Below this depth the SAH picks the split; deeper nodes split at the centroid median, which
/// halves the count at every level and so bounds the depth of any tree by `SAH_DEPTH + 32`.
const SAH_DEPTH: u32 = 64;
/// Traversal stack size: a wide node pushes at most `N - 1 <= 7` entries, and the wide tree
/// is no deeper than the binary one (`SAH_DEPTH + 32` levels), so it must exceed `7 * 97`.
const STACK: usize = 704;
/// Relative cost of one node visit against one test of a packet of triangles, for the SAH.
const COST_TRAVERSAL: f32 = 1.0;
/// A node whose box has more than this fraction of the scene box's half area is never made a
/// leaf while it can be split, and first puts its large triangles (see [`LARGE_FRACTION`])
/// apart from the others. The SAH takes the chance that a ray enters a box to be
/// proportional to its area, as for rays from outside the scene; a ray that starts inside a
/// room enters every box that holds the room's walls, so a leaf of three walls, whose box is
/// the whole room, would be tested by nearly every ray.
const ROOM_FRACTION: f32 = 0.5;
/// A triangle whose box has more than this fraction of the scene box's half area is large:
/// under a node of more than [`ROOM_FRACTION`], large triangles go into one subtree and the
/// others into another, so the walls of a room end up in leaves of their own (each entered
/// only by the rays that hit that wall) near the root.
const LARGE_FRACTION: f32 = 0.1;
/// `1 + 2^-16`: the traversal enters a box, and pops a subtree, when its (rounded) entry
/// distance is below the closest hit so far times this. The rounding of the slab test's entry
/// distance and of the triangle test's `t` could otherwise cull a box holding a coplanar
/// triangle hit a few ulps nearer than the closest hit so far (a box on the floor of a room).
const CULL_SLACK: f32 = 1.0 + 1.0 / 65536.0;
/// `1 + 2 gamma(3)` with `gamma(n) = n u / (1 - n u)`, `u = 2^-24` (pbrt-v3, Eq. 3.9): scaling
/// the far slab distance by this makes the f32 slab test conservative.
const SLAB_FAR_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// A child reference with this bit set is a leaf: bits 28..31 hold its number of packets and
/// bits 0..28 its first packet. Otherwise it is the index of an interior node.
const LEAF: u32 = 1 << 31;
const LEAF_COUNT_SHIFT: u32 = 28;
const LEAF_FIRST_MASK: u32 = (1 << LEAF_COUNT_SHIFT) - 1;
/// An empty child slot: a leaf of no packets (never visited: its box is empty).
const EMPTY_CHILD: u32 = LEAF;

/// One node of a wide tree: `N` child boxes, lane by lane.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node<const N: usize> {
    /// `bounds[plane][child]`: planes `min` x, y, z then `max` x, y, z. Empty slots have
    /// `min = +inf`, `max = -inf`, which the slab test never enters.
    bounds: [[f32; N]; 6],
    /// Child references (see [`LEAF`]).
    child: [u32; N],
}

impl<const N: usize> Node<N> {
    const EMPTY: Node<N> = Node {
        bounds: [
            [f32::INFINITY; N],
            [f32::INFINITY; N],
            [f32::INFINITY; N],
            [f32::NEG_INFINITY; N],
            [f32::NEG_INFINITY; N],
            [f32::NEG_INFINITY; N],
        ],
        child: [EMPTY_CHILD; N],
    };
}

/// Four triangles, lane by lane: `v[corner][axis][lane]`. Unused lanes hold NaN corners,
/// whose edge functions are NaN and never report a hit.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct TriPacket {
    v: [[[f32; PACKET]; 3]; 3],
}

impl TriPacket {
    /// Corners of lane `j`.
    #[cfg(test)]
    fn corners(&self, j: usize) -> [[f32; 3]; 3] {
        self.v.map(|c| [c[0][j], c[1][j], c[2][j]])
    }
}

/// A wide tree of `N` children per node over packets of triangles.
#[derive(Clone, Debug)]
struct Wide<const N: usize> {
    /// Reference to the root (see [`LEAF`]); an empty leaf when the mesh has no triangle of
    /// non-zero area.
    root: u32,
    /// Interior nodes; the root, when interior, is node 0.
    nodes: Vec<Node<N>>,
    /// Leaf triangles in packets.
    packets: Vec<TriPacket>,
    /// Mesh triangle index of each lane of `packets` (`u32::MAX` for unused lanes).
    packet_ids: Vec<[u32; PACKET]>,
}

/// The tree a [`Bvh`] traverses.
#[derive(Clone, Debug)]
enum Tree {
    /// Four children per node (SSE2, or plain arrays off x86_64).
    Four(Wide<4>),
    /// Eight children per node, traversed with AVX (only built where the CPU has it), compiled
    /// for the instruction set `Isa` says.
    Eight(Wide<8>, Isa),
}

/// Values of the `INSTANCE` parameter of [`Wide::intersect`] and [`Wide::occluded`].
const PORTABLE_OR_SSE: u8 = 0;
#[cfg(target_arch = "x86_64")]
const AVX: u8 = 1;
#[cfg(target_arch = "x86_64")]
const AVX512: u8 = 2;

/// The instructions the eight-wide traversal is compiled for. Both run the same lane
/// operations (AVX intrinsics), so they return the same hits bit for bit.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
enum Isa {
    /// AVX: sixteen vector registers.
    Avx,
    /// AVX-512 F and VL (with AVX2, BMI1, BMI2 and POPCNT, which every such CPU has): the same
    /// eight-lane operations, EVEX-encoded, with thirty-two vector registers, so the ray's
    /// constants for the node and triangle tests stay in registers instead of being spilled
    /// to the stack and reloaded at every node and leaf.
    Avx512,
}

/// An acceleration structure that owns its mesh.
#[derive(Clone, Debug)]
pub struct Bvh {
    mesh: TriangleMesh,
    bounds: Aabb,
    tree: Tree,
    /// Unit geometric normal of each mesh triangle (zero for those of zero area).
    normals: Vec<Vector3<f32>>,
}

/// Whether this CPU runs the eight-wide traversal (AVX).
fn has_avx() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The best instruction set for the eight-wide traversal on this CPU (where [`has_avx`]).
fn eight_isa() -> Isa {
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx512f")
            && is_x86_feature_detected!("avx512vl")
            && is_x86_feature_detected!("avx2")
            && is_x86_feature_detected!("bmi1")
            && is_x86_feature_detected!("bmi2")
            && is_x86_feature_detected!("popcnt")
        {
            return Isa::Avx512;
        }
    }
    Isa::Avx
}

impl Bvh {
    /// Build over `mesh` (takes ownership; read it back with [`Bvh::mesh`]).
    ///
    /// Every index in `mesh.triangles` must be a valid position index (the loaders check this).
    pub fn new(mesh: TriangleMesh) -> Bvh {
        Bvh::with_width(mesh, if has_avx() { 8 } else { 4 })
    }

    /// Build with `width` (4 or 8) children per node; 8 only where [`has_avx`].
    fn with_width(mesh: TriangleMesh, width: usize) -> Bvh {
        let bounds = mesh.bounds();
        let (binary, order) = build(&mesh);
        let corners = |i: u32| mesh.corners(i as usize).map(|p| [p.x, p.y, p.z]);
        let tree = if width == 8 {
            Tree::Eight(Wide::collapse(&binary, &order, &corners), eight_isa())
        } else {
            Tree::Four(Wide::collapse(&binary, &order, &corners))
        };
        let normals = (0..mesh.triangle_count())
            .map(|i| {
                let c = corners(i as u32);
                let n = cross_f64(&c);
                if n.norm_squared() > 0.0 && n.norm_squared().is_finite() {
                    geometric_normal(&c)
                } else {
                    Vector3::zeros()
                }
            })
            .collect();
        Bvh {
            mesh,
            bounds,
            tree,
            normals,
        }
    }

    pub fn mesh(&self) -> &TriangleMesh {
        &self.mesh
    }

    /// The unit normal that hits on `triangle` report ([`Hit::normal`]; zero for a
    /// degenerate triangle).
    pub fn normal(&self, triangle: u32) -> Vector3<f32> {
        self.normals[triangle as usize]
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Nearest hit with `t_min < t < t_max` (both sides of every triangle count).
    pub fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        let found = match &self.tree {
            Tree::Four(w) => w.intersect::<Native, Native, PORTABLE_OR_SSE>(ray, t_min, t_max),
            Tree::Eight(w, isa) => intersect_eight(w, *isa, ray, t_min, t_max),
        };
        found.map(|(triangle, t, u, v)| Hit {
            t,
            triangle,
            normal: self.normals[triangle as usize],
            u,
            v,
        })
    }

    /// Whether anything lies on the ray with `t_min < t < t_max` (shadow rays).
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        match &self.tree {
            Tree::Four(w) => w.occluded::<Native, Native, PORTABLE_OR_SSE>(ray, t_min, t_max),
            Tree::Eight(w, isa) => occluded_eight(w, *isa, ray, t_min, t_max),
        }
    }
}

/// [`Wide::intersect`] of an eight-wide tree: AVX or AVX-512 (`isa`) on x86_64 (a tree of
/// eight is only built where the CPU has AVX, with the `isa` it has), plain arrays elsewhere.
#[inline]
fn intersect_eight(
    w: &Wide<8>,
    isa: Isa,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<(u32, f32, f32, f32)> {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: `Tree::Eight` is only built by `Bvh::new` when `has_avx()`, with the `isa`
        // that `eight_isa()` detected; tests that build one or choose an `isa` directly check
        // for them first.
        unsafe {
            match isa {
                Isa::Avx => intersect_avx(w, ray, t_min, t_max),
                Isa::Avx512 => intersect_avx512(w, ray, t_min, t_max),
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = isa;
        w.intersect::<Portable<8>, Portable<8>, PORTABLE_OR_SSE>(ray, t_min, t_max)
    }
}

/// [`Wide::occluded`] of an eight-wide tree (see [`intersect_eight`]).
#[inline]
fn occluded_eight(w: &Wide<8>, isa: Isa, ray: &Ray, t_min: f32, t_max: f32) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: as in `intersect_eight`.
        unsafe {
            match isa {
                Isa::Avx => occluded_avx(w, ray, t_min, t_max),
                Isa::Avx512 => occluded_avx512(w, ray, t_min, t_max),
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = isa;
        w.occluded::<Portable<8>, Portable<8>, PORTABLE_OR_SSE>(ray, t_min, t_max)
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn intersect_avx(w: &Wide<8>, ray: &Ray, t_min: f32, t_max: f32) -> Option<(u32, f32, f32, f32)> {
    w.intersect::<Avx, Avx, AVX>(ray, t_min, t_max)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn occluded_avx(w: &Wide<8>, ray: &Ray, t_min: f32, t_max: f32) -> bool {
    w.occluded::<Avx, Avx, AVX>(ray, t_min, t_max)
}

/// [`intersect_avx`] compiled for [`Isa::Avx512`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,bmi1,bmi2,popcnt,avx512f,avx512vl")]
fn intersect_avx512(
    w: &Wide<8>,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<(u32, f32, f32, f32)> {
    w.intersect::<Avx, Avx, AVX512>(ray, t_min, t_max)
}

/// [`occluded_avx`] compiled for [`Isa::Avx512`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,bmi1,bmi2,popcnt,avx512f,avx512vl")]
fn occluded_avx512(w: &Wide<8>, ray: &Ray, t_min: f32, t_max: f32) -> bool {
    w.occluded::<Avx, Avx, AVX512>(ray, t_min, t_max)
}

impl<const N: usize> Wide<N> {
    /// Nearest hit `(triangle, t, u, v)` with node lanes `V` and leaf lanes `T`.
    ///
    /// `INSTANCE` gives each caller compiled with its own target features (the AVX and the
    /// AVX-512 function) its own copy of this code, and so of the closure inside: a closure is
    /// compiled without its caller's target features unless LLVM inlines it, and it did not
    /// inline one closure shared by two callers, whose lane operations then all became calls
    /// (ten times slower).
    #[inline(always)]
    fn intersect<V: Lanes<N>, T: LeafLanes, const INSTANCE: u8>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> Option<(u32, f32, f32, f32)> {
        // (first packet of the leaf, lane, t, u, v) of the closest hit so far.
        let mut best: Option<(usize, usize, f32, f32, f32)> = None;
        self.traverse::<V, T, _, true>(ray, t_min, t_max, |first, count, tri_ray, t_far| {
            let h = T::test_leaf(&self.packets, first, count, tri_ray, t_min, t_far, false);
            let mut t_best = t_far;
            let mut m = h.mask;
            while m != 0 {
                let j = m.trailing_zeros() as usize;
                m &= m - 1;
                if h.t[j] < t_best {
                    t_best = h.t[j];
                    best = Some((first, j, h.t[j], h.u[j], h.v[j]));
                }
            }
            (t_best, false)
        });
        best.map(|(first, j, t, u, v)| (self.packet_ids[first + j / PACKET][j % PACKET], t, u, v))
    }

    /// Whether anything lies on the ray, with node lanes `V` and leaf lanes `T` (`INSTANCE`
    /// as in [`Wide::intersect`]).
    #[inline(always)]
    fn occluded<V: Lanes<N>, T: LeafLanes, const INSTANCE: u8>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> bool {
        let mut hit = false;
        self.traverse::<V, T, _, false>(ray, t_min, t_max, |first, count, tri_ray, t_far| {
            hit = T::test_leaf(&self.packets, first, count, tri_ray, t_min, t_far, true).mask != 0;
            (t_far, hit)
        });
        hit
    }

    /// Walk the tree, calling `visit(first, count, ray, t_far)` for each leaf (packets
    /// `first .. first + count`) whose box the ray enters before `t_far`. `visit` returns the
    /// new `t_far` and whether to stop.
    /// `ORDERED`: visit the children of a node nearest first (closest hit); otherwise in any
    /// order (any hit: shadow rays), which saves sorting them.
    #[inline(always)]
    fn traverse<V: Lanes<N>, T: LeafLanes, F, const ORDERED: bool>(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        mut visit: F,
    ) where
        F: FnMut(usize, usize, &TriRay<T>, f32) -> (f32, bool),
    {
        // An empty tree's root is the one leaf of no packets that can be reached (an empty child
        // slot's box is never entered); leaf tests need at least one packet.
        if t_min.is_nan() || t_max.is_nan() || t_min >= t_max || self.root == EMPTY_CHILD {
            return;
        }
        // A ray with a NaN or infinite component meets nothing. (Its slab tests give NaN,
        // which `max`/`min` ignore, so it would enter every box, empty child slots included,
        // whose leaf reference holds no packet.)
        if !(ray.origin.iter().all(|x| x.is_finite()) && ray.dir.iter().all(|x| x.is_finite())) {
            return;
        }
        let consts = RayConsts::new(ray);
        let node_ray = NodeRay::<V, N>::new(&consts);
        let tri_ray = T::ray(&consts);
        let t_min_v = V::splat(t_min);
        let mut t_far = t_max;
        let mut t_cull = t_max * CULL_SLACK;
        // Entries: (child reference, entry distance). Left uninitialised: zeroing the stack for
        // every ray cost a few per cent of a short ray's traversal.
        let mut stack = [const { MaybeUninit::<(u32, f32)>::uninit() }; STACK];
        let mut sp = 0usize;
        let mut cur = self.root;
        loop {
            if cur & LEAF == 0 {
                let node = &self.nodes[cur as usize];
                let (mask, t_enter) = slab::<V, N>(node, &node_ray, t_min_v, V::splat(t_cull));
                if mask != 0 {
                    if mask & (mask - 1) == 0 {
                        cur = node.child[mask.trailing_zeros() as usize];
                        continue;
                    }
                    if !ORDERED {
                        // Push all but the first and descend into it.
                        let mut m = mask & (mask - 1);
                        while m != 0 {
                            let j = m.trailing_zeros() as usize;
                            m &= m - 1;
                            stack[sp].write((node.child[j], t_enter[j]));
                            sp += 1;
                        }
                        cur = node.child[mask.trailing_zeros() as usize];
                        continue;
                    }
                    // Two or more children: sort by entry distance, push all but the nearest
                    // (farthest first) and descend into the nearest.
                    let mut hits = [(0u32, 0f32); N];
                    let mut n = 0;
                    let mut m = mask;
                    while m != 0 {
                        let j = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let e = (node.child[j], t_enter[j]);
                        let mut k = n;
                        while k > 0 && hits[k - 1].1 > e.1 {
                            hits[k] = hits[k - 1];
                            k -= 1;
                        }
                        hits[k] = e;
                        n += 1;
                    }
                    for &e in hits[1..n].iter().rev() {
                        stack[sp].write(e);
                        sp += 1;
                    }
                    cur = hits[0].0;
                    continue;
                }
            } else {
                let first = (cur & LEAF_FIRST_MASK) as usize;
                let count = ((cur & !LEAF) >> LEAF_COUNT_SHIFT) as usize;
                let (t, stop) = visit(first, count, &tri_ray, t_far);
                if stop {
                    return;
                }
                t_far = t;
                t_cull = t * CULL_SLACK;
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
                if t_enter < t_cull {
                    cur = next;
                    break;
                }
            }
        }
    }

    /// Collapse the binary tree `binary` (leaves index the build `order`) into a wide one.
    fn collapse(
        binary: &[BuildNode],
        order: &[u32],
        corners: &dyn Fn(u32) -> [[f32; 3]; 3],
    ) -> Wide<N> {
        let mut wide = Wide {
            root: EMPTY_CHILD,
            nodes: Vec::with_capacity(binary.len() / (N - 1) + 1),
            packets: Vec::with_capacity(order.len() / 2 + 1),
            packet_ids: Vec::with_capacity(order.len() / 2 + 1),
        };
        if !binary.is_empty() {
            wide.root = wide.emit(binary, order, corners, 0);
        }
        wide
    }

    /// Emit binary node `ni` and its subtree; returns its child reference.
    fn emit(
        &mut self,
        binary: &[BuildNode],
        order: &[u32],
        corners: &dyn Fn(u32) -> [[f32; 3]; 3],
        ni: usize,
    ) -> u32 {
        let n = &binary[ni];
        if n.count > 0 {
            return self.leaf(order, corners, n.first as usize, n.count as usize);
        }
        // Open the interior child of largest area until there are N.
        let mut kids = vec![n.first as usize, n.first as usize + 1];
        while kids.len() < N {
            let widest = kids
                .iter()
                .enumerate()
                .filter(|(_, &k)| binary[k].count == 0)
                .max_by(|a, b| half_area(&binary[*a.1]).total_cmp(&half_area(&binary[*b.1])));
            let Some((i, &k)) = widest else {
                break;
            };
            let first = binary[k].first as usize;
            kids[i] = first;
            kids.push(first + 1);
        }
        let index = self.nodes.len();
        self.nodes.push(Node::EMPTY);
        for (lane, &k) in kids.iter().enumerate() {
            let b = binary[k].bounds;
            let child = self.emit(binary, order, corners, k);
            let node = &mut self.nodes[index];
            for (plane, &x) in b.iter().enumerate() {
                node.bounds[plane][lane] = x;
            }
            node.child[lane] = child;
        }
        index as u32
    }

    /// Pack leaf slots `first .. first + count` of the build order into packets.
    fn leaf(
        &mut self,
        order: &[u32],
        corners: &dyn Fn(u32) -> [[f32; 3]; 3],
        first: usize,
        count: usize,
    ) -> u32 {
        let first_packet = self.packets.len();
        for chunk in order[first..first + count].chunks(PACKET) {
            let mut p = TriPacket {
                v: [[[f32::NAN; PACKET]; 3]; 3],
            };
            let mut ids = [u32::MAX; PACKET];
            for (j, &tri) in chunk.iter().enumerate() {
                for (k, corner) in corners(tri).iter().enumerate() {
                    for (a, &x) in corner.iter().enumerate() {
                        p.v[k][a][j] = x;
                    }
                }
                ids[j] = tri;
            }
            self.packets.push(p);
            self.packet_ids.push(ids);
        }
        let n_packets = self.packets.len() - first_packet;
        assert!(
            first_packet <= LEAF_FIRST_MASK as usize && n_packets < 8,
            "BVH leaf reference overflow: {first_packet} packets"
        );
        LEAF | ((n_packets as u32) << LEAF_COUNT_SHIFT) | first_packet as u32
    }
}

/// Half the surface area of a binary node's box.
fn half_area(n: &BuildNode) -> f32 {
    let d = [0, 1, 2].map(|a| (n.bounds[3 + a] - n.bounds[a]).max(0.0));
    d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
}

/// Per-ray constants of the slab and watertight triangle tests.
struct RayConsts {
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

impl RayConsts {
    #[inline(always)]
    fn new(ray: &Ray) -> RayConsts {
        let d = [ray.dir.x, ray.dir.y, ray.dir.z];
        // Written without branches: the axis order of random directions is unpredictable.
        let a = d.map(f32::abs);
        let kz = if a[0] >= a[1] && a[0] >= a[2] {
            0
        } else {
            2 - (a[1] >= a[2]) as usize
        };
        // Swap kx and ky when d_kz < 0 to keep the winding.
        let flip = (d[kz] < 0.0) as usize;
        let kx = (kz + 1 + flip) % 3;
        let ky = (kz + 2 - flip) % 3;
        // The five quotients in two vector divisions (each lane exactly the scalar quotient).
        let inv = Native::splat(1.0)
            .div(Native::load(&[d[0], d[1], d[2], 1.0]))
            .to_array();
        let [sx, sy, ..] = Native::load(&[d[kx], d[ky], 1.0, 1.0])
            .div(Native::load(&[d[kz], d[kz], 1.0, 1.0]))
            .to_array();
        let inv_dir = [inv[0], inv[1], inv[2]];
        RayConsts {
            origin: [ray.origin.x, ray.origin.y, ray.origin.z],
            inv_dir,
            near: [0, 1, 2].map(|a| a + 3 * inv_dir[a].is_sign_negative() as usize),
            far: [0, 1, 2].map(|a| a + 3 * inv_dir[a].is_sign_positive() as usize),
            kx,
            ky,
            kz,
            sx,
            sy,
            sz: inv_dir[kz],
        }
    }
}

/// The ray splatted for the slab test of `N` boxes.
struct NodeRay<V, const N: usize> {
    o: [V; 3],
    inv: [V; 3],
    near: [usize; 3],
    far: [usize; 3],
}

impl<V: Lanes<N>, const N: usize> NodeRay<V, N> {
    #[inline(always)]
    fn new(c: &RayConsts) -> Self {
        NodeRay {
            o: c.origin.map(V::splat),
            inv: c.inv_dir.map(V::splat),
            near: c.near,
            far: c.far,
        }
    }
}

/// The ray splatted for the triangle test of a packet.
struct TriRay<T> {
    o: [T; 3],
    kx: usize,
    ky: usize,
    kz: usize,
    sx: T,
    sy: T,
    sz: T,
}

impl<T> TriRay<T> {
    #[inline(always)]
    fn new<const M: usize>(c: &RayConsts) -> Self
    where
        T: Lanes<M>,
    {
        TriRay {
            o: c.origin.map(T::splat),
            kx: c.kx,
            ky: c.ky,
            kz: c.kz,
            sx: T::splat(c.sx),
            sy: T::splat(c.sy),
            sz: T::splat(c.sz),
        }
    }
}

/// Conservative slab test of the `N` boxes of `n`: a bit per child whose box the ray meets
/// within `(t_min, t_far)`, and the entry distances.
#[inline(always)]
fn slab<V: Lanes<N>, const N: usize>(
    n: &Node<N>,
    r: &NodeRay<V, N>,
    t_min: V,
    t_far: V,
) -> (u32, [f32; N]) {
    let mut t0 = t_min;
    let mut t1 = t_far;
    let scale = V::splat(SLAB_FAR_SCALE);
    for a in 0..3 {
        let near = V::load(&n.bounds[r.near[a]]).sub(r.o[a]).mul(r.inv[a]);
        let far = V::load(&n.bounds[r.far[a]])
            .sub(r.o[a])
            .mul(r.inv[a])
            .mul(scale);
        // `max`/`min` keep the running bound when `near`/`far` is NaN (0 * inf: the origin on
        // the slab plane of a parallel ray), leaving the interval unchanged.
        t0 = near.max(t0);
        t1 = far.min(t1);
    }
    (t0.le(t1).bits(), t0.to_array())
}

/// How the triangle test reads the packets of a leaf: packet by packet in four lanes, or
/// (eight-wide tree, AVX) the leaf's one or two packets side by side in eight lanes, which
/// halves the number of tests while the packets stay four wide in memory (a leaf of one to
/// four triangles reads no more than in the four-wide tree).
trait LeafLanes: Sized {
    /// The ray splatted into these lanes.
    fn ray(c: &RayConsts) -> TriRay<Self>;

    /// Hits of the triangles of `packets[first .. first + count]` (`count` is 1 or 2; lane
    /// `4 i + j` is lane `j` of packet `first + i`) with `t_min < t < t_max`. With `any`
    /// (shadow rays) the test may stop at the first packet that has a hit.
    fn test_leaf(
        packets: &[TriPacket],
        first: usize,
        count: usize,
        r: &TriRay<Self>,
        t_min: f32,
        t_max: f32,
        any: bool,
    ) -> PacketHits<8>;
}

/// [`LeafLanes::test_leaf`] one four-lane packet at a time.
#[inline(always)]
fn leaf_by_packets<T: Lanes<PACKET>>(
    packets: &[TriPacket],
    first: usize,
    count: usize,
    r: &TriRay<T>,
    t_min: f32,
    t_max: f32,
    any: bool,
) -> PacketHits<8> {
    let mut out = PacketHits::<8>::NONE;
    for (i, p) in packets[first..first + count].iter().enumerate() {
        let h = packet_test::<T, PACKET, _>(p, r, t_min, t_max);
        if h.mask != 0 {
            out.mask |= h.mask << (PACKET * i);
            let lanes = PACKET * i..PACKET * (i + 1);
            out.t[lanes.clone()].copy_from_slice(&h.t);
            out.u[lanes.clone()].copy_from_slice(&h.u);
            out.v[lanes].copy_from_slice(&h.v);
            if any {
                break;
            }
        }
    }
    out
}

/// [`LeafLanes::test_leaf`] in one test of eight lanes: packet `first` in lanes 0..4, the
/// leaf's last packet in lanes 4..8. A leaf of one packet tests it twice and keeps the lower
/// half, which costs less than a branch on the count that random rays mispredict.
#[inline(always)]
fn leaf_by_pairs<T: Pairs>(
    packets: &[TriPacket],
    first: usize,
    count: usize,
    r: &TriRay<T>,
    t_min: f32,
    t_max: f32,
) -> PacketHits<8> {
    // Leaves hold one or two packets; a count of 0 (an empty child slot, which traversal
    // never enters with a finite ray) tests packet `first` and keeps no lane, instead of
    // indexing `first - 1`.
    debug_assert!((1..=2).contains(&count), "leaf of {count} packets");
    let pair = PacketPair(&packets[first], &packets[first + count.max(1) - 1]);
    let mut h = packet_test::<T, 8, _>(&pair, r, t_min, t_max);
    h.mask &= match count {
        2 => 0xff,
        1 => 0x0f,
        _ => 0,
    };
    h
}

/// `impl LeafLanes` for a lane type that tests a leaf `by_packets` (one four-lane packet at a
/// time: four-lane types) or `by_pairs` (two packets side by side: eight-lane types).
macro_rules! leaf_lanes {
    ($lanes:ty, $test:ident) => {
        impl LeafLanes for $lanes {
            #[inline(always)]
            fn ray(c: &RayConsts) -> TriRay<Self> {
                TriRay::new(c)
            }
            #[inline(always)]
            fn test_leaf(
                packets: &[TriPacket],
                first: usize,
                count: usize,
                r: &TriRay<Self>,
                t_min: f32,
                t_max: f32,
                any: bool,
            ) -> PacketHits<8> {
                leaf_lanes!(@$test packets, first, count, r, t_min, t_max, any)
            }
        }
    };
    (@by_packets $($arg:expr),*) => {
        leaf_by_packets($($arg),*)
    };
    (@by_pairs $p:expr, $f:expr, $c:expr, $r:expr, $a:expr, $b:expr, $any:expr) => {{
        let _ = $any; // a pair is one test: nothing to stop early
        leaf_by_pairs($p, $f, $c, $r, $a, $b)
    }};
}

leaf_lanes!(Portable<4>, by_packets);
leaf_lanes!(Portable<8>, by_pairs);
#[cfg(target_arch = "x86_64")]
leaf_lanes!(Sse, by_packets);
#[cfg(target_arch = "x86_64")]
leaf_lanes!(Avx, by_pairs);

/// Where [`packet_test`] reads corner `k`, axis `a` of its triangles.
trait Corners<T> {
    fn load(&self, k: usize, a: usize) -> T;
}

impl<T: Lanes<PACKET>> Corners<T> for TriPacket {
    #[inline(always)]
    fn load(&self, k: usize, a: usize) -> T {
        T::load(&self.v[k][a])
    }
}

/// Two packets side by side, eight lanes.
struct PacketPair<'a>(&'a TriPacket, &'a TriPacket);

impl<T: Pairs> Corners<T> for PacketPair<'_> {
    #[inline(always)]
    fn load(&self, k: usize, a: usize) -> T {
        T::load_pair(&self.0.v[k][a], &self.1.v[k][a])
    }
}

/// Corner `k` of each triangle relative to the ray origin, sheared and scaled into the ray's
/// frame (the ray becomes the +z axis). A function rather than a closure so that it is always
/// inlined into its caller, whose target features (AVX) the lane operations need.
#[inline(always)]
fn sheared_corner<T: Lanes<M>, const M: usize, C: Corners<T>>(
    p: &C,
    k: usize,
    r: &TriRay<T>,
) -> (T, T, T) {
    let pz = p.load(k, r.kz).sub(r.o[r.kz]);
    let px = p.load(k, r.kx).sub(r.o[r.kx]).sub(r.sx.mul(pz));
    let py = p.load(k, r.ky).sub(r.o[r.ky]).sub(r.sy.mul(pz));
    (px, py, pz)
}

/// Result of [`packet_test`]: a bit per lane that hits, and each lane's distance and
/// barycentrics (meaningful where the bit is set).
struct PacketHits<const M: usize> {
    mask: u32,
    t: [f32; M],
    u: [f32; M],
    v: [f32; M],
}

impl<const M: usize> PacketHits<M> {
    const NONE: Self = PacketHits {
        mask: 0,
        t: [0.0; M],
        u: [0.0; M],
        v: [0.0; M],
    };
}

/// Watertight two-sided ray-triangle test (Woop, Benthin and Wald 2013) of the `M` triangles
/// of `p`, hits with `t_min < t < t_max` only. Each lane computes exactly what the scalar test
/// would (see the module doc).
#[inline(always)]
fn packet_test<T: Lanes<M>, const M: usize, C: Corners<T>>(
    p: &C,
    r: &TriRay<T>,
    t_min: f32,
    t_max: f32,
) -> PacketHits<M> {
    let (ax, ay, az) = sheared_corner(p, 0, r);
    let (bx, by, bz) = sheared_corner(p, 1, r);
    let (cx, cy, cz) = sheared_corner(p, 2, r);
    // Scaled barycentric coordinates (2D edge functions).
    let mut u = cx.mul(by).sub(cy.mul(bx));
    let mut v = ax.mul(cy).sub(ay.mul(cx));
    let mut w = bx.mul(ay).sub(by.mul(ax));
    let zero = T::splat(0.0);
    let on_edge = u.eq(zero).or(v.eq(zero)).or(w.eq(zero)).bits();
    if on_edge != 0 {
        // Exactly zero in f32: recompute those lanes in f64, where the products are exact.
        let f = |p: f32, q: f32, s: f32, t: f32| (p as f64 * q as f64 - s as f64 * t as f64) as f32;
        let (ax, ay, bx, by, cx, cy) = (
            ax.to_array(),
            ay.to_array(),
            bx.to_array(),
            by.to_array(),
            cx.to_array(),
            cy.to_array(),
        );
        let (mut ua, mut va, mut wa) = (u.to_array(), v.to_array(), w.to_array());
        for j in 0..M {
            if on_edge & (1 << j) != 0 {
                ua[j] = f(cx[j], by[j], cy[j], bx[j]);
                va[j] = f(ax[j], cy[j], ay[j], cx[j]);
                wa[j] = f(bx[j], ay[j], by[j], ax[j]);
            }
        }
        (u, v, w) = (T::load(&ua), T::load(&va), T::load(&wa));
    }
    // Two-sided: reject only when the signs differ.
    let neg = u.lt(zero).or(v.lt(zero)).or(w.lt(zero));
    let pos = u.gt(zero).or(v.gt(zero)).or(w.gt(zero));
    let det = u.add(v).add(w);
    let t_scaled = u
        .mul(r.sz.mul(az))
        .add(v.mul(r.sz.mul(bz)))
        .add(w.mul(r.sz.mul(cz)));
    let inv_det = T::splat(1.0).div(det);
    let t = t_scaled.mul(inv_det);
    // A NaN `t` (degenerate ray, unused lane) fails both comparisons.
    let in_range = t.gt(T::splat(t_min)).and(t.lt(T::splat(t_max)));
    let mask = neg.and(pos).or(det.eq(zero)).andnot(in_range).bits();
    if mask == 0 {
        return PacketHits::NONE;
    }
    PacketHits {
        mask,
        t: t.to_array(),
        u: v.mul(inv_det).to_array(),
        v: w.mul(inv_det).to_array(),
    }
}

/// Distance and barycentrics of a triangle hit.
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
struct TriHit {
    t: f32,
    u: f32,
    v: f32,
}

/// Watertight two-sided ray-triangle test (Woop, Benthin and Wald 2013), hits with
/// `t_min < t < t_max` only: the scalar reference that each lane of [`packet_test`] must
/// reproduce bit for bit.
#[cfg(test)]
fn intersect_triangle(
    tri: &[[f32; 3]; 3],
    r: &RayConsts,
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

/// One node of the binary build tree.
#[derive(Clone, Copy, Debug)]
struct BuildNode {
    /// Box corners: `min` x, y, z then `max` x, y, z.
    bounds: [f32; 6],
    /// Leaf: first entry of the build order. Interior: index of its first child (the second
    /// follows it).
    first: u32,
    /// Number of triangles of a leaf; 0 for an interior node.
    count: u32,
}

/// Build record of one triangle.
struct Prim {
    lo: [f32; 3],
    hi: [f32; 3],
    centroid: [f32; 3],
}

impl Prim {
    /// Half the surface area of the triangle's box.
    fn half_area(&self) -> f32 {
        let d = [0, 1, 2].map(|a| (self.hi[a] - self.lo[a]).max(0.0));
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }
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
fn build(mesh: &TriangleMesh) -> (Vec<BuildNode>, Vec<u32>) {
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
    let mut scene = Bin::EMPTY;
    for p in &prims {
        scene.add(p);
    }
    let scene_area = scene.half_area();
    let mut nodes = Vec::new();
    if prims.is_empty() {
        return (nodes, order);
    }
    let mut idx: Vec<u32> = (0..prims.len() as u32).collect();
    nodes.reserve(2 * prims.len());
    nodes.push(BuildNode {
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
            split(&prims, &mut idx[s..e], &bounds, &cbounds, depth, scene_area).map(|m| s + m)
        };
        match mid {
            None => {
                nodes[ni].first = s as u32;
                nodes[ni].count = count as u32;
            }
            Some(mid) => {
                let l = nodes.len();
                let child = BuildNode {
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

/// Choose how to split `idx` (at least two triangles; `scene_area`: half area of the box of
/// all triangles): partitions it in place and returns the size of the left part, or `None` to
/// make a leaf.
fn split(
    prims: &[Prim],
    idx: &mut [u32],
    bounds: &Bin,
    cbounds: &Bin,
    depth: u32,
    scene_area: f32,
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
    let room = bounds.half_area() > ROOM_FRACTION * scene_area;
    if room {
        // Large triangles first, the others after.
        let large = LARGE_FRACTION * scene_area;
        let mut left = 0;
        for j in 0..count {
            if prims[idx[j] as usize].half_area() > large {
                idx.swap(j, left);
                left += 1;
            }
        }
        if left > 0 && left < count {
            return Some(left);
        }
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
            let cost = acc.half_area() * blocks(acc.count as usize)
                + right_area[k] * blocks(right_count[k] as usize);
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
    if split_cost >= blocks(count) && count <= MAX_LEAF && !room {
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

/// SAH cost of testing `n` triangles: the number of packets they fill.
fn blocks(n: usize) -> f32 {
    n.div_ceil(PACKET) as f32
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

    /// Rays with a NaN or an infinite component (a camera path or calibration gone wrong,
    /// issue 16) meet nothing and never reach an empty child slot's leaf of no packets,
    /// whose eight-lane test indexed `first - 1` ("index out of bounds in leaf_by_pairs").
    /// Triangles with a non-finite corner are left out of the tree.
    #[test]
    fn non_finite_rays_and_corners_meet_nothing() {
        let mut rng = Uniforms(7);
        let mut mesh = test_mesh(&mut rng);
        // One triangle with a NaN corner among the others.
        let bad = mesh.positions.len() as u32;
        mesh.positions.push(Point3::new(f32::NAN, 0.0, 0.0));
        mesh.triangles.push([bad, 0, 1]);
        mesh.material.push(0);
        let finite = Ray::new(Point3::new(0.1, 0.2, -5.0), Vector3::new(0.0, 0.0, 1.0));
        let (nan, inf) = (f32::NAN, f32::INFINITY);
        let rays = [
            Ray::new(Point3::new(0.0, nan, 0.0), Vector3::new(0.0, 0.0, 1.0)),
            Ray::new(Point3::new(0.0, -inf, 0.0), Vector3::new(0.0, 0.0, 1.0)),
            Ray::new(Point3::new(0.0, 0.0, -5.0), Vector3::new(nan, nan, nan)),
            Ray::new(Point3::new(0.0, 0.0, -5.0), Vector3::new(0.0, inf, 1.0)),
        ];
        for width in [4, 8] {
            let b = Bvh::with_width(mesh.clone(), width);
            if width == 4 || has_avx() {
                // The finite ray still works (and never reports the NaN triangle).
                let hit = brute_force(&mesh, &finite, f32::INFINITY);
                let got = b.intersect(&finite, 0.0, f32::INFINITY);
                assert_eq!(got.map(|h| h.triangle), hit.map(|h| h.0));
                assert_ne!(got.map(|h| h.triangle), Some(bad));
            }
            for r in &rays {
                if width == 4 || has_avx() {
                    assert!(b.intersect(r, 0.0, f32::INFINITY).is_none(), "{r:?}");
                    assert!(!b.occluded(r, 0.0, f32::INFINITY), "{r:?}");
                }
                if width == 8 {
                    let w = eight(&b);
                    assert!(w
                        .intersect::<Portable<8>, Portable<8>, PORTABLE_OR_SSE>(r, 0.0, inf)
                        .is_none());
                    assert!(!w.occluded::<Portable<8>, Portable<8>, PORTABLE_OR_SSE>(r, 0.0, inf));
                }
            }
        }
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
        for width in [4, 8] {
            let bvh = Bvh::with_width(mesh.clone(), width);
            match &bvh.tree {
                Tree::Four(w) => check_leaves(w, 1000),
                Tree::Eight(w, _) => check_leaves(w, 1000),
            }
            if width == 4 || has_avx() {
                let ray = Ray::new(Point3::new(0.25, 0.25, 0.0), Vector3::new(0.0, 0.0, 1.0));
                let hit = bvh.intersect(&ray, 0.0, f32::INFINITY).unwrap();
                assert!((hit.t - 1.0).abs() < 1e-6);
            }
        }
    }

    /// Every leaf holds at most MAX_LEAF triangles, in at most ceil(MAX_LEAF / 4) packets, and
    /// the `n` triangles are in the tree exactly once.
    fn check_leaves<const N: usize>(w: &Wide<N>, n: u32) {
        let refs = w.nodes.iter().flat_map(|n| n.child).chain([w.root]);
        for r in refs.filter(|r| r & LEAF != 0) {
            let packets = ((r & !LEAF) >> LEAF_COUNT_SHIFT) as usize;
            assert!(packets <= MAX_LEAF.div_ceil(PACKET));
            let first = (r & LEAF_FIRST_MASK) as usize;
            let tris = w.packet_ids[first..first + packets]
                .iter()
                .flatten()
                .filter(|&&id| id != u32::MAX)
                .count();
            assert!(tris <= MAX_LEAF);
        }
        let mut ids: Vec<u32> = w.packet_ids.iter().flatten().copied().collect();
        ids.retain(|&id| id != u32::MAX);
        ids.sort_unstable();
        assert_eq!(ids, (0..n).collect::<Vec<u32>>());
    }

    /// A splitmix64 stream of uniforms in [0, 1) (no dependence on the code under test).
    struct Uniforms(u64);

    impl Uniforms {
        fn next(&mut self) -> f32 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
        }

        fn range(&mut self, lo: f32, hi: f32) -> f32 {
            lo + (hi - lo) * self.next()
        }
    }

    /// A soup of random triangles of very different sizes, a grid of quads on integer
    /// coordinates (rays along the axes through their shared edges and corners make edge
    /// functions exactly zero) and a few triangles of zero area.
    fn test_mesh(rng: &mut Uniforms) -> TriangleMesh {
        let mut mesh = TriangleMesh::default();
        let push = |mesh: &mut TriangleMesh, c: [[f32; 3]; 3]| {
            let base = mesh.positions.len() as u32;
            mesh.positions
                .extend(c.iter().map(|p| Point3::new(p[0], p[1], p[2])));
            mesh.triangles.push([base, base + 1, base + 2]);
            mesh.material.push(0);
        };
        for k in 0..300 {
            let size = if k % 10 == 0 { 3.0 } else { 0.2 };
            let o = [0, 1, 2].map(|_| rng.range(-2.0, 2.0));
            let c = [0, 1, 2].map(|_| [0, 1, 2].map(|a| o[a] + rng.range(-size, size)));
            push(&mut mesh, c);
        }
        for i in -2..2 {
            for j in -2..2 {
                let (x, y, z) = (i as f32, j as f32, 0.5);
                push(
                    &mut mesh,
                    [[x, y, z], [x + 1.0, y, z], [x + 1.0, y + 1.0, z]],
                );
                push(
                    &mut mesh,
                    [[x, y, z], [x + 1.0, y + 1.0, z], [x, y + 1.0, z]],
                );
            }
        }
        push(&mut mesh, [[0.1, 0.1, 0.0]; 3]);
        push(
            &mut mesh,
            [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]],
        );
        mesh
    }

    fn test_rays(rng: &mut Uniforms, n: usize) -> Vec<(Ray, f32)> {
        let mut rays = Vec::new();
        for k in 0..n {
            let o = Point3::new(
                rng.range(-4.0, 4.0),
                rng.range(-4.0, 4.0),
                rng.range(-4.0, 4.0),
            );
            let dir = match k % 4 {
                // Axis-aligned (through grid edges and corners when the origin is on one).
                0 => {
                    let o = Point3::new(o.x.round() * 0.5, o.y.round() * 0.5, -3.0);
                    rays.push((Ray::new(o, Vector3::new(0.0, 0.0, 1.0)), f32::INFINITY));
                    continue;
                }
                // Towards a random point of the soup's region.
                _ => {
                    let target = Vector3::new(
                        rng.range(-2.0, 2.0),
                        rng.range(-2.0, 2.0),
                        rng.range(-2.0, 2.0),
                    );
                    (target - o.coords).normalize()
                }
            };
            let t_max = if k % 3 == 0 {
                rng.range(0.5, 6.0)
            } else {
                f32::INFINITY
            };
            rays.push((Ray::new(o, dir), t_max));
        }
        rays
    }

    /// Brute force with the scalar watertight test: the nearest hit `(triangle, t, u, v)`
    /// over all triangles of non-zero area (the first triangle on a tie of `t`).
    fn brute_force(mesh: &TriangleMesh, ray: &Ray, t_max: f32) -> Option<(u32, f32, f32, f32)> {
        let consts = RayConsts::new(ray);
        let mut best: Option<(u32, f32, f32, f32)> = None;
        for i in 0..mesh.triangle_count() {
            let c = mesh.corners(i).map(|p| [p.x, p.y, p.z]);
            if cross_f64(&c).norm_squared() <= 0.0 {
                continue;
            }
            if let Some(h) = intersect_triangle(&c, &consts, 0.0, t_max) {
                if best.is_none_or(|b| h.t < b.1) {
                    best = Some((i as u32, h.t, h.u, h.v));
                }
            }
        }
        best
    }

    /// A tree walk under test: nearest hit `(triangle, t, u, v)` and occlusion.
    type Cast = dyn Fn(&Bvh, &Ray, f32) -> (Option<(u32, f32, f32, f32)>, bool);

    /// The walk `cast` of a tree of `width` finds what brute force finds: the same distance bit
    /// for bit, the same triangle (or, on a tie of distance, one at the same distance) and
    /// barycentrics; `occluded` agrees; the public API gives the same hit with its normal.
    /// Both on the soup of [`test_mesh`] and inside the room of [`room_mesh`].
    fn agrees_with_brute_force(width: usize, cast: &Cast) {
        let mut rng = Uniforms(11);
        let mesh = test_mesh(&mut rng);
        let rays = test_rays(&mut rng, 3000);
        agrees_on(&mesh, &rays, width, cast);
        let mesh = room_mesh(&mut rng);
        let rays = room_rays(&mut rng, 2000);
        agrees_on(&mesh, &rays, width, cast);
    }

    fn agrees_on(mesh: &TriangleMesh, rays: &[(Ray, f32)], width: usize, cast: &Cast) {
        let bvh = Bvh::with_width(mesh.clone(), width);
        let public = width == 4 || has_avx();
        let mut hits = 0;
        for (k, (ray, t_max)) in rays.iter().enumerate() {
            let expected = brute_force(mesh, ray, *t_max);
            let (got, occluded) = cast(&bvh, ray, *t_max);
            assert_eq!(occluded, expected.is_some(), "ray {k}");
            match (expected, got) {
                (None, None) => {}
                (Some((tri, t, u, v)), Some((h_tri, h_t, h_u, h_v))) => {
                    hits += 1;
                    assert_eq!(h_t.to_bits(), t.to_bits(), "ray {k}");
                    if h_tri == tri {
                        assert_eq!((h_u, h_v), (u, v), "ray {k}");
                    } else {
                        // A tie: the other triangle must hit at exactly the same distance.
                        let c = mesh.corners(h_tri as usize).map(|p| [p.x, p.y, p.z]);
                        let other =
                            intersect_triangle(&c, &RayConsts::new(ray), 0.0, f32::INFINITY);
                        assert_eq!(other.unwrap().t.to_bits(), t.to_bits(), "ray {k}");
                    }
                }
                (e, g) => panic!("ray {k}: brute force {e:?}, BVH {g:?}"),
            }
            if public {
                let h = bvh.intersect(ray, 0.0, *t_max);
                assert_eq!(h.map(|h| (h.triangle, h.t, h.u, h.v)), got, "ray {k}");
                if let Some(h) = h {
                    let c = mesh.corners(h.triangle as usize).map(|p| [p.x, p.y, p.z]);
                    assert_eq!(h.normal, geometric_normal(&c));
                }
                assert_eq!(bvh.occluded(ray, 0.0, *t_max), occluded);
            }
        }
        assert!(hits > 1000, "only {hits} rays hit");
    }

    /// A room (the unit cube without its front face z = 1: five walls of two triangles each,
    /// triangles 0..10, wall `i / 2`), an open box standing on its floor (its bottom face is
    /// coplanar with the floor) and a cluster of 200 small triangles in the air.
    fn room_mesh(rng: &mut Uniforms) -> TriangleMesh {
        let mut mesh = TriangleMesh::default();
        let mut quad = |c: [[f32; 3]; 4]| {
            let base = mesh.positions.len() as u32;
            mesh.positions
                .extend(c.iter().map(|p| Point3::new(p[0], p[1], p[2])));
            mesh.triangles.push([base, base + 1, base + 2]);
            mesh.triangles.push([base, base + 2, base + 3]);
            mesh.material.extend([0, 0]);
        };
        // Walls: floor, ceiling, back, left, right.
        quad([[0., 0., 0.], [1., 0., 0.], [1., 0., 1.], [0., 0., 1.]]);
        quad([[0., 1., 0.], [1., 1., 0.], [1., 1., 1.], [0., 1., 1.]]);
        quad([[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]]);
        quad([[0., 0., 0.], [0., 1., 0.], [0., 1., 1.], [0., 0., 1.]]);
        quad([[1., 0., 0.], [1., 1., 0.], [1., 1., 1.], [1., 0., 1.]]);
        // An open box (no lid) [0.3, 0.5] x [0, 0.2] x [0.3, 0.5]: bottom and four sides.
        let (l, h, top) = (0.3, 0.5, 0.2);
        quad([[l, 0., l], [h, 0., l], [h, 0., h], [l, 0., h]]);
        quad([[l, 0., l], [h, 0., l], [h, top, l], [l, top, l]]);
        quad([[l, 0., h], [h, 0., h], [h, top, h], [l, top, h]]);
        quad([[l, 0., l], [l, top, l], [l, top, h], [l, 0., h]]);
        quad([[h, 0., l], [h, top, l], [h, top, h], [h, 0., h]]);
        for _ in 0..200 {
            let o = [0.6, 0.5, 0.6].map(|x| x + rng.range(-0.15, 0.15));
            let c = [0, 1, 2].map(|_| [0, 1, 2].map(|a| o[a] + rng.range(-0.03, 0.03)));
            let base = mesh.positions.len() as u32;
            mesh.positions
                .extend(c.iter().map(|p| Point3::new(p[0], p[1], p[2])));
            mesh.triangles.push([base, base + 1, base + 2]);
            mesh.material.push(0);
        }
        mesh
    }

    /// Rays from inside the room of [`room_mesh`]: every third towards a point of the box's
    /// bottom face, which lies on the floor, so the floor and the box's bottom are hit at
    /// distances a few ulps apart; the others in random directions.
    fn room_rays(rng: &mut Uniforms, n: usize) -> Vec<(Ray, f32)> {
        (0..n)
            .map(|k| {
                let o = Point3::new(
                    rng.range(0.05, 0.95),
                    rng.range(0.25, 0.95),
                    rng.range(0.05, 0.95),
                );
                let target = if k % 3 == 0 {
                    Point3::new(rng.range(0.3, 0.5), 0.0, rng.range(0.3, 0.5))
                } else {
                    Point3::new(
                        rng.range(-1.0, 2.0),
                        rng.range(-1.0, 2.0),
                        rng.range(-1.0, 2.0),
                    )
                };
                let t_max = if k % 5 == 0 {
                    rng.range(0.1, 1.0)
                } else {
                    f32::INFINITY
                };
                (Ray::new(o, (target - o).normalize()), t_max)
            })
            .collect()
    }

    /// Triangle ids of each leaf of `w`.
    fn leaf_triangles<const N: usize>(w: &Wide<N>) -> Vec<Vec<u32>> {
        let refs = w.nodes.iter().flat_map(|n| n.child).chain([w.root]);
        refs.filter(|&r| r & LEAF != 0 && r != EMPTY_CHILD)
            .map(|r| {
                let packets = ((r & !LEAF) >> LEAF_COUNT_SHIFT) as usize;
                let first = (r & LEAF_FIRST_MASK) as usize;
                w.packet_ids[first..first + packets]
                    .iter()
                    .flatten()
                    .copied()
                    .filter(|&id| id != u32::MAX)
                    .collect()
            })
            .collect()
    }

    #[test]
    fn walls_of_a_room_are_leaves_of_their_own() {
        // A leaf holding a wall and anything else would be entered by nearly every ray from
        // inside the room; each wall's two triangles must be alone in their leaf.
        let mesh = room_mesh(&mut Uniforms(5));
        for width in [4, 8] {
            let bvh = Bvh::with_width(mesh.clone(), width);
            let leaves = match &bvh.tree {
                Tree::Four(w) => leaf_triangles(w),
                Tree::Eight(w, _) => leaf_triangles(w),
            };
            for leaf in leaves {
                if let Some(wall) = leaf.iter().find(|&&id| id < 10).map(|id| id / 2) {
                    assert!(
                        leaf.iter().all(|&id| id / 2 == wall && id < 10),
                        "width {width}: leaf {leaf:?} mixes wall {wall} with other triangles"
                    );
                }
            }
        }
    }

    fn four(b: &Bvh) -> &Wide<4> {
        match &b.tree {
            Tree::Four(w) => w,
            Tree::Eight(..) => unreachable!("built with width 4"),
        }
    }

    fn eight(b: &Bvh) -> &Wide<8> {
        match &b.tree {
            Tree::Eight(w, _) => w,
            Tree::Four(_) => unreachable!("built with width 8"),
        }
    }

    #[test]
    fn four_wide_tree_agrees_with_brute_force_native() {
        agrees_with_brute_force(4, &|b, r, t| {
            let w = four(b);
            (
                w.intersect::<Native, Native, PORTABLE_OR_SSE>(r, 0.0, t),
                w.occluded::<Native, Native, PORTABLE_OR_SSE>(r, 0.0, t),
            )
        });
    }

    #[test]
    fn four_wide_tree_agrees_with_brute_force_portable() {
        agrees_with_brute_force(4, &|b, r, t| {
            let w = four(b);
            (
                w.intersect::<Portable<4>, Portable<4>, PORTABLE_OR_SSE>(r, 0.0, t),
                w.occluded::<Portable<4>, Portable<4>, PORTABLE_OR_SSE>(r, 0.0, t),
            )
        });
    }

    #[test]
    fn eight_wide_tree_agrees_with_brute_force_portable() {
        agrees_with_brute_force(8, &|b, r, t| {
            let w = eight(b);
            (
                w.intersect::<Portable<8>, Portable<8>, PORTABLE_OR_SSE>(r, 0.0, t),
                w.occluded::<Portable<8>, Portable<8>, PORTABLE_OR_SSE>(r, 0.0, t),
            )
        });
    }

    #[test]
    fn eight_wide_tree_agrees_with_brute_force_avx() {
        if !has_avx() {
            println!("skipped: no AVX on this CPU");
            return;
        }
        agrees_with_brute_force(8, &|b, r, t| {
            let w = eight(b);
            (
                intersect_eight(w, Isa::Avx, r, 0.0, t),
                occluded_eight(w, Isa::Avx, r, 0.0, t),
            )
        });
    }

    #[test]
    fn eight_wide_tree_agrees_with_brute_force_avx512() {
        if !has_avx() || eight_isa() != Isa::Avx512 {
            println!("skipped: no AVX-512 on this CPU");
            return;
        }
        agrees_with_brute_force(8, &|b, r, t| {
            let w = eight(b);
            (
                intersect_eight(w, Isa::Avx512, r, 0.0, t),
                occluded_eight(w, Isa::Avx512, r, 0.0, t),
            )
        });
    }

    /// Each lane of the packet test is the scalar test, bit for bit, including lanes that
    /// take the double-precision fallback (rays through shared edges and corners).
    fn packet_lanes_are_the_scalar_test<T: Lanes<PACKET>>() {
        let mut rng = Uniforms(12);
        let mesh = test_mesh(&mut rng);
        let bvh = Bvh::with_width(mesh, 4);
        let w = four(&bvh);
        let mut compared = 0;
        for (ray, t_max) in test_rays(&mut rng, 400) {
            let consts = RayConsts::new(&ray);
            let tri_ray = TriRay::<T>::new(&consts);
            for (p, ids) in w.packets.iter().zip(&w.packet_ids) {
                let h = packet_test::<T, PACKET, _>(p, &tri_ray, 0.0, t_max);
                for (j, &id) in ids.iter().enumerate() {
                    let scalar = if id == u32::MAX {
                        None
                    } else {
                        intersect_triangle(&p.corners(j), &consts, 0.0, t_max)
                    };
                    match scalar {
                        None => assert_eq!(h.mask & (1 << j), 0),
                        Some(s) => {
                            compared += 1;
                            assert_ne!(h.mask & (1 << j), 0);
                            assert_eq!(
                                (h.t[j].to_bits(), h.u[j].to_bits(), h.v[j].to_bits()),
                                (s.t.to_bits(), s.u.to_bits(), s.v.to_bits())
                            );
                        }
                    }
                }
            }
        }
        assert!(compared > 400, "{compared}");
    }

    #[test]
    fn packet_lanes_are_the_scalar_test_native() {
        packet_lanes_are_the_scalar_test::<Native>();
    }

    #[test]
    fn packet_lanes_are_the_scalar_test_portable() {
        packet_lanes_are_the_scalar_test::<Portable<4>>();
    }

    /// Each lane of the eight-lane leaf test (two packets side by side, or one packet whose
    /// upper half is masked off) is the scalar test of its triangle, bit for bit.
    fn pair_lanes_are_the_scalar_test<T: LeafLanes>() {
        let mut rng = Uniforms(13);
        let mesh = test_mesh(&mut rng);
        let bvh = Bvh::with_width(mesh, 4);
        let w = four(&bvh);
        let mut compared = 0;
        for (ray, t_max) in test_rays(&mut rng, 300) {
            let consts = RayConsts::new(&ray);
            let tri_ray = T::ray(&consts);
            for first in 0..w.packets.len() {
                for count in 1..=2.min(w.packets.len() - first) {
                    let h = T::test_leaf(&w.packets, first, count, &tri_ray, 0.0, t_max, false);
                    for lane in 0..8 {
                        let (pk, j) = (first + lane / PACKET, lane % PACKET);
                        let id = if lane < PACKET * count {
                            w.packet_ids[pk][j]
                        } else {
                            u32::MAX
                        };
                        let scalar = if id == u32::MAX {
                            None
                        } else {
                            intersect_triangle(&w.packets[pk].corners(j), &consts, 0.0, t_max)
                        };
                        match scalar {
                            None => assert_eq!(h.mask & (1 << lane), 0),
                            Some(s) => {
                                compared += 1;
                                assert_ne!(h.mask & (1 << lane), 0);
                                assert_eq!(
                                    (h.t[lane].to_bits(), h.u[lane].to_bits()),
                                    (s.t.to_bits(), s.u.to_bits())
                                );
                                assert_eq!(h.v[lane].to_bits(), s.v.to_bits());
                            }
                        }
                    }
                }
            }
        }
        assert!(compared > 300, "{compared}");
    }

    #[test]
    fn pair_lanes_are_the_scalar_test_portable() {
        pair_lanes_are_the_scalar_test::<Portable<8>>();
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn pair_lanes_are_the_scalar_test_avx() {
        if !has_avx() {
            println!("skipped: no AVX on this CPU");
            return;
        }
        // SAFETY: AVX was detected just above.
        unsafe { pair_lanes_avx() }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn pair_lanes_avx() {
        pair_lanes_are_the_scalar_test::<Avx>();
    }

    #[test]
    fn leaf_lanes_native_are_the_scalar_test() {
        pair_lanes_are_the_scalar_test::<Native>();
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

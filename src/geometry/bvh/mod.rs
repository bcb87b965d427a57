//! Ray-mesh intersection: the public API every caster uses.
//!
//! A wide bounding volume hierarchy (Wald, Benthin and Boulos 2008, "Getting rid of packets";
//! Embree's layouts): four children per node (BVH4) with SSE2 on x86_64 and on other
//! architectures, eight (BVH8) where the CPU has AVX (detected at run time with
//! `is_x86_feature_detected!`; where it also has AVX-512, the same eight-lane code is compiled
//! a second time for it, which gives it 32 vector registers instead of 16; `FEMTO_SIMD` or
//! [`Bvh::with_simd`] forces any of these paths, see [`crate::geometry::simd_level`]). It is built as a
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

//!
//! Layout: this file holds the tree's types and the public API; `build` makes the tree,
//! `traverse` walks it, `packets` holds the triangle test, `batch` casts many rays from one
//! origin, `tests` the tests.

mod batch;
mod build;
mod packets;
#[cfg(test)]
mod tests;
mod traverse;

#[cfg(target_arch = "x86_64")]
use super::simd::{Avx, Avx512, Sse};
use super::simd::{Lanes, Pairs, Portable, Simd, NATIVE};
use super::simd_level::{SimdError, SimdLevel};
use super::{Aabb, Hit, Ray, TriangleMesh};
use build::build;
use nalgebra::{Point3, Vector3};
use packets::{LeafLanes, TriRay};
use std::mem::MaybeUninit;
use traverse::RayConsts;

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
    /// Four children per node, traversed with the lanes `FourLanes` names.
    Four(Wide<4>, FourLanes),
    /// Eight children per node, traversed with the instruction set `Isa` holds the proof of
    /// (`Bvh::new` builds it only where the CPU has AVX); with none (tests on a CPU without
    /// AVX, other architectures), with plain arrays.
    Eight(Wide<8>, Option<Isa>),
}

/// The lanes of a four-wide tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum FourLanes {
    /// Plain arrays ([`SimdLevel::Scalar`]).
    Portable,
    /// [`NATIVE`]: SSE2 on x86_64 (which every such CPU runs), plain arrays elsewhere.
    Native,
}

/// The tree and lanes of a [`Bvh`], before it is built.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Layout {
    Four(FourLanes),
    Eight(Option<Isa>),
}

impl Layout {
    /// What `auto` gives: the eight-wide tree where the CPU has AVX (with AVX-512 where it
    /// has it), else the four-wide tree with the native lanes.
    fn auto() -> Layout {
        match eight_isa() {
            Some(isa) => Layout::Eight(Some(isa)),
            None => Layout::Four(FourLanes::Native),
        }
    }

    /// The layout of `level` (`None`: [`Layout::auto`]), with the proofs of its instruction
    /// set; an error where the CPU lacks it.
    fn of(level: Option<SimdLevel>) -> Result<Layout, SimdError> {
        let Some(level) = level else {
            return Ok(Layout::auto());
        };
        let unsupported = || SimdError::Unsupported {
            level,
            missing: level.missing_features().join(", "),
        };
        level.check()?;
        match level {
            SimdLevel::Scalar => Ok(Layout::Four(FourLanes::Portable)),
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Sse => Ok(Layout::Four(FourLanes::Native)),
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => Avx::new()
                .map(|p| Layout::Eight(Some(Isa::Avx(p))))
                .ok_or_else(unsupported),
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => Avx512::new()
                .map(|p| Layout::Eight(Some(Isa::Avx512(p))))
                .ok_or_else(unsupported),
            #[cfg(not(target_arch = "x86_64"))]
            _ => Err(unsupported()),
        }
    }
}

/// Values of the `INSTANCE` parameter of [`Wide::intersect`] and [`Wide::occluded`].
const PORTABLE_OR_SSE: u8 = 0;
#[cfg(target_arch = "x86_64")]
const AVX: u8 = 1;
#[cfg(target_arch = "x86_64")]
const AVX512: u8 = 2;
/// The batch caster's copies (`batch`): its loop compiled for AVX and for AVX-512.
#[cfg(target_arch = "x86_64")]
const AVX_BATCH: u8 = 3;
#[cfg(target_arch = "x86_64")]
const AVX512_BATCH: u8 = 4;

/// The instructions the eight-wide traversal is compiled for, with the proof that the CPU
/// runs them (none off x86_64). Both run the same lane operations (AVX intrinsics), so they
/// return the same hits bit for bit.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Isa {
    /// AVX: sixteen vector registers.
    #[cfg(target_arch = "x86_64")]
    Avx(Avx),
    /// AVX-512 F and VL (with AVX2, BMI1, BMI2 and POPCNT, which every such CPU has): the same
    /// eight-lane operations, EVEX-encoded, with thirty-two vector registers, so the ray's
    /// constants for the node and triangle tests stay in registers instead of being spilled
    /// to the stack and reloaded at every node and leaf.
    #[cfg(target_arch = "x86_64")]
    Avx512(Avx512),
}

/// An acceleration structure that owns its mesh.
#[derive(Clone, Debug)]
pub struct Bvh {
    mesh: TriangleMesh,
    bounds: Aabb,
    tree: Tree,
    /// The level it was built for (`None`: `auto`), which the tracer's rows follow.
    simd: Option<SimdLevel>,
    /// Unit geometric normal of each mesh triangle (zero for those of zero area).
    normals: Vec<Vector3<f32>>,
}

/// The best instruction set for the eight-wide traversal on this CPU, with its proof:
/// AVX-512 where it has it, else AVX; none where it has neither (or off x86_64).
fn eight_isa() -> Option<Isa> {
    #[cfg(target_arch = "x86_64")]
    {
        if let Some(proof) = Avx512::new() {
            return Some(Isa::Avx512(proof));
        }
        Avx::new().map(Isa::Avx)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        None
    }
}

impl Bvh {
    /// Build over `mesh` (takes ownership; read it back with [`Bvh::mesh`]) for the SIMD
    /// level `FEMTO_SIMD` asks for ([`SimdLevel::requested`]; `auto` when unset).
    ///
    /// Every index in `mesh.triangles` must be a valid position index (the loaders check this).
    pub fn new(mesh: TriangleMesh) -> Bvh {
        let level = SimdLevel::requested();
        match Layout::of(level) {
            Ok(layout) => Bvh::build_with(mesh, layout, level),
            // `requested` only gives levels this CPU runs; `auto` if it ever did not.
            Err(_) => Bvh::build_with(mesh, Layout::auto(), None),
        }
    }

    /// Build over `mesh` for the SIMD level `level` (`None`: `auto`; see
    /// [`crate::geometry::simd_level`]), whatever `FEMTO_SIMD` says: an error where this CPU
    /// lacks the level's instructions.
    pub fn with_simd(mesh: TriangleMesh, level: Option<SimdLevel>) -> Result<Bvh, SimdError> {
        Ok(Bvh::build_with(mesh, Layout::of(level)?, level))
    }

    /// The SIMD level the tree was built for (`None`: `auto`).
    pub fn simd(&self) -> Option<SimdLevel> {
        self.simd
    }

    /// Build with `width` (4 or 8) children per node (8 is traversed with plain arrays where
    /// [`eight_isa`] finds no instruction set).
    #[cfg(test)]
    fn with_width(mesh: TriangleMesh, width: usize) -> Bvh {
        let layout = if width == 8 {
            Layout::Eight(eight_isa())
        } else {
            Layout::Four(FourLanes::Native)
        };
        Bvh::build_with(mesh, layout, None)
    }

    fn build_with(mesh: TriangleMesh, layout: Layout, simd: Option<SimdLevel>) -> Bvh {
        let bounds = mesh.bounds();
        let (binary, order) = build(&mesh);
        let corners = |i: u32| mesh.corners(i as usize).map(|p| [p.x, p.y, p.z]);
        let tree = match layout {
            Layout::Eight(isa) => Tree::Eight(Wide::collapse(&binary, &order, &corners), isa),
            Layout::Four(lanes) => Tree::Four(Wide::collapse(&binary, &order, &corners), lanes),
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
            simd,
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
            Tree::Four(w, FourLanes::Native) => {
                w.intersect::<_, _, PORTABLE_OR_SSE>(NATIVE, NATIVE, ray, t_min, t_max)
            }
            Tree::Four(w, FourLanes::Portable) => {
                let lanes = Portable::<4>::new();
                w.intersect::<_, _, PORTABLE_OR_SSE>(lanes, lanes, ray, t_min, t_max)
            }
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
            Tree::Four(w, FourLanes::Native) => {
                w.occluded::<_, _, PORTABLE_OR_SSE>(NATIVE, NATIVE, ray, t_min, t_max)
            }
            Tree::Four(w, FourLanes::Portable) => {
                let lanes = Portable::<4>::new();
                w.occluded::<_, _, PORTABLE_OR_SSE>(lanes, lanes, ray, t_min, t_max)
            }
            Tree::Eight(w, isa) => occluded_eight(w, *isa, ray, t_min, t_max),
        }
    }
}

/// [`Wide::intersect`] of an eight-wide tree: AVX or AVX-512 on x86_64 where `isa` holds the
/// proof of one, plain arrays otherwise.
#[inline]
fn intersect_eight(
    w: &Wide<8>,
    isa: Option<Isa>,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<(u32, f32, f32, f32)> {
    match isa {
        // SAFETY: the proof `avx` says that the CPU runs AVX, the one feature the function
        // enables.
        #[cfg(target_arch = "x86_64")]
        Some(Isa::Avx(avx)) => unsafe { intersect_avx(w, avx, ray, t_min, t_max) },
        // SAFETY: the proof `p` says that the CPU runs every feature the function enables.
        #[cfg(target_arch = "x86_64")]
        Some(Isa::Avx512(p)) => unsafe { intersect_avx512(w, p, ray, t_min, t_max) },
        #[cfg(not(target_arch = "x86_64"))]
        Some(isa) => match isa {},
        None => {
            let lanes = Portable::<8>::new();
            w.intersect::<_, _, PORTABLE_OR_SSE>(lanes, lanes, ray, t_min, t_max)
        }
    }
}

/// [`Wide::occluded`] of an eight-wide tree (see [`intersect_eight`]).
#[inline]
fn occluded_eight(w: &Wide<8>, isa: Option<Isa>, ray: &Ray, t_min: f32, t_max: f32) -> bool {
    match isa {
        // SAFETY: as in `intersect_eight`.
        #[cfg(target_arch = "x86_64")]
        Some(Isa::Avx(avx)) => unsafe { occluded_avx(w, avx, ray, t_min, t_max) },
        // SAFETY: as in `intersect_eight`.
        #[cfg(target_arch = "x86_64")]
        Some(Isa::Avx512(p)) => unsafe { occluded_avx512(w, p, ray, t_min, t_max) },
        #[cfg(not(target_arch = "x86_64"))]
        Some(isa) => match isa {},
        None => {
            let lanes = Portable::<8>::new();
            w.occluded::<_, _, PORTABLE_OR_SSE>(lanes, lanes, ray, t_min, t_max)
        }
    }
}

/// [`Wide::intersect`] with the lanes of the proof `avx`, compiled for AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn intersect_avx(
    w: &Wide<8>,
    avx: Avx,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<(u32, f32, f32, f32)> {
    w.intersect::<_, _, AVX>(avx, avx, ray, t_min, t_max)
}

/// [`Wide::occluded`] with the lanes of the proof `avx`, compiled for AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn occluded_avx(w: &Wide<8>, avx: Avx, ray: &Ray, t_min: f32, t_max: f32) -> bool {
    w.occluded::<_, _, AVX>(avx, avx, ray, t_min, t_max)
}

/// [`intersect_avx`] compiled for [`Isa::Avx512`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,bmi1,bmi2,popcnt,avx512f,avx512vl")]
fn intersect_avx512(
    w: &Wide<8>,
    proof: Avx512,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<(u32, f32, f32, f32)> {
    let avx = proof.avx();
    w.intersect::<_, _, AVX512>(avx, avx, ray, t_min, t_max)
}

/// [`occluded_avx`] compiled for [`Isa::Avx512`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,bmi1,bmi2,popcnt,avx512f,avx512vl")]
fn occluded_avx512(w: &Wide<8>, proof: Avx512, ray: &Ray, t_min: f32, t_max: f32) -> bool {
    let avx = proof.avx();
    w.occluded::<_, _, AVX512>(avx, avx, ray, t_min, t_max)
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

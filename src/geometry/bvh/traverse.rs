//! Traversing a wide tree: nearest hit and any hit, nearest child first, with a stack of
//! subtrees culled against the closest hit; the per-ray constants and the conservative slab
//! test of `N` boxes in one vector test.

use super::*;

impl<const N: usize> Wide<N> {
    /// Nearest hit `(triangle, t, u, v)` with node lanes of the proof `node_lanes` and leaf
    /// lanes of the proof `leaf_lanes`.
    ///
    /// `INSTANCE` gives each caller compiled with its own target features (the AVX and the
    /// AVX-512 function) its own copy of this code, and so of the closure inside: a closure is
    /// compiled without its caller's target features unless LLVM inlines it, and it did not
    /// inline one closure shared by two callers, whose lane operations then all became calls
    /// (ten times slower).
    #[inline(always)]
    pub(super) fn intersect<V: Simd<N>, T: LeafLanes, const INSTANCE: u8>(
        &self,
        node_lanes: V,
        leaf_lanes: T,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> Option<(u32, f32, f32, f32)> {
        // (first packet of the leaf, lane, t, u, v) of the closest hit so far.
        let mut best: Option<(usize, usize, f32, f32, f32)> = None;
        self.traverse::<V, T, _, true>(
            node_lanes,
            leaf_lanes,
            ray,
            t_min,
            t_max,
            |first, count, tri_ray, t_far| {
                let h =
                    leaf_lanes.test_leaf(&self.packets, first, count, tri_ray, t_min, t_far, false);
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
            },
        );
        best.map(|(first, j, t, u, v)| (self.packet_ids[first + j / PACKET][j % PACKET], t, u, v))
    }

    /// Whether anything lies on the ray, with node lanes of the proof `node_lanes` and leaf
    /// lanes of the proof `leaf_lanes` (`INSTANCE` as in [`Wide::intersect`]).
    #[inline(always)]
    pub(super) fn occluded<V: Simd<N>, T: LeafLanes, const INSTANCE: u8>(
        &self,
        node_lanes: V,
        leaf_lanes: T,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> bool {
        let mut hit = false;
        self.traverse::<V, T, _, false>(
            node_lanes,
            leaf_lanes,
            ray,
            t_min,
            t_max,
            |first, count, tri_ray, t_far| {
                hit = leaf_lanes
                    .test_leaf(&self.packets, first, count, tri_ray, t_min, t_far, true)
                    .mask
                    != 0;
                (t_far, hit)
            },
        );
        hit
    }

    /// Walk the tree, calling `visit(first, count, ray, t_far)` for each leaf (packets
    /// `first .. first + count`) whose box the ray enters before `t_far`. `visit` returns the
    /// new `t_far` and whether to stop.
    /// `ORDERED`: visit the children of a node nearest first (closest hit); otherwise in any
    /// order (any hit: shadow rays), which saves sorting them.
    #[inline(always)]
    pub(super) fn traverse<V: Simd<N>, T: LeafLanes, F, const ORDERED: bool>(
        &self,
        node_lanes: V,
        leaf_lanes: T,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        mut visit: F,
    ) where
        F: FnMut(usize, usize, &TriRay<T::Lanes>, f32) -> (f32, bool),
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
        let node_ray = NodeRay::new(node_lanes, &consts);
        let tri_ray = leaf_lanes.ray(&consts);
        let t_min_v = node_lanes.splat(t_min);
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
                let t_cull_v = node_lanes.splat(t_cull);
                let (mask, t_enter) = slab(node_lanes, node, &node_ray, t_min_v, t_cull_v);
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
}

/// Per-ray constants of the slab and watertight triangle tests.
pub(super) struct RayConsts {
    pub(super) origin: [f32; 3],
    pub(super) inv_dir: [f32; 3],
    /// Index into `Node::bounds` of the near and far plane on each axis (the max plane is
    /// the near one when the direction component is negative, including -0).
    pub(super) near: [usize; 3],
    pub(super) far: [usize; 3],
    /// Axis of the largest direction component (`kz`) and the two others, ordered so that the
    /// sheared frame keeps the triangles' winding.
    pub(super) kx: usize,
    pub(super) ky: usize,
    pub(super) kz: usize,
    /// Shear constants of Woop et al.: `S = (d_kx / d_kz, d_ky / d_kz, 1 / d_kz)`.
    pub(super) sx: f32,
    pub(super) sy: f32,
    pub(super) sz: f32,
}

impl RayConsts {
    #[inline(always)]
    pub(super) fn new(ray: &Ray) -> RayConsts {
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
        let inv = NATIVE
            .splat(1.0)
            .div(NATIVE.load(&[d[0], d[1], d[2], 1.0]))
            .to_array();
        let [sx, sy, ..] = NATIVE
            .load(&[d[kx], d[ky], 1.0, 1.0])
            .div(NATIVE.load(&[d[kz], d[kz], 1.0, 1.0]))
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

/// The ray splatted for the slab test of `N` boxes, in lanes `L`.
pub(super) struct NodeRay<L, const N: usize> {
    pub(super) o: [L; 3],
    pub(super) inv: [L; 3],
    pub(super) near: [usize; 3],
    pub(super) far: [usize; 3],
}

impl<L: Lanes<N>, const N: usize> NodeRay<L, N> {
    #[inline(always)]
    pub(super) fn new<V: Simd<N, Lanes = L>>(lanes: V, c: &RayConsts) -> Self {
        NodeRay {
            // Written out, not with `map` and a closure: a closure shared by callers compiled
            // with different target features (the AVX and AVX-512 traversals, the batch
            // caster's copies) is compiled without them unless LLVM inlines it, and then
            // every splat is a call (the render bench's ray cast ran at half speed).
            o: [
                lanes.splat(c.origin[0]),
                lanes.splat(c.origin[1]),
                lanes.splat(c.origin[2]),
            ],
            inv: [
                lanes.splat(c.inv_dir[0]),
                lanes.splat(c.inv_dir[1]),
                lanes.splat(c.inv_dir[2]),
            ],
            near: c.near,
            far: c.far,
        }
    }
}

/// Conservative slab test of the `N` boxes of `n`, in the lanes of the proof `lanes`: a bit
/// per child whose box the ray meets within `(t_min, t_far)`, and the entry distances.
#[inline(always)]
pub(super) fn slab<V: Simd<N>, const N: usize>(
    lanes: V,
    n: &Node<N>,
    r: &NodeRay<V::Lanes, N>,
    t_min: V::Lanes,
    t_far: V::Lanes,
) -> (u32, [f32; N]) {
    let mut t0 = t_min;
    let mut t1 = t_far;
    let scale = lanes.splat(SLAB_FAR_SCALE);
    for a in 0..3 {
        let near = lanes.load(&n.bounds[r.near[a]]).sub(r.o[a]).mul(r.inv[a]);
        let far = lanes
            .load(&n.bounds[r.far[a]])
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

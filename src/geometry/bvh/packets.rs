//! The triangle test of a leaf: the watertight two-sided test of Woop, Benthin and Wald on a
//! packet of four triangles lane by lane, or on a leaf's two packets side by side in eight
//! lanes; and the scalar test each lane must reproduce bit for bit (tests only).

use super::*;

/// The ray splatted for the triangle test of a packet.
pub(super) struct TriRay<T> {
    pub(super) o: [T; 3],
    pub(super) kx: usize,
    pub(super) ky: usize,
    pub(super) kz: usize,
    pub(super) sx: T,
    pub(super) sy: T,
    pub(super) sz: T,
}

impl<T> TriRay<T> {
    #[inline(always)]
    pub(super) fn new<S: Simd<M, Lanes = T>, const M: usize>(lanes: S, c: &RayConsts) -> Self {
        TriRay {
            // Written out, not with `map` and a closure (see `NodeRay::new`).
            o: [
                lanes.splat(c.origin[0]),
                lanes.splat(c.origin[1]),
                lanes.splat(c.origin[2]),
            ],
            kx: c.kx,
            ky: c.ky,
            kz: c.kz,
            sx: lanes.splat(c.sx),
            sy: lanes.splat(c.sy),
            sz: lanes.splat(c.sz),
        }
    }
}

/// How the triangle test reads the packets of a leaf: packet by packet in four lanes, or
/// (eight-wide tree, AVX) the leaf's one or two packets side by side in eight lanes, which
/// halves the number of tests while the packets stay four wide in memory (a leaf of one to
/// four triangles reads no more than in the four-wide tree).
pub(super) trait LeafLanes: Copy {
    /// The vectors of the test.
    type Lanes;

    /// The ray splatted into these lanes.
    fn ray(self, c: &RayConsts) -> TriRay<Self::Lanes>;

    /// Hits of the triangles of `packets[first .. first + count]` (`count` is 1 or 2; lane
    /// `4 i + j` is lane `j` of packet `first + i`) with `t_min < t < t_max`. With `any`
    /// (shadow rays) the test may stop at the first packet that has a hit.
    #[allow(clippy::too_many_arguments)]
    fn test_leaf(
        self,
        packets: &[TriPacket],
        first: usize,
        count: usize,
        r: &TriRay<Self::Lanes>,
        t_min: f32,
        t_max: f32,
        any: bool,
    ) -> PacketHits<8>;
}

/// [`LeafLanes::test_leaf`] one four-lane packet at a time.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn leaf_by_packets<S: Simd<PACKET>>(
    lanes: S,
    packets: &[TriPacket],
    first: usize,
    count: usize,
    r: &TriRay<S::Lanes>,
    t_min: f32,
    t_max: f32,
    any: bool,
) -> PacketHits<8> {
    let mut out = PacketHits::<8>::NONE;
    for (i, p) in packets[first..first + count].iter().enumerate() {
        let h = packet_test(lanes, p, r, t_min, t_max);
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
pub(super) fn leaf_by_pairs<S: Pairs>(
    lanes: S,
    packets: &[TriPacket],
    first: usize,
    count: usize,
    r: &TriRay<S::Lanes>,
    t_min: f32,
    t_max: f32,
) -> PacketHits<8> {
    // Leaves hold one or two packets; a count of 0 (an empty child slot, which traversal
    // never enters with a finite ray) tests packet `first` and keeps no lane, instead of
    // indexing `first - 1`.
    debug_assert!((1..=2).contains(&count), "leaf of {count} packets");
    let pair = PacketPair(&packets[first], &packets[first + count.max(1) - 1]);
    let mut h = packet_test(lanes, &pair, r, t_min, t_max);
    h.mask &= match count {
        2 => 0xff,
        1 => 0x0f,
        _ => 0,
    };
    h
}

/// `impl LeafLanes` for the proof of `M`-lane vectors that tests a leaf `by_packets` (one
/// four-lane packet at a time: four-lane types) or `by_pairs` (two packets side by side:
/// eight-lane types).
macro_rules! leaf_lanes {
    ($lanes:ty, $m:literal, $test:ident) => {
        impl LeafLanes for $lanes {
            type Lanes = <$lanes as Simd<$m>>::Lanes;
            #[inline(always)]
            fn ray(self, c: &RayConsts) -> TriRay<Self::Lanes> {
                TriRay::new(self, c)
            }
            #[inline(always)]
            fn test_leaf(
                self,
                packets: &[TriPacket],
                first: usize,
                count: usize,
                r: &TriRay<Self::Lanes>,
                t_min: f32,
                t_max: f32,
                any: bool,
            ) -> PacketHits<8> {
                leaf_lanes!(@$test self, packets, first, count, r, t_min, t_max, any)
            }
        }
    };
    (@by_packets $($arg:expr),*) => {
        leaf_by_packets($($arg),*)
    };
    (@by_pairs $s:expr, $p:expr, $f:expr, $c:expr, $r:expr, $a:expr, $b:expr, $any:expr) => {{
        let _ = $any; // a pair is one test: nothing to stop early
        leaf_by_pairs($s, $p, $f, $c, $r, $a, $b)
    }};
}

leaf_lanes!(Portable<4>, 4, by_packets);
leaf_lanes!(Portable<8>, 8, by_pairs);
#[cfg(target_arch = "x86_64")]
leaf_lanes!(Sse, 4, by_packets);
#[cfg(target_arch = "x86_64")]
leaf_lanes!(Avx, 8, by_pairs);

/// Where [`packet_test`] reads corner `k`, axis `a` of its triangles, in the `M` lanes of the
/// proof `S`.
pub(super) trait Corners<S: Simd<M>, const M: usize> {
    fn load(&self, lanes: S, k: usize, a: usize) -> S::Lanes;
}

impl<S: Simd<PACKET>> Corners<S, PACKET> for TriPacket {
    #[inline(always)]
    fn load(&self, lanes: S, k: usize, a: usize) -> S::Lanes {
        lanes.load(&self.v[k][a])
    }
}

/// Two packets side by side, eight lanes.
pub(super) struct PacketPair<'a>(&'a TriPacket, &'a TriPacket);

impl<S: Pairs> Corners<S, 8> for PacketPair<'_> {
    #[inline(always)]
    fn load(&self, lanes: S, k: usize, a: usize) -> S::Lanes {
        lanes.load_pair(&self.0.v[k][a], &self.1.v[k][a])
    }
}

/// Corner `k` of each triangle relative to the ray origin, sheared and scaled into the ray's
/// frame (the ray becomes the +z axis). A function rather than a closure so that it is always
/// inlined into its caller, whose target features (AVX) the lane operations need.
#[inline(always)]
pub(super) fn sheared_corner<S: Simd<M>, const M: usize, C: Corners<S, M>>(
    lanes: S,
    p: &C,
    k: usize,
    r: &TriRay<S::Lanes>,
) -> (S::Lanes, S::Lanes, S::Lanes) {
    let pz = p.load(lanes, k, r.kz).sub(r.o[r.kz]);
    let px = p.load(lanes, k, r.kx).sub(r.o[r.kx]).sub(r.sx.mul(pz));
    let py = p.load(lanes, k, r.ky).sub(r.o[r.ky]).sub(r.sy.mul(pz));
    (px, py, pz)
}

/// Result of [`packet_test`]: a bit per lane that hits, and each lane's distance and
/// barycentrics (meaningful where the bit is set).
pub(super) struct PacketHits<const M: usize> {
    pub(super) mask: u32,
    pub(super) t: [f32; M],
    pub(super) u: [f32; M],
    pub(super) v: [f32; M],
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
pub(super) fn packet_test<S: Simd<M>, const M: usize, C: Corners<S, M>>(
    lanes: S,
    p: &C,
    r: &TriRay<S::Lanes>,
    t_min: f32,
    t_max: f32,
) -> PacketHits<M> {
    let (ax, ay, az) = sheared_corner(lanes, p, 0, r);
    let (bx, by, bz) = sheared_corner(lanes, p, 1, r);
    let (cx, cy, cz) = sheared_corner(lanes, p, 2, r);
    // Scaled barycentric coordinates (2D edge functions).
    let mut u = cx.mul(by).sub(cy.mul(bx));
    let mut v = ax.mul(cy).sub(ay.mul(cx));
    let mut w = bx.mul(ay).sub(by.mul(ax));
    let zero = lanes.splat(0.0);
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
        (u, v, w) = (lanes.load(&ua), lanes.load(&va), lanes.load(&wa));
    }
    // Two-sided: reject only when the signs differ.
    let neg = u.lt(zero).or(v.lt(zero)).or(w.lt(zero));
    let pos = u.gt(zero).or(v.gt(zero)).or(w.gt(zero));
    let det = u.add(v).add(w);
    let t_scaled = u
        .mul(r.sz.mul(az))
        .add(v.mul(r.sz.mul(bz)))
        .add(w.mul(r.sz.mul(cz)));
    let inv_det = lanes.splat(1.0).div(det);
    let t = t_scaled.mul(inv_det);
    // A NaN `t` (degenerate ray, unused lane) fails both comparisons.
    let in_range = t.gt(lanes.splat(t_min)).and(t.lt(lanes.splat(t_max)));
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
pub(super) struct TriHit {
    pub(super) t: f32,
    pub(super) u: f32,
    pub(super) v: f32,
}

/// Watertight two-sided ray-triangle test (Woop, Benthin and Wald 2013), hits with
/// `t_min < t < t_max` only: the scalar reference that each lane of [`packet_test`] must
/// reproduce bit for bit.
#[cfg(test)]
pub(super) fn intersect_triangle(
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

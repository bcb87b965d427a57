//! Four- and eight-lane f32 vectors for the BVH's node and triangle tests.
//!
//! [`Sse`] wraps SSE2 (`core::arch::x86_64`), which every x86_64 CPU has, so it needs no
//! runtime feature detection and no extra crate. [`Avx`] wraps AVX (eight lanes) for code
//! compiled with `#[target_feature(enable = "avx")]` and entered only after
//! `is_x86_feature_detected!("avx")` (or compiled with AVX-512 enabled as well, which only
//! gives it more registers). [`Pairs`] loads eight lanes as two halves of four from different
//! places (the two triangle packets of a leaf). [`Portable`] is the same operations on
//! `[f32; N]`, used on every other architecture and compiled everywhere so tests can check
//! that the implementations give identical results. [`Native`] is the four-lane one of this
//! architecture.
//!
//! Every operation is exactly rounded lane by lane (IEEE add, sub, mul, div; no fused
//! multiply-add), so a lane computes bit for bit what the scalar expression would. `max` and
//! `min` follow the SSE rule `a > b ? a : b` / `a < b ? a : b`: when a lane of `a` is NaN they
//! return `b`'s lane, which the slab test relies on to ignore `0 * inf` on a slab boundary.
//! Comparisons return lane masks (all bits set or clear) that [`Lanes::bits`] packs into the
//! low bits of an integer, lane 0 in bit 0.

/// A vector of `N` f32 lanes (and lane masks in the same type).
pub(crate) trait Lanes<const N: usize>: Copy {
    fn splat(x: f32) -> Self;
    fn load(a: &[f32; N]) -> Self;
    fn to_array(self) -> [f32; N];
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    /// `self > o ? self : o` per lane.
    fn max(self, o: Self) -> Self;
    /// `self < o ? self : o` per lane.
    fn min(self, o: Self) -> Self;
    fn lt(self, o: Self) -> Self;
    fn le(self, o: Self) -> Self;
    fn gt(self, o: Self) -> Self;
    fn eq(self, o: Self) -> Self;
    /// Bitwise and of masks.
    fn and(self, o: Self) -> Self;
    /// Bitwise or of masks.
    fn or(self, o: Self) -> Self;
    /// `!self & o` of masks.
    fn andnot(self, o: Self) -> Self;
    /// Sign bits of the lanes (mask lanes: 1 where set), lane 0 in bit 0.
    fn bits(self) -> u32;
}

/// Eight lanes that can be loaded as two halves of four from different places: the eight-wide
/// tree tests the two four-lane triangle packets of a leaf at once.
pub(crate) trait Pairs: Lanes<8> {
    /// Lanes 0..4 from `lo`, lanes 4..8 from `hi`.
    fn load_pair(lo: &[f32; 4], hi: &[f32; 4]) -> Self;
}

impl Pairs for Portable<8> {
    #[inline(always)]
    fn load_pair(lo: &[f32; 4], hi: &[f32; 4]) -> Self {
        Portable(std::array::from_fn(
            |i| if i < 4 { lo[i] } else { hi[i - 4] },
        ))
    }
}

/// Plain arrays: every architecture (on x86_64 only the tests use the four-lane one).
#[derive(Clone, Copy, Debug)]
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
pub(crate) struct Portable<const N: usize>([f32; N]);

#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
impl<const N: usize> Portable<N> {
    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(f32, f32) -> f32) -> Self {
        Portable(std::array::from_fn(|i| f(self.0[i], o.0[i])))
    }

    #[inline(always)]
    fn mask(c: bool) -> f32 {
        f32::from_bits(if c { u32::MAX } else { 0 })
    }

    #[inline(always)]
    fn bitwise(self, o: Self, f: impl Fn(u32, u32) -> u32) -> Self {
        self.zip(o, |a, b| f32::from_bits(f(a.to_bits(), b.to_bits())))
    }
}

impl<const N: usize> Lanes<N> for Portable<N> {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Portable([x; N])
    }
    #[inline(always)]
    fn load(a: &[f32; N]) -> Self {
        Portable(*a)
    }
    #[inline(always)]
    fn to_array(self) -> [f32; N] {
        self.0
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        self.zip(o, |a, b| a + b)
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        self.zip(o, |a, b| a - b)
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        self.zip(o, |a, b| a * b)
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        self.zip(o, |a, b| a / b)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        self.zip(o, |a, b| if a > b { a } else { b })
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        self.zip(o, |a, b| if a < b { a } else { b })
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Self {
        self.zip(o, |a, b| Self::mask(a < b))
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self {
        self.zip(o, |a, b| Self::mask(a <= b))
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self {
        self.zip(o, |a, b| Self::mask(a > b))
    }
    #[inline(always)]
    fn eq(self, o: Self) -> Self {
        self.zip(o, |a, b| Self::mask(a == b))
    }
    #[inline(always)]
    fn and(self, o: Self) -> Self {
        self.bitwise(o, |a, b| a & b)
    }
    #[inline(always)]
    fn or(self, o: Self) -> Self {
        self.bitwise(o, |a, b| a | b)
    }
    #[inline(always)]
    fn andnot(self, o: Self) -> Self {
        self.bitwise(o, |a, b| !a & b)
    }
    #[inline(always)]
    fn bits(self) -> u32 {
        (0..N).fold(0, |m, i| m | ((self.0[i].to_bits() >> 31) << i))
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use sse::Sse;

#[cfg(target_arch = "x86_64")]
mod sse {
    use super::Lanes;
    use core::arch::x86_64::*;

    /// SSE2 registers (part of the x86_64 baseline).
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Sse(__m128);

    // SAFETY (every `unsafe` block below): the intrinsics used are SSE2 or older, which the
    // x86_64 target always enables (`target_feature = "sse2"` is part of its baseline), and
    // loads and stores go through references to `[f32; 4]` with the unaligned forms.
    impl Lanes<4> for Sse {
        #[inline(always)]
        fn splat(x: f32) -> Self {
            Sse(unsafe { _mm_set1_ps(x) })
        }
        #[inline(always)]
        fn load(a: &[f32; 4]) -> Self {
            Sse(unsafe { _mm_loadu_ps(a.as_ptr()) })
        }
        #[inline(always)]
        fn to_array(self) -> [f32; 4] {
            let mut a = [0.0f32; 4];
            unsafe { _mm_storeu_ps(a.as_mut_ptr(), self.0) };
            a
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            Sse(unsafe { _mm_add_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            Sse(unsafe { _mm_sub_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            Sse(unsafe { _mm_mul_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            Sse(unsafe { _mm_div_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn max(self, o: Self) -> Self {
            // MAXPS: dest = src1 > src2 ? src1 : src2.
            Sse(unsafe { _mm_max_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn min(self, o: Self) -> Self {
            // MINPS: dest = src1 < src2 ? src1 : src2.
            Sse(unsafe { _mm_min_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn lt(self, o: Self) -> Self {
            Sse(unsafe { _mm_cmplt_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn le(self, o: Self) -> Self {
            Sse(unsafe { _mm_cmple_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn gt(self, o: Self) -> Self {
            Sse(unsafe { _mm_cmpgt_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn eq(self, o: Self) -> Self {
            Sse(unsafe { _mm_cmpeq_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn and(self, o: Self) -> Self {
            Sse(unsafe { _mm_and_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn or(self, o: Self) -> Self {
            Sse(unsafe { _mm_or_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn andnot(self, o: Self) -> Self {
            Sse(unsafe { _mm_andnot_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn bits(self) -> u32 {
            (unsafe { _mm_movemask_ps(self.0) }) as u32
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use avx::Avx;

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::{Lanes, Pairs};
    use core::arch::x86_64::*;

    /// AVX registers of eight lanes. Only for code compiled with AVX enabled
    /// (`#[target_feature(enable = "avx")]`) and called after `is_x86_feature_detected!("avx")`:
    /// each method is inlined into that code, where the intrinsics are available.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Avx(__m256);

    // SAFETY (every `unsafe` block below): these methods are only reached from functions that
    // enable AVX and are only called once the CPU was detected to support it (see `Bvh`);
    // loads and stores go through references to `[f32; 8]` with the unaligned forms.
    impl Lanes<8> for Avx {
        #[inline(always)]
        fn splat(x: f32) -> Self {
            Avx(unsafe { _mm256_set1_ps(x) })
        }
        #[inline(always)]
        fn load(a: &[f32; 8]) -> Self {
            Avx(unsafe { _mm256_loadu_ps(a.as_ptr()) })
        }
        #[inline(always)]
        fn to_array(self) -> [f32; 8] {
            let mut a = [0.0f32; 8];
            unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) };
            a
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            Avx(unsafe { _mm256_add_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            Avx(unsafe { _mm256_sub_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            Avx(unsafe { _mm256_mul_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            Avx(unsafe { _mm256_div_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn max(self, o: Self) -> Self {
            // VMAXPS: dest = src1 > src2 ? src1 : src2.
            Avx(unsafe { _mm256_max_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn min(self, o: Self) -> Self {
            // VMINPS: dest = src1 < src2 ? src1 : src2.
            Avx(unsafe { _mm256_min_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn lt(self, o: Self) -> Self {
            Avx(unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn le(self, o: Self) -> Self {
            Avx(unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn gt(self, o: Self) -> Self {
            Avx(unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn eq(self, o: Self) -> Self {
            Avx(unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn and(self, o: Self) -> Self {
            Avx(unsafe { _mm256_and_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn or(self, o: Self) -> Self {
            Avx(unsafe { _mm256_or_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn andnot(self, o: Self) -> Self {
            Avx(unsafe { _mm256_andnot_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn bits(self) -> u32 {
            (unsafe { _mm256_movemask_ps(self.0) }) as u32
        }
    }

    impl Pairs for Avx {
        #[inline(always)]
        fn load_pair(lo: &[f32; 4], hi: &[f32; 4]) -> Self {
            // SAFETY: as for `Lanes` above; each pointer is to four readable f32s.
            Avx(unsafe { _mm256_loadu2_m128(hi.as_ptr(), lo.as_ptr()) })
        }
    }
}

/// The four lanes the BVH uses on this architecture.
#[cfg(target_arch = "x86_64")]
pub(crate) type Native = Sse;
/// The four lanes the BVH uses on this architecture.
#[cfg(not(target_arch = "x86_64"))]
pub(crate) type Native = Portable<4>;

#[cfg(test)]
mod tests {
    use super::*;

    /// Every operation of `A` and `B` agrees bit for bit on awkward inputs (NaN, infinities,
    /// signed zeros, subnormals).
    fn agree<const N: usize, A: Lanes<N>, B: Lanes<N>>() {
        let vals = [
            0.0f32,
            -0.0,
            1.0,
            -1.5,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1e-40,
            3.0e38,
            0.1,
        ];
        let n = vals.len();
        let quads: Vec<[f32; N]> = (0..n)
            .flat_map(|i| {
                (0..n).map(move |j| std::array::from_fn(|k| vals[(i + j * k + k * k) % n]))
            })
            .collect();
        let same = |x: [f32; N], y: [f32; N], what: &str| {
            for k in 0..N {
                let (a, b) = (x[k], y[k]);
                assert!(
                    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                    "{what} lane {k}: {a} vs {b}"
                );
            }
        };
        for p in &quads {
            for q in &quads {
                let (a, b) = (A::load(p), A::load(q));
                let (c, d) = (B::load(p), B::load(q));
                same(a.add(b).to_array(), c.add(d).to_array(), "add");
                same(a.sub(b).to_array(), c.sub(d).to_array(), "sub");
                same(a.mul(b).to_array(), c.mul(d).to_array(), "mul");
                same(a.div(b).to_array(), c.div(d).to_array(), "div");
                same(a.max(b).to_array(), c.max(d).to_array(), "max");
                same(a.min(b).to_array(), c.min(d).to_array(), "min");
                for (m, n, what) in [
                    (a.lt(b), c.lt(d), "lt"),
                    (a.le(b), c.le(d), "le"),
                    (a.gt(b), c.gt(d), "gt"),
                    (a.eq(b), c.eq(d), "eq"),
                ] {
                    assert_eq!(m.bits(), n.bits(), "{what} {p:?} {q:?}");
                    let (m2, n2) = (a.lt(b), c.lt(d));
                    assert_eq!(m.and(m2).bits(), n.and(n2).bits());
                    assert_eq!(m.or(m2).bits(), n.or(n2).bits());
                    assert_eq!(m.andnot(m2).bits(), n.andnot(n2).bits());
                }
            }
            assert_eq!(A::splat(p[1]).bits(), B::splat(p[1]).bits());
        }
    }

    #[test]
    fn portable_lanes_follow_the_scalar_rules() {
        let a = Portable::load(&[1.0, f32::NAN, -0.0, 2.0]);
        let b = Portable::load(&[2.0, 1.0, 0.0, f32::NAN]);
        // NaN in the first operand gives the second; NaN in the second gives it back.
        assert_eq!(a.max(b).to_array()[..3], [2.0, 1.0, 0.0]);
        assert!(a.max(b).to_array()[3].is_nan());
        assert_eq!(a.lt(b).bits(), 0b0001);
        assert_eq!(a.le(b).bits(), 0b0101);
        assert_eq!(a.eq(b).bits(), 0b0100);
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn sse_agrees_with_portable() {
        agree::<4, Sse, Portable<4>>();
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx_agrees_with_portable() {
        if !is_x86_feature_detected!("avx") {
            println!("skipped: no AVX on this CPU");
            return;
        }
        // SAFETY: AVX was detected just above.
        unsafe { agree_avx() }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn agree_avx() {
        agree::<8, Avx, Portable<8>>();
        pairs_are_halves::<Avx>();
    }

    /// `load_pair(lo, hi)` holds `lo` in lanes 0..4 and `hi` in lanes 4..8, bit for bit.
    fn pairs_are_halves<P: Pairs>() {
        let lo = [1.0f32, -0.0, f32::INFINITY, 1e-40];
        let hi = [f32::NAN, 3.0e38, -1.5, 0.1];
        let got = P::load_pair(&lo, &hi).to_array();
        let want = [lo, hi].concat();
        for k in 0..8 {
            assert_eq!(got[k].to_bits(), want[k].to_bits(), "lane {k}");
        }
    }

    #[test]
    fn portable_pairs_are_halves() {
        pairs_are_halves::<Portable<8>>();
    }

    #[test]
    fn native_agrees_with_portable() {
        agree::<4, Native, Portable<4>>();
    }
}

//! Four- and eight-lane f32 vectors for the BVH's node and triangle tests, made only with a
//! proof that the CPU runs their instructions (memchr's `One::new() -> Option<Self>`).
//!
//! A proof ([`Simd`]) is a zero-sized type whose one field is private, so no code outside
//! this module can make one: [`Sse`] (SSE2, part of every x86_64 target: [`Sse::BASELINE`]
//! needs no check at run time), [`Avx`] (AVX, eight lanes), [`Avx512`] (AVX-512 F and VL with
//! AVX2, BMI1, BMI2 and POPCNT, for which the BVH compiles its eight-lane code a second time;
//! it hands out an [`Avx`] proof) and [`Portable`] (plain arrays `[f32; N]`, used on every
//! other architecture and compiled everywhere so tests can check that the implementations
//! give identical results). Each x86 proof has `new() -> Option<Self>`, which checks the CPU
//! with `is_x86_feature_detected!`, and `unsafe fn new_unchecked()`, whose caller promises
//! the features. The proof makes vectors ([`Simd::splat`], [`Simd::load`],
//! [`Pairs::load_pair`]: lanes 0..4 and 4..8 from two places, the two triangle packets of a
//! leaf); a vector's register is a private field too, so a vector exists only where its
//! proof did, and every operation that executes the instructions is a method taking `self`,
//! a vector made with the proof. [`Native`] is the four-lane proof of this architecture.
//! Which proof the BVH uses is chosen at run time: the widest the CPU gives, or the one
//! `FEMTO_SIMD` or `Bvh::with_simd` forces ([`super::simd_level`]).
//!
//! A vector's methods are `#[inline(always)]`: they are compiled into the caller, which must
//! enable the instructions (`#[target_feature(enable = "avx")]` for [`Avx`]) for the
//! intrinsics to become single instructions; the proof makes calling them sound, the
//! caller's target features make them fast.
//!
//! Every operation is exactly rounded lane by lane (IEEE add, sub, mul, div; no fused
//! multiply-add), so a lane computes bit for bit what the scalar expression would. `max` and
//! `min` follow the SSE rule `a > b ? a : b` / `a < b ? a : b`: when a lane of `a` is NaN they
//! return `b`'s lane, which the slab test relies on to ignore `0 * inf` on a slab boundary.
//! Comparisons return lane masks (all bits set or clear) that [`Lanes::bits`] packs into the
//! low bits of an integer, lane 0 in bit 0.

/// A proof that this CPU runs the instructions of vectors of `N` f32 lanes, and the maker of
/// those vectors (zero-sized; see the module doc).
pub(crate) trait Simd<const N: usize>: Copy {
    /// The vectors this proof makes.
    type Lanes: Lanes<N>;
    /// Every lane `x`.
    fn splat(self, x: f32) -> Self::Lanes;
    /// Lane `i` from `a[i]`.
    fn load(self, a: &[f32; N]) -> Self::Lanes;
}

/// A vector of `N` f32 lanes (and lane masks in the same type), made by its [`Simd`] proof.
pub(crate) trait Lanes<const N: usize>: Copy {
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
pub(crate) trait Pairs: Simd<8> {
    /// Lanes 0..4 from `lo`, lanes 4..8 from `hi`.
    fn load_pair(self, lo: &[f32; 4], hi: &[f32; 4]) -> Self::Lanes;
}

/// Plain arrays of `N` lanes: every architecture (on x86_64 only the tests use the four-lane
/// one). Needs no CPU feature, so [`Portable::new`] always gives the proof.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Portable<const N: usize> {
    _private: (),
}

impl<const N: usize> Portable<N> {
    /// The proof: plain arrays run on every CPU.
    pub(crate) const fn new() -> Portable<N> {
        Portable { _private: () }
    }
}

/// The vectors of [`Portable`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct ArrayLanes<const N: usize>([f32; N]);

impl<const N: usize> Simd<N> for Portable<N> {
    type Lanes = ArrayLanes<N>;
    #[inline(always)]
    fn splat(self, x: f32) -> ArrayLanes<N> {
        ArrayLanes([x; N])
    }
    #[inline(always)]
    fn load(self, a: &[f32; N]) -> ArrayLanes<N> {
        ArrayLanes(*a)
    }
}

impl Pairs for Portable<8> {
    #[inline(always)]
    fn load_pair(self, lo: &[f32; 4], hi: &[f32; 4]) -> ArrayLanes<8> {
        ArrayLanes(std::array::from_fn(
            |i| if i < 4 { lo[i] } else { hi[i - 4] },
        ))
    }
}

#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
impl<const N: usize> ArrayLanes<N> {
    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(f32, f32) -> f32) -> Self {
        ArrayLanes(std::array::from_fn(|i| f(self.0[i], o.0[i])))
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

impl<const N: usize> Lanes<N> for ArrayLanes<N> {
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
    use super::{Lanes, Simd};
    use core::arch::x86_64::*;

    /// Proof that this CPU runs SSE2 (zero-sized; made only by the functions below).
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Sse {
        _private: (),
    }

    impl Sse {
        /// SSE2 is part of the x86_64 baseline (`target_feature = "sse2"` is always enabled
        /// for it), so the proof needs no check at run time.
        #[cfg(target_feature = "sse2")]
        pub(crate) const BASELINE: Sse = Sse { _private: () };

        /// The proof, where the CPU runs SSE2.
        #[allow(dead_code)]
        pub(crate) fn new() -> Option<Sse> {
            is_x86_feature_detected!("sse2").then_some(Sse { _private: () })
        }

        /// The proof, unchecked.
        ///
        /// # Safety
        ///
        /// The CPU that runs the program must support SSE2.
        #[allow(dead_code)]
        pub(crate) unsafe fn new_unchecked() -> Sse {
            Sse { _private: () }
        }
    }

    /// SSE2 registers of four lanes, made by an [`Sse`] proof.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct SseLanes(__m128);

    // SAFETY (every `unsafe` block below): an `SseLanes` is made only by an `Sse` proof (or
    // from another `SseLanes`), so the CPU runs SSE2; loads and stores go through references
    // to `[f32; 4]` with the unaligned forms.
    impl Simd<4> for Sse {
        type Lanes = SseLanes;
        #[inline(always)]
        fn splat(self, x: f32) -> SseLanes {
            SseLanes(unsafe { _mm_set1_ps(x) })
        }
        #[inline(always)]
        fn load(self, a: &[f32; 4]) -> SseLanes {
            SseLanes(unsafe { _mm_loadu_ps(a.as_ptr()) })
        }
    }

    impl Lanes<4> for SseLanes {
        #[inline(always)]
        fn to_array(self) -> [f32; 4] {
            let mut a = [0.0f32; 4];
            unsafe { _mm_storeu_ps(a.as_mut_ptr(), self.0) };
            a
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            SseLanes(unsafe { _mm_add_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            SseLanes(unsafe { _mm_sub_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            SseLanes(unsafe { _mm_mul_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            SseLanes(unsafe { _mm_div_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn max(self, o: Self) -> Self {
            // MAXPS: dest = src1 > src2 ? src1 : src2.
            SseLanes(unsafe { _mm_max_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn min(self, o: Self) -> Self {
            // MINPS: dest = src1 < src2 ? src1 : src2.
            SseLanes(unsafe { _mm_min_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn lt(self, o: Self) -> Self {
            SseLanes(unsafe { _mm_cmplt_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn le(self, o: Self) -> Self {
            SseLanes(unsafe { _mm_cmple_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn gt(self, o: Self) -> Self {
            SseLanes(unsafe { _mm_cmpgt_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn eq(self, o: Self) -> Self {
            SseLanes(unsafe { _mm_cmpeq_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn and(self, o: Self) -> Self {
            SseLanes(unsafe { _mm_and_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn or(self, o: Self) -> Self {
            SseLanes(unsafe { _mm_or_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn andnot(self, o: Self) -> Self {
            SseLanes(unsafe { _mm_andnot_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn bits(self) -> u32 {
            (unsafe { _mm_movemask_ps(self.0) }) as u32
        }
    }
}
#[cfg(target_arch = "x86_64")]
pub(crate) use avx::{Avx, Avx512};

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::{Lanes, Pairs, Simd};
    use core::arch::x86_64::*;

    /// Proof that this CPU runs AVX (zero-sized; made only by the functions below).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub(crate) struct Avx {
        _private: (),
    }

    impl Avx {
        /// The proof, where the CPU runs AVX.
        pub(crate) fn new() -> Option<Avx> {
            is_x86_feature_detected!("avx").then_some(Avx { _private: () })
        }

        /// The proof, unchecked.
        ///
        /// # Safety
        ///
        /// The CPU that runs the program must support AVX.
        #[allow(dead_code)]
        pub(crate) unsafe fn new_unchecked() -> Avx {
            Avx { _private: () }
        }
    }

    /// Proof that this CPU runs AVX-512 F and VL, AVX2, BMI1, BMI2 and POPCNT (and AVX), the
    /// features of the BVH's AVX-512 compilation (zero-sized; made only by the functions
    /// below).
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub(crate) struct Avx512 {
        _private: (),
    }

    impl Avx512 {
        /// The proof, where the CPU runs every one of the features.
        pub(crate) fn new() -> Option<Avx512> {
            let all = is_x86_feature_detected!("avx")
                && is_x86_feature_detected!("avx512f")
                && is_x86_feature_detected!("avx512vl")
                && is_x86_feature_detected!("avx2")
                && is_x86_feature_detected!("bmi1")
                && is_x86_feature_detected!("bmi2")
                && is_x86_feature_detected!("popcnt");
            all.then_some(Avx512 { _private: () })
        }

        /// The proof, unchecked.
        ///
        /// # Safety
        ///
        /// The CPU that runs the program must support every feature of [`Avx512`].
        #[allow(dead_code)]
        pub(crate) unsafe fn new_unchecked() -> Avx512 {
            Avx512 { _private: () }
        }

        /// The AVX proof that this one implies.
        pub(crate) fn avx(self) -> Avx {
            Avx { _private: () }
        }
    }

    /// AVX registers of eight lanes, made by an [`Avx`] proof.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct AvxLanes(__m256);

    // SAFETY (every `unsafe` block below): an `AvxLanes` is made only by an `Avx` proof (or
    // from another `AvxLanes`), so the CPU runs AVX; loads and stores go through references
    // to `[f32; 8]`, or two of `[f32; 4]`, with the unaligned forms.
    impl Simd<8> for Avx {
        type Lanes = AvxLanes;
        #[inline(always)]
        fn splat(self, x: f32) -> AvxLanes {
            AvxLanes(unsafe { _mm256_set1_ps(x) })
        }
        #[inline(always)]
        fn load(self, a: &[f32; 8]) -> AvxLanes {
            AvxLanes(unsafe { _mm256_loadu_ps(a.as_ptr()) })
        }
    }

    impl Pairs for Avx {
        #[inline(always)]
        fn load_pair(self, lo: &[f32; 4], hi: &[f32; 4]) -> AvxLanes {
            AvxLanes(unsafe { _mm256_loadu2_m128(hi.as_ptr(), lo.as_ptr()) })
        }
    }

    impl Lanes<8> for AvxLanes {
        #[inline(always)]
        fn to_array(self) -> [f32; 8] {
            let mut a = [0.0f32; 8];
            unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) };
            a
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            AvxLanes(unsafe { _mm256_add_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            AvxLanes(unsafe { _mm256_sub_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            AvxLanes(unsafe { _mm256_mul_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            AvxLanes(unsafe { _mm256_div_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn max(self, o: Self) -> Self {
            // VMAXPS: dest = src1 > src2 ? src1 : src2.
            AvxLanes(unsafe { _mm256_max_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn min(self, o: Self) -> Self {
            // VMINPS: dest = src1 < src2 ? src1 : src2.
            AvxLanes(unsafe { _mm256_min_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn lt(self, o: Self) -> Self {
            AvxLanes(unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn le(self, o: Self) -> Self {
            AvxLanes(unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn gt(self, o: Self) -> Self {
            AvxLanes(unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn eq(self, o: Self) -> Self {
            AvxLanes(unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, o.0) })
        }
        #[inline(always)]
        fn and(self, o: Self) -> Self {
            AvxLanes(unsafe { _mm256_and_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn or(self, o: Self) -> Self {
            AvxLanes(unsafe { _mm256_or_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn andnot(self, o: Self) -> Self {
            AvxLanes(unsafe { _mm256_andnot_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn bits(self) -> u32 {
            (unsafe { _mm256_movemask_ps(self.0) }) as u32
        }
    }
}

/// The four-lane proof of this architecture: SSE2 on x86_64, plain arrays elsewhere.
#[cfg(target_arch = "x86_64")]
pub(crate) type Native = Sse;
/// The four-lane proof of this architecture: SSE2 on x86_64, plain arrays elsewhere.
#[cfg(not(target_arch = "x86_64"))]
pub(crate) type Native = Portable<4>;

/// The [`Native`] proof, which every CPU of this architecture gives without a check.
#[cfg(target_arch = "x86_64")]
pub(crate) const NATIVE: Native = Sse::BASELINE;
/// The [`Native`] proof, which every CPU of this architecture gives without a check.
#[cfg(not(target_arch = "x86_64"))]
pub(crate) const NATIVE: Native = Portable::new();

#[cfg(test)]
mod tests {
    use super::*;

    /// Every operation of the vectors of `a` and `b` agrees bit for bit on awkward inputs
    /// (NaN, infinities, signed zeros, subnormals).
    #[inline(always)]
    fn agree<const N: usize, A: Simd<N>, B: Simd<N>>(a_proof: A, b_proof: B) {
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
                let (a, b) = (a_proof.load(p), a_proof.load(q));
                let (c, d) = (b_proof.load(p), b_proof.load(q));
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
            assert_eq!(a_proof.splat(p[1]).bits(), b_proof.splat(p[1]).bits());
        }
    }

    #[test]
    fn portable_lanes_follow_the_scalar_rules() {
        let s = Portable::<4>::new();
        let a = s.load(&[1.0, f32::NAN, -0.0, 2.0]);
        let b = s.load(&[2.0, 1.0, 0.0, f32::NAN]);
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
        agree::<4, _, _>(Sse::BASELINE, Portable::<4>::new());
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn proofs_are_given_exactly_where_the_cpu_has_the_features() {
        assert!(Sse::new().is_some());
        assert_eq!(Avx::new().is_some(), is_x86_feature_detected!("avx"));
        let avx512 = is_x86_feature_detected!("avx512f")
            && is_x86_feature_detected!("avx512vl")
            && is_x86_feature_detected!("avx2")
            && is_x86_feature_detected!("bmi1")
            && is_x86_feature_detected!("bmi2")
            && is_x86_feature_detected!("popcnt");
        assert_eq!(Avx512::new().is_some(), avx512);
        // AVX-512 implies the AVX proof.
        if let Some(p) = Avx512::new() {
            assert_eq!(Avx::new(), Some(p.avx()));
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    #[cfg_attr(not(femto_host_avx), ignore = "needs AVX (not on this CPU)")]
    fn avx_agrees_with_portable() {
        let avx = Avx::new().expect("built on a CPU with AVX, run on one without");
        // SAFETY: `agree_avx` only needs AVX, which the proof `avx` holds.
        unsafe { agree_avx(avx) }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn agree_avx(avx: Avx) {
        agree::<8, _, _>(avx, Portable::<8>::new());
        pairs_are_halves(avx);
    }

    /// `load_pair(lo, hi)` holds `lo` in lanes 0..4 and `hi` in lanes 4..8, bit for bit.
    #[inline(always)]
    fn pairs_are_halves<P: Pairs>(proof: P) {
        let lo = [1.0f32, -0.0, f32::INFINITY, 1e-40];
        let hi = [f32::NAN, 3.0e38, -1.5, 0.1];
        let got = proof.load_pair(&lo, &hi).to_array();
        let want = [lo, hi].concat();
        for k in 0..8 {
            assert_eq!(got[k].to_bits(), want[k].to_bits(), "lane {k}");
        }
    }

    #[test]
    fn portable_pairs_are_halves() {
        pairs_are_halves(Portable::<8>::new());
    }

    #[test]
    fn native_agrees_with_portable() {
        agree::<4, _, _>(NATIVE, Portable::<4>::new());
    }
}

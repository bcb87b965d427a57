//! Temporal prefix sums and time-only mip levels of a cube, for the renderer's interval
//! queries.
//!
//! physics.md, "Time-resolved accumulation": one frame of the relativistic renderer needs
//! `P(t_e + dtau / D) - P(t_e)`, the integral of a pixel's world-time signal over an interval
//! whose ends fall anywhere inside bins. [`Pyramid`] stores, per pixel, the prefix sum
//! `P[i] = sum of bins 0..i` (`nt + 1` values, `P[0] = 0`). The signal is piecewise constant
//! within each bin (the cube convention: a bin holds the signal integrated over it), so its
//! integral `P(t)` is piecewise linear and exact by linear interpolation in `P`: any interval
//! costs two interpolated lookups of `P` ([`Pyramid::integral`]).
//!
//! Mip levels are the seed's anisotropic mipmapping restricted to time: level `k` box-filters
//! `2^k` bins into one sample (stored as the sum, like the cube), and
//! [`Pyramid::mip_level_for`] picks the coarsest level whose sample is no longer than the
//! query window; [`Pyramid::sample_mip`] reads it.
//!
//! # Precision: the two-level prefix
//!
//! An interval late in a profile is the difference of two large prefix values. Stored in f32
//! the prefix carries a rounding error of about `6e-8 * P`, whatever the summation (Kahan
//! only fixes the accumulation, not the storage), so on a 512-bin profile spanning a dynamic
//! range of 1e6 a 1-4 bin interval in the faint tail comes out wrong by 100 % or more
//! (`prefix_precision_on_a_1e6_dynamic_range_profile`, intervals after bin 400, against
//! exact sums in 128-bit fixed point: max relative error 1.0 for an f32 prefix, 3.5 for an
//! f32 prefix accumulated with Kahan summation). A plain f64 prefix is exact there, but it
//! costs 8 bytes per bin, and the pyramid is memory-bound.
//!
//! So `P` is stored in two levels ([`PrefixSums`]): `coarse[k] = P[8 k]` in f64 at every
//! [`PREFIX_BLOCK_BINS`]-th bin, and `fine[i] = P[i] - P[8 floor(i / 8)]`, the sum of the
//! bins before `i` within its own block of 8, in f32; `P[i] = coarse[i / 8] + fine[i]`. The
//! f32 part rounds relative to the light in its own block, not to the whole prefix, so a faint
//! interval keeps its precision unless it shares a block of 8 bins with much brighter light:
//! an interval's error is at most `2^-21` of the light in the two blocks that hold its ends
//! (a property test checks this on profiles spanning 12 decades). On the test above it
//! measures 7.6e-7 (4.8e-7 with fractional ends), against 1.0 and 3.5 for the f32 prefixes
//! (the plain f64 prefix, computed there for comparison, is exact): about what one f32 bin
//! of the cube itself carries, a few 6e-8. The storage is 4.5 bytes per bin instead of 8
//! (2.57 KB instead of 4.10 KB per pixel at 512 bins), and the pyramid kernel moves 2.69 GB
//! for a 672 x 600 x 512 cube instead of 3.30 GB, 14 % less time at the same bandwidth
//! (tools/bench_cubeops_results.md). Mip levels stay f32: each sample is a short direct sum,
//! not a difference.

use crate::cube::{Cube, TimeAxis};
use rayon::prelude::*;

/// Bins per block of the two-level prefix: `coarse` holds `P` at every `PREFIX_BLOCK_BINS`-th
/// bin.
pub const PREFIX_BLOCK_BINS: usize = 8;

/// Coarse (f64) prefix values per pixel for `nt` bins: `P[0], P[8], ..., P[8 floor(nt / 8)]`.
#[inline]
pub fn coarse_len(nt: usize) -> usize {
    nt / PREFIX_BLOCK_BINS + 1
}

/// Number of samples per pixel at mip level `k` for a profile of `nt` bins: `ceil(nt / 2^k)`.
#[inline]
pub fn level_nt(nt: usize, k: usize) -> usize {
    nt.div_ceil(1 << k)
}

/// Number of mip levels above level 0 for `nt` bins: the smallest `K` with `2^K >= nt`,
/// where the top level holds one sample per pixel.
pub fn top_level(nt: usize) -> usize {
    // ceil(log2(nt)) without a loop that a shift overflow could make endless.
    if nt <= 1 {
        0
    } else {
        (usize::BITS - (nt - 1).leading_zeros()) as usize
    }
}

/// Bytes a [`Pyramid`] of `n_pix` pixels of `nt` bins holds: the two-level prefix sums, every
/// mip level (their samples add up to at most `nt + top_level(nt)` per pixel) and the mask.
/// Floats, so that sizes read from a file cannot overflow the product.
pub fn memory_bytes(n_pix: f64, nt: f64) -> f64 {
    let fine = 4.0 * (nt + 1.0);
    let coarse = 8.0 * (nt / PREFIX_BLOCK_BINS as f64 + 1.0);
    let levels = 4.0 * (nt + nt.max(1.0).log2().ceil());
    n_pix * (fine + coarse + levels + 1.0)
}

/// Pixels per parallel task of [`pyramid_rows`].
const BLOCK_PIXELS: usize = 64;

/// Prefix sums and mip levels `1 ..= levels.len()` of whole profiles, in one pass over the
/// source. `src_rows` holds profiles of `nt` bins back to back (`[y][x][t]` for any number
/// of rows); `prefix` receives each profile's two-level prefix sums ([`PrefixSums`]:
/// [`coarse_len`]`(nt)` f64 values per profile in `prefix.coarse`, `nt + 1` f32 values in
/// `prefix.fine`), accumulated in f64; `levels[k - 1]` receives
/// `level_nt(nt, k)` samples per profile, each the sum of two samples of the level below
/// (the last one alone when that level's length is odd: the signal is zero past the axis).
/// Parallel over blocks of pixels.
///
/// The kernel is memory-bound, so it is written to move as few bytes as possible: each
/// profile is read once; levels 1 and 2 are summed from it in SSE registers, levels 3 and up
/// from one another in a per-thread scratch that stays in the L2 cache; and the levels go
/// out with non-temporal stores (no read of each output cache line before it is
/// overwritten). Building an f64 prefix and the levels in separate passes, each level from
/// the stored one below, moved 4.95 GB for a 672 x 600 x 512 cube; one pass with the f64
/// prefix moved 3.30 GB, and with the two-level prefix 2.69 GB, each at about the bandwidth
/// of a plain copy (tools/bench_cubeops_results.md).
///
/// Panics if the slice lengths disagree or more levels are asked than `top_level(nt)`.
pub fn pyramid_rows(src_rows: &[f32], nt: usize, prefix: PrefixSlices, levels: &mut [&mut [f32]]) {
    assert!(
        levels.len() <= top_level(nt),
        "more levels than the axis has"
    );
    if nt == 0 {
        prefix.coarse.fill(0.0);
        prefix.fine.fill(0.0);
        return;
    }
    assert_eq!(src_rows.len() % nt, 0, "source is not whole profiles");
    let n_pix = src_rows.len() / nt;
    let (n_coarse, n_fine) = (coarse_len(nt), nt + 1);
    assert_eq!(prefix.coarse.len(), n_pix * n_coarse, "coarse prefix size");
    assert_eq!(prefix.fine.len(), n_pix * n_fine, "fine prefix size");
    let level_nts: Vec<usize> = (1..=levels.len()).map(|k| level_nt(nt, k)).collect();
    for (k, (l, &n)) in levels.iter().zip(&level_nts).enumerate() {
        assert_eq!(l.len(), n_pix * n, "level {} size", k + 1);
    }
    // Every level of one block of pixels, level by level, each `[pixel][sample]`.
    let scratch_len: usize = BLOCK_PIXELS * level_nts.iter().sum::<usize>();
    // One task per block of pixels, holding that block's part of every output.
    let mut level_blocks: Vec<_> = levels
        .iter_mut()
        .zip(&level_nts)
        .map(|(l, &n)| l.chunks_mut(BLOCK_PIXELS * n))
        .collect();
    let blocks: Vec<Block> = src_rows
        .chunks(BLOCK_PIXELS * nt)
        .zip(prefix.coarse.chunks_mut(BLOCK_PIXELS * n_coarse))
        .zip(prefix.fine.chunks_mut(BLOCK_PIXELS * n_fine))
        .map(|((src, coarse), fine)| Block {
            src,
            prefix: PrefixSlices { coarse, fine },
            levels: level_blocks
                .iter_mut()
                .map(|c| c.next().expect("levels are sized like the source"))
                .collect(),
        })
        .collect();
    blocks.into_par_iter().for_each_init(
        || vec![0.0f32; scratch_len],
        |scratch, mut b| {
            block_pyramid(b.src, nt, b.prefix, &level_nts, scratch, &mut b.levels);
            stream::fence();
        },
    );
}

/// Where [`pyramid_rows`] writes the two-level prefix sums of its profiles (the layout of
/// [`PrefixSums`]).
pub struct PrefixSlices<'a> {
    /// [`coarse_len`]`(nt)` values per profile.
    pub coarse: &'a mut [f64],
    /// `nt + 1` values per profile.
    pub fine: &'a mut [f32],
}

/// One block of pixels of [`pyramid_rows`]: its source profiles and its part of each output.
struct Block<'a> {
    src: &'a [f32],
    prefix: PrefixSlices<'a>,
    levels: Vec<&'a mut [f32]>,
}

/// [`pyramid_rows`] for one block of pixels. The prefix is written as it is summed; level 1
/// is summed from the same profile while it is in the L1 cache, and each level above it from
/// the one below, into `scratch`
/// (a block's levels fit in the L2 cache); then each level, a contiguous stretch of its
/// output, is streamed out.
fn block_pyramid(
    src: &[f32],
    nt: usize,
    prefix: PrefixSlices,
    level_nts: &[usize],
    scratch: &mut [f32],
    levels: &mut [&mut [f32]],
) {
    let profiles = src.chunks_exact(nt).zip(
        prefix
            .coarse
            .chunks_exact_mut(coarse_len(nt))
            .zip(prefix.fine.chunks_exact_mut(nt + 1)),
    );
    if levels.is_empty() {
        profiles.for_each(|(s, (c, f))| prefix_one(s, c, f));
        return;
    }
    let n_pix = src.len() / nt;
    let n1 = level_nts[0];
    // Levels 1 and 2 go straight from registers to their outputs where SSE and the layout
    // allow it (four-fifths of the level bytes skip the scratch); the levels above them, or
    // all levels otherwise, are built in `scratch` and streamed out afterwards.
    let direct = stream::can_write_levels_1_2(nt, levels);
    // `scratch[below]` holds the block's level below the one being built.
    let mut below;
    let first_built;
    if direct {
        let n2 = level_nts[1];
        let (l1, rest) = levels.split_at_mut(1);
        let l2_scratch = &mut scratch[n_pix * n1..n_pix * (n1 + n2)];
        for (i, ((s, (c, f)), l2s)) in profiles.zip(l2_scratch.chunks_exact_mut(n2)).enumerate() {
            stream::levels_1_2(
                s,
                &mut l1[0][i * n1..(i + 1) * n1],
                &mut rest[0][i * n2..(i + 1) * n2],
                l2s,
            );
            prefix_one(s, c, f);
        }
        below = n_pix * n1..n_pix * (n1 + n2);
        first_built = 2;
    } else {
        for ((s, (c, f)), l1) in profiles.zip(scratch.chunks_exact_mut(n1)) {
            halve(s, l1);
            prefix_one(s, c, f);
        }
        below = 0..n_pix * n1;
        first_built = 1;
    }
    for k in first_built..levels.len() {
        let (n_below, n_k) = (level_nts[k - 1], level_nts[k]);
        let (done, free) = scratch.split_at_mut(below.end);
        let dst = &mut free[..n_pix * n_k];
        let src_k = &done[below.clone()];
        if n_below % 2 == 0 {
            // Even length: output j is the sum of inputs 2j and 2j + 1, whatever the pixel.
            halve(src_k, dst);
        } else {
            for (d, s) in dst.chunks_exact_mut(n_k).zip(src_k.chunks_exact(n_below)) {
                halve(s, d);
            }
        }
        below = below.end..below.end + n_pix * n_k;
    }
    let mut start = 0;
    for (k, (level, &n_k)) in levels.iter_mut().zip(level_nts).enumerate() {
        let len = n_pix * n_k;
        if k >= 2 || !direct {
            stream::copy(&scratch[start..start + len], level);
        }
        start += len;
    }
}

/// One profile's two-level prefix sums (see [`PrefixSums`]): `coarse` gets
/// [`coarse_len`]`(src.len())` values, `fine` gets `src.len() + 1`. Each whole block of 8 bins
/// goes through [`block_sums`]; the running total, one f64 addition per block, is the only
/// chain from one block to the next.
#[inline]
fn prefix_one(src: &[f32], coarse: &mut [f64], fine: &mut [f32]) {
    coarse[0] = 0.0;
    let mut running = 0.0f64;
    let blocks = src.chunks_exact(PREFIX_BLOCK_BINS);
    let tail = blocks.remainder();
    for ((v, f), c) in blocks
        .zip(fine.chunks_exact_mut(PREFIX_BLOCK_BINS))
        .zip(&mut coarse[1..])
    {
        running += block_sums(v.try_into().unwrap(), f.try_into().unwrap());
        *c = running;
    }
    // The last, partial block (or, for whole blocks, the entry at `nt`, which starts a block).
    let n = src.len() - tail.len();
    let mut acc = 0.0f32;
    fine[n] = 0.0;
    for (j, &v) in tail.iter().enumerate() {
        acc += v;
        fine[n + j + 1] = acc;
    }
}

/// One block of 8 bins `v`: writes its exclusive prefix sums `[0, v0, v0 + v1, ...]` into `f`
/// and returns its total in f64. The sums are f32, as a log-depth scan over each half of the
/// block (at most three roundings, so within `3 * 2^-24` of the block's light); the total is
/// the f64 sum of the bins. SSE2 on x86-64, four sums per instruction: against the same
/// sums formed one by one in f64 and rounded to f32, the whole pyramid kernel took 0.144
/// instead of 0.157 s on one thread and 0.072-0.092 instead of 0.086-0.110 s on two
/// (tools/bench_cubeops_results.md). [`block_sums_scalar`] (the same additions in the same
/// order) elsewhere.
#[inline(always)]
fn block_sums(v: &[f32; PREFIX_BLOCK_BINS], f: &mut [f32; PREFIX_BLOCK_BINS]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `v` and `f` are arrays of 8 f32 (two unaligned 4-lane loads and stores each);
    // SSE2 is in the x86-64 baseline.
    unsafe {
        use std::arch::x86_64::*;
        let lanes_up = |x: __m128| _mm_castsi128_ps(_mm_slli_si128::<4>(_mm_castps_si128(x)));
        // Inclusive scan of 4 lanes: add the lanes shifted up by one, then by two.
        let scan = |x: __m128| {
            let s = _mm_add_ps(x, lanes_up(x));
            _mm_add_ps(
                s,
                _mm_castsi128_ps(_mm_slli_si128::<8>(_mm_castps_si128(s))),
            )
        };
        let x0 = _mm_loadu_ps(v.as_ptr());
        let x1 = _mm_loadu_ps(v.as_ptr().add(4));
        let (i0, i1) = (scan(x0), scan(x1));
        let half = _mm_shuffle_ps::<0xFF>(i0, i0);
        _mm_storeu_ps(f.as_mut_ptr(), lanes_up(i0));
        _mm_storeu_ps(f.as_mut_ptr().add(4), _mm_add_ps(lanes_up(i1), half));
        let pairs = |x: __m128| _mm_add_pd(_mm_cvtps_pd(x), _mm_cvtps_pd(_mm_movehl_ps(x, x)));
        let d = _mm_add_pd(pairs(x0), pairs(x1));
        _mm_cvtsd_f64(_mm_add_sd(d, _mm_unpackhi_pd(d, d)))
    }
    #[cfg(not(target_arch = "x86_64"))]
    block_sums_scalar(v, f)
}

/// [`block_sums`] without SIMD: the same additions in the same order (bit-identical results,
/// `block_sums_simd_and_scalar_agree`).
#[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
fn block_sums_scalar(v: &[f32; PREFIX_BLOCK_BINS], f: &mut [f32; PREFIX_BLOCK_BINS]) -> f64 {
    let scan = |x: &[f32]| {
        let s = [x[0], x[1] + x[0], x[2] + x[1], x[3] + x[2]];
        [s[0], s[1], s[2] + s[0], s[3] + s[1]]
    };
    let (i0, i1) = (scan(&v[..4]), scan(&v[4..]));
    *f = [
        0.0,
        i0[0],
        i0[1],
        i0[2],
        i0[3],
        i1[0] + i0[3],
        i1[1] + i0[3],
        i1[2] + i0[3],
    ];
    let d = |k: usize| (v[k] as f64 + v[k + 2] as f64) + (v[k + 4] as f64 + v[k + 6] as f64);
    d(0) + d(1)
}

/// `dst[j] = src[2 j] + src[2 j + 1]`, and the last sample alone when `src.len()` is odd
/// (`dst.len() == ceil(src.len() / 2)`).
#[inline]
fn halve(src: &[f32], dst: &mut [f32]) {
    let pairs = src.chunks_exact(2);
    if let Some(&v) = pairs.remainder().first() {
        dst[dst.len() - 1] = v;
    }
    for (o, p) in dst.iter_mut().zip(pairs) {
        *o = p[0] + p[1];
    }
}

/// Stores that bypass the cache (SSE `movntps` / SSE2 `movnti`, part of every x86-64 CPU) for
/// the mip levels, outputs far larger than the cache, with plain stores on other targets.
/// Non-temporal stores are weakly ordered: [`fence`] must follow them before another thread
/// reads the data (each parallel task of this module ends with it).
mod stream {
    /// `*out = a` for an f32.
    #[inline(always)]
    fn single_f32(out: &mut f32, a: f32) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `out` is a valid, aligned, exclusive f32 location; an i32 store of its bits
        // writes the same 4 bytes. SSE2 is part of the x86-64 baseline.
        unsafe {
            std::arch::x86_64::_mm_stream_si32((out as *mut f32).cast::<i32>(), a.to_bits() as i32);
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            *out = a;
        }
    }

    /// `dst.copy_from_slice(src)`, four values per store where `dst` is 16-byte aligned.
    #[inline]
    pub fn copy(src: &[f32], dst: &mut [f32]) {
        assert_eq!(src.len(), dst.len(), "copy: sizes");
        let n = dst.len();
        let head = dst.as_ptr().align_offset(16).min(n);
        let mut i = 0;
        while i < head {
            single_f32(&mut dst[i], src[i]);
            i += 1;
        }
        #[cfg(target_arch = "x86_64")]
        while i + 4 <= n {
            let (s, d) = (&src[i..i + 4], &mut dst[i..i + 4]);
            // SAFETY: `s` and `d` hold 4 f32 each (bounds-checked slices above); `d` starts
            // on a 16-byte boundary (`head` aligned it and `i` advances by 4 f32 = 16
            // bytes); unaligned loads have no alignment requirement; SSE is in the x86-64
            // baseline.
            unsafe {
                use std::arch::x86_64::*;
                _mm_stream_ps(d.as_mut_ptr(), _mm_loadu_ps(s.as_ptr()));
            }
            i += 4;
        }
        while i < n {
            single_f32(&mut dst[i], src[i]);
            i += 1;
        }
    }

    /// Whether [`levels_1_2`] can write levels 1 and 2 of profiles of `nt` bins into
    /// `levels[0]` and `levels[1]`: on x86-64, with whole blocks of 16 bins and both outputs
    /// 16-byte aligned (so every pixel's part of them is).
    pub fn can_write_levels_1_2(nt: usize, levels: &[&mut [f32]]) -> bool {
        cfg!(target_arch = "x86_64")
            && nt.is_multiple_of(16)
            && levels.len() >= 2
            && levels[..2].iter().all(|l| l.as_ptr().align_offset(16) == 0)
    }

    /// Levels 1 and 2 of one profile `src` (a multiple of 16 bins), four sums per SSE
    /// instruction: level 1 into `l1` and level 2 into `l2` with non-temporal stores (both
    /// 16-byte aligned), and level 2 also into `l2_copy` (ordinary stores, for the levels
    /// above). The sums are the same additions, in the same order, as two
    /// [`super::halve`] passes.
    #[cfg(target_arch = "x86_64")]
    pub fn levels_1_2(src: &[f32], l1: &mut [f32], l2: &mut [f32], l2_copy: &mut [f32]) {
        use std::arch::x86_64::*;
        assert!(
            src.len().is_multiple_of(16),
            "levels_1_2: whole blocks of 16"
        );
        let n = src.len() / 16;
        assert!(l1.len() == 8 * n && l2.len() == 4 * n && l2_copy.len() == 4 * n);
        assert!(l1.as_ptr().align_offset(16) == 0 && l2.as_ptr().align_offset(16) == 0);
        for q in 0..n {
            // SAFETY: `src` holds 16 values from 16 q, `l1` 8 from 8 q and `l2`, `l2_copy` 4
            // from 4 q (lengths asserted above); `l1` and `l2` are 16-byte aligned and the
            // offsets are multiples of 4 f32, as `_mm_stream_ps` needs; loads and `storeu`
            // are unaligned; SSE is in the x86-64 baseline.
            unsafe {
                let p = src.as_ptr().add(16 * q);
                let pairs = |a: __m128, b: __m128| {
                    _mm_add_ps(
                        _mm_shuffle_ps::<0b10_00_10_00>(a, b),
                        _mm_shuffle_ps::<0b11_01_11_01>(a, b),
                    )
                };
                let l1a = pairs(_mm_loadu_ps(p), _mm_loadu_ps(p.add(4)));
                let l1b = pairs(_mm_loadu_ps(p.add(8)), _mm_loadu_ps(p.add(12)));
                let s2 = pairs(l1a, l1b);
                _mm_stream_ps(l1.as_mut_ptr().add(8 * q), l1a);
                _mm_stream_ps(l1.as_mut_ptr().add(8 * q + 4), l1b);
                _mm_stream_ps(l2.as_mut_ptr().add(4 * q), s2);
                _mm_storeu_ps(l2_copy.as_mut_ptr().add(4 * q), s2);
            }
        }
    }

    /// Never called off x86-64 ([`can_write_levels_1_2`] is false there).
    #[cfg(not(target_arch = "x86_64"))]
    pub fn levels_1_2(_: &[f32], _: &mut [f32], _: &mut [f32], _: &mut [f32]) {
        unreachable!("levels_1_2 off x86-64")
    }

    /// Orders the non-temporal stores before any later store (the end of a parallel task).
    #[inline(always)]
    pub fn fence() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `sfence` has no operands and no preconditions (SSE, x86-64 baseline).
        unsafe {
            std::arch::x86_64::_mm_sfence();
        }
    }
}

/// The two-level prefix sums of every pixel (module doc, "Precision"):
/// `P[i] = coarse[i / 8] + fine[i]`.
#[derive(Clone, Debug, PartialEq)]
pub struct PrefixSums {
    /// Bins per pixel.
    pub nt: usize,
    /// `[y][x][k]`, [`coarse_len`]`(nt)` values per pixel: `P[8 k]`, in f64.
    pub coarse: Vec<f64>,
    /// `[y][x][i]`, `nt + 1` values per pixel: `P[i] - P[8 floor(i / 8)]`, the sum of the bins
    /// before `i` in its own block of 8 (0 where `i` starts a block), in f32.
    pub fine: Vec<f32>,
}

impl PrefixSums {
    /// All-zero prefix sums of `n_pix` pixels of `nt` bins.
    pub fn zeros(n_pix: usize, nt: usize) -> PrefixSums {
        PrefixSums {
            nt,
            coarse: vec![0.0; n_pix * coarse_len(nt)],
            fine: vec![0.0; n_pix * (nt + 1)],
        }
    }

    /// The two-level form of plain prefix sums (`nt + 1` values per pixel, `P[0] = 0`), for
    /// reading pyramids stored with an f64 prefix. Panics unless `plain.len()` is a multiple
    /// of `nt + 1`.
    pub fn from_plain(plain: &[f64], nt: usize) -> PrefixSums {
        assert!(plain.len().is_multiple_of(nt + 1), "plain prefix size");
        let n_pix = plain.len() / (nt + 1);
        let mut out = PrefixSums::zeros(n_pix, nt);
        let pixels = plain.chunks_exact(nt + 1).zip(
            out.coarse
                .chunks_exact_mut(coarse_len(nt))
                .zip(out.fine.chunks_exact_mut(nt + 1)),
        );
        for (p, (c, f)) in pixels {
            for (k, c) in c.iter_mut().enumerate() {
                *c = p[k * PREFIX_BLOCK_BINS];
            }
            for (i, f) in f.iter_mut().enumerate() {
                *f = (p[i] - p[i - i % PREFIX_BLOCK_BINS]) as f32;
            }
        }
        out
    }

    /// The prefix of pixel `p` (flat index `y * nx + x`). Panics past the last pixel.
    #[inline]
    pub fn pixel(&self, p: usize) -> PixelPrefix<'_> {
        let (nc, nf) = (coarse_len(self.nt), self.nt + 1);
        PixelPrefix {
            coarse: &self.coarse[p * nc..(p + 1) * nc],
            fine: &self.fine[p * nf..(p + 1) * nf],
        }
    }

    /// Where [`pyramid_rows`] writes these sums.
    pub fn slices(&mut self) -> PrefixSlices<'_> {
        PrefixSlices {
            coarse: &mut self.coarse,
            fine: &mut self.fine,
        }
    }
}

/// One pixel's two-level prefix sums (see [`PrefixSums`]).
#[derive(Clone, Copy, Debug)]
pub struct PixelPrefix<'a> {
    coarse: &'a [f64],
    fine: &'a [f32],
}

/// Reading one pixel's prefix sums `P[0 ..= nt]`, whatever their storage: the two levels a
/// pyramid stores ([`PixelPrefix`]) or a plain f64 slice (the renderer's expanded copy).
pub trait PrefixRead {
    /// Bins of the profile.
    fn nt(&self) -> usize;

    /// `P[i]`, the sum of bins `0 .. i`, for `i <= nt`.
    fn get(&self, i: usize) -> f64;

    /// Bin `i`'s value, `P[i + 1] - P[i]`.
    #[inline]
    fn bin(&self, i: usize) -> f64 {
        self.get(i + 1) - self.get(i)
    }

    /// The pixel's total, `P[nt]`.
    #[inline]
    fn total(&self) -> f64 {
        self.get(self.nt())
    }

    /// `P` at the fractional bin coordinate `c` (0 at the axis start): 0 before the axis, the
    /// total after it, linear inside a bin; NaN for a NaN coordinate.
    #[inline]
    fn at_coord(&self, c: f64) -> f64 {
        PrefixCoord::new(c, self.nt()).read(self)
    }

    /// `P(t_ps)` on `axis` (see [`PrefixRead::at_coord`]).
    #[inline]
    fn at(&self, axis: &TimeAxis, t_ps: f64) -> f64 {
        self.at_coord(axis.bin_coord(t_ps))
    }
}

/// A fractional bin coordinate of an axis of `nt` bins, resolved once for reading several
/// pixels' prefixes at it ([`PrefixRead::at_coord`] is `PrefixCoord::new(c, nt).read(p)`):
/// the renderer reads the up to four pixels around a point at the same two coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PrefixCoord {
    /// At or before the axis start: `P = 0`.
    Before,
    /// At or after the axis end: `P` is the pixel's total.
    After,
    /// A NaN coordinate: `P` is NaN.
    Nan,
    /// Inside bin `bin`, at `frac` (0 to 1) of its width.
    Inside { bin: usize, frac: f64 },
}

impl PrefixCoord {
    /// The case of coordinate `c` on an axis of `nt` bins.
    #[inline(always)]
    pub fn new(c: f64, nt: usize) -> PrefixCoord {
        if c <= 0.0 {
            PrefixCoord::Before
        } else if c >= nt as f64 {
            PrefixCoord::After
        } else if c.is_nan() {
            PrefixCoord::Nan
        } else {
            let bin = c as usize;
            PrefixCoord::Inside {
                bin,
                frac: c - bin as f64,
            }
        }
    }

    /// `P` of the prefix `p` at this coordinate: 0 before the axis, the total after it,
    /// linear inside a bin.
    #[inline(always)]
    pub fn read<P: PrefixRead + ?Sized>(self, p: &P) -> f64 {
        match self {
            PrefixCoord::Before => 0.0,
            PrefixCoord::After => p.total(),
            PrefixCoord::Nan => f64::NAN,
            PrefixCoord::Inside { bin, frac } => p.get(bin) + frac * p.bin(bin),
        }
    }
}

impl PrefixRead for PixelPrefix<'_> {
    #[inline]
    fn nt(&self) -> usize {
        self.fine.len() - 1
    }

    #[inline]
    fn get(&self, i: usize) -> f64 {
        self.coarse[i / PREFIX_BLOCK_BINS] + self.fine[i] as f64
    }

    /// The block totals' difference plus the f32 values' (not two large sums subtracted).
    #[inline]
    fn bin(&self, i: usize) -> f64 {
        let (ka, kb) = (i / PREFIX_BLOCK_BINS, (i + 1) / PREFIX_BLOCK_BINS);
        (self.coarse[kb] - self.coarse[ka]) + (self.fine[i + 1] as f64 - self.fine[i] as f64)
    }
}

/// A plain prefix, `nt + 1` values with `P[0] = 0`.
impl PrefixRead for [f64] {
    #[inline]
    fn nt(&self) -> usize {
        self.len() - 1
    }

    #[inline]
    fn get(&self, i: usize) -> f64 {
        self[i]
    }
}

/// One mip level above level 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    /// Source bins per sample, `2^k`.
    pub bins_per_sample: usize,
    /// Samples per pixel, `ceil(nt / 2^k)`.
    pub nt: usize,
    /// `[y][x][sample]`: the sum of the `2^k` source bins of each sample (missing bins past
    /// the end of the axis count as zero).
    pub data: Vec<f32>,
}

/// Prefix sums and time-only mip levels of a cube (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct Pyramid {
    pub nx: usize,
    pub ny: usize,
    /// Time axis of the source cube (level 0).
    pub axis: TimeAxis,
    /// Per pixel, `P[i]` = sum of bins `0..i`, in two levels.
    pub prefix: PrefixSums,
    /// `levels[k - 1]` is level `k` (`2^k` bins per sample), for `k = 1 ..= top_level(nt)`.
    /// Level 0 is read from the prefix.
    pub levels: Vec<Level>,
    /// The cube's validity mask, `[y][x]`, 1 = valid.
    pub mask: Option<Vec<u8>>,
}

impl Pyramid {
    /// Prefix sums and every mip level of `cube`.
    pub fn build(cube: &Cube) -> Pyramid {
        let nt = cube.nt();
        let n_pix = cube.nx * cube.ny;
        let mut prefix = PrefixSums::zeros(n_pix, nt);
        let mut levels: Vec<Level> = (1..=top_level(nt))
            .map(|k| Level {
                bins_per_sample: 1 << k,
                nt: level_nt(nt, k),
                data: vec![0.0f32; n_pix * level_nt(nt, k)],
            })
            .collect();
        let mut outs: Vec<&mut [f32]> = levels.iter_mut().map(|l| &mut l.data[..]).collect();
        pyramid_rows(&cube.data, nt, prefix.slices(), &mut outs);
        Pyramid {
            nx: cube.nx,
            ny: cube.ny,
            axis: cube.axis,
            prefix,
            levels,
            mask: cube.mask.clone(),
        }
    }

    /// Number of levels including level 0.
    pub fn level_count(&self) -> usize {
        self.levels.len() + 1
    }

    /// The prefix of pixel `(x, y)`. Panics outside the image.
    #[inline]
    pub fn pixel_prefix(&self, x: usize, y: usize) -> PixelPrefix<'_> {
        assert!(
            x < self.nx && y < self.ny,
            "pixel ({x}, {y}) outside the image"
        );
        self.prefix.pixel(y * self.nx + x)
    }

    /// Integral of pixel `(x, y)`'s signal over `[ta_ps, tb_ps]`: `P(tb) - P(ta)`, exact for
    /// the piecewise-constant signal. Ends are clamped to the axis (the signal is zero
    /// outside it); `ta_ps > tb_ps` gives the oriented integral, minus the integral over
    /// `[tb_ps, ta_ps]`. Panics outside the image.
    #[inline]
    pub fn integral(&self, x: usize, y: usize, ta_ps: f64, tb_ps: f64) -> f64 {
        let p = self.pixel_prefix(x, y);
        p.at(&self.axis, tb_ps) - p.at(&self.axis, ta_ps)
    }

    /// The coarsest level whose sample (`2^k` bins) is no longer than `window_ps`; 0 for a
    /// window shorter than two bins (or NaN), the top level for a very long one.
    pub fn mip_level_for(&self, window_ps: f64) -> usize {
        let r = window_ps / self.axis.dt_ps;
        let mut k = 0;
        while k < self.levels.len() && ((2usize << k) as f64) <= r {
            k += 1;
        }
        k
    }

    /// Sample `i` of level `k` for pixel `p` (flat index), zero outside the level.
    #[inline]
    fn level_sample(&self, k: usize, p: usize, i: i64) -> f64 {
        if k == 0 {
            let nt = self.axis.nt;
            if i < 0 || i as usize >= nt {
                return 0.0;
            }
            self.prefix.pixel(p).bin(i as usize)
        } else {
            let l = &self.levels[k - 1];
            if i < 0 || i as usize >= l.nt {
                return 0.0;
            }
            l.data[p * l.nt + i as usize] as f64
        }
    }

    /// Average signal density (cube units per ps) of pixel `(x, y)` over a window of
    /// `window_ps` centred on `t_ps`, read from level [`Pyramid::mip_level_for`]: the
    /// level's samples divided by their length, linearly interpolated between sample
    /// centres, zero outside the axis. Exact when the window is one whole aligned sample of
    /// that level. Panics outside the image.
    pub fn sample_mip(&self, x: usize, y: usize, t_ps: f64, window_ps: f64) -> f32 {
        assert!(
            x < self.nx && y < self.ny,
            "pixel ({x}, {y}) outside the image"
        );
        let k = self.mip_level_for(window_ps);
        let w_ps = self.axis.dt_ps * (1u64 << k) as f64;
        let c = (t_ps - self.axis.t0_ps) / w_ps - 0.5;
        let i = c.floor();
        let f = c - i;
        let p = y * self.nx + x;
        let i = i as i64;
        let v = (1.0 - f) * self.level_sample(k, p, i) + f * self.level_sample(k, p, i + 1);
        (v / w_ps) as f32
    }
}

#[cfg(test)]
mod tests;

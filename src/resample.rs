//! Energy-conserving time resampling of one pixel's profile.
//!
//! Each source bin holds the signal integrated over its interval; the signal is reconstructed
//! as constant within each source bin, and each destination bin receives the integral of that
//! reconstruction over its own interval. So the total over the destination axis equals the
//! total over the source axis whenever the destination covers the source. Used by the time
//! unwarp (seed Eq. 2, fractional shifts of `eta * d / c`), the sweep-linearity correction
//! (non-uniform streak time axis to a uniform grid) and the per-scanline jitter removal.
//!
//! When the source and destination axes share the bin width (the unwarp case), a shift by
//! `k + f` bins (`k` integer, `0 <= f < 1`) sends a fraction `1 - f` of source bin `i` to
//! destination bin `i + k` and `f` to bin `i + k + 1`; [`shift_into`] evaluates that two-tap
//! form directly (no per-pixel allocation, vectorisable), which is the same overlap integral
//! as [`rebin_add`] computes. A shift within [`SNAP_BINS`] of a whole number of bins is taken
//! as exact, so integer shifts copy bins bit for bit.

use crate::cube::TimeAxis;

/// Fractional shifts closer than this (in bins) to a whole number are snapped to it. The
/// snap moves where a bin is split by at most 1e-9 of a bin, far below f32 resolution, and
/// never changes the total.
pub const SNAP_BINS: f64 = 1e-9;

/// Rebin a profile given by arbitrary increasing bin edges (`src_edges_ps.len() ==
/// src.len() + 1`) onto the uniform axis `dst_axis`, adding into `dst` (`dst.len() ==
/// dst_axis.nt`). Source bins with non-increasing edges are skipped.
pub fn rebin_add(src_edges_ps: &[f64], src: &[f32], dst_axis: &TimeAxis, dst: &mut [f32]) {
    debug_assert_eq!(src_edges_ps.len(), src.len() + 1);
    rebin_add_with(|i| src_edges_ps[i], src, dst_axis, dst);
}

/// [`rebin_add`] with the source edges given by a function of the edge index.
fn rebin_add_with(
    src_edge_ps: impl Fn(usize) -> f64,
    src: &[f32],
    dst_axis: &TimeAxis,
    dst: &mut [f32],
) {
    debug_assert_eq!(dst.len(), dst_axis.nt);
    let n_dst = dst_axis.nt as i64;
    for (i, &v) in src.iter().enumerate() {
        if v == 0.0 {
            continue;
        }
        let (a, b) = (src_edge_ps(i), src_edge_ps(i + 1));
        let width = b - a;
        if width <= 0.0 || width.is_nan() {
            continue;
        }
        let density = v as f64 / width;
        // Destination bin coordinates of the source interval.
        let ca = dst_axis.bin_coord(a);
        let cb = dst_axis.bin_coord(b);
        let j0 = ca.floor().max(0.0) as i64;
        let j1 = (cb.ceil() as i64).min(n_dst);
        for j in j0..j1 {
            let lo = ca.max(j as f64);
            let hi = cb.min((j + 1) as f64);
            if hi > lo {
                dst[j as usize] += (density * (hi - lo) * dst_axis.dt_ps) as f32;
            }
        }
    }
}

/// Shift a profile on a uniform axis by `shift_ps` (positive = later) and rebin onto
/// `dst_axis`, overwriting `dst`. Source signal that lands outside `dst_axis` is dropped.
pub fn shift_into(
    src_axis: &TimeAxis,
    src: &[f32],
    shift_ps: f64,
    dst_axis: &TimeAxis,
    dst: &mut [f32],
) {
    debug_assert_eq!(src.len(), src_axis.nt);
    debug_assert_eq!(dst.len(), dst_axis.nt);
    if src_axis.dt_ps == dst_axis.dt_ps && src_axis.dt_ps > 0.0 {
        let shift_bins = (src_axis.t0_ps + shift_ps - dst_axis.t0_ps) / dst_axis.dt_ps;
        shift_same_width(src, shift_bins, dst);
    } else {
        dst.iter_mut().for_each(|v| *v = 0.0);
        rebin_add_with(|i| src_axis.bin_start_ps(i) + shift_ps, src, dst_axis, dst);
    }
}

/// Split a shift in bins into a whole part `k` and a fraction `0 <= f < 1`, snapping
/// fractions within [`SNAP_BINS`] of a whole number.
fn split_shift(shift_bins: f64) -> (i64, f64) {
    let k = shift_bins.floor();
    let f = shift_bins - k;
    if f < SNAP_BINS {
        (k as i64, 0.0)
    } else if f > 1.0 - SNAP_BINS {
        (k as i64 + 1, 0.0)
    } else {
        (k as i64, f)
    }
}

/// Two-tap shift between axes of equal bin width: `dst[j] = (1 - f) src[j - k] + f src[j - k
/// - 1]`, source indices outside `src` reading zero. A non-finite shift leaves `dst` zero.
fn shift_same_width(src: &[f32], shift_bins: f64, dst: &mut [f32]) {
    if !shift_bins.is_finite() {
        dst.fill(0.0);
        return;
    }
    let (k, f) = split_shift(shift_bins);
    let n_src = src.len() as i64;
    let n_dst = dst.len() as i64;
    // Destination index range that any source bin reaches: [k, k + n_src] (the last one only
    // through the fraction f).
    let reach_end = if f == 0.0 { k + n_src } else { k + n_src + 1 };
    let lo = k.clamp(0, n_dst) as usize;
    let hi = reach_end.clamp(0, n_dst) as usize;
    dst[..lo].fill(0.0);
    dst[hi.max(lo)..].fill(0.0);
    if lo >= hi {
        return;
    }
    if f == 0.0 {
        // Whole-bin shift: a plain copy, exact.
        let s = (lo as i64 - k) as usize;
        dst[lo..hi].copy_from_slice(&src[s..s + (hi - lo)]);
        return;
    }
    let w0 = (1.0 - f) as f32;
    let w1 = f as f32;
    let at = |i: i64| -> f32 {
        if (0..n_src).contains(&i) {
            src[i as usize]
        } else {
            0.0
        }
    };
    // Interior where both taps are inside the source: j in [k + 1, k + n_src).
    let a = (k + 1).clamp(lo as i64, hi as i64) as usize;
    let b = (k + n_src).clamp(a as i64, hi as i64) as usize;
    let edge = |j: usize| {
        let i = j as i64 - k;
        w0 * at(i) + w1 * at(i - 1)
    };
    for (j, d) in dst.iter_mut().enumerate().take(a).skip(lo) {
        *d = edge(j);
    }
    if b > a {
        let s = (a as i64 - k) as usize;
        let n = b - a;
        let taps0 = &src[s..s + n];
        let taps1 = &src[s - 1..s - 1 + n];
        for ((d, &x0), &x1) in dst[a..b].iter_mut().zip(taps0).zip(taps1) {
            *d = w0 * x0 + w1 * x1;
        }
    }
    for (j, d) in dst.iter_mut().enumerate().take(hi).skip(b) {
        *d = edge(j);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(t0_ps: f64, dt_ps: f64, nt: usize) -> TimeAxis {
        TimeAxis { t0_ps, dt_ps, nt }
    }

    #[test]
    fn integer_shift_moves_bins_exactly() {
        let a = axis(0.0, 2.0, 6);
        let src = [0.0, 1.0, 2.0, 3.0, 0.0, 0.0];
        let mut dst = [0.0f32; 6];
        shift_into(&a, &src, 4.0, &a, &mut dst);
        assert_eq!(dst, [0.0, 0.0, 0.0, 1.0, 2.0, 3.0]);
    }

    #[test]
    fn fractional_shift_splits_by_overlap_and_conserves() {
        let a = axis(0.0, 1.0, 4);
        let src = [0.0, 4.0, 0.0, 0.0];
        let mut dst = [0.0f32; 4];
        shift_into(&a, &src, 0.25, &a, &mut dst);
        assert_eq!(dst, [0.0, 3.0, 1.0, 0.0]);
    }

    #[test]
    fn non_uniform_edges_to_uniform_grid_conserves_total() {
        let edges = [0.0, 0.5, 2.0, 2.25, 4.0];
        let src = [1.0, 3.0, 0.5, 7.0];
        let a = axis(-1.0, 0.5, 12);
        let mut dst = vec![0.0f32; 12];
        rebin_add(&edges, &src, &a, &mut dst);
        let total: f32 = dst.iter().sum();
        assert!((total - 11.5).abs() < 1e-5);
        // Bin [0.5, 1.0) lies inside source bin 1 (density 3 / 1.5 = 2 per ps): 2 * 0.5 = 1.
        assert!((dst[3] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn near_integer_shift_is_snapped_to_an_exact_copy() {
        let a = axis(0.0, 2.0, 5);
        let src = [0.1, 1.0e-7, 3.3, 1.0e9, 5.5];
        let mut dst = [9.0f32; 5];
        // 4 ps = 2 bins, minus a rounding-sized error.
        shift_into(&a, &src, 4.0 - 1e-12, &a, &mut dst);
        assert_eq!(dst, [0.0, 0.0, 0.1, 1.0e-7, 3.3]);
    }

    #[test]
    fn shift_onto_a_finer_axis_uses_the_overlap_rule() {
        // Source bin [0, 2) holding 4 shifted by 0.5 ps covers [0.5, 2.5): on 1 ps bins that is
        // 1 + 2 + 1 (density 2 per ps).
        let src_axis = axis(0.0, 2.0, 2);
        let dst_axis = axis(0.0, 1.0, 4);
        let mut dst = [0.0f32; 4];
        shift_into(&src_axis, &[4.0, 0.0], 0.5, &dst_axis, &mut dst);
        assert_eq!(dst, [1.0, 2.0, 1.0, 0.0]);
    }

    proptest::proptest! {
        /// The two-tap fast path (equal bin widths) equals the general overlap integral.
        #[test]
        fn equal_width_fast_path_matches_general_rebin(
            src in proptest::collection::vec(-10.0f32..100.0, 0..40),
            shift_ps in -60.0f64..60.0,
            dst_t0_ps in -30.0f64..30.0,
            n_dst in 0usize..60,
        ) {
            let src_axis = axis(1.5, 1.25, src.len());
            let dst_axis = axis(dst_t0_ps, 1.25, n_dst);
            let mut fast = vec![0.0f32; n_dst];
            shift_into(&src_axis, &src, shift_ps, &dst_axis, &mut fast);
            let edges: Vec<f64> = (0..=src.len())
                .map(|i| 1.5 + i as f64 * 1.25 + shift_ps)
                .collect();
            let mut general = vec![0.0f32; n_dst];
            rebin_add(&edges, &src, &dst_axis, &mut general);
            for (j, (f, g)) in fast.iter().zip(&general).enumerate() {
                proptest::prop_assert!((f - g).abs() <= 2e-5, "bin {}: {} vs {}", j, f, g);
            }
        }
    }
}

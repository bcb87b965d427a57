//! Energy-conserving time resampling of one pixel's profile.
//!
//! Each source bin holds the signal integrated over its interval; the signal is reconstructed
//! as constant within each source bin, and each destination bin receives the integral of that
//! reconstruction over its own interval. So the total over the destination axis equals the
//! total over the source axis whenever the destination covers the source. Used by the time
//! unwarp (seed Eq. 2, fractional shifts of `eta * d / c`), the sweep-linearity correction
//! (non-uniform streak time axis to a uniform grid) and the per-scanline jitter removal.

use crate::cube::TimeAxis;

/// Rebin a profile given by arbitrary increasing bin edges (`src_edges_ps.len() ==
/// src.len() + 1`) onto the uniform axis `dst_axis`, adding into `dst` (`dst.len() ==
/// dst_axis.nt`). Source bins with non-increasing edges are skipped.
pub fn rebin_add(src_edges_ps: &[f64], src: &[f32], dst_axis: &TimeAxis, dst: &mut [f32]) {
    debug_assert_eq!(src_edges_ps.len(), src.len() + 1);
    debug_assert_eq!(dst.len(), dst_axis.nt);
    let n_dst = dst_axis.nt as i64;
    for (i, &v) in src.iter().enumerate() {
        if v == 0.0 {
            continue;
        }
        let (a, b) = (src_edges_ps[i], src_edges_ps[i + 1]);
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
/// `dst_axis`, overwriting `dst`.
pub fn shift_into(
    src_axis: &TimeAxis,
    src: &[f32],
    shift_ps: f64,
    dst_axis: &TimeAxis,
    dst: &mut [f32],
) {
    dst.iter_mut().for_each(|v| *v = 0.0);
    let edges: Vec<f64> = (0..=src.len())
        .map(|i| src_axis.bin_start_ps(i) + shift_ps)
        .collect();
    rebin_add(&edges, src, dst_axis, dst);
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
}

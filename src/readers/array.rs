//! An N-dimensional array read from a file (shape, stored type, values as f32 in C order),
//! the reordering of column-major (Fortran, MATLAB) storage into C order, and the general
//! transpose that [`super::layout`] uses to put time last.

use super::dtype::{Decoded, Dtype};

/// An array in C order (last index fastest), values as f32.
#[derive(Clone, Debug, PartialEq)]
pub struct Array {
    pub shape: Vec<usize>,
    pub dtype: Dtype,
    pub values: Vec<f32>,
    /// Integer samples f32 does not hold exactly, and the largest of them.
    pub inexact: usize,
    pub largest_inexact: f64,
}

impl Array {
    /// An array of `shape` from samples decoded in C order, or in column-major order when
    /// `column_major` (reordered here).
    pub fn new(shape: Vec<usize>, dtype: Dtype, decoded: Decoded, column_major: bool) -> Array {
        let values = if column_major {
            column_major_to_c(&shape, &decoded.values)
        } else {
            decoded.values
        };
        Array {
            shape,
            dtype,
            values,
            inexact: decoded.inexact,
            largest_inexact: decoded.largest_inexact,
        }
    }
}

/// The number of elements of `shape`, `None` when it overflows.
pub fn element_count(shape: &[usize]) -> Option<usize> {
    shape.iter().try_fold(1usize, |a, &n| a.checked_mul(n))
}

/// Reorder `values`, stored column-major (first index fastest) for `shape`, into C order:
/// element `A[i0, i1, ...]` moves from `i0 + d0 (i1 + d1 (...))` to `(... i0) d1 + i1 ...`.
pub fn column_major_to_c(shape: &[usize], values: &[f32]) -> Vec<f32> {
    if shape.len() < 2 {
        return values.to_vec();
    }
    // Reversing the shape of column-major data gives a C-order array of the reversed
    // shape; permuting its axes back is a general transpose.
    let reversed: Vec<usize> = shape.iter().rev().copied().collect();
    let order: Vec<usize> = (0..shape.len()).rev().collect();
    permute(&reversed, values, &order)
}

/// The C-order array whose axis `k` is axis `order[k]` of the C-order array `values` of
/// `shape` (NumPy's `transpose(order)`).
pub fn permute(shape: &[usize], values: &[f32], order: &[usize]) -> Vec<f32> {
    let n = shape.len();
    let mut strides = vec![1usize; n];
    for k in (0..n.saturating_sub(1)).rev() {
        strides[k] = strides[k + 1] * shape[k + 1];
    }
    let out_shape: Vec<usize> = order.iter().map(|&a| shape[a]).collect();
    let out_strides: Vec<usize> = order.iter().map(|&a| strides[a]).collect();
    let mut out = Vec::with_capacity(values.len());
    if values.is_empty() {
        return out;
    }
    // The last output axis is walked as a strided run; the others by an odometer.
    let last = n - 1;
    let (run, run_stride) = (out_shape[last], out_strides[last]);
    let mut index = vec![0usize; last];
    loop {
        let base: usize = index.iter().zip(&out_strides).map(|(i, s)| i * s).sum();
        out.extend((0..run).map(|k| values[base + k * run_stride]));
        let mut k = last;
        loop {
            if k == 0 {
                return out;
            }
            k -= 1;
            index[k] += 1;
            if index[k] < out_shape[k] {
                break;
            }
            index[k] = 0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The naive reference: every element moved by its full index.
    fn naive_column_major_to_c(shape: &[usize; 3], v: &[f32]) -> Vec<f32> {
        let [a, b, c] = *shape;
        let mut out = vec![0.0; v.len()];
        for i in 0..a {
            for j in 0..b {
                for k in 0..c {
                    out[(i * b + j) * c + k] = v[i + a * (j + b * k)];
                }
            }
        }
        out
    }

    #[test]
    fn column_major_matches_the_naive_reorder() {
        for shape in [[2, 3, 4], [1, 5, 2], [4, 1, 1], [3, 3, 3]] {
            let n = shape.iter().product::<usize>();
            let v: Vec<f32> = (0..n).map(|i| i as f32).collect();
            assert_eq!(
                column_major_to_c(&shape, &v),
                naive_column_major_to_c(&shape, &v),
                "{shape:?}"
            );
        }
        // 2-D: [[0, 2, 4], [1, 3, 5]] stored by columns.
        let v = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(
            column_major_to_c(&[2, 3], &v),
            [0.0, 2.0, 4.0, 1.0, 3.0, 5.0]
        );
    }
}

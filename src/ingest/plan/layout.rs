//! Sample layout: a streak image `[t][x]` (as the files store it) into the cube's row layout
//! `[x][t]`, scaled, by 8 x 8 blocks; image `y` of an HDF5 stack as a streak image.

/// Convert a streak image `[t][x]` into the cube's row layout `[x][t]`, multiplying by
/// `scale`; the first non-finite sample (in file order) is an error `(x, t, value)`.
pub fn to_row_layout(
    image_tx: &[f32],
    nx: usize,
    nt: usize,
    scale: f32,
    out_xt: &mut [f32],
) -> Result<(), (usize, usize, f32)> {
    debug_assert_eq!(image_tx.len(), nx * nt);
    if let Some(i) = image_tx.iter().position(|v| !v.is_finite()) {
        return Err((i % nx, i / nx, image_tx[i]));
    }
    transpose_scaled(image_tx, nx, nt, out_xt, |v| v * scale);
    Ok(())
}

/// [`to_row_layout`] of integer samples (16-bit PNG scanlines): `[t][x]` in, `f32 [x][t]`
/// times `scale` out, in one pass (integers are always finite).
pub fn to_row_layout_u16(image_tx: &[u16], nx: usize, nt: usize, scale: f32, out_xt: &mut [f32]) {
    transpose_scaled(image_tx, nx, nt, out_xt, |v| f32::from(v) * scale);
}

/// `out_xt[x * nt + t] = value(image_tx[t * nx + x])`.
///
/// The transpose goes by 8 x 8 blocks gathered in a local array (a plain loop writes with a
/// stride of `nt` values and was a fifth of ingest's time; 32 x 32 tiles with indexed loops
/// were twice as slow as these blocks, which the compiler turns into vector shuffles).
fn transpose_scaled<S: Copy>(
    image_tx: &[S],
    nx: usize,
    nt: usize,
    out_xt: &mut [f32],
    value: impl Fn(S) -> f32,
) {
    const B: usize = 8;
    assert_eq!(image_tx.len(), nx * nt, "transpose: input size");
    assert_eq!(out_xt.len(), nx * nt, "transpose: output size");
    let (bx, bt) = (nx / B * B, nt / B * B);
    for x0 in (0..bx).step_by(B) {
        for t0 in (0..bt).step_by(B) {
            let mut block = [[0.0f32; B]; B]; // [x][t]
            for (dt, column) in (0..B).map(|dt| (dt, (t0 + dt) * nx + x0)) {
                let src: &[S; B] = image_tx[column..column + B].try_into().expect("block of B");
                for dx in 0..B {
                    block[dx][dt] = value(src[dx]);
                }
            }
            for (dx, line) in block.iter().enumerate() {
                let o = (x0 + dx) * nt + t0;
                out_xt[o..o + B].copy_from_slice(line);
            }
        }
    }
    // The edges: columns past the last whole block, then rows past it.
    for t in 0..nt {
        let x_start = if t < bt { bx } else { 0 };
        for x in x_start..nx {
            out_xt[x * nt + t] = value(image_tx[t * nx + x]);
        }
    }
}

/// Image `y` of a stack as a streak image `[t][x]`.
pub fn stack_image(values: &[f32], y: usize, nx: usize, nt: usize, transpose: bool) -> Vec<f32> {
    let image = &values[y * nx * nt..(y + 1) * nx * nt];
    if transpose {
        let mut out = vec![0.0f32; nx * nt];
        for x in 0..nx {
            for t in 0..nt {
                out[t * nx + x] = image[x * nt + t];
            }
        }
        out
    } else {
        image.to_vec()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ingest::time_axis::edges_from_starts;

    #[test]
    fn blocked_transpose_matches_the_plain_loop() {
        // Sizes with and without partial 8 x 8 blocks on either side.
        for (nx, nt) in [(1, 1), (8, 8), (19, 27), (16, 5), (3, 40), (672 / 8, 64)] {
            let raw: Vec<u16> = (0..nx * nt)
                .map(|i| ((i * 2_654_435_761usize) >> 9) as u16)
                .collect();
            let scale = 0.37f32;
            let mut expected = vec![0.0f32; nx * nt];
            for t in 0..nt {
                for x in 0..nx {
                    expected[x * nt + t] = f32::from(raw[t * nx + x]) * scale;
                }
            }
            let mut out = vec![f32::NAN; nx * nt];
            to_row_layout_u16(&raw, nx, nt, scale, &mut out);
            assert_eq!(out, expected, "u16 {nx} x {nt}");
            let as_f32: Vec<f32> = raw.iter().map(|&v| f32::from(v)).collect();
            let mut out = vec![f32::NAN; nx * nt];
            to_row_layout(&as_f32, nx, nt, scale, &mut out).unwrap();
            assert_eq!(out, expected, "f32 {nx} x {nt}");
        }
    }

    #[test]
    fn starts_become_edges_and_layout_is_transposed() {
        assert_eq!(edges_from_starts(&[0.0, 2.0, 5.0]), [0.0, 2.0, 5.0, 8.0]);
        // A 3 x 2 image [t][x]: rows t0 = (1, 2, 3), t1 = (4, 5, 6).
        let mut out = vec![0.0; 6];
        to_row_layout(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], 3, 2, 2.0, &mut out).unwrap();
        assert_eq!(out, [2.0, 8.0, 4.0, 10.0, 6.0, 12.0]);
        assert_eq!(
            to_row_layout(&[1.0, 2.0, f32::NAN, 4.0, 5.0, 6.0], 3, 2, 1.0, &mut out)
                .unwrap_err()
                .0,
            2
        );
    }
}

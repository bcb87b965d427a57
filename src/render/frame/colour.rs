//! Step 7's colour for four lit pixels at a time ([`wide::f64x4`]): the gamut-mapped linear
//! sRGB of each pixel's received wavelength, [`crate::color::laser_colour`]'s operations lane
//! by lane in the same order (the matching functions' table read and interpolated, `x / y` and
//! `z / y`, the matrix to linear sRGB, the least white of equal luminance that brings every
//! component to at least 0; grey outside the visible range), so each colour is bit for bit
//! the scalar one (the test below, and tests/render.rs through every rendered pixel). Each
//! lit pixel's colour cost more than its lookups when computed one at a time.

use crate::color::{cie1931, LINEAR_SRGB_TO_XYZ, VISIBLE_NM, XYZ_TO_LINEAR_SRGB};
use wide::f64x4;

/// [`crate::color::laser_colour`] of four wavelengths, nm.
#[inline]
pub(super) fn laser_colours(lambda_nm: [f64; 4]) -> [[f64; 3]; 4] {
    let s = f64x4::splat;
    let lambda = f64x4::new(lambda_nm);
    // monochromatic_linear_srgb: inside the visible range (NaN outside), which lies inside
    // the table.
    let visible = lambda.simd_ge(s(VISIBLE_NM.0)) & lambda.simd_le(s(VISIBLE_NM.1));
    let visible_lanes = visible.to_bitmask();
    // cmf_xyz: `pos >= 0` in visible lanes, so truncation is the floor; other lanes read row 0.
    let pos = lambda - s(cie1931::FIRST_NM as f64);
    let pos_lanes = pos.to_array();
    // Gathers and vector arithmetic written out rather than with `map`: closures left out of
    // line turned each vector operation into a call.
    let (mut row, mut a, mut b) = ([0.0; 4], [[0.0; 4]; 3], [[0.0; 4]; 3]);
    for k in 0..4 {
        let i = if visible_lanes & (1 << k) != 0 {
            (pos_lanes[k] as usize).min(cie1931::XYZ_CMF.len() - 2)
        } else {
            0
        };
        row[k] = i as f64;
        let (ra, rb) = (cie1931::XYZ_CMF[i], cie1931::XYZ_CMF[i + 1]);
        for c in 0..3 {
            (a[c][k], b[c][k]) = (ra[c], rb[c]);
        }
    }
    let f = pos - f64x4::new(row);
    let a = [f64x4::new(a[0]), f64x4::new(a[1]), f64x4::new(a[2])];
    let b = [f64x4::new(b[0]), f64x4::new(b[1]), f64x4::new(b[2])];
    let cmf = [
        a[0] + f * (b[0] - a[0]),
        a[1] + f * (b[1] - a[1]),
        a[2] + f * (b[2] - a[2]),
    ];
    let v = [cmf[0] / cmf[1], cmf[2] / cmf[1]];
    // xyz_to_linear_srgb of (x / y, 1, z / y): `(m0 v0 + m1 1) + m2 v2` per row.
    let m = XYZ_TO_LINEAR_SRGB;
    let row_of = |r: usize| (s(m[r][0]) * v[0] + s(m[r][1]) * s(1.0)) + s(m[r][2]) * v[1];
    let rgb = [row_of(0), row_of(1), row_of(2)];
    // desaturate_into_gamut.
    let min = rgb[0].min(rgb[1]).min(rgb[2]);
    let in_gamut = min.simd_ge(s(0.0));
    let w = LINEAR_SRGB_TO_XYZ[1];
    let y = (s(w[0]) * rgb[0] + s(w[1]) * rgb[1]) + s(w[2]) * rgb[2];
    let dark = y.simd_le(s(0.0));
    let t = -min / (y - min);
    let out_of = |c: f64x4| {
        let mixed = ((s(1.0) - t) * c + t * y).max(s(0.0));
        let gamut = in_gamut.select(c, dark.select(s(0.0), mixed));
        visible.select(gamut, s(1.0)).to_array()
    };
    let out = [out_of(rgb[0]), out_of(rgb[1]), out_of(rgb[2])];
    [
        [out[0][0], out[1][0], out[2][0]],
        [out[0][1], out[1][1], out[2][1]],
        [out[0][2], out[1][2], out[2][2]],
        [out[0][3], out[1][3], out[2][3]],
    ]
}

#[cfg(test)]
mod tests {
    use super::laser_colours;
    use crate::color::laser_colour;

    /// Four at a time, the colours are the scalar ones bit for bit: every tenth of a
    /// nanometre over and beyond the visible range, its ends, the table's ends and NaN.
    #[test]
    fn four_colours_are_the_scalar_colours_bit_for_bit() {
        let mut lambdas: Vec<f64> = (3000..=8500).map(|k| k as f64 * 0.1).collect();
        lambdas.extend([
            380.0,
            780.0,
            360.0,
            830.0,
            379.999,
            780.001,
            f64::NAN,
            -1.0,
            1e9,
        ]);
        lambdas.extend([f64::INFINITY, 550.123_456_789, 0.0]);
        for four in lambdas.chunks(4) {
            let four: [f64; 4] = std::array::from_fn(|k| four[k % four.len()]);
            let got = laser_colours(four);
            for (lambda, got) in four.iter().zip(got) {
                let want = laser_colour(*lambda);
                assert_eq!(
                    got.map(f64::to_bits),
                    want.map(f64::to_bits),
                    "{lambda} nm: {got:?} against {want:?}"
                );
            }
        }
    }
}

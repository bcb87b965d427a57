//! Colour of Doppler-shifted laser light, and the display pipeline of the renderer: CIE 1931
//! colour matching functions, XYZ to linear sRGB, gamut mapping of monochromatic light,
//! exposure, tone mapping and the sRGB transfer function (physics.md, "Colour of
//! monochromatic light"; the seed's Sec. 4.2 shows Doppler-shifted wavelengths as colours and
//! wavelengths outside the visible range as grey).
//!
//! Pipeline for one pixel, `lambda' = D lambda_laser` (see [`crate::relativity`]):
//! 1. [`cmf_xyz`]: tabulated CIE 1931 2-degree CMFs ([`cie1931`]), linear interpolation.
//! 2. [`monochromatic_linear_srgb`]: XYZ scaled to luminance `Y = 1` (the luminance of sRGB
//!    white `(1, 1, 1)`), then [`XYZ_TO_LINEAR_SRGB`]. The eye's spectral sensitivity is
//!    deliberately *not* applied: the brightness of a pixel is the measured radiance times the
//!    radiometric factor, the wavelength only sets its hue. This keeps the grey used outside
//!    the visible range seamless in brightness with the coloured inside.
//! 3. [`desaturate_into_gamut`]: monochromatic light is always outside the sRGB gamut; the rule
//!    adds the least amount of white of equal luminance that makes every component
//!    non-negative. Luminance is kept, and the chromaticity moves along the straight line
//!    towards the D65 white point, so the dominant wavelength (hue) is kept.
//! 4. [`laser_colour`] = steps 1-3, or grey `(1, 1, 1)` outside [`VISIBLE_NM`] (380-780 nm).
//! 5. [`tone_map`]: exposure (a linear multiplier), then Reinhard `Y / (1 + Y)` on luminance
//!    with all channels scaled alike (hue kept); a channel still above 1 is brought to 1 by
//!    mixing with white of the same luminance (bright saturated colours turn whitish, as on
//!    film). Output is display-linear in `[0, 1]`.
//! 6. [`srgb_encode`] (IEC 61966-2-1 transfer function) and [`encode_u8`].

pub mod cie1931;

use rayon::prelude::*;

/// Wavelengths shown in colour, nm (inclusive). Outside, [`laser_colour`] gives grey.
/// The table itself covers 360-830 nm; 380-780 nm is the conventional visible range.
pub const VISIBLE_NM: (f64, f64) = (380.0, 780.0);

/// XYZ (D65 white `Y = 1`) to linear sRGB, rows. Derived in f64 from the sRGB primaries
/// (0.64, 0.33), (0.30, 0.60), (0.15, 0.06) and white (0.3127, 0.3290) of IEC 61966-2-1; the
/// standard's 4-digit matrix is this one rounded.
pub const XYZ_TO_LINEAR_SRGB: [[f64; 3]; 3] = [
    [3.2409699419045213, -1.5373831775700932, -0.4986107602930032],
    [-0.9692436362808794, 1.8759675015077202, 0.04155505740717556],
    [
        0.055630079696993594,
        -0.20397695888897646,
        1.0569715142428784,
    ],
];

/// Linear sRGB to XYZ, rows (the inverse of [`XYZ_TO_LINEAR_SRGB`]). Its middle row gives the
/// luminance of a linear sRGB colour.
pub const LINEAR_SRGB_TO_XYZ: [[f64; 3]; 3] = [
    [0.4123907992659594, 0.35758433938387796, 0.1804807884018343],
    [0.2126390058715103, 0.7151686787677559, 0.07219231536073371],
    [
        0.019330818715591825,
        0.11919477979462596,
        0.9505321522496607,
    ],
];

#[inline]
fn mat_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// CIE 1931 2-degree colour matching functions `[xbar, ybar, zbar]` at `lambda_nm`, linearly
/// interpolated in the 1 nm table; None outside 360-830 nm (or for NaN).
pub fn cmf_xyz(lambda_nm: f64) -> Option<[f64; 3]> {
    let first = cie1931::FIRST_NM as f64;
    let last = cie1931::LAST_NM as f64;
    if !(lambda_nm >= first && lambda_nm <= last) {
        return None;
    }
    let pos = lambda_nm - first;
    // `pos >= 0` here, so truncation is the floor (and needs no libm call on x86-64).
    let i = (pos as usize).min(cie1931::XYZ_CMF.len() - 2);
    let f = pos - i as f64;
    let (a, b) = (cie1931::XYZ_CMF[i], cie1931::XYZ_CMF[i + 1]);
    Some([
        a[0] + f * (b[0] - a[0]),
        a[1] + f * (b[1] - a[1]),
        a[2] + f * (b[2] - a[2]),
    ])
}

/// CIE 1931 chromaticity `(x, y)` of monochromatic light at `lambda_nm`; None outside the
/// table (360-830 nm).
pub fn chromaticity(lambda_nm: f64) -> Option<[f64; 2]> {
    let [x, y, z] = cmf_xyz(lambda_nm)?;
    let s = x + y + z;
    Some([x / s, y / s])
}

/// Linear sRGB of a CIE XYZ colour.
#[inline]
pub fn xyz_to_linear_srgb(xyz: [f64; 3]) -> [f64; 3] {
    mat_vec(&XYZ_TO_LINEAR_SRGB, xyz)
}

/// CIE XYZ of a linear sRGB colour.
#[inline]
pub fn linear_srgb_to_xyz(rgb: [f64; 3]) -> [f64; 3] {
    mat_vec(&LINEAR_SRGB_TO_XYZ, rgb)
}

/// Relative luminance `Y` of a linear sRGB colour (white `(1, 1, 1)` has `Y = 1`).
#[inline]
pub fn luminance(rgb: [f64; 3]) -> f64 {
    let w = LINEAR_SRGB_TO_XYZ[1];
    w[0] * rgb[0] + w[1] * rgb[1] + w[2] * rgb[2]
}

/// Linear sRGB of monochromatic light at `lambda_nm`, scaled to luminance `Y = 1`, *before*
/// gamut mapping (it has a negative component); None outside [`VISIBLE_NM`].
pub fn monochromatic_linear_srgb(lambda_nm: f64) -> Option<[f64; 3]> {
    if !(lambda_nm >= VISIBLE_NM.0 && lambda_nm <= VISIBLE_NM.1) {
        return None;
    }
    let [x, y, z] = cmf_xyz(lambda_nm)?;
    Some(xyz_to_linear_srgb([x / y, 1.0, z / y]))
}

/// Bring a linear sRGB colour with negative components into the gamut by adding the least
/// amount of white of equal luminance: `rgb' = (1 - s) rgb + s Y (1, 1, 1)` with the smallest
/// `s` in `[0, 1]` that makes every component `>= 0` (`s = -m / (Y - m)`, `m` the most negative
/// component). Luminance `Y` is unchanged and the chromaticity moves straight towards the
/// white point (same dominant wavelength). Colours already in gamut are returned as they are;
/// a colour with `Y <= 0` becomes black.
pub fn desaturate_into_gamut(rgb: [f64; 3]) -> [f64; 3] {
    let m = rgb[0].min(rgb[1]).min(rgb[2]);
    if m >= 0.0 {
        return rgb;
    }
    let y = luminance(rgb);
    if y <= 0.0 {
        return [0.0; 3];
    }
    let s = -m / (y - m);
    let mix = |c: f64| ((1.0 - s) * c + s * y).max(0.0);
    [mix(rgb[0]), mix(rgb[1]), mix(rgb[2])]
}

/// Displayable linear sRGB colour of laser light received at `lambda_nm`, luminance `Y = 1`:
/// the gamut-mapped colour of that wavelength inside [`VISIBLE_NM`] (380-780 nm), grey
/// `(1, 1, 1)` outside (as the seed shows invisible wavelengths).
pub fn laser_colour(lambda_nm: f64) -> [f64; 3] {
    match monochromatic_linear_srgb(lambda_nm) {
        Some(rgb) => desaturate_into_gamut(rgb),
        None => [1.0; 3],
    }
}

/// The wavelength at which light of `lambda_nm` is drawn when the Doppler effect is off
/// (`femto render` and `femto view` alike): the wavelength itself inside [`VISIBLE_NM`], else
/// the nearer end of that range (380 or 780 nm), so that an infrared or ultraviolet laser's
/// light is drawn in the colour nearest to it rather than the grey of invisible light, and
/// the Doppler toggle shows what the shift does.
pub fn nearest_visible_nm(lambda_nm: f64) -> f64 {
    lambda_nm.clamp(VISIBLE_NM.0, VISIBLE_NM.1)
}

/// Exposure and tone mapping of a scene-linear sRGB colour to display-linear `[0, 1]`:
/// multiply by `exposure`; gamut-map ([`desaturate_into_gamut`]); scale all channels so that
/// the luminance becomes Reinhard's `Y / (1 + Y)`; if a channel then exceeds 1, mix with white
/// of the same luminance until the largest channel is 1 (luminance and hue kept).
pub fn tone_map(rgb: [f64; 3], exposure: f64) -> [f64; 3] {
    let scaled = [rgb[0] * exposure, rgb[1] * exposure, rgb[2] * exposure];
    let c = desaturate_into_gamut(scaled);
    let y = luminance(c);
    if y.is_nan() || y <= 0.0 || y.is_infinite() {
        // Black, or an infinite input: show black / white rather than NaN.
        return if y.is_infinite() { [1.0; 3] } else { [0.0; 3] };
    }
    let y_d = y / (1.0 + y);
    let k = y_d / y;
    let mut d = [c[0] * k, c[1] * k, c[2] * k];
    let max = d[0].max(d[1]).max(d[2]);
    if max > 1.0 {
        let t = (1.0 - y_d) / (max - y_d);
        for v in &mut d {
            *v = y_d + (*v - y_d) * t;
        }
    }
    [
        d[0].clamp(0.0, 1.0),
        d[1].clamp(0.0, 1.0),
        d[2].clamp(0.0, 1.0),
    ]
}

/// sRGB transfer function (IEC 61966-2-1): display-linear `[0, 1]` to encoded `[0, 1]`.
#[inline]
pub fn srgb_encode(linear: f64) -> f64 {
    let v = linear.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Inverse of [`srgb_encode`].
#[inline]
pub fn srgb_decode(encoded: f64) -> f64 {
    let v = encoded.clamp(0.0, 1.0);
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Encode a display-linear colour to 8-bit sRGB (rounded to nearest): per channel
/// `round(255 srgb_encode(v))`, looked up among the steps where it changes instead of computed (a `powf`
/// per channel was 13 % of `femto view`'s CPU time per frame; the lookup gives the same
/// byte, the tests below compare the two).
#[inline]
pub fn encode_u8(display_linear: [f64; 3]) -> [u8; 3] {
    let steps = Srgb8Steps::get();
    [
        steps.code(display_linear[0]),
        steps.code(display_linear[1]),
        steps.code(display_linear[2]),
    ]
}

/// `round(255 srgb_encode(v))` by [`srgb_encode`] itself.
fn srgb8_computed(v: f64) -> u8 {
    (srgb_encode(v) * 255.0).round() as u8
}

/// Where the 8-bit code value of [`srgb_encode`] steps up, and a table that finds the steps
/// near a value in one look.
struct Srgb8Steps {
    /// `at[k]`: the smallest `v` whose code value is `k + 1` or more, for `k < 255`; then
    /// two NaNs (no value is at or above them), so that [`Srgb8Steps::code`]'s two steps up
    /// never pass 255.
    at: [f64; 257],
    /// `below[n]`: the code value of `(n - 1) / INTERVALS` (0 for `n = 0`), a lower bound
    /// of the code of every `v` with `(v * INTERVALS) as usize == n`. Within one interval
    /// the code rises by less than 1 (its slope is at most 3295 codes per unit, 0.8 per
    /// interval), so two intervals hold at most two steps.
    below: [u8; Srgb8Steps::INTERVALS + 1],
}

impl Srgb8Steps {
    const INTERVALS: usize = 4096;

    fn get() -> &'static Srgb8Steps {
        static STEPS: std::sync::OnceLock<Srgb8Steps> = std::sync::OnceLock::new();
        STEPS.get_or_init(|| {
            // Bisect the bit patterns of [0, 1] (ordered as the values are, for non-negative
            // floats) for each step; the code value rises with `v`.
            let at: [f64; 257] = std::array::from_fn(|k| {
                if k >= 255 {
                    return f64::NAN;
                }
                let code = k as u8 + 1;
                let (mut lo, mut hi) = (0.0f64.to_bits(), 1.0f64.to_bits());
                // Invariant: code(lo) < code <= code(hi).
                while hi - lo > 1 {
                    let mid = lo + (hi - lo) / 2;
                    if srgb8_computed(f64::from_bits(mid)) >= code {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                f64::from_bits(hi)
            });
            let below = std::array::from_fn(|n| {
                let v = n.saturating_sub(1) as f64 / Self::INTERVALS as f64;
                at.iter().filter(|&&t| t <= v).count() as u8
            });
            Srgb8Steps { at, below }
        })
    }

    /// The code value of `v`: the number of steps at or below it (0 for a NaN, as
    /// `NaN as u8` is 0). Without branches: `v`'s interval gives a code at most two steps
    /// low, and two comparisons add the steps passed (a loop's unpredictable one or two
    /// turns cost more than the lookup, in `femto view`'s frames). A NaN or a `v <= 0`
    /// lands in interval 0, below every step; a `v >= 1` in the last, whose code is 255
    /// once the last step is passed.
    #[inline(always)]
    fn code(&self, v: f64) -> u8 {
        // `v * INTERVALS` may round up to the next whole number; `below` starts an interval
        // early, so the count below is never past the code of `v`.
        let n = ((v * Self::INTERVALS as f64) as usize).min(Self::INTERVALS);
        let code = self.below[n] as usize;
        let code = code + usize::from(self.at[code] <= v);
        let code = code + usize::from(self.at[code] <= v);
        code as u8
    }

    /// The code value of `v` by binary search of all the steps (the tests' second opinion).
    #[cfg(test)]
    fn searched(&self, v: f64) -> u8 {
        self.at[..255].iter().filter(|&&t| t <= v).count() as u8
    }
}

/// Tone map and encode a whole frame of scene-linear sRGB pixels into `out_rgb8`
/// (3 bytes per pixel, same order), and count the lit pixels ([`is_lit`]). Panics if `out_rgb8.len() != 3 *
/// scene_linear.len()` (a caller bug, not bad input).
pub fn encode_frame(scene_linear: &[[f32; 3]], exposure: f64, out_rgb8: &mut [u8]) -> usize {
    assert_eq!(
        out_rgb8.len(),
        3 * scene_linear.len(),
        "encode_frame: output buffer size"
    );
    // In parallel, blocks of ENCODE_BLOCK pixels: on one thread this was 8-14 ms of a
    // 640 x 480 frame in `femto view`, a third of the render's own wall time.
    let steps = Srgb8Steps::get();
    scene_linear
        .par_chunks(ENCODE_BLOCK)
        .zip(out_rgb8.par_chunks_mut(3 * ENCODE_BLOCK))
        .map(|(pixels, out)| {
            let mut lit = 0;
            for (four, out) in pixels.chunks(4).zip(out.chunks_mut(12)) {
                // A black pixel (+0 or -0) tone maps to black and encodes to 0.
                if four.iter().all(|px| *px == [0.0; 3]) {
                    out.fill(0);
                    continue;
                }
                let lanes: [[f32; 3]; 4] =
                    std::array::from_fn(|k| four.get(k).map_or([0.0; 3], |p| *p));
                for (mapped, out) in tone_map_four(lanes, exposure)
                    .iter()
                    .zip(out.chunks_exact_mut(3))
                {
                    let code = mapped.map(|v| steps.code(v));
                    lit += usize::from(is_lit(code));
                    out.copy_from_slice(&code);
                }
            }
            lit
        })
        .sum()
}

/// [`tone_map`] of four pixels, computed four at a time ([`wide::f64x4`]) where the
/// pixel is an ordinary colour (every channel finite and at least 0, luminance positive
/// and finite) and by [`tone_map`] itself elsewhere (black, a negative channel that needs
/// the gamut mapping, NaN, infinities). The vector lanes do [`tone_map`]'s operations in
/// its order, exactly rounded, with no fused multiply-add: the same values, bit for bit
/// (but for the sign of a zero, which encodes to 0 either way).
fn tone_map_four(px: [[f32; 3]; 4], exposure: f64) -> [[f64; 3]; 4] {
    use wide::f64x4;
    let s = f64x4::splat;
    let channel = |c: usize| f64x4::new(std::array::from_fn(|k| px[k][c] as f64)) * s(exposure);
    let (r, g, b) = (channel(0), channel(1), channel(2));
    let w = LINEAR_SRGB_TO_XYZ[1];
    let y = (s(w[0]) * r + s(w[1]) * g) + s(w[2]) * b;
    let zero = s(0.0);
    let ordinary = (r.simd_ge(zero) & g.simd_ge(zero) & b.simd_ge(zero) & y.simd_gt(zero))
        .to_bitmask()
        & (r + g + b + y).is_finite().to_bitmask();
    // Colours in the gamut (no channel below 0): desaturate_into_gamut leaves them as
    // they are.
    let y_d = y / (s(1.0) + y);
    let k = y_d / y;
    let d = [r * k, g * k, b * k];
    let max = d[0].max(d[1]).max(d[2]);
    let over = max.simd_gt(s(1.0));
    let t = (s(1.0) - y_d) / (max - y_d);
    // f64::clamp(0, 1) for values that are not NaN.
    let mapped = d.map(|v| {
        over.select(y_d + (v - y_d) * t, v)
            .max(zero)
            .min(s(1.0))
            .to_array()
    });
    std::array::from_fn(|lane| {
        if ordinary & (1 << lane) != 0 {
            [mapped[0][lane], mapped[1][lane], mapped[2][lane]]
        } else if px[lane] == [0.0; 3] {
            [0.0; 3]
        } else {
            tone_map(px[lane].map(f64::from), exposure)
        }
    })
}

/// Whether an 8-bit pixel counts as lit for `femto view` and [`encode_frame`]: some code
/// value above 2.
#[inline]
pub fn is_lit(code: [u8; 3]) -> bool {
    code.iter().any(|&c| c > 2)
}

/// Pixels per task of [`encode_frame`].
const ENCODE_BLOCK: usize = 4096;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::relativity::Boost;

    #[test]
    fn doppler_off_draws_an_invisible_laser_at_the_nearest_visible_colour() {
        assert_eq!(nearest_visible_nm(670.0), 670.0);
        assert_eq!(nearest_visible_nm(795.0), 780.0);
        assert_eq!(nearest_visible_nm(266.0), 380.0);
        // 795 nm itself is grey; its drawn colour is a red, not grey.
        assert_eq!(laser_colour(795.0), [1.0; 3]);
        let red = laser_colour(nearest_visible_nm(795.0));
        assert!(red[1] < 0.2 * red[0] && red[2] < 0.2 * red[0], "{red:?}");
    }
    use nalgebra::{Matrix3, Vector3};

    /// physics.md spot values of the table.
    const SPOTS: [(f64, [f64; 3]); 4] = [
        (450.0, [0.3362, 0.0380, 1.77211]),
        (555.0, [0.51205, 1.0, 0.00575]),
        (600.0, [1.0622, 0.631, 0.0008]),
        (700.0, [0.011359, 0.004102, 0.0]),
    ];

    #[test]
    fn table_matches_physics_md_spot_values_and_known_sums() {
        assert_eq!(cie1931::XYZ_CMF.len(), 471);
        for (nm, expect) in SPOTS {
            let got = cmf_xyz(nm).unwrap();
            for c in 0..3 {
                assert!(
                    // physics.md rounds to at most 6 decimals.
                    (got[c] - expect[c]).abs() <= 1e-6,
                    "{nm} nm component {c}: {} vs {}",
                    got[c],
                    expect[c]
                );
            }
        }
        // Integrals of the 1931 CMFs over 360-830 nm at 1 nm steps (CIE 15: the three are
        // about 106.86; ybar's is the luminous efficiency normalisation 683 / 106.857...).
        let sums = cie1931::XYZ_CMF
            .iter()
            .fold([0.0; 3], |s, r| [s[0] + r[0], s[1] + r[1], s[2] + r[2]]);
        assert!((sums[0] - 106.865).abs() < 0.01, "{sums:?}");
        assert!((sums[1] - 106.857).abs() < 0.01, "{sums:?}");
        assert!((sums[2] - 106.892).abs() < 0.01, "{sums:?}");
        // ybar peaks at 555 nm with value 1.
        let peak = (0..471)
            .max_by(|&a, &b| cie1931::XYZ_CMF[a][1].total_cmp(&cie1931::XYZ_CMF[b][1]))
            .unwrap();
        assert_eq!(peak + 360, 555);
    }

    #[test]
    fn interpolation_and_range() {
        let a = cmf_xyz(450.0).unwrap();
        let b = cmf_xyz(451.0).unwrap();
        let m = cmf_xyz(450.25).unwrap();
        for c in 0..3 {
            assert!((m[c] - (0.75 * a[c] + 0.25 * b[c])).abs() < 1e-15);
        }
        assert!(cmf_xyz(360.0).is_some() && cmf_xyz(830.0).is_some());
        assert_eq!(cmf_xyz(830.0).unwrap(), cie1931::XYZ_CMF[470]);
        assert!(cmf_xyz(359.999).is_none() && cmf_xyz(830.001).is_none());
        assert!(cmf_xyz(f64::NAN).is_none() && chromaticity(f64::INFINITY).is_none());
        let [x, y] = chromaticity(555.0).unwrap();
        let s = 0.51205 + 1.0 + 0.00575;
        assert!((x - 0.51205 / s).abs() < 1e-5 && (y - 1.0 / s).abs() < 1e-5);
    }

    #[test]
    fn srgb_matrix_maps_d65_to_white_and_matches_the_standard() {
        // D65 white, Y = 1, from its chromaticity (0.3127, 0.3290).
        let d65 = [0.3127 / 0.3290, 1.0, (1.0 - 0.3127 - 0.3290) / 0.3290];
        let rgb = xyz_to_linear_srgb(d65);
        for c in rgb {
            assert!((c - 1.0).abs() < 1e-12, "{rgb:?}");
        }
        assert!((luminance([1.0; 3]) - 1.0).abs() < 1e-12);
        // IEC 61966-2-1's published (rounded) matrix.
        let published = [
            [3.2406, -1.5372, -0.4986],
            [-0.9689, 1.8758, 0.0415],
            [0.0557, -0.2040, 1.0570],
        ];
        for i in 0..3 {
            for j in 0..3 {
                assert!((XYZ_TO_LINEAR_SRGB[i][j] - published[i][j]).abs() < 5e-4);
            }
        }
        // Each primary's chromaticity maps to a pure channel.
        for (k, (x, y)) in [(0.64, 0.33), (0.30, 0.60), (0.15, 0.06)]
            .into_iter()
            .enumerate()
        {
            let rgb = xyz_to_linear_srgb([x / y, 1.0, (1.0 - x - y) / y]);
            for (c, v) in rgb.iter().enumerate() {
                if c == k {
                    assert!(*v > 0.0);
                } else {
                    assert!(v.abs() < 1e-12, "primary {k}: {rgb:?}");
                }
            }
        }
        // The two matrices are inverse.
        let m = Matrix3::from_fn(|i, j| XYZ_TO_LINEAR_SRGB[i][j]);
        let n = Matrix3::from_fn(|i, j| LINEAR_SRGB_TO_XYZ[i][j]);
        assert!((m * n - Matrix3::identity()).abs().max() < 1e-12);
    }

    #[test]
    fn doppler_shifted_670_nm_has_the_chromaticity_of_the_shifted_wavelength() {
        // Head-on approach: D = gamma (1 - beta) = sqrt((1 - beta) / (1 + beta)), so the beta
        // giving lambda' = D * 670 is beta = (1 - D^2) / (1 + D^2).
        let lambda_laser = 670.0;
        for (target_nm, spot) in SPOTS.iter().take(3) {
            let d_target = target_nm / lambda_laser;
            let beta = (1.0 - d_target * d_target) / (1.0 + d_target * d_target);
            let vhat = Vector3::new(0.2, -0.3, 0.9).normalize();
            let boost = Boost::new(vhat * beta).unwrap();
            // Looking along the direction of motion, at a source ahead.
            let dop = boost.doppler_factor(&vhat);
            let lambda_seen = dop * lambda_laser;
            assert!((lambda_seen - target_nm).abs() < 1e-9);
            let rgb = monochromatic_linear_srgb(lambda_seen).unwrap();
            let [x, y, z] = linear_srgb_to_xyz(rgb);
            let s = spot[0] + spot[1] + spot[2];
            let (x_exp, y_exp) = (spot[0] / s, spot[1] / s);
            assert!(
                (x / (x + y + z) - x_exp).abs() < 2e-5 && (y / (x + y + z) - y_exp).abs() < 2e-5,
                "{target_nm} nm: ({}, {}) vs ({x_exp}, {y_exp})",
                x / (x + y + z),
                y / (x + y + z)
            );
            assert!((y - 1.0).abs() < 1e-12, "luminance {y}");
        }
    }

    #[test]
    fn gamut_mapping_keeps_luminance_and_dominant_wavelength() {
        let white = [0.3127, 0.3290];
        let mut nm = 380.0;
        while nm <= 780.0 {
            let raw = monochromatic_linear_srgb(nm).unwrap();
            let mapped = laser_colour(nm);
            assert!(raw.iter().any(|&c| c < 0.0), "{nm} nm is in gamut?");
            assert!(mapped.iter().all(|&c| c >= 0.0));
            // Minimal: one component is exactly at the boundary.
            let min = mapped[0].min(mapped[1]).min(mapped[2]);
            assert!(min.abs() < 1e-12, "{nm}: {mapped:?}");
            assert!((luminance(mapped) - 1.0).abs() < 1e-9, "{nm}: {mapped:?}");
            // Chromaticity lies between the white point and the spectral locus point.
            let xyz = linear_srgb_to_xyz(mapped);
            let s = xyz[0] + xyz[1] + xyz[2];
            let p = [xyz[0] / s, xyz[1] / s];
            let q = chromaticity(nm).unwrap();
            let (a, b) = (
                [p[0] - white[0], p[1] - white[1]],
                [q[0] - white[0], q[1] - white[1]],
            );
            let cross = a[0] * b[1] - a[1] * b[0];
            let dot = a[0] * b[0] + a[1] * b[1];
            assert!(cross.abs() < 1e-9 && dot > 0.0, "{nm}: {p:?} {q:?}");
            assert!(a[0].hypot(a[1]) < b[0].hypot(b[1]));
            nm += 2.5;
        }
        // In-gamut colours are untouched; negative luminance gives black.
        assert_eq!(desaturate_into_gamut([0.2, 0.5, 0.1]), [0.2, 0.5, 0.1]);
        assert_eq!(desaturate_into_gamut([-1.0, -1.0, 0.5]), [0.0; 3]);
    }

    #[test]
    fn laser_colours_have_the_expected_hues_and_grey_outside() {
        let dominant = |rgb: [f64; 3]| (0..3).max_by(|&a, &b| rgb[a].total_cmp(&rgb[b])).unwrap();
        assert_eq!(dominant(laser_colour(450.0)), 2);
        assert_eq!(dominant(laser_colour(530.0)), 1);
        assert_eq!(dominant(laser_colour(670.0)), 0);
        for nm in [300.0, 379.9, 780.1, 900.0, f64::NAN] {
            assert_eq!(laser_colour(nm), [1.0; 3], "{nm}");
        }
        assert!(monochromatic_linear_srgb(370.0).is_none());
    }

    #[test]
    fn tone_map_is_bounded_monotone_and_keeps_hue() {
        let colour = [0.9, 0.3, 0.05];
        let mut last = -1.0;
        for k in 0..60 {
            let exposure = 1e-3 * 1.3f64.powi(k);
            let d = tone_map(colour, exposure);
            assert!(d.iter().all(|&v| (0.0..=1.0).contains(&v)));
            let y = luminance(d);
            assert!(
                y >= last - 1e-12,
                "luminance not monotone at exposure {exposure}"
            );
            last = y;
            // Reinhard on luminance.
            let y_in = luminance(colour) * exposure;
            assert!((y - y_in / (1.0 + y_in)).abs() < 1e-9);
            if d.iter().all(|&v| v < 1.0 - 1e-12) {
                // No highlight desaturation: channel ratios are kept.
                assert!((d[0] / d[1] - 3.0).abs() < 1e-9 && (d[1] / d[2] - 6.0).abs() < 1e-9);
            }
        }
        // White at luminance 1 is shown at 0.5; black stays black; inf is white, not NaN.
        let w = tone_map([1.0; 3], 1.0);
        assert!(w.iter().all(|&v| (v - 0.5).abs() < 1e-12));
        assert_eq!(tone_map([0.0; 3], 5.0), [0.0; 3]);
        assert_eq!(tone_map([f64::INFINITY; 3], 1.0), [1.0; 3]);
    }

    #[test]
    fn srgb_encode_decode_are_monotone_inverses_with_known_values() {
        let n = 10_000;
        let mut prev = -1.0;
        for i in 0..=n {
            let v = i as f64 / n as f64;
            let e = srgb_encode(v);
            assert!(e > prev, "not increasing at {v}");
            prev = e;
            assert!((srgb_decode(e) - v).abs() < 1e-12);
        }
        // The two branches meet at the threshold (continuity of the standard's curve).
        let t: f64 = 0.003_130_8;
        assert!((12.92 * t - (1.055 * t.powf(1.0 / 2.4) - 0.055)).abs() < 1e-6);
        assert_eq!(encode_u8([0.0, 1.0, 0.5]), [0, 255, 188]);
        assert_eq!(encode_u8([f64::NAN, -1.0, 7.0]), [0, 0, 255]);
        // 18 % grey encodes to 118 (sRGB code value of middle grey).
        assert_eq!(encode_u8([0.18; 3]), [118; 3]);
        let mut out = vec![0u8; 6];
        encode_frame(&[[0.0; 3], [1e9; 3]], 1.0, &mut out);
        assert_eq!(out, vec![0, 0, 0, 255, 255, 255]);
    }

    #[test]
    fn a_frame_encodes_as_its_pixels_one_by_one_and_counts_its_lit_pixels() {
        // Ordinary colours of every brightness, black (+0 and -0), a negative channel that
        // needs the gamut mapping, NaN, infinities, and a frame length that is not a
        // multiple of four: the frame's bytes are encode_u8(tone_map(..)) pixel by pixel.
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let specials = [
            0.0,
            -0.0,
            -0.3,
            f32::NAN,
            f32::INFINITY,
            -f32::INFINITY,
            1e-30,
            3e38,
        ];
        let pixels: Vec<[f32; 3]> = (0..40_003)
            .map(|_| {
                std::array::from_fn(|_| {
                    let r = next();
                    match r % 16 {
                        0 => specials[(r >> 8) as usize % specials.len()],
                        1..=4 => 0.0,
                        // 1e-4 to 1e4, log-uniform.
                        _ => {
                            10f32.powf(((r >> 11) as f64 / (1u64 << 53) as f64 * 8.0 - 4.0) as f32)
                        }
                    }
                })
            })
            .collect();
        for exposure in [1.0, 0.37, 25.0] {
            let mut out = vec![7u8; 3 * pixels.len()];
            let lit = encode_frame(&pixels, exposure, &mut out);
            let mut want_lit = 0;
            for (i, px) in pixels.iter().enumerate() {
                let want = encode_u8(tone_map(px.map(f64::from), exposure));
                assert_eq!(
                    out[3 * i..3 * i + 3],
                    want,
                    "pixel {i} {px:?}, exposure {exposure}"
                );
                want_lit += usize::from(want.iter().any(|&c| c > 2));
            }
            assert_eq!(lit, want_lit);
            assert!(lit > pixels.len() / 2 && lit < pixels.len(), "{lit}");
        }
    }

    #[test]
    fn the_code_values_found_among_the_steps_are_the_computed_ones() {
        let steps = Srgb8Steps::get();
        let check = |v: f64| {
            let want = srgb8_computed(v);
            assert_eq!(steps.code(v), want, "at {v:e}");
            if v.is_finite() && (0.0..=1.0).contains(&v) {
                assert_eq!(steps.searched(v), want, "searched, at {v:e}");
            }
        };
        // Each step and its neighbouring floats, where the code value changes; each
        // interval's ends.
        for &t in steps.at[..255].iter() {
            let b = t.to_bits();
            for bits in [b - 2, b - 1, b, b + 1, b + 2] {
                check(f64::from_bits(bits));
            }
        }
        for n in 0..=Srgb8Steps::INTERVALS {
            let b = (n as f64 / Srgb8Steps::INTERVALS as f64).to_bits();
            for bits in [b.saturating_sub(1), b, b + 1] {
                check(f64::from_bits(bits));
            }
        }
        // A dense sweep, and the extremes.
        let mut x = 0x2545_F491_4F6C_DD1Du64;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            check((x >> 11) as f64 / (1u64 << 53) as f64 * 1.2 - 0.1);
        }
        for v in [
            0.0,
            -0.0,
            1e-300,
            0.003_130_8,
            1.0,
            f64::NAN,
            f64::INFINITY,
            -1.0,
        ] {
            check(v);
        }
    }
}

//! Random streams and direction sampling for the path tracer.
//!
//! Every pixel owns a PCG stream seeded from a hash of (user seed, purpose, pixel index), so
//! its samples do not depend on which thread renders it or in which order: the output is
//! bit-identical whatever the rayon thread count. Lambertian bounces sample the cosine-weighted
//! hemisphere (pdf `cos(theta) / pi`), for which the BRDF-cosine-pdf ratio is the albedo.
//! Directions are single precision, like the geometry they are traced against. The pixel
//! position and the first two bounce directions of a pixel's paths come from scrambled
//! low-discrepancy points ([`PixelSampler`]); the rest from the pixel's random stream.

use nalgebra::Vector3;
use rand::RngCore;
use rand_pcg::Pcg64Mcg;

/// What a random stream is used for; streams of different purposes are independent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stream {
    /// The transient render.
    Transient = 1,
    /// The steady-state render (an estimate independent of the transient one).
    Steady = 2,
    /// The direct truth of a moving camera (`crate::render::truth`).
    Truth = 3,
}

/// SplitMix64 finaliser: a bijective 64-bit mixer.
#[inline]
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random stream of one pixel.
pub fn pixel_rng(seed: u64, stream: Stream, pixel_index: u64) -> Pcg64Mcg {
    let a = splitmix64(seed ^ splitmix64(stream as u64));
    let hi = splitmix64(a ^ splitmix64(pixel_index));
    let lo = splitmix64(hi ^ 0x6A09_E667_F3BC_C909);
    // The multiplicative generator forces the low bit of its state on.
    Pcg64Mcg::new(((hi as u128) << 64) | lo as u128)
}

/// Two independent uniforms in [0, 1) from one 64-bit draw: bits 40..64 and 16..40, each
/// exactly a multiple of 2^-24 (single precision holds them exactly).
#[inline]
pub fn uniform_pair(rng: &mut Pcg64Mcg) -> (f32, f32) {
    const SCALE: f32 = 1.0 / (1u32 << 24) as f32;
    let x = rng.next_u64();
    (
        (x >> 40) as f32 * SCALE,
        ((x >> 16) & 0xFF_FFFF) as f32 * SCALE,
    )
}

/// A uniform f32 in [0, 1) (a multiple of 2^-24).
#[inline]
pub fn uniform(rng: &mut Pcg64Mcg) -> f32 {
    uniform_pair(rng).0
}

/// An orthonormal basis `(t, b)` completing the unit vector `n` (Duff et al. 2017).
#[inline]
pub fn orthonormal_basis(n: &Vector3<f32>) -> (Vector3<f32>, Vector3<f32>) {
    let sign = 1f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vector3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vector3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// A cosine-weighted direction about the unit normal `n` from a point `(u1, u2)` of the unit
/// square (Malley's method: a uniform point of the unit disk, from Shirley and Chiu's
/// area-preserving concentric map, lifted onto the hemisphere). The map is one-to-one, so
/// stratified or low-discrepancy points of the square stay well spread over the hemisphere.
#[inline]
pub fn cosine_hemisphere(n: &Vector3<f32>, u1: f32, u2: f32) -> Vector3<f32> {
    let (t, b) = orthonormal_basis(n);
    cosine_hemisphere_in(&t, &b, n, u1, u2)
}

/// [`cosine_hemisphere`] about `n` given its [`orthonormal_basis`] `(t, b)` (for normals
/// whose basis is computed once, e.g. per triangle). The basis of `-n` is `(t, -b)`, bit for
/// bit (every operation of the basis commutes with negation).
#[inline]
pub fn cosine_hemisphere_in(
    t: &Vector3<f32>,
    b: &Vector3<f32>,
    n: &Vector3<f32>,
    u1: f32,
    u2: f32,
) -> Vector3<f32> {
    let l = cosine_local(u1, u2);
    t * l.x + b * l.y + n * l.z
}

/// A direction uniform over the unit sphere (density `1 / (4 pi)`) from a point `(u1, u2)` of
/// the unit square: `z = 1 - 2 u1` (Archimedes: uniform in `z`), azimuth `2 pi u2`.
#[inline]
pub fn uniform_sphere(u1: f32, u2: f32) -> Vector3<f32> {
    let z = 1.0 - 2.0 * u1;
    let rxy = (1.0 - z * z).max(0.0).sqrt();
    let (sin, cos) = (std::f32::consts::TAU * u2).sin_cos();
    Vector3::new(rxy * cos, rxy * sin, z)
}

/// The direction of [`cosine_hemisphere`] in the frame of the normal (`z` along it).
#[inline]
pub fn cosine_local(u1: f32, u2: f32) -> Vector3<f32> {
    let (x, y) = concentric_disk(u1, u2);
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    Vector3::new(x, y, z)
}

/// Shirley and Chiu's concentric map of the unit square onto the unit disk (area preserving):
/// the square `[-1, 1]^2` is cut into four triangles by its diagonals and each is mapped onto
/// a quarter of the disk, radius `r = max(|a|, |b|)` and angle `phi = pi/4 * (b / a)` (or
/// `pi/2 - pi/4 * (a / b)`). The angle's sine and cosine are needed only on `[-pi/4, pi/4]`,
/// where Taylor polynomials to degree 9 (sine) and 10 (cosine) are exact to 2e-9, below single
/// precision: no libm trigonometry.
#[inline]
pub fn concentric_disk(u1: f32, u2: f32) -> (f32, f32) {
    let a = 2.0 * u1 - 1.0;
    let b = 2.0 * u2 - 1.0;
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    // r = a, theta = pi/4 (b / a) when |a| > |b|; else r = b and phi = pi/2 - pi/4 (a / b),
    // whose cosine and sine are the sine and cosine of pi/4 (a / b). Selects, not branches:
    // the case is a coin toss per sample.
    let swap = a.abs() <= b.abs();
    let (r, t) = if swap { (b, a) } else { (a, b) };
    let (sin, cos) = sin_cos_quarter(std::f32::consts::FRAC_PI_4 * (t / r));
    let (cx, cy) = if swap { (sin, cos) } else { (cos, sin) };
    (r * cx, r * cy)
}

/// `(sin x, cos x)` for `|x| <= pi/4` from Taylor polynomials (truncation error below 2e-9).
#[inline]
fn sin_cos_quarter(x: f32) -> (f32, f32) {
    // Coefficients 1 / k! (products, not divisions, in the loop).
    const S3: f32 = -1.0 / 6.0;
    const S5: f32 = 1.0 / 120.0;
    const S7: f32 = -1.0 / 5040.0;
    const S9: f32 = 1.0 / 362_880.0;
    const C4: f32 = 1.0 / 24.0;
    const C6: f32 = -1.0 / 720.0;
    const C8: f32 = 1.0 / 40_320.0;
    const C10: f32 = -1.0 / 3_628_800.0;
    let x2 = x * x;
    let sin = x * (1.0 + x2 * (S3 + x2 * (S5 + x2 * (S7 + x2 * S9))));
    let cos = 1.0 + x2 * (-0.5 + x2 * (C4 + x2 * (C6 + x2 * (C8 + x2 * C10))));
    (sin, cos)
}

/// Per-pixel low-discrepancy samples: Owen-scrambled Sobol points in two dimensions, drawn
/// independently for each 2D dimension (pixel position, first bounce, ...), with hash-based
/// nested uniform scrambling and index shuffling (Burley 2020, "Practical hash-based Owen
/// scrambling", JCGT 9(4)). Each point is uniformly distributed on the unit square (the
/// scramble adds a uniform random key before bijective mixing), so estimates stay unbiased;
/// the `spp` points of a pixel in one dimension pair form a (0, m, 2)-net when `spp = 2^m`,
/// which stratifies them far better than independent points. The scramble keys come from a
/// hash of (seed, purpose, pixel), so the samples of a pixel do not depend on threads.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    /// Scramble keys `[index shuffle, x, y]` of each 2D dimension.
    keys: [[u32; 3]; PixelSampler::DIMS as usize],
    /// `2^m - 1` for the smallest `2^m >= spp`: the shuffled index of a pixel's path, which
    /// varies only in these bits (the scramble of bit k depends on the bits above it, which
    /// are zero for every index below `2^m`), is kept to them.
    mask: u32,
}

impl PixelSampler {
    /// Number of 2D dimensions a pixel sampler provides: 0 the position in the pixel, 1 and
    /// 2 the first two bounces, 3 the spot's emission direction of the light vertex.
    pub const DIMS: u32 = 4;

    /// The sampler of one pixel rendered with `spp` paths (independent of its
    /// [`pixel_rng`] stream).
    pub fn new(seed: u64, stream: Stream, pixel_index: u64, spp: u32) -> PixelSampler {
        let a = splitmix64(seed ^ splitmix64(stream as u64 ^ 0xA076_1D64_78BD_642F));
        let key = splitmix64(a ^ splitmix64(pixel_index ^ 0xE703_7ED1_A0B4_28DB));
        let keys = std::array::from_fn(|dim| {
            let h = splitmix64(key ^ (dim as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
            [h as u32, (h >> 32) as u32, splitmix64(h) as u32]
        });
        PixelSampler {
            keys,
            mask: spp
                .max(1)
                .checked_next_power_of_two()
                .map_or(u32::MAX, |p| p - 1),
        }
    }

    /// Point `index` (below the pixel's `spp`) of 2D dimension `dim` (below [`Self::DIMS`]),
    /// in [0, 1)^2 (multiples of 2^-24).
    #[inline]
    pub fn sample(&self, index: u32, dim: u32) -> (f32, f32) {
        let [k0, k1, k2] = self.keys[dim as usize];
        // Shuffled Sobol index, then each coordinate Owen-scrambled: with `rev` the bit
        // reversal, scramble(x) = rev(lk(rev(x))), the first Sobol coordinate is rev(i) and
        // the second is computed bit-reversed, which saves reversals.
        let i = laine_karras(index.reverse_bits(), k0).reverse_bits() & self.mask;
        let x = laine_karras(i, k1).reverse_bits();
        let y = laine_karras(sobol_dim1_reversed(i), k2).reverse_bits();
        const SCALE: f32 = 1.0 / (1u32 << 24) as f32;
        ((x >> 8) as f32 * SCALE, (y >> 8) as f32 * SCALE)
    }

    /// Where path `index` of pixel `(x, y)` crosses the image, in continuous pixel
    /// coordinates: the pixel's corner plus the path's point of dimension 0.
    #[inline]
    pub fn image_position(&self, index: u32, x: usize, y: usize) -> (f64, f64) {
        let (du, dv) = self.sample(index, 0);
        (x as f64 + du as f64, y as f64 + dv as f64)
    }
}

/// Second dimension of the Sobol sequence (direction numbers of the polynomial `x + 1`) as a
/// bit-reversed 32-bit fraction (the first dimension, bit-reversed, is the index itself): the
/// xor of the direction numbers of the set bits of `index`, a byte at a time from tables.
#[inline]
fn sobol_dim1_reversed(index: u32) -> u32 {
    let t = &SOBOL_DIM1_REVERSED_BYTES;
    t[0][(index & 0xFF) as usize]
        ^ t[1][((index >> 8) & 0xFF) as usize]
        ^ t[2][((index >> 16) & 0xFF) as usize]
        ^ t[3][(index >> 24) as usize]
}

/// `SOBOL_DIM1_REVERSED_BYTES[k][b]`: xor of the bit-reversed direction numbers `v_j` for the
/// set bits `j` of byte `b` at byte position `k` (`v_0 = 1`, `v_j = v_{j-1} xor (v_{j-1} << 1)`).
static SOBOL_DIM1_REVERSED_BYTES: [[u32; 256]; 4] = sobol_dim1_tables();

const fn sobol_dim1_tables() -> [[u32; 256]; 4] {
    let mut v = [0u32; 32];
    v[0] = 1;
    let mut j = 1;
    while j < 32 {
        v[j] = v[j - 1] ^ (v[j - 1] << 1);
        j += 1;
    }
    let mut t = [[0u32; 256]; 4];
    let mut k = 0;
    while k < 4 {
        let mut b = 0;
        while b < 256 {
            let mut r = 0;
            let mut bit = 0;
            while bit < 8 {
                if b & (1 << bit) != 0 {
                    r ^= v[8 * k + bit];
                }
                bit += 1;
            }
            t[k][b] = r;
            b += 1;
        }
        k += 1;
    }
    t
}

/// Laine-Karras style hash permutation: each output bit depends only on the input bits
/// below it (Burley 2020, listing 3).
#[inline]
fn laine_karras(mut x: u32, key: u32) -> u32 {
    x = x.wrapping_add(key);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let mut r = pixel_rng(7, Stream::Transient, 3);
        let b: Vec<u64> = (0..4).map(|_| r.next_u64()).collect();
        let mut r2 = pixel_rng(7, Stream::Transient, 3);
        assert_eq!(b, (0..4).map(|_| r2.next_u64()).collect::<Vec<u64>>());
        assert!(b[0] != b[1]);
        let c: u64 = pixel_rng(7, Stream::Transient, 4).next_u64();
        let d: u64 = pixel_rng(7, Stream::Steady, 3).next_u64();
        let e: u64 = pixel_rng(8, Stream::Transient, 3).next_u64();
        assert!(c != b[0] && d != b[0] && e != b[0]);
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [
            Vector3::new(0.0, 0.0, 1.0),
            Vector3::new(0.0, 0.0, -1.0),
            Vector3::new(0.3, -0.4, 0.5).normalize(),
            Vector3::new(-1.0, 1e-9, -1e-9).normalize(),
        ] {
            let (t, b) = orthonormal_basis(&n);
            for (x, y) in [(t, b), (t, n), (b, n)] {
                assert!(x.dot(&y).abs() < 1e-6);
            }
            assert!((t.norm() - 1.0).abs() < 1e-6 && (b.norm() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn basis_of_the_flipped_normal_is_t_and_minus_b() {
        // The tracer computes a triangle's basis once and shades its back side with
        // (t, -b, -n): the same bits as the basis and direction computed for -n.
        let mut rng = pixel_rng(5, Stream::Steady, 1);
        for k in 0..2000 {
            let (a, b) = uniform_pair(&mut rng);
            let (c, _) = uniform_pair(&mut rng);
            let mut n = Vector3::new(a - 0.5, b - 0.5, c - 0.5);
            match k % 4 {
                0 => n.z = 0.0,
                1 => n.z = -0.0,
                _ => {}
            }
            let n = n.normalize();
            let (t, bt) = orthonormal_basis(&n);
            let (t_flip, b_flip) = orthonormal_basis(&-n);
            let bits = |v: &Vector3<f32>| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
            assert_eq!(bits(&t_flip), bits(&t), "{n:?}");
            assert_eq!(bits(&b_flip), bits(&-bt), "{n:?}");
            let (u1, u2) = uniform_pair(&mut rng);
            assert_eq!(
                bits(&cosine_hemisphere(&-n, u1, u2)),
                bits(&cosine_hemisphere_in(&t, &-bt, &-n, u1, u2))
            );
            assert_eq!(
                bits(&cosine_hemisphere(&n, u1, u2)),
                bits(&cosine_hemisphere_in(&t, &bt, &n, u1, u2))
            );
        }
    }

    #[test]
    fn uniform_pairs_are_uniform_and_independent() {
        // Mean 1/2, variance 1/12, zero correlation between the two halves (5 sigma bounds).
        let mut rng = pixel_rng(3, Stream::Steady, 9);
        let m = 100_000;
        let (mut s1, mut s2, mut s11, mut s12) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for _ in 0..m {
            let (a, b) = uniform_pair(&mut rng);
            assert!((0.0..1.0).contains(&a) && (0.0..1.0).contains(&b));
            let (a, b) = (a as f64, b as f64);
            s1 += a;
            s2 += b;
            s11 += a * a;
            s12 += (a - 0.5) * (b - 0.5);
        }
        let m = m as f64;
        let sd_mean = (1.0 / 12.0 / m).sqrt();
        assert!((s1 / m - 0.5).abs() < 5.0 * sd_mean);
        assert!((s2 / m - 0.5).abs() < 5.0 * sd_mean);
        assert!((s11 / m - 1.0 / 3.0).abs() < 5.0 * (4.0 / 45.0 / m).sqrt());
        assert!((s12 / m).abs() < 5.0 * (1.0 / 144.0 / m).sqrt());
    }

    #[test]
    fn cosine_sampling_has_the_cosine_distribution() {
        // Independent checks for pdf cos/pi on the hemisphere: E[cos] = 2/3, E[cos^2] = 1/2,
        // tangential components average to zero, and the cdf of cos^2 is uniform:
        // P(cos^2 <= c) = c (chi-square over 10 equal bins, 9 dof: 99.9 % point 27.9).
        let n = Vector3::new(0.2, 0.9, -0.1).normalize();
        let mut rng = pixel_rng(1, Stream::Transient, 0);
        let m = 200_000;
        let (mut c1, mut c2, mut tang) = (0.0f64, 0.0f64, Vector3::<f64>::zeros());
        let mut bins = [0u32; 10];
        for _ in 0..m {
            let (u1, u2) = uniform_pair(&mut rng);
            let d = cosine_hemisphere(&n, u1, u2);
            assert!((d.norm() - 1.0).abs() < 1e-6);
            let c = d.dot(&n) as f64;
            assert!(c >= -1e-7);
            c1 += c;
            c2 += c * c;
            tang += (d - n * d.dot(&n)).cast::<f64>();
            bins[((c * c * 10.0) as usize).min(9)] += 1;
        }
        let m = m as f64;
        // Standard errors: sd(cos) = sqrt(1/2 - 4/9) = 0.236, so 5 sigma ~ 0.0026.
        assert!((c1 / m - 2.0 / 3.0).abs() < 0.003, "{}", c1 / m);
        assert!((c2 / m - 0.5).abs() < 0.003, "{}", c2 / m);
        assert!((tang / m).norm() < 0.005);
        let e = m / 10.0;
        let chi2: f64 = bins.iter().map(|&b| (b as f64 - e).powi(2) / e).sum();
        assert!(chi2 < 27.9, "chi-square {chi2}, bins {bins:?}");
    }

    #[test]
    fn sphere_sampling_is_uniform() {
        // On the uniform sphere every coordinate is uniform on [-1, 1] (Archimedes): the
        // mean direction is zero and x (which the azimuth decides) fills 10 equal bins
        // (chi-square, 9 dof: 99.9 % point 27.9).
        let mut rng = pixel_rng(2, Stream::Transient, 0);
        let m = 200_000;
        let mut mean = Vector3::<f64>::zeros();
        let mut bins = [0u32; 10];
        for _ in 0..m {
            let (u1, u2) = uniform_pair(&mut rng);
            let d = uniform_sphere(u1, u2);
            assert!((d.norm() - 1.0).abs() < 1e-6);
            mean += d.cast::<f64>();
            bins[(((d.x as f64 + 1.0) * 5.0) as usize).min(9)] += 1;
        }
        // sd of each coordinate 1/sqrt(3): 5 sigma over 2e5 samples ~ 0.0065.
        assert!((mean / m as f64).norm() < 0.0065 * 3f64.sqrt(), "{mean:?}");
        let e = m as f64 / 10.0;
        let chi2: f64 = bins.iter().map(|&b| (b as f64 - e).powi(2) / e).sum();
        assert!(chi2 < 27.9, "chi-square {chi2}, bins {bins:?}");
    }

    #[test]
    fn quarter_sin_cos_matches_libm() {
        for k in -1000..=1000 {
            let x = std::f64::consts::FRAC_PI_4 * k as f64 / 1000.0;
            let (s, c) = sin_cos_quarter(x as f32);
            assert!((s as f64 - x.sin()).abs() < 2e-7, "sin {x}");
            assert!((c as f64 - x.cos()).abs() < 2e-7, "cos {x}");
        }
    }

    #[test]
    fn concentric_map_is_uniform_on_the_disk() {
        // Uniform on the disk: P(r^2 <= a) = a and the angle uniform; chi-square over 8 x 8
        // cells of (r^2, angle), 63 dof: 99.9 % point 103.4.
        let mut rng = pixel_rng(5, Stream::Steady, 1);
        let m = 128_000;
        let mut cells = [0u32; 64];
        for _ in 0..m {
            let (u1, u2) = uniform_pair(&mut rng);
            let (x, y) = concentric_disk(u1, u2);
            let r2 = (x as f64).powi(2) + (y as f64).powi(2);
            assert!(r2 <= 1.0 + 1e-6);
            let phi = (y as f64).atan2(x as f64) / std::f64::consts::TAU + 0.5;
            let i = ((r2 * 8.0) as usize).min(7) * 8 + ((phi * 8.0) as usize).min(7);
            cells[i] += 1;
        }
        let e = m as f64 / 64.0;
        let chi2: f64 = cells.iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
        assert!(chi2 < 103.4, "chi-square {chi2}");
        // Corners and edges of the square land on the circle, the centre at the centre.
        let (x, y) = concentric_disk(1.0, 0.5);
        assert!((x - 1.0).abs() < 1e-6 && y.abs() < 1e-6);
        assert_eq!(concentric_disk(0.5, 0.5), (0.0, 0.0));
    }

    #[test]
    fn scrambled_sobol_prefixes_are_nets() {
        // The first 2^m points of a dimension pair put exactly one point in each elementary
        // interval [i / 2^a, (i + 1) / 2^a) x [j / 2^b, (j + 1) / 2^b) with a + b = m.
        let m = 6u32;
        let n = 1usize << m;
        for (pixel, dim) in [(0u64, 0u32), (17, 1), (4095, 2), (123_456, 2)] {
            let s = PixelSampler::new(3, Stream::Transient, pixel, n as u32);
            let pts: Vec<(f32, f32)> = (0..n as u32).map(|i| s.sample(i, dim)).collect();
            for a in 0..=m {
                let b = m - a;
                let mut seen = vec![0u32; n];
                for &(x, y) in &pts {
                    assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
                    let i = (x * (1u32 << a) as f32) as usize;
                    let j = (y * (1u32 << b) as f32) as usize;
                    seen[i * (1 << b) + j] += 1;
                }
                assert!(
                    seen.iter().all(|&c| c == 1),
                    "pixel {pixel} dim {dim} a {a}"
                );
            }
        }
    }

    #[test]
    fn any_sample_count_is_accepted() {
        // The index mask covers every index below spp, up to u32::MAX paths.
        for spp in [0, 1, 3, 256, 257, (1 << 31) + 1, u32::MAX] {
            let s = PixelSampler::new(1, Stream::Transient, 0, spp);
            assert!(s.mask >= spp.saturating_sub(1));
            assert!(s.mask == u32::MAX || (s.mask + 1).is_power_of_two());
            let (x, y) = s.sample(spp.saturating_sub(1), 2);
            assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
        }
    }

    #[test]
    fn sobol_second_dimension_matches_its_definition() {
        // Direction numbers of x + 1 (m_k = 1): v_1 = 1/2, v_k = v_{k-1} xor v_{k-1} / 2, and
        // point i is the xor of v_k over the set bits of i (v = 1/2, 3/4, 5/8): the first
        // points are 0, 1/2, 3/4, 1/4, 5/8, 1/8, 3/8, 7/8.
        let expect = [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875];
        for (i, &e) in expect.iter().enumerate() {
            let x = sobol_dim1_reversed(i as u32).reverse_bits() as f64 / 2f64.powi(32);
            assert_eq!(x, e, "point {i}");
        }
    }

    #[test]
    fn scrambled_points_are_uniform_over_pixels() {
        // Point 5 of dimension 1 across many pixels (different scrambles): uniform on the
        // square, chi-square over 8 x 8 cells (63 dof, 99.9 % point 103.4), and the two
        // coordinates uncorrelated.
        let m = 64_000;
        let mut cells = [0u32; 64];
        let mut sxy = 0.0f64;
        for p in 0..m {
            let (x, y) = PixelSampler::new(9, Stream::Steady, p, 24).sample(5, 1);
            cells[(x * 8.0) as usize * 8 + (y * 8.0) as usize] += 1;
            sxy += (x as f64 - 0.5) * (y as f64 - 0.5);
        }
        let e = m as f64 / 64.0;
        let chi2: f64 = cells.iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
        assert!(chi2 < 103.4, "chi-square {chi2}");
        assert!((sxy / m as f64).abs() < 5.0 * (1.0 / 144.0 / m as f64).sqrt());
    }
}

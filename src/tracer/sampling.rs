//! Random streams and direction sampling for the path tracer.
//!
//! Every pixel owns a PCG stream seeded from a hash of (user seed, purpose, pixel index), so
//! its samples do not depend on which thread renders it or in which order: the output is
//! bit-identical whatever the rayon thread count. Lambertian bounces sample the cosine-weighted
//! hemisphere (pdf `cos(theta) / pi`), for which the BRDF-cosine-pdf ratio is the albedo.
//! Directions are single precision, like the geometry they are traced against.

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

/// A cosine-weighted direction about the unit normal `n` (Malley's method: a uniform point
/// of the unit disk lifted onto the hemisphere). The disk point is drawn by rejection from
/// the enclosing square (accepted with probability pi / 4), which needs no trigonometry and
/// keeps the distribution exact; the stream stays deterministic (it depends only on its own
/// draws).
#[inline]
pub fn cosine_hemisphere(n: &Vector3<f32>, rng: &mut Pcg64Mcg) -> Vector3<f32> {
    let (x, y, r2) = loop {
        let (u1, u2) = uniform_pair(rng);
        let (x, y) = (2.0 * u1 - 1.0, 2.0 * u2 - 1.0);
        let r2 = x * x + y * y;
        if r2 < 1.0 {
            break (x, y, r2);
        }
    };
    let z = (1.0 - r2).sqrt();
    let (t, b) = orthonormal_basis(n);
    t * x + b * y + n * z
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
            let d = cosine_hemisphere(&n, &mut rng);
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
}

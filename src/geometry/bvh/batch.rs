//! Nearest-hit distances of many rays from one origin (a camera's pixels, which share the
//! camera's position): rays that miss the scene's bounding box, decided four at a time in
//! one vector slab test, skip the traversal and its per-ray set-up (two vector divisions,
//! the shear constants, the root node's test), which cost about as much as a short traversal
//! (`benches/render_results.md`: a miss 31 ns, a hit 66 ns on the render bench's frame).
//!
//! The box test is the traversal's conservative slab test (far distances scaled by
//! `SLAB_FAR_SCALE`, a NaN from `0 * inf` ignored) on the mesh's bounds grown by a relative
//! margin: every node box lies inside the mesh's bounds, the slab test's entry distance only
//! falls and its exit distance only rises as a box grows (rounding is monotonic), so a ray
//! the traversal would let into any box passes this test too, and a ray that fails it has no
//! hit. The distances are therefore [`Bvh::intersect`]'s, bit for bit.

#[cfg(target_arch = "x86_64")]
use super::{Avx, Avx512, Isa, AVX512_BATCH, AVX_BATCH};
use super::{
    Bvh, FourLanes, Portable, Ray, Tree, Wide, CULL_SLACK, NATIVE, PORTABLE_OR_SSE, SLAB_FAR_SCALE,
};
use nalgebra::{Point3, Vector3};
use wide::f32x4;

/// The margin by which the batch test grows the mesh's bounds, relative to its largest
/// extent and coordinate (insurance only: the argument in the module doc needs none).
const BOX_MARGIN: f32 = 1e-4;

impl Bvh {
    /// The distance of the nearest hit of each ray `(origin, dirs[i])` with
    /// `t_min < t < t_max`, written to `out[i]`: the same as
    /// `self.intersect(&Ray::new(origin, dirs[i]), t_min, t_max).map(|h| h.t)`, with the rays
    /// that miss the scene's bounding box skipped four at a time (module doc), and the tree's
    /// traversal chosen once for all the rays instead of once per ray.
    ///
    /// Panics if `out.len() != dirs.len()` (a caller bug).
    pub fn intersect_distances(
        &self,
        origin: Point3<f32>,
        dirs: &[Vector3<f32>],
        t_min: f32,
        t_max: f32,
        out: &mut [Option<f32>],
    ) {
        assert_eq!(out.len(), dirs.len(), "intersect_distances: output size");
        if self.bounds.is_empty() {
            // No triangle, no hit (and no box to test against).
            out.fill(None);
            return;
        }
        let batch = Batch {
            bounds: self.padded_bounds(),
            origin,
            t_min,
            t_max,
        };
        match &self.tree {
            Tree::Four(w, FourLanes::Native) => batch.cast(dirs, out, |ray| {
                w.intersect::<_, _, PORTABLE_OR_SSE>(NATIVE, NATIVE, ray, t_min, t_max)
            }),
            Tree::Four(w, FourLanes::Portable) => {
                let lanes = Portable::<4>::new();
                batch.cast(dirs, out, |ray| {
                    w.intersect::<_, _, PORTABLE_OR_SSE>(lanes, lanes, ray, t_min, t_max)
                })
            }
            // SAFETY: the proof `avx` says that the CPU runs AVX, the one feature the function
            // enables.
            #[cfg(target_arch = "x86_64")]
            Tree::Eight(w, Some(Isa::Avx(avx))) => unsafe { batch_avx(&batch, w, *avx, dirs, out) },
            // SAFETY: the proof `p` says that the CPU runs every feature the function enables.
            #[cfg(target_arch = "x86_64")]
            Tree::Eight(w, Some(Isa::Avx512(p))) => unsafe {
                batch_avx512(&batch, w, *p, dirs, out)
            },
            #[cfg(not(target_arch = "x86_64"))]
            Tree::Eight(_, Some(isa)) => match *isa {},
            Tree::Eight(w, None) => {
                let lanes = Portable::<8>::new();
                batch.cast(dirs, out, |ray| {
                    w.intersect::<_, _, PORTABLE_OR_SSE>(lanes, lanes, ray, t_min, t_max)
                })
            }
        }
    }

    /// The mesh's bounds (min x, y, z, then max x, y, z) grown by [`BOX_MARGIN`] of the
    /// largest extent or coordinate.
    fn padded_bounds(&self) -> [f32; 6] {
        let b = self.bounds;
        let extent = (0..3)
            .map(|a| {
                (b.max[a] - b.min[a])
                    .max(b.max[a].abs())
                    .max(b.min[a].abs())
            })
            .fold(0.0f32, f32::max);
        let pad = BOX_MARGIN * extent;
        [
            b.min.x - pad,
            b.min.y - pad,
            b.min.z - pad,
            b.max.x + pad,
            b.max.y + pad,
            b.max.z + pad,
        ]
    }
}

/// What the rays of one [`Bvh::intersect_distances`] share.
struct Batch {
    /// The padded box of the mesh ([`Bvh::padded_bounds`]).
    bounds: [f32; 6],
    origin: Point3<f32>,
    t_min: f32,
    t_max: f32,
}

impl Batch {
    /// `out[i]` for each of `dirs`: `None` where the box test says the ray misses, else the
    /// distance of `nearest`'s hit `(triangle, t, u, v)`.
    #[inline(always)]
    fn cast(
        &self,
        dirs: &[Vector3<f32>],
        out: &mut [Option<f32>],
        nearest: impl Fn(&Ray) -> Option<(u32, f32, f32, f32)>,
    ) {
        let o = [self.origin.x, self.origin.y, self.origin.z].map(f32x4::splat);
        let lo = [0, 1, 2].map(|a| f32x4::splat(self.bounds[a]) - o[a]);
        let hi = [0, 1, 2].map(|a| f32x4::splat(self.bounds[3 + a]) - o[a]);
        let t_min_v = f32x4::splat(self.t_min);
        let t_far_v = f32x4::splat(self.t_max * CULL_SLACK);
        let scale = f32x4::splat(SLAB_FAR_SCALE);
        // Four rays at a time; the last few padded with copies of the last one.
        for (dirs, out) in dirs.chunks(4).zip(out.chunks_mut(4)) {
            let four = match *dirs {
                [a, b, c, d] => [a, b, c, d],
                _ => std::array::from_fn(|k| dirs[k.min(dirs.len() - 1)]),
            };
            let (mut t0, mut t1) = (t_min_v, t_far_v);
            for a in 0..3 {
                let d = f32x4::new([four[0][a], four[1][a], four[2][a], four[3][a]]);
                let inv = f32x4::splat(1.0) / d;
                let negative = inv.is_sign_negative();
                let (t_lo, t_hi) = (lo[a] * inv, hi[a] * inv);
                let near = negative.select(t_hi, t_lo);
                let far = negative.select(t_lo, t_hi) * scale;
                // `max`/`min` return the other operand where `near`/`far` is NaN.
                t0 = near.max(t0);
                t1 = far.min(t1);
            }
            // A lane is skipped only where the test says "miss" for certain: `t0 > t1`
            // compared as numbers (a NaN lane is kept and traversed).
            let miss = t0.simd_gt(t1).to_bitmask();
            for (k, (d, out)) in dirs.iter().zip(out.iter_mut()).enumerate() {
                *out = if miss & (1 << k) != 0 {
                    None
                } else {
                    nearest(&Ray::new(self.origin, *d)).map(|(_, t, _, _)| t)
                };
            }
        }
    }
}

/// [`Batch::cast`] of an eight-wide tree with the lanes of the proof `avx`, compiled for AVX
/// (the traversal inlined into the loop).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn batch_avx(batch: &Batch, w: &Wide<8>, avx: Avx, dirs: &[Vector3<f32>], out: &mut [Option<f32>]) {
    batch.cast(dirs, out, |ray| {
        w.intersect::<_, _, AVX_BATCH>(avx, avx, ray, batch.t_min, batch.t_max)
    })
}

/// [`batch_avx`] compiled for [`Isa::Avx512`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,bmi1,bmi2,popcnt,avx512f,avx512vl")]
fn batch_avx512(
    batch: &Batch,
    w: &Wide<8>,
    proof: Avx512,
    dirs: &[Vector3<f32>],
    out: &mut [Option<f32>],
) {
    let avx = proof.avx();
    batch.cast(dirs, out, |ray| {
        w.intersect::<_, _, AVX512_BATCH>(avx, avx, ray, batch.t_min, batch.t_max)
    })
}

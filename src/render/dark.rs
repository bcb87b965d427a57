//! Why a pixel is dark, and marks that draw the kinds of dark apart.
//!
//! A rendered pixel is black for one of four reasons (the image-based lookup of step 5 of
//! the [`crate::render`] module doc):
//!
//! - [`DarkKind::NoSurface`]: its ray leaves the scene;
//! - [`DarkKind::Unseen`]: its surface point is one the capture camera never saw (outside
//!   the capture's frame, behind an occluder, or the other side of a surface);
//! - [`DarkKind::Masked`]: the capture pixel that would show it was masked by `femto unwarp`
//!   (a mixed pixel whose footprint spans several path lengths, docs/ingest.md);
//! - [`DarkKind::Seen`] with no light now: the capture saw the point and kept its pixel, but holds no
//!   light there at the frame's emission time.
//!
//! The first three do not depend on time; the fourth is what a transient frame is mostly
//! made of. [`draw_dark_marks`] paints the second and third over a frame's 8-bit pixels
//! (`femto render --dark-marks`, on in `femto view`): unseen as a grey diagonal hatch,
//! masked as a violet cross-hatch; no light and no surface stay black. Only pixels that
//! encode to black are marked, so light is never covered.

use super::frame::{FrameProbe, SeenHit};
use super::{FrameRays, PixelSample, RenderScene, RenderSettings, View};
use crate::camera_path::FrameState;
use rayon::prelude::*;

/// Why a pixel shows no light (or that it can).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DarkKind {
    /// The capture saw the point and kept its pixel: it is lit whenever the cube holds
    /// light at its emission time.
    Seen,
    /// The ray leaves the scene.
    NoSurface,
    /// The capture camera never saw the point.
    Unseen,
    /// The capture pixel that sees the point was masked as mixed by `femto unwarp`.
    Masked,
}

impl DarkKind {
    /// The kind of a probed pixel ([`super::probe_pixel`]).
    pub fn of(scene: &RenderScene, sample: &PixelSample) -> DarkKind {
        DarkKind::of_hit(scene, &SeenHit::from(sample))
    }

    /// The kind of a pixel from its ray, hit and seeing capture pixel.
    pub(super) fn of_hit(scene: &RenderScene, hit: &SeenHit) -> DarkKind {
        let Some(point_m) = hit.hit_m else {
            return DarkKind::NoSurface;
        };
        if hit.capture_pixel.is_some() {
            return DarkKind::Seen;
        }
        // Not seen: masked when the pixel it projects into would see it without the mask.
        match scene.nearest_pixel_unmasked(&point_m, &hit.d_world) {
            Some(false) => DarkKind::Masked,
            _ => DarkKind::Unseen,
        }
    }

    /// How the page and the docs name it.
    pub fn describe(self) -> &'static str {
        match self {
            DarkKind::Seen => "seen by the capture",
            DarkKind::NoSurface => "no surface (the ray leaves the scene)",
            DarkKind::Unseen => "never seen by the capture camera",
            DarkKind::Masked => "masked as mixed by femto unwarp",
        }
    }
}

/// The 8-bit colours of the marks: two shades per kind, in stripes [`STRIPE_PX`] apart.
pub const UNSEEN_RGB: [[u8; 3]; 2] = [[22, 22, 22], [72, 72, 72]];
pub const MASKED_RGB: [[u8; 3]; 2] = [[34, 10, 46], [120, 48, 150]];
/// Period of the hatches, pixels.
pub const STRIPE_PX: usize = 8;
/// Side of the blocks of pixels that share one probe of their kind, pixels: 4 (16 pixels a
/// probe) where 2 took 5-10 ms of a 640 x 480 frame's 40 in `femto view`. The kinds' edges
/// are drawn to within a block, a quarter of a hatch's period.
pub const MARK_BLOCK: usize = 4;

/// The mark of `kind` at pixel `(i, j)`, or None for a kind drawn black.
pub fn mark_rgb(kind: DarkKind, i: usize, j: usize) -> Option<[u8; 3]> {
    // Stripes two pixels wide every STRIPE_PX: unseen along one diagonal, masked along both.
    let diag = (i + j) % STRIPE_PX < 2;
    let anti = (i + STRIPE_PX * (1 + j / STRIPE_PX) - j % STRIPE_PX) % STRIPE_PX < 2;
    match kind {
        DarkKind::Unseen => Some(UNSEEN_RGB[usize::from(diag)]),
        DarkKind::Masked => Some(MASKED_RGB[usize::from(diag || anti)]),
        DarkKind::Seen | DarkKind::NoSurface => None,
    }
}

/// Paint the marks of the unseen and masked pixels over `srgb8` (the frame `state` rendered
/// with `settings`, 8-bit RGB, row-major): every pixel that encodes to black gets the mark
/// of the kind of the top-left pixel of its [`MARK_BLOCK`] x [`MARK_BLOCK`] block (one probe
/// per block: the kinds change only at the edges of surfaces and of the capture's view).
/// Isochrone frames are drawn from the mesh alone and are left as they are.
///
/// `rays`: the [`FrameRays`] the frame was just rendered with
/// ([`super::render_sequence_reusing`]), whose rays and hits the probes then read instead
/// of casting their own (the same kinds; a probe's ray cast was 1.5-2 ms of a 640 x 480
/// frame in `femto view`).
pub fn draw_dark_marks(
    scene: &RenderScene,
    settings: &RenderSettings,
    state: &FrameState,
    rays: Option<&FrameRays>,
    srgb8: &mut [u8],
) {
    if matches!(settings.view, View::Isochrones(_)) {
        return;
    }
    let w = settings.width;
    debug_assert_eq!(srgb8.len(), 3 * w * settings.height);
    srgb8
        .par_chunks_mut(MARK_BLOCK * 3 * w)
        .enumerate()
        .for_each(|(block_row, rows)| {
            let j0 = MARK_BLOCK * block_row;
            let probe = FrameProbe::new(scene, settings, state, rays);
            let mut kinds = vec![None; w.div_ceil(MARK_BLOCK)];
            for (r, row) in rows.chunks_mut(3 * w).enumerate() {
                let j = j0 + r;
                for (i, px) in row.chunks_exact_mut(3).enumerate() {
                    if px != [0, 0, 0] {
                        continue;
                    }
                    let kind = *kinds[i / MARK_BLOCK].get_or_insert_with(|| {
                        let hit = probe.seen_hit(scene, settings, i - i % MARK_BLOCK, j0);
                        DarkKind::of_hit(scene, &hit)
                    });
                    if let Some(rgb) = mark_rgb(kind, i, j) {
                        px.copy_from_slice(&rgb);
                    }
                }
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn marks_are_distinct_hatches_and_black_kinds_stay_black() {
        let count = |kind| {
            let mut shades = std::collections::BTreeMap::new();
            for j in 0..16 {
                for i in 0..16 {
                    *shades.entry(mark_rgb(kind, i, j)).or_insert(0) += 1;
                }
            }
            shades
        };
        let unseen = count(DarkKind::Unseen);
        let masked = count(DarkKind::Masked);
        // Two shades each, the lighter in stripes: a quarter of the unseen hatch, more of
        // the masked cross-hatch.
        assert_eq!(unseen.len(), 2);
        assert_eq!(unseen[&Some(UNSEEN_RGB[1])], 64);
        assert_eq!(masked.len(), 2);
        assert!(masked[&Some(MASKED_RGB[1])] > 64);
        for kind in [DarkKind::Seen, DarkKind::NoSurface] {
            assert_eq!(count(kind).len(), 1);
            assert_eq!(mark_rgb(kind, 3, 5), None);
        }
        // No mark is black: a marked pixel is never mistaken for no light.
        for rgb in UNSEEN_RGB.iter().chain(&MASKED_RGB) {
            assert!(rgb.iter().any(|&c| c > 2), "{rgb:?}");
        }
    }
}

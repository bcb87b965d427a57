//! The image-based renderer's error against its traced truth ([`super::truth`]): per frame,
//! how far [`super::render_frame`]'s picture is from the truth of the same camera path
//! (docs/truth.md, `femto compare`).
//!
//! # Measures (per frame, on luminance `Y` of the scene-linear frames)
//!
//! - **Lit**: `Y >= threshold`, the threshold being [`LIT_FRACTION`] of the 99.5th
//!   percentile of the truth's positive luminances over the whole sequence (one threshold for
//!   every frame, so that frames without light have no lit pixels). **Dark**: `Y` below a
//!   quarter of the threshold (a margin, so that noise near the threshold counts as neither).
//! - **Relative L1**: `sum |Y_render - Y_truth| / sum Y_truth` over the pixels lit in either
//!   frame.
//! - **Holes**: the share of the truth's lit pixels that are dark in the render (light the
//!   capture camera never saw: disocclusion). **Ghosts**: the share of the render's lit
//!   pixels that are dark in the truth.
//! - **PSNR** of the display images, dB: both frames exposed alike (the exposure
//!   [`super::lit_exposure`] finds for the truth's pixel luminances over the sequence, the
//!   automatic exposure's rule, or the caller's) and encoded as `femto render` encodes its
//!   PNGs ([`crate::color::encode_frame`]); the mean squared error is over every pixel and
//!   channel of the 8-bit images.
//! - **Error image**: the signed luminance difference over the 99.5th percentile, red where
//!   the render is brighter, blue where it is darker, as the square root of its size (so
//!   that small errors show).

use super::exposure::lit_exposure;
use crate::color;

/// Lit pixels have at least this fraction of the truth's 99.5th-percentile luminance.
pub const LIT_FRACTION: f64 = 0.01;
/// Dark pixels are below this fraction of the lit threshold.
pub const DARK_FRACTION: f64 = 0.25;
/// The percentile of the truth's positive luminances that sets the scale.
pub const SCALE_PERCENTILE: f64 = 0.995;

/// One frame of scene-linear RGB, row-major from the top row.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearFrame {
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<[f32; 3]>,
}

impl LinearFrame {
    fn luminance(&self) -> impl Iterator<Item = f64> + '_ {
        self.rgb
            .iter()
            .map(|p| color::luminance([p[0] as f64, p[1] as f64, p[2] as f64]))
    }
}

/// The scale of a sequence's comparison: the truth's luminance scale, the lit threshold and
/// the display exposure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale {
    /// The truth's 99.5th-percentile luminance.
    pub reference: f64,
    /// `LIT_FRACTION * reference`.
    pub lit: f64,
    /// The exposure both display images get.
    pub exposure: f64,
}

impl Scale {
    /// The scale of `truth`'s frames, the display exposure the automatic one times
    /// `exposure_multiplier` (as `femto render --exposure`; None: 1). None when no truth
    /// pixel has light.
    pub fn of_truth(truth: &[&LinearFrame], exposure_multiplier: Option<f64>) -> Option<Scale> {
        let mut y: Vec<f64> = truth
            .iter()
            .flat_map(|f| f.luminance())
            .filter(|v| *v > 0.0 && v.is_finite())
            .collect();
        if y.is_empty() {
            return None;
        }
        let auto = lit_exposure(y.clone()).map_or(1.0, |l| l.exposure);
        let k = ((y.len() - 1) as f64 * SCALE_PERCENTILE).round() as usize;
        let (_, &mut reference, _) = y.select_nth_unstable_by(k, f64::total_cmp);
        Some(Scale {
            reference,
            lit: LIT_FRACTION * reference,
            exposure: auto * exposure_multiplier.unwrap_or(1.0),
        })
    }
}

/// The measures of one frame (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameError {
    /// Pixels lit in the truth, in the render, in either.
    pub lit_truth: usize,
    pub lit_render: usize,
    pub lit_either: usize,
    /// Relative L1 of luminance over the pixels lit in either (NaN when none is).
    pub rel_l1: f64,
    /// Share of the truth's lit pixels dark in the render (NaN when none is lit).
    pub holes: f64,
    /// Share of the render's lit pixels dark in the truth (NaN when none is lit).
    pub ghosts: f64,
    /// PSNR of the display images, dB (infinite when they are equal).
    pub psnr_db: f64,
    /// The counts and sums behind the shares, for pooling frames: truth-lit pixels dark in
    /// the render, render-lit pixels dark in the truth, `sum |Y_render - Y_truth|` and
    /// `sum Y_truth` over the pixels lit in either.
    pub hole_pixels: usize,
    pub ghost_pixels: usize,
    pub abs_diff_sum: f64,
    pub truth_sum: f64,
}

/// Frames pooled: the relative L1, hole and ghost shares of all their pixels together, and
/// the mean PSNR over the frames whose truth has a lit pixel, where it is finite.
///
/// The PSNR's frames are chosen by the truth alone, so two renders of the same truth are
/// averaged over the same frames. (Chosen by "lit in either frame", a render's ghosts in
/// frames where the truth is dark added those frames, whose PSNR is high, to its mean: a
/// render that removed them scored lower, 18.27 dB against 20.56 on `docs/truth.md`'s dolly,
/// although its PSNR was higher in 19 of its 20 lit frames.) Ghosts in such frames count in
/// the ghost share.
pub fn pooled(frames: &[FrameError]) -> (f64, f64, f64, f64) {
    let sum = |f: fn(&FrameError) -> f64| frames.iter().map(f).sum::<f64>();
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::NAN };
    // Frames dark in the truth would only inflate the mean with the PSNR of black images.
    let psnr: Vec<f64> = frames
        .iter()
        .filter(|f| f.lit_truth > 0)
        .map(|f| f.psnr_db)
        .filter(|p| p.is_finite())
        .collect();
    (
        ratio(sum(|f| f.abs_diff_sum), sum(|f| f.truth_sum)),
        ratio(sum(|f| f.hole_pixels as f64), sum(|f| f.lit_truth as f64)),
        ratio(sum(|f| f.ghost_pixels as f64), sum(|f| f.lit_render as f64)),
        if psnr.is_empty() {
            f64::INFINITY
        } else {
            psnr.iter().sum::<f64>() / psnr.len() as f64
        },
    )
}

/// Compare one frame of the render with its truth at `scale`; also returns the error image
/// (8-bit sRGB, module doc). Panics if the frames differ in size (the caller checks).
pub fn compare_frame(
    truth: &LinearFrame,
    render: &LinearFrame,
    scale: &Scale,
) -> (FrameError, Vec<u8>) {
    assert_eq!(
        (truth.width, truth.height),
        (render.width, render.height),
        "compare_frame: frame sizes"
    );
    let dark = DARK_FRACTION * scale.lit;
    let (mut lit_t, mut lit_r, mut lit_either) = (0usize, 0usize, 0usize);
    let (mut holes, mut ghosts) = (0usize, 0usize);
    let (mut l1, mut sum_t) = (0.0f64, 0.0f64);
    let mut error_image = Vec::with_capacity(3 * truth.rgb.len());
    for (yt, yr) in truth.luminance().zip(render.luminance()) {
        let (t_lit, r_lit) = (yt >= scale.lit, yr >= scale.lit);
        lit_t += t_lit as usize;
        lit_r += r_lit as usize;
        holes += (t_lit && yr < dark) as usize;
        ghosts += (r_lit && yt < dark) as usize;
        if t_lit || r_lit {
            lit_either += 1;
            l1 += (yr - yt).abs();
            sum_t += yt;
        }
        let e = ((yr - yt) / scale.reference).clamp(-1.0, 1.0);
        let v = (255.0 * e.abs().sqrt()).round() as u8;
        error_image.extend_from_slice(&if e >= 0.0 { [v, 0, 0] } else { [0, 0, v] });
    }
    let share = |n: usize, of: usize| {
        if of == 0 {
            f64::NAN
        } else {
            n as f64 / of as f64
        }
    };
    let display = |f: &LinearFrame| {
        let mut out = vec![0u8; 3 * f.rgb.len()];
        color::encode_frame(&f.rgb, scale.exposure, &mut out);
        out
    };
    let (dt, dr) = (display(truth), display(render));
    let mse = dt
        .iter()
        .zip(&dr)
        .map(|(&a, &b)| (a as f64 - b as f64).powi(2))
        .sum::<f64>()
        / dt.len().max(1) as f64;
    let psnr_db = 10.0 * (255.0f64 * 255.0 / mse).log10();
    (
        FrameError {
            lit_truth: lit_t,
            lit_render: lit_r,
            lit_either,
            rel_l1: if lit_either == 0 {
                f64::NAN
            } else {
                l1 / sum_t.max(f64::MIN_POSITIVE)
            },
            holes: share(holes, lit_t),
            ghosts: share(ghosts, lit_r),
            psnr_db,
            hole_pixels: holes,
            ghost_pixels: ghosts,
            abs_diff_sum: l1,
            truth_sum: sum_t,
        },
        error_image,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(values: &[f32]) -> LinearFrame {
        LinearFrame {
            width: values.len(),
            height: 1,
            rgb: values.iter().map(|&v| [v, v, v]).collect(),
        }
    }

    #[test]
    fn holes_ghosts_and_l1_count_what_they_say() {
        // Truth: 100 pixels at 1 and one at 0; the render loses two, adds one, doubles one.
        let mut t = vec![1.0f32; 100];
        t.push(0.0);
        let mut r = t.clone();
        r[0] = 0.0;
        r[1] = 0.0;
        r[2] = 2.0;
        r[100] = 1.0;
        let (t, r) = (frame(&t), frame(&r));
        let s = Scale::of_truth(&[&t], Some(1.0)).unwrap();
        assert!((s.reference - 1.0).abs() < 1e-6);
        let (e, image) = compare_frame(&t, &r, &s);
        assert_eq!((e.lit_truth, e.lit_render, e.lit_either), (100, 99, 101));
        assert!((e.holes - 0.02).abs() < 1e-12, "{}", e.holes);
        assert!((e.ghosts - 1.0 / 99.0).abs() < 1e-12, "{}", e.ghosts);
        // |0-1| + |0-1| + |2-1| + |1-0| over the truth's 100.
        assert!((e.rel_l1 - 0.04).abs() < 1e-6, "{}", e.rel_l1);
        assert!(e.psnr_db.is_finite() && e.psnr_db > 0.0);
        assert_eq!(&image[0..3], &[0, 0, 255]);
        assert_eq!(&image[6..9], &[255, 0, 0]);
        assert_eq!(&image[9..12], &[0, 0, 0]);
        let (same, _) = compare_frame(&t, &t, &s);
        assert_eq!((same.rel_l1, same.holes, same.ghosts), (0.0, 0.0, 0.0));
        assert!(same.psnr_db.is_infinite());
    }

    #[test]
    fn pooled_psnr_averages_the_frames_the_truth_lights_whatever_the_render() {
        let lit = frame(&[1.0, 1.0, 0.0, 0.0]);
        let dark = frame(&[0.0; 4]);
        let s = Scale::of_truth(&[&lit, &dark], Some(1.0)).unwrap();
        let near = frame(&[1.0, 0.9, 0.0, 0.0]);
        let ghost = frame(&[0.0, 0.0, 0.0, 0.02]);
        let (e_lit, _) = compare_frame(&lit, &near, &s);
        let (e_clean, _) = compare_frame(&dark, &dark, &s);
        let (e_ghost, _) = compare_frame(&dark, &ghost, &s);
        assert!(e_ghost.lit_render == 1 && e_ghost.psnr_db.is_finite());
        // A render with a ghost in the dark frame and one without: the same pooled PSNR,
        // that of the lit frame; the ghost shows in the ghost share.
        let with_ghost = pooled(&[e_lit, e_ghost]);
        let without = pooled(&[e_lit, e_clean]);
        assert_eq!(with_ghost.3, e_lit.psnr_db);
        assert_eq!(without.3, e_lit.psnr_db);
        assert!(with_ghost.2 > without.2, "{} {}", with_ghost.2, without.2);
    }

    #[test]
    fn a_dark_truth_has_no_scale() {
        assert!(Scale::of_truth(&[&frame(&[0.0, 0.0])], None).is_none());
    }
}

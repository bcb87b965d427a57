//! Framing of the demo's stills where a relativistic effect moves the scene out of the frame
//! or shrinks it to a few pixels (issue 15): which field of view or which crop shows what the
//! effect does, without touching the renderer's physics.
//!
//! - A dolly (seed Fig. 5, aberration rows): every pixel has the camera's velocity, so a
//!   pinhole's field of view is pure framing. Moving towards the scene, aberration (physics.md,
//!   `cos theta_w = (mu' - beta) / (1 - beta mu')`) squeezes the capture camera's view into a
//!   smaller cone; moving away, it spreads it. [`dolly_framing`] finds that cone's half-angle in
//!   the moving camera with [`Boost`], and the field of view that frames it.
//! - A rolling sensor (seed Fig. 8): each sensor area has its own velocity, fixed by its place
//!   on the sensor, so the field of view is part of the physics; framing is a centre crop of a
//!   larger render of the same sensor ([`seen_extent`] says how much of the frame shows the
//!   scene, [`centre_crop`] cuts it out).

use crate::camera_path::FrameState;
use crate::relativity::Boost;
use crate::render::{probe_pixel, RenderScene, RenderSettings};
use nalgebra::Vector3;

/// A panel is reframed when the scene would span less than this fraction of the frame (or,
/// spread by aberration, more than its reciprocal): down to 2/5 the shrinking or spreading is
/// seen at the capture camera's field of view (fig. 5 at beta 0.6 and -0.6); beyond it the
/// scene is a few pixels, or the frame shows a small, featureless part of it.
pub const MIN_SCENE_SPAN: f64 = 0.4;
/// The widest field of view a reframed panel gets, degrees: a pinhole's image of a wider cone
/// squeezes its centre into a few pixels.
pub const MAX_VFOV_DEG: f64 = 150.0;
/// A fig. 8 panel is a centre crop when the pixels that show the scene reach less than this
/// far from the centre ([`SeenExtent::reach`]): the scene then fills less than a quarter of the
/// frame's area.
pub const MIN_SEEN_REACH: f64 = 0.5;
/// Fraction of the pixels that show the scene that a fig. 8 crop keeps.
pub const CROP_KEEP: f64 = 0.995;

/// Angle from the direction of motion, degrees, at which a camera moving with `beta` along
/// that direction (negative: the opposite way) sees a ray that the world frame sees at
/// `world_deg` from it.
pub fn camera_angle_deg(beta: f64, world_deg: f64) -> f64 {
    let (boost, d) = boosted(beta, world_deg);
    angle_deg(&boost.inverse().aberrate(&d))
}

/// The inverse of [`camera_angle_deg`]: the world-frame angle of a camera ray at `camera_deg`.
pub fn world_angle_deg(beta: f64, camera_deg: f64) -> f64 {
    let (boost, d) = boosted(beta, camera_deg);
    angle_deg(&boost.aberrate(&d))
}

/// The boost of a camera moving with `beta` along +z and a unit ray at `deg` from +z.
fn boosted(beta: f64, deg: f64) -> (Boost, Vector3<f64>) {
    let boost = Boost::new(Vector3::new(0.0, 0.0, beta)).unwrap_or_else(|_| Boost::identity());
    let a = deg.to_radians();
    (boost, Vector3::new(a.sin(), 0.0, a.cos()))
}

fn angle_deg(d: &Vector3<f64>) -> f64 {
    d.z.clamp(-1.0, 1.0).acos().to_degrees()
}

/// How a dolly panel at speed `beta` (towards the scene; negative away) is framed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DollyFraming {
    /// Half-angle, in the moving camera, of the cone the capture camera's vertical field of
    /// view fills at rest, degrees.
    pub scene_half_deg: f64,
    /// Height of that cone in a frame of the capture camera's field of view, in frame heights
    /// (below 1: the scene shrank; above 1: it overflows the frame).
    pub span_at_capture_fov: f64,
    /// The panel's vertical field of view, degrees.
    pub vfov_deg: f64,
    /// Whether `vfov_deg` differs from the capture camera's.
    pub reframed: bool,
    /// Fraction of the capture camera's view (in height) that the panel shows (1 unless the
    /// needed field of view exceeds [`MAX_VFOV_DEG`]).
    pub shown_fraction: f64,
}

/// The framing of a dolly panel (module doc): the capture camera's field of view
/// (`capture_vfov_deg`) while the scene spans between [`MIN_SCENE_SPAN`] and its reciprocal
/// of the frame, else the field of view that the capture camera's view fills in the moving
/// camera (at most [`MAX_VFOV_DEG`]).
pub fn dolly_framing(beta: f64, capture_vfov_deg: f64) -> DollyFraming {
    let half = 0.5 * capture_vfov_deg;
    let scene_half_deg = camera_angle_deg(beta, half);
    let span_at_capture_fov = if scene_half_deg < 90.0 {
        scene_half_deg.to_radians().tan() / half.to_radians().tan()
    } else {
        f64::INFINITY
    };
    let reframed = !(MIN_SCENE_SPAN..=1.0 / MIN_SCENE_SPAN).contains(&span_at_capture_fov);
    let vfov_deg = if reframed {
        (2.0 * scene_half_deg).min(MAX_VFOV_DEG)
    } else {
        capture_vfov_deg
    };
    let shown_half = world_angle_deg(beta, 0.5 * vfov_deg);
    let shown_fraction = (shown_half.to_radians().tan() / half.to_radians().tan()).min(1.0);
    DollyFraming {
        scene_half_deg,
        span_at_capture_fov,
        vfov_deg,
        reframed,
        shown_fraction,
    }
}

/// Where a frame shows the scene: pixels whose hit point the capture camera sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeenExtent {
    /// Fraction of the frame's pixels that show the scene.
    pub fraction: f64,
    /// How far from the centre they reach: the [`CROP_KEEP`] quantile, over those pixels, of
    /// `max(|dx| / half width, |dy| / half height)` (1: the frame's border; 0 when no pixel
    /// shows the scene).
    pub reach: f64,
}

/// [`SeenExtent`] of frame `state` rendered with `settings`.
pub fn seen_extent(
    scene: &RenderScene,
    settings: &RenderSettings,
    state: &FrameState,
) -> SeenExtent {
    let (w, h) = (settings.width, settings.height);
    let (hw, hh) = (0.5 * w as f64, 0.5 * h as f64);
    let mut reach: Vec<f64> = (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .filter(|&(i, j)| {
            probe_pixel(scene, settings, state, i, j)
                .capture_pixel
                .is_some()
        })
        .map(|(i, j)| {
            let dx = (i as f64 + 0.5 - hw).abs() / hw;
            let dy = (j as f64 + 0.5 - hh).abs() / hh;
            dx.max(dy)
        })
        .collect();
    let fraction = reach.len() as f64 / (w * h).max(1) as f64;
    if reach.is_empty() {
        return SeenExtent {
            fraction,
            reach: 0.0,
        };
    }
    let k = ((reach.len() as f64 * CROP_KEEP) as usize).min(reach.len() - 1);
    let (_, q, _) = reach.select_nth_unstable_by(k, f64::total_cmp);
    SeenExtent {
        fraction,
        reach: *q,
    }
}

/// The size of a render whose centre `width x height` crop magnifies the frame's centre by
/// about `zoom` (at least 1): `round(zoom * size)`, grown by a pixel where needed so that the
/// margins left and right (above and below) are equal.
pub fn zoomed_size(width: usize, height: usize, zoom: f64) -> (usize, usize) {
    let grow = |n: usize| {
        let m = ((n as f64 * zoom.max(1.0)).round() as usize).max(n);
        m + (m - n) % 2
    };
    (grow(width), grow(height))
}

/// The centre `width x height` pixels of a `big_w x big_h` frame (row-major).
pub fn centre_crop<T: Copy>(
    pixels: &[T],
    big_w: usize,
    big_h: usize,
    width: usize,
    height: usize,
) -> Vec<T> {
    let (x0, y0) = ((big_w - width) / 2, (big_h - height) / 2);
    (y0..y0 + height)
        .flat_map(|y| {
            pixels[y * big_w + x0..y * big_w + x0 + width]
                .iter()
                .copied()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Aberration of a ray at `theta` from the direction of motion, written independently of
    /// the library: a photon arriving along the ray has 4-momentum `(1, -n)` in the world
    /// frame; boost it into the frame moving with `beta` along +z and read off the direction
    /// it comes from.
    fn camera_angle_by_four_momentum(beta: f64, world_deg: f64) -> f64 {
        let g = 1.0 / (1.0 - beta * beta).sqrt();
        let t = world_deg.to_radians();
        // Propagation direction (the photon travels towards the camera): -n.
        let (px, pz, e) = (-t.sin(), -t.cos(), 1.0);
        let e_cam = g * (e - beta * pz);
        let pz_cam = g * (pz - beta * e);
        // The camera ray points where the photon comes from: -p / e.
        let (dx, dz) = (-px / e_cam, -pz_cam / e_cam);
        dx.atan2(dz).to_degrees()
    }

    #[test]
    fn aberration_angles_agree_with_a_boosted_photon() {
        for beta in [-0.99, -0.9, -0.6, -0.3, 0.0, 0.3, 0.6, 0.9, 0.99] {
            for deg in [1.0, 8.0, 30.0, 89.0, 120.0] {
                let want = camera_angle_by_four_momentum(beta, deg);
                let got = camera_angle_deg(beta, deg);
                assert!(
                    (got - want).abs() < 1e-9,
                    "beta {beta}, {deg} deg: {got} vs {want}"
                );
                let back = world_angle_deg(beta, got);
                assert!((back - deg).abs() < 1e-9, "round trip {beta} {deg}: {back}");
            }
        }
        // Half-angle form: tan(theta'/2) = sqrt((1 - beta) / (1 + beta)) tan(theta/2).
        let t = (0.5 * camera_angle_deg(0.99, 8.0)).to_radians().tan();
        assert!((t - (0.01f64 / 1.99).sqrt() * 4f64.to_radians().tan()).abs() < 1e-12);
    }

    #[test]
    fn fast_panels_are_reframed_and_slow_ones_keep_the_capture_view() {
        let vfov = 16.0;
        let f = |b: f64| dolly_framing(b, vfov);
        for b in [0.0, 0.3, -0.3, 0.6, -0.6] {
            assert!(!f(b).reframed, "{b}");
            assert_eq!(f(b).vfov_deg, vfov);
            // Moving away the frame shows only the centre of the spread view: the world
            // half-angle of its edge, tan(theta_w / 2) = sqrt((1 + beta) / (1 - beta)) tan(4 deg).
            let k = ((1.0 + b) / (1.0 - b)).sqrt();
            let edge = 2.0 * (k * 4f64.to_radians().tan()).atan();
            let shown = (edge.tan() / 8f64.to_radians().tan()).min(1.0);
            assert!(
                (f(b).shown_fraction - shown).abs() < 1e-9,
                "{b}: {:?}",
                f(b)
            );
        }
        // Towards at 0.9: the capture view fills 2 * 1.84 degrees, about 23 % of the frame.
        let t = f(0.9);
        assert!(t.reframed);
        assert!((t.span_at_capture_fov - 0.229).abs() < 0.002, "{t:?}");
        assert!((t.vfov_deg - 2.0 * t.scene_half_deg).abs() < 1e-12);
        assert!((t.shown_fraction - 1.0).abs() < 1e-9);
        // Away at 0.9: it fills about 68 degrees (tan 34 / tan 8 = 4.8 frame heights at 16).
        let a = f(-0.9);
        assert!(
            a.reframed && (a.span_at_capture_fov - 4.78).abs() < 0.01,
            "{a:?}"
        );
        assert!((a.vfov_deg - 68.0).abs() < 1.0, "{a:?}");
        // Away at 0.99 it would need 178.5 degrees: capped, showing only part of the view.
        let c = f(-0.99);
        assert!((c.scene_half_deg - 89.2).abs() < 0.1, "{c:?}");
        assert_eq!(c.vfov_deg, MAX_VFOV_DEG);
        assert!(c.shown_fraction > 0.5 && c.shown_fraction < 0.9, "{c:?}");
    }

    #[test]
    fn zoomed_sizes_keep_the_crop_centred() {
        assert_eq!(zoomed_size(160, 120, 1.0), (160, 120));
        assert_eq!(zoomed_size(160, 120, 0.5), (160, 120));
        assert_eq!(zoomed_size(160, 120, 2.5), (400, 300));
        let (w, h) = zoomed_size(161, 121, 1.3);
        assert_eq!(((w - 161) % 2, (h - 121) % 2), (0, 0));
        // A 6 x 4 frame numbered row by row; its centre 2 x 2.
        let px: Vec<usize> = (0..24).collect();
        assert_eq!(centre_crop(&px, 6, 4, 2, 2), [8, 9, 14, 15]);
    }
}

//! The renderer's other views (see the [`crate::render`] module doc for their derivations):
//! the naive re-projection that keeps the capture camera's time warp (seed Fig. 4 top left),
//! isochrones of first arrival (seed Fig. 4 bottom), and the time-integrated image (seed
//! Fig. 2 right, computed in [`super::frame`] from the prefix sums' totals).

use super::{RenderError, RenderScene};
use crate::geometry::Ray;
use crate::units::flight_time_ps;
use nalgebra::{Point3, Vector3};

/// Colour coding of [`super::View::Isochrones`]: arrival times from `t_min_ps` (blue) to
/// `t_max_ps` (red), dark contour lines every `contour_ps`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Isochrones {
    pub t_min_ps: f64,
    pub t_max_ps: f64,
    pub contour_ps: f64,
}

impl Isochrones {
    /// Check that the range is increasing and the contour spacing positive.
    pub fn validate(&self) -> Result<(), RenderError> {
        if !(self.t_min_ps.is_finite()
            && self.t_max_ps.is_finite()
            && self.t_min_ps < self.t_max_ps)
        {
            return Err(RenderError::Setting {
                name: "isochrones",
                message: format!(
                    "time range {} .. {} ps is not increasing",
                    self.t_min_ps, self.t_max_ps
                ),
            });
        }
        if !(self.contour_ps.is_finite() && self.contour_ps > 0.0) {
            return Err(RenderError::Setting {
                name: "isochrones",
                message: format!(
                    "contour spacing {} ps is not a positive number",
                    self.contour_ps
                ),
            });
        }
        Ok(())
    }
}

/// A round contour spacing for a range of `span_ps`: the largest of 1, 2 or 5 times a power of
/// ten that gives at least 10 intervals over the span (1 ps for an empty or invalid span).
pub fn round_contour_ps(span_ps: f64) -> f64 {
    if !(span_ps.is_finite() && span_ps > 0.0) {
        return 1.0;
    }
    let target = span_ps / 10.0;
    let decade = 10f64.powf(target.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * decade)
        .find(|&s| s <= target)
        .unwrap_or(decade)
}

/// World time (ps, 0 = the pulse leaves the spot) at which direct light from the laser spot
/// first reaches `p_m`: `eta |laser - p| / c`.
#[inline]
pub fn first_arrival_world_ps(scene: &RenderScene, p_m: &Point3<f64>) -> f64 {
    flight_time_ps(scene.capture.eta, (scene.capture.laser_m - p_m).norm())
}

/// Whether the laser spot sees `p_m` directly (nothing on the segment between them, apart
/// from the surfaces at its two ends).
pub fn laser_sees(scene: &RenderScene, p_m: &Point3<f64>) -> bool {
    let to_laser = scene.capture.laser_m - p_m;
    let dist_m = to_laser.norm();
    if dist_m <= 0.0 {
        return true;
    }
    let dir = to_laser / dist_m;
    let eps = 1e-5 * (1.0 + dist_m);
    let ray = Ray::new(
        Point3::new(p_m.x as f32, p_m.y as f32, p_m.z as f32),
        Vector3::new(dir.x as f32, dir.y as f32, dir.z as f32),
    );
    !scene
        .bvh
        .occluded(&ray, eps as f32, (dist_m - eps).max(0.0) as f32)
}

/// Emission time of the naive view: the world cube sampled at the time the **capture**
/// camera's warp gives, `t_receive - eta |p - o_capture| / c`.
#[inline]
pub fn naive_emission_ps(scene: &RenderScene, p_m: &Point3<f64>, t_receive_ps: f64) -> f64 {
    // Written as (eta / c) * distance, like the transient view's re-warp, so that both views
    // agree to the last bit at the capture camera's position.
    t_receive_ps
        - flight_time_ps(scene.capture.eta, 1.0) * (p_m - scene.capture.pose.position_m).norm()
}

/// Hue ramp from blue (`s = 0`) through cyan, green and yellow to red (`s = 1`), linear
/// sRGB, full saturation.
fn hue_ramp(s: f64) -> [f64; 3] {
    let hue = 240.0 * (1.0 - s.clamp(0.0, 1.0)); // degrees, 240 = blue, 0 = red
    let h = hue / 60.0;
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let (r, g, b) = match h as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        _ => (x, 0.0, 1.0),
    };
    [r, g, b]
}

/// Display colour (linear) of an isochrone pixel whose point the laser does not reach
/// directly, so that no direct pulse arrives there: a neutral mid-grey (sRGB 118), apart from
/// every colour of the hue ramp, its darkened contour lines and the black of rays that leave
/// the scene.
pub const UNLIT_ISOCHRONE_RGB: [f64; 3] = [0.18; 3];

/// Display colour (linear, in `[0, 1]`) of an isochrone pixel with arrival time `t_ps`:
/// the hue ramp over the range, darkened to 15 % on contour lines (within 6 % of a contour
/// spacing of a multiple of `contour_ps`), [`UNLIT_ISOCHRONE_RGB`] where the laser does not
/// reach the point directly.
pub fn isochrone_colour(iso: &Isochrones, t_ps: f64, lit: bool) -> [f64; 3] {
    if !lit {
        return UNLIT_ISOCHRONE_RGB;
    }
    let s = (t_ps - iso.t_min_ps) / (iso.t_max_ps - iso.t_min_ps);
    let c = hue_ramp(s);
    let phase = (t_ps / iso.contour_ps).rem_euclid(1.0);
    let on_line = phase.min(1.0 - phase) < 0.06;
    let k = if on_line { 0.15 } else { 1.0 };
    [c[0] * k, c[1] * k, c[2] * k]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hue_ramp_runs_from_blue_to_red_through_green() {
        assert_eq!(hue_ramp(0.0), [0.0, 0.0, 1.0]);
        assert_eq!(hue_ramp(1.0), [1.0, 0.0, 0.0]);
        assert_eq!(hue_ramp(0.5), [0.0, 1.0, 0.0]);
        assert_eq!(hue_ramp(0.25), [0.0, 1.0, 1.0]); // cyan
        assert_eq!(hue_ramp(0.75), [1.0, 1.0, 0.0]); // yellow
                                                     // Out-of-range times clamp to the ends.
        assert_eq!(hue_ramp(-3.0), hue_ramp(0.0));
        assert_eq!(hue_ramp(7.0), hue_ramp(1.0));
        for k in 0..=100 {
            let c = hue_ramp(k as f64 / 100.0);
            assert!(c.iter().all(|v| (0.0..=1.0).contains(v)));
            assert_eq!(c.iter().cloned().fold(0.0, f64::max), 1.0);
        }
    }

    #[test]
    fn round_contours_give_ten_to_twenty_five_intervals() {
        assert_eq!(round_contour_ps(1000.0), 100.0);
        assert_eq!(round_contour_ps(4300.0), 200.0);
        assert_eq!(round_contour_ps(9.0), 0.5);
        assert_eq!(round_contour_ps(0.0), 1.0);
        for span in [0.37, 3.0, 77.0, 1234.5, 98765.0] {
            let n = span / round_contour_ps(span);
            assert!((10.0..=25.0).contains(&n), "{span}: {n} intervals");
        }
    }

    #[test]
    fn contour_lines_fall_on_multiples_of_the_spacing() {
        let iso = Isochrones {
            t_min_ps: 0.0,
            t_max_ps: 100.0,
            contour_ps: 10.0,
        };
        let bright = |t: f64| {
            isochrone_colour(&iso, t, true)
                .iter()
                .cloned()
                .fold(0.0, f64::max)
        };
        assert!(bright(30.0) < 0.2 && bright(29.7) < 0.2 && bright(30.4) < 0.2);
        assert!(bright(35.0) > 0.99 && bright(31.0) > 0.99);
        assert_eq!(isochrone_colour(&iso, 35.0, false), UNLIT_ISOCHRONE_RGB);
        assert!(iso.validate().is_ok());
        let bad = Isochrones {
            contour_ps: 0.0,
            ..iso
        };
        assert!(bad.validate().is_err());
    }
}

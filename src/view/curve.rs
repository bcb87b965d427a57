//! The light curve of the current view: how much light the page's camera receives at each
//! world time of reception, the lit range that the time cursor and Play stay in, and how far
//! the camera may travel along its velocity before it meets the geometry.
//!
//! The page asks for it whenever the camera, its velocity or the picture settings change
//! (`POST /api/curve`), so that the curve under the time slider always describes the view on
//! screen (seed Sec. 5: the viewer explores the light of the capture from any viewpoint;
//! the reception times of a viewpoint are its own, step 4 of [`crate::render`]).
//!
//! The curve is measured, not predicted: small frames of the state (at most
//! [`CURVE_SIDE`] pixels wide, through the render stage like every frame) at
//! [`LIGHT_CURVE_SAMPLES`] reception times, their mean display value, over the span where
//! the view's own pixels receive the cube's light ([`LightProfile::in_frame`], padded).

use super::light::{lit_range, LightCurve, LIGHT_CURVE_SAMPLES};
use super::session::{ViewError, ViewSession};
use super::state::ViewState;
use crate::render::coverage::{LightProfile, LIGHT_FRACTION};
use crate::units::flight_time_ps;

/// Widest side of the small frames the curve renders, pixels.
pub const CURVE_SIDE: usize = 80;

/// Fraction of the span of the view's light added either side of it for the curve's range:
/// the dark before and after the light shows on the curve.
pub const CURVE_PADDING: f64 = 0.15;

/// The small state whose frames the curve measures: `state` at most [`CURVE_SIDE`] wide,
/// without the marks of dark pixels (only light counts).
pub fn curve_state(state: &ViewState) -> ViewState {
    ViewState {
        dark_marks: false,
        ..state.scaled((CURVE_SIDE as f64 / state.width as f64).min(1.0))
    }
}

impl ViewSession<'_> {
    /// The light curve of `state`'s view (module doc).
    pub fn light_curve(&self, state: &ViewState) -> Result<LightCurve, ViewError> {
        state.check()?;
        let mut probe = curve_state(state);
        let (range, note) = self.reception_range_ps(&probe)?;
        let [t0, t1] = range;
        let spacing = (t1 - t0) / LIGHT_CURVE_SAMPLES as f64;
        let mut t_ps = Vec::with_capacity(LIGHT_CURVE_SAMPLES);
        let mut mean = Vec::with_capacity(LIGHT_CURVE_SAMPLES);
        for k in 0..LIGHT_CURVE_SAMPLES {
            probe.t_world_ps = t0 + spacing * (k as f64 + 0.5);
            let srgb8 = self.render_unrecorded(&probe)?;
            t_ps.push(probe.t_world_ps);
            mean.push(srgb8.iter().map(|&v| v as f64).sum::<f64>() / srgb8.len() as f64);
        }
        let lit_range_ps = lit_range(&t_ps, &mean, spacing);
        let peak = (0..mean.len())
            .max_by(|&a, &b| mean[a].total_cmp(&mean[b]))
            .map_or(t0, |k| t_ps[k]);
        let note = match (lit_range_ps, note) {
            (Some(_), _) => None,
            (None, Some(n)) => Some(n),
            (None, None) => Some(
                "no light reaches this view at any time: the surfaces it sees hold no light in \
                 the capture"
                    .into(),
            ),
        };
        Ok(LightCurve {
            t_ps,
            mean,
            lit_range_ps,
            time_range_ps: range,
            peak_ps: peak,
            travel_m: self.travel_m(state),
            note,
        })
    }

    /// The reception times over which `state`'s pixels receive the cube's light, padded by
    /// [`CURVE_PADDING`]; when they see none of the cube's pixels, the times over which light
    /// from the mesh's bounds can reach the camera, with a note saying so.
    fn reception_range_ps(
        &self,
        state: &ViewState,
    ) -> Result<([f64; 2], Option<String>), ViewError> {
        let span = self.with_planned(state, |scene, plan| {
            LightProfile::in_frame(scene, &plan.settings, &plan.path.frame(0)).span(LIGHT_FRACTION)
        })?;
        if let Some(s) = span {
            let pad = CURVE_PADDING * s.len_ps().max(state.dtau_ps);
            return Ok(([s.start_ps - pad, s.end_ps + pad], None));
        }
        let (t_a, t_b, near_m, far_m, eta) = self.with_planned(state, |scene, _| {
            let (t_a, t_b) = scene.world_span_ps();
            let (near, far) = super::session::distance_range_m(scene, &state.position_m.into());
            (t_a, t_b, near, far, scene.capture.eta)
        })?;
        Ok((
            [
                t_a + flight_time_ps(eta, near_m),
                t_b + flight_time_ps(eta, far_m),
            ],
            Some(
                "this view shows no surface the capture recorded (turn towards the scene, or \
                 Reset to the capture view)"
                    .into(),
            ),
        ))
    }

    /// How far the camera of `state` may move along its velocity before it comes within
    /// [`ViewSession::clearance_margin_m`] of the geometry, m (module doc).
    pub fn travel_m(&self, state: &ViewState) -> Option<f64> {
        let beta = nalgebra::Vector3::from(state.beta);
        let speed = beta.norm();
        if speed == 0.0 {
            return None;
        }
        let dir = beta / speed;
        let margin = self.clearance_margin_m();
        let ray = crate::geometry::Ray::new(
            nalgebra::Point3::from(state.position_m).cast::<f32>(),
            dir.cast::<f32>(),
        );
        let hit = self.with_bvh(|bvh| bvh.intersect(&ray, 0.0, f32::INFINITY))?;
        Some((hit.t as f64 - margin).max(0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_curve_state_is_small_and_keeps_the_aspect() {
        let s = crate::view::state::tests::example();
        let c = curve_state(&ViewState {
            width: 1280,
            height: 960,
            ..s.clone()
        });
        assert_eq!((c.width, c.height), (80, 60));
        let tiny = curve_state(&ViewState {
            width: 40,
            height: 30,
            ..s
        });
        assert_eq!((tiny.width, tiny.height), (40, 30));
    }
}

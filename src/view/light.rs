//! What the page is told about the light of a view: the light curve under its time slider
//! and its lit range ([`super::curve`] measures it).

use serde::Serialize;

/// Samples of the light curve.
pub const LIGHT_CURVE_SAMPLES: usize = 64;

/// A sample of the light curve is lit when it rises above the darkest sample by more than
/// this fraction of the curve's span.
pub const LIT_FRACTION: f64 = 0.05;

/// Light the camera of a state receives at each world time of reception, and its lit range.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LightCurve {
    /// World times of reception, ps.
    pub t_ps: Vec<f64>,
    /// Mean display value (0-255) of the state's small frame at each time.
    pub mean: Vec<f64>,
    /// From the first to the last sample whose mean rises above the darkest sample's by more
    /// than [`LIT_FRACTION`] of the curve's span (half a sample's spacing either side), ps;
    /// None when the curve is flat (no light in this view).
    pub lit_range_ps: Option<[f64; 2]>,
    /// The times the curve covers, ps: the slider's range for this view.
    pub time_range_ps: [f64; 2],
    /// The brightest sample's time, ps.
    pub peak_ps: f64,
    /// For a moving camera, how far it may travel along its velocity before it comes within
    /// `ViewSession::clearance_margin_m` of the geometry, m; None at rest, or when nothing
    /// lies ahead.
    pub travel_m: Option<f64>,
    /// Why the view has no light, when it has none.
    pub note: Option<String>,
}

/// The lit range of a light curve sampled at `t_ps` (spaced `spacing_ps`): from the first to
/// the last sample above the darkest by more than [`LIT_FRACTION`] of the span, widened by
/// half a spacing either side; None when the curve is flat.
pub fn lit_range(t_ps: &[f64], mean: &[f64], spacing_ps: f64) -> Option<[f64; 2]> {
    let lo = mean.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = mean.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let lit = |k: &usize| mean[*k] - lo > LIT_FRACTION * (hi - lo);
    let first = (0..mean.len()).find(lit)?;
    let last = (0..mean.len()).rev().find(lit)?;
    Some([
        t_ps[first] - 0.5 * spacing_ps,
        t_ps[last] + 0.5 * spacing_ps,
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lit_range_spans_the_samples_above_the_dark_level_and_a_flat_curve_has_none() {
        let t: Vec<f64> = (0..8).map(|k| 100.0 + 10.0 * k as f64).collect();
        // Dark 1.0, light from the third to the sixth sample; 1.2 is under 5 % of the span.
        let mean = [1.0, 1.2, 5.0, 40.0, 30.0, 2.9, 1.0, 1.0];
        assert_eq!(lit_range(&t, &mean, 10.0), Some([115.0, 145.0]));
        assert_eq!(lit_range(&t, &[3.0; 8], 10.0), None);
    }
}

//! The provenance notes an ingest adds to the cube (`ingest.*`): the plan's input, time axis,
//! corrections and their parameters, and what the first pass estimated (power gains,
//! jitter shifts).

use super::Globals;
use crate::ingest::plan::{DarkCorrection, IngestPlan, PowerCorrection, RowSource};
use crate::ingest::row_offsets::OffsetReport;

/// The provenance notes of an ingest.
pub(super) fn notes(plan: &IngestPlan, globals: &Globals) -> Vec<(String, String)> {
    let json = |v: serde_json::Value| v.to_string();
    let mut n = vec![
        ("ingest.input".to_string(), plan.input.clone()),
        (
            "ingest.source_files".to_string(),
            json(serde_json::json!(plan.source_files())),
        ),
        ("ingest.time_axis".to_string(), plan.axis_source.clone()),
        (
            "ingest.recorded_size".to_string(),
            format!(
                "{} x {} (x by t), {:?} samples",
                plan.nx, plan.nt_recorded, plan.pixel_type
            ),
        ),
        (
            "ingest.value_scale".to_string(),
            plan.value_scale.to_string(),
        ),
        (
            "ingest.corrections".to_string(),
            json(serde_json::json!(plan.corrections())),
        ),
    ];
    if let Some(laser) = &plan.laser {
        // The number alone, as `femto render` and `femto unwarp` read it.
        n.push(("laser_nm".to_string(), laser.nm.to_string()));
        n.push(("ingest.laser_nm".to_string(), laser.source.to_string()));
    }
    if let RowSource::Stack { path, dataset, .. } = &plan.source {
        n.push((
            "ingest.stack".to_string(),
            format!("{}:/{dataset}", path.display()),
        ));
    }
    if plan.transpose {
        n.push(("ingest.transpose".to_string(), "true".to_string()));
    }
    match &plan.dark {
        Some(DarkCorrection::Level(v)) => n.push(("ingest.dark".into(), format!("level {v}"))),
        Some(DarkCorrection::Frame { path, .. }) => {
            n.push(("ingest.dark".into(), format!("frame {}", path.display())))
        }
        None => {}
    }
    if let Some(f) = &plan.flat {
        n.push(("ingest.flat".into(), f.path.display().to_string()));
    }
    match &plan.power {
        Some(PowerCorrection::Region(r)) => n.push((
            "ingest.power_ref".into(),
            format!("x {}..{}, bins {}..{}", r.x0, r.x1, r.t0_bin, r.t1_bin),
        )),
        Some(PowerCorrection::Auto(_)) => n.push((
            "ingest.power_ref".into(),
            "auto (pixel integrals against the same pixels in the neighbouring rows)".into(),
        )),
        None => {}
    }
    if let Some(g) = &globals.gains {
        n.push(("ingest.power_gains".into(), json(serde_json::json!(g))));
    }
    if let Some((o, report)) = globals.power_report(plan) {
        let se: Vec<Option<f64>> = o.iter().map(|o| o.map(|o| o.std_error)).collect();
        n.push((
            "ingest.power_std_errors".into(),
            json(serde_json::json!(se)),
        ));
        n.extend(report_notes("power", &report));
    }
    if let Some(s) = &plan.sweep {
        n.push(("ingest.sweep".into(), s.source.to_string()));
        n.push((
            "ingest.sweep_edges_ps".into(),
            json(serde_json::json!(s.edges_ps)),
        ));
    }
    if let Some(t) = &plan.truth.jitter_shifts_ps {
        n.push((TRUE_JITTER_NOTE.into(), json(serde_json::json!(t))));
    }
    if let Some(s) = &globals.shifts_ps {
        n.push((JITTER_SHIFTS_NOTE.into(), json(serde_json::json!(s))));
        n.push(("ingest.jitter_rms_ps".into(), rms(s).to_string()));
    }
    if let Some((o, report)) = globals.jitter_report(plan) {
        let se: Vec<Option<f64>> = o.iter().map(|o| o.map(|o| o.std_error)).collect();
        n.push((
            "ingest.jitter_std_errors_ps".into(),
            json(serde_json::json!(se)),
        ));
        n.extend(report_notes("jitter", &report));
    }
    if let Some(s) = &plan.saturation {
        n.push((
            "ingest.saturation_level".into(),
            format!("{} ({})", s.level, s.source),
        ));
    }
    if !plan.missing.is_empty() {
        n.push((
            "ingest.missing_rows".into(),
            json(serde_json::json!(plan.missing)),
        ));
    }
    n
}

/// Cube note of the trigger delay ingest removed from each scanline, ps (a JSON list).
pub const JITTER_SHIFTS_NOTE: &str = "ingest.jitter_shifts_ps";

/// Cube note of each scanline's true trigger delay, ps (a JSON list), when a simulated
/// capture's manifest records it.
pub const TRUE_JITTER_NOTE: &str = "ingest.jitter_true_shifts_ps";

/// Root mean square of a list (0 for an empty one).
pub fn rms(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

/// `ingest.NAME_summary`, `ingest.NAME_truth` and `ingest.NAME_not_estimated` of a report.
fn report_notes(name: &str, r: &OffsetReport) -> Vec<(String, String)> {
    let mut n = vec![(format!("ingest.{name}_summary"), r.summary.clone())];
    if let Some(t) = &r.truth {
        n.push((format!("ingest.{name}_truth"), t.clone()));
    }
    if !r.not_estimated.is_empty() {
        n.push((
            format!("ingest.{name}_not_estimated"),
            r.not_estimated.join("; "),
        ));
    }
    n
}

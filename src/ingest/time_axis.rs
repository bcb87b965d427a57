//! The time axis of an ingest: which uniform camera-time axis the cube gets, and whether the
//! recorded rows are resampled onto it.
//!
//! A capture may record its own time axis: the manifest's `t0_ps` and `dt_ps` (uniform), or
//! the `.img` time table of its first scanline (HPD-TA's per-row times, uniform or not). The
//! axis of the cube is, in order:
//!
//! 1. the recorded axis: the manifest's, or the uniform axis over the `.img` table's interval
//!    with as many bins as rows (a table whose row widths vary by more than
//!    [`UNIFORM_TABLE_TOLERANCE`] is a non-linear sweep, and its rows are resampled onto
//!    that axis). A bin width or start given explicitly that contradicts it is refused
//!    ([`IngestError::AxisConflict`]), unless resampling was asked for
//!    ([`AxisRequest::resample`]): then the recorded rows are resampled onto the axis asked
//!    for;
//! 2. with no recorded axis, the bin width and start given explicitly;
//! 3. else the span of a sweep calibration table.
//!
//! No signal is dropped. Resampling ([`crate::resample::rebin_add`]) conserves a pixel's
//! integral only where the destination covers the recorded interval, so every axis that
//! rows are resampled onto is made to cover every recorded edge ([`cover`]): a start given
//! explicitly that lies after the first recorded edge is refused
//! ([`IngestError::StartAfterRecording`]); otherwise the axis is extended by whole bins on
//! either side (the grid keeps its bin boundaries). An axis that would need more than
//! [`MAX_BINS_PER_RECORDED_ROW`] bins per recorded row is refused
//! ([`IngestError::TooManyBins`]): finer bins than that carry no information and would
//! only fill memory (16 us of HPD-TA table on 10 ps bins is 1.6 million bins per pixel).
//!
//! Before this rule, `--dt-ps 10 --t0-ps 0` on a real HPD-TA file (a table of 512 rows over
//! 16 us) replaced the table's axis with 512 bins of 10 ps: the rows were resampled onto
//! 5.12 ns, which holds 16 % of the first 31 ns row, and the cube kept 3.0e5 of the file's
//! 7.06e9 counts.

use std::path::PathBuf;

use super::IngestError;
use crate::cube::TimeAxis;

/// Relative variation of the `.img` row spacing above which the sweep counts as non-linear.
pub const UNIFORM_TABLE_TOLERANCE: f64 = 1e-4;

/// Relative difference above which an explicit time-axis value contradicts the recorded one.
pub const AXIS_AGREEMENT_TOLERANCE: f64 = 1e-6;

/// Recorded edges this far (in output bins) past the output axis are rounding, not signal.
pub const COVER_SLACK_BINS: f64 = 1e-6;

/// Most output bins per recorded row that a resampling may produce.
pub const MAX_BINS_PER_RECORDED_ROW: usize = 16;

/// One of the two numbers of a uniform time axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisValue {
    /// The bin width, `dt_ps`.
    BinWidth,
    /// The start of bin 0, `t0_ps`.
    Start,
}

impl AxisValue {
    /// The option's name (`dt_ps`, `t0_ps`).
    pub fn option_name(self) -> &'static str {
        match self {
            AxisValue::BinWidth => "dt_ps",
            AxisValue::Start => "t0_ps",
        }
    }

    /// What the value is, in words.
    pub fn quantity(self) -> &'static str {
        match self {
            AxisValue::BinWidth => "bin width",
            AxisValue::Start => "start",
        }
    }
}

impl std::fmt::Display for AxisValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.option_name())
    }
}

/// Where the bin edges of recorded rows come from; its text (`Display`) names it in messages
/// and provenance.
#[derive(Clone, Debug, PartialEq)]
pub enum EdgesSource {
    /// The uniform axis of a manifest: `manifest PATH`.
    Manifest(PathBuf),
    /// The HPD-TA time table of a scanline: `.img time table of PATH` for an `.img` file,
    /// `HPD-TA TIFF time table of PATH` for a TIFF.
    ImgTable(PathBuf),
    /// A sweep calibration table given: `table PATH`.
    SweepTable(PathBuf),
    /// The sweep's bin times a manifest records (`[imperfections.sweep] bin_times_ps`):
    /// `sweep bin times of PATH`.
    ManifestSweep(PathBuf),
}

impl std::fmt::Display for EdgesSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EdgesSource::Manifest(p) => write!(f, "manifest {}", p.display()),
            EdgesSource::ImgTable(p) => {
                let img = p.extension().is_some_and(|e| e.eq_ignore_ascii_case("img"));
                let kind = if img { ".img" } else { "HPD-TA TIFF" };
                write!(f, "{kind} time table of {}", p.display())
            }
            EdgesSource::SweepTable(p) => write!(f, "table {}", p.display()),
            EdgesSource::ManifestSweep(p) => write!(f, "sweep bin times of {}", p.display()),
        }
    }
}

/// Bin edges of recorded rows, with where they come from.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedEdges {
    /// `nt + 1` increasing edges, ps.
    pub edges_ps: Vec<f64>,
    /// For messages and provenance.
    pub source: EdgesSource,
}

impl RecordedEdges {
    /// The edges of a uniform axis.
    pub fn uniform(axis: &TimeAxis, source: EdgesSource) -> RecordedEdges {
        RecordedEdges {
            edges_ps: (0..=axis.nt).map(|i| axis.bin_start_ps(i)).collect(),
            source,
        }
    }

    /// Number of recorded rows.
    pub fn nt(&self) -> usize {
        self.edges_ps.len() - 1
    }

    fn first(&self) -> f64 {
        self.edges_ps[0]
    }

    fn last(&self) -> f64 {
        self.edges_ps[self.nt()]
    }

    /// The uniform axis over the same interval with as many bins.
    pub fn span_axis(&self) -> TimeAxis {
        let nt = self.nt();
        TimeAxis {
            t0_ps: self.first(),
            dt_ps: (self.last() - self.first()) / nt as f64,
            nt,
        }
    }

    /// Narrowest and widest row, ps.
    pub fn width_range_ps(&self) -> (f64, f64) {
        self.edges_ps
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold((f64::MAX, f64::MIN), |(lo, hi), d| (lo.min(d), hi.max(d)))
    }

    /// Whether every row is as wide as the mean within [`UNIFORM_TABLE_TOLERANCE`].
    pub fn is_uniform(&self) -> bool {
        edges_are_uniform(&self.edges_ps)
    }
}

/// Whether every interval between `edges_ps` (at least two, increasing) is as wide as their
/// mean within [`UNIFORM_TABLE_TOLERANCE`].
pub fn edges_are_uniform(edges_ps: &[f64]) -> bool {
    let n = edges_ps.len() - 1;
    let mean = (edges_ps[n] - edges_ps[0]) / n as f64;
    edges_ps
        .windows(2)
        .all(|w| ((w[1] - w[0]) / mean - 1.0).abs() <= UNIFORM_TABLE_TOLERANCE)
}

/// The time axis the capture records.
#[derive(Clone, Debug, PartialEq)]
pub struct Recorded {
    /// The recorded rows' edges.
    pub edges: RecordedEdges,
    /// The uniform axis they define (the manifest's, or [`RecordedEdges::span_axis`]).
    pub axis: TimeAxis,
}

/// What was asked for.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AxisRequest {
    /// Bin width, ps.
    pub dt_ps: Option<f64>,
    /// Start of bin 0, ps.
    pub t0_ps: Option<f64>,
    /// Resample the recorded rows onto the bin width and start asked for where they
    /// contradict the recorded axis (instead of refusing them).
    pub resample: bool,
}

/// The axis of the cube, resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct ResolvedAxis {
    /// The uniform camera-time axis of the cube.
    pub out_axis: TimeAxis,
    /// The edges the recorded rows are resampled from, when they are resampled.
    pub resample_from: Option<RecordedEdges>,
    /// Which axis was used and where it came from, for provenance.
    pub description: String,
}

/// Resolve the axis of the cube from the recorded axis (if any), a sweep calibration table
/// (if any: the true edges of the recorded rows, which replace the recorded ones as the
/// edges to resample from) and what was asked for. `input` names the capture in messages.
pub fn resolve(
    recorded: Option<&Recorded>,
    sweep_table: Option<&RecordedEdges>,
    request: &AxisRequest,
    nt_recorded: usize,
    input: &str,
) -> Result<ResolvedAxis, IngestError> {
    if let Some(rec) = recorded {
        match check_agrees(request, rec) {
            Err(e) if !request.resample => return Err(e),
            Err(_) => {
                // Resampling asked for: onto the axis asked for, with as many bins as cover
                // the recorded rows.
                let from = sweep_table.cloned().unwrap_or_else(|| rec.edges.clone());
                let start = TimeAxis {
                    t0_ps: request.t0_ps.unwrap_or(rec.axis.t0_ps),
                    dt_ps: request.dt_ps.unwrap_or(rec.axis.dt_ps),
                    nt: 0,
                };
                let out_axis = cover(start, &from, request.t0_ps.is_some(), nt_recorded)?;
                let description = format!(
                    "{}{}, resampled onto {} as asked ({})",
                    rec.edges.source,
                    shape_of(&rec.edges),
                    axis_words(&out_axis),
                    asked_words(request),
                );
                return Ok(ResolvedAxis {
                    out_axis,
                    resample_from: Some(from),
                    description,
                });
            }
            Ok(()) => {}
        }
        let (from, description) = match sweep_table {
            Some(table) => (Some(table.clone()), rec.edges.source.to_string()),
            None if rec.edges.is_uniform() => (None, rec.edges.source.to_string()),
            None => (
                Some(rec.edges.clone()),
                format!(
                    "{}{}, resampled onto {}",
                    rec.edges.source,
                    shape_of(&rec.edges),
                    axis_words(&rec.axis)
                ),
            ),
        };
        return finish(rec.axis, from, description, false, nt_recorded);
    }
    if request.resample {
        return Err(IngestError::NothingToResample {
            input: input.to_string(),
        });
    }
    match (request.dt_ps, request.t0_ps, sweep_table) {
        (Some(dt_ps), Some(t0_ps), table) => {
            let axis = TimeAxis {
                t0_ps,
                dt_ps,
                nt: nt_recorded,
            };
            let description = "given bin width and start".to_string();
            finish(axis, table.cloned(), description, true, nt_recorded)
        }
        (dt_ps, t0_ps, Some(table)) => {
            let span = table.span_axis();
            let axis = TimeAxis {
                t0_ps: t0_ps.unwrap_or(span.t0_ps),
                dt_ps: dt_ps.unwrap_or(span.dt_ps),
                nt: span.nt,
            };
            let description = format!("span of the sweep table {}", table.source);
            finish(
                axis,
                Some(table.clone()),
                description,
                t0_ps.is_some(),
                nt_recorded,
            )
        }
        _ => Err(IngestError::NoTimeAxis {
            input: input.to_string(),
        }),
    }
}

/// The axis `axis`, covering `from` when rows are resampled from it (extended by whole bins,
/// or refused where `t0_pinned`), with its description.
fn finish(
    axis: TimeAxis,
    from: Option<RecordedEdges>,
    description: String,
    t0_pinned: bool,
    nt_recorded: usize,
) -> Result<ResolvedAxis, IngestError> {
    let Some(from) = from else {
        return Ok(ResolvedAxis {
            out_axis: axis,
            resample_from: None,
            description,
        });
    };
    let out_axis = cover(axis, &from, t0_pinned, nt_recorded)?;
    let description = if out_axis == axis {
        description
    } else {
        format!(
            "{description}, extended to {} to cover the recorded rows of {}",
            axis_words(&out_axis),
            from.source
        )
    };
    Ok(ResolvedAxis {
        out_axis,
        resample_from: Some(from),
        description,
    })
}

/// `axis` (bin width and grid kept) extended so that it covers every edge of `from`: bins
/// are added before the start unless `t0_pinned` (then a start after the first edge is
/// refused) and after the end as needed; at least `axis.nt` bins. Refused when that takes
/// more than [`MAX_BINS_PER_RECORDED_ROW`] bins per recorded row (`nt_recorded`).
pub fn cover(
    axis: TimeAxis,
    from: &RecordedEdges,
    t0_pinned: bool,
    nt_recorded: usize,
) -> Result<TimeAxis, IngestError> {
    let dt = axis.dt_ps;
    let mut t0 = axis.t0_ps;
    let mut nt = axis.nt;
    let before_bins = (t0 - from.first()) / dt;
    if before_bins > COVER_SLACK_BINS {
        if t0_pinned {
            return Err(IngestError::StartAfterRecording {
                t0_ps: t0,
                first_edge_ps: from.first(),
                source_name: from.source.to_string(),
            });
        }
        let k = (before_bins - COVER_SLACK_BINS).ceil();
        t0 -= k * dt;
        nt += k as usize;
    }
    let needed = ((from.last() - t0) / dt - COVER_SLACK_BINS).ceil().max(1.0);
    let max = MAX_BINS_PER_RECORDED_ROW * nt_recorded.max(1);
    if needed > max as f64 {
        return Err(IngestError::TooManyBins {
            dt_ps: dt,
            first_edge_ps: from.first(),
            last_edge_ps: from.last(),
            needed: needed as u64,
            max,
            source_name: from.source.to_string(),
        });
    }
    Ok(TimeAxis {
        t0_ps: t0,
        dt_ps: dt,
        nt: nt.max(needed as usize),
    })
}

/// Whether the values asked for agree with the recorded axis.
fn check_agrees(request: &AxisRequest, rec: &Recorded) -> Result<(), IngestError> {
    agree(
        AxisValue::BinWidth,
        request.dt_ps,
        rec.axis.dt_ps,
        &rec.edges.source,
    )?;
    agree(
        AxisValue::Start,
        request.t0_ps,
        rec.axis.t0_ps,
        &rec.edges.source,
    )
}

/// Check an explicit axis value against the recorded one.
fn agree(
    what: AxisValue,
    given: Option<f64>,
    recorded: f64,
    source: &EdgesSource,
) -> Result<(), IngestError> {
    match given {
        Some(g) if (g - recorded).abs() > AXIS_AGREEMENT_TOLERANCE * recorded.abs().max(1.0) => {
            Err(IngestError::AxisConflict {
                what,
                given: g,
                source_name: source.to_string(),
                recorded,
            })
        }
        _ => Ok(()),
    }
}

/// ` (non-uniform: rows A to B ps wide)` for a non-linear table, else nothing.
fn shape_of(edges: &RecordedEdges) -> String {
    if edges.is_uniform() {
        String::new()
    } else {
        let (lo, hi) = edges.width_range_ps();
        format!(" (non-uniform: rows {lo:.6} to {hi:.6} ps wide)")
    }
}

/// `N bins of D ps from T ps`.
fn axis_words(axis: &TimeAxis) -> String {
    format!(
        "{} bins of {} ps from {} ps",
        axis.nt, axis.dt_ps, axis.t0_ps
    )
}

/// `dt_ps D, t0_ps T` for the values given.
fn asked_words(request: &AxisRequest) -> String {
    let mut parts = Vec::new();
    if let Some(v) = request.dt_ps {
        parts.push(format!("{} {v}", AxisValue::BinWidth));
    }
    if let Some(v) = request.t0_ps {
        parts.push(format!("{} {v}", AxisValue::Start));
    }
    parts.join(", ")
}

/// Bin edges from the start time of each bin (`n >= 2` increasing values): the starts, then
/// the last start plus the last spacing.
pub fn edges_from_starts(starts_ps: &[f64]) -> Vec<f64> {
    let n = starts_ps.len();
    let mut edges = starts_ps.to_vec();
    edges.push(starts_ps[n - 1] + (starts_ps[n - 1] - starts_ps[n - 2]));
    edges
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(starts: &[f64]) -> Recorded {
        let edges = RecordedEdges {
            edges_ps: edges_from_starts(starts),
            source: EdgesSource::ImgTable("t.img".into()),
        };
        Recorded {
            axis: edges.span_axis(),
            edges,
        }
    }

    /// Rows widening from 10 to 12 ps over 8 rows: non-uniform.
    fn widening() -> Recorded {
        let mut starts = vec![0.0];
        for i in 0..7 {
            starts.push(starts[i] + 10.0 + 2.0 * i as f64 / 7.0);
        }
        table(&starts)
    }

    fn request(dt_ps: Option<f64>, t0_ps: Option<f64>, resample: bool) -> AxisRequest {
        AxisRequest {
            dt_ps,
            t0_ps,
            resample,
        }
    }

    #[test]
    fn contradicting_values_are_refused_without_resampling() {
        let rec = widening();
        for (req, what) in [
            (request(Some(10.0), None, false), AxisValue::BinWidth),
            (request(None, Some(5.0), false), AxisValue::Start),
        ] {
            match resolve(Some(&rec), None, &req, 8, "x") {
                Err(IngestError::AxisConflict { what: w, .. }) => assert_eq!(w, what),
                other => panic!("{req:?}: {other:?}"),
            }
        }
        // Values that agree are accepted, and the non-linear table is resampled onto its span.
        let span = rec.axis;
        let r = resolve(
            Some(&rec),
            None,
            &request(Some(span.dt_ps), Some(span.t0_ps), false),
            8,
            "x",
        )
        .unwrap();
        assert_eq!(r.out_axis, span);
        assert!(r.resample_from.is_some());
        assert!(r.description.contains("non-uniform"), "{}", r.description);
    }

    #[test]
    fn resampling_covers_every_recorded_edge() {
        let rec = widening();
        let last = *rec.edges.edges_ps.last().unwrap();
        let r = resolve(
            Some(&rec),
            None,
            &request(Some(3.0), Some(-1.0), true),
            8,
            "x",
        )
        .unwrap();
        assert_eq!(r.out_axis.t0_ps, -1.0);
        assert_eq!(r.out_axis.dt_ps, 3.0);
        // The end covers the last edge, by less than one bin.
        assert!(r.out_axis.end_ps() >= last && r.out_axis.end_ps() < last + 3.0);
        assert!(r.description.contains("as asked (dt_ps 3, t0_ps -1)"));
        // A start after the first edge would drop the first rows: refused.
        assert!(matches!(
            resolve(
                Some(&rec),
                None,
                &request(Some(3.0), Some(2.0), true),
                8,
                "x"
            ),
            Err(IngestError::StartAfterRecording { .. })
        ));
        // More than 16 bins per recorded row: refused (8 rows, 85 ps, 0.5 ps bins).
        assert!(matches!(
            resolve(Some(&rec), None, &request(Some(0.5), None, true), 8, "x"),
            Err(IngestError::TooManyBins { max: 128, .. })
        ));
    }

    #[test]
    fn a_sweep_table_past_the_recorded_axis_extends_it_by_whole_bins() {
        let axis = TimeAxis {
            t0_ps: 0.0,
            dt_ps: 2.0,
            nt: 4,
        };
        let rec = Recorded {
            edges: RecordedEdges::uniform(&axis, EdgesSource::Manifest("m".into())),
            axis,
        };
        let sweep = RecordedEdges {
            edges_ps: vec![-3.0, 1.0, 4.0, 6.5, 9.5],
            source: EdgesSource::SweepTable("s".into()),
        };
        let r = resolve(Some(&rec), Some(&sweep), &AxisRequest::default(), 4, "x").unwrap();
        // Two bins before (down to -4), one after (up to 10).
        assert_eq!(
            r.out_axis,
            TimeAxis {
                t0_ps: -4.0,
                dt_ps: 2.0,
                nt: 7
            }
        );
        assert!(r.description.contains("extended"), "{}", r.description);
        // A table within the axis changes nothing.
        let inside = RecordedEdges {
            edges_ps: vec![0.0, 1.0, 4.0, 6.5, 8.0],
            source: EdgesSource::SweepTable("s".into()),
        };
        let r = resolve(Some(&rec), Some(&inside), &AxisRequest::default(), 4, "x").unwrap();
        assert_eq!(r.out_axis, axis);
    }

    #[test]
    fn edge_sources_read_as_the_files_record_them() {
        for (source, text) in [
            (
                EdgesSource::Manifest("c/manifest.toml".into()),
                "manifest c/manifest.toml",
            ),
            (
                EdgesSource::ImgTable("s_0.img".into()),
                ".img time table of s_0.img",
            ),
            (
                EdgesSource::SweepTable("sweep.csv".into()),
                "table sweep.csv",
            ),
            (
                EdgesSource::ManifestSweep("c/manifest.toml".into()),
                "sweep bin times of c/manifest.toml",
            ),
        ] {
            assert_eq!(source.to_string(), text);
        }
    }

    #[test]
    fn resampling_without_a_recorded_axis_is_refused() {
        assert!(matches!(
            resolve(None, None, &request(Some(1.0), Some(0.0), true), 8, "x"),
            Err(IngestError::NothingToResample { .. })
        ));
        assert!(matches!(
            resolve(None, None, &request(Some(1.0), None, false), 8, "x"),
            Err(IngestError::NoTimeAxis { .. })
        ));
    }
}

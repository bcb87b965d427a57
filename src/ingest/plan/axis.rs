//! The time-axis decision of a plan: where the recorded rows' axis comes from
//! ([`AxisSource`]: the manifest, the `.img` time table of the reference scanline, or nothing
//! recorded), the true edges of a sweep calibration (a table given, or the manifest's bin
//! times), and the cube's uniform axis that [`crate::ingest::time_axis::resolve`] makes of
//! them with the values asked for.

use std::path::{Path, PathBuf};

use super::corrections::SweepCorrection;
use super::options::IngestOptions;
use crate::cube::TimeAxis;
use crate::formats::StreakImage;
use crate::ingest::corrections::check_sweep_edges;
use crate::ingest::time_axis::{
    self, edges_from_starts, AxisRequest, EdgesSource, Recorded, RecordedEdges,
};
use crate::ingest::IngestError;
use crate::manifest::Manifest;

/// Where the time axis of the recorded rows comes from, with what that source gives.
#[derive(Clone, Debug, PartialEq)]
pub enum AxisSource {
    /// The manifest's uniform axis (`[capture] t0_ps`, `dt_ps`, and the rows of the files).
    Manifest { manifest: PathBuf, axis: TimeAxis },
    /// The `.img` time table of the reference scanline: the start of each row's bin, ps
    /// (two or more).
    ImgTable {
        reference: PathBuf,
        starts_ps: Vec<f64>,
    },
    /// The reference is an HPD-TA `.img` file that does not calibrate its time axis (a pixel
    /// axis, or a bare sweep-range index with no table): the bin width must be given (the
    /// start defaults to 0 ps), or a sweep table's span decides. `reason` names the header
    /// keys ([`crate::formats::hamamatsu::ImgMeta::uncalibrated_time`]).
    ImgUncalibrated { reference: PathBuf, reason: String },
    /// Nothing recorded: the bin width and start given, or a sweep table's span, decide.
    NotRecorded,
}

impl AxisSource {
    /// The manifest's axis when there is a manifest (its `nx` and `nt` checked against the
    /// reference scanline `probe`, read from `reference`), else the reference's `.img` time
    /// table when it has two rows or more, else nothing recorded.
    pub fn of(
        manifest: Option<&(Manifest, PathBuf)>,
        probe: &StreakImage,
        reference: &Path,
    ) -> Result<AxisSource, IngestError> {
        if let Some((m, mpath)) = manifest {
            let c = &m.capture;
            for (what, want, found) in [("nx", c.nx, probe.nx), ("nt", c.nt, probe.nt)] {
                if want != found {
                    return Err(IngestError::ManifestSize {
                        manifest: mpath.clone(),
                        what: what.into(),
                        manifest_value: want,
                        file: reference.to_path_buf(),
                        found,
                    });
                }
            }
            let axis = TimeAxis {
                t0_ps: c.t0_ps,
                dt_ps: c.dt_ps,
                nt: probe.nt,
            };
            return Ok(AxisSource::Manifest {
                manifest: mpath.clone(),
                axis,
            });
        }
        Ok(
            match (
                probe.time_axis_ps.as_ref().filter(|t| t.len() >= 2),
                &probe.img_meta,
            ) {
                (Some(table), _) => AxisSource::ImgTable {
                    reference: reference.to_path_buf(),
                    starts_ps: table.clone(),
                },
                (None, Some(meta)) if probe.time_axis_ps.is_none() => AxisSource::ImgUncalibrated {
                    reference: reference.to_path_buf(),
                    reason: meta
                        .time_uncalibrated
                        .clone()
                        .unwrap_or_else(|| meta.uncalibrated_time()),
                },
                (None, _) => AxisSource::NotRecorded,
            },
        )
    }

    /// The recorded axis and its edges (the `.img` table's starts become edges, the last
    /// row's end one spacing after its start; its axis is their span).
    pub fn recorded(&self) -> Option<Recorded> {
        match self {
            AxisSource::Manifest { manifest, axis } => Some(Recorded {
                edges: RecordedEdges::uniform(axis, EdgesSource::Manifest(manifest.clone())),
                axis: *axis,
            }),
            AxisSource::ImgTable {
                reference,
                starts_ps,
            } => {
                let edges = RecordedEdges {
                    edges_ps: edges_from_starts(starts_ps),
                    source: EdgesSource::ImgTable(reference.clone()),
                };
                Some(Recorded {
                    axis: edges.span_axis(),
                    edges,
                })
            }
            AxisSource::ImgUncalibrated { .. } | AxisSource::NotRecorded => None,
        }
    }

    /// The `.img` time table (bin starts, ps) when it gave the axis.
    pub fn img_time_table_ps(&self) -> Option<&[f64]> {
        match self {
            AxisSource::ImgTable { starts_ps, .. } => Some(starts_ps),
            _ => None,
        }
    }
}

/// The true camera time of each recorded row edge: the sweep table given (read, and checked
/// for `nt + 1` increasing edges), else the manifest's sweep bin times (`from_manifest`),
/// else none.
pub fn sweep_edges(
    table: Option<&Path>,
    from_manifest: Option<RecordedEdges>,
    nt: usize,
) -> Result<Option<RecordedEdges>, IngestError> {
    let Some(path) = table else {
        return Ok(from_manifest);
    };
    let edges_ps = read_sweep_table(path)?;
    check_sweep_edges(&edges_ps, nt).map_err(|source| IngestError::Correction {
        what: path.display().to_string(),
        source,
    })?;
    Ok(Some(RecordedEdges {
        edges_ps,
        source: EdgesSource::SweepTable(path.to_path_buf()),
    }))
}

/// The time axis of a plan, decided.
#[derive(Clone, Debug, PartialEq)]
pub struct TimeDecision {
    /// The uniform camera-time axis of the output cube.
    pub out_axis: TimeAxis,
    /// Which axis was used and where it comes from (for provenance).
    pub description: String,
    /// The resampling of the recorded rows onto `out_axis`, when they are resampled.
    pub sweep: Option<SweepCorrection>,
    /// The `.img` time table every scanline's must agree with: the reference's when it gave
    /// the axis and no sweep table replaces it.
    pub img_time_table_ps: Option<Vec<f64>>,
}

/// Decide the cube's axis from `source`, the sweep edges (if any) and the values `options`
/// ask for; `nt` recorded rows, `input` names the capture in messages.
pub fn decide(
    source: &AxisSource,
    sweep: Option<RecordedEdges>,
    options: &IngestOptions,
    nt: usize,
    input: &str,
) -> Result<TimeDecision, IngestError> {
    let mut request = AxisRequest {
        dt_ps: options.dt_ps,
        t0_ps: options.t0_ps,
        resample: options.resample_time,
    };
    let mut uncalibrated_note = None;
    if let AxisSource::ImgUncalibrated { reference, reason } = source {
        if request.dt_ps.is_none() && sweep.is_none() {
            return Err(IngestError::ImgTimeUncalibrated {
                path: reference.clone(),
                reason: reason.clone(),
            });
        }
        if request.dt_ps.is_some() && request.t0_ps.is_none() {
            request.t0_ps = Some(0.0);
        }
        uncalibrated_note = Some(format!(
            " (the time axis of {} is not calibrated: {reason})",
            reference.display()
        ));
    }
    let mut resolved = time_axis::resolve(
        source.recorded().as_ref(),
        sweep.as_ref(),
        &request,
        nt,
        input,
    )?;
    if let Some(note) = uncalibrated_note {
        resolved.description.push_str(&note);
    }
    Ok(TimeDecision {
        out_axis: resolved.out_axis,
        description: resolved.description,
        sweep: resolved.resample_from.map(|e| SweepCorrection {
            edges_ps: e.edges_ps,
            source: e.source,
        }),
        // A sweep table replaces the files' own tables, which then need not agree.
        img_time_table_ps: source
            .img_time_table_ps()
            .filter(|_| sweep.is_none())
            .map(<[f64]>::to_vec),
    })
}

/// Read a sweep calibration table: numbers separated by commas, blanks or new lines; `#`
/// starts a comment; a first line with no number is a header.
pub fn read_sweep_table(path: &Path) -> Result<Vec<f64>, IngestError> {
    let text = std::fs::read_to_string(path).map_err(|e| IngestError::SweepTable {
        path: path.to_path_buf(),
        line: 0,
        message: e.to_string(),
    })?;
    let mut values = Vec::new();
    let mut seen_data = false;
    for (i, line) in text.lines().enumerate() {
        let content = line.split('#').next().unwrap_or("");
        let tokens: Vec<&str> = content
            .split(|c: char| c == ',' || c == ';' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .collect();
        if tokens.is_empty() {
            continue;
        }
        let parsed: Vec<Option<f64>> = tokens.iter().map(|t| t.parse::<f64>().ok()).collect();
        if !seen_data && parsed.iter().all(Option::is_none) {
            // A header line.
            seen_data = true;
            continue;
        }
        seen_data = true;
        for (t, v) in tokens.iter().zip(parsed) {
            match v {
                Some(v) => values.push(v),
                None => {
                    return Err(IngestError::SweepTable {
                        path: path.to_path_buf(),
                        line: i + 1,
                        message: format!("'{t}' is not a number (edge times in ps)"),
                    })
                }
            }
        }
    }
    Ok(values)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweep_tables_accept_csv_headers_and_comments() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sweep.csv");
        std::fs::write(
            &p,
            "edge_ps\n# calibration of 2013-07-01\n0.0\n1.5, 3.25\n4 5e0\n",
        )
        .unwrap();
        assert_eq!(read_sweep_table(&p).unwrap(), [0.0, 1.5, 3.25, 4.0, 5.0]);
        std::fs::write(&p, "0.0\n1.5\nx\n").unwrap();
        let e = read_sweep_table(&p).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("'x'"), "{e}");
    }

    fn probe(nx: usize, nt: usize, table: Option<Vec<f64>>) -> StreakImage {
        let mut img = StreakImage::new(nx, nt, vec![0.0; nx * nt]);
        img.time_axis_ps = table;
        img
    }

    #[test]
    fn the_manifest_axis_comes_first_and_its_sizes_must_match() {
        let m = (
            super::super::test_manifest(4, 3),
            PathBuf::from("c/manifest.toml"),
        );
        let table = Some(vec![0.0, 1.0, 2.0]);
        let source = AxisSource::of(Some(&m), &probe(4, 3, table.clone()), Path::new("s0.img"));
        let axis = TimeAxis {
            t0_ps: -1.0,
            dt_ps: 2.0,
            nt: 3,
        };
        assert_eq!(
            source.unwrap(),
            AxisSource::Manifest {
                manifest: "c/manifest.toml".into(),
                axis
            }
        );
        let e = AxisSource::of(Some(&m), &probe(4, 5, None), Path::new("s0.exr")).unwrap_err();
        assert!(
            matches!(&e, IngestError::ManifestSize { what, manifest_value: 3, found: 5, .. } if what == "nt"),
            "{e:?}"
        );
        let e = AxisSource::of(Some(&m), &probe(6, 3, None), Path::new("s0.exr")).unwrap_err();
        assert!(
            matches!(&e, IngestError::ManifestSize { what, .. } if what == "nx"),
            "{e:?}"
        );
    }

    #[test]
    fn without_a_manifest_an_img_table_of_two_rows_gives_the_axis() {
        let table = vec![10.0, 12.0, 14.0];
        let source =
            AxisSource::of(None, &probe(2, 3, Some(table.clone())), Path::new("a.img")).unwrap();
        assert_eq!(source.img_time_table_ps(), Some(&table[..]));
        let rec = source.recorded().unwrap();
        assert_eq!(rec.edges.edges_ps, [10.0, 12.0, 14.0, 16.0]);
        assert_eq!(rec.edges.source.to_string(), ".img time table of a.img");
        assert_eq!(
            (rec.axis.t0_ps, rec.axis.dt_ps, rec.axis.nt),
            (10.0, 2.0, 3)
        );
        // One row is no table; none is nothing recorded.
        for table in [Some(vec![5.0]), None] {
            let s = AxisSource::of(None, &probe(2, 1, table), Path::new("a.img")).unwrap();
            assert_eq!(s, AxisSource::NotRecorded);
            assert_eq!(s.recorded(), None);
            assert_eq!(s.img_time_table_ps(), None);
        }
    }

    #[test]
    fn an_img_without_a_time_calibration_needs_the_bin_width_only() {
        let source = AxisSource::ImgUncalibrated {
            reference: "focus.img".into(),
            reason: "[Scaling] ScalingYType=1 with ScalingYUnit=\"\" (sensor rows)".into(),
        };
        assert_eq!(source.recorded(), None);
        assert_eq!(source.img_time_table_ps(), None);
        let e = decide(&source, None, &IngestOptions::default(), 4, "x").unwrap_err();
        assert!(
            matches!(&e, IngestError::ImgTimeUncalibrated { path, reason }
                if path == Path::new("focus.img") && reason.contains("ScalingYType=1")),
            "{e:?}"
        );
        let options = IngestOptions {
            dt_ps: Some(2.5),
            ..IngestOptions::default()
        };
        let d = decide(&source, None, &options, 4, "x").unwrap();
        let want = TimeAxis {
            t0_ps: 0.0,
            dt_ps: 2.5,
            nt: 4,
        };
        assert_eq!(d.out_axis, want);
        assert!(
            d.description.contains("not calibrated"),
            "{}",
            d.description
        );
        let options = IngestOptions {
            dt_ps: Some(2.5),
            t0_ps: Some(-7.0),
            ..IngestOptions::default()
        };
        assert_eq!(
            decide(&source, None, &options, 4, "x")
                .unwrap()
                .out_axis
                .t0_ps,
            -7.0
        );
    }

    #[test]
    fn a_sweep_table_given_replaces_the_manifests_and_is_checked() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sweep.csv");
        std::fs::write(&p, "0\n1\n2.5\n4\n").unwrap();
        let manifest = RecordedEdges {
            edges_ps: vec![0.0, 1.0, 2.0, 3.0],
            source: EdgesSource::ManifestSweep("m.toml".into()),
        };
        assert_eq!(
            sweep_edges(None, Some(manifest.clone()), 3).unwrap(),
            Some(manifest.clone())
        );
        assert_eq!(sweep_edges(None, None, 3).unwrap(), None);
        let given = sweep_edges(Some(&p), Some(manifest), 3).unwrap().unwrap();
        assert_eq!(given.edges_ps, [0.0, 1.0, 2.5, 4.0]);
        assert_eq!(given.source, EdgesSource::SweepTable(p.clone()));
        // Four edges for five rows: refused, naming the table.
        let e = sweep_edges(Some(&p), None, 5).unwrap_err().to_string();
        assert!(e.starts_with(&p.display().to_string()), "{e}");
    }

    #[test]
    fn an_img_table_is_kept_for_agreement_only_without_sweep_edges() {
        let source = AxisSource::ImgTable {
            reference: "a.img".into(),
            starts_ps: vec![0.0, 2.0, 4.0],
        };
        let options = IngestOptions::default();
        let d = decide(&source, None, &options, 3, "x").unwrap();
        assert_eq!(d.img_time_table_ps, Some(vec![0.0, 2.0, 4.0]));
        assert_eq!(d.sweep, None);
        assert_eq!(d.description, ".img time table of a.img");
        let sweep = RecordedEdges {
            edges_ps: vec![0.0, 2.5, 4.0, 6.0],
            source: EdgesSource::SweepTable("s.csv".into()),
        };
        let d = decide(&source, Some(sweep.clone()), &options, 3, "x").unwrap();
        assert_eq!(d.img_time_table_ps, None);
        assert_eq!(
            d.sweep,
            Some(SweepCorrection {
                edges_ps: sweep.edges_ps,
                source: sweep.source
            })
        );
        // Nothing recorded and nothing given: refused.
        let e = decide(&AxisSource::NotRecorded, None, &options, 3, "x").unwrap_err();
        assert!(matches!(e, IngestError::NoTimeAxis { .. }), "{e:?}");
    }
}

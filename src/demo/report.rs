//! The demo's Markdown report: every figure file with its parameters, the calibration errors
//! against the calibrate issue's tolerances, and the time of every stage. A pure function of
//! the [`DemoSummary`]; the caller writes the text.

use super::{DemoSummary, OutputKind};
use std::fmt::Write;

/// Seed figures in the order the report shows them, with a heading each.
const FIGURES: [(&str, &str); 5] = [
    (
        "fig4",
        "Figure 4: naive re-projection against per-view re-warping, and isochrones",
    ),
    (
        "fig5",
        "Figure 5: each relativistic effect alone, at increasing speed",
    ),
    (
        "fig6",
        "Figure 6: approaching the cube scene at up to beta = 0.77",
    ),
    (
        "fig7",
        "Figure 7: approaching the Cornell box with the bunny",
    ),
    ("fig8", "Figure 8: a rotating sensor"),
];

/// Table cells may not hold a `|` or a line break.
fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

fn pass(ok: bool) -> &'static str {
    if ok {
        "yes"
    } else {
        "**no**"
    }
}

/// The report's Markdown text.
pub fn markdown(summary: &DemoSummary) -> String {
    let mut md = String::new();
    let s = &summary.sizes;
    let _ = writeln!(md, "# femto demo report\n");
    let _ = writeln!(
        md,
        "`femto demo{}` ran the whole chain (simulate, ingest, calibrate, unwarp, pyramid, \
         render) in {:.1} s on {} thread{}. Capture: {} x {} pixels, {} bins of {} ps, {} \
         samples per pixel, at most {} bounces, realistic flaws (photon noise, dark signal, \
         vignetting, trigger jitter, laser power drift, sweep non-linearity). Stills {} x {}, \
         videos {} x {} with {} frames at {} fps.\n",
        if summary.quick { " --quick" } else { "" },
        summary.total_seconds,
        summary.threads,
        if summary.threads == 1 { "" } else { "s" },
        s.capture_nx,
        s.capture_ny,
        s.nt,
        s.dt_ps,
        s.spp,
        s.max_bounces,
        s.still_width,
        s.still_height,
        s.video_width,
        s.video_height,
        s.video_frames,
        s.fps,
    );

    calibration_section(&mut md, summary);
    figure_sections(&mut md, summary);

    let _ = writeln!(md, "## Stages\n\n| stage | seconds |\n|---|---|");
    for st in &summary.stages {
        let _ = writeln!(md, "| {} | {:.2} |", cell(&st.stage), st.seconds);
    }
    let _ = writeln!(md, "| *total* | {:.2} |\n", summary.total_seconds);

    let _ = writeln!(
        md,
        "## Explore it\n\nFly through this light in the browser, from this folder \
         (docs/view.md):\n\n```sh\nfemto view --cube data/world.h5 --calibration \
         data/calibration.toml --mesh data/capture/scene.glb --open\n```\n\nIt prints a URL \
         with this run's token; open it (through an SSH tunnel from another machine).\n"
    );
    let _ = writeln!(md, "## Data\n");
    for f in &summary.data_files {
        let _ = writeln!(md, "- `{f}`");
    }
    let _ = writeln!(
        md,
        "\nMachine-readable: [`{}`]({}).",
        summary.summary_json, summary.summary_json
    );
    md
}

/// The report's "Calibration errors" section: the table of errors against the tolerances
/// and a line per scene on the fit.
fn calibration_section(md: &mut String, summary: &DemoSummary) {
    let s = &summary.sizes;
    let t = &summary.tolerances;
    let _ = writeln!(md, "## Calibration errors\n");
    let _ = writeln!(
        md,
        "The fitted calibration against the simulator's true one (`data/capture/calibration.toml`). \
         Position error per metre of the distance from the camera to the fiducials' centroid; \
         rotation: angle of the rotation between the fitted and the true orientation; focal: the \
         larger relative error of fx and fy; t0: in time bins of the ingested cube.\n"
    );
    let _ = writeln!(
        md,
        "| scene | position (mm/m) | rotation (deg) | focal (%) | t0 (bins) | within tolerance |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|");
    let _ = writeln!(
        md,
        "| *tolerance* | {} | {} | {} | {} | |",
        t.position_mm_per_m, t.rotation_deg, t.focal_percent, t.t0_bins
    );
    for c in &summary.calibrations {
        let _ = writeln!(
            md,
            "| {} | {:.3} | {:.4} | {:.3} | {:.3} | {} |",
            cell(&c.scene),
            c.position_error_mm_per_m,
            c.rotation_error_deg,
            c.focal_error_percent,
            c.t0_error_bins,
            pass(c.within_tolerance)
        );
    }
    let _ = writeln!(md);
    for c in &summary.calibrations {
        let _ = writeln!(
            md,
            "- **{}**: {} fiducials detected in a {} x {} image of the capture camera (same pose \
             and field of view; intrinsics scaled to the capture's {} x {}), {} px (of that \
             image) of Gaussian noise added to each coordinate; fit RMS {:.3} px of that image, \
             {:.3} px of the capture (the figure `femto calibrate` prints), {} outliers. Camera \
             {:.3} m from the fiducials' centroid, off by {:.3} mm. t0 fitted {:.3} ps (true \
             {:.3} ps, bins of {} ps) from the direct light of {} pixels ({} inliers, RMS {:.3} \
             ps).",
            cell(&c.scene),
            c.fiducials,
            c.fiducial_width,
            c.fiducial_height,
            s.capture_nx,
            s.capture_ny,
            c.noise_px,
            c.rms_px,
            c.rms_capture_px,
            c.outliers,
            c.camera_distance_m,
            c.position_error_mm,
            c.t0_fit_ps,
            c.t0_true_ps,
            c.dt_ps,
            c.arrival_samples,
            c.arrival_inliers,
            c.t0_rms_ps
        );
    }
    let _ = writeln!(md);
}

/// The report's section per figure ([`FIGURES`] order): each output with its caption and
/// parameter table; a figure with no output is left out, but Fig. 7 says how to run it.
fn figure_sections(md: &mut String, summary: &DemoSummary) {
    for (fig, heading) in FIGURES {
        let files: Vec<_> = summary.outputs.iter().filter(|o| o.figure == fig).collect();
        if files.is_empty() {
            if fig == "fig7" {
                let _ = writeln!(
                    md,
                    "## {heading}\n\nNot run: give a bunny mesh with `--bunny PATH` (e.g. the \
                     Stanford bunny OBJ).\n"
                );
            }
            continue;
        }
        let _ = writeln!(md, "## {heading}\n");
        for o in files {
            match o.kind {
                OutputKind::Video => {
                    let _ = writeln!(md, "### [{}]({})\n\n{}\n", o.path, o.path, o.caption);
                }
                OutputKind::Image | OutputKind::Sheet => {
                    let _ = writeln!(
                        md,
                        "### {}\n\n![{}]({})\n\n{}\n",
                        o.path,
                        cell(&o.caption),
                        o.path,
                        o.caption
                    );
                }
            }
            if !o.params.is_empty() {
                let _ = writeln!(md, "| parameter | value |\n|---|---|");
                for (k, v) in &o.params {
                    let _ = writeln!(md, "| {} | {} |", cell(k), cell(v));
                }
                let _ = writeln!(md);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{
        CalibrationErrors, DemoSizes, DemoSummary, OutputFile, OutputKind, StageTime, Tolerances,
    };
    use super::*;
    use std::collections::BTreeMap;
    use std::path::PathBuf;

    fn summary(within: bool) -> DemoSummary {
        DemoSummary {
            out_dir: PathBuf::from("out"),
            quick: true,
            sizes: DemoSizes::quick(),
            threads: 2,
            tolerances: Tolerances::default(),
            calibrations: vec![CalibrationErrors {
                scene: "cube".into(),
                fiducials: 1000,
                fiducial_width: 672,
                fiducial_height: 504,
                noise_px: 0.5,
                outliers: 0,
                rms_px: 0.7,
                rms_capture_px: 0.0278,
                camera_distance_m: 0.9,
                position_error_mm: 0.3,
                position_error_mm_per_m: 0.333,
                rotation_error_deg: 0.01,
                focal_error_percent: 0.05,
                t0_fit_ps: 0.1,
                t0_std_error_ps: 0.01,
                t0_true_ps: 0.0,
                dt_ps: 4.0,
                t0_error_bins: 0.025,
                t0_true_camera_error_bins: 0.02,
                arrival_samples: 3000,
                arrival_inliers: 2900,
                t0_rms_ps: 1.0,
                detection_floor: 0.07,
                warnings: Vec::new(),
                within_tolerance: within,
            }],
            outputs: vec![
                OutputFile {
                    figure: "fig4".into(),
                    path: "fig4_naive.png".into(),
                    kind: OutputKind::Image,
                    caption: "naive | view".into(),
                    params: BTreeMap::from([("view".to_string(), "naive".to_string())]),
                },
                OutputFile {
                    figure: "fig6".into(),
                    path: "fig6_approach.mp4".into(),
                    kind: OutputKind::Video,
                    caption: "approach".into(),
                    params: BTreeMap::new(),
                },
            ],
            data_files: vec!["data/cube.h5".into()],
            stages: vec![StageTime {
                stage: "simulate".into(),
                seconds: 1.5,
            }],
            total_seconds: 2.0,
            report: "report.md".into(),
            summary_json: "summary.json".into(),
        }
    }

    #[test]
    fn report_shows_images_links_videos_and_the_error_table() {
        let md = markdown(&summary(true));
        assert!(md.contains("![naive \\| view](fig4_naive.png)"), "{md}");
        assert!(md.contains("[fig6_approach.mp4](fig6_approach.mp4)"));
        assert!(!md.contains("![approach]"), "videos are links, not images");
        assert!(
            md.contains("| cube | 0.333 | 0.0100 | 0.050 | 0.025 | yes |"),
            "{md}"
        );
        assert!(md.contains("| *tolerance* | 1 | 0.05 | 0.2 | 0.1 | |"));
        assert!(md.contains("| simulate | 1.50 |"));
        assert!(md.contains("| view | naive |"));
        assert!(md.contains("Not run: give a bunny mesh"));
        assert!(md.contains("- `data/cube.h5`"));
        assert!(markdown(&summary(false)).contains("| **no** |"));
    }
}

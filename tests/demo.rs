//! End-to-end test of `femto demo --quick`: run the binary in a temporary folder as a user
//! would, then check what it leaves behind: every figure file, images that are neither black
//! nor saturated, a non-trivial MP4, and calibration errors within the calibrate issue's
//! tolerances (read from `summary.json`).
//!
//! Fig. 7 (the Cornell box with the bunny) needs `--bunny PATH` and a second run of the whole
//! chain; it is left out here to keep the test fast (the library's `run_demo` writes it the
//! same way as fig. 6, which is checked).

use std::path::Path;
use std::process::Command;

/// The calibrate issue's tolerances, written out here independently of the library.
const POSITION_MM_PER_M: f64 = 1.0;
const ROTATION_DEG: f64 = 0.05;
const FOCAL_PERCENT: f64 = 0.2;
const T0_BINS: f64 = 0.1;

/// Files the quick demo must write (fig. 7 only with `--bunny`).
const EXPECTED: [&str; 22] = [
    "fig4_naive.png",
    "fig4_rewarped.png",
    "fig4_isochrones_capture.png",
    "fig4_isochrones_world.png",
    "fig4_isochrones_novel.png",
    "fig5_aberration_towards.png",
    "fig5_aberration_away.png",
    "fig5_doppler.png",
    "fig5_searchlight.png",
    "fig6_approach.mp4",
    "fig6_approach_frames.png",
    "fig8_rotation_0.png",
    "fig8_rotation_0.4.png",
    "fig8_rotation_0.8.png",
    "fig8_rotation_0.99.png",
    "fig8_rotation.png",
    "report.md",
    "summary.json",
    "data/cube.h5",
    "data/world.h5",
    "data/calibration.toml",
    "data/capture/manifest.toml",
];

/// Mean of the 8-bit values over full scale, and the fraction of pixels whose brightest
/// channel exceeds `lit_above` and that are not the contact sheets' label and background
/// greys (`(235, 235, 235)` ink, `(24, 24, 24)` background).
fn brightness(path: &Path, lit_above: u8) -> (f64, f64, usize) {
    let img = image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8();
    let n = (img.width() * img.height()) as usize;
    let mut sum = 0.0;
    let mut lit = 0usize;
    for p in img.pixels() {
        let [r, g, b] = p.0;
        sum += (r as f64 + g as f64 + b as f64) / (3.0 * 255.0);
        let grey = r == g && g == b && (r == 235 || r == 24);
        if r.max(g).max(b) > lit_above && !grey {
            lit += 1;
        }
    }
    (sum / n as f64, lit as f64 / n as f64, n)
}

#[test]
fn quick_demo_writes_every_figure_with_calibration_in_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let status = Command::new(env!("CARGO_BIN_EXE_femto"))
        .args(["demo", "--quick", "--out"])
        .arg(&out)
        .status()
        .expect("run femto");
    assert!(status.success(), "femto demo --quick failed: {status}");

    for f in EXPECTED {
        let p = out.join(f);
        assert!(p.exists(), "missing {f}");
        assert!(std::fs::metadata(&p).unwrap().len() > 0, "{f} is empty");
    }
    assert!(
        !out.join("fig7_bunny.mp4").exists(),
        "fig7 is written only with --bunny"
    );

    // No image is black or saturated.
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    for f in EXPECTED.iter().filter(|f| f.ends_with(".png")) {
        let (mean, lit, n) = brightness(&out.join(f), 40);
        assert!(n > 1000, "{f}: only {n} pixels");
        assert!(
            (0.02..=0.98).contains(&mean),
            "{f}: mean value {mean:.4} of full scale (black or saturated)"
        );
        assert!(
            lit >= 0.05,
            "{f}: only {:.1} % of the pixels are lit",
            100.0 * lit
        );
        assert!(
            report.contains(&format!("]({f})")),
            "report.md does not show {f}"
        );
    }

    // The MP4 is an ISO media file with a movie box and some data.
    let mp4 = std::fs::read(out.join("fig6_approach.mp4")).unwrap();
    assert!(
        mp4.len() > 10_000,
        "fig6_approach.mp4 is only {} bytes",
        mp4.len()
    );
    assert_eq!(
        &mp4[4..8],
        b"ftyp",
        "fig6_approach.mp4 does not start with ftyp"
    );
    let has = |tag: &[u8]| mp4.windows(4).any(|w| w == tag);
    assert!(
        has(b"moov") && has(b"mdat"),
        "fig6_approach.mp4 lacks moov or mdat"
    );
    assert!(report.contains("](fig6_approach.mp4)"));

    // Calibration errors.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let cals = summary["calibrations"].as_array().expect("calibrations");
    assert_eq!(cals.len(), 1, "one scene without --bunny");
    let c = &cals[0];
    let get = |k: &str| {
        c[k].as_f64()
            .unwrap_or_else(|| panic!("summary.json: calibrations[0].{k} missing"))
    };
    let checks = [
        ("position_error_mm_per_m", POSITION_MM_PER_M),
        ("rotation_error_deg", ROTATION_DEG),
        ("focal_error_percent", FOCAL_PERCENT),
        ("t0_error_bins", T0_BINS),
    ];
    for (k, tol) in checks {
        let v = get(k);
        assert!(v.is_finite() && v <= tol, "{k} = {v} exceeds {tol}");
    }
    // The per-metre figure is the absolute error over the distance, recomputed here.
    let per_m = get("position_error_mm") / get("camera_distance_m");
    assert!((per_m - get("position_error_mm_per_m")).abs() < 1e-9 * (1.0 + per_m));
    assert_eq!(c["within_tolerance"], serde_json::Value::Bool(true));
}

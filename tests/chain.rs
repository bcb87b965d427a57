//! The chain a user runs, from the command line, with defaults only: a `femto simulate
//! --realistic` capture folder whose scanlines are PNG16 files, or HPD-TA `.img` files, then `femto ingest`, `calibrate`, `unwarp`, `pyramid` and `render --dolly`, each stage
//! checked against the simulator's truth (issue 15): t0 within 0.1 bin, the camera centre
//! within 1 mm per metre, the world-time cube's per-pixel temporal centroid within one bin of
//! `truth_world.h5`, the laser wavelength carried from the manifest to the render, and no
//! entirely black frame.

#[path = "common/cli.rs"]
mod cli;

use cli::{arg, femto_ok, Run};
use femto::camera::Calibration;
use femto::container;
use femto::cube::Cube;
use std::path::Path;

/// The capture: the built-in cube scene, 64 x 48 pixels, 256 bins of 4 ps, every realistic
/// flaw (photon and dark noise, vignetting, 2 ps rms trigger jitter, 3 % laser power drift,
/// 5 % sweep non-linearity).
fn simulate(dir: &Path, format: &str) -> std::path::PathBuf {
    let cap = dir.join("cap");
    femto_ok(&[
        "simulate",
        "--scene",
        "cube",
        "--size",
        "64x48",
        "--spp",
        "64",
        "--realistic",
        "--format",
        format,
        "--out",
        arg(&cap),
    ]);
    cap
}

/// Temporal centroid (ps) of pixel `(x, y)` of `cube` over the bins whose centres lie in
/// `[a, b)` ps, after subtracting `base`; None when the window holds no light.
fn centroid_ps(cube: &Cube, x: usize, y: usize, a: f64, b: f64, base: f64) -> Option<f64> {
    let p = cube.profile(x, y);
    let (mut sw, mut swt) = (0.0, 0.0);
    for (i, &v) in p.iter().enumerate() {
        let t = cube.axis.bin_centre_ps(i);
        if t >= a && t < b {
            sw += v as f64 - base;
            swt += (v as f64 - base) * t;
        }
    }
    (sw > 0.0).then(|| swt / sw)
}

/// Median of pixel `(x, y)`'s bins that end before `t_ps`: what the cube holds before any
/// light (a dark offset left in by an ingest without corrections); None for fewer than 8.
fn baseline_before(cube: &Cube, x: usize, y: usize, t_ps: f64) -> Option<f64> {
    let p = cube.profile(x, y);
    let mut v: Vec<f64> = (0..p.len())
        .filter(|&i| cube.axis.bin_start_ps(i + 1) <= t_ps)
        .map(|i| p[i] as f64)
        .collect();
    if v.len() < 8 {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// The checks of every stage after ingest, on the cube `cube` ingested from `cap`.
fn check_chain(dir: &Path, cap: &Path, cube: &Path, expect_laser: Option<f64>) {
    let truth = Calibration::load(&cap.join("calibration.toml")).unwrap();
    let l = truth.laser_m;

    // Calibrate, with defaults.
    let run = femto_ok(&[
        "calibrate",
        arg(cube),
        "--mesh",
        arg(&cap.join("scene.glb")),
        "--points",
        arg(&cap.join("fiducials.toml")),
        &format!("--laser={},{},{}", l.x, l.y, l.z),
    ]);
    let cal_path = cube.with_file_name("cube.calibration.toml");
    let fitted = Calibration::load(&cal_path).unwrap();
    let dt_ps = container::read_meta(cube).unwrap().axis.dt_ps;
    let t0_bins = (fitted.t0_ps - truth.t0_ps) / dt_ps;
    // Position error per metre of the distance to the fiducials' centroid (the demo's measure).
    let points = femto::calibrate::load_points(&cap.join("fiducials.toml")).unwrap();
    let centroid_m = points
        .iter()
        .map(|c| c.point_m.coords)
        .sum::<nalgebra::Vector3<f64>>()
        / points.len() as f64;
    let distance_m = (truth.pose.position_m.coords - centroid_m).norm();
    let pos_mm_per_m = 1e3 * (fitted.pose.position_m - truth.pose.position_m).norm() / distance_m;
    println!("calibrate: t0 {t0_bins:+.4} bins, camera {pos_mm_per_m:.4} mm/m");
    // Scanline times against the geometry take what ingest's jitter estimate leaves (its slow
    // part): with both, no scanline ends more than 1 ps further from on time than it began.
    let line = run
        .stdout
        .lines()
        .find(|l| l.starts_with("jitter against the manifest's truth, ingest's shifts and these"))
        .unwrap_or_else(|| panic!("no scanline truth line in {}", run.stdout));
    println!("{line}");
    let figure = |after: &str| -> f64 {
        let tail = &line[line.find(after).unwrap() + after.len()..];
        tail.split_whitespace()
            .next()
            .unwrap()
            .trim_end_matches(',')
            .parse()
            .unwrap()
    };
    assert!(figure("ps before; rms ") < 0.6, "{line}");
    assert!(line.contains(", 0 made worse by more than 1 ps"), "{line}");
    assert!(t0_bins.abs() <= 0.1, "t0 off by {t0_bins} bins");
    assert!(pos_mm_per_m <= 1.0, "camera off by {pos_mm_per_m} mm/m");

    // Unwarp, with defaults; against the world-time truth.
    let world = dir.join("world.h5");
    femto_ok(&["unwarp", arg(cube), "--out", arg(&world)]);
    let got = container::read_cube(&world).unwrap();
    let want = container::read_cube(&cap.join("truth_world.h5")).unwrap();
    // Pixels with a clear direct pulse: its top at least a tenth of the brightest pixel's
    // (the dimmer ones are Monte Carlo and photon noise at 64 paths per pixel).
    let tops: Vec<f32> = (0..want.nx * want.ny)
        .map(|p| {
            want.profile(p % want.nx, p / want.nx)
                .iter()
                .cloned()
                .fold(0.0, f32::max)
        })
        .collect();
    let brightest = tops.iter().cloned().fold(0.0f32, f32::max);
    let bvh = femto::geometry::bvh::Bvh::new(
        femto::geometry::load::load_mesh(&cap.join("scene.glb")).unwrap(),
    );
    let distance = |u: f64, v: f64| -> Option<f64> {
        let o = truth.pose.position_m.cast::<f32>();
        let ray = femto::geometry::Ray::new(o, truth.world_ray(u, v).into_inner().cast::<f32>());
        bvh.intersect(&ray, 0.0, f32::INFINITY).map(|h| h.t as f64)
    };
    let (mut checked, mut worst_bins) = (0usize, 0.0f64);
    for y in 0..want.ny {
        for x in 0..want.nx {
            if tops[y * want.nx + x] < 0.1 * brightest || !got.is_valid(x, y) {
                continue;
            }
            // A pixel is unwarped by the distance at its centre: compare the pixels whose
            // footprint lies on one surface (corner distances within 2 mm of the centre's).
            let Some(d) = distance(x as f64 + 0.5, y as f64 + 0.5) else {
                continue;
            };
            let one_surface =
                [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                    .iter()
                    .all(|(u, v)| {
                        distance(x as f64 + u, y as f64 + v).is_some_and(|c| (c - d).abs() < 2e-3)
                    });
            if !one_surface {
                continue;
            }
            // The window: the truth's main pulse (bins above a tenth of its top), two bins
            // either side; the baseline: what the cube holds before any light.
            let w = want.profile(x, y);
            let top = w.iter().cloned().fold(0.0f32, f32::max);
            let Some(peak_bin) = (0..w.len()).find(|&i| w[i] == top) else {
                continue;
            };
            let i0 = (0..=peak_bin)
                .rev()
                .take_while(|&i| w[i] > 0.1 * top)
                .last()
                .unwrap_or(peak_bin);
            let i1 = (peak_bin..w.len())
                .take_while(|&i| w[i] > 0.1 * top)
                .last()
                .unwrap_or(peak_bin);
            let a = want.axis.bin_start_ps(i0) - 2.0 * dt_ps;
            let b = want.axis.bin_start_ps(i1 + 1) + 2.0 * dt_ps;
            let first_light = (0..w.len()).find(|&i| w[i] > 1e-3 * top).unwrap_or(i0);
            let Some(base) = baseline_before(&got, x, y, want.axis.bin_start_ps(first_light))
            else {
                continue;
            };
            let (Some(cw), Some(cg)) = (
                centroid_ps(&want, x, y, a, b, 0.0),
                centroid_ps(&got, x, y, a, b, base),
            ) else {
                continue;
            };
            let err_bins = (cg - cw).abs() / dt_ps;
            worst_bins = worst_bins.max(err_bins);
            assert!(
                err_bins <= 1.0,
                "pixel ({x}, {y}): centroid {cg:.1} ps, truth {cw:.1} ps ({err_bins:.2} bins) in \
                 [{a:.1}, {b:.1}) ps, baseline {base:.4}; truth {:?}; got {:?}",
                &w[i0.saturating_sub(3)..(i1 + 4).min(w.len())],
                (0..got.axis.nt)
                    .filter(|&i| got.axis.bin_centre_ps(i) >= a - 8.0
                        && got.axis.bin_centre_ps(i) < b + 8.0)
                    .map(|i| got.profile(x, y)[i])
                    .collect::<Vec<_>>()
            );
            checked += 1;
        }
    }
    println!(
        "unwarp: {checked} pixels within one bin of truth_world.h5 (worst {worst_bins:.3} bins)"
    );
    // 370 of the 3072 pixels have a clear pulse on one surface in this capture.
    assert!(checked >= 300, "only {checked} pixels compared");

    check_mixed_pixels(&got, &want, &tops, brightest);

    // Pyramid and a short dolly render, with defaults.
    femto_ok(&["pyramid", arg(&world)]);
    let frames = dir.join("frames");
    let run: Run = femto_ok(&[
        "render",
        "--cube",
        arg(&world),
        "--calibration",
        arg(&cal_path),
        "--mesh",
        arg(&cap.join("scene.glb")),
        "--dolly",
        "0.5",
        "--size",
        "64x48",
        "--frame-count",
        "12",
        "--out",
        arg(&frames),
    ]);
    println!("render: {}", run.stderr.trim());
    if let Some(nm) = expect_laser {
        assert!(
            run.stderr
                .contains(&format!("laser {nm} nm (the cube's laser_nm attribute)")),
            "the render must say it used the capture's {nm} nm: {}",
            run.stderr
        );
    }
    assert!(!run.stderr.contains("entirely black"), "{}", run.stderr);
    let mut black = Vec::new();
    for k in 0..12 {
        let png = frames.join(format!("frame_{k:05}.png"));
        let img = image::open(&png).unwrap().to_rgb8();
        if img.pixels().all(|p| p.0 == [0, 0, 0]) {
            black.push(k);
        }
    }
    assert!(black.is_empty(), "black frames {black:?}");
}

/// The centre at half maximum of `profile`'s highest pulse, in bins (bin i's centre at
/// i + 0.5): the midpoint of the half-maximum crossings either side of the top, interpolated.
/// Unlike the top bin, it does not wander over a pulse flattened by a footprint's spread.
fn half_max_centre_bins(profile: &[f32]) -> f64 {
    let p: Vec<f64> = profile.iter().map(|&v| v as f64).collect();
    let top = (0..p.len()).fold(0, |m, i| if p[i] > p[m] { i } else { m });
    let half = 0.5 * p[top];
    let (mut a, mut b) = (top, top);
    while a > 0 && p[a - 1] >= half {
        a -= 1;
    }
    while b + 1 < p.len() && p[b + 1] >= half {
        b += 1;
    }
    let left = if a > 0 {
        a as f64 - 1.0 + (half - p[a - 1]) / (p[a] - p[a - 1])
    } else {
        a as f64
    };
    let right = if b + 1 < p.len() {
        b as f64 + (p[b] - half) / (p[b] - p[b + 1])
    } else {
        b as f64
    };
    0.5 * (left + right) + 0.5
}

/// Issue 31, item 4: every pixel the unwarp shifted (not masked) whose direct pulse is clear
/// (its top at least a twentieth of the brightest) has that pulse's centre at half maximum
/// within 2 bins of `truth_world.h5`'s, footprints on one surface or not; the pixels whose
/// footprint spans more than `MASK_SPREAD_BINS` bins of path are the ones masked.
fn check_mixed_pixels(got: &Cube, want: &Cube, tops: &[f32], brightest: f32) {
    let (mut checked, mut worst_ps, mut masked) = (0usize, 0.0f64, 0usize);
    for y in 0..want.ny {
        for x in 0..want.nx {
            if tops[y * want.nx + x] < 0.05 * brightest {
                continue;
            }
            if !got.is_valid(x, y) {
                masked += 1;
                continue;
            }
            let centre =
                |c: &Cube| c.axis.t0_ps + half_max_centre_bins(c.profile(x, y)) * c.axis.dt_ps;
            let err_ps = (centre(got) - centre(want)).abs();
            worst_ps = worst_ps.max(err_ps);
            assert!(
                err_ps <= 2.0 * want.axis.dt_ps,
                "pixel ({x}, {y}) shifted, its direct pulse {err_ps:.2} ps from the truth's"
            );
            checked += 1;
        }
    }
    println!(
        "unwarp: {checked} bright shifted pixels' pulses within {worst_ps:.2} ps of \
         truth_world.h5; {masked} bright pixels masked as mixed"
    );
    assert!(checked >= 300, "only {checked} bright pixels shifted");
}

#[test]
fn cli_chain_with_defaults_from_png16_scanlines() {
    let dir = tempfile::tempdir().unwrap();
    let cap = simulate(dir.path(), "png16");
    let cube = dir.path().join("cube.h5");
    femto_ok(&["ingest", arg(&cap), "-o", arg(&cube)]);
    check_chain(dir.path(), &cap, &cube, Some(795.0));
}

#[test]
fn cli_chain_with_defaults_from_hpd_ta_img_scanlines() {
    let dir = tempfile::tempdir().unwrap();
    let cap = simulate(dir.path(), "img16");
    let cube = dir.path().join("cube.h5");
    femto_ok(&["ingest", arg(&cap), "-o", arg(&cube)]);
    check_chain(dir.path(), &cap, &cube, Some(795.0));
}

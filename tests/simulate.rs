//! End-to-end tests of `femto simulate`: the binary is run as a user would, in a temporary
//! folder, and the capture it leaves behind is checked against independent computations
//! written here (ray casts, projections, cumulative integrals, statistics), never against
//! the simulator's own functions.

use femto::calibrate::points::load_points;
use femto::camera::Calibration;
use femto::container::read_cube;
use femto::cube::{Cube, TimeAxis, TimeFrame};
use femto::formats::{read_streak, StreakImage};
use femto::geometry::bvh::Bvh;
use femto::geometry::load::load_mesh;
use femto::geometry::Ray;
use femto::manifest::{FiducialNoise, Manifest, StreakFormat};
use femto::resample::shift_into;
use femto::units::C_M_PER_PS;
use std::path::{Path, PathBuf};
use std::process::Output;
#[path = "common/cli.rs"]
mod cli;
#[path = "common/shared.rs"]
mod shared;
use cli::{files_under, FemtoCmd};

/// Small captures: 24 x 16 pixels, 64 bins of 16 ps (the cube scene's 1 ns window), 4 spp.
const SMALL: [&str; 10] = [
    "--size",
    "24x16",
    "--nt",
    "64",
    "--dt-ps",
    "16",
    "--spp",
    "4",
    "--bounces",
    "3",
];

fn femto(dir: &Path, args: &[&str], threads: Option<usize>) -> Output {
    let cmd = FemtoCmd::new().current_dir(dir).args(args);
    match threads {
        Some(n) => cmd.env("RAYON_NUM_THREADS", n.to_string()).output(),
        None => cmd.output(),
    }
}

/// Run `femto simulate --out NAME SMALL... EXTRA...` in `dir`, expecting success.
fn simulate(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    simulate_threads(dir, name, extra, None)
}

fn simulate_threads(dir: &Path, name: &str, extra: &[&str], threads: Option<usize>) -> PathBuf {
    let mut args = vec!["simulate", "--out", name];
    args.extend(SMALL);
    args.extend(extra);
    let out = femto(dir, &args, threads);
    assert!(
        out.status.success(),
        "femto {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    dir.join(name)
}

fn manifest(cap: &Path) -> Manifest {
    Manifest::load(&cap.join("manifest.toml")).unwrap()
}

fn max_of(c: &Cube) -> f64 {
    c.data.iter().cloned().fold(0.0f32, f32::max) as f64
}

/// The streak image of scanline `y` in `ext`, as read by femto's own reader.
fn scanline(cap: &Path, y: usize, ext: &str) -> StreakImage {
    read_streak(&cap.join(format!("scanlines/scanline_{y:04}.{ext}")), false).unwrap()
}

/// Cumulative signal of a profile (constant within each bin of `axis`) up to time `t_ps`.
fn cumulative(profile: &[f32], axis: &TimeAxis, t_ps: f64) -> f64 {
    let mut sum = 0.0;
    for (i, &v) in profile.iter().enumerate() {
        let a = axis.t0_ps + i as f64 * axis.dt_ps;
        let covered = ((t_ps - a) / axis.dt_ps).clamp(0.0, 1.0);
        sum += v as f64 * covered;
    }
    sum
}

/// Integral of the profile over `[lo, hi)`.
fn integral(profile: &[f32], axis: &TimeAxis, lo: f64, hi: f64) -> f64 {
    cumulative(profile, axis, hi) - cumulative(profile, axis, lo)
}

#[test]
fn same_seed_gives_bit_identical_files_whatever_the_thread_count() {
    let tmp = tempfile::tempdir().unwrap();
    let flaws = [
        "--realistic",
        "--saturation",
        "0.95",
        "--format",
        "png16,exr,img16",
    ];
    let (d1, d2, d3) = (
        tmp.path().join("a"),
        tmp.path().join("b"),
        tmp.path().join("c"),
    );
    for d in [&d1, &d2, &d3] {
        std::fs::create_dir(d).unwrap();
    }
    // Same relative --out, so that the recorded command lines are the same too.
    let one = files_under(&simulate_threads(&d1, "cap", &flaws, Some(1)));
    let two = files_under(&simulate_threads(&d2, "cap", &flaws, Some(2)));
    assert_eq!(
        one.keys().collect::<Vec<_>>(),
        two.keys().collect::<Vec<_>>()
    );
    // 16 scanlines x 3 formats + 3 cubes + glb, calibration, fiducials, manifest, flat, dark.
    assert_eq!(one.len(), 16 * 3 + 9);
    for (path, bytes) in &one {
        assert!(bytes == &two[path], "{} differs", path.display());
    }
    // Another seed changes the render and the noise.
    let mut other_seed = flaws.to_vec();
    other_seed.extend(["--seed", "1"]);
    let three = files_under(&simulate_threads(&d3, "cap", &other_seed, Some(2)));
    for f in ["truth_camera.h5", "scanlines/scanline_0003.png", "dark.exr"] {
        assert!(
            three[Path::new(f)] != one[Path::new(f)],
            "{f} did not change"
        );
    }
}

/// A wall facing the camera and a box in front of it, lit from beside the camera (so that
/// the box's shadow hides behind it): pixels that see one flat face have nearly the same
/// distance over their whole footprint.
const WALL_SCENE: &str = r#"
name = "wall"
eta = 1.0

[laser]
position_m = [0.02, 0.03, 0.45]
normal = [0.0, 0.0, -1.0]
wavelength_nm = 795.0
pulse_width_fs = 200.0
energy = 1.0

[camera]
position_m = [0.0, 0.0, 0.5]
look_at_m = [0.0, 0.0, 0.0]
vfov_deg = 20.0
nx = 24
ny = 16
nt = 128
dt_ps = 16.0
t0_ps = 1500.0

[[mesh]]
name = "wall"
primitive = "quad"
size = [0.6, 0.4]
albedo = 0.7

[[mesh]]
name = "box"
primitive = "box"
size = [0.06, 0.06, 0.06]
rotate_deg = [0.0, 20.0, 0.0]
translate_m = [0.03, 0.0, 0.1]
albedo = 0.8
"#;

#[test]
fn world_time_truth_is_camera_time_truth_shifted_by_each_pixels_distance() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("wall.toml"), WALL_SCENE).unwrap();
    let out = femto(
        tmp.path(),
        &[
            "simulate",
            "--scene",
            "wall.toml",
            "--out",
            "cap",
            "--spp",
            "64",
            "--bounces",
            "1",
        ],
        None,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cap = tmp.path().join("cap");
    let camera = read_cube(&cap.join("truth_camera.h5")).unwrap();
    let world = read_cube(&cap.join("truth_world.h5")).unwrap();
    assert_eq!(camera.frame, TimeFrame::Camera);
    assert_eq!(world.frame, TimeFrame::World);
    let calib = Calibration::load(&cap.join("calibration.toml")).unwrap();
    let bvh = Bvh::new(load_mesh(&cap.join("scene.glb")).unwrap());
    let o = calib.pose.position_m;
    let distance = |u: f64, v: f64| -> Option<f64> {
        let dir = calib.world_ray(u, v).into_inner();
        let ray = Ray::new(o.cast::<f32>(), dir.cast::<f32>());
        bvh.intersect(&ray, 0.0, f32::INFINITY).map(|h| h.t as f64)
    };
    // Whether the laser spot sees the surface point at distance `d_m` through (u, v).
    let lit = |u: f64, v: f64, d_m: f64| -> bool {
        let p = o + calib.world_ray(u, v).into_inner() * d_m;
        let to_p = p - calib.laser_m;
        let r = to_p.norm();
        let ray = Ray::new(calib.laser_m.cast::<f32>(), (to_p / r).cast::<f32>());
        !bvh.occluded(&ray, 0.0, (r - 1e-4) as f32)
    };
    let totals = camera.time_integral();
    let max_total = totals.iter().cloned().fold(0.0, f64::max);
    let (nx, nt_w) = (camera.nx, world.nt());
    let mut checked = 0;
    let mut shifted = vec![0.0f32; nt_w];
    for y in 0..camera.ny {
        for x in 0..nx {
            let centre = (x as f64 + 0.5, y as f64 + 0.5);
            let Some(d_m) = distance(centre.0, centre.1) else {
                continue;
            };
            // Skip pixels whose footprint spans a depth edge...
            let offsets = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)];
            let corners: Vec<f64> = offsets
                .iter()
                .filter_map(|(a, b)| distance(x as f64 + a, y as f64 + b))
                .collect();
            if corners.len() < 4 || corners.iter().any(|c| (c - d_m).abs() > 2e-3) {
                continue;
            }
            // ... or a shadow edge (the light would then come from part of the footprint).
            let lit_corners = offsets
                .iter()
                .zip(&corners)
                .filter(|((a, b), &d)| lit(x as f64 + a, y as f64 + b, d))
                .count();
            if lit_corners != 4 {
                continue;
            }
            let spread_m = corners.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                - corners.iter().cloned().fold(f64::INFINITY, f64::min);
            let cam = camera.profile(x, y);
            let wld = world.profile(x, y);
            let total: f64 = cam.iter().map(|&v| v as f64).sum();
            if total < 1e-3 * max_total {
                continue;
            }
            let shift_ps = -d_m / C_M_PER_PS;
            // Same light: the same total.
            let total_w: f64 = wld.iter().map(|&v| v as f64).sum();
            assert!(
                (total_w / total - 1.0).abs() < 1e-4,
                "pixel ({x}, {y}): {total_w} vs {total}"
            );
            // Mean time shifted by the distance: exact for the binning, up to the mean
            // distance of the 64 random points of the pixel the paths went through, which
            // differs from the centre's by about spread / sqrt(12 * 64) (the distance is
            // nearly linear over the pixel); 6 of those plus 0.2 ps for brightness gradients.
            // A z-depth instead of the distance would be off by up to
            // 25 ps at the image edges.
            let tolerance_ps = 0.2 + 6.0 * spread_m / C_M_PER_PS / (12.0f64 * 64.0).sqrt();
            let mean = |p: &[f32], a: &TimeAxis| {
                p.iter()
                    .enumerate()
                    .map(|(i, &v)| v as f64 * a.bin_centre_ps(i))
                    .sum::<f64>()
                    / p.iter().map(|&v| v as f64).sum::<f64>()
            };
            let expect = mean(cam, &camera.axis) + shift_ps;
            let got = mean(wld, &world.axis);
            assert!(
                (got - expect).abs() < tolerance_ps,
                "pixel ({x}, {y}): world mean {got} ps, camera mean shifted {expect} ps"
            );
            // Profiles: the shifted camera profile and the world profile agree to within
            // the resampling error (mass moved by at most two bins).
            shift_into(&camera.axis, cam, shift_ps, &world.axis, &mut shifted);
            let cdf = |p: &[f32]| -> Vec<f64> {
                let mut acc = 0.0;
                p.iter()
                    .map(|&v| {
                        acc += v as f64;
                        acc
                    })
                    .collect()
            };
            let (cs, cw) = (cdf(&shifted), cdf(wld));
            let eps = 1e-4 * total;
            for j in 0..nt_w {
                let lo = cw[j.saturating_sub(2)];
                let hi = cw[(j + 2).min(nt_w - 1)];
                assert!(
                    cs[j] >= lo - eps && cs[j] <= hi + eps,
                    "pixel ({x}, {y}) bin {j}: {} outside [{lo}, {hi}]",
                    cs[j]
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 200, "only {checked} pixels checked");
}

#[test]
fn img_files_read_back_with_the_values_of_the_png_and_exr_files() {
    let tmp = tempfile::tempdir().unwrap();
    for (name, formats) in [("c16", "png16,exr,img16"), ("c32", "img32,png16,exr")] {
        let cap = simulate(tmp.path(), name, &["--realistic", "--format", formats]);
        let m = manifest(&cap);
        let vpc = m.capture.png_value_per_count.unwrap();
        let axis = TimeAxis {
            t0_ps: m.capture.t0_ps,
            dt_ps: m.capture.dt_ps,
            nt: m.capture.nt,
        };
        assert_eq!(
            m.scanlines[0].file,
            Path::new("scanlines/scanline_0000").with_extension(if name == "c16" {
                "png"
            } else {
                "img"
            })
        );
        for y in 0..m.capture.ny {
            let png = scanline(&cap, y, "png");
            let exr = scanline(&cap, y, "exr");
            let img = scanline(&cap, y, "img");
            assert_eq!((img.nx, img.nt), (24, 64));
            assert_eq!(
                img.data, png.data,
                "scanline {y}: .img and .png counts differ"
            );
            for (e, p) in exr.data.iter().zip(&png.data) {
                // The same counts, to f32 precision.
                let tolerance = 1e-6 * (*p as f64).max(1.0);
                assert!(
                    (*e as f64 / vpc - *p as f64).abs() < tolerance,
                    "{e} vs {p} counts"
                );
            }
            // The time table is the sweep's: the true start of every recorded row.
            let times = img.time_axis_ps.as_ref().unwrap();
            let edges = &m.imperfections.sweep.as_ref().unwrap().bin_times_ps;
            for (i, t) in times.iter().enumerate() {
                assert!((t - edges[i]).abs() < 1e-3, "row {i}: {t} vs {}", edges[i]);
            }
            assert!(
                (0..times.len()).any(|i| (times[i] - axis.bin_start_ps(i)).abs() > 0.1),
                "a realistic sweep is non-linear"
            );
            assert!(png.data.iter().any(|&v| v > 100.0));
        }
    }
}

/// The capture as `[y][x][t]` signal (counts x value per count), read from the PNGs.
fn capture_signal(cap: &Path, m: &Manifest) -> Vec<f64> {
    let (nx, ny, nt) = (m.capture.nx, m.capture.ny, m.capture.nt);
    let vpc = m.capture.png_value_per_count.unwrap();
    let mut out = vec![0.0; nx * ny * nt];
    for y in 0..ny {
        let img = scanline(cap, y, "png");
        for t in 0..nt {
            for x in 0..nx {
                out[(y * nx + x) * nt + t] = img.at(x, t) as f64 * vpc;
            }
        }
    }
    out
}

#[test]
fn each_flaw_changes_the_capture_as_documented_and_is_recorded() {
    let tmp = tempfile::tempdir().unwrap();
    let clean_cap = simulate(tmp.path(), "clean", &[]);
    let truth = read_cube(&clean_cap.join("truth_camera.h5")).unwrap();
    let full = max_of(&truth);
    let (nx, ny, nt) = (truth.nx, truth.ny, truth.nt());
    let axis = truth.axis;
    let m = manifest(&clean_cap);
    assert_eq!(m.imperfections, Default::default());
    // No flaw: the truth quantised, its maximum at 60000 counts.
    let vpc = m.capture.png_value_per_count.unwrap();
    assert!((vpc * 60000.0 / full - 1.0).abs() < 1e-9);
    let clean = capture_signal(&clean_cap, &m);
    for (c, t) in clean.iter().zip(&truth.data) {
        assert!((c - *t as f64).abs() <= 0.5 * vpc + 1e-9);
    }

    let run = |name: &str, flags: &[&str]| -> (Manifest, Vec<f64>, PathBuf) {
        let cap = simulate(tmp.path(), name, flags);
        let m = manifest(&cap);
        let s = capture_signal(&cap, &m);
        assert!(s != clean, "{name}: capture unchanged");
        // The render is the same light: the truth does not depend on the flaws.
        assert_eq!(
            read_cube(&cap.join("truth_camera.h5")).unwrap().data,
            truth.data
        );
        (m, s, cap)
    };
    let idx = |x: usize, y: usize| (y * nx + x) * nt;

    // Laser power: each scanline scaled by its recorded factor.
    let (m, s, _) = run("power", &["--power-sigma", "0.2"]);
    let p = m.imperfections.power.unwrap();
    assert_eq!(p.sigma, 0.2);
    let vpc = m.capture.png_value_per_count.unwrap();
    for y in 0..ny {
        for x in 0..nx {
            for t in 0..nt {
                let want = truth.profile(x, y)[t] as f64 * p.factors[y];
                assert!((s[idx(x, y) + t] - want).abs() <= 0.5 * vpc + 1e-9);
            }
        }
    }

    // Vignetting: gain 1 - s r^2, the same as flat.exr.
    let (m, s, cap) = run("vignetting", &["--vignetting", "0.4"]);
    assert_eq!(m.imperfections.vignetting.unwrap().strength, 0.4);
    assert_eq!(m.files.flat.as_deref(), Some(Path::new("flat.exr")));
    let flat = read_streak(&cap.join("flat.exr"), false).unwrap();
    assert_eq!((flat.nx, flat.nt), (nx, ny));
    let vpc = m.capture.png_value_per_count.unwrap();
    let half_diag2 = (nx as f64 / 2.0).powi(2) + (ny as f64 / 2.0).powi(2);
    for y in 0..ny {
        for x in 0..nx {
            let r2 = ((x as f64 + 0.5 - nx as f64 / 2.0).powi(2)
                + (y as f64 + 0.5 - ny as f64 / 2.0).powi(2))
                / half_diag2;
            let g = 1.0 - 0.4 * r2;
            assert!((flat.at(x, y) as f64 - g).abs() < 1e-6);
            for t in 0..nt {
                let want = truth.profile(x, y)[t] as f64 * g;
                assert!((s[idx(x, y) + t] - want).abs() <= 0.5 * vpc + 1e-9);
            }
        }
    }

    // Jitter: each scanline shifted later by its recorded shift.
    let (m, s, _) = run("jitter", &["--jitter-ps", "6"]);
    let j = m.imperfections.jitter.unwrap();
    assert_eq!(j.sigma_ps, 6.0);
    assert!(j.shifts_ps.iter().any(|v| v.abs() > 1.0));
    let vpc = m.capture.png_value_per_count.unwrap();
    for y in 0..ny {
        for x in 0..nx {
            let p = truth.profile(x, y);
            for t in 0..nt {
                let (a, b) = (axis.bin_start_ps(t), axis.bin_start_ps(t + 1));
                let shift = j.shifts_ps[y];
                let want = integral(p, &axis, a - shift, b - shift);
                assert!((s[idx(x, y) + t] - want).abs() <= 0.5 * vpc + 1e-6 * full);
            }
        }
    }

    // Sweep: recorded bin j integrates the truth over the recorded true edges, which follow
    // e_j = t0 + dt (j + s nt sin(pi j / nt) / pi).
    let (m, s, _) = run("sweep", &["--sweep", "0.2"]);
    let sw = m.imperfections.sweep.unwrap();
    assert_eq!(sw.strength, 0.2);
    let vpc = m.capture.png_value_per_count.unwrap();
    for (i, e) in sw.bin_times_ps.iter().enumerate() {
        let g = (std::f64::consts::PI * i as f64 / nt as f64).sin() / std::f64::consts::PI;
        let want = axis.t0_ps + axis.dt_ps * (i as f64 + 0.2 * nt as f64 * g);
        assert!((e - want).abs() < 1e-9);
    }
    for y in 0..ny {
        for x in 0..nx {
            let p = truth.profile(x, y);
            for t in 0..nt {
                let (a, b) = (sw.bin_times_ps[t], sw.bin_times_ps[t + 1]);
                let want = integral(p, &axis, a, b);
                assert!((s[idx(x, y) + t] - want).abs() <= 0.5 * vpc + 1e-6 * full);
            }
        }
    }

    // Saturation: clipped at the level (a fraction of the clean maximum), which is the top
    // count.
    let (m, s, _) = run("saturation", &["--saturation", "0.3"]);
    let level = m.imperfections.saturation.unwrap().level;
    assert!((level / (0.3 * full) - 1.0).abs() < 1e-9);
    let vpc = m.capture.png_value_per_count.unwrap();
    assert!((vpc * 65535.0 / level - 1.0).abs() < 1e-9);
    let mut clipped = 0;
    for (v, t) in s.iter().zip(&truth.data) {
        let want = (*t as f64).min(level);
        assert!((v - want).abs() <= 0.5 * vpc + 1e-9);
        clipped += (*t as f64 > level) as usize;
    }
    assert!(clipped > 0);

    // Dark: offset and Gaussian noise, fractions of the clean maximum; the dark frame too.
    let (m, s, cap) = run("dark", &["--dark", "0.02,0.004"]);
    let d = m.imperfections.dark.unwrap();
    assert!((d.offset / (0.02 * full) - 1.0).abs() < 1e-6);
    assert!((d.sigma / (0.004 * full) - 1.0).abs() < 1e-6);
    let stats = |v: &[f64]| {
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        (
            mean,
            (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt(),
        )
    };
    let diff: Vec<f64> = s
        .iter()
        .zip(&truth.data)
        .map(|(v, t)| v - *t as f64)
        .collect();
    let (mean, sd) = stats(&diff);
    // 24576 values: the mean within 5 standard errors, the sd within 5 %.
    assert!((mean - d.offset).abs() < 5.0 * d.sigma / (diff.len() as f64).sqrt());
    assert!((sd / d.sigma - 1.0).abs() < 0.05, "{sd} vs {}", d.sigma);
    let frame = read_streak(&cap.join(m.files.dark.as_ref().unwrap()), false).unwrap();
    assert_eq!((frame.nx, frame.nt), (nx, nt));
    let fv: Vec<f64> = frame.data.iter().map(|&v| v as f64).collect();
    let (mean, sd) = stats(&fv);
    // The dark frame is the average of DARK_FRAMES_AVERAGED frames, as a lab records it.
    let sd_frame = d.sigma / (femto::simulate::flaws::DARK_FRAMES_AVERAGED as f64).sqrt();
    assert!((mean - d.offset).abs() < 5.0 * sd_frame / (fv.len() as f64).sqrt());
    assert!((sd / sd_frame - 1.0).abs() < 0.1, "{sd} vs {sd_frame}");

    // Photon noise: Poisson counts of k photons per unit, k = N / clean maximum.
    let (m, s, _) = run("photon", &["--photon-noise", "20000"]);
    let k = m
        .imperfections
        .photon_noise
        .unwrap()
        .photons_per_unit
        .unwrap();
    assert!((k * full / 20000.0 - 1.0).abs() < 1e-9);
    let (mut chi2, mut dof) = (0.0, 0usize);
    for (v, t) in s.iter().zip(&truth.data) {
        let lambda = *t as f64 * k;
        if lambda > 30.0 {
            chi2 += (v * k - lambda).powi(2) / lambda;
            dof += 1;
        }
    }
    assert!(dof > 200, "{dof}");
    let ratio = chi2 / dof as f64;
    // Poisson variance (plus quantisation, small at these counts).
    assert!(
        (ratio - 1.0).abs() < 5.0 * (2.0 / dof as f64).sqrt() + 0.02,
        "chi2 / dof = {ratio} over {dof}"
    );
}

#[test]
fn fiducials_project_to_their_pixels_and_are_seen_there() {
    let tmp = tempfile::tempdir().unwrap();
    let cap = simulate(tmp.path(), "cap", &[]);
    let calib = Calibration::load(&cap.join("calibration.toml")).unwrap();
    let points = load_points(&cap.join("fiducials.toml")).unwrap();
    assert!(points.len() > 1800, "{} fiducials", points.len());
    let bvh = Bvh::new(load_mesh(&cap.join("scene.glb")).unwrap());
    let o = calib.pose.position_m;
    let (w, h) = (
        calib.intrinsics.width as f64,
        calib.intrinsics.height as f64,
    );
    assert_eq!((w, h), (24.0, 16.0));
    let mut markers = 0;
    for p in &points {
        let name = p.name.as_deref().unwrap();
        // Pinhole projection written out here: R^T (p - o), then K.
        let c = calib.pose.world_from_camera.inverse() * (p.point_m - o);
        let k = &calib.intrinsics;
        let (u, v) = (k.fx * c.x / c.z + k.cx, k.fy * c.y / c.z + k.cy);
        assert!(
            (u - p.pixel.0).abs() < 1e-6 && (v - p.pixel.1).abs() < 1e-6,
            "{name}: ({u}, {v}) vs {:?}",
            p.pixel
        );
        assert!(u >= 0.0 && u <= w && v >= 0.0 && v <= h);
        // Nothing in front of it; a marker (inside a face) is where the pixel's ray stops.
        let dir = calib.world_ray(p.pixel.0, p.pixel.1).into_inner();
        let ray = Ray::new(o.cast::<f32>(), dir.cast::<f32>());
        let hit = bvh.intersect(&ray, 0.0, f32::INFINITY).unwrap();
        let d = (p.point_m - o).norm();
        assert!(hit.t as f64 > d - 1e-3, "{name} hidden: {} vs {d}", hit.t);
        if name.contains(".marker") {
            assert!((hit.t as f64 - d).abs() < 1e-4, "{name}: {} vs {d}", hit.t);
            markers += 1;
        }
    }
    assert!(markers > 1500);
    assert!(points
        .iter()
        .any(|p| p.name.as_deref().unwrap().starts_with("cube.corner")));
    // No repeated physical points (calibration refuses them): every pair at least 1 mm
    // apart, checked by brute force.
    for (i, a) in points.iter().enumerate() {
        for b in &points[i + 1..] {
            let d = (a.point_m - b.point_m).norm();
            assert!(d >= 1e-3, "{:?} and {:?} are {d} m apart", a.name, b.name);
        }
    }
}

/// `--fiducial-photo-px` (and `--realistic`, at 0.5 px of a 4032-pixel photo) moves each
/// fiducial's pixel by Gaussian noise of that size scaled to the capture's width, recorded in
/// the manifest; the points and their order stay.
#[test]
fn fiducial_noise_has_the_stated_size_and_is_recorded() {
    let tmp = tempfile::tempdir().unwrap();
    let clean = simulate(tmp.path(), "clean", &[]);
    // 50 photo pixels: 50 x 24 / 4032 = 0.2976 capture pixels at 24 across.
    let noisy = simulate(tmp.path(), "noisy", &["--fiducial-photo-px", "50"]);
    let sigma = 50.0 * 24.0 / 4032.0;
    let a = load_points(&clean.join("fiducials.toml")).unwrap();
    let b = load_points(&noisy.join("fiducials.toml")).unwrap();
    assert_eq!(a.len(), b.len());
    let d: Vec<f64> = a
        .iter()
        .zip(&b)
        .flat_map(|(p, q)| {
            assert_eq!(p.name, q.name);
            assert_eq!(p.point_m, q.point_m);
            [q.pixel.0 - p.pixel.0, q.pixel.1 - p.pixel.1]
        })
        .collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    // The sample sd of n draws has a relative standard error of 1 / sqrt(2n) (1.2 % for the
    // 3600-odd coordinates here): within 5 of them; the mean within 5 of its own.
    assert!(
        (sd / sigma - 1.0).abs() < 5.0 / (2.0 * n).sqrt(),
        "sd {sd} of {n} draws, sigma {sigma}"
    );
    assert!(mean.abs() < 5.0 * sigma / n.sqrt(), "mean {mean}");
    assert_eq!(
        manifest(&noisy).imperfections.fiducials,
        Some(FiducialNoise {
            photo_px: 50.0,
            photo_width_px: 4032.0,
            sigma_px: sigma
        })
    );
    assert_eq!(manifest(&clean).imperfections.fiducials, None);
    let realistic = simulate(tmp.path(), "realistic", &["--realistic"]);
    assert_eq!(
        manifest(&realistic).imperfections.fiducials,
        Some(FiducialNoise {
            photo_px: 0.5,
            photo_width_px: 4032.0,
            sigma_px: 0.5 * 24.0 / 4032.0
        })
    );
}

#[test]
fn capture_folder_holds_every_file_the_manifest_names() {
    let tmp = tempfile::tempdir().unwrap();
    let cap = simulate(
        tmp.path(),
        "cap",
        &[
            "--format",
            "exr,png16",
            "--vignetting",
            "0.1",
            "--dark",
            "0.01,0.001",
        ],
    );
    let m = manifest(&cap);
    assert_eq!(
        m.capture.formats,
        [StreakFormat::ExrF32, StreakFormat::Png16]
    );
    assert_eq!((m.capture.nx, m.capture.ny, m.capture.nt), (24, 16, 64));
    assert_eq!((m.capture.dt_ps, m.capture.t0_ps), (16.0, 3200.0));
    assert_eq!((m.capture.seed, m.capture.spp), (Some(0), Some(4)));
    assert_eq!(m.capture.laser_wavelength_nm, 795.0);
    assert_eq!(m.capture.pulse_width_fs, 50.0);
    assert!(m
        .capture
        .created_by
        .as_deref()
        .unwrap()
        .contains("simulate"));
    assert_eq!(m.scanlines.len(), 16);
    for s in &m.scanlines {
        for f in [Some(&s.file), s.png.as_ref(), s.exr.as_ref()] {
            assert!(cap.join(f.unwrap()).is_file());
        }
        assert!(s.file.extension().unwrap() == "exr");
        assert!(s.img.is_none());
    }
    let f = &m.files;
    for p in [
        &f.geometry,
        &f.calibration,
        &f.fiducials,
        &f.truth_camera,
        &f.truth_world,
        &f.truth_direct,
        &f.flat,
        &f.dark,
    ] {
        assert!(cap.join(p.as_ref().unwrap()).is_file(), "{p:?}");
    }
    let camera = read_cube(&cap.join("truth_camera.h5")).unwrap();
    let direct = read_cube(&cap.join("truth_direct.h5")).unwrap();
    assert_eq!((camera.nx, camera.ny, camera.nt()), (24, 16, 64));
    assert_eq!(camera.axis, direct.axis);
    // Direct light is part of all light, and not all of it with three bounces.
    let (all, one): (f64, f64) = (
        camera.data.iter().map(|&v| v as f64).sum(),
        direct.data.iter().map(|&v| v as f64).sum(),
    );
    assert!(one > 0.0 && one < all);
    for (a, d) in camera.data.iter().zip(&direct.data) {
        assert!(d <= &(a * 1.0001 + 1e-12));
    }
    let mesh = load_mesh(&cap.join("scene.glb")).unwrap();
    let scene = femto::scene::Scene::builtin("cube", None).unwrap();
    assert_eq!(mesh.triangle_count(), scene.mesh.triangle_count());
    // Nothing left beside the capture folder.
    let names: Vec<String> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["cap"]);
}

#[test]
fn existing_folder_is_refused_unless_forced() {
    let tmp = tempfile::tempdir().unwrap();
    let cap = tmp.path().join("cap");
    std::fs::create_dir(&cap).unwrap();
    std::fs::write(cap.join("keep.txt"), "mine").unwrap();
    let mut args = vec!["simulate", "--out", "cap"];
    args.extend(SMALL);
    let out = femto(tmp.path(), &args, None);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cap") && err.contains("not empty"), "{err}");
    assert_eq!(
        std::fs::read_to_string(cap.join("keep.txt")).unwrap(),
        "mine"
    );
    args.push("--force");
    let out = femto(tmp.path(), &args, None);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!cap.join("keep.txt").exists());
    assert!(cap.join("manifest.toml").is_file());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("paths/s") && stdout.contains("files:"),
        "{stdout}"
    );
    let names: Vec<String> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["cap"]);
}

#[test]
fn bad_flags_exit_2_naming_the_flag() {
    let tmp = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &str); 21] = [
        (&["--time-filter", "box"], "--transient-only"),
        (&["--rr-start-bounce", "4"], "--transient-only"),
        (
            &["--transient-only", "--rr-start-bounce", "0"],
            "--rr-start-bounce",
        ),
        (
            &["--transient-only", "--rr-start-bounce", "-1"],
            "--rr-start-bounce",
        ),
        (
            &["--transient-only", "--time-filter", "tent"],
            "--time-filter",
        ),
        (&["--transient-only", "--realistic"], "--realistic"),
        (&["--transient-only", "--threads", "0"], "--threads"),
        (&["--spp", "-3"], "--spp"),
        (&["--spp", "0"], "--spp"),
        (&["--size", "0x10"], "--size"),
        (&["--size", "64"], "--size"),
        (&["--nt", "0"], "--nt"),
        (&["--dt-ps", "-1"], "--dt-ps"),
        (&["--scene", "nosuch"], "--scene"),
        (&["--scene", "bunny"], "--bunny"),
        (&["--format", "bmp"], "--format"),
        (&["--format", "img16,img32"], "--format"),
        (&["--sweep", "1.5"], "--sweep"),
        (&["--dark", "0.1"], "--dark"),
        (&["--photon-noise", "0"], "--photon-noise"),
        (&["--seed", "-1"], "--seed"),
    ];
    for (extra, flag) in cases {
        let mut args = vec!["simulate", "--out", "cap"];
        args.extend(extra);
        let out = femto(tmp.path(), &args, None);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {err}");
        assert!(err.contains(flag), "{extra:?}: {err}");
        assert!(!tmp.path().join("cap").exists());
    }
    let out = femto(
        tmp.path(),
        &["simulate", "--out", "cap", "--paper-size", "--nt", "8"],
        None,
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--paper-size"));
}

#[test]
#[cfg_attr(
    femto_skip_shared,
    ignore = "needs the shared data folder (../shared or $FEMTO_SHARED), absent when built"
)]
fn bunny_scene_places_the_mesh_file_in_the_cornell_box() {
    let Some(bunny) = shared::file("data/stanford-bunny.obj") else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let bunny = bunny.to_string_lossy().into_owned();
    let args = [
        "simulate",
        "--scene",
        "bunny",
        "--bunny",
        &bunny,
        "--out",
        "cap",
        "--size",
        "16x12",
        "--nt",
        "16",
        "--dt-ps",
        "64",
        "--spp",
        "1",
        "--bounces",
        "1",
    ];
    let out = femto(tmp.path(), &args, None);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cap = tmp.path().join("cap");
    let bunny_mesh = load_mesh(Path::new(&bunny)).unwrap();
    let cornell = femto::scene::Scene::builtin("cornell", None).unwrap();
    let walls = cornell
        .labels
        .iter()
        .filter(|l| l.contains("wall") || *l == "floor" || *l == "ceiling")
        .count();
    assert_eq!(walls, 5);
    let glb = load_mesh(&cap.join("scene.glb")).unwrap();
    // Five wall quads (two triangles each) and the bunny.
    assert_eq!(glb.triangle_count(), 5 * 2 + bunny_mesh.triangle_count());
    assert_eq!(manifest(&cap).capture.scene, "bunny");
}

#[test]
fn transient_only_writes_the_tracers_cube_and_its_counters() {
    // The cube scene at 24 x 16, 4 spp, 3 bounces, on 2 threads: the folder holds exactly
    // the cube and the counters; the cube is the library's render with the same options
    // (bit for bit), and a box-filtered render puts the same light in the window as the
    // sensor's (each sample's weights sum to 1 either way; the scene's light lies well
    // inside the window, which tent and box differ at).
    let tmp = tempfile::tempdir().unwrap();
    let run = |name: &str, filter: &str| {
        let args = [
            "simulate",
            "--out",
            name,
            "--size",
            "24x16",
            "--nt",
            "256",
            "--dt-ps",
            "16",
            "--spp",
            "4",
            "--bounces",
            "3",
            "--transient-only",
            "--threads",
            "2",
            "--time-filter",
            filter,
        ];
        let out = femto(tmp.path(), &args, None);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        tmp.path().join(name)
    };
    let (sensor, boxed) = (run("sensor", "sensor"), run("box", "box"));
    for dir in [&sensor, &boxed] {
        let names: Vec<PathBuf> = files_under(dir).into_keys().collect();
        assert_eq!(
            names,
            ["render.json", "truth_camera.h5"].map(PathBuf::from),
            "{}",
            dir.display()
        );
    }
    let scene = femto::scene::Scene::builtin("cube", None)
        .unwrap()
        .with_resolution(24, 16, 256, 16.0);
    let bvh = Bvh::new(scene.mesh.clone());
    for (dir, filter) in [
        (&sensor, femto::tracer::TimeFilter::Sensor),
        (&boxed, femto::tracer::TimeFilter::Box),
    ] {
        let opts = femto::tracer::TraceOptions {
            spp: 4,
            max_bounces: 3,
            seed: 0,
            split_bounces: false,
            world_time: false,
            time_filter: filter,
            ..Default::default()
        };
        let expected = femto::tracer::trace(&scene, &bvh, &opts, &|_| {});
        let cube = read_cube(&dir.join("truth_camera.h5")).unwrap();
        assert_eq!(cube.frame, TimeFrame::Camera);
        assert_eq!(cube.data, expected.camera_time.data, "{filter:?}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("render.json")).unwrap())
                .unwrap();
        assert_eq!(json["paths"], 24 * 16 * 4);
        assert_eq!(json["rays"], expected.stats.rays);
        assert_eq!(json["threads"], 2);
        assert_eq!(json["max_bounces"], 3);
        assert!(json["render_seconds"].as_f64().unwrap() > 0.0);
        assert!(json["render_cpu_seconds"].as_f64().unwrap() >= 0.0);
    }
    assert_eq!(
        serde_json::from_str::<serde_json::Value>(
            &std::fs::read_to_string(boxed.join("render.json")).unwrap()
        )
        .unwrap()["time_filter"],
        "box"
    );
    let (a, b) = (
        read_cube(&sensor.join("truth_camera.h5")).unwrap(),
        read_cube(&boxed.join("truth_camera.h5")).unwrap(),
    );
    assert_ne!(a.data, b.data);
    let nt = a.axis.nt;
    for (pa, pb) in a.data.chunks(nt).zip(b.data.chunks(nt)) {
        assert_eq!((pa[0], pa[nt - 1], pb[0], pb[nt - 1]), (0.0, 0.0, 0.0, 0.0));
        let (sa, sb) = (
            pa.iter().map(|&v| v as f64).sum::<f64>(),
            pb.iter().map(|&v| v as f64).sum::<f64>(),
        );
        assert!((sa - sb).abs() <= 1e-5 * sa.max(1e-30), "{sa} vs {sb}");
    }
}

#[test]
fn transient_only_takes_russian_roulettes_first_bounce() {
    // --rr-start-bounce 6 renders what the library renders with the same setting (bit for
    // bit), differs from the default's render (3) and is recorded in render.json.
    let tmp = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let mut args = vec![
            "simulate",
            "--out",
            name,
            "--size",
            "16x12",
            "--nt",
            "128",
            "--dt-ps",
            "16",
            "--spp",
            "4",
            "--bounces",
            "7",
            "--transient-only",
        ];
        args.extend(extra);
        let out = femto(tmp.path(), &args, Some(2));
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let dir = tmp.path().join(name);
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("render.json")).unwrap())
                .unwrap();
        (read_cube(&dir.join("truth_camera.h5")).unwrap(), json)
    };
    let (default, default_json) = run("default", &[]);
    let (late, late_json) = run("late", &["--rr-start-bounce", "6"]);
    assert_eq!(default_json["rr_start_bounce"], 3);
    assert_eq!(late_json["rr_start_bounce"], 6);
    let scene = femto::scene::Scene::builtin("cube", None)
        .unwrap()
        .with_resolution(16, 12, 128, 16.0);
    let bvh = Bvh::new(scene.mesh.clone());
    let opts = femto::tracer::TraceOptions {
        spp: 4,
        max_bounces: 7,
        seed: 0,
        split_bounces: false,
        world_time: false,
        rr_start_bounce: 6,
        ..Default::default()
    };
    let expected = femto::tracer::trace(&scene, &bvh, &opts, &|_| {});
    assert_eq!(late.data, expected.camera_time.data);
    assert_ne!(late.data, default.data);
}

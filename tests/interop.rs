//! Interop with y-tal and mitransient from femto's side, with no Python: `femto export --to
//! tal` of a registered world-time cube (the cube scene's camera, its registration cast
//! into the scene's mesh) and of a camera-time cube; `femto ingest` of the export back (a
//! round trip that must give the cube again); a confocal y-tal capture ingested, unwarped with
//! both wall legs removed and exported back exactly; the refusals (no geometry, y-tal's `H`
//! named as a stack of streak images, a mitransient array without its binning).
//! Expected values are written here from the formats' definitions (H is (T, Sx, Sy), delta_t
//! and t_start metres of optical path from the laser spot), not from femto's conversions.
//!
//! The last test runs `tools/interop_check.py` (y-tal, mitransient, rosettasciio and h5py
//! read femto's files and write files femto reads) with the Python named by
//! `FEMTO_INTEROP_PYTHON` (the virtual environment `.ci/run` makes); without it it prints
//! `skipped: <why>`, and under `CI=true` it fails.

#[path = "common/cli.rs"]
mod cli;
mod common;

use cli::{arg, FemtoCmd};
use femto::container::{self, Provenance};
use femto::cube::{Cube, TimeAxis, TimeFrame};
use femto::geometry::bvh::Bvh;
use femto::interop::tal::{LaserSpot, TalCapture};
use femto::interop::{read_tal, write_tal};
use femto::store::registration;
use std::path::{Path, PathBuf};

const C_M_PER_PS: f64 = 2.99792458e-4;
const NX: usize = 12;
const NY: usize = 9;

/// A world-time cube of the cube scene with its registration; bin values 1 + x + 100 y + 1e4 t
/// so that any transposition shows.
fn registered_cube(
    dir: &Path,
    frame: TimeFrame,
) -> (PathBuf, Cube, registration::StoredRegistration) {
    let cal = common::cube_scene_calibration(NX, NY);
    let bvh = Bvh::new(common::cube_scene_mesh());
    let reg = femto::calibrate::register(&cal, &bvh, NX, NY).unwrap();
    let axis = TimeAxis {
        t0_ps: 130.0,
        dt_ps: 2.5,
        nt: 7,
    };
    let mut cube = Cube::zeros(NX, NY, axis, frame);
    for y in 0..NY {
        for x in 0..NX {
            for (t, v) in cube.profile_mut(x, y).iter_mut().enumerate() {
                *v = (1 + x + 100 * y + 10_000 * t) as f32;
            }
        }
    }
    let path = dir.join(format!("{frame:?}.h5"));
    container::write_cube(&path, &cube, &Provenance::new("test")).unwrap();
    let group = registration::registration_group(&reg, &cal, "cube scene", None);
    container::write_groups(&path, &[(registration::GROUP, group.clone())]).unwrap();
    let stored = registration::from_group(&path, &group).unwrap();
    (path, cube, stored)
}

#[test]
fn export_to_tal_writes_the_cube_as_t_sx_sy_on_the_registrations_grid() {
    let dir = tempfile::tempdir().unwrap();
    let (cube_path, cube, stored) = registered_cube(dir.path(), TimeFrame::World);
    let out = dir.path().join("capture.hdf5");
    let run = FemtoCmd::new()
        .args(["export", "--to", "tal", arg(&cube_path), "-o", arg(&out)])
        .ok();
    assert!(run.stdout.contains("laser origin"), "{}", run.stdout);
    let cap = read_tal(&out).unwrap();
    assert_eq!((cap.nt, cap.sx, cap.sy), (7, NX, NY));
    for (t, x, y) in [(0, 0, 0), (3, 5, 2), (6, 11, 8)] {
        assert_eq!(
            cap.h[(t * NX + x) * NY + y],
            (1 + x + 100 * y + 10_000 * t) as f32,
            "H[{t}, {x}, {y}]"
        );
    }
    assert_eq!(cap.h.len(), cube.data.len());
    // 30 ps after the pulse leaves the spot (cube time 100 ps): 30 ps of light.
    assert!(
        (cap.t_start_m - 30.0 * C_M_PER_PS).abs() < 1e-12,
        "{}",
        cap.t_start_m
    );
    assert!((cap.delta_t_m - 2.5 * C_M_PER_PS).abs() < 1e-15);
    assert!(!cap.t_accounts_first_and_last_bounces);
    let reg = &stored.registration;
    let mut seen = 0;
    for y in 0..NY {
        for x in 0..NX {
            let want = reg.point_m[y * NX + x];
            let got = cap.sensor_grid_xyz_m[x * NY + y];
            for c in 0..3 {
                if want[c].is_nan() {
                    assert!(got[c].is_nan());
                } else {
                    seen += 1;
                    assert!((got[c] - f64::from(want[c])).abs() <= 1e-9, "({x}, {y})");
                }
            }
        }
    }
    assert!(seen > 3 * NX * NY / 2, "most pixels see the scene");
    let spot = stored.calibration.laser_m;
    assert_eq!(
        cap.laser_grid_xyz_m,
        femto::interop::tal::LaserSpot::Single([spot.x, spot.y, spot.z])
    );
    // No laser origin recorded: the camera centre, unless given.
    let o = reg.camera_m;
    assert_eq!(cap.laser_xyz_m, [o.x, o.y, o.z]);
    FemtoCmd::new()
        .args([
            "export",
            "--to",
            "tal",
            arg(&cube_path),
            "-o",
            arg(&out),
            "--force",
        ])
        .args(["--laser-origin-m", "0.5,-1,2"])
        .ok();
    assert_eq!(read_tal(&out).unwrap().laser_xyz_m, [0.5, -1.0, 2.0]);
}

#[test]
fn a_camera_time_cube_exports_with_both_bounces_and_ingests_back_to_the_same_cube() {
    let dir = tempfile::tempdir().unwrap();
    let (cube_path, cube, stored) = registered_cube(dir.path(), TimeFrame::Camera);
    let out = dir.path().join("capture.hdf5");
    FemtoCmd::new()
        .args(["export", "--to", "tal", arg(&cube_path), "-o", arg(&out)])
        .args(["--laser-origin-m", "-0.6,1.2,1.6"])
        .ok();
    let cap = read_tal(&out).unwrap();
    assert!(cap.t_accounts_first_and_last_bounces);
    // The first bounce: laser origin 1 m straight above the spot (-0.6, 1.2, 0.6).
    assert_eq!(stored.calibration.laser_m.z, 0.6);
    assert!((cap.t_start_m - (30.0 * C_M_PER_PS + 1.0)).abs() < 1e-12);

    // Back into femto: the same values, axis and clock, the geometry in the tal group.
    let back = dir.path().join("back.h5");
    let run = FemtoCmd::new()
        .args(["ingest", arg(&out), "-o", arg(&back)])
        .ok();
    assert!(run.stdout.contains("y-tal capture"), "{}", run.stdout);
    let got = container::read_cube(&back).unwrap();
    assert_eq!(got.data, cube.data);
    assert_eq!(got.frame, TimeFrame::Camera);
    // The spot's time is the tal clock's zero: 30 ps after it.
    assert!((got.axis.t0_ps - 30.0).abs() < 1e-9, "{}", got.axis.t0_ps);
    assert!((got.axis.dt_ps - 2.5).abs() < 1e-12);
    assert!(container::list_groups(&back)
        .unwrap()
        .contains(&"tal".to_string()));
    // And out again from the tal group alone: the same capture.
    let again = dir.path().join("again.hdf5");
    FemtoCmd::new()
        .args(["export", "--to", "tal", arg(&back), "-o", arg(&again)])
        .ok();
    let cap2 = read_tal(&again).unwrap();
    assert_eq!(cap2.h, cap.h);
    assert!((cap2.t_start_m - cap.t_start_m).abs() < 1e-12);
    assert_eq!(cap2.laser_xyz_m, cap.laser_xyz_m);
    let same = |a: &[[f64; 3]], b: &[[f64; 3]]| {
        a.iter()
            .flatten()
            .zip(b.iter().flatten())
            .all(|(p, q)| p == q || (p.is_nan() && q.is_nan()))
    };
    assert!(same(&cap2.sensor_grid_xyz_m, &cap.sensor_grid_xyz_m));
}

#[test]
fn ytal_h_named_as_a_stack_is_read_as_a_capture_not_as_streak_images() {
    let dir = tempfile::tempdir().unwrap();
    let (cube_path, cube, _) = registered_cube(dir.path(), TimeFrame::World);
    let cap = dir.path().join("capture.hdf5");
    FemtoCmd::new()
        .args(["export", "--to", "tal", arg(&cube_path), "-o", arg(&cap)])
        .ok();
    let out = dir.path().join("h.h5");
    FemtoCmd::new()
        .args(["ingest", arg(&cap), "--dataset", "H", "-o", arg(&out)])
        .ok();
    let got = container::read_cube(&out).unwrap();
    assert_eq!((got.nx, got.ny, got.axis.nt), (NX, NY, 7));
    assert_eq!(got.data, cube.data);
    assert_eq!(got.frame, TimeFrame::World);
}

#[test]
fn refusals_name_the_file_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A cube without geometry.
    let bare = d.join("bare.h5");
    let axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: 1.0,
        nt: 4,
    };
    container::write_cube(
        &bare,
        &Cube::zeros(3, 2, axis, TimeFrame::World),
        &Provenance::new("test"),
    )
    .unwrap();
    let out = d.join("x.hdf5");
    let err = FemtoCmd::new()
        .args(["export", "--to", "tal", arg(&bare), "-o", arg(&out)])
        .refused();
    assert!(
        err.contains("bare.h5") && err.contains("registration"),
        "{err}"
    );
    assert!(!out.exists());
    // A mitransient array without its binning; with a streak flag; a streak capture with a
    // mitransient flag.
    let npy = d.join("render.npy");
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    let mut header =
        "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3, 4, 3), }".to_string();
    while !(10 + header.len() + 1).is_multiple_of(64) {
        header.push(' ');
    }
    header.push('\n');
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    bytes.extend(std::iter::repeat_n(0u8, 2 * 3 * 4 * 3 * 4));
    std::fs::write(&npy, &bytes).unwrap();
    let cube = d.join("m.h5");
    let err = FemtoCmd::new()
        .args(["ingest", arg(&npy), "-o", arg(&cube)])
        .refused();
    assert!(
        err.contains("--start-opl-m") && err.contains("render.npy"),
        "{err}"
    );
    let err = FemtoCmd::new()
        .args(["ingest", arg(&npy), "-o", arg(&cube), "--dark", "3"])
        .args(["--start-opl-m", "1", "--bin-width-opl-m", "0.01"])
        .refused();
    assert!(err.contains("--dark"), "{err}");
    let err = FemtoCmd::new()
        .args([
            "ingest",
            arg(&npy),
            "-o",
            arg(&cube),
            "--channels",
            "luminance",
        ])
        .args(["--start-opl-m", "1", "--bin-width-opl-m", "0"])
        .refused();
    assert!(err.contains("bin_width_opl"), "{err}");
    assert!(!cube.exists());
    // The array ingested: 3 x 2 pixels, 4 bins of 0.01 m / c from 1 m / c.
    FemtoCmd::new()
        .args(["ingest", arg(&npy), "-o", arg(&cube)])
        .args(["--start-opl-m", "1", "--bin-width-opl-m", "0.01"])
        .ok();
    let got = container::read_cube(&cube).unwrap();
    assert_eq!((got.nx, got.ny, got.axis.nt), (3, 2, 4));
    assert!((got.axis.t0_ps - 1.0 / C_M_PER_PS).abs() < 1e-6);
    assert!((got.axis.dt_ps - 0.01 / C_M_PER_PS).abs() < 1e-9);
    assert_eq!(got.frame, TimeFrame::Camera);
}

/// A confocal y-tal capture (laser grid = sensor grid, as y-tal's `render` writes a
/// `scan_type = 'confocal'` capture) of a 4 x 3 grid on the plane z = 1 m, sensor and laser at
/// different origins, camera clock (`t_accounts_first_and_last_bounces = True`). Each pixel
/// holds one pulse: the wall point's own echo from a hidden point 0.3 m behind it (0.6 m of
/// path) after both wall legs. Ingested, unwarped and exported, it must come back exactly,
/// and the world-time cube must hold every pulse in the same bin.
#[test]
fn a_confocal_capture_unwarps_both_legs_and_round_trips_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (sx, sy, nt) = (4usize, 3usize, 400usize);
    let delta_t_m = 0.01;
    let sensor = [0.1, -0.2, -0.5];
    let laser = [-0.3, 0.1, -0.4];
    let dist = |a: [f64; 3], b: [f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let mut grid = vec![[0.0; 3]; sx * sy];
    let mut h = vec![0.0f32; nt * sx * sy];
    let echo_m = 0.6;
    for x in 0..sx {
        for y in 0..sy {
            let p = [0.2 * x as f64 - 0.3, 0.2 * y as f64 - 0.2, 1.0];
            grid[x * sy + y] = p;
            let opl = dist(laser, p) + dist(p, sensor) + echo_m;
            let t = (opl / delta_t_m).floor() as usize;
            h[(t * sx + x) * sy + y] = (1 + x + 10 * y) as f32;
        }
    }
    let cap = TalCapture {
        nt,
        sx,
        sy,
        h,
        delta_t_m,
        t_start_m: 0.0,
        t_accounts_first_and_last_bounces: true,
        sensor_xyz_m: sensor,
        sensor_grid_xyz_m: grid,
        sensor_grid_normals: None,
        laser_xyz_m: laser,
        laser_grid_xyz_m: LaserSpot::Confocal,
    };
    let src = d.join("confocal.hdf5");
    write_tal(&src, &cap).unwrap();
    assert_eq!(read_tal(&src).unwrap(), cap, "y-tal's layout reads back");
    let info = FemtoCmd::new().args(["info", arg(&src)]).ok().stdout;
    for want in [
        "y-tal capture",
        "3 x 4 x 400 (ny, nx, nt)",
        "camera time",
        "confocal",
    ] {
        assert!(info.contains(want), "{want}: {info}");
    }

    let camera = d.join("camera.h5");
    FemtoCmd::new()
        .args(["ingest", arg(&src), "-o", arg(&camera)])
        .ok();
    let back = d.join("back.hdf5");
    FemtoCmd::new()
        .args(["export", "--to", "tal", arg(&camera), "-o", arg(&back)])
        .ok();
    let again = read_tal(&back).unwrap();
    assert_eq!(again.h, cap.h, "H round-trips exactly");
    assert_eq!(again.laser_grid_xyz_m, LaserSpot::Confocal);
    assert_eq!(again.sensor_grid_xyz_m, cap.sensor_grid_xyz_m);
    assert!((again.t_start_m - cap.t_start_m).abs() < 1e-12);
    assert!((again.delta_t_m - cap.delta_t_m).abs() < 1e-15);
    assert!(again.t_accounts_first_and_last_bounces);

    // Both legs removed: every pulse lands where the echo alone puts it, 0.6 m of light
    // after the pulse is at the pixel's own wall point.
    let world = d.join("world.h5");
    let out = FemtoCmd::new()
        .args(["unwarp", arg(&camera), "-o", arg(&world)])
        .ok()
        .stdout;
    assert!(out.contains("12 of 12 pixels shifted"), "{out}");
    let w = container::read_cube(&world).unwrap();
    assert_eq!(w.frame, TimeFrame::World);
    let want_ps = echo_m / C_M_PER_PS;
    for y in 0..sy {
        for x in 0..sx {
            let profile = w.profile(x, y);
            let total: f32 = profile.iter().sum();
            let mean_ps: f64 = profile
                .iter()
                .enumerate()
                .map(|(i, &v)| f64::from(v) * (w.axis.t0_ps + (i as f64 + 0.5) * w.axis.dt_ps))
                .sum::<f64>()
                / f64::from(total);
            assert!(
                (total - (1 + x + 10 * y) as f32).abs() < 1e-3,
                "({x}, {y}) {total}"
            );
            // The pulse filled one bin of the capture: within a bin of the echo's time.
            let bin_ps = delta_t_m / C_M_PER_PS;
            assert!(
                (mean_ps - want_ps).abs() < bin_ps,
                "({x}, {y}): {mean_ps} ps, want {want_ps} +- {bin_ps}"
            );
        }
    }
    // Rendered with no calibration and no mesh: the wall grid stands for them (the camera
    // looks straight at the wall), and the echo lights the frames.
    let frames = d.join("frames");
    let run = FemtoCmd::new()
        .args(["render", "--cube", arg(&world), "--out", arg(&frames)])
        .args(["--capture-view", "--size", "16x12", "--frame-count", "20"])
        .ok();
    assert!(!run.stderr.contains("entirely black"), "{}", run.stderr);
    let lit = (0..20)
        .filter(|k| {
            let png = image::open(frames.join(format!("frame_{k:05}.png"))).unwrap();
            png.to_rgb8().pixels().any(|p| p.0.iter().any(|&c| c > 0))
        })
        .count();
    assert!(lit > 0, "some frame shows the echo");
    // The world-time cube exports as y-tal's False clock, still confocal.
    let wback = d.join("wback.hdf5");
    FemtoCmd::new()
        .args(["export", "--to", "tal", arg(&world), "-o", arg(&wback)])
        .ok();
    let wcap = read_tal(&wback).unwrap();
    assert!(!wcap.t_accounts_first_and_last_bounces);
    assert_eq!(wcap.laser_grid_xyz_m, LaserSpot::Confocal);
}

/// Whether the interop check must run (`CI=true`) rather than be skipped.
fn required() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true")
}

#[test]
#[cfg_attr(
    femto_skip_interop,
    ignore = "needs $FEMTO_INTEROP_PYTHON (the venv .ci/run makes), unset when built"
)]
fn the_python_interop_check_passes() {
    let python = match std::env::var("FEMTO_INTEROP_PYTHON") {
        Ok(p) if Path::new(&p).is_file() => p,
        other => {
            let why = match other {
                Ok(p) => format!("FEMTO_INTEROP_PYTHON={p} is not a file"),
                Err(_) => "FEMTO_INTEROP_PYTHON is not set (the venv .ci/run makes: \
                           target/interop-venv/bin/python)"
                    .to_string(),
            };
            assert!(
                !required(),
                "CI=true and the interop check cannot run: {why}"
            );
            println!("skipped: {why}");
            return;
        }
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = std::process::Command::new(&python)
        .arg(root.join("tools/interop_check.py"))
        .arg(env!("CARGO_BIN_EXE_femto"))
        .output()
        .expect("python runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    println!("{text}");
    assert!(
        out.status.success(),
        "tools/interop_check.py failed:\n{text}"
    );
}

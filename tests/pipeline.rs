//! The stages' defaults on a realistic capture, through the command line (issue 15, items 1
//! and 6): calibrate's detection floor comes from the cube's noise and a fit that depends on
//! it is refused; later stages keep the cube's compression; an output that is an input is
//! refused with nothing written.

#[path = "common/cli.rs"]
mod cli;

use cli::{arg, femto_ok, femto_refused};
use femto::camera::Calibration;
use std::path::{Path, PathBuf};

/// A realistic capture of the cube scene (64 x 48, 256 bins of 4 ps), ingested with the lab's
/// corrections given as flags (dark frame, flat field, sweep table, jitter, laser power), as
/// the demo does; `compression` is ingest's `--compression`.
fn corrected_cube(dir: &Path, compression: &str) -> (PathBuf, PathBuf) {
    let cap = dir.join("cap");
    femto_ok(&[
        "simulate",
        "--size",
        "64x48",
        "--spp",
        "64",
        "--realistic",
        "--out",
        arg(&cap),
    ]);
    let manifest = femto::manifest::Manifest::load(&cap.join("manifest.toml")).unwrap();
    let edges = manifest.imperfections.sweep.unwrap().bin_times_ps;
    let table = dir.join("sweep.txt");
    let text: Vec<String> = edges.iter().map(|e| e.to_string()).collect();
    std::fs::write(&table, text.join("\n")).unwrap();
    let cube = dir.join("cube.h5");
    femto_ok(&[
        "ingest",
        arg(&cap),
        "-o",
        arg(&cube),
        "--dark",
        arg(&cap.join("dark.exr")),
        "--flat",
        arg(&cap.join("flat.exr")),
        "--sweep-table",
        arg(&table),
        "--jitter",
        "--power-ref",
        "auto",
        "--compression",
        compression,
    ]);
    (cap, cube)
}

fn calibrate_args<'a>(cap: &'a Path, cube: &'a Path, laser: &'a str) -> Vec<String> {
    vec![
        "calibrate".into(),
        arg(cube).into(),
        "--mesh".into(),
        arg(&cap.join("scene.glb")).into(),
        "--points".into(),
        arg(&cap.join("fiducials.toml")).into(),
        format!("--laser={laser}"),
    ]
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

#[test]
fn calibrate_finds_t0_with_its_default_floor_and_refuses_a_floor_that_decides_it() {
    let dir = tempfile::tempdir().unwrap();
    let (cap, cube) = corrected_cube(dir.path(), "1");
    let truth = Calibration::load(&cap.join("calibration.toml")).unwrap();
    let l = truth.laser_m;
    let laser = format!("{},{},{}", l.x, l.y, l.z);
    let args = calibrate_args(&cap, &cube, &laser);

    // With no floor, noise spikes pass for first arrivals: refused, cube untouched.
    let before = std::fs::read(&cube).unwrap();
    let mut no_floor = args.clone();
    no_floor.extend(["--min-peak".into(), "0".into()]);
    let err = femto_refused(&strs(&no_floor));
    assert!(err.contains("t0 is not determined"), "{err}");
    assert_eq!(
        std::fs::read(&cube).unwrap(),
        before,
        "the cube was rewritten"
    );
    assert!(!cube.with_file_name("cube.calibration.toml").exists());

    // The default floor: t0 within a tenth of a bin, with its standard error reported.
    let out = femto_ok(&strs(&args));
    assert!(out.stdout.contains("detection floor"), "{}", out.stdout);
    let fitted = Calibration::load(&cube.with_file_name("cube.calibration.toml")).unwrap();
    let dt_ps = femto::container::read_meta(&cube).unwrap().axis.dt_ps;
    let err_bins = (fitted.t0_ps - truth.t0_ps).abs() / dt_ps;
    println!("t0 {:.3} ps, {err_bins:.4} bins off", fitted.t0_ps);
    assert!(err_bins <= 0.1, "t0 off by {err_bins} bins");
}

#[test]
fn calibrate_and_pyramid_keep_an_uncompressed_cube_uncompressed() {
    let dir = tempfile::tempdir().unwrap();
    let (cap, cube) = corrected_cube(dir.path(), "none");
    let meta = femto::container::read_meta(&cube).unwrap();
    let raw_bytes = (meta.nx * meta.ny * meta.axis.nt * 4) as u64;
    let size = |p: &Path| std::fs::metadata(p).unwrap().len();
    assert!(size(&cube) >= raw_bytes);
    let l = Calibration::load(&cap.join("calibration.toml"))
        .unwrap()
        .laser_m;
    let laser = format!("{},{},{}", l.x, l.y, l.z);
    femto_ok(&strs(&calibrate_args(&cap, &cube, &laser)));
    assert!(
        size(&cube) >= raw_bytes,
        "calibrate re-encoded the cube: {} bytes for {raw_bytes} bytes of values",
        size(&cube)
    );
    let reader = femto::container::CubeReader::open(&cube).unwrap();
    assert_eq!(
        reader.stored_compression(),
        femto::container::CubeCompression::None
    );
    drop(reader);
    femto_ok(&["pyramid", arg(&cube)]);
    let reader = femto::container::CubeReader::open(&cube).unwrap();
    assert_eq!(
        reader.stored_compression(),
        femto::container::CubeCompression::None
    );
    // unwarp keeps it too, unless told.
    let world = dir.path().join("world.h5");
    femto_ok(&["unwarp", arg(&cube), "--out", arg(&world)]);
    let reader = femto::container::CubeReader::open(&world).unwrap();
    assert_eq!(
        reader.stored_compression(),
        femto::container::CubeCompression::None
    );
}

#[test]
fn an_output_that_is_an_input_is_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let (cap, cube) = corrected_cube(dir.path(), "1");
    let l = Calibration::load(&cap.join("calibration.toml"))
        .unwrap()
        .laser_m;
    let laser = format!("{},{},{}", l.x, l.y, l.z);
    let before = std::fs::read(&cube).unwrap();
    let mut args = calibrate_args(&cap, &cube, &laser);
    args.extend(["--out".into(), arg(&cube).into()]);
    let err = femto_refused(&strs(&args));
    assert!(err.contains("--out"), "{err}");
    assert_eq!(std::fs::read(&cube).unwrap(), before);
    let err = femto_refused(&["unwarp", arg(&cube), "--out", arg(&cube)]);
    assert!(err.contains("--out"), "{err}");
    assert_eq!(std::fs::read(&cube).unwrap(), before);
    // calibrate for real, unwarp, then a render onto the world cube.
    femto_ok(&strs(&calibrate_args(&cap, &cube, &laser)));
    let world = dir.path().join("world.h5");
    femto_ok(&["unwarp", arg(&cube), "--out", arg(&world)]);
    let world_before = std::fs::read(&world).unwrap();
    let err = femto_refused(&[
        "render",
        "--cube",
        arg(&world),
        "--calibration",
        arg(&cube.with_file_name("cube.calibration.toml")),
        "--mesh",
        arg(&cap.join("scene.glb")),
        "--capture-view",
        "--size",
        "32x24",
        "--frame-count",
        "2",
        "--format",
        "gif",
        "--out",
        arg(&world),
    ]);
    assert!(err.contains("--out"), "{err}");
    assert_eq!(std::fs::read(&world).unwrap(), world_before);
}

//! The overwrite rule (docs/faults.md, "Overwriting"): every command refuses an output that
//! exists, in one line naming the flag and the path and saying `--force`, with nothing
//! written; with `--force` it replaces that output whole. A split render may add frames of
//! other ranges to a folder; its own frames are outputs like any other.

use super::{calibrate_args, case, cli, laser_flag, render_args};
use cli::{femto_in, refused_unchanged};

fn ok(dir: &std::path::Path, args: &[&str]) -> cli::Run {
    let run = femto_in(Some(dir), args);
    assert_eq!(
        run.code,
        Some(0),
        "femto {}: {}",
        args.join(" "),
        run.stderr
    );
    run
}

fn groups(path: &std::path::Path) -> Vec<String> {
    femto::container::GroupReader::open(path)
        .unwrap()
        .groups()
        .to_vec()
}

#[test]
fn ingest_unwarp_and_export_refuse_an_existing_out_unless_forced() {
    let dir = case(&["cap", "cube.h5", "world.h5", "cube.calibration.toml"]);
    let d = dir.path();
    // world.h5 holds a pyramid: replaced whole, the pyramid goes, and the user is told.
    assert!(groups(&d.join("world.h5")).contains(&"pyramid".to_string()));
    let unwarp = ["unwarp", "cube.h5", "--out", "world.h5"];
    refused_unchanged(d, &unwarp, &[], &["--out world.h5", "--force"]);
    let run = ok(d, &[&unwarp[..], &["--force"]].concat());
    assert!(run.stderr.contains("pyramid"), "{}", run.stderr);
    assert!(!groups(&d.join("world.h5")).contains(&"pyramid".to_string()));
    // The output is an input: refused even with --force.
    refused_unchanged(
        d,
        &["unwarp", "cube.h5", "--out", "cube.h5", "--force"],
        &[],
        &["--out cube.h5", "input"],
    );

    let export = ["export", "--to", "tal", "world.h5", "-o", "tal.hdf5"];
    ok(d, &export);
    refused_unchanged(d, &export, &[], &["--out tal.hdf5", "--force"]);
    ok(d, &[&export[..], &["--force"]].concat());

    // Last: the new cube has no registration for the unwarp above.
    let ingest = ["ingest", "cap", "-o", "cube.h5"];
    refused_unchanged(d, &ingest, &[], &["--out cube.h5", "--force"]);
    ok(d, &[&ingest[..], &["--force"]].concat());
}

#[test]
fn calibrate_and_pyramid_refuse_an_existing_file_unless_forced() {
    let dir = case(&["cap", "cube.h5", "world.h5", "cube.calibration.toml"]);
    let d = dir.path();
    let laser = laser_flag();
    // The default --out exists.
    let again = calibrate_args(&[&laser]);
    refused_unchanged(d, &again, &[], &["cube.calibration.toml", "--force"]);
    ok(d, &[&again[..], &["--force"]].concat());
    // A new --out: the cube's registration follows it.
    ok(d, &calibrate_args(&[&laser, "--out", "new.toml"]));

    // The cube's own pyramid is derived data: replaced by a new one.
    ok(d, &["pyramid", "world.h5", "--levels", "2"]);
    ok(d, &["pyramid", "world.h5", "--side-file", "side.h5"]);
    refused_unchanged(
        d,
        &["pyramid", "world.h5", "--side-file", "side.h5"],
        &[],
        &["--side-file side.h5", "--force"],
    );
    ok(
        d,
        &["pyramid", "world.h5", "--side-file", "side.h5", "--force"],
    );
}

#[test]
fn render_refuses_its_own_frames_and_videos_but_adds_other_ranges() {
    let dir = case(&["cap", "world.h5", "cube.calibration.toml"]);
    let d = dir.path();
    let base = [
        "--dolly",
        "0.5",
        "--size",
        "32x24",
        "--frame-count",
        "4",
        "--out",
    ];
    let frames = |range: &'static str| {
        let mut extra = base.to_vec();
        extra.extend(["frames", "--frames", range]);
        render_args("cube.calibration.toml", &extra)
    };
    ok(d, &frames("0..2"));
    // Another job's range joins the folder.
    ok(d, &frames("2..4"));
    let mut listed: Vec<String> = std::fs::read_dir(d.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    listed.sort();
    // The four frames and the record of the sequence they are parts of (femto encode's).
    assert_eq!(
        listed,
        [
            "frame_00000.png",
            "frame_00001.png",
            "frame_00002.png",
            "frame_00003.png",
            "sequence.toml"
        ]
    );
    refused_unchanged(d, &frames("1..3"), &[], &["frame_00001.png", "--force"]);
    ok(d, &[&frames("1..3")[..], &["--force"]].concat());

    let mut extra = base.to_vec();
    extra.push("v.gif");
    let gif = render_args("cube.calibration.toml", &extra);
    ok(d, &gif);
    refused_unchanged(d, &gif, &[], &["--out v.gif", "--force"]);
}

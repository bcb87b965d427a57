//! A capture and a video split over processes, as a cluster runs them (docs/cluster.md):
//! `simulate --rows A..B` bands equal the same rows of a whole run, whatever the thread
//! count; `merge` assembles them into the whole run's capture folder bit for bit and refuses
//! gaps, overlaps and bands of other settings; `encode` turns the PNG frame folders of a
//! split render into the single render's MP4 and GIF, byte for byte.

#[path = "common/cli.rs"]
mod cli;

use cli::{arg, files_under, refused_unchanged, FemtoCmd};
use femto::container::CubeReader;
use std::path::Path;

/// A small capture with every imperfection and two scanline formats: 32 x 24 pixels, 64
/// bins, 4 paths per pixel.
const SIM: &[&str] = &[
    "simulate",
    "--scene",
    "cube",
    "--size",
    "32x24",
    "--nt",
    "64",
    "--spp",
    "4",
    "--realistic",
    "--format",
    "png16,exr",
];

/// The bands of the tests: rows 0..9, 9..16, 16..24.
const BANDS: [(usize, usize); 3] = [(0, 9), (9, 16), (16, 24)];

/// `femto simulate SIM extra...` run in `dir` with `threads` rayon threads.
fn simulate_in(dir: &Path, threads: usize, extra: &[&str]) {
    std::fs::create_dir_all(dir).unwrap();
    FemtoCmd::new()
        .args(SIM)
        .args(extra)
        .current_dir(dir)
        .env("RAYON_NUM_THREADS", threads.to_string())
        .ok();
}

fn band_name(r: (usize, usize)) -> String {
    format!("band_{}_{}", r.0, r.1)
}

#[test]
fn three_bands_equal_the_whole_run_with_one_and_two_threads() {
    let tmp = tempfile::tempdir().unwrap();
    let whole_dir = tmp.path().join("whole");
    // The whole run and the merges write `cap` from their own folders, so the command line
    // the capture records (`--out cap`) is the same.
    simulate_in(&whole_dir, 2, &["--out", "cap"]);
    let whole = files_under(&whole_dir.join("cap"));
    for threads in [1, 2] {
        let bands_dir = tmp.path().join(format!("bands_{threads}"));
        // `--threads N` on the bands: the merged capture records the equivalent single
        // command, without it, as the whole run (which had none) recorded.
        let n = threads.to_string();
        for r in BANDS {
            let rows = format!("{}..{}", r.0, r.1);
            simulate_in(
                &bands_dir,
                threads,
                &["--out", &band_name(r), "--rows", &rows, "--threads", &n],
            );
        }
        // Each band's truth rows are the whole run's rows.
        for file in ["truth_camera.h5", "truth_world.h5", "truth_direct.h5"] {
            let full = CubeReader::open(&whole_dir.join("cap").join(file)).unwrap();
            for r in BANDS {
                let band = CubeReader::open(&bands_dir.join(band_name(r)).join(file)).unwrap();
                assert_eq!(
                    band.read_rows(0, r.1 - r.0).unwrap(),
                    full.read_rows(r.0, r.1 - r.0).unwrap(),
                    "{threads} threads, {file}, rows {r:?}"
                );
            }
        }
        let merged_dir = tmp.path().join(format!("merged_{threads}"));
        std::fs::create_dir_all(&merged_dir).unwrap();
        // Bands in any order.
        let band_dirs: Vec<String> = BANDS
            .iter()
            .rev()
            .map(|&r| arg(&bands_dir.join(band_name(r))).to_string())
            .collect();
        let run = FemtoCmd::new()
            .arg("merge")
            .args(&band_dirs)
            .args(["--out", "cap"])
            .current_dir(&merged_dir)
            .ok();
        assert!(
            run.stdout.contains("capture written to cap"),
            "{}",
            run.stdout
        );
        let merged = files_under(&merged_dir.join("cap"));
        assert_eq!(
            merged.keys().collect::<Vec<_>>(),
            whole.keys().collect::<Vec<_>>(),
            "{threads} threads: the same files"
        );
        for (name, bytes) in &whole {
            assert!(
                merged[name] == *bytes,
                "{threads} threads: {} differs from the whole run's",
                name.display()
            );
        }
    }
}

#[test]
fn merge_refuses_gaps_overlaps_and_other_settings_writing_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    for (name, rows, extra) in [
        ("a", "0..9", &[][..]),
        ("b", "9..16", &[][..]),
        ("c", "16..24", &[][..]),
        ("overlap", "8..16", &[][..]),
        ("seed", "16..24", &["--seed", "7"][..]),
        ("bounces", "16..24", &["--bounces", "2"][..]),
        ("size", "16..24", &["--nt", "32"][..]),
    ] {
        let args: Vec<&str> = SIM
            .iter()
            .copied()
            .filter(|a| !(extra.contains(&"--nt") && (*a == "--nt" || *a == "64")))
            .chain(["--out", name, "--rows", rows])
            .chain(extra.iter().copied())
            .collect();
        FemtoCmd::new().args(&args).current_dir(dir).ok();
    }
    std::fs::create_dir(dir.join("empty")).unwrap();
    let merge = |bands: &[&str], names: &[&str]| {
        let mut args = vec!["merge"];
        args.extend(bands);
        args.extend(["--out", "cap"]);
        refused_unchanged(dir, &args, &[], names)
    };
    let gap = merge(&["a", "c"], &["rows 9..16", "no band", "a", "c"]);
    let tail = merge(&["a", "b"], &["rows 16..24", "no band", "b"]);
    let head = merge(&["b", "c"], &["rows 0..9", "no band"]);
    let overlap = merge(
        &["a", "overlap", "c"],
        &["rows 8..9", "two bands", "overlap"],
    );
    let seed = merge(&["a", "b", "seed"], &["seed", "7", "differs"]);
    let bounces = merge(&["a", "b", "bounces"], &["max_bounces", "2", "differs"]);
    let size = merge(&["a", "b", "size"], &["size", "differs"]);
    let not_band = merge(&["a", "b", "empty"], &["empty", "band.toml", "not a band"]);
    for line in [gap, tail, head, overlap, seed, bounces, size, not_band] {
        println!("{line}");
    }
    // --rows outside the image is refused by simulate.
    refused_unchanged(
        dir,
        &[SIM, &["--out", "z", "--rows", "20..30"]].concat(),
        &[],
        &["--rows", "20..30", "24 rows"],
    );
}

#[test]
fn encode_makes_the_single_renders_mp4_and_gif_from_split_png_frames() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    simulate_in(dir, 2, &["--out", "cap"]);
    let render = |extra: &[&str]| {
        let base = [
            "render",
            "--cube",
            "cap/truth_world.h5",
            "--calibration",
            "cap/calibration.toml",
            "--mesh",
            "cap/scene.glb",
            "--dolly",
            "0.5",
            "--size",
            "32x24",
            "--frame-count",
            "7",
        ];
        FemtoCmd::new().args(base).args(extra).current_dir(dir).ok();
    };
    render(&["--out", "single.mp4"]);
    render(&["--out", "single.gif"]);
    for (i, frames) in ["0..3", "3..5", "5..7"].iter().enumerate() {
        render(&[
            "--frames",
            frames,
            "--format",
            "png",
            "--out",
            &format!("part{i}"),
        ]);
    }
    for video in ["split.mp4", "split.gif"] {
        FemtoCmd::new()
            .args(["encode", "part2", "part0", "part1", "--out", video])
            .current_dir(dir)
            .ok();
        let single = video.replace("split", "single");
        assert!(
            std::fs::read(dir.join(video)).unwrap() == std::fs::read(dir.join(&single)).unwrap(),
            "{video} differs from {single}"
        );
    }
    let encode = |parts: &[&str], names: &[&str]| {
        let mut args = vec!["encode"];
        args.extend(parts);
        args.extend(["--out", "bad.mp4"]);
        refused_unchanged(dir, &args, &[], names)
    };
    encode(
        &["part0", "part2"],
        &["frames 3..5", "no folder", "part0", "part2"],
    );
    encode(&["part0", "part1", "part1"], &["frame 3", "two folders"]);
    // A set shorter than the 7 frames the render planned: the last part, or the first.
    encode(
        &["part0", "part1"],
        &[
            "frames 5..7 of the 7 the render planned",
            "given end at frame 4",
        ],
    );
    encode(
        &["part2", "part1"],
        &[
            "frames 0..3 of the 7 the render planned",
            "given start at frame 3",
        ],
    );
    encode(&["cap"], &["cap", "no PNG frames"]);
    refused_unchanged(
        dir,
        &["encode", "part0", "--out", "bad.avi"],
        &[],
        &["--out", "bad.avi"],
    );
    // The overwrite rule: an existing video is refused, and replaced with --force.
    let again = ["encode", "part0", "part1", "part2", "--out", "split.mp4"];
    refused_unchanged(dir, &again, &[], &["--out split.mp4", "--force"]);
    FemtoCmd::new()
        .args(again)
        .arg("--force")
        .current_dir(dir)
        .ok();
}

//! Fault cases: inconsistent checks (issue 16). A capture whose scanlines are stored at
//! different bit depths, NaN or infinity inside an HDF5 cube or pyramid, clap's parse errors
//! (one line, like every other error), and messages that must name the file or flag at
//! fault. Each bad input is written by hand here from a copy of the fixture's files.

use super::{calibrate_args, case, cli, fixture, laser_flag, render_args};
use cli::refused_unchanged;
use femto::container::{CubeReader, CubeWriter, DataBuf, GroupData, Provenance};
use std::path::Path;

// ---------------------------------------------------------------------------------------------
// Mixed bit depths.

/// The capture's scanline files, sorted (PNG16 in the fixture).
fn scanlines(cap: &Path) -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = std::fs::read_dir(cap.join("scanlines"))
        .expect("the capture's scanlines folder")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    files.sort();
    assert!(files.len() > 3, "{files:?}");
    files
}

/// Rewrite a 16-bit grey PNG as the 8-bit PNG a user would get from a converter that keeps
/// the top byte.
fn to_png8(path: &Path) {
    let img = image::open(path).unwrap().into_luma16();
    let img8 = image::GrayImage::from_fn(img.width(), img.height(), |x, y| {
        image::Luma([(img.get_pixel(x, y)[0] >> 8) as u8])
    });
    img8.save(path).unwrap();
    let back = image::open(path).unwrap();
    assert_eq!(back.color(), image::ColorType::L8);
}

/// Render flags for a small two-frame dolly into `out.gif`.
const SMALL_DOLLY: [&str; 8] = [
    "--dolly",
    "0.5",
    "--frame-count",
    "2",
    "--size",
    "16x12",
    "--out",
    "out.gif",
];

/// An 8-bit PNG among the 16-bit scanlines (read through the general reader) is refused,
/// naming the file, its depth and the capture's; so is the converse, an 8-bit first
/// scanline followed by 16-bit ones (read through ingest's 16-bit fast path). Before,
/// both were ingested with exit 0, the 8-bit rows 256 times too dim.
#[test]
fn a_scanline_of_another_bit_depth_is_refused() {
    for which in [2usize, 0] {
        let dir = case(&["cap"]);
        let files = scanlines(&dir.path().join("cap"));
        let odd = &files[which];
        to_png8(odd);
        let name = odd.file_name().unwrap().to_str().unwrap();
        let (found, capture) = if which == 0 {
            ("16-bit integer", "8-bit integer")
        } else {
            ("8-bit integer", "16-bit integer")
        };
        let culprit = if which == 0 {
            files[1].file_name().unwrap().to_str().unwrap()
        } else {
            name
        };
        let err = refused_unchanged(
            dir.path(),
            &["ingest", "cap", "-o", "cube.h5"],
            &[],
            &[culprit, found, capture],
        );
        assert!(err.contains(&format!("{found} samples, but the capture's are {capture}")));
    }
}

// ---------------------------------------------------------------------------------------------
// NaN and infinity in cubes and pyramids.

/// Copy the cube file `name` of `dir` onto itself with `edit` applied to its values
/// (`[y][x][t]`) and to its groups, as another tool would write it.
fn rewrite_cube(
    dir: &Path,
    name: &str,
    edit: impl FnOnce(&mut [f32], usize, usize, &mut Vec<(String, GroupData)>),
) {
    let path = dir.join(name);
    let reader = CubeReader::open(&path).unwrap();
    let meta = reader.meta().clone();
    let mut values = reader.read_rows(0, meta.ny).unwrap();
    let mut groups: Vec<(String, GroupData)> = meta
        .groups
        .iter()
        .map(|g| (g.clone(), reader.read_group(g).unwrap()))
        .collect();
    let mask = reader.read_mask().unwrap();
    drop(reader);
    edit(&mut values, meta.nx, meta.axis.nt, &mut groups);
    let mut w = CubeWriter::create(
        &path,
        meta.nx,
        meta.ny,
        meta.axis,
        meta.frame,
        &meta.units,
        &Provenance::new("hand-edited by the fault corpus"),
    )
    .unwrap();
    w.write_rows(0, &values).unwrap();
    if let Some(m) = mask {
        w.write_mask(&m).unwrap();
    }
    for (g, data) in &groups {
        w.write_group(g, data).unwrap();
    }
    w.finish().unwrap();
}

/// Put `value` at pixel (3, 7), bin `nt / 2` of the cube file `name`; returns the bin.
fn poison_cube(dir: &Path, name: &str, value: f32) -> usize {
    let mut bin = 0;
    rewrite_cube(dir, name, |values, nx, nt, _| {
        bin = nt / 2;
        values[(7 * nx + 3) * nt + bin] = value;
    });
    bin
}

/// NaN in the camera-time cube: `unwarp` and `calibrate` refuse it, naming the file, the
/// dataset, the pixel and the bin. Before, both ran with exit 0.
#[test]
fn nan_in_a_cube_is_refused_by_unwarp_and_calibrate() {
    let dir = case(&[
        "cube.h5",
        "cap/scene.glb",
        "cap/fiducials.toml",
        "cap/calibration.toml",
    ]);
    let bin = poison_cube(dir.path(), "cube.h5", f32::NAN);
    let at = format!("cube.h5: cube has NaN at x 3, y 7, bin {bin}");
    refused_unchanged(
        dir.path(),
        &["unwarp", "cube.h5", "--out", "world.h5"],
        &[],
        &[&at],
    );
    refused_unchanged(dir.path(), &calibrate_args(&[&laser_flag()]), &[], &[&at]);
}

/// Infinity in the world-time cube: `pyramid` (in place and to a side file) and `render`
/// without a stored pyramid refuse it. Before, the pyramid was built of infinities.
#[test]
fn inf_in_a_cube_is_refused_by_pyramid_and_render() {
    let dir = case(&["world.h5", "cube.calibration.toml", "cap/scene.glb"]);
    // Without the stored pyramid, so that render builds its own from the cube.
    rewrite_cube(dir.path(), "world.h5", |values, nx, nt, groups| {
        groups.retain(|(g, _)| g != "pyramid");
        values[(7 * nx + 3) * nt + nt / 2] = f32::INFINITY;
    });
    let nt = CubeReader::open(&dir.path().join("world.h5"))
        .unwrap()
        .meta()
        .axis
        .nt;
    let at = format!("world.h5: cube has inf at x 3, y 7, bin {}", nt / 2);
    refused_unchanged(dir.path(), &["pyramid", "world.h5"], &[], &[&at]);
    refused_unchanged(
        dir.path(),
        &["pyramid", "world.h5", "--side-file", "side.h5"],
        &[],
        &[&at],
    );
    refused_unchanged(
        dir.path(),
        &render_args("cube.calibration.toml", &SMALL_DOLLY),
        &[],
        &[&at],
    );
}

/// A NaN in a stored pyramid's mip level (the cube itself finite): `render` refuses it,
/// naming the file, `pyramid/level_1`, the pixel and the bin.
#[test]
fn nan_in_a_stored_pyramid_is_refused_by_render() {
    let dir = case(&["world.h5", "cube.calibration.toml", "cap/scene.glb"]);
    rewrite_cube(dir.path(), "world.h5", |_, _, _, groups| {
        let (_, pyramid) = groups
            .iter_mut()
            .find(|(g, _)| g == "pyramid")
            .expect("the fixture's world.h5 has a pyramid");
        let (_, shape, data) = pyramid
            .datasets
            .iter_mut()
            .find(|(n, _, _)| n == "level_1")
            .expect("a first mip level");
        let (nx, nt1) = (shape[1], shape[2]);
        match data {
            DataBuf::F32(v) => v[(5 * nx + 2) * nt1 + 4] = f32::NAN,
            other => panic!("level_1 holds {}", other.type_name()),
        }
    });
    refused_unchanged(
        dir.path(),
        &render_args("cube.calibration.toml", &SMALL_DOLLY),
        &[],
        &["world.h5: pyramid/level_1 has NaN at x 2, y 5, bin 4"],
    );
}

/// `femto info` still describes a cube with NaN values (exit 0), and says how many there are
/// and where the first is, in the text and the JSON.
#[test]
fn info_describes_a_cube_with_nan() {
    let dir = case(&["cube.h5"]);
    let bin = poison_cube(dir.path(), "cube.h5", f32::NAN);
    let run = cli::femto_in(Some(dir.path()), &["info", "cube.h5"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    assert!(
        run.stdout.contains(&format!(
            "1 values NaN or infinite, first NaN at x 3, y 7, bin {bin}"
        )),
        "{}",
        run.stdout
    );
    let run = cli::femto_in(Some(dir.path()), &["info", "cube.h5", "--json"]);
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let j: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    let nf = &j["non_finite_values"];
    assert_eq!(nf["count"], 1, "{}", run.stdout);
    assert_eq!(nf["first"]["value"], "NaN");
    assert_eq!(
        (nf["first"]["x"].clone(), nf["first"]["bin"].clone()),
        (3.into(), bin.into())
    );
    // The fixture's own cube has none.
    let run = cli::femto_in(Some(&fixture().root), &["info", "cube.h5", "--json"]);
    let j: serde_json::Value = serde_json::from_str(&run.stdout).unwrap();
    assert!(j["non_finite_values"].is_null(), "{}", run.stdout);
}

// ---------------------------------------------------------------------------------------------
// clap's errors.

/// Each kind of command-line error is one line on stderr with exit code 2, naming the flag
/// or subcommand at fault and where to read more. Before, clap printed 3-4 lines.
#[test]
fn command_line_errors_are_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &[&str]); 7] = [
        (
            &["render", "--frobnicate"],
            &[
                "unexpected argument '--frobnicate' for 'femto render'",
                "(see 'femto render --help')",
            ],
        ),
        (
            &["unwarp", "c.h5", "--out"],
            &["'--out <OUT>'", "femto unwarp --help"],
        ),
        (
            &["simulate", "--spp", "many", "--out", "x"],
            &["invalid value 'many' for '--spp", "femto simulate --help"],
        ),
        (
            &["unwarp", "--to", "sideways", "c.h5", "-o", "w.h5"],
            &[
                "invalid value 'sideways' for '--to <TO>'",
                "possible values: world, camera",
                "femto unwarp --help",
            ],
        ),
        (
            &["unwarp", "c.h5"],
            &["required arguments were not provided", "--out <OUT>"],
        ),
        (
            &["frobnicate"],
            &["unrecognized subcommand 'frobnicate'", "femto --help"],
        ),
        (&[], &["no command given", "render", "femto --help"]),
    ];
    for (args, names) in cases {
        refused_unchanged(dir.path(), args, &[], names);
    }
}

/// `--help` and `--version` still print as clap prints them, on stdout, with exit code 0.
#[test]
fn help_and_version_still_print() {
    for args in [&["--help"][..], &["render", "--help"], &["--version"]] {
        let run = cli::femto_in(None, args);
        assert_eq!(run.code, Some(0), "{args:?}: {}", run.stderr);
        assert!(run.stderr.is_empty(), "{args:?}: {}", run.stderr);
        assert!(!run.stdout.is_empty());
    }
    let run = cli::femto_in(None, &["render", "--help"]);
    assert!(run.stdout.lines().count() > 10 && run.stdout.contains("--cube"));
}

// ---------------------------------------------------------------------------------------------
// Messages that name the right culprit.

/// Out-of-range ingest flags are named as the user typed them (`--dt-ps`, not the library's
/// `dt_ps`; `--power-ref`, not "power reference region"). Before, the message named the
/// library's value: `dt_ps = 0: must be finite (and dt_ps > 0)`.
#[test]
fn ingest_value_errors_name_the_flag() {
    let dir = case(&["cap"]);
    let cases: [(&[&str], &str); 7] = [
        (&["--dt-ps=0"], "--dt-ps 0: "),
        (&["--t0-ps=inf"], "--t0-ps inf: "),
        (&["--laser-nm=-1"], "--laser-nm -1: "),
        (&["--value-scale=0"], "--value-scale 0: "),
        (&["--saturation=-5"], "--saturation -5: "),
        (&["--dark", "nan"], "--dark NaN: "),
        (&["--power-ref", "0:1000,0:10"], "--power-ref: "),
    ];
    for (flag, named) in cases {
        let mut args = vec!["ingest", "cap", "-o", "cube.h5"];
        args.extend_from_slice(flag);
        let err = refused_unchanged(dir.path(), &args, &[], &[named]);
        assert!(err.starts_with(&format!("femto: error: {named}")), "{err}");
    }
}

/// A calibration made for another pixel grid than the world cube's: `render` names the
/// calibration file (and its flag) and the cube. Before, the message named neither file:
/// `the world cube is 32 x 24 pixels but the calibration's camera is 40 x 24`.
#[test]
fn render_names_the_calibration_of_another_size() {
    let dir = case(&["world.h5", "cube.calibration.toml", "cap/scene.glb"]);
    let cal = dir.path().join("cube.calibration.toml");
    let text = std::fs::read_to_string(&cal).unwrap();
    let edited = text.replacen("width = 32", "width = 40", 1);
    assert_ne!(edited, text, "the fixture's calibration has width = 32");
    std::fs::write(&cal, edited).unwrap();
    refused_unchanged(
        dir.path(),
        &render_args("cube.calibration.toml", &SMALL_DOLLY),
        &[],
        &[
            "--calibration cube.calibration.toml: intrinsics are for 40 x 24 pixels, but \
             world.h5 is 32 x 24",
        ],
    );
}

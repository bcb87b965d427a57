//! The fault corpus (issue 16): hand-made bad inputs and hostile flags, each run through the
//! `femto` binary as a user would, each required to give exit code 2, one line on stderr that
//! names the file, key or flag at fault, and a folder left exactly as it was
//! ([`cli::refused_unchanged`]).
//!
//! One small realistic chain is built once ([`fixture`]) and copied into a fresh folder per
//! case ([`case`]), so a case that writes where it must not is caught, and cases stay fast.
//! The modules group the cases by kind of fault.

#[path = "../common/cli.rs"]
mod cli;

mod consistency;
mod decoders;
mod numbers;
mod outputs;
mod overwrite;
mod ranges;
mod sizes;

use std::path::Path;
use std::sync::OnceLock;

/// The files of one small realistic chain, built once per test run: the simulated capture
/// folder `cap/` (built-in cube scene, 32 x 24 pixels, every `--realistic` flaw, PNG16
/// scanlines), `cube.h5` (ingested with defaults), `cube.calibration.toml` (calibrated with
/// defaults), `world.h5` (unwarped) with its pyramid group.
pub fn fixture() -> &'static cli::Fixture {
    static FIXTURE: OnceLock<cli::Fixture> = OnceLock::new();
    FIXTURE.get_or_init(|| cli::realistic_chain("32x24"))
}

/// `femto render` of the fixture's world cube (`world.h5`) with the calibration file
/// `calibration` and the fixture's mesh, then `extra`.
pub fn render_args<'a>(calibration: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "render",
        "--cube",
        "world.h5",
        "--calibration",
        calibration,
        "--mesh",
        "cap/scene.glb",
    ];
    args.extend_from_slice(extra);
    args
}

/// `femto calibrate` of the fixture's cube (`cube.h5`) against its mesh and fiducials, then
/// `extra`.
pub fn calibrate_args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "calibrate",
        "cube.h5",
        "--mesh",
        "cap/scene.glb",
        "--points",
        "cap/fiducials.toml",
    ];
    args.extend_from_slice(extra);
    args
}

/// `--laser=X,Y,Z` with the simulated capture's true laser position.
pub fn laser_flag() -> String {
    let truth =
        femto::camera::Calibration::load(&fixture().root.join("cap/calibration.toml")).unwrap();
    let l = truth.laser_m;
    format!("--laser={},{},{}", l.x, l.y, l.z)
}

/// A fresh folder holding copies of the fixture's `names` (files or folders, relative to the
/// fixture's root, e.g. `"world.h5"`, `"cap"`, `"cap/scene.glb"`), in the same relative places.
pub fn case(names: &[&str]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("a temporary folder");
    for name in names {
        copy_into(&fixture().root.join(name), &dir.path().join(name));
    }
    dir
}

fn copy_into(from: &Path, to: &Path) {
    if let Some(parent) = to.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    if from.is_dir() {
        std::fs::create_dir_all(to).unwrap();
        for entry in std::fs::read_dir(from).unwrap() {
            let entry = entry.unwrap();
            copy_into(&entry.path(), &to.join(entry.file_name()));
        }
    } else {
        std::fs::copy(from, to).unwrap_or_else(|e| panic!("{}: {e}", from.display()));
    }
}

/// The cube at `from` written to `to` as another tool would write it, through the HDF5
/// library itself (femto's writer refuses an axis out of range): `/cube` with its values and
/// its attributes `t0_ps`, `dt_ps` (after `edit`), `time_frame` and `units`; no mask, no
/// groups.
pub fn bare_cube(from: &Path, to: &Path, edit: impl FnOnce(&mut femto::cube::TimeAxis)) {
    let cube = femto::container::read_cube(from).unwrap();
    let units = femto::container::read_meta(from).unwrap().units;
    let mut axis = cube.axis;
    edit(&mut axis);
    let f = rust_hdf5::H5File::create(to).unwrap();
    let ds = f
        .new_dataset::<f32>()
        .shape([cube.ny, cube.nx, axis.nt])
        .create("cube")
        .unwrap();
    ds.write_raw(&cube.data).unwrap();
    for (k, v) in [("t0_ps", axis.t0_ps), ("dt_ps", axis.dt_ps)] {
        ds.new_attr::<f64>()
            .shape(())
            .create(k)
            .unwrap()
            .write_numeric(&v)
            .unwrap();
    }
    for (k, v) in [("time_frame", cube.frame.as_str()), ("units", &units)] {
        ds.new_attr::<rust_hdf5::VarLenUnicode>()
            .shape(())
            .create(k)
            .unwrap()
            .write_string(v)
            .unwrap();
    }
    f.close().unwrap();
}

/// The fixture chain itself runs with defaults and exit 0 (what every case starts from).
#[test]
fn the_fixture_chain_runs() {
    let root = &fixture().root;
    for name in [
        "cube.h5",
        "cube.calibration.toml",
        "world.h5",
        "cap/manifest.toml",
    ] {
        assert!(root.join(name).is_file(), "{name}");
    }
}

//! `femto demo` writes `commands.sh`: the `femto` commands that reproduce its data products
//! from its capture. Run them (with this build's binary) on a copy of the demo's capture and
//! compare with what the demo wrote: the same stages with the same options give the same
//! calibration and the same world cube.

#[path = "common/cli.rs"]
mod cli;

use cli::{arg, femto_in, femto_ok};
use femto::camera::Calibration;
use femto::container;

#[test]
fn the_demo_commands_reproduce_its_calibration_and_world_cube() {
    let dir = tempfile::tempdir().unwrap();
    let demo = dir.path().join("demo");
    femto_ok(&["demo", "--quick", "--out", arg(&demo)]);
    let script = std::fs::read_to_string(demo.join("commands.sh")).unwrap();
    let commands: Vec<&str> = script.lines().filter(|l| l.starts_with("femto ")).collect();
    assert_eq!(
        commands.len(),
        4,
        "ingest, calibrate, unwarp, pyramid: {script}"
    );

    // The same capture in a fresh folder, the commands run there as the script says.
    let again = dir.path().join("again");
    std::fs::create_dir_all(again.join("data")).unwrap();
    let copy = |from: &std::path::Path, to: &std::path::Path| {
        std::fs::create_dir_all(to).unwrap();
        for e in walk(from) {
            let rel = e.strip_prefix(from).unwrap();
            let dest = to.join(rel);
            std::fs::create_dir_all(dest.parent().unwrap()).unwrap();
            std::fs::copy(&e, &dest).unwrap();
        }
    };
    copy(&demo.join("data/capture"), &again.join("data/capture"));
    std::fs::copy(
        demo.join("data/fiducials_detected.toml"),
        again.join("data/fiducials_detected.toml"),
    )
    .unwrap();
    for c in &commands {
        let words: Vec<&str> = c.split_whitespace().skip(1).collect();
        let run = femto_in(Some(&again), &words);
        assert_eq!(run.code, Some(0), "{c}: {}", run.stderr);
    }

    let a = Calibration::load(&demo.join("data/calibration.toml")).unwrap();
    let b = Calibration::load(&again.join("data/calibration.toml")).unwrap();
    assert_eq!(a.t0_ps, b.t0_ps);
    assert_eq!(a.pose.position_m, b.pose.position_m);
    assert_eq!(a.intrinsics.fx, b.intrinsics.fx);
    let wa = container::read_cube(&demo.join("data/world.h5")).unwrap();
    let wb = container::read_cube(&again.join("data/world.h5")).unwrap();
    assert_eq!(wa.axis, wb.axis);
    assert!(wa.data == wb.data, "the world cubes differ");
    assert_eq!(wa.mask, wb.mask);
}

/// Every file under `dir`.
fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(walk(&p));
        } else {
            out.push(p);
        }
    }
    out
}

//! Targets fed extreme finite numbers (issue 28), not only NaN: every case replaces one to
//! three numbers of a well-formed seed by `1e308`, `-1e308`, a subnormal, `0`, `1e-300`,
//! `65536`, `1e9`, `2^32`, ... ([`super::Mutation::Extremes`]), so that each reaches the
//! range checks and, when it passes them, the stage that sizes something by it:
//!
//! - `extreme_cube_axis`: a world cube's `t0_ps` and `dt_ps` (the fixture's values, written
//!   by the HDF5 library as another tool would), opened for rendering with the fixture's
//!   calibration and mesh, and the light profile the renderer sizes by `span / dt_ps` (a
//!   `dt_ps` of 1e-300 indexed past it, 1e-6 asked 6.4 GB);
//! - `extreme_calibration`: every number of a calibration, then the same render inputs and
//!   profile (`time_scale = 1e9` asked 1.6 TB);
//! - `extreme_camera_path`: every number of the example paths, then frames 0, middle and
//!   last (a keyframe at 1e308 ps panicked in `f64::clamp`);
//! - `extreme_ytal`: the numbers of a y-tal capture (`delta_t`, `t_start`, the sensor, the
//!   laser, the wall points), written with femto's y-tal writer and ingested by the stage
//!   `femto ingest` runs.

use super::seeds::{self, repo_file};
use super::{check, Mutation, Target};
use femto::render::coverage::LightProfile;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn s<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// A scratch folder for files a case writes besides its case file.
fn scratch() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| tempfile::tempdir().expect("a temporary folder"))
        .path()
}

/// Open `cube` for rendering with `calibration` and the seed capture's mesh, as `femto
/// render` does, and build the light profile its camera shortcuts and coverage use.
fn render_profile(cube: &Path, calibration: &Path) -> Result<(), String> {
    use femto::pipeline::render::{open_render_inputs, SceneGeometry};
    let mesh = seeds::seeds().root.join("cap/scene.glb");
    let geometry = SceneGeometry::Files {
        calibration,
        mesh: &mesh,
    };
    let inputs = open_render_inputs(cube, None, geometry, Some(795.0)).map_err(s)?;
    let scene = inputs.scene().map_err(s)?;
    let profile = LightProfile::world(&scene);
    assert!(profile.sums.len() <= femto::render::coverage::MAX_PROFILE_BINS);
    let _ = profile.span(0.01);
    Ok(())
}

// ---------------------------------------------------------------- cube axes

/// The seed world cube's values and axis, read once.
fn world() -> &'static femto::cube::Cube {
    static CUBE: OnceLock<femto::cube::Cube> = OnceLock::new();
    CUBE.get_or_init(|| {
        femto::container::read_cube(&seeds::seeds().root.join("world.h5")).expect("world.h5")
    })
}

/// A case: `t0_ps = ...` and `dt_ps = ...` (TOML). The seed world cube is written with them
/// through the HDF5 library (femto's writer refuses an axis out of range), then rendered.
fn read_cube_axis(path: &Path) -> Result<(), String> {
    #[derive(serde::Deserialize)]
    struct Axis {
        t0_ps: f64,
        dt_ps: f64,
    }
    let text = std::fs::read_to_string(path).map_err(s)?;
    let axis: Axis = toml::from_str(&text).map_err(|e| e.message().to_string())?;
    let cube = world();
    let file = scratch().join("axis.h5");
    let f = rust_hdf5::H5File::create(&file).map_err(s)?;
    let ds = f
        .new_dataset::<f32>()
        .shape([cube.ny, cube.nx, cube.axis.nt])
        .create("cube")
        .map_err(s)?;
    ds.write_raw(&cube.data).map_err(s)?;
    for (k, v) in [("t0_ps", axis.t0_ps), ("dt_ps", axis.dt_ps)] {
        ds.new_attr::<f64>()
            .shape(())
            .create(k)
            .map_err(s)?
            .write_numeric(&v)
            .map_err(s)?;
    }
    for (k, v) in [("time_frame", "world"), ("units", "counts")] {
        ds.new_attr::<rust_hdf5::VarLenUnicode>()
            .shape(())
            .create(k)
            .map_err(s)?
            .write_string(v)
            .map_err(s)?;
    }
    f.close().map_err(s)?;
    render_profile(&file, &seeds::seeds().root.join("cube.calibration.toml"))
}

#[test]
fn extreme_cube_axis() {
    let a = world().axis;
    check(
        Target {
            name: "extreme_cube_axis",
            ext: "toml",
            seeds: vec![format!("t0_ps = {:?}\ndt_ps = {:?}\n", a.t0_ps, a.dt_ps).into_bytes()],
            mutation: Mutation::Extremes,
            read: read_cube_axis,
        },
        40,
    );
}

// ---------------------------------------------------------------- calibrations

fn read_calibration(path: &Path) -> Result<(), String> {
    render_profile(&seeds::seeds().root.join("world.h5"), path)
}

#[test]
fn extreme_calibration() {
    check(
        Target {
            name: "extreme_calibration",
            ext: "toml",
            seeds: vec![
                seeds::file("cap/calibration.toml"),
                seeds::file("cube.calibration.toml"),
            ],
            mutation: Mutation::Extremes,
            read: read_calibration,
        },
        100,
    );
}

// ---------------------------------------------------------------- camera paths

#[test]
fn extreme_camera_path() {
    check(
        Target {
            name: "extreme_camera_path",
            ext: "toml",
            seeds: ["dolly", "keyframes", "orbit", "roll"]
                .iter()
                .map(|n| repo_file(&format!("examples/paths/{n}.toml")))
                .collect(),
            mutation: Mutation::Extremes,
            read: super::targets::read_path,
        },
        300,
    );
}

// ---------------------------------------------------------------- y-tal captures

/// A case: the numbers of a 2 x 2 y-tal capture of 8 bins (TOML), written with femto's y-tal
/// writer and ingested by [`femto::interop::ingest_tal`].
fn read_ytal(path: &Path) -> Result<(), String> {
    use femto::interop::tal::{LaserSpot, TalCapture};
    #[derive(serde::Deserialize)]
    struct Numbers {
        delta_t: f64,
        t_start: f64,
        sensor_xyz: [f64; 3],
        laser_xyz: [f64; 3],
        laser_spot: [f64; 3],
        sensor_grid_xyz: [[f64; 3]; 4],
        sensor_grid_normals: [[f64; 3]; 4],
    }
    let text = std::fs::read_to_string(path).map_err(s)?;
    let n: Numbers = toml::from_str(&text).map_err(|e| e.message().to_string())?;
    let (nt, sx, sy) = (8, 2, 2);
    let cap = TalCapture {
        nt,
        sx,
        sy,
        h: (0..nt * sx * sy).map(|i| i as f32).collect(),
        delta_t_m: n.delta_t,
        t_start_m: n.t_start,
        t_accounts_first_and_last_bounces: true,
        sensor_xyz_m: n.sensor_xyz,
        sensor_grid_xyz_m: n.sensor_grid_xyz.to_vec(),
        sensor_grid_normals: Some(n.sensor_grid_normals.to_vec()),
        laser_xyz_m: n.laser_xyz,
        laser_grid_xyz_m: LaserSpot::Single(n.laser_spot),
    };
    let input: PathBuf = scratch().join("capture.hdf5");
    femto::interop::write_tal(&input, &cap).map_err(s)?;
    let out = scratch().join("ingested.h5");
    let provenance = femto::container::Provenance::new("tests/fuzz/extremes.rs");
    let cube = femto::interop::ingest_tal(&input, &out, None, &provenance).map_err(s)?;
    // What was written reads back, its axis in range.
    let meta = femto::container::read_meta(&out).map_err(s)?;
    assert_eq!(meta.axis.nt, cube.axis.nt);
    Ok(())
}

const YTAL_SEED: &str = "delta_t = 0.0012\n\
t_start = 0.96\n\
sensor_xyz = [0.0, 0.22, 0.85]\n\
laser_xyz = [-0.3, 0.1, 0.4]\n\
laser_spot = [-0.13, 0.06, -0.07]\n\
sensor_grid_xyz = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.1, 0.1, 0.0]]\n\
sensor_grid_normals = [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]\n";

#[test]
fn extreme_ytal() {
    check(
        Target {
            name: "extreme_ytal",
            ext: "toml",
            seeds: vec![YTAL_SEED.as_bytes().to_vec()],
            mutation: Mutation::Extremes,
            read: read_ytal,
        },
        80,
    );
}

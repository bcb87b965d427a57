//! Writes the inputs of `femto render` for the synthetic cube scene of the renderer's tests
//! into a folder: `scene.obj` (a box on a floor before a wall), `capture.toml` (the capture
//! camera, laser spot and time origin) and `world.h5` (a world-time cube of single-bounce
//! light in flight, 30 ps pulse).
//!
//! ```text
//! cargo run --example render_inputs -- /tmp/cube 160x120x400
//! femto render --cube /tmp/cube/world.h5 --calibration /tmp/cube/capture.toml \
//!     --mesh /tmp/cube/scene.obj --dolly 0.8 --out /tmp/cube/frames
//! ```

#[path = "../tests/common/mod.rs"]
mod common;

use femto::container::{write_cube, Provenance};
use femto::cube::TimeAxis;
use femto::geometry::bvh::Bvh;
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 3 {
        eprintln!("usage: render_inputs FOLDER WIDTHxHEIGHTxBINS");
        return ExitCode::from(2);
    }
    let dir = PathBuf::from(&args[1]);
    let dims: Vec<usize> = args[2].split('x').filter_map(|s| s.parse().ok()).collect();
    let [width, height, bins] = dims[..] else {
        eprintln!("render_inputs: size {} is not WIDTHxHEIGHTxBINS", args[2]);
        return ExitCode::from(2);
    };
    if let Err(e) = std::fs::create_dir_all(&dir) {
        eprintln!("render_inputs: {}: {e}", dir.display());
        return ExitCode::from(2);
    }
    let mesh = common::cube_scene_mesh();
    let mut obj = String::new();
    for p in &mesh.positions {
        obj.push_str(&format!("v {} {} {}\n", p.x, p.y, p.z));
    }
    for t in &mesh.triangles {
        obj.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
    }
    let cal = common::cube_scene_calibration(width, height);
    let bvh = Bvh::new(mesh);
    // World arrival times in the scene reach about 12 ns; cover them.
    let axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: 12_500.0 / bins as f64,
        nt: bins,
    };
    let cube = common::world_cube(&cal, &bvh, axis, common::single_bounce_energy(&cal, 30.0));
    let written = std::fs::write(dir.join("scene.obj"), obj)
        .and_then(|_| std::fs::write(dir.join("capture.toml"), cal.to_toml()));
    if let Err(e) = written {
        eprintln!("render_inputs: {}: {e}", dir.display());
        return ExitCode::from(1);
    }
    let provenance = Provenance::new(args.join(" ")).with_note("laser_nm", "670");
    if let Err(e) = write_cube(&dir.join("world.h5"), &cube, &provenance) {
        eprintln!("render_inputs: {e}");
        return ExitCode::from(1);
    }
    println!("wrote {}/scene.obj, capture.toml, world.h5", dir.display());
    ExitCode::SUCCESS
}

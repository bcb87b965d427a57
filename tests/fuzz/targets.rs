//! One fuzz target per reader. Each `read` function calls the reader as the commands do
//! (by path), and on success uses what it returned the way the next stage would (a mesh goes
//! into a BVH and is hit by a ray, a camera path is evaluated at its first and last frames,
//! a calibration casts a ray), so that a value the reader let through and that cannot be used
//! shows up here rather than in a command.

use super::seeds::{self, file, repo_file, scanlines};
use super::{check, Mutation, Target};
use std::path::Path;

fn s<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

// ---------------------------------------------------------------- streak images

fn read_streak(path: &Path) -> Result<(), String> {
    let a = femto::formats::read_streak(path, false).map_err(s)?;
    let b = femto::formats::read_streak(path, true).map_err(s)?;
    assert_eq!(
        a.data.len(),
        a.nx * a.nt,
        "data length of {}",
        path.display()
    );
    assert_eq!(b.data.len(), b.nx * b.nt, "transposed data length");
    Ok(())
}

#[test]
fn img() {
    check(
        Target {
            name: "img",
            ext: "img",
            seeds: {
                let mut v = scanlines("img", 3);
                v.push(seeds::img16());
                v
            },
            mutation: Mutation::Bytes,
            read: read_streak,
        },
        300,
    );
}

#[test]
fn png() {
    check(
        Target {
            name: "png",
            ext: "png",
            seeds: scanlines("png", 2),
            mutation: Mutation::Bytes,
            read: read_streak,
        },
        200,
    );
}

#[test]
fn exr() {
    check(
        Target {
            name: "exr",
            ext: "exr",
            seeds: scanlines("exr", 2),
            mutation: Mutation::Bytes,
            read: read_streak,
        },
        300,
    );
}

#[test]
fn tiff() {
    check(
        Target {
            name: "tiff",
            ext: "tif",
            seeds: seeds::tiffs(),
            mutation: Mutation::Bytes,
            read: read_streak,
        },
        200,
    );
}

#[test]
fn hdr() {
    check(
        Target {
            name: "hdr",
            ext: "hdr",
            seeds: vec![seeds::hdr()],
            mutation: Mutation::Bytes,
            read: read_streak,
        },
        150,
    );
}

// ---------------------------------------------------------------- meshes

fn read_mesh(path: &Path) -> Result<(), String> {
    use femto::geometry::{bvh::Bvh, Ray};
    use nalgebra::{Point3, Vector3};
    let mesh = femto::geometry::load::load_mesh(path).map_err(s)?;
    let centre = if mesh.positions.is_empty() {
        Point3::origin()
    } else {
        let b = mesh.bounds();
        nalgebra::center(&b.min, &b.max)
    };
    let bvh = Bvh::new(mesh);
    let ray = Ray::new(centre + Vector3::new(0.0, 0.0, 10.0), -Vector3::z());
    let _ = bvh.intersect(&ray, 0.0, f32::INFINITY);
    Ok(())
}

#[test]
fn glb() {
    check(
        Target {
            name: "glb",
            ext: "glb",
            seeds: vec![file("cap/scene.glb")],
            mutation: Mutation::Bytes,
            read: read_mesh,
        },
        400,
    );
}

#[test]
fn gltf() {
    check(
        Target {
            name: "gltf",
            ext: "gltf",
            seeds: vec![seeds::gltf_from_glb(&file("cap/scene.glb"))],
            mutation: Mutation::Text,
            read: read_mesh,
        },
        300,
    );
}

#[test]
fn obj() {
    check(
        Target {
            name: "obj",
            ext: "obj",
            seeds: vec![seeds::OBJ.as_bytes().to_vec()],
            mutation: Mutation::Text,
            read: read_mesh,
        },
        300,
    );
}

// ---------------------------------------------------------------- HDF5 cubes

fn read_cube_file(path: &Path) -> Result<(), String> {
    use femto::container::CubeReader;
    let reader = CubeReader::open(path).map_err(s)?;
    let cube = reader.read_cube().map_err(s)?;
    assert_eq!(cube.data.len(), cube.nx * cube.ny * cube.axis.nt);
    reader.read_mask().map_err(s)?;
    for name in reader.meta().groups.clone() {
        let data = reader.read_group(&name).map_err(s)?;
        if name == femto::store::registration::GROUP {
            femto::store::registration::from_group(path, &data).map_err(s)?;
        }
    }
    Ok(())
}

#[test]
fn cube() {
    check(
        Target {
            name: "cube",
            ext: "h5",
            seeds: vec![file("cube.h5")],
            mutation: Mutation::Bytes,
            read: read_cube_file,
        },
        150,
    );
}

fn read_pyramid(path: &Path) -> Result<(), String> {
    femto::container::read_meta(path).map_err(s)?;
    femto::store::pyramid::read_pyramid(path).map_err(s)?;
    Ok(())
}

#[test]
fn pyramid() {
    check(
        Target {
            name: "pyramid",
            ext: "h5",
            seeds: vec![file("world.h5")],
            mutation: Mutation::Bytes,
            read: read_pyramid,
        },
        100,
    );
}

// ---------------------------------------------------------------- TOML and CSV inputs

fn read_manifest(path: &Path) -> Result<(), String> {
    let m = femto::manifest::Manifest::load(path).map_err(s)?;
    m.validate()?;
    Ok(())
}

#[test]
fn manifest() {
    check(
        Target {
            name: "manifest",
            ext: "toml",
            seeds: vec![file("cap/manifest.toml")],
            mutation: Mutation::Text,
            read: read_manifest,
        },
        300,
    );
}

fn read_scene(path: &Path) -> Result<(), String> {
    let scene = femto::scene::Scene::load(path).map_err(s)?;
    let cal = scene.calibration();
    let _ = cal.world_ray(cal.intrinsics.cx, cal.intrinsics.cy);
    Ok(())
}

#[test]
fn scene() {
    use femto::scene::Scene;
    check(
        Target {
            name: "scene",
            ext: "toml",
            seeds: vec![
                Scene::builtin_toml("cube", None).unwrap().into_bytes(),
                Scene::builtin_toml("cornell", None).unwrap().into_bytes(),
            ],
            mutation: Mutation::Text,
            read: read_scene,
        },
        200,
    );
}

pub(super) fn read_path(path: &Path) -> Result<(), String> {
    let p = femto::camera_path::CameraPath::load(path).map_err(s)?;
    let last = p.spec().frames.saturating_sub(1);
    for k in [0, last / 2, last] {
        let f = p.frame(k);
        let _ = f.pose();
    }
    Ok(())
}

#[test]
fn camera_path() {
    check(
        Target {
            name: "camera_path",
            ext: "toml",
            seeds: ["dolly", "keyframes", "orbit", "roll"]
                .iter()
                .map(|n| repo_file(&format!("examples/paths/{n}.toml")))
                .collect(),
            mutation: Mutation::Text,
            read: read_path,
        },
        400,
    );
}

fn read_calibration(path: &Path) -> Result<(), String> {
    let c = femto::camera::Calibration::load(path).map_err(s)?;
    let _ = c.world_ray(c.intrinsics.cx, c.intrinsics.cy);
    let _ = c.project(&nalgebra::Point3::origin());
    Ok(())
}

#[test]
fn calibration() {
    check(
        Target {
            name: "calibration",
            ext: "toml",
            seeds: vec![file("cap/calibration.toml"), file("cube.calibration.toml")],
            mutation: Mutation::Text,
            read: read_calibration,
        },
        300,
    );
}

fn read_points(path: &Path) -> Result<(), String> {
    femto::calibrate::points::load_points(path).map_err(s)?;
    Ok(())
}

#[test]
fn points_toml() {
    check(
        Target {
            name: "points_toml",
            ext: "toml",
            seeds: vec![
                repo_file("examples/points/cube.toml"),
                file("cap/fiducials.toml"),
            ],
            mutation: Mutation::Text,
            read: read_points,
        },
        100,
    );
}

#[test]
fn points_csv() {
    check(
        Target {
            name: "points_csv",
            ext: "csv",
            seeds: vec![repo_file("examples/points/cube.csv")],
            mutation: Mutation::Text,
            read: read_points,
        },
        300,
    );
}

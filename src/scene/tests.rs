//! Tests of scene files: the base scene, each range and each misplaced key named with its
//! line, the camera and laser checks, the built-in scenes and their fiducials.

use super::*;
use nalgebra::Rotation3;

/// A small valid scene; tests edit one line of it at a time.
const BASE: &str = r#"name = "test"
eta = 1.0

[laser]
position_m = [-0.3, 0.3, 0.3]
normal = [0.5, -0.3, -0.6]
emission = "cosine"
wavelength_nm = 795.0
pulse_width_fs = 100.0
energy = 1.0

[camera]
position_m = [0.0, 0.4, 1.2]
look_at_m = [0.0, 0.1, 0.0]
up = [0.0, 1.0, 0.0]
vfov_deg = 35.0
nx = 16
ny = 12
nt = 32
dt_ps = 4.0
t0_ps = 3000.0

[[mesh]]
name = "floor"
primitive = "quad"
size = [1.0, 1.0]
rotate_deg = [-90.0, 0.0, 0.0]
albedo = 0.5

[[mesh]]
name = "block"
primitive = "box"
size = [0.2, 0.2, 0.2]
translate_m = [0.0, 0.1, 0.0]
albedo = 0.7

[[mesh]]
name = "ball"
primitive = "icosphere"
radius = 0.1
subdivisions = 1
translate_m = [0.3, 0.1, -0.2]
albedo = 0.3
"#;

/// 1-based line of the first line of `text` containing `needle`.
fn line_of(text: &str, needle: &str) -> usize {
    text.lines()
        .position(|l| l.contains(needle))
        .expect("needle")
        + 1
}

fn err(text: &str) -> String {
    Scene::from_toml(text, "t.toml", Path::new("."))
        .map(|_| ())
        .unwrap_err()
        .to_string()
}

#[test]
fn base_scene_resolves_with_one_material_per_entry() {
    let s = Scene::from_toml(BASE, "t.toml", Path::new(".")).unwrap();
    assert_eq!(s.name, "test");
    assert_eq!(s.albedo, vec![0.5, 0.7, 0.3]);
    assert_eq!(s.labels, vec!["floor", "block", "ball"]);
    assert_eq!(s.mesh.triangle_count(), 2 + 12 + 80);
    let count = |m: u32| s.mesh.material.iter().filter(|&&x| x == m).count();
    assert_eq!((count(0), count(1), count(2)), (2, 12, 80));
    // The floor quad, rotated -90 degrees about x, lies in y = 0 facing +y.
    for i in 0..2 {
        let [a, b, c] = s.mesh.corners(i);
        assert!(a.y.abs() < 1e-6 && b.y.abs() < 1e-6 && c.y.abs() < 1e-6);
        assert!((b - a).cross(&(c - a)).y > 0.0);
    }
    // The box sits on the floor: y from 0 to 0.2.
    let ys: Vec<f32> = s.mesh.positions[4..12].iter().map(|p| p.y).collect();
    assert!(ys.iter().all(|&y| y.abs() < 1e-6 || (y - 0.2).abs() < 1e-6));
    assert!((s.laser.normal.norm() - 1.0).abs() < 1e-12);
    assert_eq!(s.camera.axis.nt, 32);
    let calib = s.calibration();
    assert_eq!((calib.t0_ps, calib.time_scale), (0.0, 1.0));
    // The look-at point projects to the image centre.
    let (u, v) = calib.project(&Point3::new(0.0, 0.1, 0.0)).unwrap();
    assert!((u - 8.0).abs() < 1e-9 && (v - 6.0).abs() < 1e-9);
}

#[test]
fn laser_intensity_and_pulse_width() {
    let s = Scene::from_toml(BASE, "t.toml", Path::new(".")).unwrap();
    let n = s.laser.normal.into_inner();
    let pi = std::f64::consts::PI;
    assert!((s.laser.intensity(Emission::Cosine, &n) - 1.0 / pi).abs() < 1e-12);
    assert_eq!(s.laser.intensity(Emission::Cosine, &-n), 0.0);
    assert!((s.laser.intensity(Emission::Isotropic, &-n) - 0.25 / pi).abs() < 1e-12);
    // FWHM 100 fs: sigma = 0.1 ps / 2.35482.
    assert!((s.laser.pulse_sigma_ps() - 0.1 / 2.354_820_045).abs() < 1e-9);
}

#[test]
fn rotations_follow_the_documented_order() {
    // rotate_deg = [90, 90, 0]: first 90 about x, then 90 about y (fixed axes). The quad's
    // normal +z goes to -y under Rx(90), and -y stays -y under Ry(90). Its local +x edge
    // goes to +x under Rx(90), then to -z under Ry(90).
    let text = BASE.replace(
        "rotate_deg = [-90.0, 0.0, 0.0]",
        "rotate_deg = [90.0, 90.0, 0.0]",
    );
    let s = Scene::from_toml(&text, "t.toml", Path::new(".")).unwrap();
    let [a, b, c] = s.mesh.corners(0);
    let n = (b - a).cross(&(c - a)).normalize();
    assert!((n - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-6, "{n}");
    // Local corners 0 -> 1 run along +x: after rotation along -z.
    let e = (b - a).normalize();
    assert!((e - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-6, "{e}");
    // Axis-angle gives the same as the Euler form for a single axis.
    let euler = BASE.replace(
        "rotate_deg = [-90.0, 0.0, 0.0]",
        "rotate_deg = [0.0, 0.0, 30.0]",
    );
    let axis = BASE.replace(
        "rotate_deg = [-90.0, 0.0, 0.0]",
        "rotate_axis = [0.0, 0.0, 2.0]\nrotate_angle_deg = 30.0",
    );
    let s1 = Scene::from_toml(&euler, "t.toml", Path::new(".")).unwrap();
    let s2 = Scene::from_toml(&axis, "t.toml", Path::new(".")).unwrap();
    for (p, q) in s1.mesh.positions.iter().zip(&s2.mesh.positions) {
        assert!((p - q).norm() < 1e-6);
    }
    // Scale then translate: the ball's vertices sit at radius 0.1 * 2 around its centre.
    let scaled = BASE.replace("radius = 0.1", "radius = 0.1\nscale = 2.0");
    let s3 = Scene::from_toml(&scaled, "t.toml", Path::new(".")).unwrap();
    let centre = Point3::new(0.3f32, 0.1, -0.2);
    for i in 0..s3.mesh.triangle_count() {
        if s3.mesh.material[i] == 2 {
            for p in s3.mesh.corners(i) {
                assert!(((p - centre).norm() - 0.2).abs() < 1e-5);
            }
        }
    }
}

/// Replace `from` by `to` in the base scene and check the error names `key` and the line
/// where `to` (or `line_needle`) sits.
fn check_error(from: &str, to: &str, key: &str, line_needle: &str) {
    assert!(BASE.contains(from), "{from}");
    let text = BASE.replacen(from, to, 1);
    let e = err(&text);
    let line = line_of(&text, line_needle);
    assert!(e.contains("t.toml"), "{e}");
    assert!(e.contains(key), "expected key {key} in: {e}");
    assert!(
        e.contains(&format!("line {line},")),
        "expected line {line} in: {e}"
    );
}

/// Every number of a scene finite and in its physical range, the range given in the
/// message (issue 16: `eta = 1e19` gave "capacity overflow", `pulse_width_fs =
/// 4294967296` hung the tracer, a far translation put infinities in the f32 mesh).
#[test]
fn numbers_outside_their_physical_range_name_the_key_and_the_range() {
    for (from, to, key, range) in [
        ("eta = 1.0", "eta = 1e19", "eta", "[1, 10]"),
        ("eta = 1.0", "eta = nan", "eta", "[1, 10]"),
        (
            "pulse_width_fs = 100.0",
            "pulse_width_fs = 4294967296",
            "laser.pulse_width_fs",
            "[0, 1000000] fs",
        ),
        (
            "pulse_width_fs = 100.0",
            "pulse_width_fs = 200000",
            "laser.pulse_width_fs",
            "camera.nt x camera.dt_ps = 128000 fs",
        ),
        (
            "wavelength_nm = 795.0",
            "wavelength_nm = inf",
            "laser.wavelength_nm",
            "[1, 1000000] nm",
        ),
        ("energy = 1.0", "energy = 1e300", "laser.energy", "1e12"),
        (
            "dt_ps = 4.0",
            "dt_ps = 1e-300",
            "camera.dt_ps",
            "[0.001, 1000000000] ps",
        ),
        (
            "nt = 32",
            "nt = 9223372036854775807",
            "camera.nt",
            "[1, 1048576]",
        ),
        ("nx = 16", "nx = 100000", "camera.nx", "[1, 16384]"),
        (
            "position_m = [0.0, 0.4, 1.2]",
            "position_m = [0.0, 1e39, 1.2]",
            "camera.position_m",
            "[1] = 1e39 m",
        ),
        (
            "look_at_m = [0.0, 0.1, 0.0]",
            "look_at_m = [0.0, -inf, 0.0]",
            "camera.look_at_m",
            "must be finite",
        ),
        (
            "position_m = [-0.3, 0.3, 0.3]",
            "position_m = [-0.3, 0.3, 2e4]",
            "laser.position_m",
            "1e4 m",
        ),
        (
            "translate_m = [0.0, 0.1, 0.0]",
            "translate_m = [1e39, 0.1, 0.0]",
            "mesh[1].translate_m",
            "1e4 m",
        ),
        (
            "size = [1.0, 1.0]",
            "size = [1e30, 1.0]",
            "mesh[0]",
            "a vertex has a coordinate of -5.000e29 m",
        ),
        (
            "radius = 0.1",
            "radius = 0.1\nscale = 1e38",
            "mesh[2]",
            "beyond the 1e4 m",
        ),
    ] {
        assert!(BASE.contains(from), "{from}");
        let e = err(&BASE.replacen(from, to, 1));
        assert!(e.starts_with("t.toml: line "), "{e}");
        assert!(e.contains(key) && e.contains(range), "{to}: {e}");
    }
    // The built-in scenes lie inside every range.
    for name in ["cube", "cornell"] {
        Scene::builtin(name, None).unwrap();
    }
}

#[test]
fn errors_name_the_key_and_the_line() {
    // Unknown key.
    check_error(
        "albedo = 0.7",
        "albedo = 0.7\ncolour = 3",
        "colour",
        "colour",
    );
    // Missing field (reported at the table that lacks it).
    check_error("nt = 32\n", "", "nt", "[camera]");
    // Negative and zero sizes, wrong counts.
    check_error(
        "size = [0.2, 0.2, 0.2]",
        "size = [0.2, -0.2, 0.2]",
        "mesh[1].size",
        "-0.2",
    );
    check_error(
        "size = [1.0, 1.0]",
        "size = [1.0, 0.0]",
        "mesh[0].size",
        "[1.0, 0.0]",
    );
    check_error(
        "size = [1.0, 1.0]",
        "size = [1.0]",
        "mesh[0].size",
        "size = [1.0]",
    );
    check_error("radius = 0.1", "radius = -0.1", "mesh[2].radius", "radius");
    // Albedo outside [0, 1].
    check_error("albedo = 0.7", "albedo = 1.5", "mesh[1].albedo", "1.5");
    // Time axis and medium.
    check_error("nt = 32", "nt = 0", "camera.nt", "nt = 0");
    check_error("dt_ps = 4.0", "dt_ps = -1.0", "camera.dt_ps", "dt_ps");
    check_error("eta = 1.0", "eta = 0.9", "eta", "eta = 0.9");
    check_error("energy = 1.0", "energy = 0.0", "laser.energy", "energy");
    check_error(
        "normal = [0.5, -0.3, -0.6]",
        "normal = [0, 0, 0]",
        "laser.normal",
        "normal",
    );
    // An unknown primitive and an unknown emission.
    check_error(
        "primitive = \"box\"",
        "primitive = \"cone\"",
        "cone",
        "cone",
    );
    check_error(
        "emission = \"cosine\"",
        "emission = \"laser\"",
        "laser",
        "emission",
    );
    // Conflicting or missing geometry keys.
    check_error(
        "radius = 0.1",
        "size = [0.1, 0.1]",
        "mesh[2].size",
        "size = [0.1, 0.1]",
    );
    check_error(
        "primitive = \"box\"",
        "primitive = \"box\"\nfile = \"x.obj\"",
        "mesh[1].file",
        "x.obj",
    );
}

#[test]
fn camera_inside_a_closed_mesh_or_on_a_surface_is_rejected() {
    // Inside the box (centre 0, 0.1, 0).
    check_error(
        "position_m = [0.0, 0.4, 1.2]",
        "position_m = [0.02, 0.1, 0.05]",
        "camera.position_m",
        "[0.02, 0.1, 0.05]",
    );
    // Inside the icosphere.
    check_error(
        "position_m = [0.0, 0.4, 1.2]",
        "position_m = [0.3, 0.12, -0.2]",
        "camera.position_m",
        "[0.3, 0.12, -0.2]",
    );
    // Half a millimetre above the floor: within 1 mm of a surface.
    check_error(
        "position_m = [0.0, 0.4, 1.2]",
        "position_m = [0.4, 0.0005, 0.4]",
        "camera.position_m",
        "0.0005",
    );
    let e = err(&BASE.replacen(
        "position_m = [0.0, 0.4, 1.2]",
        "position_m = [0.4, 0.0005, 0.4]",
        1,
    ));
    assert!(e.contains("floor") && e.contains("1 mm"), "{e}");
    // Two millimetres above the floor is fine.
    let ok = BASE.replacen(
        "position_m = [0.0, 0.4, 1.2]",
        "position_m = [0.4, 0.002, 0.4]",
        1,
    );
    assert!(Scene::from_toml(&ok, "t.toml", Path::new(".")).is_ok());
    // A laser spot inside the box.
    check_error(
        "position_m = [-0.3, 0.3, 0.3]",
        "position_m = [0.0, 0.1, 0.0]",
        "laser.position_m",
        "[0.0, 0.1, 0.0]",
    );
}

#[test]
fn a_missing_mesh_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let text = BASE.replacen(
        "primitive = \"box\"\nsize = [0.2, 0.2, 0.2]",
        "file = \"meshes/missing.obj\"",
        1,
    );
    let e = Scene::from_toml(&text, "t.toml", dir.path())
        .map(|_| ())
        .unwrap_err()
        .to_string();
    let line = line_of(&text, "missing.obj");
    assert!(
        e.contains("missing.obj") && e.contains("mesh[1].file"),
        "{e}"
    );
    assert!(e.contains(&format!("line {line},")), "{e}");
    assert!(e.contains(&dir.path().display().to_string()), "{e}");
}

#[test]
fn load_reads_a_file_and_reports_io_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("my_scene.toml");
    std::fs::write(&path, BASE.replace("name = \"test\"\n", "")).unwrap();
    let s = Scene::load(&path).unwrap();
    assert_eq!(s.name, "my_scene");
    let e = Scene::load(&dir.path().join("nope.toml")).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }) && e.to_string().contains("nope.toml"));
}

#[test]
fn builtins_parse_and_unknown_names_fail() {
    for name in ["cube", "cornell"] {
        let s = Scene::builtin(name, None).unwrap();
        assert_eq!(s.name, name);
        assert_eq!(
            (s.camera.intrinsics.width, s.camera.intrinsics.height),
            (64, 48)
        );
        assert_eq!((s.camera.axis.nt, s.camera.axis.dt_ps), (256, 4.0));
    }
    assert!(matches!(
        Scene::builtin("bunny", None),
        Err(SceneError::BunnyNeedsMesh)
    ));
    let e = Scene::builtin("teapot", None).unwrap_err().to_string();
    assert!(e.contains("teapot") && e.contains("cornell"), "{e}");
    // The bunny scene names the mesh file it could not read.
    let e = Scene::builtin("bunny", Some(Path::new("/no/such/bunny.obj")))
        .unwrap_err()
        .to_string();
    assert!(e.contains("/no/such/bunny.obj"), "{e}");
}

#[test]
fn with_resolution_keeps_the_view_and_the_window_start() {
    let s = Scene::builtin("cube", None).unwrap();
    let big = s.with_resolution(672, 600, 512, 1.71);
    assert_eq!(big.camera.axis.t0_ps, s.camera.axis.t0_ps);
    assert_eq!(big.camera.axis.nt, 512);
    assert_eq!(
        (big.camera.intrinsics.width, big.camera.intrinsics.height),
        (672, 600)
    );
    // Same vertical field of view: the top edge of the image maps to the same ray.
    let a = s.calibration().world_ray(32.0, 0.0);
    let b = big.calibration().world_ray(336.0, 0.0);
    assert!((a.into_inner() - b.into_inner()).norm() < 1e-12);
}

/// Earliest camera time at which direct light reaches any pixel centre, found by ray
/// casting independently of the tracer.
fn direct_arrival_range_ps(s: &Scene) -> (f64, f64) {
    let bvh = Bvh::new(s.mesh.clone());
    let calib = s.calibration();
    let o = s.camera.pose.position_m;
    let (mut best, mut last) = (f64::INFINITY, 0.0f64);
    for j in 0..s.camera.intrinsics.height {
        for i in 0..s.camera.intrinsics.width {
            let d = calib.world_ray(i as f64 + 0.5, j as f64 + 0.5).into_inner();
            let ray = Ray::new(o.cast::<f32>(), d.cast::<f32>());
            let Some(h) = bvh.intersect(&ray, 0.0, f32::INFINITY) else {
                continue;
            };
            let p = o + d * h.t as f64;
            let mut n = h.normal.cast::<f64>();
            if n.dot(&d) > 0.0 {
                n = -n;
            }
            let to_l = s.laser.position_m - p;
            let r = to_l.norm();
            let w = to_l / r;
            let lit = n.dot(&w) > 0.0 && s.laser.normal.dot(&-w) > 0.0;
            let shadow = Ray::new((p + n * 1e-4).cast::<f32>(), w.cast::<f32>());
            if lit && !bvh.occluded(&shadow, 0.0, (r - 2e-4) as f32) {
                let t = s.eta * (r + h.t as f64) / crate::units::C_M_PER_PS;
                best = best.min(t);
                last = last.max(t);
            }
        }
    }
    (best, last)
}

#[test]
fn builtin_windows_start_just_before_the_first_direct_light() {
    for name in ["cube", "cornell"] {
        let s = Scene::builtin(name, None).unwrap();
        let (t_first, t_last) = direct_arrival_range_ps(&s);
        let ax = s.camera.axis;
        println!(
            "{name}: direct arrivals {t_first:.1} .. {t_last:.1} ps, window {} .. {}",
            ax.t0_ps,
            ax.end_ps()
        );
        assert!(
            t_first > ax.t0_ps && t_first < ax.t0_ps + 0.1 * (ax.end_ps() - ax.t0_ps),
            "{name}: first light at {t_first} ps, window {} .. {}",
            ax.t0_ps,
            ax.end_ps()
        );
    }
}

#[test]
fn cube_fiducials_are_visible_many_and_not_coplanar() {
    let s = Scene::builtin("cube", None).unwrap();
    let f = s.fiducials();
    assert!(f.len() >= 20, "{} fiducials", f.len());
    let corners = f
        .iter()
        .filter(|(n, _)| n.starts_with("cube.corner"))
        .count();
    // A box on a floor seen from above and in front shows at most 7 corners.
    assert!((4..=7).contains(&corners), "{corners} cube corners");
    let calib = s.calibration();
    for (name, p) in &f {
        let (u, v) = calib.project(p).unwrap();
        assert!(
            u > 0.0 && v > 0.0 && u < 64.0 && v < 48.0,
            "{name} at {u},{v}"
        );
    }
    // Not coplanar: the smallest singular value of the centred point cloud is not ~0.
    let n = f.len() as f64;
    let mean = f.iter().map(|(_, p)| p.coords).sum::<Vector3<f64>>() / n;
    let mut m = nalgebra::Matrix3::zeros();
    for (_, p) in &f {
        let d = p.coords - mean;
        m += d * d.transpose();
    }
    let ev = m.symmetric_eigenvalues();
    assert!(ev.min() / n > 1e-4, "{ev}");
    // Independent visibility of the box's corners: a corner of a convex box is visible
    // exactly when one of its three faces faces the camera (nothing else in the scene
    // stands between the camera and the box).
    let o = s.camera.pose.position_m;
    let rot = Rotation3::from_axis_angle(&Vector3::y_axis(), 30f64.to_radians());
    let centre = Vector3::new(0.02, 0.035, 0.0);
    let h = 0.035;
    let mut expected = Vec::new();
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            for sz in [-1.0, 1.0] {
                let local = Vector3::new(sx * h, sy * h, sz * h);
                let corner = Point3::from(rot * local + centre);
                let faces_camera = [
                    Vector3::new(sx, 0.0, 0.0),
                    Vector3::new(0.0, sy, 0.0),
                    Vector3::new(0.0, 0.0, sz),
                ]
                .iter()
                .any(|n| (rot * n).dot(&(o - corner)) > 0.0);
                if faces_camera {
                    expected.push(corner);
                }
            }
        }
    }
    let listed: Vec<Point3<f64>> = f
        .iter()
        .filter(|(n, _)| n.starts_with("cube.corner"))
        .map(|(_, p)| *p)
        .collect();
    assert_eq!(listed.len(), expected.len());
    for e in &expected {
        assert!(
            listed.iter().any(|p| (p - e).norm() < 1e-5),
            "corner {e} missing"
        );
    }
    let names: Vec<&str> = f.iter().map(|(n, _)| n.as_str()).collect();
    assert!(names.contains(&"floor.grid11") || names.contains(&"back_wall.grid11"));
}

/// Each mesh kind takes its own keys: a key of another kind (or none) is refused by the toml
/// crate at that key's line, the message naming the entry and the key (issue 19).
#[test]
fn keys_of_another_mesh_kind_are_refused_at_their_line() {
    for (from, to, key) in [
        (
            "size = [1.0, 1.0]",
            "size = [1.0, 1.0]\nradius = 0.1",
            "mesh[0].radius",
        ),
        (
            "size = [1.0, 1.0]",
            "size = [1.0, 1.0]\nsubdivisions = 2",
            "mesh[0].subdivisions",
        ),
        (
            "size = [0.2, 0.2, 0.2]",
            "size = [0.2, 0.2, 0.2]\nfit_size_m = 0.2",
            "mesh[1].fit_size_m",
        ),
        (
            "radius = 0.1",
            "radius = 0.1\nfit_size_m = 0.2",
            "mesh[2].fit_size_m",
        ),
        // A file mesh takes no primitive size (refused before the file is read).
        (
            "primitive = \"box\"\nsize = [0.2, 0.2, 0.2]",
            "file = \"m.obj\"\nsize = [0.2, 0.2, 0.2]",
            "mesh[1].size",
        ),
    ] {
        let needle = to.lines().last().unwrap();
        check_error(from, to, key, needle);
        let e = err(&BASE.replacen(from, to, 1));
        assert!(e.contains("unknown field"), "{e}");
    }
    // A missing key names the entry and the key, at the entry's table.
    let e = err(&BASE.replacen("size = [1.0, 1.0]\n", "", 1));
    assert!(
        e.contains("mesh[0]: missing field `size`"),
        "expected the entry and the key in: {e}"
    );
    let e = err(&BASE.replacen("radius = 0.1\n", "", 1));
    assert!(e.contains("mesh[2]: missing field `radius`"), "{e}");
    // A value of the wrong type names its key.
    check_error(
        "size = [1.0, 1.0]",
        "size = \"big\"",
        "mesh[0].size",
        "size = \"big\"",
    );
    // Neither a primitive nor a file.
    check_error("primitive = \"quad\"\n", "", "mesh[0]", "[[mesh]]");
}

#[test]
fn mesh_heads_give_the_kind_and_key_at_finds_the_key_of_an_offset() {
    use super::schema::{key_at, Kind, MeshHead};
    let head = |text: &str| -> Kind {
        let h: MeshHead = toml::from_str(text).unwrap();
        h.kind()
    };
    assert!(matches!(
        head("primitive = \"box\"\nsize = 1"),
        Kind::Tag("box")
    ));
    assert!(matches!(head("file = \"a.obj\""), Kind::Tag("file")));
    assert!(matches!(head("albedo = 0.5"), Kind::Neither));
    // Both: the span of the file's value.
    let text = "primitive = \"quad\"\nfile = \"a.obj\"";
    match head(text) {
        Kind::Both(span) => assert_eq!(&text[span], "\"a.obj\""),
        _ => panic!("both keys"),
    }
    let text = "a = 1\nlong_name = [1, 2]\n";
    let doc = toml::de::DeTable::parse(text).unwrap();
    let table = toml::de::DeValue::Table(doc.into_inner());
    assert_eq!(key_at(&table, 0).as_deref(), Some("a"));
    assert_eq!(
        key_at(&table, text.find("long").unwrap() + 2).as_deref(),
        Some("long_name")
    );
    assert_eq!(
        key_at(&table, text.find('2').unwrap()).as_deref(),
        Some("long_name")
    );
    assert_eq!(key_at(&table, text.find('=').unwrap() - 1), None);
}

//! Tests of camera paths: clocks against closed forms, speed limits, validation messages,
//! orbits, sensor rotation and the TOML round trip.

use super::path::Resolved;
use super::*;
use crate::relativity::{gamma, RotationAxis};
use crate::units::C_M_PER_PS;

fn spec(frames: usize, dtau_ps: f64) -> FrameSpec {
    FrameSpec {
        width: 64,
        height: 48,
        frames,
        dtau_ps,
    }
}

fn kf(time_ps: f64, p: [f64; 3]) -> Keyframe {
    Keyframe {
        time_ps,
        position_m: Point3::from(p),
        orientation: Orientation::LookAt {
            target_m: Point3::new(0.0, 0.0, -10.0),
            up: Vector3::y(),
        },
        vfov_deg: 40.0,
        beta: None,
    }
}

fn keyframes(clock: Clock, interpolation: Interpolation, kfs: Vec<Keyframe>) -> Motion {
    Motion::Keyframes {
        clock,
        interpolation,
        keyframes: kfs,
    }
}

#[test]
fn dolly_world_time_is_gamma_times_proper_time() {
    for beta in [0.1, 0.5, 0.8, 0.99] {
        let start = Point3::new(0.0, 0.5, 20.0);
        let target = Point3::new(0.0, 0.5, 0.0);
        let path =
            CameraPath::dolly(start, target, Vector3::y(), beta, 40.0, spec(50, 3.0)).unwrap();
        let g = 1.0 / (1.0 - beta * beta).sqrt();
        for k in [0, 1, 17, 49] {
            let f = path.frame(k);
            let tau = 3.0 * k as f64;
            assert!((f.tau_ps - tau).abs() < 1e-12);
            assert!(
                (f.t_world_ps - g * tau).abs() < 1e-9 * (1.0 + g * tau),
                "beta {beta} frame {k}: t_world {} vs gamma tau {}",
                f.t_world_ps,
                g * tau
            );
            // Position moves at beta c in world time, towards the target.
            let expect_z = 20.0 - beta * C_M_PER_PS * g * tau;
            assert!(
                (f.position_m.z - expect_z).abs() < 1e-12,
                "{}",
                f.position_m
            );
            assert!((f.beta - Vector3::new(0.0, 0.0, -beta)).norm() < 1e-12);
            assert!((f.gamma() - g).abs() < 1e-9 * g);
            // Looks at the target.
            assert!((f.pose().forward() - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
        }
    }
    // Reaching the target within the frames is an error.
    let e = CameraPath::dolly(
        Point3::new(0.0, 0.0, 0.01),
        Point3::origin(),
        Vector3::y(),
        0.9,
        40.0,
        spec(100, 5.0),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("target"), "{e}");
}

#[test]
fn world_clock_keyframes_at_constant_speed_dilate_time() {
    // Two keyframes 10 ns of world time apart, moving at 0.6 c along x.
    let beta = 0.6;
    let t1 = 10_000.0;
    let d = beta * C_M_PER_PS * t1;
    for interpolation in [Interpolation::Linear, Interpolation::Cubic] {
        let motion = keyframes(
            Clock::World,
            interpolation,
            vec![kf(0.0, [0.0, 0.0, 0.0]), kf(t1, [d, 0.0, 0.0])],
        );
        let g = gamma(beta);
        let path = CameraPath::new(spec(40, t1 / g / 40.0), None, None, motion, "t").unwrap();
        for k in 0..40 {
            let f = path.frame(k);
            assert!(
                (f.t_world_ps - g * f.tau_ps).abs() < 1e-7,
                "{interpolation:?} frame {k}: {} vs {}",
                f.t_world_ps,
                g * f.tau_ps
            );
            assert!((f.position_m.x - beta * C_M_PER_PS * f.t_world_ps).abs() < 1e-9);
            assert!((f.beta.x - beta).abs() < 1e-12);
        }
    }
}

/// Along a curved cubic path, the reported velocity is the derivative of the reported
/// position with respect to the reported world time, and world time advances at gamma of
/// the reported speed per unit of proper time.
#[test]
fn curved_paths_have_consistent_velocity_and_clocks() {
    let kfs = vec![
        kf(0.0, [0.0, 0.0, 0.0]),
        kf(4000.0, [0.5, 0.2, -0.3]),
        kf(7000.0, [0.9, 0.7, -0.2]),
        kf(12000.0, [1.2, 0.6, 0.6]),
    ];
    let mut with_beta = kfs.clone();
    with_beta[1].beta = Some(Vector3::new(0.45, 0.1, -0.2));
    for (clock, kfs) in [
        (Clock::World, kfs.clone()),
        (Clock::Proper, kfs.clone()),
        (Clock::World, with_beta.clone()),
        (Clock::Proper, with_beta),
    ] {
        let motion = keyframes(clock, Interpolation::Cubic, kfs);
        let probe = CameraPath::new(spec(1, 1.0), None, None, motion.clone(), "t").unwrap();
        let (tau_a, tau_b) = match &probe.resolved {
            Resolved::Keyframes(k) => k.tau_span(),
            Resolved::Orbit(_) => unreachable!(),
        };
        let n = 4000;
        let dtau = (tau_b - tau_a) / n as f64;
        let path = CameraPath::new(spec(n + 1, dtau), None, None, motion, "t").unwrap();
        let mut t_sum = path.frame(0).t_world_ps;
        let mut max_speed: f64 = 0.0;
        for k in 0..n {
            let (a, b) = (path.frame(k), path.frame(k + 1));
            // Trapezoid rule on dt = gamma dtau with the frames' own speeds.
            t_sum += 0.5 * (a.gamma() + b.gamma()) * dtau;
            let dt = b.t_world_ps - a.t_world_ps;
            let v = (b.position_m - a.position_m) / (C_M_PER_PS * dt);
            let mid = 0.5 * (a.beta + b.beta);
            // (Loose enough for steps across a keyframe, where the cubic's acceleration
            // jumps; a proper velocity mistaken for beta would be off by gamma ~ 1.1.)
            assert!(
                (v - mid).norm() < 1e-3,
                "{clock:?} frame {k}: dx/dt/c {v:?} vs beta {mid:?}"
            );
            max_speed = max_speed.max(a.beta.norm());
        }
        let t_end = path.frame(n).t_world_ps;
        assert!(
            (t_sum - t_end).abs() < 1e-5 * t_end,
            "{clock:?}: integrated {t_sum} vs reported {t_end}"
        );
        assert!(max_speed > 0.1 && max_speed < 1.0);
    }
}

#[test]
fn derived_speed_at_0_99_passes_and_1_01_fails_naming_the_keyframes() {
    let t = 2000.0;
    let make = |beta: f64| {
        keyframes(
            Clock::World,
            Interpolation::Cubic,
            vec![
                kf(0.0, [0.0, 0.0, 0.0]),
                kf(t, [0.0, 0.0, 0.0]),
                kf(2.0 * t, [beta * C_M_PER_PS * t, 0.0, 0.0]),
            ],
        )
    };
    let ok = CameraPath::new(spec(10, 10.0), None, None, make(0.99), "p.toml");
    // Catmull-Rom overshoots on the uneven middle keyframe: use linear for the 0.99 case.
    let linear = |beta: f64| {
        keyframes(
            Clock::World,
            Interpolation::Linear,
            vec![
                kf(0.0, [0.0, 0.0, 0.0]),
                kf(t, [0.0, 0.0, 0.0]),
                kf(2.0 * t, [beta * C_M_PER_PS * t, 0.0, 0.0]),
            ],
        )
    };
    let passes = CameraPath::new(spec(10, 10.0), None, None, linear(0.99), "p.toml");
    assert!(passes.is_ok(), "{:?}", passes.err());
    let fails = CameraPath::new(spec(10, 10.0), None, None, linear(1.01), "p.toml")
        .unwrap_err()
        .to_string();
    assert!(
        fails.contains("p.toml")
            && fails.contains("keyframe 2 of 3")
            && fails.contains("keyframe 3 of 3")
            && fails.contains("1.01"),
        "{fails}"
    );
    // The cubic version of the 0.99 path exceeds c between keyframes 2 and 3 (the tangent
    // at keyframe 2 is the average, the spline speeds up past 0.99): caught too.
    let e = ok.unwrap_err().to_string();
    assert!(
        e.contains("keyframe 2 of 3") && e.contains("speed of light"),
        "{e}"
    );
    // A given keyframe beta above 1 names that keyframe.
    let mut kfs = vec![kf(0.0, [0.0; 3]), kf(t, [0.1, 0.0, 0.0])];
    kfs[1].beta = Some(Vector3::new(0.0, 1.2, 0.0));
    let e = CameraPath::new(
        spec(2, 1.0),
        None,
        None,
        keyframes(Clock::Proper, Interpolation::Cubic, kfs),
        "q",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("keyframe 2 of 2") && e.contains("1.2"), "{e}");
    // A proper-time path can cover any distance: beta = u / sqrt(1 + u^2) < 1.
    let far = keyframes(
        Clock::Proper,
        Interpolation::Linear,
        vec![kf(0.0, [0.0; 3]), kf(t, [3.0 * C_M_PER_PS * t, 0.0, 0.0])],
    );
    let p = CameraPath::new(spec(5, 100.0), None, None, far, "r").unwrap();
    let b = p.frame(2).beta.norm();
    assert!((b - 3.0 / 10f64.sqrt()).abs() < 1e-12, "{b}");
    assert!((p.frame(4).t_world_ps - 10f64.sqrt() * 400.0).abs() < 1e-9);
}

#[test]
fn validation_errors_name_the_field() {
    let two = || vec![kf(0.0, [0.0; 3]), kf(1000.0, [0.01, 0.0, 0.0])];
    let new = |s: FrameSpec, kfs: Vec<Keyframe>| {
        CameraPath::new(
            s,
            None,
            None,
            keyframes(Clock::World, Interpolation::Cubic, kfs),
            "v.toml",
        )
        .map(|_| ())
        .unwrap_err()
        .to_string()
    };
    assert!(new(spec(0, 1.0), two()).contains("frames = 0"));
    let mut s = spec(3, 1.0);
    s.width = 0;
    assert!(new(s, two()).contains("width"));
    assert!(new(spec(3, -1.0), two()).contains("dtau_ps"));
    let mut kfs = two();
    kfs[1].time_ps = 0.0;
    let e = new(spec(3, 1.0), kfs);
    assert!(
        e.contains("keyframe 2 of 2") && e.contains("does not increase"),
        "{e}"
    );
    let mut kfs = two();
    kfs[0].vfov_deg = 180.0;
    assert!(new(spec(3, 1.0), kfs).contains("keyframe 1 of 2: vfov_deg"));
    // Frames must stay within the keyframes' span.
    let e = new(spec(2000, 1.0), two());
    assert!(e.contains("outside the keyframes' span"), "{e}");
    // Odd frame sizes are fine here (even sizes are the video encoder's concern).
    let mut odd = spec(3, 1.0);
    odd.width = 63;
    odd.height = 47;
    assert!(CameraPath::new(
        odd,
        None,
        None,
        keyframes(Clock::World, Interpolation::Cubic, two()),
        "v"
    )
    .is_ok());
    let rot = Some(SensorRotation {
        axis: RotationAxis::Roll,
        beta_edge: 1.0,
    });
    let e = CameraPath::new(
        spec(3, 1.0),
        None,
        rot,
        keyframes(Clock::World, Interpolation::Cubic, two()),
        "v",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("rotation.beta_edge"), "{e}");
}

#[test]
fn orientation_is_slerped_and_fov_interpolated() {
    let mut a = kf(0.0, [0.0; 3]);
    a.orientation = Orientation::Fixed(Rotation3::identity());
    a.vfov_deg = 30.0;
    let mut b = kf(1000.0, [0.0; 3]);
    b.orientation = Orientation::Fixed(Rotation3::from_axis_angle(&Vector3::y_axis(), 1.2));
    b.vfov_deg = 50.0;
    let path = CameraPath::new(
        spec(3, 500.0),
        None,
        None,
        keyframes(Clock::Proper, Interpolation::Cubic, vec![a, b]),
        "o",
    )
    .unwrap();
    let mid = path.frame(1);
    let expect = Rotation3::from_axis_angle(&Vector3::y_axis(), 0.6);
    assert!(
        (mid.world_from_camera.matrix() - expect.matrix())
            .abs()
            .max()
            < 1e-12
    );
    assert!((mid.vfov_deg - 40.0).abs() < 1e-12);
    assert_eq!(mid.beta, Vector3::zeros());
    assert!((mid.t_world_ps - 500.0).abs() < 1e-9);
}

#[test]
fn orbit_keeps_radius_and_speed_and_dilates_time() {
    let centre = Point3::new(0.1, 0.3, -0.2);
    let beta = 0.7;
    let path = CameraPath::orbit(centre, 2.0, beta, Vector3::y(), 35.0, spec(30, 200.0)).unwrap();
    let g = gamma(beta);
    for k in 0..30 {
        let f = path.frame(k);
        assert!((f.t_world_ps - g * f.tau_ps).abs() < 1e-9 * (1.0 + f.t_world_ps));
        let r = f.position_m - centre;
        assert!((r.norm() - 2.0).abs() < 1e-12 && r.y.abs() < 1e-12);
        assert!((f.beta.norm() - beta).abs() < 1e-12 && f.beta.dot(&r).abs() < 1e-12);
        assert!((f.pose().forward() + r / 2.0).norm() < 1e-12);
        if k + 1 < 30 {
            // Velocity is the derivative of position in world time (finite difference
            // over a short step).
            let h = 1e-3;
            let later = path.at_proper_time(f.tau_ps + h);
            let v = (later.position_m - f.position_m) / (C_M_PER_PS * g * h);
            assert!((v - f.beta).norm() < 1e-6, "{v:?} vs {:?}", f.beta);
        }
    }
    // Frame 0 starts on the +z side (e1 = +z for a y axis) and turns towards +x.
    let f0 = path.frame(0);
    assert!((f0.position_m - (centre + Vector3::new(0.0, 0.0, 2.0))).norm() < 1e-12);
    assert!(f0.beta.x > 0.0);
    assert!(CameraPath::orbit(centre, 2.0, 1.0, Vector3::y(), 35.0, spec(3, 1.0)).is_err());
}

#[test]
fn static_view_and_sample_positions() {
    let pose = Pose::look_at(Point3::new(1.0, 2.0, 3.0), Point3::origin(), Vector3::y()).unwrap();
    let path = CameraPath::static_view(&pose, 45.0, spec(5, 2.0)).unwrap();
    for k in 0..5 {
        let f = path.frame(k);
        assert_eq!(f.position_m, pose.position_m);
        let diff = f.world_from_camera.matrix() - pose.world_from_camera.matrix();
        assert!(diff.abs().max() < 1e-12);
        assert_eq!(f.beta, Vector3::zeros());
        assert!((f.t_world_ps - 2.0 * k as f64).abs() < 1e-12);
    }
    let dolly = CameraPath::dolly(
        Point3::new(0.0, 0.0, 5.0),
        Point3::origin(),
        Vector3::y(),
        0.5,
        40.0,
        spec(11, 10.0),
    )
    .unwrap();
    let s = dolly.sample_positions(21);
    assert_eq!(s.len(), 21);
    assert!((s[0] - dolly.frame(0).position_m).norm() < 1e-12);
    assert!((s[20] - dolly.frame(10).position_m).norm() < 1e-12);
    assert!((s[10] - dolly.frame(5).position_m).norm() < 1e-12);
    assert!(dolly.sample_positions(0).is_empty());
}

#[test]
fn pixel_velocity_combines_path_and_sensor_rotation() {
    let half = Vector2::new(32.0, 24.0);
    let corner = Vector2::new(32.0, 24.0);
    let dolly = CameraPath::dolly(
        Point3::new(0.0, 0.0, 5.0),
        Point3::origin(),
        Vector3::y(),
        0.6,
        40.0,
        spec(3, 10.0),
    )
    .unwrap();
    let f = dolly.frame(1);
    assert_eq!(f.pixel_beta(&corner, &half), f.beta);
    let spinning = dolly
        .with_rotation(Some(SensorRotation {
            axis: RotationAxis::Roll,
            beta_edge: 0.9,
        }))
        .unwrap();
    let f = spinning.frame(1);
    // On the axis the pixel moves with the camera.
    assert!((f.pixel_beta(&Vector2::zeros(), &half) - f.beta).norm() < 1e-15);
    // At the corner: the roll velocity is perpendicular to the dolly's (along the optical
    // axis), so the speeds combine as gamma_total = gamma_path * gamma_spin.
    let b = f.pixel_beta(&corner, &half);
    let expect = gamma(0.6) * gamma(0.9);
    assert!((gamma(b.norm()) - expect).abs() < 1e-9 * expect, "{b:?}");
    assert!(b.norm() < 1.0);
}

fn example_toml() -> String {
    r#"width = 65
height = 49
frames = 12
dtau_ps = 40.0
clock = "world"
interpolation = "cubic"

[rotation]
axis = "yaw"
beta_edge = 0.3

[[keyframe]]
time_ps = 0.0
position_m = [0.0, 0.5, 3.0]
look_at_m = [0.0, 0.3, 0.0]
vfov_deg = 40.0
beta = [0.0, 0.0, -0.4]

[[keyframe]]
time_ps = 300.0
position_m = [0.01, 0.5, 2.97]
world_from_camera = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]
vfov_deg = 45.0

[[keyframe]]
time_ps = 600.0
position_m = [0.03, 0.52, 2.94]
look_at_m = [0.0, 0.3, 0.0]
up = [0.0, 1.0, 0.1]
vfov_deg = 45.0
"#
    .to_string()
}

fn assert_same_frames(a: &CameraPath, b: &CameraPath) {
    assert_eq!(a.spec(), b.spec());
    assert_eq!(a.rotation(), b.rotation());
    for k in 0..a.spec().frames {
        let (fa, fb) = (a.frame(k), b.frame(k));
        assert!((fa.position_m - fb.position_m).norm() < 1e-12);
        assert!((fa.t_world_ps - fb.t_world_ps).abs() < 1e-9);
        assert!((fa.beta - fb.beta).norm() < 1e-12);
        assert!(
            (fa.world_from_camera.matrix() - fb.world_from_camera.matrix())
                .abs()
                .max()
                < 1e-12
        );
        assert_eq!(fa.vfov_deg, fb.vfov_deg);
    }
}

#[test]
fn toml_round_trip() {
    let path = CameraPath::from_toml(&example_toml(), "path.toml").unwrap();
    assert_eq!(path.spec().width, 65);
    assert_eq!(
        path.rotation(),
        Some(SensorRotation {
            axis: RotationAxis::Yaw,
            beta_edge: 0.3
        })
    );
    let back = CameraPath::from_toml(&path.to_toml(), "again.toml").unwrap();
    assert_same_frames(&path, &back);
    let orbit = CameraPath::orbit(
        Point3::origin(),
        1.5,
        -0.3,
        Vector3::z(),
        30.0,
        spec(7, 9.0),
    )
    .unwrap();
    let back = CameraPath::from_toml(&orbit.to_toml(), "orbit.toml").unwrap();
    assert_same_frames(&orbit, &back);
    let dolly = CameraPath::dolly(
        Point3::new(0.0, 0.0, 5.0),
        Point3::origin(),
        Vector3::y(),
        0.5,
        40.0,
        spec(11, 10.0),
    )
    .unwrap();
    let back = CameraPath::from_toml(&dolly.to_toml(), "dolly.toml").unwrap();
    assert_same_frames(&dolly, &back);
}

fn orbit_toml() -> String {
    r#"width = 32
height = 24
frames = 6
dtau_ps = 20.0
tau0_ps = 2000.0

[orbit]
centre_m = [0.0, 0.03, 0.0]
axis = [0.0, 1.0, 0.0]
height_m = 0.2
radius_m = 0.5
start_angle_deg = -41.8
beta = 0.3
look_at_m = [0.16, 0.05, 0.07]
vfov_deg = 40.0
"#
    .to_string()
}

/// Every number of both path kinds, made non-finite (or too far), is refused naming the
/// keyframe and the key (issue 16: `look_at_m = [0, -inf, 0]` reached the BVH).
/// Long (132 lines) because it is one table: a row per number of the file format.
/// Each edit of `text` (`from` replaced by `to`) is refused with one line that starts with
/// the file's name and contains `want`.
fn assert_refused_naming_the_key(text: &str, cases: &[(&str, &str, &str)]) {
    for (from, to, want) in cases {
        assert!(text.contains(from), "{from}");
        let edited = text.replacen(from, to, 1);
        let e = CameraPath::from_toml(&edited, "p.toml")
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("p.toml: ") && e.contains(want), "{to}: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}

#[test]
fn every_number_of_a_keyframe_path_must_be_finite_and_the_message_names_its_key() {
    assert_refused_naming_the_key(
        &example_toml(),
        &[
            (
                "look_at_m = [0.0, 0.3, 0.0]",
                "look_at_m = [0.0, -inf, 0.0]",
                "keyframe 1 of 3: look_at_m[1] must be finite, got -inf",
            ),
            (
                "position_m = [0.01, 0.5, 2.97]",
                "position_m = [0.01, nan, 2.97]",
                "keyframe 2 of 3: position_m[1] must be finite, got NaN",
            ),
            (
                "position_m = [0.0, 0.5, 3.0]",
                "position_m = [1e39, 0.5, 3.0]",
                "keyframe 1 of 3: position_m[0] = 1e39 m is beyond",
            ),
            (
                "up = [0.0, 1.0, 0.1]",
                "up = [0.0, inf, 0.1]",
                "keyframe 3 of 3: up[1] must be finite, got inf",
            ),
            (
                "time_ps = 300.0",
                "time_ps = nan",
                "keyframe 2 of 3: time_ps must be finite, got NaN",
            ),
            (
                "vfov_deg = 40.0",
                "vfov_deg = inf",
                "keyframe 1 of 3: vfov_deg must be finite, got inf",
            ),
            (
                "beta = [0.0, 0.0, -0.4]",
                "beta = [0.0, 0.0, -inf]",
                "keyframe 1 of 3: beta[2] must be finite, got -inf",
            ),
            (
                "[[1.0, 0.0, 0.0], [0.0, -1.0",
                "[[1.0, 0.0, 0.0], [0.0, nan",
                "keyframe 2 of 3: world_from_camera[1][1] must be finite, got NaN",
            ),
            ("dtau_ps = 40.0", "dtau_ps = inf", "dtau_ps = inf"),
            (
                "beta_edge = 0.3",
                "beta_edge = nan",
                "rotation.beta_edge = NaN",
            ),
            (
                "dtau_ps = 40.0",
                "dtau_ps = 40.0\ntau0_ps = -inf",
                "tau0_ps = -inf",
            ),
        ],
    );
}

#[test]
fn every_number_of_an_orbit_must_be_finite_and_the_message_names_its_key() {
    let orbit = orbit_toml();
    assert!(CameraPath::from_toml(&orbit, "o.toml").is_ok());
    assert_refused_naming_the_key(
        &orbit,
        &[
            (
                "centre_m = [0.0, 0.03, 0.0]",
                "centre_m = [0.0, 0.03, nan]",
                "orbit.centre_m[2] must be finite, got NaN",
            ),
            (
                "look_at_m = [0.16, 0.05, 0.07]",
                "look_at_m = [0.0, -inf, 0.0]",
                "orbit.look_at_m[1] must be finite, got -inf",
            ),
            (
                "axis = [0.0, 1.0, 0.0]",
                "axis = [0.0, inf, 0.0]",
                "orbit.axis[1] must be finite, got inf",
            ),
            (
                "height_m = 0.2",
                "height_m = -inf",
                "orbit.height_m must be finite",
            ),
            (
                "radius_m = 0.5",
                "radius_m = 1e300",
                "orbit.radius_m = 1e300 m is beyond",
            ),
            (
                "start_angle_deg = -41.8",
                "start_angle_deg = nan",
                "orbit.start_angle_deg must be finite, got NaN",
            ),
            (
                "beta = 0.3",
                "beta = inf",
                "orbit.beta must be finite, got inf",
            ),
            (
                "vfov_deg = 40.0",
                "vfov_deg = -inf",
                "orbit.vfov_deg must be finite",
            ),
            (
                "tau0_ps = 2000.0",
                "tau0_ps = nan",
                "tau0_ps = NaN is not a finite",
            ),
        ],
    );
}

/// The frame count is capped before the frames are walked: a count of 2^64 - 1 is refused
/// at once instead of checking frames for ever (issue 16).
#[test]
fn frame_counts_are_capped_before_the_walk() {
    let started = std::time::Instant::now();
    let text = orbit_toml().replace("frames = 6", "frames = 18446744073709551615");
    let e = CameraPath::from_toml(&text, "p.toml")
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("frames") && e.contains("1000000"), "{e}");
    assert!(started.elapsed().as_secs_f64() < 1.0);
    let at_cap = CameraPath::orbit(
        Point3::origin(),
        1.0,
        0.1,
        Vector3::y(),
        40.0,
        spec(MAX_FRAMES + 1, 1.0),
    );
    assert!(at_cap.is_err());
}

#[test]
fn toml_errors_give_line_and_key() {
    let text = example_toml().replace("vfov_deg = 45.0\n\n", "vfov_deg = 45.0\nzoom = 2\n\n");
    let line = text.lines().position(|l| l.starts_with("zoom")).unwrap() + 1;
    let e = CameraPath::from_toml(&text, "path.toml")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("path.toml") && e.contains(&format!("line {line}")) && e.contains("zoom"),
        "{e}"
    );
    let e = CameraPath::from_toml(&example_toml().replace("clock = \"world\"\n", ""), "p")
        .unwrap_err()
        .to_string();
    assert!(e.contains("clock is missing"), "{e}");
    let e = CameraPath::from_toml(&example_toml().replace("\"yaw\"", "\"spin\""), "p")
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 9"), "{e}");
    let e = CameraPath::from_toml(
        &example_toml().replace(
            "look_at_m = [0.0, 0.3, 0.0]\nvfov_deg = 40.0",
            "vfov_deg = 40.0",
        ),
        "p",
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("keyframe 1 of 3") && e.contains("look_at_m"),
        "{e}"
    );
}

#[test]
fn tangents_are_one_sided_at_the_ends_catmull_rom_inside_and_beta_when_given() {
    use super::keyframes::tangents;
    // Non-uniform knots 0, 1, 3 ps; x = 0, 2, 4 m: slopes 2 and 1 m/ps.
    let mut kfs = vec![
        kf(0.0, [0.0, 0.0, 0.0]),
        kf(1.0, [2.0, 0.0, 0.0]),
        kf(3.0, [4.0, 0.0, 0.0]),
    ];
    let knots: Vec<f64> = kfs.iter().map(|k| k.time_ps).collect();
    let points: Vec<Vector3<f64>> = kfs.iter().map(|k| k.position_m.coords).collect();
    let t = tangents(Clock::World, &kfs, &knots, &points);
    // Inside: the slopes weighted by the other segment's length, (2 * 2 + 1 * 1) / 3.
    let want = [2.0, 5.0 / 3.0, 1.0];
    for (ti, w) in t.iter().zip(want) {
        assert!((ti - Vector3::new(w, 0.0, 0.0)).norm() < 1e-12, "{ti}");
    }
    // A given beta is the velocity: beta c on the world clock, gamma beta c on the proper one.
    kfs[1].beta = Some(Vector3::new(0.0, 0.6, 0.0));
    let c = crate::units::C_M_PER_PS;
    let world = tangents(Clock::World, &kfs, &knots, &points);
    assert!((world[1] - Vector3::new(0.0, 0.6 * c, 0.0)).norm() < 1e-15);
    let proper = tangents(Clock::Proper, &kfs, &knots, &points);
    assert!((proper[1] - Vector3::new(0.0, 1.25 * 0.6 * c, 0.0)).norm() < 1e-15);
    // A single keyframe is at rest.
    let one = tangents(Clock::Proper, &kfs[..1], &knots[..1], &points[..1]);
    assert_eq!(one, vec![Vector3::zeros()]);
}

#[test]
fn a_single_keyframe_with_beta_moves_uniformly_and_its_clock_runs_slow() {
    let beta = Vector3::new(0.0, 0.0, -0.6);
    for clock in [Clock::World, Clock::Proper] {
        let mut k = kf(100.0, [0.0, 0.2, 1.0]);
        k.beta = Some(beta);
        let motion = Motion::Keyframes {
            clock,
            interpolation: Interpolation::Cubic,
            keyframes: vec![k],
        };
        let path = CameraPath::new(spec(5, 10.0), Some(100.0), None, motion, "t").unwrap();
        // Frame 0 is the keyframe itself, bit for bit.
        let f0 = path.frame(0);
        assert_eq!(f0.beta, beta);
        assert_eq!(f0.position_m, Point3::new(0.0, 0.2, 1.0));
        assert_eq!((f0.tau_ps, f0.t_world_ps), (100.0, 100.0));
        // Frame 4, 40 ps of proper time later: gamma = 1.25, so 50 ps of world time, and
        // 0.6 c x 50 ps along -z.
        let f4 = path.frame(4);
        assert!(
            (f4.t_world_ps - 150.0).abs() < 1e-9,
            "{clock:?} {}",
            f4.t_world_ps
        );
        let moved = f4.position_m - f0.position_m;
        let want = beta * C_M_PER_PS * 50.0;
        assert!((moved - want).norm() < 1e-12, "{clock:?} {moved}");
        assert!((f4.beta - beta).norm() < 1e-15);
    }
}

#[test]
fn at_a_keyframes_own_time_the_camera_is_exactly_in_its_state() {
    // A cubic path whose keyframes carry beta and rotations: frame 0 sits on the first
    // keyframe, and must give back its numbers unchanged (no slerp renormalisation, no
    // tangent round trip), as the viewer's still of that keyframe does.
    let r = Rotation3::from_euler_angles(0.1, -0.7, 0.3);
    let beta = Vector3::new(0.123456789, -0.01, 0.3);
    let mut a = kf(1000.0, [0.1, 0.2, 0.9]);
    a.orientation = Orientation::Fixed(r);
    a.beta = Some(beta);
    a.vfov_deg = 33.3;
    let mut b = kf(4000.0, [0.1, 0.25, 0.8]);
    b.orientation = Orientation::Fixed(Rotation3::from_euler_angles(0.0, -0.5, 0.0));
    let path = |keyframes: Vec<Keyframe>| {
        let motion = Motion::Keyframes {
            clock: Clock::World,
            interpolation: Interpolation::Cubic,
            keyframes,
        };
        CameraPath::new(spec(3, 10.0), Some(1000.0), None, motion, "t").unwrap()
    };
    let two = path(vec![a.clone(), b]).frame(0);
    let one = path(vec![a]).frame(0);
    assert_eq!(two, one);
    assert_eq!(two.beta, beta);
    assert_eq!(two.vfov_deg, 33.3);
}

//! The relativistic renderer against physics: expectations come from an independent general
//! Lorentz boost of photon 4-momenta written in `common`, from closed forms derived in each
//! test, or from the calibration's own first-arrival formula; never from the renderer.

mod common;

use common::lorentz::{photon_camera_to_world, photon_world_to_camera};
use common::*;
#[path = "common/cli.rs"]
mod cli;
use cli::FemtoCmd;
use femto::camera::{Calibration, Pose};
use femto::camera_path::{
    CameraPath, Clock, FrameSpec, FrameState, Interpolation, Keyframe, Motion, Orientation,
};
use femto::color;
use femto::cube::{Cube, TimeAxis};
use femto::geometry::bvh::Bvh;
use femto::pyramid::Pyramid;
use femto::relativity::{gamma, Radiometry, RotationAxis, SensorRotation};
use femto::render::{
    check_path_clear, probe_pixel, render_frame, render_sequence, ColourOutput, Effects,
    Isochrones, RenderError, RenderScene, RenderSettings, View,
};
use femto::units::C_M_PER_PS;
use nalgebra::{Matrix3, Point3, Rotation3, Vector2, Vector3};

fn spec(width: usize, height: usize, frames: usize, dtau_ps: f64) -> FrameSpec {
    FrameSpec {
        width,
        height,
        frames,
        dtau_ps,
    }
}

fn render(scene: &RenderScene, settings: &RenderSettings, state: &FrameState) -> Vec<[f32; 3]> {
    let mut out = vec![[0.0f32; 3]; settings.width * settings.height];
    render_frame(scene, settings, state, &mut out);
    out
}

fn lum(px: [f32; 3]) -> f64 {
    color::luminance([px[0] as f64, px[1] as f64, px[2] as f64])
}

/// Luminance-weighted centroid (pixel coordinates, centres at +0.5) of a `w x h` frame; None
/// when the frame is black.
fn centroid(img: &[[f32; 3]], w: usize, h: usize) -> Option<(f64, f64)> {
    let (mut sum, mut su, mut sv) = (0.0, 0.0, 0.0);
    for j in 0..h {
        for i in 0..w {
            let l = lum(img[j * w + i]);
            sum += l;
            su += l * (i as f64 + 0.5);
            sv += l * (j as f64 + 0.5);
        }
    }
    (sum > 0.0).then(|| (su / sum, sv / sum))
}

/// Focal length in pixels of a frame `height` pixels high with vertical field of view
/// `vfov_deg` (pinhole, principal point at the centre).
fn focal_px(height: usize, vfov_deg: f64) -> f64 {
    0.5 * height as f64 / (0.5 * vfov_deg.to_radians()).tan()
}

/// World-axes camera ray through the centre of pixel (i, j).
fn pixel_ray(
    pose: &Pose,
    width: usize,
    height: usize,
    vfov_deg: f64,
    i: usize,
    j: usize,
) -> Vector3<f64> {
    let f = focal_px(height, vfov_deg);
    let local = Vector3::new(
        (i as f64 + 0.5 - 0.5 * width as f64) / f,
        (j as f64 + 0.5 - 0.5 * height as f64) / f,
        1.0,
    );
    pose.world_from_camera * local.normalize()
}

/// A uniformly lit world: constant signal density `density` per ps at every point the
/// capture camera sees, over a long axis.
fn constant_cube(cal: &Calibration, bvh: &Bvh, density: f64) -> Cube {
    let axis = TimeAxis {
        t0_ps: -2.0e6,
        dt_ps: 1.0e6,
        nt: 4,
    };
    world_cube(cal, bvh, axis, |_, _, a, b| density * (b - a))
}

/// The cube scene's mesh, a 40 x 30 capture camera and the prefix sums of its single-bounce
/// world cube (300 bins of 40 ps, pulses of 60 ps), with the cube's mask `mask`.
fn small_cube_world(mask: Option<Vec<u8>>) -> (Bvh, Calibration, Pyramid) {
    let bvh = Bvh::new(cube_scene_mesh());
    let cal = cube_scene_calibration(40, 30);
    let axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: 40.0,
        nt: 300,
    };
    let mut cube = world_cube(&cal, &bvh, axis, single_bounce_energy(&cal, 60.0));
    cube.mask = mask;
    let pyramid = Pyramid::build(&cube);
    (bvh, cal, pyramid)
}

/// `path` with a sensor that rotates about `axis`, its edges at `beta_edge`.
fn with_rotation(path: &CameraPath, axis: RotationAxis, beta_edge: f64) -> CameraPath {
    CameraPath::new(
        path.spec(),
        Some(path.tau0_ps()),
        Some(SensorRotation { axis, beta_edge }),
        path.motion().clone(),
        "rotating",
    )
    .unwrap()
}

#[test]
fn marker_centroid_lies_within_half_a_pixel_of_the_boosted_photon_direction() {
    let wall = Bvh::new(wall_z0(200.0));
    let (w, h, vfov) = (160usize, 120usize, 50.0);
    let f = focal_px(h, vfov);
    let start = Point3::new(0.4, 0.25, 2.5);
    let target = Point3::origin();
    let pose = Pose::look_at(start, target, Vector3::y()).unwrap();
    let r = pose.world_from_camera;
    for beta in [0.3, 0.6, 0.9] {
        for towards in [true, false] {
            let signed = if towards { beta } else { -beta };
            let v = (target - start).normalize() * signed;
            // Image of a world point: its photon's direction boosted into the camera frame.
            let predict = |p: &Point3<f64>| {
                let (d_cam, _) = photon_world_to_camera(&v, &(p - start).normalize());
                let l = r.inverse_transform_vector(&d_cam);
                (
                    f * l.x / l.z + 0.5 * w as f64,
                    f * l.y / l.z + 0.5 * h as f64,
                )
            };
            // Put the marker where the camera-frame pixel (0.62 w, 0.41 h) looks: boost that
            // direction into the world and intersect the wall.
            let local = Vector3::new(
                (0.62 * w as f64 - 0.5 * w as f64) / f,
                (0.41 * h as f64 - 0.5 * h as f64) / f,
                1.0,
            )
            .normalize();
            let (n_world, _) = photon_camera_to_world(&v, &(r * local));
            let m = start + n_world * (-start.z / n_world.z);
            let (pu, pv) = predict(&m);
            // A Gaussian blob about 1.5 px wide in the image.
            let delta = 1e-4;
            let (ux, vx) = predict(&(m + Vector3::x() * delta));
            let (uy, vy) = predict(&(m + Vector3::y() * delta));
            let px_per_m = ((ux - pu).hypot(vx - pv)).min((uy - pu).hypot(vy - pv)) / delta;
            let sigma_m = 1.5 / px_per_m;
            // A capture camera close to the marker, resolving the blob finely.
            let cap_pos = m + Vector3::new(0.05, -0.04, 1.0);
            let cap_vfov = 2.0 * (5.0 * sigma_m / (m - cap_pos).norm()).atan().to_degrees();
            let cal = calibration(96, 96, cap_vfov, cap_pos, m);
            let axis = TimeAxis {
                t0_ps: -1.0e6,
                dt_ps: 1.0e6,
                nt: 2,
            };
            let cube = world_cube(&cal, &wall, axis, |p, _, a, b| {
                let d2 = (p - m).norm_squared();
                (-d2 / (2.0 * sigma_m * sigma_m)).exp() * (b - a)
            });
            let pyramid = Pyramid::build(&cube);
            let scene = RenderScene::new(&wall, cal, &pyramid, 670.0).unwrap();
            let path = CameraPath::dolly(
                start,
                target,
                Vector3::y(),
                signed,
                vfov,
                spec(w, h, 1, 1.0),
            )
            .unwrap();
            let settings = RenderSettings::for_path(&path);
            let img = render(&scene, &settings, &path.frame(0));
            let (cu, cv) = centroid(&img, w, h)
                .unwrap_or_else(|| panic!("beta {signed}: the marker is not in the frame"));
            let err = (cu - pu).hypot(cv - pv);
            assert!(
                err < 0.5,
                "beta {signed}: centroid ({cu:.3}, {cv:.3}) vs boost ({pu:.3}, {pv:.3}): {err:.3} px"
            );
            // At rest the marker would be elsewhere: the test does see the aberration.
            let rest = {
                let l = r.inverse_transform_vector(&(m - start));
                (
                    f * l.x / l.z + 0.5 * w as f64,
                    f * l.y / l.z + 0.5 * h as f64,
                )
            };
            assert!((rest.0 - pu).hypot(rest.1 - pv) > 2.0, "beta {signed}");
        }
    }
}

/// Velocity over c of a straight path through `start` along `dir` at `beta`, as a
/// world-clock keyframe path with a fixed orientation.
fn straight_path(
    start: Point3<f64>,
    beta_vec: Vector3<f64>,
    orientation: Rotation3<f64>,
    vfov: f64,
    s: FrameSpec,
) -> CameraPath {
    let t_end = (s.frames.max(2) - 1) as f64 * s.dtau_ps * gamma(beta_vec.norm()) * 1.5 + 1.0;
    let kf = |t: f64| Keyframe {
        time_ps: t,
        position_m: start + beta_vec * (C_M_PER_PS * t),
        orientation: Orientation::Fixed(orientation),
        vfov_deg: vfov,
        beta: None,
    };
    CameraPath::new(
        s,
        None,
        None,
        Motion::Keyframes {
            clock: Clock::World,
            interpolation: Interpolation::Linear,
            keyframes: vec![kf(0.0), kf(t_end)],
        },
        "test path",
    )
    .unwrap()
}

#[test]
fn constant_light_scales_as_d_to_the_minus_four_and_rays_follow_the_boost() {
    let wall = Bvh::new(wall_z0(200.0));
    let cal = calibration(
        200,
        200,
        150.0,
        Point3::new(0.0, 0.0, 8.0),
        Point3::origin(),
    );
    let density = 2.5;
    let cube = constant_cube(&cal, &wall, density);
    let pyramid = Pyramid::build(&cube);
    let scene = RenderScene::new(&wall, cal, &pyramid, 670.0).unwrap();
    let (w, h, vfov) = (33usize, 25usize, 16.0);
    let start = Point3::new(0.3, -0.2, 2.0);
    let pose = Pose::look_at(start, Point3::origin(), Vector3::y()).unwrap();
    let rest = CameraPath::static_view(&pose, vfov, spec(w, h, 1, 5.0)).unwrap();
    let pixels = [(16usize, 12usize), (8, 18), (26, 5)];
    let axis_dir = (Point3::origin() - start).normalize();
    let oblique = Vector3::new(0.3, 0.2, -1.0).normalize();
    let mut cases: Vec<Vector3<f64>> = Vec::new();
    for beta in [0.3, 0.6, 0.9] {
        cases.push(axis_dir * beta);
        cases.push(-axis_dir * beta);
    }
    for beta in [0.3, 0.6] {
        cases.push(oblique * beta);
        cases.push(Vector3::new(1.0, 0.0, 0.0) * beta);
    }
    let base = RenderSettings::for_path(&rest);
    let rest_state = rest.frame(0);
    for v in cases {
        let path = straight_path(start, v, pose.world_from_camera, vfov, spec(w, h, 1, 5.0));
        let state = path.frame(0);
        assert!((state.beta - v).norm() < 1e-12);
        for &(i, j) in &pixels {
            let d_cam = pixel_ray(&pose, w, h, vfov, i, j);
            let (n_world, dop) = photon_camera_to_world(&v, &d_cam);
            // End to end: the renderer's ray and Doppler factor are the boost's.
            let s = probe_pixel(&scene, &base, &state, i, j);
            assert!((s.d_world - n_world).norm() < 1e-9, "v {v:?} ({i}, {j})");
            assert!(
                (s.doppler - dop).abs() < 1e-9 * dop,
                "v {v:?}: D {} vs {dop}",
                s.doppler
            );
            let at_rest = probe_pixel(&scene, &base, &rest_state, i, j).value;
            assert!((at_rest - density).abs() < 1e-9 * density, "{at_rest}");
            let ratio = s.value / at_rest;
            let expect = dop.powi(-4);
            assert!(
                (ratio / expect - 1.0).abs() < 0.01,
                "v {v:?} pixel ({i}, {j}): ratio {ratio} vs D^-4 = {expect} (D = {dop})"
            );
            // The seed's literal formulas: D^-6.
            let paper = RenderSettings {
                radiometry: Radiometry::Paper,
                ..base
            };
            let ratio = probe_pixel(&scene, &paper, &state, i, j).value / at_rest;
            assert!((ratio / dop.powi(-6) - 1.0).abs() < 0.01, "paper: {ratio}");
            // Effects one at a time: only the searchlight changes the brightness.
            for (name, on) in [
                ("searchlight", true),
                ("aberration", false),
                ("doppler", false),
                ("unwarp", false),
                ("dilation", false),
                ("rotation", false),
            ] {
                let one = RenderSettings {
                    effects: Effects::parse(name).unwrap(),
                    ..base
                };
                let s1 = probe_pixel(&scene, &one, &state, i, j);
                let ratio = s1.value / at_rest;
                if on {
                    // Without aberration the ray is d', and D that of light from there.
                    let (_, d_world_dir) = photon_world_to_camera(&v, &d_cam);
                    assert!(
                        (ratio * d_world_dir.powi(4) - 1.0).abs() < 0.01,
                        "{name}: {ratio} vs D^-4 of the unaberrated ray"
                    );
                } else {
                    assert!((ratio - 1.0).abs() < 1e-9, "{name}: {ratio}");
                }
                if one.effects.aberration {
                    assert!((s1.d_world - n_world).norm() < 1e-9, "{name}");
                } else {
                    assert!((s1.d_world - d_cam).norm() < 1e-12, "{name}");
                }
            }
            let none = RenderSettings {
                effects: Effects::NONE,
                ..base
            };
            let s0 = probe_pixel(&scene, &none, &state, i, j);
            assert!((s0.d_world - d_cam).norm() < 1e-12);
            assert_eq!(s0.lambda_nm, 670.0);
            assert!((s0.value / at_rest - 1.0).abs() < 1e-9);
        }
    }
}

#[test]
fn doppler_shift_gives_the_chromaticity_of_the_received_wavelength() {
    let wall = Bvh::new(wall_z0(200.0));
    let cal = calibration(64, 64, 60.0, Point3::new(0.0, 0.0, 5.0), Point3::origin());
    let cube = constant_cube(&cal, &wall, 1.0);
    let pyramid = Pyramid::build(&cube);
    let scene = RenderScene::new(&wall, cal, &pyramid, 670.0).unwrap();
    // physics.md's table of the CIE 1931 matching functions.
    let spots = [
        (450.0, [0.3362, 0.0380, 1.77211]),
        (555.0, [0.51205, 1.0, 0.00575]),
        (600.0, [1.0622, 0.631, 0.0008]),
    ];
    let white = [0.3127, 0.3290];
    let chroma = |xyz: [f64; 3]| {
        let s = xyz[0] + xyz[1] + xyz[2];
        [xyz[0] / s, xyz[1] / s]
    };
    // Odd frame: the centre pixel's ray is the optical axis, along the velocity.
    let (w, h) = (9usize, 7usize);
    let start = Point3::new(0.0, 0.0, 2.0);
    for (target_nm, cmf) in spots {
        // Head-on, D = sqrt((1 - beta) / (1 + beta)): beta = (1 - D^2) / (1 + D^2).
        let d = target_nm / 670.0;
        let beta = (1.0 - d * d) / (1.0 + d * d);
        let path = CameraPath::dolly(
            start,
            Point3::origin(),
            Vector3::y(),
            beta,
            30.0,
            spec(w, h, 1, 1.0),
        )
        .unwrap();
        let mut settings = RenderSettings::for_path(&path);
        settings.colour = ColourOutput::Xyz;
        let img = render(&scene, &settings, &path.frame(0));
        let px = img[(h / 2) * w + w / 2];
        let got = chroma([px[0] as f64, px[1] as f64, px[2] as f64]);
        let expect = chroma(cmf);
        assert!(
            (got[0] - expect[0]).abs() < 2e-4 && (got[1] - expect[1]).abs() < 2e-4,
            "{target_nm} nm: xy {got:?} vs {expect:?}"
        );
        // Display colours keep the hue: between white and the spectral colour, on its line.
        settings.colour = ColourOutput::LinearSrgb;
        let img = render(&scene, &settings, &path.frame(0));
        let px = img[(h / 2) * w + w / 2];
        let shown = chroma(color::linear_srgb_to_xyz([
            px[0] as f64,
            px[1] as f64,
            px[2] as f64,
        ]));
        let (a, b) = (
            [shown[0] - white[0], shown[1] - white[1]],
            [expect[0] - white[0], expect[1] - white[1]],
        );
        assert!(
            (a[0] * b[1] - a[1] * b[0]).abs() < 1e-3,
            "{target_nm}: {shown:?}"
        );
        assert!(a[0] * b[0] + a[1] * b[1] > 0.0);
        // Doppler off: the laser's own colour.
        settings.effects.doppler = false;
        let img = render(&scene, &settings, &path.frame(0));
        let px = img[(h / 2) * w + w / 2];
        let c = color::laser_colour(670.0);
        let y = lum(px);
        for k in 0..3 {
            assert!((px[k] as f64 - y * c[k]).abs() < 1e-5 * y.max(1.0));
        }
    }
    // Moving away fast enough to shift 670 nm past 780 nm: grey.
    let path = CameraPath::dolly(
        start,
        Point3::origin(),
        Vector3::y(),
        -0.4,
        30.0,
        spec(w, h, 1, 1.0),
    )
    .unwrap();
    let settings = RenderSettings::for_path(&path);
    let img = render(&scene, &settings, &path.frame(0));
    let px = img[(h / 2) * w + w / 2];
    assert!(px[0] > 0.0 && px[0] == px[1] && px[1] == px[2], "{px:?}");
}

/// Period, in frames, of a sampled oscillation: the mean spacing of its upward mean
/// crossings (linear interpolation between frames).
fn period_frames(series: &[f64]) -> f64 {
    let mean = series.iter().sum::<f64>() / series.len() as f64;
    let mut crossings = Vec::new();
    for k in 0..series.len() - 1 {
        let (a, b) = (series[k] - mean, series[k + 1] - mean);
        if a < 0.0 && b >= 0.0 {
            crossings.push(k as f64 + a / (a - b));
        }
    }
    assert!(crossings.len() >= 3, "too few periods: {crossings:?}");
    (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64
}

/// A wall whose light oscillates in world time with period `period_ps`, everywhere in phase.
fn pulsing_wall_scene(cal: &Calibration, wall: &Bvh, period_ps: f64) -> Pyramid {
    let axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: 2.0,
        nt: 6000,
    };
    let w = 2.0 * std::f64::consts::PI / period_ps;
    let cube = world_cube(cal, wall, axis, |_, _, a, b| {
        (b - a) + 0.8 * ((w * b).sin() - (w * a).sin()) / w
    });
    Pyramid::build(&cube)
}

fn centre_series(scene: &RenderScene, settings: &RenderSettings, path: &CameraPath) -> Vec<f64> {
    let (w, h) = (settings.width, settings.height);
    let mut series = Vec::new();
    render_sequence::<RenderError>(scene, settings, path, 0..path.spec().frames, |_, px| {
        series.push(lum(px[(h / 2) * w + w / 2]));
        Ok(())
    })
    .unwrap();
    series
}

#[test]
fn a_periodic_source_is_seen_with_its_period_scaled_by_d_and_frame_times_follow_gamma() {
    let wall = Bvh::new(wall_z0(200.0));
    let cal = calibration(32, 24, 100.0, Point3::new(0.0, 0.0, 3.0), Point3::origin());
    let period_ps = 400.0;
    let pyramid = pulsing_wall_scene(&cal, &wall, period_ps);
    let scene = RenderScene::new(&wall, cal, &pyramid, 670.0).unwrap();
    let (w, h) = (9usize, 7usize);
    let beta: f64 = 0.6;
    let g = gamma(beta);

    // Head-on towards the wall: the centre pixel keeps looking at the same point, a source at
    // rest, whose period is seen scaled by D = sqrt((1 - beta) / (1 + beta)).
    let dtau = 4.0;
    let path = CameraPath::dolly(
        Point3::new(0.0, 0.0, 2.0),
        Point3::origin(),
        Vector3::y(),
        beta,
        20.0,
        spec(w, h, 260, dtau),
    )
    .unwrap();
    let mut settings = RenderSettings::for_path(&path);
    settings.time_offset_ps = 10000.0;
    let d = ((1.0 - beta) / (1.0 + beta)).sqrt();
    let got = period_frames(&centre_series(&scene, &settings, &path)) * dtau;
    assert!(
        (got / (d * period_ps) - 1.0).abs() < 0.01,
        "head-on: period {got} ps vs D T = {}",
        d * period_ps
    );
    // Without dilation the world clock runs at tau while the camera still covers gamma beta c
    // per unit tau: the emission time advances at 1 + gamma beta.
    settings.effects.dilation = false;
    let got = period_frames(&centre_series(&scene, &settings, &path)) * dtau;
    let expect = period_ps / (1.0 + g * beta);
    assert!(
        (got / expect - 1.0).abs() < 0.01,
        "no dilation: {got} vs {expect}"
    );

    // Sideways along the wall, looking straight at it: the centre pixel's world ray keeps its
    // angle, so its distance to the wall is constant and only the clocks differ: a period
    // T / gamma in proper time.
    let dtau = 8.0;
    let facing_wall = Rotation3::from_matrix_unchecked(Matrix3::new(
        1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0,
    ));
    let path = straight_path(
        Point3::new(-0.5, 0.0, 2.0),
        Vector3::new(beta, 0.0, 0.0),
        facing_wall,
        20.0,
        spec(w, h, 200, dtau),
    );
    let mut settings = RenderSettings::for_path(&path);
    settings.time_offset_ps = 10000.0;
    let got = period_frames(&centre_series(&scene, &settings, &path)) * dtau;
    assert!(
        (got / (period_ps / g) - 1.0).abs() < 0.01,
        "sideways: {got} vs T / gamma = {}",
        period_ps / g
    );
    // Frame times: world time of reception advances gamma dtau per frame.
    for k in [0usize, 57, 198] {
        let a = probe_pixel(&scene, &settings, &path.frame(k), w / 2, h / 2).t_receive_ps;
        let b = probe_pixel(&scene, &settings, &path.frame(k + 1), w / 2, h / 2).t_receive_ps;
        assert!(
            ((b - a) / (g * dtau) - 1.0).abs() < 1e-6,
            "frame {k}: {}",
            b - a
        );
    }
    settings.effects.dilation = false;
    let got = period_frames(&centre_series(&scene, &settings, &path)) * dtau;
    assert!(
        (got / period_ps - 1.0).abs() < 0.01,
        "sideways, no dilation: {got}"
    );
    let a = probe_pixel(&scene, &settings, &path.frame(3), w / 2, h / 2).t_receive_ps;
    let b = probe_pixel(&scene, &settings, &path.frame(4), w / 2, h / 2).t_receive_ps;
    assert!((b - a - dtau).abs() < 1e-9);
}

#[test]
fn capture_view_replays_the_capture_and_other_views_follow_their_definitions() {
    let mesh = cube_scene_mesh();
    let bvh = Bvh::new(mesh);
    let (w, h) = (40usize, 30usize);
    let cal = cube_scene_calibration(w, h);
    let axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: 4.0,
        nt: 3000,
    };
    let cube = world_cube(&cal, &bvh, axis, single_bounce_energy(&cal, 6.0));
    let pyramid = Pyramid::build(&cube);
    let scene = RenderScene::new(&bvh, cal, &pyramid, 670.0).unwrap();
    let vfov = 40.0;
    let dtau = 8.0;
    let frames = 2600;
    let path = CameraPath::static_view(&cal.pose, vfov, spec(w, h, frames, dtau)).unwrap();
    let settings = RenderSettings::for_path(&path);
    // Peak frame of some pixels against the calibration's first-arrival time.
    let probes = [(20usize, 15usize), (5, 25), (33, 8), (12, 4)];
    let series: Vec<Vec<f64>> = probes
        .iter()
        .map(|&(i, j)| {
            (0..frames)
                .map(|k| probe_pixel(&scene, &settings, &path.frame(k), i, j).value)
                .collect()
        })
        .collect();
    let state = path.frame(0);
    for (s, &(i, j)) in series.iter().zip(&probes) {
        let (p, _) = probe_pixel(&scene, &settings, &state, i, j).hit_m.unwrap();
        // Camera time of first arrival, back to physical time (t0 is when the pulse leaves).
        let t_first = cal.first_arrival_ps(&p) - cal.t0_ps;
        let peak = s
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap()
            .0;
        // Frame k integrates [k dtau, (k + 1) dtau].
        let expect = t_first / dtau - 0.5;
        assert!(
            (peak as f64 - expect).abs() <= 1.0,
            "pixel ({i}, {j}): peak frame {peak}, first arrival at frame {expect:.2}"
        );
        // Isochrones at the capture pose: the same first-arrival time.
        let iso = RenderSettings {
            view: View::Isochrones(Isochrones {
                t_min_ps: 0.0,
                t_max_ps: 1.0e4,
                contour_ps: 100.0,
            }),
            ..settings
        };
        let t = probe_pixel(&scene, &iso, &state, i, j)
            .t_arrival_ps
            .unwrap();
        assert!((t - t_first).abs() < 1e-6, "isochrone {t} vs {t_first}");
    }
    // The naive view equals the transient one at the capture pose, and elsewhere samples the
    // cube at the capture camera's warp.
    let naive = RenderSettings {
        view: View::Naive,
        ..settings
    };
    let k = 400;
    assert_eq!(
        render(&scene, &settings, &path.frame(k)),
        render(&scene, &naive, &path.frame(k))
    );
    let elsewhere = Pose::look_at(
        Point3::new(-0.6, 0.9, 1.6),
        Point3::new(0.0, 0.3, -0.3),
        Vector3::y(),
    )
    .unwrap();
    let moved = CameraPath::static_view(&elsewhere, vfov, spec(w, h, 1, dtau)).unwrap();
    let mut compared = 0;
    for j in (0..h).step_by(3) {
        for i in (0..w).step_by(3) {
            let a = probe_pixel(&scene, &settings, &moved.frame(0), i, j);
            let b = probe_pixel(&scene, &naive, &moved.frame(0), i, j);
            if let (Some(ta), Some(tb)) = (a.t_emit_ps, b.t_emit_ps) {
                let (p, r) = a.hit_m.unwrap();
                let expect = (r - (p - cal.pose.position_m).norm()) / C_M_PER_PS;
                assert!((tb - ta - expect).abs() < 1e-6, "({i}, {j})");
                compared += 1;
            }
        }
    }
    assert!(compared > 20, "{compared}");
    // The integrated view at rest is the capture's time-integrated image.
    let integrated = RenderSettings {
        view: View::Integrated,
        ..settings
    };
    let img = render(&scene, &integrated, &state);
    let total = cube.time_integral();
    for j in 0..h {
        for i in 0..w {
            let y = lum(img[j * w + i]);
            let expect = total[j * w + i];
            assert!(
                (y - expect).abs() <= 1e-5 * expect.abs().max(1e-12),
                "({i}, {j}): {y} vs {expect}"
            );
        }
    }
}

/// Signal density of the cube scene for the interpolation test: smooth over each surface,
/// and 100 times brighter on the room (floor and back wall) than on the box.
fn surface_density(p: &Point3<f64>) -> f64 {
    let eps = 1e-4;
    let on_box = p.x.abs() <= 0.2 + eps
        && p.y > eps
        && p.y <= 0.4 + eps
        && (-0.3 - eps..=0.1 + eps).contains(&p.z);
    if on_box {
        1.0 + 0.5 * p.x + 0.25 * p.y
    } else {
        100.0 * (1.0 + 0.1 * p.x + 0.05 * p.z)
    }
}

#[test]
fn a_magnified_view_interpolates_the_capture_within_a_surface_and_never_across_an_edge() {
    // The capture camera's own view at 4 x its pixels: each cube pixel spans 4 x 4 rendered
    // pixels, and the rendered centres fall between the cube pixels' centres.
    let bvh = Bvh::new(cube_scene_mesh());
    let (w, h) = (40usize, 30usize);
    let cal = cube_scene_calibration(w, h);
    let axis = TimeAxis {
        t0_ps: -2.0e6,
        dt_ps: 1.0e6,
        nt: 4,
    };
    let span_ps = axis.nt as f64 * axis.dt_ps;
    let cube = world_cube(&cal, &bvh, axis, |p, _, a, b| surface_density(p) * (b - a));
    let totals = cube.time_integral();
    let pyramid = Pyramid::build(&cube);
    let scene = RenderScene::new(&bvh, cal, &pyramid, 670.0).unwrap();
    let (rw, rh) = (4 * w, 4 * h);
    let path = CameraPath::static_view(&cal.pose, 40.0, spec(rw, rh, 1, 1.0)).unwrap();
    let settings = RenderSettings {
        view: View::Integrated,
        ..RenderSettings::for_path(&path)
    };
    let state = path.frame(0);
    let (mut err_render, mut err_nearest) = (0.0, 0.0);
    let (mut room, mut on_box, mut outline) = (0, 0, 0);
    for j in 0..rh {
        for i in 0..rw {
            let s = probe_pixel(&scene, &settings, &state, i, j);
            let (Some((x, y)), Some((p, _))) = (s.capture_pixel, s.hit_m) else {
                continue;
            };
            let truth = surface_density(&p);
            let shown = s.value / span_ps;
            let nearest = totals[y * w + x] / span_ps;
            if (truth < 10.0) != (nearest < 10.0) {
                // Within a capture pixel of the box's outline the nearest pixel may record
                // the other surface (the visibility test's tolerance, module doc of
                // `femto::render`, "Visibility"), interpolation or not.
                outline += 1;
                continue;
            }
            if truth < 10.0 {
                // The box: the nearest pixel alone is off by up to half a pixel's change
                // (1.4 % at its edges, where no neighbour is taken); a room pixel taken
                // with a weight of even 1/2000 would add 5 % more.
                on_box += 1;
                assert!(
                    (shown - truth).abs() < 0.05 * truth,
                    "({i}, {j}) on the box shows {shown}, its density is {truth}"
                );
            } else {
                room += 1;
                err_render += (shown - truth).abs();
                err_nearest += (nearest - truth).abs();
            }
        }
    }
    assert!(
        on_box > 500 && room > 5000,
        "{on_box} box, {room} room pixels"
    );
    assert!(
        outline < (on_box + room) / 50,
        "{outline} pixels near the box's outline"
    );
    // Within the room the signal is smooth: interpolation follows it, the nearest cube pixel
    // alone makes steps of up to half a pixel's change.
    assert!(
        err_render < 0.25 * err_nearest,
        "mean error {:.4} against the nearest pixel's {:.4}",
        err_render / room as f64,
        err_nearest / room as f64
    );
}

#[test]
fn rotating_sensor_gives_each_pixel_its_own_velocity() {
    let wall = Bvh::new(wall_z0(200.0));
    let cal = calibration(
        100,
        100,
        140.0,
        Point3::new(0.0, 0.0, 6.0),
        Point3::origin(),
    );
    let cube = constant_cube(&cal, &wall, 1.0);
    let pyramid = Pyramid::build(&cube);
    let scene = RenderScene::new(&wall, cal, &pyramid, 670.0).unwrap();
    let (w, h, vfov) = (33usize, 25usize, 30.0);
    let pose = Pose::look_at(Point3::new(0.2, 0.1, 2.0), Point3::origin(), Vector3::y()).unwrap();
    let beta_edge = 0.7;
    let path = CameraPath::static_view(&pose, vfov, spec(w, h, 1, 2.0))
        .unwrap()
        .with_rotation(Some(SensorRotation {
            axis: RotationAxis::Roll,
            beta_edge,
        }))
        .unwrap();
    let settings = RenderSettings::for_path(&path);
    let state = path.frame(0);
    let r_edge = (0.5 * w as f64).hypot(0.5 * h as f64);
    for (i, j) in [(16usize, 12usize), (0, 0), (32, 3), (5, 20)] {
        // Roll about the optical axis: omega = beta_edge / r_edge along +z (camera frame),
        // velocity omega x r with r the pixel's offset from the sensor centre.
        let (ox, oy) = (
            i as f64 + 0.5 - 0.5 * w as f64,
            j as f64 + 0.5 - 0.5 * h as f64,
        );
        let omega = beta_edge / r_edge;
        let v = pose.world_from_camera * Vector3::new(-omega * oy, omega * ox, 0.0);
        let s = probe_pixel(&scene, &settings, &state, i, j);
        assert!(
            (s.beta - v).norm() < 1e-12,
            "({i}, {j}): {:?} vs {v:?}",
            s.beta
        );
        let d_cam = pixel_ray(&pose, w, h, vfov, i, j);
        let (n_world, dop) = photon_camera_to_world(&v, &d_cam);
        assert!((s.d_world - n_world).norm() < 1e-9);
        assert!((s.value - dop.powi(-4)).abs() < 0.01 * dop.powi(-4));
        let off = RenderSettings {
            effects: Effects {
                rotation: false,
                ..Effects::ALL
            },
            ..settings
        };
        let s = probe_pixel(&scene, &off, &state, i, j);
        assert_eq!(s.beta, Vector3::zeros());
        assert!((s.value - 1.0).abs() < 1e-9);
    }
    // The sensor speed reaches beta_edge at the corners, as the path promised.
    let corner = state.pixel_beta(
        &Vector2::new(0.5 * w as f64, 0.5 * h as f64),
        &Vector2::new(0.5 * w as f64, 0.5 * h as f64),
    );
    assert!((corner.norm() - beta_edge).abs() < 1e-12);
}

#[test]
fn a_path_through_the_geometry_is_an_error() {
    let wall = Bvh::new(wall_z0(5.0));
    // 10 frames of 1 ns at beta 0.5: 1.56 m of travel from 0.5 m in front of the wall.
    let through = CameraPath::dolly(
        Point3::new(0.0, 0.0, 0.5),
        Point3::new(0.0, 0.0, -5.0),
        Vector3::y(),
        0.5,
        30.0,
        spec(8, 6, 10, 1000.0),
    )
    .unwrap();
    let e = check_path_clear(&wall, &through).unwrap_err();
    assert!(matches!(e, RenderError::PathThroughGeometry { .. }));
    let msg = e.to_string();
    assert!(msg.contains("passes through"), "{msg}");
    // The crossing point is reported on the wall.
    if let RenderError::PathThroughGeometry { point_m, .. } = e {
        assert!(point_m[2].abs() < 1e-4, "{point_m:?}");
    }
    let short = CameraPath::dolly(
        Point3::new(0.0, 0.0, 0.5),
        Point3::new(0.0, 0.0, -5.0),
        Vector3::y(),
        0.5,
        30.0,
        spec(8, 6, 10, 100.0),
    )
    .unwrap();
    assert!(check_path_clear(&wall, &short).is_ok());
}

#[test]
fn effects_parse_and_print() {
    assert_eq!(Effects::parse("none").unwrap(), Effects::NONE);
    assert_eq!(Effects::parse("all").unwrap(), Effects::ALL);
    let e = Effects::parse(" doppler, searchlight ").unwrap();
    assert!(e.doppler && e.searchlight && !e.aberration && !e.unwarp);
    assert_eq!(e.to_string(), "doppler,searchlight");
    assert_eq!(Effects::parse(&e.to_string()).unwrap(), e);
    let err = Effects::parse("doppler,warp").unwrap_err().to_string();
    assert!(err.contains("'warp'"), "{err}");
    assert_eq!(Effects::default(), Effects::ALL);
}

// ---------------------------------------------------------------------------------------
// The command line, run as a user would in a temporary folder.

use std::path::{Path, PathBuf};

/// The cube scene on disk: mesh (OBJ), calibration (TOML) and a single-bounce world-time
/// cube (HDF5) of 32 x 24 pixels.
fn write_cube_scene(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let mesh = cube_scene_mesh();
    let mut obj = String::new();
    for p in &mesh.positions {
        obj.push_str(&format!("v {} {} {}\n", p.x, p.y, p.z));
    }
    for t in &mesh.triangles {
        obj.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
    }
    let mesh_path = dir.join("scene.obj");
    std::fs::write(&mesh_path, obj).unwrap();
    let cal = cube_scene_calibration(32, 24);
    let cal_path = dir.join("capture.toml");
    std::fs::write(&cal_path, cal.to_toml()).unwrap();
    let bvh = Bvh::new(mesh);
    let axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: 40.0,
        nt: 300,
    };
    let cube = world_cube(&cal, &bvh, axis, single_bounce_energy(&cal, 60.0));
    let cube_path = dir.join("world.h5");
    femto::container::write_cube(
        &cube_path,
        &cube,
        &femto::container::Provenance::new("tests/render.rs").with_note("laser_nm", "670"),
    )
    .unwrap();
    (cube_path, cal_path, mesh_path)
}

fn femto_render(
    dir: &Path,
    inputs: &(PathBuf, PathBuf, PathBuf),
    extra: &[&str],
) -> std::process::Output {
    let (cube, cal, mesh) = inputs;
    FemtoCmd::new()
        .current_dir(dir)
        .arg("render")
        .arg("--cube")
        .arg(cube)
        .arg("--calibration")
        .arg(cal)
        .arg("--mesh")
        .arg(mesh)
        .args(extra)
        .output()
}

fn assert_ok(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "femto render failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn cli_frame_ranges_reproduce_the_full_render_bit_for_bit() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let inputs = write_cube_scene(dir);
    let common = ["--dolly", "0.5", "--size", "32x24", "--frame-count", "6"];
    for format in ["exr", "png"] {
        let full = format!("full_{format}");
        let part = format!("part_{format}");
        let run = |out: &str, frames: Option<&str>| {
            let mut args: Vec<&str> = common.to_vec();
            args.extend(["--format", format, "--out", out]);
            if let Some(f) = frames {
                args.extend(["--frames", f]);
            }
            assert_ok(&femto_render(dir, &inputs, &args));
        };
        run(&full, None);
        run(&part, Some("0..2"));
        run(&part, Some("2..6"));
        let mut lit = 0;
        for k in 0..6 {
            let name = format!("frame_{k:05}.{format}");
            let a = std::fs::read(dir.join(&full).join(&name)).unwrap();
            let b = std::fs::read(dir.join(&part).join(&name)).unwrap();
            assert!(
                a == b,
                "{format} frame {k} differs between the full and the split render"
            );
            if format == "png" {
                let img = image::load_from_memory(&a).unwrap().to_rgb8();
                lit += img.pixels().filter(|p| p.0 != [0, 0, 0]).count();
            }
        }
        assert_eq!(std::fs::read_dir(dir.join(&full)).unwrap().count(), 6);
        if format == "exr" {
            exr_matches_the_library(&inputs, &dir.join(&full));
        }
        if format == "png" {
            assert!(lit > 0, "every frame is black");
        }
    }
}

/// The EXR frames of `--dolly 0.5 --size 32x24 --frame-count 6` hold exactly what the
/// library renders for the same inputs, read back from the files the command read.
fn exr_matches_the_library(inputs: &(PathBuf, PathBuf, PathBuf), frames: &Path) {
    use femto::render::paths::{shortcut_path, Shortcut};
    let (cube_path, cal_path, mesh_path) = inputs;
    let cube = femto::container::read_cube(cube_path).unwrap();
    let pyramid = Pyramid::build(&cube);
    let cal = Calibration::load(cal_path).unwrap();
    let bvh = Bvh::new(femto::geometry::load::load_mesh(mesh_path).unwrap());
    let scene = RenderScene::new(&bvh, cal, &pyramid, 670.0).unwrap();
    let s = shortcut_path(&scene, Shortcut::Dolly { beta: 0.5 }, 32, 24, 6, None).unwrap();
    let mut settings = RenderSettings::for_path(&s.path);
    settings.time_offset_ps = s.time_offset_ps;
    let mut lit = 0;
    for k in 0..6 {
        let expect = render(&scene, &settings, &s.path.frame(k));
        let file = frames.join(format!("frame_{k:05}.exr"));
        let image = exr::prelude::read_first_rgba_layer_from_file(
            &file,
            |size, _| vec![[0.0f32; 3]; size.0 * size.1],
            |buf: &mut Vec<[f32; 3]>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                buf[pos.1 * 32 + pos.0] = [r, g, b];
            },
        )
        .unwrap();
        let got = &image.layer_data.channel_data.pixels;
        assert!(
            got == &expect,
            "{}: differs from the library's frame {k}",
            file.display()
        );
        lit += expect.iter().filter(|p| p[0] > 0.0).count();
    }
    assert!(lit > 0);
}

#[test]
fn cli_writes_videos_and_every_view() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let inputs = write_cube_scene(dir);
    let base = ["--capture-view", "--size", "16x12", "--frame-count", "3"];
    let run = |extra: &[&str]| {
        let mut args: Vec<&str> = base.to_vec();
        args.extend_from_slice(extra);
        assert_ok(&femto_render(dir, &inputs, &args));
    };
    // (OpenH264 rejects frames under 16 pixels high.)
    assert_ok(&femto_render(
        dir,
        &inputs,
        &[
            "--capture-view",
            "--size",
            "32x24",
            "--frame-count",
            "3",
            "--out",
            "v.mp4",
        ],
    ));
    let mp4 = std::fs::read(dir.join("v.mp4")).unwrap();
    assert_eq!(&mp4[4..8], b"ftyp");
    run(&["--out", "v.gif"]);
    let gif = std::fs::read(dir.join("v.gif")).unwrap();
    assert_eq!(&gif[..6], b"GIF89a");
    for view in ["naive", "isochrones", "integrated"] {
        let out = format!("view_{view}");
        run(&["--view", view, "--out", &out, "--frames", "1..2"]);
        let png = std::fs::read(dir.join(&out).join("frame_00001.png")).unwrap();
        let img = image::load_from_memory(&png).unwrap().to_rgb8();
        let lit = img.pixels().filter(|p| p.0 != [0, 0, 0]).count();
        assert!(lit > 16 * 12 / 4, "{view}: {lit} lit pixels");
        assert!(!dir.join(&out).join("frame_00000.png").exists());
    }
    // An orbit renders too.
    let orbit = femto_render(
        dir,
        &inputs,
        &[
            "--orbit",
            "0.3",
            "--size",
            "16x12",
            "--frame-count",
            "2",
            "--out",
            "orbit",
        ],
    );
    assert_ok(&orbit);
    assert!(dir.join("orbit/frame_00001.png").exists());
}

#[test]
fn cli_errors_name_the_flag_and_leave_no_output() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let inputs = write_cube_scene(dir);
    // A camera-time cube.
    let (cube, cal, mesh) = &inputs;
    let mut camera_cube = femto::container::read_cube(cube).unwrap();
    camera_cube.frame = femto::cube::TimeFrame::Camera;
    let camera_path = dir.join("camera.h5");
    femto::container::write_cube(
        &camera_path,
        &camera_cube,
        &femto::container::Provenance::new("t"),
    )
    .unwrap();
    // A path through the back wall: 20 frames of 1 ns at beta 0.5 from just in front of it.
    let through = CameraPath::dolly(
        Point3::new(0.0, 0.5, -0.8),
        Point3::new(0.0, 0.5, -8.0),
        Vector3::y(),
        0.5,
        30.0,
        spec(16, 12, 20, 1000.0),
    )
    .unwrap();
    std::fs::write(dir.join("through.toml"), through.to_toml()).unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--dolly", "1.0", "--out", "o1"], "--dolly"),
        (vec!["--orbit", "-1.2", "--out", "o2"], "--orbit"),
        (
            vec!["--capture-view", "--size", "31x24", "--out", "o3.mp4"],
            "--size",
        ),
        (
            vec!["--capture-view", "--effects", "doppler,warp", "--out", "o4"],
            "--effects",
        ),
        (
            vec!["--capture-view", "--view", "sideways", "--out", "o5"],
            "--view",
        ),
        (
            vec![
                "--capture-view",
                "--frame-count",
                "6",
                "--frames",
                "4..9",
                "--out",
                "o6",
            ],
            "--frames",
        ),
        (vec!["--path", "through.toml", "--out", "o7"], "--path"),
        (
            vec!["--capture-view", "--size", "16by12", "--out", "o8"],
            "--size",
        ),
        (
            vec!["--capture-view", "--radiometry", "classic", "--out", "o9"],
            "--radiometry",
        ),
        (vec!["--capture-view", "--out", "o10.avi"], "--out"),
    ];
    for (args, flag) in cases {
        let out = femto_render(dir, &inputs, &args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(flag), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        let target = args.iter().skip_while(|a| **a != "--out").nth(1).unwrap();
        assert!(!dir.join(target).exists(), "{args:?} left {target}");
    }
    let out = femto_render(dir, &inputs, &["--path", "through.toml", "--out", "o7"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("passes through"));
    // Files: a camera-time cube, a missing mesh.
    let run = |cube: &Path, mesh: &Path| {
        FemtoCmd::new()
            .current_dir(dir)
            .args(["render", "--capture-view", "--out", "o11"])
            .arg("--cube")
            .arg(cube)
            .arg("--calibration")
            .arg(cal)
            .arg("--mesh")
            .arg(mesh)
            .output()
    };
    let out = run(&camera_path, mesh);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        err.contains("--cube") && err.contains("camera time"),
        "{err}"
    );
    let out = run(cube, &dir.join("missing.obj"));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        err.contains("--mesh") && err.contains("missing.obj"),
        "{err}"
    );
    assert!(!dir.join("o11").exists());
}

/// `femto render --size 16384x16384` under `ulimit -v 4000000` (about 4.1 GB of address
/// space; the machine may have far more RAM): the render needs about 17 GB, so it is refused
/// before it allocates, in one line that names --size, the need and the budget, exit 2, and
/// nothing is left in the folder (no staging folder). It used to abort on a 6.4 GB
/// allocation, its staging folder left behind, the check having compared with MemAvailable.
#[test]
fn a_render_beyond_the_address_space_limit_is_refused_before_it_allocates() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let (cube, cal, mesh) = write_cube_scene(dir);
    let out_dir = dir.join("out");
    std::fs::create_dir(&out_dir).unwrap();
    let out = std::process::Command::new("sh")
        .current_dir(&out_dir)
        .arg("-c")
        .arg("ulimit -v 4000000 && exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_femto"))
        .arg("render")
        .arg("--cube")
        .arg(&cube)
        .arg("--calibration")
        .arg(&cal)
        .arg("--mesh")
        .arg(&mesh)
        .args(["--capture-view", "--size", "16384x16384", "--out", "big"])
        .env_remove("FEMTO_MEMORY_LIMIT_BYTES")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("--size"), "{err}");
    assert!(
        err.contains("ulimit -v"),
        "names the limit that binds: {err}"
    );
    // Both figures: the need (about 17 GB) and the budget (under 4.1 GB).
    let figures: Vec<f64> = err
        .split(" GB")
        .filter_map(|before| before.rsplit(' ').next()?.parse().ok())
        .collect();
    assert_eq!(figures.len(), 2, "{err}");
    assert!(figures[0] > 16.0 && figures[1] < 4.1, "{err}");
    let left: Vec<_> = std::fs::read_dir(&out_dir).unwrap().collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn shortcut_paths_keep_the_target_in_the_centre_of_the_image() {
    use femto::render::paths::{scene_target, shortcut_path, Shortcut};
    let (bvh, cal, pyramid) = small_cube_world(None);
    let scene = RenderScene::new(&bvh, cal, &pyramid, 670.0).unwrap();
    let target = scene_target(&scene);
    // The capture camera's optical axis meets the mesh there.
    let d = cal.pose.forward();
    let along = (target - cal.pose.position_m).dot(&d);
    assert!(((target - cal.pose.position_m) - d * along).norm() < 1e-5);
    let (w, h, frames) = (21usize, 15usize, 30usize);
    for (shortcut, beta) in [
        (Shortcut::Dolly { beta: 0.7 }, 0.7),
        (Shortcut::Dolly { beta: -0.5 }, -0.5),
        (Shortcut::Orbit { beta: 0.8 }, 0.8),
        (Shortcut::Orbit { beta: -0.6 }, -0.6),
        (Shortcut::CaptureView, 0.0),
    ] {
        let s = shortcut_path(&scene, shortcut, w, h, frames, None).unwrap();
        let settings = RenderSettings::for_path(&s.path);
        let g = gamma(beta);
        let d_expect = match shortcut {
            Shortcut::Dolly { .. } => g * (1.0 - beta),
            Shortcut::Orbit { .. } => 1.0 / g,
            Shortcut::CaptureView => 1.0,
        };
        // (The frame interval and time offset: shortcut_times_follow_the_light_they_look_at.)
        let r0 = (target - cal.pose.position_m).norm();
        for k in [0, frames / 2, frames - 1] {
            let state = s.path.frame(k);
            assert!(
                (state.beta.norm() - beta.abs()).abs() < 1e-6,
                "{shortcut:?} frame {k}"
            );
            let c = probe_pixel(&scene, &settings, &state, w / 2, h / 2);
            let (p, _) = c.hit_m.unwrap();
            assert!(
                (p - target).norm() < 2e-3,
                "{shortcut:?} frame {k}: sees {p:?}, target {target:?}"
            );
            assert!(
                (c.doppler / d_expect - 1.0).abs() < 1e-3,
                "{shortcut:?}: D {}",
                c.doppler
            );
            if let Shortcut::Orbit { .. } = shortcut {
                // On the circle: constant distance to the target, velocity perpendicular.
                let rel = state.position_m - target;
                assert!((rel.norm() - r0).abs() < 1e-6);
                assert!(state.beta.dot(&rel).abs() < 1e-6);
                assert!(
                    ((state.t_world_ps - g * state.tau_ps) / (1.0 + state.t_world_ps)).abs() < 1e-6
                );
            }
        }
        if shortcut == Shortcut::CaptureView {
            let f = s.path.frame(0);
            assert_eq!(f.position_m, cal.pose.position_m);
        }
    }
}

#[test]
fn capture_visibility_agrees_with_a_ray_cast_from_the_capture_camera() {
    let bvh = Bvh::new(cube_scene_mesh());
    let (cw, ch) = (64usize, 48usize);
    let cal = cube_scene_calibration(cw, ch);
    let cube = constant_cube(&cal, &bvh, 1.0);
    let pyramid = Pyramid::build(&cube);
    let scene = RenderScene::new(&bvh, cal, &pyramid, 670.0).unwrap();
    // A viewpoint to the left of and above the capture camera: parts of the floor behind the
    // box and the box's left side are hidden from the capture camera.
    let pose = Pose::look_at(
        Point3::new(-1.1, 1.0, 1.4),
        Point3::new(0.0, 0.2, -0.2),
        Vector3::y(),
    )
    .unwrap();
    let (w, h) = (96usize, 72usize);
    let path = CameraPath::static_view(&pose, 45.0, spec(w, h, 1, 1.0)).unwrap();
    let settings = RenderSettings::for_path(&path);
    let state = path.frame(0);
    let o = cal.pose.position_m;
    let (mut hits, mut hidden, mut disagree) = (0, 0, 0);
    for j in 0..h {
        for i in 0..w {
            let s = probe_pixel(&scene, &settings, &state, i, j);
            let Some((p, _)) = s.hit_m else { continue };
            hits += 1;
            // Brute force: does the capture camera's ray towards p stop at p, and does p
            // project into the capture image?
            let to_p = p - o;
            let dist = to_p.norm();
            let dir = to_p / dist;
            let ray = femto::geometry::Ray::new(
                Point3::new(o.x as f32, o.y as f32, o.z as f32),
                Vector3::new(dir.x as f32, dir.y as f32, dir.z as f32),
            );
            let first = bvh.intersect(&ray, 0.0, f32::INFINITY).map(|h| h.t as f64);
            let inside = cal
                .project(&p)
                .is_some_and(|(u, v)| u >= 0.0 && v >= 0.0 && u < cw as f64 && v < ch as f64);
            let seen = inside && first.is_some_and(|t| (t - dist).abs() < 1e-4 * dist + 1e-5);
            if !seen {
                hidden += 1;
            }
            if seen != s.capture_pixel.is_some() {
                disagree += 1;
            }
        }
    }
    assert!(
        hidden > hits / 20,
        "the test view hides too little: {hidden} of {hits}"
    );
    assert!(
        (disagree as f64) < 0.02 * hits as f64,
        "{disagree} of {hits} pixels disagree ({hidden} hidden)"
    );
}

#[test]
fn emitted_energy_equals_the_pyramid_integral_at_cube_times() {
    use rand::{Rng, SeedableRng};
    let wall = Bvh::new(wall_z0(10.0));
    let mut cal = calibration(8, 6, 40.0, Point3::new(0.0, 0.0, 2.0), Point3::origin());
    cal.t0_ps = 137.5;
    cal.time_scale = 1.03;
    let axis = TimeAxis {
        t0_ps: -20.0,
        dt_ps: 2.5,
        nt: 40,
    };
    let cube = world_cube(&cal, &wall, axis, |p, _, a, b| {
        (1.0 + p.x * p.x) * ((0.01 * b).sin() - (0.01 * a).sin()).abs() + 0.1 * (b - a)
    });
    let pyramid = Pyramid::build(&cube);
    let scene = RenderScene::new(&wall, cal, &pyramid, 670.0).unwrap();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    for _ in 0..2000 {
        let (x, y) = (rng.random_range(0..8), rng.random_range(0..6));
        // World times from well before to well after the axis (cube -20 .. 80 ps).
        let ta = rng.random_range(-250.0..0.0);
        let tb = ta + rng.random_range(0.0..120.0);
        let got = scene.emitted_energy(x, y, ta, tb);
        let cube_t = |t: f64| cal.t0_ps + cal.time_scale * t;
        let expect = pyramid.integral(x, y, cube_t(ta), cube_t(tb));
        assert!(
            (got - expect).abs() <= 1e-12 * expect.abs().max(1.0),
            "({x}, {y}) [{ta}, {tb}]: {got} vs {expect}"
        );
    }
}

/// Reads the EXR frames `frame_00000.exr ..` of `dir` (width 32).
fn read_exr_frames(dir: &Path, n: usize) -> Vec<Vec<[f32; 3]>> {
    (0..n)
        .map(|k| {
            let file = dir.join(format!("frame_{k:05}.exr"));
            exr::prelude::read_first_rgba_layer_from_file(
                &file,
                |size, _| vec![[0.0f32; 3]; size.0 * size.1],
                |buf: &mut Vec<[f32; 3]>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                    buf[pos.1 * 32 + pos.0] = [r, g, b];
                },
            )
            .unwrap()
            .layer_data
            .channel_data
            .pixels
        })
        .collect()
}

fn femto_pyramid(dir: &Path, args: &[&std::ffi::OsStr]) {
    let out = FemtoCmd::new()
        .current_dir(dir)
        .arg("pyramid")
        .args(args)
        .output();
    assert_ok(&out);
}

/// The renderer reads the pyramid that `femto pyramid` stored (in the cube file or a side
/// file given with `--pyramid`) instead of rebuilding it, and says so when it has to build.
/// A side file built from the same cube with every value doubled gives frames of exactly
/// twice the values (scaling by 2 is exact in every step, down to the subnormal f32 output
/// values, which are rounded to a fixed step), which shows that the stored prefix sums are the
/// ones used; a side file of another time axis is refused.
#[test]
fn cli_reads_the_stored_pyramid() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let inputs = write_cube_scene(dir);
    let (cube_path, cal, mesh) = inputs.clone();
    let args = [
        "--dolly",
        "0.5",
        "--size",
        "32x24",
        "--frame-count",
        "3",
        "--format",
        "exr",
    ];
    let run = |inputs: &(PathBuf, PathBuf, PathBuf), extra: &[&str]| {
        let mut a: Vec<&str> = args.to_vec();
        a.extend_from_slice(extra);
        let out = femto_render(dir, inputs, &a);
        assert_ok(&out);
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    // No stored pyramid: built in memory, with a note.
    let err = run(&inputs, &["--out", "built"]);
    assert!(err.contains("no stored pyramid"), "{err}");
    let built = read_exr_frames(&dir.join("built"), 3);
    assert!(built.iter().flatten().any(|p| p[0] > 0.0), "black frames");
    // Stored in the cube's own file: the same frames, bit for bit, and no note.
    let stored = dir.join("stored.h5");
    std::fs::copy(&cube_path, &stored).unwrap();
    femto_pyramid(dir, &[stored.as_os_str()]);
    let stored_inputs = (stored.clone(), cal.clone(), mesh.clone());
    let err = run(&stored_inputs, &["--out", "stored"]);
    assert!(!err.contains("no stored pyramid"), "{err}");
    assert!(read_exr_frames(&dir.join("stored"), 3) == built);
    // A side file built from the doubled cube: every value exactly doubled.
    let mut doubled = femto::container::read_cube(&cube_path).unwrap();
    doubled.data.iter_mut().for_each(|v| *v *= 2.0);
    let doubled_path = dir.join("doubled.h5");
    femto::container::write_cube(
        &doubled_path,
        &doubled,
        &femto::container::Provenance::new("t"),
    )
    .unwrap();
    let side = dir.join("side.h5");
    femto_pyramid(
        dir,
        &[
            doubled_path.as_os_str(),
            "--side-file".as_ref(),
            side.as_os_str(),
        ],
    );
    let side_arg = side.to_str().unwrap();
    let err = run(&inputs, &["--pyramid", side_arg, "--out", "side"]);
    assert!(!err.contains("no stored pyramid"), "{err}");
    let twice = read_exr_frames(&dir.join("side"), 3);
    for (a, b) in twice.iter().flatten().zip(built.iter().flatten()) {
        for (&a, &b) in a.iter().zip(b) {
            if b.abs() >= f32::MIN_POSITIVE {
                assert_eq!(a, 2.0 * b);
            } else {
                // Subnormal f32 b: each rounding is off by up to half a step of 1.4e-45.
                assert!((a - 2.0 * b).abs() <= 3e-45, "{a} vs 2 x {b}");
            }
        }
    }
    // A side file of another cube (other time axis) is refused, naming the flag.
    let mut other = doubled;
    other.axis.dt_ps *= 2.0;
    let other_path = dir.join("other.h5");
    femto::container::write_cube(&other_path, &other, &femto::container::Provenance::new("t"))
        .unwrap();
    let other_side = dir.join("other_side.h5");
    femto_pyramid(
        dir,
        &[
            other_path.as_os_str(),
            "--side-file".as_ref(),
            other_side.as_os_str(),
        ],
    );
    let mut a: Vec<&str> = args.to_vec();
    a.extend([
        "--pyramid",
        other_side.to_str().unwrap(),
        "--out",
        "refused",
    ]);
    let out = femto_render(dir, &inputs, &a);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--pyramid") && err.contains("rebuild"),
        "{err}"
    );
    assert!(!dir.join("refused").exists());
}

/// Frames rendered with the rays of the frame before (a dolly keeps its orientation and
/// velocity; an orbit and a rotating sensor do not), and with its hits too where the camera
/// has not moved, are the frames `render_frame` makes, bit for bit, whatever the order in
/// which frames and settings come.
#[test]
fn reused_rays_give_the_same_frames_bit_for_bit() {
    use femto::render::paths::{shortcut_path, Shortcut};
    use femto::render::{render_frame_reusing_rays, FrameRays};
    let (bvh, cal, pyramid) = small_cube_world(None);
    let scene = RenderScene::new(&bvh, cal, &pyramid, 670.0).unwrap();
    let (w, h, frames) = (24usize, 18usize, 8usize);
    let mut rays = FrameRays::default();
    let mut lit = 0;
    for shortcut in [
        Shortcut::Dolly { beta: 0.6 },
        Shortcut::Orbit { beta: 0.5 },
        Shortcut::Dolly { beta: -0.4 },
    ] {
        let s = shortcut_path(&scene, shortcut, w, h, frames, None).unwrap();
        let mut all = RenderSettings::for_path(&s.path);
        all.time_offset_ps = s.time_offset_ps;
        let no_aberration = RenderSettings {
            effects: Effects::parse("unwarp,doppler,searchlight,dilation").unwrap(),
            ..all
        };
        for k in [0, 1, 2, 5, 5, 7, 3] {
            let state = s.path.frame(k);
            for settings in [&all, &no_aberration] {
                let want = render(&scene, settings, &state);
                let mut got = vec![[f32::NAN; 3]; w * h];
                render_frame_reusing_rays(&scene, settings, &state, &mut rays, &mut got);
                assert!(got == want, "{shortcut:?} frame {k}");
                lit += want.iter().filter(|p| p[0] > 0.0).count();
            }
        }
    }
    assert!(lit > 0, "every frame is black");
    // A camera that stays where it is while its time moves (femto view's Play at rest):
    // rays and hits kept from the frame before, frames those of render_frame; then a step
    // aside, which casts again.
    let s = shortcut_path(&scene, Shortcut::Dolly { beta: 0.6 }, w, h, frames, None).unwrap();
    let mut all = RenderSettings::for_path(&s.path);
    all.time_offset_ps = s.time_offset_ps;
    let mut lit_at_rest = 0;
    for (steps, aside_m) in [(0.0, 0.0), (1.0, 0.0), (3.0, 0.0), (1.0, 0.0), (1.0, 0.05)] {
        let mut state = s.path.frame(4);
        state.t_world_ps += steps * s.path.spec().dtau_ps;
        state.tau_ps += steps * s.path.spec().dtau_ps;
        state.position_m.x += aside_m;
        let want = render(&scene, &all, &state);
        let mut got = vec![[f32::NAN; 3]; w * h];
        render_frame_reusing_rays(&scene, &all, &state, &mut rays, &mut got);
        assert!(
            got == want,
            "at rest, {steps} frames later, {aside_m} m aside"
        );
        lit_at_rest += want.iter().filter(|p| p[0] > 0.0).count();
    }
    assert!(lit_at_rest > 0, "every frame at rest is black");
    // A rotating sensor: a boost per pixel, rendered as render_frame does.
    let dolly = shortcut_path(&scene, Shortcut::Dolly { beta: 0.3 }, w, h, frames, None).unwrap();
    let path = with_rotation(&dolly.path, RotationAxis::Roll, 0.5);
    let settings = RenderSettings::for_path(&path);
    for k in [0, 1] {
        let state = path.frame(k);
        let mut got = vec![[f32::NAN; 3]; w * h];
        render_frame_reusing_rays(&scene, &settings, &state, &mut rays, &mut got);
        assert!(
            got == render(&scene, &settings, &state),
            "rotating frame {k}"
        );
    }
}

/// The dark marks drawn from the rays and hits a frame was rendered with
/// (`render_sequence_reusing` hands them to its sink, and `femto view` draws them so) are those drawn with a
/// probe's own ray per block (`femto render --dark-marks`), byte for byte: with a masked
/// strip of the capture, from the capture view, a step aside (unseen points), a turn that
/// looks past the mesh (no surface), and frames whose rays were not kept (a rotating sensor).
#[test]
fn dark_marks_from_the_kept_rays_are_those_of_the_probes() {
    use femto::render::dark::{draw_dark_marks, MASKED_RGB, UNSEEN_RGB};
    use femto::render::paths::{shortcut_path, Shortcut};
    use femto::render::{encode_srgb8, render_frame_reusing_rays, FrameRays};
    // Columns 10-17 masked as mixed.
    let mask = (0..40 * 30).map(|p| u8::from(!(10..18).contains(&(p % 40))));
    let (bvh, cal, pyramid) = small_cube_world(Some(mask.collect()));
    let scene = RenderScene::new(&bvh, cal, &pyramid, 670.0).unwrap();
    let (w, h) = (64usize, 48usize);
    let s = shortcut_path(&scene, Shortcut::Dolly { beta: 0.0 }, w, h, 4, None).unwrap();
    let mut rays = FrameRays::default();
    let mut kinds_seen = [0usize; 2];
    for (aside_m, turn_rad, rotating) in [
        (0.0, 0.0, false),
        (0.0, 0.0, false),
        (0.3, 0.0, false),
        (0.0, 0.6, false),
        (0.0, 0.0, true),
    ] {
        let path = if rotating {
            with_rotation(&s.path, RotationAxis::Roll, 0.5)
        } else {
            s.path.clone()
        };
        let mut settings = RenderSettings::for_path(&path);
        settings.time_offset_ps = s.time_offset_ps;
        let mut state = path.frame(1);
        state.position_m.x += aside_m;
        state.world_from_camera =
            Rotation3::from_axis_angle(&Vector3::y_axis(), turn_rad) * state.world_from_camera;
        let mut pixels = vec![[0.0f32; 3]; w * h];
        render_frame_reusing_rays(&scene, &settings, &state, &mut rays, &mut pixels);
        let mut want = vec![0u8; 3 * pixels.len()];
        encode_srgb8(&settings, &pixels, &mut want);
        let mut got = want.clone();
        draw_dark_marks(&scene, &settings, &state, None, &mut want);
        draw_dark_marks(&scene, &settings, &state, Some(&rays), &mut got);
        assert!(
            got == want,
            "aside {aside_m} m, turned {turn_rad} rad, rotating {rotating}"
        );
        for px in want.chunks_exact(3) {
            kinds_seen[0] += usize::from(UNSEEN_RGB.contains(&[px[0], px[1], px[2]]));
            kinds_seen[1] += usize::from(MASKED_RGB.contains(&[px[0], px[1], px[2]]));
        }
    }
    assert!(
        kinds_seen.iter().all(|&n| n > 50),
        "unseen and masked marks: {kinds_seen:?}"
    );
}

/// `render_frame`'s row pipeline (rays four at a time, the batch ray caster, the transient
/// view's vector projection and its lookups) writes, for every pixel, the colour that
/// `probe_pixel` (the whole pipeline of one pixel, step by step) computes, bit for bit: for
/// dollies, an orbit and a rotating sensor, with every effect, with none and with each one
/// off, both radiometries, the naive and integrated views, a capture camera with lens
/// distortion, and frames whose width is not a multiple of four.
#[test]
fn the_row_pipeline_renders_each_pixel_as_probe_pixel_does() {
    use femto::render::paths::{shortcut_path, Shortcut};
    let bvh = Bvh::new(cube_scene_mesh());
    let axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: 20.0,
        nt: 600,
    };
    let mut distorted = cube_scene_calibration(40, 30);
    distorted.intrinsics.k1 = -0.12;
    distorted.intrinsics.k2 = 0.03;
    let mut lit = 0;
    let mut pixels = 0;
    for cal in [cube_scene_calibration(40, 30), distorted] {
        let cube = world_cube(&cal, &bvh, axis, single_bounce_energy(&cal, 30.0));
        let pyramid = Pyramid::build(&cube);
        let scene = RenderScene::new(&bvh, cal, &pyramid, 532.0).unwrap();
        let (w, h, frames) = (27usize, 19usize, 6usize);
        let mut paths: Vec<(String, CameraPath, f64)> = [
            Shortcut::Dolly { beta: 0.6 },
            Shortcut::Orbit { beta: 0.5 },
            Shortcut::Dolly { beta: -0.4 },
        ]
        .into_iter()
        .map(|sc| {
            let s = shortcut_path(&scene, sc, w, h, frames, None).unwrap();
            (format!("{sc:?}"), s.path, s.time_offset_ps)
        })
        .collect();
        let rotating = with_rotation(&paths[0].1, RotationAxis::Yaw, 0.4);
        paths.push(("rotating".into(), rotating, paths[0].2));
        for (name, path, offset) in &paths {
            let mut all = RenderSettings::for_path(path);
            all.time_offset_ps = *offset;
            let mut variants = vec![
                all,
                RenderSettings {
                    radiometry: Radiometry::Paper,
                    ..all
                },
                RenderSettings {
                    view: View::Naive,
                    ..all
                },
                RenderSettings {
                    view: View::Integrated,
                    ..all
                },
                RenderSettings {
                    colour: ColourOutput::Xyz,
                    ..all
                },
            ];
            for effects in [
                "none",
                "aberration,doppler,searchlight,dilation,rotation",
                "unwarp,doppler,searchlight,dilation,rotation",
                "unwarp,aberration,searchlight,dilation,rotation",
                "unwarp,aberration,doppler,dilation,rotation",
                "unwarp,aberration,doppler,searchlight,rotation",
            ] {
                variants.push(RenderSettings {
                    effects: Effects::parse(effects).unwrap(),
                    ..all
                });
            }
            for k in [0, 2, frames - 1] {
                let state = path.frame(k);
                for settings in &variants {
                    let got = render(&scene, settings, &state);
                    for (n, px) in got.iter().enumerate() {
                        let (i, j) = (n % w, n / w);
                        let want = probe_pixel(&scene, settings, &state, i, j)
                            .rgb
                            .map(|c| c as f32);
                        assert!(
                            px.map(f32::to_bits) == want.map(f32::to_bits),
                            "{name} frame {k}, {} {} {:?}, pixel ({i}, {j}): {px:?}, probe_pixel {want:?}",
                            settings.view.name(),
                            settings.effects,
                            settings.radiometry,
                        );
                        lit += usize::from(px[1] > 0.0);
                    }
                    pixels += got.len();
                }
            }
        }
    }
    // The comparison is not of black frames.
    assert!(lit * 10 > pixels, "{lit} of {pixels} pixels lit");
}

// ---------------------------------------------------------------------------------------
// Black frames: the shortcuts' times against where the cube holds light (issue 15).

/// The cube scene seen by a 32 x 24 capture camera, with two world cubes whose light fills
/// a small part of their axes: (1) an undarkened streak capture (a dark pedestal plus
/// single-bounce light) recorded during the camera times 11..15 ns and unwarped onto the
/// covering axis (each pixel empty over most of it); (2) single-bounce light followed by a
/// 1.5 ns tail of indirect light holding 30 % of its energy, on an axis that starts 20 ns
/// before the pulse and ends 40 ns after it.
fn sparse_light_cubes() -> (Bvh, Calibration, Vec<(&'static str, Pyramid)>) {
    let bvh = Bvh::new(cube_scene_mesh());
    let cal = cube_scene_calibration(32, 24);
    let direct = single_bounce_energy(&cal, 60.0);
    let windowed = windowed_world_cube(&cal, &bvh, 40.0, (11_000.0, 15_000.0), 2e-5, &direct);
    let padded_axis = TimeAxis {
        t0_ps: cal.t0_ps - 20_000.0,
        dt_ps: 40.0,
        nt: 1500,
    };
    let with_tail = single_bounce_with_tail_energy(&cal, 60.0, 0.3, 1500.0);
    let padded = world_cube(&cal, &bvh, padded_axis, &with_tail);
    let cubes = vec![
        ("recording window", Pyramid::build(&windowed)),
        ("padded axis", Pyramid::build(&padded)),
    ];
    (bvh, cal, cubes)
}

const SHORTCUTS: [femto::render::paths::Shortcut; 6] = {
    use femto::render::paths::Shortcut;
    [
        Shortcut::Dolly { beta: 0.5 },
        Shortcut::Dolly { beta: -0.5 },
        Shortcut::Dolly { beta: 0.9 },
        Shortcut::Orbit { beta: 0.5 },
        Shortcut::Orbit { beta: -0.8 },
        Shortcut::CaptureView,
    ]
};

#[test]
fn shortcuts_with_default_times_render_no_black_frame() {
    use femto::render::coverage::frame_is_black;
    use femto::render::paths::shortcut_path;
    use femto::render::{auto_exposure, encode_srgb8};
    let (bvh, cal, cubes) = sparse_light_cubes();
    let (w, h, frames) = (32usize, 24usize, 24usize);
    let mut failures = Vec::new();
    for (name, pyramid) in &cubes {
        let scene = RenderScene::new(&bvh, cal, pyramid, 670.0).unwrap();
        for shortcut in SHORTCUTS {
            let s = match shortcut_path(&scene, shortcut, w, h, frames, None) {
                Ok(s) => s,
                Err(e) => {
                    failures.push(format!("{name}, {shortcut:?}: {e}"));
                    continue;
                }
            };
            let mut settings = RenderSettings::for_path(&s.path);
            settings.time_offset_ps = s.time_offset_ps;
            settings.exposure = auto_exposure(&scene, &settings.view);
            let mut black = Vec::new();
            let mut srgb = vec![0u8; 3 * w * h];
            render_sequence::<RenderError>(&scene, &settings, &s.path, 0..frames, |k, px| {
                encode_srgb8(&settings, px, &mut srgb);
                if frame_is_black(px) || srgb.iter().all(|&b| b == 0) {
                    black.push(k);
                }
                Ok(())
            })
            .unwrap();
            if !black.is_empty() {
                failures.push(format!(
                    "{name}, {shortcut:?}: black frames {black:?} of {frames}"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn shortcut_times_follow_the_light_they_look_at() {
    use femto::render::paths::{scene_target, shortcut_path, Shortcut, DOLLY_MAX_APPROACH};
    let (bvh, cal, cubes) = sparse_light_cubes();
    let (w, h, frames) = (cal.intrinsics.width, cal.intrinsics.height, 20usize);
    // The capture view's frames tile the light as the capture camera received it: the
    // camera times at which the signal summed over the capture pixels exceeds 1 % of its
    // peak, computed here from the fixtures' own light (not from the cube), in 10 ps bins.
    let hits = capture_hits(&cal, &bvh);
    let o = cal.pose.position_m;
    let direct = single_bounce_energy(&cal, 60.0);
    let with_tail = single_bounce_with_tail_energy(&cal, 60.0, 0.3, 1500.0);
    let window = (11_000.0, 15_000.0);
    let received = |cube: &str, t_ps: f64, dt_ps: f64| -> f64 {
        hits.iter()
            .flatten()
            .map(|(p, n)| {
                let r_ps = (p - o).norm() / C_M_PER_PS;
                let (a, b) = (t_ps - r_ps, t_ps + dt_ps - r_ps);
                match cube {
                    "recording window" => {
                        let (lo, hi) = (a.max(window.0 - r_ps), b.min(window.1 - r_ps));
                        if lo < hi {
                            direct(p, n, lo, hi) + 2e-5 * (hi - lo)
                        } else {
                            0.0
                        }
                    }
                    _ => with_tail(p, n, a, b),
                }
            })
            .sum()
    };
    for (name, pyramid) in &cubes {
        let scene = RenderScene::new(&bvh, cal, pyramid, 670.0).unwrap();
        let bins: Vec<(f64, f64)> = (0..4000)
            .map(|i| {
                let t = 5_000.0 + 10.0 * i as f64;
                (t, received(name, t, 10.0))
            })
            .collect();
        let peak = bins.iter().map(|b| b.1).fold(0.0, f64::max);
        let lit: Vec<f64> = bins
            .iter()
            .filter(|b| b.1 > 0.01 * peak)
            .map(|b| b.0)
            .collect();
        let (first, last) = (lit[0], lit[lit.len() - 1] + 10.0);
        let s = shortcut_path(&scene, Shortcut::CaptureView, w, h, frames, None).unwrap();
        let dtau = s.path.spec().dtau_ps;
        // Within a cube bin (40 ps) and the 10 ps bins here.
        assert!(
            (s.time_offset_ps - first).abs() <= 50.0,
            "{name}: starts at {} ps, light at {first} ps",
            s.time_offset_ps
        );
        let end = s.time_offset_ps + frames as f64 * dtau;
        assert!(
            (end - last).abs() <= 50.0,
            "{name}: ends at {end} ps, light until {last} ps"
        );
        if *name == "recording window" {
            // The light fills the recording window.
            assert!((first - window.0).abs() <= 50.0 && (last - window.1).abs() <= 50.0);
        }
    }
    // A dolly towards the target whose light lasts longer than the camera needs to reach it
    // stops a quarter of the way short (the old rule refused: "the camera covers 71.9 m").
    let constant = constant_cube(&cal, &bvh, 1.0);
    let pyramid = Pyramid::build(&constant);
    let scene = RenderScene::new(&bvh, cal, &pyramid, 670.0).unwrap();
    let target = scene_target(&scene);
    let r0 = (target - cal.pose.position_m).norm();
    for beta in [0.3, 0.9] {
        let s = shortcut_path(&scene, Shortcut::Dolly { beta }, w, h, frames, None).unwrap();
        let left = (s.path.frame(frames - 1).position_m - target).norm();
        assert!(
            (left - (1.0 - DOLLY_MAX_APPROACH) * r0).abs() < 1e-6 * r0,
            "beta {beta}: {left} m left of {r0} m"
        );
        check_path_clear(&bvh, &s.path).unwrap();
    }
}

#[test]
fn coverage_flags_frames_whose_times_miss_the_light() {
    use femto::render::coverage::{frame_is_black, predict_coverage, FrameLight};
    use femto::render::paths::{shortcut_path, Shortcut};
    let (bvh, cal, cubes) = sparse_light_cubes();
    let (w, h, frames) = (32usize, 24usize, 12usize);
    let rendered_black = |scene: &RenderScene, settings: &RenderSettings, path: &CameraPath| {
        let mut black = Vec::new();
        render_sequence::<RenderError>(scene, settings, path, 0..frames, |k, px| {
            if frame_is_black(px) {
                black.push(k);
            }
            Ok(())
        })
        .unwrap();
        black
    };
    for (name, pyramid) in &cubes {
        let scene = RenderScene::new(&bvh, cal, pyramid, 670.0).unwrap();
        // Direct light reaches the points the capture camera sees at |laser - p| / c, the
        // tail follows it: the padded cube's light lies after the first of those times,
        // less the pulse's width (the other cube's dark pedestal comes before).
        let hits = capture_hits(&cal, &bvh);
        let first_light = hits
            .iter()
            .flatten()
            .map(|(p, _)| (cal.laser_m - p).norm() / C_M_PER_PS)
            .fold(f64::INFINITY, f64::min);
        for shortcut in [Shortcut::CaptureView, Shortcut::Dolly { beta: 0.6 }] {
            let s = shortcut_path(&scene, shortcut, w, h, frames, None).unwrap();
            let mut settings = RenderSettings::for_path(&s.path);
            let at = |offset_ps: f64| RenderSettings {
                time_offset_ps: offset_ps,
                ..settings
            };
            // The shortcut's own times: every frame lit, nothing to say.
            settings.time_offset_ps = s.time_offset_ps;
            let hit = predict_coverage(&scene, &settings, &s.path, 0..frames).unwrap();
            let light = hit.light_ps.unwrap();
            if *name == "padded axis" {
                assert!(light.start_ps >= first_light - 4.0 * 60.0, "{light:?}");
            }
            assert_eq!(hit.black_count(), 0, "{name}, {shortcut:?}: {hit}");
            assert_eq!(hit.to_string(), "");
            assert!(rendered_black(&scene, &settings, &s.path).is_empty());
            // 40 ns early (the default offset of a path file is 0): every frame sees times
            // before the light, and the suggested offset shows it again.
            let early = at(s.time_offset_ps - 40_000.0);
            let miss = predict_coverage(&scene, &early, &s.path, 0..frames).unwrap();
            assert_eq!(
                miss.runs(FrameLight::Before),
                vec![0..frames],
                "{name}: {miss}"
            );
            let (_, seen_end) = miss.seen_ps(FrameLight::Before).unwrap();
            assert!(seen_end <= light.start_ps);
            let text = miss.to_string();
            assert!(
                text.starts_with(&format!("frames 0..{frames} of {frames} see world times "))
                    && text.contains("before the cube's light"),
                "{text}"
            );
            // The warning states its threshold and where the cube's last non-zero bin ends,
            // which the threshold's span leaves out when weak light follows the pulse.
            let last = miss.last_signal_ps.unwrap();
            assert!(
                text.contains(&format!(
                    "(light above 1 % of the peak of the signal summed over the image lies in \
                     {:.0}..{:.0} ps; the cube's last non-zero bin ends at {last:.0} ps)",
                    light.start_ps, light.end_ps
                )),
                "{text}"
            );
            assert!(last >= light.end_ps, "{last} {light:?}");
            if *name == "padded axis" {
                // The tail decays over 1500 ps and is still non-zero at the axis' end.
                let (_, axis_end_ps) = scene.world_span_ps();
                assert!(last >= light.end_ps + 10_000.0, "{last} {light:?}");
                assert!((last - axis_end_ps).abs() < 1e-6, "{last} {axis_end_ps}");
            }
            assert_eq!(
                rendered_black(&scene, &early, &s.path),
                (0..frames).collect::<Vec<_>>()
            );
            let suggested = miss.suggested_time_offset_ps().unwrap();
            let again = predict_coverage(&scene, &at(suggested), &s.path, 0..frames).unwrap();
            assert!(again.runs(FrameLight::Before).is_empty(), "{name}: {again}");
            assert!(again.frames[0].light == FrameLight::Lit, "{name}: {again}");
            // 60 ns late (past the axis): every frame after the light.
            let late = at(s.time_offset_ps + 60_000.0);
            let miss = predict_coverage(&scene, &late, &s.path, 0..frames).unwrap();
            assert_eq!(
                miss.runs(FrameLight::After),
                vec![0..frames],
                "{name}: {miss}"
            );
            assert!(miss.to_string().contains("after the cube's light"));
            assert_eq!(rendered_black(&scene, &late, &s.path).len(), frames);
        }
        if *name == "recording window" {
            // 2 ns early: inside the cube's light in world time, but each pixel shows a time
            // outside its own recording window (the black frames of issue 15): dark.
            let s = shortcut_path(&scene, Shortcut::CaptureView, w, h, frames, None).unwrap();
            let mut settings = RenderSettings::for_path(&s.path);
            settings.time_offset_ps =
                s.time_offset_ps - 2_000.0 - frames as f64 * s.path.spec().dtau_ps;
            let cov = predict_coverage(&scene, &settings, &s.path, 0..frames).unwrap();
            let black = rendered_black(&scene, &settings, &s.path);
            assert_eq!(black.len(), frames);
            assert_eq!(cov.runs(FrameLight::Dark), vec![0..frames], "{cov}");
            assert!(cov
                .to_string()
                .contains("where their cube pixels hold no light"));
        }
    }
}

/// The tone-mapped display luminance (0..1) of a scene-linear pixel at `exposure`.
fn display_lum(px: [f32; 3], exposure: f64) -> f64 {
    color::luminance(color::tone_map(
        [px[0] as f64, px[1] as f64, px[2] as f64],
        exposure,
    ))
}

#[test]
fn auto_exposure_shows_the_weak_late_tail_and_keeps_the_direct_pulse_below_white() {
    use femto::pyramid::PrefixRead;
    use femto::render::paths::{shortcut_path, Shortcut};
    use femto::render::{auto_exposure, exposure_for};
    // The padded cube: a direct pulse (sigma 60 ps) and a tail holding 0.3 of it, decaying
    // over 1500 ps, so that each bin of the tail is about 30 times weaker than the pulse's.
    let (bvh, cal, cubes) = sparse_light_cubes();
    let pyramid = &cubes[1].1;
    let scene = RenderScene::new(&bvh, cal, pyramid, 670.0).unwrap();
    let (w, h) = (32usize, 24usize);
    let s = shortcut_path(&scene, Shortcut::CaptureView, w, h, 1, Some(40.0)).unwrap();
    let settings = RenderSettings::for_path(&s.path);
    let exposure = auto_exposure(&scene, &settings.view);
    // The old exposure: the 99.9th percentile of every positive bin at luminance 1.
    let nt = pyramid.axis.nt;
    let old = exposure_for(
        (0..pyramid.nx * pyramid.ny * nt)
            .map(|b| pyramid.prefix.pixel(b / nt).bin(b % nt) / pyramid.axis.dt_ps)
            .collect(),
    )
    .unwrap();
    let frame_at = |offset_ps: f64| {
        let at = RenderSettings {
            time_offset_ps: offset_ps,
            ..settings
        };
        render(&scene, &at, &s.path.frame(0))
    };
    let hits = capture_hits(&cal, &bvh);
    let seen: Vec<usize> = (0..w * h).filter(|&i| hits[i].is_some()).collect();
    let mean_display = |px: &[[f32; 3]], e: f64| {
        seen.iter().map(|&i| display_lum(px[i], e)).sum::<f64>() / seen.len() as f64
    };
    let white = |px: &[[f32; 3]], e: f64| {
        let n = seen
            .iter()
            .filter(|&&i| {
                let c = color::tone_map([px[i][0] as f64, px[i][1] as f64, px[i][2] as f64], e);
                color::encode_u8(c).contains(&255)
            })
            .count();
        n as f64 / seen.len() as f64
    };
    // The brightest frame of the pulse: the shortcut's own time, give or take 200 ps.
    let direct = (-5..=5)
        .map(|k| frame_at(s.time_offset_ps + 40.0 * k as f64))
        .max_by(|a, b| mean_display(a, 1.0).total_cmp(&mean_display(b, 1.0)))
        .unwrap();
    // One decay time later: the tail alone.
    let late = frame_at(s.time_offset_ps + 1500.0);
    let (late_new, late_old) = (mean_display(&late, exposure), mean_display(&late, old));
    let (white_new, direct_new) = (white(&direct, exposure), mean_display(&direct, exposure));
    eprintln!(
        "exposure {exposure:.4e} (old {old:.4e}): late frame mean display {late_new:.4} \
         (old {late_old:.4}); direct frame mean {direct_new:.4}, white {white_new:.4}"
    );
    // Measured: 0.054 against 0.013 with the old exposure.
    assert!(late_new >= 0.04, "late light too dark: {late_new}");
    assert!(late_new >= 3.0 * late_old, "{late_new} against {late_old}");
    assert!(
        white_new <= 0.05,
        "the direct pulse is white in {white_new} of the pixels"
    );
}

#[test]
fn isochrone_range_probes_the_isochrone_view_whatever_view_it_is_given() {
    use femto::pipeline::render::{plan, Camera, RenderOptions, ViewKind};
    use femto::render::isochrone_range;
    use femto::render::paths::{shortcut_path, Shortcut};
    let (bvh, cal, cubes) = sparse_light_cubes();
    let scene = RenderScene::new(&bvh, cal, &cubes[1].1, 670.0).unwrap();
    let s = shortcut_path(&scene, Shortcut::CaptureView, 32, 24, 2, None).unwrap();
    let transient = RenderSettings::for_path(&s.path);
    let iso = isochrone_range(&scene, &transient, &s.path, None);
    // The arrival times of frame 0's pixels, probed in the isochrone view.
    let probe = RenderSettings {
        view: View::Isochrones(iso),
        ..transient
    };
    let times: Vec<f64> = (0..24)
        .flat_map(|j| (0..32).map(move |i| (i, j)))
        .filter_map(|(i, j)| probe_pixel(&scene, &probe, &s.path.frame(0), i, j).t_arrival_ps)
        .collect();
    let lo = times.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = times.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    assert!(times.len() > 100, "{} pixels with a time", times.len());
    assert_eq!((iso.t_min_ps, iso.t_max_ps), (lo, hi));
    // Not the fallback 0..1 ps: the cube scene's arrivals span hundreds of ps.
    assert!(hi - lo > 100.0, "{iso:?}");
    // The render stage's plan (femto render, femto view) resolves the same range.
    let options = RenderOptions {
        size: Some((32, 24)),
        frame_count: Some(2),
        view: ViewKind::Isochrones,
        ..RenderOptions::default()
    };
    let planned = plan(&scene, &Camera::Shortcut(Shortcut::CaptureView), &options).unwrap();
    match planned.settings.view {
        View::Isochrones(p) => assert_eq!((p.t_min_ps, p.t_max_ps), (lo, hi)),
        v => panic!("planned view {v:?}"),
    }
}

#[test]
fn cli_isochrones_of_a_realistic_capture_are_graded_not_one_red() {
    // Issue: femto render --view isochrones drew a noisy capture as red speckle (its range
    // was 0..1 ps, contours every 0.1 ps). The capture view's isochrones of the realistic
    // chain must use the blue-to-red ramp: fewer than half of the pixels pure red.
    let fx = cli::realistic_chain("48x36");
    let r = &fx.root;
    let out = r.join("iso");
    let run = FemtoCmd::new()
        .current_dir(r)
        .args([
            "render",
            "--cube",
            "world.h5",
            "--calibration",
            "cube.calibration.toml",
        ])
        .arg("--mesh")
        .arg(r.join("cap").join("scene.glb"))
        .args(["--capture-view", "--size", "48x36", "--frame-count", "1"])
        .args(["--view", "isochrones", "--out"])
        .arg(&out)
        .output();
    assert_ok(&run);
    let img = image::open(out.join("frame_00000.png")).unwrap().to_rgb8();
    let n = img.pixels().count() as f64;
    let red = img
        .pixels()
        .filter(|p| p[0] > 200 && p[1] < 60 && p[2] < 60)
        .count() as f64
        / n;
    let blue = img.pixels().filter(|p| p[2] > 200 && p[0] < 60).count() as f64 / n;
    eprintln!("isochrones: {red:.3} of the pixels red, {blue:.3} blue");
    assert!(red < 0.5, "{red} of the pixels red");
    assert!(blue > 0.02, "{blue} of the pixels blue");

    // The times the isochrones colour (the direct light's arrival at the camera, at the
    // capture pose) against the simulation's noise-free direct light, truth_direct.h5
    // (camera time of the true calibration, t0 0, scale 1): its centroid over each pixel's
    // footprint, the footprint's mean arrival.
    let (calibration, mesh) = (
        r.join("cube.calibration.toml"),
        r.join("cap").join("scene.glb"),
    );
    let geometry = femto::pipeline::render::SceneGeometry::Files {
        calibration: &calibration,
        mesh: &mesh,
    };
    let inputs =
        femto::pipeline::render::open_render_inputs(&r.join("world.h5"), None, geometry, None)
            .unwrap();
    let scene = inputs.scene().unwrap();
    let truth = femto::container::read_cube(&r.join("cap").join("truth_direct.h5")).unwrap();
    let (w, h) = (truth.nx, truth.ny);
    let path = femto::render::paths::shortcut_path(
        &scene,
        femto::render::paths::Shortcut::CaptureView,
        w,
        h,
        1,
        None,
    )
    .unwrap()
    .path;
    let settings = RenderSettings {
        view: View::Isochrones(Isochrones {
            t_min_ps: 0.0,
            t_max_ps: 1.0,
            contour_ps: 1.0,
        }),
        ..RenderSettings::for_path(&path)
    };
    let (mut compared, mut close) = (0usize, 0usize);
    for y in 0..h {
        for x in 0..w {
            let s = probe_pixel(&scene, &settings, &path.frame(0), x, y);
            let (Some(t_iso), false) = (
                s.t_arrival_ps,
                s.rgb == femto::render::views::UNLIT_ISOCHRONE_RGB,
            ) else {
                continue; // no hit, or a point the laser does not see
            };
            let p = truth.profile(x, y);
            let total: f64 = p.iter().map(|&v| v as f64).sum();
            if total <= 0.0 {
                continue;
            }
            let t_truth = p
                .iter()
                .enumerate()
                .map(|(i, &v)| v as f64 * truth.axis.bin_centre_ps(i))
                .sum::<f64>()
                / total;
            compared += 1;
            if (t_iso - t_truth).abs() <= 2.0 * truth.axis.dt_ps {
                close += 1;
            }
        }
    }
    let fraction = close as f64 / compared as f64;
    eprintln!("isochrone times within 2 bins of the truth: {close} of {compared} ({fraction:.3})");
    // Measured: 1225 of 1262 (0.971).
    assert!(compared > w * h / 2, "{compared} pixels compared");
    assert!(fraction >= 0.9, "{fraction}");
}

/// Light in a medium (issue 31): with eta 1.33 and beta 0.6, a marker's image lies within
/// half a pixel of the direction an independent boost of the light's world line gives
/// (`medium_world_to_camera`: the Lorentz matrix applied to `(1, -n / eta)`), with the
/// camera moving forward, at 45, 90 and 135 degrees to the marker; every pixel's Doppler
/// factor is that of the boosted wave 4-vector within 1e-6; and where the medium's
/// aberration differs from the vacuum's, the image is not where the vacuum formula puts it.
#[test]
fn marker_in_a_medium_lies_where_the_boosted_world_line_points() {
    use common::lorentz::medium_world_to_camera;
    let (eta, beta) = (1.33, 0.6);
    let wall = Bvh::new(wall_z0(200.0));
    let (w, h, vfov) = (160usize, 120usize, 50.0);
    let f = focal_px(h, vfov);
    let start = Point3::new(0.4, 0.25, 2.5);
    let m = Point3::new(0.05, -0.1, 0.0);
    let n = (m - start).normalize();
    let across = n.cross(&Vector3::y()).normalize();
    for angle_deg in [0.0f64, 45.0, 90.0, 135.0] {
        let a = angle_deg.to_radians();
        let v = (n * a.cos() + across * a.sin()) * beta;
        let (d_cam, _) = medium_world_to_camera(&v, &n, eta);
        // Look a little beside the marker's apparent direction, so it is off the centre.
        let look = d_cam + across * 0.05 + Vector3::y() * 0.03;
        let pose = Pose::look_at(start, start + look, Vector3::y()).unwrap();
        let r = pose.world_from_camera;
        let project = |d: &Vector3<f64>| {
            let l = r.inverse_transform_vector(d);
            (
                f * l.x / l.z + 0.5 * w as f64,
                f * l.y / l.z + 0.5 * h as f64,
            )
        };
        let predict =
            |p: &Point3<f64>| project(&medium_world_to_camera(&v, &(p - start).normalize(), eta).0);
        let (pu, pv) = predict(&m);
        let delta = 1e-4;
        let (ux, vx) = predict(&(m + Vector3::x() * delta));
        let (uy, vy) = predict(&(m + Vector3::y() * delta));
        let px_per_m = ((ux - pu).hypot(vx - pv)).min((uy - pu).hypot(vy - pv)) / delta;
        let sigma_m = 1.5 / px_per_m;
        let cap_pos = m + Vector3::new(0.05, -0.04, 1.0);
        let cap_vfov = 2.0 * (5.0 * sigma_m / (m - cap_pos).norm()).atan().to_degrees();
        let mut cal = calibration(96, 96, cap_vfov, cap_pos, m);
        cal.eta = eta;
        let axis = TimeAxis {
            t0_ps: -1.0e6,
            dt_ps: 1.0e6,
            nt: 2,
        };
        let cube = world_cube(&cal, &wall, axis, |p, _, a, b| {
            let d2 = (p - m).norm_squared();
            (-d2 / (2.0 * sigma_m * sigma_m)).exp() * (b - a)
        });
        let pyramid = Pyramid::build(&cube);
        let scene = RenderScene::new(&wall, cal, &pyramid, 670.0).unwrap();
        let path = straight_path(start, v, r, vfov, spec(w, h, 1, 1.0));
        let settings = RenderSettings::for_path(&path);
        let state = path.frame(0);
        let img = render(&scene, &settings, &state);
        let (cu, cv) = centroid(&img, w, h)
            .unwrap_or_else(|| panic!("{angle_deg} deg: the marker is not in the frame"));
        let err = (cu - pu).hypot(cv - pv);
        println!("eta {eta}, beta {beta}, {angle_deg} deg: centroid {err:.3} px from the boost");
        assert!(
            err < 0.5,
            "{angle_deg} deg: centroid ({cu:.3}, {cv:.3}) vs boost ({pu:.3}, {pv:.3}): {err:.3} px"
        );
        for (i, j) in [(3, 5), (80, 60), (150, 110), (20, 100)] {
            let s = probe_pixel(&scene, &settings, &state, i, j);
            let (d_oracle, doppler) = medium_world_to_camera(&v, &s.d_world, eta);
            assert!(
                (d_oracle - s.d_camera).norm() < 1e-9,
                "{angle_deg} deg, pixel ({i}, {j}): ray {:?} vs {:?}",
                s.d_camera,
                d_oracle
            );
            assert!(
                (s.doppler - doppler).abs() < 1e-6,
                "{angle_deg} deg, pixel ({i}, {j}): D {} vs {doppler}",
                s.doppler
            );
        }
        if angle_deg > 0.0 {
            let vacuum = project(&photon_world_to_camera(&v, &n).0);
            let apart = (vacuum.0 - pu).hypot(vacuum.1 - pv);
            println!("  the vacuum formula would put it {apart:.1} px away");
            assert!(
                apart > 2.0,
                "{angle_deg} deg: medium and vacuum {apart:.2} px apart"
            );
        }
    }
}

/// In a medium of eta 1.33, a camera at beta 0.9 > 1 / eta is refused by name, as a dolly
/// shortcut and as a path file's speed; eta 1 keeps the vacuum's limit.
#[test]
fn a_camera_faster_than_light_in_the_medium_is_refused() {
    use femto::pipeline::render::{plan, Camera, RenderOptions};
    use femto::render::paths::Shortcut;
    let wall = Bvh::new(wall_z0(20.0));
    let start = Point3::new(0.4, 0.25, 2.5);
    let mut cal = calibration(32, 24, 40.0, start, Point3::origin());
    cal.eta = 1.33;
    let axis = TimeAxis {
        t0_ps: 0.0,
        dt_ps: 10.0,
        nt: 64,
    };
    let cube = world_cube(&cal, &wall, axis, |_, _, a, b| b - a);
    let pyramid = Pyramid::build(&cube);
    let scene = RenderScene::new(&wall, cal, &pyramid, 670.0).unwrap();
    let options = RenderOptions {
        size: Some((32, 24)),
        frame_count: Some(2),
        ..RenderOptions::default()
    };
    let e = plan(
        &scene,
        &Camera::Shortcut(Shortcut::Dolly { beta: 0.9 }),
        &options,
    )
    .err()
    .expect("beta 0.9 in eta 1.33 refused")
    .to_string();
    assert!(
        e.starts_with("--dolly 0.9: ") && e.contains("eta 1.33"),
        "{e}"
    );
    assert!(plan(
        &scene,
        &Camera::Shortcut(Shortcut::Dolly { beta: 0.7 }),
        &options
    )
    .is_ok());
    let path = straight_path(
        start,
        Vector3::new(0.0, 0.0, -0.8),
        Rotation3::identity(),
        40.0,
        spec(32, 24, 2, 1.0),
    );
    let e = plan(
        &scene,
        &Camera::Path {
            path: Box::new(path.clone()),
            name: "p.toml".into(),
        },
        &options,
    )
    .err()
    .expect("a path at 0.8 in eta 1.33 refused")
    .to_string();
    assert!(e.contains("frame 0") && e.contains("eta 1.33"), "{e}");
    // The vacuum takes both.
    cal.eta = 1.0;
    let scene = RenderScene::new(&wall, cal, &pyramid, 670.0).unwrap();
    assert!(plan(
        &scene,
        &Camera::Shortcut(Shortcut::Dolly { beta: 0.9 }),
        &options
    )
    .is_ok());
}

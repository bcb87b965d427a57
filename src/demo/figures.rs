//! The demo's figures (seed Figs. 4 to 8), rendered from a chain's world-time cube with
//! [`crate::render`] and written as PNG stills, contact sheets and MP4 videos.
//!
//! When to look: a frame of a camera at rest shows each surface point at the world time its
//! light left it, `t_receive - eta r / c`, so a single frame spans many world times. The demo
//! picks the moment from the data: [`receive_quantiles_ps`] spreads the world cube's energy
//! over the times at which it reaches a camera at rest at the viewpoint, and a still is taken
//! when that camera has received [`SHOW_FRACTION`] of the captured light (the wavefront then
//! lies inside the scene). The exposure window of a still is [`STILL_WINDOW_BINS`] bins of
//! the cube; the exposure is the renderer's automatic one ([`crate::render::auto_exposure`],
//! which depends on the cube only), the same for every frame of a figure so that brightness
//! changes (searchlight) show.
//!
//! Camera paths come from [`crate::camera_path`]: [`CameraPath::static_view`] (figs. 4, 8, with
//! [`CameraPath::with_rotation`] for the rotating sensor), [`CameraPath::dolly`] (fig. 5: frame
//! 0 of a dolly at each speed), and for the approach videos (figs. 6, 7) a keyframed path on the
//! proper-time clock whose proper velocity `u = gamma beta c` grows linearly from 0 to that of
//! `beta = 0.77` (a cubic Hermite segment with the end velocities as tangents reproduces that
//! quadratic exactly), so that the speed rises smoothly from rest.

use super::contact_sheet::{contact_sheet, SheetStyle, Tile};
use super::{write_png, DemoError, DemoSizes, OutputFile, OutputKind};
use crate::camera::Pose;
use crate::camera_path::{
    CameraPath, Clock, FrameSpec, Interpolation, Keyframe, Motion, Orientation,
};
use crate::pyramid::PrefixRead;
use crate::relativity::{gamma, Radiometry, RotationAxis, SensorRotation};
use crate::render::paths::scene_target;
use crate::render::{
    auto_exposure, encode_srgb8, isochrone_range, render_frame, ColourOutput, Effects, Isochrones,
    RenderScene, RenderSettings, View,
};
use crate::units::{flight_time_ps, C_M_PER_PS};
use crate::video::{Frame, VideoFormat, VideoWriter};
use nalgebra::{Point3, Rotation3, Unit, Vector3};
use std::collections::BTreeMap;
use std::path::Path;

/// The stills are taken when a camera at rest at their viewpoint has received this fraction
/// of the captured light (module doc).
pub const SHOW_FRACTION: f64 = 0.3;
/// The approach videos sweep the times of reception between these fractions.
pub const SPAN_FRACTIONS: (f64, f64) = (0.05, 0.95);
/// Exposure window of the stills, bins of the world cube: a one-bin window shows the
/// direct wavefront as a broken line (neighbouring capture pixels put it in neighbouring
/// bins); four bins show it as a band.
pub const STILL_WINDOW_BINS: f64 = 4.0;
/// Yaw of fig. 4's novel view about the vertical through the target, degrees.
pub const NOVEL_YAW_DEG: f64 = 30.0;
/// Fig. 5's rows: (file stem, title, effects on besides unwarp, speeds; negative = away).
pub const FIG5_ROWS: [(&str, &str, &str, &[f64]); 4] = [
    (
        "fig5_aberration_towards",
        "aberration, moving towards the scene",
        "aberration",
        &[0.0, 0.3, 0.6, 0.9, 0.99],
    ),
    (
        "fig5_aberration_away",
        "aberration, moving away from the scene",
        "aberration",
        &[0.0, -0.3, -0.6, -0.9, -0.99],
    ),
    (
        "fig5_doppler",
        "Doppler shift, moving towards the scene",
        "doppler",
        &[0.0, 0.15, 0.25, 0.35, 0.5, 0.55],
    ),
    (
        "fig5_searchlight",
        "searchlight, moving towards the scene",
        "searchlight",
        &[0.0, 0.2, 0.3, 0.4, 0.5],
    ),
];
/// Fig. 8's sensor edge speeds.
pub const FIG8_BETA_EDGE: [f64; 4] = [0.0, 0.4, 0.8, 0.99];
/// Top speed of the approach videos.
pub const APPROACH_BETA: f64 = 0.77;
/// Frames of an approach video shown in its contact sheet.
pub const POSTER_FRAMES: usize = 6;

/// The capture camera's vertical field of view, degrees.
fn capture_vfov_deg(scene: &RenderScene) -> f64 {
    let k = &scene.capture.intrinsics;
    2.0 * (0.5 * k.height as f64 / k.fy).atan().to_degrees()
}

/// The capture camera's up direction in the world.
fn capture_up(scene: &RenderScene) -> Vector3<f64> {
    scene.capture.pose.world_from_camera * Vector3::new(0.0, -1.0, 0.0)
}

fn settings(
    width: usize,
    height: usize,
    dtau_ps: f64,
    effects: Effects,
    view: View,
) -> RenderSettings {
    RenderSettings {
        width,
        height,
        effects,
        radiometry: Radiometry::Consistent,
        view,
        colour: ColourOutput::LinearSrgb,
        exposure: 1.0,
        dtau_ps,
        time_offset_ps: 0.0,
    }
}

/// Render frame `k` of `path` and encode it to 8-bit sRGB.
fn render_rgb8(scene: &RenderScene, s: &RenderSettings, path: &CameraPath, k: usize) -> Vec<u8> {
    let mut pixels = vec![[0.0f32; 3]; s.width * s.height];
    render_frame(scene, s, &path.frame(k), &mut pixels);
    let mut rgb8 = vec![0u8; 3 * pixels.len()];
    encode_srgb8(s, &pixels, &mut rgb8);
    rgb8
}

/// Write `frames` (label, `w` x `h` 8-bit RGB) side by side as one labelled contact sheet.
fn write_sheet(
    path: &Path,
    w: usize,
    h: usize,
    frames: &[(String, Vec<u8>)],
) -> Result<(), DemoError> {
    let tiles: Vec<Tile> = frames
        .iter()
        .map(|(label, rgb8)| Tile {
            width: w,
            height: h,
            rgb8,
            label,
        })
        .collect();
    let sheet = contact_sheet(&tiles, &SheetStyle::default());
    write_png(path, sheet.width, sheet.height, &sheet.rgb8)
}

/// Times of reception (world time at which light reaches the camera, ps) by which a camera
/// at rest at `camera_m` has received each fraction in `fractions` (increasing, in `[0, 1]`)
/// of the captured light: every bin of the world cube, at the surface point its capture
/// pixel sees (`points_m`, NaN where none), arrives `eta |p - camera| / c` after it left.
/// Quantiles are read on a histogram of the world cube's bin width; negative bins (noise
/// after dark subtraction) count as nothing. An all-zero cube gives the histogram's start.
pub fn receive_quantiles_ps(
    scene: &RenderScene,
    points_m: &[[f32; 3]],
    camera_m: &Point3<f64>,
    fractions: &[f64],
) -> Vec<f64> {
    let w = scene.world;
    let nt = w.axis.nt;
    let dt = w.axis.dt_ps;
    let eta = scene.capture.eta;
    let shifts: Vec<Option<f64>> = points_m
        .iter()
        .enumerate()
        .map(|(pix, q)| {
            let valid = q[0].is_finite() && w.mask.as_ref().is_none_or(|m| m[pix] != 0);
            valid.then(|| {
                let q = Point3::new(q[0] as f64, q[1] as f64, q[2] as f64);
                flight_time_ps(eta, (q - camera_m).norm())
            })
        })
        .collect();
    let (lo, hi) = shifts
        .iter()
        .flatten()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &s| {
            (a.min(s), b.max(s))
        });
    let t_start = scene.world_time_ps(w.axis.t0_ps);
    if lo > hi {
        // No pixel sees the mesh (min/max of nothing).
        return vec![t_start; fractions.len()];
    }
    let start = t_start + lo;
    let bins = nt + ((hi - lo) / dt).ceil() as usize + 1;
    let mut hist = vec![0.0f64; bins];
    for (pix, shift) in shifts.iter().enumerate() {
        let Some(shift) = shift else { continue };
        let p = w.pixel_prefix(pix % w.nx, pix / w.nx);
        let k0 = ((shift - lo) / dt).round() as usize;
        for i in 0..nt {
            hist[k0 + i] += p.bin(i).max(0.0);
        }
    }
    let total: f64 = hist.iter().sum();
    let mut out = Vec::with_capacity(fractions.len());
    let (mut i, mut cum) = (0usize, 0.0f64);
    for &f in fractions {
        let want = f * total;
        while i < bins && cum + hist[i] < want {
            cum += hist[i];
            i += 1;
        }
        let frac = if i < bins && hist[i] > 0.0 {
            ((want - cum) / hist[i]).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(start + (i.min(bins) as f64 + frac) * dt);
    }
    out
}

/// The capture camera's own view, at rest, one frame.
fn capture_view(
    scene: &RenderScene,
    width: usize,
    height: usize,
    dtau_ps: f64,
) -> Result<CameraPath, DemoError> {
    Ok(CameraPath::static_view(
        &scene.capture.pose,
        capture_vfov_deg(scene),
        FrameSpec {
            width,
            height,
            frames: 1,
            dtau_ps,
        },
    )?)
}

/// Common quantities of a scene's stills.
struct Stills {
    target: Point3<f64>,
    /// Surface point seen by each capture pixel (NaN where none).
    points_m: Vec<[f32; 3]>,
    dtau_ps: f64,
    exposure: f64,
}

impl Stills {
    fn new(scene: &RenderScene) -> Result<Stills, DemoError> {
        let k = &scene.capture.intrinsics;
        let reg = crate::calibrate::register(&scene.capture, scene.bvh, k.width, k.height)?;
        Ok(Stills {
            target: scene_target(scene),
            points_m: reg.point_m,
            dtau_ps: STILL_WINDOW_BINS * scene.world.axis.dt_ps,
            exposure: auto_exposure(scene, &View::Transient),
        })
    }

    /// Receive-time quantiles for a camera at rest at `camera_m`
    /// ([`receive_quantiles_ps`]).
    fn quantiles(&self, scene: &RenderScene, camera_m: &Point3<f64>, f: &[f64]) -> Vec<f64> {
        receive_quantiles_ps(scene, &self.points_m, camera_m, f)
    }

    /// The time offset of a still from a camera at rest at `camera_m` at frame 0: the time by
    /// which it has received [`SHOW_FRACTION`] of the captured light.
    fn show_offset(&self, scene: &RenderScene, camera_m: &Point3<f64>) -> f64 {
        self.quantiles(scene, camera_m, &[SHOW_FRACTION])[0]
    }
}

fn params(pairs: &[(&str, String)]) -> BTreeMap<String, String> {
    pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.clone()))
        .collect()
}

fn still_output(figure: &str, path: &str, caption: &str, pairs: &[(&str, String)]) -> OutputFile {
    OutputFile {
        figure: figure.into(),
        path: path.into(),
        kind: OutputKind::Image,
        caption: caption.into(),
        params: params(pairs),
    }
}

/// Seed Fig. 4: a novel view (the capture camera yawed by [`NOVEL_YAW_DEG`] about the vertical
/// through the target) shown naively (keeping the capture camera's time warp) and re-warped,
/// and three isochrone images: the capture camera's time of arrival, world time, and the
/// novel camera's time of arrival.
pub fn fig4(
    scene: &RenderScene,
    sizes: &DemoSizes,
    out: &Path,
) -> Result<Vec<OutputFile>, DemoError> {
    let st = Stills::new(scene)?;
    let (w, h) = (sizes.still_width, sizes.still_height);
    let up = capture_up(scene);
    let yaw = Rotation3::from_axis_angle(&Unit::new_normalize(up), NOVEL_YAW_DEG.to_radians());
    let novel_pos = st.target + yaw * (scene.capture.pose.position_m - st.target);
    let novel_pose = Pose::look_at(novel_pos, st.target, up).ok_or_else(|| {
        DemoError::Render(crate::render::RenderError::Setting {
            name: "novel view",
            message: "the novel camera looks along its up direction".into(),
        })
    })?;
    let vfov = capture_vfov_deg(scene);
    let spec = FrameSpec {
        width: w,
        height: h,
        frames: 1,
        dtau_ps: st.dtau_ps,
    };
    let novel = CameraPath::static_view(&novel_pose, vfov, spec)?;
    let capture = CameraPath::static_view(&scene.capture.pose, vfov, spec)?;
    let mut outputs = Vec::new();
    let t_receive_ps = st.show_offset(scene, &novel_pos);
    let common = |view: &str| {
        vec![
            ("view", view.to_string()),
            ("size", format!("{w}x{h}")),
            ("t_receive_ps", format!("{t_receive_ps:.1}")),
            ("exposure_window_ps", format!("{}", st.dtau_ps)),
            ("novel_yaw_deg", format!("{NOVEL_YAW_DEG}")),
        ]
    };
    for (view, file, caption) in [
        (
            View::Naive,
            "fig4_naive.png",
            "novel view, naive: the capture's camera-time frames re-projected (time warp of the capture camera kept)",
        ),
        (
            View::Transient,
            "fig4_rewarped.png",
            "novel view, re-warped: world time shifted by the novel camera's own distances",
        ),
    ] {
        let mut s = settings(w, h, st.dtau_ps, Effects::ALL, view);
        s.exposure = st.exposure;
        s.time_offset_ps = t_receive_ps;
        let rgb = render_rgb8(scene, &s, &novel, 0);
        write_png(&out.join(file), w, h, &rgb)?;
        let mut p = common(view.name());
        p.push(("exposure", format!("{:.4e}", st.exposure)));
        outputs.push(still_output("fig4", file, caption, &p));
    }
    let iso_renders: [(&CameraPath, bool, &str, &str); 3] = [
        (
            &capture,
            true,
            "fig4_isochrones_capture.png",
            "isochrones of the capture camera: time of arrival at the capture camera (camera time)",
        ),
        (
            &capture,
            false,
            "fig4_isochrones_world.png",
            "isochrones in world time: when the direct light reaches each point",
        ),
        (
            &novel,
            true,
            "fig4_isochrones_novel.png",
            "isochrones of the novel camera: time of arrival at the novel camera",
        ),
    ];
    for (path, unwarp, file, caption) in iso_renders {
        let effects = Effects {
            unwarp,
            ..Effects::ALL
        };
        let probe = settings(
            w,
            h,
            st.dtau_ps,
            effects,
            View::Isochrones(Isochrones {
                t_min_ps: 0.0,
                t_max_ps: 1.0,
                contour_ps: 1.0,
            }),
        );
        let iso = isochrone_range(scene, &probe, path, None);
        let s = RenderSettings {
            view: View::Isochrones(iso),
            ..probe
        };
        let rgb = render_rgb8(scene, &s, path, 0);
        write_png(&out.join(file), w, h, &rgb)?;
        let mut p = common("isochrones");
        p.retain(|(k, _)| *k != "t_receive_ps" && *k != "exposure_window_ps");
        p.push((
            "clock",
            if unwarp {
                "arrival at the camera"
            } else {
                "world"
            }
            .into(),
        ));
        p.push((
            "range_ps",
            format!("{:.1} .. {:.1}", iso.t_min_ps, iso.t_max_ps),
        ));
        p.push(("contour_ps", format!("{}", iso.contour_ps)));
        outputs.push(still_output("fig4", file, caption, &p));
    }
    Ok(outputs)
}

/// Seed Fig. 5: one contact sheet per row, each effect alone (with the per-view time
/// re-warp) at increasing speed, frame 0 of a dolly from the capture camera's position
/// towards the target (away for negative speeds).
pub fn fig5(
    scene: &RenderScene,
    sizes: &DemoSizes,
    out: &Path,
) -> Result<Vec<OutputFile>, DemoError> {
    let st = Stills::new(scene)?;
    let (w, h) = (sizes.still_width, sizes.still_height);
    let start = scene.capture.pose.position_m;
    let up = capture_up(scene);
    let vfov = capture_vfov_deg(scene);
    let spec = FrameSpec {
        width: w,
        height: h,
        frames: 1,
        dtau_ps: st.dtau_ps,
    };
    let mut outputs = Vec::new();
    let t_receive_ps = st.show_offset(scene, &start);
    for (stem, title, effect, betas) in FIG5_ROWS {
        let effects = Effects::parse(&format!("unwarp,{effect}"))?;
        let mut frames = Vec::with_capacity(betas.len());
        for &beta in betas {
            let path = CameraPath::dolly(start, st.target, up, beta, vfov, spec)?;
            let mut s = settings(w, h, st.dtau_ps, effects, View::Transient);
            s.exposure = st.exposure;
            s.time_offset_ps = t_receive_ps;
            frames.push(render_rgb8(scene, &s, &path, 0));
        }
        let labelled: Vec<(String, Vec<u8>)> = betas
            .iter()
            .map(|b| format!("beta={b}"))
            .zip(frames)
            .collect();
        let file = format!("{stem}.png");
        write_sheet(&out.join(&file), w, h, &labelled)?;
        outputs.push(OutputFile {
            figure: "fig5".into(),
            path: file,
            kind: OutputKind::Sheet,
            caption: format!("{title}: beta {}", join_betas(betas)),
            params: params(&[
                ("effects", effects.to_string()),
                ("beta", join_betas(betas)),
                ("frame_size", format!("{w}x{h}")),
                ("t_receive_ps", format!("{t_receive_ps:.1}")),
                ("exposure_window_ps", format!("{}", st.dtau_ps)),
                ("exposure", format!("{:.4e}", st.exposure)),
                ("camera", "frame 0 of a dolly from the capture camera's position; negative beta moves away".into()),
            ]),
        });
    }
    Ok(outputs)
}

fn join_betas(betas: &[f64]) -> String {
    betas
        .iter()
        .map(|b| b.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The approach path: from `start` towards `target`, proper velocity rising linearly from 0 to
/// that of `beta_max` over the proper time of `spec`'s frames, `dtau_ps` times the number of
/// frame intervals (module doc).
pub fn approach_path(
    start: Point3<f64>,
    target: Point3<f64>,
    up: Vector3<f64>,
    vfov_deg: f64,
    beta_max: f64,
    spec: FrameSpec,
) -> Result<CameraPath, DemoError> {
    let total_tau_ps = spec.dtau_ps * (spec.frames.max(2) - 1) as f64;
    let pose = Pose::look_at(start, target, up).ok_or_else(|| {
        DemoError::Render(crate::render::RenderError::Setting {
            name: "approach",
            message: "the camera looks along its up direction".into(),
        })
    })?;
    let dir = (target - start).normalize();
    let u_max_m_per_ps = gamma(beta_max) * beta_max * C_M_PER_PS;
    let end = start + dir * (0.5 * u_max_m_per_ps * total_tau_ps);
    let kf = |time_ps: f64, position_m: Point3<f64>, beta: f64| Keyframe {
        time_ps,
        position_m,
        orientation: Orientation::Fixed(pose.world_from_camera),
        vfov_deg,
        beta: Some(dir * beta),
    };
    let motion = Motion::Keyframes {
        clock: Clock::Proper,
        interpolation: Interpolation::Cubic,
        keyframes: vec![kf(0.0, start, 0.0), kf(total_tau_ps, end, beta_max)],
    };
    Ok(CameraPath::new(
        spec,
        Some(0.0),
        None,
        motion,
        "demo approach",
    )?)
}

/// How much later a camera at rest at frame 0's position would receive the light that
/// reaches the camera at the last frame than that of frame 0 (light from the target; the
/// span of reception times the video sweeps).
fn swept_span_ps(path: &CameraPath, target: &Point3<f64>, eta: f64) -> f64 {
    let at = |k: usize| {
        let f = path.frame(k);
        f.t_world_ps - flight_time_ps(eta, (target - f.position_m).norm())
    };
    at(path.spec().frames - 1) - at(0)
}

/// Seed Figs. 6 and 7: the camera accelerating from rest to [`APPROACH_BETA`] towards the
/// target with every effect on, as an MP4 (`<stem>.mp4`), and a contact sheet of
/// [`POSTER_FRAMES`] of its frames (`<stem>_frames.png`). Frame 0 is taken when a camera at
/// rest at the start has received [`SPAN_FRACTIONS`]`.0` of the captured light; the proper
/// duration is chosen so that the light reaching the moving camera at the last frame would
/// reach the start position when [`SPAN_FRACTIONS`]`.1` of it has arrived there.
pub fn approach_video(
    scene: &RenderScene,
    sizes: &DemoSizes,
    out: &Path,
    figure: &str,
    stem: &str,
) -> Result<Vec<OutputFile>, DemoError> {
    let st = Stills::new(scene)?;
    let (w, h, n) = (sizes.video_width, sizes.video_height, sizes.video_frames);
    let start = scene.capture.pose.position_m;
    let up = capture_up(scene);
    let vfov = capture_vfov_deg(scene);
    let eta = scene.capture.eta;
    let r0 = (st.target - start).norm();
    let span = st.quantiles(scene, &start, &[SPAN_FRACTIONS.0, SPAN_FRACTIONS.1]);
    let want_ps = span[1] - span[0];
    // The camera must stop short of the target: at most 60 % of the way.
    let u_max = gamma(APPROACH_BETA) * APPROACH_BETA * C_M_PER_PS;
    let tau_max = 1.2 * r0 / u_max;
    let build = |tau: f64| {
        let spec = FrameSpec {
            width: w,
            height: h,
            frames: n,
            dtau_ps: tau / (n.max(2) - 1) as f64,
        };
        approach_path(start, st.target, up, vfov, APPROACH_BETA, spec)
    };
    let mut tau = tau_max;
    if swept_span_ps(&build(tau_max)?, &st.target, eta) > want_ps {
        let (mut lo, mut hi) = (0.0, tau_max);
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            if swept_span_ps(&build(mid)?, &st.target, eta) < want_ps {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        tau = hi;
    }
    let path = build(tau)?;
    let mut s = settings(w, h, path.spec().dtau_ps, Effects::ALL, View::Transient);
    s.exposure = st.exposure;
    s.time_offset_ps = span[0];
    let file = format!("{stem}.mp4");
    let mut writer = VideoWriter::create(&out.join(&file), VideoFormat::Mp4, w, h, sizes.fps)?;
    let poster_at: Vec<usize> = (0..POSTER_FRAMES)
        .map(|i| i * (n - 1) / (POSTER_FRAMES - 1).max(1))
        .collect();
    let mut poster: Vec<(String, Vec<u8>)> = Vec::new();
    crate::render::render_sequence::<DemoError>(scene, &s, &path, 0..n, |k, pixels| {
        let mut rgb8 = vec![0u8; 3 * pixels.len()];
        encode_srgb8(&s, pixels, &mut rgb8);
        if poster_at.contains(&k) {
            let beta = path.frame(k).beta.norm();
            poster.push((format!("beta={beta:.2}"), rgb8.clone()));
        }
        writer.push(&Frame {
            width: w,
            height: h,
            linear_rgb: Vec::new(),
            srgb8: rgb8,
        })?;
        Ok(())
    })?;
    writer.finish()?;
    let last = path.frame(n - 1);
    let pairs = vec![
        ("effects", Effects::ALL.to_string()),
        (
            "beta",
            format!("0 .. {APPROACH_BETA} (proper velocity linear in proper time)"),
        ),
        ("frames", format!("{n} at {} fps, {w}x{h}", sizes.fps)),
        ("dtau_ps", format!("{:.3}", path.spec().dtau_ps)),
        ("proper_duration_ps", format!("{tau:.1}")),
        ("world_duration_ps", format!("{:.1}", last.t_world_ps)),
        (
            "distance_travelled_m",
            format!("{:.4}", (last.position_m - start).norm()),
        ),
        ("start_distance_m", format!("{r0:.4}")),
        ("exposure", format!("{:.4e}", st.exposure)),
    ];
    let mut outputs = vec![OutputFile {
        figure: figure.into(),
        path: file,
        kind: OutputKind::Video,
        caption: format!(
            "{}: the camera accelerates towards the scene from rest to beta = {APPROACH_BETA}, every effect on",
            scene_label(figure)
        ),
        params: params(&pairs),
    }];
    let sheet_file = format!("{stem}_frames.png");
    write_sheet(&out.join(&sheet_file), w, h, &poster)?;
    outputs.push(OutputFile {
        figure: figure.into(),
        path: sheet_file,
        kind: OutputKind::Sheet,
        caption: format!(
            "{POSTER_FRAMES} frames of the video above, labelled with the camera's speed"
        ),
        params: params(&[("frames", join_usize(&poster_at))]),
    });
    Ok(outputs)
}

fn join_usize(v: &[usize]) -> String {
    v.iter()
        .map(|k| k.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

fn scene_label(figure: &str) -> &'static str {
    if figure == "fig7" {
        "Cornell box with the bunny"
    } else {
        "cube scene"
    }
}

/// The exposure that puts the 99.9th percentile of a frame's non-zero luminances at 1 (half
/// of white after tone mapping), None for a black frame.
pub fn frame_exposure(pixels: &[[f32; 3]]) -> Option<f64> {
    crate::render::exposure_for(
        pixels
            .iter()
            .map(|p| crate::color::luminance([p[0] as f64, p[1] as f64, p[2] as f64]))
            .collect(),
    )
}

/// Seed Fig. 8: the capture camera's view with a sensor rolling about its optical axis,
/// `beta_edge` 0, 0.4, 0.8, 0.99 (every effect on, the camera itself at rest): one PNG each
/// and a contact sheet. Each frame gets its own exposure ([`frame_exposure`]): away from the
/// axis the sensor moves across the line of sight, `D` approaches `gamma` and the frame
/// dims by `D^-3` (about 1/360 at the edge at 0.99), which would leave nothing to see of the
/// distortion; the exposures relative to the sensor at rest are in the parameters.
pub fn fig8(
    scene: &RenderScene,
    sizes: &DemoSizes,
    out: &Path,
) -> Result<Vec<OutputFile>, DemoError> {
    let st = Stills::new(scene)?;
    let (w, h) = (sizes.still_width, sizes.still_height);
    let pose = scene.capture.pose;
    let t_receive_ps = st.show_offset(scene, &pose.position_m);
    let mut outputs = Vec::new();
    let mut frames = Vec::new();
    let mut reference_exposure = None;
    for beta_edge in FIG8_BETA_EDGE {
        let path = capture_view(scene, w, h, st.dtau_ps)?.with_rotation(Some(SensorRotation {
            axis: RotationAxis::Roll,
            beta_edge,
        }))?;
        let mut s = settings(w, h, st.dtau_ps, Effects::ALL, View::Transient);
        s.time_offset_ps = t_receive_ps;
        let mut pixels = vec![[0.0f32; 3]; w * h];
        render_frame(scene, &s, &path.frame(0), &mut pixels);
        s.exposure = frame_exposure(&pixels).unwrap_or(st.exposure);
        let relative = s.exposure / *reference_exposure.get_or_insert(s.exposure);
        let mut rgb = vec![0u8; 3 * pixels.len()];
        encode_srgb8(&s, &pixels, &mut rgb);
        let file = format!("fig8_rotation_{beta_edge}.png");
        write_png(&out.join(&file), w, h, &rgb)?;
        outputs.push(still_output(
            "fig8",
            &file,
            &format!(
                "sensor rolling clockwise about the optical axis, edge speed beta = {beta_edge}"
            ),
            &[
                ("beta_edge", format!("{beta_edge}")),
                ("axis", "roll".into()),
                ("effects", Effects::ALL.to_string()),
                ("size", format!("{w}x{h}")),
                ("t_receive_ps", format!("{t_receive_ps:.1}")),
                ("exposure_window_ps", format!("{}", st.dtau_ps)),
                ("exposure", format!("{:.4e} (this frame's own)", s.exposure)),
                ("exposure_relative_to_edge_0", format!("{relative:.3}")),
            ],
        ));
        frames.push((format!("edge={beta_edge}"), rgb));
    }
    let file = "fig8_rotation.png";
    write_sheet(&out.join(file), w, h, &frames)?;
    outputs.push(OutputFile {
        figure: "fig8".into(),
        path: file.into(),
        kind: OutputKind::Sheet,
        caption: "the four rotating-sensor frames side by side, each exposed on its own".into(),
        params: params(&[("beta_edge", "0, 0.4, 0.8, 0.99".into())]),
    });
    Ok(outputs)
}

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
//! changes (searchlight) show; fig. 8 alone exposes each frame on its own ([`fig8`]).
//!
//! Framing (issue 15: no panel that shows nothing): where aberration shrinks the scene to a
//! few pixels or spreads a featureless part of it over the frame (fig. 5 at |beta| 0.9 and
//! 0.99), the panel's field of view is the cone the capture camera's view fills in the moving
//! camera; where a rolling sensor sees the scene only near its axis (fig. 8 at 0.8 and 0.99),
//! the panel is the centre of the sensor, magnified ([`framing`]). Labels and captions say so.
//! Isochrone images carry a colour bar in ps ([`super::contact_sheet::colour_bar`]).
//!
//! Camera paths come from [`crate::camera_path`]: [`CameraPath::static_view`] (figs. 4, 8, with
//! [`CameraPath::with_rotation`] for the rotating sensor), [`CameraPath::dolly`] (fig. 5: frame
//! 0 of a dolly at each speed), and for the approach videos (figs. 6, 7) a keyframed path on the
//! proper-time clock whose proper velocity `u = gamma beta c` grows linearly from 0 to that of
//! `beta = 0.77` (a cubic Hermite segment with the end velocities as tangents reproduces that
//! quadratic exactly), so that the speed rises smoothly from rest.

pub mod framing;

use super::contact_sheet::colour_bar::{colour_bar, stack, BarRange};
use super::contact_sheet::{contact_sheet, Sheet, SheetStyle, Tile};
use super::{write_png, DemoError, DemoSizes, OutputFile, OutputKind};
use crate::camera::Pose;
use crate::camera_path::{
    CameraPath, Clock, FrameSpec, Interpolation, Keyframe, Motion, Orientation,
};
use crate::color::encode_u8;
use crate::pyramid::PrefixRead;
use crate::relativity::{gamma, Radiometry, RotationAxis, SensorRotation};
use crate::render::paths::scene_target;
use crate::render::views::isochrone_colour;
use crate::render::{
    auto_exposure, encode_srgb8, isochrone_range, render_frame, ColourOutput, Effects, Isochrones,
    RenderScene, RenderSettings, View,
};
use crate::units::{flight_time_ps, C_M_PER_PS};
use crate::video::{Frame, VideoFormat, VideoWriter};
use framing::{dolly_framing, DollyFraming, MAX_VFOV_DEG, MIN_SCENE_SPAN};
use nalgebra::{Point3, Rotation3, Unit, Vector3};
use std::collections::BTreeMap;
use std::fmt::Write;
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
    let t_receive_ps = st.show_offset(scene, &novel_pos);
    let fig = Fig4 {
        scene,
        st: &st,
        size: (w, h),
        t_receive_ps,
        out,
    };
    let mut outputs = fig.novel_views(&novel)?;
    outputs.extend(fig.isochrones(&capture, &novel)?);
    Ok(outputs)
}

/// What the images of [`fig4`] share.
struct Fig4<'a, 's> {
    scene: &'a RenderScene<'s>,
    st: &'a Stills,
    /// Width and height of each image, pixels.
    size: (usize, usize),
    /// The time offset of the novel camera's stills ([`Stills::show_offset`]), ps.
    t_receive_ps: f64,
    out: &'a Path,
}

impl Fig4<'_, '_> {
    /// The parameters every image of the figure lists, for `view`.
    fn common(&self, view: &str) -> Vec<(&'static str, String)> {
        let (w, h) = self.size;
        vec![
            ("view", view.to_string()),
            ("size", format!("{w}x{h}")),
            ("t_receive_ps", format!("{:.1}", self.t_receive_ps)),
            ("exposure_window_ps", format!("{}", self.st.dtau_ps)),
            ("novel_yaw_deg", format!("{NOVEL_YAW_DEG}")),
        ]
    }

    /// The novel view from `novel`, naive and re-warped.
    fn novel_views(&self, novel: &CameraPath) -> Result<Vec<OutputFile>, DemoError> {
        let (st, (w, h)) = (self.st, self.size);
        let mut outputs = Vec::new();
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
            s.time_offset_ps = self.t_receive_ps;
            let rgb = render_rgb8(self.scene, &s, novel, 0);
            write_png(&self.out.join(file), w, h, &rgb)?;
            let mut p = self.common(view.name());
            p.push(("exposure", format!("{:.4e}", st.exposure)));
            outputs.push(still_output("fig4", file, caption, &p));
        }
        Ok(outputs)
    }

    /// The three isochrone images, each with its colour bar: arrival at the `capture`
    /// camera, world time, arrival at the `novel` camera.
    fn isochrones(
        &self,
        capture: &CameraPath,
        novel: &CameraPath,
    ) -> Result<Vec<OutputFile>, DemoError> {
        let iso_renders: [(&CameraPath, bool, &str, &str); 3] = [
            (
                capture,
                true,
                "fig4_isochrones_capture.png",
                "isochrones of the capture camera: time of arrival at the capture camera (camera time)",
            ),
            (
                capture,
                false,
                "fig4_isochrones_world.png",
                "isochrones in world time: when the direct light reaches each point",
            ),
            (
                novel,
                true,
                "fig4_isochrones_novel.png",
                "isochrones of the novel camera: time of arrival at the novel camera",
            ),
        ];
        iso_renders
            .into_iter()
            .map(|(path, unwarp, file, caption)| self.isochrone(path, unwarp, file, caption))
            .collect()
    }

    /// One isochrone image from `path` (arrival at the camera with `unwarp`, else world
    /// time) with its colour bar, written to `file`.
    fn isochrone(
        &self,
        path: &CameraPath,
        unwarp: bool,
        file: &str,
        caption: &str,
    ) -> Result<OutputFile, DemoError> {
        let (scene, (w, h)) = (self.scene, self.size);
        let effects = Effects {
            unwarp,
            ..Effects::ALL
        };
        let probe = settings(
            w,
            h,
            self.st.dtau_ps,
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
        let image = Sheet {
            width: w,
            height: h,
            rgb8: render_rgb8(scene, &s, path, 0),
        };
        let bar = isochrone_bar(&iso, w);
        let with_bar = stack(&image, &bar.strip);
        write_png(&self.out.join(file), w, with_bar.height, &with_bar.rgb8)?;
        let mut p = self.common("isochrones");
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
        p.push((
            "colour_bar_ticks_ps",
            bar.ticks
                .iter()
                .map(|t| t.label.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        ));
        let caption = format!(
            "{caption}; colour bar below: time in ps, blue early to red late, a dark line every {} ps as in the image",
            iso.contour_ps
        );
        Ok(still_output("fig4", file, &caption, &p))
    }
}

/// Label scale of text drawn on a still `width` pixels wide: font pixels of 1 screen pixel up
/// to 239 pixels, 2 from 240 (the full demo's 320).
fn still_label_scale(width: usize) -> usize {
    (width / 160).clamp(1, 4)
}

/// The colour bar under an isochrone image `width` pixels wide: the view's own colour map
/// ([`isochrone_colour`], contour lines included) over its range, ticks on multiples of the
/// contour spacing, in ps.
fn isochrone_bar(iso: &Isochrones, width: usize) -> super::contact_sheet::colour_bar::ColourBar {
    let style = SheetStyle {
        label_scale: still_label_scale(width),
        ..SheetStyle::default()
    };
    let range = BarRange {
        min: iso.t_min_ps,
        max: iso.t_max_ps,
        base_step: iso.contour_ps,
        unit: "ps",
    };
    colour_bar(
        width,
        &range,
        |t| encode_u8(isochrone_colour(iso, t, true)),
        &style,
    )
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
        // Only aberration moves the scene in the frame; the other rows keep the capture
        // camera's field of view.
        let framings: Vec<DollyFraming> = betas
            .iter()
            .map(|&b| {
                if effects.aberration {
                    dolly_framing(b, vfov)
                } else {
                    dolly_framing(0.0, vfov)
                }
            })
            .collect();
        let mut labelled = Vec::with_capacity(betas.len());
        for (&beta, fr) in betas.iter().zip(&framings) {
            let path = CameraPath::dolly(start, st.target, up, beta, fr.vfov_deg, spec)?;
            let mut s = settings(w, h, st.dtau_ps, effects, View::Transient);
            s.exposure = st.exposure;
            s.time_offset_ps = t_receive_ps;
            let label = if effects.aberration {
                format!("beta={beta}\nfov {}°", fmt_deg(fr.vfov_deg))
            } else {
                format!("beta={beta}")
            };
            labelled.push((label, render_rgb8(scene, &s, &path, 0)));
        }
        let file = format!("{stem}.png");
        write_sheet(&out.join(&file), w, h, &labelled)?;
        let mut pairs = vec![
            ("effects", effects.to_string()),
            ("beta", join_betas(betas)),
            ("frame_size", format!("{w}x{h}")),
            ("t_receive_ps", format!("{t_receive_ps:.1}")),
            ("exposure_window_ps", format!("{}", st.dtau_ps)),
            ("exposure", format!("{:.4e} (every panel)", st.exposure)),
            (
                "camera",
                "frame 0 of a dolly from the capture camera's position; negative beta moves away"
                    .into(),
            ),
        ];
        let caption = if effects.aberration {
            pairs.push((
                "vfov_deg",
                join(framings.iter().map(|f| fmt_deg(f.vfov_deg))),
            ));
            pairs.push((
                "scene_span_at_capture_fov",
                join(
                    framings
                        .iter()
                        .map(|f| format!("{:.3}", f.span_at_capture_fov)),
                ),
            ));
            aberration_caption(title, betas, &framings, vfov)
        } else if effect == "searchlight" {
            // Doppler factor at the centre of the frame, D = gamma (1 - beta).
            let d_centre: Vec<f64> = betas
                .iter()
                .map(|&b| ((1.0 - b) / (1.0 + b)).sqrt())
                .collect();
            format!(
                "{title}: beta {}. The searchlight brightens the frame, most at its centre (Doppler factor D = {} there; constant light would brighten by D^-4 = {}), the capture's noise with the signal; exposure the same for every panel",
                join_betas(betas),
                join(d_centre.iter().map(|d| format!("{d:.2}"))),
                join(d_centre.iter().map(|d| format!("{:.1}", d.powi(-4))))
            )
        } else {
            format!(
                "{title}: beta {}; exposure the same for every panel",
                join_betas(betas)
            )
        };
        outputs.push(OutputFile {
            figure: "fig5".into(),
            path: file,
            kind: OutputKind::Sheet,
            caption,
            params: params(&pairs),
        });
    }
    Ok(outputs)
}

/// An angle in degrees as a label shows it: one decimal below 10, none above.
fn fmt_deg(deg: f64) -> String {
    if deg < 10.0 {
        format!("{deg:.1}")
    } else {
        format!("{deg:.0}")
    }
}

fn join(items: impl Iterator<Item = String>) -> String {
    items.collect::<Vec<_>>().join(", ")
}

/// The caption of an aberration row of fig. 5: what aberration does to the capture camera's
/// view at each speed, and which panels are reframed ([`framing::dolly_framing`]).
fn aberration_caption(title: &str, betas: &[f64], framings: &[DollyFraming], vfov: f64) -> String {
    let towards = betas.iter().all(|&b| b >= 0.0);
    let cones = join(
        framings
            .iter()
            .map(|f| format!("{}°", fmt_deg(2.0 * f.scene_half_deg))),
    );
    let spans = join(framings.iter().map(|f| {
        let x = f.span_at_capture_fov;
        if towards {
            format!("{:.0} %", 100.0 * x)
        } else if x < 10.0 {
            format!("{x:.1}")
        } else {
            format!("{x:.0}")
        }
    }));
    let mut c = format!(
        "{title}: beta {}. Aberration {} the capture camera's {}° view into a cone of {cones} in the moving camera: at the capture's field of view the scene spans {spans}{}",
        join_betas(betas),
        if towards { "squeezes" } else { "spreads" },
        fmt_deg(vfov),
        if towards {
            " of the frame's height"
        } else {
            " times the frame's height (the frame shows only its centre)"
        },
    );
    let reframed: Vec<(f64, &DollyFraming)> = betas
        .iter()
        .zip(framings)
        .filter(|(_, f)| f.reframed)
        .map(|(&b, f)| (b, f))
        .collect();
    if !reframed.is_empty() {
        let capped: Vec<&(f64, &DollyFraming)> = reframed
            .iter()
            .filter(|(_, f)| f.shown_fraction < 0.999)
            .collect();
        let _ = write!(
            c,
            ". Panels where it would span {} (beta {}) are shown with the field of view {} to that cone{} (label: fov), so that the scene fills them: the zoom is framing, the {} is the fov in the label, the distortion inside the frame is the aberration",
            if towards {
                format!("less than {:.0} % of the frame", 100.0 * MIN_SCENE_SPAN)
            } else {
                format!("more than {:.1} times the frame", 1.0 / MIN_SCENE_SPAN)
            },
            join(reframed.iter().map(|(b, _)| b.to_string())),
            if towards { "narrowed" } else { "widened" },
            if capped.is_empty() {
                String::new()
            } else {
                format!(", at most {MAX_VFOV_DEG:.0}°")
            },
            if towards { "shrinking" } else { "spreading" },
        );
        for (b, f) in capped {
            let _ = write!(
                c,
                "; at beta {b} a pinhole would need {}°, so that panel shows the central {:.0} % of the view",
                fmt_deg(2.0 * f.scene_half_deg),
                100.0 * f.shown_fraction
            );
        }
    }
    c.push_str(". Exposure the same for every panel (aberration alone does not change brightness)");
    c
}

fn join_betas(betas: &[f64]) -> String {
    join(betas.iter().map(|b| b.to_string()))
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

/// Largest magnification of a fig. 8 crop.
pub const MAX_CROP_ZOOM: f64 = 8.0;

/// Seed Fig. 8: the capture camera's view with a sensor rolling about its optical axis,
/// `beta_edge` 0, 0.4, 0.8, 0.99 (every effect on, the camera itself at rest): one PNG each
/// and a contact sheet.
///
/// Each sensor area moves across the line of sight with `beta_edge r / r_edge`, and
/// aberration tilts its rays against the motion by `asin(beta)`: only the areas near the axis
/// still look into the part of the scene the capture camera saw, and the rest of the frame is
/// black (no captured light there, as in the seed). Where the pixels that show the scene
/// reach less than [`framing::MIN_SEEN_REACH`] of the way to the border
/// ([`framing::seen_extent`]), the panel is the centre of the sensor, magnified: the centre crop of a render of the same sensor, with the same field of
/// view and velocity field, at more pixels ([`framing::zoomed_size`], at most
/// [`MAX_CROP_ZOOM`]). Each panel gets its own exposure ([`frame_exposure`]); the fast areas
/// also dim by `D^-3` (`D` near `gamma`: about 1/360 at the edge at 0.99). The exposures
/// relative to the sensor at rest and the crops are in the parameters and captions.
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
    let rotating = |beta_edge: f64, width: usize, height: usize| {
        capture_view(scene, width, height, st.dtau_ps).and_then(|p| {
            Ok(p.with_rotation(Some(SensorRotation {
                axis: RotationAxis::Roll,
                beta_edge,
            }))?)
        })
    };
    for beta_edge in FIG8_BETA_EDGE {
        let mut s = settings(w, h, st.dtau_ps, Effects::ALL, View::Transient);
        s.time_offset_ps = t_receive_ps;
        let seen = framing::seen_extent(scene, &s, &rotating(beta_edge, w, h)?.frame(0));
        let zoom = if seen.reach > 0.0 && seen.reach < framing::MIN_SEEN_REACH {
            (1.0 / seen.reach).min(MAX_CROP_ZOOM)
        } else {
            1.0
        };
        let (big_w, big_h) = framing::zoomed_size(w, h, zoom);
        let big = RenderSettings {
            width: big_w,
            height: big_h,
            ..s
        };
        let mut big_pixels = vec![[0.0f32; 3]; big_w * big_h];
        render_frame(
            scene,
            &big,
            &rotating(beta_edge, big_w, big_h)?.frame(0),
            &mut big_pixels,
        );
        let pixels = framing::centre_crop(&big_pixels, big_w, big_h, w, h);
        s.exposure = frame_exposure(&pixels).unwrap_or(st.exposure);
        let relative = s.exposure / *reference_exposure.get_or_insert(s.exposure);
        let mut rgb = vec![0u8; 3 * pixels.len()];
        encode_srgb8(&s, &pixels, &mut rgb);
        let file = format!("fig8_rotation_{beta_edge}.png");
        write_png(&out.join(&file), w, h, &rgb)?;
        let magnified = big_h as f64 / h as f64;
        let shown = if big_w > w {
            format!(
                "the centre of the sensor magnified x{magnified:.1} (the centre {w}x{h} of a {big_w}x{big_h} render with the same field of view and sensor motion: framing only), because only {:.1} % of the whole frame shows the scene",
                100.0 * seen.fraction
            )
        } else {
            format!(
                "the whole sensor ({:.0} % of the frame shows the scene)",
                100.0 * seen.fraction
            )
        };
        let caption = format!(
            "sensor rolling clockwise about the optical axis, edge speed beta = {beta_edge}: {shown}. {}Exposure: this frame's own, x{relative:.2} that of the sensor at rest",
            if beta_edge > 0.0 {
                format!(
                    "The sensor's areas move across the line of sight, up to beta {beta_edge} at the corners, and aberration tilts their rays against the motion by up to {:.1}°; outside the areas near the axis the rays miss what the capture camera saw, and the frame is black there for that physical reason. ",
                    beta_edge.asin().to_degrees()
                )
            } else {
                String::new()
            }
        );
        outputs.push(still_output(
            "fig8",
            &file,
            &caption,
            &[
                ("beta_edge", format!("{beta_edge}")),
                ("axis", "roll".into()),
                ("effects", Effects::ALL.to_string()),
                ("size", format!("{w}x{h}")),
                ("t_receive_ps", format!("{t_receive_ps:.1}")),
                ("exposure_window_ps", format!("{}", st.dtau_ps)),
                ("exposure", format!("{:.4e} (this frame's own)", s.exposure)),
                ("exposure_relative_to_edge_0", format!("{relative:.3}")),
                (
                    "scene_fraction_of_whole_frame",
                    format!("{:.4}", seen.fraction),
                ),
                (
                    "crop",
                    if big_w > w {
                        format!("centre {w}x{h} of {big_w}x{big_h} (x{magnified:.2})")
                    } else {
                        "none".into()
                    },
                ),
            ],
        ));
        let label = if big_w > w {
            format!("edge={beta_edge}\ncentre x{magnified:.1}")
        } else {
            format!("edge={beta_edge}\nwhole sensor")
        };
        frames.push((label, rgb));
    }
    let file = "fig8_rotation.png";
    write_sheet(&out.join(file), w, h, &frames)?;
    outputs.push(OutputFile {
        figure: "fig8".into(),
        path: file.into(),
        kind: OutputKind::Sheet,
        caption: "the four rotating-sensor frames side by side, each exposed on its own; where only the sensor's centre sees the scene, the panel shows that centre magnified (label); the black around the scene is physical (see each frame's caption)".into(),
        params: params(&[("beta_edge", "0, 0.4, 0.8, 0.99".into())]),
    });
    Ok(outputs)
}

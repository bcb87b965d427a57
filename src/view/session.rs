//! One viewer session: the opened inputs, the renderer's scene, the keyframes, and the
//! frames of camera states (stills as PNG, interactive frames as JPEG) with their heads-up
//! numbers. Every frame goes through the render stage's own [`plan`] and
//! [`render_sequence_reusing`], on the state's one-frame path ([`ViewState::path`]): the
//! code and defaults of `femto render` (whose [`crate::render::render_sequence`] is the same
//! with rays made afresh; the session keeps the last frame's, for the next one).

use super::admission::{self, Admission, Permit, Refusal};
use super::keyframes::{export_path, frames_of_path, LoadedPath};
use super::light::LightCurve;
use super::state::{BadState, FrameOptions, ViewName, ViewState};
use crate::camera_path::CameraPath;
use crate::pipeline::render::{plan, Camera, Plan, RenderInputs};
use crate::pipeline::StageError;
use crate::render::paths::{shortcut_path, Shortcut};
use crate::render::{probe_pixel, render_sequence_reusing, FrameRays, RenderScene};
use crate::units::flight_time_ps;
use serde::Serialize;
use std::sync::{Mutex, RwLock};

/// Why a request for a frame was refused: a bad state (the client's fault, HTTP 400) or a
/// render the stage refuses for this state (also 400: the path passes through the geometry,
/// say), a frame that does not fit in memory (413) or not now (503), or an encoder failure
/// (500).
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    #[error(transparent)]
    State(#[from] BadState),
    #[error("{0}")]
    Render(String),
    #[error(transparent)]
    Admission(#[from] Refusal),
    #[error("encoding the frame: {0}")]
    Encode(String),
}

impl From<StageError> for ViewError {
    fn from(e: StageError) -> ViewError {
        ViewError::Render(e.to_string())
    }
}

impl From<crate::render::RenderError> for ViewError {
    fn from(e: crate::render::RenderError) -> ViewError {
        ViewError::Render(e.to_string())
    }
}

/// The heads-up numbers of a frame.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct Hud {
    /// `|beta|` of the camera.
    pub beta: f64,
    pub gamma: f64,
    /// Smallest and largest Doppler factor `D` (received over emitted wavelength) over the
    /// frame's pixels (a 16 x 12 grid of them, and the corners).
    pub doppler_min: f64,
    pub doppler_max: f64,
    /// World time of reception, ps.
    pub t_world_ps: f64,
    pub width: usize,
    pub height: usize,
    /// Milliseconds spent rendering and encoding the frame.
    pub render_ms: f64,
    /// Laser wavelength in its rest frame, nm (the received wavelengths are `D` times it).
    pub laser_nm: f64,
    /// Fraction of the frame's pixels brighter than 2 of 255 in some channel: 0 is a black
    /// frame, which the page explains.
    pub lit_fraction: f64,
    /// The times the isochrone view colour-codes, blue to red, ps; None in other views.
    pub isochrones: Option<IsochroneScale>,
}

/// The colour scale of an isochrone frame: arrival times `t_min_ps` (blue) to `t_max_ps`
/// (red), dark contour lines every `contour_ps` ([`crate::render::views::isochrone_colour`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct IsochroneScale {
    pub t_min_ps: f64,
    pub t_max_ps: f64,
    pub contour_ps: f64,
}

/// One colour of the page's wavelength legend: the colour the renderer draws light of
/// `nm` in ([`crate::color::laser_colour`], its largest channel brought to 1), as 8-bit sRGB.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SpectrumColour {
    pub nm: f64,
    pub srgb8: [u8; 3],
}

/// Wavelengths of the page's legend, nm: from, to, step.
const SPECTRUM_NM: (f64, f64, f64) = (200.0, 1000.0, 5.0);

/// The legend's colours, [`SPECTRUM_NM`].
fn spectrum() -> Vec<SpectrumColour> {
    let (a, b, step) = SPECTRUM_NM;
    let n = ((b - a) / step).round() as usize;
    (0..=n)
        .map(|k| {
            let nm = a + step * k as f64;
            let c = crate::color::laser_colour(nm);
            let top = c.iter().cloned().fold(f64::MIN, f64::max).max(1e-12);
            SpectrumColour {
                nm,
                srgb8: crate::color::encode_u8([c[0] / top, c[1] / top, c[2] / top]),
            }
        })
        .collect()
}

/// What the page needs to start: the capture's numbers, the time range of its light and the
/// capture view as the first state.
#[derive(Clone, Debug, Serialize)]
pub struct SessionInfo {
    pub cube: CubeInfo,
    /// World times of reception over which the slider runs, ps: from the cube's first light
    /// at the nearest point to its last light at the farthest, as the capture camera sees them.
    pub time_range_ps: [f64; 2],
    /// The capture camera's view at rest, at the time its first light arrives.
    pub capture_state: ViewState,
    /// The world's up direction at the capture camera (the image's up).
    pub up: [f64; 3],
    /// A step of the page's movement keys: a fiftieth of the farthest distance from the
    /// capture camera to the mesh's bounds, m.
    pub move_step_m: f64,
    /// Where the laser wavelength came from.
    pub laser: String,
    /// The `femto render` flags that name the session's inputs.
    pub render_inputs: String,
    pub max_side: usize,
    pub notes: Vec<String>,
    /// The light curve of the capture view, the first state ([`super::curve`]).
    pub light_curve: LightCurve,
    /// Wavelengths drawn in colour, nm ([`crate::color::VISIBLE_NM`]); outside, grey.
    pub visible_nm: [f64; 2],
    /// The colours of the wavelength legend.
    pub spectrum: Vec<SpectrumColour>,
    /// The wavelength false colour draws the laser's own light at, nm
    /// ([`crate::render::FALSE_COLOUR_LASER_NM`]).
    pub false_colour_laser_nm: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct CubeInfo {
    pub nx: usize,
    pub ny: usize,
    pub nt: usize,
    pub dt_ps: f64,
}

/// A viewer session over opened render inputs.
pub struct ViewSession<'a> {
    /// The opened inputs (for videos, which the render stage renders from them).
    inputs: &'a RenderInputs,
    /// The video being saved, if any ([`super::video_export`]).
    video: super::progress::VideoProgress,
    /// The renderer's scene. Its laser wavelength is the one state field that lives in the
    /// scene: a state with another one takes the write lock and renders alone.
    scene: RwLock<RenderScene<'a>>,
    info: SessionInfo,
    keyframes: Mutex<Vec<ViewState>>,
    latest: Mutex<ViewState>,
    /// How many frames render at once, within the memory budget.
    admission: Admission,
    /// The rays and hits of the last recorded frame: the next one from the same camera
    /// (Play at rest: only the time moves) skips the ray cast, one that only moves (a strafe)
    /// skips the rays. 40 bytes a pixel of that frame (12 MB at 640 x 480), held between
    /// frames; a frame that finds it busy renders without it.
    rays: Mutex<FrameRays>,
}

/// Memory a render of one frame holds besides its pixels: its thread's stack and a malloc
/// arena (64 MiB of address space each on glibc), bytes.
pub const RENDER_OVERHEAD_BYTES: f64 = 64.0 * 1024.0 * 1024.0;

/// Memory a frame of `width` x `height` takes while it renders and is encoded, bytes: the
/// render stage's per-pixel buffers ([`crate::pipeline::render::BYTES_PER_FRAME_PIXEL`]), the
/// 8-bit sRGB copy (3) and the encoded image (at most 3 more), and
/// [`RENDER_OVERHEAD_BYTES`].
pub fn frame_memory_bytes(width: usize, height: usize) -> f64 {
    let pixels = width as f64 * height as f64;
    pixels * (crate::pipeline::render::BYTES_PER_FRAME_PIXEL + 6.0) + RENDER_OVERHEAD_BYTES
}

/// Default frame size of the viewer, pixels.
pub const DEFAULT_SIZE: (usize, usize) = (640, 480);

impl<'a> ViewSession<'a> {
    /// A session over `inputs`; `render_inputs` are the `femto render` flags naming them;
    /// `exposure` the first view's multiplier of the automatic exposure (`--exposure`).
    pub fn new(
        inputs: &'a RenderInputs,
        render_inputs: String,
        exposure: f64,
    ) -> Result<Self, StageError> {
        let scene = inputs.scene()?;
        let (width, height) = DEFAULT_SIZE;
        let capture = shortcut_path(&scene, Shortcut::CaptureView, width, height, 100, None)?;
        let frame = capture.path.frame(0);
        let spec = capture.path.spec();
        let rows = frame.world_from_camera.matrix();
        let capture_state = ViewState {
            position_m: frame.position_m.coords.into(),
            world_from_camera: std::array::from_fn(|i| std::array::from_fn(|j| rows[(i, j)])),
            vfov_deg: frame.vfov_deg,
            beta: [0.0; 3],
            t_world_ps: capture.time_offset_ps,
            dtau_ps: spec.dtau_ps,
            width,
            height,
            rotation: None,
            effects: crate::render::Effects::ALL,
            view: ViewName::Transient,
            radiometry: crate::relativity::Radiometry::Consistent,
            exposure,
            laser_nm: inputs.laser.nm,
            dark_marks: true,
            // An invisible laser (the realistic capture's 795 nm) would be a grey field at
            // rest: start in false colour, which the legend says.
            false_colour: !(crate::color::VISIBLE_NM.0..=crate::color::VISIBLE_NM.1)
                .contains(&inputs.laser.nm),
        };
        let w = scene.world;
        let (t_a, t_b) = scene.world_span_ps();
        let (near_m, far_m) = distance_range_m(&scene, &scene.capture.pose.position_m);
        let eta = scene.capture.eta;
        let info = SessionInfo {
            cube: CubeInfo {
                nx: w.nx,
                ny: w.ny,
                nt: w.axis.nt,
                dt_ps: w.axis.dt_ps,
            },
            time_range_ps: [
                t_a + flight_time_ps(eta, near_m),
                t_b + flight_time_ps(eta, far_m),
            ],
            move_step_m: far_m / 50.0,
            up: (frame.world_from_camera * nalgebra::Vector3::new(0.0, -1.0, 0.0)).into(),
            capture_state: capture_state.clone(),
            laser: inputs.laser.to_string(),
            render_inputs,
            max_side: super::state::MAX_VIEW_SIDE,
            notes: inputs.notes.clone(),
            light_curve: LightCurve {
                t_ps: Vec::new(),
                mean: Vec::new(),
                lit_range_ps: None,
                time_range_ps: [0.0; 2],
                peak_ps: 0.0,
                travel_m: None,
                note: None,
            },
            visible_nm: [crate::color::VISIBLE_NM.0, crate::color::VISIBLE_NM.1],
            spectrum: spectrum(),
            false_colour_laser_nm: crate::render::FALSE_COLOUR_LASER_NM,
        };
        let mut session = ViewSession {
            inputs,
            video: Default::default(),
            scene: RwLock::new(scene),
            info,
            keyframes: Mutex::new(Vec::new()),
            latest: Mutex::new(capture_state),
            admission: Admission::new(rayon::current_num_threads()),
            rays: Mutex::new(FrameRays::default()),
        };
        let curve = session
            .light_curve(&session.info.capture_state)
            .map_err(|e| {
                StageError::Render(crate::render::RenderError::Setting {
                    name: "view",
                    message: e.to_string(),
                })
            })?;
        // The first picture is at the brightest sample: light in flight, not the dark
        // before it.
        session.info.capture_state.t_world_ps = curve.peak_ps;
        session.info.light_curve = curve;
        *session.latest.get_mut().unwrap_or_else(|p| p.into_inner()) =
            session.info.capture_state.clone();
        Ok(session)
    }

    /// The distance the camera keeps from the geometry during Play: one step of the page's
    /// movement keys, m.
    pub fn clearance_margin_m(&self) -> f64 {
        self.info.move_step_m
    }

    pub fn info(&self) -> &SessionInfo {
        &self.info
    }

    /// The opened inputs.
    pub fn inputs(&self) -> &RenderInputs {
        self.inputs
    }

    /// The progress of the video being saved.
    pub fn video_progress(&self) -> &super::progress::VideoProgress {
        &self.video
    }

    /// The state most recently rendered by any client (the capture view at first).
    pub fn latest_state(&self) -> ViewState {
        self.latest
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// How many frames render at once (the rayon threads).
    pub fn max_renders(&self) -> usize {
        self.admission.max_renders()
    }

    /// Render `state`'s frame: 8-bit sRGB pixels and the heads-up numbers, through the
    /// render stage's plan of the state's one-frame path.
    pub fn render_srgb8(&self, state: &ViewState) -> Result<(Vec<u8>, Hud), ViewError> {
        let (srgb8, hud, _permit) = self.render_admitted(state, true)?;
        Ok((srgb8, hud))
    }

    /// [`Self::render_srgb8`]'s pixels, without recording `state` as the latest (the light
    /// curve's small frames, the probe's).
    pub(super) fn render_unrecorded(&self, state: &ViewState) -> Result<Vec<u8>, ViewError> {
        let (srgb8, _, _permit) = self.render_admitted(state, false)?;
        Ok(srgb8)
    }

    /// Run `f` on the scene (with `state`'s laser wavelength) and the render stage's plan of
    /// `state`'s one-frame path.
    pub(super) fn with_planned<T>(
        &self,
        state: &ViewState,
        f: impl FnOnce(&RenderScene, &Plan) -> T,
    ) -> Result<T, ViewError> {
        let path = state.path()?;
        self.with_scene(state.laser_nm, |scene| {
            let camera = Camera::Path {
                path: Box::new(path),
                name: "state".into(),
            };
            let plan = plan(scene, &camera, &state.render_options())?;
            Ok(f(scene, &plan))
        })
    }

    /// Run `f` on the scene's geometry.
    pub(super) fn with_bvh<T>(&self, f: impl FnOnce(&crate::geometry::bvh::Bvh) -> T) -> T {
        let scene = self.scene.read().unwrap_or_else(|p| p.into_inner());
        f(scene.bvh)
    }

    /// [`Self::render_srgb8`], once admitted ([`admission`]): the permit is held until the
    /// caller has encoded the frame. `record`: remember `state` as the latest rendered.
    fn render_admitted(
        &self,
        state: &ViewState,
        record: bool,
    ) -> Result<(Vec<u8>, Hud, Permit<'_>), ViewError> {
        state.check()?;
        let permit = self.admission.admit(
            frame_memory_bytes(state.width, state.height),
            format_args!("a frame of {} x {}", state.width, state.height),
            admission::WAIT,
        )?;
        let started = std::time::Instant::now();
        let path = state.path()?;
        let render = |scene: &RenderScene| -> Result<(Vec<u8>, Hud), ViewError> {
            let camera = Camera::Path {
                path: Box::new(path),
                name: "state".into(),
            };
            let planned = plan(scene, &camera, &state.render_options())?;
            let (settings, path) = (planned.settings, &planned.path);
            let mut srgb8 = vec![0u8; 3 * settings.width * settings.height];
            let mut lit = 0.0;
            // The light curve's and the probe's small frames (not recorded) leave the
            // recorded frames' rays alone.
            let mut kept = record.then(|| self.rays.try_lock().ok()).flatten();
            let mut fresh = FrameRays::default();
            let rays = kept.as_deref_mut().unwrap_or(&mut fresh);
            render_sequence_reusing::<ViewError>(
                scene,
                &settings,
                path,
                planned.frames.clone(),
                rays,
                |k, pixels, rays| {
                    // Light is counted before the marks of the dark pixels are drawn.
                    let lit_pixels = crate::render::encode_srgb8(&settings, pixels, &mut srgb8);
                    lit = lit_pixels as f64 / pixels.len().max(1) as f64;
                    planned.mark_dark(scene, k, Some(rays), &mut srgb8);
                    Ok(())
                },
            )?;
            let (doppler_min, doppler_max) = doppler_range(scene, &settings, path);
            let hud = Hud {
                beta: state.beta.iter().map(|b| b * b).sum::<f64>().sqrt(),
                gamma: state.gamma(),
                doppler_min,
                doppler_max,
                t_world_ps: path.frame(0).t_world_ps + settings.time_offset_ps,
                width: settings.width,
                height: settings.height,
                render_ms: 0.0,
                laser_nm: scene.laser_nm,
                lit_fraction: lit,
                isochrones: match settings.view {
                    crate::render::View::Isochrones(iso) => Some(IsochroneScale {
                        t_min_ps: iso.t_min_ps,
                        t_max_ps: iso.t_max_ps,
                        contour_ps: iso.contour_ps,
                    }),
                    _ => None,
                },
            };
            Ok((srgb8, hud))
        };
        let (srgb8, mut hud) = self.with_scene(state.laser_nm, render)?;
        hud.render_ms = started.elapsed().as_secs_f64() * 1e3;
        if record {
            *self.latest.lock().unwrap_or_else(|p| p.into_inner()) = state.clone();
        }
        Ok((srgb8, hud, permit))
    }

    /// The still of `state`: the PNG that `femto render --path` writes for the state's
    /// one-frame path with the state's flags ([`ViewState::path_toml`]), byte for byte.
    pub fn still_png(&self, state: &ViewState) -> Result<Vec<u8>, ViewError> {
        let (srgb8, _, _permit) = self.render_admitted(state, true)?;
        let mut png = Vec::new();
        crate::video::encode_png(&srgb8, state.width, state.height, &mut png)
            .map_err(|e| ViewError::Encode(e.to_string()))?;
        Ok(png)
    }

    /// An interactive frame: `state` at `options.scale` of its size, as JPEG of
    /// `options.quality`, with its heads-up numbers. The options are checked here
    /// ([`FrameOptions::check`]), for the HTTP API and the WebSocket alike.
    pub fn frame_jpeg(
        &self,
        state: &ViewState,
        options: FrameOptions,
    ) -> Result<(Vec<u8>, Hud), ViewError> {
        options.check()?;
        state.check()?;
        let started = std::time::Instant::now();
        let scaled = state.scaled(options.scale);
        let (srgb8, mut hud, _permit) = self.render_admitted(&scaled, true)?;
        let jpeg = super::jpeg::encode_rgb(
            &srgb8,
            scaled.width as u16,
            scaled.height as u16,
            options.quality as u8,
        )
        .map_err(|e| ViewError::Encode(e.to_string()))?;
        hud.render_ms = started.elapsed().as_secs_f64() * 1e3;
        Ok((jpeg, hud))
    }

    /// Run `f` on the scene with laser wavelength `laser_nm`: under the shared lock when the
    /// scene has it, else alone under the write lock after setting it.
    pub(super) fn with_scene<T>(&self, laser_nm: f64, f: impl FnOnce(&RenderScene) -> T) -> T {
        {
            let scene = self.scene.read().unwrap_or_else(|p| p.into_inner());
            if scene.laser_nm == laser_nm {
                return f(&scene);
            }
        }
        let mut scene = self.scene.write().unwrap_or_else(|p| p.into_inner());
        scene.laser_nm = laser_nm;
        f(&scene)
    }

    /// The keyframes recorded so far, in the order they were added.
    pub fn keyframes(&self) -> Vec<ViewState> {
        self.keyframes
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }

    /// Record `state` as a keyframe; returns the keyframes.
    pub fn add_keyframe(&self, state: ViewState) -> Result<Vec<ViewState>, BadState> {
        state.check()?;
        let mut k = self.keyframes.lock().unwrap_or_else(|p| p.into_inner());
        if k.len() >= super::keyframes::MAX_KEYFRAMES {
            return Err(BadState {
                field: "keyframes".into(),
                message: format!("at most {} keyframes", super::keyframes::MAX_KEYFRAMES),
            });
        }
        k.push(state);
        Ok(k.clone())
    }

    /// Delete keyframe `index` (0-based); returns the keyframes.
    pub fn delete_keyframe(&self, index: usize) -> Result<Vec<ViewState>, BadState> {
        let mut k = self.keyframes.lock().unwrap_or_else(|p| p.into_inner());
        if index >= k.len() {
            return Err(BadState {
                field: "keyframes".into(),
                message: format!("no keyframe {index}: there are {}", k.len()),
            });
        }
        k.remove(index);
        Ok(k.clone())
    }

    /// Delete every keyframe.
    pub fn clear_keyframes(&self) {
        self.keyframes
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clear();
    }

    /// The keyframes as a camera-path TOML that `femto render --path` renders.
    pub fn path_toml(&self) -> Result<String, BadState> {
        export_path(&self.keyframes(), &self.info.render_inputs)
    }

    /// Load a camera-path TOML: its frames as states, with the render settings of `like`.
    pub fn load_path(text: &str, like: &ViewState) -> Result<LoadedPath, BadState> {
        let path = CameraPath::from_toml(text, "the loaded file").map_err(|e| BadState {
            field: "path".into(),
            message: e.to_string(),
        })?;
        frames_of_path(&path, like)
    }
}

/// The smallest and largest Doppler factor over a grid of the frame's pixels.
fn doppler_range(
    scene: &RenderScene,
    settings: &crate::render::RenderSettings,
    path: &CameraPath,
) -> (f64, f64) {
    let state = path.frame(0);
    let (w, h) = (settings.width, settings.height);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for gj in 0..=12 {
        for gi in 0..=16 {
            let i = (gi * (w - 1)) / 16;
            let j = (gj * (h - 1)) / 12;
            let d = probe_pixel(scene, settings, &state, i, j).doppler;
            lo = lo.min(d);
            hi = hi.max(d);
        }
    }
    (lo, hi)
}

/// Nearest and farthest distance from `o` to the corners of the mesh's bounds (the nearest
/// 0 inside them), m.
pub(super) fn distance_range_m(scene: &RenderScene, o: &nalgebra::Point3<f64>) -> (f64, f64) {
    let b = scene.bvh.bounds();
    let o = *o;
    let mut far = 0.0f64;
    for k in 0..8 {
        let c = nalgebra::Point3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x } as f64,
            if k & 2 == 0 { b.min.y } else { b.max.y } as f64,
            if k & 4 == 0 { b.min.z } else { b.max.z } as f64,
        );
        far = far.max((c - o).norm());
    }
    // The nearest point of the box.
    let clamp = |v: f64, a: f32, b: f32| v.clamp(a as f64, b as f64);
    let near = nalgebra::Point3::new(
        clamp(o.x, b.min.x, b.max.x),
        clamp(o.y, b.min.y, b.max.y),
        clamp(o.z, b.min.z, b.max.z),
    );
    ((near - o).norm(), far)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_legend_spectrum_is_grey_outside_the_visible_range_and_coloured_inside() {
        let s = spectrum();
        let at = |nm: f64| s.iter().find(|c| c.nm == nm).unwrap().srgb8;
        assert_eq!(at(300.0), [255, 255, 255]);
        assert_eq!(at(900.0), [255, 255, 255]);
        let red = at(650.0);
        assert!(red[0] == 255 && red[1] < 100 && red[2] < 100, "{red:?}");
    }
}

//! The render stage: a world-time cube, its calibration and mesh opened into what the
//! relativistic renderer needs ([`open_render_inputs`]), and a camera path rendered into a
//! frame sequence or a video ([`render_to`]; seed Sec. 4, physics.md).
//!
//! The world-time cube's prefix sums come from the pyramid stored by `femto pyramid` (the
//! cube file's `pyramid` group, or a side file); a cube without one is read whole and its
//! prefix sums built in memory, with a note saying so. The laser wavelength comes from the
//! caller, else from the cube's `laser_nm` attribute (written by `femto ingest` from the
//! capture's manifest and carried by `femto unwarp`), else [`DEFAULT_LASER_NM`] with a
//! warning: [`LaserWavelength::source`] says which.

use super::{refuse_same_file, Progress, StageError, StageOption};
use crate::camera::Calibration;
use crate::camera_path::{CameraPath, FrameSpec};
use crate::container::{self, CubeMeta};
use crate::cube::TimeFrame;
use crate::geometry::bvh::Bvh;
use crate::geometry::load::load_mesh;
use crate::geometry::TriangleMesh;
use crate::interop::{geometry_from_group, tal, wall_view};
use crate::limits::check_memory;
use crate::pyramid::Pyramid;
use crate::relativity::Radiometry;
use crate::render::coverage::{frame_is_black, predict_coverage};
use crate::render::paths::{shortcut_path, Shortcut};
use crate::render::{
    auto_exposure, check_frames, check_path_clear, encode_srgb8, isochrone_range, render_sequence,
    Effects, FrameRays, RenderError, RenderScene, RenderSettings, View,
};
use crate::store::pyramid::{self as stored_pyramid, read_pyramid_for};
use crate::video::{Frame, VideoFormat, VideoWriter};
use std::ops::Range;
use std::path::Path;
use std::time::Instant;

/// Laser wavelength used when neither the caller nor the cube says, nm.
pub const DEFAULT_LASER_NM: f64 = 670.0;
/// Cube attributes that may hold the laser wavelength in nm: femto's, then other spellings.
pub const LASER_NM_NOTES: [&str; 3] = ["laser_nm", "laser_wavelength_nm", "laser.wavelength_nm"];
/// Largest frame side accepted, pixels.
pub const MAX_SIDE: usize = 16384;
/// Largest number of frames accepted.
pub const MAX_FRAMES: usize = 1_000_000;

/// Memory of the process before the stage allocates anything (code, threads, HDF5, the mesh
/// of a scanned scene), bytes.
const BASE_BYTES: f64 = 32e6;

/// Bytes per frame pixel held while a sequence renders: the linear RGB frame (12), the camera
/// rays of the frame in world space (24) with their Doppler factors (8) and hit distances
/// (8), the frame handed to the writer (12 as linear RGB, 3 as sRGB) and the encoder's copy.
pub const BYTES_PER_FRAME_PIXEL: f64 = 72.0;

/// Bytes per cube pixel of the renderer's scene besides the pyramid: the capture camera's
/// G-buffer entry (point, normal, tolerance, side).
const BYTES_PER_CUBE_PIXEL: f64 = 40.0;

/// Peak memory of reading a world-time cube of `nx` x `ny` pixels and `nt` bins for the
/// renderer, bytes: its pyramid, the prefix sums expanded to f64 (`nt + 1` per pixel), the
/// G-buffer and, when the pyramid is built in memory (`build_pyramid`), the cube itself.
pub fn inputs_memory_estimate(nx: usize, ny: usize, nt: usize, build_pyramid: bool) -> f64 {
    let (n_pix, fnt) = (nx as f64 * ny as f64, nt as f64);
    let cube = if build_pyramid {
        4.0 * n_pix * fnt
    } else {
        0.0
    };
    BASE_BYTES
        + crate::pyramid::memory_bytes(n_pix, fnt)
        + n_pix * (8.0 * (fnt + 1.0) + BYTES_PER_CUBE_PIXEL)
        + cube
}

/// Bytes per pixel of each frame that an MP4 or GIF holds in memory until it is written
/// whole (a frame sequence streams its frames to disk): about 4 x the 0.27 bytes a pixel of
/// the demo's H.264 (`fig6_approach.mp4`: 2.45 MB for 120 frames of 320 x 240), and the
/// 1.5 bytes a pixel of GIF's LZW at its worst (12-bit codes for 8-bit indices).
fn encoded_bytes_per_pixel(format: VideoFormat) -> f64 {
    match format {
        VideoFormat::Mp4 => 1.0,
        VideoFormat::Gif => 1.5,
        VideoFormat::PngSequence | VideoFormat::ExrSequence => 0.0,
    }
}

/// Peak memory of rendering `frames` frames of `width` x `height` into `format` from a
/// world-time cube of `nx` x `ny` pixels and `nt` bins whose pyramid is in memory, bytes.
pub fn memory_estimate(
    (nx, ny, nt): (usize, usize, usize),
    (width, height, frames): (usize, usize, usize),
    format: VideoFormat,
) -> f64 {
    let frame_pixels = width as f64 * height as f64;
    inputs_memory_estimate(nx, ny, nt, false)
        + BYTES_PER_FRAME_PIXEL * frame_pixels
        + encoded_bytes_per_pixel(format) * frame_pixels * frames as f64
}

/// Where the laser wavelength came from.
#[derive(Clone, Debug, PartialEq)]
pub enum WavelengthSource {
    /// Given by the caller (`--laser-nm`).
    Given,
    /// The cube's attribute of this name.
    Cube(String),
    /// Nobody said: [`DEFAULT_LASER_NM`].
    Default,
}

/// The laser wavelength of a render and where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserWavelength {
    pub nm: f64,
    pub source: WavelengthSource,
}

impl std::fmt::Display for LaserWavelength {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.source {
            WavelengthSource::Given => write!(f, "{} nm (given)", self.nm),
            WavelengthSource::Cube(key) => write!(f, "{} nm (the cube's {key} attribute)", self.nm),
            WavelengthSource::Default => write!(
                f,
                "{} nm (the default: the cube records no laser wavelength; give --laser-nm)",
                self.nm
            ),
        }
    }
}

/// The laser wavelength for a cube: `given`, else the cube's attribute, else the default.
pub fn laser_wavelength(
    given: Option<f64>,
    meta: &CubeMeta,
    cube_path: &Path,
) -> Result<LaserWavelength, StageError> {
    if let Some(nm) = given {
        if !(nm.is_finite() && nm > 0.0) {
            return Err(StageError::Option {
                name: StageOption::LaserNm,
                message: format!("{nm}: must be a positive wavelength in nm"),
            });
        }
        return Ok(LaserWavelength {
            nm,
            source: WavelengthSource::Given,
        });
    }
    for key in LASER_NM_NOTES {
        if let Some((_, value)) = meta.notes.iter().find(|(k, _)| k == key) {
            return match value.trim().parse::<f64>() {
                Ok(nm) if nm.is_finite() && nm > 0.0 => Ok(LaserWavelength {
                    nm,
                    source: WavelengthSource::Cube(key.to_string()),
                }),
                _ => Err(StageError::Input {
                    path: cube_path.display().to_string(),
                    message: format!(
                        "attribute {key} = '{value}' is not a wavelength in nm; give --laser-nm"
                    ),
                }),
            };
        }
    }
    Ok(LaserWavelength {
        nm: DEFAULT_LASER_NM,
        source: WavelengthSource::Default,
    })
}

/// What the renderer reads: the mesh, the capture calibration, the world-time cube's prefix
/// sums and the laser wavelength, opened and checked.
pub struct RenderInputs {
    pub bvh: Bvh,
    pub calibration: Calibration,
    pub pyramid: Pyramid,
    pub laser: LaserWavelength,
    /// Things the user should know (no stored pyramid, default wavelength).
    pub notes: Vec<String>,
}

impl RenderInputs {
    /// The renderer's scene (casts the capture camera's G-buffer: call once).
    pub fn scene(&self) -> Result<RenderScene<'_>, RenderError> {
        RenderScene::new(&self.bvh, self.calibration, &self.pyramid, self.laser.nm)
    }
}

/// Where the renderer's capture camera and scene geometry come from.
#[derive(Clone, Copy, Debug)]
pub enum SceneGeometry<'a> {
    /// A calibration TOML and a mesh file (`--calibration`, `--mesh`).
    Files {
        calibration: &'a Path,
        mesh: &'a Path,
    },
    /// The cube's own `tal` group (a y-tal capture, a confocal scan of a relay wall): its wall
    /// grid, seen by the camera of [`crate::interop::wall_view`].
    Wall,
}

/// Open a world-time cube (its stored pyramid, or `pyramid_file`, or prefix sums built in
/// memory) and its calibration and mesh, from files or from the cube's wall grid.
/// `laser_nm`: the wavelength, when the caller knows it.
pub fn open_render_inputs(
    cube_path: &Path,
    pyramid_file: Option<&Path>,
    geometry: SceneGeometry<'_>,
    laser_nm: Option<f64>,
) -> Result<RenderInputs, StageError> {
    // Errors name the flag that gave the file (the file's own messages name the file).
    let flagged = |name: StageOption| {
        move |e: StageError| StageError::Option {
            name,
            message: e.to_string(),
        }
    };
    let meta = container::read_meta(cube_path)
        .map_err(StageError::from)
        .map_err(flagged(StageOption::Cube))?;
    let (calibration, mesh, calibration_name) = match geometry {
        SceneGeometry::Files { calibration, mesh } => {
            let cal = Calibration::load(calibration)
                .map_err(StageError::from)
                .map_err(flagged(StageOption::Calibration))?;
            let m = load_mesh(mesh)
                .map_err(StageError::from)
                .map_err(flagged(StageOption::Mesh))?;
            if m.triangles.is_empty() {
                return Err(flagged(StageOption::Mesh)(StageError::Input {
                    path: mesh.display().to_string(),
                    message: "the mesh has no triangles".into(),
                }));
            }
            (cal, m, calibration.display().to_string())
        }
        SceneGeometry::Wall => {
            let (cal, m) = wall_geometry(cube_path, &meta)?;
            (cal, m, cube_path.display().to_string())
        }
    };
    let bvh = Bvh::new(mesh);
    if meta.frame != TimeFrame::World {
        return Err(flagged(StageOption::Cube)(StageError::Input {
            path: cube_path.display().to_string(),
            message: format!(
                "the cube is in {} time; the renderer needs a world-time cube (unwarp it first)",
                meta.frame
            ),
        }));
    }
    // Checked here, where both files are known, so that the message names them (the
    // renderer's own check, RenderScene::new, knows neither).
    let k = &calibration.intrinsics;
    if (meta.nx, meta.ny) != (k.width, k.height) {
        return Err(flagged(StageOption::Calibration)(StageError::Input {
            path: calibration_name,
            message: format!(
                "intrinsics are for {} x {} pixels, but {} is {} x {}",
                k.width,
                k.height,
                cube_path.display(),
                meta.nx,
                meta.ny
            ),
        }));
    }
    let laser = laser_wavelength(laser_nm, &meta, cube_path)?;
    let stored = pyramid_file.is_some() || meta.groups.iter().any(|g| g == stored_pyramid::GROUP);
    check_memory(
        inputs_memory_estimate(meta.nx, meta.ny, meta.axis.nt, !stored),
        format_args!(
            "--cube {}: rendering its {} x {} pixels of {} bins",
            cube_path.display(),
            meta.nx,
            meta.ny,
            meta.axis.nt
        ),
        "render a cropped or coarser cube, on a machine with more memory",
    )?;
    let mut notes = Vec::new();
    let pyramid = if let Some(side) = pyramid_file {
        read_pyramid_for(cube_path, Some(side)).map_err(|e| StageError::Option {
            name: StageOption::Pyramid,
            message: e.to_string(),
        })?
    } else if meta.groups.iter().any(|g| g == stored_pyramid::GROUP) {
        read_pyramid_for(cube_path, None)?
    } else {
        notes.push(format!(
            "{} has no stored pyramid; its prefix sums were built in memory (`femto pyramid {}` \
             stores them once)",
            cube_path.display(),
            cube_path.display()
        ));
        Pyramid::build(&container::read_cube(cube_path)?)
    };
    if laser.source == WavelengthSource::Default {
        notes.push(format!("laser wavelength {laser}"));
    }
    Ok(RenderInputs {
        bvh,
        calibration,
        pyramid,
        laser,
        notes,
    })
}

/// The camera and mesh of the wall grid in `cube_path`'s `tal` group ([`SceneGeometry::Wall`]).
fn wall_geometry(
    cube_path: &Path,
    meta: &CubeMeta,
) -> Result<(Calibration, TriangleMesh), StageError> {
    let refuse = |message: String| StageError::Option {
        name: StageOption::Calibration,
        message: format!("{}: {message}", cube_path.display()),
    };
    if !meta.groups.iter().any(|g| g == tal::GROUP) {
        return Err(refuse(format!(
            "no calibration given and no /{} group (the wall point of each pixel, from a y-tal \
             capture or a confocal scan): give --calibration CAL.toml --mesh MESH",
            tal::GROUP
        )));
    }
    let group = container::read_group(cube_path, tal::GROUP)?;
    let geo = geometry_from_group(cube_path, &group, meta.nx, meta.ny)
        .map_err(|e| refuse(e.to_string()))?;
    wall_view(&geo, meta.nx, meta.ny).map_err(|why| {
        refuse(format!(
            "the /{} group's wall grid cannot stand for a capture camera ({why}): give \
             --calibration CAL.toml --mesh MESH",
            tal::GROUP
        ))
    })
}

/// Which camera moves through the scene.
#[derive(Clone, Debug)]
pub enum Camera {
    /// A camera-path TOML file.
    PathFile(std::path::PathBuf),
    /// A camera path already resolved (from text that is not a file: `femto view`'s states);
    /// `name` stands for the file in messages. Rendered as [`Camera::PathFile`] renders the
    /// same path read from a file.
    Path { path: Box<CameraPath>, name: String },
    /// A shortcut derived from the capture camera ([`crate::render::paths`]).
    Shortcut(Shortcut),
}

/// What a frame shows, before its isochrone range is resolved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ViewKind {
    #[default]
    Transient,
    Naive,
    Isochrones,
    Integrated,
}

/// How [`render_to`] renders; `Default` is what `femto render` does.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Frame size; None: the path file's, or 640 x 480 for a shortcut.
    pub size: Option<(usize, usize)>,
    /// Frames of the whole sequence; None: the path file's, or 100 for a shortcut.
    pub frame_count: Option<usize>,
    /// Only these frames of the sequence; None: all.
    pub frames: Option<Range<usize>>,
    /// Frame interval, ps of proper time; None: the path file's, or the shortcut's own.
    pub dtau_ps: Option<f64>,
    /// World time of the path's time 0, ps; None: 0 for a path file, the shortcut's own.
    pub time_offset_ps: Option<f64>,
    pub effects: Effects,
    pub radiometry: Radiometry,
    pub view: ViewKind,
    /// Multiplier of the automatic exposure.
    pub exposure: f64,
    /// Isochrone contour spacing, ps; None: automatic.
    pub contour_ps: Option<f64>,
    pub format: VideoFormat,
    /// Frames per second of MP4 and GIF output.
    pub fps: f64,
    /// Replace existing output (the video file, or the frame files this render writes);
    /// without it they are refused ([`super::overwrite`]).
    pub force: bool,
    /// Mark the dark pixels the capture never saw and those unwarp masked
    /// ([`crate::render::dark`]) in 8-bit output; EXR frames stay scene-linear.
    pub dark_marks: bool,
    /// Draw the received light in false colour relative to the laser
    /// ([`crate::render::ColourOutput::FalseColour`]).
    pub false_colour: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            size: None,
            frame_count: None,
            frames: None,
            dtau_ps: None,
            time_offset_ps: None,
            effects: Effects::ALL,
            radiometry: Radiometry::Consistent,
            view: ViewKind::Transient,
            exposure: 1.0,
            contour_ps: None,
            format: VideoFormat::PngSequence,
            fps: 30.0,
            force: false,
            dark_marks: false,
            false_colour: false,
        }
    }
}

/// What [`render_to`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct Rendered {
    pub frames: Range<usize>,
    pub frames_written: usize,
    pub width: usize,
    pub height: usize,
    pub seconds: f64,
    /// Global indices of the frames that came out entirely black.
    pub black_frames: Vec<usize>,
    /// The time offset used, ps.
    pub time_offset_ps: f64,
    /// The frame interval used, ps of proper time.
    pub dtau_ps: f64,
    pub laser: LaserWavelength,
    pub warnings: Vec<String>,
}

/// The path and settings of a render, resolved and checked, before any frame is rendered.
pub struct Plan {
    pub path: CameraPath,
    pub settings: RenderSettings,
    pub frames: Range<usize>,
    /// [`RenderOptions::dark_marks`].
    pub dark_marks: bool,
}

impl Plan {
    /// Frame `k`'s linear `pixels` as 8-bit sRGB for display into `out` ([`encode_srgb8`]),
    /// with the marks of unseen and masked pixels when the plan asks for them
    /// ([`crate::render::dark::draw_dark_marks`]): what PNG frames, MP4, GIF and the
    /// viewer's frames hold.
    pub fn display_srgb8(
        &self,
        scene: &RenderScene,
        k: usize,
        pixels: &[[f32; 3]],
        out: &mut [u8],
    ) {
        encode_srgb8(&self.settings, pixels, out);
        self.mark_dark(scene, k, None, out);
    }

    /// The marks of [`Plan::display_srgb8`] over frame `k`'s encoded pixels `srgb8`, when the
    /// plan asks for them; `rays`: those the frame was rendered with, when the caller kept
    /// them ([`crate::render::dark::draw_dark_marks`]).
    pub fn mark_dark(
        &self,
        scene: &RenderScene,
        k: usize,
        rays: Option<&FrameRays>,
        srgb8: &mut [u8],
    ) {
        if self.dark_marks {
            let state = self.path.frame(k);
            crate::render::dark::draw_dark_marks(scene, &self.settings, &state, rays, srgb8);
        }
    }
}

/// Refuse a shortcut camera that would move at or faster than light (`--dolly`, `--orbit`
/// with `|beta| >= 1`, or not finite), naming the flag. The CLI checks this before opening
/// its inputs; [`plan`] checks it again.
pub fn check_camera(camera: &Camera) -> Result<(), StageError> {
    let (name, beta) = match camera {
        Camera::Shortcut(Shortcut::Dolly { beta }) => (StageOption::Dolly, *beta),
        Camera::Shortcut(Shortcut::Orbit { beta }) => (StageOption::Orbit, *beta),
        _ => return Ok(()),
    };
    if beta.is_finite() && beta.abs() < 1.0 {
        Ok(())
    } else {
        Err(StageError::Option {
            name,
            message: format!("{beta}: the camera must move slower than light (|beta| < 1)"),
        })
    }
}

/// Refuse render options out of range (frame count, size, interval, exposure, ...), naming
/// the option. [`plan`] checks them; the CLI checks them first as well, so that a bad flag is
/// refused before the inputs (gigabytes, at times) are opened.
pub fn check_options(options: &RenderOptions) -> Result<(), StageError> {
    let bad = |name, message: String| Err(StageError::Option { name, message });
    if let Some(n) = options.frame_count {
        if n == 0 || n > MAX_FRAMES {
            return bad(
                StageOption::FrameCount,
                format!("{n}: need between 1 and {MAX_FRAMES} frames"),
            );
        }
    }
    if let Some((w, h)) = options.size {
        if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
            return bad(
                StageOption::Size,
                format!("{w}x{h}: each side must be between 1 and {MAX_SIDE} pixels"),
            );
        }
    }
    if let Some(d) = options.dtau_ps {
        if !(d.is_finite() && d > 0.0) {
            return bad(
                StageOption::DtauPs,
                format!("{d}: must be a positive number of picoseconds"),
            );
        }
    }
    if let Some(t) = options.time_offset_ps {
        if !t.is_finite() {
            return bad(
                StageOption::TimeOffsetPs,
                format!("{t}: must be a finite number"),
            );
        }
    }
    // Times in their meaningful ranges ([`crate::ranges`]), after the messages above.
    for (name, v, range) in [
        (
            StageOption::DtauPs,
            options.dtau_ps,
            crate::ranges::INTERVAL_PS,
        ),
        (
            StageOption::TimeOffsetPs,
            options.time_offset_ps,
            crate::ranges::TIME_PS,
        ),
        (
            StageOption::ContourPs,
            options.contour_ps,
            crate::ranges::INTERVAL_PS,
        ),
    ] {
        if let Some(Err(e)) = v.map(|v| crate::ranges::check("", v, range)) {
            return bad(name, e.detail());
        }
    }
    if !(options.exposure.is_finite() && options.exposure > 0.0) {
        return bad(
            StageOption::Exposure,
            format!("{}: must be a positive number", options.exposure),
        );
    }
    if !(options.fps.is_finite() && options.fps > 0.0) {
        return bad(
            StageOption::Fps,
            format!("{}: must be a positive number", options.fps),
        );
    }
    if let Some(c) = options.contour_ps {
        if !(c.is_finite() && c > 0.0) {
            return bad(
                StageOption::ContourPs,
                format!("{c}: must be a positive number"),
            );
        }
    }
    Ok(())
}

/// Refuse a path that, in a medium of index `eta > 1` (the calibration's), moves any part of
/// the sensor at or above `c / eta` in one of `frames`: light in the medium could not reach
/// it from behind ([`crate::relativity::medium`]). The speed of a rotating sensor is taken at
/// its corners, edge midpoints and centre, where the spin's speed is largest or the path's.
pub(crate) fn check_medium_speed(
    path: &crate::camera_path::CameraPath,
    frames: std::ops::Range<usize>,
    eta: f64,
) -> Result<(), String> {
    if eta == 1.0 {
        return Ok(());
    }
    let spec = path.spec();
    let half = nalgebra::Vector2::new(0.5 * spec.width as f64, 0.5 * spec.height as f64);
    for k in frames {
        let state = path.frame(k);
        let mut speed: f64 = 0.0;
        for (sx, sy) in [
            (-1.0, -1.0),
            (0.0, -1.0),
            (1.0, -1.0),
            (-1.0, 0.0),
            (0.0, 0.0),
            (1.0, 0.0),
            (-1.0, 1.0),
            (0.0, 1.0),
            (1.0, 1.0),
        ] {
            let offset = nalgebra::Vector2::new(sx * half.x, sy * half.y);
            speed = speed.max(state.pixel_beta(&offset, &half).norm());
        }
        crate::relativity::medium::check_speed(speed, eta)
            .map_err(|e| format!("frame {k}: {e} (eta from the calibration)"))?;
    }
    Ok(())
}

/// Resolve the camera path, frame range and settings of a render on `scene`.
pub fn plan(
    scene: &RenderScene,
    camera: &Camera,
    options: &RenderOptions,
) -> Result<Plan, StageError> {
    check_options(options)?;
    check_camera(camera)?;
    let (path, default_offset_ps) = camera_path(scene, camera, options)?;
    check_frame_size(scene, &path.spec(), options.format)?;
    let spec = path.spec();
    check_path_clear(scene.bvh, &path).map_err(|e| {
        let (name, value) = camera_flag(camera);
        let message = if value.is_empty() {
            e.to_string()
        } else {
            format!("{value}: {e}")
        };
        StageError::Option { name, message }
    })?;
    let frames = options.frames.clone().unwrap_or(0..spec.frames);
    check_frames(&path, &frames).map_err(|e| StageError::Option {
        name: StageOption::Frames,
        message: format!("{}..{}: {e}", frames.start, frames.end),
    })?;
    check_medium_speed(&path, frames.clone(), scene.capture.eta).map_err(|e| {
        let (name, value) = camera_flag(camera);
        StageError::Option {
            name,
            message: format!("{value}{}{e}", if value.is_empty() { "" } else { ": " }),
        }
    })?;

    let mut settings = RenderSettings::for_path(&path);
    settings.effects = options.effects;
    settings.radiometry = options.radiometry;
    settings.time_offset_ps = options.time_offset_ps.unwrap_or(default_offset_ps);
    if options.false_colour {
        settings.colour = crate::render::ColourOutput::FalseColour;
    }
    settings.view = match options.view {
        ViewKind::Transient => View::Transient,
        ViewKind::Naive => View::Naive,
        ViewKind::Integrated => View::Integrated,
        ViewKind::Isochrones => {
            View::Isochrones(isochrone_range(scene, &settings, &path, options.contour_ps))
        }
    };
    settings.exposure = options.exposure * auto_exposure(scene, &settings.view);
    Ok(Plan {
        path,
        settings,
        frames,
        dark_marks: options.dark_marks,
    })
}

/// The camera path of a render and the time offset it defaults to (a shortcut's own; 0 for
/// a path file): a path file as loaded, with the frame size, count and spacing that
/// `options` give instead of its own; a shortcut built for `scene` at `options`' size.
fn camera_path(
    scene: &RenderScene,
    camera: &Camera,
    options: &RenderOptions,
) -> Result<(CameraPath, f64), StageError> {
    Ok(match camera {
        Camera::PathFile(p) => {
            let loaded = CameraPath::load(p).map_err(|e| StageError::Option {
                name: StageOption::Path,
                message: e.to_string(),
            })?;
            (
                with_frame_spec(loaded, options, &p.display().to_string())?,
                0.0,
            )
        }
        Camera::Path { path, name } => (with_frame_spec((**path).clone(), options, name)?, 0.0),
        Camera::Shortcut(shortcut) => {
            let (width, height) = options.size.unwrap_or((640, 480));
            let s = shortcut_path(
                scene,
                *shortcut,
                width,
                height,
                options.frame_count.unwrap_or(100),
                options.dtau_ps,
            )
            .map_err(|e| match e {
                // The shortcut's own setting: named by its flag, with the value given.
                RenderError::Setting {
                    name: "dolly" | "orbit",
                    message,
                } => {
                    let (name, value) = camera_flag(camera);
                    StageError::Option {
                        name,
                        message: format!("{value}: {message}"),
                    }
                }
                other => other.into(),
            })?;
            (s.path, s.time_offset_ps)
        }
    })
}

/// A path as loaded, with the frame size, count and spacing that `options` give instead of
/// its own (`name` names it in messages).
pub(crate) fn with_frame_spec(
    loaded: CameraPath,
    options: &RenderOptions,
    name: &str,
) -> Result<CameraPath, StageError> {
    let spec = loaded.spec();
    let (width, height) = options.size.unwrap_or((spec.width, spec.height));
    let spec = FrameSpec {
        width,
        height,
        frames: options.frame_count.unwrap_or(spec.frames),
        dtau_ps: options.dtau_ps.unwrap_or(spec.dtau_ps),
    };
    Ok(if spec == loaded.spec() {
        loaded
    } else {
        CameraPath::new(
            spec,
            Some(loaded.tau0_ps()),
            loaded.rotation(),
            loaded.motion().clone(),
            name,
        )?
    })
}

/// Refuse frames of `spec` larger than [`MAX_SIDE`] a side or more than [`MAX_FRAMES`], a
/// render of `scene` that needs more memory than is available in `format`, and an MP4 of
/// odd width or height.
fn check_frame_size(
    scene: &RenderScene,
    spec: &FrameSpec,
    format: VideoFormat,
) -> Result<(), StageError> {
    if spec.width > MAX_SIDE || spec.height > MAX_SIDE || spec.frames > MAX_FRAMES {
        return Err(StageError::Option {
            name: StageOption::Size,
            message: format!(
                "{}x{} pixels and {} frames: at most {MAX_SIDE} pixels a side and {MAX_FRAMES} frames",
                spec.width, spec.height, spec.frames
            ),
        });
    }
    let w = scene.world;
    let in_memory = encoded_bytes_per_pixel(format) > 0.0;
    check_memory(
        memory_estimate(
            (w.nx, w.ny, w.axis.nt),
            (spec.width, spec.height, spec.frames),
            format,
        ),
        format_args!(
            "rendering {} frames of {}x{} from a {} x {} x {} cube{}",
            spec.frames,
            spec.width,
            spec.height,
            w.nx,
            w.ny,
            w.axis.nt,
            if in_memory {
                format!(" into an {} held in memory until it is written", format)
            } else {
                String::new()
            }
        ),
        if in_memory {
            "lower --size or --frame-count, or render a frame sequence (--format png)"
        } else {
            "lower --size"
        },
    )?;
    if format == VideoFormat::Mp4 && (spec.width % 2 == 1 || spec.height % 2 == 1) {
        return Err(StageError::Option {
            name: StageOption::Size,
            message: format!(
                "{}x{}: MP4 (H.264, 4:2:0) needs an even width and height; use {}x{} or another format",
                spec.width,
                spec.height,
                spec.width + spec.width % 2,
                spec.height + spec.height % 2
            ),
        });
    }
    Ok(())
}

/// The flag that chose `camera`, without dashes, and its value.
fn camera_flag(camera: &Camera) -> (StageOption, String) {
    match camera {
        Camera::PathFile(p) => (StageOption::Path, p.display().to_string()),
        Camera::Path { name, .. } => (StageOption::Path, name.clone()),
        Camera::Shortcut(Shortcut::Dolly { beta }) => (StageOption::Dolly, beta.to_string()),
        Camera::Shortcut(Shortcut::Orbit { beta }) => (StageOption::Orbit, beta.to_string()),
        Camera::Shortcut(Shortcut::CaptureView) => (StageOption::CaptureView, String::new()),
    }
}

/// Render `camera` on `inputs` into `out` (a folder for frame sequences, a file for MP4 and
/// GIF; never one of the inputs: `inputs_paths`).
pub fn render_to(
    inputs: &RenderInputs,
    camera: &Camera,
    options: &RenderOptions,
    out: &Path,
    input_paths: &[&Path],
    progress: &dyn Progress,
) -> Result<Rendered, StageError> {
    refuse_same_file(out, input_paths, "out")?;
    let scene = inputs.scene()?;
    progress.poll();
    let plan = plan(&scene, camera, options)?;
    progress.poll();
    let spec = plan.path.spec();
    if options.format.is_sequence() {
        let names = plan
            .frames
            .clone()
            .map(|k| out.join(crate::video::sequence_file_name(k, options.format)));
        super::overwrite::refuse_existing_any(names, options.force, "out")?;
    } else {
        super::overwrite::refuse_existing(out, input_paths, options.force, "out")?;
    }
    let mut writer =
        VideoWriter::create(out, options.format, spec.width, spec.height, options.fps)?
            .first_frame_index(plan.frames.start)
            .sequence_length(spec.frames)
            .record_sequence(plan.frames != (0..spec.frames));
    let mut frame = Frame {
        width: spec.width,
        height: spec.height,
        linear_rgb: Vec::new(),
        srgb8: Vec::new(),
    };
    let mut rendered = render_planned(inputs, &scene, &plan, progress, |k, pixels, _| {
        if options.format == VideoFormat::ExrSequence {
            frame.linear_rgb.clear();
            frame.linear_rgb.extend(pixels.iter().flatten());
        } else {
            frame.srgb8.resize(3 * pixels.len(), 0);
            plan.display_srgb8(&scene, k, pixels, &mut frame.srgb8);
        }
        writer.push(&frame)?;
        Ok(())
    })?;
    rendered.frames_written = writer.finish()?;
    Ok(rendered)
}

/// Render the frames of `plan` (from [`plan`] on `scene`, the scene of `inputs`), handing
/// each to `on_frame` with its global index, its linear RGB pixels (row-major, top row
/// first; what EXR frames hold) and the settings that encode it for display
/// ([`encode_srgb8`]; what PNG frames hold). The front ends that keep frames in memory
/// (the Python package) call this; [`render_to`] calls it with a video writer.
/// `frames_written` of the outcome counts the frames handed over.
pub fn render_planned(
    inputs: &RenderInputs,
    scene: &RenderScene,
    plan: &Plan,
    progress: &dyn Progress,
    mut on_frame: impl FnMut(usize, &[[f32; 3]], &RenderSettings) -> Result<(), StageError>,
) -> Result<Rendered, StageError> {
    let Plan {
        path,
        settings,
        frames,
        ..
    } = plan;
    let spec = path.spec();
    // Frames whose times miss the cube's light, predicted before rendering (a coarse probe
    // of each frame, render::coverage); the rendered black frames are counted below.
    progress.poll();
    let coverage = predict_coverage(scene, settings, path, frames.clone())?;
    progress.start("render", frames.len() as u64);
    let started = Instant::now();
    let mut black_frames = Vec::new();
    let mut done = 0u64;
    render_sequence::<StageError>(scene, settings, path, frames.clone(), |k, pixels| {
        if frame_is_black(pixels) {
            black_frames.push(k);
        }
        on_frame(k, pixels, settings)?;
        done += 1;
        progress.set(done);
        Ok(())
    })?;
    progress.finish();
    let mut warnings = inputs.notes.clone();
    if !black_frames.is_empty() {
        // Why, from the prediction when it saw it (with the offset that shows the light).
        let why: Vec<String> = coverage.to_string().lines().map(str::to_string).collect();
        let why = if why.is_empty() {
            let (t_a, t_b) = scene.world_span_ps();
            format!(
                "their world times miss the light of the cube ({t_a:.0} .. {t_b:.0} ps world \
                 time); the time offset was {:.1} ps, give --time-offset-ps or --dtau-ps to move \
                 the frames onto it",
                settings.time_offset_ps
            )
        } else {
            let hint = coverage
                .suggested_time_offset_ps()
                .map(|t| format!("; try --time-offset-ps {t:.0}"))
                .unwrap_or_default();
            format!("{}{hint}", why.join("; "))
        };
        warnings.push(format!(
            "{} of {} frames are entirely black ({}): {why}",
            black_frames.len(),
            frames.len(),
            describe_indices(&black_frames),
        ));
    }
    Ok(Rendered {
        frames: frames.clone(),
        frames_written: done as usize,
        width: spec.width,
        height: spec.height,
        seconds: started.elapsed().as_secs_f64(),
        black_frames,
        time_offset_ps: settings.time_offset_ps,
        dtau_ps: settings.dtau_ps,
        laser: inputs.laser.clone(),
        warnings,
    })
}

/// `0..4, 7, 9..12` for sorted indices.
fn describe_indices(idx: &[usize]) -> String {
    let mut parts = Vec::new();
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && idx[j + 1] == idx[j] + 1 {
            j += 1;
        }
        parts.push(if j > i {
            format!("{}..{}", idx[i], idx[j] + 1)
        } else {
            idx[i].to_string()
        });
        i = j + 1;
    }
    parts.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_runs_are_described_as_ranges() {
        assert_eq!(
            describe_indices(&[0, 1, 2, 3, 7, 9, 10, 11]),
            "0..4, 7, 9..12"
        );
        assert_eq!(describe_indices(&[5]), "5");
        assert_eq!(describe_indices(&[]), "");
    }
}

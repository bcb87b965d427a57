//! `femto render`: relativistic novel-view videos of a world-time cube (the library's
//! [`femto::render`]). Reads the cube, the calibration and the mesh, builds the camera path
//! (a TOML file or a shortcut), and writes PNG / EXR frame sequences, an MP4 or a GIF.
//!
//! ```text
//! femto render --cube world.h5 --calibration capture.toml --mesh scene.glb \
//!     --dolly 0.6 --size 640x480 --frame-count 120 --out dolly.mp4
//! femto render ... --path path.toml --frames 0..60 --format exr --out frames/   # job 1
//! femto render ... --path path.toml --frames 60..120 --format exr --out frames/ # job 2
//! ```
//!
//! The world-time cube's prefix sums come from the pyramid stored by `femto pyramid`: the
//! cube file's `pyramid` group, or the side file given with `--pyramid`
//! ([`femto::store::pyramid::read_pyramid_for`], refused when it was built from a cube of
//! another shape or time axis). A cube without one is read whole and its prefix sums are
//! built in memory (`Pyramid::build`, the same kernel), with a note saying so. Frame
//! sequences are numbered with the global frame index, so the parts of a split render land
//! side by side.

use anyhow::{anyhow, bail, Context};
use clap::{ArgGroup, Args};
use femto::camera::Calibration;
use femto::camera_path::{CameraPath, FrameSpec};
use femto::container;
use femto::cube::TimeFrame;
use femto::geometry::bvh::Bvh;
use femto::geometry::load::load_mesh;
use femto::pyramid::Pyramid;
use femto::relativity::Radiometry;
use femto::render::paths::{shortcut_path, Shortcut};
use femto::render::{
    auto_exposure, check_frames, check_path_clear, encode_srgb8, isochrone_range, render_sequence,
    Effects, Isochrones, RenderScene, RenderSettings, View,
};
use femto::store::pyramid::{self as stored_pyramid, read_pyramid_for};
use femto::video::{Frame, VideoFormat, VideoWriter};
use std::ops::Range;
use std::path::PathBuf;
use std::time::Instant;

/// Laser wavelength used when neither `--laser-nm` nor the cube says, nm.
const DEFAULT_LASER_NM: f64 = 670.0;
/// Cube attributes (provenance notes) that may hold the laser wavelength in nm.
const LASER_NM_NOTES: [&str; 3] = ["laser_nm", "laser_wavelength_nm", "laser.wavelength_nm"];

#[derive(Args, Debug)]
#[command(group(
    ArgGroup::new("camera")
        .required(true)
        .args(["path", "dolly", "orbit", "capture_view"])
))]
pub struct RenderArgs {
    /// World-time cube (HDF5, e.g. from the unwarp step).
    #[arg(long, value_name = "WORLD.h5")]
    pub cube: PathBuf,
    /// Pyramid side file of the cube (`femto pyramid CUBE --side-file PATH`). Default: the
    /// cube file's own `pyramid` group when it has one, else prefix sums built in memory.
    #[arg(long, value_name = "PYRAMID.h5")]
    pub pyramid: Option<PathBuf>,
    /// Calibration of the capture camera, laser spot and time origin (TOML).
    #[arg(long, value_name = "CAL.toml")]
    pub calibration: PathBuf,
    /// Scene geometry in world metres (.glb, .gltf or .obj).
    #[arg(long, value_name = "MESH")]
    pub mesh: PathBuf,
    /// Camera path file (TOML; frame size, count and interval from the file unless given).
    #[arg(long, value_name = "PATH.toml")]
    pub path: Option<PathBuf>,
    /// Straight dolly from the capture camera towards the scene at constant speed BETA
    /// (in units of c; negative backs away).
    #[arg(long, value_name = "BETA", allow_negative_numbers = true)]
    pub dolly: Option<f64>,
    /// Orbit about the scene through the capture camera's position at constant speed BETA
    /// (negative: clockwise seen from above).
    #[arg(long, value_name = "BETA", allow_negative_numbers = true)]
    pub orbit: Option<f64>,
    /// The capture camera's own view, at rest.
    #[arg(long)]
    pub capture_view: bool,
    /// Frame size (default 640x480, or the path file's).
    #[arg(long, value_name = "WxH")]
    pub size: Option<String>,
    /// Render only frames A..B (B excluded) of the sequence; identical to the same frames
    /// of a full render, numbered alike in frame sequences.
    #[arg(long, value_name = "A..B")]
    pub frames: Option<String>,
    /// Number of frames of the whole sequence (default 100, or the path file's).
    #[arg(long, value_name = "N")]
    pub frame_count: Option<usize>,
    /// Frame interval and exposure window in ps of camera proper time (default: the path
    /// file's; for the shortcuts, so that the frames sweep the cube's time span).
    #[arg(long, value_name = "PS")]
    pub dtau_ps: Option<f64>,
    /// World time of the path's time 0, ps after the pulse leaves the laser spot (default 0
    /// for a path file; for the shortcuts, when the target's first light reaches the camera).
    #[arg(long, value_name = "PS", allow_negative_numbers = true)]
    pub time_offset_ps: Option<f64>,
    /// Effects to apply: a comma-separated list of unwarp, aberration, doppler, searchlight,
    /// dilation, rotation; or all; or none.
    #[arg(long, value_name = "LIST", default_value = "all")]
    pub effects: String,
    /// consistent (physics.md: D^-3 over the window dtau/D) or paper (the seed's D^-5
    /// literally).
    #[arg(long, value_name = "MODE", default_value = "consistent")]
    pub radiometry: String,
    /// transient, naive (keeps the capture's time warp), isochrones (time of first arrival)
    /// or integrated (time-integrated image).
    #[arg(long, value_name = "VIEW", default_value = "transient")]
    pub view: String,
    /// Exposure multiplier relative to the automatic exposure (which puts the brightest
    /// 0.1 % of the capture at half of the display range).
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    pub exposure: f64,
    /// Laser wavelength in nm (default: the cube's `laser_nm` attribute, else 670).
    #[arg(long, value_name = "NM")]
    pub laser_nm: Option<f64>,
    /// Contour spacing of the isochrone view, ps (default: a round value giving 10 to 25
    /// contours over the frame's range).
    #[arg(long, value_name = "PS")]
    pub contour_ps: Option<f64>,
    /// Output format: png or exr (frame sequences in the folder --out), mp4 or gif (the file
    /// --out). Default: from the extension of --out, else png.
    #[arg(long, value_name = "FORMAT")]
    pub format: Option<String>,
    /// Output file (mp4, gif) or folder (png, exr sequences).
    #[arg(long, value_name = "PATH")]
    pub out: PathBuf,
    /// Frames per second of MP4 and GIF output.
    #[arg(long, value_name = "FPS", default_value_t = 30.0)]
    pub fps: f64,
    /// Worker threads (default: all cores).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
}

/// Largest frame side accepted, pixels.
const MAX_SIDE: usize = 16384;
/// Largest number of frames accepted.
const MAX_FRAMES: usize = 1_000_000;

/// `WxH` with both positive and at most [`MAX_SIDE`].
fn parse_size(text: &str) -> anyhow::Result<(usize, usize)> {
    let parsed = text.split_once(['x', 'X']).and_then(|(w, h)| {
        Some((
            w.trim().parse::<usize>().ok()?,
            h.trim().parse::<usize>().ok()?,
        ))
    });
    match parsed {
        Some((w, h)) if w > 0 && h > 0 && w <= MAX_SIDE && h <= MAX_SIDE => Ok((w, h)),
        Some((w, h)) if w > 0 && h > 0 => {
            bail!("--size {text}: each side must be at most {MAX_SIDE} pixels")
        }
        _ => bail!("--size {text}: expected WIDTHxHEIGHT with positive integers, e.g. 640x480"),
    }
}

/// `A..B` (B excluded).
fn parse_frames(text: &str) -> anyhow::Result<Range<usize>> {
    let parsed = text
        .split_once("..")
        .and_then(|(a, b)| Some(a.trim().parse::<usize>().ok()?..b.trim().parse::<usize>().ok()?));
    match parsed {
        Some(r) if r.start < r.end => Ok(r),
        _ => bail!("--frames {text}: expected A..B with A < B, frame B excluded, e.g. 0..50"),
    }
}

fn output_format(args: &RenderArgs) -> anyhow::Result<VideoFormat> {
    if let Some(f) = &args.format {
        return VideoFormat::parse(f).map_err(|e| anyhow!("--format {f}: {e}"));
    }
    match VideoFormat::from_path(&args.out) {
        Some(Ok(f)) => Ok(f),
        Some(Err(e)) => Err(anyhow!(
            "--out {}: {e}; name the format with --format",
            args.out.display()
        )),
        None => Ok(VideoFormat::PngSequence),
    }
}

/// The laser wavelength: the flag, else the cube's attribute, else 670 nm.
fn laser_wavelength(args: &RenderArgs, notes: &[(String, String)]) -> anyhow::Result<f64> {
    if let Some(nm) = args.laser_nm {
        if !(nm.is_finite() && nm > 0.0) {
            bail!("--laser-nm {nm}: must be a positive wavelength in nm");
        }
        return Ok(nm);
    }
    for (key, value) in notes {
        if LASER_NM_NOTES.contains(&key.as_str()) {
            return match value.trim().parse::<f64>() {
                Ok(nm) if nm.is_finite() && nm > 0.0 => Ok(nm),
                _ => bail!(
                    "--cube {}: attribute {key} = '{value}' is not a wavelength in nm; give --laser-nm",
                    args.cube.display()
                ),
            };
        }
    }
    Ok(DEFAULT_LASER_NM)
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    if let Some(n) = args.threads {
        if n == 0 {
            bail!("--threads 0: need at least one thread");
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(|e| anyhow!("--threads {n}: {e}"))?;
    }
    // Flags first: cheap to check, before any file is read.
    let size = args.size.as_deref().map(parse_size).transpose()?;
    let frames_flag = args.frames.as_deref().map(parse_frames).transpose()?;
    let effects =
        Effects::parse(&args.effects).map_err(|e| anyhow!("--effects {}: {e}", args.effects))?;
    let radiometry = match args.radiometry.as_str() {
        "consistent" => Radiometry::Consistent,
        "paper" => Radiometry::Paper,
        other => bail!("--radiometry {other}: expected consistent or paper"),
    };
    // Validated now; the isochrone range is resolved once the scene is loaded.
    View::parse(
        &args.view,
        Isochrones {
            t_min_ps: 0.0,
            t_max_ps: 1.0,
            contour_ps: 1.0,
        },
    )
    .map_err(|e| anyhow!("--view {}: {e}", args.view))?;
    let format = output_format(&args)?;
    if let Some(n) = args.frame_count {
        if n == 0 || n > MAX_FRAMES {
            bail!("--frame-count {n}: need between 1 and {MAX_FRAMES} frames");
        }
    }
    if let Some(d) = args.dtau_ps {
        if !(d.is_finite() && d > 0.0) {
            bail!("--dtau-ps {d}: must be a positive number of picoseconds");
        }
    }
    if !(args.exposure.is_finite() && args.exposure > 0.0) {
        bail!("--exposure {}: must be a positive number", args.exposure);
    }
    if !(args.fps.is_finite() && args.fps > 0.0) {
        bail!("--fps {}: must be a positive number", args.fps);
    }
    if let Some(c) = args.contour_ps {
        if !(c.is_finite() && c > 0.0) {
            bail!("--contour-ps {c}: must be a positive number");
        }
    }
    if let Some(t) = args.time_offset_ps {
        if !t.is_finite() {
            bail!("--time-offset-ps {t}: must be a finite number");
        }
    }
    for (flag, beta) in [("--dolly", args.dolly), ("--orbit", args.orbit)] {
        if let Some(b) = beta {
            if !(b.is_finite() && b.abs() < 1.0) {
                bail!("{flag} {b}: the camera must move slower than light (|beta| < 1)");
            }
        }
    }

    // Inputs.
    let calibration = Calibration::load(&args.calibration)
        .with_context(|| format!("--calibration {}", args.calibration.display()))?;
    let mesh = load_mesh(&args.mesh).with_context(|| format!("--mesh {}", args.mesh.display()))?;
    if mesh.triangles.is_empty() {
        bail!("--mesh {}: the mesh has no triangles", args.mesh.display());
    }
    let bvh = Bvh::new(mesh);
    let cube_ctx = || format!("--cube {}", args.cube.display());
    let meta = container::read_meta(&args.cube).with_context(cube_ctx)?;
    if meta.frame != TimeFrame::World {
        bail!(
            "--cube {}: the cube is in {} time; the renderer needs a world-time cube (unwarp it first)",
            args.cube.display(),
            meta.frame
        );
    }
    let laser_nm = laser_wavelength(&args, &meta.notes)?;
    // The note is printed once the inputs have passed every check (an error stays one line).
    let (pyramid, pyramid_note) = if let Some(side) = &args.pyramid {
        let p = read_pyramid_for(&args.cube, Some(side))
            .with_context(|| format!("--pyramid {}", side.display()))?;
        (p, None)
    } else if meta.groups.iter().any(|g| g == stored_pyramid::GROUP) {
        (
            read_pyramid_for(&args.cube, None).with_context(cube_ctx)?,
            None,
        )
    } else {
        let cube = container::read_cube(&args.cube).with_context(cube_ctx)?;
        let note = format!(
            "femto render: note: {} has no stored pyramid; its prefix sums were built in \
             memory (`femto pyramid {}` stores them once)",
            args.cube.display(),
            args.cube.display()
        );
        (Pyramid::build(&cube), Some(note))
    };
    let scene = RenderScene::new(&bvh, calibration, &pyramid, laser_nm).with_context(|| {
        format!(
            "--cube {} and --calibration {}",
            args.cube.display(),
            args.calibration.display()
        )
    })?;

    // Camera path.
    let (path, default_offset_ps, path_flag) = if let Some(p) = &args.path {
        let flag = format!("--path {}", p.display());
        let loaded = CameraPath::load(p).with_context(|| flag.clone())?;
        let spec = loaded.spec();
        let (width, height) = size.unwrap_or((spec.width, spec.height));
        let spec = FrameSpec {
            width,
            height,
            frames: args.frame_count.unwrap_or(spec.frames),
            dtau_ps: args.dtau_ps.unwrap_or(spec.dtau_ps),
        };
        let path = if spec == loaded.spec() {
            loaded
        } else {
            CameraPath::new(
                spec,
                Some(loaded.tau0_ps()),
                loaded.rotation(),
                loaded.motion().clone(),
                &p.display().to_string(),
            )
            .with_context(|| format!("{flag} with --size / --frame-count / --dtau-ps"))?
        };
        (path, 0.0, flag)
    } else {
        let (shortcut, flag) = if let Some(beta) = args.dolly {
            (Shortcut::Dolly { beta }, format!("--dolly {beta}"))
        } else if let Some(beta) = args.orbit {
            (Shortcut::Orbit { beta }, format!("--orbit {beta}"))
        } else {
            (Shortcut::CaptureView, "--capture-view".to_string())
        };
        let (width, height) = size.unwrap_or((640, 480));
        let s = shortcut_path(
            &scene,
            shortcut,
            width,
            height,
            args.frame_count.unwrap_or(100),
            args.dtau_ps,
        )
        .with_context(|| flag.clone())?;
        (s.path, s.time_offset_ps, flag)
    };
    let spec = path.spec();
    if spec.width > MAX_SIDE || spec.height > MAX_SIDE || spec.frames > MAX_FRAMES {
        bail!(
            "{path_flag}: {}x{} pixels and {} frames: at most {MAX_SIDE} pixels a side and {MAX_FRAMES} frames",
            spec.width,
            spec.height,
            spec.frames
        );
    }
    if format == VideoFormat::Mp4 && (spec.width % 2 == 1 || spec.height % 2 == 1) {
        bail!(
            "--size {}x{}: MP4 (H.264, 4:2:0) needs an even width and height; use --size {}x{} or another --format",
            spec.width,
            spec.height,
            spec.width + spec.width % 2,
            spec.height + spec.height % 2
        );
    }
    check_path_clear(&bvh, &path).with_context(|| path_flag.clone())?;
    let frames = frames_flag.unwrap_or(0..spec.frames);
    check_frames(&path, &frames)
        .map_err(|e| anyhow!("--frames {}..{}: {e}", frames.start, frames.end))?;

    // Settings.
    let mut settings = RenderSettings::for_path(&path);
    settings.effects = effects;
    settings.radiometry = radiometry;
    settings.time_offset_ps = args.time_offset_ps.unwrap_or(default_offset_ps);
    settings.view = View::parse(
        &args.view,
        Isochrones {
            t_min_ps: 0.0,
            t_max_ps: 1.0,
            contour_ps: 1.0,
        },
    )?;
    if let View::Isochrones(_) = settings.view {
        settings.view =
            View::Isochrones(isochrone_range(&scene, &settings, &path, args.contour_ps));
    }
    settings.exposure = args.exposure * auto_exposure(&scene, &settings.view);

    // Output.
    let mut writer = VideoWriter::create(&args.out, format, spec.width, spec.height, args.fps)
        .with_context(|| format!("--out {}", args.out.display()))?
        .first_frame_index(frames.start);
    if let Some(note) = pyramid_note {
        eprintln!("{note}");
    }
    let bar = super::progress(frames.len() as u64, "render");
    let started = Instant::now();
    let mut frame = Frame {
        width: spec.width,
        height: spec.height,
        linear_rgb: Vec::new(),
        srgb8: Vec::new(),
    };
    let out_ctx = || format!("--out {}", args.out.display());
    render_sequence::<anyhow::Error>(&scene, &settings, &path, frames.clone(), |_, pixels| {
        if format == VideoFormat::ExrSequence {
            frame.linear_rgb.clear();
            frame.linear_rgb.extend(pixels.iter().flatten());
        } else {
            frame.srgb8.resize(3 * pixels.len(), 0);
            encode_srgb8(&settings, pixels, &mut frame.srgb8);
        }
        writer.push(&frame).with_context(out_ctx)?;
        bar.inc(1);
        Ok(())
    })?;
    let written = writer.finish().with_context(out_ctx)?;
    bar.finish_and_clear();
    let secs = started.elapsed().as_secs_f64();
    eprintln!(
        "femto render: {written} frames ({}..{}) of {}x{} to {} ({}) in {secs:.2} s, {:.1} frames/s",
        frames.start,
        frames.end,
        spec.width,
        spec.height,
        args.out.display(),
        format,
        written as f64 / secs.max(1e-9)
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_and_frame_ranges_parse_and_errors_name_the_flag() {
        assert_eq!(parse_size("640x480").unwrap(), (640, 480));
        assert_eq!(parse_size("64X48").unwrap(), (64, 48));
        for bad in ["640", "0x10", "ax4", "10x-2", "100000x10"] {
            assert!(parse_size(bad).unwrap_err().to_string().contains("--size"));
        }
        assert_eq!(parse_frames("3..9").unwrap(), 3..9);
        for bad in ["3..3", "9..3", "3-9", "..4"] {
            assert!(parse_frames(bad)
                .unwrap_err()
                .to_string()
                .contains("--frames"));
        }
    }

    #[test]
    fn laser_wavelength_comes_from_flag_then_attribute_then_default() {
        let args = |nm: Option<f64>| RenderArgs {
            cube: "c.h5".into(),
            pyramid: None,
            calibration: "c.toml".into(),
            mesh: "m.obj".into(),
            path: None,
            dolly: None,
            orbit: None,
            capture_view: true,
            size: None,
            frames: None,
            frame_count: None,
            dtau_ps: None,
            time_offset_ps: None,
            effects: "all".into(),
            radiometry: "consistent".into(),
            view: "transient".into(),
            exposure: 1.0,
            laser_nm: nm,
            contour_ps: None,
            format: None,
            out: "o".into(),
            fps: 30.0,
            threads: None,
        };
        let notes = vec![("laser_nm".to_string(), "532".to_string())];
        assert_eq!(laser_wavelength(&args(Some(800.0)), &notes).unwrap(), 800.0);
        assert_eq!(laser_wavelength(&args(None), &notes).unwrap(), 532.0);
        assert_eq!(
            laser_wavelength(&args(None), &[]).unwrap(),
            DEFAULT_LASER_NM
        );
        let bad = vec![("laser_nm".to_string(), "red".to_string())];
        assert!(laser_wavelength(&args(None), &bad)
            .unwrap_err()
            .to_string()
            .contains("--laser-nm"));
        assert!(laser_wavelength(&args(Some(-1.0)), &[]).is_err());
    }
}

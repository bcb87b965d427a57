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
//! side by side. Flags map onto [`femto::pipeline::render::RenderOptions`]; the stage is
//! [`femto::pipeline::render`].

use super::values::{
    EffectsArg, EnumArg, FrameRange, RadiometryArg, Size, VideoFormatArg, ViewArg,
};
use anyhow::anyhow;
use clap::{ArgGroup, Args};
use femto::pipeline::render::{render_to, Camera, RenderOptions};
use femto::render::paths::Shortcut;
use femto::render::Effects;
use femto::video::VideoFormat;
use std::path::PathBuf;

#[derive(Args, Debug)]
#[command(group(
    ArgGroup::new("camera")
        .required(true)
        .args(["path", "dolly", "orbit", "capture_view"])
))]
pub struct RenderArgs {
    #[command(flatten)]
    pub inputs: super::render_inputs::RenderInputArgs,
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
    pub size: Option<Size>,
    /// Render only frames A..B (B excluded) of the sequence; identical to the same frames
    /// of a full render, numbered alike in frame sequences.
    #[arg(long, value_name = "A..B")]
    pub frames: Option<FrameRange>,
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
    #[arg(long, value_name = "LIST", default_value = "all", value_parser = EffectsArg)]
    pub effects: Effects,
    /// Radiometry of a moving camera: consistent (radiance times D^-3, accumulated over the
    /// exposure window dtau/D: docs/physics.md) or paper (Jarabo et al. 2013's D^-5,
    /// literally, which counts one factor of D twice).
    #[arg(long, value_name = "MODE", value_enum, default_value_t = RadiometryArg::Consistent)]
    pub radiometry: RadiometryArg,
    /// What a frame shows: transient, naive (keeps the capture's time warp), isochrones
    /// (time of first arrival) or integrated (time-integrated image).
    #[arg(long, value_name = "VIEW", default_value = "transient", ignore_case = true,
          value_parser = EnumArg::<ViewArg>::new())]
    pub view: ViewArg,
    /// Exposure multiplier relative to the automatic exposure, which shows the log-average
    /// of the capture's lit bins (those more than 5 robust sigmas above its noise floor) at
    /// mid-grey (luminance 0.18) and its brightest 0.1 % between luminance 1 and 16 (0.5 and
    /// 0.94 of the display range), so that weak late light (echoes, multi-bounce) shows
    /// beside the direct pulse.
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    pub exposure: f64,
    /// Contour spacing of the isochrone view, ps (default: a round value giving 10 to 25
    /// contours over the frame's range).
    #[arg(long, value_name = "PS")]
    pub contour_ps: Option<f64>,
    /// Draw the kinds of dark apart in PNG, MP4 and GIF frames: points the capture camera
    /// never saw as a grey diagonal hatch, pixels `femto unwarp` masked as mixed as a violet
    /// cross-hatch; no light now, and no surface, stay black (as `femto view` draws them).
    #[arg(long)]
    pub dark_marks: bool,
    /// Draw the received light in false colour relative to the laser: the laser's own
    /// wavelength green (550 nm), light received at D times it in the colour of D x 550 nm,
    /// so an infrared or ultraviolet laser shows its Doppler shifts in colour (without it,
    /// light outside 380-780 nm is drawn grey).
    #[arg(long)]
    pub false_colour: bool,
    /// Output format: png or exr (frame sequences in the folder --out), mp4 or gif (the file
    /// --out). Default: from the extension of --out, else png.
    #[arg(long, value_name = "FORMAT", ignore_case = true,
          value_parser = EnumArg::<VideoFormatArg>::extension())]
    pub format: Option<VideoFormatArg>,
    /// Output file (mp4, gif) or folder (png, exr sequences).
    #[arg(long, value_name = "PATH")]
    pub out: PathBuf,
    /// Frames per second of MP4 and GIF output.
    #[arg(long, value_name = "FPS", default_value_t = 30.0)]
    pub fps: f64,
    /// Replace existing output: the video file, or the frame files this render writes
    /// (without it, they are refused; frames of other --frames ranges are kept).
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub threads: super::threads::ThreadsArg,
}

fn output_format(args: &RenderArgs) -> anyhow::Result<VideoFormat> {
    if let Some(f) = args.format {
        return Ok(f.into());
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

/// The flags as the render stage's options (every flag checked before a file is read).
fn options(args: &RenderArgs) -> anyhow::Result<(Camera, RenderOptions)> {
    let camera = if let Some(p) = &args.path {
        Camera::PathFile(p.clone())
    } else if let Some(beta) = args.dolly {
        Camera::Shortcut(Shortcut::Dolly { beta })
    } else if let Some(beta) = args.orbit {
        Camera::Shortcut(Shortcut::Orbit { beta })
    } else {
        Camera::Shortcut(Shortcut::CaptureView)
    };
    femto::pipeline::render::check_camera(&camera)?;
    let options = RenderOptions {
        size: args.size.map(Size::pair),
        frame_count: args.frame_count,
        frames: args.frames.clone().map(|f| f.0),
        dtau_ps: args.dtau_ps,
        time_offset_ps: args.time_offset_ps,
        effects: args.effects,
        radiometry: args.radiometry.into(),
        view: args.view.into(),
        exposure: args.exposure,
        contour_ps: args.contour_ps,
        format: output_format(args)?,
        fps: args.fps,
        force: args.force,
        dark_marks: args.dark_marks,
        false_colour: args.false_colour,
    };
    Ok((camera, options))
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    args.threads.init()?;
    let (camera, options) = options(&args)?;
    femto::pipeline::render::check_options(&options)?;
    let inputs = args.inputs.open()?;
    let mut input_paths = args.inputs.paths();
    input_paths.extend(args.path.as_deref());
    let done = render_to(
        &inputs,
        &camera,
        &options,
        &args.out,
        &input_paths,
        &super::Bar::default(),
    )?;
    for w in &done.warnings {
        eprintln!("femto render: warning: {w}");
    }
    eprintln!(
        "femto render: {} frames ({}..{}) of {}x{} to {} ({}) in {:.2} s, {:.1} frames/s; laser {}; \
         frame interval {:.3} ps, time offset {:.1} ps",
        done.frames_written,
        done.frames.start,
        done.frames.end,
        done.width,
        done.height,
        args.out.display(),
        options.format,
        done.seconds,
        done.frames_written as f64 / done.seconds.max(1e-9),
        done.laser,
        done.dtau_ps,
        done.time_offset_ps
    );
    Ok(())
}

//! `femto simulate --truth-path`: the direct truth of a moving camera
//! ([`crate::render::truth`]) written into the capture folder it belongs to, as `truth/`
//! frames that `femto render` of the same capture should reproduce.
//!
//! The truth is resolved exactly as `femto render --cube DIR/truth_world.h5 --calibration
//! DIR/calibration.toml --mesh DIR/scene.glb --path PATH` resolves its render
//! ([`super::render::plan`]: the path file, its frame size, count and interval, the time
//! offset, the effects, the radiometry and the automatic exposure of that cube), so that the
//! two sets of frames differ only in how each pixel's light is found: traced here, looked up
//! in the capture there. The frames are written into the capture's temporary folder before
//! it is put in place: a capture with a truth path has its truth, or nothing is written.

use super::render::{self as render_stage, open_render_inputs, Camera, RenderOptions};
use super::{StageError, StageOption};
use crate::camera_path::CameraPath;
use crate::geometry::bvh::Bvh;
use crate::render::truth::{
    render_truth_frame, TruthOptions, TruthScene, TruthStats, TruthSummary,
};
use crate::render::{check_frames, check_path_clear, encode_srgb8};
use crate::scene::Scene;
use crate::video::{sequence_file_name, write_exr, write_png, VideoFormat};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The folder of the truth frames inside the capture folder.
pub const TRUTH_DIR: &str = "truth";

/// What `--truth-path` and the render flags beside it ask for.
#[derive(Clone, Debug, PartialEq)]
pub struct TruthRequest {
    /// `--truth-path`: the camera path file (the format `femto render --path` reads).
    pub path: PathBuf,
    /// `--truth-spp`: paths per pixel of the truth; None: the capture's `--spp`.
    pub spp: Option<u32>,
    /// The render flags (`--frames`, `--effects`, `--radiometry`, `--exposure`,
    /// `--time-offset-ps`); the view is always the transient one.
    pub options: RenderOptions,
}

/// A render error in the words of `femto simulate`: the path file named by `--truth-path`.
fn named(e: StageError) -> StageError {
    match e {
        StageError::Option {
            name: StageOption::Path,
            message,
        } => StageError::Input {
            path: "--truth-path".into(),
            message,
        },
        other => other,
    }
}

/// Check a truth request against `scene` before the capture is traced: the render options,
/// the path file, its frames, that it keeps clear of the geometry and below the speed of
/// light in the scene's medium. What needs the capture (the exposure) is resolved later.
pub fn check_truth(req: &TruthRequest, scene: &Scene, bvh: &Bvh) -> Result<(), StageError> {
    render_stage::check_options(&req.options)?;
    let name = req.path.display().to_string();
    let path_error = |message: String| StageError::Input {
        path: "--truth-path".into(),
        message,
    };
    let loaded = CameraPath::load(&req.path).map_err(|e| path_error(e.to_string()))?;
    let path = render_stage::with_frame_spec(loaded, &req.options, &name).map_err(named)?;
    let frames = req.options.frames.clone().unwrap_or(0..path.spec().frames);
    check_frames(&path, &frames).map_err(|e| StageError::Option {
        name: StageOption::Frames,
        message: format!("{}..{}: {e}", frames.start, frames.end),
    })?;
    check_path_clear(bvh, &path).map_err(|e| path_error(format!("{name}: {e}")))?;
    render_stage::check_medium_speed(&path, frames, scene.eta)
        .map_err(|e| path_error(format!("{name}: {e}")))?;
    Ok(())
}

/// Render the truth of `req` into `dir/truth` as `frame_NNNNN.exr` (scene-linear) and
/// `frame_NNNNN.png` (exposed and tone mapped like `femto render`'s). `dir` is the capture
/// folder being written (it holds `truth_world.h5`, `calibration.toml` and `scene.glb`);
/// `scene` and `bvh` are the scene it was traced from. `on_frame` is called after each frame.
pub fn stage_truth(
    scene: &Scene,
    bvh: &Bvh,
    req: &TruthRequest,
    opts: TruthOptions,
    dir: &Path,
    on_frame: &dyn Fn(),
) -> Result<TruthSummary, StageError> {
    let inputs = open_render_inputs(
        &dir.join("truth_world.h5"),
        None,
        render_stage::SceneGeometry::Files {
            calibration: &dir.join("calibration.toml"),
            mesh: &dir.join("scene.glb"),
        },
        Some(scene.laser.wavelength_nm),
    )?;
    let render_scene = inputs.scene()?;
    let options = RenderOptions {
        view: render_stage::ViewKind::Transient,
        ..req.options.clone()
    };
    let plan = render_stage::plan(&render_scene, &Camera::PathFile(req.path.clone()), &options)
        .map_err(named)?;
    let truth = TruthScene::new(scene, bvh, opts);
    let out = dir.join(TRUTH_DIR);
    std::fs::create_dir_all(&out).map_err(|source| StageError::Io {
        path: out.display().to_string(),
        source,
    })?;
    let (w, h) = (plan.settings.width, plan.settings.height);
    let mut pixels = vec![[0.0f32; 3]; w * h];
    let mut srgb8 = vec![0u8; 3 * w * h];
    let mut linear = Vec::with_capacity(3 * w * h);
    let mut stats = TruthStats::default();
    let started = Instant::now();
    for k in plan.frames.clone() {
        let s = render_truth_frame(&truth, &plan.settings, &plan.path.frame(k), &mut pixels);
        stats.paths += s.paths;
        stats.rays += s.rays;
        linear.clear();
        linear.extend(pixels.iter().flatten());
        write_exr(
            &out.join(sequence_file_name(k, VideoFormat::ExrSequence)),
            &linear,
            w,
            h,
        )?;
        encode_srgb8(&plan.settings, &pixels, &mut srgb8);
        write_png(
            &out.join(sequence_file_name(k, VideoFormat::PngSequence)),
            &srgb8,
            w,
            h,
        )?;
        on_frame();
    }
    Ok(TruthSummary {
        frames: plan.frames.clone(),
        width: w,
        height: h,
        spp: opts.spp,
        stats,
        seconds: started.elapsed().as_secs_f64(),
        exposure: plan.settings.exposure,
    })
}

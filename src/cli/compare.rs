//! `femto compare`: the image-based renderer's error against its traced truth, frame by
//! frame (library: [`femto::render::ibr_error`]; docs/truth.md).
//!
//! ```text
//! femto simulate --scene cube --truth-path orbit.toml --out cap
//! femto render --cube cap/truth_world.h5 --calibration cap/calibration.toml \
//!     --mesh cap/scene.glb --path orbit.toml --format exr --out ibr
//! femto compare --truth cap/truth --render ibr --out errors
//! ```

use anyhow::{anyhow, Context};
use clap::Args;
use femto::render::ibr_error::{compare_frame, pooled, LinearFrame, Scale};
use femto::video::{read_exr, sequence_file_name, Frame, VideoFormat, VideoWriter};
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// Folder of the truth's EXR frames (`femto simulate --truth-path`'s DIR/truth).
    #[arg(long, value_name = "DIR")]
    pub truth: PathBuf,
    /// Folder of the render's EXR frames of the same path (`femto render --format exr`).
    #[arg(long, value_name = "DIR")]
    pub render: PathBuf,
    /// Write each frame's error image here (frame_NNNNN.png: red where the render is
    /// brighter than the truth, blue where darker, as the square root of the luminance
    /// difference over the truth's 99.5th percentile).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Exposure multiplier of both display images for the PSNR, relative to the automatic
    /// exposure (its rule applied to the truth's pixels), as `femto render --exposure` and
    /// `femto view`'s Exposure (2^stops) [default: 1].
    #[arg(long, value_name = "X")]
    pub exposure: Option<f64>,
    /// Replace --out's frames if they exist.
    #[arg(long)]
    pub force: bool,
}

/// The frame numbers of the EXR frames `frame_NNNNN.exr` in `dir`, sorted.
fn exr_frames(dir: &Path, flag: &str) -> anyhow::Result<Vec<usize>> {
    let entries = std::fs::read_dir(dir).with_context(|| format!("--{flag} {}", dir.display()))?;
    let mut frames = Vec::new();
    for entry in entries {
        let name = entry
            .with_context(|| format!("--{flag} {}", dir.display()))?
            .file_name();
        let name = name.to_string_lossy();
        if let Some(n) = name
            .strip_prefix("frame_")
            .and_then(|s| s.strip_suffix(".exr"))
            .filter(|s| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()))
            .and_then(|s| s.parse().ok())
        {
            frames.push(n);
        }
    }
    frames.sort_unstable();
    Ok(frames)
}

fn read_frame(dir: &Path, k: usize) -> anyhow::Result<LinearFrame> {
    let path = dir.join(sequence_file_name(k, VideoFormat::ExrSequence));
    let (width, height, rgb) = read_exr(&path)?;
    if let Some(p) = rgb.iter().flatten().find(|v| !v.is_finite()) {
        return Err(anyhow!("{}: a pixel value is {p}", path.display()));
    }
    Ok(LinearFrame { width, height, rgb })
}

pub fn run(args: CompareArgs) -> anyhow::Result<()> {
    if let Some(x) = args.exposure {
        if !(x.is_finite() && x > 0.0) {
            return Err(anyhow!("--exposure {x}: must be a positive number"));
        }
    }
    let truth_frames = exr_frames(&args.truth, "truth")?;
    let render_frames = exr_frames(&args.render, "render")?;
    let common: Vec<usize> = truth_frames
        .iter()
        .copied()
        .filter(|k| render_frames.binary_search(k).is_ok())
        .collect();
    if common.is_empty() {
        return Err(anyhow!(
            "--truth {} and --render {}: no EXR frame (frame_NNNNN.exr) is in both",
            args.truth.display(),
            args.render.display()
        ));
    }
    if let Some(out) = &args.out {
        let inputs = [args.truth.as_path(), args.render.as_path()];
        femto::pipeline::refuse_same_file(out, &inputs, "out")?;
        if common.windows(2).any(|w| w[1] != w[0] + 1) {
            return Err(anyhow!(
                "--out {}: the frames both folders hold are not consecutive ({:?}); compare \
                 without --out or complete the frames",
                out.display(),
                common
            ));
        }
        let names = common
            .iter()
            .map(|&k| out.join(sequence_file_name(k, VideoFormat::PngSequence)));
        femto::pipeline::overwrite::refuse_existing_any(names, args.force, "out")?;
    }
    let mut truth = Vec::with_capacity(common.len());
    let mut render = Vec::with_capacity(common.len());
    for &k in &common {
        let (t, r) = (read_frame(&args.truth, k)?, read_frame(&args.render, k)?);
        if (t.width, t.height) != (r.width, r.height) {
            return Err(anyhow!(
                "frame {k}: the truth is {}x{} pixels, the render {}x{}",
                t.width,
                t.height,
                r.width,
                r.height
            ));
        }
        truth.push(t);
        render.push(r);
    }
    let refs: Vec<&LinearFrame> = truth.iter().collect();
    let Some(scale) = Scale::of_truth(&refs, args.exposure) else {
        return Err(anyhow!(
            "--truth {}: every truth frame is black; nothing to compare against",
            args.truth.display()
        ));
    };
    let mut writer = match &args.out {
        Some(out) => Some(
            VideoWriter::create(
                out,
                VideoFormat::PngSequence,
                truth[0].width,
                truth[0].height,
                30.0,
            )?
            .first_frame_index(common[0]),
        ),
        None => None,
    };
    println!(
        "lit: luminance >= {:.4e} (1 % of the truth's 99.5th percentile {:.4e}); display \
         exposure {:.4e}",
        scale.lit, scale.reference, scale.exposure
    );
    println!("frame  lit_truth  lit_render  rel_L1   holes   ghosts  PSNR_dB");
    let mut errors = Vec::with_capacity(common.len());
    for ((k, t), r) in common.iter().zip(&truth).zip(&render) {
        let (e, image) = compare_frame(t, r, &scale);
        println!(
            "{k:5}  {:9}  {:10}  {:6.4}  {:6.4}  {:6.4}  {:7.2}",
            e.lit_truth, e.lit_render, e.rel_l1, e.holes, e.ghosts, e.psnr_db
        );
        if let Some(w) = writer.as_mut() {
            w.push(&Frame {
                width: t.width,
                height: t.height,
                linear_rgb: Vec::new(),
                srgb8: image,
            })?;
        }
        errors.push(e);
    }
    let (l1, holes, ghosts, psnr) = pooled(&errors);
    println!(
        "all    {:9}  {:10}  {l1:6.4}  {holes:6.4}  {ghosts:6.4}  {psnr:7.2}",
        errors.iter().map(|e| e.lit_truth).sum::<usize>(),
        errors.iter().map(|e| e.lit_render).sum::<usize>(),
    );
    if let Some(w) = writer {
        w.finish()?;
    }
    Ok(())
}

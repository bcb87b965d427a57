//! `femto encode`: one MP4 or GIF from the PNG frame sequences of a split render
//! (`femto render --frames A..B --format png`, one folder per part), identical to the file
//! one `femto render --out video.mp4` writes (library: [`femto::video::encode`]).
//!
//! ```text
//! femto render ... --frames 0..60 --format png --out part0/    # job 1
//! femto render ... --frames 60..120 --format png --out part1/  # job 2
//! femto encode part0 part1 --out video.mp4
//! ```

use anyhow::anyhow;
use clap::Args;
use femto::video::encode::encode_sequences;
use femto::video::VideoFormat;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct EncodeArgs {
    /// Folders of PNG frames (frame_NNNNN.png, numbered as the whole render numbers them),
    /// in any order; together they must hold frames A..B once each.
    #[arg(required = true, value_name = "FRAMES_DIR")]
    pub frames: Vec<PathBuf>,
    /// The video file: .mp4 or .gif.
    #[arg(long, value_name = "PATH")]
    pub out: PathBuf,
    /// Frames per second (as given to femto render).
    #[arg(long, value_name = "FPS", default_value_t = 30.0)]
    pub fps: f64,
    /// Replace --out if it exists (without it, an existing --out is refused).
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: EncodeArgs) -> anyhow::Result<()> {
    let format = match VideoFormat::from_path(&args.out) {
        Some(Ok(f @ (VideoFormat::Mp4 | VideoFormat::Gif))) => f,
        _ => {
            return Err(anyhow!(
                "--out {}: name an .mp4 or .gif file",
                args.out.display()
            ))
        }
    };
    let inputs: Vec<&std::path::Path> = args.frames.iter().map(PathBuf::as_path).collect();
    femto::pipeline::overwrite::refuse_existing(&args.out, &inputs, args.force, "out")?;
    let started = std::time::Instant::now();
    let done = encode_sequences(&args.frames, &args.out, format, args.fps)?;
    eprintln!(
        "femto encode: frames {}..{} of {}x{} to {} ({format}) in {:.2} s",
        done.frames.start,
        done.frames.end,
        done.width,
        done.height,
        args.out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

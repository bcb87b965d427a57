//! Videos saved from the page (`POST /api/video?format=mp4|gif`, docs/view.md "Save"): the
//! page's keyframes as the camera path [`export_path`] writes, rendered by the render stage
//! exactly as `femto render --path PATH.toml --format mp4` renders that file ([`plan`],
//! [`render_planned`], [`crate::video::VideoWriter`]), encoded in memory
//! ([`VideoWriter::in_memory`]: the server never touches the file system). One video renders
//! at a time; its progress is read from `GET /api/video` while the request that renders it
//! is still open.

use super::keyframes::export_path;
use super::session::{ViewError, ViewSession};
use super::state::{bad, ViewState};
use crate::camera_path::CameraPath;
use crate::pipeline::render::{plan, render_planned, Camera};
use crate::pipeline::Progress;
use crate::video::{Frame, VideoError, VideoFormat, VideoWriter};
use serde::Serialize;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Progress of the video being rendered, as `GET /api/video` reports it.
#[derive(Debug, Default)]
pub struct VideoProgress {
    running: AtomicBool,
    done: AtomicU64,
    total: AtomicU64,
}

/// What `GET /api/video` answers.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct VideoStatus {
    pub running: bool,
    pub frames_done: u64,
    pub frames: u64,
}

impl VideoProgress {
    pub fn status(&self) -> VideoStatus {
        VideoStatus {
            running: self.running.load(Ordering::SeqCst),
            frames_done: self.done.load(Ordering::SeqCst),
            frames: self.total.load(Ordering::SeqCst),
        }
    }
}

impl Progress for VideoProgress {
    fn start(&self, _what: &str, len: u64) {
        self.total.store(len, Ordering::SeqCst);
        self.done.store(0, Ordering::SeqCst);
    }

    fn set(&self, done: u64) {
        self.done.store(done, Ordering::SeqCst);
    }
}

/// Clears the running flag however the render ends.
struct Running<'p>(&'p VideoProgress);

impl Drop for Running<'_> {
    fn drop(&mut self) {
        self.0.running.store(false, Ordering::SeqCst);
    }
}

/// The video formats the page saves: MP4 and GIF.
pub fn parse_video_format(name: &str) -> Result<VideoFormat, String> {
    match name {
        "mp4" => Ok(VideoFormat::Mp4),
        "gif" => Ok(VideoFormat::Gif),
        _ => Err(format!("format={name}: the page saves mp4 or gif")),
    }
}

impl ViewSession<'_> {
    /// Render the camera path through `keyframes` (with the first keyframe's render
    /// settings) as a video of `format`; its bytes.
    pub fn video(
        &self,
        keyframes: &[ViewState],
        format: VideoFormat,
    ) -> Result<Vec<u8>, ViewError> {
        let progress = self.video_progress();
        if progress.running.swap(true, Ordering::SeqCst) {
            return Err(bad(
                "video",
                "a video is being rendered already; wait for it".into(),
            )
            .into());
        }
        let _running = Running(progress);
        progress.start("video", 0);
        for (i, k) in keyframes.iter().enumerate() {
            k.check()
                .map_err(|e| bad(&format!("keyframes[{i}].{}", e.field), e.message))?;
        }
        let text = export_path(keyframes, &self.info().render_inputs)?;
        let path = CameraPath::from_toml(&text, "the keyframes' path")
            .map_err(|e| bad("keyframes", e.to_string()))?;
        let first = keyframes.first().expect("export_path refuses no keyframes");
        let options = crate::pipeline::render::RenderOptions {
            format,
            ..first.render_options()
        };
        let name = format!("femto-path.{}", format.as_str());
        let encode = |e: VideoError| ViewError::Encode(e.to_string());
        self.with_scene(first.laser_nm, |scene| -> Result<Vec<u8>, ViewError> {
            let camera = Camera::Path {
                path: Box::new(path),
                name: "the keyframes' path".into(),
            };
            let planned = plan(scene, &camera, &options)?;
            let spec = planned.path.spec();
            let mut writer =
                VideoWriter::in_memory(&name, format, spec.width, spec.height, options.fps)
                    .map_err(encode)?;
            let mut frame = Frame {
                width: spec.width,
                height: spec.height,
                linear_rgb: Vec::new(),
                srgb8: vec![0u8; 3 * spec.width * spec.height],
            };
            render_planned(self.inputs(), scene, &planned, progress, |k, pixels, _| {
                planned.display_srgb8(scene, k, pixels, &mut frame.srgb8);
                writer.push(&frame)?;
                Ok(())
            })?;
            Ok(writer.finish_bytes().map_err(encode)?.1)
        })
    }
}

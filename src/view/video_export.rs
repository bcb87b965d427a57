//! Videos saved from the page (`POST /api/video?format=mp4|gif`, docs/view.md "Save"): the
//! page's keyframes as the camera path [`export_path`] writes, rendered by the render stage
//! exactly as `femto render --path PATH.toml --format mp4` renders that file ([`plan`],
//! [`render_planned`], [`crate::video::VideoWriter`]), encoded in memory
//! ([`VideoWriter::in_memory`]: the server never touches the file system). One video renders
//! at a time; its progress is read from `GET /api/video` while the request that renders it
//! is still open.

use super::keyframes::export_path;
use super::progress::Running;
use super::session::{ViewError, ViewSession};
use super::state::{bad, ViewState};
use crate::camera_path::CameraPath;
use crate::pipeline::render::{plan, render_planned, Camera};
use crate::video::{Frame, VideoError, VideoFormat, VideoWriter};

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
        let Some(_running) = Running::start(progress) else {
            return Err(bad(
                "video",
                "a video is being rendered already; wait for it".into(),
            )
            .into());
        };
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

//! The progress of the video being saved from the page, as `GET /api/video` reports it
//! ([`super::video_export`] renders it).

use crate::pipeline::Progress;
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

/// The running flag of a video render, cleared however the render ends.
pub struct Running<'p>(&'p VideoProgress);

impl<'p> Running<'p> {
    /// Mark a render as running and its progress as none yet; None when one already is.
    pub fn start(progress: &'p VideoProgress) -> Option<Running<'p>> {
        if progress.running.swap(true, Ordering::SeqCst) {
            return None;
        }
        progress.start("video", 0);
        Some(Running(progress))
    }
}

impl Drop for Running<'_> {
    fn drop(&mut self) {
        self.0.running.store(false, Ordering::SeqCst);
    }
}

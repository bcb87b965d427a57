//! femto: a toolkit for femto-photography (transient imaging of light in flight).
//!
//! The library holds every algorithm; the `femto` binary only parses flags, opens files,
//! draws progress bars and calls into it. Conventions (units, clocks, signs) follow
//! `physics.md`: lengths in metres, times in picoseconds, camera frame x right / y down /
//! z forward, pixel `(x, y)` covering `[x, x+1) x [y, y+1)` with its centre at `(x+0.5, y+0.5)`.

pub mod atomic;
pub mod calibrate;
pub mod camera;
pub mod camera_path;
pub mod color;
pub mod container;
pub mod cube;
pub mod demo;
pub mod formats;
pub mod geometry;
pub mod ingest;
pub mod interrupt;
pub mod limits;
pub mod manifest;
pub mod pipeline;
pub mod pyramid;
pub mod relativity;
pub mod render;
pub mod resample;
pub mod scene;
pub mod simulate;
pub mod store;
pub mod tracer;
pub mod units;
pub mod unwarp;
pub mod video;

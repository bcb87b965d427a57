//! Ingest of real streak-camera captures: from one streak image per scanline to a calibrated
//! x-y-t [`Cube`](crate::cube::Cube).
//!
//! [`corrections`] holds the per-scanline correction kernels (dark, flat, sweep linearity,
//! time jitter, laser power, saturation); the readers and the assembly of a cube come on top.

pub mod corrections;

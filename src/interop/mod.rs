//! Interoperability with the field's Python tools: y-tal captures both ways and
//! mitransient's transient renders in.
//!
//! | module | what it holds |
//! |---|---|
//! | [`tal`] | a y-tal capture in memory ([`tal::TalCapture`]) and its conversion to and from a cube with its geometry ([`tal::TalGeometry`]: sensor grid, laser origin and spot) |
//! | `tal_file` | y-tal's HDF5 layout (`tal.io.read_capture`'s `HDF5_TAL`): [`read_tal`], [`write_tal`], [`is_tal_capture`] |
//! | [`mitransient`] | mitransient's transient array `(H, W, T, C)` in optical path length into a cube, colour channels collapsed as asked |
//! | [`wall_view`] | a capture camera and a wall mesh for a cube that knows only its wall grid (what `femto render` uses without `--calibration` and `--mesh`) |
//! | `stage` | the stages `femto export` and `femto ingest` call: [`export_tal`], [`ingest_tal`], [`ingest_mitransient`] |
//!
//! Clocks (physics.md, "Units and clocks"): y-tal and mitransient bin light by optical path
//! length in metres; femto by picoseconds, `t_ps = opl_m / c` with `c` =
//! [`crate::units::C_M_PER_PS`]. femto's world time, measured from the pulse leaving the
//! laser spot, is y-tal's `t_accounts_first_and_last_bounces = False`; femto's camera time
//! adds the last bounce (surface point to sensor), y-tal's `True` adds the first bounce as well
//! (laser origin to spot), which the conversions add or remove with the laser origin.

pub mod mitransient;
mod stage;
pub mod tal;
mod tal_file;
mod wall_view;

pub use stage::{export_tal, ingest_mitransient, ingest_tal, LaserOrigin, TalExport};
pub use tal_file::{geometry_from_group, geometry_group, is_tal_capture, read_tal, write_tal};
pub use wall_view::wall_view;

use std::path::PathBuf;

/// What can go wrong reading or writing another tool's files.
#[derive(Debug, thiserror::Error)]
pub enum InteropError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// The HDF5 library refused the file.
    #[error("{path}: {message}")]
    Hdf5 { path: PathBuf, message: String },
    /// A key or dataset the format requires is absent.
    #[error("{path}: no {key} (a y-tal capture holds H, delta_t, t_start, sensor_grid_xyz and laser_grid_xyz)")]
    Missing { path: PathBuf, key: String },
    /// A value of the file does not fit the format or what femto can represent.
    #[error("{path}: {key}: {message}")]
    Invalid {
        path: PathBuf,
        key: String,
        message: String,
    },
    /// An array file femto could not read (`.npy`; the message names the file).
    #[error(transparent)]
    Reader(#[from] crate::readers::ReaderError),
    /// A cube file femto could not read (the message names the file).
    #[error(transparent)]
    Container(#[from] crate::container::ContainerError),
    /// A cube's registration group could not be read (the message names the file).
    #[error(transparent)]
    Store(#[from] crate::store::StoreError),
    /// The cube given cannot be converted (no geometry, wrong sizes).
    #[error("{path}: {message}")]
    Cube { path: PathBuf, message: String },
    /// A limit of the machine or of femto.
    #[error("{path}: {source}")]
    Limit {
        path: PathBuf,
        source: crate::limits::LimitError,
    },
}

//! Errors of the cube container ([`ContainerError`]): every message names the file, and the
//! dataset or attribute where one is involved; `h5` and `invalid` build them.

use crate::cube;
use rust_hdf5::Hdf5Error;
use std::io;
use std::path::Path;
use std::path::PathBuf;

/// Errors of the cube container. Every message names the file, and the dataset or
/// attribute where one is involved.
#[derive(Debug, thiserror::Error)]
pub enum ContainerError {
    /// A dataset larger than the memory this machine has available ([`crate::limits`]).
    #[error("{}: {source}", path.display())]
    Limit {
        path: PathBuf,
        #[source]
        source: crate::limits::LimitError,
    },
    /// The file or its folder could not be opened, created, read or renamed (a missing file
    /// or folder, no permission, a full disk).
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    /// The file exists but is not an HDF5 file (no HDF5 signature).
    #[error("{}: not an HDF5 file", path.display())]
    NotHdf5 { path: PathBuf },
    /// The HDF5 file holds no `/cube` dataset.
    #[error("{}: no /cube dataset, so not a femto cube", path.display())]
    NoCube { path: PathBuf },
    /// A dataset has a number of dimensions other than the schema's.
    #[error("{}: dataset /{dataset} has {found} dimensions, expected {expected}", path.display())]
    WrongRank {
        path: PathBuf,
        dataset: String,
        found: usize,
        expected: usize,
    },
    /// A dataset holds elements of a type the schema does not allow.
    #[error("{}: dataset /{dataset} holds {found}, expected {expected}", path.display())]
    WrongType {
        path: PathBuf,
        dataset: String,
        found: String,
        expected: String,
    },
    /// A dataset's shape disagrees with the cube it belongs to.
    #[error("{}: dataset /{dataset} has shape {found:?}, expected {expected:?}", path.display())]
    WrongShape {
        path: PathBuf,
        dataset: String,
        found: Vec<usize>,
        expected: Vec<usize>,
    },
    /// A required attribute is absent.
    #[error("{}: /{object} has no attribute '{attr}'", path.display())]
    MissingAttribute {
        path: PathBuf,
        object: String,
        attr: String,
    },
    /// An attribute is present but its type or value cannot be used (a `time_frame` other
    /// than "camera" or "world", a non-positive `dt_ps`, a numeric attribute where a string
    /// is expected).
    #[error("{}: attribute '{attr}' of /{object}: {reason}", path.display())]
    BadAttribute {
        path: PathBuf,
        object: String,
        attr: String,
        reason: String,
    },
    /// A named group is absent.
    #[error("{}: no group /{group}", path.display())]
    NoGroup { path: PathBuf, group: String },
    /// A named dataset is absent.
    #[error("{}: no dataset /{dataset}", path.display())]
    NoDataset { path: PathBuf, dataset: String },
    /// What the caller asked for does not fit the schema or the file: an empty or
    /// non-finite time axis, a buffer whose length is not a whole number of rows, a row
    /// range past the end, a reserved or duplicate name, rows never written.
    #[error("{}: {reason}", path.display())]
    Invalid { path: PathBuf, reason: String },
    /// A dataset read for computation holds a NaN or an infinity (a cube or pyramid written by
    /// another tool, or damaged): named with its first pixel and bin, before any stage uses it.
    #[error("{}: {dataset} has {} at x {}, y {}, bin {}", path.display(), at.kind(), at.x, at.y, at.bin)]
    NonFinite {
        path: PathBuf,
        /// The dataset, e.g. `cube` or `pyramid/level_2`.
        dataset: String,
        at: cube::NonFiniteAt,
    },
    /// Any other failure reported by the HDF5 library (a corrupt or unsupported file).
    #[error("{}: HDF5: {message}", path.display())]
    Hdf5 { path: PathBuf, message: String },
}

impl From<io::Error> for ContainerError {
    /// An I/O error without a path yet; `ContainerError::at` fills it in.
    fn from(source: io::Error) -> Self {
        ContainerError::Io {
            path: PathBuf::new(),
            source,
        }
    }
}

impl ContainerError {
    /// Name `path` in an I/O error that was raised without one.
    pub(super) fn at(self, path: &Path) -> Self {
        match self {
            ContainerError::Io { path: p, source } if p.as_os_str().is_empty() => {
                ContainerError::Io {
                    path: path.to_path_buf(),
                    source,
                }
            }
            other => other,
        }
    }
}

pub(super) type Result<T> = std::result::Result<T, ContainerError>;

/// Map an error of the HDF5 layer to a [`ContainerError`] naming `path`.
pub(super) fn h5(path: &Path) -> impl Fn(Hdf5Error) -> ContainerError + '_ {
    move |e| match e {
        Hdf5Error::Io(source) => ContainerError::Io {
            path: path.to_path_buf(),
            source,
        },
        other => ContainerError::Hdf5 {
            path: path.to_path_buf(),
            message: other.to_string(),
        },
    }
}

pub(super) fn invalid(path: &Path, reason: impl Into<String>) -> ContainerError {
    ContainerError::Invalid {
        path: path.to_path_buf(),
        reason: reason.into(),
    }
}

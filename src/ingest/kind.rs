//! Which kind of input `femto ingest` was given, decided once, here, from the file and the
//! options the user gave ([`decide`]): a streak capture (a folder, manifest, pattern,
//! scanline file or an HDF5 stack of streak images), a y-tal capture, a mitransient render,
//! or a file of [`crate::readers`] (arrays, Delmic, PTU). The command line and the Python
//! package map their flags onto [`KindHints`] and act on the answer; neither looks at the
//! file itself.

use crate::readers::{self, Format};
use std::path::Path;

/// What `femto ingest` reads the input as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    /// Streak images, one per scanline ([`crate::ingest::plan`]).
    Streak,
    /// A y-tal capture (HDF5 with `H` and `H_format`).
    Tal,
    /// A mitransient render `(H, W, T, C)` saved with `np.save`.
    Mitransient,
    /// A file of [`crate::readers`].
    Array(Format),
}

/// What the user said that bears on the kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KindHints<'a> {
    /// `--from`: the kind named outright (`Array(_)`: any array format, sniffed).
    pub from: Option<InputKind>,
    /// `--dataset`.
    pub dataset: Option<&'a str>,
    /// Flags only a mitransient render takes (its binning, channels, clock).
    pub mitransient_flags: bool,
}

/// Why the kind could not be decided: one line naming the file and what would decide it.
#[derive(Debug, thiserror::Error)]
pub enum KindError {
    /// A plain HDF5 file's only dataset is 3-D and records no time axis.
    #[error(
        "{path}: /{dataset} is 3-D and records no time axis, so its layout is not known: \
         --dataset {dataset} reads it as streak images (ny, nt, nx; with --transpose ny, nx, \
         nt), --from array as an x-y-t cube (ny, nx, nt)"
    )]
    Ambiguous3d { path: String, dataset: String },
    /// `--from array` of a file that is no array file.
    #[error("{path}: not an array file (.npy, .npz, .mat, .hspy, HDF5, Delmic HDF5, .ptu)")]
    NotAnArray { path: String },
    /// A file femto knows and does not read.
    #[error("{path}: {hint}")]
    Convert { path: String, hint: &'static str },
    /// A file of no kind femto reads.
    #[error("{path}: not a file femto reads; {list}")]
    Unknown { path: String, list: String },
}

/// Decide what kind of input `input` is (module documentation).
pub fn decide(input: &str, hints: &KindHints) -> Result<InputKind, KindError> {
    let path = Path::new(input);
    let shown = || path.display().to_string();
    let format = Format::sniff(path);
    match hints.from {
        Some(InputKind::Array(_)) => {
            return format
                .map(InputKind::Array)
                .ok_or(KindError::NotAnArray { path: shown() })
        }
        Some(k) => return Ok(k),
        None => {}
    }
    if let Some(hint) = Format::convert_hint(path) {
        return Err(KindError::Convert {
            path: shown(),
            hint,
        });
    }
    if format == Some(Format::Npy) {
        return Ok(if hints.mitransient_flags {
            InputKind::Mitransient
        } else {
            InputKind::Array(Format::Npy)
        });
    }
    // y-tal's H is (T, Sx, Sy), not a stack of (ny, nt, nx) streak images.
    let tal_dataset = hints
        .dataset
        .is_none_or(|d| d.trim_start_matches('/') == "H");
    if tal_dataset && path.is_file() && crate::interop::is_tal_capture(path) {
        return Ok(InputKind::Tal);
    }
    match (format, hints.dataset) {
        // A 3-D dataset named with --dataset is a stack of streak images (the scanline
        // route, docs/ingest.md); --from array reads it as an x-y-t cube instead.
        (Some(Format::Hdf5Array), Some(d)) if readers::is_3d_dataset(path, d) => {
            Ok(InputKind::Streak)
        }
        (Some(Format::Hdf5Array), None) => match readers::ambiguous_3d_dataset(path) {
            Some(dataset) => Err(KindError::Ambiguous3d {
                path: shown(),
                dataset,
            }),
            None => Ok(InputKind::Array(Format::Hdf5Array)),
        },
        (Some(f), _) => Ok(InputKind::Array(f)),
        (None, _) => {
            if path.is_file() && !is_streak_or_capture_file(path) {
                return Err(KindError::Unknown {
                    path: shown(),
                    list: Format::readable_list(),
                });
            }
            Ok(InputKind::Streak)
        }
    }
}

/// Whether a file is one the streak route reads by name: a scanline image or a manifest.
fn is_streak_or_capture_file(path: &Path) -> bool {
    crate::formats::streak_extension(path).is_some()
        || path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
}

//! Plain HDF5 arrays: one numeric dataset (`--dataset NAME`, or the only candidate of
//! [`super::datasets`]), with its dimension labels (`DIMENSION_LABELS`: `T` names time, `Y`
//! and `X` space, others are extra axes) and what its group records of its time axis.
//!
//! Scalars beside the dataset (in its group), or attributes of the dataset, give:
//! - the bin width: a key named like `timebin_width_ps`, `bin_width_ps`, `dt_ps`,
//!   `delta_t_ps`, `time_resolution_ps`, `resolution_ps` (or with `_fs`, `_ns`, `_us`, `_s`
//!   in place of `_ps`); the key used is recorded in the cube's provenance;
//! - the start: `t0_ps`, `t_start_ps`, `start_ps` (likewise);
//! - which dimension is time: `n_timebins`, `n_bins`, `nt` equal to exactly one dimension.
//!
//! A unit-less key (`delta_t`, `dt`) is not read: y-tal's `delta_t` is metres of optical
//! path, others' are seconds; such files need `--dt-ps`.

use super::array::Array;
use super::h5::{self, Attr};
use super::hspy::ps_per_unit;
use super::layout::Role;
use super::ReaderError;
use rust_hdf5::H5File;
use std::path::Path;

const WIDTH_KEYS: [&str; 6] = [
    "timebin_width",
    "bin_width",
    "dt",
    "delta_t",
    "time_resolution",
    "resolution",
];
const START_KEYS: [&str; 3] = ["t0", "t_start", "start"];
const COUNT_KEYS: [&str; 3] = ["n_timebins", "n_bins", "nt"];

/// The dataset read, and what its group said of its time axis.
pub(super) struct Plain {
    pub name: String,
    pub array: Array,
    /// Its dimension labels (`DIMENSION_LABELS`, one per dimension), if it has them.
    pub labels: Option<Vec<String>>,
    /// Bin width in ps and the key it came from.
    pub dt_ps: Option<(f64, String)>,
    /// Start of the first bin in ps and the key it came from.
    pub t0_ps: Option<(f64, String)>,
    /// The time dimension named by a bin count, with the key.
    pub t_dim: Option<(usize, String)>,
}

/// The role of an axis from its dimension label: `T`/`time` is time, `Y`, `X` space, any
/// other label an extra axis (`C` channels or wavelengths, `Z`); an empty label says nothing.
pub(super) fn role_of_label(label: &str) -> Option<Role> {
    match label.trim().to_ascii_lowercase().as_str() {
        "" => None,
        "t" | "time" => Some(Role::Time),
        "y" => Some(Role::Y),
        "x" => Some(Role::X),
        _ => Some(Role::Extra),
    }
}

/// The numeric datasets of 2 or 3 dimensions (whether a lone 3-D one is a streak stack).
fn candidates(file: &H5File) -> Vec<(String, Vec<usize>)> {
    h5::datasets(file)
        .into_iter()
        .filter(|(_, shape, numeric)| *numeric && matches!(shape.len(), 2 | 3))
        .map(|(n, s, _)| (n, s))
        .collect()
}

/// A `(key, value in ps)` found among `names`/values for one of `stems` with a time suffix.
fn timed(stems: &[&str], found: &[(String, f64)]) -> Option<(f64, String)> {
    for (key, v) in found {
        let lower = key.to_ascii_lowercase();
        for stem in stems {
            let Some(rest) = lower.strip_prefix(stem) else {
                continue;
            };
            let Some(unit) = rest.strip_prefix('_') else {
                continue;
            };
            if let Some(k) = ps_per_unit(unit) {
                return Some((v * k, key.clone()));
            }
        }
    }
    None
}

/// The numeric scalars beside dataset `name` (in its group) and its numeric attributes.
fn keys(file: &H5File, name: &str) -> Vec<(String, f64)> {
    let group = name.rsplit_once('/').map_or("", |(g, _)| g);
    let mut found: Vec<(String, f64)> = h5::datasets(file)
        .into_iter()
        .filter(|(n, _, numeric)| {
            *numeric && n.rsplit_once('/').map_or("", |(g, _)| g) == group && n != name
        })
        .filter_map(|(n, _, _)| {
            let v = h5::scalar_dataset(file, &n)?;
            let key = n
                .rsplit_once('/')
                .map_or(n.as_str(), |(_, k)| k)
                .to_string();
            Some((key, v))
        })
        .collect();
    found.extend(
        h5::dataset_attrs(file, name)
            .into_iter()
            .filter_map(|(k, v)| match v {
                Attr::Number(x) => Some((k, x)),
                _ => None,
            }),
    );
    found
}

/// The rank of dataset `name`, and whether its group records a bin width or bin count.
pub(super) fn read_keys(file: &H5File, name: &str) -> Option<(usize, bool)> {
    let rank = file.dataset(name).ok()?.shape().len();
    let found = keys(file, name);
    let counted = found
        .iter()
        .any(|(k, _)| COUNT_KEYS.contains(&k.to_ascii_lowercase().as_str()));
    Some((rank, counted || timed(&WIDTH_KEYS, &found).is_some()))
}

/// Read the dataset `name`.
pub(super) fn read_plain(file: &H5File, path: &Path, name: &str) -> Result<Plain, ReaderError> {
    let name = name.to_string();
    let array = h5::read_array(file, path, &name, false)?;
    let found = keys(file, &name);
    let t_dim = found.iter().find_map(|(k, v)| {
        if !COUNT_KEYS.contains(&k.to_ascii_lowercase().as_str()) {
            return None;
        }
        let dims: Vec<usize> = (0..array.shape.len())
            .filter(|&d| array.shape[d] as f64 == *v)
            .collect();
        match dims.as_slice() {
            [d] => Some((*d, k.clone())),
            _ => None,
        }
    });
    Ok(Plain {
        dt_ps: timed(&WIDTH_KEYS, &found),
        t0_ps: timed(&START_KEYS, &found),
        t_dim,
        labels: h5::dimension_labels(file, &name),
        name,
        array,
    })
}

/// The plain HDF5 file's only candidate dataset when it is a 3-D one that records no time
/// axis: either a stack of streak images `(ny, nt, nx)` (`--dataset NAME`, the scanline route)
/// or an x-y-t cube `(ny, nx, nt)` (`--from array`). Nothing in the file tells them apart,
/// so `femto ingest` asks which rather than guess.
pub fn ambiguous_3d_dataset(path: &Path) -> Option<String> {
    let file = h5::open(path).ok()?;
    match candidates(&file).as_slice() {
        [(name, shape)] if shape.len() == 3 && is_streak_stack(path, name) => Some(name.clone()),
        _ => None,
    }
}

/// Whether `dataset` of the HDF5 file `path` is 3-D: named with `--dataset`, such a dataset
/// is a stack of streak images `(ny, nt, nx)` for the scanline route of `femto ingest`.
pub fn is_3d_dataset(path: &Path, dataset: &str) -> bool {
    let Ok(file) = h5::open(path) else {
        return false;
    };
    matches!(
        read_keys(&file, dataset.trim_start_matches('/')),
        Some((3, _))
    )
}

/// Whether `dataset` of the plain HDF5 file `path` is a stack of streak images for the
/// scanline route of `femto ingest` (`(ny, nt, nx)`, streak corrections apply): a 3-D
/// dataset whose group records no bin width or bin count. Any other dataset is an
/// assembled array read by [`super::open()`].
pub fn is_streak_stack(path: &Path, dataset: &str) -> bool {
    let Ok(file) = h5::open(path) else {
        return false;
    };
    match read_keys(&file, dataset.trim_start_matches('/')) {
        Some((rank, recorded)) => rank == 3 && !recorded,
        None => false,
    }
}

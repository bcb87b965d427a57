//! Plain HDF5 arrays: one numeric dataset of 1 to 3 dimensions (`--dataset NAME`, or the
//! only numeric dataset of 2 or 3 dimensions), with what its group records of its time axis.
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
    /// Bin width in ps and the key it came from.
    pub dt_ps: Option<(f64, String)>,
    /// Start of the first bin in ps and the key it came from.
    pub t0_ps: Option<(f64, String)>,
    /// The time dimension named by a bin count, with the key.
    pub t_dim: Option<(usize, String)>,
}

/// The numeric datasets of 2 or 3 dimensions (the default candidates).
pub(super) fn candidates(file: &H5File) -> Vec<(String, Vec<usize>)> {
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

/// Read `want`, or the only candidate.
pub(super) fn read_plain(
    file: &H5File,
    path: &Path,
    want: Option<&str>,
) -> Result<Plain, ReaderError> {
    let name = match want {
        Some(w) => w.trim_start_matches('/').to_string(),
        None => {
            let c = candidates(file);
            match c.as_slice() {
                [(n, _)] => n.clone(),
                [] => {
                    return Err(ReaderError::invalid(
                        path,
                        "--dataset",
                        "no numeric dataset of 2 or 3 dimensions; name one with --dataset",
                    ))
                }
                many => {
                    let list: Vec<String> =
                        many.iter().map(|(n, s)| format!("/{n} {s:?}")).collect();
                    return Err(ReaderError::invalid(
                        path,
                        "--dataset",
                        format!(
                            "several datasets could be the data; name one of: {}",
                            list.join(", ")
                        ),
                    ));
                }
            }
        }
    };
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
        name,
        array,
    })
}

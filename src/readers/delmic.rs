//! Delmic SPARC HDF5 files as Odemis writes them (the SVI layout that rosettasciio's
//! `delmic` reader reads): each acquisition is a root group `AcquisitionN` holding
//! `ImageData/Image`, a 5-D array labelled (C, T, Z, Y, X), beside the dimension scales
//! `DimensionScaleT` (an explicit time axis, seconds, one value per index), `DimensionScaleC`
//! (wavelengths, metres), `DimensionScaleX`/`Y` (the pixel size, metres) and the offsets
//! `XOffset`/`YOffset` (the centre of the image, metres). `Preview/Image` is an RGB
//! thumbnail and never read.
//!
//! Time-correlator maps and spots and streak-camera maps are read alike: T is time, Y and X
//! the cube's rows and columns, C (wavelengths of a streak camera, one channel otherwise) and
//! Z extra axes, summed unless `--select C=I` keeps one ([`super::layout`]). Without
//! `--dataset`, the one acquisition whose T axis is longer than 1 is read (a survey SEM image
//! or a concurrent SE value has T = 1). As rosettasciio does, Y goes up: the first row is
//! the top, at the largest y, and an axis offset is the first pixel's centre.

use super::h5;
use super::layout::{AxisInfo, Role, Stored};
use super::{Axis, ReaderError, TimeSpec};
use rust_hdf5::H5File;
use std::path::Path;

/// The acquisition groups of the file (`AcquisitionN` with a 5-D `ImageData/Image`).
pub(super) fn acquisitions(file: &H5File) -> Vec<String> {
    let mut found: Vec<String> = h5::datasets(file)
        .into_iter()
        .filter_map(|(n, shape, numeric)| {
            let group = n.strip_suffix("/ImageData/Image")?;
            (numeric
                && shape.len() == 5
                && group.starts_with("Acquisition")
                && !group.contains('/'))
            .then(|| group.to_string())
        })
        .collect();
    found.sort_by_key(|g| {
        g.trim_start_matches("Acquisition")
            .parse::<u64>()
            .unwrap_or(u64::MAX)
    });
    found
}

/// The image dataset of acquisition `group`.
pub(super) fn image_of(group: &str) -> String {
    format!("{group}/ImageData/Image")
}

/// The acquisition named by `want` (`Acquisition2`, or its image's path), else the one whose
/// time axis is longer than 1.
fn choose(file: &H5File, path: &Path, want: Option<&str>) -> Result<String, ReaderError> {
    let all = acquisitions(file);
    let shape = |g: &str| {
        h5::dataset_type(file, &image_of(g))
            .map(|(s, _)| s)
            .unwrap_or_default()
    };
    let list = || {
        all.iter()
            .map(|g| format!("{g} {:?}", shape(g)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    if let Some(w) = want {
        let w = w.trim_start_matches('/');
        let w = w.strip_suffix("/ImageData/Image").unwrap_or(w);
        return all.iter().find(|g| *g == w).cloned().ok_or_else(|| {
            ReaderError::invalid(
                path,
                "--dataset",
                format!(
                    "no acquisition {w}; the file holds (C, T, Z, Y, X): {}",
                    list()
                ),
            )
        });
    }
    let timed: Vec<&String> = all
        .iter()
        .filter(|g| shape(g).get(1).is_some_and(|&t| t > 1))
        .collect();
    match timed.as_slice() {
        [one] => Ok((*one).clone()),
        [] => Err(ReaderError::invalid(
            path,
            "data",
            format!(
                "no time-resolved acquisition (T > 1) among (C, T, Z, Y, X): {}",
                list()
            ),
        )),
        _ => Err(ReaderError::invalid(
            path,
            "data",
            format!(
                "{} time-resolved acquisitions; name one with --dataset NAME: {}",
                timed.len(),
                list()
            ),
        )),
    }
}

/// A number of the scalar dataset `name`, if it holds one.
fn scalar(file: &H5File, name: &str) -> Option<f64> {
    h5::scalar_dataset(file, name).filter(|v| v.is_finite())
}

/// The spatial axis `label` (`X` or `Y`) of `n` pixels: pixel size and centre from the
/// dimension scale and offset, in metres; the first pixel's centre is the offset.
fn spatial(file: &H5File, group: &str, label: &str, n: usize) -> Option<Axis> {
    let size = scalar(file, &format!("{group}/ImageData/DimensionScale{label}"))?;
    let centre = scalar(file, &format!("{group}/ImageData/{label}Offset")).unwrap_or(0.0);
    // Y goes up: the first (top) row is the largest y.
    let step = if label == "Y" { -size } else { size };
    Some(Axis {
        name: label.to_string(),
        units: "m".into(),
        scale: Some(step),
        offset: Some(centre - (n as f64 - 1.0) / 2.0 * step),
        values: None,
    })
}

/// Read acquisition `want` (or the time-resolved one) of the Delmic file.
pub(super) fn read(file: &H5File, path: &Path, want: Option<&str>) -> Result<Stored, ReaderError> {
    let group = choose(file, path, want)?;
    let image = image_of(&group);
    let array = h5::read_array(file, path, &image, false)?;
    let labels = h5::dimension_labels(file, &image)
        .unwrap_or_else(|| ["C", "T", "Z", "Y", "X"].map(String::from).to_vec());
    let role = |l: &str| match l {
        "T" => Role::Time,
        "Y" => Role::Y,
        "X" => Role::X,
        _ => Role::Extra,
    };
    let axes: Vec<AxisInfo> = labels.iter().map(|l| AxisInfo::named(l, role(l))).collect();
    let dim = |l: &str| labels.iter().position(|m| m == l);
    let scales = labels
        .iter()
        .enumerate()
        .map(|(d, l)| match l.as_str() {
            "X" | "Y" => spatial(file, &group, l, array.shape[d]),
            _ => None,
        })
        .collect();
    let t_key = format!("{group}/ImageData/DimensionScaleT");
    let nt = dim("T").map_or(1, |d| array.shape[d]);
    let time = if file.dataset(&t_key).is_ok() {
        let seconds = h5::read_f64s(file, path, &t_key)?;
        if seconds.len() != nt {
            return Err(ReaderError::invalid(
                path,
                &t_key,
                format!("{} values for a T axis of {nt}", seconds.len()),
            ));
        }
        TimeSpec::from_table(path, &t_key, seconds.iter().map(|s| s * 1e12).collect())?
    } else {
        TimeSpec::Uncalibrated {
            reason: format!("{group} has no DimensionScaleT"),
        }
    };
    let mut attributes = vec![("delmic.acquisition".to_string(), group.clone())];
    let c_key = format!("{group}/ImageData/DimensionScaleC");
    if let (Some(d), Ok(_)) = (dim("C"), file.dataset(&c_key)) {
        let metres = h5::read_f64s(file, path, &c_key)?;
        if metres.len() == array.shape[d] && metres.len() > 1 {
            let nm: Vec<f64> = metres.iter().map(|m| m * 1e9).collect();
            attributes.push((
                "delmic.wavelengths_nm".into(),
                serde_json::to_string(&nm).expect("finite numbers"),
            ));
        }
    }
    if let Some(t) = scalar(file, &format!("{group}/ImageData/TOffset")) {
        attributes.push(("delmic.acquired_unix_s".into(), t.to_string()));
    }
    Ok(Stored {
        source: format!("acquisition {group}"),
        array,
        axes,
        scales,
        time,
        time_source: t_key,
        attributes,
    })
}

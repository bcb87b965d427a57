//! HyperSpy `.hspy` files (HDF5, root attribute `file_format = "HyperSpy"`): each signal is
//! a group `Experiments/NAME` holding `data` and one group `axis-N` per dimension `N` (in
//! array order) with the attributes `name`, `units`, `size` and either `scale`/`offset`
//! (a uniform axis) or a dataset `axis` of explicit values.
//!
//! The time axis is the one whose units are a time unit (fs, ps, ns, us, µs, ms, s), else
//! the one named time; it is converted to ps. HyperSpy's axis value of index `i` is taken as
//! the start of bin `i`, as femto reads HPD-TA time tables. The other axes are kept as
//! [`Axis`] values (name, units, scale and offset, or values).

use super::array::Array;
use super::h5::{self, Attr};
use super::{Axis, ReaderError, TimeSpec};
use rust_hdf5::H5File;
use std::path::Path;

/// Whether the open HDF5 file is a HyperSpy file.
pub(super) fn is_hyperspy(file: &H5File) -> bool {
    h5::group_attrs(file, "/")
        .iter()
        .any(|(k, v)| k == "file_format" && matches!(v, Attr::Text(s) if s == "HyperSpy"))
}

/// ps per unit of a time unit's name.
pub fn ps_per_unit(units: &str) -> Option<f64> {
    Some(match units.trim() {
        "fs" => 1e-3,
        "ps" => 1.0,
        "ns" => 1e3,
        "us" | "µs" | "μs" => 1e6,
        "ms" => 1e9,
        "s" => 1e12,
        _ => return None,
    })
}

/// The signals (`Experiments/NAME` groups holding `data`) of the file.
pub(super) fn signals(file: &H5File) -> Vec<String> {
    let mut names: Vec<String> = h5::datasets(file)
        .into_iter()
        .filter_map(|(n, _, _)| {
            let rest = n.strip_prefix("Experiments/")?;
            let sig = rest.strip_suffix("/data")?;
            (!sig.contains('/')).then(|| sig.to_string())
        })
        .collect();
    names.sort();
    names
}

/// What a signal holds: its array, the index of its time dimension (if found), the time
/// axis, and every axis in array order (the time axis among them).
pub(super) struct Signal {
    pub name: String,
    pub array: Array,
    pub t_dim: Option<usize>,
    pub time: TimeSpec,
    pub axes: Vec<Axis>,
}

/// The `axis-N` groups of a signal, one per dimension.
fn axis(file: &H5File, path: &Path, group: &str, size: usize) -> Result<Axis, ReaderError> {
    let attrs = h5::group_attrs(file, group);
    let text = |k: &str| {
        attrs.iter().find_map(|(n, v)| match v {
            Attr::Text(s) if n == k => Some(s.clone()),
            _ => None,
        })
    };
    let num = |k: &str| {
        attrs.iter().find_map(|(n, v)| match v {
            Attr::Number(x) if n == k => Some(*x),
            _ => None,
        })
    };
    let values_name = format!("{group}/axis");
    let values = if file.dataset(&values_name).is_ok() {
        Some(h5::read_f64s(file, path, &values_name)?)
    } else {
        None
    };
    let ax = Axis {
        name: text("name").unwrap_or_default(),
        units: text("units").unwrap_or_default(),
        scale: num("scale"),
        offset: num("offset"),
        values,
    };
    let bad = |m: String| ReaderError::invalid(path, group, m);
    match (&ax.values, ax.scale, ax.offset) {
        (Some(v), _, _) if v.len() != size => Err(bad(format!(
            "{} axis values for a dimension of {size}",
            v.len()
        ))),
        (Some(v), _, _) => match v.iter().find(|x| !x.is_finite()) {
            Some(x) => Err(bad(format!("axis value {x}"))),
            None => Ok(ax),
        },
        (None, Some(s), Some(o)) if s.is_finite() && s != 0.0 && o.is_finite() => Ok(ax),
        (None, s, o) => Err(bad(format!(
            "scale {s:?}, offset {o:?}: an axis needs a finite non-zero scale and a finite \
             offset, or explicit values"
        ))),
    }
}

/// Read the signal `want` (the only one when `None`).
pub(super) fn read_signal(
    file: &H5File,
    path: &Path,
    want: Option<&str>,
) -> Result<Signal, ReaderError> {
    let names = signals(file);
    let name = match (want, names.as_slice()) {
        (Some(w), _) => {
            let w = w.trim_start_matches('/');
            let w = w.strip_prefix("Experiments/").unwrap_or(w);
            let w = w.strip_suffix("/data").unwrap_or(w);
            if !names.iter().any(|n| n == w) {
                return Err(ReaderError::invalid(
                    path,
                    "--dataset",
                    format!("no signal {w}; the file holds: {}", names.join(", ")),
                ));
            }
            w.to_string()
        }
        (None, [one]) => one.clone(),
        (None, []) => {
            return Err(ReaderError::invalid(
                path,
                "Experiments",
                "a HyperSpy file without a signal (no Experiments/NAME/data)",
            ))
        }
        (None, many) => {
            return Err(ReaderError::invalid(
                path,
                "--dataset",
                format!("several signals; name one of: {}", many.join(", ")),
            ))
        }
    };
    let group = format!("Experiments/{name}");
    let array = h5::read_array(file, path, &format!("{group}/data"), false)?;
    let axes = array
        .shape
        .iter()
        .enumerate()
        .map(|(i, &n)| axis(file, path, &format!("{group}/axis-{i}"), n))
        .collect::<Result<Vec<_>, _>>()?;
    let by_units = axes.iter().position(|a| ps_per_unit(&a.units).is_some());
    let by_name = axes
        .iter()
        .position(|a| matches!(a.name.to_ascii_lowercase().as_str(), "time" | "t" | "delay"));
    let t_dim = by_units.or(by_name);
    let time = match t_dim {
        None => TimeSpec::Uncalibrated {
            reason: format!(
                "no axis of signal {name} has time units (fs, ps, ns, us, ms, s) or is named Time"
            ),
        },
        Some(d) => time_of(path, &group, d, &axes[d])?,
    };
    Ok(Signal {
        name,
        array,
        t_dim,
        time,
        axes,
    })
}

/// The time axis in ps.
fn time_of(path: &Path, group: &str, d: usize, a: &Axis) -> Result<TimeSpec, ReaderError> {
    let key = format!("{group}/axis-{d}");
    let Some(k) = ps_per_unit(&a.units) else {
        return Ok(TimeSpec::Uncalibrated {
            reason: format!(
                "the time axis {key} has units '{}', not a time unit",
                a.units
            ),
        });
    };
    match (&a.values, a.scale, a.offset) {
        (Some(v), _, _) => {
            let ps: Vec<f64> = v.iter().map(|x| x * k).collect();
            TimeSpec::from_table(path, &key, ps)
        }
        (None, Some(s), Some(o)) => TimeSpec::uniform(path, &key, o * k, s * k),
        _ => unreachable!("checked by axis()"),
    }
}

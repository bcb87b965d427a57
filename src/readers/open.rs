//! [`open`]: a file of any format of [`super::Format`] into a [`Capture`]. Each format's
//! reader hands over its stored array with what the file says of its axes ([`Stored`]); the
//! layout ([`super::layout`]) then decides time, rows and columns the same way for all.
//! PicoQuant PTU files are histogrammed straight into `[y][x][t]` by [`super::ptu`].

use super::array::Array;
use super::datasets::{self, Candidate};
use super::layout::{self, AxisInfo, Role, Stored};
use super::{check_dt, Capture, Format, ReadOptions, ReaderError, TimeSpec};
use super::{delmic, h5, hdf5_array, hspy, mat, npy, npz, ptu};
use std::path::Path;

fn no_axis(what: &str) -> TimeSpec {
    TimeSpec::Uncalibrated {
        reason: format!("{what} records no time axis"),
    }
}

/// Open the file at `path` as `format` (see [`Format::sniff`]).
pub fn open(path: &Path, format: Format, options: &ReadOptions) -> Result<Capture, ReaderError> {
    let dataset = options.dataset.as_deref();
    let stored = match format {
        Format::Ptu if dataset.is_some() => {
            return Err(ReaderError::invalid(
                path,
                "--dataset",
                "a PTU file holds one measurement (frames and channels: --select)",
            ))
        }
        Format::Ptu => return ptu::read(path, &options.layout),
        Format::Npy => {
            if dataset.is_some() {
                return Err(ReaderError::invalid(
                    path,
                    "--dataset",
                    "a .npy file holds one array",
                ));
            }
            plain(String::new(), npy::read_npy(path)?, "a .npy array")
        }
        Format::Npz => {
            let found = datasets::candidates(path, format)?;
            let c = datasets::choose(path, &found, dataset, "array")?;
            plain(
                format!("array {}", c.name),
                npz::read_member(path, &c.name)?,
                "a .npz array",
            )
        }
        Format::Mat => mat_variable(path, dataset)?,
        Format::Hspy => {
            let file = h5::open(path)?;
            hyperspy(hspy::read_signal(&file, path, dataset)?)
        }
        Format::Hdf5Array => {
            let file = h5::open(path)?;
            let found = datasets::candidates(path, format)?;
            let name = match dataset {
                // A named dataset is read even when it is no candidate (a picture asked for
                // by name is refused by the layout, not hidden).
                Some(w) => w.trim_start_matches('/').to_string(),
                None => datasets::choose(path, &found, None, "dataset")?
                    .name
                    .trim_start_matches('/')
                    .to_string(),
            };
            plain_hdf5(path, hdf5_array::read_plain(&file, path, &name)?)?
        }
        Format::Delmic => {
            let file = h5::open(path)?;
            delmic::read(&file, path, dataset)?
        }
    };
    assemble(path, format, stored, &options.layout)
}

/// An array that says nothing of its axes.
fn plain(source: String, array: Array, what: &str) -> Stored {
    Stored {
        source,
        axes: vec![],
        scales: vec![None; array.shape.len()],
        array,
        time: no_axis(what),
        time_source: String::new(),
        attributes: vec![],
    }
}

/// A HyperSpy signal: the axis with time units is time; the others keep their names and
/// calibrations and become rows and columns in order.
fn hyperspy(s: hspy::Signal) -> Stored {
    let axes = s
        .axes
        .iter()
        .enumerate()
        .map(|(d, a)| AxisInfo {
            name: a.name.clone(),
            role: (Some(d) == s.t_dim).then_some(Role::Time),
        })
        .collect();
    let scales = s
        .axes
        .iter()
        .enumerate()
        .map(|(d, a)| (Some(d) != s.t_dim).then(|| a.clone()))
        .collect();
    Stored {
        source: format!("signal {}", s.name),
        time_source: s.t_dim.map_or(String::new(), |d| format!("axis-{d}")),
        array: s.array,
        axes,
        scales,
        time: s.time,
        attributes: vec![],
    }
}

/// A plain HDF5 dataset: its dimension labels and what its group records of time.
fn plain_hdf5(path: &Path, p: hdf5_array::Plain) -> Result<Stored, ReaderError> {
    let rank = p.array.shape.len();
    let mut axes: Vec<AxisInfo> = match &p.labels {
        Some(l) => l
            .iter()
            .map(|n| AxisInfo {
                name: n.clone(),
                role: hdf5_array::role_of_label(n),
            })
            .collect(),
        None => vec![AxisInfo::default(); rank],
    };
    let mut notes = vec![];
    if let Some((d, key)) = &p.t_dim {
        axes[*d].role = Some(Role::Time);
        notes.push(format!("time dimension {d} from {key}"));
    }
    let time = match (&p.dt_ps, &p.t0_ps) {
        (Some((dt, kd)), Some((t0, k0))) => {
            notes.insert(0, format!("bin width from {kd}, start from {k0}"));
            TimeSpec::uniform(path, kd, *t0, *dt)?
        }
        (Some((dt, kd)), None) => {
            check_dt(path, kd, *dt)?;
            notes.insert(0, format!("bin width from {kd}"));
            TimeSpec::Width { dt_ps: *dt }
        }
        _ => no_axis(&format!("/{} (no sibling timebin_width_ps, dt_ps)", p.name)),
    };
    Ok(Stored {
        source: format!("dataset /{}", p.name),
        scales: vec![None; rank],
        array: p.array,
        axes,
        time,
        time_source: notes.join("; "),
        attributes: vec![],
    })
}

/// The stored array laid out as the cube's `[y][x][t]`.
fn assemble(
    path: &Path,
    format: Format,
    s: Stored,
    options: &layout::LayoutOptions,
) -> Result<Capture, ReaderError> {
    let shape = s.array.shape.clone();
    // A picture (a preview, a thumbnail) read with no word on its layout: its colour axis
    // would be taken for time. A small integer array of 3 or 4 bins whose other axes are
    // no longer than twice that is read as data.
    let wide = shape
        .iter()
        .rev()
        .skip(1)
        .any(|&n| n >= 2 * shape[shape.len() - 1]);
    if datasets::is_picture(&shape, s.array.dtype) && wide && options.is_empty() {
        return Err(ReaderError::invalid(
            path,
            "data",
            format!(
                "{} {shape:?} {} is an RGB(A) picture (a preview or thumbnail), not \
                 time-resolved data",
                s.source,
                s.array.dtype.name()
            ),
        ));
    }
    let what = if s.source.is_empty() {
        "the array".to_string()
    } else {
        s.source.clone()
    };
    let mitransient = format == Format::Npy && shape.len() == 4 && options.is_empty();
    let layout = layout::decide(path, &what, &shape, &s.axes, options).map_err(|e| {
        if mitransient {
            e.and_then_say(
                " (a 4-D (H, W, T, C) array is a mitransient render: give --start-opl-m and \
                 --bin-width-opl-m)",
            )
        } else {
            e
        }
    })?;
    let (ny, nx, nt) = layout.dims();
    if let TimeSpec::Table(t) = &s.time {
        if t.len() != nt {
            return Err(ReaderError::invalid(
                path,
                "time axis",
                format!("{} values for {nt} bins", t.len()),
            ));
        }
    }
    let samples = layout.apply(&s.array);
    let scale = |d: Option<usize>| d.and_then(|d| s.scales.get(d).cloned().flatten());
    Ok(Capture {
        path: path.to_path_buf(),
        format,
        source: s.source,
        stored_shape: shape,
        dtype: s.array.dtype,
        ny,
        nx,
        nt,
        time: s.time,
        time_source: s.time_source,
        layout: layout.describe(),
        y: scale(layout.y),
        x: scale(layout.x),
        samples,
        attributes: s.attributes,
        inexact: s.array.inexact,
        largest_inexact: s.array.largest_inexact,
    })
}

/// The variable of a `.mat` file: the one named, else the only candidate (a numeric array
/// of 1 to 5 dimensions with more than one value); numeric scalars become attributes
/// `mat.NAME`. MATLAB names no axes.
fn mat_variable(path: &Path, want: Option<&str>) -> Result<Stored, ReaderError> {
    // A first pass lists the variables without decoding the large ones.
    let listed = mat::read_mat(path, &|_| false)?;
    if let Some(v) = want.and_then(|w| listed.iter().find(|v| v.name == w)) {
        if v.dtype.is_none() {
            return Err(ReaderError::invalid(
                path,
                "--dataset",
                format!(
                    "variable {} is a {} array, not a numeric one",
                    v.name, v.class
                ),
            ));
        }
    }
    let found = datasets::candidates(path, Format::Mat)?;
    let pick: Candidate = match datasets::choose(path, &found, want, "variable") {
        Ok(c) => c.clone(),
        Err(e) => {
            // Name the variables femto does not read too, so the user sees the whole file.
            let others: Vec<String> = listed
                .iter()
                .filter(|v| v.dtype.is_none())
                .map(|v| format!("{} ({})", v.name, v.class))
                .collect();
            return Err(if others.is_empty() {
                e
            } else {
                e.and_then_say(&format!("; not read: {}", others.join(", ")))
            });
        }
    };
    let vars = mat::read_mat(path, &|n| n == pick.name)?;
    let mut attributes = Vec::new();
    let mut chosen = None;
    for v in vars {
        if v.name == pick.name {
            chosen = v.array;
        } else if let Some(x) = v.scalar {
            attributes.push((format!("mat.{}", v.name), x.to_string()));
        }
    }
    let array = chosen.ok_or_else(|| ReaderError::invalid(path, &pick.name, "not read"))?;
    let mut s = plain(format!("variable {}", pick.name), array, "a MATLAB array");
    s.attributes = attributes;
    Ok(s)
}

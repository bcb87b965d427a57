//! Describing an array file as `femto ingest` reads it ([`crate::readers`]): `.npy`, `.mat`,
//! `.hspy`, a plain HDF5 dataset, with its shape, stored type, which variable or dataset,
//! its axes with units, and what ingest would ask for. Also a y-tal capture and an HDF5
//! stack of streak images, named as such. The JSON form is the `array` object of
//! docs/cube-format.md.

use super::{line, serialize_path};
use crate::interop::tal::LaserSpot;
use crate::pipeline::StageError;
use crate::readers::{self, Format, ReadOptions, TimeSpec};
use serde::Serialize;
use std::fmt;
use std::path::{Path, PathBuf};

/// An array file.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ArrayDescription {
    #[serde(serialize_with = "serialize_path")]
    pub file: PathBuf,
    /// `NumPy array`, `MATLAB file`, `HyperSpy signal`, `HDF5 dataset`.
    pub format: String,
    /// The variable, signal or dataset read (empty for `.npy`).
    pub source: String,
    pub stored_shape: Vec<usize>,
    pub dtype: String,
    /// The cube it becomes: rows, columns, bins.
    pub ny: usize,
    pub nx: usize,
    pub nt: usize,
    /// The time axis recorded, in words.
    pub time_axis: String,
    /// Which stored axis becomes time, rows and columns, and what becomes of the others
    /// (empty when the layout could not be decided: `ingest_needs` says why).
    pub layout: String,
    /// Every array of the file that could be the data, with its shape (`.npz`, `.mat`,
    /// HDF5, Delmic acquisitions, HyperSpy signals).
    pub candidates: Vec<String>,
    /// The column and row axes: `name (units): scale, offset` or `n values`.
    pub x_axis: Option<String>,
    pub y_axis: Option<String>,
    /// Values kept as cube attributes (`mat.width`).
    pub attributes: Vec<(String, String)>,
    /// The flags `femto ingest` needs for it (empty: none).
    pub ingest_needs: String,
}

fn axis_text(a: &readers::Axis) -> String {
    match (&a.values, a.scale, a.offset) {
        (Some(v), _, _) => format!("{} ({}): {} explicit values", a.name, a.units, v.len()),
        (None, Some(s), Some(o)) => format!("{} ({}): scale {s}, offset {o}", a.name, a.units),
        _ => format!("{} ({})", a.name, a.units),
    }
}

/// Describe the array file at `path` (read as `format`, with `read`'s dataset and layout).
/// A file whose dataset or layout `femto ingest` would ask for is still described: its
/// candidates and shape, and in `ingest_needs` the line ingest would refuse it with.
pub fn describe_array(
    path: &Path,
    format: Format,
    read: &ReadOptions,
) -> Result<ArrayDescription, StageError> {
    let candidates: Vec<readers::Candidate> = readers::candidates(path, format)?;
    let listed: Vec<String> = candidates
        .iter()
        .map(readers::Candidate::describe)
        .collect();
    let c = match readers::open(path, format, read) {
        Ok(c) => c,
        Err(readers::ReaderError::Choice { key, message, .. }) => {
            let want = read.dataset.as_deref().map(|w| w.trim_start_matches('/'));
            let one = match (want, candidates.as_slice()) {
                (Some(w), _) => candidates
                    .iter()
                    .find(|c| c.name.trim_start_matches('/') == w),
                (None, [c]) => Some(c),
                _ => None,
            };
            return Ok(ArrayDescription {
                file: path.to_path_buf(),
                format: format.name().into(),
                source: one.map_or(String::new(), |c| c.name.clone()),
                stored_shape: one.map_or(vec![], |c| c.shape.clone()),
                dtype: one.map_or(String::new(), |c| c.dtype.name().to_string()),
                ny: 0,
                nx: 0,
                nt: 0,
                time_axis: String::new(),
                layout: String::new(),
                candidates: listed,
                x_axis: None,
                y_axis: None,
                attributes: vec![],
                ingest_needs: format!("{key}: {message}"),
            });
        }
        Err(e) => return Err(e.into()),
    };
    let ambiguous = (format == Format::Hdf5Array && read.dataset.is_none())
        .then(|| readers::ambiguous_3d_dataset(path))
        .flatten();
    let (time_axis, needs) = match &c.time {
        TimeSpec::Uniform { t0_ps, dt_ps } => (
            format!("{dt_ps} ps bins from {t0_ps} ps ({})", c.time_source),
            String::new(),
        ),
        TimeSpec::Width { dt_ps } => (
            format!("{dt_ps} ps bins, start not recorded ({})", c.time_source),
            "--t0-ps PS (default 0)".into(),
        ),
        TimeSpec::Table(t) => (
            format!(
                "{} non-uniform bin starts, {} .. {} ps (resampled on ingest)",
                t.len(),
                t[0],
                t[t.len() - 1]
            ),
            String::new(),
        ),
        TimeSpec::Uncalibrated { reason } => {
            (reason.clone(), "--dt-ps PS [--t0-ps PS, default 0]".into())
        }
    };
    Ok(ArrayDescription {
        file: path.to_path_buf(),
        format: format.name().into(),
        source: c.source,
        stored_shape: c.stored_shape,
        dtype: c.dtype.name().into(),
        ny: c.ny,
        nx: c.nx,
        nt: c.nt,
        time_axis,
        layout: c.layout,
        candidates: listed,
        x_axis: c.x.as_ref().map(axis_text),
        y_axis: c.y.as_ref().map(axis_text),
        attributes: c.attributes,
        ingest_needs: match ambiguous {
            Some(name) => format!(
                "{needs}, and the layout: --dataset {name} (streak images, ny nt nx) or --from \
                 array (an x-y-t cube, ny nx nt, as described here)"
            ),
            None => needs,
        },
    })
}

/// Describe the y-tal capture at `path` as `femto ingest` reads it: `H (T, Sx, Sy)`, its
/// axis in ps, its clock and its laser (one spot, or confocal).
pub fn describe_tal(path: &Path) -> Result<ArrayDescription, StageError> {
    let cap = crate::interop::read_tal(path)?;
    let (cube, _) = cap.to_cube();
    let laser = match cap.laser_grid_xyz_m {
        LaserSpot::Single(p) => format!("one spot at {p:?} m"),
        LaserSpot::Confocal => "confocal: laser_grid_xyz is the sensor grid".into(),
    };
    Ok(ArrayDescription {
        file: path.to_path_buf(),
        format: "y-tal capture".into(),
        source: "H".into(),
        stored_shape: vec![cap.nt, cap.sx, cap.sy],
        dtype: "float32".into(),
        ny: cap.sy,
        nx: cap.sx,
        nt: cap.nt,
        time_axis: format!(
            "{} ps bins from {} ps, {} time (delta_t {} m, t_start {} m, \
             t_accounts_first_and_last_bounces = {})",
            cube.axis.dt_ps,
            cube.axis.t0_ps,
            cube.frame,
            cap.delta_t_m,
            cap.t_start_m,
            if cap.t_accounts_first_and_last_bounces {
                "True"
            } else {
                "False"
            }
        ),
        layout: "time: axis 0 of H (T, Sx, Sy); rows: Sy; columns: Sx".into(),
        candidates: vec![],
        x_axis: None,
        y_axis: None,
        attributes: vec![
            ("laser".into(), laser),
            ("sensor_xyz".into(), format!("{:?} m", cap.sensor_xyz_m)),
        ],
        ingest_needs: String::new(),
    })
}

impl fmt::Display for ArrayDescription {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        line(f, "file", self.file.display())?;
        line(f, "kind", format!("array file: {}", self.format))?;
        if !self.source.is_empty() {
            line(f, "reads", &self.source)?;
        }
        if !self.stored_shape.is_empty() {
            line(
                f,
                "stored",
                format!(
                    "{:?} {} (axes 0 to {}, as --time-axis and --select number them)",
                    self.stored_shape,
                    self.dtype,
                    self.stored_shape.len() - 1
                ),
            )?;
        }
        if self.candidates.len() > 1 || self.stored_shape.is_empty() {
            for c in &self.candidates {
                line(f, "candidate", c)?;
            }
        }
        if self.nt > 0 {
            line(
                f,
                "cube",
                format!("{} x {} x {} (ny, nx, nt)", self.ny, self.nx, self.nt),
            )?;
            line(f, "layout", &self.layout)?;
            line(f, "time axis", &self.time_axis)?;
        }
        if let Some(x) = &self.x_axis {
            line(f, "x axis", x)?;
        }
        if let Some(y) = &self.y_axis {
            line(f, "y axis", y)?;
        }
        for (k, v) in &self.attributes {
            line(f, "attribute", format!("{k} = {v}"))?;
        }
        let needs = if self.ingest_needs.is_empty() {
            "nothing more (femto ingest FILE -o CUBE.h5)"
        } else {
            &self.ingest_needs
        };
        line(f, "ingest needs", needs)
    }
}

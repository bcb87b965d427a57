//! Files as instruments and labs write them (`.npy`, `.npz`, `.mat`, `.hspy`, HDF5, Delmic
//! SPARC, PicoQuant PTU): the library's kind decision ([`femto::ingest::kind::decide`]), the
//! array ingest ([`femto::ingest::arrays::ingest_array`]) and the describe stage (`femto
//! info`), with the options of their flags. `femto.ingest` calls [`input_kind`] and sends an
//! array file to [`ingest_array`]; `femto.info` is [`info`].

use crate::errors::{value_error, IntoPy};
use crate::stages::saturation_input;
use femto::container::Provenance;
use femto::cube::TimeFrame;
use femto::ingest::arrays::{ingest_array as ingest_array_file, ArrayIngest, Confocal};
use femto::ingest::kind::{decide, InputKind, KindHints};
use femto::pipeline::describe::{describe_file, DescribeOptions};
use femto::pipeline::overwrite::refuse_existing;
use femto::readers::{AxisRef, LayoutOptions, ReadOptions};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};

/// The dataset and layout options, as `--dataset`, `--time-axis`, `--select`, `--sum`.
fn read_options(
    dataset: Option<String>,
    time_axis: Option<usize>,
    transpose: bool,
    select: Vec<(String, usize)>,
    sum: Vec<String>,
) -> ReadOptions {
    ReadOptions {
        dataset,
        layout: LayoutOptions {
            time_axis,
            transpose,
            select: select
                .into_iter()
                .map(|(a, i)| (AxisRef::parse(&a), i))
                .collect(),
            sum: sum.iter().map(|a| AxisRef::parse(a)).collect(),
        },
    }
}

/// What `femto ingest` reads `source` as: `"streak"`, `"tal"`, `"mitransient"` or
/// `"array"` (with `dataset` and whether mitransient's flags were given, as the CLI decides).
#[pyfunction]
#[pyo3(signature = (source, dataset, mitransient_flags))]
pub fn input_kind(
    source: String,
    dataset: Option<String>,
    mitransient_flags: bool,
) -> PyResult<&'static str> {
    let hints = KindHints {
        from: None,
        dataset: dataset.as_deref(),
        mitransient_flags,
    };
    Ok(match decide(&source, &hints).py_err()? {
        InputKind::Streak => "streak",
        InputKind::Tal => "tal",
        InputKind::Mitransient => "mitransient",
        InputKind::Array(_) => "array",
    })
}

/// `femto ingest FILE -o OUT` of an array, Delmic or PTU file.
#[pyfunction]
#[pyo3(signature = (
    source, out, dataset, time_axis, transpose, select, sum, dt_ps, t0_ps, saturation,
    confocal_wall_size_m, device_m, clock, laser_nm, force
))]
#[allow(clippy::too_many_arguments)]
pub fn ingest_array<'py>(
    py: Python<'py>,
    source: PathBuf,
    out: PathBuf,
    dataset: Option<String>,
    time_axis: Option<usize>,
    transpose: bool,
    select: Vec<(String, usize)>,
    sum: Vec<String>,
    dt_ps: Option<f64>,
    t0_ps: Option<f64>,
    saturation: Option<Bound<'py, PyAny>>,
    confocal_wall_size_m: Option<f64>,
    device_m: Option<[f64; 3]>,
    clock: Option<String>,
    laser_nm: Option<f64>,
    force: bool,
) -> PyResult<Bound<'py, PyDict>> {
    refuse_existing(&out, &[source.as_path()], force, "out").py_err()?;
    let hints = KindHints {
        from: Some(InputKind::Array(femto::readers::Format::Npy)),
        ..KindHints::default()
    };
    let InputKind::Array(format) = decide(&source.to_string_lossy(), &hints).py_err()? else {
        return Err(value_error(format!(
            "{}: not an array file",
            source.display()
        )));
    };
    let saturation = saturation_input(saturation)?;
    let clock = match clock.as_deref() {
        None | Some("camera") => TimeFrame::Camera,
        Some("world") => TimeFrame::World,
        Some(other) => return Err(value_error(format!("--clock {other}: camera or world"))),
    };
    let opts = ArrayIngest {
        read: read_options(dataset, time_axis, transpose, select, sum),
        dt_ps,
        t0_ps,
        saturation,
        confocal: confocal_wall_size_m.map(|wall_size_m| Confocal {
            wall_size_m,
            device_m,
        }),
        clock,
    };
    let mut provenance = Provenance::new("python: femto.ingest");
    if let Some(nm) = laser_nm {
        provenance = provenance.with_note("laser_nm", nm.to_string());
    }
    let r = py
        .detach(|| ingest_array_file(&source, format, &out, &opts, &provenance))
        .py_err()?;
    let d = PyDict::new(py);
    d.set_item("path", &out)?;
    d.set_item("format", r.format.name())?;
    d.set_item("source", &r.source)?;
    d.set_item("shape", (r.ny, r.nx, r.axis.nt))?;
    d.set_item("t0_ps", r.axis.t0_ps)?;
    d.set_item("dt_ps", r.axis.dt_ps)?;
    d.set_item("time_axis", &r.time_axis)?;
    d.set_item("layout", &r.layout)?;
    d.set_item("saturated_pixels", r.saturated_pixels)?;
    d.set_item("inexact_values", r.inexact)?;
    Ok(d)
}

/// `femto info FILE --json [--dataset NAME --time-axis N --select AXIS=I --sum AXIS]`: the
/// description as a JSON string.
#[pyfunction]
#[pyo3(signature = (path, dataset, time_axis, select, sum))]
pub fn info(
    py: Python<'_>,
    path: PathBuf,
    dataset: Option<String>,
    time_axis: Option<usize>,
    select: Vec<(String, usize)>,
    sum: Vec<String>,
) -> PyResult<String> {
    let options = DescribeOptions {
        array: read_options(dataset, time_axis, false, select, sum),
        ..DescribeOptions::default()
    };
    let d = py
        .detach(|| describe_file(Path::new(&path), &options, &femto::pipeline::Quiet))
        .py_err()?;
    Ok(d.to_json().to_string())
}

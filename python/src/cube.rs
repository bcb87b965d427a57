//! Cubes in and out of numpy: `open_cube`'s reads (values, metadata, extra groups, the
//! stored pyramid) and `cube_from_array`'s write, through the library's container
//! ([`femto::container`]): the same reader and writer as every stage.

use crate::errors::{value_error, IntoPy};
use crate::runner::run_stage;
use femto::container::{AttrValue, CubeReader, CubeView, DataBuf, GroupReader, Provenance};
use femto::cube::{TimeAxis, TimeFrame};
use numpy::ndarray::{Array2, Array3, ArrayD, IxDyn};
use numpy::{IntoPyArray, PyReadonlyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

/// An attribute of a group as a Python value.
fn attr_value<'py>(py: Python<'py>, v: &AttrValue) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        AttrValue::F64(x) => x.into_pyobject(py)?.into_any(),
        AttrValue::I64(x) => x.into_pyobject(py)?.into_any(),
        AttrValue::Str(s) => s.into_pyobject(py)?.into_any(),
        AttrValue::F64Array(a) => a.clone().into_pyarray(py).into_any(),
    })
}

/// A dataset of a group as a numpy array of its shape.
fn dataset_array<'py>(
    py: Python<'py>,
    shape: &[usize],
    data: &DataBuf,
) -> PyResult<Bound<'py, PyAny>> {
    fn shaped<'py, T: numpy::Element>(
        py: Python<'py>,
        shape: &[usize],
        v: Vec<T>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let a = ArrayD::from_shape_vec(IxDyn(shape), v)
            .map_err(|e| value_error(format!("dataset of shape {shape:?}: {e}")))?;
        Ok(a.into_pyarray(py).into_any())
    }
    match data.clone() {
        DataBuf::F32(v) => shaped(py, shape, v),
        DataBuf::F64(v) => shaped(py, shape, v),
        DataBuf::U8(v) => shaped(py, shape, v),
        DataBuf::U32(v) => shaped(py, shape, v),
        DataBuf::I32(v) => shaped(py, shape, v),
    }
}

/// The metadata of the cube at `path`: a dict with `nx`, `ny`, `nt`, `t0_ps`, `dt_ps`,
/// `clock`, `units`, `femto_version`, `command_line`, `notes` (list of pairs), `groups`.
#[pyfunction]
pub fn read_meta<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let meta = py.detach(|| femto::container::read_meta(&path)).py_err()?;
    let d = PyDict::new(py);
    d.set_item("nx", meta.nx)?;
    d.set_item("ny", meta.ny)?;
    d.set_item("nt", meta.axis.nt)?;
    d.set_item("t0_ps", meta.axis.t0_ps)?;
    d.set_item("dt_ps", meta.axis.dt_ps)?;
    d.set_item("clock", meta.frame.as_str())?;
    d.set_item("units", &meta.units)?;
    d.set_item("femto_version", &meta.femto_version)?;
    d.set_item("command_line", &meta.command_line)?;
    d.set_item("notes", PyList::new(py, &meta.notes)?)?;
    d.set_item("groups", PyList::new(py, &meta.groups)?)?;
    d.set_item("has_mask", meta.has_mask)?;
    Ok(d)
}

/// The values of the cube at `path` as a float32 array `(ny, nx, nt)` and its mask (uint8
/// `(ny, nx)`, or None), read with the GIL released.
#[pyfunction]
#[pyo3(signature = (path, progress=None))]
pub fn read_values<'py>(
    py: Python<'py>,
    path: PathBuf,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyAny>, Option<Bound<'py, PyAny>>)> {
    let cube = run_stage(py, progress.as_ref(), |shared| {
        let reader = CubeReader::open(&path).py_err()?;
        femto::pipeline::Progress::start(shared, "reading", reader.meta().ny as u64);
        reader
            .read_cube_reporting(&|rows| shared.set(rows as u64))
            .py_err()
    })?;
    let (ny, nx, nt) = cube.shape();
    let data = Array3::from_shape_vec((ny, nx, nt), cube.data)
        .map_err(|e| value_error(format!("{}: {e}", path.display())))?;
    let mask = match cube.mask {
        Some(m) => Some(
            Array2::from_shape_vec((ny, nx), m)
                .map_err(|e| value_error(format!("{}: /mask: {e}", path.display())))?
                .into_pyarray(py)
                .into_any(),
        ),
        None => None,
    };
    Ok((data.into_pyarray(py).into_any(), mask))
}

/// The extra group `name` of the file at `path`: `(attrs dict, datasets dict of arrays)`.
#[pyfunction]
pub fn read_group<'py>(
    py: Python<'py>,
    path: PathBuf,
    name: String,
) -> PyResult<(Bound<'py, PyDict>, Bound<'py, PyDict>)> {
    let data = py
        .detach(|| GroupReader::open(&path).and_then(|r| r.read_group(&name)))
        .py_err()?;
    let attrs = PyDict::new(py);
    for (k, v) in &data.attrs {
        attrs.set_item(k, attr_value(py, v)?)?;
    }
    let datasets = PyDict::new(py);
    for (k, shape, values) in &data.datasets {
        datasets.set_item(k, dataset_array(py, shape, values)?)?;
    }
    Ok((attrs, datasets))
}

/// The temporal prefix sums of a cube (its stored `pyramid` group or side file), for box
/// integrals over any time window.
#[pyclass(module = "femto._femto", name = "Pyramid", frozen)]
pub struct PyPyramid {
    pyramid: femto::pyramid::Pyramid,
}

#[pymethods]
impl PyPyramid {
    /// The signal of every pixel integrated over `[t0_ps, t1_ps)` (ps, the cube's clock),
    /// as float64 `(ny, nx)`: the stored prefix sums, interpolated within a bin.
    fn integral<'py>(
        &self,
        py: Python<'py>,
        t0_ps: f64,
        t1_ps: f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        if !(t0_ps.is_finite() && t1_ps.is_finite()) {
            return Err(value_error(format!(
                "integral({t0_ps}, {t1_ps}): the window must be finite picoseconds"
            )));
        }
        let p = &self.pyramid;
        let values = py.detach(|| {
            use rayon::prelude::*;
            let mut out = vec![0.0f64; p.nx * p.ny];
            out.par_chunks_mut(p.nx).enumerate().for_each(|(y, row)| {
                for (x, v) in row.iter_mut().enumerate() {
                    *v = p.integral(x, y, t0_ps, t1_ps);
                }
            });
            out
        });
        Ok(Array2::from_shape_vec((p.ny, p.nx), values)
            .map_err(|e| value_error(e.to_string()))?
            .into_pyarray(py)
            .into_any())
    }

    /// `(ny, nx, nt)` of the cube the prefix sums were built from.
    #[getter]
    fn shape(&self) -> (usize, usize, usize) {
        (self.pyramid.ny, self.pyramid.nx, self.pyramid.axis.nt)
    }

    /// Number of mip levels stored.
    #[getter]
    fn levels(&self) -> usize {
        self.pyramid.level_count()
    }

    fn __repr__(&self) -> String {
        let p = &self.pyramid;
        format!(
            "Pyramid(ny={}, nx={}, nt={}, levels={})",
            p.ny,
            p.nx,
            p.axis.nt,
            p.level_count()
        )
    }
}

/// The pyramid stored for the cube at `path` (from `side_file` when given), checked against
/// the cube's shape and time axis.
#[pyfunction]
#[pyo3(signature = (path, side_file=None))]
pub fn read_pyramid(
    py: Python<'_>,
    path: PathBuf,
    side_file: Option<PathBuf>,
) -> PyResult<PyPyramid> {
    let pyramid = py
        .detach(|| femto::store::pyramid::read_pyramid_for(&path, side_file.as_deref()))
        .py_err()?;
    Ok(PyPyramid { pyramid })
}

/// Write `array` (float32 `(ny, nx, nt)`, C order or not) as a cube file at `path`:
/// bins of `dt_ps` from `t0_ps`, on `clock`, values in `units`, with `notes` as string
/// attributes of `/cube`. The library's checks ([`femto::container::check_cube`]: a finite
/// axis, finite values, a mask of 0 and 1) refuse it before anything is written; the write
/// is atomic and Ctrl-C stops it between slabs, leaving nothing at `path`.
#[pyfunction]
#[pyo3(signature = (array, dt_ps, t0_ps, path, clock, units, notes, mask, force, compression, progress))]
#[allow(clippy::too_many_arguments)]
pub fn write_cube(
    py: Python<'_>,
    array: PyReadonlyArray3<'_, f32>,
    dt_ps: f64,
    t0_ps: f64,
    path: PathBuf,
    clock: &str,
    units: &str,
    notes: Vec<(String, String)>,
    mask: Option<numpy::PyReadonlyArray2<'_, u8>>,
    force: bool,
    compression: Option<String>,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<()> {
    let compression = match compression.as_deref() {
        None => femto::container::CubeCompression::default(),
        Some(c) => femto::container::CubeCompression::parse(c)
            .map_err(|e| value_error(format!("compression={c}: {e}")))?,
    };
    let frame = TimeFrame::parse(clock)
        .ok_or_else(|| value_error(format!("clock={clock:?}: expected \"camera\" or \"world\"")))?;
    let shape = array.as_array().shape().to_vec();
    let (ny, nx, nt) = (shape[0], shape[1], shape[2]);
    // The arrays' own buffers (C order: femto/_cube.py makes them so), not copies.
    let values = array
        .as_slice()
        .map_err(|e| value_error(format!("array: {e} (expected C order)")))?;
    let mask_values = match &mask {
        Some(m) => {
            let shape = m.as_array().shape().to_vec();
            if shape != [ny, nx] {
                return Err(value_error(format!(
                    "mask of shape ({}, {}): expected (ny, nx) = ({ny}, {nx}), the array's first two",
                    shape[0], shape[1]
                )));
            }
            Some(
                m.as_slice()
                    .map_err(|e| value_error(format!("mask: {e} (expected C order)")))?,
            )
        }
        None => None,
    };
    if !force && path.exists() {
        return Err(value_error(format!(
            "path={}: exists; pass force=True to replace it",
            path.display()
        )));
    }
    let cube = CubeView {
        nx,
        ny,
        axis: TimeAxis { t0_ps, dt_ps, nt },
        frame,
        values,
        mask: mask_values,
    };
    let mut provenance = Provenance::new("python: femto.cube_from_array");
    provenance.notes = notes;
    run_stage(py, progress.as_ref(), |shared| {
        femto::pipeline::Progress::start(shared, "writing", ny as u64);
        femto::container::write_checked_cube(
            &path,
            &cube,
            units,
            &provenance,
            compression,
            &|rows| shared.set(rows as u64),
        )
        .py_err()
    })
}

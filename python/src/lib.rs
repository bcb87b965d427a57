//! The `femto` Python package's extension module (`femto._femto`): the library's stages and
//! cube container called directly, numpy arrays in and out. `python/python/femto/__init__.py`
//! wraps these functions with keyword arguments named as the CLI's flags, docstrings, and
//! progress bars.
//!
//! | module | what it binds |
//! |---|---|
//! | `errors` | library errors as `femto.FemtoError` and its OSError variants, the CLI's line |
//! | `runner` | long stages on a worker thread: GIL released, progress, Ctrl-C |
//! | `cube` | `open_cube`'s reads, the pyramid's integrals, `cube_from_array`'s write |
//! | `stages` | `ingest`, `calibrate`, `unwarp`, `pyramid`, y-tal and mitransient interop |
//! | `instruments` | the kind of an input, array/Delmic/PTU ingest, `info` (`femto info`) |
//! | `simulate` | `simulate`: a streak capture, band or transient cube of a scene |
//! | `render` | `render` and `render_still`: frames in memory or written as the CLI writes them |

mod cube;
mod errors;
mod instruments;
mod render;
mod runner;
mod simulate;
mod stages;

use pyo3::prelude::*;

#[pymodule]
fn _femto(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(cube::read_meta, m)?)?;
    m.add_function(wrap_pyfunction!(cube::read_values, m)?)?;
    m.add_function(wrap_pyfunction!(cube::read_group, m)?)?;
    m.add_function(wrap_pyfunction!(cube::read_pyramid, m)?)?;
    m.add_function(wrap_pyfunction!(cube::write_cube, m)?)?;
    m.add_class::<cube::PyPyramid>()?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::render_still, m)?)?;
    m.add_function(wrap_pyfunction!(render::state_path_toml, m)?)?;
    for f in [
        wrap_pyfunction!(stages::pyramid, m)?,
        wrap_pyfunction!(stages::unwarp, m)?,
        wrap_pyfunction!(stages::calibrate, m)?,
        wrap_pyfunction!(stages::ingest, m)?,
        wrap_pyfunction!(stages::export_tal, m)?,
        wrap_pyfunction!(stages::ingest_tal, m)?,
        wrap_pyfunction!(stages::ingest_mitransient, m)?,
        wrap_pyfunction!(instruments::input_kind, m)?,
        wrap_pyfunction!(instruments::ingest_array, m)?,
        wrap_pyfunction!(instruments::info, m)?,
        wrap_pyfunction!(simulate::simulate, m)?,
    ] {
        m.add_function(f)?;
    }
    Ok(())
}

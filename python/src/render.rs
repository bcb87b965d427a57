//! `femto.render` and `femto.render_still`: the render stage ([`femto::pipeline::render`])
//! with the options of `femto render`'s flags, frames kept in memory as numpy arrays (8-bit
//! display sRGB as the PNG frames hold, or linear float32 as the EXR frames hold), or
//! written to `out` exactly as the CLI writes them.

use crate::errors::{value_error, IntoPy};
use crate::runner::run_stage;
use femto::pipeline::render::{
    check_camera, check_options, open_render_inputs, plan, render_planned, render_to, Camera,
    RenderInputs, RenderOptions, Rendered, SceneGeometry, ViewKind,
};
use femto::pipeline::StageError;
use femto::relativity::Radiometry;
use femto::render::paths::Shortcut;
use femto::render::Effects;
use femto::video::VideoFormat;
use femto::view::state::ViewState;
use numpy::ndarray::Array4;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};

/// Parse a `--radiometry` value.
fn parse_radiometry(name: &str) -> PyResult<Radiometry> {
    match name.trim().to_ascii_lowercase().as_str() {
        "consistent" => Ok(Radiometry::Consistent),
        "paper" => Ok(Radiometry::Paper),
        _ => Err(value_error(format!(
            "--radiometry {name}: expected consistent or paper"
        ))),
    }
}

/// Parse a `--view` value.
fn view_kind(name: &str) -> PyResult<ViewKind> {
    match name.trim().to_ascii_lowercase().as_str() {
        "transient" => Ok(ViewKind::Transient),
        "naive" => Ok(ViewKind::Naive),
        "isochrones" => Ok(ViewKind::Isochrones),
        "integrated" => Ok(ViewKind::Integrated),
        _ => Err(value_error(format!(
            "--view {name}: expected transient, naive, isochrones or integrated"
        ))),
    }
}

/// Parse a `--format` value.
fn video_format(name: &str) -> PyResult<VideoFormat> {
    VideoFormat::parse(name).map_err(|e| value_error(format!("--format {name}: {e}")))
}

/// Open the render inputs: a cube with calibration and mesh, or a y-tal wall cube alone.
fn open_inputs(
    cube: &Path,
    calibration: Option<&Path>,
    mesh: Option<&Path>,
    pyramid: Option<&Path>,
    laser_nm: Option<f64>,
) -> PyResult<RenderInputs> {
    let geometry = match (calibration, mesh) {
        (Some(calibration), Some(mesh)) => SceneGeometry::Files { calibration, mesh },
        (None, None) => SceneGeometry::Wall,
        (Some(_), None) => {
            return Err(value_error(
                "calibration= needs mesh= (both, or neither for a y-tal wall cube)",
            ))
        }
        (None, Some(_)) => {
            return Err(value_error(
                "mesh= needs calibration= (both, or neither for a y-tal wall cube)",
            ))
        }
    };
    open_render_inputs(cube, pyramid, geometry, laser_nm).py_err()
}

/// The figures `femto render` prints, as a dict.
fn figures<'py>(py: Python<'py>, done: &Rendered) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("frames", (done.frames.start, done.frames.end))?;
    d.set_item("frames_written", done.frames_written)?;
    d.set_item("width", done.width)?;
    d.set_item("height", done.height)?;
    d.set_item("seconds", done.seconds)?;
    d.set_item("black_frames", done.black_frames.clone())?;
    d.set_item("time_offset_ps", done.time_offset_ps)?;
    d.set_item("dtau_ps", done.dtau_ps)?;
    d.set_item("laser_nm", done.laser.nm)?;
    d.set_item("laser", done.laser.to_string())?;
    d.set_item("warnings", done.warnings.clone())?;
    Ok(d)
}

/// Render `camera` on the inputs `open` opens (on the worker, so that Ctrl-C reaches a slow
/// open) into memory: `(frames, h, w, 3)` uint8 display sRGB, or float32 linear RGB when
/// `linear`.
fn render_in_memory<'py>(
    py: Python<'py>,
    open: &(dyn Fn() -> PyResult<RenderInputs> + Sync),
    camera: &Camera,
    options: &RenderOptions,
    linear: bool,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    enum Pixels {
        Srgb8(Vec<u8>),
        Linear(Vec<f32>),
    }
    let (pixels, done, shape) = run_stage(py, progress, |shared| {
        let inputs = open()?;
        shared.check();
        let scene = inputs.scene().py_err()?;
        shared.check();
        let plan = plan(&scene, camera, options).py_err()?;
        shared.check();
        let spec = plan.path.spec();
        let n = plan.frames.len();
        let values = n * spec.width * spec.height * 3;
        let bytes_per_value = if linear { 4.0 } else { 1.0 };
        femto::limits::check_memory(
            values as f64 * bytes_per_value,
            format_args!(
                "{n} frames of {}x{} held in memory as a numpy array",
                spec.width, spec.height
            ),
            "lower size= or frame_count=, render fewer frames= at a time, or write them with out=",
        )
        .py_err()?;
        let mut pixels = if linear {
            Pixels::Linear(Vec::with_capacity(values))
        } else {
            Pixels::Srgb8(vec![0u8; values])
        };
        let frame_len = spec.width * spec.height * 3;
        let mut k_local = 0usize;
        let done = render_planned(&inputs, &scene, &plan, shared, |k, frame, _| {
            match &mut pixels {
                Pixels::Linear(v) => v.extend(frame.iter().flatten()),
                Pixels::Srgb8(v) => {
                    let out = &mut v[k_local * frame_len..(k_local + 1) * frame_len];
                    plan.display_srgb8(&scene, k, frame, out);
                }
            }
            k_local += 1;
            Ok::<(), StageError>(())
        })
        .py_err()?;
        Ok((pixels, done, [n, spec.height, spec.width, 3]))
    })?;
    let array = match pixels {
        Pixels::Srgb8(v) => Array4::from_shape_vec(shape, v)
            .map_err(|e| value_error(e.to_string()))?
            .into_pyarray(py)
            .into_any(),
        Pixels::Linear(v) => Array4::from_shape_vec(shape, v)
            .map_err(|e| value_error(e.to_string()))?
            .into_pyarray(py)
            .into_any(),
    };
    let figures = figures(py, &done)?;
    Ok((array, figures))
}

/// `femto render`: see `femto.render` (python/python/femto/_render.py) for the arguments.
#[pyfunction]
#[pyo3(signature = (
    cube, calibration, mesh, path, pyramid, laser_nm, dolly, orbit, capture_view, size,
    frames, frame_count, dtau_ps, time_offset_ps, effects, radiometry, view, exposure,
    contour_ps, linear, out, format, fps, force, progress
))]
#[allow(clippy::too_many_arguments)]
pub fn render<'py>(
    py: Python<'py>,
    cube: PathBuf,
    calibration: Option<PathBuf>,
    mesh: Option<PathBuf>,
    path: Option<PathBuf>,
    pyramid: Option<PathBuf>,
    laser_nm: Option<f64>,
    dolly: Option<f64>,
    orbit: Option<f64>,
    capture_view: bool,
    size: Option<(usize, usize)>,
    frames: Option<(usize, usize)>,
    frame_count: Option<usize>,
    dtau_ps: Option<f64>,
    time_offset_ps: Option<f64>,
    effects: &str,
    radiometry: &str,
    view: &str,
    exposure: f64,
    contour_ps: Option<f64>,
    linear: bool,
    out: Option<PathBuf>,
    format: Option<String>,
    fps: f64,
    force: bool,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<(Option<Bound<'py, PyAny>>, Bound<'py, PyDict>)> {
    let chosen = [
        path.is_some(),
        dolly.is_some(),
        orbit.is_some(),
        capture_view,
    ];
    let n_chosen = chosen.iter().filter(|&&c| c).count();
    if n_chosen != 1 {
        return Err(value_error(format!(
            "give exactly one camera: path=, dolly=, orbit= or capture_view=True ({n_chosen} given)"
        )));
    }
    let camera = if let Some(p) = &path {
        Camera::PathFile(p.clone())
    } else if let Some(beta) = dolly {
        Camera::Shortcut(Shortcut::Dolly { beta })
    } else if let Some(beta) = orbit {
        Camera::Shortcut(Shortcut::Orbit { beta })
    } else {
        Camera::Shortcut(Shortcut::CaptureView)
    };
    check_camera(&camera).py_err()?;
    if let Some((a, b)) = frames {
        if a >= b {
            return Err(value_error(format!(
                "--frames {a}..{b}: expected A..B with A < B, frame B excluded, e.g. 0..50"
            )));
        }
    }
    let format = match (&format, &out) {
        (Some(f), _) => video_format(f)?,
        (None, Some(o)) => match VideoFormat::from_path(o) {
            Some(Ok(f)) => f,
            Some(Err(e)) => {
                return Err(value_error(format!(
                    "--out {}: {e}; name the format with --format",
                    o.display()
                )))
            }
            None => VideoFormat::PngSequence,
        },
        (None, None) => VideoFormat::PngSequence,
    };
    let options = RenderOptions {
        size,
        frame_count,
        frames: frames.map(|(a, b)| a..b),
        dtau_ps,
        time_offset_ps,
        effects: Effects::parse(effects)
            .map_err(|e| value_error(format!("--effects {effects}: {e}")))?,
        radiometry: parse_radiometry(radiometry)?,
        view: view_kind(view)?,
        exposure,
        contour_ps,
        format,
        fps,
        force,
        dark_marks: false,
        false_colour: false,
    };
    check_options(&options).py_err()?;
    let open = || {
        open_inputs(
            &cube,
            calibration.as_deref(),
            mesh.as_deref(),
            pyramid.as_deref(),
            laser_nm,
        )
    };
    match out {
        None => {
            let (array, figures) =
                render_in_memory(py, &open, &camera, &options, linear, progress.as_ref())?;
            Ok((Some(array), figures))
        }
        Some(out) => {
            let mut input_paths: Vec<&Path> = vec![cube.as_path()];
            input_paths.extend(calibration.as_deref());
            input_paths.extend(mesh.as_deref());
            input_paths.extend(pyramid.as_deref());
            input_paths.extend(path.as_deref());
            let done = run_stage(py, progress.as_ref(), |shared| {
                let inputs = open()?;
                shared.check();
                render_to(&inputs, &camera, &options, &out, &input_paths, shared).py_err()
            })?;
            Ok((None, figures(py, &done)?))
        }
    }
}

/// `femto.render_still`: the frame of a viewer state (the `/api/state` JSON of
/// `femto view`), as `femto render --path` renders the state's one-frame path.
#[pyfunction]
#[pyo3(signature = (cube, calibration, mesh, state_json, pyramid, linear, progress))]
#[allow(clippy::too_many_arguments)]
pub fn render_still<'py>(
    py: Python<'py>,
    cube: PathBuf,
    calibration: Option<PathBuf>,
    mesh: Option<PathBuf>,
    state_json: &str,
    pyramid: Option<PathBuf>,
    linear: bool,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let state = ViewState::from_json(state_json.as_bytes()).py_err()?;
    let path = state.path().py_err()?;
    let camera = Camera::Path {
        path: Box::new(path),
        name: "state".into(),
    };
    let options = state.render_options();
    let open = || {
        open_inputs(
            &cube,
            calibration.as_deref(),
            mesh.as_deref(),
            pyramid.as_deref(),
            Some(state.laser_nm),
        )
    };
    let (frames, figures) =
        render_in_memory(py, &open, &camera, &options, linear, progress.as_ref())?;
    // One frame: drop the frames axis.
    let shape: Vec<usize> = frames.getattr("shape")?.extract()?;
    let frame = frames.call_method1("reshape", (shape[1..].to_vec(),))?;
    Ok((frame, figures))
}

/// The camera path TOML of a viewer state, as `femto view` exports it (`inputs`: the
/// `femto render` flags to quote in its comment).
#[pyfunction]
pub fn state_path_toml(state_json: &str, inputs: &str) -> PyResult<String> {
    let state = ViewState::from_json(state_json.as_bytes()).py_err()?;
    Ok(state.path_toml(inputs))
}

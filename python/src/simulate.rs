//! `femto simulate` from Python: the keyword arguments (whole numbers checked exactly by
//! `femto/_args.py`) fill the library's [`SimulateRequest`] (the command's flags, with its
//! defaults), which
//! [`femto::pipeline::simulate`] checks, plans and runs on a worker thread
//! ([`run_stage`]); the figures the command prints come back as a dict.

use crate::errors::IntoPy;
use crate::runner::{run_stage, Shared};
use femto::pipeline::simulate::{parse_format, parse_time_filter, prepare, run, SimulateRequest};
use femto::simulate::{Flaws, SimulateSummary, Stage};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// The provenance a capture made from Python records.
const CREATED_BY: &str = "python: femto.simulate";

/// `femto simulate --out OUT ...`: a simulated streak capture (or band, or transient cube).
#[pyfunction]
#[pyo3(signature = (
    out, scene, bunny, format, spp, seed, bounces, size, nt, dt_ps, paper_size, transient_only,
    time_filter, rr_start_bounce, rows, marker_spacing_m, realistic, photon_noise, dark, vignetting, jitter_ps,
    power_sigma, sweep, saturation, fiducial_photo_px, force, progress
))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    out: PathBuf,
    scene: String,
    bunny: Option<PathBuf>,
    format: Vec<String>,
    spp: u32,
    seed: u64,
    bounces: u32,
    size: Option<(usize, usize)>,
    nt: Option<usize>,
    dt_ps: Option<f64>,
    paper_size: bool,
    transient_only: bool,
    time_filter: &str,
    rr_start_bounce: Option<u32>,
    rows: Option<(usize, usize)>,
    marker_spacing_m: f64,
    realistic: bool,
    photon_noise: Option<f64>,
    dark: Option<(f64, f64)>,
    vignetting: Option<f64>,
    jitter_ps: Option<f64>,
    power_sigma: Option<f64>,
    sweep: Option<f64>,
    saturation: Option<f64>,
    fiducial_photo_px: Option<f64>,
    force: bool,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut req = SimulateRequest {
        scene,
        bunny,
        out,
        force,
        formats: format
            .iter()
            .map(|f| parse_format(f))
            .collect::<Result<_, _>>()
            .py_err()?,
        spp,
        seed,
        bounces,
        size,
        nt,
        dt_ps,
        paper_size,
        transient_only,
        time_filter: parse_time_filter(time_filter).py_err()?,
        rr_start_bounce,
        rows: rows.map(|(a, b)| a..b),
        marker_spacing_m,
        realistic,
        flaws: Flaws {
            photon_noise,
            dark,
            vignetting,
            jitter_ps,
            power_sigma,
            sweep,
            saturation,
            fiducial_photo_px,
        },
        created_by: CREATED_BY.into(),
        command: Vec::new(),
        truth: None,
    };
    // A band records the command line `femto merge` re-plans the capture from.
    req.command = req.command_line();
    let (plan, summary) = run_stage(py, progress.as_ref(), |shared| {
        let plan = prepare(&req).py_err()?;
        let ny = plan.scene.camera.intrinsics.height;
        let rendered = plan.rows_rendered(req.rows.as_ref());
        let report = RowProgress::new(shared, rendered as u64, ny as u64);
        let on_rows = |stage: Stage, n: usize| report.add(stage, n as u64);
        let summary = run(&req, &plan, &on_rows).py_err()?;
        Ok((plan, summary))
    })?;
    let d = PyDict::new(py);
    let (scene, opts) = (&plan.scene, &plan.opts);
    let axis = scene.camera.axis;
    d.set_item("path", &summary.out_dir)?;
    d.set_item("scene", &scene.name)?;
    let (nx, ny) = (
        scene.camera.intrinsics.width,
        scene.camera.intrinsics.height,
    );
    d.set_item("shape", (ny, nx, axis.nt))?;
    d.set_item("t0_ps", axis.t0_ps)?;
    d.set_item("dt_ps", axis.dt_ps)?;
    d.set_item("spp", opts.spp)?;
    d.set_item("bounces", opts.max_bounces)?;
    d.set_item("seed", opts.seed)?;
    d.set_item("threads", rayon::current_num_threads())?;
    d.set_item("transient_only", opts.transient_only)?;
    d.set_item(
        "time_filter",
        femto::simulate::transient::time_filter_name(opts.time_filter),
    )?;
    d.set_item("rr_start_bounce", opts.rr_start_bounce)?;
    d.set_item("rows", req.rows.as_ref().map(|r| (r.start, r.end)))?;
    d.set_item("command", req.command.clone())?;
    summary_figures(&d, &summary)?;
    Ok(d)
}

/// The figures of a [`SimulateSummary`] the command prints.
fn summary_figures(d: &Bound<'_, PyDict>, s: &SimulateSummary) -> PyResult<()> {
    let in_scanlines =
        |f: &&PathBuf| f.parent().and_then(|p| p.file_name()) == Some("scanlines".as_ref());
    d.set_item("paths", s.paths)?;
    d.set_item("rays", s.rays)?;
    d.set_item("render_seconds", s.render_seconds)?;
    d.set_item("render_cpu_seconds", s.render_cpu_seconds)?;
    d.set_item("paths_per_second", s.paths_per_second)?;
    d.set_item("seconds", s.seconds)?;
    d.set_item("files", s.files.clone())?;
    d.set_item("streak_images", s.files.iter().filter(in_scanlines).count())?;
    d.set_item("fiducials", s.fiducials)?;
    d.set_item("values_at_top_count", s.values_at_top_count)?;
    Ok(())
}

/// The simulation's row counts as the runner's passes: "rendering" rows, then "writing"
/// scanlines (the second begins at the first scanline written).
struct RowProgress<'a> {
    shared: &'a Shared,
    writing_rows: u64,
    current: Mutex<Stage>,
    done: AtomicU64,
}

impl<'a> RowProgress<'a> {
    fn new(shared: &'a Shared, rendering_rows: u64, writing_rows: u64) -> Self {
        shared.begin("rendering", rendering_rows);
        RowProgress {
            shared,
            writing_rows,
            current: Mutex::new(Stage::Render),
            done: AtomicU64::new(0),
        }
    }

    /// `n` more rows of `stage` are done.
    fn add(&self, stage: Stage, n: u64) {
        if let Ok(mut current) = self.current.lock() {
            if *current != stage {
                *current = stage;
                self.done.store(0, Ordering::Relaxed);
                self.shared.begin("writing", self.writing_rows);
            }
        }
        let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
        self.shared.set(done);
    }
}

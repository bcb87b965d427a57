//! `femto demo`: the whole chain on the built-in scenes, reproducing the seed's figures
//! (Jarabo et al. 2013, Figs. 4 to 8) in one folder with a report.
//!
//! Stages, each a direct call into the library (no subprocess, no command line):
//!
//! 1. **simulate** ([`crate::simulate::simulate_capture`]): the built-in `cube` scene's
//!    transient (seed Eq. 1) rendered by the path tracer and written as a streak capture with
//!    [`crate::simulate::Flaws::realistic`] imperfections at a lower noise level (30 000
//!    photons at full scale and 0.1 % dark noise instead of 3 000 and 0.3 %: a lab averages
//!    many sweeps per scanline; at the realistic single-sweep level the noise of the empty
//!    bins fills the frames with speckle), plus its ground truth;
//! 2. **ingest**: the scanlines assembled into a camera-time cube with every correction (dark
//!    frame, flat field, sweep table, trigger jitter, laser power, saturation mask);
//! 3. **calibrate** ([`crate::calibrate`]): the camera fitted to the fiducial markers (pixel
//!    positions with 0.5 px of seeded Gaussian noise, the noise the calibrate issue's
//!    tolerances are stated for), then the time origin `t0` fitted to the direct light
//!    (first arrivals, then centroids over each pixel's footprint); both compared with the simulator's true calibration
//!    ([`chain::CalibrationErrors`]);
//! 4. **unwarp** ([`crate::unwarp`], seed Eq. 2): camera time to world time,
//!    `t_world = t_camera - eta |p - o| / c` per pixel;
//! 5. **pyramid** ([`crate::pyramid`]): the world cube's prefix sums;
//! 6. **render** ([`crate::render`]): the figures, written into the output folder:
//!    - `fig4_*.png`: a novel view at rest, naive (keeping the capture camera's time warp)
//!      and re-warped, and three isochrone images (seed Fig. 4);
//!    - `fig5_*.png`: one contact sheet per row of the seed's Fig. 5 (aberration towards and
//!      away from the scene, Doppler, searchlight), each effect alone at increasing speed;
//!    - `fig6_approach.mp4`: the camera accelerating towards the scene from rest to
//!      `beta = 0.77` with every effect (seed Fig. 6), and a sheet of some of its frames;
//!    - `fig7_bunny.mp4`: the same for the Cornell box with the bunny, when a bunny mesh is
//!      given (the whole chain is run on that scene too);
//!    - `fig8_*.png`: a sensor rotating about its optical axis at `beta_edge` 0, 0.4, 0.8,
//!      0.99 (seed Fig. 8);
//! 7. **report**: `report.md` (every image with its parameters, the calibration errors
//!    against their tolerances, the time of every stage) and `summary.json` (the same,
//!    machine-readable).
//!
//! Intermediate data go to `DIR/data/`: `capture/` (the simulated capture folder), `cube.h5`
//! (ingested, camera time), `world.h5` (unwarped), `calibration.toml` (fitted); the bunny
//! scene's under `DIR/data/bunny/`. Every file is written atomically.
//!
//! Sizes ([`DemoSizes`]): `--quick` is small enough for the tests' end-to-end run, the full
//! demo large enough that its figures show the indirect light without speckle. Their times
//! are measured by `tools/bench_demo.sh` into benches/demo_results.md (with the machine and
//! its load); the report gives the time of each stage of a run.

pub mod chain;
pub mod contact_sheet;
pub mod figures;
pub mod report;

pub use chain::{CalibrationErrors, Tolerances};

use crate::atomic::write_atomically;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Errors of the demo; each names the stage and, where there is one, the file.
#[derive(Debug, thiserror::Error)]
pub enum DemoError {
    /// A built-in scene could not be built (the bunny mesh file is missing or unreadable).
    #[error("scene: {0}")]
    Scene(#[from] crate::scene::SceneError),
    /// The simulated capture failed.
    #[error("simulate: {0}")]
    Simulate(#[from] crate::simulate::SimulateError),
    /// The capture could not be ingested.
    #[error("ingest: {0}")]
    Ingest(#[from] crate::ingest::IngestError),
    /// The capture's dark frame could not be read.
    #[error("ingest: {0}")]
    Format(#[from] crate::formats::FormatError),
    /// The capture's manifest could not be read.
    #[error("ingest: {0}")]
    Manifest(#[from] crate::manifest::ManifestError),
    /// A calibration could not be fitted or read.
    #[error("calibrate: {0}")]
    Calibrate(#[from] crate::calibrate::CalibrateError),
    /// The simulator's true calibration could not be read.
    #[error("calibrate: {0}")]
    Camera(#[from] crate::camera::CameraError),
    /// The capture's mesh could not be read.
    #[error("geometry: {0}")]
    Mesh(#[from] crate::geometry::load::LoadError),
    /// A cube file could not be written or read.
    #[error("container: {0}")]
    Container(#[from] crate::container::ContainerError),
    /// The unwarp failed.
    #[error("unwarp: {0}")]
    Unwarp(#[from] crate::unwarp::UnwarpError),
    /// A camera path could not be built.
    #[error("camera path: {0}")]
    Path(#[from] crate::camera_path::CameraPathError),
    /// The renderer refused its inputs.
    #[error("render: {0}")]
    Render(#[from] crate::render::RenderError),
    /// A stage of the pipeline failed.
    #[error(transparent)]
    Stage(#[from] crate::pipeline::StageError),
    /// A video could not be written.
    #[error("video: {0}")]
    Video(#[from] crate::video::VideoError),
    /// A PNG could not be encoded or written.
    #[error("{}: {source}", path.display())]
    Image {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    /// A file or folder could not be created or written.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The output folder exists and holds something else than an earlier demo.
    #[error("{}: {message}", path.display())]
    OutDir { path: PathBuf, message: String },
}

/// What to run.
#[derive(Clone, Debug, PartialEq)]
pub struct DemoOptions {
    /// Folder that receives the figures, the report and `data/`.
    pub out_dir: PathBuf,
    /// Small sizes ([`DemoSizes::quick`]).
    pub quick: bool,
    /// A bunny mesh (e.g. the Stanford bunny OBJ): also run the Cornell box with the bunny
    /// and write `fig7_bunny.mp4`.
    pub bunny: Option<PathBuf>,
    /// Replace an earlier demo in `out_dir` (without it, a folder holding anything is
    /// refused; with it, one holding other files than a demo's still is).
    pub force: bool,
}

/// Sizes of one demo run (see [`DemoSizes::quick`] and [`DemoSizes::full`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DemoSizes {
    /// Capture: pixels per scanline, scanlines, time bins and bin width.
    pub capture_nx: usize,
    pub capture_ny: usize,
    pub nt: usize,
    pub dt_ps: f64,
    /// Path tracer: samples per pixel and bounces of the simulated capture.
    pub spp: u32,
    pub max_bounces: u32,
    /// Image in which the fiducial markers are detected (the capture camera's field of view
    /// at this resolution; the fitted intrinsics are scaled to the capture's size).
    pub fiducial_nx: usize,
    pub fiducial_ny: usize,
    /// Stills (figs. 4, 5, 8).
    pub still_width: usize,
    pub still_height: usize,
    /// Videos (figs. 6, 7): frame size, frame count and playback rate.
    pub video_width: usize,
    pub video_height: usize,
    pub video_frames: usize,
    pub fps: f64,
}

impl DemoSizes {
    /// `--quick`: a 160 x 120 x 256 capture at 64 spp, 160 x 120 stills, a 32-frame video.
    pub fn quick() -> DemoSizes {
        DemoSizes {
            capture_nx: 160,
            capture_ny: 120,
            nt: 256,
            dt_ps: 4.0,
            spp: 64,
            max_bounces: 4,
            fiducial_nx: 4032,
            fiducial_ny: 3024,
            still_width: 160,
            still_height: 120,
            video_width: 160,
            video_height: 120,
            video_frames: 32,
            fps: 12.0,
        }
    }

    /// The full demo: a 320 x 240 x 256 capture at 4096 spp, 320 x 240 stills, a 120-frame
    /// video. The spp is what keeps the indirect light of 4 ps bins from looking like speckle
    /// (at 256 spp it does).
    pub fn full() -> DemoSizes {
        DemoSizes {
            capture_nx: 320,
            capture_ny: 240,
            nt: 256,
            dt_ps: 4.0,
            spp: 4096,
            max_bounces: 4,
            fiducial_nx: 4032,
            fiducial_ny: 3024,
            still_width: 320,
            still_height: 240,
            video_width: 320,
            video_height: 240,
            video_frames: 120,
            fps: 24.0,
        }
    }
}

/// Kind of an output file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum OutputKind {
    /// One rendered frame (PNG).
    Image,
    /// Several frames side by side with labels (PNG).
    Sheet,
    /// H.264 MP4.
    Video,
}

/// One figure file with what made it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OutputFile {
    /// `fig4` .. `fig8`.
    pub figure: String,
    /// Path relative to the output folder.
    pub path: String,
    pub kind: OutputKind,
    /// One line saying what it shows.
    pub caption: String,
    /// Rendering parameters (speed, effects, time, view, size, ...).
    pub params: BTreeMap<String, String>,
}

/// Wall-clock time of one stage.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StageTime {
    pub stage: String,
    pub seconds: f64,
}

/// What a demo run produced (also written as `summary.json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DemoSummary {
    pub out_dir: PathBuf,
    pub quick: bool,
    pub sizes: DemoSizes,
    /// Threads of the rayon pool the demo ran on.
    pub threads: usize,
    pub tolerances: Tolerances,
    /// One per scene whose chain ran (`cube`, and `bunny` when given).
    pub calibrations: Vec<CalibrationErrors>,
    /// Every figure file, in the order written.
    pub outputs: Vec<OutputFile>,
    /// Intermediate data, relative to the output folder.
    pub data_files: Vec<String>,
    pub stages: Vec<StageTime>,
    pub total_seconds: f64,
    /// `report.md` and `summary.json`, relative to the output folder.
    pub report: String,
    pub summary_json: String,
}

impl DemoSummary {
    /// Whether every calibration error is within its tolerance.
    pub fn calibration_ok(&self) -> bool {
        self.calibrations.iter().all(|c| c.within_tolerance)
    }
}

/// File names in the output folder.
pub const REPORT_FILE: &str = "report.md";
pub const SUMMARY_FILE: &str = "summary.json";
pub const DATA_DIR: &str = "data";
pub const COMMANDS_FILE: &str = "commands.sh";

/// Records the time of each stage and tells the caller when one starts and ends.
pub(crate) struct Stages<'a> {
    progress: &'a (dyn Fn(&str) + Sync),
    pub(crate) times: Vec<StageTime>,
}

impl<'a> Stages<'a> {
    fn new(progress: &'a (dyn Fn(&str) + Sync)) -> Stages<'a> {
        Stages {
            progress,
            times: Vec::new(),
        }
    }

    /// The progress line printer, for a stage that reports its own progress.
    pub(crate) fn say(&self) -> &'a (dyn Fn(&str) + Sync) {
        self.progress
    }

    /// Run `f` as the stage `name` (described by `what`), timing it.
    pub(crate) fn run<T>(
        &mut self,
        name: &str,
        what: &str,
        f: impl FnOnce() -> Result<T, DemoError>,
    ) -> Result<T, DemoError> {
        (self.progress)(&format!("{name}: {what}"));
        let t = Instant::now();
        let value = f()?;
        let seconds = t.elapsed().as_secs_f64();
        (self.progress)(&format!("{name}: done in {seconds:.1} s"));
        self.times.push(StageTime {
            stage: name.to_string(),
            seconds,
        });
        Ok(value)
    }
}

/// Write `bytes` to `path` atomically.
pub(crate) fn write_file(path: &Path, bytes: &[u8]) -> Result<(), DemoError> {
    write_atomically(path, |tmp| std::fs::write(tmp, bytes)).map_err(|source| DemoError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Write an 8-bit sRGB image as PNG, atomically.
pub(crate) fn write_png(
    path: &Path,
    width: usize,
    height: usize,
    rgb8: &[u8],
) -> Result<(), DemoError> {
    enum E {
        Io(std::io::Error),
        Image(image::ImageError),
    }
    impl From<std::io::Error> for E {
        fn from(e: std::io::Error) -> Self {
            E::Io(e)
        }
    }
    write_atomically(path, |tmp| {
        image::save_buffer_with_format(
            tmp,
            rgb8,
            width as u32,
            height as u32,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(E::Image)
    })
    .map_err(|e| match e {
        E::Io(source) => DemoError::Io {
            path: path.to_path_buf(),
            source,
        },
        E::Image(source) => DemoError::Image {
            path: path.to_path_buf(),
            source,
        },
    })
}

fn create_dir(path: &Path) -> Result<(), DemoError> {
    std::fs::create_dir_all(path).map_err(|source| DemoError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Refuse an output folder that holds files but no earlier demo (no `summary.json` and no
/// `data/`), so that the demo never mixes its files into an unrelated folder; and one that
/// holds an earlier demo unless `force` (the overwrite rule, [`crate::pipeline::overwrite`]).
fn check_out_dir(out_dir: &Path, force: bool) -> Result<(), DemoError> {
    let entries = match std::fs::read_dir(out_dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(source) => {
            return Err(DemoError::Io {
                path: out_dir.to_path_buf(),
                source,
            })
        }
    };
    let names: Vec<String> = entries
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    if names.is_empty() {
        Ok(())
    } else if names.iter().any(|n| n == SUMMARY_FILE || n == DATA_DIR) {
        if force {
            Ok(())
        } else {
            Err(DemoError::OutDir {
                path: out_dir.to_path_buf(),
                message: "holds an earlier demo; add --force to replace it".into(),
            })
        }
    } else {
        Err(DemoError::OutDir {
            path: out_dir.to_path_buf(),
            message: format!(
                "exists and holds {} entries but no earlier demo (no {SUMMARY_FILE} or {DATA_DIR}/); choose an empty or new folder",
                names.len()
            ),
        })
    }
}

/// Run the whole demo (module doc) into `opts.out_dir`. `progress` is told when each stage
/// starts and ends, one line each.
pub fn run_demo(
    opts: &DemoOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<DemoSummary, DemoError> {
    let started = Instant::now();
    let sizes = if opts.quick {
        DemoSizes::quick()
    } else {
        DemoSizes::full()
    };
    check_out_dir(&opts.out_dir, opts.force)?;
    let out = opts.out_dir.as_path();
    let data = out.join(DATA_DIR);
    create_dir(&data)?;
    let mut stages = Stages::new(progress);
    let tolerances = Tolerances::default();

    let cube_scene = crate::scene::Scene::builtin("cube", None)?;
    let cube = chain::run_chain(&cube_scene, &sizes, &data, "", &mut stages)?;
    let mut calibrations = vec![cube.errors.clone()];
    let mut commands = cube.commands.clone();
    let mut data_files = cube.data_files.clone();

    let mut outputs = Vec::new();
    {
        let scene = cube.render_scene()?;
        outputs.extend(stages.run(
            "fig4",
            "novel view, naive and re-warped; isochrones",
            || figures::fig4(&scene, &sizes, out),
        )?);
        outputs.extend(
            stages.run("fig5", "aberration, Doppler and searchlight rows", || {
                figures::fig5(&scene, &sizes, out)
            })?,
        );
        outputs.extend(stages.run(
            "fig6",
            "approach video, beta 0 to 0.77, every effect",
            || figures::approach_video(&scene, &sizes, out, "fig6", "fig6_approach"),
        )?);
        outputs.extend(stages.run("fig8", "rotating sensor", || {
            figures::fig8(&scene, &sizes, out)
        })?);
    }

    if let Some(mesh) = &opts.bunny {
        let bunny_scene = crate::scene::Scene::builtin("bunny", Some(mesh))?;
        let bunny = chain::run_chain(
            &bunny_scene,
            &sizes,
            &data.join("bunny"),
            "bunny ",
            &mut stages,
        )?;
        calibrations.push(bunny.errors.clone());
        commands.extend(bunny.commands.iter().cloned());
        data_files.extend(bunny.data_files.iter().cloned());
        let scene = bunny.render_scene()?;
        outputs.extend(
            stages.run("fig7", "Cornell box with the bunny: approach video", || {
                figures::approach_video(&scene, &sizes, out, "fig7", "fig7_bunny")
            })?,
        );
    }

    let mut summary = DemoSummary {
        out_dir: out.to_path_buf(),
        quick: opts.quick,
        sizes,
        threads: rayon::current_num_threads(),
        tolerances,
        calibrations,
        outputs,
        data_files: data_files.iter().map(|p| relative(out, p)).collect(),
        stages: Vec::new(),
        total_seconds: 0.0,
        report: REPORT_FILE.into(),
        summary_json: SUMMARY_FILE.into(),
    };
    let report_path = out.join(REPORT_FILE);
    let json_path = out.join(SUMMARY_FILE);
    progress("report: report.md and summary.json");
    summary.stages = std::mem::take(&mut stages.times);
    summary.total_seconds = started.elapsed().as_secs_f64();
    write_file(
        &out.join(COMMANDS_FILE),
        commands_script(&commands).as_bytes(),
    )?;
    write_file(&report_path, report::markdown(&summary).as_bytes())?;
    let json = serde_json::to_string_pretty(&summary).expect("the summary serialises");
    write_file(&json_path, json.as_bytes())?;
    Ok(summary)
}

/// `commands.sh`: the CLI commands that reproduce the demo's data products from its simulated
/// captures (run from the demo's folder, with `femto` on the PATH).
fn commands_script(commands: &[String]) -> String {
    let mut s = String::from(
        "#!/bin/sh\n# The femto commands that reproduce this demo's data products (cube, \
         calibration, world cube,\n# pyramid) from its simulated capture: the same stages with \
         the same options.\n# Run from this folder with femto on the PATH.\nset -e\ncd \"$(dirname \"$0\")\"\n",
    );
    for c in commands {
        s.push_str(c);
        s.push('\n');
    }
    s
}

/// `path` relative to `base` when it lies under it, else as given.
pub(crate) fn relative(base: &Path, path: &Path) -> String {
    path.strip_prefix(base)
        .unwrap_or(path)
        .to_string_lossy()
        .replace('\\', "/")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_earlier_demo_is_replaced_only_with_force() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("demo");
        assert!(check_out_dir(&out, false).is_ok(), "a new folder");
        std::fs::create_dir(&out).unwrap();
        assert!(check_out_dir(&out, false).is_ok(), "an empty folder");
        std::fs::create_dir(out.join(DATA_DIR)).unwrap();
        let e = check_out_dir(&out, false).unwrap_err().to_string();
        assert!(e.contains("earlier demo") && e.contains("--force"), "{e}");
        assert!(check_out_dir(&out, true).is_ok());
        std::fs::write(dir.path().join("notes.txt"), "mine").unwrap();
        let other = check_out_dir(dir.path(), true).unwrap_err().to_string();
        assert!(other.contains("no earlier demo"), "{other}");
    }
}

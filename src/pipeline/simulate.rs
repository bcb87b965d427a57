//! `femto simulate` as library calls: a [`SimulateRequest`] (the command's flags, typed, with
//! the command's defaults) is checked into a scene and [`SimulateOptions`] ([`plan`],
//! [`prepare`]) and run into a capture or band folder ([`run`]). The `femto simulate` and
//! `femto merge` commands and the Python package's `femto.simulate` call these, so a capture
//! is the same whichever front end asked for it, and so are the messages that refuse one:
//! each names the flag at fault as the command spells it (`--sweep: ...`).

use super::truth::{check_truth, stage_truth, TruthRequest};
use super::StageError;
use crate::geometry::bvh::Bvh;
use crate::manifest::StreakFormat;
use crate::render::truth::TruthOptions;
use crate::scene::{Scene, SceneError, BUILTIN_NAMES};
use crate::simulate::band::simulate_band;
use crate::simulate::capture::check_destination;
use crate::simulate::capture::simulate_capture_and;
use crate::simulate::fiducials::DEFAULT_MARKER_SPACING_M;
use crate::simulate::transient::time_filter_name;
use crate::simulate::{
    simulate_capture, Flaw, FlawError, Flaws, SimulateError, SimulateOption, SimulateOptions,
    SimulateSummary, Stage,
};
use crate::tracer::TimeFilter;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// `--paper-size`: the capture size of Jarabo et al. 2013, 672 x 600 pixels, 512 bins of
/// 1.71 ps.
pub const PAPER_SIZE: (usize, usize, usize, f64) = (672, 600, 512, 1.71);
/// The most bounces `--bounces` may ask for.
pub const MAX_BOUNCES: u32 = 1000;
/// The most time bins `--nt` may ask for.
pub const MAX_NT: usize = 1 << 20;

/// What `femto simulate` is asked for: one field per flag, `Default` being the command
/// without flags (the built-in `cube` scene at its own size, 64 paths per pixel, 4 bounces,
/// seed 0, PNG scanlines, no imperfections).
#[derive(Clone, Debug, PartialEq)]
pub struct SimulateRequest {
    /// `--scene`: a built-in name ([`BUILTIN_NAMES`]) or a scene file (.toml).
    pub scene: String,
    /// `--bunny`: the mesh file of the `bunny` scene.
    pub bunny: Option<PathBuf>,
    /// `--out`: the capture (or band) folder.
    pub out: PathBuf,
    /// `--force`: replace `out` if it exists.
    pub force: bool,
    /// `--format`: scanline formats, the first the manifest's primary file.
    pub formats: Vec<StreakFormat>,
    /// `--spp`: camera paths per pixel.
    pub spp: u32,
    /// `--seed`: the random seed (at most `i64::MAX`).
    pub seed: u64,
    /// `--bounces`: most surface interactions per path (1 to [`MAX_BOUNCES`]).
    pub bounces: u32,
    /// `--size`: image width and height in pixels (default: the scene's).
    pub size: Option<(usize, usize)>,
    /// `--nt`: time bins (default: the scene's; 1 to [`MAX_NT`]).
    pub nt: Option<usize>,
    /// `--dt-ps`: width of a time bin, ps (default: the scene's).
    pub dt_ps: Option<f64>,
    /// `--paper-size`: [`PAPER_SIZE`] (not with `size`, `nt` or `dt_ps`).
    pub paper_size: bool,
    /// `--transient-only`: only the true camera-time cube and the render's counters.
    pub transient_only: bool,
    /// `--time-filter`: how arrival times are binned ([`TimeFilter::Box`] only with
    /// `transient_only`).
    pub time_filter: TimeFilter,
    /// `--rr-start-bounce`: first bounce of Russian roulette (only with `transient_only`).
    pub rr_start_bounce: Option<u32>,
    /// `--rows A..B`: render only these image rows into a band folder.
    pub rows: Option<Range<usize>>,
    /// `--marker-spacing-m`: spacing of the fiducial marker grid, metres.
    pub marker_spacing_m: f64,
    /// `--realistic`: start from [`Flaws::realistic`] rather than no imperfections.
    pub realistic: bool,
    /// `--photon-noise`, `--dark`, ...: each imperfection given overrides the start set.
    pub flaws: Flaws,
    /// Provenance recorded in the manifest and the truth cubes.
    pub created_by: String,
    /// The command line recorded in a band's `band.toml`, which `femto merge` re-plans the
    /// capture from.
    pub command: Vec<String>,
    /// `--truth-path` and the render flags beside it: the direct truth of a moving camera,
    /// written into the capture as `truth/` frames ([`super::truth`]).
    pub truth: Option<TruthRequest>,
}

impl Default for SimulateRequest {
    fn default() -> Self {
        let opts = SimulateOptions::default();
        SimulateRequest {
            scene: "cube".into(),
            bunny: None,
            out: PathBuf::new(),
            force: false,
            formats: opts.formats,
            spp: opts.spp,
            seed: opts.seed,
            bounces: opts.max_bounces,
            size: None,
            nt: None,
            dt_ps: None,
            paper_size: false,
            transient_only: false,
            time_filter: opts.time_filter,
            rr_start_bounce: None,
            rows: None,
            marker_spacing_m: DEFAULT_MARKER_SPACING_M,
            realistic: false,
            flaws: Flaws::default(),
            created_by: opts.created_by,
            command: Vec::new(),
            truth: None,
        }
    }
}

impl SimulateRequest {
    /// The `femto simulate` command line that asks for this request (the flags that differ
    /// from the defaults, `--scene` and `--out` always): what a band made by another front
    /// end records, so that `femto merge` can re-plan its capture.
    pub fn command_line(&self) -> Vec<String> {
        let d = SimulateRequest::default();
        let mut c: Vec<String> = ["femto", "simulate", "--scene", &self.scene, "--out"]
            .map(String::from)
            .into();
        c.push(self.out.display().to_string());
        // `--name=value`: a value may start with a minus sign.
        let mut set = |name: &str, on: bool, value: String| {
            if on {
                c.push(format!("--{name}={value}"));
            }
        };
        if let Some(bunny) = &self.bunny {
            set("bunny", true, bunny.display().to_string());
        }
        let formats: Vec<&str> = self.formats.iter().map(|&f| format_name(f)).collect();
        set("format", self.formats != d.formats, formats.join(","));
        set("spp", self.spp != d.spp, self.spp.to_string());
        set("seed", self.seed != d.seed, self.seed.to_string());
        set(
            "bounces",
            self.bounces != d.bounces,
            self.bounces.to_string(),
        );
        let spacing = self.marker_spacing_m;
        set(
            "marker-spacing-m",
            spacing != d.marker_spacing_m,
            spacing.to_string(),
        );
        let filter = time_filter_name(self.time_filter);
        set(
            "time-filter",
            self.time_filter != d.time_filter,
            filter.into(),
        );
        let f = &self.flaws;
        let optional = [
            ("size", self.size.map(|(w, h)| format!("{w}x{h}"))),
            ("nt", self.nt.map(|n| n.to_string())),
            ("dt-ps", self.dt_ps.map(|v| v.to_string())),
            (
                "rr-start-bounce",
                self.rr_start_bounce.map(|b| b.to_string()),
            ),
            (
                "rows",
                self.rows
                    .as_ref()
                    .map(|r| format!("{}..{}", r.start, r.end)),
            ),
            ("photon-noise", f.photon_noise.map(|v| v.to_string())),
            ("dark", f.dark.map(|(o, s)| format!("{o},{s}"))),
            ("vignetting", f.vignetting.map(|v| v.to_string())),
            ("jitter-ps", f.jitter_ps.map(|v| v.to_string())),
            ("power-sigma", f.power_sigma.map(|v| v.to_string())),
            ("sweep", f.sweep.map(|v| v.to_string())),
            ("saturation", f.saturation.map(|v| v.to_string())),
            (
                "fiducial-photo-px",
                f.fiducial_photo_px.map(|v| v.to_string()),
            ),
        ];
        for (name, value) in optional {
            if let Some(v) = value {
                set(name, true, v);
            }
        }
        let switches = [
            ("force", self.force),
            ("paper-size", self.paper_size),
            ("transient-only", self.transient_only),
            ("realistic", self.realistic),
        ];
        for (name, on) in switches {
            if on {
                c.push(format!("--{name}"));
            }
        }
        c
    }
}

/// The `--format` name of a scanline format.
pub fn format_name(format: StreakFormat) -> &'static str {
    match format {
        StreakFormat::Png16 => "png16",
        StreakFormat::ExrF32 => "exr",
        StreakFormat::Img16 => "img16",
        StreakFormat::Img32 => "img32",
    }
}

/// Why a simulation was refused or failed; the message is `femto simulate`'s.
#[derive(Debug, thiserror::Error)]
pub enum SimulateRunError {
    /// A flag, or a combination of flags, is refused; the message names them.
    #[error("{0}")]
    Flags(String),
    /// The scene could not be loaded (a missing scene or mesh file, a malformed scene).
    #[error("--scene")]
    Scene(#[source] Box<SceneError>),
    /// The output is one of the inputs.
    #[error(transparent)]
    Stage(Box<StageError>),
    /// The output folder exists and is not empty, and `force` was not given.
    #[error("--out {0} (--force replaces it)")]
    OutputExists(Box<SimulateError>),
    /// The simulation failed (a file could not be written, ...).
    #[error(transparent)]
    Simulate(Box<SimulateError>),
}

impl From<StageError> for SimulateRunError {
    fn from(e: StageError) -> Self {
        SimulateRunError::Stage(Box::new(e))
    }
}

impl From<SceneError> for SimulateRunError {
    fn from(e: SceneError) -> Self {
        SimulateRunError::Scene(Box::new(e))
    }
}

impl From<SimulateError> for SimulateRunError {
    /// A library error in the command's words: options and imperfections named by their
    /// flags, an existing output with the hint that `--force` replaces it.
    fn from(e: SimulateError) -> Self {
        match e {
            SimulateError::InvalidOption { option, message } => {
                SimulateRunError::Flags(format!("{}: {message}", option_flag(option)))
            }
            SimulateError::Flaw(f) => f.into(),
            e @ SimulateError::OutputExists { .. } => SimulateRunError::OutputExists(Box::new(e)),
            other => SimulateRunError::Simulate(Box::new(other)),
        }
    }
}

impl From<FlawError> for SimulateRunError {
    fn from(f: FlawError) -> Self {
        SimulateRunError::Flags(format!("{}: {}", flaw_flag(f.flaw), f.message))
    }
}

/// The flag that sets each imperfection.
pub fn flaw_flag(flaw: Flaw) -> &'static str {
    match flaw {
        Flaw::PhotonNoise => "--photon-noise",
        Flaw::Dark => "--dark",
        Flaw::Vignetting => "--vignetting",
        Flaw::JitterPs => "--jitter-ps",
        Flaw::PowerSigma => "--power-sigma",
        Flaw::Sweep => "--sweep",
        Flaw::Saturation => "--saturation",
        Flaw::FiducialPhotoPx => "--fiducial-photo-px",
    }
}

/// The flag that sets each option [`SimulateOptions::validate`] checks.
pub fn option_flag(option: SimulateOption) -> &'static str {
    match option {
        SimulateOption::Spp => "--spp",
        SimulateOption::MaxBounces => "--bounces",
        SimulateOption::Seed => "--seed",
        SimulateOption::Formats => "--format",
        SimulateOption::MarkerSpacingM => "--marker-spacing-m",
        SimulateOption::TimeFilter => "--time-filter",
        SimulateOption::RrStartBounce => "--rr-start-bounce",
    }
}

/// A scanline format by its `--format` name (`png16` or `png`, `exr`, `img16` or `img`,
/// `img32`; any case).
pub fn parse_format(name: &str) -> Result<StreakFormat, SimulateRunError> {
    match name.trim().to_ascii_lowercase().as_str() {
        "png16" | "png" => Ok(StreakFormat::Png16),
        "exr" => Ok(StreakFormat::ExrF32),
        "img16" | "img" => Ok(StreakFormat::Img16),
        "img32" => Ok(StreakFormat::Img32),
        _ => Err(SimulateRunError::Flags(format!(
            "--format: '{name}' is not a scanline format (png16, exr, img16, img32)"
        ))),
    }
}

/// A time filter by its `--time-filter` name (`sensor` or `box`; any case).
pub fn parse_time_filter(name: &str) -> Result<TimeFilter, SimulateRunError> {
    match name.trim().to_ascii_lowercase().as_str() {
        "sensor" => Ok(TimeFilter::Sensor),
        "box" => Ok(TimeFilter::Box),
        _ => Err(SimulateRunError::Flags(format!(
            "--time-filter: '{name}' is not a time filter (sensor, box)"
        ))),
    }
}

/// The scene and the checked options a request makes.
#[derive(Debug)]
pub struct SimulatePlan {
    /// The scene at the requested size.
    pub scene: Scene,
    /// The options of the capture.
    pub opts: SimulateOptions,
}

impl SimulatePlan {
    /// The first line `femto simulate` prints: the scene, its size, the render's settings.
    pub fn describe(&self, threads: usize) -> String {
        let (scene, opts) = (&self.scene, &self.opts);
        let (nx, ny) = (
            scene.camera.intrinsics.width,
            scene.camera.intrinsics.height,
        );
        let axis = scene.camera.axis;
        let transient = if opts.transient_only {
            format!(
                ", transient only, time filter {}",
                time_filter_name(opts.time_filter)
            )
        } else {
            String::new()
        };
        format!(
            "femto simulate: scene {}, {nx} x {ny} pixels, {} bins of {} ps from {} ps, spp {}, \
             bounces {}, seed {}, {threads} threads{transient}",
            scene.name, axis.nt, axis.dt_ps, axis.t0_ps, opts.spp, opts.max_bounces, opts.seed,
        )
    }

    /// Image rows rendered: the band's, or all.
    pub fn rows_rendered(&self, rows: Option<&Range<usize>>) -> usize {
        rows.map_or(self.scene.camera.intrinsics.height, |r| r.len())
    }
}

/// Check the values that `femto simulate`'s flag parser checks before anything runs (the
/// CLI never gets here with them wrong; other front ends do).
fn check_flags(req: &SimulateRequest) -> Result<(), SimulateRunError> {
    let refuse = |m: String| Err(SimulateRunError::Flags(m));
    if !(1..=MAX_BOUNCES).contains(&req.bounces) {
        return refuse(format!(
            "--bounces: {} is not in 1..={MAX_BOUNCES}",
            req.bounces
        ));
    }
    if let Some(nt) = req.nt {
        if !(1..=MAX_NT).contains(&nt) {
            return refuse(format!("--nt: {nt} is not in 1..={MAX_NT}"));
        }
    }
    if let Some((w, h)) = req.size {
        if w == 0 || h == 0 {
            return refuse(format!(
                "--size: {w}x{h}: expected WIDTHxHEIGHT with both at least 1, e.g. 640x480"
            ));
        }
    }
    if let Some(d) = req.dt_ps {
        if !(d.is_finite() && d > 0.0) {
            return refuse(format!("--dt-ps: {d} must be finite and > 0"));
        }
    }
    if req.paper_size && (req.size.is_some() || req.nt.is_some() || req.dt_ps.is_some()) {
        return refuse("--paper-size cannot be used with --size, --nt or --dt-ps".into());
    }
    if let Some(rows) = &req.rows {
        if rows.start >= rows.end {
            return refuse(format!(
                "--rows {}..{}: expected A..B with A < B, row B excluded, e.g. 0..100",
                rows.start, rows.end
            ));
        }
        if req.transient_only {
            return refuse("--rows cannot be used with --transient-only".into());
        }
    }
    if req.time_filter != TimeFilter::Sensor && !req.transient_only {
        return refuse("--time-filter needs --transient-only".into());
    }
    if req.transient_only {
        let streak = req.formats != SimulateOptions::default().formats
            || req.realistic
            || req.flaws != Flaws::default()
            || req.marker_spacing_m != DEFAULT_MARKER_SPACING_M;
        if streak {
            return refuse(
                "--transient-only cannot be used with --format, --realistic, the \
                 imperfections or --marker-spacing-m (it writes no streak images)"
                    .into(),
            );
        }
    }
    Ok(())
}

/// The scene a request names: built-in (with `bunny`'s mesh file) or a scene file.
pub fn load_scene(req: &SimulateRequest) -> Result<Scene, SimulateRunError> {
    let refuse = |m: &str| Err(SimulateRunError::Flags(m.into()));
    let name = req.scene.as_str();
    if BUILTIN_NAMES.contains(&name) {
        if name == "bunny" && req.bunny.is_none() {
            return refuse(
                "--scene bunny needs --bunny PATH (a mesh file, e.g. the Stanford bunny OBJ)",
            );
        }
        if name != "bunny" && req.bunny.is_some() {
            return refuse("--bunny applies only to --scene bunny");
        }
        return Ok(Scene::builtin(name, req.bunny.as_deref())?);
    }
    if req.bunny.is_some() {
        return refuse("--bunny applies only to --scene bunny");
    }
    let path = Path::new(name);
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"))
        || path.exists()
    {
        return Ok(Scene::load(path)?);
    }
    Err(SimulateRunError::Flags(format!(
        "--scene: '{name}' is neither a built-in scene ({}) nor a scene file (.toml)",
        BUILTIN_NAMES.join(", ")
    )))
}

/// `scene` at the size the request asks for (`--paper-size`, `--size`, `--nt`, `--dt-ps`).
fn resized(scene: Scene, req: &SimulateRequest) -> Scene {
    let cam = &scene.camera;
    let own = (
        cam.intrinsics.width,
        cam.intrinsics.height,
        cam.axis.nt,
        cam.axis.dt_ps,
    );
    let (mut nx, mut ny, mut nt, mut dt_ps) = if req.paper_size { PAPER_SIZE } else { own };
    if let Some(size) = req.size {
        (nx, ny) = size;
    }
    nt = req.nt.unwrap_or(nt);
    dt_ps = req.dt_ps.unwrap_or(dt_ps);
    if (nx, ny, nt, dt_ps) == own {
        return scene;
    }
    scene.with_resolution(nx, ny, nt, dt_ps)
}

/// The imperfections a request asks for: the start set (realistic or none) with each one
/// given overriding it.
fn flaws(req: &SimulateRequest) -> Flaws {
    let start = if req.realistic {
        Flaws::realistic()
    } else {
        Flaws::default()
    };
    let given = &req.flaws;
    Flaws {
        photon_noise: given.photon_noise.or(start.photon_noise),
        dark: given.dark.or(start.dark),
        vignetting: given.vignetting.or(start.vignetting),
        jitter_ps: given.jitter_ps.or(start.jitter_ps),
        power_sigma: given.power_sigma.or(start.power_sigma),
        sweep: given.sweep.or(start.sweep),
        saturation: given.saturation.or(start.saturation),
        fiducial_photo_px: given.fiducial_photo_px.or(start.fiducial_photo_px),
    }
}

/// Check a request's flags and load its scene into the capture's scene and options (what
/// `femto merge` re-plans a band's capture with). The output is not looked at.
pub fn plan(req: &SimulateRequest) -> Result<SimulatePlan, SimulateRunError> {
    check_flags(req)?;
    let flaws = flaws(req);
    flaws.validate()?;
    let scene = resized(load_scene(req)?, req);
    let opts = SimulateOptions {
        spp: req.spp,
        seed: req.seed,
        max_bounces: req.bounces,
        formats: req.formats.clone(),
        flaws,
        marker_spacing_m: req.marker_spacing_m,
        force: req.force,
        created_by: req.created_by.clone(),
        transient_only: req.transient_only,
        time_filter: req.time_filter,
        rr_start_bounce: req.rr_start_bounce,
    };
    opts.validate(&scene)?;
    Ok(SimulatePlan { scene, opts })
}

/// [`plan`] and the output's checks, in `femto simulate`'s order: the output may not be or
/// hold an input, the request must plan, the output must be new or empty (unless `force`),
/// and a band's rows must lie in the image. Nothing is written.
pub fn prepare(req: &SimulateRequest) -> Result<SimulatePlan, SimulateRunError> {
    // The capture folder replaces `out` whole: it may not be or hold an input.
    let scene_file = Path::new(&req.scene);
    let inputs: Vec<&Path> = [
        Some(scene_file).filter(|p| p.is_file()),
        req.bunny.as_deref(),
    ]
    .into_iter()
    .flatten()
    .collect();
    super::refuse_same_file(&req.out, &inputs, "out")?;
    let plan = plan(req)?;
    check_destination(&req.out, plan.opts.force)
        .map_err(|e| SimulateRunError::OutputExists(Box::new(e)))?;
    let ny = plan.scene.camera.intrinsics.height;
    if let Some(truth) = &req.truth {
        if req.transient_only || req.rows.is_some() {
            return Err(SimulateRunError::Flags(format!(
                "--truth-path: not with {} (the truth is rendered against a whole capture's \
                 truth_world.h5)",
                if req.transient_only {
                    "--transient-only"
                } else {
                    "--rows"
                }
            )));
        }
        let bvh = Bvh::new(plan.scene.mesh.clone());
        check_truth(truth, &plan.scene, &bvh)?;
    }
    if let Some(rows) = &req.rows {
        if rows.end > ny {
            return Err(SimulateRunError::Flags(format!(
                "--rows {}..{}: beyond the image's {ny} rows (0 <= A < B <= {ny})",
                rows.start, rows.end
            )));
        }
    }
    Ok(plan)
}

/// Write the capture (or, with `rows`, the band) a prepared request asks for into
/// `req.out`; `progress` is told of each finished row ([`Stage`]).
pub fn run(
    req: &SimulateRequest,
    plan: &SimulatePlan,
    progress: &(dyn Fn(Stage, usize) + Sync),
) -> Result<SimulateSummary, SimulateRunError> {
    let (scene, opts) = (&plan.scene, &plan.opts);
    let summary = match (&req.rows, &req.truth) {
        (Some(rows), _) => {
            simulate_band(scene, opts, rows.clone(), &req.command, &req.out, progress)
        }
        (None, None) => simulate_capture(scene, opts, &req.out, progress),
        (None, Some(truth)) => simulate_capture_and(scene, opts, &req.out, progress, |tmp| {
            let bvh = Bvh::new(scene.mesh.clone());
            let opts = TruthOptions {
                spp: truth.spp.unwrap_or(opts.spp),
                max_bounces: opts.max_bounces,
                seed: opts.seed,
            };
            stage_truth(scene, &bvh, truth, opts, tmp, &|| progress(Stage::Truth, 1))
                .map(Some)
                .map_err(|e| SimulateError::Staged {
                    message: e.to_string(),
                })
        }),
    };
    Ok(summary?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refusal(req: SimulateRequest) -> String {
        match plan(&req) {
            Ok(_) => panic!("{req:?} was planned"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn flags_are_checked_and_named_as_the_command_names_them() {
        let req = |f: fn(&mut SimulateRequest)| {
            let mut r = SimulateRequest::default();
            f(&mut r);
            r
        };
        assert_eq!(
            refusal(req(|r| r.flaws.sweep = Some(2.0))),
            "--sweep: strength 2 must be in [0, 1)"
        );
        assert_eq!(refusal(req(|r| r.spp = 0)), "--spp: must be at least 1");
        assert!(refusal(req(|r| r.bounces = 1001)).starts_with("--bounces: "));
        assert!(refusal(req(|r| {
            r.paper_size = true;
            r.nt = Some(8)
        }))
        .starts_with("--paper-size"));
        assert!(refusal(req(|r| r.time_filter = TimeFilter::Box)).contains("--transient-only"));
        assert!(refusal(req(|r| r.scene = "nosuch".into())).starts_with("--scene: 'nosuch'"));
        assert!(refusal(req(|r| r.scene = "bunny".into())).contains("--bunny"));
        assert!(parse_format("BMP")
            .unwrap_err()
            .to_string()
            .starts_with("--format"));
        assert_eq!(parse_format(" PNG ").unwrap(), StreakFormat::Png16);
        assert_eq!(parse_time_filter("Box").unwrap(), TimeFilter::Box);
    }

    #[test]
    fn a_missing_scene_file_keeps_its_io_error() {
        let e = plan(&SimulateRequest {
            scene: "no/such/scene.toml".into(),
            ..SimulateRequest::default()
        })
        .unwrap_err();
        let io = std::error::Error::source(&e)
            .and_then(std::error::Error::source)
            .and_then(|c| c.downcast_ref::<std::io::Error>())
            .expect("an io::Error cause");
        assert_eq!(io.kind(), std::io::ErrorKind::NotFound);
        assert_eq!(e.to_string(), "--scene");
    }

    #[test]
    fn the_default_request_plans_the_commands_defaults() {
        let p = plan(&SimulateRequest {
            size: Some((8, 6)),
            nt: Some(16),
            ..SimulateRequest::default()
        })
        .unwrap();
        let d = SimulateOptions::default();
        assert_eq!(
            (p.opts.spp, p.opts.max_bounces, p.opts.seed),
            (d.spp, d.max_bounces, 0)
        );
        assert_eq!(p.opts.flaws, Flaws::default());
        assert_eq!(p.scene.camera.intrinsics.width, 8);
        assert_eq!(p.scene.camera.axis.nt, 16);
        let realistic = plan(&SimulateRequest {
            size: Some((8, 6)),
            realistic: true,
            flaws: Flaws {
                sweep: Some(0.0),
                ..Flaws::default()
            },
            ..SimulateRequest::default()
        })
        .unwrap();
        assert_eq!(realistic.opts.flaws.sweep, Some(0.0));
        assert_eq!(realistic.opts.flaws.jitter_ps, Flaws::realistic().jitter_ps);
    }
}

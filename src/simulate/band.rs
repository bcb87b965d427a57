//! Bands of a simulated capture, for a capture split over many processes or machines (a
//! Slurm job array: `tools/slurm/`, docs/cluster.md).
//!
//! [`simulate_band`] renders image rows `A..B` of the true cubes into a band folder:
//! `truth_camera.h5`, `truth_world.h5` and `truth_direct.h5` of those rows, and
//! [`BAND_FILE`], which records the rows, the settings, the command that made the band, the
//! rows' peaks and the render's counters. [`merge_bands`] assembles bands that cover every
//! row once into the capture folder that [`super::simulate_capture`] writes in one process,
//! bit for bit.
//!
//! A band holds truth rows rather than streak images because the imperfections are scaled by
//! the whole clean cube's peaks ([`super::flaws::Peaks`]): the merge takes the largest of the
//! bands' peaks, copies the rows into the whole truth cubes in row order, and then writes the
//! streak images, side files and manifest as a single run does
//! (`capture::finish_capture`).
//!
//! Why a band equals the same rows of a whole run: each pixel's paths draw from a random
//! stream keyed by the seed and the pixel ([`crate::tracer`]'s `pixel_rng`), and each
//! scanline's imperfections from one keyed by the seed and the scanline, so neither the rows
//! a process renders nor its thread count change a value.

use super::budget::BAND_TARGET_BYTES;
use super::capture::{
    capture_shape, finish_capture, provenance, render_truths, set_folder_permissions,
    stage_and_install, trace_options, SimulateSummary,
};
use super::flaws::Peaks;
use super::options::{
    SimulateError, SimulateOptions, Stage, TRUTH_CAMERA_FILE, TRUTH_DIRECT_FILE, TRUTH_WORLD_FILE,
};
use crate::container::{CubeReader, CubeWriter, DEFAULT_UNITS};
use crate::geometry::bvh::Bvh;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The band's record in a band folder.
pub const BAND_FILE: &str = "band.toml";

/// The note of a band's truth cubes that records their image rows (`A..B`).
pub const ROWS_NOTE: &str = "band_rows";

/// The truth cubes a band folder holds (of its rows only).
pub const BAND_CUBES: [&str; 3] = [TRUTH_CAMERA_FILE, TRUTH_WORLD_FILE, TRUTH_DIRECT_FILE];

/// Everything that decides a capture's values; bands merge only when theirs are equal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BandSettings {
    /// The scene's name.
    pub scene: String,
    /// A digest of everything in the resolved scene (mesh, materials, camera, laser), hex.
    pub scene_digest: String,
    /// Image width, pixels.
    pub nx: usize,
    /// Image height, pixels (the whole capture's).
    pub ny: usize,
    /// Time bins.
    pub nt: usize,
    /// Bin width, ps.
    pub dt_ps: f64,
    /// Start of the first bin, ps.
    pub t0_ps: f64,
    /// Camera paths per pixel.
    pub spp: u32,
    /// The random seed.
    pub seed: u64,
    /// Most surface interactions per path.
    pub max_bounces: u32,
    /// Scanline formats, in order.
    pub formats: Vec<String>,
    /// The imperfections, as Rust writes them (exact values).
    pub flaws: String,
    /// Fiducial marker spacing, metres.
    pub marker_spacing_m: f64,
}

impl BandSettings {
    /// The settings of a capture of `scene` made with `opts`.
    pub fn of(scene: &Scene, opts: &SimulateOptions) -> BandSettings {
        BandSettings {
            scene: scene.name.clone(),
            scene_digest: scene_digest(scene),
            nx: scene.camera.intrinsics.width,
            ny: scene.camera.intrinsics.height,
            nt: scene.camera.axis.nt,
            dt_ps: scene.camera.axis.dt_ps,
            t0_ps: scene.camera.axis.t0_ps,
            spp: opts.spp,
            seed: opts.seed,
            max_bounces: opts.max_bounces,
            formats: opts.formats.iter().map(|f| format!("{f:?}")).collect(),
            flaws: format!("{:?}", opts.flaws),
            marker_spacing_m: opts.marker_spacing_m,
        }
    }

    /// The first setting that differs from `other`'s: `(name, this value, other value)`.
    pub fn first_difference(&self, other: &BandSettings) -> Option<(String, String, String)> {
        let table = |s: &BandSettings| toml::Table::try_from(s).unwrap_or_default();
        let (a, b) = (table(self), table(other));
        a.iter().find_map(|(k, v)| {
            let w = b.get(k)?;
            (v != w).then(|| (k.clone(), v.to_string(), w.to_string()))
        })
    }
}

/// A hex digest of the resolved scene's every value (its `Debug` text, which writes each
/// number exactly), streamed through the standard library's SipHash with fixed keys.
fn scene_digest(scene: &Scene) -> String {
    use std::fmt::Write as _;
    use std::hash::Hasher;
    struct HashText(std::hash::DefaultHasher);
    impl std::fmt::Write for HashText {
        fn write_str(&mut self, s: &str) -> std::fmt::Result {
            self.0.write(s.as_bytes());
            Ok(())
        }
    }
    let mut h = HashText(std::hash::DefaultHasher::new());
    let _ = write!(h, "{scene:?}");
    format!("{:016x}", h.0.finish())
}

/// The peaks of a band's camera-time rows, stored exactly.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BandPeaks {
    /// [`Peaks::clean_max`] (an f32, held exactly).
    pub clean_max: f64,
    /// [`Peaks::noiseless`].
    pub noiseless: f64,
}

/// The render's counters of a band.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BandRender {
    /// Camera paths traced.
    pub paths: u64,
    /// Rays cast.
    pub rays: u64,
    /// Wall-clock seconds of the render.
    pub seconds: f64,
    /// CPU seconds of the render (all threads).
    pub cpu_seconds: f64,
}

/// The content of [`BAND_FILE`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BandInfo {
    /// First image row of the band.
    pub rows_start: usize,
    /// One past the last image row of the band.
    pub rows_end: usize,
    /// The command line that made the band (program name first), or the tool's name.
    pub command: Vec<String>,
    /// The capture's settings.
    pub settings: BandSettings,
    /// The band rows' peaks.
    pub peaks: BandPeaks,
    /// The band's render counters.
    pub render: BandRender,
}

impl BandInfo {
    /// The band's rows.
    pub fn rows(&self) -> Range<usize> {
        self.rows_start..self.rows_end
    }

    /// Read `dir`'s [`BAND_FILE`].
    pub fn load(dir: &Path) -> Result<BandInfo, SimulateError> {
        let path = dir.join(BAND_FILE);
        let bad = |message: String| SimulateError::Band { message };
        let text = std::fs::read_to_string(&path).map_err(|e| {
            bad(format!(
                "{}: not a band folder ({BAND_FILE}: {e}; bands are made by simulate --rows)",
                dir.display()
            ))
        })?;
        let info: BandInfo = toml::from_str(&text)
            .map_err(|e| bad(format!("{}: {}", path.display(), one_line(&e))))?;
        // The capture's size, in exact arithmetic: each side at least 1, the cube at most
        // MAX_COUNT values (a height of 2^64 - 1 was accepted).
        let st = &info.settings;
        let values = [st.nx, st.ny, st.nt].iter().try_fold(1u128, |a, &n| {
            (n > 0).then(|| a.checked_mul(n as u128)).flatten()
        });
        if values.is_none_or(|v| v > u128::from(crate::limits::MAX_COUNT)) {
            return Err(bad(format!(
                "{}: settings nx = {}, ny = {}, nt = {}: not a capture (1 to {} values)",
                path.display(),
                st.nx,
                st.ny,
                st.nt,
                crate::limits::MAX_COUNT
            )));
        }
        if info.rows_start >= info.rows_end || info.rows_end > info.settings.ny {
            return Err(bad(format!(
                "{}: rows {}..{} are not a band of {} rows",
                path.display(),
                info.rows_start,
                info.rows_end,
                info.settings.ny
            )));
        }
        Ok(info)
    }
}

fn one_line(e: &dyn std::fmt::Display) -> String {
    e.to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// Render image rows `rows` of the capture of `scene` with `opts` into the band folder
/// `out_dir` (module doc), staged and put in place whole like a capture folder. `command` is
/// recorded in [`BAND_FILE`] (the command line that made the band, for the merge).
pub fn simulate_band(
    scene: &Scene,
    opts: &SimulateOptions,
    rows: Range<usize>,
    command: &[String],
    out_dir: &Path,
    progress: &(dyn Fn(Stage, usize) + Sync),
) -> Result<SimulateSummary, SimulateError> {
    let started = Instant::now();
    opts.validate(scene)?;
    let ny = scene.camera.intrinsics.height;
    if rows.start >= rows.end || rows.end > ny {
        return Err(SimulateError::Band {
            message: format!(
                "rows {}..{}: not a band of the image's {ny} rows (0 <= A < B <= {ny})",
                rows.start, rows.end
            ),
        });
    }
    if opts.transient_only {
        return Err(SimulateError::Band {
            message: "a transient-only render is not split into bands".into(),
        });
    }
    let (info, files) = stage_and_install(out_dir, opts.force, |dir| {
        let bvh = Bvh::new(scene.mesh.clone());
        let shape = capture_shape(scene, opts)?;
        // Each truth file records its rows, which the merge checks with the seed.
        let band_provenance =
            provenance(scene, opts).with_note(ROWS_NOTE, format!("{}..{}", rows.start, rows.end));
        let (peaks, stats) = render_truths(
            scene,
            &bvh,
            &trace_options(opts),
            &shape,
            rows.clone(),
            dir,
            &band_provenance,
            progress,
        )?;
        let info = BandInfo {
            rows_start: rows.start,
            rows_end: rows.end,
            command: command.to_vec(),
            settings: BandSettings::of(scene, opts),
            peaks: BandPeaks {
                clean_max: peaks.clean_max as f64,
                noiseless: peaks.noiseless,
            },
            render: BandRender {
                paths: stats.paths,
                rays: stats.rays,
                seconds: stats.seconds,
                cpu_seconds: stats.cpu_seconds,
            },
        };
        let path = dir.join(BAND_FILE);
        let text = toml::to_string(&info).map_err(|e| SimulateError::Band {
            message: format!("{}: {e}", path.display()),
        })?;
        std::fs::write(&path, text).map_err(|source| SimulateError::Io {
            path: path.clone(),
            source,
        })?;
        set_folder_permissions(&[dir.to_path_buf()])?;
        let mut files: Vec<PathBuf> = BAND_CUBES.iter().map(PathBuf::from).collect();
        files.push(BAND_FILE.into());
        Ok((info, files))
    })?;
    Ok(summary(out_dir, &[info], files, 0, 0, started))
}

fn summary(
    out_dir: &Path,
    bands: &[BandInfo],
    files: Vec<PathBuf>,
    fiducials: usize,
    values_at_top_count: usize,
    started: Instant,
) -> SimulateSummary {
    let sum = |f: &dyn Fn(&BandRender) -> f64| bands.iter().map(|b| f(&b.render)).sum::<f64>();
    let paths = bands.iter().map(|b| b.render.paths).sum::<u64>();
    let render_seconds = sum(&|r| r.seconds);
    SimulateSummary {
        out_dir: out_dir.to_path_buf(),
        paths,
        rays: bands.iter().map(|b| b.render.rays).sum(),
        render_seconds,
        render_cpu_seconds: sum(&|r| r.cpu_seconds),
        seconds: started.elapsed().as_secs_f64(),
        paths_per_second: if render_seconds > 0.0 {
            paths as f64 / render_seconds
        } else {
            0.0
        },
        files: files.iter().map(|f| out_dir.join(f)).collect(),
        fiducials,
        values_at_top_count,
        truth: None,
    }
}

/// Read the band folders `dirs` and put them in row order, refusing (one line each, naming
/// the bands) any that is not a band, settings or seeds that differ, rows in two bands and
/// rows in none.
pub fn check_bands(dirs: &[PathBuf]) -> Result<Vec<(PathBuf, BandInfo)>, SimulateError> {
    let bad = |message: String| Err(SimulateError::Band { message });
    if dirs.is_empty() {
        return bad("no band folders given".into());
    }
    let mut bands = dirs
        .iter()
        .map(|d| Ok((d.clone(), BandInfo::load(d)?)))
        .collect::<Result<Vec<_>, SimulateError>>()?;
    let (first_dir, first) = (&bands[0].0, &bands[0].1);
    for (dir, b) in &bands[1..] {
        if let Some((name, here, there)) = b.settings.first_difference(&first.settings) {
            return bad(format!(
                "{}: {name} {here} differs from {}'s {there}: bands of one capture share every setting",
                dir.display(),
                first_dir.display()
            ));
        }
    }
    bands.sort_by_key(|(_, b)| (b.rows_start, b.rows_end));
    let ny = bands[0].1.settings.ny;
    let mut next = 0;
    let mut previous: Option<&(PathBuf, BandInfo)> = None;
    for band in &bands {
        let (dir, b) = band;
        if b.rows_start > next {
            let after = match previous {
                Some((p, pb)) => format!("{} ends at row {}", p.display(), pb.rows_end),
                None => "no band starts at row 0".into(),
            };
            return bad(format!(
                "rows {next}..{} are in no band ({after}, {} starts at row {})",
                b.rows_start,
                dir.display(),
                b.rows_start
            ));
        }
        if b.rows_start < next {
            let (p, pb) = previous.expect("a band before");
            return bad(format!(
                "rows {}..{} are in two bands: {} (rows {}..{}) and {} (rows {}..{})",
                b.rows_start,
                next.min(b.rows_end),
                p.display(),
                pb.rows_start,
                pb.rows_end,
                dir.display(),
                b.rows_start,
                b.rows_end
            ));
        }
        next = b.rows_end;
        previous = Some(band);
    }
    if next < ny {
        let (p, _) = previous.expect("at least one band");
        return bad(format!(
            "rows {next}..{ny} are in no band (the last, {}, ends at row {next} of {ny})",
            p.display()
        ));
    }
    Ok(bands)
}

/// Assemble the band folders `dirs` ([`check_bands`]: every row once, equal settings) into
/// the capture folder `out_dir` that [`super::simulate_capture`] writes for `scene` and
/// `opts` in one process, bit for bit; bands made with other settings than `scene` and
/// `opts` are refused. Staged and put in place whole; nothing is written on a refusal.
pub fn merge_bands(
    scene: &Scene,
    opts: &SimulateOptions,
    dirs: &[PathBuf],
    out_dir: &Path,
    progress: &(dyn Fn(Stage, usize) + Sync),
) -> Result<SimulateSummary, SimulateError> {
    let started = Instant::now();
    opts.validate(scene)?;
    let bands = check_bands(dirs)?;
    let want = BandSettings::of(scene, opts);
    if let Some((name, here, there)) = bands[0].1.settings.first_difference(&want) {
        return Err(SimulateError::Band {
            message: format!(
                "{}: {name} {here} differs from {there}, that of the capture to merge into (its scene or options changed since the bands were made)",
                bands[0].0.display()
            ),
        });
    }
    for (dir, b) in &bands {
        for file in BAND_CUBES {
            let path = dir.join(file);
            let meta = CubeReader::open(&path)?.meta().clone();
            check_band_truth(&path, &meta.notes, b)?;
            if meta.nx != want.nx || meta.ny != b.rows().len() {
                return Err(SimulateError::Band {
                    message: format!(
                        "{}: {} x {} pixels, not the band's {} x {}",
                        path.display(),
                        meta.nx,
                        meta.ny,
                        want.nx,
                        b.rows().len()
                    ),
                });
            }
        }
    }
    let (files, n_points, top) = stage_and_install(out_dir, opts.force, |dir| {
        copy_truths(scene, opts, &bands, dir)?;
        // Two folds, one per type: a single loop taking an f32 and an f64 maximum together
        // is vectorised by rustc 1.95's LLVM 22 into invalid IR (an `fcmp` of a double and a
        // float vector) that crashes `cargo build --release` (SIGSEGV in x86 isel).
        let peaks = Peaks {
            clean_max: bands
                .iter()
                .map(|(_, b)| b.peaks.clean_max)
                .fold(0.0, f64::max) as f32,
            noiseless: bands
                .iter()
                .map(|(_, b)| b.peaks.noiseless)
                .fold(0.0, f64::max),
        };
        let bvh = Bvh::new(scene.mesh.clone());
        let shape = capture_shape(scene, opts)?;
        finish_capture(scene, opts, &bvh, shape, &peaks, dir, progress)
    })?;
    let infos: Vec<BandInfo> = bands.into_iter().map(|(_, b)| b).collect();
    Ok(summary(out_dir, &infos, files, n_points, top, started))
}

/// A band's truth file must be of the band's rows and seed (the notes it was written
/// with): a truth file swapped between two bands of as many rows was merged into
/// duplicated rows.
fn check_band_truth(
    path: &Path,
    notes: &[(String, String)],
    band: &BandInfo,
) -> Result<(), SimulateError> {
    let note = |key: &str| {
        notes
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    };
    let rows = format!("{}..{}", band.rows_start, band.rows_end);
    let seed = band.settings.seed.to_string();
    let refuse = |what: String| {
        Err(SimulateError::Band {
            message: format!(
                "{}: {what}, but its band.toml says rows {rows}, seed {seed}: the truth file \
                 is not this band's",
                path.display()
            ),
        })
    };
    match (note(ROWS_NOTE), note("seed")) {
        (Some(r), Some(s)) if r == rows && s == seed => Ok(()),
        (Some(r), Some(s)) => refuse(format!("rows {r}, seed {s}")),
        (None, _) => refuse(format!(
            "no '{ROWS_NOTE}' note (not written by simulate --rows)"
        )),
        (_, None) => refuse("no 'seed' note".into()),
    }
}

/// Write the whole truth cubes into `dir` from the bands' rows, in row order.
fn copy_truths(
    scene: &Scene,
    opts: &SimulateOptions,
    bands: &[(PathBuf, BandInfo)],
    dir: &Path,
) -> Result<(), SimulateError> {
    let provenance = provenance(scene, opts);
    let (nx, ny) = (
        scene.camera.intrinsics.width,
        scene.camera.intrinsics.height,
    );
    for file in BAND_CUBES {
        let first = CubeReader::open(&bands[0].0.join(file))?;
        let meta = first.meta().clone();
        let what = first_note(&meta.notes, "content");
        let mut writer = CubeWriter::create(
            &dir.join(file),
            nx,
            ny,
            meta.axis,
            meta.frame,
            DEFAULT_UNITS,
            &provenance.clone().with_note("content", what),
        )?;
        for (band_dir, b) in bands {
            let reader = CubeReader::open(&band_dir.join(file))?;
            let row_len = nx * reader.meta().axis.nt;
            let step = (BAND_TARGET_BYTES / (4 * row_len).max(1)).max(1);
            let n = b.rows().len();
            for r0 in (0..n).step_by(step) {
                let rows = reader.read_rows(r0, step.min(n - r0))?;
                writer.write_rows(b.rows_start + r0, &rows)?;
            }
        }
        writer.finish()?;
    }
    Ok(())
}

fn first_note(notes: &[(String, String)], key: &str) -> String {
    notes
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.clone())
        .unwrap_or_default()
}

//! Golden references: femto's transient of mitransient's Cornell box
//! (`tools/scenes/peer_cornell/scene.toml`, 32 x 32 pixels, 64 box time bins) against Mitsuba
//! 3.9.1 + mitransient 1.3.1 renders committed in `tests/golden/` (made by
//! `tools/make_golden.py`; docs/golden.md).
//!
//! femto renders the scene with `TimeFilter::Box` (each sample whole in the bin it falls in,
//! the quantity of mitransient's histogram) in `FEMTO_BATCHES` independent batches, so both
//! sides carry a mean and the variance of that mean per bin. One-bounce light is compared
//! with the reference of `max_depth = 2`, light of 2 to 4 bounces with `all - direct` (the
//! references of `max_depth = 5` and 2, independent renders: their variances add).
//! Every tolerance is a quantile of the Monte Carlo noise, never a fixed percent:
//!
//! * aggregates: the whole-image sum over each group of `GROUP_BINS` bins and over all bins,
//!   z = (femto - golden) / sqrt(var_femto + var_golden) with both variances taken from the
//!   batches' own sums (a path's bounces land in several bins, so summing per-bin variances
//!   would be wrong), bounded by the Student t quantile of the Welch-Satterthwaite degrees of
//!   freedom at a two-sided level `ALPHA / m` for the `m` aggregate checks of the file
//!   (Bonferroni);
//! * per bin, over the bins with signal: max |z| bounded in the same way for that many bins,
//!   and the mean of z^2 within `Z2_SIGMAS` standard deviations of its expectation under the
//!   noise alone (a t variable with nu degrees of freedom has E z^2 = nu / (nu - 2)), so a
//!   localised error (a wrong bin, a shifted arrival) fails too;
//! * the first lit bin and the peak bin of the whole-image histogram agree.
//!
//! These checks found a bias of 2e-4 in one-bounce light, now fixed (docs/golden.md, "What
//! the references found").
//!
//! On failure the test writes `target/golden-diff/<name>.h5` (femto - golden) and
//! `<name>-z.h5` (the z scores) as femto cubes (`femto info` reads them) and names them in its
//! panic message. With `FEMTO_BLESS=1` the golden file is first rendered again by
//! `tools/make_golden.py` with the Python in `FEMTO_INTEROP_PYTHON`; without it nothing is
//! written under `tests/golden/`.

use femto::container::{write_cube_with_units, Provenance};
use femto::cube::{Cube, TimeAxis, TimeFrame};
use femto::geometry::bvh::Bvh;
use femto::scene::Scene;
use femto::tracer::{trace, TimeFilter, TraceOptions};
use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

const SCENE: &str = "tools/scenes/peer_cornell/scene.toml";
const GOLDEN: &str = "tests/golden/peer_cornell_32x32x64.h5";
/// Independent femto renders (seeds 1 ..= FEMTO_BATCHES).
const FEMTO_BATCHES: usize = 32;
/// Camera paths per pixel in each femto batch.
const FEMTO_SPP: u32 = 64;
/// Bins per aggregate group.
const GROUP_BINS: usize = 8;
/// Family-wise false-alarm probability of each kind of check (aggregates, per-bin maximum,
/// mean z^2) over the whole file: with the three kinds the test fails by chance about once
/// in 3,000 runs.
const ALPHA: f64 = 1e-4;
/// How far the mean z^2 may stray from its expectation, in its own standard deviations
/// (two-sided normal quantile of ALPHA / 2 checks, rounded up).
const Z2_SIGMAS: f64 = 4.5;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn no_progress(_: usize) {}

// ---------------------------------------------------------------------------------------
// Statistics.

/// Standard normal upper tail probability, from the complementary error function
/// (Numerical Recipes' `erfcc`, fractional error below 1.2e-7).
fn normal_upper_tail(z: f64) -> f64 {
    let x = z / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * x.abs());
    let poly = -x * x - 1.26551223
        + t * (1.00002368
            + t * (0.37409196
                + t * (0.09678418
                    + t * (-0.18628806
                        + t * (0.27886807
                            + t * (-1.13520398
                                + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277))))))));
    let erfc = t * poly.exp();
    0.5 * if x >= 0.0 { erfc } else { 2.0 - erfc }
}

/// The z with upper tail probability `p` (0 < p < 0.5), by bisection.
fn normal_quantile_upper(p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 40.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if normal_upper_tail(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The Student t quantile with upper tail probability `p` for `nu` degrees of freedom: the
/// Cornish-Fisher expansion about the normal quantile (Abramowitz & Stegun 26.7.5), within
/// a fraction of a percent for nu >= 10 and conservative (too large) below.
fn t_quantile_upper(p: f64, nu: f64) -> f64 {
    let z = normal_quantile_upper(p);
    let (z3, z5, z7) = (z.powi(3), z.powi(5), z.powi(7));
    z + (z3 + z) / (4.0 * nu)
        + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * nu * nu)
        + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * nu.powi(3))
}

/// A mean over independent batches and the variance of that mean, with its degrees of
/// freedom; sums and differences of independent estimates combine by Welch-Satterthwaite.
#[derive(Clone, Copy, Debug)]
struct Est {
    mean: f64,
    var: f64,
    /// `var^2 / nu`, the term of the Welch-Satterthwaite sum (0 when `var` is 0).
    var2_over_nu: f64,
}

impl Est {
    fn from_batches(values: &[f64]) -> Est {
        let b = values.len() as f64;
        let mean = values.iter().sum::<f64>() / b;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (b - 1.0) / b;
        Est::new(mean, var, b - 1.0)
    }

    fn new(mean: f64, var: f64, nu: f64) -> Est {
        Est {
            mean,
            var,
            var2_over_nu: var * var / nu,
        }
    }

    /// `self - o` for independent estimates (`sign` -1) or `self + o` (`sign` 1).
    fn combine(self, o: Est, sign: f64) -> Est {
        Est {
            mean: self.mean + sign * o.mean,
            var: self.var + o.var,
            var2_over_nu: self.var2_over_nu + o.var2_over_nu,
        }
    }

    /// Welch-Satterthwaite degrees of freedom.
    fn nu(&self) -> f64 {
        self.var * self.var / self.var2_over_nu
    }
}

// ---------------------------------------------------------------------------------------
// The two sides.

/// One side of a comparison: per-bin means and variances of the mean (`[y][x][t]`), and
/// the independent estimates it is made of for any sum of bins of the whole image.
struct Side {
    mean: Vec<f64>,
    var: Vec<f64>,
    /// Degrees of freedom per bin (as [`Est`] terms: `var^2 / nu`).
    var2_over_nu: Vec<f64>,
    /// `(sign, per-batch whole-image histograms)` of each independent part.
    parts: Vec<(f64, Vec<Vec<f64>>)>,
    /// Per bin, the variance of one path's contribution (a reference's: its variance of the
    /// mean times its paths per pixel; empty for femto).
    path_var: Vec<f64>,
}

impl Side {
    fn bin(&self, i: usize) -> Est {
        Est {
            mean: self.mean[i],
            var: self.var[i],
            var2_over_nu: self.var2_over_nu[i],
        }
    }

    /// The whole-image sum over time bins `bins`.
    fn aggregate(&self, bins: Range<usize>) -> Est {
        let mut total: Option<Est> = None;
        for (sign, hists) in &self.parts {
            let sums: Vec<f64> = hists.iter().map(|h| h[bins.clone()].iter().sum()).collect();
            let e = Est::from_batches(&sums);
            total = Some(match total {
                None => Est {
                    mean: sign * e.mean,
                    ..e
                },
                Some(t) => t.combine(e, *sign),
            });
        }
        total.expect("a side has at least one part")
    }

    /// The whole-image histogram (mean).
    fn histogram(&self, nt: usize) -> Vec<f64> {
        let mut h = vec![0.0; nt];
        for (i, m) in self.mean.iter().enumerate() {
            h[i % nt] += m;
        }
        h
    }
}

/// A reference of the golden file: mean, variance of the mean, per-batch histograms.
struct Reference {
    mean: Vec<f64>,
    var: Vec<f64>,
    hists: Vec<Vec<f64>>,
    /// Paths per pixel in each batch.
    spp: usize,
}

impl Reference {
    fn side(&self) -> Side {
        let nu = self.hists.len() as f64 - 1.0;
        Side {
            mean: self.mean.clone(),
            var: self.var.clone(),
            var2_over_nu: self.var.iter().map(|v| v * v / nu).collect(),
            parts: vec![(1.0, self.hists.clone())],
            path_var: self.path_var(),
        }
    }

    fn path_var(&self) -> Vec<f64> {
        let paths = (self.hists.len() * self.spp) as f64;
        self.var.iter().map(|v| v * paths).collect()
    }

    /// `self - o`, two independent references.
    fn minus(&self, o: &Reference) -> Side {
        let (a, b) = (self.side(), o.side());
        Side {
            mean: a.mean.iter().zip(&b.mean).map(|(x, y)| x - y).collect(),
            var: a.var.iter().zip(&b.var).map(|(x, y)| x + y).collect(),
            var2_over_nu: a
                .var2_over_nu
                .iter()
                .zip(&b.var2_over_nu)
                .map(|(x, y)| x + y)
                .collect(),
            parts: vec![(1.0, self.hists.clone()), (-1.0, o.hists.clone())],
            path_var: self
                .path_var()
                .iter()
                .zip(o.path_var())
                .map(|(x, y)| x + y)
                .collect(),
        }
    }
}

struct Golden {
    nx: usize,
    ny: usize,
    axis: TimeAxis,
    direct: Reference,
    all: Reference,
}

fn read_golden(path: &Path) -> Golden {
    let name = path.display();
    let f = rust_hdf5::H5File::open(path).unwrap_or_else(|e| panic!("{name}: {e}"));
    let root = f.root_group();
    let num = |k: &str| -> f64 {
        root.attr(k)
            .and_then(|a| a.read_numeric_as::<f64>())
            .unwrap_or_else(|e| panic!("{name}: attribute {k}: {e}"))[0]
    };
    let int = |k: &str| -> usize {
        root.attr(k)
            .and_then(|a| a.read_numeric::<i64>())
            .unwrap_or_else(|e| panic!("{name}: attribute {k}: {e}")) as usize
    };
    let text = |k: &str| -> String {
        root.attr(k)
            .and_then(|a| a.read_string())
            .unwrap_or_else(|e| panic!("{name}: attribute {k}: {e}"))
    };
    // The golden file holds the scene it was rendered from, verbatim: refuse a stale one.
    let sources = root
        .attr("source_files")
        .and_then(|a| a.read_strings())
        .unwrap_or_else(|e| panic!("{name}: attribute source_files: {e}"));
    assert!(
        sources.iter().any(|s| s == SCENE),
        "{name}: not rendered from {SCENE}"
    );
    for rel in &sources {
        let now = std::fs::read_to_string(repo().join(rel))
            .unwrap_or_else(|e| panic!("{}: {e}", repo().join(rel).display()));
        assert!(
            text(&format!("text:{rel}")) == now,
            "{name} was rendered from another version of {rel}: regenerate it with \
             FEMTO_BLESS=1 FEMTO_INTEROP_PYTHON=<python with mitsuba> cargo test --test golden"
        );
    }
    let (nx, ny, nt) = (int("nx"), int("ny"), int("nt"));
    let axis = TimeAxis {
        t0_ps: num("t0_ps"),
        dt_ps: num("dt_ps"),
        nt,
    };
    let dataset = |k: &str| -> (Vec<usize>, Vec<f64>) {
        let ds = f
            .dataset(k)
            .unwrap_or_else(|e| panic!("{name}: dataset {k}: {e}"));
        let v = ds
            .read_numeric_as::<f64>()
            .unwrap_or_else(|e| panic!("{name}: dataset {k}: {e}"));
        (ds.shape(), v)
    };
    let reference = |r: &str| -> Reference {
        let (shape, mean) = dataset(&format!("{r}_mean"));
        assert_eq!(shape, [ny, nx, nt], "{name}: {r}_mean");
        let (shape, var) = dataset(&format!("{r}_var"));
        assert_eq!(shape, [ny, nx, nt], "{name}: {r}_var");
        let spp = f
            .dataset(&format!("{r}_mean"))
            .and_then(|d| d.attr("spp_per_batch"))
            .and_then(|a| a.read_numeric::<i64>())
            .unwrap_or_else(|e| panic!("{name}: {r}_mean: attribute spp_per_batch: {e}"));
        let (shape, h) = dataset(&format!("{r}_batch_hist"));
        assert!(
            shape.len() == 2 && shape[1] == nt && shape[0] >= 2,
            "{name}: {r}_batch_hist"
        );
        Reference {
            mean,
            var,
            hists: h.chunks(nt).map(<[f64]>::to_vec).collect(),
            spp: spp as usize,
        }
    };
    Golden {
        nx,
        ny,
        axis,
        direct: reference("direct"),
        all: reference("all"),
    }
}

/// With `FEMTO_BLESS=1`, render the golden file again with `tools/make_golden.py`.
fn bless_if_asked() {
    if std::env::var("FEMTO_BLESS").as_deref() != Ok("1") {
        return;
    }
    let python = std::env::var("FEMTO_INTEROP_PYTHON").unwrap_or_else(|_| {
        panic!(
            "FEMTO_BLESS=1 needs FEMTO_INTEROP_PYTHON: a Python with mitsuba 3.9.1, mitransient \
             1.3.1 and h5py (and DRJIT_LIBLLVM_PATH if its LLVM is not found)"
        )
    });
    let status = std::process::Command::new(&python)
        .args(["tools/make_golden.py", "--out", GOLDEN])
        .current_dir(repo())
        .status()
        .unwrap_or_else(|e| panic!("FEMTO_INTEROP_PYTHON={python}: {e}"));
    assert!(status.success(), "tools/make_golden.py failed ({status})");
}

/// femto's one-bounce and multi-bounce sides, on the golden file's size and axis.
fn femto_sides(g: &Golden) -> (Side, Side) {
    let scene = Scene::load(&repo().join(SCENE)).unwrap_or_else(|e| panic!("{e}"));
    let mut scene = scene.with_resolution(g.nx, g.ny, g.axis.nt, g.axis.dt_ps);
    scene.camera.axis.t0_ps = g.axis.t0_ps;
    let bvh = Bvh::new(scene.mesh.clone());
    let n = g.nx * g.ny * g.axis.nt;
    let (mut direct, mut multi) = (Vec::new(), Vec::new());
    for b in 0..FEMTO_BATCHES {
        let opts = TraceOptions {
            spp: FEMTO_SPP,
            max_bounces: 4,
            seed: b as u64 + 1,
            split_bounces: true,
            world_time: false,
            time_filter: TimeFilter::Box,
            ..TraceOptions::default()
        };
        let r = trace(&scene, &bvh, &opts, &no_progress);
        direct.push(r.direct.expect("split_bounces gives the direct cube").data);
        multi.push(r.multi.expect("split_bounces gives the multi cube").data);
    }
    let side = |batches: &[Vec<f32>]| -> Side {
        let nu = batches.len() as f64 - 1.0;
        let (mut mean, mut var) = (vec![0.0; n], vec![0.0; n]);
        for i in 0..n {
            let e = Est::from_batches(&batches.iter().map(|c| c[i] as f64).collect::<Vec<_>>());
            mean[i] = e.mean;
            var[i] = e.var;
        }
        let hists = batches
            .iter()
            .map(|c| {
                let mut h = vec![0.0; g.axis.nt];
                for (i, v) in c.iter().enumerate() {
                    h[i % g.axis.nt] += *v as f64;
                }
                h
            })
            .collect();
        Side {
            var2_over_nu: var.iter().map(|v| v * v / nu).collect(),
            mean,
            var,
            parts: vec![(1.0, hists)],
            path_var: Vec::new(),
        }
    };
    (side(&direct), side(&multi))
}

struct Fixture {
    golden: Golden,
    femto_direct: Side,
    femto_multi: Side,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        bless_if_asked();
        let golden = read_golden(&repo().join(GOLDEN));
        let (femto_direct, femto_multi) = femto_sides(&golden);
        Fixture {
            golden,
            femto_direct,
            femto_multi,
        }
    })
}

// ---------------------------------------------------------------------------------------
// The comparison.

/// Aggregate checks per comparison: one per group of bins and the total.
fn aggregate_ranges(nt: usize) -> Vec<Range<usize>> {
    let mut r: Vec<Range<usize>> = (0..nt)
        .step_by(GROUP_BINS)
        .map(|a| a..(a + GROUP_BINS).min(nt))
        .collect();
    r.push(0..nt);
    r
}

/// Aggregate checks in the whole file (both comparisons).
fn aggregate_checks(nt: usize) -> usize {
    2 * aggregate_ranges(nt).len()
}

/// Largest relative standard deviation of one femto batch in a bin with signal.
const MAX_BATCH_REL_SD: f64 = 0.5;

/// Bins with signal: the reference's mean is positive and one femto batch is predicted to
/// estimate it within `MAX_BATCH_REL_SD` (the reference's own variance per path over a femto
/// batch's `FEMTO_SPP` paths; femto's is no larger, so this is conservative). The choice depends on the reference alone, not on femto's outcome. In bins
/// a batch reaches with fewer paths, its mean is a sum of a few skewed samples and the z
/// scores stop following a t distribution (heavier tails), which would make the per-bin
/// bounds fail on correct code.
fn has_signal(g: &Side, i: usize) -> bool {
    let m = g.mean[i];
    m > 0.0 && g.path_var[i] / FEMTO_SPP as f64 <= (MAX_BATCH_REL_SD * m).powi(2)
}

/// Compare `femto` with `golden`; the failures, one line each, and the z score per bin (0
/// where there is no signal).
fn compare(
    name: &str,
    femto: &Side,
    golden: &Side,
    g: &Golden,
    per_bin: bool,
) -> (Vec<String>, Vec<f64>) {
    let (nx, nt) = (g.nx, g.axis.nt);
    let mut fails = Vec::new();
    let mut report = Vec::new();
    // Aggregates.
    let m = aggregate_checks(nt) as f64;
    for bins in aggregate_ranges(nt) {
        let (fa, ga) = (
            femto.aggregate(bins.clone()),
            golden.aggregate(bins.clone()),
        );
        let d = fa.combine(ga, -1.0);
        if d.var == 0.0 {
            if fa.mean != ga.mean {
                fails.push(format!(
                    "{name}: bins {bins:?}: femto {} vs golden {} with no noise",
                    fa.mean, ga.mean
                ));
            }
            continue;
        }
        let z = d.mean / d.var.sqrt();
        let bound = t_quantile_upper(ALPHA / (2.0 * m), d.nu());
        report.push(format!(
            "{name}: bins {bins:?}: femto {:.6} golden {:.6} ({:+.3} % +- {:.3} %), z {z:+.2} (bound {bound:.2}, nu {:.0})",
            fa.mean,
            ga.mean,
            100.0 * (fa.mean / ga.mean - 1.0),
            100.0 * d.var.sqrt() / ga.mean,
            d.nu()
        ));
        if z.abs() > bound {
            fails.push(report.last().unwrap().clone());
        }
    }
    // Per bin.
    let n = femto.mean.len();
    let mut z = vec![0.0; n];
    let signal: Vec<usize> = (0..n).filter(|&i| has_signal(golden, i)).collect();
    let nb = signal.len() as f64;
    let (mut z2_sum, mut e_sum, mut v_sum) = (0.0, 0.0, 0.0);
    let mut worst: Option<(f64, usize, f64, f64)> = None;
    for &i in &signal {
        let d = femto.bin(i).combine(golden.bin(i), -1.0);
        let zi = d.mean / d.var.sqrt();
        z[i] = zi;
        let nu = d.nu().max(4.5);
        z2_sum += zi * zi;
        e_sum += nu / (nu - 2.0);
        v_sum += 2.0 * nu * nu * (nu - 1.0) / ((nu - 2.0).powi(2) * (nu - 4.0));
        let bound = t_quantile_upper(ALPHA / (4.0 * nb), nu);
        if worst.is_none_or(|w| zi.abs() / bound > w.0) {
            worst = Some((zi.abs() / bound, i, zi, bound));
        }
    }
    let (mean_z2, expect, sd) = (z2_sum / nb, e_sum / nb, v_sum.sqrt() / nb);
    // How much of the compared noise is the reference's (median over the bins with signal).
    let mut share: Vec<f64> = signal
        .iter()
        .map(|&i| golden.var[i] / (golden.var[i] + femto.var[i]))
        .collect();
    share.sort_by(f64::total_cmp);
    report.push(format!(
        "{name}: {} bins with signal: mean z^2 {mean_z2:.3} (expected {expect:.3} +- {sd:.3}); \
         the reference's share of the variance: median {:.3}",
        signal.len(),
        share.get(share.len() / 2).copied().unwrap_or(f64::NAN)
    ));
    if per_bin && (mean_z2 - expect).abs() > Z2_SIGMAS * sd {
        fails.push(report.last().unwrap().clone());
    }
    if let Some((ratio, i, zi, bound)) = worst {
        let (pixel, t) = (i / nt, i % nt);
        report.push(format!(
            "{name}: largest |z| {zi:+.2} at bin {t} of pixel (x {}, y {}) (bound {bound:.2})",
            pixel % nx,
            pixel / nx
        ));
        if per_bin && ratio > 1.0 {
            fails.push(report.last().unwrap().clone());
        }
    }
    for line in &report {
        println!("{line}");
    }
    (fails, z)
}

/// First bin with light and peak bin of a whole-image histogram.
fn first_and_peak(h: &[f64]) -> (Option<usize>, usize) {
    let first = h.iter().position(|&v| v > 0.0);
    let peak = (0..h.len())
        .max_by(|&a, &b| h[a].total_cmp(&h[b]))
        .unwrap_or(0);
    (first, peak)
}

/// Write the diff cubes of a failed comparison; their paths.
fn write_diff(name: &str, femto: &Side, golden: &Side, z: &[f64], g: &Golden) -> String {
    let dir = repo().join("target/golden-diff");
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let cube = |values: Vec<f32>| Cube {
        nx: g.nx,
        ny: g.ny,
        axis: g.axis,
        frame: TimeFrame::Camera,
        data: values,
        mask: None,
    };
    let prov = Provenance::new(format!("cargo test --test golden ({name})"));
    let diff = dir.join(format!("{name}.h5"));
    let zs = dir.join(format!("{name}-z.h5"));
    let d: Vec<f32> = femto
        .mean
        .iter()
        .zip(&golden.mean)
        .map(|(f, g)| (f - g) as f32)
        .collect();
    write_cube_with_units(&diff, &cube(d), "femto - golden (radiance per bin)", &prov)
        .unwrap_or_else(|e| panic!("{e}"));
    write_cube_with_units(
        &zs,
        &cube(z.iter().map(|&v| v as f32).collect()),
        "z score",
        &prov,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    format!("{} and {}", diff.display(), zs.display())
}

/// Run the checks of one comparison (the per-bin ones with `per_bin`) and panic with all
/// failures and the diff cubes' paths.
fn check(name: &str, femto: &Side, golden: &Side, histograms: (&[f64], &[f64]), per_bin: bool) {
    let g = &fixture().golden;
    let (mut fails, z) = compare(name, femto, golden, g, per_bin);
    let (f_first, f_peak) = first_and_peak(histograms.0);
    let (g_first, g_peak) = first_and_peak(histograms.1);
    println!("{name}: first lit bin femto {f_first:?} golden {g_first:?}, peak bin femto {f_peak} golden {g_peak}");
    if f_first != g_first || f_peak != g_peak {
        fails.push(format!(
            "{name}: first lit bin femto {f_first:?} golden {g_first:?}, peak bin femto {f_peak} golden {g_peak}"
        ));
    }
    if !fails.is_empty() {
        let paths = write_diff(name, femto, golden, &z, g);
        panic!(
            "{} check(s) failed:\n{}\ndiff cubes: {paths}",
            fails.len(),
            fails.join("\n")
        );
    }
}

fn check_one_bounce(name: &str, per_bin: bool) {
    let f = fixture();
    let golden = f.golden.direct.side();
    let nt = f.golden.axis.nt;
    check(
        name,
        &f.femto_direct,
        &golden,
        (&f.femto_direct.histogram(nt), &golden.histogram(nt)),
        per_bin,
    );
}

/// One-bounce light: aggregates, per-bin checks, first lit bin and peak bin.
#[test]
fn one_bounce_light_matches_mitransient() {
    check_one_bounce("peer_cornell_direct", true);
}

#[test]
fn multi_bounce_light_matches_mitransient() {
    let f = fixture();
    let golden = f.golden.all.minus(&f.golden.direct);
    let nt = f.golden.axis.nt;
    // First and peak bins of all light (the multi-bounce histogram is flat at its top).
    let femto_all: Vec<f64> = f
        .femto_direct
        .histogram(nt)
        .iter()
        .zip(f.femto_multi.histogram(nt))
        .map(|(a, b)| a + b)
        .collect();
    check(
        "peer_cornell_multi",
        &f.femto_multi,
        &golden,
        (&femto_all, &f.golden.all.side().histogram(nt)),
        true,
    );
}

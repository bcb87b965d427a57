//! Mutation fuzzing of every reader and TOML/CSV input (issue 16), in stable Rust: a seeded
//! mutator ([`mutate`]) turns valid files written by femto's own writers ([`seeds`]) into
//! hostile ones, and each reader must
//!
//! - return `Ok` or `Err`, never panic (every case runs under `catch_unwind`);
//! - never ask for one allocation above [`alloc_bound`] (64 MB + 16 x the input's size),
//!   measured by the counting global allocator of this binary ([`PEAK_REQUEST_BYTES`]);
//!   a request above [`HARD_CAP_BYTES`] is refused outright (the process aborts, naming the
//!   case file) so that a hostile file cannot take the machine's memory;
//! - finish within [`CASE_TIME_LIMIT`] (a watchdog ends the process after
//!   [`HANG_LIMIT`] and keeps the case file).
//!
//! Cases per target: the `cases` of each `#[test]` (sized so that the whole binary stays
//! under a minute on 2 cores in the dev profile), or `FEMTO_FUZZ_CASES` for a longer run
//! (`tools/fuzz.sh`); the generator's seed is `FEMTO_FUZZ_SEED` (default 16). Each target
//! prints one line: executions, executions per second, failures, the largest single
//! allocation. A failing case is kept under `target/tmp/fuzz/<target>/` with its number.
//!
//! The targets run one at a time (a lock), so that the allocation peak belongs to the case
//! that made it even when a reader decodes on rayon's threads.

#[path = "../common/cli.rs"]
mod cli;
mod decoders;
mod extremes;
mod mutate;
mod regressions;
mod seeds;
mod targets;

use rand::SeedableRng;
use std::alloc::{GlobalAlloc, Layout, System};
use std::io::Write;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

/// The largest single allocation request since the last reset, bytes.
pub static PEAK_REQUEST_BYTES: AtomicUsize = AtomicUsize::new(0);

/// Requests above this are refused (null, so the process aborts) instead of served.
pub const HARD_CAP_BYTES: usize = 2 << 30;

/// Counts requests and refuses those above [`HARD_CAP_BYTES`].
struct CountingAlloc;

fn note(size: usize) -> bool {
    PEAK_REQUEST_BYTES.fetch_max(size, Ordering::Relaxed);
    if size > HARD_CAP_BYTES {
        // No allocation here: a fixed message on the unbuffered stderr.
        let _ = std::io::stderr().write_all(
            b"fuzz: an allocation above 2 GiB was refused; the case is the `case.*` file \
              under target/tmp/fuzz/<target>/\n",
        );
        return false;
    }
    true
}

unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !note(layout.size()) {
            return std::ptr::null_mut();
        }
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !note(layout.size()) {
            return std::ptr::null_mut();
        }
        System.alloc_zeroed(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if !note(new_size) {
            return std::ptr::null_mut();
        }
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

/// The largest single allocation a reader may ask for an input of `input_len` bytes.
pub fn alloc_bound(input_len: usize) -> usize {
    64_000_000 + 16 * input_len
}

/// A case slower than this fails (dev profile; the seeds are a few kB to a few hundred kB).
pub const CASE_TIME_LIMIT: Duration = Duration::from_secs(10);

/// A case still running after this is a hang: the watchdog keeps its file and exits.
pub const HANG_LIMIT: Duration = Duration::from_secs(120);

/// One reader under test.
pub struct Target {
    /// Name in reports and in the folder of kept cases.
    pub name: &'static str,
    /// Extension of the case file (the readers dispatch on it).
    pub ext: &'static str,
    /// Valid files to mutate.
    pub seeds: Vec<Vec<u8>>,
    /// How the seeds are mutated.
    pub mutation: Mutation,
    /// Read the case file; `Err` is a refusal (fine), a panic is a failure.
    pub read: fn(&Path) -> Result<(), String>,
}

/// How a target's seeds are mutated ([`mutate`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mutation {
    /// Byte mutations only (binary files).
    Bytes,
    /// Byte and TOML/CSV text mutations.
    Text,
    /// Numbers of a text seed replaced by extreme finite values only (1e308, subnormals, 0,
    /// huge counts; [`mutate::extreme_mutation`]): the file stays well-formed, so every case
    /// reaches the range checks and what comes after them (issue 28).
    Extremes,
}

/// What one target's run found.
pub struct Report {
    pub executions: u64,
    pub refused: u64,
    pub elapsed: Duration,
    pub failures: Vec<String>,
    pub peak_bytes: usize,
}

/// Serialises the targets (see the module doc).
static SERIAL: Mutex<()> = Mutex::new(());

/// The message of the last panic, recorded by the hook instead of printed.
static LAST_PANIC: Mutex<Option<String>> = Mutex::new(None);

/// When the current case started (ms since [`epoch`]; 0 = none) and its file.
static CASE_STARTED_MS: AtomicU64 = AtomicU64::new(0);
static CASE_FILE: Mutex<Option<PathBuf>> = Mutex::new(None);
static WATCHDOG: AtomicBool = AtomicBool::new(false);

fn epoch() -> Instant {
    static EPOCH: OnceLock<Instant> = OnceLock::new();
    *EPOCH.get_or_init(Instant::now)
}

fn install_hooks() {
    static ONCE: OnceLock<()> = OnceLock::new();
    ONCE.get_or_init(|| {
        epoch();
        std::panic::set_hook(Box::new(|info| {
            let at = info
                .location()
                .map(|l| format!(" at {}:{}", l.file(), l.line()))
                .unwrap_or_default();
            let msg = info
                .payload()
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| info.payload().downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "(non-string panic)".into());
            if CASE_STARTED_MS.load(Ordering::SeqCst) == 0 {
                // Not inside a case: the test's own assertion, printed as usual.
                eprintln!("panicked: {msg}{at}");
            } else {
                *LAST_PANIC.lock().unwrap_or_else(|e| e.into_inner()) = Some(format!("{msg}{at}"));
            }
        }));
        if !WATCHDOG.swap(true, Ordering::SeqCst) {
            std::thread::spawn(|| loop {
                std::thread::sleep(Duration::from_secs(1));
                let started = CASE_STARTED_MS.load(Ordering::SeqCst);
                let now = epoch().elapsed().as_millis() as u64;
                if started != 0 && now.saturating_sub(started) > HANG_LIMIT.as_millis() as u64 {
                    let file = CASE_FILE.lock().unwrap_or_else(|e| e.into_inner()).clone();
                    eprintln!(
                        "fuzz: a case has run for more than {} s (hang); its file: {}",
                        HANG_LIMIT.as_secs(),
                        file.map(|f| f.display().to_string()).unwrap_or_default()
                    );
                    std::process::exit(3);
                }
            });
        }
    });
}

/// Run `f` alone (under the targets' lock) and return its result with the largest single
/// allocation it asked for, bytes.
pub fn with_peak<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    PEAK_REQUEST_BYTES.store(0, Ordering::SeqCst);
    let out = f();
    (out, PEAK_REQUEST_BYTES.load(Ordering::SeqCst))
}

/// The number of cases: `FEMTO_FUZZ_CASES` when set, else `default`.
pub fn case_count(default: u64) -> u64 {
    match std::env::var("FEMTO_FUZZ_CASES") {
        Ok(v) => v
            .parse()
            .unwrap_or_else(|_| panic!("FEMTO_FUZZ_CASES={v:?} is not a whole number")),
        Err(_) => default,
    }
}

fn fuzz_seed() -> u64 {
    match std::env::var("FEMTO_FUZZ_SEED") {
        Ok(v) => v
            .parse()
            .unwrap_or_else(|_| panic!("FEMTO_FUZZ_SEED={v:?} is not a whole number")),
        Err(_) => 16,
    }
}

/// The folder where a target's cases are written and failing ones kept.
fn case_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("fuzz")
        .join(name);
    std::fs::create_dir_all(&dir).expect("the fuzz case folder");
    dir
}

/// Run `cases` mutated inputs through `target` and report.
pub fn run(target: &Target, cases: u64) -> Report {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    install_hooks();
    assert!(!target.seeds.is_empty(), "{}: no seeds", target.name);
    let dir = case_dir(target.name);
    let file = dir.join(format!("case.{}", target.ext));
    *CASE_FILE.lock().unwrap() = Some(file.clone());
    // One generator per target, so that adding a target does not change another's cases.
    let name_hash = target.name.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    });
    let mut rng = rand_pcg::Pcg64::seed_from_u64(fuzz_seed() ^ name_hash);
    let mut report = Report {
        executions: 0,
        refused: 0,
        elapsed: Duration::ZERO,
        failures: Vec::new(),
        peak_bytes: 0,
    };
    let start = Instant::now();
    // The seeds themselves first: a valid file must read.
    let n_seeds = target.seeds.len() as u64;
    for case in 0..cases + n_seeds {
        let data = if case < n_seeds {
            target.seeds[case as usize].clone()
        } else {
            match target.mutation {
                Mutation::Extremes => mutate::extreme_mutation(&mut rng, &target.seeds),
                m => mutate::mutate(&mut rng, &target.seeds, m == Mutation::Text),
            }
        };
        std::fs::write(&file, &data).expect("write the case file");
        PEAK_REQUEST_BYTES.store(0, Ordering::SeqCst);
        *LAST_PANIC.lock().unwrap() = None;
        let t0 = Instant::now();
        CASE_STARTED_MS.store(
            epoch().elapsed().as_millis().max(1) as u64,
            Ordering::SeqCst,
        );
        let outcome = catch_unwind(AssertUnwindSafe(|| (target.read)(&file)));
        CASE_STARTED_MS.store(0, Ordering::SeqCst);
        let took = t0.elapsed();
        let peak = PEAK_REQUEST_BYTES.load(Ordering::SeqCst);
        report.peak_bytes = report.peak_bytes.max(peak);
        report.executions += 1;
        let mut failure = None;
        match outcome {
            Ok(Ok(())) => {}
            Ok(Err(e)) if case < n_seeds => {
                failure = Some(format!("the valid seed {case} was refused: {e}"))
            }
            Ok(Err(e)) => {
                report.refused += 1;
                if e.contains('\n') {
                    failure = Some(format!("an error of several lines: {e:?}"));
                }
            }
            Err(_) => {
                let msg = LAST_PANIC.lock().unwrap().take().unwrap_or_default();
                failure = Some(format!("panic: {msg}"));
            }
        }
        if failure.is_none() && peak > alloc_bound(data.len()) {
            failure = Some(format!(
                "asked for one allocation of {peak} bytes for a {}-byte input (bound {})",
                data.len(),
                alloc_bound(data.len())
            ));
        }
        if failure.is_none() && took > CASE_TIME_LIMIT {
            failure = Some(format!("took {:.1} s", took.as_secs_f64()));
        }
        if let Some(why) = failure {
            let kept = dir.join(format!("fail-{}-{case}.{}", fuzz_seed(), target.ext));
            std::fs::write(&kept, &data).expect("keep the failing case");
            report
                .failures
                .push(format!("case {case} ({}): {why}", kept.display()));
        }
    }
    report.elapsed = start.elapsed();
    let _ = std::fs::remove_file(&file);
    println!(
        "fuzz {:<12} {:>8} executions {:>9.0}/s {:>5} failures  {:>5.1}% refused  largest allocation {} B",
        target.name,
        report.executions,
        report.executions as f64 / report.elapsed.as_secs_f64().max(1e-9),
        report.failures.len(),
        100.0 * report.refused as f64 / report.executions.max(1) as f64,
        report.peak_bytes
    );
    report
}

/// Run `target` and fail the test on any failure, listing the kept case files.
pub fn check(target: Target, default_cases: u64) {
    let report = run(&target, case_count(default_cases));
    assert!(
        report.failures.is_empty(),
        "fuzz {}: {} failures in {} executions:\n{}",
        target.name,
        report.failures.len(),
        report.executions,
        report.failures.join("\n")
    );
}

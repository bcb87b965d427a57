//! Running a long stage from Python: on a worker thread with the GIL released, while the
//! calling thread wakes every [`TICK`] to hand the progress to the caller's callback and to
//! check for signals (`Python::check_signals`, so Ctrl-C raises `KeyboardInterrupt`).
//!
//! A stage reports its progress through [`femto::pipeline::Progress`] (or the closures of
//! simulate and ingest, which call [`Shared::set`]); after an interrupt the next report
//! unwinds the stage with [`Cancelled`] (`std::panic::resume_unwind`, which runs no panic
//! hook). Unwinding drops the stage's staged outputs ([`femto::atomic`]), so nothing is
//! written: the same guarantee as the CLI's Ctrl-C, which ends the process instead.

use pyo3::prelude::*;
use pyo3::types::PyAny;
use std::panic::AssertUnwindSafe;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Duration;

/// How often the calling thread reports progress and checks for signals.
const TICK: Duration = Duration::from_millis(50);

/// Stack of the worker thread, bytes (the CLI's stages run on the main thread's 8 MiB).
const WORKER_STACK_BYTES: usize = 16 << 20;

/// The payload a cancelled stage unwinds with.
pub struct Cancelled;

/// The progress of a stage and its cancellation flag, shared by the worker and the caller.
#[derive(Default)]
pub struct Shared {
    what: Mutex<String>,
    len: AtomicU64,
    done: AtomicU64,
    cancelled: AtomicBool,
}

impl Shared {
    /// Unwind the stage if the caller was interrupted.
    pub fn check(&self) {
        if self.cancelled.load(Ordering::Relaxed) {
            std::panic::resume_unwind(Box::new(Cancelled));
        }
    }

    /// A pass named `what` of `len` steps begins.
    pub fn begin(&self, what: &str, len: u64) {
        if let Ok(mut w) = self.what.lock() {
            w.clear();
            w.push_str(what);
        }
        self.len.store(len, Ordering::Relaxed);
        self.done.store(0, Ordering::Relaxed);
        self.check();
    }

    /// `done` steps of the current pass are done.
    pub fn set(&self, done: u64) {
        self.done.store(done, Ordering::Relaxed);
        self.check();
    }

    fn snapshot(&self) -> (String, u64, u64) {
        let what = self.what.lock().map(|w| w.clone()).unwrap_or_default();
        (
            what,
            self.done.load(Ordering::Relaxed),
            self.len.load(Ordering::Relaxed),
        )
    }
}

impl femto::pipeline::Progress for Shared {
    fn start(&self, what: &str, len: u64) {
        self.begin(what, len);
    }
    fn set(&self, done: u64) {
        Shared::set(self, done);
    }
    fn finish(&self) {
        let len = self.len.load(Ordering::Relaxed);
        self.done.store(len, Ordering::Relaxed);
    }
    fn poll(&self) {
        self.check();
    }
}

/// Run `stage` on a worker thread with the GIL released; `progress`, when given, is called
/// as `progress(what, done, total)` on the calling thread while it runs. Ctrl-C (any
/// signal whose Python handler raises) stops the stage at its next progress report and
/// raises here.
pub fn run_stage<T, F>(py: Python<'_>, progress: Option<&Bound<'_, PyAny>>, stage: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&Shared) -> PyResult<T> + Send,
{
    let shared = Shared::default();
    std::thread::scope(|scope| {
        let worker = std::thread::Builder::new()
            .name("femto-stage".into())
            .stack_size(WORKER_STACK_BYTES)
            .spawn_scoped(scope, || {
                std::panic::catch_unwind(AssertUnwindSafe(|| stage(&shared)))
            })
            .map_err(|e| {
                pyo3::exceptions::PyRuntimeError::new_err(format!("worker thread: {e}"))
            })?;
        let mut interrupted: Option<PyErr> = None;
        let mut last = (String::new(), u64::MAX, u64::MAX);
        loop {
            let finished = py.detach(|| {
                let step = Duration::from_millis(5);
                let mut waited = Duration::ZERO;
                while waited < TICK && !worker.is_finished() {
                    std::thread::sleep(step);
                    waited += step;
                }
                worker.is_finished()
            });
            if interrupted.is_none() {
                if let Some(callback) = progress {
                    let now = shared.snapshot();
                    if now != last && !now.0.is_empty() {
                        if let Err(e) = callback.call1((now.0.as_str(), now.1, now.2)) {
                            shared.cancelled.store(true, Ordering::Relaxed);
                            interrupted = Some(e);
                        }
                        last = now;
                    }
                }
            }
            if interrupted.is_none() {
                if let Err(e) = py.check_signals() {
                    shared.cancelled.store(true, Ordering::Relaxed);
                    interrupted = Some(e);
                }
            }
            if finished {
                break;
            }
        }
        let outcome = worker.join().and_then(|caught| caught);
        match (outcome, interrupted) {
            (Ok(_), Some(e)) => Err(e),
            (Ok(result), None) => result,
            (Err(payload), Some(e)) if payload.is::<Cancelled>() => Err(e),
            (Err(payload), _) => std::panic::resume_unwind(payload),
        }
    })
}

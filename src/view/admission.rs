//! How many frames the viewer renders at once and how much memory they may take: at most as
//! many as rayon has threads (more would only share the same cores, each holding its
//! buffers), and each counted against the memory budget ([`crate::limits::memory_budget`]).
//!
//! A render is admitted when a slot is free and its estimate fits twice over: with the
//! estimates of the renders running, within the budget the server had when it started (the
//! limits do not move, and a render admitted a moment ago may not have allocated yet), and
//! alone within the budget now (which already counts what the running renders have
//! allocated, and what other processes took meanwhile). A render that does not fit waits
//! up to [`WAIT`] for one to finish, in a queue of at most four per slot; then it is refused
//! as busy (HTTP 503). One that cannot fit even alone is refused at once (413). Either way
//! the server goes on.

use crate::limits::{human_bytes, memory_budget, MemoryBudget};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

/// The longest a render waits for a slot or for memory before it is refused as busy.
pub const WAIT: Duration = Duration::from_secs(10);

/// Requests that may wait per slot; more are refused at once.
const WAITING_PER_SLOT: usize = 4;

/// Why a render was not admitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Refusal {
    /// It needs more than the whole budget (HTTP 413).
    #[error(
        "{what} needs about {}, more than the {} {}; lower width and height",
        human_bytes(*needed_bytes),
        human_bytes(budget.bytes as f64),
        budget.source
    )]
    TooLarge {
        what: String,
        needed_bytes: f64,
        budget: MemoryBudget,
    },
    /// Nothing freed a slot or enough memory in time (HTTP 503).
    #[error("busy: {0}; try again")]
    Busy(String),
}

/// The renders running and waiting.
#[derive(Debug, Default)]
struct Load {
    running: usize,
    reserved_bytes: f64,
    waiting: usize,
}

/// The admission of renders of one server.
pub struct Admission {
    max_renders: usize,
    /// The budget when the server started.
    ceiling: MemoryBudget,
    load: Mutex<Load>,
    freed: Condvar,
}

/// A render's place: released (slot and memory) when dropped.
pub struct Permit<'a> {
    admission: &'a Admission,
    bytes: f64,
}

impl Drop for Permit<'_> {
    fn drop(&mut self) {
        let mut load = self.admission.lock();
        load.running -= 1;
        load.reserved_bytes = (load.reserved_bytes - self.bytes).max(0.0);
        drop(load);
        self.admission.freed.notify_all();
    }
}

impl Admission {
    /// At most `max_renders` at once (at least one), within the memory budget as it is now.
    pub fn new(max_renders: usize) -> Admission {
        Admission {
            max_renders: max_renders.max(1),
            ceiling: memory_budget(),
            load: Mutex::new(Load::default()),
            freed: Condvar::new(),
        }
    }

    pub fn max_renders(&self) -> usize {
        self.max_renders
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Load> {
        self.load.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Admit a render of `needed_bytes` (`what` names it in a refusal), waiting up to
    /// `wait` for room.
    pub fn admit(
        &self,
        needed_bytes: f64,
        what: impl std::fmt::Display,
        wait: Duration,
    ) -> Result<Permit<'_>, Refusal> {
        if !(needed_bytes.is_finite() && needed_bytes <= self.ceiling.bytes as f64) {
            return Err(Refusal::TooLarge {
                what: what.to_string(),
                needed_bytes,
                budget: self.ceiling,
            });
        }
        let deadline = Instant::now() + wait;
        let mut load = self.lock();
        let mut queued = false;
        loop {
            let why_not = if load.running >= self.max_renders {
                format!(
                    "{} renders running, at most {} at once (one per thread)",
                    load.running, self.max_renders
                )
            } else {
                let now = memory_budget();
                let with_others = load.reserved_bytes + needed_bytes;
                if with_others <= self.ceiling.bytes as f64 && needed_bytes <= now.bytes as f64 {
                    load.running += 1;
                    load.reserved_bytes += needed_bytes;
                    if queued {
                        load.waiting -= 1;
                    }
                    return Ok(Permit {
                        admission: self,
                        bytes: needed_bytes,
                    });
                }
                format!(
                    "{what} needs about {} and the {} running need {}, of {} (now {} {})",
                    human_bytes(needed_bytes),
                    load.running,
                    human_bytes(load.reserved_bytes),
                    human_bytes(self.ceiling.bytes as f64),
                    human_bytes(now.bytes as f64),
                    now.source
                )
            };
            let left = deadline.saturating_duration_since(Instant::now());
            let queue_full = !queued && load.waiting >= WAITING_PER_SLOT * self.max_renders;
            if left.is_zero() || queue_full {
                if queued {
                    load.waiting -= 1;
                }
                return Err(Refusal::Busy(why_not));
            }
            if !queued {
                load.waiting += 1;
                queued = true;
            }
            load = self
                .freed
                .wait_timeout(load, left)
                .unwrap_or_else(|p| p.into_inner())
                .0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_more_renders_than_slots_run_at_once_and_a_freed_slot_admits_the_next() {
        let a = Admission::new(2);
        let p1 = a.admit(1.0, "a", Duration::ZERO).unwrap();
        let _p2 = a.admit(1.0, "b", Duration::ZERO).unwrap();
        let e = a.admit(1.0, "c", Duration::ZERO).err().unwrap();
        assert!(matches!(e, Refusal::Busy(_)), "{e}");
        assert!(!e.to_string().contains('\n'));
        std::thread::scope(|s| {
            let waiter = s.spawn(|| a.admit(1.0, "d", Duration::from_secs(20)).is_ok());
            std::thread::sleep(Duration::from_millis(50));
            drop(p1);
            assert!(waiter.join().unwrap());
        });
        assert_eq!(a.lock().running, 1);
        assert_eq!(a.lock().waiting, 0);
    }

    #[test]
    fn renders_are_counted_against_the_budget() {
        let mut a = Admission::new(8);
        a.ceiling = MemoryBudget {
            bytes: 1000,
            source: crate::limits::MemorySource::Override,
        };
        let e = a.admit(1001.0, "a still", Duration::ZERO).err().unwrap();
        assert!(matches!(e, Refusal::TooLarge { .. }), "{e}");
        assert!(e.to_string().contains("a still needs about 1.0 kB"), "{e}");
        assert!(a.admit(f64::NAN, "x", Duration::ZERO).is_err());
        let _p = a.admit(600.0, "a", Duration::ZERO).unwrap();
        let e = a.admit(600.0, "b", Duration::ZERO).err().unwrap();
        assert!(matches!(e, Refusal::Busy(_)), "{e}");
        assert!(a.admit(400.0, "c", Duration::ZERO).is_ok());
    }
}

//! Bounds on what a command may ask of the machine, checked before anything is allocated or
//! walked: a memory estimate against the memory this process may use (its budget: the least
//! of the machine's available memory, the process's `ulimit -v` and `ulimit -d` less what it
//! already maps, and its cgroup's memory limit; [`budget`]), the one decoded-size check of
//! every file reader, made from a header's shape in exact arithmetic before any read,
//! inflate or allocation ([`check_decoded`]), and counts derived from user numbers (a span
//! divided by a step, a frame count) capped before a loop or a `Vec` sees them.
//!
//! Every refusal names the flag or key that would fix it and gives the estimate, so a user
//! who asked for `--nt 1000000000` reads "needs 64.0 GB ... lower --nt", not "capacity
//! overflow" or an OOM kill.

use std::fmt;

pub mod budget;

pub use budget::{check_decoded, decoded_bytes, memory_budget, MemoryBudget, MemorySource};

/// Environment variable that overrides the memory this machine is taken to have available
/// (bytes), for tests and for users who share a machine. It stands for `MemAvailable`; the
/// process's own limits (`ulimit -v`, `ulimit -d`, its cgroup's) still bind when lower.
pub const MEMORY_LIMIT_ENV: &str = "FEMTO_MEMORY_LIMIT_BYTES";

/// The largest count any loop or allocation derived from a user number may reach (2^40):
/// far beyond any real capture, small enough that `count * size_of::<f64>()` cannot
/// overflow and that refusing takes no time.
pub const MAX_COUNT: u64 = 1 << 40;

/// A request the machine cannot or must not serve.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LimitError {
    /// The estimate exceeds the memory this process may use.
    #[error(
        "{what} needs about {}, more than the {} {limit}; {fix}",
        human_bytes(*needed_bytes),
        human_bytes(*available_bytes as f64)
    )]
    Memory {
        what: String,
        needed_bytes: f64,
        available_bytes: u64,
        /// The limit that sets `available_bytes`.
        limit: MemorySource,
        fix: String,
    },
    /// A count derived from user numbers is not finite, negative or above its cap.
    #[error("{what} would be {}, more than the limit of {limit}; {fix}", show_count(*value))]
    Count {
        what: String,
        value: f64,
        limit: u64,
        fix: String,
    },
}

fn show_count(v: f64) -> String {
    if v.is_finite() && v.abs() < 1e15 {
        format!("{v:.0}")
    } else {
        format!("{v:e}")
    }
}

/// A user's number as they would write it: plain between 1e-4 and 1e15 (`0.008`, `4`),
/// in exponent form beyond (`1e-300`, `1e-9`), so that a message stays one short line.
pub fn short_number(v: f64) -> String {
    if v == 0.0 || !v.is_finite() || (1e-4..1e15).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// Bytes as a short human figure: `512 B`, `3.2 MB`, `64.0 GB`, `5.3e4 TB`.
pub fn human_bytes(bytes: f64) -> String {
    const UNITS: [&str; 5] = ["B", "kB", "MB", "GB", "TB"];
    if !bytes.is_finite() {
        return "an unbounded amount of memory".into();
    }
    let mut v = bytes.max(0.0);
    let mut unit = 0;
    while v >= 1000.0 && unit + 1 < UNITS.len() {
        v /= 1000.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{v:.0} B")
    } else if v >= 1e4 {
        format!("{v:.1e} {}", UNITS[unit])
    } else {
        format!("{v:.1} {}", UNITS[unit])
    }
}

/// The memory this process may use for one command, bytes: [`memory_budget`]'s figure (the
/// least of the machine's available memory or [`MEMORY_LIMIT_ENV`], the address-space and
/// data-segment limits less what the process maps, and its cgroup's limit less its working
/// set).
pub fn available_memory_bytes() -> u64 {
    memory_budget().bytes
}

/// The override [`MEMORY_LIMIT_ENV`], when set to a number of bytes.
fn memory_override_bytes() -> Option<u64> {
    std::env::var(MEMORY_LIMIT_ENV)
        .ok()
        .and_then(|s| s.trim().parse::<u64>().ok())
}

/// Refuse when `needed_bytes` (an estimate; `f64` so that products of user numbers cannot
/// overflow) exceeds the memory this process may use ([`memory_budget`]). `what` says what needs it ("the world cube of
/// 512 x 512 x 1000000000 bins"), `fix` the flag that would help ("lower --nt").
pub fn check_memory(
    needed_bytes: f64,
    what: impl fmt::Display,
    fix: &str,
) -> Result<(), LimitError> {
    let budget = memory_budget();
    if needed_bytes.is_finite() && needed_bytes <= budget.bytes as f64 {
        return Ok(());
    }
    Err(LimitError::Memory {
        what: what.to_string(),
        needed_bytes,
        available_bytes: budget.bytes,
        limit: budget.source,
        fix: fix.to_string(),
    })
}

/// A count computed from user numbers (`span / step`, a frame count read from a file) as a
/// `usize`, refused when it is not finite, negative or above `limit` (at most
/// [`MAX_COUNT`]). Use it before `Vec::with_capacity`, `vec![..; n]` or a loop of `n` turns.
pub fn bounded_count(
    value: f64,
    limit: u64,
    what: impl fmt::Display,
    fix: &str,
) -> Result<usize, LimitError> {
    let limit = limit.min(MAX_COUNT);
    if value.is_finite() && value >= 0.0 && value <= limit as f64 {
        return Ok(value as usize);
    }
    Err(LimitError::Count {
        what: what.to_string(),
        value,
        limit,
        fix: fix.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meminfo_is_read_in_kilobytes() {
        let text = "MemTotal: 24000000 kB\nMemFree: 100 kB\nMemAvailable:   2048 kB\n";
        assert_eq!(budget::parse_meminfo_available(text), Some(2048 * 1024));
        assert_eq!(budget::parse_meminfo_available("MemTotal: 1 kB\n"), None);
    }

    #[test]
    fn memory_beyond_the_machine_is_refused_with_the_estimate_and_the_fix() {
        let e = check_memory(64e12, "the world cube", "lower --nt").unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("64.0 TB"), "{msg}");
        assert!(msg.ends_with("lower --nt"), "{msg}");
        assert!(check_memory(f64::NAN, "x", "y").is_err());
        assert!(check_memory(f64::INFINITY, "x", "y").is_err());
        assert!(check_memory(1.0, "x", "y").is_ok());
    }

    #[test]
    fn counts_are_bounded_before_use() {
        assert_eq!(bounded_count(12.0, 100, "bins", "fix").unwrap(), 12);
        for bad in [f64::NAN, f64::INFINITY, -1.0, 101.0, 1e300] {
            assert!(bounded_count(bad, 100, "bins", "fix").is_err(), "{bad}");
        }
        let e = bounded_count(1e300, u64::MAX, "time bins", "raise --dt-ps").unwrap_err();
        assert!(e.to_string().contains("1e300"), "{e}");
        assert!(e.to_string().contains(&MAX_COUNT.to_string()), "{e}");
    }

    #[test]
    fn numbers_in_messages_stay_short() {
        assert_eq!(short_number(0.008), "0.008");
        assert_eq!(short_number(4.0), "4");
        assert_eq!(short_number(1e-9), "1e-9");
        assert_eq!(short_number(1e-300), "1e-300");
        assert_eq!(short_number(1e300), "1e300");
        assert_eq!(short_number(0.0), "0");
    }

    #[test]
    fn bytes_read_as_people_write_them() {
        assert_eq!(human_bytes(512.0), "512 B");
        assert_eq!(human_bytes(6.4e9), "6.4 GB");
        assert_eq!(human_bytes(5.3e16), "5.3e4 TB");
    }
}

//! The memory this process may use, bytes: the least of
//!
//! - what the machine has available: `MemAvailable` of `/proc/meminfo`, or the override
//!   [`super::MEMORY_LIMIT_ENV`] when set (for tests and for users who share a machine);
//! - the address-space limit (`RLIMIT_AS`, `ulimit -v`) less what the process already maps
//!   (`VmSize` of `/proc/self/status`): the kernel refuses any mapping past the limit, and
//!   everything mapped counts against it (thread stacks, malloc arenas, the inputs read so
//!   far), so only the difference is left for what a command is about to allocate;
//! - the data-segment limit (`RLIMIT_DATA`, `ulimit -d`) less `VmData`, for the same reason
//!   (since Linux 4.7 it bounds every private writable mapping, which is where heap
//!   allocations live);
//! - the memory limit of the process's cgroup and of each cgroup above it (v2 `memory.max`,
//!   or v1 `memory.limit_in_bytes` on a machine that mounts the v1 memory controller) less
//!   the cgroup's working set: its usage (`memory.current`, `memory.usage_in_bytes`) minus
//!   its inactive file cache (`inactive_file` of `memory.stat`), which the kernel reclaims
//!   before it kills anything. This is the figure container runtimes report as a
//!   container's free memory; subtracting the whole usage would count the page cache of
//!   files read earlier as taken.
//!
//! The limits that are unset ("max", `RLIM_INFINITY`, v1's page-rounded `i64::MAX`) or
//! unreadable (not Linux, no `/sys/fs/cgroup`) take no part. Estimates made after a command
//! has read its inputs are counted against a budget from which those inputs' mappings are
//! already gone: the check errs on the side of refusing.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where the memory budget's figure comes from: the limit that binds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemorySource {
    /// `FEMTO_MEMORY_LIMIT_BYTES`.
    Override,
    /// `MemAvailable` of `/proc/meminfo`.
    MachineAvailable,
    /// `RLIMIT_AS` less `VmSize`.
    AddressSpace,
    /// `RLIMIT_DATA` less `VmData`.
    DataSegment,
    /// A cgroup's memory limit less its working set.
    Cgroup,
    /// Nothing could be read: a modest machine (8 GB) is assumed.
    Assumed,
}

impl fmt::Display for MemorySource {
    /// The words that follow "more than the 3.9 GB" in a refusal.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            MemorySource::Override => "that FEMTO_MEMORY_LIMIT_BYTES allows",
            MemorySource::MachineAvailable => "this machine has available",
            MemorySource::AddressSpace => {
                "this process may still map under its address-space limit (ulimit -v)"
            }
            MemorySource::DataSegment => {
                "this process may still allocate under its data-segment limit (ulimit -d)"
            }
            MemorySource::Cgroup => "its cgroup's memory limit leaves",
            MemorySource::Assumed => "assumed (this machine's memory could not be read)",
        })
    }
}

/// The memory this process may use now and the limit that sets it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryBudget {
    pub bytes: u64,
    pub source: MemorySource,
}

/// Memory assumed when nothing can be read, bytes.
const ASSUMED_BYTES: u64 = 8_000_000_000;

/// The memory budget of this process now (module documentation).
pub fn memory_budget() -> MemoryBudget {
    let machine = match super::memory_override_bytes() {
        Some(bytes) => MemoryBudget {
            bytes,
            source: MemorySource::Override,
        },
        None => match read("/proc/meminfo").and_then(|t| parse_meminfo_available(&t)) {
            Some(bytes) => MemoryBudget {
                bytes,
                source: MemorySource::MachineAvailable,
            },
            None => MemoryBudget {
                bytes: ASSUMED_BYTES,
                source: MemorySource::Assumed,
            },
        },
    };
    let status = read("/proc/self/status").unwrap_or_default();
    let rlimit_left = |resource, field, source| {
        let limit = soft_rlimit_bytes(resource)?;
        let used = parse_status_kb(&status, field).unwrap_or(0);
        Some(MemoryBudget {
            bytes: limit.saturating_sub(used),
            source,
        })
    };
    let candidates = [
        Some(machine),
        rlimit_left(
            libc::RLIMIT_AS as i32,
            "VmSize:",
            MemorySource::AddressSpace,
        ),
        rlimit_left(
            libc::RLIMIT_DATA as i32,
            "VmData:",
            MemorySource::DataSegment,
        ),
        cgroup_left_bytes().map(|bytes| MemoryBudget {
            bytes,
            source: MemorySource::Cgroup,
        }),
    ];
    least(&candidates).unwrap_or(machine)
}

/// Bytes that decoding an array of shape `dims` needs when each element takes
/// `element_bytes` after conversion (4 for the float32 cube) and the stage holds `copies`
/// such arrays at once: the exact product in u128, `None` only beyond u128 (no header of a
/// realistic rank gets there; any such product is refused).
pub fn decoded_bytes(dims: &[usize], element_bytes: usize, copies: usize) -> Option<u128> {
    dims.iter()
        .map(|&d| d as u128)
        .chain([element_bytes as u128, copies as u128])
        .try_fold(1u128, u128::checked_mul)
}

/// The one size check of every reader, made from the header alone, before any read, inflate
/// or allocation: refuse decoding an array of shape `dims` (as the file declares it) into
/// elements of `element_bytes` each (after conversion: 4 for the float32 cube), with
/// `copies` of it held at once, when that exceeds the memory budget ([`memory_budget`]).
/// The product is exact ([`decoded_bytes`]): a shape whose byte count wraps a `usize`
/// (2^62 values of 4 bytes) is refused, never read as 0. `what` names the array and its
/// declared shape and type; `fix` what would help. Returns the bytes needed.
pub fn check_decoded(
    dims: &[usize],
    element_bytes: usize,
    copies: usize,
    what: impl fmt::Display,
    fix: &str,
) -> Result<u128, super::LimitError> {
    let needed = decoded_bytes(dims, element_bytes, copies);
    let budget = memory_budget();
    match needed {
        Some(n) if n <= u128::from(budget.bytes) => Ok(n),
        _ => {
            // For the message only: the product in f64 (finite for any realistic rank).
            let approx = dims.iter().map(|&d| d as f64).product::<f64>()
                * element_bytes as f64
                * copies as f64;
            Err(super::LimitError::Memory {
                what: what.to_string(),
                needed_bytes: approx,
                available_bytes: budget.bytes,
                limit: budget.source,
                fix: fix.to_string(),
            })
        }
    }
}

/// The smallest of the budgets that are known (the first of equals).
fn least(candidates: &[Option<MemoryBudget>]) -> Option<MemoryBudget> {
    candidates
        .iter()
        .flatten()
        .copied()
        .reduce(|a, b| if b.bytes < a.bytes { b } else { a })
}

fn read(path: impl AsRef<Path>) -> Option<String> {
    std::fs::read_to_string(path).ok()
}

pub(super) fn parse_meminfo_available(text: &str) -> Option<u64> {
    parse_status_kb(text, "MemAvailable:")
}

/// A `NAME:   1234 kB` line of `/proc/meminfo` or `/proc/self/status`, bytes.
fn parse_status_kb(text: &str, field: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(field))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kb.checked_mul(1024)
}

/// The soft limit of `resource` (the one the kernel enforces), bytes; None when unlimited.
/// (`rlim_t` is `u64` on Linux, not on every Unix: hence the conversions.)
#[cfg(unix)]
#[allow(clippy::useless_conversion)]
fn soft_rlimit_bytes(resource: i32) -> Option<u64> {
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: getrlimit writes one rlimit through a valid pointer to a local.
    let rc = unsafe { libc::getrlimit(resource as _, &mut limit) };
    if rc != 0 || limit.rlim_cur == libc::RLIM_INFINITY {
        return None;
    }
    u64::try_from(limit.rlim_cur).ok()
}

#[cfg(not(unix))]
fn soft_rlimit_bytes(_resource: i32) -> Option<u64> {
    None
}

/// The least, over the process's cgroup and its ancestors, of the memory limit less the
/// working set; None when no cgroup sets a limit (or none can be read).
fn cgroup_left_bytes() -> Option<u64> {
    let membership = read("/proc/self/cgroup")?;
    let mounts = read("/proc/self/mountinfo").unwrap_or_default();
    let mut dirs = Vec::new();
    if let Some(dir) = cgroup_dir(&membership, &mounts, Hierarchy::V2) {
        dirs.extend(ancestors(&dir, Hierarchy::V2, &mounts));
    }
    if let Some(dir) = cgroup_dir(&membership, &mounts, Hierarchy::V1Memory) {
        dirs.extend(ancestors(&dir, Hierarchy::V1Memory, &mounts));
    }
    dirs.iter()
        .filter_map(|(dir, h)| cgroup_left_in(dir, *h))
        .min()
}

/// The two ways a cgroup's memory limit is kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Hierarchy {
    /// The unified hierarchy: `memory.max`, `memory.current`.
    V2,
    /// The v1 memory controller: `memory.limit_in_bytes`, `memory.usage_in_bytes`.
    V1Memory,
}

/// The mount point of `h` and the cgroup path at its root, from `/proc/self/mountinfo`
/// (`ID PARENT MAJ:MIN ROOT MOUNT_POINT OPTIONS... - FSTYPE SOURCE SUPER_OPTIONS`).
fn mount_of(mounts: &str, h: Hierarchy) -> Option<(PathBuf, String)> {
    mounts.lines().find_map(|line| {
        let (before, after) = line.split_once(" - ")?;
        let fields: Vec<&str> = before.split_whitespace().collect();
        let after: Vec<&str> = after.split_whitespace().collect();
        let (root, point) = (fields.get(3)?, fields.get(4)?);
        let fstype = after.first()?;
        let wanted = match h {
            Hierarchy::V2 => *fstype == "cgroup2",
            Hierarchy::V1Memory => {
                *fstype == "cgroup" && after.get(2)?.split(',').any(|o| o == "memory")
            }
        };
        wanted.then(|| (PathBuf::from(point), root.to_string()))
    })
}

/// The process's cgroup folder in hierarchy `h`: its path from `/proc/self/cgroup`
/// (`0::/path` for v2, `N:...memory...:/path` for v1) under the hierarchy's mount point
/// (`/sys/fs/cgroup` for v2 when mountinfo does not say).
fn cgroup_dir(membership: &str, mounts: &str, h: Hierarchy) -> Option<PathBuf> {
    let path = membership.lines().find_map(|line| {
        let mut parts = line.splitn(3, ':');
        let (id, controllers, path) = (parts.next()?, parts.next()?, parts.next()?);
        let wanted = match h {
            Hierarchy::V2 => id == "0" && controllers.is_empty(),
            Hierarchy::V1Memory => controllers.split(',').any(|c| c == "memory"),
        };
        wanted.then(|| path.to_string())
    })?;
    let (point, root) = match (mount_of(mounts, h), h) {
        (Some(m), _) => m,
        (None, Hierarchy::V2) => (PathBuf::from("/sys/fs/cgroup"), "/".to_string()),
        (None, Hierarchy::V1Memory) => return None,
    };
    // Inside a cgroup namespace the mount's root is the process's cgroup itself.
    let relative = path.strip_prefix(root.as_str()).unwrap_or(&path);
    let relative = relative.trim_start_matches('/');
    if relative.split('/').any(|c| c == "..") {
        return None;
    }
    Some(point.join(relative))
}

/// `dir` and its parents up to the hierarchy's mount point (included).
fn ancestors(dir: &Path, h: Hierarchy, mounts: &str) -> Vec<(PathBuf, Hierarchy)> {
    let top = mount_of(mounts, h)
        .map(|(p, _)| p)
        .unwrap_or_else(|| PathBuf::from("/sys/fs/cgroup"));
    let mut out = Vec::new();
    let mut d = Some(dir);
    while let Some(p) = d {
        if !p.starts_with(&top) {
            break;
        }
        out.push((p.to_path_buf(), h));
        d = p.parent();
    }
    out
}

/// One cgroup's limit less its working set, bytes; None when it sets no limit.
fn cgroup_left_in(dir: &Path, h: Hierarchy) -> Option<u64> {
    let (limit_file, usage_file, inactive_key) = match h {
        Hierarchy::V2 => ("memory.max", "memory.current", "inactive_file"),
        Hierarchy::V1Memory => (
            "memory.limit_in_bytes",
            "memory.usage_in_bytes",
            "total_inactive_file",
        ),
    };
    let limit = parse_cgroup_limit(&read(dir.join(limit_file))?)?;
    let usage: u64 = read(dir.join(usage_file))
        .and_then(|t| t.trim().parse().ok())
        .unwrap_or(0);
    let inactive = read(dir.join("memory.stat"))
        .and_then(|t| parse_memory_stat(&t, inactive_key))
        .unwrap_or(0);
    Some(cgroup_left(limit, usage, inactive))
}

/// A cgroup memory limit: None for v2's "max" and for v1's "no limit" (the largest page
/// multiple of `i64::MAX`, or anything from 2^60 up).
fn parse_cgroup_limit(text: &str) -> Option<u64> {
    let text = text.trim();
    if text == "max" {
        return None;
    }
    text.parse::<u64>().ok().filter(|&v| v < 1 << 60)
}

fn parse_memory_stat(text: &str, key: &str) -> Option<u64> {
    text.lines().find_map(|l| {
        let (k, v) = l.split_once(' ')?;
        (k == key).then(|| v.trim().parse().ok()).flatten()
    })
}

/// A limit less the working set (usage less inactive file cache), bytes.
fn cgroup_left(limit: u64, usage: u64, inactive_file: u64) -> u64 {
    limit.saturating_sub(usage.saturating_sub(inactive_file))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decoded_sizes_are_exact_where_usize_arithmetic_wraps() {
        let two = |k: u32| 1usize << k;
        for (dims, want) in [
            (vec![0usize], Some(0u128)),
            (vec![two(31)], Some(1u128 << 34)),
            (vec![two(32)], Some(1u128 << 35)),
            (vec![two(62)], Some(1u128 << 65)),
            (vec![usize::MAX], Some(u128::from(u64::MAX) * 8)),
            // The .mat of issue 45: 2^62 values of 4 bytes wrapped to 0 in usize.
            (vec![two(21), two(21), two(20)], Some(1u128 << 65)),
            (vec![usize::MAX, usize::MAX, usize::MAX], None),
        ] {
            assert_eq!(decoded_bytes(&dims, 4, 2), want, "{dims:?}");
        }
        assert_eq!(decoded_bytes(&[3, 5], 4, 0), Some(0));
    }

    #[test]
    fn a_decode_beyond_the_budget_is_refused_naming_what_and_the_fix() {
        let two = |k: u32| 1usize << k;
        for dims in [
            vec![two(62)],
            vec![usize::MAX],
            vec![two(21), two(21), two(20)],
            vec![usize::MAX, usize::MAX, usize::MAX],
        ] {
            let e = check_decoded(&dims, 4, 3, "variable a of [..] uint8", "crop it").unwrap_err();
            let msg = e.to_string();
            assert!(
                msg.starts_with("variable a of [..] uint8 needs about "),
                "{msg}"
            );
            assert!(msg.ends_with("; crop it"), "{msg}");
            assert!(!msg.contains('\n'), "{msg}");
        }
        assert_eq!(check_decoded(&[0], 4, 3, "x", "y"), Ok(0));
        assert_eq!(check_decoded(&[16, 16], 4, 2, "x", "y"), Ok(2048));
        // 2^31 and 2^32 values fit the figure of a large machine, not of this test's budget
        // when it is below 8 GiB: either way the answer is the exact size or a refusal.
        for dims in [vec![two(31)], vec![two(32)]] {
            match check_decoded(&dims, 4, 1, "x", "y") {
                Ok(n) => assert_eq!(n, (dims[0] as u128) * 4),
                Err(e) => assert!(e.to_string().contains("needs about"), "{e}"),
            }
        }
    }

    #[test]
    fn status_fields_are_read_in_kilobytes() {
        let status = "Name:\tfemto\nVmPeak:\t  9000 kB\nVmSize:\t  4096 kB\nVmData:\t 100 kB\n";
        assert_eq!(parse_status_kb(status, "VmSize:"), Some(4096 * 1024));
        assert_eq!(parse_status_kb(status, "VmData:"), Some(100 * 1024));
        assert_eq!(parse_status_kb(status, "VmSwap:"), None);
    }

    #[test]
    fn the_least_known_budget_binds() {
        let b = |bytes, source| Some(MemoryBudget { bytes, source });
        let got = least(&[
            b(20_000_000_000, MemorySource::MachineAvailable),
            b(3_900_000_000, MemorySource::AddressSpace),
            None,
            b(5_000_000_000, MemorySource::Cgroup),
        ]);
        assert_eq!(got, b(3_900_000_000, MemorySource::AddressSpace));
        assert_eq!(least(&[None, None]), None);
    }

    #[test]
    fn cgroup_limits_read_as_the_kernel_writes_them() {
        assert_eq!(parse_cgroup_limit("max\n"), None);
        assert_eq!(parse_cgroup_limit("9223372036854771712\n"), None);
        assert_eq!(parse_cgroup_limit("4294967296\n"), Some(4 << 30));
        assert_eq!(parse_cgroup_limit("junk"), None);
        let stat = "anon 100\nfile 900\ninactive_file 700\nactive_file 200\n";
        assert_eq!(parse_memory_stat(stat, "inactive_file"), Some(700));
        assert_eq!(parse_memory_stat(stat, "inactive_anon"), None);
        // 4 GB limit, 3 GB used of which 2 GB is inactive page cache: 3 GB left.
        assert_eq!(cgroup_left(4 << 30, 3 << 30, 2 << 30), 3 << 30);
        assert_eq!(cgroup_left(1 << 30, 3 << 30, 0), 0);
    }

    #[test]
    fn the_process_cgroup_is_found_under_its_mount() {
        let mounts = "31 23 0:28 / /sys/fs/cgroup rw - tmpfs tmpfs rw\n\
                      35 31 0:32 / /sys/fs/cgroup/memory rw - cgroup cgroup rw,memory\n\
                      41 31 0:38 / /sys/fs/cgroup/unified rw - cgroup2 cgroup2 rw\n";
        let membership = "4:memory:/jobs/a\n1:cpu:/\n0::/user.slice/b\n";
        assert_eq!(
            cgroup_dir(membership, mounts, Hierarchy::V2),
            Some(PathBuf::from("/sys/fs/cgroup/unified/user.slice/b"))
        );
        assert_eq!(
            cgroup_dir(membership, mounts, Hierarchy::V1Memory),
            Some(PathBuf::from("/sys/fs/cgroup/memory/jobs/a"))
        );
        let dir = cgroup_dir(membership, mounts, Hierarchy::V1Memory).unwrap();
        let up: Vec<PathBuf> = ancestors(&dir, Hierarchy::V1Memory, mounts)
            .into_iter()
            .map(|(p, _)| p)
            .collect();
        assert_eq!(
            up,
            [
                "/sys/fs/cgroup/memory/jobs/a",
                "/sys/fs/cgroup/memory/jobs",
                "/sys/fs/cgroup/memory"
            ]
            .map(PathBuf::from)
        );
        // A v2-only machine whose mountinfo is unreadable; a namespaced cgroup whose mount
        // root is the cgroup itself.
        assert_eq!(
            cgroup_dir("0::/a/b\n", "", Hierarchy::V2),
            Some(PathBuf::from("/sys/fs/cgroup/a/b"))
        );
        let ns = "50 1 0:40 /a/b /sys/fs/cgroup rw - cgroup2 cgroup2 rw\n";
        assert_eq!(
            cgroup_dir("0::/a/b\n", ns, Hierarchy::V2),
            Some(PathBuf::from("/sys/fs/cgroup"))
        );
        assert_eq!(cgroup_dir("0::/../x\n", ns, Hierarchy::V2), None);
    }

    #[test]
    fn the_budget_of_this_process_is_at_most_what_the_machine_has() {
        let b = memory_budget();
        assert!(b.bytes > 0);
        if let Some(avail) = read("/proc/meminfo").and_then(|t| parse_meminfo_available(&t)) {
            if super::super::memory_override_bytes().is_none() {
                assert!(b.bytes <= avail, "{b:?} > {avail}");
            }
        }
    }
}

//! CPU time of this process (user + system, all threads), for the counters of long stages:
//! on a shared machine it is steadier than wall time, and with the wall time it says how
//! many cores a stage kept busy.

/// CPU seconds this process has used so far (`getrusage(RUSAGE_SELF)`, microsecond
/// resolution); NaN where the call fails.
pub fn process_cpu_seconds() -> f64 {
    // SAFETY: getrusage writes one plain C struct that we own; zeroed is a valid value of it.
    let usage = unsafe {
        let mut usage: libc::rusage = std::mem::zeroed();
        if libc::getrusage(libc::RUSAGE_SELF, &mut usage) != 0 {
            return f64::NAN;
        }
        usage
    };
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    seconds(usage.ru_utime) + seconds(usage.ru_stime)
}

#[cfg(test)]
mod tests {
    #[test]
    fn cpu_time_grows_with_work() {
        // Busy work until 20 ms of CPU time are counted: on a loaded machine the thread may
        // get a small share of the wall time (50 ms of wall gave 18 ms of CPU at load 10),
        // so the wall clock only bounds the wait (10 s).
        let before = super::process_cpu_seconds();
        let mut x = 0u64;
        let started = std::time::Instant::now();
        let mut after = before;
        while after - before < 0.02 && started.elapsed().as_secs() < 10 {
            for _ in 0..100_000 {
                x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
            }
            after = super::process_cpu_seconds();
        }
        assert!(after - before >= 0.02, "{before} -> {after}");
    }
}

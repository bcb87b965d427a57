//! Physical constants and the time-of-flight relation shared by every module.
//!
//! physics.md, "Units and clocks": lengths in metres, times in picoseconds, light in a medium
//! of index `eta` travels at `c / eta`, so a path of length `L` takes `eta * L / c`.

/// Speed of light in vacuum, metres per picosecond.
pub const C_M_PER_PS: f64 = 2.997_924_580e-4;

/// Time of flight in picoseconds over `dist_m` metres in a medium of index `eta`.
#[inline]
pub fn flight_time_ps(eta: f64, dist_m: f64) -> f64 {
    eta * dist_m / C_M_PER_PS
}

/// Distance in metres that light covers in `time_ps` picoseconds in a medium of index `eta`.
#[inline]
pub fn flight_distance_m(eta: f64, time_ps: f64) -> f64 {
    time_ps * C_M_PER_PS / eta
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_metre_in_vacuum_is_3336_ps() {
        // 1 m / 299 792 458 m/s = 3.335 640 95 ns.
        assert!((flight_time_ps(1.0, 1.0) - 3_335.640_95).abs() < 1e-3);
        assert!((flight_distance_m(1.0, flight_time_ps(1.0, 2.5)) - 2.5).abs() < 1e-12);
    }
}

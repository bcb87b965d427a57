//! mitransient's transient output into a femto cube.
//!
//! mitransient (Mitsuba 3's transient renderer) develops its `transient_hdr_film` into an
//! array `(H, W, T, C)`: image rows, columns, time bins, colour channels (RGB, linear
//! Rec. 709, alpha already removed). Users keep it with `np.save`; the film's binning lives in
//! the scene (`start_opl`, `bin_width_opl`, `temporal_bins`, in scene units of optical path
//! length, metres for femto), not in the array, so it is given with it ([`OplBinning`]). The
//! film bins a path of optical length `opl` into `floor((opl - start_opl) / bin_width_opl)`,
//! so bin `i` covers `[start + i w, start + (i + 1) w)`: femto's convention, with
//! `t_ps = opl_m / c` ([`crate::units::C_M_PER_PS`]). The path length runs from the emitter to
//! the sensor: camera time (`camera_unwarp = false`, the integrator's default), or world
//! time when the scene was rendered with `camera_unwarp = true`.

use super::InteropError;
use crate::cube::{Cube, TimeAxis, TimeFrame};
use crate::ranges;
use crate::readers::npy::read_npy;
use crate::units::C_M_PER_PS;
use std::path::Path;

/// The film's binning in optical path length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OplBinning {
    /// `start_opl`, metres.
    pub start_opl_m: f64,
    /// `bin_width_opl`, metres, > 0.
    pub bin_width_opl_m: f64,
}

impl OplBinning {
    /// The time axis of `nt` bins: `t_ps = opl_m / c`.
    pub fn axis(&self, nt: usize) -> TimeAxis {
        TimeAxis {
            t0_ps: self.start_opl_m / C_M_PER_PS,
            dt_ps: self.bin_width_opl_m / C_M_PER_PS,
            nt,
        }
    }
}

/// How the colour channels become the cube's one value per bin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channels {
    /// The mean of the channels.
    Mean,
    /// One channel.
    R,
    G,
    B,
    /// Rec. 709 luminance `0.2126 R + 0.7152 G + 0.0722 B` (Mitsuba's RGB is linear Rec. 709).
    Luminance,
}

impl Channels {
    /// The weight of each of `n` channels, or why this choice does not fit them.
    fn weights(self, n: usize) -> Result<Vec<f32>, String> {
        let one = |i: usize| -> Result<Vec<f32>, String> {
            if i >= n {
                return Err(format!(
                    "the array has {n} colour channel(s), no channel {i}"
                ));
            }
            Ok((0..n).map(|j| if j == i { 1.0 } else { 0.0 }).collect())
        };
        match self {
            // Summed, then divided by n (below), as NumPy's mean does: 1/3 is not a float.
            Channels::Mean => Ok(vec![1.0; n]),
            Channels::R => one(0),
            Channels::G => one(1),
            Channels::B => one(2),
            Channels::Luminance if n == 1 => Ok(vec![1.0]),
            Channels::Luminance if n == 3 => Ok(vec![0.2126, 0.7152, 0.0722]),
            Channels::Luminance => Err(format!(
                "luminance needs 3 colour channels (RGB), the array has {n}"
            )),
        }
    }
}

/// Read a transient array saved with `np.save` (`(H, W, T, C)`, or `(H, W, T)` for one
/// channel) into a cube of `W x H` pixels and `T` bins on `binning`'s axis, in `frame`.
pub fn read_transient_npy(
    path: &Path,
    binning: OplBinning,
    channels: Channels,
    frame: TimeFrame,
) -> Result<Cube, InteropError> {
    let bad = |key: &str, message: String| InteropError::Invalid {
        path: path.to_path_buf(),
        key: key.to_string(),
        message,
    };
    if !(binning.bin_width_opl_m.is_finite() && binning.bin_width_opl_m > 0.0) {
        return Err(bad(
            "bin_width_opl",
            format!("{} m, must be > 0", binning.bin_width_opl_m),
        ));
    }
    if !binning.start_opl_m.is_finite() {
        return Err(bad("start_opl", format!("{} m", binning.start_opl_m)));
    }
    // A bin width and a time as optical path ([`crate::ranges`] times c).
    for (key, v, range) in [
        (
            "bin_width_opl",
            binning.bin_width_opl_m,
            ranges::BIN_WIDTH_PS.scaled(C_M_PER_PS, " m"),
        ),
        (
            "start_opl",
            binning.start_opl_m,
            ranges::TIME_PS.scaled(C_M_PER_PS, " m"),
        ),
    ] {
        ranges::check(key, v, range).map_err(|e| bad(key, e.detail()))?;
    }
    let a = read_npy(path)?;
    let (ny, nx, nt, nc) = match a.shape.as_slice() {
        &[h, w, t, c] => (h, w, t, c),
        &[h, w, t] => (h, w, t, 1),
        other => {
            return Err(bad(
                "shape",
                format!("{other:?}: expected mitransient's (H, W, T, C) or (H, W, T)"),
            ))
        }
    };
    if a.shape.contains(&0) {
        return Err(bad("shape", format!("{:?} is empty", a.shape)));
    }
    let weights = channels.weights(nc).map_err(|m| bad("channels", m))?;
    if let Some(i) = a.values.iter().position(|v| !v.is_finite()) {
        let (p, t, c) = (i / (nt * nc), i / nc % nt, i % nc);
        return Err(bad(
            "values",
            format!(
                "{} at row {}, column {}, bin {t}, channel {c}",
                a.values[i],
                p / nx,
                p % nx
            ),
        ));
    }
    // (H, W, T, C) is (y, x, t, c): the cube's [y][x][t] with the channels innermost.
    let divisor = if channels == Channels::Mean {
        nc as f32
    } else {
        1.0
    };
    let data: Vec<f32> = a
        .values
        .chunks_exact(nc)
        .map(|c| c.iter().zip(&weights).map(|(v, w)| v * w).sum::<f32>() / divisor)
        .collect();
    Ok(Cube {
        nx,
        ny,
        axis: binning.axis(nt),
        frame,
        data,
        mask: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::readers::npy::npy_bytes;

    #[test]
    fn channels_collapse_and_path_length_becomes_picoseconds() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.npy");
        // 1 row, 2 columns, 2 bins, RGB: value = 100 x + 10 t + c.
        let mut v = Vec::new();
        for x in 0..2 {
            for t in 0..2 {
                for c in 0..3 {
                    v.push((100 * x + 10 * t + c) as f32);
                }
            }
        }
        std::fs::write(&p, npy_bytes(&[1, 2, 2, 3], &v)).unwrap();
        // 0.3 m of optical path is 1000.69 ps (0.3 / 2.99792458e-4).
        let b = OplBinning {
            start_opl_m: 0.3,
            bin_width_opl_m: 0.0006,
        };
        let cube = read_transient_npy(&p, b, Channels::G, TimeFrame::Camera).unwrap();
        assert_eq!((cube.nx, cube.ny, cube.axis.nt), (2, 1, 2));
        assert_eq!(cube.data, [1.0, 11.0, 101.0, 111.0]);
        assert!((cube.axis.t0_ps - 1_000.692_286).abs() < 1e-5);
        assert!((cube.axis.dt_ps - 2.001_384_57).abs() < 1e-7);
        let mean = read_transient_npy(&p, b, Channels::Mean, TimeFrame::World).unwrap();
        assert_eq!(mean.data, [1.0, 11.0, 101.0, 111.0]);
        assert_eq!(mean.frame, TimeFrame::World);
        let lum = read_transient_npy(&p, b, Channels::Luminance, TimeFrame::Camera).unwrap();
        assert!((lum.data[0] - (0.7152 + 2.0 * 0.0722)).abs() < 1e-6);
        // One channel: no blue to pick; a 5-D array is refused.
        std::fs::write(&p, npy_bytes(&[1, 2, 2], &[0.0; 4])).unwrap();
        assert!(read_transient_npy(&p, b, Channels::B, TimeFrame::Camera).is_err());
        std::fs::write(&p, npy_bytes(&[1, 1, 1, 1, 1], &[0.0])).unwrap();
        assert!(read_transient_npy(&p, b, Channels::Mean, TimeFrame::Camera).is_err());
    }
}

//! The x-y-t cube: one time profile per pixel, contiguous in memory.
//!
//! Layout `[y][x][t]`: `data[(y * nx + x) * nt + t]`. Bin `i` covers the time interval
//! `[t0_ps + i * dt_ps, t0_ps + (i + 1) * dt_ps)`, and its value is the signal *integrated*
//! over that bin (energy per bin), so a pixel's time integral is the plain sum of its bins.
//! Which clock the axis measures is recorded in [`TimeFrame`] (physics.md, "two clocks").

use std::fmt;

/// Which clock the time axis of a cube measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeFrame {
    /// When light reaches the sensor (what a streak camera records).
    Camera,
    /// When light is at the surface point: `t_world = t_camera - eta * |p - o| / c`.
    World,
}

impl TimeFrame {
    pub fn as_str(self) -> &'static str {
        match self {
            TimeFrame::Camera => "camera",
            TimeFrame::World => "world",
        }
    }

    pub fn parse(s: &str) -> Option<TimeFrame> {
        match s {
            "camera" => Some(TimeFrame::Camera),
            "world" => Some(TimeFrame::World),
            _ => None,
        }
    }
}

impl fmt::Display for TimeFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A uniform time axis: `nt` bins of `dt_ps` starting at `t0_ps`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeAxis {
    pub t0_ps: f64,
    pub dt_ps: f64,
    pub nt: usize,
}

impl TimeAxis {
    /// Start of bin `i`, in ps.
    #[inline]
    pub fn bin_start_ps(&self, i: usize) -> f64 {
        self.t0_ps + i as f64 * self.dt_ps
    }

    /// Centre of bin `i`, in ps.
    #[inline]
    pub fn bin_centre_ps(&self, i: usize) -> f64 {
        self.t0_ps + (i as f64 + 0.5) * self.dt_ps
    }

    /// End of the last bin, in ps.
    #[inline]
    pub fn end_ps(&self) -> f64 {
        self.bin_start_ps(self.nt)
    }

    /// Continuous bin coordinate of time `t_ps` (0.0 at the start of bin 0).
    #[inline]
    pub fn bin_coord(&self, t_ps: f64) -> f64 {
        (t_ps - self.t0_ps) / self.dt_ps
    }
}

/// An x-y-t cube of f32, laid out `[y][x][t]`, with an optional validity mask (`1` = valid).
#[derive(Clone, Debug, PartialEq)]
pub struct Cube {
    pub nx: usize,
    pub ny: usize,
    pub axis: TimeAxis,
    pub frame: TimeFrame,
    pub data: Vec<f32>,
    /// One byte per pixel, `[y][x]`, 1 where the pixel holds valid data.
    pub mask: Option<Vec<u8>>,
}

impl Cube {
    /// A cube of zeros.
    pub fn zeros(nx: usize, ny: usize, axis: TimeAxis, frame: TimeFrame) -> Cube {
        Cube {
            nx,
            ny,
            axis,
            frame,
            data: vec![0.0; nx * ny * axis.nt],
            mask: None,
        }
    }

    #[inline]
    pub fn nt(&self) -> usize {
        self.axis.nt
    }

    /// Shape as `(ny, nx, nt)`, the order of the on-disk dataset.
    pub fn shape(&self) -> (usize, usize, usize) {
        (self.ny, self.nx, self.axis.nt)
    }

    #[inline]
    fn offset(&self, x: usize, y: usize) -> usize {
        (y * self.nx + x) * self.axis.nt
    }

    /// The time profile of pixel `(x, y)`.
    #[inline]
    pub fn profile(&self, x: usize, y: usize) -> &[f32] {
        let o = self.offset(x, y);
        &self.data[o..o + self.axis.nt]
    }

    /// The mutable time profile of pixel `(x, y)`.
    #[inline]
    pub fn profile_mut(&mut self, x: usize, y: usize) -> &mut [f32] {
        let o = self.offset(x, y);
        let nt = self.axis.nt;
        &mut self.data[o..o + nt]
    }

    /// Row `y` as `nx * nt` values (`[x][t]`).
    pub fn row(&self, y: usize) -> &[f32] {
        let n = self.nx * self.axis.nt;
        &self.data[y * n..(y + 1) * n]
    }

    /// Whether pixel `(x, y)` is valid (true when there is no mask).
    #[inline]
    pub fn is_valid(&self, x: usize, y: usize) -> bool {
        self.mask.as_ref().is_none_or(|m| m[y * self.nx + x] != 0)
    }

    /// Size of the data in memory, bytes.
    pub fn size_bytes(&self) -> usize {
        self.data.len() * std::mem::size_of::<f32>() + self.mask.as_ref().map_or(0, |m| m.len())
    }

    /// Smallest and largest finite values (None for an empty or all-NaN cube).
    pub fn value_range(&self) -> Option<(f32, f32)> {
        value_range(&self.data)
    }

    /// Time integral of each pixel (`[y][x]`), the classic steady-state image.
    pub fn time_integral(&self) -> Vec<f64> {
        self.data
            .chunks_exact(self.axis.nt.max(1))
            .map(|p| p.iter().map(|&v| v as f64).sum())
            .collect()
    }
}

/// Smallest and largest finite values of a slice.
pub fn value_range(values: &[f32]) -> Option<(f32, f32)> {
    let mut lo = f32::INFINITY;
    let mut hi = f32::NEG_INFINITY;
    for &v in values.iter().filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    (lo <= hi).then_some((lo, hi))
}

/// A value a cube must not hold (NaN or infinite) and where it is: pixel `(x, y)`, bin `bin`
/// of a `[y][x][t]` slab whose first row is `y = 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NonFiniteAt {
    pub x: usize,
    pub y: usize,
    pub bin: usize,
    /// The value as stored (NaN, `inf` or `-inf`), widened to f64.
    pub value: f64,
}

impl NonFiniteAt {
    /// `NaN`, `inf` or `-inf`, as messages name it.
    pub fn kind(&self) -> &'static str {
        if self.value.is_nan() {
            "NaN"
        } else if self.value > 0.0 {
            "inf"
        } else {
            "-inf"
        }
    }
}

/// Samples whose finiteness [`first_non_finite`] checks.
pub trait Sample: Copy + Send + Sync {
    fn finite(self) -> bool;
    fn widen(self) -> f64;
}

impl Sample for f32 {
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
    #[inline]
    fn widen(self) -> f64 {
        self as f64
    }
}

impl Sample for f64 {
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
    #[inline]
    fn widen(self) -> f64 {
        self
    }
}

/// The first NaN or infinite value of a `[y][x][t]` slab of `nx` pixels by `nt` bins per row
/// (in memory order), or `None` when every value is finite. Scans blocks in parallel without
/// a branch per value (the check must cost little beside decompression: issue 16).
pub fn first_non_finite<T: Sample>(values: &[T], nx: usize, nt: usize) -> Option<NonFiniteAt> {
    use rayon::prelude::*;
    const BLOCK: usize = 1 << 14;
    let block = values
        .par_chunks(BLOCK)
        .position_first(|b| !b.iter().fold(true, |ok, &v| ok & v.finite()))?;
    let i = block * BLOCK
        + values[block * BLOCK..]
            .iter()
            .position(|&v| !v.finite())
            .expect("the block holds a non-finite value");
    let (nt, nx) = (nt.max(1), nx.max(1));
    Some(NonFiniteAt {
        x: i / nt % nx,
        y: i / nt / nx,
        bin: i % nt,
        value: values[i].widen(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_is_y_x_t() {
        let axis = TimeAxis {
            t0_ps: 10.0,
            dt_ps: 2.0,
            nt: 4,
        };
        let mut c = Cube::zeros(3, 2, axis, TimeFrame::Camera);
        c.profile_mut(2, 1)[3] = 7.0;
        assert_eq!(c.data[(3 + 2) * 4 + 3], 7.0);
        assert_eq!(c.value_range(), Some((0.0, 7.0)));
        assert_eq!(axis.bin_centre_ps(1), 13.0);
        assert_eq!(axis.bin_coord(14.0), 2.0);
        assert_eq!(c.time_integral()[5], 7.0);
    }

    /// The first NaN or infinity is found wherever it lies, with its pixel and bin.
    #[test]
    fn first_non_finite_names_the_pixel_and_bin() {
        let (nx, ny, nt) = (5, 4, 3000); // blocks of 2^14 values split rows
        let mut v = vec![1.0f32; nx * ny * nt];
        assert_eq!(first_non_finite(&v, nx, nt), None);
        let at = |x: usize, y: usize, t: usize| (y * nx + x) * nt + t;
        v[at(3, 2, 2999)] = f32::NEG_INFINITY;
        v[at(1, 3, 7)] = f32::NAN;
        let found = first_non_finite(&v, nx, nt).unwrap();
        assert_eq!(
            (found.x, found.y, found.bin, found.kind()),
            (3, 2, 2999, "-inf")
        );
        v[at(0, 0, 0)] = f32::INFINITY;
        let found = first_non_finite(&v, nx, nt).unwrap();
        assert_eq!(
            (found.x, found.y, found.bin, found.kind()),
            (0, 0, 0, "inf")
        );
        let w = [0.0f64, 1.0, f64::NAN, 2.0];
        let found = first_non_finite(&w, 1, 2).unwrap();
        assert_eq!(
            (found.x, found.y, found.bin, found.kind()),
            (0, 1, 0, "NaN")
        );
    }
}

/// Slabs of whole rows for streaming a cube of `ny` rows whose rows are `row_bytes` long:
/// consecutive row ranges `y0..y1` of at most `target_bytes` (at least one row each) that
/// cover `0..ny`. Every stage that streams a cube (calibrate, unwarp, pyramid, the
/// container's copies) walks its rows with this.
pub fn row_slabs(
    ny: usize,
    row_bytes: usize,
    target_bytes: usize,
) -> impl Iterator<Item = std::ops::Range<usize>> {
    let rows = (target_bytes / row_bytes.max(1)).clamp(1, ny.max(1));
    (0..ny).step_by(rows).map(move |y0| y0..(y0 + rows).min(ny))
}

#[cfg(test)]
mod slab_tests {
    use super::row_slabs;

    #[test]
    fn slabs_cover_every_row_once_within_the_budget() {
        for (ny, row, target) in [
            (10, 4, 12),
            (10, 4, 1),
            (1, 100, 10),
            (7, 3, 1000),
            (0, 1, 1),
        ] {
            let slabs: Vec<_> = row_slabs(ny, row, target).collect();
            let rows: Vec<usize> = slabs.iter().flat_map(|r| r.clone()).collect();
            assert_eq!(rows, (0..ny).collect::<Vec<_>>(), "{ny} {row} {target}");
            for s in &slabs {
                assert!(!s.is_empty());
                assert!(s.len() == 1 || s.len() * row <= target);
            }
        }
    }
}

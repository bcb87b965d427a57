//! Cubes made by a caller's own code (the Python package's `cube_from_array`), checked as
//! the reader checks every cube it reads before anything is written: a time axis of finite
//! picoseconds with a bin width in range, values that are all finite (the first NaN or
//! infinity named by its pixel and bin, in the words of [`ContainerError::NonFinite`]), a
//! mask of 0 and 1 over the cube's pixels. Then written in slabs, atomically.

use super::error::{invalid, ContainerError, Result};
use super::schema::{CubeCompression, Provenance, CUBE_DATASET};
use super::write::CubeWriter;
use crate::cube::{first_non_finite, Cube, TimeAxis, TimeFrame};
use std::path::Path;

/// A cube in the caller's memory (a numpy array's buffer, borrowed): values `[y][x][t]`,
/// their axis and clock, and an optional mask `[y][x]`.
#[derive(Clone, Copy, Debug)]
pub struct CubeView<'a> {
    pub nx: usize,
    pub ny: usize,
    pub axis: TimeAxis,
    pub frame: TimeFrame,
    pub values: &'a [f32],
    pub mask: Option<&'a [u8]>,
}

impl<'a> CubeView<'a> {
    /// A view of `cube`.
    pub fn of(cube: &'a Cube) -> CubeView<'a> {
        CubeView {
            nx: cube.nx,
            ny: cube.ny,
            axis: cube.axis,
            frame: cube.frame,
            values: &cube.data,
            mask: cube.mask.as_deref(),
        }
    }
}

/// Rows per slab: about 8 MiB of values, so that a caller polling `on_rows` between slabs
/// (the Python package's Ctrl-C) waits for one slab's compression only.
fn slab_rows(nx: usize, nt: usize, ny: usize) -> usize {
    ((8usize << 20) / (4 * nx * nt).max(1)).clamp(1, ny.max(1))
}

/// Refuse `cube` (to be written to `dest`, which errors name) unless the reader would read
/// it back: see the module doc.
pub fn check_cube(dest: &Path, cube: &CubeView) -> Result<()> {
    let (ny, nx, nt) = (cube.ny, cube.nx, cube.axis.nt);
    if nx == 0 || ny == 0 || nt == 0 {
        return Err(invalid(
            dest,
            format!("a cube of {ny} x {nx} x {nt}: it needs at least one pixel and one bin"),
        ));
    }
    if cube.values.len() != nx * ny * nt {
        return Err(invalid(
            dest,
            format!(
                "{} values for a cube of {ny} x {nx} x {nt}",
                cube.values.len()
            ),
        ));
    }
    let axis = cube.axis;
    if !axis.t0_ps.is_finite() {
        return Err(invalid(
            dest,
            format!("t0_ps {}: must be finite", axis.t0_ps),
        ));
    }
    crate::ranges::check("dt_ps", axis.dt_ps, crate::ranges::INTERVAL_PS)
        .map_err(|e| invalid(dest, e.to_string()))?;
    if let Some(at) = first_non_finite(cube.values, nx, nt) {
        return Err(ContainerError::NonFinite {
            path: dest.to_path_buf(),
            dataset: CUBE_DATASET.into(),
            at,
        });
    }
    if let Some(mask) = cube.mask {
        if mask.len() != nx * ny {
            return Err(invalid(
                dest,
                format!("a mask of {} values for {ny} x {nx} pixels", mask.len()),
            ));
        }
        if let Some(i) = mask.iter().position(|&m| m > 1) {
            return Err(invalid(
                dest,
                format!(
                    "mask value {} at x {}, y {}: 1 marks a valid pixel, 0 another",
                    mask[i],
                    i % nx,
                    i / nx
                ),
            ));
        }
    }
    Ok(())
}

/// Write `cube` to `path` with `units`, `provenance` and `compression` after [`check_cube`]:
/// refused before anything is written, else written whole or not at all. `on_rows(n)` is
/// called after each slab with the rows written so far; a caller that unwinds from it
/// (the Python package on Ctrl-C) leaves nothing behind.
pub fn write_checked_cube(
    path: &Path,
    cube: &CubeView,
    units: &str,
    provenance: &Provenance,
    compression: CubeCompression,
    on_rows: &dyn Fn(usize),
) -> Result<()> {
    check_cube(path, cube)?;
    let (ny, nx, nt) = (cube.ny, cube.nx, cube.axis.nt);
    let mut w = CubeWriter::create_with(
        path,
        nx,
        ny,
        cube.axis,
        cube.frame,
        units,
        provenance,
        compression,
    )?;
    let row_len = nx * nt;
    let slab = slab_rows(nx, nt, ny);
    for y0 in (0..ny).step_by(slab) {
        let y1 = (y0 + slab).min(ny);
        w.write_rows(y0, &cube.values[y0 * row_len..y1 * row_len])?;
        on_rows(y1);
    }
    if let Some(m) = cube.mask {
        w.write_mask(m)?;
    }
    w.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> Cube {
        let axis = TimeAxis {
            t0_ps: -10.0,
            dt_ps: 2.0,
            nt: 6,
        };
        let mut c = Cube::zeros(4, 3, axis, TimeFrame::World);
        for (i, v) in c.data.iter_mut().enumerate() {
            *v = i as f32 * 0.25;
        }
        c
    }

    #[test]
    fn a_non_finite_value_or_a_bad_mask_is_refused_before_anything_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("c.h5");
        let write = |c: &Cube| {
            write_checked_cube(
                &dest,
                &CubeView::of(c),
                "arbitrary",
                &Provenance::new("test"),
                CubeCompression::default(),
                &|_| {},
            )
        };
        let mut nan = cube();
        nan.profile_mut(3, 2)[4] = f32::NAN;
        let e = write(&nan).unwrap_err().to_string();
        assert!(e.ends_with("c.h5: cube has NaN at x 3, y 2, bin 4"), "{e}");
        let mut inf = cube();
        inf.profile_mut(1, 0)[0] = f32::NEG_INFINITY;
        let e = write(&inf).unwrap_err().to_string();
        assert!(e.ends_with("cube has -inf at x 1, y 0, bin 0"), "{e}");
        let mut masked = cube();
        masked.mask = Some(vec![0, 1, 1, 1, 1, 1, 1, 1, 1, 2, 1, 1]);
        let e = write(&masked).unwrap_err().to_string();
        assert!(e.contains("mask value 2 at x 1, y 2"), "{e}");
        let mut axis = cube();
        axis.axis.dt_ps = f64::NAN;
        assert!(write(&axis).unwrap_err().to_string().contains("dt_ps"));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);

        let rows = std::cell::RefCell::new(Vec::new());
        let good = cube();
        write_checked_cube(
            &dest,
            &CubeView::of(&good),
            "arbitrary",
            &Provenance::new("test"),
            CubeCompression::default(),
            &|n| rows.borrow_mut().push(n),
        )
        .unwrap();
        assert_eq!(rows.into_inner().last(), Some(&3));
        assert_eq!(super::super::read_cube(&dest).unwrap().data, good.data);
    }
}

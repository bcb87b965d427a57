//! The `registration` group of a cube file: what every pixel sees through the calibrated
//! camera ([`crate::calibrate::register()`]: surface point, distance to the camera centre,
//! normal, triangle, mask), with the calibration that produced it.
//!
//! The distances are the `|p - o|` of physics.md's `t_world = t_camera - eta |p - o| / c`,
//! which `femto unwarp` reads from here, with `eta` from the stored calibration.
//!
//! Schema (docs/cube-format.md), all datasets `[y][x]` in C order:
//!
//! | dataset    | type | shape         | meaning                                         |
//! |------------|------|---------------|-------------------------------------------------|
//! | `point_m`  | f32  | `(ny, nx, 3)` | surface point seen, mesh frame, metres (NaN: none) |
//! | `dist_m`   | f32  | `(ny, nx)`    | distance from the camera centre, metres (NaN: none) |
//! | `normal`   | f32  | `(ny, nx, 3)` | unit normal facing the camera (NaN: none)       |
//! | `triangle` | u32  | `(ny, nx)`    | triangle index (4294967295: none)               |
//! | `mask`     | u8   | `(ny, nx)`    | 1 where the pixel sees geometry                 |
//!
//! Attributes: `calibration` (the calibration TOML text, the authority), and copies of its key
//! numbers for other tools (`fx`, `fy`, `cx`, `cy`, `k1`, `k2`, `width`, `height`, `camera_m`,
//! `world_from_camera` (9 values, row-major), `t0_ps`, `time_scale`, `laser_m`, `eta`), the
//! `mesh` file, `hit_pixels`, `dist_min_m`, `dist_max_m`, and, when the calibration was fitted
//! here, the fit figures (`points`, `outliers`, `reprojection_rms_px`, `time_samples`,
//! `time_inliers`, `time_residual_rms_ps`).

use super::{attr, GroupView, StoreError};
use crate::calibrate::Registration;
use crate::camera::Calibration;
use crate::container::{AttrValue, DataBuf, GroupData};
use nalgebra::Point3;
use std::path::Path;

/// Name of the group.
pub const GROUP: &str = "registration";

/// Figures of the fit that produced a calibration, stored with it.
#[derive(Clone, Debug, PartialEq)]
pub struct FitSummary {
    /// Correspondences given.
    pub points: usize,
    /// Correspondences flagged as outliers.
    pub outliers: usize,
    /// RMS reprojection error over the points used, pixels.
    pub reprojection_rms_px: f64,
    /// Pixels with a first arrival used by the time fit.
    pub time_samples: usize,
    /// Of those, the inliers of the robust fit.
    pub time_inliers: usize,
    /// RMS time residual over the inliers, ps.
    pub time_residual_rms_ps: f64,
}

/// A registration read back, with its calibration and provenance.
#[derive(Clone, Debug, PartialEq)]
pub struct StoredRegistration {
    pub registration: Registration,
    pub calibration: Calibration,
    /// The mesh file the rays were cast into, as given on the command line.
    pub mesh: String,
    /// The fit figures, when the calibration was fitted by `femto calibrate`.
    pub fit: Option<FitSummary>,
}

/// Smallest and largest distance over the pixels that see geometry (None when none does).
pub fn dist_range_m(reg: &Registration) -> Option<(f32, f32)> {
    let mut lo = f32::INFINITY;
    let mut hi = f32::NEG_INFINITY;
    for (&d, &m) in reg.dist_m.iter().zip(&reg.mask) {
        if m != 0 && d.is_finite() {
            lo = lo.min(d);
            hi = hi.max(d);
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// The group for `reg`, cast through `cal` into the mesh file `mesh`.
pub fn registration_group(
    reg: &Registration,
    cal: &Calibration,
    mesh: &str,
    fit: Option<&FitSummary>,
) -> GroupData {
    let k = &cal.intrinsics;
    let r = cal.pose.world_from_camera.matrix();
    let (dmin, dmax) =
        dist_range_m(reg).map_or((f64::NAN, f64::NAN), |(a, b)| (a as f64, b as f64));
    let mut attrs = vec![
        attr("calibration", AttrValue::Str(cal.to_toml())),
        attr("mesh", AttrValue::Str(mesh.to_string())),
        attr("width", AttrValue::I64(k.width as i64)),
        attr("height", AttrValue::I64(k.height as i64)),
        attr("fx", AttrValue::F64(k.fx)),
        attr("fy", AttrValue::F64(k.fy)),
        attr("cx", AttrValue::F64(k.cx)),
        attr("cy", AttrValue::F64(k.cy)),
        attr("k1", AttrValue::F64(k.k1)),
        attr("k2", AttrValue::F64(k.k2)),
        attr(
            "camera_m",
            AttrValue::F64Array(reg.camera_m.coords.iter().copied().collect()),
        ),
        attr(
            "world_from_camera",
            AttrValue::F64Array((0..9).map(|i| r[(i / 3, i % 3)]).collect()),
        ),
        attr("t0_ps", AttrValue::F64(cal.t0_ps)),
        attr("time_scale", AttrValue::F64(cal.time_scale)),
        attr(
            "laser_m",
            AttrValue::F64Array(cal.laser_m.coords.iter().copied().collect()),
        ),
        attr("eta", AttrValue::F64(cal.eta)),
        attr("hit_pixels", AttrValue::I64(reg.hit_count() as i64)),
        attr("dist_min_m", AttrValue::F64(dmin)),
        attr("dist_max_m", AttrValue::F64(dmax)),
    ];
    if let Some(f) = fit {
        attrs.extend([
            attr("points", AttrValue::I64(f.points as i64)),
            attr("outliers", AttrValue::I64(f.outliers as i64)),
            attr("reprojection_rms_px", AttrValue::F64(f.reprojection_rms_px)),
            attr("time_samples", AttrValue::I64(f.time_samples as i64)),
            attr("time_inliers", AttrValue::I64(f.time_inliers as i64)),
            attr(
                "time_residual_rms_ps",
                AttrValue::F64(f.time_residual_rms_ps),
            ),
        ]);
    }
    let (ny, nx) = (reg.ny, reg.nx);
    let flat3 = |v: &[[f32; 3]]| DataBuf::F32(v.iter().flatten().copied().collect());
    GroupData {
        attrs,
        datasets: vec![
            ("point_m".into(), vec![ny, nx, 3], flat3(&reg.point_m)),
            (
                "dist_m".into(),
                vec![ny, nx],
                DataBuf::F32(reg.dist_m.clone()),
            ),
            ("normal".into(), vec![ny, nx, 3], flat3(&reg.normal)),
            (
                "triangle".into(),
                vec![ny, nx],
                DataBuf::U32(reg.triangle.clone()),
            ),
            ("mask".into(), vec![ny, nx], DataBuf::U8(reg.mask.clone())),
        ],
    }
}

/// Name of the optional dataset of each scanline's time offset against the geometry
/// ([`crate::calibrate::scanline_time`]), f64 `(ny,)`, ps: the offset `femto unwarp` removes
/// (0 where not significant, NaN where not estimated).
pub const SCANLINE_OFFSETS: &str = "scanline_offset_ps";

/// Add `offsets` (one per row) to `group` as [`SCANLINE_OFFSETS`], with the count of rows
/// estimated and shifted as attributes (`scanlines_estimated`, `scanlines_shifted`).
pub fn add_scanline_offsets(
    group: &mut GroupData,
    offsets: &[Option<crate::ingest::row_offsets::RowOffset>],
) {
    let applied = crate::calibrate::scanline_time::applied_ps(offsets);
    let estimated = offsets.iter().flatten().count();
    let shifted = applied
        .iter()
        .filter(|v| **v != 0.0 && v.is_finite())
        .count();
    group.attrs.extend([
        attr("scanlines_estimated", AttrValue::I64(estimated as i64)),
        attr("scanlines_shifted", AttrValue::I64(shifted as i64)),
    ]);
    group.datasets.push((
        SCANLINE_OFFSETS.into(),
        vec![applied.len()],
        DataBuf::F64(applied),
    ));
}

/// The scanline offsets of a registration group of `ny` rows, ps (NaN: not estimated), or None
/// when it has none (a registration cast by `femto unwarp`, or written before they were).
/// Refused: a wrong shape or type, or an offset that is infinite or beyond a second.
pub fn scanline_offsets(
    path: &Path,
    data: &GroupData,
    ny: usize,
) -> Result<Option<Vec<f64>>, StoreError> {
    if data.dataset(SCANLINE_OFFSETS).is_none() {
        return Ok(None);
    }
    let v = GroupView {
        path,
        group: GROUP,
        data,
    };
    let offsets = v.typed::<f64>(SCANLINE_OFFSETS, &[ny])?.to_vec();
    if let Some((y, o)) = offsets
        .iter()
        .enumerate()
        .find(|(_, o)| o.is_infinite() || o.abs() > 1e12)
    {
        return Err(v.schema(format!(
            "dataset '{SCANLINE_OFFSETS}': row {y} has {o} ps (finite, under a second, or NaN)"
        )));
    }
    Ok(Some(offsets))
}

/// Name of the dataset of each pixel's footprint spread of distances
/// ([`crate::calibrate::mixed::footprint_spread_m`]), f32 `(ny, nx)`, metres: the largest less
/// the smallest distance from the camera centre over rays spanning the pixel (infinite where
/// one misses the mesh, NaN where the pixel sees nothing). `femto unwarp` masks the pixels
/// that span more than [`crate::calibrate::mixed::MASK_SPREAD_BINS`] bins of path.
pub const FOOTPRINT_SPREAD: &str = "footprint_spread_m";

/// Add `spread_m` (one per pixel, `[y][x]`) to `group` as [`FOOTPRINT_SPREAD`].
pub fn add_footprint_spread(group: &mut GroupData, nx: usize, ny: usize, spread_m: Vec<f32>) {
    group.datasets.push((
        FOOTPRINT_SPREAD.into(),
        vec![ny, nx],
        DataBuf::F32(spread_m),
    ));
}

/// The footprint spreads of a registration group of `nx` x `ny` pixels, metres, or None when
/// it has none. Refused: a wrong shape or type, or a negative value.
pub fn footprint_spread(
    path: &Path,
    data: &GroupData,
    nx: usize,
    ny: usize,
) -> Result<Option<Vec<f32>>, StoreError> {
    if data.dataset(FOOTPRINT_SPREAD).is_none() {
        return Ok(None);
    }
    let v = GroupView {
        path,
        group: GROUP,
        data,
    };
    let spread = v.typed::<f32>(FOOTPRINT_SPREAD, &[ny, nx])?.to_vec();
    if let Some((i, o)) = spread.iter().enumerate().find(|(_, o)| **o < 0.0) {
        return Err(v.schema(format!(
            "dataset '{FOOTPRINT_SPREAD}': pixel ({}, {}) has {o} m (0 or more, inf, or NaN)",
            i % nx.max(1),
            i / nx.max(1)
        )));
    }
    Ok(Some(spread))
}

/// The calibration stored in a registration group's `calibration` attribute.
pub fn stored_calibration(path: &Path, data: &GroupData) -> Result<Calibration, StoreError> {
    let v = GroupView {
        path,
        group: GROUP,
        data,
    };
    let text = v.str("calibration")?;
    Calibration::from_toml(text, &format!("{}:/{GROUP}/calibration", path.display()))
        .map_err(|e| v.schema(format!("attribute 'calibration': {e}")))
}

/// Every number of a registration's arrays in its range ([`crate::ranges`], docs/faults.md):
/// `point_m` in [`COORD_M`](crate::ranges::COORD_M) and `normal` in
/// [`DIRECTION`](crate::ranges::DIRECTION), or all three NaN (a pixel that sees nothing);
/// `dist_m` in [`DISTANCE_M`](crate::ranges::DISTANCE_M), or NaN; `mask` 0 or 1. A `dist_m`
/// of 1e12 m was read and its pixel quietly masked.
fn check_arrays(
    v: &GroupView,
    nx: usize,
    point_m: &[[f32; 3]],
    normal: &[[f32; 3]],
    dist_m: &[f32],
    mask: &[u8],
) -> Result<(), StoreError> {
    use crate::ranges::{self, Range};
    let at = |i: usize| format!("pixel ({}, {})", i % nx.max(1), i / nx.max(1));
    let triples = |name: &str, values: &[[f32; 3]], range: Range| -> Result<(), StoreError> {
        for (i, p) in values.iter().enumerate() {
            if p.iter().all(|c| c.is_nan()) {
                continue;
            }
            let p = p.map(f64::from);
            ranges::check_point(format_args!("dataset '{name}' at {}", at(i)), &p, range).map_err(
                |e| v.schema(format!("{e} (a pixel that sees nothing has all three NaN)")),
            )?;
        }
        Ok(())
    };
    triples("point_m", point_m, ranges::COORD_M)?;
    triples("normal", normal, ranges::DIRECTION)?;
    if let Some((i, &d)) = dist_m
        .iter()
        .enumerate()
        .find(|(_, d)| !d.is_nan() && !ranges::DISTANCE_M.contains(f64::from(**d)))
    {
        let e = ranges::check(
            format_args!("dataset 'dist_m' at {}", at(i)),
            f64::from(d),
            ranges::DISTANCE_M,
        )
        .expect_err("out of range");
        return Err(v.schema(format!("{e} (or NaN where the pixel sees nothing)")));
    }
    if let Some((i, m)) = mask.iter().enumerate().find(|(_, m)| **m > 1) {
        return Err(v.schema(format!("dataset 'mask' at {} is {m} (0 or 1)", at(i))));
    }
    Ok(())
}

/// Read a registration group (read from the file at `path`) back into typed values,
/// checking its schema.
pub fn from_group(path: &Path, data: &GroupData) -> Result<StoredRegistration, StoreError> {
    let v = GroupView {
        path,
        group: GROUP,
        data,
    };
    let calibration = stored_calibration(path, data)?;
    let (nx, ny) = (calibration.intrinsics.width, calibration.intrinsics.height);
    let triples =
        |x: &[f32]| -> Vec<[f32; 3]> { x.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect() };
    let point_m = triples(v.typed("point_m", &[ny, nx, 3])?);
    let normal = triples(v.typed("normal", &[ny, nx, 3])?);
    let dist_m = v.typed::<f32>("dist_m", &[ny, nx])?.to_vec();
    let triangle = v.typed::<u32>("triangle", &[ny, nx])?.to_vec();
    let mask = v.typed::<u8>("mask", &[ny, nx])?.to_vec();
    check_arrays(&v, nx, &point_m, &normal, &dist_m, &mask)?;
    let camera_m = match data.attr("camera_m") {
        Some(AttrValue::F64Array(c)) if c.len() == 3 => {
            crate::ranges::check_point("attribute 'camera_m'", c, crate::ranges::COORD_M)
                .map_err(|e| v.schema(e.to_string()))?;
            Point3::new(c[0], c[1], c[2])
        }
        _ => return Err(v.schema("attribute 'camera_m' is not 3 numbers")),
    };
    let fit = if data.attr("points").is_some() {
        Some(FitSummary {
            points: v.usize("points")?,
            outliers: v.usize("outliers")?,
            reprojection_rms_px: v.f64("reprojection_rms_px")?,
            time_samples: v.usize("time_samples")?,
            time_inliers: v.usize("time_inliers")?,
            time_residual_rms_ps: v.f64("time_residual_rms_ps")?,
        })
    } else {
        None
    };
    Ok(StoredRegistration {
        registration: Registration {
            nx,
            ny,
            camera_m,
            point_m,
            dist_m,
            normal,
            triangle,
            mask,
        },
        calibration,
        mesh: v.str("mesh")?.to_string(),
        fit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Intrinsics, Pose};
    use nalgebra::Vector3;

    #[test]
    fn group_round_trips_and_refuses_a_wrong_shape() {
        let (nx, ny) = (3, 2);
        let cal = Calibration {
            intrinsics: Intrinsics::from_vfov(nx, ny, 30.0),
            pose: Pose::look_at(Point3::new(0.0, 1.0, 2.0), Point3::origin(), Vector3::y())
                .unwrap(),
            t0_ps: -12.5,
            time_scale: 1.0,
            laser_m: Point3::new(0.5, 0.0, 0.0),
            eta: 1.33,
        };
        let mut reg = Registration {
            nx,
            ny,
            camera_m: cal.pose.position_m,
            point_m: vec![[0.1, 0.2, 0.3]; 6],
            dist_m: vec![2.0, 2.5, 3.0, f32::NAN, 1.5, 2.0],
            normal: vec![[0.0, 1.0, 0.0]; 6],
            triangle: vec![4, 5, 6, u32::MAX, 1, 2],
            mask: vec![1, 1, 1, 0, 1, 1],
        };
        reg.point_m[3] = [f32::NAN; 3];
        assert_eq!(dist_range_m(&reg), Some((1.5, 3.0)));
        let fit = FitSummary {
            points: 30,
            outliers: 1,
            reprojection_rms_px: 0.7,
            time_samples: 5,
            time_inliers: 5,
            time_residual_rms_ps: 0.25,
        };
        let g = registration_group(&reg, &cal, "scene.glb", Some(&fit));
        let back = from_group(Path::new("c.h5"), &g).unwrap();
        assert_eq!(back.fit, Some(fit));
        assert_eq!(back.mesh, "scene.glb");
        assert_eq!(back.registration.triangle, reg.triangle);
        assert_eq!(back.registration.dist_m[..3], reg.dist_m[..3]);
        assert!(back.registration.point_m[3][0].is_nan());
        assert_eq!(back.calibration.eta, 1.33);
        assert_eq!(back.calibration.t0_ps, -12.5);

        let mut bad = g.clone();
        bad.datasets[1].1 = vec![nx, ny];
        let e = from_group(Path::new("c.h5"), &bad).unwrap_err().to_string();
        assert!(
            e.contains("c.h5") && e.contains("/registration") && e.contains("dist_m"),
            "{e}"
        );

        // Scanline offsets: absent, round trip (NaN kept), and refused when infinite or of
        // the wrong length, naming the dataset and the row.
        let path = Path::new("c.h5");
        assert_eq!(scanline_offsets(path, &g, ny).unwrap(), None);
        let row = |e: f64, applied: f64| {
            Some(crate::ingest::row_offsets::RowOffset {
                estimate: e,
                std_error: 0.1,
                applied,
            })
        };
        let mut with = g.clone();
        add_scanline_offsets(&mut with, &[row(2.0, 2.0), None]);
        let back = scanline_offsets(path, &with, ny).unwrap().unwrap();
        assert_eq!(back[0], 2.0);
        assert!(back[1].is_nan());
        assert!(scanline_offsets(path, &with, 3).is_err());
        let mut inf = g.clone();
        add_scanline_offsets(&mut inf, &[row(1.0, f64::INFINITY), row(0.0, 0.0)]);
        let e = scanline_offsets(path, &inf, ny).unwrap_err().to_string();
        assert!(e.contains(SCANLINE_OFFSETS) && e.contains("row 0"), "{e}");
    }
}

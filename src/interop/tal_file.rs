//! y-tal's HDF5 capture layout (`FileFormat.HDF5_TAL`, what `tal.io.read_capture` reads and
//! `tal.io.write_capture` writes): root datasets `H` (float32, `(T, Sx, Sy)`), `H_format`,
//! `sensor_grid_format`, `laser_grid_format` (enum or integer, one element), `sensor_xyz`,
//! `laser_xyz` (3), `sensor_grid_xyz`, `sensor_grid_normals` (`(Sx, Sy, 3)`),
//! `laser_grid_xyz` (`(1, 1, 3)`, or `(Sx, Sy, 3)` equal to the sensor grid for a confocal
//! scan: y-tal's `is_confocal`), `delta_t`, `t_start` (scalars, metres of optical path) and
//! `t_accounts_first_and_last_bounces` (bool). y-tal refuses any other root key, so femto
//! writes only these. Also the cube group `tal` ([`super::tal::GROUP`]) that keeps a capture's
//! geometry inside a femto cube.

use super::tal::{LaserSpot, TalCapture, TalGeometry, GROUP};
use super::InteropError;
use crate::container::{AttrValue, DataBuf, GroupData};
use crate::ranges;
use crate::units::C_M_PER_PS;
use rust_hdf5::{DatatypeMessage, H5Dataset, H5File, HBool};
use std::path::Path;

/// y-tal's `HFormat.T_Sx_Sy` and `GridFormat.X_Y_3`.
const H_FORMAT_T_SX_SY: i32 = 1;
const GRID_FORMAT_X_Y_3: i32 = 2;

fn h5err(path: &Path) -> impl Fn(rust_hdf5::Hdf5Error) -> InteropError + '_ {
    move |e| InteropError::Hdf5 {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

fn invalid(path: &Path, key: &str, message: impl Into<String>) -> InteropError {
    InteropError::Invalid {
        path: path.to_path_buf(),
        key: key.to_string(),
        message: message.into(),
    }
}

/// `v` in `range` ([`crate::ranges`]), else an error naming `key` and the value.
fn in_range(path: &Path, key: &str, v: f64, range: ranges::Range) -> Result<f64, InteropError> {
    ranges::check(key, v, range).map_err(|e| invalid(path, key, e.detail()))
}

/// Three numbers in `range`, the first outside named `key[i]`.
fn check_point(
    path: &Path,
    key: &str,
    p: &[f64; 3],
    range: ranges::Range,
) -> Result<(), InteropError> {
    ranges::check_point(key, p, range).map_err(|e| invalid(path, &e.key, e.detail()))
}

/// A device's position (the sensor's, the laser's origin): in [`ranges::COORD_M`], or all
/// three NaN, a position the capture does not record (a confocal scan read from a `.mat`
/// file; `femto unwarp` then asks for `--device-m`).
fn check_device(path: &Path, key: &str, p: &[f64; 3]) -> Result<(), InteropError> {
    if p.iter().all(|c| c.is_nan()) {
        return Ok(());
    }
    check_point(path, key, p, ranges::COORD_M)
}

/// A grid of points or normals (one per pixel; `at(i)` names entry `i` as the file indexes
/// it): each entry's three numbers in `range`, or all three NaN, a pixel that sees nothing
/// (what `femto export` writes for it). Any other NaN, an infinity or a number beyond the
/// range is refused.
fn check_grid(
    path: &Path,
    key: &str,
    grid: &[[f64; 3]],
    range: ranges::Range,
    at: impl Fn(usize) -> String,
) -> Result<(), InteropError> {
    for (i, p) in grid.iter().enumerate() {
        if p.iter().all(|c| c.is_nan()) {
            continue;
        }
        if let Err(e) = ranges::check_point(format_args!("{key}{}", at(i)), p, range) {
            return Err(invalid(
                path,
                &e.key,
                format!(
                    "{} (a pixel that sees nothing has all three NaN)",
                    e.detail()
                ),
            ));
        }
    }
    Ok(())
}

/// A capture's sensor grid must see something: at least one point known (not all three
/// NaN). One unknown point is a pixel that sees nothing; a grid of none is no capture (a
/// file of NaN was ingested and exported again). For a confocal scan this is also its
/// laser points.
fn require_known_point(path: &Path, key: &str, grid: &[[f64; 3]]) -> Result<(), InteropError> {
    if grid.iter().all(|p| p.iter().all(|c| c.is_nan())) {
        return Err(invalid(
            path,
            key,
            format!(
                "all {} points are NaN (unknown): a capture needs at least one known sensor \
                 point",
                grid.len()
            ),
        ));
    }
    Ok(())
}

/// Whether `path` is an HDF5 file with y-tal's `H` and `H_format` datasets.
pub fn is_tal_capture(path: &Path) -> bool {
    if !matches!(crate::container::is_hdf5(path), Ok(true)) {
        return false;
    }
    let Ok(file) = H5File::open(path) else {
        return false;
    };
    let names = file.dataset_names();
    ["H", "H_format"]
        .iter()
        .all(|k| names.iter().any(|n| n.trim_start_matches('/') == *k))
}

/// Write `cap` as a y-tal capture at `path`, atomically. On a failed write (a full disk) the
/// file is discarded explicitly, so that the HDF5 library's drop never tries to finish it and
/// print its own line beside femto's error.
pub fn write_tal(path: &Path, cap: &TalCapture) -> Result<(), InteropError> {
    let io = |source| InteropError::Io {
        path: path.to_path_buf(),
        source,
    };
    crate::atomic::write_atomically_with(path, io, |tmp| {
        let e = h5err(path);
        let file = H5File::create(tmp).map_err(&e)?;
        match write_capture(&file, path, cap) {
            Ok(()) => file.close().map_err(&e),
            Err(err) => {
                file.discard();
                Err(err)
            }
        }
    })
}

/// The datasets of `cap` into the open `file` (`path` names it in errors).
fn write_capture(file: &H5File, path: &Path, cap: &TalCapture) -> Result<(), InteropError> {
    let e = h5err(path);
    let f64s = |name: &str, shape: &[usize], v: &[f64]| -> Result<(), InteropError> {
        let ds = file
            .new_dataset::<f64>()
            .shape(shape)
            .create(name)
            .map_err(&e)?;
        ds.write_raw(v).map_err(&e)
    };
    let enum_like = |name: &str, v: i32| -> Result<(), InteropError> {
        let ds = file
            .new_dataset::<i32>()
            .shape([1])
            .create(name)
            .map_err(&e)?;
        ds.write_raw(&[v]).map_err(&e)
    };
    let ds = file
        .new_dataset::<f32>()
        .shape([cap.nt, cap.sx, cap.sy])
        .create("H")
        .map_err(&e)?;
    ds.write_raw(&cap.h).map_err(&e)?;
    enum_like("H_format", H_FORMAT_T_SX_SY)?;
    f64s("sensor_xyz", &[3], &cap.sensor_xyz_m)?;
    let flat = |v: &[[f64; 3]]| v.iter().flatten().copied().collect::<Vec<f64>>();
    f64s(
        "sensor_grid_xyz",
        &[cap.sx, cap.sy, 3],
        &flat(&cap.sensor_grid_xyz_m),
    )?;
    if let Some(n) = &cap.sensor_grid_normals {
        f64s("sensor_grid_normals", &[cap.sx, cap.sy, 3], &flat(n))?;
    }
    enum_like("sensor_grid_format", GRID_FORMAT_X_Y_3)?;
    f64s("laser_xyz", &[3], &cap.laser_xyz_m)?;
    match cap.laser_grid_xyz_m {
        LaserSpot::Single(spot) => f64s("laser_grid_xyz", &[1, 1, 3], &spot)?,
        LaserSpot::Confocal => f64s(
            "laser_grid_xyz",
            &[cap.sx, cap.sy, 3],
            &flat(&cap.sensor_grid_xyz_m),
        )?,
    }
    enum_like("laser_grid_format", GRID_FORMAT_X_Y_3)?;
    f64s("delta_t", &[], &[cap.delta_t_m])?;
    f64s("t_start", &[], &[cap.t_start_m])?;
    let ds = file
        .new_dataset::<HBool>()
        .scalar()
        .create("t_accounts_first_and_last_bounces")
        .map_err(&e)?;
    ds.write_raw(&[HBool::from(cap.t_accounts_first_and_last_bounces)])
        .map_err(&e)
}

/// The values of a numeric dataset (integer, float, enum or bool, little-endian) as f64.
fn numbers(ds: &H5Dataset, path: &Path, key: &str) -> Result<Vec<f64>, InteropError> {
    let dt = ds.datatype().map_err(h5err(path))?;
    let dt = match dt {
        DatatypeMessage::Enum { base, .. } => *base,
        other => other,
    };
    let bytes = ds.read_raw_bytes().map_err(h5err(path))?;
    if dt.scalar_byte_order() == Some(rust_hdf5::ByteOrder::BigEndian) {
        return Err(invalid(path, key, "big-endian values are not read"));
    }
    let values: Vec<f64> = match dt {
        DatatypeMessage::FloatingPoint { size: 4, .. } => bytes
            .chunks_exact(4)
            .map(|b| f64::from(f32::from_le_bytes(b.try_into().expect("4 bytes"))))
            .collect(),
        DatatypeMessage::FloatingPoint { size: 8, .. } => bytes
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")))
            .collect(),
        DatatypeMessage::FixedPoint { size, signed, .. } if matches!(size, 1 | 2 | 4 | 8) => {
            let n = size as usize;
            bytes
                .chunks_exact(n)
                .map(|b| {
                    let mut w = [0u8; 8];
                    w[..n].copy_from_slice(b);
                    let negative = signed && b[n - 1] & 0x80 != 0;
                    if negative {
                        w[n..].fill(0xff);
                    }
                    if signed {
                        i64::from_le_bytes(w) as f64
                    } else {
                        u64::from_le_bytes(w) as f64
                    }
                })
                .collect()
        }
        other => return Err(invalid(path, key, format!("not a number type ({other:?})"))),
    };
    Ok(values)
}

/// y-tal's `H`: its sizes `(T, Sx, Sy)` and values, checked finite.
fn read_h(ds: &H5Dataset, path: &Path) -> Result<(usize, usize, usize, Vec<f32>), InteropError> {
    let shape = ds.shape();
    let [nt, sx, sy] = <[usize; 3]>::try_from(shape.as_slice())
        .map_err(|_| invalid(path, "H", format!("shape {shape:?}, expected (T, Sx, Sy)")))?;
    if shape.contains(&0) {
        return Err(invalid(path, "H", format!("shape {shape:?} is empty")));
    }
    // The stored values (up to 8 bytes), their f64 copy and the f32 capture are held
    // together: 20 bytes a value, 5 float32 copies (checked arithmetic, before any read).
    crate::limits::check_decoded(
        &shape,
        4,
        5,
        format_args!("H of {shape:?} values (read as float32, 5 copies held)"),
        "downscale the capture in y-tal first (NLOSCaptureData.downscale)",
    )
    .map_err(|source| InteropError::Limit {
        path: path.to_path_buf(),
        source,
    })?;
    let h: Vec<f32> = numbers(ds, path, "H")?
        .into_iter()
        .map(|v| v as f32)
        .collect();
    if let Some(i) = h.iter().position(|v| !v.is_finite()) {
        let (t, x, y) = (i / (sx * sy), i / sy % sx, i % sy);
        return Err(invalid(
            path,
            "H",
            format!("{} at (t {t}, x {x}, y {y})", h[i]),
        ));
    }
    Ok((nt, sx, sy, h))
}

/// Read the y-tal capture at `path` (one laser point, `H_format = T_Sx_Sy`); confocal and
/// multi-laser captures are refused, naming what they hold.
pub fn read_tal(path: &Path) -> Result<TalCapture, InteropError> {
    let f = TalReader::open(path)?;
    let h_format = f.scalar("H_format")?;
    if h_format != f64::from(H_FORMAT_T_SX_SY) {
        return Err(invalid(
            path,
            "H_format",
            format!(
                "{h_format} (femto reads T_Sx_Sy = 1: one laser point, a grid of sensor points)"
            ),
        ));
    }
    let (nt, sx, sy, h) = read_h(&f.dataset("H")?, path)?;
    let (sensor_grid_xyz_m, sensor_grid_normals) = f.sensor_grid(sx, sy)?;
    let laser_grid_xyz_m = f.laser_grid(sx, sy, &sensor_grid_xyz_m)?;
    // Optical path lengths: a bin width and a time in metres ([`ranges::BIN_WIDTH_PS`],
    // [`ranges::TIME_PS`] times c); `delta_t = 1e-300` was ingested as a cube of 3e-297 ps bins.
    let delta_t_m = in_range(
        path,
        "delta_t",
        f.scalar("delta_t")?,
        ranges::BIN_WIDTH_PS.scaled(C_M_PER_PS, " m"),
    )?;
    let t_start_m = in_range(
        path,
        "t_start",
        f.scalar("t_start")?,
        ranges::TIME_PS.scaled(C_M_PER_PS, " m"),
    )?;
    Ok(TalCapture {
        nt,
        sx,
        sy,
        h,
        delta_t_m,
        t_start_m,
        t_accounts_first_and_last_bounces: f.scalar("t_accounts_first_and_last_bounces")? != 0.0,
        sensor_xyz_m: f.point("sensor_xyz")?,
        sensor_grid_xyz_m,
        sensor_grid_normals,
        laser_xyz_m: f.point("laser_xyz")?,
        laser_grid_xyz_m,
    })
}

/// A y-tal file open for reading, its datasets by name; each read names the file and the
/// dataset when it fails.
struct TalReader<'a> {
    path: &'a Path,
    file: H5File,
    names: Vec<String>,
}

impl<'a> TalReader<'a> {
    fn open(path: &'a Path) -> Result<Self, InteropError> {
        let file = H5File::open(path).map_err(h5err(path))?;
        let names: Vec<String> = file
            .dataset_names()
            .into_iter()
            .map(|n| n.trim_start_matches('/').to_string())
            .collect();
        Ok(TalReader { path, file, names })
    }

    fn has(&self, k: &str) -> bool {
        self.names.iter().any(|n| n == k)
    }

    /// Dataset `k`, refused as missing when the file has none.
    fn dataset(&self, k: &str) -> Result<H5Dataset, InteropError> {
        if !self.has(k) {
            return Err(InteropError::Missing {
                path: self.path.to_path_buf(),
                key: k.to_string(),
            });
        }
        self.file.dataset(k).map_err(h5err(self.path))
    }

    /// Dataset `k`'s shape and numbers.
    fn read(&self, k: &str) -> Result<(Vec<usize>, Vec<f64>), InteropError> {
        let ds = self.dataset(k)?;
        let shape = ds.shape();
        // The stored values and their f64 copy, before either is read.
        crate::limits::check_decoded(
            &shape,
            8,
            2,
            format_args!("{k} of {shape:?} values"),
            "is the file damaged?",
        )
        .map_err(|source| InteropError::Limit {
            path: self.path.to_path_buf(),
            source,
        })?;
        Ok((shape, numbers(&ds, self.path, k)?))
    }

    /// Dataset `k` as one finite number.
    fn scalar(&self, k: &str) -> Result<f64, InteropError> {
        let (_, v) = self.read(k)?;
        match v.as_slice() {
            [x] if x.is_finite() => Ok(*x),
            _ => Err(invalid(
                self.path,
                k,
                format!("expected one finite number, found {v:?}"),
            )),
        }
    }

    /// Dataset `k` as the position of a device (the sensor, the laser).
    fn point(&self, k: &str) -> Result<[f64; 3], InteropError> {
        let (_, v) = self.read(k)?;
        let p = <[f64; 3]>::try_from(v.as_slice()).map_err(|_| {
            invalid(
                self.path,
                k,
                format!("expected 3 numbers, found {}", v.len()),
            )
        })?;
        check_device(self.path, k, &p)?;
        Ok(p)
    }

    /// Dataset `k` as an `(sx, sy)` grid of 3-vectors, `[x][y]`.
    fn grid(&self, k: &str, sx: usize, sy: usize) -> Result<Vec<[f64; 3]>, InteropError> {
        let (shape, v) = self.read(k)?;
        if shape != [sx, sy, 3] {
            return Err(invalid(
                self.path,
                k,
                format!("shape {shape:?}, expected [{sx}, {sy}, 3]"),
            ));
        }
        Ok(v.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect())
    }

    /// The sensor grid's points and, when the file has them, its normals, checked.
    #[allow(clippy::type_complexity)]
    fn sensor_grid(
        &self,
        sx: usize,
        sy: usize,
    ) -> Result<(Vec<[f64; 3]>, Option<Vec<[f64; 3]>>), InteropError> {
        // Entry i of a (Sx, Sy) grid is [x][y].
        let xy = |i: usize| format!("[{}][{}]", i / sy, i % sy);
        let points = self.grid("sensor_grid_xyz", sx, sy)?;
        check_grid(self.path, "sensor_grid_xyz", &points, ranges::COORD_M, xy)?;
        require_known_point(self.path, "sensor_grid_xyz", &points)?;
        // y-tal writes an absent value as an empty dataset (h5py.Empty): no normals then.
        let normals = match self.has("sensor_grid_normals") {
            true if !self.read("sensor_grid_normals")?.1.is_empty() => {
                Some(self.grid("sensor_grid_normals", sx, sy)?)
            }
            _ => None,
        };
        if let Some(n) = &normals {
            check_grid(self.path, "sensor_grid_normals", n, ranges::DIRECTION, xy)?;
        }
        Ok((points, normals))
    }

    /// The laser grid: one spot, or the sensor grid itself (a confocal scan); any other
    /// (several laser points, a custom pairing) is refused.
    fn laser_grid(
        &self,
        sx: usize,
        sy: usize,
        sensor_grid_xyz_m: &[[f64; 3]],
    ) -> Result<LaserSpot, InteropError> {
        let (lshape, lv) = self.read("laser_grid_xyz")?;
        if lv.len() == 3 {
            let spot = [lv[0], lv[1], lv[2]];
            check_point(self.path, "laser_grid_xyz", &spot, ranges::COORD_M)?;
            return Ok(LaserSpot::Single(spot));
        }
        if lshape == [sx, sy, 3] && is_confocal_grid(&lv, sensor_grid_xyz_m) {
            return Ok(LaserSpot::Confocal);
        }
        let what = if lshape.starts_with(&[sx, sy]) {
            "a laser point per sensor point that is not the sensor point (a custom pairing)"
        } else {
            "several laser points"
        };
        Err(invalid(
            self.path,
            "laser_grid_xyz",
            format!("shape {lshape:?}: {what}; femto reads one laser spot or a confocal scan (split the capture in y-tal: get_single_subdata_from_laser_point)"),
        ))
    }
}

/// Whether a laser grid (flat `x, y, z` triples) is the sensor grid, as y-tal's
/// `NLOSCaptureData.is_confocal` decides it (`numpy.allclose`: `|a - b| <= 1e-8 + 1e-5 |b|`).
fn is_confocal_grid(laser: &[f64], sensor: &[[f64; 3]]) -> bool {
    laser.len() == 3 * sensor.len()
        && laser
            .iter()
            .zip(sensor.iter().flatten())
            .all(|(&a, &b)| (a - b).abs() <= 1e-8 + 1e-5 * b.abs())
}

/// The cube group that keeps `geo` (datasets `sensor_grid_m`, `sensor_normals` `(ny, nx, 3)`;
/// attributes `sensor_m`, `laser_origin_m`, `t_spot_ps`, `time_scale`, and `laser_spot_m`, or
/// `confocal = 1` for a confocal scan).
pub fn geometry_group(geo: &TalGeometry, nx: usize, ny: usize) -> GroupData {
    let flat = |v: &[[f64; 3]]| DataBuf::F64(v.iter().flatten().copied().collect());
    let mut datasets = vec![(
        "sensor_grid_m".to_string(),
        vec![ny, nx, 3],
        flat(&geo.sensor_grid_m),
    )];
    if let Some(n) = &geo.sensor_normals {
        datasets.push(("sensor_normals".to_string(), vec![ny, nx, 3], flat(n)));
    }
    GroupData {
        attrs: vec![
            (
                "sensor_m".into(),
                AttrValue::F64Array(geo.sensor_m.to_vec()),
            ),
            (
                "laser_origin_m".into(),
                AttrValue::F64Array(geo.laser_origin_m.to_vec()),
            ),
            ("t_spot_ps".into(), AttrValue::F64(geo.t_spot_ps)),
            ("time_scale".into(), AttrValue::F64(geo.time_scale)),
            match geo.laser_spot_m {
                LaserSpot::Single(spot) => {
                    ("laser_spot_m".into(), AttrValue::F64Array(spot.to_vec()))
                }
                LaserSpot::Confocal => ("confocal".into(), AttrValue::I64(1)),
            },
        ],
        datasets,
    }
}

/// The geometry kept in a cube's `tal` group (`path` names the cube in errors).
pub fn geometry_from_group(
    path: &Path,
    data: &GroupData,
    nx: usize,
    ny: usize,
) -> Result<TalGeometry, InteropError> {
    let key = |k: &str| format!("/{GROUP}/{k}");
    let point = |k: &str| -> Result<[f64; 3], InteropError> {
        match data.attr(k) {
            Some(AttrValue::F64Array(v)) if v.len() == 3 => {
                let p = [v[0], v[1], v[2]];
                check_device(path, &key(k), &p)?;
                Ok(p)
            }
            _ => Err(invalid(path, &key(k), "expected an attribute of 3 numbers")),
        }
    };
    let number = |k: &str, range: ranges::Range| -> Result<f64, InteropError> {
        match data.attr(k) {
            Some(AttrValue::F64(v)) => in_range(path, &key(k), *v, range),
            _ => Err(invalid(path, &key(k), "expected a number attribute")),
        }
    };
    // Entry i of a [y][x] grid.
    let yx = |i: usize| format!("[{}][{}]", i / nx, i % nx);
    let grid = |k: &str| -> Result<Option<Vec<[f64; 3]>>, InteropError> {
        match data.dataset(k) {
            None => Ok(None),
            Some((shape, DataBuf::F64(v))) if shape == [ny, nx, 3] => Ok(Some(
                v.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect(),
            )),
            Some((shape, _)) => Err(invalid(
                path,
                &key(k),
                format!("expected f64 of shape [{ny}, {nx}, 3], found {shape:?}"),
            )),
        }
    };
    let sensor_grid_m =
        grid("sensor_grid_m")?.ok_or_else(|| invalid(path, &key("sensor_grid_m"), "missing"))?;
    check_grid(
        path,
        &key("sensor_grid_m"),
        &sensor_grid_m,
        ranges::COORD_M,
        yx,
    )?;
    require_known_point(path, &key("sensor_grid_m"), &sensor_grid_m)?;
    let sensor_normals = grid("sensor_normals")?;
    if let Some(n) = &sensor_normals {
        check_grid(path, &key("sensor_normals"), n, ranges::DIRECTION, yx)?;
    }
    Ok(TalGeometry {
        sensor_grid_m,
        sensor_normals,
        sensor_m: point("sensor_m")?,
        laser_origin_m: point("laser_origin_m")?,
        laser_spot_m: match data.attr("confocal") {
            Some(AttrValue::I64(1)) => LaserSpot::Confocal,
            None => LaserSpot::Single(point("laser_spot_m")?),
            Some(_) => return Err(invalid(path, &key("confocal"), "expected the integer 1")),
        },
        t_spot_ps: number("t_spot_ps", ranges::TIME_PS)?,
        time_scale: number("time_scale", ranges::TIME_SCALE)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_laser_grid_is_confocal_when_numpy_allclose_says_so() {
        let sensor = [[0.0, 0.0, 1.0], [0.1, 0.0, 1.0]];
        let same: Vec<f64> = sensor.iter().flatten().copied().collect();
        assert!(is_confocal_grid(&same, &sensor));
        let mut near = same.clone();
        near[3] += 1e-9;
        assert!(is_confocal_grid(&near, &sensor), "within atol 1e-8");
        let mut custom = same.clone();
        custom[3] = 0.2;
        assert!(!is_confocal_grid(&custom, &sensor), "a custom pairing");
        assert!(!is_confocal_grid(&same[..3], &sensor), "one point");
    }
}

//! The `pyramid` group: the temporal prefix sums and time-only mip levels of
//! [`crate::pyramid::Pyramid`] (physics.md, "Time-resolved accumulation": the renderer's
//! `P(t_e + dtau / D) - P(t_e)`), stored in the cube's file or in a side file that holds this
//! group only.
//!
//! [`write_pyramid`] streams the cube by row slabs through [`pyramid_rows`], so peak memory
//! is one slab whatever the cube's size;
//! [`read_pyramid`] loads a stored pyramid whole, as the renderer needs it, instead of
//! rebuilding it from the cube.
//!
//! Schema (docs/cube-format.md), `[y][x][t]` in C order:
//!
//! | dataset         | type | shape                      | meaning                                  |
//! |-----------------|------|----------------------------|------------------------------------------|
//! | `prefix_coarse` | f64  | `(ny, nx, floor(nt/8) + 1)` | `P[8 k]`, `P[i]` = sum of bins `0 .. i` |
//! | `prefix_fine`   | f32  | `(ny, nx, nt + 1)`         | `P[i] - P[8 floor(i / 8)]`               |
//! | `level_k`       | f32  | `(ny, nx, ceil(nt / 2^k))` | sums of `2^k` bins, `k = 1 ..= levels`   |
//! | `mask`          | u8   | `(ny, nx)`                 | the cube's mask, when it has one         |
//!
//! so `P[i] = prefix_coarse[i / 8] + prefix_fine[i]` (the two-level prefix of
//! [`crate::pyramid::PrefixSums`]). Pyramids written before the two levels hold one f64
//! dataset `prefix`, `(ny, nx, nt + 1)`, instead; [`from_group`] reads those too.
//!
//! Attributes: `nx`, `ny`, `nt`, `levels` (integers), `t0_ps`, `dt_ps` (the cube's time axis),
//! `time_frame`, `source` (the cube file the pyramid was built from).

use super::{attr, GroupView, StoreError};
use crate::container::{
    AttrValue, ContainerError, CubeCompression, CubeMeta, CubeReader, DataBuf, DatasetSpec,
    GroupData, GroupElem, GroupReader, GroupUpdate,
};
use crate::cube::{TimeAxis, TimeFrame};
use crate::limits::check_memory;
use crate::pyramid::{
    coarse_len, level_nt, pyramid_rows, top_level, Level, PrefixSlices, PrefixSums, Pyramid,
};
use std::path::Path;

/// Name of the group.
pub const GROUP: &str = "pyramid";

/// Dataset of the f64 prefix values at every 8th bin.
pub const COARSE: &str = "prefix_coarse";

/// Dataset of the f32 prefix values within each block of 8 bins.
pub const FINE: &str = "prefix_fine";

/// Dataset of the single f64 prefix that pyramids held before the two levels.
const LEGACY_PREFIX: &str = "prefix";

/// Largest prefix slab computed at once, bytes.
const SLAB_TARGET_BYTES: usize = 32 << 20;

/// Name of the dataset of mip level `k >= 1`.
pub fn level_name(k: usize) -> String {
    format!("level_{k}")
}

/// What a stored pyramid holds, from its attributes alone.
#[derive(Clone, Debug, PartialEq)]
pub struct PyramidInfo {
    pub nx: usize,
    pub ny: usize,
    /// Time axis of the cube it was built from (level 0).
    pub axis: TimeAxis,
    pub frame: TimeFrame,
    /// Mip levels stored above level 0.
    pub levels: usize,
    /// The cube file it was built from, as given on the command line.
    pub source: String,
}

impl PyramidInfo {
    /// Samples per pixel of each stored level `1 ..= levels`.
    pub fn level_nts(&self) -> Vec<usize> {
        (1..=self.levels)
            .map(|k| level_nt(self.axis.nt, k))
            .collect()
    }

    /// The group's attributes.
    fn attrs(&self) -> Vec<(String, AttrValue)> {
        vec![
            attr("nx", AttrValue::I64(self.nx as i64)),
            attr("ny", AttrValue::I64(self.ny as i64)),
            attr("nt", AttrValue::I64(self.axis.nt as i64)),
            attr("t0_ps", AttrValue::F64(self.axis.t0_ps)),
            attr("dt_ps", AttrValue::F64(self.axis.dt_ps)),
            attr("time_frame", AttrValue::Str(self.frame.as_str().into())),
            attr("levels", AttrValue::I64(self.levels as i64)),
            attr("source", AttrValue::Str(self.source.clone())),
        ]
    }

    /// Refuse a pyramid built from a cube of another shape or time axis than `meta`.
    pub fn check_matches(&self, path: &Path, meta: &CubeMeta) -> Result<(), StoreError> {
        if self.nx != meta.nx || self.ny != meta.ny || self.axis != meta.axis {
            return Err(StoreError::Mismatch {
                path: path.to_path_buf(),
                message: format!(
                    "the pyramid was built from a {} x {} cube with {} bins of {} ps from {} ps, \
                     not this {} x {} cube with {} bins of {} ps from {} ps; rebuild it with \
                     `femto pyramid`",
                    self.nx,
                    self.ny,
                    self.axis.nt,
                    self.axis.dt_ps,
                    self.axis.t0_ps,
                    meta.nx,
                    meta.ny,
                    meta.axis.nt,
                    meta.axis.dt_ps,
                    meta.axis.t0_ps
                ),
            });
        }
        Ok(())
    }
}

/// Read the attributes of a pyramid group (`attrs` as read from the file at `path`).
pub fn info_from_attrs(
    path: &Path,
    attrs: Vec<(String, AttrValue)>,
) -> Result<PyramidInfo, StoreError> {
    let data = GroupData {
        attrs,
        datasets: Vec::new(),
    };
    let v = GroupView {
        path,
        group: GROUP,
        data: &data,
    };
    let frame_s = v.str("time_frame")?;
    let frame = TimeFrame::parse(frame_s)
        .ok_or_else(|| v.schema(format!("attribute 'time_frame' is '{frame_s}'")))?;
    let axis = TimeAxis {
        t0_ps: v.f64_in("t0_ps", crate::ranges::TIME_PS)?,
        dt_ps: v.f64_in("dt_ps", crate::ranges::BIN_WIDTH_PS)?,
        nt: v.usize("nt")?,
    };
    if !(axis.t0_ps.is_finite() && axis.dt_ps.is_finite() && axis.dt_ps > 0.0 && axis.nt > 0) {
        return Err(v.schema(format!(
            "time axis t0 {} ps, dt {} ps, {} bins is not a valid axis",
            axis.t0_ps, axis.dt_ps, axis.nt
        )));
    }
    let info = PyramidInfo {
        nx: v.usize("nx")?,
        ny: v.usize("ny")?,
        axis,
        frame,
        levels: v.usize("levels")?,
        source: v.str("source")?.to_string(),
    };
    if info.levels > top_level(axis.nt) {
        return Err(v.schema(format!(
            "{} levels stored, but {} bins have at most {}",
            info.levels,
            axis.nt,
            top_level(axis.nt)
        )));
    }
    Ok(info)
}

/// Memory of the process before the pyramid stage allocates anything, bytes.
const PYRAMID_BASE_BYTES: f64 = 24e6;

/// Build the pyramid of the cube `reader` reads, keeping mip levels `1 ..= levels`, and write
/// it as group [`GROUP`] into `out` (the cube's own file or a side file), row slab by row slab.
/// `source` names the cube in the `source` attribute; `on_rows` is called with the number of
/// rows done so far. Refused, before anything is allocated, when one slab of rows needs more
/// memory than the machine has ([`crate::limits::check_memory`]).
pub fn write_pyramid(
    reader: &CubeReader,
    out: &mut GroupUpdate,
    levels: usize,
    source: &str,
    compression: CubeCompression,
    on_rows: &dyn Fn(usize),
) -> Result<PyramidInfo, StoreError> {
    let meta = reader.meta();
    // Sizes from the file's attributes, in floats: one row of the source, its prefix sums and
    // levels, refused before a slab is allocated when it cannot be held.
    let (nx, ny, nt) = (meta.nx as f64, meta.ny as f64, meta.axis.nt as f64);
    let row_bytes = 4.0 * nx * nt + crate::pyramid::memory_bytes(nx, nt);
    let rows_per_slab = (SLAB_TARGET_BYTES as f64 / row_bytes.max(1.0))
        .floor()
        .clamp(1.0, ny.max(1.0));
    check_memory(
        PYRAMID_BASE_BYTES + rows_per_slab * row_bytes,
        format_args!(
            "{source}: the pyramid of {} x {} pixels of {} bins, {rows_per_slab} rows at a time",
            meta.nx, meta.ny, meta.axis.nt
        ),
        "store fewer --levels or use a machine with more memory",
    )
    .map_err(|e| StoreError::Mismatch {
        path: Path::new(source).to_path_buf(),
        message: e.to_string(),
    })?;
    let rows_per_slab = rows_per_slab as usize;
    write_pyramid_slabs(
        reader,
        out,
        levels,
        source,
        compression,
        rows_per_slab,
        on_rows,
    )
}

/// [`write_pyramid`] with a given number of rows per slab (at least 1, at most all).
fn write_pyramid_slabs(
    reader: &CubeReader,
    out: &mut GroupUpdate,
    levels: usize,
    source: &str,
    compression: CubeCompression,
    rows_per_slab: usize,
    on_rows: &dyn Fn(usize),
) -> Result<PyramidInfo, StoreError> {
    let meta = reader.meta();
    let (nx, ny, nt) = (meta.nx, meta.ny, meta.axis.nt);
    if levels > top_level(nt) {
        return Err(StoreError::Mismatch {
            path: Path::new(source).to_path_buf(),
            message: format!(
                "{levels} mip levels asked, but a cube of {nt} bins has at most {} \
                 (level k sums 2^k bins)",
                top_level(nt)
            ),
        });
    }
    let info = PyramidInfo {
        nx,
        ny,
        axis: meta.axis,
        frame: meta.frame,
        levels,
        source: source.to_string(),
    };
    let attrs = info.attrs();
    let mask = reader.read_mask()?;
    let mut specs = vec![
        DatasetSpec::new(COARSE, &[ny, nx, coarse_len(nt)], GroupElem::F64)
            .with_compression(compression),
        DatasetSpec::new(FINE, &[ny, nx, nt + 1], GroupElem::F32).with_compression(compression),
    ];
    for (k, &nt_k) in (1..=levels).zip(&info.level_nts()) {
        specs.push(
            DatasetSpec::new(level_name(k), &[ny, nx, nt_k], GroupElem::F32)
                .with_compression(compression),
        );
    }
    if mask.is_some() {
        specs.push(DatasetSpec::new("mask", &[ny, nx], GroupElem::U8));
    }
    out.begin_group(GROUP, &attrs, &specs)?;
    if let Some(m) = mask {
        out.write_group_rows(GROUP, "mask", 0, &DataBuf::U8(m))?;
    }
    let rows_per_slab = rows_per_slab.clamp(1, ny);
    // One set of slab buffers for the whole cube (page faults and allocation once): the
    // source rows, the prefix and each level, resized (down, for the last slab) in place.
    let mut src = vec![0.0f32; rows_per_slab * nx * nt];
    let mut coarse = vec![0.0f64; rows_per_slab * nx * coarse_len(nt)];
    let mut fine = vec![0.0f32; rows_per_slab * nx * (nt + 1)];
    let mut level_bufs: Vec<Vec<f32>> = (1..=levels)
        .map(|k| vec![0.0f32; rows_per_slab * nx * level_nt(nt, k)])
        .collect();
    for y0 in (0..ny).step_by(rows_per_slab) {
        let n = rows_per_slab.min(ny - y0);
        let src = &mut src[..n * nx * nt];
        reader.read_rows_into(y0, src)?;
        coarse.truncate(n * nx * coarse_len(nt));
        fine.truncate(n * nx * (nt + 1));
        for (k, l) in (1..=levels).zip(level_bufs.iter_mut()) {
            l.truncate(n * nx * level_nt(nt, k));
        }
        let mut outs: Vec<&mut [f32]> = level_bufs.iter_mut().map(|l| &mut l[..]).collect();
        let prefix = PrefixSlices {
            coarse: &mut coarse,
            fine: &mut fine,
        };
        pyramid_rows(src, nt, prefix, &mut outs);
        // The buffers are moved into a `DataBuf` for the write and back out after it.
        let written = DataBuf::F64(std::mem::take(&mut coarse));
        out.write_group_rows(GROUP, COARSE, y0, &written)?;
        if let DataBuf::F64(c) = written {
            coarse = c;
        }
        let written = DataBuf::F32(std::mem::take(&mut fine));
        out.write_group_rows(GROUP, FINE, y0, &written)?;
        if let DataBuf::F32(f) = written {
            fine = f;
        }
        for (k, l) in (1..=levels).zip(level_bufs.iter_mut()) {
            let written = DataBuf::F32(std::mem::take(l));
            out.write_group_rows(GROUP, &level_name(k), y0, &written)?;
            if let DataBuf::F32(v) = written {
                *l = v;
            }
        }
        on_rows(y0 + n);
    }
    Ok(info)
}

/// Turn a pyramid group read from the file at `path` back into a [`Pyramid`].
pub fn from_group(path: &Path, data: GroupData) -> Result<Pyramid, StoreError> {
    let info = info_from_attrs(path, data.attrs.clone())?;
    let v = GroupView {
        path,
        group: GROUP,
        data: &data,
    };
    let (nx, ny, nt) = (info.nx, info.ny, info.axis.nt);
    // Every value the renderer reads must be finite: refused here, naming the dataset and
    // the first pixel and bin, like the cube's own values ([`CubeReader::read_rows_into`]).
    let finite =
        |name: &str, values: &[f32], bins: usize| finite_or_refused(path, name, values, nx, bins);
    let prefix = if data.dataset(COARSE).is_none() && data.dataset(LEGACY_PREFIX).is_some() {
        let plain: &[f64] = v.typed(LEGACY_PREFIX, &[ny, nx, nt + 1])?;
        finite_or_refused(path, LEGACY_PREFIX, plain, nx, nt + 1)?;
        PrefixSums::from_plain(plain, nt)
    } else {
        let coarse: &[f64] = v.typed(COARSE, &[ny, nx, coarse_len(nt)])?;
        finite_or_refused(path, COARSE, coarse, nx, coarse_len(nt))?;
        let fine = v.typed(FINE, &[ny, nx, nt + 1])?;
        finite(FINE, fine, nt + 1)?;
        PrefixSums {
            nt,
            coarse: coarse.to_vec(),
            fine: fine.to_vec(),
        }
    };
    let mut levels = Vec::with_capacity(info.levels);
    for (k, nt_k) in (1..=info.levels).zip(info.level_nts()) {
        let data = v.typed(&level_name(k), &[ny, nx, nt_k])?;
        finite(&level_name(k), data, nt_k)?;
        levels.push(Level {
            bins_per_sample: 1 << k,
            nt: nt_k,
            data: data.to_vec(),
        });
    }
    let mask = match data.dataset("mask") {
        None => None,
        Some(_) => Some(v.typed::<u8>("mask", &[ny, nx])?.to_vec()),
    };
    Ok(Pyramid {
        nx,
        ny,
        axis: info.axis,
        prefix,
        levels,
        mask,
    })
}

/// Refuse a NaN or infinite value of dataset `name` of the group (`[y][x][t]`, `nx` pixels
/// by `bins` per row), naming the file, `pyramid/<name>` and the first pixel and bin.
fn finite_or_refused<T: crate::cube::Sample>(
    path: &Path,
    name: &str,
    values: &[T],
    nx: usize,
    bins: usize,
) -> Result<(), StoreError> {
    match crate::cube::first_non_finite(values, nx, bins) {
        None => Ok(()),
        Some(at) => Err(ContainerError::NonFinite {
            path: path.to_path_buf(),
            dataset: format!("{GROUP}/{name}"),
            at,
        }
        .into()),
    }
}

/// Load the pyramid stored in the file at `path`: a cube file with a `pyramid` group, or a
/// side file written by `femto pyramid --side-file`.
pub fn read_pyramid(path: &Path) -> Result<Pyramid, StoreError> {
    let reader = GroupReader::open(path)?;
    from_group(path, reader.read_group(GROUP)?)
}

/// Load the pyramid for the cube at `cube_path`: from `side_file` when given, else from the
/// cube's own file; refused when it was built from a cube of another shape or time axis.
pub fn read_pyramid_for(cube_path: &Path, side_file: Option<&Path>) -> Result<Pyramid, StoreError> {
    let meta = crate::container::read_meta(cube_path)?;
    let path = side_file.unwrap_or(cube_path);
    let reader = GroupReader::open(path)?;
    let info = info_from_attrs(path, reader.read_group_attrs(GROUP)?)?;
    info.check_matches(path, &meta)?;
    from_group(path, reader.read_group(GROUP)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::container::{write_cube, Provenance};
    use crate::cube::Cube;
    use crate::pyramid::PrefixRead;

    /// Streams of 2 rows give the prefix sums and box sums computed here directly from the
    /// cube's values, stored compressed or not.
    #[test]
    fn slabs_of_rows_give_the_brute_force_pyramid() {
        for compression in [CubeCompression::Deflate(1), CubeCompression::None] {
            slabs_of_rows_give_the_brute_force_pyramid_with(compression);
        }
    }

    fn slabs_of_rows_give_the_brute_force_pyramid_with(compression: CubeCompression) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.h5");
        let axis = TimeAxis {
            t0_ps: 5.0,
            dt_ps: 0.5,
            nt: 11,
        };
        let (nx, ny) = (4, 5);
        let mut cube = Cube::zeros(nx, ny, axis, TimeFrame::World);
        for (i, v) in cube.data.iter_mut().enumerate() {
            *v = ((i * 37) % 17) as f32 - 3.0;
        }
        cube.mask = Some((0..nx * ny).map(|i| (i % 4 != 1) as u8).collect());
        write_cube(&path, &cube, &Provenance::new("test")).unwrap();
        let reader = CubeReader::open(&path).unwrap();
        let mut up = GroupUpdate::open(&path).unwrap();
        let info =
            write_pyramid_slabs(&reader, &mut up, 3, "c.h5", compression, 2, &|_| {}).unwrap();
        drop(reader);
        up.finish().unwrap();
        assert_eq!(info.level_nts(), vec![6, 3, 2]);
        let pyr = read_pyramid(&path).unwrap();
        assert_eq!(pyr.levels.len(), 3);
        assert_eq!(pyr.mask, cube.mask);
        for y in 0..ny {
            for x in 0..nx {
                let prof = cube.profile(x, y);
                let mut acc = 0.0f64;
                let p = pyr.pixel_prefix(x, y);
                assert_eq!(p.get(0), 0.0);
                for (i, &v) in prof.iter().enumerate() {
                    acc += v as f64;
                    assert_eq!(p.get(i + 1), acc);
                }
                for (k1, level) in pyr.levels.iter().enumerate() {
                    let w = 1 << (k1 + 1);
                    for s in 0..level.nt {
                        let want: f32 = prof[s * w..((s + 1) * w).min(axis.nt)].iter().sum();
                        let got = level.data[(y * nx + x) * level.nt + s];
                        assert!((got - want).abs() < 1e-5, "level {} sample {s}", k1 + 1);
                    }
                }
            }
        }
        // The cube is untouched by the update.
        assert_eq!(crate::container::read_cube(&path).unwrap(), cube);
        // Too many levels for 11 bins (at most 4).
        let reader = CubeReader::open(&path).unwrap();
        let mut up = GroupUpdate::open(&path).unwrap();
        let e = write_pyramid(&reader, &mut up, 5, "c.h5", compression, &|_| {}).unwrap_err();
        assert!(e.to_string().contains("at most 4"), "{e}");
    }

    /// A pyramid stored before the two-level prefix (one f64 dataset `prefix`) reads back as
    /// the two levels the kernel builds now.
    #[test]
    fn a_stored_f64_prefix_is_read_as_two_levels() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("old.h5");
        let axis = TimeAxis {
            t0_ps: 0.0,
            dt_ps: 2.0,
            nt: 21,
        };
        let (nx, ny) = (3, 2);
        let mut cube = Cube::zeros(nx, ny, axis, TimeFrame::World);
        for (i, v) in cube.data.iter_mut().enumerate() {
            *v = ((i * 13) % 11) as f32 * 0.5;
        }
        write_cube(&path, &cube, &Provenance::new("test")).unwrap();
        let mut plain = vec![0.0f64; nx * ny * (axis.nt + 1)];
        for (p, prof) in cube.data.chunks_exact(axis.nt).enumerate() {
            for (i, &v) in prof.iter().enumerate() {
                let o = p * (axis.nt + 1) + i;
                plain[o + 1] = plain[o] + v as f64;
            }
        }
        let info = PyramidInfo {
            nx,
            ny,
            axis,
            frame: TimeFrame::World,
            levels: 0,
            source: "old.h5".into(),
        };
        let spec = DatasetSpec::new(LEGACY_PREFIX, &[ny, nx, axis.nt + 1], GroupElem::F64);
        let mut up = GroupUpdate::open(&path).unwrap();
        up.begin_group(GROUP, &info.attrs(), &[spec]).unwrap();
        up.write_group_rows(GROUP, LEGACY_PREFIX, 0, &DataBuf::F64(plain))
            .unwrap();
        up.finish().unwrap();
        let pyr = read_pyramid_for(&path, None).unwrap();
        assert_eq!(pyr.prefix, Pyramid::build(&cube).prefix);
    }
}

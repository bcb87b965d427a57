//! Reading cubes: [`CubeReader`] (metadata at once, values by row slabs, decoded chunk by
//! chunk in parallel where the chunk layout allows) and the one-call readers.

use super::attributes::{read_f64_attr, read_str_attr, required_str_attr};
use super::error::{h5, invalid, ContainerError, Result};
use super::groups::GroupReader;
use super::open::{dataset_elem, open_dataset, open_h5};
use super::schema::{
    axis_ranges, slab_rows, CubeCompression, CubeMeta, Elem, GroupData, CUBE_DATASET,
    DEFLATE_LEVEL, MASK_DATASET, RESERVED_ATTRS,
};
use crate::cube;
use crate::cube::Cube;
use crate::cube::TimeAxis;
use crate::cube::TimeFrame;
use crate::ranges;
use rayon::prelude::*;
use rust_hdf5::format::messages::filter::reverse_filters_masked_bounded;
use rust_hdf5::format::messages::filter::FILTER_DEFLATE;
use rust_hdf5::format::messages::filter::FILTER_SHUFFLE;
use rust_hdf5::FilterPipeline;
use rust_hdf5::H5Dataset;
use rust_hdf5::Hdf5Error;
use std::path::Path;

/// Streaming reader of a cube file: metadata at once, values by row slabs.
pub struct CubeReader {
    /// The file, its path and its groups (it holds `/cube` too).
    pub(super) groups: GroupReader,
    pub(super) cube: H5Dataset,
    pub(super) meta: CubeMeta,
    /// Chunk width `cx` and filters of a cube chunked `(1, cx, nt)` through a filter
    /// pipeline: its rows are decoded chunk by chunk on rayon's threads.
    row_chunks: Option<(usize, FilterPipeline)>,
}

impl CubeReader {
    /// Open the cube file at `path` and read its metadata.
    pub fn open(path: &Path) -> Result<CubeReader> {
        let file = open_h5(path)?;
        let cube = file.dataset(CUBE_DATASET).map_err(|e| match e {
            Hdf5Error::NotFound(_) => ContainerError::NoCube {
                path: path.to_path_buf(),
            },
            other => h5(path)(other),
        })?;
        let shape = cube.shape();
        if shape.len() != 3 {
            return Err(ContainerError::WrongRank {
                path: path.to_path_buf(),
                dataset: CUBE_DATASET.into(),
                found: shape.len(),
                expected: 3,
            });
        }
        let (elem, found) = dataset_elem(&cube, path)?;
        if elem != Some(Elem::F32) {
            return Err(ContainerError::WrongType {
                path: path.to_path_buf(),
                dataset: CUBE_DATASET.into(),
                found,
                expected: "f32".into(),
            });
        }
        let (ny, nx, nt) = (shape[0], shape[1], shape[2]);
        if nx == 0 || ny == 0 || nt == 0 {
            return Err(invalid(path, format!("/cube is empty, shape {shape:?}")));
        }
        let object = CUBE_DATASET;
        let t0_ps = read_f64_attr(&cube, path, object, "t0_ps")?;
        let dt_ps = read_f64_attr(&cube, path, object, "dt_ps")?;
        let axis = TimeAxis { t0_ps, dt_ps, nt };
        // Each attribute in its range before anything sized by it is made (a render's
        // profile of span / dt_ps bins: dt_ps = 1e-300 indexed past it).
        for (attr, value, range) in axis_ranges(&axis) {
            ranges::check(attr, value, range).map_err(|e| ContainerError::BadAttribute {
                path: path.to_path_buf(),
                object: object.into(),
                attr: attr.into(),
                reason: e.detail(),
            })?;
        }
        let frame_s = required_str_attr(&cube, path, object, "time_frame")?;
        let frame = TimeFrame::parse(&frame_s).ok_or_else(|| ContainerError::BadAttribute {
            path: path.to_path_buf(),
            object: object.into(),
            attr: "time_frame".into(),
            reason: format!("{frame_s:?} is neither \"camera\" nor \"world\""),
        })?;
        let units = required_str_attr(&cube, path, object, "units")?;
        let femto_version = read_str_attr(&cube, path, object, "femto_version")?;
        let command_line = read_str_attr(&cube, path, object, "command_line")?;
        let mut notes = Vec::new();
        for name in cube.attr_names().map_err(h5(path))? {
            if RESERVED_ATTRS.contains(&name.as_str()) {
                continue;
            }
            // A note written by another tool may be numeric: keep it, as text.
            let value = match read_str_attr(&cube, path, object, &name) {
                Ok(v) => v.unwrap_or_default(),
                Err(_) => cube
                    .attr(&name)
                    .and_then(|a| a.read_numeric_as::<f64>())
                    .map(|v| {
                        v.iter()
                            .map(|x| x.to_string())
                            .collect::<Vec<_>>()
                            .join(" ")
                    })
                    .unwrap_or_default(),
            };
            notes.push((name, value));
        }
        let root = file.root_group();
        let has_mask = root
            .dataset_names()
            .map_err(h5(path))?
            .iter()
            .any(|n| n == MASK_DATASET);
        let mut groups = root.group_names().map_err(h5(path))?;
        groups.sort();
        let meta = CubeMeta {
            nx,
            ny,
            axis,
            frame,
            units,
            femto_version,
            command_line,
            notes,
            groups,
            has_mask,
        };
        let row_chunks = match (cube.chunk_dims(), cube.filters()) {
            (Some(d), Ok(filters))
                if d.len() == 3 && d[0] == 1 && d[2] == meta.axis.nt && !filters.is_empty() =>
            {
                Some((d[1], FilterPipeline { filters }))
            }
            _ => None,
        };
        let groups = GroupReader {
            file,
            path: path.to_path_buf(),
            groups: meta.groups.clone(),
            has_cube: true,
        };
        Ok(CubeReader {
            groups,
            cube,
            meta,
            row_chunks,
        })
    }

    /// Rows `y0 ..` into `out` (whole rows) from the stored chunks of a cube chunked
    /// `(1, cx, nt)`: read one by one, decoded in parallel. `None` when a chunk cannot be
    /// read or decoded this way (the caller then reads through the HDF5 library, which
    /// reports the fault).
    pub(super) fn read_rows_by_chunks(&self, y0: usize, out: &mut [f32]) -> Option<()> {
        let (cx, pipeline) = self.row_chunks.as_ref()?;
        let (nx, nt) = (self.meta.nx, self.meta.axis.nt);
        let row_len = nx * nt;
        let n_chunks = nx.div_ceil(*cx);
        let stored: Vec<(Vec<u8>, u32)> = (0..out.len() / row_len)
            .flat_map(|r| (0..n_chunks).map(move |c| (y0 + r, c)))
            .map(|(y, c)| self.cube.read_chunk_raw_at(&[y, c, 0]).ok())
            .collect::<Option<_>>()?;
        let chunk_values = cx * nt;
        let ok = out
            .par_chunks_mut(row_len)
            .zip(stored.par_chunks(n_chunks))
            .all(|(row, chunks)| {
                row.chunks_mut(chunk_values)
                    .zip(chunks)
                    .all(|(dst, (bytes, mask))| {
                        match reverse_filters_masked_bounded(
                            pipeline,
                            bytes,
                            *mask,
                            chunk_values * 4,
                        ) {
                            Ok(raw) if raw.len() == chunk_values * 4 => {
                                for (v, b) in dst.iter_mut().zip(raw.chunks_exact(4)) {
                                    *v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                                }
                                true
                            }
                            _ => false,
                        }
                    })
            });
        ok.then_some(())
    }

    /// The cube's metadata.
    pub fn meta(&self) -> &CubeMeta {
        &self.meta
    }

    pub(super) fn check_rows(&self, y0: usize, n: usize) -> Result<()> {
        if y0 + n > self.meta.ny {
            return Err(invalid(
                &self.groups.path,
                format!(
                    "rows {y0}..{} past the cube's {} rows",
                    y0 + n,
                    self.meta.ny
                ),
            ));
        }
        Ok(())
    }

    /// Read rows `y0 .. y0 + n` (`n * nx * nt` values, layout `[y][x][t]`).
    pub fn read_rows(&self, y0: usize, n: usize) -> Result<Vec<f32>> {
        let mut out = vec![0.0; n * self.meta.row_len()];
        self.read_rows_into(y0, &mut out)?;
        Ok(out)
    }

    /// Read rows starting at `y0` into `out`, whose length must be a whole number of rows.
    /// A NaN or infinite value is refused ([`ContainerError::NonFinite`], naming its pixel
    /// and bin): every stage reads the cube through here, so none of them sees one.
    pub fn read_rows_into(&self, y0: usize, out: &mut [f32]) -> Result<()> {
        self.read_rows_as_stored(y0, out)?;
        let (nx, nt) = (self.meta.nx, self.meta.axis.nt);
        match cube::first_non_finite(out, nx, nt) {
            None => Ok(()),
            Some(mut at) => {
                at.y += y0;
                Err(ContainerError::NonFinite {
                    path: self.groups.path.clone(),
                    dataset: CUBE_DATASET.into(),
                    at,
                })
            }
        }
    }

    /// [`Self::read_rows_into`] without the check of the values (for [`Self::value_scan`],
    /// which describes a cube whatever it holds).
    pub(super) fn read_rows_as_stored(&self, y0: usize, out: &mut [f32]) -> Result<()> {
        let row_len = self.meta.row_len();
        if !out.len().is_multiple_of(row_len) {
            return Err(invalid(
                &self.groups.path,
                format!(
                    "buffer of {} values is not whole rows of {row_len}",
                    out.len()
                ),
            ));
        }
        let n = out.len() / row_len;
        self.check_rows(y0, n)?;
        if n == 0 || self.read_rows_by_chunks(y0, out).is_some() {
            return Ok(());
        }
        self.cube
            .read_slice_into(out, &[y0, 0, 0], &[n, self.meta.nx, self.meta.axis.nt])
            .map_err(h5(&self.groups.path))
    }

    /// Whether `/cube` is stored as femto's writer stores it (chunks `(1, cx, nt)`, shuffle
    /// of 4-byte values then deflate at any level), so that its chunks can be copied as
    /// they are into a new cube of chunk width `cx` ([`GroupUpdate::open`]).
    /// How `/cube` is stored: shuffle + deflate at its level when its filters hold deflate
    /// (a cube of another tool's with deflate alone is re-stored with shuffle too), else
    /// [`CubeCompression::None`]. Stages that rewrite a cube keep this unless told otherwise.
    ///
    /// [`GroupUpdate::open`]: super::GroupUpdate::open
    pub fn stored_compression(&self) -> CubeCompression {
        match self.cube.filters() {
            Ok(filters) => {
                filters
                    .iter()
                    .find(|f| f.id == FILTER_DEFLATE)
                    .map_or(CubeCompression::None, |f| {
                        CubeCompression::Deflate(
                            f.cd_values.first().copied().unwrap_or(DEFLATE_LEVEL).min(9),
                        )
                    })
            }
            Err(_) => CubeCompression::None,
        }
    }

    pub(super) fn stored_as_written(&self, cx: usize) -> bool {
        match &self.row_chunks {
            Some((c, p)) => {
                let f = &p.filters;
                *c == cx
                    && f.len() == 2
                    && f[0].id == FILTER_SHUFFLE
                    && matches!(f[0].cd_values.first(), None | Some(4))
                    && f[1].id == FILTER_DEFLATE
            }
            None => false,
        }
    }

    /// The stored (filtered) bytes and filter mask of the `n_chunks` chunks of row `y`, or
    /// `None` if one of them cannot be read raw (never written, for example).
    pub(super) fn read_raw_row(&self, y: usize, n_chunks: usize) -> Option<Vec<(Vec<u8>, u32)>> {
        (0..n_chunks)
            .map(|c| self.cube.read_chunk_raw_at(&[y, c, 0]).ok())
            .collect()
    }

    /// The validity mask (`ny * nx` bytes, `[y][x]`), if the file has one.
    pub fn read_mask(&self) -> Result<Option<Vec<u8>>> {
        if !self.meta.has_mask {
            return Ok(None);
        }
        let ds = open_dataset(&self.groups.file, &self.groups.path, MASK_DATASET)?;
        let expected = vec![self.meta.ny, self.meta.nx];
        if ds.shape() != expected {
            return Err(ContainerError::WrongShape {
                path: self.groups.path.clone(),
                dataset: MASK_DATASET.into(),
                found: ds.shape(),
                expected,
            });
        }
        let (elem, found) = dataset_elem(&ds, &self.groups.path)?;
        if elem != Some(Elem::U8) {
            return Err(ContainerError::WrongType {
                path: self.groups.path.clone(),
                dataset: MASK_DATASET.into(),
                found,
                expected: "u8".into(),
            });
        }
        ds.read_raw::<u8>().map(Some).map_err(h5(&self.groups.path))
    }

    /// The whole cube in memory.
    pub fn read_cube(&self) -> Result<Cube> {
        self.read_cube_reporting(&|_| {})
    }

    /// [`Self::read_cube`] by slabs of rows, calling `on_rows` with the rows read so far
    /// after each: a caller that unwinds from it (the Python package on Ctrl-C) stops the
    /// read within a slab's time.
    pub fn read_cube_reporting(&self, on_rows: &dyn Fn(usize)) -> Result<Cube> {
        let (ny, row_len) = (self.meta.ny, self.meta.row_len());
        let mut data = vec![0.0f32; ny * row_len];
        let rows = slab_rows(row_len * 4, ny);
        for (k, slab) in data.chunks_mut(rows * row_len.max(1)).enumerate() {
            self.read_rows_into(k * rows, slab)?;
            on_rows((k * rows + rows).min(ny));
        }
        Ok(Cube {
            nx: self.meta.nx,
            ny: self.meta.ny,
            axis: self.meta.axis,
            frame: self.meta.frame,
            data,
            mask: self.read_mask()?,
        })
    }

    /// Smallest and largest finite values (None when there are none), streaming the cube
    /// by slabs; `on_rows` is called with the number of rows scanned so far. NaN and
    /// infinite values are skipped, not refused ([`Self::value_scan`] counts them).
    pub fn value_range(&self, on_rows: &dyn Fn(usize)) -> Result<Option<(f32, f32)>> {
        Ok(self.value_scan(on_rows)?.range)
    }

    /// The finite values' range and the NaN and infinite values (how many, the first),
    /// streaming the cube by slabs: what `femto info` reports of a cube that the stages
    /// refuse. `on_rows` is called with the number of rows scanned so far.
    pub fn value_scan(&self, on_rows: &dyn Fn(usize)) -> Result<ValueScan> {
        let row_len = self.meta.row_len();
        let (nx, nt) = (self.meta.nx, self.meta.axis.nt);
        let rows = slab_rows(row_len * 4, self.meta.ny);
        let mut buf = vec![0.0f32; rows * row_len];
        let mut scan = ValueScan::default();
        for y0 in (0..self.meta.ny).step_by(rows) {
            let n = rows.min(self.meta.ny - y0);
            let slab = &mut buf[..n * row_len];
            self.read_rows_as_stored(y0, slab)?;
            if let Some((lo, hi)) = cube::value_range(slab) {
                scan.range = Some(scan.range.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
            }
            if let Some(mut at) = cube::first_non_finite(slab, nx, nt) {
                at.y += y0;
                scan.first_non_finite.get_or_insert(at);
                scan.non_finite += slab.iter().filter(|v| !v.is_finite()).count();
            }
            on_rows(y0 + n);
        }
        Ok(scan)
    }
}

/// A cube reader reads the file's extra groups as the [`GroupReader`] it owns: `read_group`,
/// `read_group_attrs`, `group_dataset_names`, `group_dataset_shape` and `read_group_rows`
/// are [`GroupReader`]'s, called on a `CubeReader` as they are.
impl std::ops::Deref for CubeReader {
    type Target = GroupReader;
    fn deref(&self) -> &GroupReader {
        &self.groups
    }
}

/// What [`CubeReader::value_scan`] finds in a cube's values.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ValueScan {
    /// Smallest and largest finite value (None when there are none).
    pub range: Option<(f32, f32)>,
    /// How many values are NaN or infinite.
    pub non_finite: usize,
    /// The first of them in storage order.
    pub first_non_finite: Option<cube::NonFiniteAt>,
}

/// Read the whole cube at `path`.
pub fn read_cube(path: &Path) -> Result<Cube> {
    CubeReader::open(path)?.read_cube()
}

/// Read the metadata of the cube at `path`.
pub fn read_meta(path: &Path) -> Result<CubeMeta> {
    Ok(CubeReader::open(path)?.meta)
}

/// Names of the extra groups of the cube at `path`, sorted.
pub fn list_groups(path: &Path) -> Result<Vec<String>> {
    Ok(CubeReader::open(path)?.meta.groups)
}

/// Read extra group `name` of the cube at `path` whole.
pub fn read_group(path: &Path, name: &str) -> Result<GroupData> {
    CubeReader::open(path)?.read_group(name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::container::schema::{AttrValue, DataBuf};
    use crate::container::update::GroupUpdate;
    use crate::container::write::camera_writer;

    /// A cube reader answers for its groups as the group reader of the same file does: it
    /// owns one.
    #[test]
    fn cube_reader_reads_groups_as_a_group_reader() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.h5");
        let axis = TimeAxis {
            t0_ps: 0.0,
            dt_ps: 1.0,
            nt: 4,
        };
        let mut w = camera_writer(&p, 2, 3, axis, CubeCompression::default()).unwrap();
        w.write_rows(0, &[1.0; 2 * 3 * 4]).unwrap();
        let data = GroupData {
            attrs: vec![("k".into(), AttrValue::Str("v".into()))],
            datasets: vec![("d".into(), vec![3, 2], DataBuf::U32(vec![1, 2, 3, 4, 5, 6]))],
        };
        w.write_group("g", &data).unwrap();
        w.finish().unwrap();
        let cube = CubeReader::open(&p).unwrap();
        let groups = GroupReader::open(&p).unwrap();
        assert_eq!(cube.groups(), groups.groups());
        assert_eq!(cube.groups(), cube.meta().groups.as_slice());
        assert!(cube.has_cube() && groups.has_cube());
        assert_eq!(cube.read_group("g").unwrap(), data);
        assert_eq!(groups.read_group("g").unwrap(), data);
        assert_eq!(cube.read_group_attrs("g").unwrap(), data.attrs);
        assert_eq!(cube.group_dataset_names("g").unwrap(), ["d"]);
        assert_eq!(
            cube.group_dataset_shape("g", "d").unwrap(),
            (vec![3, 2], "u32")
        );
        assert_eq!(
            cube.read_group_rows("g", "d", 1, 2).unwrap(),
            DataBuf::U32(vec![3, 4, 5, 6])
        );
        // Errors name the file the same way through either reader.
        let e1 = cube.read_group("nope").unwrap_err().to_string();
        let e2 = groups.read_group("nope").unwrap_err().to_string();
        assert_eq!(e1, e2);
        assert!(e1.ends_with("no group /nope"), "{e1}");
        // An update keeps reading through the owned group reader.
        let mut u = GroupUpdate::open(&p).unwrap();
        u.write_group("h", &data).unwrap();
        u.finish().unwrap();
        assert_eq!(CubeReader::open(&p).unwrap().groups(), ["g", "h"]);
    }
}

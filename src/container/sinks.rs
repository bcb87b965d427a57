//! Extra groups being written: the checks of their names and shapes, their chunked datasets
//! (one row a chunk, compressed on rayon's threads) and the sinks that fill them by row slabs.

use super::attributes::write_group_attrs;
use super::error::{h5, invalid, Result};
use super::schema::{
    check_name, le_bytes, AttrValue, CubeCompression, DataBuf, DatasetSpec, Elem, GroupData,
    CUBE_DATASET, GROUP_ATTRS_INDEX, MASK_DATASET,
};
use rayon::prelude::*;
use rust_hdf5::format::messages::filter::apply_filters;
use rust_hdf5::FilterPipeline;
use rust_hdf5::H5Dataset;
use rust_hdf5::H5File;
use rust_hdf5::H5Group;
use rust_hdf5::H5Type;
use std::path::Path;

pub(super) fn check_group(path: &Path, name: &str, data: &GroupData) -> Result<()> {
    let layout: Vec<(&str, &[usize])> = data
        .datasets
        .iter()
        .map(|(d, shape, _)| (d.as_str(), shape.as_slice()))
        .collect();
    check_group_layout(path, name, &data.attrs, &layout)?;
    for (d, shape, buf) in &data.datasets {
        let n: usize = shape.iter().product();
        if n != buf.len() {
            return Err(invalid(
                path,
                format!(
                    "dataset /{name}/{d} has shape {shape:?} ({n} values) but {} values",
                    buf.len()
                ),
            ));
        }
    }
    Ok(())
}

/// Check the names of a group, its attributes and datasets, and the datasets' shapes.
pub(super) fn check_group_layout(
    path: &Path,
    name: &str,
    attrs: &[(String, AttrValue)],
    datasets: &[(&str, &[usize])],
) -> Result<()> {
    check_name(path, "group", name)?;
    if name == CUBE_DATASET || name == MASK_DATASET {
        return Err(invalid(path, format!("group name '{name}' is reserved")));
    }
    for (i, (a, _)) in attrs.iter().enumerate() {
        check_name(path, "attribute", a)?;
        if a == GROUP_ATTRS_INDEX || attrs[..i].iter().any(|(o, _)| o == a) {
            return Err(invalid(
                path,
                format!("attribute '{a}' of group /{name} is reserved or given twice"),
            ));
        }
    }
    for (i, (d, shape)) in datasets.iter().enumerate() {
        check_name(path, "dataset", d)?;
        if datasets[..i].iter().any(|(o, _)| o == d) {
            return Err(invalid(path, format!("dataset /{name}/{d} given twice")));
        }
        if shape.is_empty() || shape.contains(&0) {
            return Err(invalid(
                path,
                format!("dataset /{name}/{d} has shape {shape:?}: every axis needs length > 0"),
            ));
        }
    }
    Ok(())
}

/// The filters of a group dataset of `elem`: shuffle (for values wider than a byte), then
/// deflate; `None` for an uncompressed one.
pub(super) fn group_pipeline(elem: Elem, compression: CubeCompression) -> Option<FilterPipeline> {
    match compression {
        CubeCompression::Deflate(level) if elem.size() > 1 => {
            Some(FilterPipeline::shuffle_deflate(elem.size() as u32, level))
        }
        CubeCompression::Deflate(level) => Some(FilterPipeline::deflate(level)),
        CubeCompression::None => None,
    }
}

/// Create a chunked dataset of `elem` in `group`, one row (index of the first axis) per
/// chunk, so that rows are compressed independently, in parallel ([`write_group_rows`]).
pub(super) fn create_group_dataset(
    group: &H5Group,
    name: &str,
    elem: Elem,
    shape: &[usize],
    compression: CubeCompression,
) -> rust_hdf5::Result<H5Dataset> {
    pub(super) fn make<T: H5Type>(
        group: &H5Group,
        name: &str,
        shape: &[usize],
        chunk: &[usize],
        compression: CubeCompression,
    ) -> rust_hdf5::Result<H5Dataset> {
        let b = group.new_dataset::<T>().shape(shape).chunk(chunk);
        match compression {
            CubeCompression::Deflate(level) if T::element_size() > 1 => {
                b.shuffle_deflate(level).create(name)
            }
            CubeCompression::Deflate(level) => b.deflate(level).create(name),
            CubeCompression::None => b.create(name),
        }
    }
    let mut chunk = shape.to_vec();
    chunk[0] = 1;
    match elem {
        Elem::F64 => make::<f64>(group, name, shape, &chunk, compression),
        Elem::U8 => make::<u8>(group, name, shape, &chunk, compression),
        Elem::U32 => make::<u32>(group, name, shape, &chunk, compression),
        Elem::I32 => make::<i32>(group, name, shape, &chunk, compression),
        _ => make::<f32>(group, name, shape, &chunk, compression),
    }
}

/// Little-endian bytes of elements `range` of `buf` ([`le_bytes`]).
pub(super) fn buf_le_bytes(
    buf: &DataBuf,
    range: std::ops::Range<usize>,
) -> std::borrow::Cow<'_, [u8]> {
    match buf {
        DataBuf::F32(v) => le_bytes(&v[range]),
        DataBuf::F64(v) => le_bytes(&v[range]),
        DataBuf::U8(v) => le_bytes(&v[range]),
        DataBuf::U32(v) => le_bytes(&v[range]),
        DataBuf::I32(v) => le_bytes(&v[range]),
    }
}

/// Write `buf` as rows `r0 ..` of a group dataset of shape `shape` (made by
/// [`create_group_dataset`]): each row is one chunk, compressed on rayon's threads and
/// stored as it is.
pub(super) fn write_group_rows(
    ds: &H5Dataset,
    shape: &[usize],
    compression: CubeCompression,
    r0: usize,
    buf: &DataBuf,
) -> rust_hdf5::Result<()> {
    let row_elems: usize = shape[1..].iter().product();
    let pipeline = group_pipeline(buf.elem(), compression);
    // Uncompressed rows are stored from `buf` itself (on little-endian machines).
    let chunks: Vec<std::borrow::Cow<[u8]>> = (0..buf.len() / row_elems)
        .into_par_iter()
        .map(|i| {
            let raw = buf_le_bytes(buf, i * row_elems..(i + 1) * row_elems);
            match &pipeline {
                Some(p) => apply_filters(p, &raw)
                    .expect("shuffle and deflate cannot fail on a whole chunk")
                    .into(),
                None => raw,
            }
        })
        .collect();
    let mut coords = vec![0; shape.len()];
    for (i, bytes) in chunks.iter().enumerate() {
        coords[0] = r0 + i;
        if pipeline.is_some() {
            ds.write_chunk_raw_at(&coords, bytes, 0)?;
        } else {
            ds.write_chunk_at(&coords, bytes)?;
        }
    }
    Ok(())
}

/// One dataset of a group being written, and which of its rows have been.
pub(super) struct OpenGroupDataset {
    group: String,
    name: String,
    ds: H5Dataset,
    shape: Vec<usize>,
    elem: Elem,
    compression: CubeCompression,
    rows_written: Vec<bool>,
}

/// The extra groups of a file being written, their datasets filled by row slabs.
#[derive(Default)]
pub(super) struct GroupSinks {
    /// Names of the groups created so far.
    pub(super) written: Vec<String>,
    pub(super) datasets: Vec<OpenGroupDataset>,
}

impl GroupSinks {
    pub(super) fn begin(
        &mut self,
        file: &H5File,
        path: &Path,
        name: &str,
        attrs: &[(String, AttrValue)],
        specs: &[DatasetSpec],
    ) -> Result<()> {
        let layout: Vec<(&str, &[usize])> = specs
            .iter()
            .map(|d| (d.name.as_str(), d.shape.as_slice()))
            .collect();
        check_group_layout(path, name, attrs, &layout)?;
        if self.written.iter().any(|g| g == name) {
            return Err(invalid(path, format!("group /{name} given twice")));
        }
        let e = h5(path);
        let group = file.create_group(name).map_err(&e)?;
        write_group_attrs(&group, attrs).map_err(&e)?;
        for d in specs {
            let ds = create_group_dataset(&group, &d.name, d.elem.elem(), &d.shape, d.compression)
                .map_err(&e)?;
            self.datasets.push(OpenGroupDataset {
                group: name.to_string(),
                name: d.name.clone(),
                ds,
                shape: d.shape.clone(),
                elem: d.elem.elem(),
                compression: d.compression,
                rows_written: vec![false; d.shape[0]],
            });
        }
        self.written.push(name.to_string());
        Ok(())
    }

    pub(super) fn write_rows(
        &mut self,
        path: &Path,
        group: &str,
        dataset: &str,
        r0: usize,
        rows: &DataBuf,
    ) -> Result<()> {
        let d = self
            .datasets
            .iter_mut()
            .find(|d| d.group == group && d.name == dataset)
            .ok_or_else(|| {
                invalid(
                    path,
                    format!("dataset /{group}/{dataset} was not declared by begin_group"),
                )
            })?;
        if rows.elem() != d.elem {
            return Err(invalid(
                path,
                format!(
                    "dataset /{group}/{dataset} holds {}, not {}",
                    d.elem.name(),
                    rows.type_name()
                ),
            ));
        }
        let row_elems: usize = d.shape[1..].iter().product();
        if rows.is_empty() || !rows.len().is_multiple_of(row_elems) {
            return Err(invalid(
                path,
                format!(
                    "{} values are not whole rows of {row_elems} of /{group}/{dataset}",
                    rows.len()
                ),
            ));
        }
        let n = rows.len() / row_elems;
        if r0 + n > d.shape[0] {
            return Err(invalid(
                path,
                format!(
                    "rows {r0}..{} past the {} rows of /{group}/{dataset}",
                    r0 + n,
                    d.shape[0]
                ),
            ));
        }
        write_group_rows(&d.ds, &d.shape, d.compression, r0, rows).map_err(h5(path))?;
        d.rows_written[r0..r0 + n].fill(true);
        Ok(())
    }

    pub(super) fn write_whole(
        &mut self,
        file: &H5File,
        path: &Path,
        name: &str,
        data: &GroupData,
    ) -> Result<()> {
        check_group(path, name, data)?;
        let specs: Vec<DatasetSpec> = data
            .datasets
            .iter()
            .map(|(n, shape, buf)| DatasetSpec::new(n.clone(), shape, buf.group_elem()))
            .collect();
        self.begin(file, path, name, &data.attrs, &specs)?;
        for (n, _, buf) in &data.datasets {
            self.write_rows(path, name, n, 0, buf)?;
        }
        Ok(())
    }

    /// Check that every row of every dataset was written, then release the datasets.
    pub(super) fn close(self, path: &Path) -> Result<()> {
        for d in &self.datasets {
            if let Some(r) = d.rows_written.iter().position(|w| !w) {
                let n = d.rows_written.iter().filter(|w| !**w).count();
                return Err(invalid(
                    path,
                    format!(
                        "{n} rows of /{}/{} were never written (first: row {r})",
                        d.group, d.name
                    ),
                ));
            }
        }
        Ok(())
    }
}

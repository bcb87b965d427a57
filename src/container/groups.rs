//! Reading extra groups: [`GroupReader`] of any HDF5 file (a cube file or a side file), which
//! a [`CubeReader`] owns for its groups.
//!
//! [`CubeReader`]: super::CubeReader

use super::attributes::read_group_attrs;
use super::error::{h5, invalid, ContainerError, Result};
use super::open::{dataset_elem, open_dataset, open_h5};
use super::schema::{AttrValue, DataBuf, Elem, GroupData, CUBE_DATASET};
use rust_hdf5::H5Dataset;
use rust_hdf5::H5File;
use rust_hdf5::H5Group;
use rust_hdf5::Hdf5Error;
use std::path::Path;
use std::path::PathBuf;

/// Reader of the extra groups of any HDF5 file: a cube file, or a side file that holds
/// groups only (e.g. `femto pyramid --side-file`), which [`CubeReader`] refuses for lack
/// of a `/cube`.
///
/// [`CubeReader`]: super::CubeReader
pub struct GroupReader {
    pub(super) file: H5File,
    pub(super) path: PathBuf,
    pub(super) groups: Vec<String>,
    pub(super) has_cube: bool,
}

impl GroupReader {
    /// Open the HDF5 file at `path` and list its groups.
    pub fn open(path: &Path) -> Result<GroupReader> {
        let file = open_h5(path)?;
        let root = file.root_group();
        let mut groups = root.group_names().map_err(h5(path))?;
        groups.sort();
        let has_cube = root
            .dataset_names()
            .map_err(h5(path))?
            .iter()
            .any(|n| n == CUBE_DATASET);
        Ok(GroupReader {
            file,
            path: path.to_path_buf(),
            groups,
            has_cube,
        })
    }

    /// Names of the groups at the file root, sorted.
    pub fn groups(&self) -> &[String] {
        &self.groups
    }

    /// Whether the file also holds a `/cube` dataset.
    pub fn has_cube(&self) -> bool {
        self.has_cube
    }

    /// Read one group whole.
    pub fn read_group(&self, name: &str) -> Result<GroupData> {
        read_group_in(&self.file, &self.path, name)
    }

    /// The attributes of group `name`, without reading its datasets.
    pub fn read_group_attrs(&self, name: &str) -> Result<Vec<(String, AttrValue)>> {
        let group = open_group(&self.file, &self.path, name)?;
        read_group_attrs(&group, &self.path, name)
    }

    /// Names of the datasets of group `name`, sorted.
    pub fn group_dataset_names(&self, name: &str) -> Result<Vec<String>> {
        let group = open_group(&self.file, &self.path, name)?;
        dataset_names_in(&group, &self.path, name)
    }

    /// Shape and element type name of dataset `dataset` of group `group`.
    pub fn group_dataset_shape(
        &self,
        group: &str,
        dataset: &str,
    ) -> Result<(Vec<usize>, &'static str)> {
        group_dataset_shape_in(&self.file, &self.path, group, dataset)
    }

    /// Read rows `r0 .. r0 + n` (along the first axis) of dataset `dataset` of group
    /// `group`, in row-major order.
    pub fn read_group_rows(
        &self,
        group: &str,
        dataset: &str,
        r0: usize,
        n: usize,
    ) -> Result<DataBuf> {
        read_group_rows_in(&self.file, &self.path, group, dataset, r0, n)
    }
}

pub(super) fn read_group_in(file: &H5File, path: &Path, name: &str) -> Result<GroupData> {
    let group = open_group(file, path, name)?;
    let attrs = read_group_attrs(&group, path, name)?;
    let mut datasets = Vec::new();
    for ds_name in dataset_names_in(&group, path, name)? {
        let (shape, _) = group_dataset_shape_in(file, path, name, &ds_name)?;
        let rows = shape[0];
        let data = read_group_rows_in(file, path, name, &ds_name, 0, rows)?;
        datasets.push((ds_name, shape, data));
    }
    Ok(GroupData { attrs, datasets })
}

pub(super) fn open_group(file: &H5File, path: &Path, name: &str) -> Result<H5Group> {
    file.root_group().group(name).map_err(|e| match e {
        Hdf5Error::NotFound(_) => ContainerError::NoGroup {
            path: path.to_path_buf(),
            group: name.to_string(),
        },
        other => h5(path)(other),
    })
}

pub(super) fn dataset_names_in(group: &H5Group, path: &Path, name: &str) -> Result<Vec<String>> {
    let sub = group.group_names().map_err(h5(path))?;
    if let Some(s) = sub.first() {
        return Err(invalid(
            path,
            format!("group /{name} holds a nested group /{name}/{s}, which femto does not read"),
        ));
    }
    let mut names = group.dataset_names().map_err(h5(path))?;
    names.sort();
    Ok(names)
}

pub(super) fn group_dataset_shape_in(
    file: &H5File,
    path: &Path,
    group: &str,
    dataset: &str,
) -> Result<(Vec<usize>, &'static str)> {
    let full = format!("{group}/{dataset}");
    open_group(file, path, group)?;
    let ds = open_dataset(file, path, &full)?;
    let elem = group_elem(&ds, path, &full)?;
    let shape = ds.shape();
    if shape.is_empty() {
        return Err(ContainerError::WrongRank {
            path: path.to_path_buf(),
            dataset: full,
            found: 0,
            expected: 1,
        });
    }
    Ok((shape, elem.name()))
}

pub(super) fn read_group_rows_in(
    file: &H5File,
    path: &Path,
    group: &str,
    dataset: &str,
    r0: usize,
    n: usize,
) -> Result<DataBuf> {
    let (shape, _) = group_dataset_shape_in(file, path, group, dataset)?;
    let full = format!("{group}/{dataset}");
    if r0 + n > shape[0] {
        return Err(invalid(
            path,
            format!(
                "rows {r0}..{} past the {} rows of /{full}",
                r0 + n,
                shape[0]
            ),
        ));
    }
    let ds = open_dataset(file, path, &full)?;
    let elem = group_elem(&ds, path, &full)?;
    let mut starts = vec![0; shape.len()];
    starts[0] = r0;
    let mut counts = shape.clone();
    counts[0] = n;
    if n == 0 {
        return Ok(empty_buf(elem));
    }
    let e = h5(path);
    Ok(match elem {
        Elem::F32 => DataBuf::F32(ds.read_slice(&starts, &counts).map_err(e)?),
        Elem::F64 => DataBuf::F64(ds.read_slice(&starts, &counts).map_err(e)?),
        Elem::U8 => DataBuf::U8(ds.read_slice(&starts, &counts).map_err(e)?),
        Elem::U32 => DataBuf::U32(ds.read_slice(&starts, &counts).map_err(e)?),
        Elem::I32 => DataBuf::I32(ds.read_slice(&starts, &counts).map_err(e)?),
        _ => unreachable!("group_elem admits the DataBuf types only"),
    })
}

pub(super) fn empty_buf(elem: Elem) -> DataBuf {
    match elem {
        Elem::F64 => DataBuf::F64(Vec::new()),
        Elem::U8 => DataBuf::U8(Vec::new()),
        Elem::U32 => DataBuf::U32(Vec::new()),
        Elem::I32 => DataBuf::I32(Vec::new()),
        _ => DataBuf::F32(Vec::new()),
    }
}

/// The element type of a group dataset, which must be one [`DataBuf`] can hold.
pub(super) fn group_elem(ds: &H5Dataset, path: &Path, full: &str) -> Result<Elem> {
    let (elem, found) = dataset_elem(ds, path)?;
    match elem {
        Some(e @ (Elem::F32 | Elem::F64 | Elem::U8 | Elem::U32 | Elem::I32)) => Ok(e),
        _ => Err(ContainerError::WrongType {
            path: path.to_path_buf(),
            dataset: full.to_string(),
            found,
            expected: "f32, f64, u8, u32 or i32".into(),
        }),
    }
}

//! The HDF5 reading that the array readers share (HyperSpy, MATLAB v7.3, plain datasets):
//! opening a file (a user block before the superblock included), a numeric dataset into an
//! [`Array`], scalar datasets, and numeric, string and boolean attributes of groups and
//! datasets. femto's own cube files are read by `container/`.

use super::array::{element_count, Array};
use super::dtype::{decode, Dtype};

use super::ReaderError;
use rust_hdf5::{ByteOrder, DatatypeMessage, H5Attribute, H5Dataset, H5File};
use std::path::Path;

pub(super) fn h5err(path: &Path) -> impl Fn(rust_hdf5::Hdf5Error) -> ReaderError + '_ {
    move |e| ReaderError::Hdf5 {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Open the HDF5 file at `path` for reading.
pub(super) fn open(path: &Path) -> Result<H5File, ReaderError> {
    match crate::container::is_hdf5(path) {
        Err(source) => Err(ReaderError::Io {
            path: path.to_path_buf(),
            source,
        }),
        Ok(false) => Err(ReaderError::invalid(path, "file", "not an HDF5 file")),
        Ok(true) => H5File::options()
            .best_effort_locking()
            .open(path)
            .map_err(h5err(path)),
    }
}

/// The sample type of an HDF5 datatype (enums by their base), and whether it is big-endian.
pub(super) fn dtype_of(dt: &DatatypeMessage) -> Option<(Dtype, bool)> {
    match dt {
        DatatypeMessage::Enum { base, .. } => dtype_of(base),
        DatatypeMessage::FixedPoint {
            size,
            signed,
            byte_order,
            ..
        } => Some((
            Dtype::from_parts(false, *signed, *size as usize)?,
            *byte_order == ByteOrder::BigEndian,
        )),
        DatatypeMessage::FloatingPoint {
            size, byte_order, ..
        } => Some((
            Dtype::from_parts(true, true, *size as usize)?,
            *byte_order == ByteOrder::BigEndian,
        )),
        _ => None,
    }
}

/// Whether the dataset holds numbers (integers, floats, enums of them).
pub(super) fn is_numeric(ds: &H5Dataset) -> bool {
    ds.datatype().ok().as_ref().and_then(dtype_of).is_some()
}

/// Read the numeric dataset `name` into a C-order array (`column_major`: reorder from
/// MATLAB's storage, whose HDF5 dimensions are the array's reversed).
pub(super) fn read_array(
    file: &H5File,
    path: &Path,
    name: &str,
    column_major: bool,
) -> Result<Array, ReaderError> {
    let ds = file
        .dataset(name)
        .map_err(|_| ReaderError::invalid(path, name, "no such dataset".to_string()))?;
    let dt = ds.datatype().map_err(h5err(path))?;
    let (dtype, big) = dtype_of(&dt).ok_or_else(|| {
        ReaderError::invalid(path, name, format!("not a numeric dataset ({dt:?})"))
    })?;
    let mut shape = ds.shape();
    let count = element_count(&shape)
        .ok_or_else(|| ReaderError::invalid(path, name, format!("shape {shape:?} overflows")))?;
    crate::limits::check_memory(
        (dtype.size() + 8) as f64 * count as f64,
        format!("the dataset /{name} of {shape:?} values"),
        "crop it first",
    )
    .map_err(|source| ReaderError::Limit {
        path: path.to_path_buf(),
        source,
    })?;
    let bytes = ds.read_raw_bytes().map_err(h5err(path))?;
    if bytes.len() != count * dtype.size() {
        return Err(ReaderError::invalid(
            path,
            name,
            format!(
                "{} bytes of values for shape {shape:?} ({} expected)",
                bytes.len(),
                count * dtype.size()
            ),
        ));
    }
    if column_major {
        shape.reverse();
    }
    Ok(Array::new(
        shape,
        dtype,
        decode(&bytes, dtype, big),
        column_major,
    ))
}

/// The value of a dataset holding one number (shape `()` or one element), if it does.
pub(super) fn scalar_dataset(file: &H5File, name: &str) -> Option<f64> {
    let ds = file.dataset(name).ok()?;
    let (dtype, big) = dtype_of(&ds.datatype().ok()?)?;
    if element_count(&ds.shape())? != 1 {
        return None;
    }
    let bytes = ds.read_raw_bytes().ok()?;
    let v = super::dtype::value_f64(&bytes, dtype, big)?;
    Some(v)
}

/// An attribute's value, as femto keeps it.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Attr {
    Number(f64),
    Numbers(Vec<f64>),
    Text(String),
}

/// Read one attribute: numbers (h5py's booleans are enums of int8: 0 or 1), or text.
pub(super) fn read_attr(attr: &H5Attribute) -> Option<Attr> {
    let dt = attr.datatype().ok()?;
    if matches!(
        dt,
        DatatypeMessage::VarLenString { .. } | DatatypeMessage::FixedString { .. }
    ) {
        return attr.read_string().ok().map(Attr::Text);
    }
    let (dtype, big) = dtype_of(&dt)?;
    let bytes = attr.read_raw().ok()?;
    let values: Vec<f64> = bytes
        .chunks_exact(dtype.size())
        .filter_map(|b| super::dtype::value_f64(b, dtype, big))
        .collect();
    match values.as_slice() {
        [v] => Some(Attr::Number(*v)),
        _ => Some(Attr::Numbers(values)),
    }
}

/// The attributes of the group at `group` (`""` or `"/"` for the root), by name.
pub(super) fn group_attrs(file: &H5File, group: &str) -> Vec<(String, Attr)> {
    let g = if group.trim_matches('/').is_empty() {
        file.root_group()
    } else {
        match file.root_group().group(group.trim_matches('/')) {
            Ok(g) => g,
            Err(_) => return Vec::new(),
        }
    };
    let names = g.attr_names().unwrap_or_default();
    names
        .into_iter()
        .filter_map(|n| {
            let a = g.attr(&n).ok()?;
            Some((n, read_attr(&a)?))
        })
        .collect()
}

/// The attributes of the dataset `name`, by name.
pub(super) fn dataset_attrs(file: &H5File, name: &str) -> Vec<(String, Attr)> {
    let Ok(ds) = file.dataset(name) else {
        return Vec::new();
    };
    ds.attr_names()
        .unwrap_or_default()
        .into_iter()
        .filter_map(|n| {
            let a = ds.attr(&n).ok()?;
            Some((n, read_attr(&a)?))
        })
        .collect()
}

/// Every dataset of the file, full names without the leading `/`, with its shape.
pub(super) fn datasets(file: &H5File) -> Vec<(String, Vec<usize>, bool)> {
    file.dataset_names()
        .into_iter()
        .filter_map(|n| {
            let name = n.trim_start_matches('/').to_string();
            let ds = file.dataset(&name).ok()?;
            Some((name, ds.shape(), is_numeric(&ds)))
        })
        .collect()
}

/// The values of a numeric dataset as f64 (an explicit axis, in full precision).
pub(super) fn read_f64s(file: &H5File, path: &Path, name: &str) -> Result<Vec<f64>, ReaderError> {
    let ds = file
        .dataset(name)
        .map_err(|_| ReaderError::invalid(path, name, "no such dataset"))?;
    let dt = ds.datatype().map_err(h5err(path))?;
    let (dtype, big) = dtype_of(&dt)
        .ok_or_else(|| ReaderError::invalid(path, name, format!("not numeric ({dt:?})")))?;
    let count = ds
        .shape()
        .iter()
        .try_fold(1u128, |a, &n| a.checked_mul(n as u128));
    super::check_bytes(
        path,
        count.and_then(|c| c.checked_mul(dtype.size() as u128 + 8)),
        &format!("the axis /{name} of {:?} values", ds.shape()),
    )?;
    let bytes = ds.read_raw_bytes().map_err(h5err(path))?;
    Ok(bytes
        .chunks_exact(dtype.size())
        .filter_map(|b| super::dtype::value_f64(b, dtype, big))
        .collect())
}

/// The shape and sample type of the numeric dataset `name`, if it is one.
pub(super) fn dataset_type(file: &H5File, name: &str) -> Option<(Vec<usize>, Dtype)> {
    let ds = file.dataset(name.trim_start_matches('/')).ok()?;
    let (dtype, _) = dtype_of(&ds.datatype().ok()?)?;
    Some((ds.shape(), dtype))
}

/// A text attribute of dataset `name` (`CLASS`, `UNIT`), bytes or string.
pub(super) fn text_attr(file: &H5File, name: &str, key: &str) -> Option<String> {
    dataset_attrs(file, name)
        .into_iter()
        .find_map(|(k, v)| match v {
            Attr::Text(s) if k == key => Some(s),
            _ => None,
        })
}

/// Whether dataset `name` is an HDF5 dimension scale (`CLASS = "DIMENSION_SCALE"`): an axis
/// of another dataset, never data.
pub(super) fn is_dimension_scale(file: &H5File, name: &str) -> bool {
    text_attr(file, name, "CLASS").is_some_and(|c| c.trim_end_matches('\0') == "DIMENSION_SCALE")
}

/// The dimension labels of dataset `name` (`DIMENSION_LABELS`, as h5py's `dims[i].label`
/// writes them), one per dimension; `None` when it has none.
pub(super) fn dimension_labels(file: &H5File, name: &str) -> Option<Vec<String>> {
    let ds = file.dataset(name.trim_start_matches('/')).ok()?;
    let a = ds.attr("DIMENSION_LABELS").ok()?;
    let labels = a.read_strings().ok()?;
    let labels: Vec<String> = labels
        .into_iter()
        .map(|l| l.trim_end_matches('\0').to_string())
        .collect();
    (labels.len() == ds.shape().len()).then_some(labels)
}

//! Image stacks: the 3-D datasets of streak images that `femto ingest` reads from HDF5 files.

use super::error::{h5, ContainerError, Result};
use super::open::{dataset_elem, open_dataset, open_h5};
use super::schema::Elem;
use std::path::Path;

/// Read a 3-D stack of streak images stored in one dataset, converting u8, u16, u32, i32,
/// f32 or f64 values to f32. Returns the dataset's shape and its values in row-major order.
pub fn read_image_stack(path: &Path, dataset: &str) -> Result<(Vec<usize>, Vec<f32>)> {
    let file = open_h5(path)?;
    let name = dataset.trim_start_matches('/');
    let ds = open_dataset(&file, path, name)?;
    let shape = ds.shape();
    if shape.len() != 3 {
        return Err(ContainerError::WrongRank {
            path: path.to_path_buf(),
            dataset: name.to_string(),
            found: shape.len(),
            expected: 3,
        });
    }
    let (elem, found) = dataset_elem(&ds, path)?;
    // The raw values and their f32 copy are held together: at most 8 + 4 bytes a value,
    // three float32 copies (exact arithmetic, before anything is read).
    crate::limits::check_decoded(
        &shape,
        4,
        3,
        format_args!("the image stack /{name} of {shape:?} values"),
        "split the stack into several datasets, or ingest its images as files",
    )
    .map_err(|source| ContainerError::Limit {
        path: path.to_path_buf(),
        source,
    })?;
    let e = h5(path);
    let values: Vec<f32> = match elem {
        Some(Elem::U8) => convert(ds.read_raw::<u8>().map_err(e)?, f32::from),
        Some(Elem::U16) => convert(ds.read_raw::<u16>().map_err(e)?, f32::from),
        Some(Elem::U32) => convert(ds.read_raw::<u32>().map_err(e)?, |v| v as f32),
        Some(Elem::I32) => convert(ds.read_raw::<i32>().map_err(e)?, |v| v as f32),
        Some(Elem::F32) => ds.read_raw::<f32>().map_err(e)?,
        Some(Elem::F64) => convert(ds.read_raw::<f64>().map_err(e)?, |v| v as f32),
        _ => {
            return Err(ContainerError::WrongType {
                path: path.to_path_buf(),
                dataset: name.to_string(),
                found,
                expected: "u8, u16, u32, i32, f32 or f64".into(),
            })
        }
    };
    Ok((shape, values))
}

pub(super) fn convert<T: Copy>(v: Vec<T>, f: impl Fn(T) -> f32) -> Vec<f32> {
    v.into_iter().map(f).collect()
}

//! What other tools wrote into a cube file: the root attributes, and the groups and datasets
//! that are not femto's (`/cube`, `/mask`, `/registration`, `/pyramid`), such as the notes
//! an h5py user adds. A command that writes a new cube from an old one copies them into it
//! ([`super::CubeWriter::keep_foreign_from`]), so that they survive it.
//!
//! Attributes are copied with their HDF5 type: every fixed-size type (integers, floats,
//! enums such as h5py's bool, fixed-length strings) as its bytes, variable-length strings
//! (h5py's `str` and lists of `str`) as strings. Datasets of a fixed-size type are copied
//! whole with their attributes, groups recursively. Anything else (a reference, a
//! variable-length sequence, a link to another file) is refused by name rather than
//! dropped.

use super::error::{h5, invalid, Result};
use super::schema::{CUBE_DATASET, MASK_DATASET};
use rust_hdf5::DatatypeMessage;
use rust_hdf5::H5Attribute;
use rust_hdf5::H5Dataset;
use rust_hdf5::H5File;
use rust_hdf5::H5Group;
use rust_hdf5::H5Type;
use std::path::Path;

/// The root objects femto writes (and rewrites) itself; everything else at the root is
/// another tool's.
pub(super) const FEMTO_OBJECTS: [&str; 4] = [CUBE_DATASET, MASK_DATASET, "registration", "pyramid"];

/// An attribute read from the source file, ready to be written.
enum AttrCopy {
    /// Fixed-size elements: type, dimensions (empty: scalar), bytes.
    Raw(DatatypeMessage, Vec<u64>, Vec<u8>),
    /// Variable-length strings: type (its character set), dimensions (empty: scalar),
    /// values.
    Strings(DatatypeMessage, Vec<u64>, Vec<String>),
}

fn read_attr(attr: &H5Attribute, path: &Path, object: &str) -> Result<AttrCopy> {
    let e = h5(path);
    let dt = attr.datatype().map_err(&e)?;
    let dims = attr.dims().map_err(&e)?;
    match dt {
        DatatypeMessage::VarLenString { .. } => {
            let values = attr.read_strings().map_err(&e)?;
            Ok(AttrCopy::Strings(dt, dims, values))
        }
        DatatypeMessage::FixedPoint { .. }
        | DatatypeMessage::FloatingPoint { .. }
        | DatatypeMessage::Enum { .. }
        | DatatypeMessage::FixedString { .. }
        | DatatypeMessage::BitField { .. } => {
            Ok(AttrCopy::Raw(dt, dims, attr.read_raw().map_err(&e)?))
        }
        other => Err(invalid(
            path,
            format!(
                "attribute '{}' of {object} is of a type femto cannot carry into the new \
                 cube ({other})",
                attr.name()
            ),
        )),
    }
}

/// Where copied attributes go: a group (the root included) or a dataset being written.
trait AttrSink {
    fn put(&self, name: &str, value: AttrCopy) -> rust_hdf5::Result<()>;
}

/// Groups and datasets being written take attributes through the same two calls.
macro_rules! attr_sink {
    ($t:ty) => {
        impl AttrSink for $t {
            fn put(&self, name: &str, value: AttrCopy) -> rust_hdf5::Result<()> {
                match value {
                    AttrCopy::Raw(dt, dims, bytes) => self.set_attr_raw(name, dt, &dims, bytes),
                    AttrCopy::Strings(dt, dims, values) => {
                        let v: Vec<&str> = values.iter().map(String::as_str).collect();
                        self.set_attr_strings_as(name, &v, &dims, dt)
                    }
                }
            }
        }
    };
}
attr_sink!(H5Group);
attr_sink!(H5Dataset);

/// Copy what other tools wrote in `src` (at `src_path`) into `dst` (being written to
/// `dst_path`): the root attributes, and every root group and dataset not in
/// [`FEMTO_OBJECTS`] nor in `skip`, recursively.
pub(super) fn copy_foreign(
    src: &H5File,
    src_path: &Path,
    dst: &H5File,
    dst_path: &Path,
    skip: &[String],
) -> Result<()> {
    let es = h5(src_path);
    let ed = h5(dst_path);
    let root = src.root_group();
    let dst_root = dst.root_group();
    for name in root.attr_names().map_err(&es)? {
        let value = read_attr(&root.attr(&name).map_err(&es)?, src_path, "/")?;
        dst_root.put(&name, value).map_err(&ed)?;
    }
    copy_children(src, src_path, "", dst_path, &dst_root, Some(skip))
}

/// Copy the groups and datasets in group `prefix` of `src` into `into` (a group of the file
/// being written to `dst_path`).
fn copy_children(
    src: &H5File,
    src_path: &Path,
    prefix: &str,
    dst_path: &Path,
    into: &H5Group,
    root_skip: Option<&[String]>,
) -> Result<()> {
    let es = h5(src_path);
    let ed = h5(dst_path);
    let group = if prefix.is_empty() {
        src.root_group()
    } else {
        src.root_group().group(prefix).map_err(&es)?
    };
    let skip =
        |n: &str| root_skip.is_some_and(|s| FEMTO_OBJECTS.contains(&n) || s.iter().any(|o| o == n));
    let full_name = |name: &str| {
        if prefix.is_empty() {
            name.to_string()
        } else {
            format!("{prefix}/{name}")
        }
    };
    for name in group.dataset_names().map_err(&es)? {
        if skip(&name) {
            continue;
        }
        let full = full_name(&name);
        let ds = src.dataset(&full).map_err(&es)?;
        copy_dataset(&ds, src_path, &full, into, dst_path, &name)?;
    }
    for name in group.group_names().map_err(&es)? {
        if skip(&name) {
            continue;
        }
        let full = full_name(&name);
        let src_group = src.root_group().group(&full).map_err(&es)?;
        let dst_group = into.create_group(&name).map_err(&ed)?;
        for a in src_group.attr_names().map_err(&es)? {
            let value = read_attr(
                &src_group.attr(&a).map_err(&es)?,
                src_path,
                &format!("/{full}"),
            )?;
            dst_group.put(&a, value).map_err(&ed)?;
        }
        copy_children(src, src_path, &full, dst_path, &dst_group, None)?;
    }
    Ok(())
}

/// Copy dataset `ds` (at `full` in the source) into `into` as `name`, with its attributes.
fn copy_dataset(
    ds: &H5Dataset,
    src_path: &Path,
    full: &str,
    into: &H5Group,
    dst_path: &Path,
    name: &str,
) -> Result<()> {
    let es = h5(src_path);
    let ed = h5(dst_path);
    let dt = ds.datatype().map_err(&es)?;
    let shape = ds.shape();
    let refuse = |what: String| {
        invalid(
            src_path,
            format!("dataset /{full} is {what}, which femto cannot carry into the new cube"),
        )
    };
    let fixed = matches!(
        dt,
        DatatypeMessage::FixedPoint { .. }
            | DatatypeMessage::FloatingPoint { .. }
            | DatatypeMessage::Enum { .. }
            | DatatypeMessage::FixedString { .. }
            | DatatypeMessage::BitField { .. }
    );
    if !fixed {
        return Err(refuse(format!("of type {dt}")));
    }
    let bytes = ds.read_raw_bytes().map_err(&es)?;
    // The element type only sizes the builder; the dataset takes the source's type.
    fn create<T: H5Type>(
        into: &H5Group,
        dt: &DatatypeMessage,
        shape: &[usize],
        name: &str,
    ) -> rust_hdf5::Result<H5Dataset> {
        into.new_dataset::<T>()
            .datatype(dt.clone())
            .shape(shape)
            .create(name)
    }
    let out = match dt.element_size() {
        1 => create::<u8>(into, &dt, &shape, name),
        2 => create::<u16>(into, &dt, &shape, name),
        4 => create::<u32>(into, &dt, &shape, name),
        8 => create::<u64>(into, &dt, &shape, name),
        n => return Err(refuse(format!("made of {n}-byte elements"))),
    }
    .map_err(&ed)?;
    out.write_raw_bytes(&bytes).map_err(&ed)?;
    for a in ds.attr_names().map_err(&es)? {
        let value = read_attr(&ds.attr(&a).map_err(&es)?, src_path, &format!("/{full}"))?;
        out.put(&a, value).map_err(&ed)?;
    }
    Ok(())
}

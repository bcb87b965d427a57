//! Typed contents of the extra groups of a cube file (docs/cube-format.md, "Extra groups"):
//! the `registration` group that `femto calibrate` writes ([`registration`]) and the `pyramid`
//! group or side file of `femto pyramid` ([`pyramid`]).
//!
//! [`crate::container`] moves untyped groups ([`crate::container::GroupData`]) in and out of
//! HDF5; this module fixes their schemas, turns the library's typed values
//! ([`crate::calibrate::Registration`], [`crate::camera::Calibration`],
//! [`crate::pyramid::Pyramid`]) into groups and back, and checks what it reads, so that a
//! group written by another tool or an older femto is refused with a message that names the
//! file, the group and what is wrong.

pub mod pyramid;
pub mod registration;

use crate::container::{AttrValue, ContainerError, DataBuf, GroupData};
use std::path::{Path, PathBuf};

/// Errors of reading or writing a typed group.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// The file could not be read or written (see [`ContainerError`]).
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// A group does not follow its schema: a missing or mistyped attribute or dataset, or a
    /// dataset of the wrong shape.
    #[error("{}: group /{group}: {message}", path.display())]
    Schema {
        path: PathBuf,
        group: String,
        message: String,
    },
    /// Stored data does not fit the cube it is used with (another pixel grid or time axis).
    #[error("{}: {message}", path.display())]
    Mismatch { path: PathBuf, message: String },
}

/// Reads the attributes and datasets of one group, naming the file and group in errors.
pub(crate) struct GroupView<'a> {
    pub path: &'a Path,
    pub group: &'a str,
    pub data: &'a GroupData,
}

impl GroupView<'_> {
    pub fn schema(&self, message: impl Into<String>) -> StoreError {
        StoreError::Schema {
            path: self.path.to_path_buf(),
            group: self.group.to_string(),
            message: message.into(),
        }
    }

    pub fn f64(&self, name: &str) -> Result<f64, StoreError> {
        match self.data.attr(name) {
            Some(AttrValue::F64(v)) => Ok(*v),
            Some(AttrValue::I64(v)) => Ok(*v as f64),
            Some(_) => Err(self.schema(format!("attribute '{name}' is not a number"))),
            None => Err(self.schema(format!("no attribute '{name}'"))),
        }
    }

    /// Attribute `name`, a number in `range` ([`crate::ranges`]).
    pub fn f64_in(&self, name: &str, range: crate::ranges::Range) -> Result<f64, StoreError> {
        let x = self.f64(name)?;
        crate::ranges::check(format_args!("attribute '{name}'"), x, range)
            .map_err(|e| self.schema(e.to_string()))
    }

    pub fn usize(&self, name: &str) -> Result<usize, StoreError> {
        match self.data.attr(name) {
            Some(AttrValue::I64(v)) if *v >= 0 => Ok(*v as usize),
            Some(_) => {
                Err(self.schema(format!("attribute '{name}' is not a non-negative integer")))
            }
            None => Err(self.schema(format!("no attribute '{name}'"))),
        }
    }

    pub fn str(&self, name: &str) -> Result<&str, StoreError> {
        match self.data.attr(name) {
            Some(AttrValue::Str(s)) => Ok(s),
            Some(_) => Err(self.schema(format!("attribute '{name}' is not a string"))),
            None => Err(self.schema(format!("no attribute '{name}'"))),
        }
    }

    /// Dataset `name`, which must have shape `shape`.
    pub fn dataset(&self, name: &str, shape: &[usize]) -> Result<&DataBuf, StoreError> {
        let (found, buf) = self
            .data
            .dataset(name)
            .ok_or_else(|| self.schema(format!("no dataset '{name}'")))?;
        if found != shape {
            return Err(self.schema(format!(
                "dataset '{name}' has shape {found:?}, expected {shape:?}"
            )));
        }
        Ok(buf)
    }

    /// Dataset `name`, which must have shape `shape` and elements of type `T`.
    pub fn typed<T: Elem>(&self, name: &str, shape: &[usize]) -> Result<&[T], StoreError> {
        let buf = self.dataset(name, shape)?;
        T::of(buf).ok_or_else(|| {
            self.schema(format!(
                "dataset '{name}' holds {}, expected {}",
                buf.type_name(),
                T::NAME
            ))
        })
    }
}

/// Element types of a dataset read through [`GroupView::typed`].
pub(crate) trait Elem: Sized {
    /// The type's name in errors, as [`DataBuf::type_name`] gives it.
    const NAME: &'static str;
    /// The values of `buf` when it holds this type.
    fn of(buf: &DataBuf) -> Option<&[Self]>;
}

macro_rules! elem {
    ($t:ty, $variant:ident, $name:literal) => {
        impl Elem for $t {
            const NAME: &'static str = $name;
            fn of(buf: &DataBuf) -> Option<&[Self]> {
                match buf {
                    DataBuf::$variant(v) => Some(v),
                    _ => None,
                }
            }
        }
    };
}
elem!(f32, F32, "f32");
elem!(f64, F64, "f64");
elem!(u8, U8, "u8");
elem!(u32, U32, "u32");

/// An attribute entry.
pub(crate) fn attr(name: &str, value: AttrValue) -> (String, AttrValue) {
    (name.to_string(), value)
}

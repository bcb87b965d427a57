//! The arrays of a file that could be its data ([`candidates`]): every numeric array of 1 to 5
//! dimensions holding more than one value, with its shape. An RGB(A) picture (uint8 or
//! uint16 with a last axis of 3 or 4, as a preview or thumbnail is stored) is never one, nor
//! an HDF5 dimension scale (an axis of another dataset). A `1 x N` array is one pixel's
//! histogram. When the user names none, the only candidate is read; several are listed in
//! one line ([`choose`]).

use super::{delmic, h5, hspy, mat, npy, npz, Dtype, Format, ReaderError};
use std::path::Path;

/// An array that could be the data.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidate {
    /// As `--dataset` takes it (`/group/name` for HDF5, the variable, the `.npz` member).
    pub name: String,
    pub shape: Vec<usize>,
    pub dtype: Dtype,
}

impl Candidate {
    /// `/counts [901, 1] uint16` (`(one pixel's histogram)` for a 1 x N array).
    pub fn describe(&self) -> String {
        let long = self.shape.iter().filter(|&&n| n > 1).count();
        let one_pixel = if long == 1 && self.shape.len() > 1 {
            " (one pixel's histogram)"
        } else {
            ""
        };
        format!(
            "{} {:?} {}{one_pixel}",
            self.name,
            self.shape,
            self.dtype.name()
        )
    }
}

/// Whether an array of `shape` and `dtype` is a picture (RGB or RGBA), never data.
pub fn is_picture(shape: &[usize], dtype: Dtype) -> bool {
    shape.len() >= 3
        && matches!(dtype, Dtype::U8 | Dtype::U16)
        && matches!(shape.last(), Some(3 | 4))
}

/// Whether an array of `shape` could be data: 1 to 5 dimensions, more than one value, not a
/// picture whose other axes are far longer than its colour axis.
fn could_be_data(shape: &[usize], dtype: Dtype) -> bool {
    let Some(&colours) = shape.last() else {
        return false;
    };
    let count = shape.iter().try_fold(1usize, |a, &n| a.checked_mul(n));
    // In u128: a crafted shape's lengths may be near 2^64.
    let wide = shape
        .iter()
        .rev()
        .skip(1)
        .any(|&n| n as u128 >= 2 * colours as u128);
    shape.len() <= 5 && count.unwrap_or(0) > 1 && !(is_picture(shape, dtype) && wide)
}

/// The candidate arrays of the file at `path`, read as `format`.
pub fn candidates(path: &Path, format: Format) -> Result<Vec<Candidate>, ReaderError> {
    let keep = |c: &Candidate| could_be_data(&c.shape, c.dtype);
    let all: Vec<Candidate> = match format {
        Format::Npy => {
            let (shape, dtype) = npy::header_of(path)?;
            vec![Candidate {
                name: String::new(),
                shape,
                dtype,
            }]
        }
        Format::Ptu => vec![],
        Format::Npz => npz::members(path)?
            .into_iter()
            .map(|(name, shape, dtype)| Candidate { name, shape, dtype })
            .collect(),
        Format::Mat => mat::read_mat(path, &|_| false)?
            .into_iter()
            .filter_map(|v| {
                Some(Candidate {
                    dtype: v.dtype?,
                    name: v.name,
                    shape: v.dims,
                })
            })
            .collect(),
        Format::Hspy => {
            let file = h5::open(path)?;
            hspy::signals(&file)
                .into_iter()
                .filter_map(|s| {
                    let (shape, dtype) = h5::dataset_type(&file, &format!("Experiments/{s}/data"))?;
                    Some(Candidate {
                        name: s,
                        shape,
                        dtype,
                    })
                })
                .collect()
        }
        Format::Delmic => {
            let file = h5::open(path)?;
            delmic::acquisitions(&file)
                .into_iter()
                .filter_map(|a| {
                    let (shape, dtype) = h5::dataset_type(&file, &delmic::image_of(&a))?;
                    Some(Candidate {
                        name: a,
                        shape,
                        dtype,
                    })
                })
                .collect()
        }
        Format::Hdf5Array => {
            let file = h5::open(path)?;
            h5::datasets(&file)
                .into_iter()
                .filter(|(n, _, numeric)| *numeric && !h5::is_dimension_scale(&file, n))
                .filter_map(|(n, _, _)| {
                    let (shape, dtype) = h5::dataset_type(&file, &n)?;
                    Some(Candidate {
                        name: format!("/{n}"),
                        shape,
                        dtype,
                    })
                })
                .collect()
        }
    };
    Ok(all.into_iter().filter(keep).collect())
}

/// The candidate to read: the one named `want` (checked to be a candidate or at least a
/// numeric array of the file), else the only one; several or none are refused in one line
/// that lists them. `kind` names a candidate in messages (`variable`, `dataset`).
pub fn choose<'a>(
    path: &Path,
    found: &'a [Candidate],
    want: Option<&str>,
    kind: &str,
) -> Result<&'a Candidate, ReaderError> {
    let list = || {
        found
            .iter()
            .map(Candidate::describe)
            .collect::<Vec<_>>()
            .join(", ")
    };
    match want {
        Some(w) => {
            let bare = |n: &str| n.trim_start_matches('/').to_string();
            found.iter().find(|c| bare(&c.name) == bare(w)).ok_or_else(|| {
                ReaderError::choice(
                    path,
                    "--dataset",
                    if found.is_empty() {
                        format!("no {kind} {w}; the file holds no numeric array of 1 to 5 dimensions")
                    } else {
                        format!("no {kind} {w} that could be data; the candidates: {}", list())
                    },
                )
            })
        }
        None => match found {
            [one] => Ok(one),
            [] => Err(ReaderError::choice(
                path,
                "data",
                format!(
                    "the file holds no numeric array of 1 to 5 dimensions with more than one \
                     value (pictures and axes left out), so no {kind} to read"
                ),
            )),
            _ => Err(ReaderError::choice(
                path,
                "data",
                format!(
                    "{} {kind}s could be the data; name one with --dataset NAME: {}",
                    found.len(),
                    list()
                ),
            )),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pictures_and_single_values_are_not_data() {
        assert!(is_picture(&[512, 512, 3], Dtype::U8));
        assert!(is_picture(&[10, 64, 64, 4], Dtype::U16));
        assert!(!is_picture(&[512, 512, 3], Dtype::F32));
        assert!(!is_picture(&[64, 64, 2048], Dtype::U16));
        assert!(!could_be_data(&[1, 1], Dtype::F64));
        assert!(could_be_data(&[1, 65536], Dtype::F64));
        assert!(!could_be_data(&[2, 2, 2, 2, 2, 2], Dtype::F64));
        let c = Candidate {
            name: "out".into(),
            shape: vec![1, 65536],
            dtype: Dtype::F64,
        };
        assert_eq!(
            c.describe(),
            "out [1, 65536] float64 (one pixel's histogram)"
        );
    }

    #[test]
    fn the_only_candidate_is_chosen_and_several_are_listed() {
        let p = Path::new("f.h5");
        let a = Candidate {
            name: "/a".into(),
            shape: vec![4, 5],
            dtype: Dtype::U16,
        };
        let b = Candidate {
            name: "/b".into(),
            shape: vec![9],
            dtype: Dtype::F32,
        };
        assert_eq!(
            choose(p, std::slice::from_ref(&a), None, "dataset").unwrap(),
            &a
        );
        let two = [a.clone(), b.clone()];
        let err = choose(p, &two, None, "dataset").unwrap_err().to_string();
        assert!(
            err.contains("/a [4, 5] uint16") && err.contains("/b [9] float32"),
            "{err}"
        );
        assert!(err.contains("--dataset"), "{err}");
        assert_eq!(choose(p, &two, Some("b"), "dataset").unwrap(), &b);
        assert!(choose(p, &two, Some("c"), "dataset").is_err());
    }
}

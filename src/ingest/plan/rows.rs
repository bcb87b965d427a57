//! The scanlines of an input, before and at the first read: where each one comes from
//! ([`RowSource`]), which are missing, the reference scanline that sizes the capture, and the
//! value scale its samples get.

use std::path::{Path, PathBuf};

use super::input::{InputSpec, Printf};
use super::layout::stack_image;
use super::options::IngestOptions;
use crate::formats::{read_streak, PixelType, StreakImage};
use crate::ingest::IngestError;
use crate::manifest::Manifest;

/// Where the scanlines come from.
#[derive(Clone, Debug, PartialEq)]
pub enum RowSource {
    /// One file per scanline; `None` for a missing scanline (only with `allow_missing`).
    Files(Vec<Option<PathBuf>>),
    /// A stack read from one HDF5 dataset: `ny` images of `a x b` values, `[y][a][b]`, with
    /// `(a, b) = (nt, nx)`, or `(nx, nt)` with `transpose`.
    Stack {
        path: PathBuf,
        dataset: String,
        values: Vec<f32>,
    },
}

/// The scanlines of an input, before any file is read.
pub(super) struct Listed {
    pub(super) source: RowSource,
    pub(super) ny: usize,
    pub(super) manifest: Option<(Manifest, PathBuf)>,
    pub(super) stack_nx_nt: Option<(usize, usize)>,
    pub(super) stack_pixel_type: PixelType,
}

impl Listed {
    /// The value scale of the samples: the one given, else the manifest's value per count for
    /// scanlines that store integer counts (16-bit PNG, HPD-TA `.img`), else 1.
    pub(super) fn value_scale(&self, given: Option<f64>, pixel_type: PixelType) -> f64 {
        if let Some(v) = given {
            return v;
        }
        match &self.manifest {
            Some((m, _)) if pixel_type.max_stored_value().is_some() => {
                m.capture.png_value_per_count.unwrap_or(1.0)
            }
            _ => 1.0,
        }
    }

    /// The scanlines without a file (only with `allow_missing`); refused when that is every
    /// one. `input` names the capture in the message.
    pub(super) fn missing(&self, input: &str) -> Result<Vec<usize>, IngestError> {
        let missing: Vec<usize> = match &self.source {
            RowSource::Files(files) => (0..files.len()).filter(|&y| files[y].is_none()).collect(),
            RowSource::Stack { .. } => Vec::new(),
        };
        if missing.len() == self.ny {
            return Err(IngestError::AllMissing {
                input: input.to_string(),
            });
        }
        Ok(missing)
    }

    /// The reference scanline, the first present one, read (its size, sample type and time
    /// table are the capture's), with the name messages give it: the file, or
    /// `STACK.h5:/DATASET` for a stack. Needs one present scanline ([`Listed::missing`]).
    pub(super) fn reference(&self, transpose: bool) -> Result<(StreakImage, PathBuf), IngestError> {
        Ok(match &self.source {
            RowSource::Files(files) => {
                let path = files.iter().flatten().next().expect("one present").clone();
                (read_streak(&path, transpose)?, path)
            }
            RowSource::Stack {
                path,
                dataset,
                values,
            } => {
                let (nx, nt) = self.stack_nx_nt.expect("stack sizes");
                let mut img = StreakImage::new(nx, nt, stack_image(values, 0, nx, nt, transpose));
                img.pixel_type = self.stack_pixel_type;
                (img, PathBuf::from(format!("{}:/{dataset}", path.display())))
            }
        })
    }
}

/// List the scanlines of `input`: the file of each (checking that it is there, unless
/// `allow_missing`), or the values of a stack (checked finite), before any scanline is read.
pub(super) fn list_rows(input: &InputSpec, options: &IngestOptions) -> Result<Listed, IngestError> {
    let allow_missing = options.allow_missing;
    match input {
        InputSpec::Manifest(path) => manifest_rows(path, allow_missing),
        InputSpec::Printf { pattern, rows } => Ok(files_only(
            printf_rows(pattern, *rows, allow_missing)?,
            None,
        )),
        InputSpec::Glob(pattern) => Ok(files_only(glob_rows(pattern, allow_missing)?, None)),
        InputSpec::File(path) => Ok(files_only(vec![Some(path.clone())], None)),
        InputSpec::Stack { path, dataset } => stack_rows(path, dataset, options.transpose),
    }
}

/// A listing of scanline files (`None`: a missing one).
fn files_only(files: Vec<Option<PathBuf>>, manifest: Option<(Manifest, PathBuf)>) -> Listed {
    Listed {
        ny: files.len(),
        source: RowSource::Files(files),
        manifest,
        stack_nx_nt: None,
        stack_pixel_type: PixelType::F32,
    }
}

/// The scanlines a manifest lists.
fn manifest_rows(path: &Path, allow_missing: bool) -> Result<Listed, IngestError> {
    let m = Manifest::load(path)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut files = Vec::with_capacity(m.capture.ny);
    for y in 0..m.capture.ny {
        let file = m
            .scanline_path(dir, y)
            .expect("validated manifest covers 0..ny");
        if file.is_file() {
            files.push(Some(file));
        } else if allow_missing {
            files.push(None);
        } else {
            return Err(IngestError::ManifestFileMissing {
                manifest: path.to_path_buf(),
                row: y,
                file,
            });
        }
    }
    Ok(files_only(files, Some((m, path.to_path_buf()))))
}

/// The scanlines of a printf pattern, rows `0..rows`.
fn printf_rows(
    pattern: &str,
    rows: usize,
    allow_missing: bool,
) -> Result<Vec<Option<PathBuf>>, IngestError> {
    let p = Printf::parse(pattern)?.expect("classified as printf");
    let mut files = Vec::with_capacity(rows);
    for y in 0..rows {
        let file = PathBuf::from(p.format(y));
        if file.is_file() {
            files.push(Some(file));
        } else if allow_missing {
            files.push(None);
        } else {
            return Err(IngestError::MissingScanline {
                row: y,
                expected: format!("expected file {}", file.display()),
            });
        }
    }
    Ok(files)
}

/// The scanlines a glob matches, placed by the last number in their names (in name order
/// when some name holds none).
fn glob_rows(pattern: &str, allow_missing: bool) -> Result<Vec<Option<PathBuf>>, IngestError> {
    let bad = |message: String| IngestError::BadGlob {
        pattern: pattern.to_string(),
        message,
    };
    let mut matches: Vec<PathBuf> = glob::glob(pattern)
        .map_err(|e| bad(e.to_string()))?
        .filter_map(Result::ok)
        .filter(|p| p.is_file())
        .collect();
    if matches.is_empty() {
        return Err(IngestError::NoMatches {
            pattern: pattern.to_string(),
        });
    }
    matches.sort();
    let numbers: Option<Vec<u64>> = matches.iter().map(|p| file_number(p)).collect();
    let Some(numbers) = numbers else {
        return Ok(matches.into_iter().map(Some).collect());
    };
    let first = *numbers.iter().min().expect("non-empty");
    let last = *numbers.iter().max().expect("non-empty");
    let ny = usize::try_from(last - first + 1).unwrap_or(usize::MAX);
    if ny > 16 * matches.len() + 1024 {
        return Err(bad(format!(
            "file numbers run from {first} to {last} for only {} files",
            matches.len()
        )));
    }
    let mut files: Vec<Option<PathBuf>> = vec![None; ny];
    for (p, n) in matches.iter().zip(&numbers) {
        let y = (n - first) as usize;
        if let Some(prev) = &files[y] {
            return Err(IngestError::DuplicateNumber {
                number: *n,
                first: prev.clone(),
                second: p.clone(),
            });
        }
        files[y] = Some(p.clone());
    }
    if !allow_missing {
        if let Some(y) = files.iter().position(Option::is_none) {
            let before = files[..y].iter().flatten().next_back();
            return Err(IngestError::MissingScanline {
                row: y,
                expected: format!(
                    "no file numbered {} matches {pattern} (after {})",
                    first + y as u64,
                    before.map_or("-".into(), |p| p.display().to_string())
                ),
            });
        }
    }
    Ok(files)
}

/// The values of an HDF5 image stack, one image a scanline (checked finite).
fn stack_rows(path: &Path, dataset: &str, transpose: bool) -> Result<Listed, IngestError> {
    let (shape, values) = crate::container::read_image_stack(path, dataset)?;
    if shape.contains(&0) {
        return Err(IngestError::StackShape {
            path: path.to_path_buf(),
            dataset: dataset.trim_start_matches('/').to_string(),
            shape,
            message: "every axis needs length > 0".into(),
        });
    }
    let (ny, a, b) = (shape[0], shape[1], shape[2]);
    let (nx, nt) = if transpose { (a, b) } else { (b, a) };
    let name = dataset.trim_start_matches('/').to_string();
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        let (y, rest) = (i / (a * b), i % (a * b));
        let (x, t) = if transpose {
            (rest / b, rest % b)
        } else {
            (rest % b, rest / b)
        };
        return Err(IngestError::NonFinite {
            path: PathBuf::from(format!("{}:/{name} image {y}", path.display())),
            x,
            t,
            value: values[i],
        });
    }
    Ok(Listed {
        source: RowSource::Stack {
            path: path.to_path_buf(),
            dataset: name,
            values,
        },
        ny,
        manifest: None,
        stack_nx_nt: Some((nx, nt)),
        stack_pixel_type: PixelType::F32,
    })
}

/// The last run of digits in a file name, if any.
fn file_number(path: &Path) -> Option<u64> {
    let name = path.file_name()?.to_string_lossy().into_owned();
    let bytes = name.as_bytes();
    let end = bytes.iter().rposition(u8::is_ascii_digit)? + 1;
    let start = bytes[..end]
        .iter()
        .rposition(|b| !b.is_ascii_digit())
        .map_or(0, |i| i + 1);
    name[start..end].parse().ok()
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_numbers_are_the_last_digit_run() {
        assert_eq!(file_number(Path::new("run2/scan_0017.png")), Some(17));
        assert_eq!(file_number(Path::new("a7b_12x.png")), Some(12));
        assert_eq!(file_number(Path::new("scan.png")), None);
    }

    fn stack(ny: usize, nx: usize, nt: usize) -> Listed {
        Listed {
            source: RowSource::Stack {
                path: "s.h5".into(),
                dataset: "images".into(),
                values: (0..ny * nx * nt).map(|i| i as f32).collect(),
            },
            ny,
            manifest: None,
            stack_nx_nt: Some((nx, nt)),
            stack_pixel_type: PixelType::F32,
        }
    }

    fn files(present: &[bool]) -> Listed {
        Listed {
            source: RowSource::Files(
                present
                    .iter()
                    .enumerate()
                    .map(|(y, &p)| p.then(|| PathBuf::from(format!("s{y}.png"))))
                    .collect(),
            ),
            ny: present.len(),
            manifest: None,
            stack_nx_nt: None,
            stack_pixel_type: PixelType::F32,
        }
    }

    #[test]
    fn missing_rows_are_listed_and_all_missing_is_refused() {
        assert_eq!(
            files(&[true, false, true, false]).missing("x").unwrap(),
            [1, 3]
        );
        assert!(stack(2, 3, 4).missing("x").unwrap().is_empty());
        let e = files(&[false, false]).missing("cap/*.png").unwrap_err();
        assert!(matches!(e, IngestError::AllMissing { ref input } if input == "cap/*.png"));
    }

    #[test]
    fn the_reference_of_a_stack_is_its_first_image_named_by_dataset() {
        // Two images of 3 x 2 (x by t), stored [y][t][x]: image 0 holds 0..6.
        let (img, name) = stack(2, 3, 2).reference(false).unwrap();
        assert_eq!((img.nx, img.nt), (3, 2));
        assert_eq!(img.data, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(img.pixel_type, PixelType::F32);
        assert_eq!(name, PathBuf::from("s.h5:/images"));
        // Stored [y][x][t] (transpose): image 0 is x0 = (0, 1), x1 = (2, 3), x2 = (4, 5).
        let (img, _) = stack(2, 3, 2).reference(true).unwrap();
        assert_eq!(img.data, [0.0, 2.0, 4.0, 1.0, 3.0, 5.0]);
    }

    #[test]
    fn the_value_scale_is_given_else_the_manifests_for_counts_else_one() {
        let mut listed = files(&[true]);
        assert_eq!(listed.value_scale(None, PixelType::U16), 1.0);
        assert_eq!(listed.value_scale(Some(0.25), PixelType::U16), 0.25);
        let mut m = super::super::test_manifest(4, 3);
        m.capture.png_value_per_count = Some(0.5);
        listed.manifest = Some((m, "m/manifest.toml".into()));
        assert_eq!(listed.value_scale(None, PixelType::U16), 0.5);
        // Float samples are signal values already.
        assert_eq!(listed.value_scale(None, PixelType::F32), 1.0);
        assert_eq!(listed.value_scale(Some(2.0), PixelType::F32), 2.0);
        // A manifest without a value per count: 1.
        listed
            .manifest
            .as_mut()
            .unwrap()
            .0
            .capture
            .png_value_per_count = None;
        assert_eq!(listed.value_scale(None, PixelType::U16), 1.0);
    }
}

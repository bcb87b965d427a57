//! What the user named as the capture ([`InputSpec`]): a capture folder or manifest, a glob
//! or printf pattern of scanline files, a stack in one HDF5 dataset, or one scanline file;
//! how a name is classified and described in messages.

use std::path::{Path, PathBuf};

use super::MAX_SCANLINES;
use crate::formats::streak_extension;
use crate::ingest::IngestError;
use crate::limits::bounded_count;

/// What the user named as the capture.
#[derive(Clone, Debug, PartialEq)]
pub enum InputSpec {
    /// A manifest file (a capture folder resolves to its `manifest.toml`).
    Manifest(PathBuf),
    /// A glob pattern matching one file per scanline.
    Glob(String),
    /// A printf pattern (one `%d`, `%Nd` or `%0Nd`) for scanlines `0..rows`.
    Printf { pattern: String, rows: usize },
    /// A 3-D dataset of an HDF5 file holding the streak images.
    Stack { path: PathBuf, dataset: String },
    /// One scanline file: a capture of one scanline.
    File(PathBuf),
}

/// A printf pattern split around its one integer conversion.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Printf {
    prefix: String,
    suffix: String,
    width: usize,
    zero_pad: bool,
}

impl Printf {
    /// Parse `pattern`; `Ok(None)` when it holds no conversion at all.
    pub(super) fn parse(pattern: &str) -> Result<Option<Printf>, IngestError> {
        let bad = |message: &str| IngestError::BadPrintf {
            pattern: pattern.to_string(),
            message: message.to_string(),
        };
        let mut found: Option<Printf> = None;
        let mut literal = String::new();
        let chars: Vec<char> = pattern.chars().collect();
        let mut i = 0;
        while i < chars.len() {
            if chars[i] != '%' {
                literal.push(chars[i]);
                i += 1;
                continue;
            }
            if chars.get(i + 1) == Some(&'%') {
                literal.push('%');
                i += 2;
                continue;
            }
            let mut j = i + 1;
            let zero_pad = chars.get(j) == Some(&'0');
            if zero_pad {
                j += 1;
            }
            let digits_start = j;
            while chars.get(j).is_some_and(|c| c.is_ascii_digit()) {
                j += 1;
            }
            if chars.get(j) != Some(&'d') {
                return Err(bad("only %d, %Nd and %0Nd are understood"));
            }
            if found.is_some() {
                return Err(bad("more than one conversion"));
            }
            let width: String = chars[digits_start..j].iter().collect();
            found = Some(Printf {
                prefix: std::mem::take(&mut literal),
                suffix: String::new(),
                width: width.parse().unwrap_or(0),
                zero_pad,
            });
            i = j + 1;
        }
        Ok(found.map(|mut p| {
            p.suffix = literal;
            p
        }))
    }

    pub(super) fn format(&self, n: usize) -> String {
        let number = if self.zero_pad {
            format!("{n:0width$}", width = self.width)
        } else {
            format!("{n:width$}", width = self.width)
        };
        format!("{}{number}{}", self.prefix, self.suffix)
    }
}

impl InputSpec {
    /// Decide what kind of input `input` is: with a `dataset` it is an HDF5 stack; a `%d`
    /// conversion makes a printf pattern (which needs `rows`); `*`, `?` or `[` a glob; a
    /// folder with `manifest.toml` a capture folder (one without is refused, naming the
    /// image files it holds); a `.toml` file a manifest; a file that [`read_streak`](crate::formats::read_streak) reads
    /// a capture of one scanline.
    pub fn classify(
        input: &str,
        rows: Option<usize>,
        dataset: Option<&str>,
    ) -> Result<InputSpec, IngestError> {
        if let Some(dataset) = dataset {
            return Ok(InputSpec::Stack {
                path: PathBuf::from(input),
                dataset: dataset.to_string(),
            });
        }
        if Printf::parse(input)?.is_some() {
            return match rows {
                Some(rows) if rows > 0 => Ok(InputSpec::Printf {
                    pattern: input.to_string(),
                    rows: bounded_count(
                        rows as f64,
                        MAX_SCANLINES,
                        format_args!("the scanlines of {input} (--rows)"),
                        "lower --rows",
                    )?,
                }),
                _ => Err(IngestError::PrintfNeedsRows {
                    pattern: input.to_string(),
                }),
            };
        }
        if input.contains(['*', '?', '[']) {
            return Ok(InputSpec::Glob(input.to_string()));
        }
        let path = Path::new(input);
        if path.is_dir() {
            let manifest = path.join("manifest.toml");
            if !manifest.exists() {
                return Err(IngestError::FolderWithoutManifest {
                    dir: path.to_path_buf(),
                    found: streak_files_by_extension(path),
                });
            }
            return Ok(InputSpec::Manifest(manifest));
        }
        let is_toml = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
        if is_toml {
            return Ok(InputSpec::Manifest(path.to_path_buf()));
        }
        if !path.exists() {
            return Err(IngestError::NoSuchInput {
                input: input.to_string(),
            });
        }
        if path.is_file() && streak_extension(path).is_some() {
            return Ok(InputSpec::File(path.to_path_buf()));
        }
        Err(IngestError::NotAnInput {
            input: input.to_string(),
        })
    }

    /// The input as the user would write it, for messages and provenance.
    pub fn describe(&self) -> String {
        match self {
            InputSpec::Manifest(p) => p.display().to_string(),
            InputSpec::Glob(g) => g.clone(),
            InputSpec::Printf { pattern, rows } => format!("{pattern} (rows 0..{rows})"),
            InputSpec::Stack { path, dataset } => format!("{}:/{dataset}", path.display()),
            InputSpec::File(p) => p.display().to_string(),
        }
    }
}

/// The files of `dir` that [`read_streak`](crate::formats::read_streak) reads, counted by extension (lower case), most
/// first, then by name; an unreadable folder counts none.
pub fn streak_files_by_extension(dir: &Path) -> Vec<(String, usize)> {
    let mut counts: std::collections::BTreeMap<&'static str, usize> = Default::default();
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        if let Some(ext) = streak_extension(&path).filter(|_| path.is_file()) {
            *counts.entry(ext).or_default() += 1;
        }
    }
    let mut found: Vec<(String, usize)> = counts
        .into_iter()
        .map(|(e, n)| (e.to_string(), n))
        .collect();
    found.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    found
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn printf_patterns_parse_and_format() {
        let p = Printf::parse("a/scan_%04d.png").unwrap().unwrap();
        assert_eq!(p.format(7), "a/scan_0007.png");
        assert_eq!(p.format(12345), "a/scan_12345.png");
        let p = Printf::parse("s%d_100%%.exr").unwrap().unwrap();
        assert_eq!(p.format(3), "s3_100%.exr");
        let p = Printf::parse("s%3d.png").unwrap().unwrap();
        assert_eq!(p.format(3), "s  3.png");
        assert_eq!(Printf::parse("plain.png").unwrap(), None);
        assert!(Printf::parse("a%s.png").is_err());
        assert!(Printf::parse("a%d_%d.png").is_err());
    }

    #[test]
    fn inputs_are_classified() {
        assert_eq!(
            InputSpec::classify("x_%03d.png", Some(4), None).unwrap(),
            InputSpec::Printf {
                pattern: "x_%03d.png".into(),
                rows: 4
            }
        );
        assert!(matches!(
            InputSpec::classify("x_%03d.png", None, None),
            Err(IngestError::PrintfNeedsRows { .. })
        ));
        assert_eq!(
            InputSpec::classify("d/x_*.png", None, None).unwrap(),
            InputSpec::Glob("d/x_*.png".into())
        );
        assert_eq!(
            InputSpec::classify("cap/manifest.toml", None, None).unwrap(),
            InputSpec::Manifest("cap/manifest.toml".into())
        );
        assert!(matches!(
            InputSpec::classify("stack.h5", None, Some("images")).unwrap(),
            InputSpec::Stack { .. }
        ));
        assert!(matches!(
            InputSpec::classify("/no/such/thing.png", None, None),
            Err(IngestError::NoSuchInput { .. })
        ));
        // One scanline file; a file of another kind; a folder without a manifest.
        let dir = tempfile::tempdir().unwrap();
        let img = dir.path().join("Scan.IMG");
        std::fs::write(&img, b"").unwrap();
        assert_eq!(
            InputSpec::classify(img.to_str().unwrap(), None, None).unwrap(),
            InputSpec::File(img.clone())
        );
        let txt = dir.path().join("notes.txt");
        std::fs::write(&txt, b"").unwrap();
        assert!(matches!(
            InputSpec::classify(txt.to_str().unwrap(), None, None),
            Err(IngestError::NotAnInput { .. })
        ));
        for name in ["a.png", "b.png", "c.exr"] {
            std::fs::write(dir.path().join(name), b"").unwrap();
        }
        std::fs::create_dir(dir.path().join("sub.png")).unwrap();
        match InputSpec::classify(dir.path().to_str().unwrap(), None, None) {
            Err(IngestError::FolderWithoutManifest { found, .. }) => assert_eq!(
                found,
                [("png".into(), 2), ("exr".into(), 1), ("img".into(), 1)]
            ),
            other => panic!("{other:?}"),
        }
    }
}

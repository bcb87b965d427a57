//! 2D-3D correspondences for spatial calibration: a pixel and the mesh point seen there
//! (fiducials, or corners picked by the user), read from TOML or CSV.
//!
//! Pixel coordinates are continuous, in the convention of [`crate::camera`]: pixel `(i, j)`
//! covers `[i, i+1) x [j, j+1)` and its centre is `(i + 0.5, j + 0.5)`; x grows to the right,
//! y downwards. 3-D points are in the mesh's (world) frame, metres.
//!
//! # TOML (what `femto simulate` writes for its fiducials, and [`save_points_toml`] writes)
//!
//! ```toml
//! [[point]]
//! name = "cube corner 1"      # optional
//! pixel = [312.5, 288.25]     # x, y in pixels
//! world_m = [0.15, 0.3, -0.15] # X, Y, Z in metres, mesh frame
//!
//! [[point]]
//! pixel = [100.0, 40.5]
//! world_m = [-1.0, 1.2, -1.5]
//! ```
//!
//! # CSV
//!
//! A header line names the columns, in any order: `name,x_px,y_px,X_m,Y_m,Z_m`, or without
//! the `name` column. Blank lines and lines starting with `#` are skipped; a field may be
//! wrapped in double quotes (no quotes or commas inside).
//!
//! ```text
//! name,x_px,y_px,X_m,Y_m,Z_m
//! cube corner 1,312.5,288.25,0.15,0.3,-0.15
//! ```
//!
//! Errors name the file and the line.

use super::CalibrateError;
use nalgebra::Point3;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One pixel and the 3-D point it sees.
#[derive(Clone, Debug, PartialEq)]
pub struct Correspondence {
    /// Optional label (used in messages).
    pub name: Option<String>,
    /// Continuous pixel coordinates `(x, y)`; the centre of pixel `(i, j)` is `(i+0.5, j+0.5)`.
    pub pixel: (f64, f64),
    /// The point in the mesh frame, metres.
    pub point_m: Point3<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PointsFileIn {
    #[serde(default)]
    point: Vec<toml::Spanned<PointIn>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PointIn {
    #[serde(default)]
    name: Option<String>,
    pixel: [f64; 2],
    world_m: [f64; 3],
}

#[derive(Serialize)]
struct PointsFileOut<'a> {
    point: Vec<PointOut<'a>>,
}

#[derive(Serialize)]
struct PointOut<'a> {
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<&'a str>,
    pixel: [f64; 2],
    world_m: [f64; 3],
}

/// Read correspondences from a `.toml` or `.csv` file (format in the module doc).
pub fn load_points(path: &Path) -> Result<Vec<Correspondence>, CalibrateError> {
    let name = path.display().to_string();
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    let parse: fn(&str, &str) -> Result<Vec<Correspondence>, CalibrateError> = match ext.as_deref()
    {
        Some("toml") => parse_points_toml,
        Some("csv") => parse_points_csv,
        _ => {
            return Err(CalibrateError::Format {
                path: name,
                message: "unknown correspondence file type, expected a .toml or .csv file".into(),
            })
        }
    };
    let text = std::fs::read_to_string(path).map_err(|source| CalibrateError::Io {
        path: name.clone(),
        source,
    })?;
    parse(&text, &name)
}

/// 1-based line of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}

/// Parse the TOML form; `origin` names the source in error messages.
pub fn parse_points_toml(text: &str, origin: &str) -> Result<Vec<Correspondence>, CalibrateError> {
    let file: PointsFileIn = toml::from_str(text).map_err(|e| {
        let line = e.span().map_or(1, |s| line_of(text, s.start));
        CalibrateError::Parse {
            path: origin.to_string(),
            line,
            message: e.message().replace('\n', " ").trim().to_string(),
        }
    })?;
    let mut out = Vec::with_capacity(file.point.len());
    for spanned in file.point {
        let line = line_of(text, spanned.span().start);
        let p = spanned.into_inner();
        if !(p
            .pixel
            .iter()
            .chain(p.world_m.iter())
            .all(|v| v.is_finite()))
        {
            return Err(CalibrateError::Parse {
                path: origin.to_string(),
                line,
                message: "pixel and world_m must be finite numbers".into(),
            });
        }
        out.push(Correspondence {
            name: p.name,
            pixel: (p.pixel[0], p.pixel[1]),
            point_m: Point3::from(p.world_m),
        });
    }
    if out.is_empty() {
        return Err(CalibrateError::Format {
            path: origin.to_string(),
            message: "no [[point]] entries".into(),
        });
    }
    Ok(out)
}

/// The column names of the CSV form.
const CSV_COLUMNS: [&str; 6] = ["name", "x_px", "y_px", "X_m", "Y_m", "Z_m"];

fn unquote(field: &str) -> &str {
    let f = field.trim();
    f.strip_prefix('"')
        .and_then(|s| s.strip_suffix('"'))
        .unwrap_or(f)
}

/// Parse the CSV form; `origin` names the source in error messages.
pub fn parse_points_csv(text: &str, origin: &str) -> Result<Vec<Correspondence>, CalibrateError> {
    let err = |line: usize, message: String| CalibrateError::Parse {
        path: origin.to_string(),
        line,
        message,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let expected = "expected the header 'name,x_px,y_px,X_m,Y_m,Z_m' or 'x_px,y_px,X_m,Y_m,Z_m'";
    let Some((header_line, header)) = lines.next() else {
        return Err(CalibrateError::Format {
            path: origin.to_string(),
            message: format!("empty file, {expected}"),
        });
    };
    // column index of each of CSV_COLUMNS (name optional)
    let mut index: [Option<usize>; 6] = [None; 6];
    let header_fields: Vec<&str> = header.split(',').map(unquote).collect();
    for (col, field) in header_fields.iter().enumerate() {
        let Some(k) = CSV_COLUMNS.iter().position(|c| c == field) else {
            return Err(err(
                header_line,
                format!("unknown column '{field}', {expected}"),
            ));
        };
        if index[k].is_some() {
            return Err(err(header_line, format!("column '{field}' appears twice")));
        }
        index[k] = Some(col);
    }
    if let Some(k) = (1..6).find(|&k| index[k].is_none()) {
        return Err(err(
            header_line,
            format!("missing column '{}', {expected}", CSV_COLUMNS[k]),
        ));
    }
    let mut out = Vec::new();
    for (line, row) in lines {
        let fields: Vec<&str> = row.split(',').map(unquote).collect();
        if fields.len() != header_fields.len() {
            return Err(err(
                line,
                format!(
                    "{} fields, the header has {}",
                    fields.len(),
                    header_fields.len()
                ),
            ));
        }
        let mut v = [0.0f64; 6];
        for k in 1..6 {
            let field = fields[index[k].expect("checked above")];
            v[k] = field
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    err(
                        line,
                        format!("{} = '{field}' is not a finite number", CSV_COLUMNS[k]),
                    )
                })?;
        }
        let name = index[0]
            .map(|c| fields[c].to_string())
            .filter(|s| !s.is_empty());
        out.push(Correspondence {
            name,
            pixel: (v[1], v[2]),
            point_m: Point3::new(v[3], v[4], v[5]),
        });
    }
    if out.is_empty() {
        return Err(CalibrateError::Format {
            path: origin.to_string(),
            message: "no correspondences after the header".into(),
        });
    }
    Ok(out)
}

/// The TOML form of `points` (module doc).
pub fn points_to_toml(points: &[Correspondence]) -> String {
    let file = PointsFileOut {
        point: points
            .iter()
            .map(|p| PointOut {
                name: p.name.as_deref(),
                pixel: [p.pixel.0, p.pixel.1],
                world_m: p.point_m.coords.into(),
            })
            .collect(),
    };
    let body = toml::to_string(&file).expect("correspondences serialise");
    format!(
        "# femto 2D-3D correspondences: pixel = [x, y] (pixel (i, j) centre at i+0.5, j+0.5), \
         world_m = mesh frame, metres\n\n{body}"
    )
}

/// Write `points` as TOML (module doc), atomically.
pub fn save_points_toml(path: &Path, points: &[Correspondence]) -> Result<(), CalibrateError> {
    let text = points_to_toml(points);
    crate::atomic::write_atomically(path, |tmp| std::fs::write(tmp, &text)).map_err(|source| {
        CalibrateError::Io {
            path: path.display().to_string(),
            source,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<Correspondence> {
        vec![
            Correspondence {
                name: Some("corner a".into()),
                pixel: (12.5, 40.25),
                point_m: Point3::new(0.1, -0.2, 3.0),
            },
            Correspondence {
                name: None,
                pixel: (0.0, 599.75),
                point_m: Point3::new(-1.0, 0.0, 1e-3),
            },
        ]
    }

    #[test]
    fn toml_round_trip_through_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fid.toml");
        save_points_toml(&path, &sample()).unwrap();
        assert_eq!(load_points(&path).unwrap(), sample());
    }

    #[test]
    fn csv_with_and_without_names() {
        let with = "# picked by hand\nname,x_px,y_px,X_m,Y_m,Z_m\n\"corner a\",12.5,40.25,0.1,-0.2,3\n,0,599.75,-1,0,0.001\n";
        assert_eq!(parse_points_csv(with, "a.csv").unwrap(), sample());
        let reordered = "X_m,Y_m,Z_m,x_px,y_px\n-1,0,0.001,0,599.75\n";
        let p = parse_points_csv(reordered, "b.csv").unwrap();
        assert_eq!(p, vec![sample()[1].clone()]);
    }

    #[test]
    fn errors_name_file_and_line() {
        let bad_number = "name,x_px,y_px,X_m,Y_m,Z_m\na,1,2,3,4,5\n\nb,1,two,3,4,5\n";
        let e = parse_points_csv(bad_number, "p.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("p.csv: line 4:") && e.contains("y_px"), "{e}");
        let short_row = "x_px,y_px,X_m,Y_m,Z_m\n1,2,3,4\n";
        let e = parse_points_csv(short_row, "p.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("p.csv: line 2:"), "{e}");
        let bad_header = "x,y,X,Y,Z\n";
        let e = parse_points_csv(bad_header, "p.csv")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 1") && e.contains("unknown column 'x'"),
            "{e}"
        );

        let toml_text = "[[point]]\npixel = [1.0, 2.0]\nworld_m = [1.0, 2.0, 3.0]\n\n[[point]]\npixel = [1.0, 2.0]\nworld_m = [1.0, 2.0]\n";
        let e = parse_points_toml(toml_text, "f.toml")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("f.toml: line 7:"), "{e}");
        let nan = "[[point]]\npixel = [1.0, 2.0]\nworld_m = [1.0, 2.0, 3.0]\n[[point]]\npixel = [nan, 2.0]\nworld_m = [1.0, 2.0, 3.0]\n";
        let e = parse_points_toml(nan, "f.toml").unwrap_err().to_string();
        assert!(
            e.starts_with("f.toml: line 4:") && e.contains("finite"),
            "{e}"
        );
        let typo = "[[point]]\npixel = [1.0, 2.0]\nworld = [1.0, 2.0, 3.0]\n";
        let e = parse_points_toml(typo, "f.toml").unwrap_err().to_string();
        assert!(e.contains("line") && e.contains("world"), "{e}");
    }

    #[test]
    fn unknown_extension_and_missing_file_are_errors() {
        let e = load_points(Path::new("points.txt"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("points.txt") && e.contains(".csv"), "{e}");
        let e = load_points(Path::new("/nonexistent/p.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/p.csv"), "{e}");
    }
}

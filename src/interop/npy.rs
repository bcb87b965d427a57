//! The NumPy `.npy` format (versions 1-3), read into f32: the magic `\x93NUMPY`, a version,
//! a header length, a Python dict literal (`descr`, `fortran_order`, `shape`) and the values
//! in C order. Little-endian `f2`, `f4`, `f8` are read (what `np.save` writes for a
//! mitransient render: `float32`); other types and Fortran order are refused.
//!
//! Hand-written rather than a crate: the format is a 10-byte preamble and a one-line dict,
//! and a new dependency would touch the `Cargo.lock` that other branches edit in parallel.

use super::InteropError;
use std::path::Path;

/// The array of a `.npy` file: its shape and values as f32.
pub(super) struct NpyArray {
    pub shape: Vec<usize>,
    pub values: Vec<f32>,
}

fn bad(path: &Path, message: impl Into<String>) -> InteropError {
    InteropError::Invalid {
        path: path.to_path_buf(),
        key: "npy header".into(),
        message: message.into(),
    }
}

/// The value of `key` in the header dict, as written (`'<f4'`, `False`, `(16, 16, 32, 3)`).
fn dict_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let start = header.find(&format!("'{key}'"))? + key.len() + 2;
    let rest = header[start..].trim_start().strip_prefix(':')?.trim_start();
    let end = if rest.starts_with('(') {
        rest.find(')')? + 1
    } else {
        rest.find([',', '}']).unwrap_or(rest.len())
    };
    Some(rest[..end].trim())
}

/// Read the `.npy` file at `path`.
pub(super) fn read_npy(path: &Path) -> Result<NpyArray, InteropError> {
    let bytes = std::fs::read(path).map_err(|source| InteropError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_npy(path, &bytes)
}

pub(super) fn parse_npy(path: &Path, bytes: &[u8]) -> Result<NpyArray, InteropError> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err(bad(path, "not a .npy file (no \\x93NUMPY magic)"));
    }
    let (header_len, start) = match bytes[6] {
        1 => (usize::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes")) as usize,
            12,
        ),
        v => return Err(bad(path, format!("version {v} is not read (1 to 3 are)"))),
    };
    let header = bytes
        .get(start..start + header_len)
        .and_then(|h| std::str::from_utf8(h).ok())
        .ok_or_else(|| bad(path, "truncated or non-text header"))?;
    let descr = dict_value(header, "descr").ok_or_else(|| bad(path, "no 'descr'"))?;
    let descr = descr.trim_matches(['\'', '"']);
    if dict_value(header, "fortran_order") != Some("False") {
        return Err(bad(
            path,
            "Fortran order is not read (save a C-ordered array)",
        ));
    }
    let shape_text = dict_value(header, "shape").ok_or_else(|| bad(path, "no 'shape'"))?;
    let shape: Vec<usize> = shape_text
        .trim_matches(['(', ')'])
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad(path, format!("shape {shape_text}")))?;
    let count = shape
        .iter()
        .try_fold(1usize, |a, &n| a.checked_mul(n))
        .ok_or_else(|| bad(path, format!("shape {shape_text} overflows")))?;
    let size = match descr {
        "<f2" => 2,
        "<f4" => 4,
        "<f8" => 8,
        other => {
            return Err(bad(
                path,
                format!(
                    "dtype {other} is not read (little-endian float16, float32 or float64 are)"
                ),
            ))
        }
    };
    let data = &bytes[start + header_len..];
    if data.len() != count * size {
        return Err(bad(
            path,
            format!(
                "{} bytes of values for shape {shape_text} of {descr} ({} expected)",
                data.len(),
                count * size
            ),
        ));
    }
    let values = match size {
        2 => data
            .chunks_exact(2)
            .map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32())
            .collect(),
        4 => data
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes")))
            .collect(),
        _ => data
            .chunks_exact(8)
            .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")) as f32)
            .collect(),
    };
    Ok(NpyArray { shape, values })
}

#[cfg(test)]
pub(super) fn npy_bytes(shape: &[usize], values: &[f32]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|n| n.to_string()).collect();
    let tuple = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {tuple}, }}");
    while !(10 + header.len() + 1).is_multiple_of(64) {
        header.push(' ');
    }
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_float32_array_reads_back_and_bad_headers_are_refused() {
        let p = Path::new("x.npy");
        let a = parse_npy(p, &npy_bytes(&[2, 3], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.5])).unwrap();
        assert_eq!(a.shape, [2, 3]);
        assert_eq!(a.values, [1.0, 2.0, 3.0, 4.0, 5.0, 6.5]);
        let mut b = npy_bytes(&[2, 3], &[0.0; 6]);
        b.pop();
        assert!(parse_npy(p, &b).is_err());
        let f = String::from_utf8_lossy(&npy_bytes(&[2], &[0.0; 2]))
            .replace("False", "True ")
            .into_bytes();
        assert!(parse_npy(p, &f).is_err());
        assert!(parse_npy(p, b"PNG").is_err());
    }
}

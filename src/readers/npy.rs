//! The NumPy `.npy` format (versions 1-3), femto's one `.npy` parser: the magic `\x93NUMPY`,
//! a version, a header length, a Python dict literal (`descr`, `fortran_order`, `shape`) and
//! the values. Read: C and Fortran order; `u1 u2 u4 u8 i1 i2 i4 i8 f2 f4 f8`, little- and
//! big-endian (`<`, `>`, `|` for one byte). Structured, complex, boolean and object arrays
//! are refused.
//!
//! Hand-written rather than a crate: the format is a 10-byte preamble and a one-line dict
//! (the `npyz` crate would read it, at the price of a dependency for 100 lines).

use super::array::{element_count, Array};
use super::dtype::{decode_from, Dtype};
use super::ReaderError;
use std::io::Read;
use std::path::Path;

/// The value of `key` in the header dict, as written (`'<f4'`, `False`, `(16, 16, 32, 3)`).
fn dict_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let at = header
        .find(&format!("'{key}'"))
        .or_else(|| header.find(&format!("\"{key}\"")))?;
    let start = at + key.len() + 2;
    let rest = header[start..].trim_start().strip_prefix(':')?.trim_start();
    let end = if rest.starts_with('(') {
        rest.find(')')? + 1
    } else {
        rest.find([',', '}']).unwrap_or(rest.len())
    };
    Some(rest[..end].trim())
}

/// The type and byte order of a `descr` such as `<u2`, `>f8`, `|u1`.
fn parse_descr(descr: &str) -> Option<(Dtype, bool)> {
    let mut chars = descr.chars();
    let order = chars.next()?;
    let big = match order {
        '<' | '|' | '=' => false,
        '>' => true,
        _ => return None,
    };
    let kind = chars.next()?;
    let size: usize = chars.as_str().parse().ok()?;
    let dtype = match kind {
        'u' => Dtype::from_parts(false, false, size)?,
        'i' => Dtype::from_parts(false, true, size)?,
        'f' => Dtype::from_parts(true, true, size)?,
        _ => return None,
    };
    // One-byte types have no byte order; wider ones must say it.
    (order != '|' || size == 1).then_some((dtype, big))
}

/// The longest header read, bytes: NumPy pads its dict to 64 bytes, and a version-1 header
/// is at most 65,535 long; a version-2 header may claim 4 GiB, which no array needs.
const MAX_HEADER_BYTES: usize = 1 << 20;

/// Read the `.npy` file at `path`: the header first, then, once the declared array is known
/// to match the file's length and to fit in memory ([`super::check_decode`]), its values
/// decoded in chunks (the file is never read whole).
pub fn read_npy(path: &Path) -> Result<Array, ReaderError> {
    let io = |source| ReaderError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let file_bytes = file.metadata().map_err(io)?.len();
    read_npy_from(path, std::io::BufReader::new(file), file_bytes)
}

/// [`read_npy`] of the `file_bytes` bytes that `reader` yields (a file, or an `.npz` member).
pub(super) fn read_npy_from(
    path: &Path,
    mut reader: impl Read,
    file_bytes: u64,
) -> Result<Array, ReaderError> {
    let bad = |m: String| ReaderError::invalid(path, "npy header", m);
    let short = |e: std::io::Error| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => bad("not a .npy file (truncated header)".into()),
        _ => bad(format!("reading the header: {e}")),
    };
    // The magic and version (8 bytes), then a 2-byte (version 1) or 4-byte length.
    let mut head = vec![0u8; 10];
    reader.read_exact(&mut head).map_err(short)?;
    if matches!(head[6], 2 | 3) {
        head.resize(12, 0);
        reader.read_exact(&mut head[10..]).map_err(short)?;
    }
    let (header_len, start) = preamble(path, &head)?;
    if header_len > MAX_HEADER_BYTES {
        return Err(bad(format!(
            "a header of {header_len} bytes (at most {MAX_HEADER_BYTES} are read)"
        )));
    }
    let data_start = start + header_len;
    head.resize(data_start, 0);
    reader.read_exact(&mut head[start..]).map_err(short)?;
    let h = parse_header(path, &head)?;
    let count = data_length(path, &h, file_bytes.saturating_sub(h.data_start as u64))?;
    super::check_decode(path, "the array", &h.shape, h.dtype, false)?;
    let decoded = decode_from(&mut reader, count, h.dtype, h.big_endian)
        .map_err(|e| ReaderError::invalid(path, "npy data", format!("reading the values: {e}")))?;
    Ok(Array::new(h.shape, h.dtype, decoded, h.fortran_order))
}

/// The number of values of the header's shape, refused unless the `data_bytes` after the
/// header are exactly its bytes (checked arithmetic: a shape whose byte count overflows is
/// refused, never wrapped).
fn data_length(path: &Path, h: &NpyHeader, data_bytes: u64) -> Result<usize, ReaderError> {
    let count = element_count(&h.shape);
    let want = count.and_then(|c| c.checked_mul(h.dtype.size()));
    match (count, want) {
        (Some(count), Some(want)) if want as u64 == data_bytes => Ok(count),
        _ => Err(ReaderError::invalid(
            path,
            "npy data",
            format!(
                "{data_bytes} bytes of values for shape {:?} of {} ({} expected): truncated \
                 or padded",
                h.shape,
                h.dtype.name(),
                crate::limits::decoded_bytes(&h.shape, h.dtype.size(), 1)
                    .map_or("more than 2^128".into(), |n| n.to_string())
            ),
        )),
    }
}

/// The header's length and where it starts, from the magic, the version and the length
/// field of the first 10 or 12 bytes.
fn preamble(path: &Path, bytes: &[u8]) -> Result<(usize, usize), ReaderError> {
    let bad = |m: String| ReaderError::invalid(path, "npy header", m);
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err(bad("not a .npy file (no \\x93NUMPY magic)".into()));
    }
    match bytes[6] {
        1 => Ok((usize::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10)),
        2 | 3 if bytes.len() >= 12 => Ok((
            u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes")) as usize,
            12,
        )),
        v => Err(bad(format!("version {v} is not read (1 to 3 are)"))),
    }
}

/// The shape and sample type a `.npy` file's header declares (its values are not read).
pub fn header_of(path: &Path) -> Result<(Vec<usize>, Dtype), ReaderError> {
    let mut head = Vec::new();
    std::io::Read::read_to_end(
        &mut std::io::Read::take(
            std::fs::File::open(path).map_err(|source| ReaderError::Io {
                path: path.to_path_buf(),
                source,
            })?,
            HEAD_BYTES,
        ),
        &mut head,
    )
    .map_err(|source| ReaderError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let h = parse_header(path, &head)?;
    Ok((h.shape, h.dtype))
}

/// The most of a `.npy` file read to find its header (NumPy writes headers of a few
/// hundred bytes; version 2 allows up to 4 GiB, which no array needs).
pub(super) const HEAD_BYTES: u64 = 1 << 20;

/// Refuse an array whose declared values, with the `stored_bytes` they come in, do not fit
/// the memory budget.
pub(super) fn check_declared(
    path: &Path,
    h: &NpyHeader,
    stored_bytes: u64,
) -> Result<(), ReaderError> {
    let count = h
        .shape
        .iter()
        .try_fold(1u128, |a, &n| a.checked_mul(n as u128));
    let copies = if h.fortran_order { 2 } else { 1 };
    let need = count
        .and_then(|c| c.checked_mul(4 * copies))
        .and_then(|v| v.checked_add(u128::from(stored_bytes)));
    super::check_bytes(
        path,
        need,
        &format!("the array {:?} of {}", h.shape, h.dtype.name()),
    )
}

/// The `.npy` header of `bytes`: shape, type, byte order, Fortran order, data offset.
pub(super) struct NpyHeader {
    pub shape: Vec<usize>,
    pub dtype: Dtype,
    pub big_endian: bool,
    pub fortran_order: bool,
    pub data_start: usize,
}

/// Parse the header of a `.npy` file's bytes (the whole file, or its header).
pub(super) fn parse_header(path: &Path, bytes: &[u8]) -> Result<NpyHeader, ReaderError> {
    let bad = |m: String| ReaderError::invalid(path, "npy header", m);
    let (header_len, start) = preamble(path, bytes)?;
    let header = bytes
        .get(start..start.saturating_add(header_len))
        .and_then(|h| std::str::from_utf8(h).ok())
        .ok_or_else(|| bad("truncated or non-text header".into()))?;
    let descr_text = dict_value(header, "descr").ok_or_else(|| bad("no 'descr'".into()))?;
    let descr = descr_text.trim_matches(['\'', '"']);
    let (dtype, big_endian) = parse_descr(descr).ok_or_else(|| {
        bad(format!(
            "dtype {descr_text} is not read (integers u1-u8, i1-i8 and floats f2, f4, f8, \
             either byte order, are)"
        ))
    })?;
    let fortran_order = match dict_value(header, "fortran_order") {
        Some("False") => false,
        Some("True") => true,
        other => return Err(bad(format!("fortran_order {other:?}"))),
    };
    let shape_text = dict_value(header, "shape").ok_or_else(|| bad("no 'shape'".into()))?;
    let shape: Vec<usize> = shape_text
        .trim_matches(['(', ')'])
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.trim_end_matches('L').parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad(format!("shape {shape_text}")))?;
    Ok(NpyHeader {
        shape,
        dtype,
        big_endian,
        fortran_order,
        data_start: start + header_len,
    })
}

/// Parse a whole `.npy` file's bytes into a C-order array (as [`read_npy`] reads a file).
pub fn parse_npy(path: &Path, bytes: &[u8]) -> Result<Array, ReaderError> {
    read_npy_from(path, bytes, bytes.len() as u64)
}

/// A `.npy` file's bytes: version 1, `descr` as given, the raw values in the order given.
#[cfg(test)]
pub(crate) fn npy_bytes_raw(shape: &[usize], descr: &str, fortran: bool, raw: &[u8]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|n| n.to_string()).collect();
    let tuple = if dims.len() == 1 {
        format!("({},)", dims[0])
    } else {
        format!("({})", dims.join(", "))
    };
    let order = if fortran { "True" } else { "False" };
    let mut header =
        format!("{{'descr': '{descr}', 'fortran_order': {order}, 'shape': {tuple}, }}");
    while !(10 + header.len() + 1).is_multiple_of(64) {
        header.push(' ');
    }
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(raw);
    out
}

/// A C-order little-endian float32 `.npy` file's bytes.
#[cfg(test)]
pub(crate) fn npy_bytes(shape: &[usize], values: &[f32]) -> Vec<u8> {
    let raw: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    npy_bytes_raw(shape, "<f4", false, &raw)
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
        assert!(parse_npy(p, b"PNG").is_err());
        assert!(parse_npy(p, &npy_bytes_raw(&[1], "<c8", false, &[0; 8])).is_err());
        assert!(parse_npy(p, &npy_bytes_raw(&[1], "|u2", false, &[0; 2])).is_err());
    }

    #[test]
    fn fortran_order_and_big_endian_integers_read_as_numpy_indexes_them() {
        let p = Path::new("x.npy");
        // A (2, 3) array A[i, j] = 10 i + j, stored by columns, big-endian u2.
        let by_columns = [0u16, 10, 1, 11, 2, 12];
        let raw: Vec<u8> = by_columns.iter().flat_map(|v| v.to_be_bytes()).collect();
        let a = parse_npy(p, &npy_bytes_raw(&[2, 3], ">u2", true, &raw)).unwrap();
        assert_eq!(a.dtype, Dtype::U16);
        assert_eq!(a.values, [0.0, 1.0, 2.0, 10.0, 11.0, 12.0]);
    }
}

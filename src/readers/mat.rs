//! MATLAB `.mat` files: level 5 (v5, v6, v7: tagged data elements, miCOMPRESSED elements
//! zlib-compressed) and v7.3 (an HDF5 file after a 512-byte user block, each variable a
//! root dataset with a `MATLAB_class` attribute and its dimensions reversed).
//!
//! MATLAB stores arrays column-major; both readers return them in C order with MATLAB's
//! indexing kept: `A(i, j, k)` is element `[i, j, k]` of the [`Array`], whatever the storage.
//! Numeric arrays are read (double, single, int8-64, uint8-64); their sample type is the
//! type the values are stored in, which v5 may make narrower than the class (a double array
//! of counts saved as uint16), as `scipy.io.loadmat` reports it. Complex, sparse, char, cell
//! and struct variables are listed but not read.
//!
//! Hand-written for v5 rather than the `matfile` crate: `matfile` 0.5 calls itself alpha,
//! would add `nom`, `libflate` and three more crates to the lock file, and reads the same
//! subset (numeric arrays); this reader is the tag walk below, with `flate2` (already in the
//! build through `png`) for the compressed elements.

use super::array::Array;
use super::dtype::{decode, decode_from, value_f64, Dtype};
use super::h5;
use super::ReaderError;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

const MI_INT8: u32 = 1;
const MI_UINT32: u32 = 6;
const MI_INT32: u32 = 5;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;

/// One variable of a `.mat` file.
#[derive(Clone, Debug, PartialEq)]
pub struct MatVar {
    pub name: String,
    /// MATLAB's dimensions (at least 2).
    pub dims: Vec<usize>,
    /// The numeric class, `None` for a variable femto does not read (its class name in
    /// `class`).
    pub dtype: Option<Dtype>,
    pub class: String,
    /// The values, C order with MATLAB's indexing (`None` unless asked for).
    pub array: Option<Array>,
    /// The value of a numeric 1 x 1 variable, in full precision.
    pub scalar: Option<f64>,
}

/// Whether `bytes` (the start of a file) is a v7.3 MAT file (HDF5 behind a MATLAB header).
pub fn is_v73_header(bytes: &[u8]) -> bool {
    bytes.starts_with(b"MATLAB 7.3 MAT-file")
}

/// Whether `bytes` is the start of a level-5 MAT file.
pub fn is_v5_header(bytes: &[u8]) -> bool {
    bytes.len() >= 128 && bytes.starts_with(b"MATLAB 5.0 MAT-file") && !is_v73_header(bytes)
}

/// The largest expansion of deflate (RFC 1951: 258 bytes from about 2 bits of a code).
const MAX_DEFLATE_RATIO: u64 = 1032;

/// The longest sub-element of a variable's header (its flags, dimensions, name) read,
/// bytes: 16,384 dimensions or a name of a million characters are not a MATLAB variable.
const MAX_HEADER_ELEMENT_BYTES: u64 = 1 << 20;

/// Read every variable of the `.mat` file at `path`; numeric arrays with their values
/// when `read_values` accepts their name.
///
/// The file is walked element by element, never read whole: each variable's header (flags,
/// dimensions, name, the tag of its values) is read first, inflated from its miCOMPRESSED
/// element as far as the header goes; its values are read (and inflated) only when asked
/// for, after the declared byte count is checked against the dimensions (checked arithmetic)
/// and the decoded array against the memory budget ([`super::check_decode`]).
pub fn read_mat(
    path: &Path,
    read_values: &dyn Fn(&str) -> bool,
) -> Result<Vec<MatVar>, ReaderError> {
    let io = |source| ReaderError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let file_bytes = file.metadata().map_err(io)?.len();
    let mut head = Vec::with_capacity(128);
    (&mut file).take(128).read_to_end(&mut head).map_err(io)?;
    if is_v73_header(&head) {
        drop(file);
        return read_v73(path, read_values);
    }
    if !is_v5_header(&head) {
        return Err(ReaderError::invalid(
            path,
            "mat header",
            "not a MATLAB .mat file (no 'MATLAB 5.0 MAT-file' or 'MATLAB 7.3 MAT-file' text)",
        ));
    }
    let big = match &head[126..128] {
        b"IM" => false,
        b"MI" => true,
        other => {
            return Err(ReaderError::invalid(
                path,
                "mat header",
                format!("endian indicator {other:?}, expected 'IM' or 'MI'"),
            ))
        }
    };
    let mut reader = std::io::BufReader::new(file);
    let mut vars = Vec::new();
    let mut at = 128u64;
    while at < file_bytes {
        reader.seek(SeekFrom::Start(at)).map_err(io)?;
        let tag = read_tag(&mut reader, big).map_err(|e| element_error(path, at, e))?;
        // The element's end, padded to 8 bytes unless compressed (checked: a size near
        // 2^32 must not wrap).
        let padded = if tag.ty == MI_COMPRESSED {
            tag.n
        } else {
            tag.n.next_multiple_of(8)
        };
        let data_at = at + tag.tag_bytes;
        let end = if tag.inline.is_some() {
            at + 8
        } else {
            data_at + padded
        };
        if data_at + tag.n > file_bytes {
            return Err(truncated(path, at));
        }
        match tag.ty {
            MI_MATRIX => {
                let mut body = (&mut reader).take(tag.n);
                vars.push(matrix(path, &mut body, big, read_values, at)?);
            }
            MI_COMPRESSED => {
                let z = flate2::bufread::ZlibDecoder::new((&mut reader).take(tag.n));
                let mut z = std::io::BufReader::new(z);
                let inner = read_tag(&mut z, big).map_err(|e| element_error(path, at, e))?;
                // Deflate expands at most 1032:1: a variable declared larger than its
                // compressed bytes can inflate to is refused before anything is allocated.
                let most = tag.n.saturating_mul(MAX_DEFLATE_RATIO).saturating_add(1024);
                if inner.n > most {
                    return Err(ReaderError::invalid(
                        path,
                        "mat data",
                        format!(
                            "the compressed element at byte {at} declares a variable of {} \
                             bytes, more than its {} compressed bytes inflate to (at most {most})",
                            inner.n, tag.n
                        ),
                    ));
                }
                if inner.ty == MI_MATRIX {
                    let mut body = (&mut z).take(inner.n);
                    vars.push(matrix(path, &mut body, big, read_values, at)?);
                }
            }
            _ => {}
        }
        at = end;
    }
    Ok(vars)
}

fn truncated(path: &Path, at: u64) -> ReaderError {
    ReaderError::invalid(
        path,
        "mat data",
        format!("the element at byte {at} runs past the end of the file (truncated?)"),
    )
}

/// A tag that could not be read: the end of the data, or a malformed one.
fn element_error(path: &Path, at: u64, e: std::io::Error) -> ReaderError {
    if e.kind() == std::io::ErrorKind::UnexpectedEof {
        return truncated(path, at);
    }
    ReaderError::invalid(path, "mat data", format!("the element at byte {at}: {e}"))
}

fn u32_at(bytes: &[u8], at: usize, big: bool) -> Option<u32> {
    let b: [u8; 4] = bytes.get(at..at + 4)?.try_into().ok()?;
    Some(if big {
        u32::from_be_bytes(b)
    } else {
        u32::from_le_bytes(b)
    })
}

/// A data element's tag: its type, its byte count, the bytes the tag takes (8, or 4 for a
/// small element), and a small element's data (up to 4 bytes inside the tag).
struct Tag {
    ty: u32,
    n: u64,
    tag_bytes: u64,
    inline: Option<Vec<u8>>,
}

/// Read a tag. A small element (its size in the upper half of the first word) holds up to
/// 4 bytes in the second word of the tag, which is read with it.
fn read_tag(reader: &mut impl Read, big: bool) -> std::io::Result<Tag> {
    let mut w = [0u8; 8];
    reader.read_exact(&mut w)?;
    let first = u32_at(&w, 0, big).expect("4 bytes");
    if first >> 16 != 0 {
        let n = (first >> 16) as usize;
        if n > 4 {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!("a small data element of {n} bytes (at most 4)"),
            ));
        }
        return Ok(Tag {
            ty: first & 0xffff,
            n: n as u64,
            tag_bytes: 4,
            inline: Some(w[4..4 + n].to_vec()),
        });
    }
    Ok(Tag {
        ty: first,
        n: u64::from(u32_at(&w, 4, big).expect("4 bytes")),
        tag_bytes: 8,
        inline: None,
    })
}

/// MATLAB's class code to a numeric type.
fn class_dtype(class: u8) -> (Option<Dtype>, &'static str) {
    match class {
        6 => (Some(Dtype::F64), "double"),
        7 => (Some(Dtype::F32), "single"),
        8 => (Some(Dtype::I8), "int8"),
        9 => (Some(Dtype::U8), "uint8"),
        10 => (Some(Dtype::I16), "int16"),
        11 => (Some(Dtype::U16), "uint16"),
        12 => (Some(Dtype::I32), "int32"),
        13 => (Some(Dtype::U32), "uint32"),
        14 => (Some(Dtype::I64), "int64"),
        15 => (Some(Dtype::U64), "uint64"),
        1 => (None, "cell"),
        2 => (None, "struct"),
        3 => (None, "object"),
        4 => (None, "char"),
        5 => (None, "sparse"),
        _ => (None, "unknown"),
    }
}

/// The storage type of a numeric data element.
fn storage_dtype(ty: u32) -> Option<Dtype> {
    Some(match ty {
        1 => Dtype::I8,
        2 => Dtype::U8,
        3 => Dtype::I16,
        4 => Dtype::U16,
        5 => Dtype::I32,
        6 => Dtype::U32,
        7 => Dtype::F32,
        9 => Dtype::F64,
        12 => Dtype::I64,
        13 => Dtype::U64,
        _ => return None,
    })
}

/// A sub-element of a variable's header, whole (at most [`MAX_HEADER_ELEMENT_BYTES`]): its
/// type and data, with the padding to 8 bytes read past.
fn header_element(
    path: &Path,
    body: &mut impl Read,
    big: bool,
    what: &str,
) -> Result<(u32, Vec<u8>), ReaderError> {
    let short = |e: std::io::Error| {
        ReaderError::invalid(
            path,
            "mat data",
            format!("a variable's {what} is truncated ({e})"),
        )
    };
    let tag = read_tag(body, big).map_err(short)?;
    if let Some(data) = tag.inline {
        return Ok((tag.ty, data));
    }
    if tag.n > MAX_HEADER_ELEMENT_BYTES {
        return Err(ReaderError::invalid(
            path,
            "mat data",
            format!(
                "a variable's {what} of {} bytes (at most {MAX_HEADER_ELEMENT_BYTES})",
                tag.n
            ),
        ));
    }
    let mut data = vec![0u8; tag.n as usize];
    body.read_exact(&mut data).map_err(short)?;
    let pad = tag.n.next_multiple_of(8) - tag.n;
    std::io::copy(&mut body.take(pad), &mut std::io::sink()).map_err(short)?;
    Ok((tag.ty, data))
}

/// The sub-elements of a miMATRIX read from `body` (the element's bytes, inflated if it was
/// compressed): flags, dimensions, name, then the real part when asked for. `at` is the
/// element's byte in the file, for messages.
fn matrix<R: Read>(
    path: &Path,
    body: &mut std::io::Take<R>,
    big: bool,
    read_values: &dyn Fn(&str) -> bool,
    at: u64,
) -> Result<MatVar, ReaderError> {
    let (fty, flags) = header_element(path, body, big, "array flags")?;
    let flags0 = match (fty, flags.len() >= 4) {
        (MI_UINT32, true) => u32_at(&flags, 0, big).expect("4 bytes"),
        _ => return Err(ReaderError::invalid(path, "mat data", "bad array flags")),
    };
    let (mut dtype, class) = class_dtype((flags0 & 0xff) as u8);
    let complex = flags0 & 0x0800 != 0;
    let (dty, dims_bytes) = header_element(path, body, big, "dimensions")?;
    if dty != MI_INT32 {
        return Err(ReaderError::invalid(path, "mat data", "bad dimensions"));
    }
    let dims: Vec<usize> = dims_bytes
        .chunks_exact(4)
        .map(|b| u32_at(b, 0, big).expect("4 bytes") as i32)
        .map(|d| usize::try_from(d).unwrap_or(usize::MAX))
        .collect();
    let (nty, name_bytes) = header_element(path, body, big, "name")?;
    if nty != MI_INT8 && nty != 2 {
        return Err(ReaderError::invalid(path, "mat data", "bad variable name"));
    }
    let name = String::from_utf8_lossy(&name_bytes).into_owned();
    let mut class = class.to_string();
    if complex && dtype.is_some() {
        dtype = None;
        class = format!("complex {class}");
    }
    let mut var = MatVar {
        name,
        dims,
        dtype,
        class,
        array: None,
        scalar: None,
    };
    if dtype.is_none() {
        return Ok(var);
    }
    let is_scalar = var.dims.iter().all(|&d| d == 1);
    if !(is_scalar || read_values(&var.name)) {
        return Ok(var);
    }
    let (array, scalar) = values(path, body, big, &var, at)?;
    var.scalar = scalar.filter(|_| is_scalar);
    var.array = Some(array);
    Ok(var)
}

/// The real part of the numeric variable `var`: its tag, its byte count checked against the
/// dimensions (exactly, in u128), the decoded array checked against the memory budget, then
/// the values decoded as they are read (and inflated). Also the first value in full
/// precision (a scalar's).
fn values<R: Read>(
    path: &Path,
    body: &mut std::io::Take<R>,
    big: bool,
    var: &MatVar,
    at: u64,
) -> Result<(Array, Option<f64>), ReaderError> {
    let bad = |m: String| ReaderError::invalid(path, &var.name, m);
    if var.dims.contains(&usize::MAX) {
        return Err(bad(format!("dimensions {:?}", var.dims)));
    }
    let tag = read_tag(body, big).map_err(|e| {
        ReaderError::invalid(
            path,
            &var.name,
            format!("the values of the element at byte {at} are truncated ({e})"),
        )
    })?;
    let stored = storage_dtype(tag.ty).ok_or_else(|| bad(format!("data type {}", tag.ty)))?;
    // The values lie inside their element (whose bytes are known to be in the file, or
    // bounded by what its compressed bytes inflate to).
    if tag.inline.is_none() && tag.n > body.limit() {
        return Err(bad(format!(
            "{} bytes of values declared in the element at byte {at}, which holds {} more",
            tag.n,
            body.limit()
        )));
    }
    let expected = crate::limits::decoded_bytes(&var.dims, stored.size(), 1);
    let count = super::array::element_count(&var.dims);
    let count = match (expected, count) {
        (Some(e), Some(c)) if e == u128::from(tag.n) => c,
        _ => {
            return Err(bad(format!(
                "{} bytes of values for dimensions {:?} of {} ({} expected)",
                tag.n,
                var.dims,
                stored.name(),
                expected.map_or("more than 2^128".into(), |e| e.to_string())
            )))
        }
    };
    let what = format!("variable {}", var.name);
    super::check_decode(path, &what, &var.dims, stored, false)?;
    let short = |e: std::io::Error| {
        ReaderError::invalid(
            path,
            &var.name,
            format!("reading the values of the element at byte {at}: {e}"),
        )
    };
    if count > 1 {
        let decoded = decode_from(body, count, stored, big).map_err(short)?;
        return Ok((Array::new(var.dims.clone(), stored, decoded, true), None));
    }
    // One value (or none): its bytes, to keep a scalar in full precision.
    let raw = match tag.inline {
        Some(raw) => raw,
        None => {
            let mut raw = vec![0u8; tag.n as usize];
            body.read_exact(&mut raw).map_err(short)?;
            raw
        }
    };
    let raw = &raw[..tag.n as usize];
    let first = value_f64(raw, stored, big);
    let decoded = decode(raw, stored, big);
    Ok((Array::new(var.dims.clone(), stored, decoded, true), first))
}

/// A v7.3 file: its root datasets with a `MATLAB_class` attribute.
fn read_v73(path: &Path, read_values: &dyn Fn(&str) -> bool) -> Result<Vec<MatVar>, ReaderError> {
    let file = h5::open(path)?;
    let mut vars = Vec::new();
    for (name, shape, numeric) in h5::datasets(&file) {
        if name.contains('/') {
            continue; // #refs# and struct members
        }
        let class = h5::dataset_attrs(&file, &name)
            .into_iter()
            .find(|(k, _)| k == "MATLAB_class")
            .and_then(|(_, v)| match v {
                h5::Attr::Text(s) => Some(s),
                _ => None,
            })
            .unwrap_or_else(|| "unknown".into());
        let dtype = match class.as_str() {
            "double" | "single" | "int8" | "uint8" | "int16" | "uint16" | "int32" | "uint32"
            | "int64" | "uint64"
                if numeric =>
            {
                let ds_dtype = file
                    .dataset(&name)
                    .ok()
                    .and_then(|d| d.datatype().ok())
                    .and_then(|d| h5::dtype_of(&d));
                ds_dtype.map(|(d, _)| d)
            }
            _ => None,
        };
        // HDF5 dimensions are MATLAB's reversed.
        let mut dims = shape;
        dims.reverse();
        let is_scalar = dims.iter().all(|&d| d == 1);
        let array = match dtype {
            Some(_) if is_scalar || read_values(&name) => {
                Some(h5::read_array(&file, path, &name, true)?)
            }
            _ => None,
        };
        let scalar = match (is_scalar, dtype) {
            (true, Some(_)) => h5::read_f64s(&file, path, &name)?.first().copied(),
            _ => None,
        };
        vars.push(MatVar {
            name,
            dims,
            dtype,
            class,
            array,
            scalar,
        });
    }
    Ok(vars)
}

/// One variable for [`v5_bytes`]: name, dims, class code, storage type, raw bytes.
pub type V5Var<'a> = (&'a str, &'a [usize], u8, u32, &'a [u8]);

/// A level-5 MAT file of numeric variables `(name, dims, class code, storage type, raw
/// little-endian bytes column-major)`, each in a miCOMPRESSED element when `compress`
/// (what `scipy.io.savemat(..., do_compression=True)` writes). For tests.
pub fn v5_bytes(vars: &[V5Var], compress: bool) -> Vec<u8> {
    fn element(out: &mut Vec<u8>, ty: u32, data: &[u8]) {
        out.extend_from_slice(&ty.to_le_bytes());
        out.extend_from_slice(&(data.len() as u32).to_le_bytes());
        out.extend_from_slice(data);
        out.resize(out.len().next_multiple_of(8), 0);
    }
    let mut header = b"MATLAB 5.0 MAT-file, written by femto's tests".to_vec();
    header.resize(116, b' ');
    header.extend_from_slice(&[0; 8]);
    header.extend_from_slice(&0x0100u16.to_le_bytes());
    header.extend_from_slice(b"IM");
    let mut out = header;
    for (name, dims, class, storage, raw) in vars {
        let mut body = Vec::new();
        element(
            &mut body,
            MI_UINT32,
            &[&u32::from(*class).to_le_bytes()[..], &[0; 4]].concat(),
        );
        let d: Vec<u8> = dims
            .iter()
            .flat_map(|&n| (n as i32).to_le_bytes())
            .collect();
        element(&mut body, MI_INT32, &d);
        element(&mut body, MI_INT8, name.as_bytes());
        element(&mut body, *storage, raw);
        let mut m = Vec::new();
        element(&mut m, MI_MATRIX, &body);
        if compress {
            let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
            std::io::Write::write_all(&mut z, &m).expect("in memory");
            let c = z.finish().expect("in memory");
            out.extend_from_slice(&MI_COMPRESSED.to_le_bytes());
            out.extend_from_slice(&(c.len() as u32).to_le_bytes());
            out.extend_from_slice(&c);
        } else {
            out.extend_from_slice(&m);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compressed_and_plain_variables_keep_matlab_indexing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.mat");
        // A(i, j, k) = 100 i + 10 j + k for dims (2, 3, 4), stored column-major as u16 in
        // a uint16 variable, and a 1 x 1 double.
        let (a, b, c) = (2usize, 3usize, 4usize);
        let mut raw = Vec::new();
        for k in 0..c {
            for j in 0..b {
                for i in 0..a {
                    raw.extend_from_slice(&((100 * i + 10 * j + k) as u16).to_le_bytes());
                }
            }
        }
        let width = 0.35f64.to_le_bytes();
        for compress in [false, true] {
            let bytes = v5_bytes(
                &[
                    ("width", &[1, 1], 6, 9, &width),
                    ("rect", &[a, b, c], 11, 4, &raw),
                ],
                compress,
            );
            std::fs::write(&p, bytes).unwrap();
            let vars = read_mat(&p, &|_| true).unwrap();
            assert_eq!(vars.len(), 2);
            let r = vars[1].array.as_ref().unwrap();
            assert_eq!(vars[1].class, "uint16");
            assert_eq!((r.shape.as_slice(), r.dtype), (&[2, 3, 4][..], Dtype::U16));
            assert_eq!(r.values[(b + 2) * c + 3], 123.0);
            assert_eq!(vars[0].scalar, Some(0.35));
        }
        // Truncated: one line naming the element.
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 10]).unwrap();
        assert!(read_mat(&p, &|_| true).is_err());
    }
}

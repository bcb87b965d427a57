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

use super::array::{element_count, Array};
use super::dtype::{decode, value_f64, Dtype};
use super::h5;
use super::ReaderError;
use std::io::Read;
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

/// Read every variable of the `.mat` file at `path`; numeric arrays with their values
/// when `read_values` accepts their name.
pub fn read_mat(
    path: &Path,
    read_values: &dyn Fn(&str) -> bool,
) -> Result<Vec<MatVar>, ReaderError> {
    let mut head = [0u8; 20];
    let n = std::fs::File::open(path)
        .and_then(|mut f| f.read(&mut head))
        .map_err(|source| ReaderError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    if is_v73_header(&head[..n]) {
        return read_v73(path, read_values);
    }
    // A v5 file is read whole: its bytes, and up to 8 bytes of decoded f32 values (a
    // column-major reorder included) per stored byte, checked against the budget first.
    let bytes = super::read_whole(path, 8)?;
    if !is_v5_header(&bytes) {
        return Err(ReaderError::invalid(
            path,
            "mat header",
            "not a MATLAB .mat file (no 'MATLAB 5.0 MAT-file' or 'MATLAB 7.3 MAT-file' text)",
        ));
    }
    let big = match &bytes[126..128] {
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
    let mut vars = Vec::new();
    let mut at = 128usize;
    while at < bytes.len() {
        let (ty, n, data_at) = tag(path, &bytes, at, big)?;
        let body = bytes
            .get(data_at..data_at + n)
            .ok_or_else(|| truncated(path, at))?;
        match ty {
            MI_MATRIX => vars.push(matrix(path, body, big, read_values)?),
            MI_COMPRESSED => {
                let inner = inflate(path, body, big)?;
                let (ity, inn, idata) = tag(path, &inner, 0, big)?;
                let ibody = inner
                    .get(idata..idata + inn)
                    .ok_or_else(|| truncated(path, at))?;
                if ity == MI_MATRIX {
                    vars.push(matrix(path, ibody, big, read_values)?);
                }
            }
            _ => {}
        }
        // Elements are padded to 8 bytes; compressed ones are not.
        at = data_at
            + if ty == MI_COMPRESSED {
                n
            } else {
                n.next_multiple_of(8)
            };
    }
    Ok(vars)
}

fn truncated(path: &Path, at: usize) -> ReaderError {
    ReaderError::invalid(
        path,
        "mat data",
        format!("the element at byte {at} runs past the end of the file (truncated?)"),
    )
}

fn u32_at(bytes: &[u8], at: usize, big: bool) -> Option<u32> {
    let b: [u8; 4] = bytes.get(at..at + 4)?.try_into().ok()?;
    Some(if big {
        u32::from_be_bytes(b)
    } else {
        u32::from_le_bytes(b)
    })
}

/// The tag at `at`: type, number of bytes, where the data start. A small element (its
/// size in the upper half of the first word) holds up to 4 bytes inside the tag.
fn tag(
    path: &Path,
    bytes: &[u8],
    at: usize,
    big: bool,
) -> Result<(u32, usize, usize), ReaderError> {
    let first = u32_at(bytes, at, big).ok_or_else(|| truncated(path, at))?;
    if first >> 16 != 0 {
        return Ok((first & 0xffff, (first >> 16) as usize, at + 4));
    }
    let n = u32_at(bytes, at + 4, big).ok_or_else(|| truncated(path, at))?;
    Ok((first, n as usize, at + 8))
}

/// Decompress a miCOMPRESSED element, refusing one that would not fit in memory.
fn inflate(path: &Path, body: &[u8], big: bool) -> Result<Vec<u8>, ReaderError> {
    let mut z = flate2::read::ZlibDecoder::new(body);
    let mut head = [0u8; 8];
    z.read_exact(&mut head)
        .map_err(|e| ReaderError::invalid(path, "mat data", format!("compressed element: {e}")))?;
    // The inner element's declared size bounds what is decompressed.
    let declared = u64::from(u32_at(&head, 4, big).expect("4 bytes"));
    crate::limits::check_memory(
        declared as f64 * 2.0,
        format!("a compressed MATLAB variable of {declared} bytes"),
        "save it in parts",
    )
    .map_err(|source| ReaderError::Limit {
        path: path.to_path_buf(),
        source,
    })?;
    let mut out = head.to_vec();
    z.take(declared + 8)
        .read_to_end(&mut out)
        .map_err(|e| ReaderError::invalid(path, "mat data", format!("compressed element: {e}")))?;
    Ok(out)
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

/// The sub-elements of a miMATRIX: flags, dimensions, name, real part.
fn matrix(
    path: &Path,
    body: &[u8],
    big: bool,
    read_values: &dyn Fn(&str) -> bool,
) -> Result<MatVar, ReaderError> {
    let mut at = 0usize;
    let mut next = |what: &str| -> Result<(u32, &[u8]), ReaderError> {
        let (ty, n, d) = tag(path, body, at, big)?;
        let data = body.get(d..d + n).ok_or_else(|| {
            ReaderError::invalid(
                path,
                "mat data",
                format!("a variable's {what} is truncated"),
            )
        })?;
        at = d + n.next_multiple_of(if d == at + 4 { 4 } else { 8 });
        Ok((ty, data))
    };
    let (fty, flags) = next("array flags")?;
    let flags0 = match (fty, flags.len() >= 4) {
        (MI_UINT32, true) => u32_at(flags, 0, big).expect("4 bytes"),
        _ => return Err(ReaderError::invalid(path, "mat data", "bad array flags")),
    };
    let (mut dtype, class) = class_dtype((flags0 & 0xff) as u8);
    let complex = flags0 & 0x0800 != 0;
    let (dty, dims_bytes) = next("dimensions")?;
    if dty != MI_INT32 {
        return Err(ReaderError::invalid(path, "mat data", "bad dimensions"));
    }
    let dims: Vec<usize> = dims_bytes
        .chunks_exact(4)
        .map(|b| u32_at(b, 0, big).expect("4 bytes") as i32)
        .map(|d| usize::try_from(d).unwrap_or(usize::MAX))
        .collect();
    let (nty, name_bytes) = next("name")?;
    if nty != MI_INT8 && nty != 2 {
        return Err(ReaderError::invalid(path, "mat data", "bad variable name"));
    }
    let name = String::from_utf8_lossy(name_bytes).into_owned();
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
    let bad = |m: String| ReaderError::invalid(path, &var.name, m);
    let count = element_count(&var.dims)
        .filter(|_| var.dims.iter().all(|&d| d != usize::MAX))
        .ok_or_else(|| bad(format!("dimensions {:?}", var.dims)))?;
    let (rty, real) = next("values")?;
    let stored = storage_dtype(rty).ok_or_else(|| bad(format!("data type {rty}")))?;
    if real.len() != count * stored.size() {
        return Err(bad(format!(
            "{} bytes of values for dimensions {:?} ({} expected)",
            real.len(),
            var.dims,
            count * stored.size()
        )));
    }
    if is_scalar {
        var.scalar = value_f64(real, stored, big);
    }
    // The stored type, as scipy.io.loadmat returns it: MATLAB saves a double array of
    // counts as uint16 when every value fits (data_s_u.mat's rect_data does).
    let decoded = decode(real, stored, big);
    var.array = Some(Array::new(var.dims.clone(), stored, decoded, true));
    Ok(var)
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

//! NumPy `.npz` archives (`numpy.savez`, `numpy.savez_compressed`): a zip file of `.npy`
//! members, each one a dataset named without its `.npy` (`--dataset NAME`). Read with the
//! `zip` crate (stored and deflated members, zip64 for large arrays); each member's header
//! is read first and its declared size checked against the memory budget before its values
//! are decompressed.

use super::array::Array;
use super::npy::{check_declared, parse_header, read_npy_from, HEAD_BYTES};
use super::{Dtype, ReaderError};
use std::io::Read;
use std::path::Path;

fn open(path: &Path) -> Result<zip::ZipArchive<std::io::BufReader<std::fs::File>>, ReaderError> {
    let f = std::fs::File::open(path).map_err(|source| ReaderError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    zip::ZipArchive::new(std::io::BufReader::new(f))
        .map_err(|e| ReaderError::invalid(path, "npz", format!("not a readable zip archive: {e}")))
}

fn zip_err<'a>(path: &'a Path, member: &str) -> impl Fn(zip::result::ZipError) -> ReaderError + 'a {
    let member = member.to_string();
    move |e| ReaderError::invalid(path, &member, e.to_string())
}

/// Every `.npy` member: its name (without `.npy`), shape and sample type; members whose
/// header femto does not read (complex, object arrays) are left out.
pub(super) fn members(path: &Path) -> Result<Vec<(String, Vec<usize>, Dtype)>, ReaderError> {
    let mut z = open(path)?;
    let mut out = Vec::new();
    for i in 0..z.len() {
        let mut m = z.by_index(i).map_err(zip_err(path, "npz"))?;
        let Some(name) = m.name().strip_suffix(".npy").map(str::to_string) else {
            continue;
        };
        let mut head = Vec::new();
        (&mut m)
            .take(HEAD_BYTES)
            .read_to_end(&mut head)
            .map_err(|e| ReaderError::invalid(path, &name, e.to_string()))?;
        if let Ok(h) = parse_header(path, &head) {
            out.push((name, h.shape, h.dtype));
        }
    }
    Ok(out)
}

/// The array of member `name` (`name.npy` in the archive).
pub(super) fn read_member(path: &Path, name: &str) -> Result<Array, ReaderError> {
    let file = format!("{name}.npy");
    let mut z = open(path)?;
    let (size, head) = {
        let mut m = z.by_name(&file).map_err(zip_err(path, &file))?;
        let mut head = Vec::new();
        (&mut m)
            .take(HEAD_BYTES)
            .read_to_end(&mut head)
            .map_err(|e| ReaderError::invalid(path, &file, e.to_string()))?;
        (m.size(), head)
    };
    let h = parse_header(path, &head)?;
    check_declared(path, &h, size)?;
    let m = z.by_name(&file).map_err(zip_err(path, &file))?;
    // Streamed, and bounded by the declared size whatever the stream holds.
    read_npy_from(path, m.take(size), size)
}

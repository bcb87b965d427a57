//! Opening HDF5 files and datasets for reading: the signature check that tells a missing
//! file and a non-HDF5 file apart from a corrupt one.

use super::error::{h5, ContainerError, Result};
use super::schema::{type_description, Elem};
use rust_hdf5::H5Dataset;
use rust_hdf5::H5File;
use rust_hdf5::Hdf5Error;
use std::fs::File;
use std::io;
use std::io::Read;
use std::io::Seek;
use std::io::SeekFrom;
use std::path::Path;

/// The 8-byte signature at the start of every HDF5 superblock.
pub(super) const HDF5_SIGNATURE: [u8; 8] = [0x89, b'H', b'D', b'F', b'\r', b'\n', 0x1a, b'\n'];

/// Whether the file at `path` is an HDF5 file: its signature sits at offset 0, or at 512,
/// 1024, 2048, ... when the file starts with a user block.
pub fn is_hdf5(path: &Path) -> io::Result<bool> {
    let mut f = File::open(path)?;
    let len = f.metadata()?.len();
    let mut offset = 0u64;
    let mut sig = [0u8; 8];
    while offset + 8 <= len {
        f.seek(SeekFrom::Start(offset))?;
        f.read_exact(&mut sig)?;
        if sig == HDF5_SIGNATURE {
            return Ok(true);
        }
        offset = if offset == 0 { 512 } else { offset * 2 };
    }
    Ok(false)
}

/// Open an existing HDF5 file for reading, telling a missing file and a non-HDF5 file
/// apart from a corrupt one.
pub(super) fn open_h5(path: &Path) -> Result<H5File> {
    match is_hdf5(path) {
        Err(source) => {
            return Err(ContainerError::Io {
                path: path.to_path_buf(),
                source,
            })
        }
        Ok(false) => {
            return Err(ContainerError::NotHdf5 {
                path: path.to_path_buf(),
            })
        }
        Ok(true) => {}
    }
    H5File::options()
        .best_effort_locking()
        .open(path)
        .map_err(h5(path))
}

/// Open the dataset at `name`, mapping "not found" to [`ContainerError::NoDataset`].
pub(super) fn open_dataset(file: &H5File, path: &Path, name: &str) -> Result<H5Dataset> {
    file.dataset(name).map_err(|e| match e {
        Hdf5Error::NotFound(_) => ContainerError::NoDataset {
            path: path.to_path_buf(),
            dataset: name.to_string(),
        },
        other => h5(path)(other),
    })
}

/// The element type of a reader-mode dataset.
pub(super) fn dataset_elem(ds: &H5Dataset, path: &Path) -> Result<(Option<Elem>, String)> {
    let dt = ds.datatype().map_err(h5(path))?;
    Ok((Elem::of(&dt), type_description(&dt)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signature_found_after_user_block() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x");
        let mut bytes = vec![0u8; 512];
        bytes.extend_from_slice(&HDF5_SIGNATURE);
        std::fs::write(&p, &bytes).unwrap();
        assert!(is_hdf5(&p).unwrap());
        std::fs::write(&p, b"\x89PNG\r\n\x1a\n").unwrap();
        assert!(!is_hdf5(&p).unwrap());
    }
}

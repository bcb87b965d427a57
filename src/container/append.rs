//! Copy-on-write appends: adding or replacing groups of an existing HDF5 file without
//! rewriting it ([`AppendFile`]).
//!
//! The file is opened for appending through the patched `rust_hdf5`
//! (`vendor/rust-hdf5/PATCH.md`) in its copy-on-write mode: everything new (the group's
//! datasets, every rewritten object header, the root group's included) goes past the old
//! end of the file, no byte of the old file is written (the file handle refuses it), and
//! the one write that switches readers to the new root is the superblock, under a hundred
//! bytes at offset 0, written last. So a reader, or a later command, sees either the old
//! file or the new one: an update that fails or is interrupted before that write leaves the
//! old file's bytes as they were, and is truncated back to its old length when it can be.
//! Everything else in the file (the cube, and whatever other tools such as h5py wrote) is
//! kept as it is, byte for byte.

use super::error::{h5, invalid, Result};
use rust_hdf5::H5File;
use std::fs::OpenOptions;
use std::io::Read;
use std::path::Path;
use std::path::PathBuf;

/// How many leading bytes of the old file are kept to tell, after a failed close, whether
/// the superblock (the commit) was written: more than any superblock (v0 with its root
/// symbol table entry is 96 bytes for 8-byte addresses; v2 and v3 are 48).
const HEAD_BYTES: usize = 256;

/// An HDF5 file open for a copy-on-write append. Dropped without [`AppendFile::commit`],
/// it writes nothing more (no object header, no superblock) and truncates the file back to
/// its old length.
pub(super) struct AppendFile {
    file: Option<H5File>,
    path: PathBuf,
    old_len: u64,
    old_head: Vec<u8>,
    /// Cuts the file back to `old_len` if the command is interrupted before the commit.
    interrupt: Option<crate::interrupt::Registration>,
}

impl AppendFile {
    /// Open the HDF5 file at `path` for a copy-on-write append. `Ok(None)` when the HDF5
    /// library cannot append to this file (a layout it does not model), for the caller to
    /// fall back to a rewrite.
    pub(super) fn open(path: &Path) -> Result<Option<AppendFile>> {
        let io = |source| super::error::ContainerError::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut old_head = Vec::with_capacity(HEAD_BYTES);
        let old = std::fs::File::open(path).map_err(io)?;
        let old_len = old.metadata().map_err(io)?.len();
        old.take(HEAD_BYTES as u64)
            .read_to_end(&mut old_head)
            .map_err(io)?;
        let Ok(file) = H5File::options().best_effort_locking().open_rw(path) else {
            return Ok(None);
        };
        let append = AppendFile {
            file: Some(file),
            path: path.to_path_buf(),
            old_len,
            old_head,
            interrupt: Some(crate::interrupt::register_append(path, old_len)),
        };
        if append.file().set_copy_on_write().is_err() {
            // Dropping `append` discards the session.
            return Ok(None);
        }
        Ok(Some(append))
    }

    /// The file being appended to.
    pub(super) fn file(&self) -> &H5File {
        self.file
            .as_ref()
            .expect("an AppendFile holds its file until commit")
    }

    /// Write the new object headers and, last, the superblock. On failure the old file is
    /// left as it was when the superblock was not written.
    pub(super) fn commit(mut self) -> Result<()> {
        let file = self
            .file
            .take()
            .expect("an AppendFile holds its file until commit");
        // A signal waits for the headers and the superblock, or comes before them (and the
        // file is cut back to its old length).
        let _commit = crate::interrupt::commit();
        // No fsync, as for every output of femto (`CubeSink::close`).
        let closed = file.close_no_sync();
        if let Some(r) = self.interrupt.take() {
            crate::interrupt::unregister(r);
        }
        match closed {
            Ok(()) => Ok(()),
            Err(e) => {
                let message = h5(&self.path)(e).to_string();
                if self.restore() {
                    Err(invalid(
                        &self.path,
                        format!("adding groups in place failed, the file is as it was: {message}"),
                    ))
                } else {
                    Err(invalid(&self.path, message))
                }
            }
        }
    }

    /// Truncate the file back to its old length if its superblock is still the old one
    /// (nothing committed); whether it was.
    fn restore(&self) -> bool {
        let mut head = Vec::with_capacity(HEAD_BYTES);
        let same = std::fs::File::open(&self.path)
            .and_then(|f| f.take(HEAD_BYTES as u64).read_to_end(&mut head))
            .is_ok()
            && head == self.old_head;
        same && OpenOptions::new()
            .write(true)
            .open(&self.path)
            .and_then(|f| f.set_len(self.old_len))
            .is_ok()
    }
}

impl Drop for AppendFile {
    fn drop(&mut self) {
        if let Some(file) = self.file.take() {
            file.discard();
            self.restore();
        }
        if let Some(r) = self.interrupt.take() {
            crate::interrupt::unregister(r);
        }
    }
}

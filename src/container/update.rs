//! Group updates: [`GroupUpdate`] adds or replaces extra groups of a cube file in place,
//! copy-on-write ([`super::append`]; the cube is not rewritten), or, where the HDF5 library
//! cannot append to the file, through a new file renamed onto it; it also writes side files
//! of groups only. [`write_groups`] does it with whole groups.

use super::append::AppendFile;
use super::attributes::{read_group_attrs, write_group_attrs};
use super::error::ContainerError;
use super::error::{h5, invalid, Result};
use super::foreign::{copy_foreign, FEMTO_OBJECTS};
use super::groups::{dataset_names_in, group_elem, open_group};
use super::open::open_dataset;
use super::read::CubeReader;
use super::schema::Provenance;
use super::schema::{
    chunk_rows, slab_rows, AttrValue, CubeCompression, DataBuf, DatasetSpec, GroupData,
    GROUP_DEFLATE_LEVEL,
};
use super::sinks::{check_group, create_group_dataset, write_group_rows, GroupSinks};
use super::write::write_cube;
use super::write::{commit, create_atomic, CubeAttrs, CubeSink, QuietFile};
use crate::atomic::AtomicFile;
use crate::cube::Cube;
use rust_hdf5::format::messages::filter::FILTER_DEFLATE;
use rust_hdf5::H5File;
use std::path::Path;
use std::path::PathBuf;

/// Add the given extra groups to the cube at `cube_path`, replacing groups of the same
/// names, atomically, as [`GroupUpdate`] does with groups streamed by rows.
pub fn write_groups(cube_path: &Path, groups: &[(&str, GroupData)]) -> Result<()> {
    for (i, (name, data)) in groups.iter().enumerate() {
        check_group(cube_path, name, data)?;
        if groups[..i].iter().any(|(o, _)| o == name) {
            return Err(invalid(cube_path, format!("group /{name} given twice")));
        }
    }
    let mut update = GroupUpdate::open(cube_path)?;
    for (name, data) in groups {
        update.write_group(name, data)?;
    }
    update.finish()
}

/// Copy every row of group `name` of `reader` into a new group of `file`.
pub(super) fn copy_group(reader: &CubeReader, file: &H5File, name: &str) -> Result<()> {
    let path = &reader.path;
    let e = h5(path);
    let src = open_group(&reader.file, path, name)?;
    let dst = file.create_group(name).map_err(&e)?;
    write_group_attrs(&dst, &read_group_attrs(&src, path, name)?).map_err(&e)?;
    for ds_name in dataset_names_in(&src, path, name)? {
        let (shape, _) = reader.group_dataset_shape(name, &ds_name)?;
        let full = format!("{name}/{ds_name}");
        let src_ds = open_dataset(&reader.file, path, &full)?;
        let elem = group_elem(&src_ds, path, &full)?;
        // Stored as it was: uncompressed, or deflated at its level.
        let compression = match src_ds
            .filters()
            .map_err(&e)?
            .iter()
            .find(|f| f.id == FILTER_DEFLATE)
        {
            Some(f) => CubeCompression::Deflate(
                f.cd_values
                    .first()
                    .copied()
                    .unwrap_or(GROUP_DEFLATE_LEVEL)
                    .min(9),
            ),
            None => CubeCompression::None,
        };
        let ds = create_group_dataset(&dst, &ds_name, elem, &shape, compression).map_err(&e)?;
        let row_bytes = shape[1..].iter().product::<usize>() * elem.size();
        let step = slab_rows(row_bytes, shape[0]);
        for r0 in (0..shape[0]).step_by(step) {
            let n = step.min(shape[0] - r0);
            let slab = reader.read_group_rows(name, &ds_name, r0, n)?;
            write_group_rows(&ds, &shape, compression, r0, &slab).map_err(&e)?;
        }
    }
    Ok(())
}

/// What a [`GroupUpdate`] writes into.
pub(super) enum UpdateTarget {
    /// The cube file itself, appended to copy-on-write.
    InPlace { file: AppendFile },
    /// A copy of a cube file (the fallback where the HDF5 library cannot append to it); its
    /// groups not rewritten are copied at the end.
    Cube {
        sink: Box<CubeSink>,
        reader: Box<CubeReader>,
    },
    /// A file holding groups only.
    SideFile { file: QuietFile },
}

impl UpdateTarget {
    /// The file being written.
    fn file(&self) -> &H5File {
        match self {
            UpdateTarget::InPlace { file } => file.file(),
            UpdateTarget::Cube { sink, .. } => &sink.file,
            UpdateTarget::SideFile { file } => file,
        }
    }
}

/// Adds or replaces extra groups of an existing cube file, or writes a side file that holds
/// groups only, with datasets streamed by row slabs so that peak memory is one slab.
///
/// A cube file is appended to in place, copy-on-write (module `container::append`): the cube and
/// everything else in the file stay where they are, byte for byte, and the new groups
/// become visible with the last, small write of [`GroupUpdate::finish`]; dropping an
/// unfinished update leaves the old file as it was. Where the HDF5 library cannot append
/// to the file, and for a side file, everything goes to a temporary file beside the
/// destination, renamed onto it by [`GroupUpdate::finish`] (for a cube, the cube and mask
/// copied when the update is opened, and the groups that were not rewritten when it is
/// finished).
pub struct GroupUpdate {
    // Field order matters: the HDF5 file is closed before the temporary path is deleted.
    groups: GroupSinks,
    target: UpdateTarget,
    /// The temporary file of a rewrite or a side file; `None` in place.
    out: Option<AtomicFile>,
    /// The file updated or written, named in errors.
    dest: PathBuf,
}

impl GroupUpdate {
    /// Start an update of the cube file at `cube_path`: in place where the HDF5 library can
    /// append to it, else by a rewrite (copying its cube and mask now).
    pub fn open(cube_path: &Path) -> Result<GroupUpdate> {
        let reader = CubeReader::open(cube_path)?;
        if let Some(file) = AppendFile::open(cube_path)? {
            return Ok(GroupUpdate {
                groups: GroupSinks::default(),
                target: UpdateTarget::InPlace { file },
                out: None,
                dest: cube_path.to_path_buf(),
            });
        }
        Self::rewrite(reader)
    }

    /// Start an update that rewrites the cube file `reader` reads (copying its cube and
    /// mask now): the fallback of [`GroupUpdate::open`].
    pub(super) fn rewrite(reader: CubeReader) -> Result<GroupUpdate> {
        let cube_path = &reader.path.clone();
        let out = create_atomic(cube_path)?;
        let meta = reader.meta.clone();
        let attrs = CubeAttrs {
            axis: meta.axis,
            frame: meta.frame,
            units: &meta.units,
            femto_version: meta.femto_version.as_deref(),
            command_line: meta.command_line.as_deref(),
            notes: &meta.notes,
        };
        // The cube keeps its compression (level included).
        let compression = reader.stored_compression();
        let mut sink =
            CubeSink::create_with(out.path(), cube_path, meta.nx, meta.ny, &attrs, compression)?;
        let row_len = meta.row_len();
        // Chunks stored as this sink stores them are copied as they are (no decompression
        // and recompression); other rows are decoded and written.
        let cx = chunk_rows(meta.axis.nt * 4, meta.nx);
        let raw =
            matches!(sink.compression, CubeCompression::Deflate(_)) && reader.stored_as_written(cx);
        let rows = slab_rows(row_len * 4, meta.ny);
        let mut buf = vec![0.0f32; rows * row_len];
        for y0 in (0..meta.ny).step_by(rows) {
            let n = rows.min(meta.ny - y0);
            let copied = raw
                .then(|| {
                    (y0..y0 + n)
                        .map(|y| reader.read_raw_row(y, meta.nx.div_ceil(cx)))
                        .collect::<Option<Vec<_>>>()
                })
                .flatten();
            match copied {
                Some(slab) => {
                    for (y, chunks) in (y0..).zip(&slab) {
                        sink.write_raw_row(y, chunks)?;
                    }
                }
                None => {
                    reader.read_rows_into(y0, &mut buf[..n * row_len])?;
                    sink.write_rows(y0, &buf[..n * row_len])?;
                }
            }
        }
        drop(buf);
        if let Some(mask) = reader.read_mask()? {
            sink.write_mask(&mask)?;
        }
        Ok(GroupUpdate {
            groups: GroupSinks::default(),
            target: UpdateTarget::Cube {
                sink: Box::new(sink),
                reader: Box::new(reader),
            },
            out: Some(out),
            dest: cube_path.to_path_buf(),
        })
    }

    /// Start a new side file at `path` that will hold groups only (no `/cube`); read it back
    /// with [`GroupReader`].
    ///
    /// [`GroupReader`]: super::GroupReader
    pub fn side_file(path: &Path) -> Result<GroupUpdate> {
        let out = create_atomic(path)?;
        let file = H5File::options()
            .best_effort_locking()
            .create(out.path())
            .map_err(h5(path))?;
        Ok(GroupUpdate {
            groups: GroupSinks::default(),
            target: UpdateTarget::SideFile {
                file: QuietFile(Some(file)),
            },
            out: Some(out),
            dest: path.to_path_buf(),
        })
    }

    /// Create group `name` with its attributes and empty datasets, to be filled by
    /// [`GroupUpdate::write_group_rows`]. A group of that name in the old file is replaced.
    pub fn begin_group(
        &mut self,
        name: &str,
        attrs: &[(String, AttrValue)],
        datasets: &[DatasetSpec],
    ) -> Result<()> {
        let _io = self.io_section();
        self.unlink_old(name)?;
        let file = self.target.file();
        self.groups.begin(file, &self.dest, name, attrs, datasets)
    }

    /// In place, every write to the cube file runs inside an interrupt commit section: a
    /// signal waits for the write under way and then holds the section while it cuts the
    /// file back, so no write lands after the cut (a rewrite writes a temporary file, which
    /// the handler removes: no section needed).
    fn io_section(&self) -> Option<crate::interrupt::Commit> {
        matches!(self.target, UpdateTarget::InPlace { .. }).then(crate::interrupt::commit)
    }

    /// In place, delete group `name` of the old file (if it has one) before it is written
    /// again; its bytes stay where they are until the update is finished.
    fn unlink_old(&mut self, name: &str) -> Result<()> {
        let UpdateTarget::InPlace { file } = &self.target else {
            return Ok(());
        };
        if self.groups.written.iter().any(|g| g == name) {
            return Ok(());
        }
        let file = file.file();
        let e = h5(&self.dest);
        if file
            .root_group()
            .group_names()
            .map_err(&e)?
            .iter()
            .any(|g| g == name)
        {
            file.delete_group(name).map_err(&e)?;
        }
        Ok(())
    }

    /// Write rows `r0 ..` of dataset `dataset` of group `group` (begun before).
    pub fn write_group_rows(
        &mut self,
        group: &str,
        dataset: &str,
        r0: usize,
        rows: &DataBuf,
    ) -> Result<()> {
        let _io = self.io_section();
        self.groups.write_rows(&self.dest, group, dataset, r0, rows)
    }

    /// Write a whole group at once.
    pub fn write_group(&mut self, name: &str, data: &GroupData) -> Result<()> {
        let _io = self.io_section();
        self.unlink_old(name)?;
        let file = self.target.file();
        self.groups.write_whole(file, &self.dest, name, data)
    }

    /// Check that every row was written, copy the untouched groups of the old cube file,
    /// close the file and rename it onto the destination.
    pub fn finish(self) -> Result<()> {
        self.finish_staged()?.persist()
    }

    /// [`GroupUpdate::finish`] but the commit (the rename, or in place the final write of
    /// the headers and the superblock): the file stays as it was until
    /// [`StagedFile::persist`], for a command that commits several outputs together.
    pub fn finish_staged(self) -> Result<StagedFile> {
        let GroupUpdate {
            groups,
            target,
            out,
            dest,
        } = self;
        let written = groups.written.clone();
        let io = matches!(target, UpdateTarget::InPlace { .. }).then(crate::interrupt::commit);
        groups.close(&dest)?;
        drop(io);
        let out = match (target, out) {
            (UpdateTarget::InPlace { file }, _) => return Ok(StagedFile(Staged::InPlace(file))),
            (target, Some(out)) => (target, out),
            (_, None) => unreachable!("a rewrite or side file has its temporary file"),
        };
        let (target, out) = out;
        match target {
            UpdateTarget::InPlace { .. } => unreachable!("returned above"),
            UpdateTarget::Cube { sink, reader } => {
                // femto's own groups through femto's reader; everything else another tool
                // wrote (root attributes, groups, datasets) as it is.
                for old in &reader.meta.groups {
                    if !written.contains(old) && FEMTO_OBJECTS.contains(&old.as_str()) {
                        copy_group(&reader, &sink.file, old)?;
                    }
                }
                copy_foreign(&reader.file, &reader.path, &sink.file, &dest, &written)?;
                drop(reader);
                sink.close()?;
            }
            UpdateTarget::SideFile { file } => file.into_inner().close().map_err(h5(&dest))?,
        }
        Ok(StagedFile(Staged::Renamed(out)))
    }
}

/// A finished update not yet committed (dropping it leaves the destination as it was).
pub struct StagedFile(Staged);

/// What a [`StagedFile`] holds.
enum Staged {
    /// A new file under its temporary name beside its destination.
    Renamed(AtomicFile),
    /// A copy-on-write append whose headers and superblock are not written yet.
    InPlace(AppendFile),
}

impl StagedFile {
    /// Commit: rename the file onto its destination, or write the appended file's headers
    /// and, last, its superblock.
    pub fn persist(self) -> Result<()> {
        match self.0 {
            Staged::Renamed(out) => commit(out),
            Staged::InPlace(file) => file.commit(),
        }
    }
}

/// Write `cube` and its extra `groups` to `path` atomically: both go into a staged file that
/// is renamed onto `path` only when all are in.
pub fn write_cube_with_groups(
    path: &Path,
    cube: &Cube,
    provenance: &Provenance,
    groups: &[(&str, GroupData)],
) -> Result<()> {
    let io = |source| ContainerError::Io {
        path: path.to_path_buf(),
        source,
    };
    crate::atomic::write_atomically_with(path, io, |tmp| {
        write_cube(tmp, cube, provenance)?;
        if !groups.is_empty() {
            write_groups(tmp, groups)?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::container::error::ContainerError;
    use crate::container::groups::GroupReader;
    use crate::container::read::{read_cube, CubeReader};
    use crate::container::schema::{chunk_rows, GroupElem};
    use crate::container::write::camera_writer;
    use crate::cube::TimeAxis;

    /// The fallback rewrite copies the cube: chunk by chunk as stored when femto's writer
    /// made it (deflate at any level), decoded and written again otherwise (an uncompressed
    /// cube); the cube, its mask and its compression come back unchanged either way.
    #[test]
    fn group_update_copies_the_cube_raw_or_decoded() {
        let dir = tempfile::tempdir().unwrap();
        let (nx, ny, nt) = (300, 3, 512);
        let axis = TimeAxis {
            t0_ps: 1.0,
            dt_ps: 2.0,
            nt,
        };
        let data: Vec<f32> = (0..nx * ny * nt).map(|i| (i % 97) as f32 - 3.5).collect();
        let mask: Vec<u8> = (0..nx * ny).map(|i| u8::from(i % 4 != 0)).collect();
        for (compression, raw) in [
            (CubeCompression::Deflate(6), true),
            (CubeCompression::None, false),
        ] {
            let p = dir.path().join(format!("{compression:?}.h5"));
            let mut w = camera_writer(&p, nx, ny, axis, compression).unwrap();
            w.write_rows(0, &data).unwrap();
            w.write_mask(&mask).unwrap();
            w.finish().unwrap();
            let cx = chunk_rows(nt * 4, nx);
            assert!(cx < nx, "the test needs several chunks per row");
            assert_eq!(CubeReader::open(&p).unwrap().stored_as_written(cx), raw);
            let mut u = GroupUpdate::rewrite(CubeReader::open(&p).unwrap()).unwrap();
            u.begin_group("g", &[], &[DatasetSpec::new("d", &[2, 3], GroupElem::F64)])
                .unwrap();
            u.write_group_rows("g", "d", 0, &DataBuf::F64(vec![1.0; 6]))
                .unwrap();
            u.finish().unwrap();
            let back = read_cube(&p).unwrap();
            assert_eq!(back.data, data, "{compression:?}");
            assert_eq!(back.mask.as_deref(), Some(&mask[..]));
            // The cube keeps its compression: an uncompressed cube stays uncompressed.
            let reader = CubeReader::open(&p).unwrap();
            assert_eq!(reader.stored_compression(), compression);
            assert_eq!(reader.stored_as_written(cx), raw);
        }
    }

    /// The rewrite (the fallback where the HDF5 layer cannot append to a file) keeps what
    /// another tool wrote: h5py's root attributes, its group with its attributes and its
    /// dataset (tests/data/h5py, made by tools/make_h5py_fixtures.py).
    #[test]
    fn the_fallback_rewrite_keeps_what_h5py_wrote() {
        let dir = tempfile::tempdir().unwrap();
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/h5py/annotated.h5");
        let p = dir.path().join("annotated.h5");
        std::fs::copy(&src, &p).unwrap();
        let listing = |p: &Path| {
            let f = H5File::open(p).unwrap();
            let root = f.root_group();
            let notes = root.group("notes").unwrap();
            let trace = f.dataset("notes/trace").unwrap();
            let raw = |a: rust_hdf5::H5Attribute| match a.datatype().unwrap() {
                rust_hdf5::DatatypeMessage::VarLenString { .. } => {
                    format!("{:?}", a.read_strings().unwrap())
                }
                dt => format!("{dt:?} {:?} {:?}", a.dims().unwrap(), a.read_raw().unwrap()),
            };
            let mut v: Vec<String> = notes
                .attr_names()
                .unwrap()
                .into_iter()
                .map(|n| format!("{n} {}", raw(notes.attr(&n).unwrap())))
                .collect();
            v.extend(
                root.attr_names()
                    .unwrap()
                    .into_iter()
                    .map(|n| format!("/{n}")),
            );
            v.push(format!("{:?}", trace.read_raw_bytes().unwrap()));
            v.sort();
            v
        };
        let want = listing(&p);
        assert_eq!(want.len(), 8 + 2 + 1, "{want:?}");
        let cube = read_cube(&p).unwrap();
        let mut u = GroupUpdate::rewrite(CubeReader::open(&p).unwrap()).unwrap();
        assert!(matches!(u.target, UpdateTarget::Cube { .. }));
        u.write_group("g", &GroupData::default()).unwrap();
        u.finish().unwrap();
        assert_eq!(listing(&p), want);
        assert_eq!(read_cube(&p).unwrap(), cube);
        assert_eq!(GroupReader::open(&p).unwrap().groups(), ["g", "notes"]);
    }

    #[test]
    fn streamed_groups_must_be_complete_and_leave_nothing_on_failure() {
        let dir = tempfile::tempdir().unwrap();
        let side = dir.path().join("side.h5");
        let spec = [DatasetSpec::new("d", &[3, 2], GroupElem::F64)];
        let attrs = vec![("n".to_string(), AttrValue::I64(3))];
        // Row 2 never written: refused, and neither the file nor a temporary file remains.
        let mut up = GroupUpdate::side_file(&side).unwrap();
        up.begin_group("g", &attrs, &spec).unwrap();
        up.write_group_rows("g", "d", 0, &DataBuf::F64(vec![1.0, 2.0, 3.0, 4.0]))
            .unwrap();
        let e = up.finish().unwrap_err().to_string();
        assert!(e.contains("/g/d") && e.contains("row 2"), "{e}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        // Wrong type, past the end, undeclared dataset, then a complete file read back.
        let mut up = GroupUpdate::side_file(&side).unwrap();
        up.begin_group("g", &attrs, &spec).unwrap();
        assert!(up
            .write_group_rows("g", "d", 0, &DataBuf::F32(vec![0.0; 2]))
            .is_err());
        assert!(up
            .write_group_rows("g", "d", 2, &DataBuf::F64(vec![0.0; 4]))
            .is_err());
        assert!(up
            .write_group_rows("g", "e", 0, &DataBuf::F64(vec![0.0; 2]))
            .is_err());
        assert!(up.begin_group("g", &[], &[]).is_err());
        for r in [2, 0, 1] {
            let v = vec![r as f64, -(r as f64)];
            up.write_group_rows("g", "d", r, &DataBuf::F64(v)).unwrap();
        }
        up.finish().unwrap();
        let reader = GroupReader::open(&side).unwrap();
        assert!(!reader.has_cube());
        assert_eq!(reader.groups(), ["g"]);
        let g = reader.read_group("g").unwrap();
        assert_eq!(g.attrs, attrs);
        assert_eq!(
            g.dataset("d").unwrap(),
            (
                &[3usize, 2][..],
                &DataBuf::F64(vec![0.0, -0.0, 1.0, -1.0, 2.0, -2.0])
            )
        );
        assert!(matches!(
            CubeReader::open(&side),
            Err(ContainerError::NoCube { .. })
        ));
    }
}

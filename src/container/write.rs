//! Writing cubes: [`write_cube`] for a cube in memory, [`CubeWriter`] for one streamed by row
//! slabs, and the sink under both that creates `/cube` with its attributes and `/mask`.

use super::attributes::set_attr;
use super::compression::{CompressedRow, RowCompressor, RowStorage};
use super::error::{h5, invalid, ContainerError, Result};
use super::schema::{
    check_axis, check_name, chunk_rows, le_bytes, slab_rows, AttrValue, CubeCompression, DataBuf,
    DatasetSpec, GroupData, Provenance, CUBE_DATASET, DEFAULT_UNITS, DEFLATE_LEVEL, MASK_DATASET,
    RESERVED_ATTRS,
};
use super::sinks::GroupSinks;
use crate::atomic::{write_atomically, AtomicFile};
use crate::cube::Cube;
use crate::cube::TimeAxis;
use crate::cube::TimeFrame;
use rayon::prelude::*;
use rust_hdf5::H5Dataset;
use rust_hdf5::H5File;
use std::path::Path;
use std::path::PathBuf;

/// An open HDF5 file being written with a `/cube` dataset, not yet atomic: the callers put
/// it on a temporary path. `path` is the destination named in error messages.
pub(super) struct CubeSink {
    pub(super) cube: H5Dataset,
    pub(super) file: QuietFile,
    pub(super) compression: CubeCompression,
    pub(super) path: PathBuf,
    pub(super) nx: usize,
    pub(super) ny: usize,
    pub(super) nt: usize,
    pub(super) rows_written: Vec<bool>,
    pub(super) mask_written: bool,
}

/// What goes into the attributes of `/cube`.
pub(super) struct CubeAttrs<'a> {
    pub(super) axis: TimeAxis,
    pub(super) frame: TimeFrame,
    pub(super) units: &'a str,
    pub(super) femto_version: Option<&'a str>,
    pub(super) command_line: Option<&'a str>,
    pub(super) notes: &'a [(String, String)],
}

impl CubeSink {
    pub(super) fn create(
        tmp: &Path,
        path: &Path,
        nx: usize,
        ny: usize,
        attrs: &CubeAttrs,
    ) -> Result<Self> {
        Self::create_with(tmp, path, nx, ny, attrs, CubeCompression::default())
    }

    pub(super) fn create_with(
        tmp: &Path,
        path: &Path,
        nx: usize,
        ny: usize,
        attrs: &CubeAttrs,
        compression: CubeCompression,
    ) -> Result<Self> {
        if let CubeCompression::Deflate(level) = compression {
            if level > 9 {
                return Err(invalid(
                    path,
                    format!("deflate level {level} (levels are 0 to 9)"),
                ));
            }
        }
        check_axis(path, &attrs.axis)?;
        if nx == 0 || ny == 0 {
            return Err(invalid(
                path,
                format!("a cube needs pixels, not {nx} x {ny}"),
            ));
        }
        for (i, (k, _)) in attrs.notes.iter().enumerate() {
            check_name(path, "note", k)?;
            if RESERVED_ATTRS.contains(&k.as_str()) {
                return Err(invalid(
                    path,
                    format!("note '{k}' uses a reserved attribute name"),
                ));
            }
            if attrs.notes[..i].iter().any(|(o, _)| o == k) {
                return Err(invalid(path, format!("note '{k}' given twice")));
            }
        }
        let nt = attrs.axis.nt;
        let e = h5(path);
        let file = QuietFile(Some(
            H5File::options()
                .best_effort_locking()
                .create(tmp)
                .map_err(&e)?,
        ));
        let cx = chunk_rows(nt * 4, nx);
        let builder = file
            .new_dataset::<f32>()
            .shape([ny, nx, nt])
            .chunk(&[1, cx, nt]);
        let builder = match compression {
            CubeCompression::Deflate(level) => builder.shuffle_deflate(level),
            CubeCompression::None => builder,
        };
        let cube = builder.create(CUBE_DATASET).map_err(&e)?;
        set_attr(&cube, "t0_ps", &AttrValue::F64(attrs.axis.t0_ps)).map_err(&e)?;
        set_attr(&cube, "dt_ps", &AttrValue::F64(attrs.axis.dt_ps)).map_err(&e)?;
        let frame = AttrValue::Str(attrs.frame.as_str().to_string());
        set_attr(&cube, "time_frame", &frame).map_err(&e)?;
        set_attr(&cube, "units", &AttrValue::Str(attrs.units.to_string())).map_err(&e)?;
        if let Some(v) = attrs.femto_version {
            set_attr(&cube, "femto_version", &AttrValue::Str(v.to_string())).map_err(&e)?;
        }
        if let Some(c) = attrs.command_line {
            set_attr(&cube, "command_line", &AttrValue::Str(c.to_string())).map_err(&e)?;
        }
        for (k, v) in attrs.notes {
            set_attr(&cube, k, &AttrValue::Str(v.clone())).map_err(&e)?;
        }
        Ok(CubeSink {
            cube,
            file,
            compression,
            path: path.to_path_buf(),
            nx,
            ny,
            nt,
            rows_written: vec![false; ny],
            mask_written: false,
        })
    }

    /// Number of whole rows in `rows`, to be written from row `y0`; an error when they are
    /// not whole rows or run past the cube.
    pub(super) fn check_rows(&self, y0: usize, rows: &[f32]) -> Result<usize> {
        let row_len = self.nx * self.nt;
        if rows.is_empty() || !rows.len().is_multiple_of(row_len) {
            return Err(invalid(
                &self.path,
                format!(
                    "{} values are not a whole number of rows of {} x {} values",
                    rows.len(),
                    self.nx,
                    self.nt
                ),
            ));
        }
        let n = rows.len() / row_len;
        if y0 + n > self.ny {
            return Err(invalid(
                &self.path,
                format!("rows {y0}..{} past the cube's {} rows", y0 + n, self.ny),
            ));
        }
        Ok(n)
    }

    /// Write whole rows from row `y0`, compressed in parallel on rayon's threads (see
    /// [`RowCompressor`]) and appended as they are.
    pub(super) fn write_rows(&mut self, y0: usize, rows: &[f32]) -> Result<()> {
        self.check_rows(y0, rows)?;
        let compressor = self.row_compressor();
        let compressed: Vec<CompressedRow> = rows
            .par_chunks(compressor.row_len())
            .map(|row| compressor.compress(row))
            .collect();
        for (i, row) in compressed.iter().enumerate() {
            self.write_compressed_row(y0 + i, row)?;
        }
        Ok(())
    }

    /// A compressor for this cube's rows (see [`RowCompressor`]).
    pub(super) fn row_compressor(&self) -> RowCompressor {
        RowCompressor {
            nx: self.nx,
            nt: self.nt,
            cx: chunk_rows(self.nt * 4, self.nx),
            compression: self.compression,
        }
    }

    /// Write row `y` from chunks made by this sink's [`RowCompressor`], as they are (an
    /// uncompressed row from its own buffer, without a copy).
    pub(super) fn write_compressed_row(&mut self, y: usize, row: &CompressedRow) -> Result<()> {
        let s = self;
        let cx = chunk_rows(s.nt * 4, s.nx);
        let chunks = s.nx.div_ceil(cx);
        let fits = match &row.storage {
            RowStorage::Filtered { chunks: c, .. } => c.len() == chunks,
            RowStorage::Plain(values) => values.len() == s.nx * s.nt,
        };
        if y >= s.ny || row.nx != s.nx || row.nt != s.nt || !fits {
            return Err(invalid(
                &s.path,
                format!(
                    "compressed row {y} ({} x {} values) does not fit the cube's {} rows of \
                     {} x {} in {chunks} chunks",
                    row.nx, row.nt, s.ny, s.nx, s.nt
                ),
            ));
        }
        if matches!(row.storage, RowStorage::Filtered { .. })
            != matches!(s.compression, CubeCompression::Deflate(_))
        {
            return Err(invalid(
                &s.path,
                "compressed row made by another writer's compressor",
            ));
        }
        let e = h5(&s.path);
        match &row.storage {
            RowStorage::Filtered { chunks, .. } => {
                for (c, bytes) in chunks.iter().enumerate() {
                    s.cube
                        .write_chunk_raw_at(&[y, c, 0], bytes, 0)
                        .map_err(&e)?;
                }
            }
            RowStorage::Plain(values) => {
                let chunk_values = cx * s.nt;
                for (c, part) in values.chunks(chunk_values).enumerate() {
                    if part.len() == chunk_values {
                        s.cube
                            .write_chunk_at(&[y, c, 0], &le_bytes(part))
                            .map_err(&e)?;
                    } else {
                        // The edge chunk, padded with zeros as HDF5 stores it.
                        let mut padded = vec![0.0f32; chunk_values];
                        padded[..part.len()].copy_from_slice(part);
                        s.cube
                            .write_chunk_at(&[y, c, 0], &le_bytes(&padded))
                            .map_err(&e)?;
                    }
                }
            }
        }
        s.rows_written[y] = true;
        Ok(())
    }

    /// Store row `y` from chunks already filtered by this sink's pipeline (bytes and filter
    /// mask of each, as [`CubeReader::read_raw_row`] gives them).
    ///
    /// [`CubeReader::read_raw_row`]: super::CubeReader::read_raw_row
    pub(super) fn write_raw_row(&mut self, y: usize, chunks: &[(Vec<u8>, u32)]) -> Result<()> {
        for (c, (bytes, mask)) in chunks.iter().enumerate() {
            self.cube
                .write_chunk_raw_at(&[y, c, 0], bytes, *mask)
                .map_err(h5(&self.path))?;
        }
        self.rows_written[y] = true;
        Ok(())
    }

    pub(super) fn write_mask(&mut self, mask: &[u8]) -> Result<()> {
        if mask.len() != self.nx * self.ny {
            return Err(invalid(
                &self.path,
                format!(
                    "mask has {} values, expected {} x {}",
                    mask.len(),
                    self.ny,
                    self.nx
                ),
            ));
        }
        if self.mask_written {
            return Err(invalid(&self.path, "mask written twice"));
        }
        let e = h5(&self.path);
        let rows = chunk_rows(self.nx, self.ny);
        let ds = self
            .file
            .new_dataset::<u8>()
            .shape([self.ny, self.nx])
            .chunk(&[rows, self.nx])
            .deflate(DEFLATE_LEVEL)
            .create(MASK_DATASET)
            .map_err(&e)?;
        ds.write_raw(mask).map_err(&e)?;
        self.mask_written = true;
        Ok(())
    }

    /// Check every row was written and close the file.
    pub(super) fn close(self) -> Result<()> {
        if let Some(y) = self.rows_written.iter().position(|w| !w) {
            let n = self.rows_written.iter().filter(|w| !**w).count();
            return Err(invalid(
                &self.path,
                format!("{n} rows of the cube were never written (first: row {y})"),
            ));
        }
        let CubeSink {
            cube, file, path, ..
        } = self;
        drop(cube);
        // No fsync, as for every other output of femto (`atomic::write_atomically`) and as
        // the HDF5 library and h5py close files: the file is complete and renamed atomically
        // for other processes, and the operating system writes it to disk in its own time.
        // The fsync of `close` made the caller wait for the disk: 0.5 s or more of wall time
        // for a 825 MB cube on the benchmark machine (tools/bench_ingest_results.md).
        file.into_inner().close_no_sync().map_err(h5(&path))
    }
}

/// An HDF5 file being written that, dropped unclosed (a write failed: a full disk), is closed
/// without a word: the library would print a second error line on stderr, and the file is a
/// temporary one about to be deleted.
pub(super) struct QuietFile(pub(super) Option<H5File>);

impl QuietFile {
    pub(super) fn into_inner(mut self) -> H5File {
        self.0
            .take()
            .expect("a QuietFile holds its file until into_inner")
    }
}

impl std::ops::Deref for QuietFile {
    type Target = H5File;
    fn deref(&self) -> &H5File {
        self.0
            .as_ref()
            .expect("a QuietFile holds its file until into_inner")
    }
}

impl Drop for QuietFile {
    fn drop(&mut self) {
        if let Some(f) = self.0.take() {
            let _ = f.close_no_sync();
        }
    }
}

pub(super) fn write_sink_cube(sink: &mut CubeSink, cube: &Cube) -> Result<()> {
    let row_len = cube.nx * cube.nt();
    let rows = slab_rows(row_len * 4, cube.ny);
    for y0 in (0..cube.ny).step_by(rows) {
        let y1 = (y0 + rows).min(cube.ny);
        sink.write_rows(y0, &cube.data[y0 * row_len..y1 * row_len])?;
    }
    if let Some(m) = &cube.mask {
        sink.write_mask(m)?;
    }
    Ok(())
}

/// Write `cube` to `path` atomically, with units [`DEFAULT_UNITS`].
pub fn write_cube(path: &Path, cube: &Cube, provenance: &Provenance) -> Result<()> {
    write_cube_with_units(path, cube, DEFAULT_UNITS, provenance)
}

/// Write `cube` to `path` atomically, recording `units` for its values.
///
/// On failure any earlier file at `path` is left untouched and no temporary file remains.
pub fn write_cube_with_units(
    path: &Path,
    cube: &Cube,
    units: &str,
    provenance: &Provenance,
) -> Result<()> {
    if cube.data.len() != cube.nx * cube.ny * cube.nt() {
        return Err(invalid(
            path,
            format!(
                "cube data has {} values, expected {} x {} x {}",
                cube.data.len(),
                cube.ny,
                cube.nx,
                cube.nt()
            ),
        ));
    }
    let attrs = CubeAttrs {
        axis: cube.axis,
        frame: cube.frame,
        units,
        femto_version: Some(env!("CARGO_PKG_VERSION")),
        command_line: Some(&provenance.command_line),
        notes: &provenance.notes,
    };
    write_atomically(path, |tmp| {
        let mut sink = CubeSink::create(tmp, path, cube.nx, cube.ny, &attrs)?;
        write_sink_cube(&mut sink, cube)?;
        sink.close()
    })
    .map_err(|e| e.at(path))
}

/// Streaming writer of a cube file: rows are written in any order as slabs, so peak memory
/// is one slab whatever the cube's size.
///
/// The file is written to a temporary path beside the destination and renamed onto it by
/// [`CubeWriter::finish`]; dropping an unfinished writer deletes the temporary file and
/// leaves any earlier file at the destination untouched.
pub struct CubeWriter {
    // Field order matters: the HDF5 file is closed before the temporary path is deleted.
    groups: GroupSinks,
    sink: CubeSink,
    out: AtomicFile,
    /// The file whose other tools' objects are copied in at the end
    /// ([`CubeWriter::keep_foreign_from`]).
    foreign_from: Option<PathBuf>,
}

impl CubeWriter {
    /// Start writing a cube of `nx` by `ny` pixels on `axis` to `path`.
    pub fn create(
        path: &Path,
        nx: usize,
        ny: usize,
        axis: TimeAxis,
        frame: TimeFrame,
        units: &str,
        provenance: &Provenance,
    ) -> Result<CubeWriter> {
        Self::create_with(
            path,
            nx,
            ny,
            axis,
            frame,
            units,
            provenance,
            CubeCompression::default(),
        )
    }

    /// [`CubeWriter::create`] with a choice of compression for `/cube`.
    #[allow(clippy::too_many_arguments)]
    pub fn create_with(
        path: &Path,
        nx: usize,
        ny: usize,
        axis: TimeAxis,
        frame: TimeFrame,
        units: &str,
        provenance: &Provenance,
        compression: CubeCompression,
    ) -> Result<CubeWriter> {
        let out = create_atomic(path)?;
        let attrs = CubeAttrs {
            axis,
            frame,
            units,
            femto_version: Some(env!("CARGO_PKG_VERSION")),
            command_line: Some(&provenance.command_line),
            notes: &provenance.notes,
        };
        let sink = CubeSink::create_with(out.path(), path, nx, ny, &attrs, compression)?;
        Ok(CubeWriter {
            groups: GroupSinks::default(),
            sink,
            out,
            foreign_from: None,
        })
    }

    /// Keep in the new cube what other tools wrote into the file at `source` (its root
    /// attributes, groups and datasets that are not femto's, such as an h5py user's
    /// notes): copied in by [`CubeWriter::finish`], which fails, naming it, on one femto
    /// cannot carry.
    pub fn keep_foreign_from(&mut self, source: &Path) {
        self.foreign_from = Some(source.to_path_buf());
    }

    /// Write rows `y0 .. y0 + n` from `rows` (`n * nx * nt` values, layout `[y][x][t]`).
    ///
    /// The rows are compressed in parallel on rayon's threads (see [`RowCompressor`]) and
    /// appended as they are.
    pub fn write_rows(&mut self, y0: usize, rows: &[f32]) -> Result<()> {
        self.sink.write_rows(y0, rows)
    }

    /// Write the validity mask (`ny * nx` bytes, `[y][x]`, 1 = valid). At most once.
    pub fn write_mask(&mut self, mask: &[u8]) -> Result<()> {
        self.sink.write_mask(mask)
    }

    /// Create extra group `name` with its attributes and empty datasets, to be filled by
    /// [`CubeWriter::write_group_rows`].
    pub fn begin_group(
        &mut self,
        name: &str,
        attrs: &[(String, AttrValue)],
        datasets: &[DatasetSpec],
    ) -> Result<()> {
        self.groups
            .begin(&self.sink.file, self.out.dest(), name, attrs, datasets)
    }

    /// Write rows `r0 ..` of dataset `dataset` of group `group` (begun before).
    pub fn write_group_rows(
        &mut self,
        group: &str,
        dataset: &str,
        r0: usize,
        rows: &DataBuf,
    ) -> Result<()> {
        self.groups
            .write_rows(self.out.dest(), group, dataset, r0, rows)
    }

    /// Write a whole extra group at once.
    pub fn write_group(&mut self, name: &str, data: &GroupData) -> Result<()> {
        self.groups
            .write_whole(&self.sink.file, self.out.dest(), name, data)
    }

    /// A compressor for this cube's rows, to run on worker threads (see [`RowCompressor`]).
    pub fn row_compressor(&self) -> RowCompressor {
        self.sink.row_compressor()
    }

    /// Write row `y` from chunks made by this writer's [`RowCompressor`]: the bytes are
    /// stored as they are, so the writer's thread does no compression (and, for an
    /// uncompressed cube, no copy: the row's values go to the file from where they are).
    pub fn write_compressed_row(&mut self, y: usize, row: &CompressedRow) -> Result<()> {
        self.sink.write_compressed_row(y, row)
    }

    /// Check every row (of the cube and of every group) was written, close the file and
    /// rename it onto the destination.
    pub fn finish(self) -> Result<()> {
        let CubeWriter {
            groups,
            sink,
            out,
            foreign_from,
        } = self;
        groups.close(out.dest())?;
        if let Some(source) = foreign_from {
            let src = super::open::open_h5(&source)?;
            super::foreign::copy_foreign(&src, &source, &sink.file, out.dest(), &[])?;
        }
        sink.close()?;
        commit(out)
    }
}

/// A new [`AtomicFile`] for `dest`, for a writer that holds it open across calls; an error
/// names `dest`.
pub(super) fn create_atomic(dest: &Path) -> Result<AtomicFile> {
    AtomicFile::create(dest).map_err(|e| ContainerError::from(e).at(dest))
}

/// Rename a finished [`AtomicFile`] onto its destination; an error names the destination.
pub(super) fn commit(file: AtomicFile) -> Result<()> {
    let dest = file.dest().to_path_buf();
    file.commit()
        .map_err(|source| ContainerError::Io { path: dest, source })
}

#[cfg(test)]
/// A writer of a camera-time test cube at `p`, for the tests of the writer and its neighbours.
pub(super) fn camera_writer(
    p: &Path,
    nx: usize,
    ny: usize,
    axis: TimeAxis,
    compression: CubeCompression,
) -> Result<CubeWriter> {
    CubeWriter::create_with(
        p,
        nx,
        ny,
        axis,
        TimeFrame::Camera,
        DEFAULT_UNITS,
        &Provenance::new("test"),
        compression,
    )
}

//! The chunk compressor of `/cube`: HDF5 shuffle + deflate of each chunk of a row, written by
//! hand on `rust_hdf5`'s filter internals so that rows compress on worker threads
//! ([`RowCompressor`]) and the writer only appends the bytes.

use super::schema::{chunk_rows, CubeCompression};
use rust_hdf5::format::messages::filter::apply_filters;
use rust_hdf5::FilterPipeline;

/// Compresses one row of a cube into the chunks of its `/cube` dataset (the writer's filters,
/// shuffle + deflate by default, and the chunk shape of the schema), without touching the
/// file.
///
/// Compression is the slow part of writing a cube and the writer runs it on one thread;
/// a `RowCompressor` (from [`CubeWriter::row_compressor`]) is `Send + Sync`, so streaming
/// commands compress rows on their worker threads and hand the bytes to
/// [`CubeWriter::write_compressed_row`], which only appends them to the file.
///
/// The chunks are standard HDF5 shuffle + deflate (zlib streams), which any HDF5 reader
/// decodes with its built-in filters. The deflate encoder depends on the level, each the
/// faster of the two measured on camera data (`examples/bench_chunk_compression.rs`,
/// `tools/bench_ingest_results.md`): miniz_oxide at level 1 (its fast greedy mode beat
/// libdeflate's level 1 by 1.5x in CPU for 5 % more bytes), libdeflate at every other level
/// (at level 4, 2.2x faster than miniz_oxide and 5 % smaller).
///
/// [`CubeWriter::row_compressor`]: super::CubeWriter::row_compressor
/// [`CubeWriter::write_compressed_row`]: super::CubeWriter::write_compressed_row
#[derive(Clone, Debug)]
pub struct RowCompressor {
    pub(super) nx: usize,
    pub(super) nt: usize,
    pub(super) cx: usize,
    pub(super) compression: CubeCompression,
}

/// One row of a cube as stored chunks, from [`RowCompressor::compress`].
#[derive(Clone, Debug)]
pub struct CompressedRow {
    pub(super) nx: usize,
    pub(super) nt: usize,
    pub(super) storage: RowStorage,
}

#[derive(Clone, Debug)]
pub(super) enum RowStorage {
    /// The chunks after shuffle + deflate; `row` is the buffer the values came in (kept only
    /// so the caller can reuse it, see [`CompressedRow::into_buffer`]).
    Filtered { chunks: Vec<Vec<u8>>, row: Vec<f32> },
    /// The values themselves (an unfiltered cube stores them as they are).
    Plain(Vec<f32>),
}

impl CompressedRow {
    /// Stored size, bytes (an unfiltered edge chunk counts its padding).
    pub fn stored_bytes(&self) -> usize {
        match &self.storage {
            RowStorage::Filtered { chunks, .. } => chunks.iter().map(Vec::len).sum(),
            RowStorage::Plain(values) => {
                let cx = chunk_rows(self.nt * 4, self.nx);
                values.len().div_ceil(cx * self.nt) * cx * self.nt * 4
            }
        }
    }

    /// The row buffer given to [`RowCompressor::compress_owned`], for reuse once the row is
    /// written (its contents are unspecified; empty when the row came from
    /// [`RowCompressor::compress`] of a filtered cube).
    pub fn into_buffer(self) -> Vec<f32> {
        match self.storage {
            RowStorage::Filtered { row, .. } => row,
            RowStorage::Plain(values) => values,
        }
    }
}

impl RowCompressor {
    /// Values in one row (`nx * nt`, layout `[x][t]`).
    pub fn row_len(&self) -> usize {
        self.nx * self.nt
    }

    /// Compress one row (`nx * nt` values, layout `[x][t]`). The last chunk along x is padded
    /// with zeros when `nx` is not a multiple of the chunk width, as HDF5 stores edge chunks.
    ///
    /// # Panics
    /// If `row.len() != self.row_len()` (a programming error, not bad input).
    pub fn compress(&self, row: &[f32]) -> CompressedRow {
        match self.compression {
            CubeCompression::None => self.compress_owned(row.to_vec()),
            CubeCompression::Deflate(_) => CompressedRow {
                nx: self.nx,
                nt: self.nt,
                storage: RowStorage::Filtered {
                    chunks: self.deflate_chunks(row),
                    row: Vec::new(),
                },
            },
        }
    }

    /// [`RowCompressor::compress`] of a row the caller gives away: an uncompressed cube
    /// keeps the values where they are (no copy), and [`CompressedRow::into_buffer`] hands
    /// the buffer back for the next row.
    ///
    /// # Panics
    /// If `row.len() != self.row_len()`.
    pub fn compress_owned(&self, row: Vec<f32>) -> CompressedRow {
        assert_eq!(row.len(), self.row_len(), "RowCompressor: row length");
        let storage = match self.compression {
            CubeCompression::None => RowStorage::Plain(row),
            CubeCompression::Deflate(_) => RowStorage::Filtered {
                chunks: self.deflate_chunks(&row),
                row,
            },
        };
        CompressedRow {
            nx: self.nx,
            nt: self.nt,
            storage,
        }
    }

    pub(super) fn deflate_chunks(&self, row: &[f32]) -> Vec<Vec<u8>> {
        assert_eq!(row.len(), self.row_len(), "RowCompressor: row length");
        let CubeCompression::Deflate(level) = self.compression else {
            unreachable!("deflate_chunks of an unfiltered cube")
        };
        let chunk_values = self.cx * self.nt;
        DEFLATE_SCRATCH.with_borrow_mut(|scratch| {
            row.chunks(chunk_values)
                .map(|values| scratch.shuffle_deflate(values, chunk_values, level))
                .collect()
        })
    }
}

thread_local! {
    /// Per-thread buffers and encoder of [`RowCompressor`].
    static DEFLATE_SCRATCH: std::cell::RefCell<DeflateScratch> =
        std::cell::RefCell::new(DeflateScratch::default());
}

/// The shuffled bytes of the chunk being compressed, and a libdeflate encoder of the last
/// level used (allocating one costs more than compressing a small chunk).
#[derive(Default)]
pub(super) struct DeflateScratch {
    shuffled: Vec<u8>,
    encoder: Option<(u32, libdeflater::Compressor)>,
}

impl DeflateScratch {
    /// HDF5 shuffle (element size 4) then deflate (zlib stream) of one chunk: `values`
    /// padded with zeros to `chunk_values`.
    pub(super) fn shuffle_deflate(
        &mut self,
        values: &[f32],
        chunk_values: usize,
        level: u32,
    ) -> Vec<u8> {
        // Shuffle: byte k of every value, for k = 0..4 (little-endian, the stored order).
        self.shuffled.clear();
        self.shuffled.resize(chunk_values * 4, 0);
        let (b0, rest) = self.shuffled.split_at_mut(chunk_values);
        let (b1, rest) = rest.split_at_mut(chunk_values);
        let (b2, b3) = rest.split_at_mut(chunk_values);
        for (i, v) in values.iter().enumerate() {
            [b0[i], b1[i], b2[i], b3[i]] = v.to_le_bytes();
        }
        if level == 1 {
            return apply_filters(&FilterPipeline::deflate(1), &self.shuffled)
                .expect("deflate cannot fail on a whole chunk");
        }
        let encoder = match &mut self.encoder {
            Some((l, e)) if *l == level => e,
            slot => {
                let lvl = libdeflater::CompressionLvl::new(level as i32)
                    .expect("levels 0-9 are libdeflate levels");
                &mut slot.insert((level, libdeflater::Compressor::new(lvl))).1
            }
        };
        let mut out = vec![0u8; encoder.zlib_compress_bound(self.shuffled.len())];
        let n = encoder
            .zlib_compress(&self.shuffled, &mut out)
            .expect("the output holds the compress bound");
        out.truncate(n);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::container::read::read_cube;
    use crate::container::write::camera_writer;
    use crate::cube::TimeAxis;

    #[test]
    fn compressed_rows_read_back_like_plain_rows() {
        // nx = 69 with nt = 1024 gives two 35-pixel chunks (at most 64 per chunk): one full
        // chunk and an edge chunk padded by one pixel.
        let (nx, ny, nt) = (69usize, 3usize, 1024usize);
        let axis = TimeAxis {
            t0_ps: -3.0,
            dt_ps: 0.5,
            nt,
        };
        let value = |y: usize, i: usize| ((y * 7919 + i * 104_729) % 10_007) as f32 * 0.25 - 9.0;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.h5");
        let mut w = camera_writer(&path, nx, ny, axis, CubeCompression::default()).unwrap();
        let compressor = w.row_compressor();
        assert_eq!(compressor.row_len(), nx * nt);
        for y in [2, 0] {
            let row: Vec<f32> = (0..nx * nt).map(|i| value(y, i)).collect();
            let c = compressor.compress(&row);
            assert!(c.stored_bytes() > 0);
            w.write_compressed_row(y, &c).unwrap();
        }
        let plain: Vec<f32> = (0..nx * nt).map(|i| value(1, i)).collect();
        w.write_rows(1, &plain).unwrap();
        let bad = RowCompressor {
            nx: nx - 1,
            ..compressor.clone()
        };
        assert!(w
            .write_compressed_row(0, &bad.compress(&plain[..(nx - 1) * nt]))
            .is_err());
        w.finish().unwrap();
        let back = read_cube(&path).unwrap();
        for y in 0..ny {
            for i in 0..nx * nt {
                assert_eq!(back.data[y * nx * nt + i], value(y, i), "y {y} i {i}");
            }
        }

        // Uncompressed cubes and every deflate level (miniz_oxide at 1, libdeflate at the
        // others) read back the same, from borrowed and from owned rows.
        let levels = (0..=9).map(CubeCompression::Deflate);
        for compression in std::iter::once(CubeCompression::None).chain(levels) {
            let p = dir.path().join("d.h5");
            let mut w = camera_writer(&p, nx, ny, axis, compression).unwrap();
            let row0: Vec<f32> = (0..nx * nt).map(|i| value(0, i)).collect();
            // Deflated chunks decode whatever their level; raw ones only fit an unfiltered cube.
            let foreign = w.write_compressed_row(0, &compressor.compress(&row0));
            assert_eq!(foreign.is_err(), compression == CubeCompression::None);
            let c = w.row_compressor();
            for y in 0..ny {
                let row: Vec<f32> = (0..nx * nt).map(|i| value(y, i)).collect();
                let packed = if y == 1 {
                    c.compress(&row)
                } else {
                    c.compress_owned(row.clone())
                };
                w.write_compressed_row(y, &packed).unwrap();
                if y != 1 || compression == CubeCompression::None {
                    // The buffer comes back for the next row.
                    assert_eq!(packed.into_buffer().len(), nx * nt);
                }
            }
            w.finish().unwrap();
            assert_eq!(read_cube(&p).unwrap().data, back.data, "{compression:?}");
        }
        assert!(camera_writer(
            &dir.path().join("e.h5"),
            nx,
            ny,
            axis,
            CubeCompression::Deflate(10)
        )
        .is_err());
    }
}

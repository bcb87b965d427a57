//! What deflate buys on the cube's chunks, and what it costs: the evidence behind the
//! compression default of `femto ingest` (`tools/bench_ingest_results.md`).
//!
//! Each input streak image (PNG, TIFF, HPD-TA `.img`, ...) is converted as ingest converts it
//! (f32, cube row layout `[x][t]`, times `--value-scale`, default 1) and cut into the cube's
//! chunks (whole time profiles, about 256 KiB, as `container` writes them). Every chunk is then
//! compressed, with and without the HDF5 shuffle filter, by miniz_oxide (through rust_hdf5's
//! filter pipeline, femto's writer before libdeflate) and by libdeflate, at each level asked
//! for. Printed per combination: ratio (f32 bytes / stored bytes) and CPU milliseconds per
//! MB of f32 on one thread (the thread's own CPU time from `/proc/thread-self/schedstat`, so
//! other load on the machine disturbs it little; wall time where that file is missing).
//!
//! Usage: `cargo run --release --example bench_chunk_compression -- [--levels 1,4,6]
//! [--value-scale S] FILE...` (files of different sizes are fine; all must decode).

use femto::formats::read_streak;
use femto::ingest::plan::to_row_layout;
use rust_hdf5::format::messages::filter::apply_filters;
use rust_hdf5::FilterPipeline;
use std::time::Instant;

fn main() {
    let mut levels = vec![1u32, 4, 6];
    let mut scale = 1.0f32;
    let mut files = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--levels" => {
                levels = args
                    .next()
                    .expect("--levels L1,L2,..")
                    .split(',')
                    .map(|s| s.parse().expect("a deflate level 0-9"))
                    .collect()
            }
            "--value-scale" => scale = args.next().expect("--value-scale S").parse().unwrap(),
            _ => files.push(std::path::PathBuf::from(a)),
        }
    }
    assert!(!files.is_empty(), "usage: bench_chunk_compression FILE...");

    // Chunks of every file: f32 little-endian bytes, whole time profiles, about 256 KiB.
    let mut chunks: Vec<Vec<u8>> = Vec::new();
    for path in &files {
        let img = read_streak(path, false).unwrap_or_else(|e| panic!("{e}"));
        let mut row = vec![0.0f32; img.nx * img.nt];
        to_row_layout(&img.data, img.nx, img.nt, scale, &mut row).expect("finite samples");
        let cx = (256 * 1024 / (4 * img.nt)).clamp(1, img.nx);
        let n = img.nx.div_ceil(cx);
        let cx = img.nx.div_ceil(n);
        for c in row.chunks(cx * img.nt) {
            chunks.push(c.iter().flat_map(|v| v.to_le_bytes()).collect());
        }
    }
    let raw_bytes: usize = chunks.iter().map(Vec::len).sum();
    println!(
        "{} files, {} chunks, {:.1} MB of f32",
        files.len(),
        chunks.len(),
        raw_bytes as f64 / 1e6
    );
    println!(
        "{:<12} {:>5} {:>8} {:>8} {:>10}",
        "backend", "level", "shuffle", "ratio", "ms/MB"
    );
    for &level in &levels {
        for shuffle in [false, true] {
            // miniz_oxide through the HDF5 filter pipeline.
            let pipeline = if shuffle {
                FilterPipeline::shuffle_deflate(4, level)
            } else {
                FilterPipeline::deflate(level)
            };
            let start = CpuClock::now();
            let stored: usize = chunks
                .iter()
                .map(|c| apply_filters(&pipeline, c).expect("filters").len())
                .sum();
            report("miniz_oxide", level, shuffle, raw_bytes, stored, start);

            // libdeflate, zlib format (what HDF5's deflate filter stores).
            let mut compressor = libdeflater::Compressor::new(
                libdeflater::CompressionLvl::new(level as i32).expect("level 0-12"),
            );
            let mut shuffled = Vec::new();
            let mut out = Vec::new();
            let start = CpuClock::now();
            let mut stored = 0;
            for c in &chunks {
                let input = if shuffle {
                    shuffle4(c, &mut shuffled);
                    &shuffled[..]
                } else {
                    &c[..]
                };
                out.resize(compressor.zlib_compress_bound(input.len()), 0);
                stored += compressor.zlib_compress(input, &mut out).expect("bound");
            }
            report("libdeflate", level, shuffle, raw_bytes, stored, start);
        }
    }
}

/// HDF5 shuffle of 4-byte elements: byte k of every element, for k = 0..4.
fn shuffle4(bytes: &[u8], out: &mut Vec<u8>) {
    out.resize(bytes.len(), 0);
    let n = bytes.len() / 4;
    let (p0, rest) = out.split_at_mut(n);
    let (p1, rest) = rest.split_at_mut(n);
    let (p2, p3) = rest.split_at_mut(n);
    for (i, b) in bytes.chunks_exact(4).enumerate() {
        (p0[i], p1[i], p2[i], p3[i]) = (b[0], b[1], b[2], b[3]);
    }
}

/// CPU time of the calling thread (wall time where the kernel does not say).
struct CpuClock {
    cpu_ns: Option<u64>,
    wall: Instant,
}

impl CpuClock {
    fn cpu_ns() -> Option<u64> {
        let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
        s.split_whitespace().next()?.parse().ok()
    }

    fn now() -> CpuClock {
        CpuClock {
            cpu_ns: Self::cpu_ns(),
            wall: Instant::now(),
        }
    }

    fn elapsed_ms(&self) -> f64 {
        match (self.cpu_ns, Self::cpu_ns()) {
            (Some(a), Some(b)) => (b - a) as f64 / 1e6,
            _ => self.wall.elapsed().as_secs_f64() * 1e3,
        }
    }
}

fn report(backend: &str, level: u32, shuffle: bool, raw: usize, stored: usize, start: CpuClock) {
    let ms = start.elapsed_ms();
    println!(
        "{backend:<12} {level:>5} {:>8} {:>8.3} {:>10.2}",
        if shuffle { "yes" } else { "no" },
        raw as f64 / stored as f64,
        ms / (raw as f64 / 1e6)
    );
}

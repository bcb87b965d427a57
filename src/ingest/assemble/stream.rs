//! The streaming machinery of an ingest: a pool of row buffers, the scratch file of a
//! two-pass ingest (uncompressed rows on disk, not in memory), and the ordered parallel
//! pipeline that decodes rows on worker threads, at most `2 x threads + 2` in flight, and
//! hands them to the calling thread in order.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::{mpsc, Condvar, Mutex};

use crate::ingest::IngestError;

/// Rows in flight per worker thread (decoded or being written).
const ROWS_IN_FLIGHT_PER_THREAD: usize = 2;

/// Row buffers handed back after a row is written, for the next rows to decode into: so
/// streaming allocates (and the kernel zero-fills) a few rows per thread, not one per
/// scanline.
pub(super) struct RowPool {
    free: Mutex<Vec<Vec<f32>>>,
    row_len: usize,
}

impl RowPool {
    pub(super) fn new(row_len: usize) -> RowPool {
        RowPool {
            free: Mutex::new(Vec::new()),
            row_len,
        }
    }

    /// A buffer of `row_len` values (contents unspecified: the caller overwrites them all).
    pub(super) fn take(&self) -> Vec<f32> {
        let mut row = self
            .free
            .lock()
            .expect("pool lock")
            .pop()
            .unwrap_or_default();
        row.resize(self.row_len, 0.0);
        row
    }

    /// Keep `row` for a later [`RowPool::take`] (at most a window's worth are kept).
    pub(super) fn give(&self, row: Vec<f32>) {
        let mut free = self.free.lock().expect("pool lock");
        if row.capacity() >= self.row_len && free.len() < 64 {
            free.push(row);
        }
    }
}

/// Uncompressed rows of a two-pass ingest in an anonymous temporary file (removed by the
/// operating system when closed).
pub(super) struct Scratch {
    file: Mutex<File>,
    row_len: usize,
    dir: PathBuf,
}

impl Scratch {
    pub(super) fn create(dir: &Path, row_len: usize) -> Result<Scratch, IngestError> {
        let file = tempfile::tempfile_in(dir).map_err(|source| IngestError::Scratch {
            dir: dir.to_path_buf(),
            source,
        })?;
        Ok(Scratch {
            file: Mutex::new(file),
            row_len,
            dir: dir.to_path_buf(),
        })
    }

    fn err(&self) -> impl FnOnce(std::io::Error) -> IngestError + '_ {
        move |source| IngestError::Scratch {
            dir: self.dir.clone(),
            source,
        }
    }

    pub(super) fn write_row(&self, y: usize, row: &[f32]) -> Result<(), IngestError> {
        debug_assert_eq!(row.len(), self.row_len);
        let mut bytes = Vec::with_capacity(row.len() * 4);
        for v in row {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        let mut f = self.file.lock().expect("scratch lock");
        f.seek(SeekFrom::Start((y * self.row_len * 4) as u64))
            .map_err(self.err())?;
        f.write_all(&bytes).map_err(self.err())
    }

    pub(super) fn read_row(&self, y: usize) -> Result<Vec<f32>, IngestError> {
        let mut bytes = vec![0u8; self.row_len * 4];
        {
            let mut f = self.file.lock().expect("scratch lock");
            f.seek(SeekFrom::Start((y * self.row_len * 4) as u64))
                .map_err(self.err())?;
            f.read_exact(&mut bytes).map_err(self.err())?;
        }
        Ok(bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect())
    }
}

/// Compute `work(i)` for `i in 0..n` on worker threads and hand the results to `sink` on the
/// calling thread in order of `i`, with at most `window` items claimed beyond the last one
/// sunk (so memory stays bounded whatever `n`). The first error in order of `i` stops the
/// workers and is returned.
pub(super) fn ordered_pipeline<T: Send>(
    n: usize,
    work: &(dyn Fn(usize) -> Result<T, IngestError> + Sync),
    sink: &mut dyn FnMut(usize, T) -> Result<(), IngestError>,
) -> Result<(), IngestError> {
    let threads = rayon::current_num_threads().max(1);
    let window = ROWS_IN_FLIGHT_PER_THREAD * threads + 2;

    struct State {
        next: usize,
        done: usize,
        abort: bool,
    }
    let state = Mutex::new(State {
        next: 0,
        done: 0,
        abort: false,
    });
    let wake = Condvar::new();
    struct StopOnDrop<'a> {
        state: &'a Mutex<State>,
        wake: &'a Condvar,
    }
    impl Drop for StopOnDrop<'_> {
        fn drop(&mut self) {
            self.state.lock().unwrap_or_else(|e| e.into_inner()).abort = true;
            self.wake.notify_all();
        }
    }
    let stop = |state: &Mutex<State>| {
        state.lock().expect("pipeline lock").abort = true;
        wake.notify_all();
    };

    std::thread::scope(|scope| {
        let (tx, rx) = mpsc::channel::<(usize, Result<T, IngestError>)>();
        for _ in 0..threads.min(n) {
            let tx = tx.clone();
            let (state, wake) = (&state, &wake);
            scope.spawn(move || loop {
                let i = {
                    let mut s = state.lock().expect("pipeline lock");
                    while !s.abort && s.next < n && s.next >= s.done + window {
                        s = wake.wait(s).expect("pipeline lock");
                    }
                    if s.abort || s.next >= n {
                        return;
                    }
                    s.next += 1;
                    s.next - 1
                };
                if tx.send((i, work(i))).is_err() {
                    return;
                }
            });
        }
        drop(tx);
        // The workers stop however the sink ends: an error, or a panic unwinding through here
        // (a caller that stops the ingest from its progress callback, as the Python package
        // does on Ctrl-C); without it they would wait for a slot forever and the scope with
        // them.
        let _stop = StopOnDrop {
            state: &state,
            wake: &wake,
        };

        let mut pending: BTreeMap<usize, Result<T, IngestError>> = BTreeMap::new();
        let mut done = 0;
        while done < n {
            let Ok((i, result)) = rx.recv() else {
                break; // every worker ended: only after a panic, which the scope re-raises
            };
            pending.insert(i, result);
            while let Some(result) = pending.remove(&done) {
                if let Err(e) = result.and_then(|t| sink(done, t)) {
                    stop(&state);
                    return Err(e);
                }
                done += 1;
                state.lock().expect("pipeline lock").done = done;
                wake.notify_all();
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn pipeline_sinks_in_order_with_bounded_lead() {
        let threads = rayon::current_num_threads().max(1);
        let window = ROWS_IN_FLIGHT_PER_THREAD * threads + 2;
        let sunk = AtomicUsize::new(0);
        let worst_lead = AtomicUsize::new(0);
        let work = |i: usize| -> Result<usize, IngestError> {
            // Items are claimed in order, and never more than `window` ahead of the sink.
            let lead = i - sunk.load(Ordering::SeqCst).min(i);
            worst_lead.fetch_max(lead, Ordering::SeqCst);
            if i.is_multiple_of(7) {
                std::thread::sleep(std::time::Duration::from_millis(2));
            }
            Ok(i * i)
        };
        let mut seen = Vec::new();
        ordered_pipeline(200, &work, &mut |i, v| {
            assert_eq!(v, i * i);
            seen.push(i);
            sunk.store(i + 1, Ordering::SeqCst);
            Ok(())
        })
        .unwrap();
        assert_eq!(seen, (0..200).collect::<Vec<_>>());
        assert!(worst_lead.load(Ordering::SeqCst) <= window);
    }

    #[test]
    fn a_sink_that_panics_stops_the_workers_instead_of_hanging() {
        let work = |i: usize| -> Result<usize, IngestError> { Ok(i) };
        let started = std::time::Instant::now();
        let unwound = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            ordered_pipeline(10_000, &work, &mut |i, _| {
                if i == 3 {
                    std::panic::resume_unwind(Box::new("stopped"));
                }
                Ok(())
            })
        }));
        assert!(unwound.is_err());
        assert!(started.elapsed() < std::time::Duration::from_secs(10));
    }

    #[test]
    fn pipeline_reports_the_first_error_in_order() {
        let work = |i: usize| -> Result<usize, IngestError> {
            if i == 37 || i == 90 {
                Err(IngestError::AllMissing {
                    input: format!("item {i}"),
                })
            } else {
                Ok(i)
            }
        };
        let mut last = None;
        let e = ordered_pipeline(500, &work, &mut |i, _| {
            last = Some(i);
            Ok(())
        })
        .unwrap_err();
        assert!(e.to_string().contains("item 37"), "{e}");
        assert_eq!(last, Some(36));
    }
}

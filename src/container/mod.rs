//! The on-disk cube container: HDF5 files holding a [`Cube`] plus optional extra groups.
//!
//! This is the only module of femto that talks to HDF5 (through the pure-Rust `rust_hdf5`
//! crate), so the choice of library can change here alone. The schema is documented for
//! users of other tools in `docs/cube-format.md`; in short:
//!
//! - `/cube`: f32, shape `(ny, nx, nt)`, i.e. the in-memory layout `[y][x][t]` of
//!   [`Cube`], chunked `(1, cx, nt)` and compressed with shuffle + deflate. Bin `i` covers
//!   `[t0_ps + i dt_ps, t0_ps + (i + 1) dt_ps)` and holds the signal integrated over it.
//!   Attributes: `t0_ps` (f64), `dt_ps` (f64), `time_frame` (`"camera"` or `"world"`,
//!   physics.md "two clocks"), `units` (string), `femto_version`, `command_line` and any
//!   provenance notes (strings).
//! - `/mask`: optional u8, shape `(ny, nx)`, 1 where a pixel holds valid data.
//! - `/<group>`: optional extra groups (e.g. `registration`, `pyramid`) holding datasets and
//!   attributes, read and written generically as [`GroupData`].
//!
//! Cubes can be streamed by row slabs ([`CubeWriter`], [`CubeReader`]) so that commands can
//! process cubes larger than memory. Every write is atomic: it goes to a temporary file in
//! the destination folder ([`crate::atomic::AtomicFile`]) which is renamed onto the
//! destination only on success.
//!
//! | module | what it holds |
//! |---|---|
//! | `error` | [`ContainerError`] and the helpers that name the file in every error |
//! | `schema` | names, chunk and slab sizes, types: [`CubeMeta`], [`DataBuf`], [`GroupData`] |
//! | `open` | opening HDF5 files and datasets for reading ([`is_hdf5`]) |
//! | `write` | the cube writer: [`write_cube`], [`CubeWriter`] and the sink under both |
//! | `checked` | cubes made by a caller's own code, checked as the reader checks before writing ([`write_checked_cube`]) |
//! | `compression` | the shuffle + deflate chunk compressor ([`RowCompressor`]) |
//! | `read` | the cube reader with direct chunk reads ([`CubeReader`], [`read_cube`]) |
//! | `attributes` | attributes of datasets and groups, and the JSON attribute index of groups |
//! | `foreign` | what other tools wrote (root attributes, groups, datasets), carried into a new cube |
//! | `groups` | the reader of extra groups ([`GroupReader`]), which [`CubeReader`] owns |
//! | `sinks` | extra groups being written, filled by row slabs |
//! | `append` | copy-on-write appends of groups to an existing file, without rewriting it |
//! | `update` | group updates (in place, else by a rewrite) and side files ([`GroupUpdate`], [`write_groups`]) |
//! | `stack` | image stacks, the HDF5 input of `femto ingest` ([`read_image_stack`]) |

mod append;
mod attributes;
mod checked;
mod compression;
mod error;
mod foreign;
mod groups;
mod open;
mod read;
mod schema;
mod sinks;
mod stack;
mod update;
mod write;

#[cfg(doc)]
use crate::cube::Cube;

pub use checked::{check_cube, write_checked_cube, CubeView};
pub use compression::{CompressedRow, RowCompressor};
pub use error::ContainerError;
pub use groups::GroupReader;
pub use open::is_hdf5;
pub use read::{list_groups, read_cube, read_group, read_meta, CubeReader, ValueScan};
pub use schema::{
    AttrValue, CubeCompression, CubeMeta, DataBuf, DatasetSpec, GroupData, GroupElem, Provenance,
    CUBE_DATASET, DEFAULT_UNITS, GROUP_ATTRS_INDEX, MASK_DATASET,
};
pub use stack::read_image_stack;
pub use update::{write_cube_with_groups, write_groups, GroupUpdate, StagedFile};
pub use write::{write_cube, write_cube_with_units, CubeWriter};

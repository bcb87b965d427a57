//! The pyramid stage: a cube's temporal prefix sums and time-only mip levels (the renderer's
//! interval queries, seed Sec. 5; kernels [`crate::pyramid`], schema [`crate::store::pyramid`]),
//! stored in the cube file's `pyramid` group or in a side file. The cube itself is copied as
//! it is stored (its compression kept).

use super::{refuse_same_file, Progress, StageError, StageOption};
use crate::container::{CubeCompression, CubeReader, GroupUpdate};
use crate::pyramid::top_level;
use crate::store::pyramid::{write_pyramid, PyramidInfo};
use std::path::{Path, PathBuf};

/// How [`pyramid_file`] stores the pyramid; `Default` is what `femto pyramid` does.
#[derive(Clone, Debug, PartialEq)]
pub struct PyramidOptions {
    /// Mip levels above level 0; None: all, up to one sample per pixel.
    pub levels: Option<usize>,
    /// A side file to hold the group instead of the cube's own file.
    pub side_file: Option<PathBuf>,
    /// Compression of the pyramid's datasets. Derived data, rebuilt from the cube in seconds:
    /// uncompressed by default, written at disk speed.
    pub compression: CubeCompression,
}

impl Default for PyramidOptions {
    fn default() -> Self {
        PyramidOptions {
            levels: None,
            side_file: None,
            compression: CubeCompression::None,
        }
    }
}

/// Build and store the pyramid of the cube at `cube_path`.
pub fn pyramid_file(
    cube_path: &Path,
    options: &PyramidOptions,
    progress: &dyn Progress,
) -> Result<PyramidInfo, StageError> {
    let reader = CubeReader::open(cube_path)?;
    let meta = reader.meta().clone();
    let top = top_level(meta.axis.nt);
    let levels = options.levels.unwrap_or(top);
    if levels > top {
        return Err(StageError::Option {
            name: StageOption::Levels,
            message: format!(
                "{levels}: a cube of {} bins has at most {top} mip levels (level k sums 2^k bins)",
                meta.axis.nt
            ),
        });
    }
    let mut out = match &options.side_file {
        Some(side) => {
            refuse_same_file(side, &[cube_path], "side-file")?;
            GroupUpdate::side_file(side)?
        }
        None => GroupUpdate::open(cube_path)?,
    };
    progress.start("pyramid", meta.ny as u64);
    let info = write_pyramid(
        &reader,
        &mut out,
        levels,
        &cube_path.display().to_string(),
        options.compression,
        &|rows| progress.set(rows as u64),
    )?;
    progress.finish();
    drop(reader);
    out.finish()?;
    Ok(info)
}

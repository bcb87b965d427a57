//! The input flags that `femto render` and `femto view` share: the world-time cube, its
//! pyramid, calibration and mesh, and the laser wavelength, opened by the render stage's
//! [`open_render_inputs`].

use clap::Args;
use femto::pipeline::render::{open_render_inputs, RenderInputs, SceneGeometry};
use femto::pipeline::StageError;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct RenderInputArgs {
    /// World-time cube (HDF5, e.g. from the unwarp step).
    #[arg(long, value_name = "WORLD.h5")]
    pub cube: PathBuf,
    /// Pyramid side file of the cube (`femto pyramid CUBE --side-file PATH`). Default: the
    /// cube file's own `pyramid` group when it has one, else prefix sums built in memory.
    #[arg(long, value_name = "PYRAMID.h5")]
    pub pyramid: Option<PathBuf>,
    /// Calibration of the capture camera, laser spot and time origin (TOML) [default, with
    /// no --mesh either: the cube's wall grid (a y-tal capture or a confocal scan, its /tal
    /// group), seen straight on by a camera whose pixels are the grid's points].
    #[arg(long, value_name = "CAL.toml", requires = "mesh")]
    pub calibration: Option<PathBuf>,
    /// Scene geometry in world metres (.glb, .gltf or .obj), with --calibration.
    #[arg(long, value_name = "MESH", requires = "calibration")]
    pub mesh: Option<PathBuf>,
    /// Laser wavelength in nm [default: the cube's `laser_nm` attribute, which `femto ingest`
    /// takes from the capture's manifest; else 670 nm, with a warning].
    #[arg(long, value_name = "NM")]
    pub laser_nm: Option<f64>,
}

impl RenderInputArgs {
    /// Open and check the inputs.
    pub fn open(&self) -> Result<RenderInputs, StageError> {
        let geometry = match (&self.calibration, &self.mesh) {
            (Some(calibration), Some(mesh)) => SceneGeometry::Files { calibration, mesh },
            _ => SceneGeometry::Wall,
        };
        open_render_inputs(&self.cube, self.pyramid.as_deref(), geometry, self.laser_nm)
    }

    /// The input files (an output may be none of them).
    pub fn paths(&self) -> Vec<&Path> {
        let mut paths = vec![self.cube.as_path()];
        paths.extend(self.calibration.as_deref());
        paths.extend(self.mesh.as_deref());
        paths.extend(self.pyramid.as_deref());
        paths
    }

    /// The files as `femto render` flags, quoted for a POSIX shell.
    pub fn shell_flags(&self) -> String {
        let mut flags = format!("--cube {}", shell_quote(&self.cube));
        if let (Some(c), Some(m)) = (&self.calibration, &self.mesh) {
            flags.push_str(&format!(
                " --calibration {} --mesh {}",
                shell_quote(c),
                shell_quote(m)
            ));
        }
        if let Some(p) = &self.pyramid {
            flags.push_str(&format!(" --pyramid {}", shell_quote(p)));
        }
        flags
    }
}

fn shell_quote(p: &Path) -> String {
    let s = p.display().to_string();
    if s.chars()
        .all(|c| c.is_ascii_alphanumeric() || "/._-+,:=@".contains(c))
    {
        s
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

//! The interop stages that `femto export` and `femto ingest` call: a cube file to a y-tal
//! capture, a y-tal capture or a mitransient array to a cube file. Each checks everything
//! before it writes, and writes atomically.

use super::mitransient::{read_transient_npy, Channels, OplBinning};
use super::tal::{TalCapture, TalGeometry, GROUP};
use super::tal_file::{geometry_from_group, geometry_group, read_tal, write_tal};
use super::InteropError;
use crate::container::{self, Provenance};
use crate::cube::{Cube, TimeFrame};
use crate::saturation::{saturation_mask, SaturationInput};
use crate::store::registration;
use std::path::Path;

/// Where the laser's own origin of an export came from.
#[derive(Clone, Debug, PartialEq)]
pub enum LaserOrigin {
    /// Given by the caller (`--laser-origin-m`).
    Given,
    /// The cube's `tal` group (a capture ingested from y-tal).
    TalGroup,
    /// No record of it: the camera centre of the registration (laser beside the camera).
    CameraCentre,
}

/// What [`export_tal`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct TalExport {
    pub capture: TalCapture,
    /// Where the sensor grid came from: `"registration"` or `"tal"`.
    pub geometry_group: &'static str,
    pub laser_origin: LaserOrigin,
    /// Sensor points that see nothing (NaN in `sensor_grid_xyz`).
    pub unseen_points: usize,
}

fn cube_err(path: &Path, message: impl Into<String>) -> InteropError {
    InteropError::Cube {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Write the cube at `cube_path` as a y-tal capture at `out`: the sensor grid from its
/// `registration` group (else its `tal` group), the laser origin given, else the `tal`
/// group's, else the registration's camera centre.
pub fn export_tal(
    cube_path: &Path,
    out: &Path,
    laser_origin_m: Option<[f64; 3]>,
) -> Result<TalExport, InteropError> {
    let groups = container::list_groups(cube_path)?;
    let has = |g: &str| groups.iter().any(|n| n == g);
    let meta = container::read_meta(cube_path)?;
    let (nx, ny) = (meta.nx, meta.ny);
    let tal_geo = if has(GROUP) {
        let data = container::read_group(cube_path, GROUP)?;
        Some(geometry_from_group(cube_path, &data, nx, ny)?)
    } else {
        None
    };
    let (geo, from, origin) = if has(registration::GROUP) {
        let data = container::read_group(cube_path, registration::GROUP)?;
        let stored = registration::from_group(cube_path, &data)?;
        let (o, how) = match (laser_origin_m, &tal_geo) {
            (Some(o), _) => (o, LaserOrigin::Given),
            (None, Some(t)) => (t.laser_origin_m, LaserOrigin::TalGroup),
            (None, None) => (
                stored.registration.camera_m.coords.into(),
                LaserOrigin::CameraCentre,
            ),
        };
        (
            TalGeometry::from_registration(&stored, o),
            "registration",
            how,
        )
    } else if let Some(mut t) = tal_geo {
        let how = match laser_origin_m {
            Some(o) => {
                t.laser_origin_m = o;
                LaserOrigin::Given
            }
            None => LaserOrigin::TalGroup,
        };
        (t, "tal", how)
    } else {
        return Err(cube_err(
            cube_path,
            "no registration group (run femto calibrate) and no tal group: y-tal needs the \
             wall point each pixel sees",
        ));
    };
    if geo.sensor_grid_m.len() != nx * ny {
        return Err(cube_err(
            cube_path,
            format!("the {from} group is not {nx} x {ny} pixels"),
        ));
    }
    let cube: Cube = container::read_cube(cube_path)?;
    let capture = TalCapture::from_cube(&cube, &geo);
    let unseen_points = capture
        .sensor_grid_xyz_m
        .iter()
        .filter(|p| p.iter().any(|c| !c.is_finite()))
        .count();
    write_tal(out, &capture)?;
    Ok(TalExport {
        capture,
        geometry_group: from,
        laser_origin: origin,
        unseen_points,
    })
}

/// Ingest the y-tal capture at `input` into the cube file `out`, its geometry in the `tal`
/// group; the cube is in world time when the capture's clock starts at the laser spot
/// (`t_accounts_first_and_last_bounces = False`), else in camera time. With `saturation`
/// (a level: y-tal's `H` is read as floats, so `auto` is refused), a pixel with a bin at or
/// above the level is masked, as streak ingest masks it.
pub fn ingest_tal(
    input: &Path,
    out: &Path,
    saturation: Option<SaturationInput>,
    provenance: &Provenance,
) -> Result<Cube, InteropError> {
    let level = match saturation {
        None => None,
        Some(SaturationInput::Level(v)) if v.is_finite() && v > 0.0 => Some(v),
        Some(s) => {
            return Err(InteropError::Invalid {
                path: input.to_path_buf(),
                key: "--saturation".into(),
                message: format!("{s:?}: y-tal's H is read as floats; give a finite level > 0"),
            })
        }
    };
    let capture = read_tal(input)?;
    let (mut cube, geo) = capture.to_cube();
    // t_start less the first bounce: the cube's start, in range before a cube is written.
    crate::ranges::check("t_start", cube.axis.t0_ps, crate::ranges::TIME_PS).map_err(|e| {
        InteropError::Invalid {
            path: input.to_path_buf(),
            key: "t_start".into(),
            message: format!("the cube's start {}", e.detail()),
        }
    })?;
    let mut provenance = provenance.clone();
    if let Some(level) = level {
        let (nx, nt) = (cube.nx, cube.nt());
        let mask: Vec<u8> = cube
            .data
            .chunks(nx * nt)
            .flat_map(|row| saturation_mask(row, nx, nt, level as f32))
            .collect();
        let masked = mask.iter().filter(|&&m| m == 0).count();
        provenance = provenance
            .with_note("ingest.saturation_level", format!("{level} (given)"))
            .with_note("ingest.saturated_pixels", masked.to_string());
        cube.mask = Some(mask);
    }
    let group = geometry_group(&geo, cube.nx, cube.ny);
    let provenance = provenance.with_note(
        "ingest.source",
        format!(
            "y-tal capture {} (t_accounts_first_and_last_bounces = {})",
            input.display(),
            if capture.t_accounts_first_and_last_bounces {
                "True"
            } else {
                "False"
            }
        ),
    );
    container::write_cube_with_groups(out, &cube, &provenance, &[(GROUP, group)])?;
    Ok(cube)
}

/// Ingest mitransient's transient array at `input` into the cube file `out`.
pub fn ingest_mitransient(
    input: &Path,
    out: &Path,
    binning: OplBinning,
    channels: Channels,
    frame: TimeFrame,
    provenance: &Provenance,
) -> Result<Cube, InteropError> {
    let cube = read_transient_npy(input, binning, channels, frame)?;
    let provenance = provenance.clone().with_note(
        "ingest.source",
        format!(
            "mitransient array {} (start_opl {} m, bin_width_opl {} m, channels {channels:?})",
            input.display(),
            binning.start_opl_m,
            binning.bin_width_opl_m
        ),
    );
    container::write_cube(out, &cube, &provenance)?;
    Ok(cube)
}

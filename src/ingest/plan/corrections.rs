//! The correction decisions of a plan, one function each: the corrections a manifest records,
//! dark signal ([`dark`]), flat field ([`flat`]), laser power ([`power`]) and saturation
//! ([`saturation`]), each read and checked against the reference scanline ([`Capture`]), and
//! their resolved, typed forms with their provenance.

use std::path::{Path, PathBuf};

use super::layout::to_row_layout;
use super::options::{DarkInput, PowerRef, SaturationInput};
use crate::formats::{read_streak, PixelType};
use crate::ingest::corrections::{check_flat, RefRegion};
use crate::ingest::row_offsets::RowOffsetFit;
use crate::ingest::time_axis::{EdgesSource, RecordedEdges};
use crate::ingest::{IngestError, IngestValue};
use crate::manifest::Manifest;

/// The corrections a manifest records, applied unless given otherwise (the plan's module doc, "Manifest
/// corrections").
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ManifestCorrections {
    pub dark: Option<DarkInput>,
    pub flat: Option<PathBuf>,
    pub sweep: Option<RecordedEdges>,
}

impl ManifestCorrections {
    /// The dark frame and flat field named in `[files]` (relative to the manifest's folder)
    /// and the sweep's bin times of `[imperfections.sweep]`.
    pub fn of(m: &Manifest, path: &Path) -> ManifestCorrections {
        let dir = path.parent().unwrap_or(Path::new("."));
        ManifestCorrections {
            dark: m.files.dark.as_ref().map(|d| DarkInput::File(dir.join(d))),
            flat: m.files.flat.as_ref().map(|f| dir.join(f)),
            sweep: m.imperfections.sweep.as_ref().map(|s| RecordedEdges {
                edges_ps: s.bin_times_ps.clone(),
                source: EdgesSource::ManifestSweep(path.to_path_buf()),
            }),
        }
    }
}

/// Dark signal, resolved.
#[derive(Clone, Debug, PartialEq)]
pub enum DarkCorrection {
    /// A constant level, scaled value units.
    Level(f32),
    /// A dark frame in the row layout `[x][t]` (recorded bins), scaled value units.
    Frame { path: PathBuf, values_xt: Vec<f32> },
}

/// Flat field, resolved: per-pixel gains (1 = nominal).
#[derive(Clone, Debug, PartialEq)]
pub struct FlatCorrection {
    pub path: PathBuf,
    /// `ny * nx` gains (`[y][x]`), or `nx` gains applied to every scanline.
    pub gains: Vec<f32>,
}

impl FlatCorrection {
    /// The gains of scanline `y`.
    pub fn row(&self, y: usize, nx: usize) -> &[f32] {
        if self.gains.len() == nx {
            &self.gains
        } else {
            &self.gains[y * nx..(y + 1) * nx]
        }
    }
}

/// Sweep-linearity correction, resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepCorrection {
    /// True camera time of each recorded row edge (`nt + 1`, increasing), ps.
    pub edges_ps: Vec<f64>,
    /// Where the edges come from (for provenance).
    pub source: EdgesSource,
}

/// Saturation masking, resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct SaturationCorrection {
    /// The level, scaled value units.
    pub level: f32,
    /// A raw value at or above this is saturated: the level, less half a count for integer
    /// files (a value clipped at the level is stored rounded to the nearest count).
    pub threshold: f32,
    /// How the level was chosen (for provenance).
    pub source: SaturationSource,
}

/// Laser power normalisation, resolved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PowerCorrection {
    /// Reference region (recorded bins), rows scaled to the median of its integral.
    Region(RefRegion),
    /// Pixel integrals against the same pixels in the neighbouring rows
    /// ([`crate::ingest::row_offsets`]).
    Auto(RowOffsetFit),
}

/// How a saturation level was chosen; its text (`Display`) is the provenance the cube
/// records.
#[derive(Clone, Debug, PartialEq)]
pub enum SaturationSource {
    /// Given as a level.
    Given,
    /// The largest value the files' integer sample type stores, times the value scale.
    Auto {
        max: f64,
        pixel_type: PixelType,
        value_scale: f64,
    },
}

impl std::fmt::Display for SaturationSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SaturationSource::Given => f.write_str("given"),
            SaturationSource::Auto {
                max,
                pixel_type,
                value_scale,
            } => write!(
                f,
                "auto: {max} ({pixel_type:?}) x value scale {value_scale}"
            ),
        }
    }
}

/// What the corrections are read and checked against: the reference scanline (the first
/// one read) and the capture's sizes.
#[derive(Clone, Copy, Debug)]
pub struct Capture<'a> {
    /// The reference scanline's file (or `STACK.h5:/DATASET`), for messages.
    pub reference: &'a Path,
    /// Columns, scanlines and recorded time rows.
    pub nx: usize,
    pub ny: usize,
    pub nt: usize,
    /// The reference scanline's sample type.
    pub pixel_type: PixelType,
    /// Multiplies every sample read (integer samples: the signal per count).
    pub value_scale: f64,
    /// The files store time across and x down.
    pub transpose: bool,
}

/// The dark signal: a finite level, or a frame of the scanlines' size in the row layout
/// (integer samples scaled like the scanlines, float samples taken as signal).
pub fn dark(input: Option<&DarkInput>, c: &Capture) -> Result<Option<DarkCorrection>, IngestError> {
    let (nx, nt) = (c.nx, c.nt);
    Ok(match input {
        None => None,
        Some(DarkInput::Level(v)) => {
            if !v.is_finite() {
                return Err(IngestError::BadValue {
                    what: IngestValue::DarkLevel,
                    value: v.to_string(),
                    message: "must be finite".into(),
                });
            }
            Some(DarkCorrection::Level(*v as f32))
        }
        Some(DarkInput::File(path)) => {
            let img = read_streak(path, c.transpose)?;
            if (img.nx, img.nt) != (nx, nt) {
                return Err(IngestError::SizeMismatch {
                    path: path.clone(),
                    what: "dark frame".into(),
                    found_nx: img.nx,
                    found_nt: img.nt,
                    nx,
                    nt,
                    reference: c.reference.to_path_buf(),
                });
            }
            // Counts are scaled like the scanlines; float samples are signal already.
            let scale = match img.pixel_type.max_stored_value() {
                Some(_) => c.value_scale as f32,
                None => 1.0,
            };
            let mut values_xt = vec![0.0f32; nx * nt];
            to_row_layout(&img.data, nx, nt, scale, &mut values_xt).map_err(|(x, t, value)| {
                IngestError::NonFinite {
                    path: path.clone(),
                    x,
                    t,
                    value,
                }
            })?;
            Some(DarkCorrection::Frame {
                path: path.clone(),
                values_xt,
            })
        }
    })
}

/// The flat field: an image `nx` wide and `ny` or 1 high, whose gains are checked.
pub fn flat(path: Option<&Path>, c: &Capture) -> Result<Option<FlatCorrection>, IngestError> {
    let Some(path) = path else {
        return Ok(None);
    };
    let (nx, ny) = (c.nx, c.ny);
    let img = read_streak(path, false)?;
    if img.nx != nx || (img.nt != ny && img.nt != 1) {
        return Err(IngestError::FlatSize {
            path: path.to_path_buf(),
            width: img.nx,
            height: img.nt,
            nx,
            ny,
        });
    }
    check_flat(&img.data[..nx], nx).map_err(|source| IngestError::Correction {
        what: path.display().to_string(),
        source,
    })?;
    Ok(Some(FlatCorrection {
        path: path.to_path_buf(),
        gains: img.data,
    }))
}

/// The laser power normalisation: automatic, or a reference region inside the scanlines.
pub fn power(input: Option<PowerRef>, c: &Capture) -> Result<Option<PowerCorrection>, IngestError> {
    Ok(match input {
        None => None,
        Some(PowerRef::Auto) => Some(PowerCorrection::Auto(RowOffsetFit::gaussian())),
        Some(PowerRef::Region(region)) => {
            region
                .check(c.nx, c.nt)
                .map_err(|source| IngestError::Correction {
                    what: "power reference region".into(),
                    source,
                })?;
            Some(PowerCorrection::Region(region))
        }
    })
}

/// The saturation mask: a positive level given, or (auto) the largest value of the files'
/// integer sample type times the value scale; the threshold is half a count below the
/// level for integer samples.
pub fn saturation(
    input: Option<SaturationInput>,
    c: &Capture,
) -> Result<Option<SaturationCorrection>, IngestError> {
    let Some(sat) = input else {
        return Ok(None);
    };
    let value_scale = c.value_scale;
    let quantum = match c.pixel_type.max_stored_value() {
        Some(_) => value_scale,
        None => 0.0,
    };
    let (level, source) = match sat {
        SaturationInput::Level(v) => {
            if !(v.is_finite() && v > 0.0) {
                return Err(IngestError::BadValue {
                    what: IngestValue::SaturationLevel,
                    value: v.to_string(),
                    message: "must be finite and > 0".into(),
                });
            }
            (v, SaturationSource::Given)
        }
        SaturationInput::Auto => match c.pixel_type.max_stored_value() {
            Some(max) => (
                max * value_scale,
                SaturationSource::Auto {
                    max,
                    pixel_type: c.pixel_type,
                    value_scale,
                },
            ),
            None => {
                return Err(IngestError::SaturationAuto {
                    path: c.reference.to_path_buf(),
                    pixel_type: format!("{:?}", c.pixel_type),
                })
            }
        },
    };
    Ok(Some(SaturationCorrection {
        level: level as f32,
        threshold: (level - 0.5 * quantum) as f32,
        source,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::raster::{write_exr_f32, write_png16};
    use crate::formats::StreakImage;
    use crate::manifest::Sweep;

    /// A capture of 3 x 2 (x by t) scanlines, 2 of them, 16-bit counts of 0.5.
    fn capture(reference: &Path, pixel_type: PixelType) -> Capture<'_> {
        Capture {
            reference,
            nx: 3,
            ny: 2,
            nt: 2,
            pixel_type,
            value_scale: 0.5,
            transpose: false,
        }
    }

    /// An image `[t][x]` of `nx` x `nt` values `0, 1, 2, ...`.
    fn ramp(nx: usize, nt: usize) -> StreakImage {
        StreakImage::new(nx, nt, (0..nx * nt).map(|i| i as f32).collect())
    }

    #[test]
    fn manifest_corrections_are_named_beside_the_manifest() {
        let mut m = super::super::test_manifest(3, 2);
        let path = Path::new("cap/manifest.toml");
        assert_eq!(
            ManifestCorrections::of(&m, path),
            ManifestCorrections::default()
        );
        m.files.dark = Some("dark.exr".into());
        m.files.flat = Some("flat.exr".into());
        m.imperfections.sweep = Some(Sweep {
            strength: 0.05,
            bin_times_ps: vec![0.0, 1.0, 3.0],
        });
        let c = ManifestCorrections::of(&m, path);
        assert_eq!(c.dark, Some(DarkInput::File("cap/dark.exr".into())));
        assert_eq!(c.flat, Some(PathBuf::from("cap/flat.exr")));
        let sweep = c.sweep.unwrap();
        assert_eq!(sweep.edges_ps, [0.0, 1.0, 3.0]);
        assert_eq!(
            sweep.source.to_string(),
            "sweep bin times of cap/manifest.toml"
        );
    }

    #[test]
    fn a_dark_level_must_be_finite() {
        let c = capture(Path::new("s0.png"), PixelType::U16);
        assert_eq!(dark(None, &c).unwrap(), None);
        assert_eq!(
            dark(Some(&DarkInput::Level(2.5)), &c).unwrap(),
            Some(DarkCorrection::Level(2.5))
        );
        let e = dark(Some(&DarkInput::Level(f64::INFINITY)), &c).unwrap_err();
        assert_eq!(e.to_string(), "dark level = inf: must be finite");
    }

    #[test]
    fn a_dark_frame_is_transposed_and_scaled_only_when_it_holds_counts() {
        let dir = tempfile::tempdir().unwrap();
        let c = capture(Path::new("s0.png"), PixelType::U16);
        // Float samples: signal values, not scaled.
        let exr = dir.path().join("dark.exr");
        write_exr_f32(&exr, &ramp(3, 2)).unwrap();
        let Some(DarkCorrection::Frame { path, values_xt }) =
            dark(Some(&DarkInput::File(exr.clone())), &c).unwrap()
        else {
            panic!("a frame");
        };
        assert_eq!(path, exr);
        assert_eq!(values_xt, [0.0, 3.0, 1.0, 4.0, 2.0, 5.0]);
        // Counts (one count is 1.0 here): scaled by the value scale 0.5.
        let png = dir.path().join("dark.png");
        write_png16(&png, &ramp(3, 2), 1.0).unwrap();
        let Some(DarkCorrection::Frame { values_xt, .. }) =
            dark(Some(&DarkInput::File(png)), &c).unwrap()
        else {
            panic!("a frame");
        };
        assert_eq!(values_xt, [0.0, 1.5, 0.5, 2.0, 1.0, 2.5]);
        // Another size: refused, naming both files.
        let small = dir.path().join("small.exr");
        write_exr_f32(&small, &ramp(2, 2)).unwrap();
        let e = dark(Some(&DarkInput::File(small)), &c).unwrap_err();
        assert!(
            matches!(&e, IngestError::SizeMismatch { found_nx: 2, nx: 3, reference, .. }
                if reference == Path::new("s0.png")),
            "{e:?}"
        );
    }

    #[test]
    fn a_flat_field_is_one_row_or_one_per_scanline() {
        let dir = tempfile::tempdir().unwrap();
        let c = capture(Path::new("s0.png"), PixelType::U16);
        assert_eq!(flat(None, &c).unwrap(), None);
        for high in [1, 2] {
            let p = dir.path().join(format!("flat{high}.exr"));
            write_exr_f32(&p, &ramp(3, high)).unwrap();
            let f = flat(Some(&p), &c).unwrap().unwrap();
            assert_eq!(f.gains.len(), 3 * high);
            assert_eq!(f.row(high - 1, 3), &f.gains[3 * (high - 1)..3 * high]);
        }
        let p = dir.path().join("flat3.exr");
        write_exr_f32(&p, &ramp(3, 3)).unwrap();
        let e = flat(Some(&p), &c).unwrap_err();
        assert!(
            matches!(
                e,
                IngestError::FlatSize {
                    width: 3,
                    height: 3,
                    nx: 3,
                    ny: 2,
                    ..
                }
            ),
            "{e:?}"
        );
    }

    #[test]
    fn a_power_reference_region_must_lie_inside_the_scanlines() {
        let c = capture(Path::new("s0.png"), PixelType::U16);
        assert_eq!(power(None, &c).unwrap(), None);
        assert_eq!(
            power(Some(PowerRef::Auto), &c).unwrap(),
            Some(PowerCorrection::Auto(RowOffsetFit::gaussian()))
        );
        let inside = RefRegion {
            x0: 0,
            x1: 3,
            t0_bin: 1,
            t1_bin: 2,
        };
        assert_eq!(
            power(Some(PowerRef::Region(inside)), &c).unwrap(),
            Some(PowerCorrection::Region(inside))
        );
        let outside = RefRegion { x1: 4, ..inside };
        let e = power(Some(PowerRef::Region(outside)), &c)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("power reference region: "), "{e}");
    }

    #[test]
    fn saturation_levels_are_given_or_the_largest_count() {
        let counts = capture(Path::new("s0.png"), PixelType::U16);
        assert_eq!(saturation(None, &counts).unwrap(), None);
        // Given: the level; integer samples are stored rounded, so half a count lower.
        let s = saturation(Some(SaturationInput::Level(100.0)), &counts)
            .unwrap()
            .unwrap();
        assert_eq!((s.level, s.threshold), (100.0, 99.75));
        assert_eq!(s.source.to_string(), "given");
        let s = saturation(Some(SaturationInput::Auto), &counts)
            .unwrap()
            .unwrap();
        assert_eq!((s.level, s.threshold), (32767.5, 32767.25));
        assert_eq!(s.source.to_string(), "auto: 65535 (U16) x value scale 0.5");
        // Float samples: the level is the threshold; auto has no largest value.
        let floats = capture(Path::new("s0.exr"), PixelType::F32);
        let s = saturation(Some(SaturationInput::Level(8.0)), &floats)
            .unwrap()
            .unwrap();
        assert_eq!((s.level, s.threshold), (8.0, 8.0));
        let e = saturation(Some(SaturationInput::Auto), &floats).unwrap_err();
        assert!(matches!(e, IngestError::SaturationAuto { .. }), "{e:?}");
        let e = saturation(Some(SaturationInput::Level(0.0)), &counts).unwrap_err();
        assert_eq!(
            e.to_string(),
            "saturation level = 0: must be finite and > 0"
        );
    }
}

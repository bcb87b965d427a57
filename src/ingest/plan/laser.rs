//! The laser-wavelength decision of a plan: the manifest's `[capture] laser_wavelength_nm`,
//! else the one given; one given that contradicts the manifest's is refused.

use std::path::PathBuf;

use crate::ingest::IngestError;
use crate::manifest::Manifest;

/// Relative difference above which a laser wavelength given contradicts the manifest's.
const LASER_AGREEMENT_TOLERANCE: f64 = 1e-6;

/// Where the laser wavelength comes from; its text (`Display`) is the provenance the cube
/// records (`manifest PATH` or `given`).
#[derive(Clone, Debug, PartialEq)]
pub enum LaserSource {
    /// The manifest at this path.
    Manifest(PathBuf),
    /// Given with the ingest's options.
    Given,
}

impl std::fmt::Display for LaserSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LaserSource::Manifest(p) => write!(f, "manifest {}", p.display()),
            LaserSource::Given => f.write_str("given"),
        }
    }
}

/// The laser wavelength of the capture, with where it comes from.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserWavelength {
    /// Wavelength, nm.
    pub nm: f64,
    /// The manifest, or given.
    pub source: LaserSource,
}

/// The manifest's wavelength (checked against `given`, if any), else `given`, else none.
pub fn laser(
    manifest: Option<&(Manifest, PathBuf)>,
    given: Option<f64>,
) -> Result<Option<LaserWavelength>, IngestError> {
    Ok(match (manifest, given) {
        (Some((m, mpath)), given) => {
            let recorded = m.capture.laser_wavelength_nm;
            if let Some(g) = given {
                if (g - recorded).abs() > LASER_AGREEMENT_TOLERANCE * recorded {
                    return Err(IngestError::LaserConflict {
                        given: g,
                        manifest: mpath.clone(),
                        recorded,
                    });
                }
            }
            Some(LaserWavelength {
                nm: recorded,
                source: LaserSource::Manifest(mpath.clone()),
            })
        }
        (None, Some(nm)) => Some(LaserWavelength {
            nm,
            source: LaserSource::Given,
        }),
        (None, None) => None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_manifests_wavelength_wins_and_a_contradiction_is_refused() {
        // The test manifest records 800 nm.
        let m = (
            super::super::test_manifest(4, 3),
            PathBuf::from("c/manifest.toml"),
        );
        for given in [None, Some(800.0), Some(800.0 * (1.0 + 1e-7))] {
            let l = laser(Some(&m), given).unwrap().unwrap();
            assert_eq!(l.nm, 800.0);
            assert_eq!(l.source.to_string(), "manifest c/manifest.toml");
        }
        let e = laser(Some(&m), Some(670.0)).unwrap_err().to_string();
        assert_eq!(
            e,
            "laser_nm = 670 nm contradicts c/manifest.toml, whose [capture] \
             laser_wavelength_nm is 800 nm"
        );
    }

    #[test]
    fn without_a_manifest_the_wavelength_is_given_or_none() {
        let l = laser(None, Some(532.0)).unwrap().unwrap();
        assert_eq!((l.nm, l.source.to_string()), (532.0, "given".to_string()));
        assert_eq!(laser(None, None).unwrap(), None);
    }
}

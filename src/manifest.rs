//! The capture folder's `manifest.toml`: which file holds which scanline, the time axis of
//! the streak images, and (for simulated captures) every imperfection with its true
//! parameters, so that ingest and calibration can be tested against ground truth.
//!
//! A capture is `ny` streak images, one per scanline `y` (the seed's capture scans the rows
//! with a mirror), each `nx` columns by `nt` time rows. Row `i` of every streak image covers
//! camera time `[t0_ps + i dt_ps, t0_ps + (i+1) dt_ps)`, the convention of
//! [`crate::cube::TimeAxis`]. Signal units: the values the simulator hands to the writers
//! (for 16-bit PNG, `stored count * png_value_per_count`).
//!
//! ```toml
//! [capture]
//! scene = "cornell"
//! nx = 672
//! ny = 64
//! nt = 512
//! dt_ps = 1.9
//! t0_ps = 0.0
//! eta = 1.0
//! laser_wavelength_nm = 800.0
//! pulse_width_fs = 100.0
//! formats = ["png16", "exr"]
//! png_value_per_count = 0.001
//! seed = 7
//! spp = 64
//!
//! [files]
//! geometry = "scene.glb"
//! calibration = "calibration.toml"
//! truth_camera = "truth_camera.h5"
//!
//! [imperfections.dark]
//! offset = 0.01
//! sigma = 0.002
//!
//! [[scanline]]
//! index = 0
//! file = "scanlines/scanline_0000.png"
//! exr = "scanlines/scanline_0000.exr"
//! ```
//!
//! Loading validates the structure (sizes, positive steps, per-scanline vectors of length
//! `ny`, the sweep table of length `nt + 1`, scanline indices covering `0..ny` exactly once).
//! Whether the named files exist is ingest's job.

use crate::camera::one_line_toml_error;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Errors of the manifest: every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    /// The manifest could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Not TOML of the documented shape: "line L, column C: message" (unknown keys included).
    #[error("{}: {message}", path.display())]
    Parse { path: PathBuf, message: String },
    /// Well-formed TOML whose contents do not make a capture (names the key or scanline).
    #[error("{}: {message}", path.display())]
    Invalid { path: PathBuf, message: String },
}

/// File formats a simulated capture can write each scanline in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum StreakFormat {
    /// 16-bit grey PNG with `png_value_per_count`.
    #[serde(rename = "png16")]
    Png16,
    /// Single-channel (`Y`) f32 OpenEXR.
    #[serde(rename = "exr")]
    ExrF32,
    /// Hamamatsu HPD-TA `.img`, 16-bit.
    #[serde(rename = "img16")]
    Img16,
    /// Hamamatsu HPD-TA `.img`, 32-bit.
    #[serde(rename = "img32")]
    Img32,
}

impl StreakFormat {
    /// The file extension (without the dot).
    pub fn extension(self) -> &'static str {
        match self {
            StreakFormat::Png16 => "png",
            StreakFormat::ExrF32 => "exr",
            StreakFormat::Img16 | StreakFormat::Img32 => "img",
        }
    }
}

/// `[capture]`: what was captured and how the streak images are laid out.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaptureInfo {
    /// Scene name.
    pub scene: String,
    /// Columns of each streak image (x along the slit).
    pub nx: usize,
    /// Number of scanlines (streak images).
    pub ny: usize,
    /// Time rows of each streak image.
    pub nt: usize,
    /// Width of one time row, ps.
    pub dt_ps: f64,
    /// Camera time of the start of row 0, ps.
    pub t0_ps: f64,
    /// Wall-clock integration time of one streak image, seconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposure_s: Option<f64>,
    /// Free-text description of the exposure (e.g. how many laser pulses were summed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposure_note: Option<String>,
    /// Time resolution of the streak sensor (FWHM of its impulse response), ps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor_fwhm_ps: Option<f64>,
    /// Signal value of one count of the 16-bit PNGs (required when `png16` is written); the
    /// simulator's `.img` files hold the same counts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub png_value_per_count: Option<f64>,
    /// Refractive index of the medium.
    pub eta: f64,
    /// Laser wavelength, nm.
    pub laser_wavelength_nm: f64,
    /// Laser pulse width (FWHM), fs.
    pub pulse_width_fs: f64,
    /// Formats each scanline was written in; the first is the one `file` names.
    pub formats: Vec<StreakFormat>,
    /// Random seed of the simulation (at most `i64::MAX`, TOML's integer range).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Samples per pixel of the simulation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spp: Option<u32>,
    /// Command line or tool that produced the capture (provenance).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub created_by: Option<String>,
}

/// `[files]`: the other files of the capture folder, relative to it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaptureFiles {
    /// Scene geometry (`.glb`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub geometry: Option<PathBuf>,
    /// Camera calibration (`.toml`, see [`crate::camera::Calibration`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<PathBuf>,
    /// Fiducial markers (positions known in the world and seen in the capture).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fiducials: Option<PathBuf>,
    /// True x-y-t cube in camera time (`.h5`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth_camera: Option<PathBuf>,
    /// True x-y-t cube in world time (`.h5`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth_world: Option<PathBuf>,
    /// True direct (single-bounce) component (`.h5`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth_direct: Option<PathBuf>,
    /// Flat field: the gain of every pixel, an image of `nx` columns by `ny` rows (`.exr`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flat: Option<PathBuf>,
    /// Dark frame: a streak image (`nx` by `nt`) taken with no light, same units as the
    /// scanlines (`.exr`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dark: Option<PathBuf>,
}

/// `[[scanline]]`: the streak image of scanline `index`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scanline {
    /// Scanline (image row) `y`.
    pub index: usize,
    /// The file in the first of `capture.formats`, relative to the capture folder.
    pub file: PathBuf,
    /// The 16-bit PNG copy, if written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub png: Option<PathBuf>,
    /// The EXR copy, if written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exr: Option<PathBuf>,
    /// The HPD-TA copy, if written.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub img: Option<PathBuf>,
}

/// Shot noise: Poisson photon counts. Exactly one of the two fields is given.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhotonNoise {
    /// Expected photons for a signal equal to the capture's full-scale value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub photons_at_full_scale: Option<f64>,
    /// Expected photons per unit of signal.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub photons_per_unit: Option<f64>,
}

/// Dark signal: Gaussian with this mean and standard deviation, signal units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Dark {
    /// Mean added to every pixel.
    pub offset: f64,
    /// Standard deviation.
    pub sigma: f64,
}

/// Vignetting: a multiplicative fall-off of the signal across the image.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Vignetting {
    /// Strength (0 = none), as the model defines it.
    pub strength: f64,
    /// How the fall-off is computed (formula in words).
    pub model: String,
}

/// Trigger jitter: each scanline's time axis shifted by a random amount.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Jitter {
    /// Standard deviation of the shifts, ps.
    pub sigma_ps: f64,
    /// The true shift of each scanline (indexed by `y`), ps.
    pub shifts_ps: Vec<f64>,
}

/// Laser power fluctuation: each scanline's signal multiplied by a random factor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Power {
    /// Relative standard deviation of the factors.
    pub sigma: f64,
    /// The true factor of each scanline (indexed by `y`).
    pub factors: Vec<f64>,
}

/// Sweep non-linearity: the time rows are not evenly spaced.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sweep {
    /// Strength (0 = linear sweep), as the simulator defines it.
    pub strength: f64,
    /// True camera time of each row edge (`nt + 1` values, strictly increasing), ps.
    pub bin_times_ps: Vec<f64>,
}

/// Saturation: values clipped at this level, signal units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Saturation {
    /// Clip level.
    pub level: f64,
}

/// Fiducial detection noise: the markers' pixel positions in the fiducials file carry
/// Gaussian noise (the calibration file holds the true camera).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FiducialNoise {
    /// Standard deviation of each coordinate in the photo the markers were found in, pixels.
    pub photo_px: f64,
    /// Width of that photo, pixels.
    pub photo_width_px: f64,
    /// Standard deviation of each pixel coordinate in the fiducials file, capture pixels.
    pub sigma_px: f64,
}

/// `[imperfections]`: every simulated imperfection with its true parameters (absent = off).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Imperfections {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub photon_noise: Option<PhotonNoise>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dark: Option<Dark>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vignetting: Option<Vignetting>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jitter: Option<Jitter>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub power: Option<Power>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<Sweep>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub saturation: Option<Saturation>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fiducials: Option<FiducialNoise>,
}

/// The whole manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    pub capture: CaptureInfo,
    #[serde(default)]
    pub files: CaptureFiles,
    #[serde(default)]
    pub imperfections: Imperfections,
    /// One entry per scanline, sorted by index after loading.
    #[serde(default, rename = "scanline")]
    pub scanlines: Vec<Scanline>,
}

impl Manifest {
    /// The conventional file name of scanline `y` in a capture folder:
    /// `scanlines/scanline_0007.<ext>`.
    pub fn default_scanline_name(y: usize, ext: &str) -> PathBuf {
        PathBuf::from("scanlines").join(format!("scanline_{y:04}.{ext}"))
    }

    /// The primary file of scanline `y`, joined onto the capture folder `dir`.
    pub fn scanline_path(&self, dir: &Path, y: usize) -> Option<PathBuf> {
        self.scanlines
            .iter()
            .find(|s| s.index == y)
            .map(|s| dir.join(&s.file))
    }

    /// Parse manifest text (`origin` names it in errors), validate it and sort the scanlines.
    pub fn from_toml(text: &str, origin: &Path) -> Result<Manifest, ManifestError> {
        let mut m: Manifest = toml::from_str(text).map_err(|e| ManifestError::Parse {
            path: origin.to_path_buf(),
            message: one_line_toml_error(&e, text),
        })?;
        m.validate().map_err(|message| ManifestError::Invalid {
            path: origin.to_path_buf(),
            message,
        })?;
        m.scanlines.sort_by_key(|s| s.index);
        Ok(m)
    }

    /// Read and validate `path`.
    pub fn load(path: &Path) -> Result<Manifest, ManifestError> {
        let text = std::fs::read_to_string(path).map_err(|source| ManifestError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Manifest::from_toml(&text, path)
    }

    /// The manifest as TOML text (after validation).
    pub fn to_toml(&self) -> Result<String, String> {
        self.validate()?;
        let body = toml::to_string(self).map_err(|e| e.to_string())?;
        Ok(format!(
            "# femto capture manifest (times in ps; row i of each streak image covers \
             [t0_ps + i dt_ps, t0_ps + (i+1) dt_ps))\n{body}"
        ))
    }

    /// Validate and write `path` atomically.
    pub fn save(&self, path: &Path) -> Result<(), ManifestError> {
        let text = self.to_toml().map_err(|message| ManifestError::Invalid {
            path: path.to_path_buf(),
            message,
        })?;
        crate::atomic::write_atomically(path, |tmp| std::fs::write(tmp, &text)).map_err(|source| {
            ManifestError::Io {
                path: path.to_path_buf(),
                source,
            }
        })
    }

    /// Check the structure; the message names the offending key or scanline.
    pub fn validate(&self) -> Result<(), String> {
        validate_capture(&self.capture)?;
        validate_scanlines(&self.capture, &self.scanlines)?;
        validate_imperfections(&self.imperfections, self.capture.nt, self.capture.ny)
    }
}

/// The `[capture]` table's checks of [`Manifest::validate`]: sizes, times, optics, formats.
fn validate_capture(c: &CaptureInfo) -> Result<(), String> {
    for (name, v) in [("nx", c.nx), ("ny", c.ny), ("nt", c.nt)] {
        if v == 0 {
            return Err(format!("capture.{name} must be at least 1"));
        }
    }
    positive("capture.dt_ps", c.dt_ps)?;
    finite("capture.t0_ps", c.t0_ps)?;
    if !(c.eta.is_finite() && c.eta >= 1.0) {
        return Err(format!("capture.eta = {} must be finite and >= 1", c.eta));
    }
    for (key, v, range) in [
        ("capture.dt_ps", c.dt_ps, crate::ranges::BIN_WIDTH_PS),
        ("capture.t0_ps", c.t0_ps, crate::ranges::TIME_PS),
        ("capture.eta", c.eta, crate::ranges::ETA),
    ] {
        crate::ranges::check(key, v, range).map_err(|e| e.to_string())?;
    }
    positive("capture.laser_wavelength_nm", c.laser_wavelength_nm)?;
    non_negative("capture.pulse_width_fs", c.pulse_width_fs)?;
    if let Some(v) = c.exposure_s {
        positive("capture.exposure_s", v)?;
    }
    if let Some(v) = c.sensor_fwhm_ps {
        non_negative("capture.sensor_fwhm_ps", v)?;
    }
    if c.formats.is_empty() {
        return Err("capture.formats is empty".into());
    }
    if let Some((i, f)) = c
        .formats
        .iter()
        .enumerate()
        .find(|(i, f)| c.formats[..*i].contains(f))
    {
        return Err(format!("capture.formats lists {f:?} twice (entry {i})"));
    }
    if c.formats.contains(&StreakFormat::Img16) && c.formats.contains(&StreakFormat::Img32) {
        return Err("capture.formats lists both img16 and img32 (one .img per scanline)".into());
    }
    match c.png_value_per_count {
        Some(v) => positive("capture.png_value_per_count", v)?,
        None if c.formats.contains(&StreakFormat::Png16) => {
            return Err("capture.png_value_per_count is required with format png16".into())
        }
        None => {}
    }
    if let Some(seed) = c.seed {
        if seed > i64::MAX as u64 {
            return Err(format!(
                "capture.seed = {seed} exceeds TOML's integer range"
            ));
        }
    }
    Ok(())
}

/// The scanline entries' checks of [`Manifest::validate`]: indices covering `0..ny` once
/// each, a file name, and no file of a format that `[capture] formats` does not list.
fn validate_scanlines(c: &CaptureInfo, scanlines: &[Scanline]) -> Result<(), String> {
    let ny = c.ny;
    // The entries must cover 0..ny once each: more rows than entries is refused before
    // anything is sized by ny (a ny of 2^64 - 1 asked for that many flags).
    if ny > scanlines.len() {
        return Err(format!(
            "capture.ny = {ny} but only {} scanline entries are listed (indices must cover \
             0..ny exactly once)",
            scanlines.len()
        ));
    }
    let mut seen = vec![false; ny];
    for (k, s) in scanlines.iter().enumerate() {
        if s.index >= ny {
            return Err(format!(
                "scanline entry {k}: index {} is outside 0..{ny}",
                s.index
            ));
        }
        if seen[s.index] {
            return Err(format!("scanline index {} appears twice", s.index));
        }
        seen[s.index] = true;
        if s.file.as_os_str().is_empty() {
            return Err(format!("scanline {}: empty file name", s.index));
        }
        for (fmt, name, field) in [
            (StreakFormat::Png16, "png", &s.png),
            (StreakFormat::ExrF32, "exr", &s.exr),
        ] {
            if field.is_some() && !c.formats.contains(&fmt) {
                return Err(format!(
                    "scanline {}: {name} file given but capture.formats does not list {fmt:?}",
                    s.index
                ));
            }
        }
        if s.img.is_some()
            && !(c.formats.contains(&StreakFormat::Img16)
                || c.formats.contains(&StreakFormat::Img32))
        {
            return Err(format!(
                "scanline {}: img file given but capture.formats lists no img format",
                s.index
            ));
        }
    }
    // ny <= entries, each in 0..ny and none twice: every index is covered.
    Ok(())
}

/// The `[imperfections]` tables' checks of [`Manifest::validate`] for a capture of `nt` bins
/// and `ny` scanlines.
fn validate_imperfections(im: &Imperfections, nt: usize, ny: usize) -> Result<(), String> {
    if let Some(p) = &im.photon_noise {
        match (p.photons_at_full_scale, p.photons_per_unit) {
            (Some(v), None) => positive("imperfections.photon_noise.photons_at_full_scale", v)?,
            (None, Some(v)) => positive("imperfections.photon_noise.photons_per_unit", v)?,
            _ => {
                return Err("imperfections.photon_noise needs exactly one of \
                            photons_at_full_scale and photons_per_unit"
                    .into())
            }
        }
    }
    if let Some(d) = &im.dark {
        finite("imperfections.dark.offset", d.offset)?;
        non_negative("imperfections.dark.sigma", d.sigma)?;
    }
    if let Some(v) = &im.vignetting {
        non_negative("imperfections.vignetting.strength", v.strength)?;
    }
    if let Some(j) = &im.jitter {
        non_negative("imperfections.jitter.sigma_ps", j.sigma_ps)?;
        per_scanline("imperfections.jitter.shifts_ps", &j.shifts_ps, ny)?;
    }
    if let Some(p) = &im.power {
        non_negative("imperfections.power.sigma", p.sigma)?;
        per_scanline("imperfections.power.factors", &p.factors, ny)?;
    }
    if let Some(s) = &im.sweep {
        finite("imperfections.sweep.strength", s.strength)?;
        let t = &s.bin_times_ps;
        if t.len() != nt.saturating_add(1) {
            return Err(format!(
                "imperfections.sweep.bin_times_ps has {} values, expected nt + 1 = {}",
                t.len(),
                nt as u128 + 1
            ));
        }
        if let Some(i) = t.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "imperfections.sweep.bin_times_ps[{i}] is not finite"
            ));
        }
        if let Some(i) = t.windows(2).position(|w| w[1] <= w[0]) {
            return Err(format!(
                "imperfections.sweep.bin_times_ps is not strictly increasing at index {}",
                i + 1
            ));
        }
    }
    if let Some(s) = &im.saturation {
        positive("imperfections.saturation.level", s.level)?;
    }
    Ok(())
}

fn finite(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{key} = {v} is not finite"))
    }
}

fn positive(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(format!("{key} = {v} must be finite and > 0"))
    }
}

fn non_negative(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(format!("{key} = {v} must be finite and >= 0"))
    }
}

fn per_scanline(key: &str, values: &[f64], ny: usize) -> Result<(), String> {
    if values.len() != ny {
        return Err(format!(
            "{key} has {} values, expected one per scanline (ny = {ny})",
            values.len()
        ));
    }
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(format!("{key}[{i}] is not finite"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> Manifest {
        Manifest {
            capture: CaptureInfo {
                scene: "box".into(),
                nx: 4,
                ny: 2,
                nt: 3,
                dt_ps: 2.0,
                t0_ps: -1.0,
                exposure_s: None,
                exposure_note: None,
                sensor_fwhm_ps: None,
                png_value_per_count: None,
                eta: 1.0,
                laser_wavelength_nm: 800.0,
                pulse_width_fs: 100.0,
                formats: vec![StreakFormat::ExrF32],
                seed: None,
                spp: None,
                created_by: None,
            },
            files: CaptureFiles::default(),
            imperfections: Imperfections::default(),
            scanlines: (0..2)
                .map(|y| Scanline {
                    index: y,
                    file: Manifest::default_scanline_name(y, "exr"),
                    png: None,
                    exr: None,
                    img: None,
                })
                .collect(),
        }
    }

    #[test]
    fn coverage_errors_name_the_index() {
        let mut m = small();
        m.scanlines[1].index = 0;
        assert!(m.validate().unwrap_err().contains("index 0 appears twice"));
        m.scanlines.pop();
        let e = m.validate().unwrap_err();
        assert!(
            e.contains("capture.ny = 2 but only 1 scanline entries"),
            "{e}"
        );
        // A row count no memory holds is refused by the same comparison, at once.
        m.capture.ny = usize::MAX;
        let e = m.validate().unwrap_err();
        assert!(e.contains(&format!("capture.ny = {}", usize::MAX)), "{e}");
        m.capture.ny = 2;
        m.scanlines.push(m.scanlines[0].clone());
        m.scanlines[0].index = 5;
        assert!(m
            .validate()
            .unwrap_err()
            .contains("index 5 is outside 0..2"));
    }

    #[test]
    fn png16_needs_a_scale_and_vectors_need_ny_values() {
        let mut m = small();
        m.capture.formats = vec![StreakFormat::Png16];
        assert!(m.validate().unwrap_err().contains("png_value_per_count"));
        m.capture.png_value_per_count = Some(0.5);
        assert!(m.validate().is_ok());
        m.imperfections.power = Some(Power {
            sigma: 0.1,
            factors: vec![1.0],
        });
        assert!(m
            .validate()
            .unwrap_err()
            .contains("expected one per scanline (ny = 2)"));
        m.imperfections.power = None;
        m.imperfections.sweep = Some(Sweep {
            strength: 0.1,
            bin_times_ps: vec![0.0, 1.0, 3.0, 2.0],
        });
        assert!(m
            .validate()
            .unwrap_err()
            .contains("not strictly increasing at index 3"));
    }
}

//! Scenes for the transient path tracer: a TOML scene file (or a built-in scene by name)
//! resolved into typed values — one triangle mesh with a Lambertian albedo per entry, the
//! laser's diffuser spot, the streak camera with its time axis, and the medium's index.
//!
//! This is the input of the time-resolved rendering equation (seed Eq. 1, physics.md
//! "Transient path tracing"). Clocks: the laser pulse leaves the diffuser spot at cube time 0;
//! the camera's time axis (the cube's) starts at `camera.t0_ps`, so a bin `i` covers camera
//! times `[t0_ps + i dt_ps, t0_ps + (i + 1) dt_ps)` measured from the pulse emission. The
//! matching [`Calibration`] therefore has `t0_ps = 0`.
//!
//! # Scene file
//!
//! Metres, degrees, picoseconds; y is up in the built-in scenes (any frame works).
//!
//! ```toml
//! name = "my scene"          # optional (default: the file name)
//! eta = 1.0                  # optional, index of the medium (>= 1)
//!
//! [laser]                    # the diffuser spot hit by the pulse: a point emitter
//! position_m = [-0.13, 0.06, -0.07]
//! normal = [0.8, 0.2, 0.55]  # diffuser normal: axis of cosine emission (always required)
//! emission = "cosine"        # optional: "cosine" (default) or "isotropic"
//! wavelength_nm = 795.0
//! pulse_width_fs = 50.0      # FWHM of the Gaussian pulse (0 = a delta pulse)
//! energy = 1.0               # pulse energy; cube values scale with it
//!
//! [camera]                   # the streak camera (pinhole, square pixels)
//! position_m = [0.0, 0.22, 0.85]
//! look_at_m = [0.0, 0.05, 0.0]
//! up = [0.0, 1.0, 0.0]       # optional, default +y
//! vfov_deg = 16.0
//! nx = 64
//! ny = 48
//! nt = 256
//! dt_ps = 4.0
//! t0_ps = 3200.0             # start of the time window after the pulse leaves the spot
//!
//! [[mesh]]                   # any number of entries, each its own material
//! name = "floor"             # optional label (default "mesh<i>")
//! primitive = "quad"         # "quad" (size = [x, y], in the z = 0 plane, normal +z),
//!                            # "box" (size = [x, y, z]) or "icosphere" (radius, subdivisions)
//! # file = "bunny.obj"       # ... or a mesh file, relative to the scene file's folder
//! # fit_size_m = 0.2         # file meshes: centre x/z, bottom at y = 0, largest extent = this
//! size = [0.4, 0.35]
//! scale = 1.0                # optional uniform scale
//! rotate_deg = [-90.0, 0.0, 0.0] # optional: about x, then y, then z (fixed axes)
//! # rotate_axis = [0, 1, 0]  # ... or an axis and an angle
//! # rotate_angle_deg = 30.0
//! translate_m = [0.0, 0.0, 0.0]  # optional
//! albedo = 0.7               # Lambertian reflectance at the laser wavelength, 0..1
//! ```
//!
//! Ranges: every number finite; `eta` in [1, 10]; `laser.pulse_width_fs` in [0, 1e6] and no
//! longer than the camera's window `nt * dt_ps`; `laser.wavelength_nm` in [1, 1e6];
//! `laser.energy` in (0, 1e12]; `camera.nx`, `camera.ny` in [1, 16384], `camera.nt` in
//! [1, 2^20], `camera.dt_ps` in [1e-3, 1e6]; every point (camera, look-at, laser, translation,
//! and every vertex after its entry's transform) within 1e4 m of the origin on each axis.
//!
//! Each entry is transformed as: fit (file meshes), scale, rotate, translate. Any unknown key,
//! missing field, out-of-range value, a camera inside a closed mesh (box, icosphere, closed
//! file mesh) or within 1 mm of a surface, or a laser spot inside a closed mesh is an error
//! that names the key and its line.
//!
//! # Layout
//!
//! - `schema`: the serde types of the file (a mesh entry is one of four kinds, each with
//!   `deny_unknown_fields`);
//! - `resolve`: the ranges below and the checks of the camera and the laser against the
//!   meshes;
//! - `entry`: one mesh entry built and placed in world coordinates;
//! - `builtin`: the built-in scenes, TOML files in `src/scene/builtin/`.
//!
//! Geometry queries (inside a closed mesh, distance to a surface), mesh-file welding and
//! fitting, and fiducial candidates live in [`crate::geometry`].

mod builtin;
mod checks;
mod entry;
mod resolve;
mod schema;
#[cfg(test)]
mod tests;

pub use builtin::BUILTIN_NAMES;
pub use checks::{
    DT_PS_RANGE, ETA_RANGE, MAX_ENERGY, MAX_EXTENT_M, MAX_NT, MAX_PULSE_WIDTH_FS, MAX_SIDE,
    WAVELENGTH_NM_RANGE,
};

use crate::camera::{Calibration, Intrinsics, Pose};
use crate::cube::TimeAxis;
use crate::geometry::bvh::Bvh;
use crate::geometry::{Ray, TriangleMesh};
use checks::Resolver;
use nalgebra::{Point3, Unit, Vector3};
use serde::Deserialize;
use std::path::Path;

/// Errors of scene files and built-in scenes.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file could not be read.
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// Not TOML of the documented shape: syntax, unknown key, missing field or wrong type
    /// ("line L, column C: ..." naming the key).
    #[error("{origin}: {message}")]
    Parse { origin: String, message: String },
    /// A value is out of range or the geometry is impossible (names the key and its line).
    #[error("{origin}: {message}")]
    Invalid { origin: String, message: String },
    /// A mesh file named by the scene is missing or unreadable (names the file); `source` is
    /// a `NotFound` I/O error, worded as `message`, when the file does not exist.
    #[error("{origin}: {location}: mesh file {path}: {message}")]
    MeshFile {
        origin: String,
        location: String,
        path: String,
        message: String,
        #[source]
        source: Option<std::io::Error>,
    },
    /// No built-in scene has this name.
    #[error("unknown built-in scene '{name}' (known: {})", BUILTIN_NAMES.join(", "))]
    UnknownBuiltin { name: String },
    /// The `bunny` built-in scene was asked for without a mesh file.
    #[error("built-in scene 'bunny' needs a mesh file (e.g. the Stanford bunny OBJ)")]
    BunnyNeedsMesh,
}

/// How the diffuser spot emits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Emission {
    /// Lambertian diffuser: intensity `energy * cos(theta) / pi` about the normal, 0 behind.
    Cosine,
    /// Uniform in all directions: intensity `energy / (4 pi)`.
    Isotropic,
}

impl Emission {
    pub fn as_str(self) -> &'static str {
        match self {
            Emission::Cosine => "cosine",
            Emission::Isotropic => "isotropic",
        }
    }
}

/// The laser's diffuser spot: a point emitter of one Gaussian pulse leaving at time 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Laser {
    pub position_m: Point3<f64>,
    /// Unit normal of the diffuser, the axis of cosine emission.
    pub normal: Unit<Vector3<f64>>,
    pub emission: Emission,
    pub wavelength_nm: f64,
    /// Full width at half maximum of the Gaussian pulse, femtoseconds.
    pub pulse_width_fs: f64,
    /// Pulse energy (J, or any unit: cube values are proportional to it).
    pub energy: f64,
}

impl Laser {
    /// Radiant intensity (energy per steradian) sent along the unit direction `dir_world`
    /// (pointing away from the spot), with the given emission profile.
    #[inline]
    pub fn intensity(&self, emission: Emission, dir_world: &Vector3<f64>) -> f64 {
        match emission {
            Emission::Cosine => {
                self.energy * self.normal.dot(dir_world).max(0.0) / std::f64::consts::PI
            }
            Emission::Isotropic => self.energy / (4.0 * std::f64::consts::PI),
        }
    }

    /// Standard deviation of the pulse in time, ps: `FWHM / (2 sqrt(2 ln 2))`.
    pub fn pulse_sigma_ps(&self) -> f64 {
        self.pulse_width_fs * 1e-3 / (2.0 * (2.0 * std::f64::consts::LN_2).sqrt())
    }
}

/// The streak camera: a pinhole camera and the time axis of the cube it records.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreakCamera {
    pub intrinsics: Intrinsics,
    pub pose: Pose,
    /// Camera-time axis of the cube; times are measured from the pulse leaving the spot.
    pub axis: TimeAxis,
    /// Vertical field of view the intrinsics were made from, degrees.
    pub vfov_deg: f64,
}

/// A resolved scene, ready for the tracer.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    /// All mesh entries merged; `mesh.material[i]` is the index of triangle i's entry.
    pub mesh: TriangleMesh,
    /// Lambertian albedo of each entry (index = material).
    pub albedo: Vec<f32>,
    /// Label of each entry (index = material).
    pub labels: Vec<String>,
    pub laser: Laser,
    pub camera: StreakCamera,
    /// Index of the medium (light travels at c / eta).
    pub eta: f64,
    /// Points that can serve as fiducials (box corners, quad corners and grids), not yet
    /// filtered by visibility.
    fiducial_candidates: Vec<(String, Point3<f64>)>,
}

impl Scene {
    /// Read a scene file; mesh files are resolved relative to its folder.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            path: name.clone(),
            source,
        })?;
        let base = path.parent().unwrap_or(Path::new("."));
        Scene::from_toml(&text, &name, base)
    }

    /// Parse scene TOML; `origin` names the source in errors (and, by its file stem, the
    /// scene when the file has no `name`), `base_dir` resolves mesh files.
    pub fn from_toml(text: &str, origin: &str, base_dir: &Path) -> Result<Scene, SceneError> {
        let resolver = Resolver {
            origin,
            text,
            base_dir,
        };
        let (file, meshes) = resolver.parse()?;
        resolver.resolve(file, meshes)
    }

    /// The same scene with another image size and time sampling; the field of view and the
    /// window start (`t0_ps`) are kept.
    pub fn with_resolution(&self, nx: usize, ny: usize, nt: usize, dt_ps: f64) -> Scene {
        let mut s = self.clone();
        s.camera.intrinsics = Intrinsics::from_vfov(nx, ny, self.camera.vfov_deg);
        s.camera.axis = TimeAxis {
            t0_ps: self.camera.axis.t0_ps,
            dt_ps,
            nt,
        };
        s
    }

    /// The capture calibration this scene implies: time origin (`t0_ps = 0`) at the pulse
    /// leaving the spot, time scale 1.
    pub fn calibration(&self) -> Calibration {
        Calibration {
            intrinsics: self.camera.intrinsics,
            pose: self.camera.pose,
            t0_ps: 0.0,
            time_scale: 1.0,
            laser_m: self.laser.position_m,
            eta: self.eta,
        }
    }

    /// Fiducial points visible from the camera: the corners of every box entry, and the
    /// corners and a 3 x 3 grid of every quad entry, kept when they project inside the image
    /// (half a pixel from the border) and nothing lies between them and the camera.
    /// Named `<label>.corner<k>` and `<label>.grid<r><c>`.
    pub fn fiducials(&self) -> Vec<(String, Point3<f64>)> {
        let bvh = Bvh::new(self.mesh.clone());
        let calib = self.calibration();
        let (w, h) = (
            self.camera.intrinsics.width as f64,
            self.camera.intrinsics.height as f64,
        );
        let o = self.camera.pose.position_m;
        self.fiducial_candidates
            .iter()
            .filter(|(_, p)| {
                let Some((u, v)) = calib.project(p) else {
                    return false;
                };
                if !(u >= 0.5 && v >= 0.5 && u <= w - 0.5 && v <= h - 0.5) {
                    return false;
                }
                let d = p - o;
                let dist = d.norm();
                let ray = Ray::new(o.cast::<f32>(), (d / dist).cast::<f32>());
                !bvh.occluded(&ray, 0.0, (dist - 1e-3) as f32)
            })
            .cloned()
            .collect()
    }
}

// ---------------------------------------------------------------------------------------
// File schema

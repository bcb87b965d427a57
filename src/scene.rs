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

use crate::camera::{one_line_toml_error, Calibration, Intrinsics, Pose};
use crate::cube::TimeAxis;
use crate::geometry::bvh::Bvh;
use crate::geometry::{primitives, Ray, TriangleMesh};
use crate::limits::short_number;
use nalgebra::{Matrix4, Point3, Rotation3, Unit, Vector3};
use serde::Deserialize;
use std::ops::Range;
use std::path::Path;
use toml::Spanned;

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
    /// A mesh file named by the scene is missing or unreadable (names the file).
    #[error("{origin}: {location}: mesh file {path}: {message}")]
    MeshFile {
        origin: String,
        location: String,
        path: String,
        message: String,
    },
    /// No built-in scene has this name.
    #[error("unknown built-in scene '{name}' (known: {})", BUILTIN_NAMES.join(", "))]
    UnknownBuiltin { name: String },
    /// The `bunny` built-in scene was asked for without a mesh file.
    #[error("built-in scene 'bunny' needs a mesh file (e.g. the Stanford bunny OBJ)")]
    BunnyNeedsMesh,
}

/// Names accepted by [`Scene::builtin`].
pub const BUILTIN_NAMES: [&str; 3] = ["cube", "cornell", "bunny"];

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
    /// A built-in scene by name (`cube`, `cornell`, `bunny`); `bunny_mesh` is the mesh file
    /// the `bunny` scene places in the Cornell box (ignored by the others).
    pub fn builtin(name: &str, bunny_mesh: Option<&Path>) -> Result<Scene, SceneError> {
        let text = Scene::builtin_toml(name, bunny_mesh)?;
        Scene::from_toml(&text, &format!("built-in scene '{name}'"), Path::new("."))
    }

    /// The scene file text of a built-in scene (what [`Scene::builtin`] parses).
    pub fn builtin_toml(name: &str, bunny_mesh: Option<&Path>) -> Result<String, SceneError> {
        match name {
            "cube" => Ok(CUBE_TOML.to_string()),
            "cornell" => Ok(format!("{CORNELL_HEAD}{CORNELL_WALLS}{CORNELL_OBJECTS}")),
            "bunny" => {
                let path = bunny_mesh.ok_or(SceneError::BunnyNeedsMesh)?;
                let quoted = toml::Value::String(path.display().to_string()).to_string();
                Ok(format!(
                    "{}{CORNELL_WALLS}{}",
                    CORNELL_HEAD.replace("name = \"cornell\"", "name = \"bunny\""),
                    BUNNY_ENTRY.replace("@PATH@", &quoted)
                ))
            }
            _ => Err(SceneError::UnknownBuiltin {
                name: name.to_string(),
            }),
        }
    }

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
        let file: SceneFile = toml::from_str(text).map_err(|e| SceneError::Parse {
            origin: origin.to_string(),
            message: one_line_toml_error(&e, text),
        })?;
        Resolver {
            origin,
            text,
            base_dir,
        }
        .resolve(file)
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

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    eta: Option<Spanned<f64>>,
    laser: Spanned<LaserEntry>,
    camera: Spanned<CameraEntry>,
    #[serde(default)]
    mesh: Vec<Spanned<MeshEntry>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LaserEntry {
    position_m: Spanned<[f64; 3]>,
    normal: Spanned<[f64; 3]>,
    #[serde(default)]
    emission: Option<Emission>,
    wavelength_nm: Spanned<f64>,
    pulse_width_fs: Spanned<f64>,
    energy: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraEntry {
    position_m: Spanned<[f64; 3]>,
    look_at_m: Spanned<[f64; 3]>,
    #[serde(default)]
    up: Option<Spanned<[f64; 3]>>,
    vfov_deg: Spanned<f64>,
    nx: Spanned<usize>,
    ny: Spanned<usize>,
    nt: Spanned<usize>,
    dt_ps: Spanned<f64>,
    t0_ps: Spanned<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Primitive {
    Quad,
    Box,
    Icosphere,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshEntry {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    primitive: Option<Spanned<Primitive>>,
    #[serde(default)]
    file: Option<Spanned<String>>,
    #[serde(default)]
    fit_size_m: Option<Spanned<f64>>,
    #[serde(default)]
    size: Option<Spanned<Vec<f64>>>,
    #[serde(default)]
    radius: Option<Spanned<f64>>,
    #[serde(default)]
    subdivisions: Option<Spanned<u32>>,
    #[serde(default)]
    scale: Option<Spanned<f64>>,
    #[serde(default)]
    rotate_deg: Option<Spanned<[f64; 3]>>,
    #[serde(default)]
    rotate_axis: Option<Spanned<[f64; 3]>>,
    #[serde(default)]
    rotate_angle_deg: Option<Spanned<f64>>,
    #[serde(default)]
    translate_m: Option<Spanned<[f64; 3]>>,
    albedo: Spanned<f64>,
}

/// Most subdivisions an icosphere may ask for (20 * 4^7 = 327 680 triangles).
const MAX_SUBDIVISIONS: u32 = 7;
/// The range of `eta`: from vacuum to well beyond any transparent medium (water 1.33,
/// diamond 2.42, germanium about 4 in the infrared). A larger index multiplies every flight
/// time and the world-time axis with it (`eta = 1e19` asked for an impossible allocation).
pub const ETA_RANGE: (f64, f64) = (1.0, 10.0);
/// The largest pulse width, fs (1 ns): far beyond femtosecond lasers, small enough that the
/// pulse's time response stays a bounded number of bins (4294967296 fs hung the tracer).
/// The pulse must also be shorter than the camera's time window.
pub const MAX_PULSE_WIDTH_FS: f64 = 1e6;
/// How far from the origin, in metres, any point of a scene may lie (camera, laser, look-at
/// target, every vertex after its entry's transform): the tracer casts rays in `f32`, which
/// loses millimetres beyond about 1e4 m and turns coordinates above 3.4e38 into infinities.
pub const MAX_EXTENT_M: f64 = 1e4;
/// The range of `camera.dt_ps`: a femtosecond to a microsecond per bin.
pub const DT_PS_RANGE: (f64, f64) = (1e-3, 1e6);
/// The range of `laser.wavelength_nm`: soft X-rays to far infrared (the Doppler-shifted
/// colour and the CIE tables need a positive, finite wavelength).
pub const WAVELENGTH_NM_RANGE: (f64, f64) = (1.0, 1e6);
/// The largest `laser.energy` (cube values are `f32` and scale with it).
pub const MAX_ENERGY: f64 = 1e12;
/// The largest `camera.nx` and `camera.ny`.
pub const MAX_SIDE: u64 = 16384;
/// The largest `camera.nt`.
pub const MAX_NT: u64 = 1 << 20;
/// Closest a camera may be to a surface, metres.
const CAMERA_CLEARANCE_M: f64 = 1e-3;

struct Resolver<'a> {
    origin: &'a str,
    text: &'a str,
    base_dir: &'a Path,
}

impl Resolver<'_> {
    /// "line L, column C" of a byte offset.
    fn at(&self, span: &Range<usize>) -> String {
        let before = &self.text[..span.start.min(self.text.len())];
        let line = before.matches('\n').count() + 1;
        let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
        format!("line {line}, column {col}")
    }

    fn bad(&self, span: &Range<usize>, key: &str, what: impl std::fmt::Display) -> SceneError {
        SceneError::Invalid {
            origin: self.origin.to_string(),
            message: format!("{}: {key}: {what}", self.at(span)),
        }
    }

    fn positive(&self, v: &Spanned<f64>, key: &str) -> Result<f64, SceneError> {
        let x = *v.get_ref();
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(self.bad(&v.span(), key, format!("must be positive, got {x}")))
        }
    }

    /// A number within `[lo, hi]` (`unit` follows the numbers in the message).
    fn in_range(
        &self,
        v: &Spanned<f64>,
        key: &str,
        (lo, hi): (f64, f64),
        unit: &str,
    ) -> Result<f64, SceneError> {
        let x = *v.get_ref();
        if x.is_finite() && x >= lo && x <= hi {
            Ok(x)
        } else {
            Err(self.bad(
                &v.span(),
                key,
                format!(
                    "must lie in [{}, {}]{unit}, got {}",
                    short_number(lo),
                    short_number(hi),
                    short_number(x)
                ),
            ))
        }
    }

    /// A point within [`MAX_EXTENT_M`] of the origin.
    fn point(&self, v: &Spanned<[f64; 3]>, key: &str) -> Result<Vector3<f64>, SceneError> {
        let p = self.finite3(v, key)?;
        match p.iter().position(|x| x.abs() > MAX_EXTENT_M) {
            None => Ok(p),
            Some(i) => Err(self.bad(
                &v.span(),
                key,
                format!(
                    "[{i}] = {:e} m lies beyond the {MAX_EXTENT_M:e} m from the origin that a scene may reach",
                    p[i]
                ),
            )),
        }
    }

    fn finite3(&self, v: &Spanned<[f64; 3]>, key: &str) -> Result<Vector3<f64>, SceneError> {
        let a = *v.get_ref();
        if a.iter().all(|x| x.is_finite()) {
            Ok(Vector3::from(a))
        } else {
            Err(self.bad(&v.span(), key, format!("must be finite, got {a:?}")))
        }
    }

    fn direction(
        &self,
        v: &Spanned<[f64; 3]>,
        key: &str,
    ) -> Result<Unit<Vector3<f64>>, SceneError> {
        let d = self.finite3(v, key)?;
        Unit::try_new(d, 1e-12)
            .ok_or_else(|| self.bad(&v.span(), key, "must be a non-zero direction"))
    }

    fn resolve(&self, file: SceneFile) -> Result<Scene, SceneError> {
        let eta = match &file.eta {
            Some(e) => {
                let x = *e.get_ref();
                if !(x.is_finite() && x >= ETA_RANGE.0 && x <= ETA_RANGE.1) {
                    return Err(self.bad(
                        &e.span(),
                        "eta",
                        format!(
                            "must lie in [{}, {}] (a refractive index), got {x}",
                            ETA_RANGE.0, ETA_RANGE.1
                        ),
                    ));
                }
                x
            }
            None => 1.0,
        };
        let laser = self.laser(&file.laser)?;
        let camera = self.camera(&file.camera)?;
        // The pulse must fit in the camera's time window.
        let window_fs = camera.axis.nt as f64 * camera.axis.dt_ps * 1e3;
        if laser.pulse_width_fs > window_fs {
            let p = &file.laser.get_ref().pulse_width_fs;
            return Err(self.bad(
                &p.span(),
                "laser.pulse_width_fs",
                format!(
                    "{} fs is longer than the camera's time window (camera.nt x camera.dt_ps = {window_fs} fs)",
                    laser.pulse_width_fs
                ),
            ));
        }
        if file.mesh.is_empty() {
            return Err(SceneError::Invalid {
                origin: self.origin.to_string(),
                message: "mesh: the scene has no [[mesh]] entry".into(),
            });
        }
        let mut mesh = TriangleMesh::default();
        let mut albedo = Vec::new();
        let mut labels = Vec::new();
        let mut candidates = Vec::new();
        let cam_span = file.camera.get_ref().position_m.span();
        let laser_span = file.laser.get_ref().position_m.span();
        for (i, entry) in file.mesh.iter().enumerate() {
            let e = entry.get_ref();
            let key = format!("mesh[{i}]");
            let label = e.name.clone().unwrap_or_else(|| format!("mesh{i}"));
            let a = *e.albedo.get_ref();
            if !(0.0..=1.0).contains(&a) {
                return Err(self.bad(
                    &e.albedo.span(),
                    &format!("{key}.albedo"),
                    format!("must lie in [0, 1], got {a}"),
                ));
            }
            let (part, closed, corners) = self.entry_mesh(entry, &key)?;
            // Camera and laser must be outside closed shapes; the camera off every surface.
            if closed && inside_closed(&part, &camera.pose.position_m) {
                return Err(self.bad(
                    &cam_span,
                    "camera.position_m",
                    format!("the camera is inside {key} ('{label}')"),
                ));
            }
            if closed && inside_closed(&part, &laser.position_m) {
                return Err(self.bad(
                    &laser_span,
                    "laser.position_m",
                    format!("the laser spot is inside {key} ('{label}')"),
                ));
            }
            let d = distance_to_mesh(&part, &camera.pose.position_m);
            if d < CAMERA_CLEARANCE_M {
                return Err(self.bad(
                    &cam_span,
                    "camera.position_m",
                    format!(
                        "the camera is {:.2} mm from the surface of {key} ('{label}'), closer than 1 mm",
                        d * 1e3
                    ),
                ));
            }
            for (kind, p) in corners {
                candidates.push((format!("{label}.{}", kind.name()), p));
            }
            mesh.append(&part, i as u32);
            albedo.push(a as f32);
            labels.push(label);
        }
        Ok(Scene {
            name: file.name.unwrap_or_else(|| {
                Path::new(self.origin)
                    .file_stem()
                    .map_or("scene".into(), |s| s.to_string_lossy().into_owned())
            }),
            mesh,
            albedo,
            labels,
            laser,
            camera,
            eta,
            fiducial_candidates: candidates,
        })
    }

    fn laser(&self, l: &Spanned<LaserEntry>) -> Result<Laser, SceneError> {
        let e = l.get_ref();
        let position = self.point(&e.position_m, "laser.position_m")?;
        let normal = self.direction(&e.normal, "laser.normal")?;
        let pulse = self.in_range(
            &e.pulse_width_fs,
            "laser.pulse_width_fs",
            (0.0, MAX_PULSE_WIDTH_FS),
            " fs",
        )?;
        let energy = self.positive(&e.energy, "laser.energy")?;
        if energy > MAX_ENERGY {
            return Err(self.bad(
                &e.energy.span(),
                "laser.energy",
                format!(
                    "must lie in (0, {MAX_ENERGY:e}], got {}",
                    short_number(energy)
                ),
            ));
        }
        Ok(Laser {
            position_m: Point3::from(position),
            normal,
            emission: e.emission.unwrap_or(Emission::Cosine),
            wavelength_nm: self.in_range(
                &e.wavelength_nm,
                "laser.wavelength_nm",
                WAVELENGTH_NM_RANGE,
                " nm",
            )?,
            pulse_width_fs: pulse,
            energy,
        })
    }

    fn camera(&self, c: &Spanned<CameraEntry>) -> Result<StreakCamera, SceneError> {
        let e = c.get_ref();
        let position = self.point(&e.position_m, "camera.position_m")?;
        let look_at = self.point(&e.look_at_m, "camera.look_at_m")?;
        let up = match &e.up {
            Some(u) => self.direction(u, "camera.up")?.into_inner(),
            None => Vector3::y(),
        };
        let vfov = *e.vfov_deg.get_ref();
        if !(vfov > 0.0 && vfov < 180.0) {
            return Err(self.bad(
                &e.vfov_deg.span(),
                "camera.vfov_deg",
                format!("must lie in (0, 180), got {vfov}"),
            ));
        }
        for (v, key, limit) in [
            (&e.nx, "camera.nx", MAX_SIDE),
            (&e.ny, "camera.ny", MAX_SIDE),
            (&e.nt, "camera.nt", MAX_NT),
        ] {
            if *v.get_ref() == 0 {
                return Err(self.bad(&v.span(), key, "must be positive, got 0"));
            }
            crate::limits::bounded_count(*v.get_ref() as f64, limit, key, "use fewer").map_err(
                |_| {
                    self.bad(
                        &v.span(),
                        key,
                        format!("must lie in [1, {limit}], got {}", v.get_ref()),
                    )
                },
            )?;
        }
        let dt_ps = self.in_range(&e.dt_ps, "camera.dt_ps", DT_PS_RANGE, " ps")?;
        let t0_ps = *e.t0_ps.get_ref();
        if !t0_ps.is_finite() {
            return Err(self.bad(&e.t0_ps.span(), "camera.t0_ps", "must be finite"));
        }
        if (look_at - position).norm() < 1e-9 {
            return Err(self.bad(
                &e.look_at_m.span(),
                "camera.look_at_m",
                "must differ from camera.position_m",
            ));
        }
        let pose =
            Pose::look_at(Point3::from(position), Point3::from(look_at), up).ok_or_else(|| {
                let span = e.up.as_ref().map_or(c.span(), |u| u.span());
                self.bad(&span, "camera.up", "is parallel to the viewing direction")
            })?;
        Ok(StreakCamera {
            intrinsics: Intrinsics::from_vfov(*e.nx.get_ref(), *e.ny.get_ref(), vfov),
            pose,
            axis: TimeAxis {
                t0_ps,
                dt_ps,
                nt: *e.nt.get_ref(),
            },
            vfov_deg: vfov,
        })
    }

    /// The entry's mesh in world coordinates, whether it is closed, and its fiducial
    /// candidates as (kind, point).
    #[allow(clippy::type_complexity)]
    fn entry_mesh(
        &self,
        entry: &Spanned<MeshEntry>,
        key: &str,
    ) -> Result<(TriangleMesh, bool, Vec<(Candidate, Point3<f64>)>), SceneError> {
        let e = entry.get_ref();
        let k = |name: &str| format!("{key}.{name}");
        let reject_key = |present: bool, span: Option<Range<usize>>, name: &str, why: &str| {
            if present {
                Err(self.bad(&span.unwrap_or(entry.span()), &k(name), why))
            } else {
                Ok(())
            }
        };
        let (mut mesh, closed, local_fiducials): (
            TriangleMesh,
            bool,
            Vec<(Candidate, Point3<f64>)>,
        ) = match (&e.primitive, &e.file) {
            (Some(_), Some(f)) => {
                return Err(self.bad(
                    &f.span(),
                    &k("file"),
                    "give either primitive or file, not both",
                ))
            }
            (None, None) => {
                return Err(self.bad(
                    &entry.span(),
                    key,
                    "needs a primitive (quad, box, icosphere) or a file",
                ))
            }
            (Some(p), None) => {
                let prim = *p.get_ref();
                reject_key(
                    e.fit_size_m.is_some(),
                    e.fit_size_m.as_ref().map(|s| s.span()),
                    "fit_size_m",
                    "applies to mesh files only",
                )?;
                match prim {
                    Primitive::Quad | Primitive::Box => {
                        let want = if prim == Primitive::Quad { 2 } else { 3 };
                        let what = if want == 2 { "[x, y]" } else { "[x, y, z]" };
                        reject_key(
                            e.radius.is_some(),
                            e.radius.as_ref().map(|s| s.span()),
                            "radius",
                            "applies to icospheres only (use size)",
                        )?;
                        reject_key(
                            e.subdivisions.is_some(),
                            e.subdivisions.as_ref().map(|s| s.span()),
                            "subdivisions",
                            "applies to icospheres only",
                        )?;
                        let s = e.size.as_ref().ok_or_else(|| {
                            self.bad(
                                &entry.span(),
                                &k("size"),
                                format!("missing: give size = {what}"),
                            )
                        })?;
                        let v = s.get_ref();
                        if v.len() != want {
                            return Err(self.bad(
                                &s.span(),
                                &k("size"),
                                format!("needs {want} values {what}, got {}", v.len()),
                            ));
                        }
                        if let Some(x) = v.iter().find(|x| !(x.is_finite() && **x > 0.0)) {
                            return Err(self.bad(
                                &s.span(),
                                &k("size"),
                                format!("sizes must be positive, got {x}"),
                            ));
                        }
                        if prim == Primitive::Quad {
                            let (hx, hy) = (0.5 * v[0], 0.5 * v[1]);
                            let mut pts = Vec::new();
                            for (c, (sx, sy)) in
                                [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                                    .iter()
                                    .enumerate()
                            {
                                pts.push((
                                    Candidate::Corner(c),
                                    Point3::new(sx * hx, sy * hy, 0.0),
                                ));
                            }
                            for r in 0..3 {
                                for c in 0..3 {
                                    let fx = (c as f64 + 1.0) / 4.0 * 2.0 - 1.0;
                                    let fy = (r as f64 + 1.0) / 4.0 * 2.0 - 1.0;
                                    pts.push((
                                        Candidate::Grid(r, c),
                                        Point3::new(fx * hx, fy * hy, 0.0),
                                    ));
                                }
                            }
                            (primitives::quad(v[0] as f32, v[1] as f32), false, pts)
                        } else {
                            let size = Vector3::new(v[0], v[1], v[2]);
                            let pts = (0..8)
                                .map(|c| {
                                    let s = |bit: usize| if c & bit != 0 { 0.5 } else { -0.5 };
                                    (
                                        Candidate::Corner(c),
                                        Point3::new(s(1) * size.x, s(2) * size.y, s(4) * size.z),
                                    )
                                })
                                .collect();
                            (primitives::cuboid(size.cast::<f32>()), true, pts)
                        }
                    }
                    Primitive::Icosphere => {
                        reject_key(
                            e.size.is_some(),
                            e.size.as_ref().map(|s| s.span()),
                            "size",
                            "an icosphere takes radius, not size",
                        )?;
                        let r = e.radius.as_ref().ok_or_else(|| {
                            self.bad(
                                &entry.span(),
                                &k("radius"),
                                "missing: an icosphere needs a radius",
                            )
                        })?;
                        let radius = self.positive(r, &k("radius"))?;
                        let sub = match &e.subdivisions {
                            Some(s) if *s.get_ref() > MAX_SUBDIVISIONS => {
                                return Err(self.bad(
                                    &s.span(),
                                    &k("subdivisions"),
                                    format!("at most {MAX_SUBDIVISIONS}, got {}", s.get_ref()),
                                ))
                            }
                            Some(s) => *s.get_ref(),
                            None => 3,
                        };
                        (primitives::icosphere(radius as f32, sub), true, Vec::new())
                    }
                }
            }
            (None, Some(f)) => {
                for (present, span, name) in [
                    (e.size.is_some(), e.size.as_ref().map(|s| s.span()), "size"),
                    (
                        e.radius.is_some(),
                        e.radius.as_ref().map(|s| s.span()),
                        "radius",
                    ),
                    (
                        e.subdivisions.is_some(),
                        e.subdivisions.as_ref().map(|s| s.span()),
                        "subdivisions",
                    ),
                ] {
                    reject_key(
                        present,
                        span,
                        name,
                        "applies to primitives only (use scale or fit_size_m)",
                    )?;
                }
                let path = self.base_dir.join(f.get_ref());
                let mut m = load_mesh_file(&path).map_err(|message| SceneError::MeshFile {
                    origin: self.origin.to_string(),
                    location: format!("{}: {}", self.at(&f.span()), k("file")),
                    path: path.display().to_string(),
                    message,
                })?;
                if m.triangles.is_empty() {
                    return Err(SceneError::MeshFile {
                        origin: self.origin.to_string(),
                        location: format!("{}: {}", self.at(&f.span()), k("file")),
                        path: path.display().to_string(),
                        message: "has no triangles".into(),
                    });
                }
                if let Some(fit) = &e.fit_size_m {
                    let size = self.positive(fit, &k("fit_size_m"))?;
                    fit_mesh(&mut m, size);
                }
                m.material.iter_mut().for_each(|x| *x = 0);
                let closed = primitives::is_closed(&welded(&m));
                (m, closed, Vec::new())
            }
        };
        let scale = match &e.scale {
            Some(s) => self.positive(s, &k("scale"))?,
            None => 1.0,
        };
        let rotation = match (&e.rotate_deg, &e.rotate_axis, &e.rotate_angle_deg) {
            (Some(r), None, None) => {
                let a = self.finite3(r, &k("rotate_deg"))?.map(f64::to_radians);
                Rotation3::from_axis_angle(&Vector3::z_axis(), a.z)
                    * Rotation3::from_axis_angle(&Vector3::y_axis(), a.y)
                    * Rotation3::from_axis_angle(&Vector3::x_axis(), a.x)
            }
            (None, Some(axis), Some(angle)) => {
                let axis = self.direction(axis, &k("rotate_axis"))?;
                let deg = *angle.get_ref();
                if !deg.is_finite() {
                    return Err(self.bad(&angle.span(), &k("rotate_angle_deg"), "must be finite"));
                }
                Rotation3::from_axis_angle(&axis, deg.to_radians())
            }
            (None, None, None) => Rotation3::identity(),
            (Some(r), _, _) => {
                return Err(self.bad(
                    &r.span(),
                    &k("rotate_deg"),
                    "give either rotate_deg or rotate_axis with rotate_angle_deg, not both",
                ))
            }
            (None, Some(a), None) => {
                return Err(self.bad(
                    &a.span(),
                    &k("rotate_angle_deg"),
                    "missing: rotate_axis needs rotate_angle_deg",
                ))
            }
            (None, None, Some(a)) => {
                return Err(self.bad(
                    &a.span(),
                    &k("rotate_axis"),
                    "missing: rotate_angle_deg needs rotate_axis",
                ))
            }
        };
        let translate = match &e.translate_m {
            Some(t) => self.point(t, &k("translate_m"))?,
            None => Vector3::zeros(),
        };
        let m: Matrix4<f64> = Matrix4::new_translation(&translate)
            * rotation.to_homogeneous()
            * Matrix4::new_scaling(scale);
        // Every vertex, after fit, scale, rotation and translation, within the scene's extent
        // (checked in f64, before the f32 mesh can hold an infinity).
        let far = mesh.positions.iter().find_map(|p| {
            let q = m.transform_point(&p.cast::<f64>());
            q.coords
                .iter()
                .copied()
                .find(|x| !x.is_finite() || x.abs() > MAX_EXTENT_M)
        });
        if let Some(r) = far {
            return Err(self.bad(
                &entry.span(),
                key,
                format!(
                    "after fit, scale, rotation and translation a vertex has a coordinate of {r:.3e} m, beyond the {MAX_EXTENT_M:e} m from the origin that a scene may reach"
                ),
            ));
        }
        mesh.transform(&m.cast::<f32>());
        let fiducials = local_fiducials
            .into_iter()
            .map(|(c, p)| (c, m.transform_point(&p)))
            .collect();
        Ok((mesh, closed, fiducials))
    }
}

/// Kind of a fiducial candidate within its mesh entry.
#[derive(Clone, Copy, Debug)]
enum Candidate {
    Corner(usize),
    Grid(usize, usize),
}

impl Candidate {
    fn name(&self) -> String {
        match self {
            Candidate::Corner(i) => format!("corner{i}"),
            Candidate::Grid(r, c) => format!("grid{r}{c}"),
        }
    }
}

/// Read a mesh file into triangles (metres, the file's own frame).
fn load_mesh_file(path: &Path) -> Result<TriangleMesh, String> {
    if !path.is_file() {
        return Err("not found".into());
    }
    crate::geometry::load::load_mesh(path).map_err(|e| e.to_string())
}

/// The mesh with vertices at bit-identical positions merged (files often repeat a vertex per
/// face or per normal), so that closedness is judged on the surface, not on the indexing.
fn welded(mesh: &TriangleMesh) -> TriangleMesh {
    let mut index: std::collections::HashMap<[u32; 3], u32> = std::collections::HashMap::new();
    let mut positions = Vec::new();
    let remap: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            *index
                .entry([p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
                .or_insert_with(|| {
                    positions.push(*p);
                    (positions.len() - 1) as u32
                })
        })
        .collect();
    TriangleMesh {
        positions,
        triangles: mesh
            .triangles
            .iter()
            .map(|t| t.map(|i| remap[i as usize]))
            .collect(),
        material: mesh.material.clone(),
    }
}

/// Centre the mesh's bounds in x and z, put its bottom at y = 0 and scale it uniformly so its
/// largest extent is `size_m`.
fn fit_mesh(mesh: &mut TriangleMesh, size_m: f64) {
    let b = mesh.bounds();
    let extent = b.max - b.min;
    let largest = extent.x.max(extent.y).max(extent.z) as f64;
    let s = if largest > 0.0 { size_m / largest } else { 1.0 };
    let shift = Vector3::new(
        -0.5 * (b.min.x + b.max.x) as f64,
        -b.min.y as f64,
        -0.5 * (b.min.z + b.max.z) as f64,
    );
    let m = Matrix4::new_scaling(s) * Matrix4::new_translation(&shift);
    mesh.transform(&m.cast::<f32>());
}

/// Whether `p` lies inside a closed mesh: parity of the crossings of a ray from `p`.
fn inside_closed(mesh: &TriangleMesh, p: &Point3<f64>) -> bool {
    // A direction unlikely to graze an edge of an axis-aligned or primitive mesh.
    let dir = Vector3::new(0.5773, 0.6117, 0.5406).normalize();
    let mut crossings = 0usize;
    for i in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.corners(i).map(|q| q.cast::<f64>());
        let e1 = b - a;
        let e2 = c - a;
        let pv = dir.cross(&e2);
        let det = e1.dot(&pv);
        if det.abs() < 1e-18 {
            continue;
        }
        let s = p - a;
        let u = s.dot(&pv) / det;
        let q = s.cross(&e1);
        let v = dir.dot(&q) / det;
        let t = e2.dot(&q) / det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 {
            crossings += 1;
        }
    }
    crossings % 2 == 1
}

/// Distance from `p` to the nearest point of any triangle of `mesh`, metres.
fn distance_to_mesh(mesh: &TriangleMesh, p: &Point3<f64>) -> f64 {
    (0..mesh.triangle_count())
        .map(|i| {
            let [a, b, c] = mesh.corners(i).map(|q| q.cast::<f64>());
            (closest_point_on_triangle(p, &a, &b, &c) - p).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Closest point to `p` on triangle `abc` (Ericson, Real-Time Collision Detection, 5.1.5).
fn closest_point_on_triangle(
    p: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> Point3<f64> {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

// ---------------------------------------------------------------------------------------
// Built-in scenes (y up, metres). The window start t0_ps of each is set just before the
// earliest direct arrival seen by a pixel (checked by a test).

const CUBE_TOML: &str = r#"# femto built-in scene "cube": a tabletop scene in the spirit of the seed's captures: a 7 cm
# box on a floor in front of a back wall, lit by a laser diffuser spot low at the back left.
# Sized so that the direct light spans about the default 1 ns window. Metres, y up.
name = "cube"
eta = 1.0

[laser]
position_m = [-0.13, 0.06, -0.07]
normal = [0.8, 0.2, 0.55]
emission = "cosine"
wavelength_nm = 795.0
pulse_width_fs = 50.0
energy = 1.0

[camera]
position_m = [0.0, 0.22, 0.85]
look_at_m = [0.0, 0.05, 0.0]
up = [0.0, 1.0, 0.0]
vfov_deg = 16.0
nx = 64
ny = 48
nt = 256
dt_ps = 4.0
t0_ps = 3200.0

[[mesh]]
name = "floor"
primitive = "quad"
size = [0.4, 0.35]
rotate_deg = [-90.0, 0.0, 0.0]
translate_m = [0.0, 0.0, 0.075]
albedo = 0.7

[[mesh]]
name = "back_wall"
primitive = "quad"
size = [0.4, 0.2]
translate_m = [0.0, 0.1, -0.1]
albedo = 0.7

[[mesh]]
name = "cube"
primitive = "box"
size = [0.07, 0.07, 0.07]
rotate_deg = [0.0, 30.0, 0.0]
translate_m = [0.02, 0.035, 0.0]
albedo = 0.8
"#;

const CORNELL_HEAD: &str = r#"# femto built-in scene "cornell": a 25 cm Cornell box open towards the camera, lit by a
# laser diffuser spot on the ceiling towards the back, pointing down. Monochrome albedos (one
# laser wavelength): the left wall bright, the right wall dark. Sized so that the direct
# light spans about the default 1 ns window. Metres, y up.
name = "cornell"
eta = 1.0

[laser]
position_m = [0.0, 0.249, -0.17]
normal = [0.0, -1.0, 0.0]
emission = "cosine"
wavelength_nm = 795.0
pulse_width_fs = 50.0
energy = 1.0

[camera]
position_m = [0.0, 0.125, 0.5]
look_at_m = [0.0, 0.125, -0.125]
up = [0.0, 1.0, 0.0]
vfov_deg = 30.0
nx = 64
ny = 48
nt = 256
dt_ps = 4.0
t0_ps = 2440.0
"#;

const CORNELL_WALLS: &str = r#"
[[mesh]]
name = "floor"
primitive = "quad"
size = [0.25, 0.25]
rotate_deg = [-90.0, 0.0, 0.0]
translate_m = [0.0, 0.0, -0.125]
albedo = 0.75

[[mesh]]
name = "ceiling"
primitive = "quad"
size = [0.25, 0.25]
rotate_deg = [90.0, 0.0, 0.0]
translate_m = [0.0, 0.25, -0.125]
albedo = 0.75

[[mesh]]
name = "back_wall"
primitive = "quad"
size = [0.25, 0.25]
translate_m = [0.0, 0.125, -0.25]
albedo = 0.75

[[mesh]]
name = "left_wall"
primitive = "quad"
size = [0.25, 0.25]
rotate_deg = [0.0, 90.0, 0.0]
translate_m = [-0.125, 0.125, -0.125]
albedo = 0.6

[[mesh]]
name = "right_wall"
primitive = "quad"
size = [0.25, 0.25]
rotate_deg = [0.0, -90.0, 0.0]
translate_m = [0.125, 0.125, -0.125]
albedo = 0.25
"#;

const CORNELL_OBJECTS: &str = r#"
[[mesh]]
name = "tall_box"
primitive = "box"
size = [0.07, 0.15, 0.07]
rotate_deg = [0.0, 17.0, 0.0]
translate_m = [-0.045, 0.075, -0.165]
albedo = 0.75

[[mesh]]
name = "sphere"
primitive = "icosphere"
radius = 0.04
subdivisions = 3
translate_m = [0.05, 0.04, -0.085]
albedo = 0.75
"#;

const BUNNY_ENTRY: &str = r#"
[[mesh]]
name = "bunny"
file = @PATH@
fit_size_m = 0.11
rotate_deg = [0.0, 20.0, 0.0]
translate_m = [0.0, 0.0, -0.135]
albedo = 0.75
"#;

#[cfg(test)]
mod tests {
    use super::*;

    /// A small valid scene; tests edit one line of it at a time.
    const BASE: &str = r#"name = "test"
eta = 1.0

[laser]
position_m = [-0.3, 0.3, 0.3]
normal = [0.5, -0.3, -0.6]
emission = "cosine"
wavelength_nm = 795.0
pulse_width_fs = 100.0
energy = 1.0

[camera]
position_m = [0.0, 0.4, 1.2]
look_at_m = [0.0, 0.1, 0.0]
up = [0.0, 1.0, 0.0]
vfov_deg = 35.0
nx = 16
ny = 12
nt = 32
dt_ps = 4.0
t0_ps = 3000.0

[[mesh]]
name = "floor"
primitive = "quad"
size = [1.0, 1.0]
rotate_deg = [-90.0, 0.0, 0.0]
albedo = 0.5

[[mesh]]
name = "block"
primitive = "box"
size = [0.2, 0.2, 0.2]
translate_m = [0.0, 0.1, 0.0]
albedo = 0.7

[[mesh]]
name = "ball"
primitive = "icosphere"
radius = 0.1
subdivisions = 1
translate_m = [0.3, 0.1, -0.2]
albedo = 0.3
"#;

    /// 1-based line of the first line of `text` containing `needle`.
    fn line_of(text: &str, needle: &str) -> usize {
        text.lines()
            .position(|l| l.contains(needle))
            .expect("needle")
            + 1
    }

    fn err(text: &str) -> String {
        Scene::from_toml(text, "t.toml", Path::new("."))
            .map(|_| ())
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn base_scene_resolves_with_one_material_per_entry() {
        let s = Scene::from_toml(BASE, "t.toml", Path::new(".")).unwrap();
        assert_eq!(s.name, "test");
        assert_eq!(s.albedo, vec![0.5, 0.7, 0.3]);
        assert_eq!(s.labels, vec!["floor", "block", "ball"]);
        assert_eq!(s.mesh.triangle_count(), 2 + 12 + 80);
        let count = |m: u32| s.mesh.material.iter().filter(|&&x| x == m).count();
        assert_eq!((count(0), count(1), count(2)), (2, 12, 80));
        // The floor quad, rotated -90 degrees about x, lies in y = 0 facing +y.
        for i in 0..2 {
            let [a, b, c] = s.mesh.corners(i);
            assert!(a.y.abs() < 1e-6 && b.y.abs() < 1e-6 && c.y.abs() < 1e-6);
            assert!((b - a).cross(&(c - a)).y > 0.0);
        }
        // The box sits on the floor: y from 0 to 0.2.
        let ys: Vec<f32> = s.mesh.positions[4..12].iter().map(|p| p.y).collect();
        assert!(ys.iter().all(|&y| y.abs() < 1e-6 || (y - 0.2).abs() < 1e-6));
        assert!((s.laser.normal.norm() - 1.0).abs() < 1e-12);
        assert_eq!(s.camera.axis.nt, 32);
        let calib = s.calibration();
        assert_eq!((calib.t0_ps, calib.time_scale), (0.0, 1.0));
        // The look-at point projects to the image centre.
        let (u, v) = calib.project(&Point3::new(0.0, 0.1, 0.0)).unwrap();
        assert!((u - 8.0).abs() < 1e-9 && (v - 6.0).abs() < 1e-9);
    }

    #[test]
    fn laser_intensity_and_pulse_width() {
        let s = Scene::from_toml(BASE, "t.toml", Path::new(".")).unwrap();
        let n = s.laser.normal.into_inner();
        let pi = std::f64::consts::PI;
        assert!((s.laser.intensity(Emission::Cosine, &n) - 1.0 / pi).abs() < 1e-12);
        assert_eq!(s.laser.intensity(Emission::Cosine, &-n), 0.0);
        assert!((s.laser.intensity(Emission::Isotropic, &-n) - 0.25 / pi).abs() < 1e-12);
        // FWHM 100 fs: sigma = 0.1 ps / 2.35482.
        assert!((s.laser.pulse_sigma_ps() - 0.1 / 2.354_820_045).abs() < 1e-9);
    }

    #[test]
    fn rotations_follow_the_documented_order() {
        // rotate_deg = [90, 90, 0]: first 90 about x, then 90 about y (fixed axes). The quad's
        // normal +z goes to -y under Rx(90), and -y stays -y under Ry(90). Its local +x edge
        // goes to +x under Rx(90), then to -z under Ry(90).
        let text = BASE.replace(
            "rotate_deg = [-90.0, 0.0, 0.0]",
            "rotate_deg = [90.0, 90.0, 0.0]",
        );
        let s = Scene::from_toml(&text, "t.toml", Path::new(".")).unwrap();
        let [a, b, c] = s.mesh.corners(0);
        let n = (b - a).cross(&(c - a)).normalize();
        assert!((n - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-6, "{n}");
        // Local corners 0 -> 1 run along +x: after rotation along -z.
        let e = (b - a).normalize();
        assert!((e - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-6, "{e}");
        // Axis-angle gives the same as the Euler form for a single axis.
        let euler = BASE.replace(
            "rotate_deg = [-90.0, 0.0, 0.0]",
            "rotate_deg = [0.0, 0.0, 30.0]",
        );
        let axis = BASE.replace(
            "rotate_deg = [-90.0, 0.0, 0.0]",
            "rotate_axis = [0.0, 0.0, 2.0]\nrotate_angle_deg = 30.0",
        );
        let s1 = Scene::from_toml(&euler, "t.toml", Path::new(".")).unwrap();
        let s2 = Scene::from_toml(&axis, "t.toml", Path::new(".")).unwrap();
        for (p, q) in s1.mesh.positions.iter().zip(&s2.mesh.positions) {
            assert!((p - q).norm() < 1e-6);
        }
        // Scale then translate: the ball's vertices sit at radius 0.1 * 2 around its centre.
        let scaled = BASE.replace("radius = 0.1", "radius = 0.1\nscale = 2.0");
        let s3 = Scene::from_toml(&scaled, "t.toml", Path::new(".")).unwrap();
        let centre = Point3::new(0.3f32, 0.1, -0.2);
        for i in 0..s3.mesh.triangle_count() {
            if s3.mesh.material[i] == 2 {
                for p in s3.mesh.corners(i) {
                    assert!(((p - centre).norm() - 0.2).abs() < 1e-5);
                }
            }
        }
    }

    /// Replace `from` by `to` in the base scene and check the error names `key` and the line
    /// where `to` (or `line_needle`) sits.
    fn check_error(from: &str, to: &str, key: &str, line_needle: &str) {
        assert!(BASE.contains(from), "{from}");
        let text = BASE.replacen(from, to, 1);
        let e = err(&text);
        let line = line_of(&text, line_needle);
        assert!(e.contains("t.toml"), "{e}");
        assert!(e.contains(key), "expected key {key} in: {e}");
        assert!(
            e.contains(&format!("line {line},")),
            "expected line {line} in: {e}"
        );
    }

    /// Every number of a scene finite and in its physical range, the range given in the
    /// message (issue 16: `eta = 1e19` gave "capacity overflow", `pulse_width_fs =
    /// 4294967296` hung the tracer, a far translation put infinities in the f32 mesh).
    #[test]
    fn numbers_outside_their_physical_range_name_the_key_and_the_range() {
        for (from, to, key, range) in [
            ("eta = 1.0", "eta = 1e19", "eta", "[1, 10]"),
            ("eta = 1.0", "eta = nan", "eta", "[1, 10]"),
            (
                "pulse_width_fs = 100.0",
                "pulse_width_fs = 4294967296",
                "laser.pulse_width_fs",
                "[0, 1000000] fs",
            ),
            (
                "pulse_width_fs = 100.0",
                "pulse_width_fs = 200000",
                "laser.pulse_width_fs",
                "camera.nt x camera.dt_ps = 128000 fs",
            ),
            (
                "wavelength_nm = 795.0",
                "wavelength_nm = inf",
                "laser.wavelength_nm",
                "[1, 1000000] nm",
            ),
            ("energy = 1.0", "energy = 1e300", "laser.energy", "1e12"),
            (
                "dt_ps = 4.0",
                "dt_ps = 1e-300",
                "camera.dt_ps",
                "[0.001, 1000000] ps",
            ),
            (
                "nt = 32",
                "nt = 9223372036854775807",
                "camera.nt",
                "[1, 1048576]",
            ),
            ("nx = 16", "nx = 100000", "camera.nx", "[1, 16384]"),
            (
                "position_m = [0.0, 0.4, 1.2]",
                "position_m = [0.0, 1e39, 1.2]",
                "camera.position_m",
                "[1] = 1e39 m",
            ),
            (
                "look_at_m = [0.0, 0.1, 0.0]",
                "look_at_m = [0.0, -inf, 0.0]",
                "camera.look_at_m",
                "must be finite",
            ),
            (
                "position_m = [-0.3, 0.3, 0.3]",
                "position_m = [-0.3, 0.3, 2e4]",
                "laser.position_m",
                "1e4 m",
            ),
            (
                "translate_m = [0.0, 0.1, 0.0]",
                "translate_m = [1e39, 0.1, 0.0]",
                "mesh[1].translate_m",
                "1e4 m",
            ),
            (
                "size = [1.0, 1.0]",
                "size = [1e30, 1.0]",
                "mesh[0]",
                "a vertex has a coordinate of -5.000e29 m",
            ),
            (
                "radius = 0.1",
                "radius = 0.1\nscale = 1e38",
                "mesh[2]",
                "beyond the 1e4 m",
            ),
        ] {
            assert!(BASE.contains(from), "{from}");
            let e = err(&BASE.replacen(from, to, 1));
            assert!(e.starts_with("t.toml: line "), "{e}");
            assert!(e.contains(key) && e.contains(range), "{to}: {e}");
        }
        // The built-in scenes lie inside every range.
        for name in ["cube", "cornell"] {
            Scene::builtin(name, None).unwrap();
        }
    }

    #[test]
    fn errors_name_the_key_and_the_line() {
        // Unknown key.
        check_error(
            "albedo = 0.7",
            "albedo = 0.7\ncolour = 3",
            "colour",
            "colour",
        );
        // Missing field (reported at the table that lacks it).
        check_error("nt = 32\n", "", "nt", "[camera]");
        // Negative and zero sizes, wrong counts.
        check_error(
            "size = [0.2, 0.2, 0.2]",
            "size = [0.2, -0.2, 0.2]",
            "mesh[1].size",
            "-0.2",
        );
        check_error(
            "size = [1.0, 1.0]",
            "size = [1.0, 0.0]",
            "mesh[0].size",
            "[1.0, 0.0]",
        );
        check_error(
            "size = [1.0, 1.0]",
            "size = [1.0]",
            "mesh[0].size",
            "size = [1.0]",
        );
        check_error("radius = 0.1", "radius = -0.1", "mesh[2].radius", "radius");
        // Albedo outside [0, 1].
        check_error("albedo = 0.7", "albedo = 1.5", "mesh[1].albedo", "1.5");
        // Time axis and medium.
        check_error("nt = 32", "nt = 0", "camera.nt", "nt = 0");
        check_error("dt_ps = 4.0", "dt_ps = -1.0", "camera.dt_ps", "dt_ps");
        check_error("eta = 1.0", "eta = 0.9", "eta", "eta = 0.9");
        check_error("energy = 1.0", "energy = 0.0", "laser.energy", "energy");
        check_error(
            "normal = [0.5, -0.3, -0.6]",
            "normal = [0, 0, 0]",
            "laser.normal",
            "normal",
        );
        // An unknown primitive and an unknown emission.
        check_error(
            "primitive = \"box\"",
            "primitive = \"cone\"",
            "cone",
            "cone",
        );
        check_error(
            "emission = \"cosine\"",
            "emission = \"laser\"",
            "laser",
            "emission",
        );
        // Conflicting or missing geometry keys.
        check_error(
            "radius = 0.1",
            "size = [0.1, 0.1]",
            "mesh[2].size",
            "size = [0.1, 0.1]",
        );
        check_error(
            "primitive = \"box\"",
            "primitive = \"box\"\nfile = \"x.obj\"",
            "mesh[1].file",
            "x.obj",
        );
    }

    #[test]
    fn camera_inside_a_closed_mesh_or_on_a_surface_is_rejected() {
        // Inside the box (centre 0, 0.1, 0).
        check_error(
            "position_m = [0.0, 0.4, 1.2]",
            "position_m = [0.02, 0.1, 0.05]",
            "camera.position_m",
            "[0.02, 0.1, 0.05]",
        );
        // Inside the icosphere.
        check_error(
            "position_m = [0.0, 0.4, 1.2]",
            "position_m = [0.3, 0.12, -0.2]",
            "camera.position_m",
            "[0.3, 0.12, -0.2]",
        );
        // Half a millimetre above the floor: within 1 mm of a surface.
        check_error(
            "position_m = [0.0, 0.4, 1.2]",
            "position_m = [0.4, 0.0005, 0.4]",
            "camera.position_m",
            "0.0005",
        );
        let e = err(&BASE.replacen(
            "position_m = [0.0, 0.4, 1.2]",
            "position_m = [0.4, 0.0005, 0.4]",
            1,
        ));
        assert!(e.contains("floor") && e.contains("1 mm"), "{e}");
        // Two millimetres above the floor is fine.
        let ok = BASE.replacen(
            "position_m = [0.0, 0.4, 1.2]",
            "position_m = [0.4, 0.002, 0.4]",
            1,
        );
        assert!(Scene::from_toml(&ok, "t.toml", Path::new(".")).is_ok());
        // A laser spot inside the box.
        check_error(
            "position_m = [-0.3, 0.3, 0.3]",
            "position_m = [0.0, 0.1, 0.0]",
            "laser.position_m",
            "[0.0, 0.1, 0.0]",
        );
    }

    #[test]
    fn a_missing_mesh_file_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let text = BASE.replacen(
            "primitive = \"box\"\nsize = [0.2, 0.2, 0.2]",
            "file = \"meshes/missing.obj\"",
            1,
        );
        let e = Scene::from_toml(&text, "t.toml", dir.path())
            .map(|_| ())
            .unwrap_err()
            .to_string();
        let line = line_of(&text, "missing.obj");
        assert!(
            e.contains("missing.obj") && e.contains("mesh[1].file"),
            "{e}"
        );
        assert!(e.contains(&format!("line {line},")), "{e}");
        assert!(e.contains(&dir.path().display().to_string()), "{e}");
    }

    #[test]
    fn load_reads_a_file_and_reports_io_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("my_scene.toml");
        std::fs::write(&path, BASE.replace("name = \"test\"\n", "")).unwrap();
        let s = Scene::load(&path).unwrap();
        assert_eq!(s.name, "my_scene");
        let e = Scene::load(&dir.path().join("nope.toml")).unwrap_err();
        assert!(matches!(e, SceneError::Io { .. }) && e.to_string().contains("nope.toml"));
    }

    #[test]
    fn file_meshes_are_welded_before_the_closedness_test_and_fitted() {
        // A box whose triangles each carry their own three vertices, as OBJ files often do.
        let shared = primitives::cuboid(Vector3::new(0.2, 0.4, 0.1));
        let mut split = TriangleMesh::default();
        for i in 0..shared.triangle_count() {
            let k = split.positions.len() as u32;
            split.positions.extend_from_slice(&shared.corners(i));
            split.triangles.push([k, k + 1, k + 2]);
            split.material.push(0);
        }
        assert!(!primitives::is_closed(&split));
        assert!(primitives::is_closed(&welded(&split)));
        // Fit: bottom at y = 0, centred in x and z, largest extent (y, 0.4) scaled to 0.1.
        let mut m = split.clone();
        m.transform(&Matrix4::new_translation(&Vector3::new(1.0, 2.0, 3.0)));
        fit_mesh(&mut m, 0.1);
        let b = m.bounds();
        assert!(b.min.y.abs() < 1e-6 && (b.max.y - 0.1).abs() < 1e-6);
        assert!((b.min.x + b.max.x).abs() < 1e-6 && (b.min.z + b.max.z).abs() < 1e-6);
        assert!((b.max.x - b.min.x - 0.05).abs() < 1e-6);
    }

    #[test]
    fn builtins_parse_and_unknown_names_fail() {
        for name in ["cube", "cornell"] {
            let s = Scene::builtin(name, None).unwrap();
            assert_eq!(s.name, name);
            assert_eq!(
                (s.camera.intrinsics.width, s.camera.intrinsics.height),
                (64, 48)
            );
            assert_eq!((s.camera.axis.nt, s.camera.axis.dt_ps), (256, 4.0));
        }
        assert!(matches!(
            Scene::builtin("bunny", None),
            Err(SceneError::BunnyNeedsMesh)
        ));
        let e = Scene::builtin("teapot", None).unwrap_err().to_string();
        assert!(e.contains("teapot") && e.contains("cornell"), "{e}");
        // The bunny scene names the mesh file it could not read.
        let e = Scene::builtin("bunny", Some(Path::new("/no/such/bunny.obj")))
            .unwrap_err()
            .to_string();
        assert!(e.contains("/no/such/bunny.obj"), "{e}");
    }

    #[test]
    fn with_resolution_keeps_the_view_and_the_window_start() {
        let s = Scene::builtin("cube", None).unwrap();
        let big = s.with_resolution(672, 600, 512, 1.71);
        assert_eq!(big.camera.axis.t0_ps, s.camera.axis.t0_ps);
        assert_eq!(big.camera.axis.nt, 512);
        assert_eq!(
            (big.camera.intrinsics.width, big.camera.intrinsics.height),
            (672, 600)
        );
        // Same vertical field of view: the top edge of the image maps to the same ray.
        let a = s.calibration().world_ray(32.0, 0.0);
        let b = big.calibration().world_ray(336.0, 0.0);
        assert!((a.into_inner() - b.into_inner()).norm() < 1e-12);
    }

    /// Earliest camera time at which direct light reaches any pixel centre, found by ray
    /// casting independently of the tracer.
    fn direct_arrival_range_ps(s: &Scene) -> (f64, f64) {
        let bvh = Bvh::new(s.mesh.clone());
        let calib = s.calibration();
        let o = s.camera.pose.position_m;
        let (mut best, mut last) = (f64::INFINITY, 0.0f64);
        for j in 0..s.camera.intrinsics.height {
            for i in 0..s.camera.intrinsics.width {
                let d = calib.world_ray(i as f64 + 0.5, j as f64 + 0.5).into_inner();
                let ray = Ray::new(o.cast::<f32>(), d.cast::<f32>());
                let Some(h) = bvh.intersect(&ray, 0.0, f32::INFINITY) else {
                    continue;
                };
                let p = o + d * h.t as f64;
                let mut n = h.normal.cast::<f64>();
                if n.dot(&d) > 0.0 {
                    n = -n;
                }
                let to_l = s.laser.position_m - p;
                let r = to_l.norm();
                let w = to_l / r;
                let lit = n.dot(&w) > 0.0 && s.laser.normal.dot(&-w) > 0.0;
                let shadow = Ray::new((p + n * 1e-4).cast::<f32>(), w.cast::<f32>());
                if lit && !bvh.occluded(&shadow, 0.0, (r - 2e-4) as f32) {
                    let t = s.eta * (r + h.t as f64) / crate::units::C_M_PER_PS;
                    best = best.min(t);
                    last = last.max(t);
                }
            }
        }
        (best, last)
    }

    #[test]
    fn builtin_windows_start_just_before_the_first_direct_light() {
        for name in ["cube", "cornell"] {
            let s = Scene::builtin(name, None).unwrap();
            let (t_first, t_last) = direct_arrival_range_ps(&s);
            let ax = s.camera.axis;
            println!(
                "{name}: direct arrivals {t_first:.1} .. {t_last:.1} ps, window {} .. {}",
                ax.t0_ps,
                ax.end_ps()
            );
            assert!(
                t_first > ax.t0_ps && t_first < ax.t0_ps + 0.1 * (ax.end_ps() - ax.t0_ps),
                "{name}: first light at {t_first} ps, window {} .. {}",
                ax.t0_ps,
                ax.end_ps()
            );
        }
    }

    #[test]
    fn cube_fiducials_are_visible_many_and_not_coplanar() {
        let s = Scene::builtin("cube", None).unwrap();
        let f = s.fiducials();
        assert!(f.len() >= 20, "{} fiducials", f.len());
        let corners = f
            .iter()
            .filter(|(n, _)| n.starts_with("cube.corner"))
            .count();
        // A box on a floor seen from above and in front shows at most 7 corners.
        assert!((4..=7).contains(&corners), "{corners} cube corners");
        let calib = s.calibration();
        for (name, p) in &f {
            let (u, v) = calib.project(p).unwrap();
            assert!(
                u > 0.0 && v > 0.0 && u < 64.0 && v < 48.0,
                "{name} at {u},{v}"
            );
        }
        // Not coplanar: the smallest singular value of the centred point cloud is not ~0.
        let n = f.len() as f64;
        let mean = f.iter().map(|(_, p)| p.coords).sum::<Vector3<f64>>() / n;
        let mut m = nalgebra::Matrix3::zeros();
        for (_, p) in &f {
            let d = p.coords - mean;
            m += d * d.transpose();
        }
        let ev = m.symmetric_eigenvalues();
        assert!(ev.min() / n > 1e-4, "{ev}");
        // Independent visibility of the box's corners: a corner of a convex box is visible
        // exactly when one of its three faces faces the camera (nothing else in the scene
        // stands between the camera and the box).
        let o = s.camera.pose.position_m;
        let rot = Rotation3::from_axis_angle(&Vector3::y_axis(), 30f64.to_radians());
        let centre = Vector3::new(0.02, 0.035, 0.0);
        let h = 0.035;
        let mut expected = Vec::new();
        for sx in [-1.0, 1.0] {
            for sy in [-1.0, 1.0] {
                for sz in [-1.0, 1.0] {
                    let local = Vector3::new(sx * h, sy * h, sz * h);
                    let corner = Point3::from(rot * local + centre);
                    let faces_camera = [
                        Vector3::new(sx, 0.0, 0.0),
                        Vector3::new(0.0, sy, 0.0),
                        Vector3::new(0.0, 0.0, sz),
                    ]
                    .iter()
                    .any(|n| (rot * n).dot(&(o - corner)) > 0.0);
                    if faces_camera {
                        expected.push(corner);
                    }
                }
            }
        }
        let listed: Vec<Point3<f64>> = f
            .iter()
            .filter(|(n, _)| n.starts_with("cube.corner"))
            .map(|(_, p)| *p)
            .collect();
        assert_eq!(listed.len(), expected.len());
        for e in &expected {
            assert!(
                listed.iter().any(|p| (p - e).norm() < 1e-5),
                "corner {e} missing"
            );
        }
        let names: Vec<&str> = f.iter().map(|(n, _)| n.as_str()).collect();
        assert!(names.contains(&"floor.grid11") || names.contains(&"back_wall.grid11"));
    }
}

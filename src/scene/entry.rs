//! One mesh entry resolved into world coordinates: its shape built (a primitive of
//! [`crate::geometry::primitives`] or a mesh file, welded to judge closedness and optionally
//! fitted), then scaled, rotated and translated ([`Placement`]), every vertex checked to lie
//! within [`MAX_EXTENT_M`] of the origin; with the entry's fiducial candidates
//! ([`crate::geometry::fiducials`]) carried along.

use super::checks::{Resolver, MAX_EXTENT_M, MAX_SUBDIVISIONS};
use super::schema::{MeshEntry, Placement, Shape};
use super::SceneError;
use crate::geometry::fiducials::{box_candidates, quad_candidates, Candidate};
use crate::geometry::normalize::{fit_mesh, welded};
use crate::geometry::{primitives, TriangleMesh};
use nalgebra::{Matrix4, Point3, Rotation3, Vector3};
use std::path::Path;
use toml::Spanned;

/// A mesh entry in world coordinates.
pub(super) struct PlacedMesh {
    pub mesh: TriangleMesh,
    /// Whether the surface is closed (box, icosphere, closed file mesh).
    pub closed: bool,
    /// Fiducial candidates, world coordinates.
    pub candidates: Vec<(Candidate, Point3<f64>)>,
}

impl Resolver<'_> {
    /// The entry's mesh in world coordinates, whether it is closed, and its fiducial
    /// candidates.
    pub(super) fn entry_mesh(
        &self,
        entry: &Spanned<MeshEntry>,
        key: &str,
    ) -> Result<PlacedMesh, SceneError> {
        let e = entry.get_ref();
        let k = |name: &str| format!("{key}.{name}");
        let (mut mesh, closed, local) = match &e.shape {
            Shape::Quad { size } => {
                let v = self.sizes(size, 2, "[x, y]", &k("size"))?;
                let quad = primitives::quad(v[0] as f32, v[1] as f32);
                (quad, false, quad_candidates(v[0], v[1]))
            }
            Shape::Box { size } => {
                let v = self.sizes(size, 3, "[x, y, z]", &k("size"))?;
                let size = Vector3::new(v[0], v[1], v[2]);
                let cuboid = primitives::cuboid(size.cast::<f32>());
                (cuboid, true, box_candidates(&size))
            }
            Shape::Icosphere {
                radius,
                subdivisions,
            } => {
                let radius = self.positive(radius, &k("radius"))?;
                let sub = match subdivisions {
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
            Shape::File { file, fit_size_m } => {
                let m = self.file_mesh(file, fit_size_m.as_ref(), key)?;
                let closed = primitives::is_closed(&welded(&m));
                (m, closed, Vec::new())
            }
        };
        let m = self.placement(&e.placement, key)?;
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
        let candidates = local
            .into_iter()
            .map(|(c, p)| (c, m.transform_point(&p)))
            .collect();
        Ok(PlacedMesh {
            mesh,
            closed,
            candidates,
        })
    }

    /// The `want` positive sizes of a quad (`[x, y]`) or a box (`[x, y, z]`).
    fn sizes<'v>(
        &self,
        s: &'v Spanned<Vec<f64>>,
        want: usize,
        what: &str,
        key: &str,
    ) -> Result<&'v [f64], SceneError> {
        let v = s.get_ref();
        if v.len() != want {
            return Err(self.bad(
                &s.span(),
                key,
                format!("needs {want} values {what}, got {}", v.len()),
            ));
        }
        if let Some(x) = v.iter().find(|x| !(x.is_finite() && **x > 0.0)) {
            return Err(self.bad(&s.span(), key, format!("sizes must be positive, got {x}")));
        }
        Ok(v)
    }

    /// A mesh file's triangles (one material), fitted to `fit_size_m` when given.
    fn file_mesh(
        &self,
        file: &Spanned<String>,
        fit_size_m: Option<&Spanned<f64>>,
        key: &str,
    ) -> Result<TriangleMesh, SceneError> {
        let path = self.base_dir.join(file.get_ref());
        let mesh_file_error =
            |(message, source): (String, Option<std::io::Error>)| SceneError::MeshFile {
                origin: self.origin.to_string(),
                location: format!("{}: {key}.file", self.at(&file.span())),
                path: path.display().to_string(),
                message,
                source,
            };
        let mut m = load_mesh_file(&path).map_err(mesh_file_error)?;
        if m.triangles.is_empty() {
            return Err(mesh_file_error(("has no triangles".into(), None)));
        }
        if let Some(fit) = fit_size_m {
            let size = self.positive(fit, &format!("{key}.fit_size_m"))?;
            fit_mesh(&mut m, size);
        }
        m.material.iter_mut().for_each(|x| *x = 0);
        Ok(m)
    }

    /// The entry's transform: scale, then rotate (`rotate_deg` about x, then y, then z, fixed
    /// axes; or `rotate_axis` with `rotate_angle_deg`), then translate.
    pub(super) fn placement(&self, p: &Placement, key: &str) -> Result<Matrix4<f64>, SceneError> {
        let k = |name: &str| format!("{key}.{name}");
        let scale = match &p.scale {
            Some(s) => self.positive(s, &k("scale"))?,
            None => 1.0,
        };
        let rotation = match (&p.rotate_deg, &p.rotate_axis, &p.rotate_angle_deg) {
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
        let translate = match &p.translate_m {
            Some(t) => self.point(t, &k("translate_m"))?,
            None => Vector3::zeros(),
        };
        Ok(Matrix4::new_translation(&translate)
            * rotation.to_homogeneous()
            * Matrix4::new_scaling(scale))
    }
}

/// Read a mesh file into triangles (metres, the file's own frame).
/// A mesh file's triangles, or what is wrong with it: a message and, for a file that does not
/// exist, an I/O error of kind `NotFound` whose text is the message (so that a caller can
/// tell a missing file apart while the line stays "not found").
fn load_mesh_file(path: &Path) -> Result<TriangleMesh, (String, Option<std::io::Error>)> {
    const NOT_FOUND: &str = "not found";
    if !path.is_file() {
        let kind = std::io::ErrorKind::NotFound;
        let missing = std::fs::metadata(path).is_err_and(|e| e.kind() == kind);
        let source = missing.then(|| std::io::Error::new(kind, NOT_FOUND));
        return Err((NOT_FOUND.into(), source));
    }
    crate::geometry::load::load_mesh(path).map_err(|e| (e.to_string(), None))
}

//! Resolution of a parsed scene file into a [`Scene`]: every number checked against its
//! physical range (the ranges and checks of [`super::checks`]), the camera and the laser
//! built, and the mesh entries placed ([`super::entry`]) and checked against the camera and
//! the laser (the camera outside closed meshes and at least 1 mm from every surface, the laser
//! spot outside closed meshes). Each error names the key and its line.

use super::checks::{
    Resolver, CAMERA_CLEARANCE_M, DT_PS_RANGE, ETA_RANGE, MAX_ENERGY, MAX_NT, MAX_PULSE_WIDTH_FS,
    MAX_SIDE, WAVELENGTH_NM_RANGE,
};
use super::entry::PlacedMesh;
use super::schema::{self, CameraEntry, Kind, LaserEntry, MeshEntry, SceneFile};
use super::{Emission, Laser, Scene, SceneError, StreakCamera};
use crate::camera::{one_line_toml_error, Intrinsics, Pose};
use crate::cube::TimeAxis;
use crate::geometry::queries::{distance_to_mesh, inside_closed};
use crate::geometry::TriangleMesh;
use crate::limits::short_number;
use nalgebra::{Point3, Vector3};
use std::path::Path;
use toml::de::DeTable;
use toml::Spanned;

impl Resolver<'_> {
    /// Parse the text: the whole file as the toml crate reads it, then each mesh entry as its
    /// kind ([`schema::mesh_entry`]). Syntax, types, unknown and misplaced keys are refused
    /// here, before any value is checked.
    pub(super) fn parse(&self) -> Result<(SceneFile, Vec<Spanned<MeshEntry>>), SceneError> {
        let parse_error = |e: toml::de::Error| SceneError::Parse {
            origin: self.origin.to_string(),
            message: one_line_toml_error(&e, self.text),
        };
        let file: SceneFile = toml::from_str(self.text).map_err(parse_error)?;
        let doc = DeTable::parse(self.text).map_err(parse_error)?;
        let tables = doc
            .get_ref()
            .get("mesh")
            .and_then(|m| m.get_ref().as_array())
            .map_or(&[][..], |a| &a[..]);
        let mut meshes = Vec::with_capacity(file.mesh.len());
        for (i, (head, table)) in file.mesh.iter().zip(tables).enumerate() {
            let key = format!("mesh[{i}]");
            let tag = match head.get_ref().kind() {
                Kind::Tag(tag) => tag,
                Kind::Both(file_span) => {
                    return Err(self.bad(
                        &file_span,
                        &format!("{key}.file"),
                        "give either primitive or file, not both",
                    ))
                }
                Kind::Neither => {
                    return Err(self.bad(
                        &head.span(),
                        &key,
                        "needs a primitive (quad, box, icosphere) or a file",
                    ))
                }
            };
            let entry =
                schema::mesh_entry(table, tag).map_err(|e| self.entry_error(&e, table, &key))?;
            meshes.push(Spanned::new(head.span(), entry));
        }
        Ok((file, meshes))
    }

    /// A toml error inside mesh entry `key`, naming the entry's key where the error lies
    /// (`mesh[2].size: unknown field ...`), else the entry (`mesh[2]: missing field ...`).
    fn entry_error(
        &self,
        e: &toml::de::Error,
        table: &Spanned<toml::de::DeValue<'_>>,
        key: &str,
    ) -> SceneError {
        let message = e.message().replace('\n', " ");
        let Some(span) = e.span() else {
            return SceneError::Parse {
                origin: self.origin.to_string(),
                message: format!("{key}: {}", message.trim()),
            };
        };
        let key = match schema::key_at(table.get_ref(), span.start) {
            Some(name) => format!("{key}.{name}"),
            None => key.to_string(),
        };
        SceneError::Parse {
            origin: self.origin.to_string(),
            message: format!("{}: {key}: {}", self.at(&span), message.trim()),
        }
    }

    /// Check every value and build the scene.
    pub(super) fn resolve(
        &self,
        file: SceneFile,
        meshes: Vec<Spanned<MeshEntry>>,
    ) -> Result<Scene, SceneError> {
        let eta = self.eta(file.eta.as_ref())?;
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
        if meshes.is_empty() {
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
        for (i, entry) in meshes.iter().enumerate() {
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
            let PlacedMesh {
                mesh: part,
                closed,
                candidates: corners,
            } = self.entry_mesh(entry, &key)?;
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

    /// The medium's index: 1 when absent, else within [`ETA_RANGE`].
    fn eta(&self, eta: Option<&Spanned<f64>>) -> Result<f64, SceneError> {
        match eta {
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
                Ok(x)
            }
            None => Ok(1.0),
        }
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
}
